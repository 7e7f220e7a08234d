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
        1.0 / self.lights.len() as f32
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
        let idx = ((u.x * n as f32) as usize).min(n - 1);
        u.x = (u.x * n as f32 - idx as f32).clamp(0.0, crate::sampler::ONE_MINUS_EPS);
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

    /// Mitsuba's `path` integrator. `wl`: the path's wavelengths in spectral mode (the result
    /// is then the radiance at them, see [`crate::spectral`]), `None` in RGB mode.
    pub fn li_path<S: Sampler>(
        &self,
        settings: &PathSettings,
        mut ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        // The wavelengths the rest of the path is shaded at: after a dispersive Dirac refraction
        // keeps one channel, the dead ones take its wavelength (see `collapse_dead_channels`),
        // so later dispersive interfaces do not split the path again. The film keeps `wl`.
        let mut wl_path = wl.copied();
        let ctx = BsdfContext::RADIANCE;
        let mut result = Rgb::ZERO;
        let mut throughput = Rgb::ONE;
        let mut eta = 1.0f32;
        let mut depth: i32 = 0;
        let mut prev_bsdf_pdf = 1.0f32;
        let mut prev_bsdf_delta = true;
        let mut prev_p = ray.o;
        let max_depth = if settings.max_depth < 0 {
            i32::MAX
        } else {
            settings.max_depth
        };
        // the camera ray (traced by the caller); each bounce traces the next at its end
        counters.rays += 1;
        let mut next = hit;
        loop {
            let wl = wl_path.as_ref();
            let hit = next;
            let show_emitters = depth > 0 || !settings.hide_emitters;
            let Some(hit) = hit else {
                // escaped: infinitely distant lights
                if show_emitters {
                    let bsdf_pdf = (!prev_bsdf_delta).then_some(prev_bsdf_pdf);
                    result += throughput * self.infinite_radiance(ray.d, bsdf_pdf, 1.0, wl);
                }
                break;
            };
            let shape = hit.shape as usize;
            let si: SurfaceGeometry = self.geometry[shape].surface(&ray, &hit);
            let wi = si.sh_frame.to_local(-ray.d);

            // emission of an area light hit by the previous bounce
            if let (Some(li), true) = (self.shape_light[shape], show_emitters) {
                if let Light::Area { radiance, .. } = &self.lights[li as usize] {
                    if wi.z > 0.0 {
                        let w = if prev_bsdf_delta {
                            1.0
                        } else {
                            mis(
                                prev_bsdf_pdf,
                                self.area_light_pdf(hit.shape, prev_p, si.p, si.n_geo),
                            )
                        };
                        result +=
                            throughput * self.area_emission_at(li, radiance, si.uv, si.p, wl) * w;
                    }
                }
            }

            if depth + 1 >= max_depth {
                break;
            }
            let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
            let mut sp = si.shading_point(&hit, self.geometry[shape].surface_data());
            sp.wavelengths = wl.copied();
            let flags = bsdf.flags();

            // the random numbers in the order they have always been drawn (light, then
            // BSDF); the light is sampled first and the BSDF sampled before the light sample
            // is evaluated, so that the CPU overlaps the light sampler's table lookups
            // (cache misses on a large environment map) with the BSDF's arithmetic
            let smooth = flags.intersects(specula_bsdf::LobeFlags::SMOOTH);
            let u_light = rng.next_2d();
            let u1 = rng.next_1d();
            let u2 = rng.next_2d();
            let light = if smooth {
                self.sample_light(si.p, u_light)
            } else {
                None
            };
            let sampled = bsdf.sample(&ctx, &sp, wi, u1, u2);

            // next-event estimation
            // (`light` is None for a material without smooth lobes)
            if let Some(ls) = light {
                let wo = si.sh_frame.to_local(ls.wi);
                let (f, bsdf_pdf) = bsdf.eval_pdf(&ctx, &sp, wi, wo);
                if !f.is_black() {
                    let o = offset_ray_origin(si.p, si.n_geo, ls.wi);
                    let t_max = if ls.dist.is_finite() {
                        ls.dist * (1.0 - SHADOW_EPSILON)
                    } else {
                        f32::INFINITY
                    };
                    counters.rays += 1;
                    if !self.occluded(&Ray { o, d: ls.wi, t_max }) {
                        let w = if ls.is_delta {
                            1.0
                        } else {
                            mis(ls.pdf, bsdf_pdf)
                        };
                        result += throughput * f * self.light_weight(&ls, wl) * (wo.z.abs() * w);
                    }
                }
            }

            // BSDF sampling
            let Some(bs) = sampled else {
                break;
            };
            let d = si.sh_frame.to_world(bs.wo).normalize();
            throughput *= bs.weight;
            if let Some(w) = wl_path.as_mut() {
                collapse_dead_channels(w, throughput.0);
            }
            eta *= bs.eta;
            prev_bsdf_pdf = bs.pdf;
            prev_bsdf_delta = bs.lobe.is_delta();
            prev_p = si.p;
            ray = Ray {
                o: offset_ray_origin(si.p, si.n_geo, d),
                d,
                t_max: f32::INFINITY,
            };

            depth += 1;
            let tmax = throughput.max_component();
            if tmax <= 0.0 {
                break;
            }
            if depth >= settings.rr_depth {
                let q = (tmax * eta * eta).min(0.95);
                if rng.next_1d() >= q {
                    break;
                }
                throughput /= q;
            }
            counters.rays += 1;
            self.prefetch_infinite(ray.d);
            next = self.intersect(&ray);
        }
        result
    }

    /// Asks the cache for what evaluating the environment maps along `d` will read, should
    /// the ray about to be traced escape (see [`crate::emitters::Envmap::prefetch`]).
    #[inline]
    fn prefetch_infinite(&self, d: Vec3) {
        for &li in &self.infinite_lights {
            if let Light::Other(crate::emitters::Emitter::Envmap(e)) = &self.lights[li as usize] {
                e.prefetch(d);
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

    /// Mitsuba's `direct` integrator.
    pub fn li_direct<S: Sampler>(
        &self,
        settings: &DirectSettings,
        ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        counters.rays += 1;
        let Some(hit) = hit else {
            return if settings.hide_emitters {
                Rgb::ZERO
            } else {
                self.infinite_radiance(ray.d, None, 1.0, wl)
            };
        };
        let shape = hit.shape as usize;
        let si = self.geometry[shape].surface(&ray, &hit);
        let wi = si.sh_frame.to_local(-ray.d);
        let mut result = Rgb::ZERO;
        if !settings.hide_emitters {
            if let Some(le) = self.area_emission(shape, &si, wi, wl) {
                result += le;
            }
        }
        let (ne, nb) = (settings.emitter_samples, settings.bsdf_samples);
        let total = (ne + nb).max(1) as f32;
        let (frac_lum, frac_bsdf) = (ne as f32 / total, nb as f32 / total);
        let ctx = BsdfContext::RADIANCE;
        let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
        let mut sp = si.shading_point(&hit, self.geometry[shape].surface_data());
        sp.wavelengths = wl.copied();
        let smooth = bsdf.flags().intersects(specula_bsdf::LobeFlags::SMOOTH);

        // emitter sampling
        for _ in 0..ne {
            let u = rng.next_2d();
            if !smooth {
                continue;
            }
            let Some(ls) = self.sample_light(si.p, u) else {
                continue;
            };
            let wo = si.sh_frame.to_local(ls.wi);
            let (f, bsdf_pdf) = bsdf.eval_pdf(&ctx, &sp, wi, wo);
            if f.is_black() {
                continue;
            }
            let o = offset_ray_origin(si.p, si.n_geo, ls.wi);
            let t_max = if ls.dist.is_finite() {
                ls.dist * (1.0 - SHADOW_EPSILON)
            } else {
                f32::INFINITY
            };
            counters.rays += 1;
            if self.occluded(&Ray { o, d: ls.wi, t_max }) {
                continue;
            }
            let w = if ls.is_delta {
                1.0
            } else {
                mis(ls.pdf * frac_lum, bsdf_pdf * frac_bsdf)
            };
            result += f * self.light_weight(&ls, wl) * (wo.z.abs() * w / ne as f32);
        }

        // BSDF sampling
        for _ in 0..nb {
            let u1 = rng.next_1d();
            let u2 = rng.next_2d();
            let Some(bs) = bsdf.sample(&ctx, &sp, wi, u1, u2) else {
                continue;
            };
            if bs.pdf <= 0.0 && !bs.lobe.is_delta() {
                continue;
            }
            let d = si.sh_frame.to_world(bs.wo).normalize();
            let r = Ray {
                o: offset_ray_origin(si.p, si.n_geo, d),
                d,
                t_max: f32::INFINITY,
            };
            counters.rays += 1;
            let delta = bs.lobe.is_delta();
            let bsdf_pdf = if delta {
                None
            } else {
                Some(bs.pdf * frac_bsdf)
            };
            let le = match self.intersect(&r) {
                None => self.infinite_radiance(d, bsdf_pdf, frac_lum, wl),
                Some(h2) => {
                    let s2 = h2.shape as usize;
                    let si2 = self.geometry[s2].surface(&r, &h2);
                    let wi2 = si2.sh_frame.to_local(-d);
                    match self.area_emission(s2, &si2, wi2, wl) {
                        None => Rgb::ZERO,
                        Some(le) => {
                            let w = match bsdf_pdf {
                                None => 1.0,
                                Some(p) => mis(
                                    p,
                                    self.area_light_pdf(h2.shape, si.p, si2.p, si2.n_geo)
                                        * frac_lum,
                                ),
                            };
                            le * w
                        }
                    }
                }
            };
            if !le.is_black() {
                result += bs.weight * le * (1.0 / nb as f32);
            }
        }
        result
    }

    /// Mitsuba's `aov` integrator.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn li_aov<S: Sampler>(
        &self,
        a: &AovSettings,
        ray: Ray,
        differentials: Option<&RayDifferentials>,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        out: &mut [f32],
        spectral: Option<(&Wavelengths, &[f32; 3])>,
    ) -> Rgb {
        let mut k = 0;
        let mut image = Rgb::ZERO;
        for (i, (_, inner)) in a.integrators.iter().enumerate() {
            // in spectral mode, at the sample's wavelengths and developed
            let l = match spectral {
                None => self.sample(inner, ray, hit, rng, counters, &mut []),
                Some(w) => {
                    self.sample_at_wavelengths(inner, ray, None, hit, rng, counters, w, &mut [])
                }
            };
            let hide = match inner {
                Integrator::Path(p) => p.hide_emitters,
                Integrator::Direct(d) => d.hide_emitters,
                _ => true,
            };
            let valid = hit.is_some() || (!hide && !self.infinite_lights.is_empty());
            if i == 0 {
                image = l;
            }
            if out.len() >= k + 4 {
                out[k..k + 3].copy_from_slice(&l.0);
                out[k + 3] = valid as u32 as f32;
            }
            k += 4;
        }
        if a.integrators.is_empty() {
            counters.rays += 1;
        }
        let si = hit.map(|h| (h, self.geometry[h.shape as usize].surface(&ray, &h)));
        // ∂uv/∂x and ∂uv/∂y, computed once for both AOVs
        let mut uv_partials = None;
        let mut partials = |s: &SurfaceGeometry| {
            *uv_partials.get_or_insert_with(|| {
                differentials.map_or((Vec2::ZERO, Vec2::ZERO), |d| d.uv_partials(s))
            })
        };
        for (_, t) in &a.aovs {
            let v: [f32; 3] = match (&si, t) {
                (None, _) => [0.0; 3],
                (Some((h, s)), AovType::Albedo) => {
                    let shape = h.shape as usize;
                    let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
                    let mut sp = s.shading_point(h, self.geometry[shape].surface_data());
                    // spectral mode: the reflectance at the wavelengths, developed (Mitsuba)
                    sp.wavelengths = spectral.map(|(w, _)| *w);
                    let r = bsdf.diffuse_reflectance(&sp, s.sh_frame.to_local(-ray.d));
                    match spectral {
                        None => r.0,
                        Some((w, weight)) => specula_bsdf::spectral::cie::develop(r, w, weight).0,
                    }
                }
                (Some((_, s)), AovType::DpDu) => s.dp_du.to_array(),
                (Some((_, s)), AovType::DpDv) => s.dp_dv.to_array(),
                (Some((_, s)), AovType::DuvDx) => {
                    let d = partials(s).0;
                    [d.x, d.y, 0.0]
                }
                (Some((_, s)), AovType::DuvDy) => {
                    let d = partials(s).1;
                    [d.x, d.y, 0.0]
                }
                (Some((h, _)), AovType::Depth) => [h.t, 0.0, 0.0],
                (Some((_, s)), AovType::Position) => s.p.to_array(),
                (Some((_, s)), AovType::Uv) => [s.uv.x, s.uv.y, 0.0],
                (Some((_, s)), AovType::GeoNormal) => s.n_geo.to_array(),
                (Some((_, s)), AovType::ShNormal) => s.sh_frame.n.to_array(),
                (Some((h, _)), AovType::PrimIndex) => [h.prim as f32, 0.0, 0.0],
                (Some((h, _)), AovType::ShapeIndex) => [(h.shape + 1) as f32, 0.0, 0.0],
            };
            let n = t.suffixes().len();
            if out.len() >= k + n {
                out[k..k + n].copy_from_slice(&v[..n]);
            }
            k += n;
        }
        image
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn scene(integrator: &str, extra: &str) -> Result<Scene> {
        let text = format!(
            r#"<scene version="3.0.0">
    {integrator}
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="9"/><integer name="height" value="3"/><rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><float name="radius" value="0.5"/><point name="center" x="-1.3" y="0" z="0"/></shape>
    <shape type="sphere"><float name="radius" value="0.5"/></shape>
    {extra}
</scene>"#
        );
        Scene::from_xml_str(&text, "<test>", Path::new("."), &[])
    }

    /// Sphere lights sampled by their cone (in f32): every sample lies on the sphere's near
    /// side, inside the cone, with the pdf `area_light_pdf` gives, for a large close sphere
    /// and a tiny distant one (where 1 − cosθmax ≈ 5e-11).
    #[test]
    fn sphere_light_cone_samples_lie_on_the_sphere() {
        for (r, z) in [(1.0f32, 2.5f32), (1e-3, -100.0)] {
            let light = format!(
                r#"<shape type="sphere"><float name="radius" value="{r}"/><point name="center" x="0.3" y="0.1" z="{z}"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#
            );
            let s = scene(r#"<integrator type="path"/>"#, &light).unwrap();
            let Light::Area { shape, .. } = &s.lights[0] else {
                panic!("not an area light")
            };
            let shape = *shape;
            let c = Vec3::new(0.3, 0.1, z);
            let x = Vec3::new(0.0, 0.0, 4.0);
            let mut n = 0;
            for i in 0..64 {
                for j in 0..16 {
                    let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 16.0);
                    let Some(ls) = s.sample_light(x, u) else {
                        continue;
                    };
                    n += 1;
                    let p = x + ls.wi * ls.dist;
                    let err = ((p - c).length() - r).abs();
                    assert!(err <= 1e-5 * (x - c).length(), "{r} {z}: off by {err}");
                    // the near side: the surface faces x
                    assert!((p - c).dot(x - p) >= -1e-4 * r * (x - c).length());
                    let pdf = s.area_light_pdf(shape, x, p, (p - c) / r);
                    assert!((ls.pdf / pdf - 1.0).abs() < 1e-5, "{} vs {pdf}", ls.pdf);
                    assert!((ls.wi.length() - 1.0).abs() < 1e-6);
                }
            }
            assert_eq!(n, 64 * 16, "{r} {z}: samples refused");
        }
    }

    #[test]
    fn parses_mitsuba_parameters_and_refuses_bad_ones() {
        let s = scene(
            r#"<integrator type="direct"><integer name="shading_samples" value="3"/></integrator>"#,
            "",
        )
        .unwrap();
        assert_eq!(
            s.integrator,
            Integrator::Direct(DirectSettings {
                emitter_samples: 3,
                bsdf_samples: 3,
                hide_emitters: false
            })
        );
        let s = scene(r#"<integrator type="aov"><string name="aovs" value="nn:sh_normal, position:position, depth.y:depth"/><integrator type="path" name="image"/></integrator>"#, "").unwrap();
        assert_eq!(
            s.integrator.aov_channels(),
            [
                "image.R",
                "image.G",
                "image.B",
                "image.A",
                "nn.X",
                "nn.Y",
                "nn.Z",
                "position.X",
                "position.Y",
                "position.Z",
                "depth.y.T"
            ]
        );
        // every AOV type of Mitsuba 3.9, with Mitsuba's channel suffixes
        let s = scene(r#"<integrator type="aov"><string name="aovs" value="a:albedo,b:dp_du,c:dp_dv,d:duv_dx,e:duv_dy"/></integrator>"#, "").unwrap();
        assert_eq!(
            s.integrator.aov_channels().join(" "),
            "a.R a.G a.B b.X b.Y b.Z c.X c.Y c.Z d.U d.V e.U e.V"
        );
        assert!(s.integrator.needs_differentials());
        assert!(!Integrator::default().needs_differentials());
        for (bad, msg) in [
            (
                r#"<integrator type="direct"><integer name="emitter_samples" value="-1"/></integrator>"#,
                "emitter_samples",
            ),
            (
                r#"<integrator type="direct"><integer name="max_depth" value="2"/></integrator>"#,
                "max_depth",
            ),
            (
                r#"<integrator type="direct"><integer name="shading_samples" value="2"/><integer name="bsdf_samples" value="0"/></integrator>"#,
                "not both",
            ),
            (
                r#"<integrator type="direct"><integer name="emitter_samples" value="0"/><integer name="bsdf_samples" value="0"/></integrator>"#,
                "at least one",
            ),
            (
                r#"<integrator type="aov"><string name="aovs" value="a:nonsense"/></integrator>"#,
                "invalid AOV type 'nonsense'",
            ),
            (
                r#"<integrator type="aov"><string name="aovs" value="a:boundary_test"/></integrator>"#,
                "invalid AOV type 'boundary_test'",
            ),
            (
                r#"<integrator type="aov"><string name="aovs" value="depth"/></integrator>"#,
                "name:type",
            ),
            (
                r#"<integrator type="depth"><integrator type="path"/></integrator>"#,
                "cannot be nested",
            ),
            (r#"<integrator type="ptracer"/>"#, "not supported"),
        ] {
            let e = scene(bad, "").err().unwrap().to_string();
            assert!(e.contains(msg) && e.contains("<test>:2:"), "{e}");
        }
    }

    #[test]
    fn uv_partials_solve_the_tangent_plane() {
        // the plane z = 0 with ∂p/∂u = (2, 0, 0), ∂p/∂v = (0.5, 3, 0), seen from above by a
        // ray along −z; the differential rays start 0.1 over in x and y (orthographic)
        let mut si = SurfaceGeometry {
            p: Vec3::new(0.2, 0.1, 0.0),
            n_geo: Vec3::Z,
            sh_frame: specula_bsdf::frame::Frame::from_normal(Vec3::Z),
            uv: Vec2::ZERO,
            dp_du: Vec3::new(2.0, 0.0, 0.0),
            dp_dv: Vec3::new(0.5, 3.0, 0.0),
        };
        let (o, d) = (Vec3::new(0.2, 0.1, 5.0), -Vec3::Z);
        let diff = RayDifferentials {
            o_x: o + Vec3::X * 0.1,
            d_x: d,
            o_y: o + Vec3::Y * 0.1,
            d_y: d,
        };
        // Δp = u·(2, 0, 0) + v·(0.5, 3, 0): Δp = (0.1, 0, 0) ⇒ (0.05, 0); (0, 0.1, 0) ⇒
        // v = 1/30, u = −0.5·v/2
        let (dx, dy) = diff.uv_partials(&si);
        assert!((dx - Vec2::new(0.05, 0.0)).length() < 1e-6, "{dx}");
        assert!(
            (dy - Vec2::new(-0.25 / 30.0, 1.0 / 30.0)).length() < 1e-6,
            "{dy}"
        );
        // halving the differentials halves the partials (Mitsuba's 1/√spp with 4 spp)
        let (hx, hy) = diff.scaled(o, d, 0.5).uv_partials(&si);
        assert!((hx - dx * 0.5).length() < 1e-6 && (hy - dy * 0.5).length() < 1e-6);
        // a degenerate parameterisation gives 0, not NaN
        si.dp_du = Vec3::ZERO;
        assert_eq!(diff.uv_partials(&si), (Vec2::ZERO, Vec2::ZERO));
    }

    #[test]
    fn depth_and_aovs_of_the_first_hit() {
        let s = scene(r#"<integrator type="aov"><string name="aovs" value="d:depth,p:prim_index,s:shape_index,n:geo_normal,uv:uv"/></integrator>"#, "").unwrap();
        let mut rng = specula_bsdf::rng::Pcg32::new(1, 1);
        let mut c = Counters::default();
        let mut out = [f32::NAN; 8];
        // the centre pixel looks at the second sphere's front
        let ray = s.camera.ray(Vec2::new(0.5, 0.5));
        let hit = s.intersect(&ray);
        let l = s.sample(&s.integrator, ray, hit, &mut rng, &mut c, &mut out);
        assert_eq!(l, Rgb::ZERO);
        let t = 5.0 - 0.5 - 0.01; // near clip 0.01
        assert!((out[0] - t).abs() < 1e-3, "{out:?}");
        assert_eq!(out[1..3], [0.0, 2.0]);
        assert!((Vec3::from_slice(&out[3..6]) - Vec3::Z).length() < 1e-3);
        assert!(out[6..8].iter().all(|v| (0.0..=1.0).contains(v)));
        // a miss: all zero
        let ray = s.camera.ray(Vec2::new(0.5, 0.02));
        let l = s.sample(
            &s.integrator,
            ray,
            s.intersect(&ray),
            &mut rng,
            &mut c,
            &mut out,
        );
        assert_eq!((l, out), (Rgb::ZERO, [0.0; 8]));
        // the depth integrator agrees with the AOV
        let d = scene(r#"<integrator type="depth"/>"#, "").unwrap();
        let ray = d.camera.ray(Vec2::new(0.5, 0.5));
        let l = d.li(ray, &mut rng, &mut c);
        assert!((l.r() - t).abs() < 1e-3 && l.r() == l.b());
    }

    #[test]
    fn direct_strategies_agree_in_expectation() {
        // a diffuse sphere under a spherical area light and a constant environment: emitter
        // sampling, BSDF sampling and their combination estimate the same value
        let light = r#"<shape type="sphere"><point name="center" x="0" y="2" z="2"/><float name="radius" value="0.5"/><emitter type="area"><rgb name="radiance" value="4"/></emitter></shape>
        <emitter type="constant"><rgb name="radiance" value="0.3"/></emitter>"#;
        let est = |e: u32, b: u32| {
            let s = scene(&format!(r#"<integrator type="direct"><integer name="emitter_samples" value="{e}"/><integer name="bsdf_samples" value="{b}"/></integrator>"#), light).unwrap();
            let mut rng = specula_bsdf::rng::Pcg32::new(7, 3);
            let mut c = Counters::default();
            let ray = s.camera.ray(Vec2::new(0.5, 0.45));
            let n = 200_000;
            let mut acc = 0.0f64;
            for _ in 0..n {
                acc += s.li(ray, &mut rng, &mut c).g() as f64;
            }
            acc / n as f64
        };
        let both = est(1, 1);
        let lum = est(1, 0);
        let bsdf = est(0, 1);
        let many = est(3, 2);
        assert!(both > 0.05, "{both}");
        for (name, v) in [("emitter", lum), ("bsdf", bsdf), ("3+2", many)] {
            assert!((v / both - 1.0).abs() < 0.02, "{name}: {v} vs {both}");
        }
    }
}
