//! Spectral mode against Mitsuba 3's spectral variant: render every scene of `../shared/scenes`
//! that has a reference in `tests/data/spectral/` (Mitsuba 3.9.1 `llvm_ad_spectral`, made by
//! `scripts/make_spectral_references.py` at half the scenes' resolution) with
//! [`Scene::set_spectral`], at 64 spp and the reference's resolution, and judge it with the
//! criteria of the other conformance tests (`../shared/README.md`) against Mitsuba's own
//! 64-spp figures in that directory's `metrics.json`: every channel of the mean ratio within
//! 1 ± 0.01 (± 0.02 where the reference has more than 1024 spp), block8 ≤ 2 × Mitsuba's + 1e-5,
//! relMSE ≤ 1.5 × Mitsuba's. `SPECULA_SCENES=a,b` renders only those.

mod common;

use common::{criteria, mean_tol_by_ref_spp, read_metrics, render_and_judge, selected, Report};
use specula_render::scene::Scene;
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/spectral")
}

/// `path` loaded at the resolution of its metrics entry `m` and 64 spp, in spectral mode (or
/// the failure reported).
fn load(report: &mut Report, name: &str, path: &Path, m: &serde_json::Value) -> Option<Scene> {
    let res = m["resolution"].as_array().unwrap();
    let (w, h) = (res[0].as_u64().unwrap(), res[1].as_u64().unwrap());
    let params = [
        ("spp".to_string(), "64".to_string()),
        ("resx".to_string(), w.to_string()),
        ("resy".to_string(), h.to_string()),
    ];
    let mut scene = match Scene::load(path, &params) {
        Ok(s) => s,
        Err(e) => {
            report.fail(format!("{name}: does not load: {e}"));
            return None;
        }
    };
    if let Err(e) = scene.set_spectral(true) {
        report.fail(format!("{name}: no spectral mode: {e}"));
        return None;
    }
    Some(scene)
}

/// Renders `scene` and judges it against `tests/data/spectral/<name>.exr`.
fn judge(report: &mut Report, name: &str, scene: &Scene, m: &serde_json::Value) {
    let c = criteria(m, mean_tol_by_ref_spp(m));
    let reference = data().join(format!("{name}.exr"));
    let j = render_and_judge(name, scene, 1, &reference, &c);
    // the media's coplanar-tie scene is reported, not judged (see below)
    if name == "med_fog_box" {
        report.unjudged(name, j, "coplanar tie");
    } else {
        report.judged(name, j);
    }
}

#[test]
fn spectral_renders_match_mitsuba_spectral_references() {
    let Some(scenes_dir) = specula_testdata::shared("scenes") else {
        return;
    };
    let metrics = read_metrics(&data().join("metrics.json"));
    let mut names: Vec<&String> = metrics
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| !k.starts_with('_'))
        .collect();
    names.sort();
    let mut report = Report::default();
    for name in names.into_iter().filter(|n| selected(n)) {
        let path = scenes_dir.join(format!("{name}.xml"));
        if let Some(scene) = load(&mut report, name, &path, &metrics[name]) {
            judge(&mut report, name, &scene, &metrics[name]);
        }
    }
    report.finish("spectral", true);
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
    let Some(shared_media) = specula_testdata::shared("media/scenes") else {
        return;
    };
    let local = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/media");
    let metrics = read_metrics(&data().join("med_metrics.json"));
    let mut names: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    names.sort();
    let mut report = Report::default();
    for name in names.into_iter().filter(|n| selected(n)) {
        let path = [
            shared_media.join(format!("{name}.xml")),
            local.join(format!("{name}.xml")),
        ]
        .into_iter()
        .find(|p| p.exists());
        let Some(path) = path else {
            report.fail(format!("{name}: no scene file"));
            continue;
        };
        if let Some(scene) = load(&mut report, name, &path, &metrics[name]) {
            assert!(!scene.media.is_empty(), "{name} has no medium");
            judge(&mut report, name, &scene, &metrics[name]);
        }
    }
    report.finish("spectral media", true);
}
