//! Conformance with Mitsuba 3: render every scene in `../shared/scenes` that has a reference
//! image, at 64 spp and the reference's resolution, and check the three criteria of
//! `../shared/README.md` against Mitsuba's own 64-spp figures in `metrics.json`:
//! every channel of the mean ratio within 1 ± 0.01 (± 0.02 where the reference has more than
//! 1024 spp), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.

use specula_render::image_io::read_image;
use specula_render::metrics::{Criteria, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// `../shared` when its scenes are there; `None` (skip) when absent, except under CI.
fn shared() -> Option<PathBuf> {
    specula_testdata::shared("scenes")?;
    Some(specula_testdata::root())
}

#[test]
fn renders_match_mitsuba_references() {
    let Some(shared) = shared() else { return };
    let metrics: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(shared.join("reference/metrics.json")).unwrap(),
    )
    .unwrap();
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(shared.join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    let only = std::env::var("SPECULA_SCENES").ok();
    let mut failures = Vec::new();
    let mut rows = Vec::new();
    let mut rendered = 0;
    for path in &scenes {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if let Some(o) = &only {
            if !o.split(',').any(|s| s == name) {
                continue;
            }
        }
        let reference_path = shared.join("reference").join(format!("{name}.exr"));
        let Some(m) = metrics.get(&name) else {
            continue;
        };
        if !reference_path.exists() {
            continue;
        }
        let scene = match Scene::load(path, &[("spp".into(), "64".into())]) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: does not load: {e}"));
                continue;
            }
        };
        let opts = RenderOptions {
            spp: 64,
            seed: 0,
            threads: 0,
        };
        let out = render(&scene, &opts, &AtomicBool::new(false), &|_, _| {});
        rendered += 1;
        let (refimg, _) = read_image(&reference_path).unwrap();
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
