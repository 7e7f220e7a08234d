//! `<spectrum>` values become the RGB that Mitsuba 3.9.1's RGB variants give them, per use
//! (reflectance, unbounded, emission): the fixture `data/spectra/fixture.txt` holds Mitsuba's
//! `scalar_rgb` results for the wavelength lists of Mitsuba's documentation scenes, hand-made
//! lists (irregular spacing, beyond 360–830 nm, negative, out of gamut), constants, `.spd`
//! files from Mitsuba's `data/ior`, and the spectrum plugins (see
//! `scripts/gen_spectrum_fixture.py`, which made it).
//!
//! Tolerance: |Specula − Mitsuba| ≤ 1e-5·|Mitsuba| + 1e-7 per channel (both compute in double
//! precision from the same float32 tables and store float32; the observed error is ~1e-7).

use specula_render::xml::{parse_scene_str, Usage};
use std::path::Path;

const FIXTURE: &str = include_str!("data/spectra/fixture.txt");

#[test]
fn spectra_convert_like_mitsuba() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/spectra");
    let (mut n, mut worst) = (0, 0.0f64);
    for line in FIXTURE.lines().filter(|l| l.starts_with("case ")) {
        let mut it = line.splitn(6, ' ').skip(1);
        let usage = match it.next().unwrap() {
            "reflectance" => Usage::Reflectance,
            "unbounded" => Usage::Unbounded,
            "emission" => Usage::Emission,
            u => panic!("unknown usage {u}"),
        };
        let want: Vec<f64> = (0..3)
            .map(|_| it.next().unwrap().parse().unwrap())
            .collect();
        let element = it.next().unwrap();
        let scene = format!(r#"<scene version="3.0.0"><shape type="x">{element}</shape></scene>"#);
        let root = parse_scene_str(&scene, "fixture.xml", &dir, &[])
            .unwrap_or_else(|e| panic!("{element}: {e}"));
        let got = root.children[0]
            .color_opt("c", usage)
            .unwrap_or_else(|e| panic!("{element}: {e}"))
            .unwrap();
        for k in 0..3 {
            let err = (got[k] as f64 - want[k]).abs();
            assert!(
                err <= 1e-5 * want[k].abs() + 1e-7,
                "{usage:?} {element}: Specula {got:?}, Mitsuba {want:?}"
            );
            worst = worst.max(err / want[k].abs().max(1e-3));
        }
        n += 1;
    }
    assert!(n >= 100, "only {n} cases");
    println!("{n} cases, largest relative difference {worst:.2e}");
}

/// A blackbody spectrum is an emission spectrum; elsewhere it is a located error.
#[test]
fn blackbody_outside_emission_is_an_error() {
    let scene = r#"<scene version="3.0.0"><shape type="x">
<spectrum type="blackbody" name="c"><float name="temperature" value="5000"/></spectrum></shape></scene>"#;
    let root = parse_scene_str(scene, "bb.xml", Path::new("."), &[]).unwrap();
    let err = root.children[0].rgb_opt("c").unwrap_err();
    assert!(err.to_string().starts_with("bb.xml:2:1:"), "{err}");
    assert!(err.to_string().contains("emission spectrum"), "{err}");
}

