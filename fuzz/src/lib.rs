//! Fuzz targets for Specula: one function per reader, plus the whole pipeline. Each takes the
//! fuzzer's bytes and must return normally, whatever they are: an `Err` from a reader is the
//! expected outcome for most inputs; a panic, an abort, a hang or an allocation beyond the
//! fuzzer's `-rss_limit_mb` is a finding.
//!
//! The libFuzzer binaries in `fuzz_targets/` call these functions; `tests/replay.rs` runs
//! the seed corpora (from `../shared`) and the checked-in `regressions/` through them with
//! plain `cargo test`, without libFuzzer. See `README.md`.

use glam::{Mat4, Vec2, Vec3};
use specula_bsdf::measured::merl::Merl;
use specula_bsdf::measured::rgl::{Rgl, TensorFile};
use specula_bsdf::{Bsdf, BsdfContext, BsdfModel, ShadingPoint};
use specula_render::accel::{Bvh, Intersector};
use specula_render::core::Ray;
use specula_render::geometry::Geometry;
use specula_render::image_io::decode_image;
use specula_render::mesh_io::{parse_obj, parse_ply, MeshData};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Scenes resolve relative file names against `../shared/scenes` (where the seed scenes
/// live, with their `assets/`).
pub fn scene_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes")
}

/// The largest film the rendering targets render (bigger ones are only loaded).
const MAX_RENDER_PIXELS: usize = 64;

/// Renders `scene` at one sample per pixel (films of at most [`MAX_RENDER_PIXELS`] pixels)
/// and checks that every pixel is finite.
fn render_small(scene: &Scene) {
    if scene.film.width * scene.film.height > MAX_RENDER_PIXELS {
        return;
    }
    let opts = RenderOptions {
        spp: 1,
        seed: 0,
        threads: 0,
    };
    let out = render(scene, &opts, &AtomicBool::new(false), &|_, _| {});
    // overflowed pixels are reported (and black), never written as ±∞ or NaN
    if let Some(v) = out.rgb.iter().find(|v| !v.is_finite()) {
        panic!("non-finite pixel value {v}");
    }
}

/// XML scene files: parsing, includes, parameters, building every plugin, the BVH.
pub fn xml_scene(data: &[u8]) {
    xml_scene_in(data, &scene_dir());
}

/// [`xml_scene`] with relative file names resolved against `dir`.
pub fn xml_scene_in(data: &[u8], dir: &Path) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = Scene::from_xml_str(text, "fuzz.xml", dir, &[]);
}

/// A fixed scene whose every parameter comes from `-D` overrides.
const OVERRIDE_SCENE: &str = r#"<scene version="3.0.0">
<default name="spp" value="1"/>
<default name="resx" value="4"/>
<default name="resy" value="4"/>
<default name="fov" value="40"/>
<default name="stddev" value="0.5"/>
<default name="radiance" value="1"/>
<default name="intensity" value="1"/>
<default name="bsdf" value="diffuse"/>
<default name="alpha" value="0.1"/>
<default name="max_depth" value="4"/>
<default name="radius" value="1"/>
<default name="z" value="0"/>
<default name="scale" value="1"/>
<integrator type="path"><integer name="max_depth" value="$max_depth"/></integrator>
<sensor type="perspective">
  <float name="fov" value="$fov"/>
  <transform name="to_world"><lookat origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
  <film type="hdrfilm">
    <integer name="width" value="$resx"/><integer name="height" value="$resy"/>
    <rfilter type="gaussian"><float name="stddev" value="$stddev"/></rfilter>
  </film>
</sensor>
<shape type="sphere">
  <float name="radius" value="$radius"/>
  <transform name="to_world"><scale value="$scale"/><translate z="$z"/></transform>
  <bsdf type="$bsdf"/>
</shape>
<shape type="rectangle">
  <transform name="to_world"><translate z="3"/></transform>
  <bsdf type="roughconductor"><float name="alpha" value="$alpha"/></bsdf>
  <emitter type="area"><rgb name="radiance" value="$radiance"/></emitter>
</shape>
<emitter type="point"><point name="position" value="0, 3, -2"/><rgb name="intensity" value="$intensity"/></emitter>
<emitter type="constant"><rgb name="radiance" value="$radiance"/></emitter>
</scene>"#;

