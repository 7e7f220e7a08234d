//! A renderable scene, assembled from a Mitsuba 3 XML plugin tree.

use crate::accel::{Bvh, Intersector};
use crate::camera::{Camera, FilmWindow};
use crate::core::{Loc, Ray, Result, SceneError};
use crate::emitters::{Emitter, NamedTexture};
use crate::film::{Film, RFilter};
use crate::geometry::{Geometry, ShapeGroup};
use crate::integrator::Integrator;
use crate::sampler::SamplerSettings;
use crate::texture::{Bitmap, Checkerboard, MeshAttributeTexture};
use crate::xml::{Node, PropValue, Usage};
use glam::{Mat4, Vec3};
use specula_bsdf::{build_bsdf, Bsdf, Props, Rgb, Texture, Value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Settings of Mitsuba's `path` integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    /// Longest path (number of segments); −1 = unbounded.
    pub max_depth: i32,
    /// Depth from which Russian roulette starts.
    pub rr_depth: i32,
    /// Whether directly visible emitters are hidden.
    pub hide_emitters: bool,
}

/// A light source: an emitting shape or one of the other emitters.
#[derive(Debug)]
pub enum Light {
    /// Mitsuba's `area` emitter on shape `shape`, emitting `radiance` from its front side.
    Area {
        shape: u32,
        radiance: AreaRadiance,
    },
    Other(Emitter),
}

/// The `radiance` of Mitsuba's `area` emitter: a colour, or a texture looked up at the surface
/// point's uv (a nested `<texture name="radiance">` or a `<ref name="radiance" id=…>`).
///
/// Light sampling picks points uniformly by area (spheres seen from outside: uniformly in
/// the cone they subtend) whether or not the radiance is textured, and the MIS pdf is that
/// of the same strategy. Mitsuba importance-samples a textured radiance's image instead
/// (`Texture::sample_position`); both are unbiased, so images agree in expectation and
/// differ only in noise.
#[derive(Clone, Debug)]
pub enum AreaRadiance {
    Rgb(Rgb),
    Texture(Arc<dyn Texture>),
    /// A `<spectrum>`: `rgb` in RGB mode, `curve` in spectral mode
    /// ([`AreaRadiance::emission`]).
    Spectral {
        rgb: Rgb,
        curve: Arc<dyn specula_bsdf::bsdf::SpectralCurve>,
    },
}

impl From<Rgb> for AreaRadiance {
    fn from(c: Rgb) -> Self {
        AreaRadiance::Rgb(c)
    }
}

impl AreaRadiance {
    /// Radiance at a surface point with texture coordinates `uv` (position `p`).
    #[inline]
    pub fn eval(&self, uv: glam::Vec2, p: Vec3) -> Rgb {
        match self {
            AreaRadiance::Rgb(c) | AreaRadiance::Spectral { rgb: c, .. } => *c,
            AreaRadiance::Texture(t) => t.eval(&specula_bsdf::ShadingPoint {
                uv,
                p,
                ..Default::default()
            }),
        }
    }

    /// Radiance at the point `o + t·d` where a ray meets the sphere `g` (a shape whose surface
    /// point follows from the ray alone; not a mesh, which needs the hit's barycentrics): the
    /// point's uv is only computed for a textured radiance.
    #[inline]
    pub fn eval_along(&self, g: &Geometry, o: Vec3, d: Vec3, t: f32) -> Rgb {
        match self {
            AreaRadiance::Rgb(c) | AreaRadiance::Spectral { rgb: c, .. } => *c,
            AreaRadiance::Texture(_) => {
                let ray = Ray {
                    o,
                    d,
                    t_max: f32::INFINITY,
                };
                let hit = crate::core::Hit {
                    t,
                    shape: 0,
                    prim: 0,
                    u: 0.0,
                    v: 0.0,
                    vertices: None,
                };
                let si = g.surface(&ray, &hit);
                self.eval(si.uv, si.p)
            }
        }
    }
}

/// Changes applied to a scene file as it loads.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Render at this film size (width, height) with the same horizontal field of view, as
    /// Mitsuba does when a film is resized through `mi.traverse`: as if every film's `width`
    /// and `height` were edited in the file, its crop window reset to the full film, and the
    /// camera's field of view given as the horizontal one it had on the original film (a
    /// sensor without a film gets an `hdrfilm` of this size).
    pub size: Option<(usize, usize)>,
    /// Reproduce Mitsuba 3.9's known deviations from the plugins' definitions, so that a scene
    /// renders as Mitsuba 3.9 renders it (`specula render --mitsuba-compat`). Today one:
    /// `blendbsdf` weights a sample of a Dirac lobe as Mitsuba 3.9 does (an energy loss; see
    /// the `dirac_mixing` parameter of `blendbsdf`), unless the file sets `dirac_mixing`.
    pub mitsuba_compat: bool,
}

impl LoadOptions {
    /// Applies the options to the parsed scene tree.
    fn apply(&self, root: &mut Node) -> Result<()> {
        if self.mitsuba_compat {
            let mut stack: Vec<&mut Node> = vec![&mut *root];
            while let Some(n) = stack.pop() {
                if n.tag == "bsdf"
                    && n.plugin_type == "blendbsdf"
                    && !n.props.iter().any(|p| p.name == "dirac_mixing")
                {
                    let loc = n.loc.clone();
                    n.props.push(crate::xml::Prop::new(
                        "dirac_mixing",
                        PropValue::Str("mitsuba".into()),
                        loc,
                    ));
                }
                stack.extend(n.children.iter_mut());
            }
        }
        let Some((w, h)) = self.size else {
            return Ok(());
        };
        if w == 0 || h == 0 || w > 1 << 16 || h > 1 << 16 {
            return Err(SceneError::new(
                None,
                format!("invalid film size {w}×{h} (each side must lie in [1, 65536])"),
            ));
        }
        fn film_props(film: &mut Node, w: usize, h: usize) {
            film.props.retain(|p| {
                !matches!(
                    p.name.as_str(),
                    "width"
                        | "height"
                        | "crop_offset_x"
                        | "crop_offset_y"
                        | "crop_width"
                        | "crop_height"
                )
            });
            for (name, v) in [("width", w), ("height", h)] {
                let loc = film.loc.clone();
                film.props
                    .push(crate::xml::Prop::new(name, PropValue::Int(v as i64), loc));
            }
        }
        // ids of films declared apart from their sensor (reached through <ref>)
        fn film_ids(n: &Node, ids: &mut Vec<String>) {
            if n.tag == "film" {
                ids.extend(n.id.clone());
            }
            n.children.iter().for_each(|c| film_ids(c, ids));
        }
        let mut ids = vec![];
        film_ids(root, &mut ids);
        keep_horizontal_fov(root)?;
        fn walk(n: &mut Node, w: usize, h: usize, ids: &[String]) {
            if n.tag == "film" {
                film_props(n, w, h);
            }
            let has_film = n.children.iter().any(|c| {
                c.tag == "film"
                    || (c.tag == "ref" && c.id.as_ref().is_some_and(|i| ids.contains(i)))
            });
            if n.tag == "sensor" && !has_film {
                let mut film = Node {
                    tag: "film".into(),
                    plugin_type: "hdrfilm".into(),
                    id: None,
                    name: None,
                    props: vec![],
                    children: vec![],
                    loc: n.loc.clone(),
                };
                film_props(&mut film, w, h);
                n.children.push(film);
            }
            for c in &mut n.children {
                walk(c, w, h, ids);
            }
        }
        walk(root, w, h, &ids);
        Ok(())
    }
}

/// Mitsuba keeps a perspective camera's horizontal field of view when its film is resized
/// (`mi.traverse`: the sensor's x fov was computed from the file's film and stays), which is
/// how the docs-scene references at reduced size were made. So before `--size` changes the
/// film, each `perspective`/`thinlens` sensor's `fov`/`fov_axis`/`focal_length` is replaced
/// by the horizontal fov they give on the film as written (with `fov_axis="x"`, this is the
/// same camera at the original size). With `fov_axis` `x` nothing changes; with the other
/// axes, the same field of view on a film of a slightly different aspect.
fn keep_horizontal_fov(root: &mut Node) -> Result<()> {
    let mut stack: Vec<&mut Node> = vec![root];
    while let Some(n) = stack.pop() {
        if n.tag == "sensor" && matches!(n.plugin_type.as_str(), "perspective" | "thinlens") {
            let film = n.children.iter().find(|c| c.tag == "film");
            let dim = |name: &str, default: i64| -> i64 {
                film.and_then(|f| f.props.iter().find(|p| p.name == name))
                    .and_then(|p| match p.value {
                        PropValue::Int(v) => Some(v),
                        _ => None,
                    })
                    .unwrap_or(default)
            };
            let (w, h) = (dim("width", 768), dim("height", 576));
            if w > 0 && h > 0 {
                let t = crate::camera::parse_fov(n, w as f64 / h as f64)? as f64;
                let fov_x = 2.0 * t.atan().to_degrees();
                let loc = n
                    .props
                    .iter()
                    .find(|p| matches!(p.name.as_str(), "fov" | "focal_length"))
                    .map_or(n.loc.clone(), |p| p.loc.clone());
                n.props
                    .retain(|p| !matches!(p.name.as_str(), "fov" | "fov_axis" | "focal_length"));
                n.props.push(crate::xml::Prop::new(
                    "fov",
                    PropValue::Float(fov_x),
                    loc.clone(),
                ));
                n.props.push(crate::xml::Prop::new(
                    "fov_axis",
                    PropValue::Str("x".into()),
                    loc,
                ));
            }
        }
        stack.extend(n.children.iter_mut());
    }
    Ok(())
}

