//! Spectral mode against Mitsuba 3's spectral variant: render every scene of `../shared/scenes`
//! that has a reference in `tests/data/spectral/` (Mitsuba 3.9.1 `llvm_ad_spectral`, made by
//! `scripts/make_spectral_references.py` at half the scenes' resolution) with
//! [`Scene::set_spectral`], at 64 spp and the reference's resolution, and judge it with the
//! criteria of the other conformance tests (`../shared/README.md`) against Mitsuba's own
//! 64-spp figures in that directory's `metrics.json`: every channel of the mean ratio within
//! 1 ± 0.01 (± 0.02 where the reference has more than 1024 spp), block8 ≤ 2 × Mitsuba's + 1e-5,
//! relMSE ≤ 1.5 × Mitsuba's. `SPECULA_SCENES=a,b` renders only those.

use specula_render::image_io::read_image;
use specula_render::metrics::{Criteria, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/spectral")
}

#[test]
fn spectral_renders_match_mitsuba_spectral_references() {
    let Some(scenes_dir) = specula_testdata::shared("scenes") else {
        return;
    };
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data().join("metrics.json")).unwrap())
            .unwrap();
    let only = std::env::var("SPECULA_SCENES").ok();
    let mut failures = Vec::new();
    let mut rows = Vec::new();
    let mut rendered = 0;
    let mut names: Vec<&String> = metrics
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| !k.starts_with('_'))
        .collect();
    names.sort();
    for name in names {
        if let Some(o) = &only {
            if !o.split(',').any(|s| s == name) {
                continue;
            }
        }
        let m = &metrics[name];
        let res = m["resolution"].as_array().unwrap();
        let (w, h) = (res[0].as_u64().unwrap(), res[1].as_u64().unwrap());
        let path = scenes_dir.join(format!("{name}.xml"));
        let params = [
            ("spp".to_string(), "64".to_string()),
            ("resx".to_string(), w.to_string()),
            ("resy".to_string(), h.to_string()),
        ];
        let mut scene = match Scene::load(&path, &params) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: does not load: {e}"));
                continue;
            }
        };
        if let Err(e) = scene.set_spectral(true) {
            failures.push(format!("{name}: no spectral mode: {e}"));
            continue;
        }
        let opts = RenderOptions {
            spp: 64,
            seed: 0,
            threads: 0,
        };
        let out = render(&scene, &opts, &AtomicBool::new(false), &|_, _| {});
        rendered += 1;
        let (refimg, _) = read_image(&data().join(format!("{name}.exr"))).unwrap();
        let reference = RgbImage::from(&refimg);
        if (out.width, out.height) != (reference.width, reference.height) {
            failures.push(format!(
                "{name}: rendered {}×{}, reference {}×{}",
                out.width, out.height, reference.width, reference.height
            ));
            continue;
        }
        let img = RgbImage {
            width: out.width,
            height: out.height,
            data: out.rgb,
        };
        let ref_spp = m["ref_spp"].as_f64().unwrap();
        let criteria = Criteria::new(
            m["mitsuba_64spp_relmse"].as_f64().unwrap(),
            m["mitsuba_64spp_block8"].as_f64().unwrap(),
            if ref_spp > 1024.0 { 0.02 } else { 0.01 },
        );
        let v = criteria.judge(std::slice::from_ref(&img), &reference);
        let ok = v.ok() && out.counters.invalid == 0;
        rows.push(format!(
            "{name:<24} {}  {:.1}s  invalid {}  {}",
            v.row(&criteria),
            out.elapsed.as_secs_f64(),
            out.counters.invalid,
            if ok { "ok" } else { "FAIL" }
        ));
        if !ok {
            failures.push(format!(
                "{name}: {}; invalid samples {}",
                v.failures(&criteria),
                out.counters.invalid
            ));
        }
    }
    println!("{}", rows.join("\n"));
    assert!(rendered > 0 || only.is_some(), "no scene was rendered");
    assert!(
        failures.is_empty(),
        "non-conforming scenes:\n{}",
        failures.join("\n")
    );
}

