//! Integrators, as Mitsuba 3 names them:
//!
//! - `path` ([`PathSettings`]): unidirectional path tracing with next-event estimation and
//!   multiple importance sampling (power heuristic), following the structure and depth
//!   semantics of Mitsuba 3's `path` integrator: `max_depth` (−1) counts path segments (1 =
//!   only directly visible emitters, 2 = direct lighting, −1 = unbounded), Russian roulette
//!   starts at `rr_depth` (5), `hide_emitters` (false) hides directly visible emitters.
//! - `direct` ([`DirectSettings`]): direct illumination only, with `emitter_samples` emitter
//!   samples and `bsdf_samples` BSDF samples per shading point (both default to
//!   `shading_samples`, 1), combined by the power heuristic weighted by the two sample counts
//!   as in Mitsuba's `direct`; `hide_emitters` (false). Deviation: a delta light's
//!   emitter samples are averaged (Mitsuba adds each with weight 1 whatever `emitter_samples`).
//! - `depth`: the distance along the camera ray to the first hit (0 where nothing is hit), in
//!   all three channels; `hide_emitters` is accepted and has no effect.
//! - `aov` ([`AovSettings`]): arbitrary output variables of the first hit, listed in `aovs`
//!   ("name:type, …"; every type of Mitsuba 3.9: `albedo`, `depth`, `position`, `uv`,
//!   `geo_normal`, `sh_normal`, `dp_du`, `dp_dv`, `duv_dx`, `duv_dy`, `prim_index`,
//!   `shape_index`) written as extra channels named as Mitsuba names them (`name.R/G/B` for
//!   `albedo`; `name.T`; `name.X/Y/Z` for positions, normals and ∂p/∂u, ∂p/∂v; `name.U/V` for
//!   uv and its screen-space partials; `name.I`), and nested integrators, each written as
//!   `name.R/G/B/A`; the image (R, G, B) is the first nested integrator's (black without one).
//!   Misses give 0 (Mitsuba's `duv_dx`/`duv_dy` are NaN there: a deviation). `shape_index`
//!   counts shapes from 1 in the order the scene declares them, as Mitsuba's scalar variants
//!   number spheres, disks and cylinders; Mitsuba numbers meshes, rectangles and cubes after
//!   those, in an order of its own, which Specula does not reproduce. `albedo` is the material's
//!   [`specula_bsdf::Bsdf::diffuse_reflectance`] (Mitsuba's `eval_diffuse_reflectance`);
//!   `dp_du`/`dp_dv` are the unnormalised world-space derivatives of the shape's uv
//!   parameterisation (Mitsuba's `si.dp_du`/`si.dp_dv`); `duv_dx`/`duv_dy` are Mitsuba's
//!   `si.compute_uv_partials` of the camera ray's differentials (the rays through the film
//!   position one pixel to the right and one pixel down, scaled by 1/√spp as Mitsuba's
//!   `scale_differential`; see [`RayDifferentials`]), 0 when the render supplies none.
//!
//! Every integrator draws its random numbers from a [`Sampler`] in an order that depends only
//! on the path's structure (the same dimensions at the same bounce, whatever the material), so
//! that stratified samplers stay stratified dimension by dimension.
//!
//! **Files**: `path.rs`, `direct.rs` and `aov.rs` hold those integrators' loops; this file the
//! `<integrator>` parameters, light sampling and the emission lookups they share; `volpath`
//! (participating media) is [`crate::volpath`]; `tests.rs` the tests.

use crate::core::{Hit, Ray, Result, SceneError, SurfaceGeometry};
use crate::geometry::Geometry;
use crate::sampler::Sampler;
pub use crate::scene::PathSettings;
use crate::scene::{Light, Scene};
use crate::xml::Node;
use glam::{Vec2, Vec3};
use specula_bsdf::spectral::dispersion::collapse_dead_channels;
use specula_bsdf::{BsdfContext, BsdfModel, Rgb, Wavelengths};

