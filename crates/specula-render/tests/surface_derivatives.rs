//! Surface derivatives against Mitsuba 3.9.1: for every shape of `tests/data/
//! derivative_fixture.txt` (written by `scripts/gen_derivative_fixture.py` from the same XML)
//! the rays recorded there must hit with Mitsuba's uv, ∂p/∂u and ∂p/∂v (what `bumpmap` perturbs
//! the shading frame with): rectangles, disks, spheres, cubes, OBJ meshes with, without and
//! with degenerate texture coordinates.

use glam::{Vec2, Vec3};
use specula_render::core::Ray;
use specula_render::scene::Scene;
use std::path::Path;

const FIXTURE: &str = include_str!("data/derivative_fixture.txt");

fn scene_with(shape: &str) -> Scene {
    let xml = format!(
        r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="40"/>
                <film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>
            </sensor>
            {shape}
        </scene>"#
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    Scene::from_xml_str(&xml, "derivative fixture", &dir, &[]).unwrap()
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 2e-4 * b.abs().max_element().max(1.0)
}

#[test]
fn derivatives_match_mitsuba() {
    let mut scene = None;
    let mut label = String::new();
    let mut hits = 0;
    for line in FIXTURE.lines().filter(|l| !l.starts_with('#')) {
        if let Some(xml) = line.strip_prefix("shape ") {
            scene = Some(scene_with(xml));
            label = xml.to_string();
            continue;
        }
        let x: Vec<f32> = line
            .strip_prefix("hit ")
            .unwrap()
            .split_whitespace()
            .map(|w| w.parse().unwrap())
            .collect();
        let s = scene.as_ref().unwrap();
        let ray = Ray::new(Vec3::new(x[0], x[1], x[2]), Vec3::new(x[3], x[4], x[5]));
        let hit = s
            .intersect(&ray)
            .unwrap_or_else(|| panic!("{label}: ray {ray:?} misses"));
        let sg = s.geometry[hit.shape as usize].surface(&ray, &hit);
        let (uv, du, dv) = (
            Vec2::new(x[6], x[7]),
            Vec3::new(x[8], x[9], x[10]),
            Vec3::new(x[11], x[12], x[13]),
        );
        assert!(
            (sg.uv - uv).abs().max_element() < 1e-4,
            "{label}: uv {} vs Mitsuba {uv}",
            sg.uv
        );
        assert!(
            close(sg.dp_du, du) && close(sg.dp_dv, dv),
            "{label}: ray {ray:?}: dp_du {} dp_dv {}, Mitsuba {du} {dv}",
            sg.dp_du,
            sg.dp_dv
        );
        // the shading point carries them in the local frame, with the geometric normal
        let sp = sg.shading_point(&hit, None, true);
        assert!((sg.sh_frame.to_world(sp.dp_du) - sg.dp_du).length() < 1e-4 * du.length().max(1.0));
        assert!((sg.sh_frame.to_world(sp.n_geo) - sg.n_geo).length() < 1e-5);
        hits += 1;
    }
    assert!(hits >= 40, "{hits} hits");
}