/// Participating media in spectral mode (`volpath`) against Mitsuba 3.9.1 `llvm_ad_spectral`
/// references in `tests/data/spectral/med_*.exr` and `med_metrics.json`, made by
/// `scripts/make_spectral_media_references.py`: the scenes of `../shared/media/scenes` at half
/// their resolution (an absorbing medium inside a `dielectric`, a scattering `hg` medium inside
/// a `roughdielectric`, a fog box) and, from `tests/data/media` at their own 64×64, the fog
/// box lifted 1 mm and two `heterogeneous` media (an RGB `sigma_t` grid with an RGB albedo
/// grid, and a one-channel smoke grid). 64 spp, seed 0; judged by the same criteria as the
/// test above. `med_fog_box` is rendered and reported but not judged, as in
/// `media_conformance.rs` (its fog cube's bottom face is coplanar with the floor, and the
/// reference depends on which of the two each ray meets first); `med_fog_box_lifted` is judged
/// in its place. `SPECULA_SCENES=a,b` renders only those.
#[test]
fn spectral_media_match_mitsuba_spectral_references() {
    const COPLANAR_TIE: &[&str] = &["med_fog_box"];
    let Some(shared_media) = specula_testdata::shared("media/scenes") else {
        return;
    };
    let local = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/media");
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data().join("med_metrics.json")).unwrap())
            .unwrap();
    let only = std::env::var("SPECULA_SCENES").ok();
    let (mut failures, mut rows, mut rendered) = (Vec::new(), Vec::new(), 0);
    let mut names: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    names.sort();
    for name in names {
        if let Some(o) = &only {
            if !o.split(',').any(|s| s == name) {
                continue;
            }
        }
        let m = &metrics[name];
        let res = m["resolution"].as_array().unwrap();
        let (w, h) = (res[0].as_u64().unwrap(), res[1].as_u64().unwrap());
        let path = [
            shared_media.join(format!("{name}.xml")),
            local.join(format!("{name}.xml")),
        ]
        .into_iter()
        .find(|p| p.exists());
        let Some(path) = path else {
            failures.push(format!("{name}: no scene file"));
            continue;
        };
        let params = [
            ("spp".to_string(), "64".to_string()),
            ("resx".to_string(), w.to_string()),
            ("resy".to_string(), h.to_string()),
        ];
        let mut scene = match Scene::load(&path, &params) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: does not load: {e}"));
                continue;
            }
        };
        assert!(!scene.media.is_empty(), "{name} has no medium");
        if let Err(e) = scene.set_spectral(true) {
            failures.push(format!("{name}: no spectral mode: {e}"));
            continue;
        }
        let opts = RenderOptions {
            spp: 64,
            seed: 0,
            threads: 0,
        };
        let out = render(&scene, &opts, &AtomicBool::new(false), &|_, _| {});
        rendered += 1;
        let (refimg, _) = read_image(&data().join(format!("{name}.exr"))).unwrap();
        let reference = RgbImage::from(&refimg);
        if (out.width, out.height) != (reference.width, reference.height) {
            failures.push(format!(
                "{name}: rendered {}×{}, reference {}×{}",
                out.width, out.height, reference.width, reference.height
            ));
            continue;
        }
        let img = RgbImage {
            width: out.width,
            height: out.height,
            data: out.rgb,
        };
        let ref_spp = m["ref_spp"].as_f64().unwrap();
        let criteria = Criteria::new(
            m["mitsuba_64spp_relmse"].as_f64().unwrap(),
            m["mitsuba_64spp_block8"].as_f64().unwrap(),
            if ref_spp > 1024.0 { 0.02 } else { 0.01 },
        );
        let v = criteria.judge(std::slice::from_ref(&img), &reference);
        let judged = !COPLANAR_TIE.contains(&name.as_str());
        let ok = v.ok() && out.counters.invalid == 0;
        rows.push(format!(
            "{name:<24} {}  {:.1}s  invalid {}  {}",
            v.row(&criteria),
            out.elapsed.as_secs_f64(),
            out.counters.invalid,
            match (ok, judged) {
                (true, _) => "ok",
                (false, true) => "FAIL",
                (false, false) => "not judged (coplanar tie)",
            }
        ));
        if !ok && judged {
            failures.push(format!(
                "{name}: {}; invalid samples {}",
                v.failures(&criteria),
                out.counters.invalid
            ));
        }
    }
    println!("{}", rows.join("\n"));
    assert!(rendered > 0 || only.is_some(), "no scene was rendered");
    assert!(
        failures.is_empty(),
        "non-conforming scenes:\n{}",
        failures.join("\n")
    );
}
