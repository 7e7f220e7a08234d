//! The scenes in `examples/` (shipped with the repository, so that a fresh clone can render
//! something): each loads and renders, with finite, non-black pixels; the measured-material
//! example reads its RGL file from `examples/data/` and looks like green felt.

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
    let names: Vec<_> = scenes.iter().map(|p| p.file_name().unwrap()).collect();
    for want in [
        "cornell_box.xml",
        "material_preview.xml",
        "measured_material.xml",
    ] {
        assert!(
            names.iter().any(|n| *n == want),
            "examples/{want} is missing"
        );
    }
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

#[test]
fn measured_example_renders_the_felt() {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples/measured_material.xml");
    let overrides = [
        ("resx".to_string(), "48".to_string()),
        ("resy".to_string(), "36".to_string()),
    ];
    let scene = Scene::load(&path, &overrides).unwrap();
    let felt = scene
        .bsdfs
        .iter()
        .position(|b| b.plugin_name() == "measured")
        .expect("the example uses Mitsuba's measured plugin") as u32;
    let out = render(
        &scene,
        &RenderOptions {
            spp: 16,
            seed: 1,
            threads: 0,
        },
        &AtomicBool::new(false),
        &|_, _| {},
    );
    // the pixels whose centre sees the felt: green (the measured reflectance of green felt is
    // about (0.19, 0.31, 0.05) at normal incidence)
    let mut sum = [0.0f64; 3];
    let mut n = 0;
    for y in 0..out.height {
        for x in 0..out.width {
            let s = glam::Vec2::new(
                (x as f32 + 0.5) / out.width as f32,
                (y as f32 + 0.5) / out.height as f32,
            );
            let ray = scene.camera.ray(s);
            let Some(hit) = scene.intersect(&ray) else {
                continue;
            };
            if scene.shape_bsdf[hit.shape as usize] == felt {
                let i = (y * out.width + x) * 3;
                for (s, v) in sum.iter_mut().zip(&out.rgb[i..i + 3]) {
                    *s += *v as f64;
                }
                n += 1;
            }
        }
    }
    assert!(n > 200, "only {n} felt pixels");
    let [r, g, b] = sum.map(|v| v / n as f64);
    assert!(
        g > 0.02 && g > 1.3 * r && g > 2.0 * b,
        "felt mean ({r}, {g}, {b})"
    );
}