/// The infinite lights whose texels are worth prefetching (see `Scene::prefetched_maps`).
fn prefetched_maps(lights: &[Light], infinite: &[u32]) -> Vec<u32> {
    infinite
        .iter()
        .copied()
        .filter(|&li| {
            matches!(&lights[li as usize],
                Light::Other(crate::emitters::Emitter::Envmap(e)) if e.worth_prefetching())
        })
        .collect()
}

pub struct Scene {
    pub geometry: Vec<Geometry>,
    /// BSDF of each shape.
    pub shape_bsdf: Vec<u32>,
    /// Light attached to each shape, if it emits.
    pub shape_light: Vec<Option<u32>>,
    /// The scene's BSDFs. Replace one with [`Scene::set_bsdf`], which keeps what the
    /// shapes using it compute per hit in step (assigning here directly can leave a shape
    /// skipping the uv its new BSDF reads).
    pub bsdfs: Vec<Bsdf>,
    pub lights: Vec<Light>,
    /// Indices of infinitely distant lights (environment, constant) seen by escaping rays.
    pub infinite_lights: Vec<u32>,
    /// Those of them whose texels the path loop prefetches along each new ray: environment
    /// maps too large to stay in the core's cache ([`crate::emitters::Envmap::prefetch`]).
    pub(crate) prefetched_maps: Vec<u32>,
    pub accel: Bvh,
    pub camera: Camera,
    pub film: Film,
    /// Samples per pixel: the sampler's `sample_count`, rounded as the sampler requires.
    pub spp: u32,
    /// The sampler's `seed`.
    pub seed: u64,
    pub sampler: SamplerSettings,
    pub integrator: Integrator,
    /// Participating media ([`crate::media`]); shapes and the camera refer to them by index.
    pub media: Vec<crate::media::Medium>,
    /// Interior and exterior medium of each shape (Mitsuba's `interior`/`exterior`).
    pub shape_media: Vec<crate::media::ShapeMedia>,
    /// The medium the camera sits in.
    pub camera_medium: Option<u32>,
    /// The integrator is Mitsuba's `volpath` (with [`Scene::integrator`]'s settings).
    pub volpath: bool,
    /// Render in spectral mode ([`crate::spectral`]; set it with [`Scene::set_spectral`]).
    pub spectral: bool,
    /// Per light, in spectral mode: its colour prepared for upsampling when it is constant
    /// (see [`Scene::light_weight`]); empty in RGB mode.
    pub(crate) light_colours: Vec<Option<specula_bsdf::spectral::upsample::Illuminant>>,
}

impl Scene {
    /// Load a Mitsuba 3 scene file; `overrides` are `-D name=value` pairs.
    pub fn load(path: &Path, overrides: &[(String, String)]) -> Result<Scene> {
        Self::load_with(path, overrides, &LoadOptions::default())
    }

    /// [`Scene::load`] with [`LoadOptions`] (e.g. another film size).
    pub fn load_with(
        path: &Path,
        overrides: &[(String, String)],
        opts: &LoadOptions,
    ) -> Result<Scene> {
        let parse = crate::timings::span(crate::timings::Phase::Parse);
        let mut root = crate::xml::load_scene(path, overrides)?;
        drop(parse);
        opts.apply(&mut root)?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        prefetch_bsdf_tables(&root);
        let _images = crate::image_io::prefetch(crate::texture::scene_images(&root, &base));
        let _meshes = crate::prefetch::prefetch_meshes(mesh_files(&root, &base));
        Builder {
            base,
            ids: HashMap::new(),
            bsdf_ids: HashMap::new(),
            texture_ids: HashMap::new(),
            groups: HashMap::new(),
            attr_uses: MeshAttrUses::default(),
        }
        .build(&root)
    }

    /// Build a scene from Mitsuba 3 XML text (for scenes made by a program); `label` names it
    /// in error locations, and files and `<include>`s resolve against `base_dir`.
    pub fn from_xml_str(
        text: &str,
        label: &str,
        base_dir: &Path,
        overrides: &[(String, String)],
    ) -> Result<Scene> {
        let root = crate::xml::parse_scene_str(text, label, base_dir, overrides)?;
        Builder {
            base: base_dir.to_path_buf(),
            ids: HashMap::new(),
            bsdf_ids: HashMap::new(),
            texture_ids: HashMap::new(),
            groups: HashMap::new(),
            attr_uses: MeshAttrUses::default(),
        }
        .build(&root)
    }

    /// Add a light that is not part of the XML (e.g. an environment map made in memory),
    /// registering it as infinitely distant when it is.
    pub fn add_light(&mut self, emitter: Emitter) {
        if emitter.is_infinite() {
            self.infinite_lights.push(self.lights.len() as u32);
        }
        self.lights.push(Light::Other(emitter));
        self.prefetched_maps = prefetched_maps(&self.lights, &self.infinite_lights);
    }

    /// Replaces BSDF `index` (as `bsdfs[index] = bsdf`) and has the spheres and flat-faced
    /// meshes that use it compute their hits' uv again if the new BSDF may read it (the
    /// scene's analysis turned the uv off for shapes whose material reads none, see
    /// `skip_unread_uv`). Panics if `index` is out of range, as indexing does.
    pub fn set_bsdf(&mut self, index: usize, bsdf: Bsdf) {
        if bsdf.reads_uv() {
            for (g, &b) in self.geometry.iter_mut().zip(&self.shape_bsdf) {
                if let (true, Some(uv)) = (b as usize == index, g.uv_flag_mut()) {
                    *uv = true;
                }
            }
        }
        self.bsdfs[index] = bsdf;
    }

    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<crate::core::Hit> {
        self.accel.intersect(ray)
    }

    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }
}

/// Builds the BSDF with id `id` from the scene file at `path` (a top-level `<bsdf>` or one
/// nested in a shape), with the scene's `<default>`s and `overrides`; textures it references
/// by id are built too. Nothing else of the scene is loaded.
pub fn load_bsdf_by_id(path: &Path, id: &str, overrides: &[(String, String)]) -> Result<Bsdf> {
    let root = crate::xml::load_scene(path, overrides)?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    find_and_build_bsdf(&root, base, Some(id)).map_err(|e| match e {
        Some(e) => e,
        None => SceneError::new(
            Some(root.loc.clone()),
            format!(
                "the scene has no <bsdf id=\"{id}\">{}",
                bsdf_ids_hint(&root)
            ),
        ),
    })
}

/// Builds a BSDF from an XML snippet such as `<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>`
/// (Mitsuba 3 syntax; several elements may be given, the last `<bsdf>` is built and earlier
/// `<texture id=…>`s may be referenced). `label` names the text in messages; files resolve
/// against `base_dir`.
pub fn bsdf_from_xml_str(text: &str, label: &str, base_dir: &Path) -> Result<Bsdf> {
    // offset the snippet onto line 1 of the wrapper so that locations stay right
    let wrapped = format!("<scene version=\"3.0.0\">{text}</scene>");
    let root = crate::xml::parse_scene_str(&wrapped, label, base_dir, &[])?;
    find_and_build_bsdf(&root, base_dir.to_path_buf(), None).map_err(|e| {
        e.unwrap_or_else(|| {
            SceneError::new(Some(root.loc.clone()), "the text has no <bsdf> element")
        })
    })
}

fn bsdf_ids_hint(root: &Node) -> String {
    let mut ids = vec![];
    fn walk(n: &Node, ids: &mut Vec<String>) {
        for c in &n.children {
            if c.tag == "bsdf" {
                if let Some(id) = &c.id {
                    ids.push(id.clone());
                }
            }
            if c.tag == "shape" {
                walk(c, ids);
            }
        }
    }
    walk(root, &mut ids);
    if ids.is_empty() {
        " (it defines no BSDF ids)".into()
    } else {
        format!(" (BSDF ids: {})", ids.join(", "))
    }
}

/// Walks the top level (and shapes) in order, registering textures; builds the BSDF whose id is
/// `id`, or the last top-level `<bsdf>` when `id` is None. `Err(None)`: not found.
fn find_and_build_bsdf(
    root: &Node,
    base: PathBuf,
    id: Option<&str>,
) -> std::result::Result<Bsdf, Option<SceneError>> {
    let mut b = Builder {
        base,
        ids: HashMap::new(),
        bsdf_ids: HashMap::new(),
        texture_ids: HashMap::new(),
        groups: HashMap::new(),
        attr_uses: MeshAttrUses::default(),
    };
    let mut last = None;
    for child in &root.children {
        if let Some(cid) = &child.id {
            b.ids
                .insert(cid.clone(), (child.tag.clone(), child.loc.clone()));
        }
        match child.tag.as_str() {
            "texture" => {
                let t = b.texture(child).map_err(Some)?;
                if let Some(cid) = &child.id {
                    b.texture_ids.insert(cid.clone(), t);
                }
            }
            "bsdf" => match id {
                Some(want) if child.id.as_deref() == Some(want) => {
                    return b.bsdf(child).map_err(Some)
                }
                None => last = Some(child),
                _ => {}
            },
            "shape" => {
                if let Some(want) = id {
                    if let Some(n) = child
                        .children
                        .iter()
                        .find(|c| c.tag == "bsdf" && c.id.as_deref() == Some(want))
                    {
                        return b.bsdf(n).map_err(Some);
                    }
                }
            }
            _ => {}
        }
    }
    match last {
        Some(n) => b.bsdf(n).map_err(Some),
        None => Err(None),
    }
}