/// A malformed .spd file names the file and the line.
#[test]
fn bad_spd_file_is_a_located_error() {
    let dir = std::env::temp_dir().join(format!("specula-spectra-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bad.spd"), "# header\n400 0.5\n500 0.7 junk\n").unwrap();
    let scene = r#"<scene version="3.0.0"><shape type="x">
  <spectrum name="c" filename="bad.spd"/></shape></scene>"#;
    let err = parse_scene_str(scene, "s.xml", &dir, &[]).unwrap_err();
    let msg = err.to_string();
    assert!(msg.starts_with("s.xml:2:3:"), "{msg}");
    assert!(msg.contains("bad.spd") && msg.contains("line 3"), "{msg}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Through the scene builder: a reflectance list is D65-weighted and clamped, a conductor's
/// eta is D65-weighted but not clamped above 1, an area emitter's radiance is not D65-weighted
/// (values from the fixture, i.e. from Mitsuba).
#[test]
fn scene_builder_reads_each_use_as_mitsuba() {
    use specula_bsdf::bsdf::SpectrumParam;
    use specula_bsdf::Bsdf;
    use specula_render::scene::{AreaRadiance, Light, Scene};
    let dir = std::env::temp_dir().join(format!("specula-spectra-scene-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("s.xml"),
        r#"<scene version="3.0.0">
  <sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
  <shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.5, 700:0.5"/></bsdf></shape>
  <shape type="sphere"><bsdf type="conductor">
    <spectrum name="eta" value="300:1.8, 400:1.65, 500:0.9, 600:0.2, 700:0.16, 800:0.18"/>
    <spectrum name="k" value="0.5"/></bsdf></shape>
  <shape type="sphere"><emitter type="area"><spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/></emitter></shape>
</scene>"#,
    )
    .unwrap();
    let s = Scene::load(&dir.join("s.xml"), &[]).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    let close = |a: [f32; 3], b: [f64; 3]| {
        (0..3).all(|k| (a[k] as f64 - b[k]).abs() <= 1e-5 * b[k].abs() + 1e-7)
    };
    let constant = |p: &SpectrumParam| match p {
        SpectrumParam::Const(c) | SpectrumParam::Spectral { rgb: c, .. } => c.0,
        _ => panic!("not a constant"),
    };
    let Bsdf::Diffuse(d) = &s.bsdfs[s.shape_bsdf[0] as usize] else {
        panic!("not diffuse")
    };
    let r = constant(&d.reflectance);
    assert!(
        close(
            r,
            [0.4976710081100464, 0.4998781979084015, 0.49745455384254456]
        ),
        "{r:?}"
    );
    let Bsdf::Conductor(c) = &s.bsdfs[s.shape_bsdf[1] as usize] else {
        panic!("not a conductor")
    };
    let eta = constant(&c.eta);
    assert!(
        close(
            eta,
            [0.04523409530520439, 0.5857088565826416, 1.3369237184524536]
        ),
        "{eta:?}"
    );
    assert_eq!(constant(&c.k), [0.5; 3]);
    let light = s.shape_light[2].expect("an emitter") as usize;
    // a <spectrum> radiance keeps its RGB conversion (what RGB mode emits) beside the curve
    let radiance = match &s.lights[light] {
        Light::Area {
            radiance: AreaRadiance::Rgb(r),
            ..
        }
        | Light::Area {
            radiance: AreaRadiance::Spectral { rgb: r, .. },
            ..
        } => r,
        _ => panic!("not an area light of constant radiance"),
    };
    assert!(
        close(
            radiance.0,
            [20.71083641052246, 10.854634284973145, 2.7711520195007324]
        ),
        "{radiance:?}"
    );
}

/// `filename=` resolves like other files: the declaring file's folder, then `<path>` folders.
#[test]
fn spd_files_resolve_through_search_paths() {
    let dir = std::env::temp_dir().join(format!("specula-spectra-path-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("data")).unwrap();
    std::fs::write(dir.join("data/flat.spd"), "# flat\n360 1\n830 1\n").unwrap();
    let scene = r#"<scene version="3.0.0"><path value="data"/><shape type="x">
  <spectrum name="c" filename="flat.spd"/></shape></scene>"#;
    let root = parse_scene_str(scene, "s.xml", &dir, &[]).unwrap();
    let c = root.children[0].rgb_opt("c").unwrap().unwrap();
    // Mitsuba: a flat unit reflectance over 360-830 nm is (0.998985, 0.998874, 0.998802)
    for (v, w) in c.iter().zip([0.9989853, 0.9988737, 0.9988016]) {
        assert!((v - w).abs() <= 1e-5 * w, "{c:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