use crate::accel::{offset_ray_origin, SHADOW_EPSILON};

mod aov;
mod direct;
mod path;
#[cfg(test)]
mod tests;

/// Per-thread counters.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    pub rays: u64,
    pub samples: u64,
    /// Samples whose estimate was NaN or infinite and was discarded.
    pub invalid: u64,
}

impl Counters {
    pub fn add(&mut self, o: &Counters) {
        self.rays += o.rays;
        self.samples += o.samples;
        self.invalid += o.invalid;
    }
}

#[inline]
fn mis(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// The cone of directions a sphere subtends from an outside point: (unit axis, distance to the
/// centre, 1 − cosθmax). `None` from inside (or on) the sphere, or for inward-facing spheres,
/// where uniform area sampling is used instead. In f32 as Mitsuba's `Sphere::sample_direction`
/// (1 − cosθmax is formed without cancellation, so tiny or distant spheres keep a finite,
/// accurate pdf).
#[inline]
fn sphere_cone(g: &Geometry, x: Vec3) -> Option<(Vec3, f32, f32)> {
    let Geometry::Sphere(sph) = g else {
        return None;
    };
    if sph.flip_normals {
        return None;
    }
    let to_c = sph.center - x;
    let d2 = to_c.length_squared();
    let r2 = sph.radius * sph.radius;
    if d2 <= r2 * (1.0 + 1e-6) || !d2.is_finite() {
        return None;
    }
    let dist = d2.sqrt();
    let sin2 = r2 / d2;
    // 1 − cos without cancellation for small spheres
    let one_minus_cos = sin2 / (1.0 + (1.0 - sin2).sqrt());
    Some((to_c / dist, dist, one_minus_cos))
}

/// A light sample as seen from a shading point.
pub(crate) struct LightSample {
    pub(crate) wi: Vec3,
    pub(crate) dist: f32,
    /// radiance / (solid-angle pdf · selection probability)
    pub(crate) weight: Rgb,
    /// solid-angle pdf including the light selection probability
    pub(crate) pdf: f32,
    pub(crate) is_delta: bool,
    /// Index of the sampled light in `Scene::lights`.
    pub(crate) light: u32,
}

impl Scene {
    #[inline]
    pub(crate) fn light_select_pdf(&self) -> f32 {
        1.0 / self.light_count_f32()
    }

    /// The number of lights as f32 (through u32, [`crate::core::to_f32`]).
    #[inline]
    fn light_count_f32(&self) -> f32 {
        crate::core::to_f32(self.lights.len())
    }

    /// Solid-angle pdf that next-event estimation samples a point at `p_light` (normal `n_light`)
    /// on shape `shape` from `x`, including the light selection probability.
    #[inline]
    pub(crate) fn area_light_pdf(&self, shape: u32, x: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
        let g = &self.geometry[shape as usize];
        if let Some((_, _, omc)) = sphere_cone(g, x) {
            return 1.0 / (2.0 * std::f32::consts::PI * omc) * self.light_select_pdf();
        }
        let d = p_light - x;
        let dist2 = d.length_squared();
        let cos_l = n_light.dot(d).abs() / dist2.sqrt();
        if cos_l <= 0.0 {
            return 0.0;
        }
        g.pdf_position() * dist2 / cos_l * self.light_select_pdf()
    }

    /// Samples a light, then a direction towards it, from one 2D sample: `u.x` picks the
    /// light and is rescaled to \[0, 1) for the direction (Mitsuba's sample reuse, which keeps
    /// the 2D sample stratified over each light).
    pub(crate) fn sample_light(&self, x: Vec3, mut u: Vec2) -> Option<LightSample> {
        let n = self.lights.len();
        if n == 0 {
            return None;
        }
        // through u32, which x86-64 converts in one instruction each way (usize takes a
        // sequence); the same values for any light count below 2²⁴
        let nf = self.light_count_f32();
        let idx = crate::core::to_index(u.x * nf).min(n - 1);
        u.x = (u.x * nf - crate::core::to_f32(idx)).clamp(0.0, crate::sampler::ONE_MINUS_EPS);
        let sel = self.light_select_pdf();
        match &self.lights[idx] {
            Light::Area { shape, radiance } => {
                let g: &Geometry = &self.geometry[*shape as usize];
                if let (Some((axis, dist_c, omc)), Geometry::Sphere(sph)) = (sphere_cone(g, x), g) {
                    // uniform over the cone of directions the sphere subtends (as Mitsuba)
                    // with a = 1 − cosθ: sin²θ = a(2 − a), free of cancellation
                    let a = u.x * omc;
                    let cos_t = 1.0 - a;
                    let sin2_t = (a * (2.0 - a)).max(0.0);
                    let sin_t = sin2_t.sqrt();
                    let (sin_p, cos_p) = specula_bsdf::math::sincos_2pi(u.y);
                    let f = specula_bsdf::frame::Frame::from_normal(axis);
                    let d =
                        (f.s * (sin_t * cos_p) + f.t * (sin_t * sin_p) + f.n * cos_t).normalize();
                    // nearest intersection with the sphere along d: d leaves the centre's
                    // direction at angle θ, so the squared distance of the chord's midpoint
                    // from the centre is dist²·sin²θ (no cancellation of b² against dist²)
                    let r = sph.radius;
                    let disc = (r * r - dist_c * dist_c * sin2_t).max(0.0);
                    let t = dist_c * cos_t - disc.sqrt();
                    let pdf = 1.0 / (2.0 * std::f32::consts::PI * omc) * sel;
                    if t.is_nan() || t <= 0.0 || !pdf.is_finite() {
                        return None;
                    }
                    let wi = d;
                    return Some(LightSample {
                        wi,
                        dist: t,
                        weight: radiance.eval_along(g, x, wi, t) / pdf,
                        pdf,
                        is_delta: false,
                        light: idx as u32,
                    });
                }
                let ps = g.sample_position(u);
                let d = ps.p - x;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                // emits from the front side only
                let cos_l = -ps.n.dot(wi);
                if cos_l <= 0.0 || ps.pdf <= 0.0 {
                    return None;
                }
                let pdf = ps.pdf * dist2 / cos_l * sel;
                Some(LightSample {
                    wi,
                    dist,
                    weight: radiance.eval(ps.uv, ps.p) / pdf,
                    pdf,
                    is_delta: false,
                    light: idx as u32,
                })
            }
            Light::Other(e) => {
                let ds = e.sample_direction(x, u)?;
                if ds.pdf <= 0.0 {
                    return None;
                }
                let pdf = ds.pdf * sel;
                Some(LightSample {
                    wi: ds.wi,
                    dist: ds.dist,
                    weight: ds.radiance / pdf,
                    pdf,
                    is_delta: ds.is_delta,
                    light: idx as u32,
                })
            }
        }
    }

    /// Radiance carried along `ray` from the camera (one sample of the scene's integrator;
    /// AOV channels are dropped).
    pub fn li<S: Sampler>(&self, ray: Ray, rng: &mut S, counters: &mut Counters) -> Rgb {
        let hit = self.intersect(&ray);
        self.li_from(ray, hit, rng, counters)
    }

    /// [`Scene::li`] with the camera ray's intersection already found (`hit`, as
    /// `intersect(&ray)` returns it).
    pub fn li_from<S: Sampler>(
        &self,
        ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
    ) -> Rgb {
        self.sample(&self.integrator, ray, hit, rng, counters, &mut [])
    }

    /// One sample of `integrator` along the camera ray `ray` (whose intersection is `hit`):
    /// the radiance, and the AOV channels written into `aovs` (as many as
    /// [`Integrator::aov_channels`] names; extra space is left alone).
    pub fn sample<S: Sampler>(
        &self,
        integrator: &Integrator,
        ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        aovs: &mut [f32],
    ) -> Rgb {
        self.sample_differential(integrator, ray, None, hit, rng, counters, aovs)
    }

    /// [`Scene::sample`] with the camera ray's differentials (what the `duv_dx`/`duv_dy` AOVs
    /// read; see [`Integrator::needs_differentials`]).
    #[allow(clippy::too_many_arguments)]
    pub fn sample_differential<S: Sampler>(
        &self,
        integrator: &Integrator,
        ray: Ray,
        differentials: Option<&RayDifferentials>,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        aovs: &mut [f32],
    ) -> Rgb {
        match integrator {
            Integrator::Path(p) => self.li_path(p, ray, hit, rng, counters, None),
            Integrator::Volpath(p) => self.li_volpath(p, ray, hit, rng, counters, None),
            Integrator::Direct(d) => self.li_direct(d, ray, hit, rng, counters, None),
            Integrator::Depth => {
                counters.rays += 1;
                Rgb::splat(hit.map_or(0.0, |h| h.t))
            }
            Integrator::Aov(a) => {
                self.li_aov(a, ray, differentials, hit, rng, counters, aovs, None)
            }
        }
    }
}

/// A scene's `<integrator>`.
#[derive(Clone, Debug, PartialEq)]
pub enum Integrator {
    Path(PathSettings),
    /// Mitsuba's `volpath` (participating media; see [`crate::volpath`]).
    Volpath(PathSettings),
    Direct(DirectSettings),
    Depth,
    Aov(AovSettings),
}

impl Default for Integrator {
    /// What a scene without `<integrator>` uses: Mitsuba's default `path`.
    fn default() -> Self {
        Integrator::Path(PathSettings {
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
        })
    }
}

/// Settings of Mitsuba's `direct` integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectSettings {
    pub emitter_samples: u32,
    pub bsdf_samples: u32,
    pub hide_emitters: bool,
}

