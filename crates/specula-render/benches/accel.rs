//! Ray traversal speed on the geometry of `../shared/scenes/meshes.xml` (76 k triangles), and
//! the same groups on `cbox.xml` prefixed `cbox/`.
//!
//! Run with `cargo bench -p specula-render --bench accel`. Four fixed ray sets of 4096 rays
//! each, generated once from the scene itself (no random numbers are drawn while measuring):
//!
//! - `closest/primary`: camera rays through random film positions;
//! - `closest/secondary`: rays leaving the primary hits in cosine-distributed directions
//!   about the geometric normal (what the path tracer traces after a diffuse bounce);
//! - `occluded/point`: shadow rays from the primary hits to the scene's point light;
//! - `occluded/directional`: shadow rays from the primary hits towards the directional light.
//!
//! Each benchmark iteration traces the whole set, so the time per ray is the reported time
//! divided by 4096 (criterion's throughput line gives rays/s). The plain names measure the
//! box/triangle test implementation picked for this CPU (AVX2 where available); the other
//! implementations follow as `sse2/…` and `scalar/…` (`-- '^(closest|occluded)'` runs only
//! the plain ones).
//!
//! The `build` group times [`Bvh::build`] (binary SAH tree, collapse, packets; with the
//! default thread pool) on the geometry of `meshes.xml` (76 k triangles), of the matpreview
//! scene `bsdf_roughplastic_nopreserve.xml` of `../shared/mitsuba-data` (~70 k triangles) and
//! of a unit UV sphere of 500 rings (998 000 triangles, the tessellation of
//! `scripts/gen_sphere_mesh.py`, generated here): `-- '^build'` runs only it.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use specula_bsdf::frame::Frame;
use specula_bsdf::rng::Pcg32;
use specula_bsdf::warp::square_to_cosine_hemisphere;
use specula_render::accel::{spawn_ray, spawn_ray_to, Bvh, Intersector, Isa};
use specula_render::core::Ray;
use specula_render::geometry::Geometry;
use specula_render::mesh_io::MeshData;
use specula_render::scene::Scene;

const N: usize = 4096;

struct Rays {
    primary: Vec<Ray>,
    secondary: Vec<Ray>,
    point: Vec<Ray>,
    directional: Vec<Ray>,
    /// 8 camera rays through each of N/8 random pixels (of a 256×192 film).
    pixels: Vec<Ray>,
}

fn rays(scene: &Scene) -> Rays {
    let mut rng = Pcg32::new(7, 1);
    let mut r = Rays {
        primary: Vec::new(),
        secondary: Vec::new(),
        point: Vec::new(),
        directional: Vec::new(),
        pixels: Vec::new(),
    };
    while r.pixels.len() < N {
        let (px, py) = (
            (rng.next_f32() * 256.0).floor(),
            (rng.next_f32() * 192.0).floor(),
        );
        for _ in 0..8 {
            let s = glam::Vec2::new((px + rng.next_f32()) / 256.0, (py + rng.next_f32()) / 192.0);
            r.pixels.push(scene.camera.ray(s));
        }
    }
    let light_pos = Vec3::new(2.0, 3.0, -2.0);
    let to_sun = -Vec3::new(0.4, -1.0, 0.6).normalize();
    while r.primary.len() < N || r.secondary.len() < N {
        let ray = scene.camera.ray(rng.next_vec2());
        if r.primary.len() < N {
            r.primary.push(ray);
        }
        let Some(hit) = scene.intersect(&ray) else {
            continue;
        };
        let si = scene.geometry[hit.shape as usize].surface(&ray, &hit);
        let n = if si.n_geo.dot(ray.d) > 0.0 {
            -si.n_geo
        } else {
            si.n_geo
        };
        if r.secondary.len() < N {
            let local = square_to_cosine_hemisphere(rng.next_vec2());
            let d = Frame::from_normal(n).to_world(local).normalize();
            r.secondary.push(spawn_ray(si.p, si.n_geo, d));
            r.point.push(spawn_ray_to(si.p, si.n_geo, light_pos));
            let mut sun = spawn_ray(si.p, si.n_geo, to_sun);
            sun.t_max = f32::INFINITY;
            r.directional.push(sun);
        }
    }
    r
}

