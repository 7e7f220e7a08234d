//! The scenes in `examples/` (shipped with the repository, so that a fresh clone can render
//! something): each loads and renders, with finite, non-black pixels.

use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

#[test]
fn every_example_renders() {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 2, "examples/ holds {} scenes", scenes.len());
    for path in &scenes {
        let overrides = [
            ("resx".to_string(), "24".to_string()),
            ("resy".to_string(), "16".to_string()),
        ];
        let scene =
            Scene::load(path, &overrides).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let opts = RenderOptions {
            spp: 4,
            seed: 1,
            threads: 0,
        };
        let out = render(&scene, &opts, &AtomicBool::new(false), &|_, _| {});
        assert_eq!((out.width, out.height), (24, 16), "{}", path.display());
        assert_eq!(out.counters.invalid, 0, "{}", path.display());
        assert!(out.rgb.iter().all(|v| v.is_finite() && *v >= 0.0));
        let mean = out.rgb.iter().sum::<f32>() / out.rgb.len() as f32;
        assert!(mean > 0.01, "{}: mean {mean}", path.display());
    }
}