/// What an AOV records (Mitsuba 3's AOV types).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovType {
    Albedo,
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
    DpDu,
    DpDv,
    DuvDx,
    DuvDy,
    PrimIndex,
    ShapeIndex,
}

/// The camera ray's differentials (Mitsuba's `RayDifferential3f` after `scale_differential`):
/// the rays for a step of one pixel in x and in y, already scaled by the sampler's
/// 1/√(samples per pixel). Only their lines matter (`duv_dx`/`duv_dy` intersect them with the
/// tangent plane at the hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayDifferentials {
    pub o_x: Vec3,
    pub d_x: Vec3,
    pub o_y: Vec3,
    pub d_y: Vec3,
}

impl RayDifferentials {
    /// Mitsuba's `RayDifferential3f::scale_differential`: moves the differential rays towards
    /// the primary ray `(o, d)` by `amount` (origins and directions alike).
    pub fn scaled(self, o: Vec3, d: Vec3, amount: f32) -> Self {
        RayDifferentials {
            o_x: o + (self.o_x - o) * amount,
            d_x: d + (self.d_x - d) * amount,
            o_y: o + (self.o_y - o) * amount,
            d_y: d + (self.d_y - d) * amount,
        }
    }

    /// Mitsuba's `SurfaceInteraction3f::compute_uv_partials`: where the differential rays meet
    /// the tangent plane at `si`, expressed in the uv parameterisation by least squares
    /// (∂uv/∂x, ∂uv/∂y); zero when `dp_du`/`dp_dv` are degenerate.
    pub fn uv_partials(&self, si: &SurfaceGeometry) -> (Vec2, Vec2) {
        let n = si.n_geo;
        let plane = n.dot(si.p);
        let t_x = (plane - n.dot(self.o_x)) / n.dot(self.d_x);
        let t_y = (plane - n.dot(self.o_y)) / n.dot(self.d_y);
        let dp_dx = self.o_x + self.d_x * t_x - si.p;
        let dp_dy = self.o_y + self.d_y * t_y - si.p;
        let (du, dv) = (si.dp_du, si.dp_dv);
        let (a00, a01, a11) = (du.dot(du), du.dot(dv), dv.dot(dv));
        let inv_det = 1.0 / (a00 * a11 - a01 * a01);
        let inv_det = if inv_det.is_finite() { inv_det } else { 0.0 };
        let solve = |dp: Vec3| {
            let (b0, b1) = (du.dot(dp), dv.dot(dp));
            Vec2::new(a11 * b0 - a01 * b1, a00 * b1 - a01 * b0) * inv_det
        };
        (solve(dp_dx), solve(dp_dy))
    }
}

