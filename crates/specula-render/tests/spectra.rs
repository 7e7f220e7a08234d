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
