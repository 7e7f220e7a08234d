//! `<spectrum>` values in spectral mode against Mitsuba 3's spectral variant: the scenes of
//! `tests/data/spectral_xml/` (wavelength lists with a narrow spike and values above 1, `.spd`
//! files for a reflectance, a lamp and a conductor's η and k, a `regular` spectrum, a
//! `blackbody` area light, a uniform-valued and an `srgb`-spectrum environment, a spot with a
//! wavelength list, principled with a spectral base colour and its tints) and Mitsuba's
//! documentation Cornell box for its spectral variants (`../shared`, at 125×125; skipped
//! without `../shared`) rendered with
//! [`Scene::set_spectral`] at 64 spp and judged against Mitsuba 3.9.1 `llvm_ad_spectral`
//! references (`scripts/make_spectral_xml_references.py`, 4096 spp) with the criteria of the
//! other conformance tests and Mitsuba's own 64-spp figures in that directory's
//! `metrics.json`: every channel of the mean ratio within 1 ± 0.01, block8 ≤ 2 × Mitsuba's +
//! 1e-5, relMSE ≤ 1.5 × Mitsuba's.

mod common;

use common::{criteria, read_metrics, render_and_judge, Report};
use specula_render::scene::{LoadOptions, Scene};
use std::path::PathBuf;

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/spectral_xml")
}

#[test]
fn spectrum_scenes_match_mitsuba_spectral_references() {
    let metrics = read_metrics(&data().join("metrics.json"));
    let mut names: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    names.sort();
    assert_eq!(
        names,
        [
            "emitters",
            "materials",
            "reflectances",
            "variants_cbox_spectral"
        ]
    );
    let mut report = Report::default();
    for name in names {
        let m = &metrics[name];
        let res = m["resolution"].as_array().unwrap();
        let size = (
            res[0].as_u64().unwrap() as usize,
            res[1].as_u64().unwrap() as usize,
        );
        // a scene of ../shared (skipped where it is absent), at the reference's film size
        let path = match m["shared"].as_str() {
            None => data().join(format!("{name}.xml")),
            Some(rel) => match specula_testdata::shared(rel) {
                Some(p) => p,
                None => continue,
            },
        };
        let opts = LoadOptions {
            size: Some(size),
            ..Default::default()
        };
        let mut scene = Scene::load_with(&path, &[], &opts).unwrap();
        scene.set_spectral(true).unwrap();
        let reference = data().join(format!("{name}.exr"));
        let j = render_and_judge(name, &scene, 1, &reference, &criteria(m, 0.01));
        report.judged(name, j);
    }
    report.finish("spectrum scenes", true);
}

fn fixture() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(data().join("fixture.json")).unwrap()).unwrap()
}

fn vec3(v: &serde_json::Value) -> glam::Vec3 {
    let a: Vec<f32> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect();
    glam::Vec3::new(a[0], a[1], a[2])
}

/// Agreement to `tol` relative, with a 1e-12 absolute floor for round-off "zeros".
fn close(got: [f32; 3], want: glam::Vec3, tol: f32) -> bool {
    (0..3).all(|k| (got[k] - want[k]).abs() <= tol * want[k].abs() + 1e-12)
}