/// A unit UV sphere: `rings` rings of 2·rings quads, triangle fans at the poles
/// (4·rings·(rings − 1) triangles), as `scripts/gen_sphere_mesh.py` tessellates it.
fn uv_sphere(rings: u32) -> Geometry {
    let cols = 2 * rings;
    let mut data = MeshData::default();
    data.positions.push(Vec3::Y);
    for i in 1..rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..cols {
            let phi = std::f32::consts::TAU * j as f32 / cols as f32;
            data.positions.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ));
        }
    }
    data.positions.push(-Vec3::Y);
    let south = data.positions.len() as u32 - 1;
    let at = |ring: u32, j: u32| 1 + (ring - 1) * cols + j % cols;
    for j in 0..cols {
        data.indices.push([0, at(1, j + 1), at(1, j)]);
        data.indices
            .push([south, at(rings - 1, j), at(rings - 1, j + 1)]);
    }
    for r in 1..rings - 1 {
        for j in 0..cols {
            let (a, b, c, d) = (at(r, j), at(r, j + 1), at(r + 1, j), at(r + 1, j + 1));
            data.indices.push([a, b, d]);
            data.indices.push([a, d, c]);
        }
    }
    Geometry::mesh(data, glam::Mat4::IDENTITY, false, false).expect("a valid sphere")
}

fn bench_build(c: &mut Criterion) {
    let root = specula_testdata::root();
    let mut inputs: Vec<(&str, Vec<Geometry>)> = Vec::new();
    for (name, path) in [
        ("meshes", root.join("scenes/meshes.xml")),
        (
            "roughplastic",
            root.join("mitsuba-data/docs/scenes/bsdf_roughplastic_nopreserve.xml"),
        ),
    ] {
        match Scene::load(&path, &[]) {
            Ok(s) => inputs.push((name, s.geometry)),
            Err(e) => eprintln!("skipping build/{name}: {e}"),
        }
    }
    inputs.push(("sphere1m", vec![uv_sphere(500)]));
    let mut g = c.benchmark_group("build");
    for (name, geoms) in &inputs {
        let bvh = Bvh::build(geoms);
        eprintln!(
            "build/{name}: {} primitives, SAH cost {:.4}",
            bvh.primitive_count(),
            bvh.sah_cost()
        );
        g.throughput(Throughput::Elements(bvh.primitive_count() as u64));
        if *name == "sphere1m" {
            g.sample_size(10);
        }
        g.bench_function(*name, |b| b.iter(|| Bvh::build(black_box(geoms))));
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    bench_scene(c, "meshes", "");
    bench_scene(c, "cbox", "cbox/");
}

/// The traversal groups on `../shared/scenes/{name}.xml`, their names prefixed by `tag`.
fn bench_scene(c: &mut Criterion, name: &str, tag: &str) {
    let path = specula_testdata::root().join(format!("scenes/{name}.xml"));
    let scene = match Scene::load(&path, &[]) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("skipping the accel benchmark on {name}: {e}");
            return;
        }
    };
    let rays = rays(&scene);
    // the implementation picked for this CPU under the plain names, the others prefixed
    let best = scene.accel.isa();
    let mut isas = vec![best];
    isas.extend(Isa::available().into_iter().rev().filter(|&i| i != best));
    for isa in isas {
        let mut accel = scene.accel.clone();
        accel.set_isa(isa);
        let prefix = if isa == best {
            tag.to_string()
        } else {
            format!("{tag}{isa:?}/").to_lowercase()
        };
        let mut g = c.benchmark_group(format!("{prefix}closest"));
        g.throughput(Throughput::Elements(N as u64));
        for (name, set) in [("primary", &rays.primary), ("secondary", &rays.secondary)] {
            g.bench_function(name, |b| {
                b.iter(|| {
                    let mut hits = 0u32;
                    for ray in set.iter() {
                        hits += accel.intersect(black_box(ray)).is_some() as u32;
                    }
                    hits
                })
            });
        }
        g.finish();
        let mut g = c.benchmark_group(format!("{prefix}occluded"));
        g.throughput(Throughput::Elements(N as u64));
        for (name, set) in [("point", &rays.point), ("directional", &rays.directional)] {
            g.bench_function(name, |b| {
                b.iter(|| {
                    let mut hits = 0u32;
                    for ray in set.iter() {
                        hits += accel.occluded(black_box(ray)) as u32;
                    }
                    hits
                })
            });
        }
        g.finish();
        // a pixel's 8 camera rays, one by one and as a packet
        let mut g = c.benchmark_group(format!("{prefix}pixel8"));
        g.throughput(Throughput::Elements(N as u64));
        g.bench_function("single", |b| {
            b.iter(|| {
                let mut hits = 0u32;
                for ray in rays.pixels.iter() {
                    hits += accel.intersect(black_box(ray)).is_some() as u32;
                }
                hits
            })
        });
        g.bench_function("packet", |b| {
            let mut out = [None; 8];
            b.iter(|| {
                let mut hits = 0u32;
                for packet in rays.pixels.chunks(8) {
                    accel.intersect_packet(black_box(packet), &mut out);
                    hits += out.iter().filter(|h| h.is_some()).count() as u32;
                }
                hits
            })
        });
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_millis(500)).measurement_time(std::time::Duration::from_secs(2));
    targets = bench, bench_build
}
criterion_main!(benches);
