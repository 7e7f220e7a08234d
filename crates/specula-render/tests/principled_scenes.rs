//! `principled` and `principledthin` against Mitsuba 3: small scenes in
//! `tests/data/principled/` (several parameter sets: clear-coated and sheened, anisotropic
//! metal, flat fake subsurface, transmissive with `eta` and with `specular`, every scalar
//! parameter textured through `bitmap` and `checkerboard`, thin sheets lit from behind),
//! rendered at 64 spp and held to `../shared/README.md`'s criteria against Mitsuba's
//! references (made by `scripts/gen_principled_refs.py`, with Mitsuba's own 64-spp error in
//! `metrics.json`, averaged over 8 seeds): mean ratio within max(0.01, 2 × Mitsuba's worst
//! deviation), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's.

use specula_render::image_io::read_image;
use specula_render::metrics::{block8, mean_ratio, relmse, RgbImage};
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
        let (r, b, mr) = (
            relmse(&img, &reference),
            block8(&img, &reference),
            mean_ratio(&img, &reference),
        );
        let m_r = m["mitsuba_64spp_relmse"].as_f64().unwrap();
        let m_b = m["mitsuba_64spp_block8"].as_f64().unwrap();
        let tol = (2.0 * m["mitsuba_64spp_max_mean_dev"].as_f64().unwrap()).max(0.01);
        let ok = mr.iter().all(|v| (v - 1.0).abs() <= tol)
            && b <= 2.0 * m_b + 1e-5
            && r <= 1.5 * m_r
            && out.counters.invalid == 0;
        println!(
            "{name:<26} mean [{:.4} {:.4} {:.4}] (±{tol:.3})  block8 {b:.3e} (mitsuba {m_b:.3e})  relmse {r:.3e} (mitsuba {m_r:.3e})  {}",
            mr[0],
            mr[1],
            mr[2],
            if ok { "ok" } else { "FAIL" }
        );
        if !ok {
            failures.push(name.clone());
        }
    }
    assert!(failures.is_empty(), "non-conforming: {failures:?}");
}