/// BSDFs whose parameters are `<spectrum>` values (wavelength lists, `.spd` files, `regular`,
/// `uniform`, `d65`, `srgb`; conductors' η and k; principled's and principledthin's base
/// colour with their `spec_tint` and `sheen_tint`; a checkerboard's colours) evaluated at fixed wavelengths, against
/// Mitsuba 3.9.1 `scalar_spectral` (`scripts/gen_spectral_xml_fixture.py`: f·|cos θo| to
/// 1e-4 relative, 2e-2 for the two records that go through an RGB upsampling). The principled
/// records check the tints' luminance: Mitsuba's mean of ȳ(λ)·base(λ) over the wavelengths.
#[test]
fn bsdfs_with_spectrum_values_match_mitsuba_at_fixed_wavelengths() {
    use specula_bsdf::{BsdfContext, BsdfModel, ShadingPoint, Wavelengths};
    let f = fixture();
    let mut failures = vec![];
    let records = f["bsdf"].as_array().unwrap();
    assert!(records.len() > 150);
    let mut principled = 0;
    for r in records {
        let xml = r["xml"].as_str().unwrap();
        let b = specula_render::scene::bsdf_from_xml_str(xml, "<fixture>", &data())
            .unwrap_or_else(|e| panic!("{xml}: {e}"));
        let wl = vec3(&r["wl"]);
        let uv = r.get("uv").map_or(glam::Vec2::splat(0.5), |v| {
            let v = vec3(&serde_json::json!([v[0], v[1], 0.0]));
            glam::Vec2::new(v.x, v.y)
        });
        let sp = ShadingPoint {
            uv,
            wavelengths: Some(Wavelengths(wl.to_array())),
            ..Default::default()
        };
        let (wi, wo) = (vec3(&r["wi"]), vec3(&r["wo"]));
        // (Specula's eval is f, Mitsuba's f·|cos θo|)
        let got = (b.eval(&BsdfContext::default(), &sp, wi, wo) * wo.z.abs()).0;
        let want = vec3(&r["value"]);
        let tol = r["tol"].as_f64().unwrap() as f32;
        principled += xml.contains("principled") as usize;
        if !close(got, want, tol) {
            failures.push(format!(
                "{xml} at {wl} nm, wi {wi} wo {wo}: {got:?}, Mitsuba {want}"
            ));
        }
    }
    assert!(principled >= 50, "{principled}");
    assert!(
        failures.is_empty(),
        "{} of {} records differ:\n{}",
        failures.len(),
        records.len(),
        failures.join("\n")
    );
}

/// Emitters given `<spectrum>` values (and, for contrast, `<rgb>`/`<float>` values: D65 ×
/// the upsampled colour) at fixed wavelengths, against Mitsuba 3.9.1 `scalar_spectral`: an
/// area emitter's radiance and a point light's intensity at distance 1. A `value="0.5"`
/// spectrum is flat 0.5, a `blackbody` is Planck's law (zero outside its range), a list is
/// its interpolant.
#[test]
fn emitters_with_spectrum_values_match_mitsuba_at_fixed_wavelengths() {
    use specula_bsdf::Wavelengths;
    use specula_render::scene::Light;
    let f = fixture();
    let mut failures = vec![];
    let records = f["emitter"].as_array().unwrap();
    for r in records {
        let xml = r["xml"].as_str().unwrap();
        let text = format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">
            <integer name="width" value="2"/><integer name="height" value="2"/></film></sensor>
            {xml}</scene>"#
        );
        let s = Scene::from_xml_str(&text, "<fixture>", &data(), &[])
            .unwrap_or_else(|e| panic!("{xml}: {e}"));
        let w = Wavelengths(vec3(&r["wl"]).to_array());
        let got = match &s.lights[0] {
            Light::Area { radiance, .. } => {
                radiance.emission(glam::Vec2::ZERO, glam::Vec3::ZERO, Some(&w))
            }
            Light::Other(e) => match e.spectrum() {
                Some((curve, _)) => curve.eval_at(&w),
                None => {
                    let ds = e
                        .sample_direction(glam::Vec3::new(0.0, 0.0, 0.0), glam::Vec2::ZERO)
                        .unwrap();
                    specula_render::spectral::emission(ds.radiance, Some(&w))
                }
            },
        };
        let want = vec3(&r["value"]);
        let tol = if xml.contains("<rgb") || xml.contains("<float") {
            2e-2
        } else {
            1e-4
        };
        if !close(got.0, want, tol) {
            failures.push(format!("{xml} at {:?} nm: {got:?}, Mitsuba {want}", w.0));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} records differ:\n{}",
        failures.len(),
        records.len(),
        failures.join("\n")
    );
}