/// The plain parameters of a `<bsdf>` node (numbers, strings, colours; not its nested
/// elements) as material-library [`Props`]; `filename`s resolve through `resolve`.
fn bsdf_plain_props(n: &Node, resolve: impl Fn(&Loc, &str) -> PathBuf) -> Result<Props> {
    let mut props = Props::new(n.plugin_type.clone(), loc_str(&n.loc));
    for p in &n.props {
        let v = match &p.value {
            PropValue::Float(v) => Value::Float(*v),
            PropValue::Int(v) => Value::Int(*v),
            PropValue::Bool(v) => Value::Bool(*v),
            // data files of measured materials resolve relative to the scene file
            PropValue::Str(v) if p.name == "filename" => {
                Value::Str(resolve(&p.loc, v).to_string_lossy().into_owned())
            }
            PropValue::Str(v) => Value::Str(v.clone()),
            PropValue::Rgb(v) => Value::Rgb(Rgb(*v)),
            // a constant stays a number; anything else keeps its RGB value the way
            // Mitsuba's plugins read it (IORs and roughness unbounded, the rest as
            // reflectances) for RGB mode, and the spectrum itself for spectral mode
            PropValue::Spectrum(s) => match s.as_constant() {
                Some(v) => Value::Float(v),
                None => {
                    let usage = match p.name.as_str() {
                        "eta" | "k" | "alpha" | "alpha_u" | "alpha_v" => Usage::Unbounded,
                        _ => Usage::Reflectance,
                    };
                    let rgb = s.to_rgb(usage).map_err(|why| {
                        SceneError::new(
                            Some(p.loc.clone()),
                            format!("parameter '{}' of bsdf '{}': {why}", p.name, n.plugin_type),
                        )
                    })?;
                    Value::Spectral {
                        rgb: Rgb(rgb),
                        curve: s.curve(),
                    }
                }
            },
            other => {
                return Err(SceneError::new(
                    Some(p.loc.clone()),
                    format!(
                        "parameter '{}' of bsdf '{}' cannot be a {other:?}",
                        p.name, n.plugin_type
                    ),
                ))
            }
        };
        props.set(&p.name, v, loc_str(&p.loc)).map_err(bsdf_err)?;
    }
    Ok(props)
}

/// Starts building, on a thread of its own, the BSDFs whose construction precomputes tables
/// (`roughplastic`'s coat transmittance and internal reflectance: tens of milliseconds each)
/// from their plain parameters, which alone decide the tables (nested textures do not). The
/// tables are cached process-wide, so the loader's own build of each such BSDF, in document
/// order, takes them from the cache or waits for them instead of computing them after the
/// images and meshes before it; meanwhile they are computed on cores the loader leaves idle
/// (while it waits for an image, or builds the BVH). The results are the same bits: the
/// tables depend only on those parameters. Errors are left to the loader's build.
fn prefetch_bsdf_tables(root: &Node) {
    fn walk(n: &Node, out: &mut Vec<Props>) {
        if n.tag == "bsdf" && n.plugin_type == "roughplastic" {
            if let Ok(p) = bsdf_plain_props(n, |_, v| PathBuf::from(v)) {
                out.push(p);
            }
        }
        for c in &n.children {
            walk(c, out);
        }
    }
    let mut props = vec![];
    walk(root, &mut props);
    if props.is_empty() {
        return;
    }
    let spawned = std::thread::Builder::new()
        .name("specula-bsdf-tables".into())
        .spawn(move || {
            for p in props {
                let _ = build_bsdf(p);
            }
        });
    // (without a thread the loader computes the tables itself)
    drop(spawned);
}

/// [`Builder::resolve_from`] with the main scene's directory `base`.
fn resolve_file(base: &Path, loc: &Loc, name: &str) -> PathBuf {
    let p = Path::new(name);
    if p.is_absolute() {
        return p.to_path_buf();
    }
    if let Some(dir) = Path::new(&loc.file).parent() {
        let candidate = dir.join(p);
        if candidate.exists() {
            return candidate;
        }
    }
    base.join(p)
}

/// The mesh files of the scene's `obj`, `ply` and `serialized` shapes (wherever nested), as
/// [`crate::prefetch`] keys them: what the loader will read, started ahead of it. A shape
/// whose parameters are not plain (the loader will report it) is left out.
fn mesh_files(root: &Node, base: &Path) -> Vec<crate::prefetch::MeshKey> {
    fn walk(n: &Node, base: &Path, out: &mut Vec<crate::prefetch::MeshKey>) {
        if n.tag == "shape" && matches!(n.plugin_type.as_str(), "obj" | "ply" | "serialized") {
            let prop = |name: &str| n.props.iter().find(|p| p.name == name).map(|p| &p.value);
            let index = match (n.plugin_type.as_str(), prop("shape_index")) {
                ("serialized", Some(PropValue::Int(i))) => Some(*i),
                ("serialized", Some(_)) => None,
                _ => Some(0),
            };
            if let (Some(PropValue::Str(file)), Some(index)) = (prop("filename"), index) {
                let path = resolve_file(base, &n.loc, file);
                out.push((n.plugin_type.clone(), path, index));
            }
        }
        for c in &n.children {
            walk(c, base, out);
        }
    }
    let mut out = vec![];
    walk(root, base, &mut out);
    out
}

fn loc_str(l: &Loc) -> Option<String> {
    Some(l.to_string())
}

struct Builder {
    base: PathBuf,
    /// id → tag, to give good errors for refs of the wrong kind
    ids: HashMap<String, (String, Loc)>,
    bsdf_ids: HashMap<String, u32>,
    texture_ids: HashMap<String, Arc<dyn Texture>>,
    /// `shapegroup`s by id, for `instance`s.
    groups: HashMap<String, Arc<ShapeGroup>>,
    attr_uses: MeshAttrUses,
}

/// The mesh attributes that materials read through `mesh_attribute` textures, checked against
/// the shapes the materials are attached to.
#[derive(Default)]
struct MeshAttrUses {
    /// Met while building the current BSDF: (attribute name, where the texture was given).
    pending: std::cell::RefCell<Vec<(String, Loc)>>,
    /// Per BSDF (index into the scene's list).
    by_bsdf: HashMap<u32, Vec<(String, Loc)>>,
}

/// A `<sensor>`: its camera, film and sampler.
type Sensor = (Camera, Film, SamplerSettings);

struct Parts<'a> {
    geometry: Vec<Geometry>,
    shape_bsdf: Vec<u32>,
    shape_light: Vec<Option<u32>>,
    materials: Materials<'a>,
    lights: Vec<Light>,
    media: crate::media::SceneMedia,
}

/// The scene's BSDFs as the walk over the document meets them. Building one can wait for its
/// images to be decoded (and a `roughplastic` for its tables), so the walk only gives each its
/// index and leaves it pending, with the checks of the shapes' mesh attributes against it;
/// [`Builder::build_pending`] builds them in document order afterwards, while the BVH is built
/// over the finished geometry ([`Builder::bsdfs_and_bvh`]). The walk meets nothing that
/// depends on a BSDF but its index, and an error it meets is reported after the pending work
/// before it (the first error in document order, as when everything is built as it is met).
#[derive(Default)]
struct Materials<'a> {
    /// Per index: built, or to be built by a [`Pending::Bsdf`].
    bsdfs: Vec<Option<Bsdf>>,
    /// In document order.
    pending: Vec<Pending<'a>>,
}

enum Pending<'a> {
    /// BSDF `node`, the scene's BSDF `index`.
    Bsdf { index: u32, node: &'a Node },
    /// The mesh attributes BSDF `bsdf` reads, checked against those of the shape declared at
    /// `at` ([`shape_attributes`]).
    MeshAttributes {
        bsdf: u32,
        shape: Option<Vec<(String, usize)>>,
        at: &'a Loc,
    },
}

/// The mesh attributes (name, channels) that `mesh_attribute` textures can read on a shape
/// (an instance: on its group's member), or None when the shape is not a triangle mesh.
fn shape_attributes(geom: &Geometry) -> Option<Vec<(String, usize)>> {
    let geom = match geom {
        Geometry::Instance(i) => &i.group.shapes[i.member as usize],
        g => g,
    };
    match geom {
        Geometry::Mesh(m) => Some(
            m.attributes
                .iter()
                .map(|a| (a.name.clone(), a.dim))
                .collect(),
        ),
        _ => None,
    }
}

/// Primitives from which the scene's BVH is built on a thread of its own beside the BSDFs; a
/// smaller one (about a millisecond) is built after them, without a thread.
const BVH_BESIDE: usize = 4096;