impl AovType {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "albedo" => AovType::Albedo,
            "depth" => AovType::Depth,
            "position" => AovType::Position,
            "uv" => AovType::Uv,
            "geo_normal" => AovType::GeoNormal,
            "sh_normal" => AovType::ShNormal,
            "dp_du" => AovType::DpDu,
            "dp_dv" => AovType::DpDv,
            "duv_dx" => AovType::DuvDx,
            "duv_dy" => AovType::DuvDy,
            "prim_index" => AovType::PrimIndex,
            "shape_index" => AovType::ShapeIndex,
            _ => return None,
        })
    }
    /// Channel suffixes, as Mitsuba names them.
    fn suffixes(self) -> &'static [&'static str] {
        match self {
            AovType::Albedo => &["R", "G", "B"],
            AovType::Depth => &["T"],
            AovType::Position
            | AovType::GeoNormal
            | AovType::ShNormal
            | AovType::DpDu
            | AovType::DpDv => &["X", "Y", "Z"],
            AovType::Uv | AovType::DuvDx | AovType::DuvDy => &["U", "V"],
            AovType::PrimIndex | AovType::ShapeIndex => &["I"],
        }
    }
}

/// Settings of Mitsuba's `aov` integrator.
#[derive(Clone, Debug, PartialEq)]
pub struct AovSettings {
    /// (name, type) in the order of the `aovs` string.
    pub aovs: Vec<(String, AovType)>,
    /// Nested integrators with their `name`s.
    pub integrators: Vec<(String, Integrator)>,
}