/// `-D name=value` overrides (one per line of the input) of [`OVERRIDE_SCENE`], then a tiny
/// render.
pub fn overrides(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let mut pairs = Vec::new();
    for line in text.lines() {
        let Some((k, v)) = line.split_once('=') else {
            return;
        };
        pairs.push((k.to_string(), v.to_string()));
    }
    if let Ok(scene) = Scene::from_xml_str(OVERRIDE_SCENE, "overrides.xml", &scene_dir(), &pairs) {
        render_small(&scene);
    }
}

/// A mesh as a shape, in a BVH, hit by a few rays.
fn exercise_mesh(m: MeshData) {
    let Ok(g) = Geometry::mesh(m, Mat4::IDENTITY, false, false) else {
        return;
    };
    let bvh = Bvh::build(std::slice::from_ref(&g));
    for d in [Vec3::Z, -Vec3::Z, Vec3::new(0.3, -0.2, 1.0).normalize()] {
        let ray = Ray::new(Vec3::new(0.1, 0.2, -10.0) * d.z.signum(), d);
        if let Some(hit) = bvh.intersect(&ray) {
            let _ = g.surface(&ray, &hit);
        }
    }
}

/// Wavefront OBJ meshes.
pub fn obj(data: &[u8]) {
    if let Ok(m) = parse_obj(data) {
        exercise_mesh(m);
    }
}

/// Stanford PLY meshes (ascii and binary).
pub fn ply(data: &[u8]) {
    if let Ok(m) = parse_ply(data) {
        exercise_mesh(m);
    }
}

/// Mitsuba `.serialized` meshes (zlib-compressed): the first byte of the input picks the
/// shape index (0–3), the rest is the file.
pub fn serialized(data: &[u8]) {
    let Some((&index, file)) = data.split_first() else {
        return;
    };
    if let Ok(m) = specula_render::serialized::parse(file, (index % 4) as i64) {
        exercise_mesh(m);
    }
}

/// Evaluates and samples a BSDF in a few directions.
fn exercise_bsdf(b: &Bsdf) {
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let dirs = [
        Vec3::Z,
        Vec3::new(0.3, 0.1, 0.9).normalize(),
        Vec3::new(-0.8, 0.0, 0.6),
        Vec3::new(0.2, 0.3, -0.93).normalize(),
    ];
    for wi in dirs {
        for wo in dirs {
            let _ = b.eval(&ctx, &sp, wi, wo);
            let _ = b.pdf(&ctx, &sp, wi, wo);
        }
        for u in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.9, 0.6),
            Vec2::new(0.5, 0.999),
        ] {
            let _ = b.sample(&ctx, &sp, wi, 0.3, u);
        }
    }
}

/// MERL `.binary` measured BRDFs.
pub fn merl(data: &[u8]) {
    if let Ok(m) = Merl::from_bytes("fuzz.binary", data) {
        exercise_bsdf(&Bsdf::Merl(m));
    }
}

/// RGL `.bsdf` tensor files.
pub fn rgl(data: &[u8]) {
    let Ok(tf) = TensorFile::from_bytes("fuzz.bsdf", data.to_vec()) else {
        return;
    };
    if let Ok(r) = Rgl::from_tensor(&tf) {
        exercise_bsdf(&Bsdf::Measured(std::sync::Arc::new(r)));
    }
}

/// Images (OpenEXR, PNG, JPEG, Radiance HDR), then an environment map built from them.
pub fn image(data: &[u8]) {
    let Ok((img, srgb)) = decode_image(data) else {
        return;
    };
    if img.width * img.height > 1 << 16 {
        return;
    }
    if let Ok(env) = specula_render::emitters::Envmap::new(&img, srgb, 1.0, &Mat4::IDENTITY) {
        let e = specula_render::emitters::Emitter::Envmap(Box::new(env));
        for u in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.7, 0.4),
            Vec2::new(0.999, 0.0),
        ] {
            if let Some(s) = e.sample_direction(Vec3::ZERO, u) {
                let _ = e.pdf_direction(s.wi);
                let _ = e.eval_direction(s.wi);
            }
        }
    }
}

/// One-line material specs (`specula brdf eval "…"`).
pub fn spec(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(b) = specula_bsdf::parse_spec(text) {
        exercise_bsdf(&b);
    }
}

/// A whole scene, loaded and rendered at 1 sample per pixel when its film is tiny; every
/// pixel must be finite.
pub fn pipeline(data: &[u8]) {
    pipeline_in(data, &scene_dir());
}

/// [`pipeline`] with relative file names resolved against `dir`.
pub fn pipeline_in(data: &[u8], dir: &Path) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(scene) = Scene::from_xml_str(text, "fuzz.xml", dir, &[]) {
        render_small(&scene);
    }
}