/// Marks the spheres and meshes whose uv nothing reads (no texture in their BSDF, no
/// textured emission, no AOV integrator), so that their hits in the path loop skip it: a
/// sphere's trigonometry (an atan2 and an asin per hit: 2–3 % of a sphere scene's
/// instructions), a flat-faced mesh's (rectangle, cube) index and uv loads and interpolation
/// (about 1 % of `cbox`'s); see `Geometry::surface_uv`. Nothing else changes: the uv is not
/// read where it is skipped, and `Geometry::surface` still computes it for every caller.
fn skip_unread_uv(parts: &mut Parts, bsdfs: &[Bsdf], integrator: &Integrator) {
    if !integrator.aov_channels().is_empty() {
        return;
    }
    for (i, g) in parts.geometry.iter_mut().enumerate() {
        let Some(uv) = g.uv_flag_mut() else {
            continue;
        };
        let emission_reads_uv = match parts.shape_light[i] {
            Some(li) => !matches!(
                &parts.lights[li as usize],
                Light::Area {
                    radiance: AreaRadiance::Rgb(_) | AreaRadiance::Spectral { .. },
                    ..
                }
            ),
            None => false,
        };
        let bsdf_reads_uv = bsdfs
            .get(parts.shape_bsdf[i] as usize)
            .is_none_or(Bsdf::reads_uv);
        *uv = emission_reads_uv || bsdf_reads_uv;
    }
}

/// The scene's BVH (its phase timed on the thread that builds it).
fn build_bvh(geometry: &[Geometry]) -> Bvh {
    let _t = crate::timings::span(crate::timings::Phase::Bvh);
    Bvh::build(geometry)
}

impl Builder {
    /// A file named by a parameter declared at `loc`: relative to the directory of the file
    /// that declares it (an `<include>`d file), then to the main scene's directory — like
    /// Mitsuba's file resolver.
    fn resolve_from(&self, loc: &Loc, name: &str) -> PathBuf {
        resolve_file(&self.base, loc, name)
    }

    fn build(mut self, root: &Node) -> Result<Scene> {
        if root.tag != "scene" {
            return Err(SceneError::new(
                Some(root.loc.clone()),
                "the root element must be <scene>",
            ));
        }
        let mut parts = Parts {
            geometry: vec![],
            shape_bsdf: vec![],
            shape_light: vec![],
            materials: Materials::default(),
            lights: vec![],
            media: Default::default(),
        };
        let walked = self.walk(root, &mut parts);
        let materials = std::mem::take(&mut parts.materials);
        let (integrator, sensor) = match walked {
            Ok(found) => found,
            Err(e) => {
                // the BSDFs before the error come first
                self.build_pending(materials)?;
                return Err(e);
            }
        };
        let (bsdfs, accel) = self.bsdfs_and_bvh(materials, &parts.geometry)?;
        root.check_unused(&[])?;
        let Some((camera, film, sampler)) = sensor else {
            return Err(SceneError::new(
                Some(root.loc.clone()),
                "the scene has no <sensor>",
            ));
        };
        if parts.geometry.is_empty() && parts.lights.is_empty() {
            return Err(SceneError::new(
                Some(root.loc.clone()),
                "the scene has no shapes and no emitters",
            ));
        }
        let infinite_lights: Vec<u32> = parts
            .lights
            .iter()
            .enumerate()
            .filter(|(_, l)| matches!(l, Light::Other(e) if e.is_infinite()))
            .map(|(i, _)| i as u32)
            .collect();
        parts.media.check_integrator(root)?;
        let prefetched_maps = prefetched_maps(&parts.lights, &infinite_lights);
        skip_unread_uv(&mut parts, &bsdfs, &integrator);
        Ok(Scene {
            geometry: parts.geometry,
            shape_bsdf: parts.shape_bsdf,
            shape_light: parts.shape_light,
            bsdfs,
            lights: parts.lights,
            infinite_lights,
            prefetched_maps,
            accel,
            camera,
            film,
            spp: sampler.sample_count(sampler.sample_count),
            seed: sampler.seed,
            sampler,
            integrator,
            media: parts.media.media,
            shape_media: parts.media.shape_media,
            camera_medium: parts.media.camera_medium,
            volpath: parts.media.volpath,
            spectral: false,
            light_colours: Vec::new(),
        })
    }

    /// Builds the pending BSDFs ([`Builder::build_pending`]) and the BVH over `geometry`: a
    /// large BVH on a thread of its own meanwhile (the BSDFs mostly wait for their images
    /// and tables), a small one after them.
    fn bsdfs_and_bvh(
        &mut self,
        materials: Materials,
        geometry: &[Geometry],
    ) -> Result<(Vec<Bsdf>, Bvh)> {
        let primitives: usize = geometry
            .iter()
            .map(|g| match g {
                Geometry::Mesh(m) => m.indices.len(),
                _ => 1,
            })
            .sum();
        if primitives < BVH_BESIDE {
            let bsdfs = self.build_pending(materials)?;
            return Ok((bsdfs, build_bvh(geometry)));
        }
        std::thread::scope(|s| {
            let bvh = std::thread::Builder::new()
                .name("specula-bvh".into())
                .spawn_scoped(s, || build_bvh(geometry));
            let bsdfs = self.build_pending(materials);
            match bvh {
                Ok(h) => {
                    let accel = h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
                    Ok((bsdfs?, accel))
                }
                // (no thread: after them)
                Err(_) => Ok((bsdfs?, build_bvh(geometry))),
            }
        })
    }