impl Integrator {
    /// Names of the channels this integrator writes besides R, G, B, in order (Mitsuba's
    /// order: the nested integrators' R, G, B, A first, then the AOVs).
    pub fn aov_channels(&self) -> Vec<String> {
        let Integrator::Aov(a) = self else {
            return vec![];
        };
        let mut out = vec![];
        for (name, _) in &a.integrators {
            for c in ["R", "G", "B", "A"] {
                out.push(format!("{name}.{c}"));
            }
        }
        for (name, t) in &a.aovs {
            for c in t.suffixes() {
                out.push(format!("{name}.{c}"));
            }
        }
        out
    }

    /// Whether samples need the camera ray's differentials (an `aov` integrator with a
    /// `duv_dx` or `duv_dy` output).
    pub fn needs_differentials(&self) -> bool {
        matches!(self, Integrator::Aov(a)
            if a.aovs.iter().any(|(_, t)| matches!(t, AovType::DuvDx | AovType::DuvDy)))
    }

    /// Builds an `<integrator>` node (and its nested integrators).
    pub fn from_node(n: &Node) -> Result<Integrator> {
        let hide = |n: &Node| n.bool("hide_emitters", false);
        let i = match n.plugin_type.as_str() {
            "path" => {
                let s = PathSettings {
                    max_depth: n.int("max_depth", -1)? as i32,
                    rr_depth: n.int("rr_depth", 5)? as i32,
                    hide_emitters: hide(n)?,
                };
                if s.max_depth < -1 || s.rr_depth <= 0 {
                    return Err(SceneError::new(
                        Some(n.loc.clone()),
                        "max_depth must be ≥ −1 and rr_depth ≥ 1",
                    ));
                }
                n.check_unused(&["max_depth", "rr_depth", "hide_emitters"])?;
                Integrator::Path(s)
            }
            "direct" => {
                let count = |name: &str, default: i64| -> Result<u32> {
                    let v = n.int(name, default)?;
                    if !(0..=1 << 16).contains(&v) {
                        return Err(SceneError::new(
                            Some(n.loc.clone()),
                            format!("{name} must lie in [0, 65536], got {v}"),
                        ));
                    }
                    Ok(v as u32)
                };
                if n.has("shading_samples") && (n.has("emitter_samples") || n.has("bsdf_samples")) {
                    return Err(SceneError::new(
                        Some(n.loc.clone()),
                        "give either shading_samples or emitter_samples/bsdf_samples, not both",
                    ));
                }
                let shading = count("shading_samples", 1)?;
                let s = DirectSettings {
                    emitter_samples: count("emitter_samples", shading as i64)?,
                    bsdf_samples: count("bsdf_samples", shading as i64)?,
                    hide_emitters: hide(n)?,
                };
                if s.emitter_samples + s.bsdf_samples == 0 {
                    return Err(SceneError::new(
                        Some(n.loc.clone()),
                        "the direct integrator needs at least one emitter or BSDF sample",
                    ));
                }
                n.check_unused(&[
                    "shading_samples",
                    "emitter_samples",
                    "bsdf_samples",
                    "hide_emitters",
                ])?;
                Integrator::Direct(s)
            }
            "depth" => {
                hide(n)?;
                n.check_unused(&["hide_emitters"])?;
                Integrator::Depth
            }
            "aov" => {
                let list = n.string("aovs", "")?;
                let mut aovs = vec![];
                for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
                    let Some((name, ty)) = item.split_once(':') else {
                        return Err(SceneError::new(
                            Some(n.loc.clone()),
                            format!("aovs: '{item}' is not of the form name:type"),
                        ));
                    };
                    let (name, ty) = (name.trim(), ty.trim());
                    let t = AovType::parse(ty).ok_or_else(|| {
                        let known = "albedo, depth, position, uv, geo_normal, sh_normal, \
                                     dp_du, dp_dv, duv_dx, duv_dy, prim_index, shape_index";
                        SceneError::new(
                            Some(n.loc.clone()),
                            format!("invalid AOV type '{ty}' (supported: {known})"),
                        )
                    })?;
                    if name.is_empty() {
                        return Err(SceneError::new(
                            Some(n.loc.clone()),
                            format!("aovs: '{item}' has an empty name"),
                        ));
                    }
                    aovs.push((name.to_string(), t));
                }
                let mut integrators = vec![];
                for c in &n.children {
                    if c.tag != "integrator" {
                        return Err(SceneError::new(
                            Some(c.loc.clone()),
                            format!("<{}> cannot be nested in an integrator", c.tag),
                        ));
                    }
                    let inner = Integrator::from_node(c)?;
                    if matches!(inner, Integrator::Aov(_)) {
                        return Err(SceneError::new(
                            Some(c.loc.clone()),
                            "an aov integrator cannot be nested in another",
                        ));
                    }
                    let name = c
                        .name
                        .clone()
                        .unwrap_or_else(|| format!("integrator_{}", integrators.len()));
                    integrators.push((name, inner));
                }
                n.check_unused(&["aovs"])?;
                Integrator::Aov(AovSettings { aovs, integrators })
            }
            other => {
                return Err(SceneError::new(
                    Some(n.loc.clone()),
                    format!(
                    "integrator '{other}' is not supported (supported: path, direct, depth, aov)"
                ),
                ))
            }
        };
        if !matches!(i, Integrator::Aov(_)) {
            if let Some(c) = n.children.first() {
                return Err(SceneError::new(
                    Some(c.loc.clone()),
                    format!(
                        "<{}> cannot be nested in a '{}' integrator",
                        c.tag, n.plugin_type
                    ),
                ));
            }
        }
        Ok(i)
    }
}

