//! `principled` and `principledthin` against Mitsuba 3: small scenes in
//! `tests/data/principled/` (several parameter sets: clear-coated and sheened, anisotropic
//! metal, flat fake subsurface, transmissive with `eta` and with `specular`, every scalar
//! parameter textured through `bitmap` and `checkerboard`, thin sheets lit from behind),
//! rendered at 64 spp and held to `../shared/README.md`'s criteria against Mitsuba's
//! references (made by `scripts/gen_principled_refs.py`, with Mitsuba's own 64-spp error in
//! `metrics.json`, averaged over 8 seeds): mean ratio within max(0.01, 2 × Mitsuba's worst
//! deviation), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.

use specula_render::image_io::read_image;
use specula_render::metrics::{Criteria, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/principled")
}

#[test]
fn principled_scenes_match_mitsuba() {
    let metrics: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(data().join("metrics.json")).unwrap())
            .unwrap();
    let mut failures = vec![];
    let names: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    assert_eq!(names.len(), 4);
    for name in names {
        let m = &metrics[name.as_str()];
        let scene = Scene::load(&data().join(format!("{name}.xml")), &[]).unwrap();
        let opts = RenderOptions {
            spp: 64,
            seed: 0,
            threads: 0,
        };
        let out = render(&scene, &opts, &AtomicBool::new(false), &|_, _| {});
        let (r, _) = read_image(&data().join(format!("{name}.exr"))).unwrap();
        let reference = RgbImage::from(&r);
        assert_eq!(
            (out.width, out.height),
            (reference.width, reference.height),
            "{name}"
        );
        let img = RgbImage {
            width: out.width,
            height: out.height,
            data: out.rgb,
        };
        let criteria = Criteria::new(
            m["mitsuba_64spp_relmse"].as_f64().unwrap(),
            m["mitsuba_64spp_block8"].as_f64().unwrap(),
            (2.0 * m["mitsuba_64spp_max_mean_dev"].as_f64().unwrap()).max(0.01),
        );
        let v = criteria.judge(std::slice::from_ref(&img), &reference);
        let ok = v.ok() && out.counters.invalid == 0;
        println!(
            "{name:<26} {}  {}",
            v.row(&criteria),
            if ok { "ok" } else { "FAIL" }
        );
        if !ok {
            failures.push(name.clone());
        }
    }
    assert!(failures.is_empty(), "non-conforming: {failures:?}");
}