    /// The top level of the scene, in document order: the integrator and sensor, with the
    /// shapes, emitters and media in `parts` and its BSDFs pending there ([`Materials`]).
    fn walk<'a>(
        &mut self,
        root: &'a Node,
        parts: &mut Parts<'a>,
    ) -> Result<(Integrator, Option<Sensor>)> {
        let mut integrator = Integrator::default();
        let mut sensor = None;
        for child in &root.children {
            if let Some(id) = &child.id {
                if child.tag != "ref" {
                    if let Some((_, first)) = self.ids.get(id) {
                        return Err(SceneError::new(
                            Some(child.loc.clone()),
                            format!("id '{id}' is already used at {first}"),
                        ));
                    }
                    self.ids
                        .insert(id.clone(), (child.tag.clone(), child.loc.clone()));
                }
            }
            match child.tag.as_str() {
                "integrator" if matches!(child.plugin_type.as_str(), "volpath" | "volpathmis") => {
                    parts.media.volpath = true;
                    integrator = Integrator::Volpath(crate::volpath::settings_from_node(child)?);
                }
                "integrator" => integrator = self.integrator(child)?,
                "sensor" => {
                    parts.media.camera_medium = parts.media.attached(child, false)?.1;
                    sensor = Some(self.sensor(child)?)
                }
                "medium" => parts.media.declare(child)?,
                "bsdf" => {
                    let index = self.add_bsdf(child, &mut parts.materials)?;
                    if let Some(id) = &child.id {
                        self.bsdf_ids.insert(id.clone(), index);
                    }
                }
                "texture" => {
                    let t = self.texture(child)?;
                    if let Some(id) = &child.id {
                        self.texture_ids.insert(id.clone(), t);
                    }
                }
                "shape" => self.shape(child, parts)?,
                "emitter" => {
                    let e = self.emitter(child)?;
                    parts.lights.push(Light::Other(e));
                }
                other => {
                    return Err(SceneError::new(
                        Some(child.loc.clone()),
                        format!("<{other}> is not supported at the top level of a scene (supported: integrator, sensor, bsdf, texture, shape, emitter)"),
                    ))
                }
            }
        }
        Ok((integrator, sensor))
    }

    fn integrator(&self, n: &Node) -> Result<Integrator> {
        Integrator::from_node(n)
    }

    /// A `<sampler>` (nested in a sensor).
    fn sampler(&self, n: &Node) -> Result<SamplerSettings> {
        SamplerSettings::from_node(n)
    }

    fn sensor(&self, n: &Node) -> Result<Sensor> {
        if !crate::camera::SENSORS.contains(&n.plugin_type.as_str()) {
            return Err(SceneError::new(
                Some(n.loc.clone()),
                format!(
                    "sensor '{}' is not supported (supported: {})",
                    n.plugin_type,
                    crate::camera::SENSORS.join(", ")
                ),
            ));
        }
        let mut film = None;
        let mut sampler = SamplerSettings::default();
        for c in &n.children {
            match c.tag.as_str() {
                "film" => film = Some(self.film(c)?),
                "medium" | "ref" => {} // the camera's medium (build() reads it)
                "sampler" => sampler = self.sampler(c)?,
                other => {
                    return Err(SceneError::new(
                        Some(c.loc.clone()),
                        format!("<{other}> cannot be nested in a sensor"),
                    ))
                }
            }
        }
        // Mitsuba's default film: hdrfilm, 768 × 576
        let (film, window) = match film {
            Some(f) => f,
            None => (
                Film::new(768, 576, RFilter::default_gaussian()),
                FilmWindow::full(768, 576),
            ),
        };
        let cam = Camera::from_node(n, &window)?;
        Ok((cam, film, sampler))
    }

    fn film(&self, n: &Node) -> Result<(Film, FilmWindow)> {
        if n.plugin_type != "hdrfilm" {
            return Err(SceneError::new(
                Some(n.loc.clone()),
                format!(
                    "film '{}' is not supported (supported: hdrfilm)",
                    n.plugin_type
                ),
            ));
        }
        let w = n.int("width", 768)?;
        let h = n.int("height", 576)?;
        crate::film::check_film_size(w, h).map_err(|m| SceneError::new(Some(n.loc.clone()), m))?;
        for p in [
            "file_format",
            "pixel_format",
            "component_format",
            "banner",
            "sample_border",
        ] {
            let _ = n.prop(p);
        }
        let mut filter = RFilter::default_gaussian();
        for c in &n.children {
            if c.tag != "rfilter" {
                return Err(SceneError::new(
                    Some(c.loc.clone()),
                    format!("<{}> cannot be nested in a film", c.tag),
                ));
            }
            filter = self.rfilter(c)?;
        }
        let window = FilmWindow::from_node(n, w as usize, h as usize)?;
        n.check_unused(&[
            "width",
            "height",
            "rfilter",
            "file_format",
            "pixel_format",
            "component_format",
            "banner",
            "sample_border",
        ])?;
        let (cw, ch) = window.crop_size;
        Ok((Film::new(cw, ch, filter), window))
    }

    fn rfilter(&self, n: &Node) -> Result<RFilter> {
        let f = match n.plugin_type.as_str() {
            "box" => RFilter::Box,
            "tent" => RFilter::Tent,
            "gaussian" => RFilter::gaussian_checked(n.float("stddev", 0.5)?).map_err(|m| {
                let loc = n.prop("stddev").map_or(&n.loc, |p| &p.loc);
                SceneError::new(Some(loc.clone()), m)
            })?,
            other => {
                return Err(SceneError::new(
                    Some(n.loc.clone()),
                    format!("rfilter '{other}' is not supported (supported: box, tent, gaussian)"),
                ))
            }
        };
        n.check_unused(&["stddev"])?;
        Ok(f)
    }

    fn texture(&self, n: &Node) -> Result<Arc<dyn Texture>> {
        let _t = crate::timings::span(crate::timings::Phase::Textures);
        let to_uv = n.transform("to_uv")?.unwrap_or(Mat4::IDENTITY);
        let t: Arc<dyn Texture> = match n.plugin_type.as_str() {
            "checkerboard" => {
                let c0 = n.rgb("color0", [0.4; 3])?;
                let c1 = n.rgb("color1", [0.2; 3])?;
                n.check_unused(&["color0", "color1", "to_uv"])?;
                let mut t = Checkerboard::new(Rgb(c0), Rgb(c1), to_uv);
                // `<spectrum>` colours, for spectral mode (a constant is grey either way)
                for (k, name) in ["color0", "color1"].into_iter().enumerate() {
                    if let Some(PropValue::Spectrum(s)) = n.prop(name).map(|p| &p.value) {
                        t.spectra[k] = s.as_constant().is_none().then(|| s.curve());
                    }
                }
                Arc::new(t)
            }
            "bitmap" => {
                let file = n.string_opt("filename")?.ok_or_else(|| {
                    SceneError::new(Some(n.loc.clone()), "bitmap needs 'filename'")
                })?;
                let filter = n.string("filter_type", "bilinear")?;
                let wrap = n.string("wrap_mode", "repeat")?;
                let raw = n.bool("raw", false)?;
                n.check_unused(&[
                    "filename",
                    "filter_type",
                    "wrap_mode",
                    "raw",
                    "to_uv",
                    "format",
                ])?;
                let path = self.resolve_from(&n.loc, &file);
                let b = Bitmap::load(&path, &filter, &wrap, raw, to_uv)
                    .map_err(|e| SceneError::new(Some(n.loc.clone()), e.to_string()))?;
                Arc::new(b)
            }
            "mesh_attribute" => {
                let name = n.string_opt("name")?.ok_or_else(|| {
                    SceneError::new(
                        Some(n.loc.clone()),
                        "mesh_attribute needs 'name' (vertex_… or face_…)",
                    )
                })?;
                if !(name.starts_with("vertex_") || name.starts_with("face_")) {
                    return Err(SceneError::new(
                        Some(n.loc.clone()),
                        format!("invalid mesh attribute name '{name}': it must start with 'vertex_' or 'face_'"),
                    ));
                }
                let scale = n.float("scale", 1.0)?;
                n.check_unused(&["name", "scale"])?;
                Arc::new(MeshAttributeTexture { name, scale })
            }
            other => {
                return Err(SceneError::new(
                    Some(n.loc.clone()),
                    format!("texture '{other}' is not supported (supported: bitmap, checkerboard, mesh_attribute)"),
                ))
            }
        };
        Ok(t)
    }

    /// Convert an XML BSDF node into the material library's parameters and build it.
    fn bsdf(&self, n: &Node) -> Result<Bsdf> {
        let _t = crate::timings::span(crate::timings::Phase::Bsdfs);
        let mut props = bsdf_plain_props(n, |loc, v| self.resolve_from(loc, v))?;
        n.mark_all_used();
        for c in &n.children {
            match c.tag.as_str() {
                "texture" => {
                    // bumpmap takes its one texture whatever its name (as Mitsuba)
                    let name =
                        match (&c.name, n.plugin_type.as_str()) {
                            (Some(name), _) => name.clone(),
                            (None, "bumpmap") => "(unnamed texture)".to_string(),
                            (None, _) => return Err(SceneError::new(
                                Some(c.loc.clone()),
                                "a texture nested in a bsdf needs a 'name' (the parameter it sets)",
                            )),
                        };
                    let t = self.texture(c)?;
                    self.note_mesh_attribute(&t, &c.loc);
                    props
                        .set(&name, Value::Texture(t), loc_str(&c.loc))
                        .map_err(bsdf_err)?;
                }
                "bsdf" => {
                    let b = self.bsdf(c)?;
                    props.add_child(b, loc_str(&c.loc));
                }
                "ref" => {
                    let id = c.id.clone().unwrap_or_default();
                    if let Some(t) = self.texture_ids.get(&id) {
                        self.note_mesh_attribute(t, &c.loc);
                        let name = c.name.clone().ok_or_else(|| {
                            SceneError::new(
                                Some(c.loc.clone()),
                                format!("a reference to texture '{id}' needs a 'name'"),
                            )
                        })?;
                        props
                            .set(&name, Value::Texture(t.clone()), loc_str(&c.loc))
                            .map_err(bsdf_err)?;
                    } else {
                        return Err(self.bad_ref(c, "bsdf or texture"));
                    }
                }
                other => {
                    return Err(SceneError::new(
                        Some(c.loc.clone()),
                        format!("<{other}> cannot be nested in a bsdf"),
                    ))
                }
            }
        }
        build_bsdf(props).map_err(bsdf_err)
    }

    /// Gives BSDF `n` the scene's next index and leaves it pending in `m` ([`Materials`]), or
    /// builds it now when one of its `<ref>`s names no texture defined so far: built later,
    /// it could find one defined after it (then it fails here, as it would have).
    fn add_bsdf<'a>(&mut self, n: &'a Node, m: &mut Materials<'a>) -> Result<u32> {
        let index = m.bsdfs.len() as u32;
        if self.refs_resolve(n) {
            m.bsdfs.push(None);
            m.pending.push(Pending::Bsdf { index, node: n });
        } else {
            m.bsdfs.push(Some(self.bsdf(n)?));
            self.file_mesh_attributes(index);
        }
        Ok(index)
    }

    /// Whether every `<ref>` that [`Builder::bsdf`] looks up in building `n` (in it and in the
    /// BSDFs nested in it) names a texture defined so far: what it reads of the builder, the
    /// textures by id, is then the same now and later (ids are never redefined).
    fn refs_resolve(&self, n: &Node) -> bool {
        n.children.iter().all(|c| match c.tag.as_str() {
            "ref" => self
                .texture_ids
                .contains_key(c.id.as_deref().unwrap_or_default()),
            "bsdf" => self.refs_resolve(c),
            _ => true,
        })
    }

    /// Checks the mesh attributes that BSDF `bsdf` reads against shape `geom` (declared at
    /// `at`) now, or after the BSDF is built when it is pending.
    fn check_or_defer_mesh_attributes<'a>(
        &self,
        bsdf: u32,
        geom: &Geometry,
        at: &'a Loc,
        m: &mut Materials<'a>,
    ) -> Result<()> {
        let shape = shape_attributes(geom);
        if m.bsdfs[bsdf as usize].is_some() {
            return self.check_mesh_attributes(bsdf, &shape, at);
        }
        m.pending.push(Pending::MeshAttributes { bsdf, shape, at });
        Ok(())
    }

    /// Builds the pending BSDFs and checks in document order (the first error is the scene's);
    /// the scene's BSDFs.
    fn build_pending(&mut self, m: Materials) -> Result<Vec<Bsdf>> {
        let mut bsdfs = m.bsdfs;
        for p in m.pending {
            match p {
                Pending::Bsdf { index, node } => {
                    bsdfs[index as usize] = Some(self.bsdf(node)?);
                    self.file_mesh_attributes(index);
                }
                Pending::MeshAttributes { bsdf, shape, at } => {
                    self.check_mesh_attributes(bsdf, &shape, at)?
                }
            }
        }
        Ok(bsdfs
            .into_iter()
            .map(|b| b.expect("every BSDF is built or pending"))
            .collect())
    }

    /// Remembers that the BSDF being built reads a mesh attribute (when `t` is a
    /// `mesh_attribute` texture).
    fn note_mesh_attribute(&self, t: &Arc<dyn Texture>, loc: &Loc) {
        if let Some(name) = t.mesh_attribute() {
            self.attr_uses
                .pending
                .borrow_mut()
                .push((name.to_string(), loc.clone()));
        }
    }

    /// Files the mesh attributes met while building BSDF `index` under it.
    fn file_mesh_attributes(&mut self, index: u32) {
        let uses = self.attr_uses.pending.take();
        if !uses.is_empty() {
            self.attr_uses
                .by_bsdf
                .entry(index)
                .or_default()
                .extend(uses);
        }
    }

    /// Checks that a shape (declared at `at`, with mesh attributes `shape` as
    /// [`shape_attributes`] lists them) has every attribute BSDF `bsdf` reads, with 1 or 3
    /// channels (Mitsuba fails at render time).
    fn check_mesh_attributes(
        &self,
        bsdf: u32,
        shape: &Option<Vec<(String, usize)>>,
        at: &Loc,
    ) -> Result<()> {
        let Some(uses) = self.attr_uses.by_bsdf.get(&bsdf) else {
            return Ok(());
        };
        for (name, loc) in uses {
            let msg = match shape {
                Some(attributes) => match attributes.iter().find(|(n, _)| n == name) {
                    Some((_, 1 | 3)) => continue,
                    Some((_, dim)) => format!(
                        "mesh_attribute '{name}': the attribute has {dim} channels (1 or 3 can be read)"
                    ),
                    None => {
                        let have: Vec<&str> = attributes.iter().map(|(n, _)| n.as_str()).collect();
                        format!(
                            "mesh_attribute '{name}': the shape at {at} has no such attribute (it has: {})",
                            if have.is_empty() { "none".to_string() } else { have.join(", ") }
                        )
                    }
                },
                None => format!("mesh_attribute '{name}': the shape at {at} is not a mesh"),
            };
            return Err(SceneError::new(Some(loc.clone()), msg));
        }
        Ok(())
    }

    fn bad_ref(&self, c: &Node, want: &str) -> SceneError {
        let id = c.id.clone().unwrap_or_default();
        match self.ids.get(&id) {
            Some((tag, at)) => SceneError::new(
                Some(c.loc.clone()),
                format!("'{id}' (defined at {at}) is a {tag}, not a {want}"),
            ),
            None => SceneError::new(
                Some(c.loc.clone()),
                format!("reference to undefined id '{id}' (ids must be defined before use)"),
            ),
        }
    }

    fn emitter(&self, n: &Node) -> Result<Emitter> {
        let _t = crate::timings::span(crate::timings::Phase::Emitters);
        let textures = self.emitter_textures(n)?;
        Emitter::from_node_textured(n, &self.base, &textures)
    }

    /// The textures nested in (or referenced by) an emitter, with the parameter each sets;
    /// other nested elements are left for the emitter to reject.
    fn emitter_textures(&self, n: &Node) -> Result<Vec<NamedTexture>> {
        let mut out = vec![];
        for c in &n.children {
            let texture = match c.tag.as_str() {
                "texture" => self.texture(c)?,
                "ref" => match c.id.as_ref().and_then(|id| self.texture_ids.get(id)) {
                    Some(t) => t.clone(),
                    None => return Err(self.bad_ref(c, "texture")),
                },
                _ => continue,
            };
            let name = c.name.clone().ok_or_else(|| {
                c.error(format!(
                    "a texture given to {} needs a 'name' (the parameter it sets)",
                    n.describe()
                ))
            })?;
            out.push(NamedTexture {
                name,
                texture,
                loc: c.loc.clone(),
            });
        }
        Ok(out)
    }

    /// Mitsuba's `area` emitter nested in a shape: its `radiance`, a colour or a texture.
    fn area_radiance(&self, c: &Node) -> Result<AreaRadiance> {
        let textures = self.emitter_textures(c)?;
        if let Some(other) = c
            .children
            .iter()
            .find(|x| x.tag != "texture" && x.tag != "ref")
        {
            return Err(other.error(format!(
                "<{}> cannot be nested in an area emitter",
                other.tag
            )));
        }
        let radiance = match textures.as_slice() {
            [] => {
                let rgb = crate::emitters::light_rgb(c, "radiance")?;
                match crate::emitters::light_spectrum(c, "radiance")? {
                    Some(curve) => AreaRadiance::Spectral { rgb, curve },
                    None => AreaRadiance::Rgb(rgb),
                }
            }
            [t] if t.name == "radiance" && !c.has("radiance") => {
                AreaRadiance::Texture(t.texture.clone())
            }
            [t, ..] => {
                return Err(SceneError::new(
                    Some(t.loc.clone()),
                    format!(
                        "an area emitter takes one texture, 'radiance' (got '{}'{})",
                        t.name,
                        if c.has("radiance") {
                            " besides a radiance value"
                        } else {
                            ""
                        }
                    ),
                ))
            }
        };
        c.check_unused(&["radiance"])?;
        Ok(radiance)
    }

    fn shape<'a>(&mut self, n: &'a Node, parts: &mut Parts<'a>) -> Result<()> {
        match n.plugin_type.as_str() {
            "shapegroup" => return self.shapegroup(n, parts),
            "instance" => return self.instance(n, parts),
            "merge" => return self.merge(n, parts),
            _ => {}
        }
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let flip = n.bool("flip_normals", false)?;
        let geom = match n.plugin_type.as_str() {
            "obj" | "ply" | "serialized" => {
                let _t = crate::timings::span(crate::timings::Phase::Meshes);
                let file = n.string_opt("filename")?.ok_or_else(|| SceneError::new(Some(n.loc.clone()), format!("{} needs 'filename'", n.plugin_type)))?;
                let face_normals = n.bool("face_normals", false)?;
                let path = self.resolve_from(&n.loc, &file);
let shape_index = match n.plugin_type.as_str() {
                    "serialized" => n.int("shape_index", 0)?,
                    _ => 0,
                };
                // (from the prefetch started with the scene, when it holds the file)
                let mut data = crate::prefetch::take_mesh(&n.plugin_type, &path, shape_index)
                .map_err(|e| SceneError::new(Some(n.loc.clone()), e.to_string()))?;
                // Mitsuba's OBJ loader flips v unless told not to (load_obj flips, as the default)
                if n.plugin_type == "obj" && !n.bool("flip_tex_coords", true)? {
                    if let Some(uvs) = data.uvs.as_mut() {
                        for uv in uvs.iter_mut() {
                            uv.y = 1.0 - uv.y;
                        }
                    }
                }
                let valid: &[&str] = match n.plugin_type.as_str() {
                    "obj" => &["filename", "face_normals", "flip_normals", "to_world", "flip_tex_coords"],
                    "ply" => &["filename", "face_normals", "flip_normals", "to_world"],
                    _ => &["filename", "shape_index", "face_normals", "flip_normals", "to_world"],
                };
                n.check_unused(valid)?;
                Geometry::mesh(data, to_world, face_normals, flip)
                    .map_err(|e| SceneError::new(Some(n.loc.clone()), e.to_string()))?
            }
            "sphere" => {
                let center = n.point("center", Vec3::ZERO)?;
                let radius = n.float("radius", 1.0)?;
                if radius.is_nan() || radius <= 0.0 {
                    return Err(SceneError::new(Some(n.loc.clone()), format!("sphere radius must be positive, got {radius}")));
                }
                n.check_unused(&["center", "radius", "to_world", "flip_normals"])?;
                Geometry::sphere(center, radius, to_world, flip)
            }
            "cylinder" => {
                let p0 = n.point("p0", Vec3::ZERO)?;
                let p1 = n.point("p1", Vec3::Z)?;
                let radius = n.float("radius", 1.0)?;
                n.check_unused(&["p0", "p1", "radius", "to_world", "flip_normals"])?;
                Geometry::cylinder(p0, p1, radius, to_world, flip)
                    .map_err(|e| SceneError::new(Some(n.loc.clone()), e.to_string()))?
            }
            "rectangle" | "cube" | "disk" => {
                n.check_unused(&["to_world", "flip_normals"])?;
                match n.plugin_type.as_str() {
                    "rectangle" => Geometry::rectangle(to_world, flip),
                    "cube" => Geometry::cube(to_world, flip),
                    _ => Geometry::disk(to_world, flip),
                }
            }
            other => {
                return Err(SceneError::new(
                    Some(n.loc.clone()),
                    format!("shape '{other}' is not supported (supported: obj, ply, serialized, sphere, rectangle, cube, disk, cylinder, shapegroup, instance, merge)"),
                ))
            }
        };
        let shape_index = parts.geometry.len() as u32;
        let mut bsdf = None;
        let mut light = None;
        for c in &n.children {
            match c.tag.as_str() {
                "bsdf" => bsdf = Some(self.add_bsdf(c, &mut parts.materials)?),
                "medium" => {}
                "ref" if matches!(c.name.as_deref(), Some("interior" | "exterior")) => {}
                "ref" => {
                    let id = c.id.clone().unwrap_or_default();
                    match self.bsdf_ids.get(&id) {
                        Some(&b) => bsdf = Some(b),
                        None => return Err(self.bad_ref(c, "bsdf")),
                    }
                }
                "emitter" => {
                    if c.plugin_type != "area" {
                        return Err(SceneError::new(
                            Some(c.loc.clone()),
                            format!(
                                "only 'area' emitters can be attached to a shape, not '{}'",
                                c.plugin_type
                            ),
                        ));
                    }
                    let radiance = self.area_radiance(c)?;
                    parts.lights.push(Light::Area {
                        shape: shape_index,
                        radiance,
                    });
                    light = Some(parts.lights.len() as u32 - 1);
                }
                other => {
                    return Err(SceneError::new(
                        Some(c.loc.clone()),
                        format!("<{other}> cannot be nested in a shape"),
                    ))
                }
            }
        }
        let bsdf = match bsdf {
            Some(b) => b,
            None => {
                // Mitsuba's default: diffuse with reflectance 0.5, or 0 on an emitting shape
                let rho = if light.is_some() { 0.0 } else { 0.5 };
                parts
                    .materials
                    .bsdfs
                    .push(Some(Bsdf::Diffuse(specula_bsdf::models::Diffuse {
                        reflectance: rho.into(),
                    })));
                parts.materials.bsdfs.len() as u32 - 1
            }
        };
        self.check_or_defer_mesh_attributes(bsdf, &geom, &n.loc, &mut parts.materials)?;
        parts.geometry.push(geom);
        parts.shape_bsdf.push(bsdf);
        parts.shape_light.push(light);
        let sm = parts.media.attached(n, true)?.0;
        parts.media.shape_media.push(sm);
        Ok(())
    }
}