impl Scene {
    /// Radiance of infinitely distant lights seen along `d`, each weighted against BSDF
    /// sampling (`bsdf_pdf`, already scaled) by the power heuristic; `None` weights by 1.
    pub(crate) fn infinite_radiance(
        &self,
        d: Vec3,
        bsdf_pdf: Option<f32>,
        light_frac: f32,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        // the commonest cases, one `constant` or `envmap` light in RGB mode, without the
        // general loop's dispatch (the same operations: the loop's one iteration written out)
        if let ([li], None) = (&self.infinite_lights[..], wl) {
            use crate::emitters::Emitter;
            let (le, pdf) = match (&self.lights[*li as usize], bsdf_pdf) {
                (Light::Other(Emitter::Constant(c)), _) => {
                    (c.radiance, specula_bsdf::warp::UNIFORM_SPHERE_PDF)
                }
                (Light::Other(Emitter::Envmap(e)), Some(_)) => e.eval_pdf(d),
                (Light::Other(Emitter::Envmap(e)), None) => (e.eval(d), 0.0),
                _ => return self.infinite_radiance_all(d, bsdf_pdf, light_frac, wl),
            };
            return self.weighted_infinite(le, pdf, bsdf_pdf, light_frac);
        }
        self.infinite_radiance_all(d, bsdf_pdf, light_frac, wl)
    }

