//! Conformance of participating media with Mitsuba 3 (`volpath`): render every scene in
//! `../shared/media/scenes` that has a reference image in `../shared/media/reference`, at 64 spp and the reference's resolution, and check the three criteria of
//! `../shared/README.md` against Mitsuba's own 64-spp figures in `metrics.json`:
//! every channel of the mean ratio within 1 ± 0.01 (± 0.02 where the reference has more than
//! 1024 spp), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.

use specula_render::image_io::read_image;
use specula_render::metrics::{block8, mean_ratio, relmse, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// `../shared` when its scenes are there; `None` (skip) when absent, except under CI.
fn shared() -> Option<PathBuf> {
    specula_testdata::shared("media/scenes")?;
    Some(specula_testdata::root().join("media"))
}

#[test]
fn media_renders_match_mitsuba_references() {
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
        let (r, b, mr) = (
            relmse(&img, &reference),
            block8(&img, &reference),
            mean_ratio(&img, &reference),
        );
        let m_r = m["mitsuba_64spp_relmse"].as_f64().unwrap();
        let m_b = m["mitsuba_64spp_block8"].as_f64().unwrap();
        let ref_spp = m["ref_spp"].as_f64().unwrap();
        let tol = if ref_spp > 1024.0 { 0.02 } else { 0.01 };
        let ok_mean = mr.iter().all(|v| (v - 1.0).abs() <= tol);
        let ok_b = b <= 2.0 * m_b + 1e-5;
        let ok_r = r <= 1.5 * m_r;
        let verdict = if ok_mean && ok_b && ok_r {
            "ok"
        } else {
            "FAIL"
        };
        rows.push(format!(
            "{name:<24} mean [{:.4} {:.4} {:.4}]  block8 {b:.3e} (mitsuba {m_b:.3e})  relmse {r:.3e} (mitsuba {m_r:.3e})  {:.1}s  invalid {}  {verdict}",
            mr[0],
            mr[1],
            mr[2],
            out.elapsed.as_secs_f64(),
            out.counters.invalid
        ));
        if verdict != "ok" || out.counters.invalid != 0 {
            failures.push(format!("{name}: mean {mr:?} (±{tol}), block8 {b:.3e} ≤ {:.3e}?, relmse {r:.3e} ≤ {:.3e}?, invalid samples {}", 2.0 * m_b + 1e-5, 1.5 * m_r, out.counters.invalid));
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
