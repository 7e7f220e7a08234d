//! `principled` and `principledthin` against Mitsuba 3: small scenes in
//! `tests/data/principled/` (several parameter sets: clear-coated and sheened, anisotropic
//! metal, flat fake subsurface, transmissive with `eta` and with `specular`, every scalar
//! parameter textured through `bitmap` and `checkerboard`, thin sheets lit from behind),
//! rendered at 64 spp and held to `../shared/README.md`'s criteria against Mitsuba's
//! references (made by `scripts/gen_principled_refs.py`, with Mitsuba's own 64-spp error in
//! `metrics.json`, averaged over 8 seeds): mean ratio within max(0.01, 2 × Mitsuba's worst
//! deviation), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.

mod common;

use common::{criteria, mean_tol_by_mitsuba_dev, read_metrics, render_and_judge, Report};
use specula_render::scene::Scene;
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/principled")
}

#[test]
fn principled_scenes_match_mitsuba() {
    let metrics = read_metrics(&data().join("metrics.json"));
    let names: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    assert_eq!(names.len(), 4);
    let mut report = Report::default();
    for name in names {
        let m = &metrics[name.as_str()];
        let scene = Scene::load(&data().join(format!("{name}.xml")), &[]).unwrap();
        let c = criteria(m, mean_tol_by_mitsuba_dev(m));
        let reference = data().join(format!("{name}.exr"));
        report.judged(name, render_and_judge(name, &scene, 1, &reference, &c));
    }
    report.finish("principled", true);
}