    /// The single infinite light's radiance `le` (light pdf `pdf`) along a ray that escaped,
    /// MIS-weighted against the BSDF sample's pdf (`None`: a Dirac lobe or the camera ray,
    /// weight 1): [`Scene::infinite_radiance`]'s one-light case, and the path loop's for the
    /// environment-map lookup it kept.
    #[inline]
    fn weighted_infinite(&self, le: Rgb, pdf: f32, bsdf_pdf: Option<f32>, light_frac: f32) -> Rgb {
        let out = Rgb::ZERO;
        if le.is_black() {
            return out;
        }
        let w = match bsdf_pdf {
            None => 1.0,
            Some(p) => mis(p, pdf * self.light_select_pdf() * light_frac),
        };
        out + le * w
    }

    /// [`Scene::infinite_radiance`] over every infinite light.
    fn infinite_radiance_all(
        &self,
        d: Vec3,
        bsdf_pdf: Option<f32>,
        light_frac: f32,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        let mut out = Rgb::ZERO;
        for &li in &self.infinite_lights {
            if let Light::Other(e) = &self.lights[li as usize] {
                let (le, pdf) = match bsdf_pdf {
                    Some(_) => e.eval_pdf_direction(d),
                    None => (e.eval_direction(d), 0.0),
                };
                if le.is_black() {
                    continue;
                }
                let le = self.infinite_emission_of(li, e, d, le, wl);
                let w = match bsdf_pdf {
                    None => 1.0,
                    Some(p) => mis(p, pdf * self.light_select_pdf() * light_frac),
                };
                out += le * w;
            }
        }
        out
    }

    /// Radiance an area light on the hit shape emits towards the previous vertex (`wi` local
    /// to the hit's shading frame, pointing back along the ray), or `None` when the shape does
    /// not emit towards it.
    fn area_emission(
        &self,
        shape: usize,
        si: &SurfaceGeometry,
        wi: Vec3,
        wl: Option<&Wavelengths>,
    ) -> Option<Rgb> {
        let li = self.shape_light[shape]?;
        match &self.lights[li as usize] {
            Light::Area { radiance, .. } if wi.z > 0.0 => {
                Some(self.area_emission_at(li, radiance, si.uv, si.p, wl))
            }
            _ => None,
        }
    }
}
