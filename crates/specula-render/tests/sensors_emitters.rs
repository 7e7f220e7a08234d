//! Sensors and emitters against Mitsuba 3: small scenes in `tests/data/sensors_emitters/`
//! (orthographic with a scaled `to_world`, thinlens with a focal length, perspective with a
//! principal point offset, crop windows, textured and plain `spot`, `projector`, area emitters
//! with textured radiance), rendered at 64 spp and held to `../shared/README.md`'s criteria
//! against Mitsuba's references (made by `scripts/gen_sensor_emitter_refs.py`, with Mitsuba's
//! own 64-spp error in `metrics.json`): mean ratio within max(0.01, 2 × Mitsuba's worst
//! deviation), block8 ≤ 2 × Mitsuba's + 1e-5, relMSE ≤ 1.5 × Mitsuba's. Also: `--size`
//! (`LoadOptions::size`) gives exactly the scene with the film's size edited.

mod common;

use common::{criteria, mean_tol_by_mitsuba_dev, read_metrics, render_and_judge, Report};
use glam::Vec2;
use specula_render::scene::{LoadOptions, Scene};
use std::path::{Path, PathBuf};

fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/sensors_emitters")
}

#[test]
fn scenes_match_mitsuba() {
    let metrics = read_metrics(&data().join("metrics.json"));
    let names: Vec<&String> = metrics.as_object().unwrap().keys().collect();
    assert_eq!(names.len(), 3);
    let mut report = Report::default();
    for name in names {
        let m = &metrics[name.as_str()];
        let scene = Scene::load(&data().join(format!("{name}.xml")), &[]).unwrap();
        let c = criteria(m, mean_tol_by_mitsuba_dev(m));
        // a size mismatch (the crop window's size) is reported as a failure
        let reference = data().join(format!("{name}.exr"));
        report.judged(name, render_and_judge(name, &scene, 1, &reference, &c));
    }
    report.finish("sensors and emitters", true);
}

#[test]
fn size_option_equals_editing_the_film() {
    let path = data().join("perspective_ppo_crop.xml");
    let text = std::fs::read_to_string(&path).unwrap();
    let resized = Scene::load_with(
        &path,
        &[],
        &LoadOptions {
            size: Some((40, 24)),
            ..Default::default()
        },
    )
    .unwrap();
    // the same file with width/height edited, the crop window removed, and the field of view
    // given as the horizontal one of the original 80×60 film (Mitsuba keeps it on a resize):
    // the default 50 mm spans the diagonal of a 36×24 mm sensor
    let tan_diag = 36f64.hypot(24.0) / (2.0 * 50.0);
    let tan_x = tan_diag * 80.0 / 80f64.hypot(60.0);
    let fov_x = 2.0 * tan_x.atan().to_degrees();
    let mut edited = String::new();
    for line in text.lines() {
        if line.contains("crop_") {
            continue;
        }
        edited += &line
            .replace(r#"name="width" value="80""#, r#"name="width" value="40""#)
            .replace(r#"name="height" value="60""#, r#"name="height" value="24""#)
            .replace(
                r#"<sensor type="perspective">"#,
                &format!(
                    r#"<sensor type="perspective"><float name="fov" value="{fov_x:.17}"/><string name="fov_axis" value="x"/>"#
                ),
            );
        edited.push('\n');
    }
    assert_ne!(edited, text);
    let by_hand = Scene::from_xml_str(&edited, "edited", &data(), &[]).unwrap();
    assert_eq!((resized.film.width, resized.film.height), (40, 24));
    assert_eq!(resized.film, by_hand.film);
    for s in [Vec2::ZERO, Vec2::new(0.3, 0.9), Vec2::ONE] {
        // the same camera up to float rounding of the field of view
        let (a, b) = (resized.camera.ray(s), by_hand.camera.ray(s));
        assert!(
            a.o.abs_diff_eq(b.o, 1e-6) && a.d.abs_diff_eq(b.d, 1e-6),
            "{a:?} vs {b:?}"
        );
    }
    // a sensor without a film gets one of the requested size
    let bare =
        r#"<scene version="3.0.0"><sensor type="perspective"/><shape type="sphere"/></scene>"#;
    let dir = std::env::temp_dir().join(format!("specula-size-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("bare.xml");
    std::fs::write(&file, bare).unwrap();
    let s = Scene::load_with(
        &file,
        &[],
        &LoadOptions {
            size: Some((30, 20)),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!((s.film.width, s.film.height), (30, 20));
    let s = Scene::load(&file, &[]).unwrap();
    assert_eq!((s.film.width, s.film.height), (768, 576));
    let e = Scene::load_with(
        &file,
        &[],
        &LoadOptions {
            size: Some((0, 20)),
            ..Default::default()
        },
    )
    .err();
    assert!(e.unwrap().to_string().contains("film size"));
    std::fs::remove_dir_all(&dir).unwrap();
}
