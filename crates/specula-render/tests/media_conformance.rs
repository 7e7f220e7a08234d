//! Conformance of participating media with Mitsuba 3 (`volpath`): render every scene in
//! `../shared/media/scenes` that has a reference in `../shared/media/reference`, and the scenes
//! in `tests/data/media` with their references there, at 64 spp and the reference's resolution,
//! and check the three criteria of `../shared/README.md` against Mitsuba's own 64-spp figures
//! in `metrics.json`: every channel of the mean ratio within 1 ± 0.01 (± 0.02 where the
//! reference has more than 1024 spp), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.
//!
//! `med_fog_box` is rendered and reported but not judged: the bottom face of its fog cube (a
//! `null` boundary) is coplanar with the floor, and which of the two a ray meets first is
//! decided by the rounding of two different intersection routines, so Mitsuba's reference
//! shows, under the box, the outline of the cube face's two triangles. `med_fog_box_lifted`
//! (`tests/data/media`, made by `scripts/gen_media_fog_lifted_reference.py`) is the same scene
//! with the cube 1 mm higher, with a Mitsuba reference of its own, and is judged.
//! `med_hetero_smoke` and `med_hetero_chromatic` (`tests/data/media`, scenes, `.vol` grids and
//! references made by `scripts/gen_media_hetero_refs.py`) are `heterogeneous` media: a smoke
//! plume (one-channel grid) lit by an area light, and a chromatic RGB grid with an RGB albedo
//! grid, rotated by its `to_world`, lit by a spherical area light.
//! `volpathmis_renders_match_mitsuba_references` renders the judged scenes again with
//! `volpathmis` (see its docs). `SPECULA_SCENES=a,b` restricts the run to those scenes.

mod common;

use common::{criteria, mean_tol_by_ref_spp, render_and_judge, selected, Judged, Report};
use specula_render::scene::Scene;
use std::path::{Path, PathBuf};

/// Scenes whose reference depends on how coplanar surfaces are ordered (see the module docs).
const COPLANAR_TIE: &[&str] = &["med_fog_box"];

/// (name, scene, reference, metrics) of every scene in `scenes` with a reference in `refs`.
fn collect(scenes: &Path, refs: &Path) -> Vec<(String, PathBuf, PathBuf, serde_json::Value)> {
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(refs.join("metrics.json")).unwrap()).unwrap();
    let mut out: Vec<_> = std::fs::read_dir(scenes)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .filter_map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().to_string();
            let r = refs.join(format!("{name}.exr"));
            let m = metrics.get(&name)?.clone();
            r.exists().then_some((name, p, r, m))
        })
        .collect();
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

/// Renders `scene` at 64 spp (seed 0) and judges it against `reference` with Mitsuba's
/// 64-spp figures `m`.
fn check(name: &str, scene: &Scene, reference: &Path, m: &serde_json::Value) -> Judged {
    let c = criteria(m, mean_tol_by_ref_spp(m));
    render_and_judge(name, scene, 1, reference, &c)
}

/// Adds a judged scene to the report; a scene of [`COPLANAR_TIE`] is reported, not judged
/// (but fails on NaN or infinite samples).
fn add(report: &mut Report, name: &str, j: Judged) {
    if COPLANAR_TIE.contains(&name) {
        report.unjudged(name, j, "coplanar tie");
    } else {
        report.judged(name, j);
    }
}

#[test]
fn media_renders_match_mitsuba_references() {
    let local = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/media");
    let mut scenes = collect(&local, &local);
    assert!(
        !scenes.is_empty(),
        "tests/data/media has no scene with a reference"
    );
    if let Some(media) = specula_testdata::shared("media/scenes") {
        scenes.extend(collect(&media, &media.parent().unwrap().join("reference")));
    }
    let mut report = Report::default();
    for (name, path, reference, m) in &scenes {
        if !selected(name) {
            continue;
        }
        match Scene::load(path, &[("spp".into(), "64".into())]) {
            Ok(scene) => add(&mut report, name, check(name, &scene, reference, m)),
            Err(e) => report.fail(format!("{name}: does not load: {e}")),
        }
    }
    report.finish("media", true);
}

/// `volpathmis` (same expectation as `volpath`): the scenes listed in
/// `tests/data/media/volpathmis_metrics.json`, with their integrator's type changed to
/// `volpathmis`, against the `volpath` references and Mitsuba's own 64-spp `volpathmis` error
/// (made by `scripts/gen_media_volpathmis_metrics.py`).
#[test]
fn volpathmis_renders_match_mitsuba_references() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let local = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/media");
    let metrics: serde_json::Map<String, serde_json::Value> = serde_json::from_str(
        &std::fs::read_to_string(local.join("volpathmis_metrics.json")).unwrap(),
    )
    .unwrap();
    assert!(!metrics.is_empty());
    let resolve = |p: &str| match p.strip_prefix("shared:") {
        Some(rel) => specula_testdata::shared(rel),
        None => Some(root.join(p)),
    };
    let mut report = Report::default();
    for (name, m) in &metrics {
        if !selected(name) {
            continue;
        }
        let (Some(path), Some(reference)) = (
            resolve(m["scene"].as_str().unwrap()),
            resolve(m["reference"].as_str().unwrap()),
        ) else {
            continue;
        };
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.matches(r#"type="volpath""#).count(), 1, "{name}");
        let text = text.replace(r#"type="volpath""#, r#"type="volpathmis""#);
        match Scene::from_xml_str(
            &text,
            &path.display().to_string(),
            path.parent().unwrap(),
            &[("spp".into(), "64".into())],
        ) {
            Ok(scene) => report.judged(name, check(name, &scene, &reference, m)),
            Err(e) => report.fail(format!("{name}: does not load: {e}")),
        }
    }
    report.finish("volpathmis", false);
}