impl Builder {
    /// Mitsuba's `shapegroup`: builds its shapes (in the group's space, BSDFs in the scene's
    /// list) and one BVH over them, kept under its id for `instance`s; nothing is rendered
    /// until instanced.
    fn shapegroup<'a>(&mut self, n: &'a Node, parts: &mut Parts<'a>) -> Result<()> {
        n.check_unused(&[])?;
        let mut gp = Parts {
            geometry: vec![],
            shape_bsdf: vec![],
            shape_light: vec![],
            materials: std::mem::take(&mut parts.materials),
            lights: vec![],
            media: Default::default(),
        };
        let mut result = Ok(());
        for c in &n.children {
            result = self.group_member(c, &mut gp);
            if result.is_err() {
                break;
            }
        }
        parts.materials = std::mem::take(&mut gp.materials);
        result?;
        if !gp.lights.is_empty() {
            return Err(SceneError::new(
                Some(n.loc.clone()),
                "Instancing of emitters is not supported (a shape in a shapegroup cannot carry an emitter)",
            ));
        }
        let group = Arc::new(ShapeGroup::new(gp.geometry, gp.shape_bsdf));
        if let Some(id) = &n.id {
            self.groups.insert(id.clone(), group);
        }
        Ok(())
    }

    /// One nested element of a `shapegroup`: a shape without emitters (Mitsuba's errors).
    fn group_member<'a>(&mut self, c: &'a Node, gp: &mut Parts<'a>) -> Result<()> {
        let err = |m: &str| Err(SceneError::new(Some(c.loc.clone()), m));
        if c.tag != "shape" {
            return err(&format!(
                "<{}> cannot be nested in a shapegroup (only shapes can)",
                c.tag
            ));
        }
        match c.plugin_type.as_str() {
            "shapegroup" => return err("Nested ShapeGroup is not permitted"),
            "instance" => return err("Nested instancing is not permitted"),
            _ => {}
        }
        if c.children.iter().any(|e| e.tag == "emitter") {
            return err("Instancing of emitters is not supported (a shape in a shapegroup cannot carry an emitter)");
        }
        self.shape(c, gp)
    }

    /// Mitsuba's `merge` (3.5+): its nested shapes, with the triangle meshes that share a BSDF
    /// (and have no emitter, and the same normal / texture-coordinate layout and
    /// `flip_normals`) concatenated into one mesh each; other shapes are kept as they are.
    /// As in Mitsuba the kept shapes come first, then the merged meshes. Same image as
    /// without `merge`; fewer, larger meshes.
    fn merge<'a>(&mut self, n: &'a Node, parts: &mut Parts<'a>) -> Result<()> {
        n.check_unused(&[])?;
        let start = parts.geometry.len();
        for c in &n.children {
            if c.tag != "shape" || c.plugin_type == "shapegroup" {
                return Err(SceneError::new(
                    Some(c.loc.clone()),
                    format!(
                        "<{} type=\"{}\"> cannot be nested in a merge (only shapes can; shapegroups belong at the top level)",
                        c.tag, c.plugin_type
                    ),
                ));
            }
            self.shape(c, parts)?;
        }
        let geometry: Vec<Geometry> = parts.geometry.drain(start..).collect();
        let bsdfs: Vec<u32> = parts.shape_bsdf.drain(start..).collect();
        let lights: Vec<Option<u32>> = parts.shape_light.drain(start..).collect();
        let media: Vec<crate::media::ShapeMedia> = parts.media.shape_media.drain(start..).collect();
        // (bsdf, layout) → meshes, in order of first appearance
        type Key = (u32, (bool, bool, bool));
        let mut groups: Vec<(Key, Vec<Geometry>)> = Vec::new();
        for (((g, bsdf), light), sm) in geometry.into_iter().zip(bsdfs).zip(lights).zip(media) {
            // shapes that bound a medium keep their own identity
            let key = if sm.is_transition() || sm != Default::default() {
                None
            } else {
                g.merge_key()
            };
            match (light, key) {
                (None, Some(k)) => match groups.iter_mut().find(|(key, _)| *key == (bsdf, k)) {
                    Some((_, list)) => list.push(g),
                    None => groups.push(((bsdf, k), vec![g])),
                },
                _ => {
                    if let Some(li) = light {
                        if let Light::Area { shape, .. } = &mut parts.lights[li as usize] {
                            *shape = parts.geometry.len() as u32;
                        }
                    }
                    parts.geometry.push(g);
                    parts.shape_bsdf.push(bsdf);
                    parts.shape_light.push(light);
                    parts.media.shape_media.push(sm);
                }
            }
        }
        for ((bsdf, _), list) in groups {
            let merged = Geometry::merge_meshes(list)
                .map_err(|e| SceneError::new(Some(n.loc.clone()), e.to_string()))?;
            parts.geometry.push(merged);
            parts.shape_bsdf.push(bsdf);
            parts.shape_light.push(None);
            parts.media.shape_media.push(Default::default());
        }
        Ok(())
    }

    /// Mitsuba's `instance`: `<ref id=…>` to a shapegroup, placed by `to_world`. Adds one scene
    /// shape per group shape (sharing the group's BVH; see `geometry`'s module docs).
    fn instance<'a>(&mut self, n: &'a Node, parts: &mut Parts<'a>) -> Result<()> {
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        n.check_unused(&["to_world"])?;
        let mut group = None;
        for c in &n.children {
            if c.tag != "ref" || group.is_some() {
                return Err(SceneError::new(
                    Some(c.loc.clone()),
                    "Only a shapegroup can be specified in an instance (one <ref id=…/>)",
                ));
            }
            match self.groups.get(c.id.as_deref().unwrap_or_default()) {
                Some(g) => group = Some(g.clone()),
                None => return Err(self.bad_ref(c, "shapegroup")),
            }
        }
        let Some(group) = group else {
            return Err(SceneError::new(
                Some(n.loc.clone()),
                "A reference to a 'shapegroup' must be specified (<ref id=…/>)",
            ));
        };
        let slots = Geometry::instance(&group, to_world)
            .map_err(|e| SceneError::new(Some(n.loc.clone()), e.to_string()))?;
        for (g, &bsdf) in slots.into_iter().zip(&group.bsdfs) {
            parts.geometry.push(g);
            parts.shape_bsdf.push(bsdf);
            parts.shape_light.push(None);
            parts.media.shape_media.push(Default::default());
        }
        Ok(())
    }
}

