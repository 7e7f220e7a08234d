//! Conformance with Mitsuba 3: render every scene in `../shared/scenes` that has a reference
//! image, at 64 spp and the reference's resolution, and check the three criteria of
//! `../shared/README.md` against Mitsuba's own 64-spp figures in `metrics.json`:
//! every channel of the mean ratio within 1 ± 0.01 (± 0.02 where the reference has more than
//! 1024 spp), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.

mod common;

use common::{criteria, mean_tol_by_ref_spp, read_metrics, render_and_judge, selected, Report};
use specula_render::scene::Scene;
use std::path::PathBuf;

/// `../shared` when its scenes are there; `None` (skip) when absent, except under CI.
fn shared() -> Option<PathBuf> {
    specula_testdata::shared("scenes")?;
    Some(specula_testdata::root())
}

#[test]
fn renders_match_mitsuba_references() {
    let Some(shared) = shared() else { return };
    let metrics = read_metrics(&shared.join("reference/metrics.json"));
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(shared.join("scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    let mut report = Report::default();
    for path in &scenes {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        let reference = shared.join("reference").join(format!("{name}.exr"));
        let Some(m) = metrics.get(&name) else {
            continue;
        };
        if !selected(&name) || !reference.exists() {
            continue;
        }
        match Scene::load(path, &[("spp".into(), "64".into())]) {
            Ok(scene) => {
                let c = criteria(m, mean_tol_by_ref_spp(m));
                report.judged(&name, render_and_judge(&name, &scene, 1, &reference, &c));
            }
            Err(e) => report.fail(format!("{name}: does not load: {e}")),
        }
    }
    report.finish("conformance", true);
}