fn bsdf_err(e: specula_bsdf::BuildError) -> SceneError {
    SceneError::new(None, e.to_string())
}

#[cfg(test)]
mod from_xml_str_tests {
    use super::*;

    /// A scene built with a placeholder material whose shapes skip their uv (a constant
    /// diffuse) gets it back when `set_bsdf` gives them one that reads it (the `gallery`'s
    /// probe, whose woven and textured materials rendered as if at uv (0, 0) until then).
    #[test]
    fn set_bsdf_turns_the_uv_back_on() {
        let text = r#"<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
    <shape type="rectangle"><transform name="to_world"><translate z="-3"/></transform><bsdf type="diffuse"/></shape>
    <shape type="sphere"><point name="center" value="5, 0, 0"/><bsdf type="conductor"/></shape>
</scene>"#;
        let mut s = Scene::from_xml_str(text, "<test>", Path::new("."), &[]).unwrap();
        let flags = |s: &Scene| {
            s.geometry
                .iter()
                .map(|g| match g {
                    Geometry::Sphere(x) => x.uv,
                    Geometry::Mesh(m) => m.uv,
                    _ => unreachable!(),
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(flags(&s), [false, false, false]);
        let constant = specula_bsdf::parse_spec("diffuse reflectance=0.3").unwrap();
        let woven = specula_bsdf::parse_spec(concat!(
            "irawan pattern=polyester repeatU=60 repeatV=30",
            " warp_kd=0.1 warp_ks=0.5 weft_kd=0.1 weft_ks=0.5"
        ))
        .unwrap();
        let (sphere, rect) = (s.shape_bsdf[0] as usize, s.shape_bsdf[1] as usize);
        s.set_bsdf(sphere, constant);
        assert_eq!(flags(&s), [false, false, false]);
        s.set_bsdf(sphere, woven.clone());
        s.set_bsdf(rect, woven);
        assert_eq!(flags(&s), [true, true, false]);
        // and the hit's uv is the sphere's own again
        let ray = Ray {
            o: Vec3::new(0.3, 0.2, 5.0),
            d: -Vec3::Z,
            t_max: f32::INFINITY,
        };
        let hit = s.intersect(&ray).unwrap();
        let uv = s.geometry[hit.shape as usize]
            .surface_uv(&ray, &hit, false)
            .uv;
        assert_ne!(uv, glam::Vec2::ZERO);
    }

    #[test]
    fn spheres_skip_the_uv_only_where_nothing_reads_it() {
        let scene = |integrator: &str| {
            let text = format!(
                r#"<scene version="3.0.0">{integrator}
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
    <shape type="sphere"><bsdf type="roughconductor"><string name="material" value="Cu"/></bsdf></shape>
    <shape type="sphere"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></shape>
    <shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance"/></bsdf></bsdf></shape>
    <shape type="sphere"><bsdf type="plastic"/></shape>
    <shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <shape type="sphere"><emitter type="area"><texture type="checkerboard" name="radiance"/></emitter></shape>
    <shape type="rectangle"/>
</scene>"#
            );
            let s = Scene::from_xml_str(&text, "<test>", Path::new("."), &[]).unwrap();
            s.geometry
                .iter()
                .filter_map(|g| match g {
                    Geometry::Sphere(s) => Some(s.uv),
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        // constant diffuse and spectral copper: no; textures, a model not analysed (plastic),
        // a textured emission: yes
        assert_eq!(
            scene(""),
            [false, false, true, true, true, false, true],
            "path integrator"
        );
        // an AOV integrator may output uv: every sphere keeps it
        let aov = r#"<integrator type="aov"><string name="aovs" value="uv:uv"/></integrator>"#;
        assert_eq!(scene(aov), [true; 7]);
    }

    #[test]
    fn scene_from_text_and_added_lights() {
        let text = r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="conductor"/></shape>
</scene>"#;
        let mut s = Scene::from_xml_str(text, "<test>", Path::new("."), &[]).unwrap();
        assert_eq!((s.film.width, s.film.height), (8, 6));
        assert_eq!(s.bsdfs.len(), 1);
        assert!(s.lights.is_empty() && s.infinite_lights.is_empty());
        s.add_light(Emitter::point(Vec3::ONE, Rgb::splat(1.0)));
        s.add_light(Emitter::constant(Rgb::splat(0.5)));
        assert_eq!(s.lights.len(), 2);
        assert_eq!(s.infinite_lights, vec![1]);
        // only environment maps too large for the cache are prefetched along new rays
        assert!(s.prefetched_maps.is_empty());
        let map = |w: usize, h: usize| {
            let img = crate::image_io::Image {
                width: w,
                height: h,
                channels: 3,
                data: vec![1.0; w * h * 3],
            };
            let e = crate::emitters::Envmap::new(&img, false, 1.0, &glam::Mat4::IDENTITY);
            Emitter::Envmap(Box::new(e.unwrap()))
        };
        s.add_light(map(16, 8));
        assert!(s.prefetched_maps.is_empty());
        s.add_light(map(256, 128));
        assert_eq!(s.infinite_lights, vec![1, 2, 3]);
        assert_eq!(s.prefetched_maps, vec![3]);
        let e = Scene::from_xml_str(
            "<scene version=\"3.0.0\">\n<shape type=\"cone\"/></scene>",
            "<test>",
            Path::new("."),
            &[],
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("<test>:2:"), "{e}");
    }

    #[test]
    fn area_emitters_with_textured_radiance() {
        let scene = |emitter: &str| {
            let text = format!(
                r#"<scene version="3.0.0">
    <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>
    <texture type="checkerboard" id="tex"><rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/></texture>
    <shape type="rectangle">{emitter}</shape>
    <shape type="sphere"><point name="center" value="0, 0, 5"/>{emitter}</shape>
</scene>"#
            );
            Scene::from_xml_str(&text, "<test>", Path::new("."), &[])
        };
        let nested = r#"<emitter type="area"><texture type="checkerboard" name="radiance"><rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/></texture></emitter>"#;
        let by_ref = r#"<emitter type="area"><ref name="radiance" id="tex"/></emitter>"#;
        for e in [nested, by_ref] {
            let s = scene(e).unwrap();
            for (i, light) in s.lights.iter().enumerate() {
                let Light::Area { shape, radiance } = light else {
                    panic!()
                };
                assert_eq!(*shape as usize, i);
                assert!(matches!(radiance, AreaRadiance::Texture(_)));
                let g = &s.geometry[i];
                // the uv of a light sample is the uv a ray finds at the same point
                let mut rng = specula_bsdf::rng::Pcg32::new(5, 7);
                let x = Vec3::new(0.3, -0.2, 2.5);
                for _ in 0..200 {
                    let ps = g.sample_position(rng.next_vec2());
                    let d = (ps.p - x).normalize();
                    let ray = Ray {
                        o: x,
                        d,
                        t_max: f32::INFINITY,
                    };
                    let Some(hit) = s.intersect(&ray) else {
                        continue;
                    };
                    if hit.shape as usize != i || (ray.at(hit.t) - ps.p).length() > 1e-4 {
                        continue; // the sample is hidden behind another part of the shape
                    }
                    let si = g.surface(&ray, &hit);
                    let le = radiance.eval(si.uv, si.p);
                    assert_eq!(radiance.eval(ps.uv, ps.p), le, "{:?} vs {:?}", ps.uv, si.uv);
                    if matches!(g, Geometry::Sphere(_)) {
                        assert_eq!(radiance.eval_along(g, x, d, hit.t), le);
                    }
                    assert!(le == Rgb::new(1.0, 0.0, 0.0) || le == Rgb::new(0.0, 0.0, 1.0));
                }
            }
        }
        let s =
            scene(r#"<emitter type="area"><rgb name="radiance" value="2"/></emitter>"#).unwrap();
        assert!(
            matches!(&s.lights[0], Light::Area { radiance: AreaRadiance::Rgb(c), .. } if *c == Rgb::splat(2.0))
        );
        for (e, want) in [
            (
                r#"<emitter type="area"><texture type="checkerboard" name="irradiance"/></emitter>"#,
                "'radiance'",
            ),
            (
                r#"<emitter type="area"><rgb name="radiance" value="1"/><ref name="radiance" id="tex"/></emitter>"#,
                "duplicate parameter",
            ),
            (
                r#"<emitter type="area"><texture type="checkerboard"/></emitter>"#,
                "needs a 'name'",
            ),
            (
                r#"<emitter type="area"><ref name="radiance" id="nope"/></emitter>"#,
                "nope",
            ),
            (
                r#"<emitter type="area"><bsdf type="diffuse"/></emitter>"#,
                "cannot be nested",
            ),
            (
                r#"<emitter type="area"><float name="scale" value="2"/></emitter>"#,
                "scale",
            ),
        ] {
            let err = scene(e)
                .err()
                .unwrap_or_else(|| panic!("accepted: {e}"))
                .to_string();
            assert!(err.contains(want) && err.contains("<test>:"), "{e}: {err}");
        }
    }

    /// The BSDFs are built after the walk over the document (see [`Materials`]), yet the error
    /// reported is the first in document order, as when each is built where it is met.
    #[test]
    fn errors_in_document_order_with_bsdfs_built_after_the_walk() {
        let err = |body: &str| {
            let text = format!(
                "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>"
            );
            match Scene::from_xml_str(&text, "t", Path::new("."), &[]) {
                Ok(_) => panic!("loaded: {body}"),
                Err(e) => e.to_string(),
            }
        };
        let missing = r#"<bsdf type="diffuse" id="m"><texture type="bitmap" name="reflectance"><string name="filename" value="no/such/image.png"/></texture></bsdf>"#;
        let attr = r#"<bsdf type="diffuse" id="a"><texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture></bsdf>"#;
        let cases = [
            // a failing BSDF, then errors the walk meets after it: the BSDF's
            (format!("{missing}\n<shape type=\"cone\"/>"), "t:3:", "cannot open image"),
            (format!("{missing}\n<shape type=\"sphere\"><ref id=\"nothing\"/></shape>"), "t:3:", "cannot open image"),
            (format!("<shape type=\"sphere\">{missing}<emitter type=\"point\"/></shape>"), "t:3:", "cannot open image"),
            (format!("{missing}\n<emitter type=\"nothing\"/>"), "t:3:", "cannot open image"),
            // the walk's error before the BSDF: the walk's
            (format!("<shape type=\"cone\"/>\n{missing}"), "t:3:", "shape 'cone' is not supported"),
            (format!("<shape type=\"sphere\"><emitter type=\"point\"/>{missing}</shape>"), "t:3:", "only 'area' emitters"),
            // a reference to no texture (built where it is met)
            (
                "<bsdf type=\"diffuse\"><ref name=\"reflectance\" id=\"tex\"/></bsdf>\n<shape type=\"cone\"/>".to_string(),
                "t:3:",
                "reference to undefined id 'tex'",
            ),
            // a shape's mesh attributes are checked where the shape is, before what follows
            (format!("{attr}\n<shape type=\"sphere\"><ref id=\"a\"/></shape>\n<shape type=\"cone\"/>"), "t:3:", "is not a mesh"),
            (format!("{attr}\n<shape type=\"cone\"/>\n<shape type=\"sphere\"><ref id=\"a\"/></shape>"), "t:4:", "shape 'cone' is not supported"),
            // after the walk: the BSDFs' errors before the scene's own
            (missing.to_string(), "t:3:", "cannot open image"),
        ];
        for (body, at, want) in cases {
            let e = err(&body);
            assert!(
                e.starts_with(at) && e.contains(want),
                "{body}\n  gave {e}\n  want {at} … {want}"
            );
        }
        // the same without a sensor: the BSDF's error, then the scene's
        let text = format!("<scene version=\"3.0.0\">\n{missing}\n</scene>");
        let e = Scene::from_xml_str(&text, "t", Path::new("."), &[])
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.starts_with("t:2:") && e.contains("cannot open image"),
            "{e}"
        );
    }
}
