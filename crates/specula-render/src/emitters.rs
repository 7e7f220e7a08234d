//! Emitters other than area lights, in world space, as Mitsuba 3 defines them: `point`,
//! `directional`, `constant`, `envmap`, `spot` and `projector`.
//!
//! Mitsuba 3.9.1 conventions (checked with its Python bindings; numbers in the tests):
//! - `envmap` maps a local direction d to lat-long coordinates
//!   u = atan2(d.x, −d.z)/2π, v = acos(d.y)/π (+y is up, v = 0 the zenith, u = 0 towards −z,
//!   u = ¼ towards +x). The image is padded with a copy of its first column and looked up
//!   *bilinearly* with pixel (x, y) sitting exactly at u = (x + ½)/W, v = y/(H − 1): the first
//!   and last rows lie on the poles. Radiance is that value × `scale`; `to_world` rotates the
//!   map (world direction = to_world · local direction).
//! - `point`: radiance-like value intensity / dist² from `position` (or the `to_world`
//!   translation).
//! - `directional`: `irradiance` arriving from −direction, where direction is `direction` or
//!   `to_world` · (0, 0, 1).
//! - `constant`: uniform-sphere sampling, pdf 1/4π.
//! - `spot`: a point light at the `to_world` origin shining along its +z: `intensity`
//!   (default 1) / dist² × falloff(θ) × `texture`(uv) (optional, nested or referenced). The
//!   falloff is 1 up to `beam_width` (degrees, default ¾ `cutoff_angle`), falls linearly *in angle* to 0
//!   at `cutoff_angle` (degrees, default 20; must lie in (0, 180)), and is 0 beyond (strictly:
//!   cos θ > cos cutoff). The texture is looked up at uv = ½ + ½ (x, y) / (z tan cutoff) of the
//!   local direction (x, y, z) (u grows towards local +x, v towards +y; no flip). θ comes from
//!   the direction in the light's local frame, the 1/dist² from the world distance.
//! - `projector`: a point light at the `to_world` origin projecting the `irradiance` image
//!   (texture or colour, default 1) × `scale` (default 1) along +z with Mitsuba's
//!   field-of-view rules (`fov`/`fov_axis`/`focal_length`, default 50 mm; the aspect ratio is
//!   the image's). A point at local p (z > 0) sees uv = ½ − ½ (x, y·aspect) / (z tan(fov_x/2))
//!   (u = 0 towards local +x, as a camera image; uv outside [0, 1] is dark) and receives the
//!   radiance-like value E(uv) · scale · π / (z² · cos), cos = −n·d between the light's
//!   `to_world` · (0, 0, 1) (not normalised, as Mitsuba) and the direction d from the light to
//!   the point: irradiance E·scale·π on a plane facing the projector at unit depth.
//!
//! A `<spectrum>` value of `point`, `directional`, `constant`, `spot` or `projector` (without
//! an image) is kept beside its RGB value (`spectrum` fields, [`light_spectrum`]): RGB mode
//! uses the RGB value (the spectrum converted as Mitsuba's RGB variants do), spectral mode
//! emits the spectrum itself (`crate::spectral`); a spot's texture then multiplies it as an
//! upsampled reflectance, as in Mitsuba.
//!
//! Importance sampling of `envmap` differs from Mitsuba's (a bilinear `Hierarchical2D` warp over
//! the padded pixel grid) but is unbiased and consistent with [`Emitter::pdf_direction`]: the
//! cells between four neighbouring pixels of the bilinear lookup are chosen with probability
//! ∝ (mean luminance of their four corners) × (solid angle), marginal rows first, then the
//! column; inside a cell directions are uniform in solid angle, so the pdf is constant per cell.
//! That constant is the corners' mean luminance × W / (2π Σ weights) whatever the row (the band's
//! solid angle cancels), so it is the mean of a density share each texel keeps beside its RGB: a
//! lookup's radiance and pdf come from the same two cache lines, with no per-cell table.

use crate::core::{Loc, Result, SceneError};
use crate::image_io::{srgb_to_linear, Image};
use crate::xml::Node;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use specula_bsdf::bsdf::SpectralCurve;
use specula_bsdf::warp::{square_to_uniform_sphere, UNIFORM_SPHERE_PDF};
use specula_bsdf::{Rgb, ShadingPoint, Texture};
use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

/// A direction towards a light, sampled from a reference point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionSample {
    /// Unit vector from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the light; `f32::INFINITY` for infinitely distant lights.
    pub dist: f32,
    /// Incident radiance along `wi` (for delta lights, the arriving irradiance-like value:
    /// intensity/dist² or irradiance).
    pub radiance: Rgb,
    /// Solid-angle density of `wi`; 1 for delta lights.
    pub pdf: f32,
    pub is_delta: bool,
}

/// An emitter's value given as a `<spectrum>` (see [`light_spectrum`]): what spectral mode
/// emits instead of the RGB value upsampled.
pub type EmissionSpectrum = Arc<dyn SpectralCurve>;

/// Mitsuba's `point`.
#[derive(Clone, Debug)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr).
    pub intensity: Rgb,
    /// `intensity` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
}

/// Mitsuba's `directional`.
#[derive(Clone, Debug)]
pub struct DirectionalLight {
    /// Unit direction in which the light travels.
    pub direction: Vec3,
    pub irradiance: Rgb,
    /// `irradiance` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
}

/// Mitsuba's `constant`.
#[derive(Clone, Debug)]
pub struct ConstantLight {
    pub radiance: Rgb,
    /// `radiance` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
}

/// Mitsuba's `envmap`: a lat-long environment image with luminance-based importance
/// sampling.
#[derive(Clone)]
pub struct Envmap {
    /// Resolution of the source image.
    pub width: usize,
    pub height: usize,
    pub scale: f32,
    /// Local → world rotation (and its inverse).
    to_world: Mat3,
    to_local: Mat3,
    /// Per texel (`width + 1` columns, the last repeating the first, × `height` rows): linear
    /// RGB and, in the fourth lane, its share of the sampling density: its luminance (clamped
    /// to ≥ 0, non-finite as 0) × W / (2π Σ weights), a cell's pdf being the mean of its four
    /// corners' (see the module docs; the factor is applied per texel, in f64, so that no
    /// f32 factor can overflow for a very dark map). One aligned 16-byte load gives a texel,
    /// and a cell's pdf comes from the texels its radiance reads (no table of its own to miss
    /// in the cache).
    data: Vec<Vec4>,
    /// cos θ of each pixel row (θ = π·y/(H − 1)).
    cos_theta: Vec<f32>,
    /// Marginal CDF over the H − 1 cell rows (H entries, 0 … 1).
    row_cdf: Vec<f32>,
    /// Per cell row, the conditional CDF over its W cells (W + 1 entries each).
    col_cdf: Vec<f32>,
    /// Cutpoint guide tables ([`guide`]) of `row_cdf` and of each row of `col_cdf`
    /// (`guide::buckets(W) + 1` entries each).
    row_guide: Vec<u32>,
    col_guide: Vec<u32>,
}

impl std::fmt::Debug for Envmap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Envmap")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("scale", &self.scale)
            .field("to_world", &self.to_world)
            .finish_non_exhaustive()
    }
}

/// A non-area light source.
#[derive(Clone, Debug)]
pub enum Emitter {
    Point(PointLight),
    Directional(DirectionalLight),
    Constant(ConstantLight),
    Envmap(Box<Envmap>),
    Spot(Box<SpotLight>),
    Projector(Box<ProjectorLight>),
}

impl Emitter {
    pub fn point(position: Vec3, intensity: Rgb) -> Self {
        Emitter::Point(PointLight {
            position,
            intensity,
            spectrum: None,
        })
    }

    /// A `point` placed by its `to_world` transform (the translation).
    pub fn point_from_to_world(to_world: &Mat4, intensity: Rgb) -> Self {
        Emitter::point(to_world.transform_point3(Vec3::ZERO), intensity)
    }

    /// A `directional` light travelling along `direction` (normalised here; must be non-zero).
    pub fn directional(direction: Vec3, irradiance: Rgb) -> Self {
        Emitter::Directional(DirectionalLight {
            direction: direction.normalize(),
            irradiance,
            spectrum: None,
        })
    }

    /// A `directional` light oriented by `to_world`: it travels along to_world · (0, 0, 1).
    pub fn directional_from_to_world(to_world: &Mat4, irradiance: Rgb) -> Self {
        Emitter::directional(to_world.transform_vector3(Vec3::Z), irradiance)
    }

    pub fn constant(radiance: Rgb) -> Self {
        Emitter::Constant(ConstantLight {
            radiance,
            spectrum: None,
        })
    }

    /// The `<spectrum>` the emitter's value was given as, with that value's RGB (`point`,
    /// `directional`, `spot`: intensity or irradiance; `constant`: radiance; `projector`:
    /// irradiance without an image); `None` for RGB values and for `envmap`.
    pub fn spectrum(&self) -> Option<(&EmissionSpectrum, Rgb)> {
        match self {
            Emitter::Point(l) => l.spectrum.as_ref().map(|s| (s, l.intensity)),
            Emitter::Directional(l) => l.spectrum.as_ref().map(|s| (s, l.irradiance)),
            Emitter::Constant(l) => l.spectrum.as_ref().map(|s| (s, l.radiance)),
            Emitter::Spot(l) => l.spectrum.as_ref().map(|s| (s, l.intensity)),
            Emitter::Projector(l) => l.spectrum.as_ref().map(|s| (s, l.irradiance)),
            Emitter::Envmap(_) => None,
        }
    }

    /// The emitter's colour when every light sample's weight is a multiple of it (no image, no
    /// `<spectrum>`, not an environment map): what spectral mode prepares once
    /// ([`specula_bsdf::spectral::upsample::Illuminant`]).
    pub fn constant_colour(&self) -> Option<Rgb> {
        if self.spectrum().is_some() {
            return None;
        }
        match self {
            Emitter::Point(l) => Some(l.intensity),
            Emitter::Directional(l) => Some(l.irradiance),
            Emitter::Constant(l) => Some(l.radiance),
            Emitter::Spot(l) => l.texture.is_none().then_some(l.intensity),
            Emitter::Projector(l) => l.texture.is_none().then_some(l.irradiance),
            Emitter::Envmap(_) => None,
        }
    }

    /// Reads the `<spectrum>` of the emitter's value parameter `name` ([`light_spectrum`]) into
    /// the emitter built from node `n`.
    fn with_spectrum(mut self, n: &Node, name: &str) -> Result<Self> {
        let s = light_spectrum(n, name)?;
        match &mut self {
            Emitter::Point(l) => l.spectrum = s,
            Emitter::Directional(l) => l.spectrum = s,
            Emitter::Constant(l) => l.spectrum = s,
            Emitter::Spot(l) => l.spectrum = s,
            // an image replaces the irradiance value
            Emitter::Projector(l) if l.texture.is_none() => l.spectrum = s,
            Emitter::Projector(_) | Emitter::Envmap(_) => {}
        }
        Ok(self)
    }

    /// An `envmap` from an EXR/HDR (or PNG/JPEG, linearised) lat-long image.
    pub fn envmap_from_file(path: &Path, scale: f32, to_world: &Mat4) -> Result<Self> {
        let (img, srgb) = {
            let _t = crate::timings::span(crate::timings::Phase::Textures);
            let raw = crate::image_io::read_image_raw_prefetched(path)?;
            let srgb = raw.srgb;
            (raw.into_image(), srgb)
        };
        Envmap::new(&img, srgb, scale, to_world)
            .map(|e| Emitter::Envmap(Box::new(e)))
            .map_err(|msg| SceneError::file(path, msg))
    }

    /// Builds a top-level `<emitter>` (point, directional, constant, envmap) with Mitsuba 3's
    /// parameters and defaults; relative filenames resolve against `base`. Errors carry the
    /// node's location. (`area` emitters belong to shapes and are built by the scene.)
    pub fn from_node(n: &Node, base: &Path) -> Result<Self> {
        if let Some(c) = n.children.first() {
            return Err(c.error(format!(
                "<{}> cannot be nested in {} (textured emitters are not supported)",
                c.tag,
                n.describe()
            )));
        }
        let rgb = |name: &str| light_rgb(n, name);
        let e = match n.plugin_type.as_str() {
            "point" => {
                let intensity = rgb("intensity")?;
                let position = n.point_opt("position")?;
                let to_world = n.transform("to_world")?;
                n.check_unused(&["intensity", "position", "to_world"])?;
                let e = match (position, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(
                            n.error("point: give either 'position' or 'to_world', not both")
                        )
                    }
                    (Some(p), None) => Emitter::point(p, intensity),
                    (None, Some(m)) => Emitter::point_from_to_world(&m, intensity),
                    (None, None) => Emitter::point(Vec3::ZERO, intensity),
                }
                .with_spectrum(n, "intensity")?;
                if let Emitter::Point(l) = &e {
                    if !l.position.is_finite() {
                        return Err(n.error(format!(
                            "point: the position {} is not finite",
                            l.position
                        )));
                    }
                }
                e
            }
            "directional" => {
                let irradiance = rgb("irradiance")?;
                let direction = n.vector_opt("direction")?;
                let to_world = n.transform("to_world")?;
                n.check_unused(&["irradiance", "direction", "to_world"])?;
                let d = match (direction, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(n.error(
                            "directional: give either 'direction' or 'to_world', not both",
                        ))
                    }
                    (Some(d), None) => d,
                    (None, Some(m)) => m.transform_vector3(Vec3::Z),
                    (None, None) => Vec3::Z,
                };
                if !(d.length_squared() > 0.0 && d.is_finite()) {
                    return Err(n.error("directional: the direction must be a non-zero vector"));
                }
                Emitter::directional(d, irradiance).with_spectrum(n, "irradiance")?
            }
            "constant" => {
                let radiance = rgb("radiance")?;
                n.check_unused(&["radiance"])?;
                Emitter::constant(radiance).with_spectrum(n, "radiance")?
            }
            "envmap" => {
                let file = n
                    .string_opt("filename")?
                    .ok_or_else(|| n.error("envmap needs a 'filename'"))?;
                let scale = n.float("scale", 1.0)?;
                if !(scale.is_finite() && scale >= 0.0) {
                    let loc = n.prop("scale").map_or(&n.loc, |p| &p.loc);
                    return Err(SceneError::new(
                        Some(loc.clone()),
                        format!("envmap: 'scale' must be finite and non-negative, not {scale}"),
                    ));
                }
                let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                // Only changes how Mitsuba samples the map (unbiased either way).
                let _ = n.bool("mis_compensation", false)?;
                n.check_unused(&["filename", "scale", "to_world", "mis_compensation"])?;
                let p = Path::new(&file);
                let path = if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    base.join(p)
                };
                Emitter::envmap_from_file(&path, scale, &to_world)
                    .map_err(|e| n.error(e.to_string()))?
            }
            "spot" => Emitter::spot_from_node(n, &[])?,
            "projector" => Emitter::projector_from_node(n, &[])?,
            "area" => {
                return Err(n.error("an 'area' emitter must be nested in the shape that emits"))
            }
            other => {
                return Err(n.error(format!(
                    "emitter '{other}' is not supported (supported: point, directional, constant, envmap, spot, projector, and area inside shapes)"
                )))
            }
        };
        Ok(e)
    }

    /// True for delta lights (`point`, `directional`, `spot`, `projector`), which only next-event estimation can
    /// reach.
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Emitter::Point(_) | Emitter::Directional(_) | Emitter::Spot(_) | Emitter::Projector(_)
        )
    }

    /// True for environment lights (`constant`, `envmap`): infinitely distant and seen by rays
    /// that escape the scene (`eval_direction`). `directional` is also at infinity
    /// (`sample_direction` reports `dist = ∞`) but, being a delta light, is never seen, so it
    /// is not counted here.
    pub fn is_infinite(&self) -> bool {
        matches!(self, Emitter::Constant(_) | Emitter::Envmap(_))
    }

    /// Samples a direction from `ref_p` towards the light. `None` when nothing can be sampled
    /// (reference point on a point light, black environment). Allocation-free.
    pub fn sample_direction(&self, ref_p: Vec3, u: Vec2) -> Option<DirectionSample> {
        match self {
            Emitter::Point(l) => {
                let d = l.position - ref_p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if dist <= 0.0 || !dist.is_finite() {
                    return None;
                }
                Some(DirectionSample {
                    wi: d / dist,
                    dist,
                    radiance: l.intensity * (1.0 / dist2),
                    pdf: 1.0,
                    is_delta: true,
                })
            }
            Emitter::Directional(l) => Some(DirectionSample {
                wi: -l.direction,
                dist: f32::INFINITY,
                radiance: l.irradiance,
                pdf: 1.0,
                is_delta: true,
            }),
            Emitter::Constant(l) => Some(DirectionSample {
                wi: square_to_uniform_sphere(u),
                dist: f32::INFINITY,
                radiance: l.radiance,
                pdf: UNIFORM_SPHERE_PDF,
                is_delta: false,
            }),
            Emitter::Envmap(e) => e.sample(u),
            Emitter::Spot(l) => l.sample(ref_p),
            Emitter::Projector(l) => l.sample(ref_p),
        }
    }

    /// Radiance arriving from world direction `d` (pointing away from the receiver, towards
    /// the light); 0 for delta lights.
    pub fn eval_direction(&self, d_world: Vec3) -> Rgb {
        match self {
            Emitter::Point(_)
            | Emitter::Directional(_)
            | Emitter::Spot(_)
            | Emitter::Projector(_) => Rgb::ZERO,
            Emitter::Constant(l) => l.radiance,
            Emitter::Envmap(e) => e.eval(d_world),
        }
    }

    /// [`Emitter::eval_direction`] and [`Emitter::pdf_direction`] together.
    pub fn eval_pdf_direction(&self, d_world: Vec3) -> (Rgb, f32) {
        match self {
            Emitter::Envmap(e) => e.eval_pdf(d_world),
            _ => (self.eval_direction(d_world), self.pdf_direction(d_world)),
        }
    }

    /// Solid-angle density with which `sample_direction` produces `d` (0 for delta lights).
    pub fn pdf_direction(&self, d_world: Vec3) -> f32 {
        match self {
            Emitter::Point(_)
            | Emitter::Directional(_)
            | Emitter::Spot(_)
            | Emitter::Projector(_) => 0.0,
            Emitter::Constant(_) => UNIFORM_SPHERE_PDF,
            Emitter::Envmap(e) => e.pdf(d_world),
        }
    }
}

/// Picks the bin of a CDF (`n + 1` entries, 0 … 1) holding `u`, skipping empty bins, and
/// returns it with `u` rescaled to [0, 1) within it: the binary search over the whole CDF
/// that [`guide::sample`] reproduces (kept as its reference in the tests).
#[cfg(test)]
fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let idx = cdf[1..n].partition_point(|&c| c <= u);
    bin_offset(cdf, idx, u)
}

/// Cutpoint guide tables (Chen & Asau's method) for sampling a CDF: with m buckets, a value x
/// falls in bucket b(x) = min(⌊x·m⌋, m − 1) (the same f32 operations when the table is built
/// and when it is read, and non-decreasing in x), and entry k counts the CDF's interior entries
/// in buckets below k. The interior entries before entry b(u) are then < u and those from entry
/// b(u) + 1 on are > u, so the bin holding u is found among the few entries in u's bucket
/// instead of over the whole CDF, with no division; it returns exactly what the binary search
/// over the whole CDF returns (same bins, same images).
mod guide {
    /// Buckets for a CDF of `n` bins: about four bins per bucket.
    #[inline]
    pub fn buckets(n: usize) -> usize {
        n.div_ceil(4).max(1)
    }

    /// The bucket of `x` among `m` (`m` as f32 too).
    #[inline]
    fn bucket(x: f32, m: usize, mf: f32) -> usize {
        // `as usize` saturates: negative x gives 0
        ((x * mf) as usize).min(m - 1)
    }

    /// Appends the guide (`buckets(n) + 1` entries) of a CDF of `n + 1` non-decreasing
    /// entries.
    pub fn build(cdf: &[f32], out: &mut Vec<u32>) {
        let inner = &cdf[1..cdf.len() - 1];
        let m = buckets(cdf.len() - 1);
        let mf = m as f32;
        let mut c = 0;
        for k in 0..m {
            while c < inner.len() && bucket(inner[c], m, mf) < k {
                c += 1;
            }
            out.push(c as u32);
        }
        out.push(inner.len() as u32);
    }

    /// Picks the bin of `cdf` (`n + 1` entries, 0 … 1) holding `u`, skipping empty bins,
    /// through its guide `start`; returns it with `u` rescaled to [0, 1) within it.
    #[inline]
    pub fn sample(cdf: &[f32], start: &[u32], u: f32) -> (usize, f32) {
        let m = start.len() - 1;
        let k = bucket(u, m, m as f32);
        let (lo, hi) = (start[k] as usize, start[k + 1] as usize);
        let idx = lo + cdf[1 + lo..1 + hi].partition_point(|&c| c <= u);
        super::bin_offset(cdf, idx, u)
    }
}

#[inline]
fn bin_offset(cdf: &[f32], idx: usize, u: f32) -> (usize, f32) {
    let (lo, hi) = (cdf[idx], cdf[idx + 1]);
    let t = if hi > lo { (u - lo) / (hi - lo) } else { 0.5 };
    (idx, t.clamp(0.0, 1.0 - f32::EPSILON / 2.0))
}

impl Envmap {
    /// Builds the map from decoded pixels (`srgb`: values are sRGB-encoded and get
    /// linearised). Errors are messages for the caller to attach to a file.
    pub fn new(img: &Image, srgb: bool, scale: f32, to_world: &Mat4) -> Result<Self, String> {
        let (w, h) = (img.width, img.height);
        if w < 2 || h < 3 {
            return Err(format!(
                "the environment map resolution must be at least 2×3 pixels (got {w}×{h})"
            ));
        }
        let lin = |v: f32| if srgb { srgb_to_linear(v) } else { v };
        let pw = w + 1;
        let mut data = vec![Vec4::ZERO; pw * h];
        for y in 0..h {
            for x in 0..pw {
                let rgb = img.rgb(x % w, y);
                let c = Rgb::new(lin(rgb[0]), lin(rgb[1]), lin(rgb[2]));
                let l = c.luminance();
                let l = if l.is_finite() { l.max(0.0) } else { 0.0 };
                data[y * pw + x] = Vec4::new(c.0[0], c.0[1], c.0[2], l);
            }
        }
        let lin3 = Mat3::from_mat4(*to_world);
        let to_local = lin3.inverse();
        if !to_local.is_finite() {
            return Err("the envmap's to_world transform is singular".into());
        }

        // Sampling distribution over the (H − 1) × W cells of the bilinear lookup.
        let cos_theta: Vec<f32> = (0..h)
            .map(|y| (std::f64::consts::PI * y as f64 / (h - 1) as f64).cos() as f32)
            .collect();
        let lum: Vec<f64> = data.iter().map(|t| t.w as f64).collect();
        let rows = h - 1;
        let mut weights = vec![0.0f64; rows * w];
        let mut row_sum = vec![0.0f64; rows];
        for j in 0..rows {
            let th0 = std::f64::consts::PI * j as f64 / rows as f64;
            let th1 = std::f64::consts::PI * (j + 1) as f64 / rows as f64;
            let band = th0.cos() - th1.cos();
            for i in 0..w {
                let avg = 0.25
                    * (lum[j * pw + i]
                        + lum[j * pw + i + 1]
                        + lum[(j + 1) * pw + i]
                        + lum[(j + 1) * pw + i + 1]);
                let wt = avg * band;
                weights[j * w + i] = wt;
                row_sum[j] += wt;
            }
        }
        let total: f64 = row_sum.iter().sum();
        let mut row_cdf = vec![0.0f32; rows + 1];
        let mut col_cdf = vec![0.0f32; rows * (w + 1)];
        if total > 0.0 && total.is_finite() {
            let mut acc = 0.0f64;
            for j in 0..rows {
                acc += row_sum[j];
                // Exactly 1 once all the mass is in (the sums run in the same order), so
                // trailing empty bins can never be drawn.
                row_cdf[j + 1] = if acc >= total {
                    1.0
                } else {
                    (acc / total) as f32
                };
                let cdf = &mut col_cdf[j * (w + 1)..(j + 1) * (w + 1)];
                let mut a = 0.0f64;
                for i in 0..w {
                    a += weights[j * w + i];
                    cdf[i + 1] = if row_sum[j] > 0.0 {
                        if a >= row_sum[j] {
                            1.0
                        } else {
                            (a / row_sum[j]) as f32
                        }
                    } else {
                        (i + 1) as f32 / w as f32
                    };
                }
                cdf[w] = 1.0;
            }
            row_cdf[rows] = 1.0;
        }
        // a cell's weight is its corners' mean luminance × its band's solid angle, so its
        // solid-angle density is that mean × W / (2π Σ weights) in every row: each texel keeps
        // its luminance times that factor (all 0 for a black map, which is never sampled)
        let pdf_scale = if total > 0.0 && total.is_finite() {
            w as f64 / (2.0 * std::f64::consts::PI * total)
        } else {
            0.0
        };
        for (t, &l) in data.iter_mut().zip(&lum) {
            t.w = (l * pdf_scale) as f32;
        }
        let mut row_guide = vec![];
        guide::build(&row_cdf, &mut row_guide);
        let mut col_guide = Vec::with_capacity(rows * (guide::buckets(w) + 1));
        for cdf in col_cdf.chunks_exact(w + 1) {
            guide::build(cdf, &mut col_guide);
        }
        Ok(Envmap {
            width: w,
            height: h,
            scale,
            to_world: lin3,
            to_local,
            data,
            cos_theta,
            row_cdf,
            col_cdf,
            row_guide,
            col_guide,
        })
    }

    /// Lat-long coordinates of a local direction (Mitsuba's `direction_to_uv`).
    #[inline]
    fn direction_to_uv(d: Vec3) -> Vec2 {
        Vec2::new(
            specula_bsdf::math::atan2(d.x, -d.z) * (0.5 / PI),
            d.y.clamp(-1.0, 1.0).acos() * (1.0 / PI),
        )
    }

    #[inline]
    fn texel(&self, index: usize) -> Rgb {
        let t = self.data[index];
        Rgb::new(t.x, t.y, t.z)
    }

    /// The solid-angle pdf of the sampling cell whose upper-left texel is `index`.
    #[inline]
    fn cell_pdf_at(&self, index: usize) -> f32 {
        let pw = self.width + 1;
        let l = |k: usize| 0.25 * self.data[k].w;
        (l(index) + l(index + 1)) + (l(index + pw) + l(index + pw + 1))
    }

    /// The sampling cell (row-major over (H − 1) × W) holding local direction `d`.
    #[cfg(test)]
    fn cell(&self, d: Vec3) -> usize {
        let i = self.bilinear_cell(Self::direction_to_uv(d)).0;
        let pw = self.width + 1;
        (i / pw) * self.width + i % pw
    }

    /// The solid-angle pdf of sampling cell `cell` (row-major over (H − 1) × W).
    #[cfg(test)]
    fn cell_pdf(&self, cell: usize) -> f32 {
        let (j, i) = (cell / self.width, cell % self.width);
        self.cell_pdf_at(j * (self.width + 1) + i)
    }

    /// The bilinear lookup at lat-long `uv`: the index of the upper-left texel of its cell
    /// and the weights of the right and lower texels.
    #[inline]
    fn bilinear_cell(&self, uv: Vec2) -> (usize, Vec2) {
        let (w, h) = (self.width, self.height);
        let mut uv = uv;
        uv.x -= 0.5 / w as f32;
        uv.x -= uv.x.floor();
        // Mitsuba also wraps v (`uv -= floor(uv)`), which would send the exact south pole
        // (v = 1) to the north pole; its f32 acos never yields exactly 1 there (it returns
        // the bottom row), so v is only clamped here.
        uv.y = uv.y.clamp(0.0, 1.0);
        uv *= Vec2::new(w as f32, (h - 1) as f32);
        let px = (uv.x as usize).min(w - 1);
        let py = (uv.y as usize).min(h - 2);
        (py * (w + 1) + px, uv - Vec2::new(px as f32, py as f32))
    }

    /// The radiance (times `scale`) interpolated with weights `w1` in the cell from texel `i`.
    #[inline]
    fn interpolate(&self, i: usize, w1: Vec2) -> Rgb {
        let pw = self.width + 1;
        let w0 = Vec2::ONE - w1;
        let v0 = self.data[i] * w0.x + self.data[i + 1] * w1.x;
        let v1 = self.data[i + pw] * w0.x + self.data[i + pw + 1] * w1.x;
        let v = v0 * w0.y + v1 * w1.y;
        Rgb::new(v.x, v.y, v.z) * self.scale
    }

    /// Mitsuba's `eval_spectrum`: bilinear lookup at lat-long `uv`, times `scale`.
    fn eval_uv(&self, uv: Vec2) -> Rgb {
        let (i, w1) = self.bilinear_cell(uv);
        self.interpolate(i, w1)
    }

    /// Spectral mode: the radiance from world direction `d` at the wavelengths `wl`, as
    /// Mitsuba's spectral `envmap` computes it: each of the four texels around the lookup is
    /// upsampled as an illuminant (shape ρᵢ of rgbᵢ/sᵢ, sᵢ = 2·max(rgbᵢ)), and the bilinear
    /// interpolation of the shapes is multiplied by the interpolation of the sᵢ and by D65
    /// (not the interpolation of the products: near a small bright sun this shifts the colour
    /// by a percent or so against upsampling the interpolated RGB, which Specula reproduces
    /// so that spectral renders match Mitsuba's).
    pub fn eval_spectral(&self, d_world: Vec3, wl: &specula_bsdf::Wavelengths) -> Rgb {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return Rgb::ZERO;
        }
        let (i, w1) = self.bilinear_cell(Self::direction_to_uv(d));
        let w0 = Vec2::ONE - w1;
        let pw = self.width + 1;
        let mut shape = Rgb::ZERO;
        let mut scale = 0.0f32;
        for (idx, wt) in [
            (i, w0.x * w0.y),
            (i + 1, w1.x * w0.y),
            (i + pw, w0.x * w1.y),
            (i + pw + 1, w1.x * w1.y),
        ] {
            let rgb = self.texel(idx).map(|v| v.max(0.0));
            let s = 2.0 * rgb.max_component();
            if s > 0.0 {
                shape += specula_bsdf::spectral::upsample::reflectance(rgb / s, wl) * wt;
                scale += s * wt;
            }
        }
        let d65 = Rgb(wl.0.map(specula_bsdf::spectral::cie::d65));
        shape * d65 * (scale * self.scale)
    }

    #[inline]
    fn local(&self, d_world: Vec3) -> Vec3 {
        (self.to_local * d_world).normalize_or_zero()
    }

    /// Asks the cache for the texels that a lookup from world direction `d_world` reads,
    /// before the caller traces a ray that may escape along it (the lookup itself would wait
    /// for them when the ray escapes); a map small enough to stay in the core's cache
    /// (under 256 KiB of texels) is skipped.
    #[inline]
    pub fn prefetch(&self, d_world: Vec3) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            if self.data.len() < 16 * 1024 {
                return;
            }
            let i = self.coarse_cell(d_world);
            // SAFETY: the cell's four texels i, i + 1, i + w + 1 and i + w + 2 lie in `data`
            // (py ≤ h − 2 and px ≤ w − 1, so i + w + 2 ≤ (h − 1)(w + 1) + w = len − 1), and
            // prefetching never faults
            unsafe {
                let p = self.data.as_ptr().add(i) as *const i8;
                _mm_prefetch::<_MM_HINT_T0>(p);
                _mm_prefetch::<_MM_HINT_T0>(p.add(16));
                let q = self.data.as_ptr().add(i + self.width + 1) as *const i8;
                _mm_prefetch::<_MM_HINT_T0>(q);
                _mm_prefetch::<_MM_HINT_T0>(q.add(16));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = d_world;
    }

    /// The upper-left texel of the bilinear lookup's cell for world direction `d_world`
    /// (as `bilinear_cell(direction_to_uv(local(d)))` gives it) computed cheaply for
    /// [`Envmap::prefetch`]: acos from a short polynomial (error under 0.0001 rad) instead
    /// of libm's, and no normalisation, so it can be a texel off next to a cell's edge.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    fn coarse_cell(&self, d_world: Vec3) -> usize {
        let d = self.to_local * d_world;
        // φ as the lookup computes it (a short polynomial already)
        let phi = specula_bsdf::math::atan2(d.x, -d.z);
        // θ = acos(y/|d|): √(1 − y)·(1.5707288 − 0.2121144 y + 0.0742610 y² − 0.0187293 y³)
        // for y ≥ 0 (Abramowitz & Stegun 4.4.45), mirrored for y < 0
        let len = d.length();
        let y = if len > 0.0 {
            (d.y / len).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let ay = y.abs();
        let a = (1.0 - ay).sqrt()
            * (1.570_728_8 + ay * (-0.212_114_4 + ay * (0.074_261 - 0.018_729_3 * ay)));
        let theta = if y < 0.0 { PI - a } else { a };
        let (w, h) = (self.width, self.height);
        let mut u = phi * (0.5 / PI) - 0.5 / w as f32;
        if u < 0.0 {
            u += 1.0;
        }
        // (`as i32` of NaN is 0: a degenerate direction still gives a texel in the map)
        let px = ((u * w as f32) as i32).clamp(0, w as i32 - 1) as usize;
        let py = ((theta * (1.0 / PI) * (h - 1) as f32) as i32).clamp(0, h as i32 - 2) as usize;
        py * (w + 1) + px
    }

    /// Radiance arriving from world direction `d`.
    pub fn eval(&self, d_world: Vec3) -> Rgb {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return Rgb::ZERO;
        }
        self.eval_uv(Self::direction_to_uv(d))
    }

    /// [`Envmap::eval`] and [`Envmap::pdf`] together (one lat-long conversion, and the pdf
    /// from the texels the radiance reads).
    pub fn eval_pdf(&self, d_world: Vec3) -> (Rgb, f32) {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return (Rgb::ZERO, 0.0);
        }
        let (i, w1) = self.bilinear_cell(Self::direction_to_uv(d));
        (self.interpolate(i, w1), self.cell_pdf_at(i))
    }

    /// Solid-angle pdf of [`Envmap::sample`]: that of the cell of the bilinear lookup.
    pub fn pdf(&self, d_world: Vec3) -> f32 {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return 0.0;
        }
        self.cell_pdf_at(self.bilinear_cell(Self::direction_to_uv(d)).0)
    }

    /// Importance-samples a direction (see the module documentation).
    pub fn sample(&self, u: Vec2) -> Option<DirectionSample> {
        if self.row_cdf[self.height - 1] != 1.0 {
            return None; // black (or non-finite) map
        }
        let w = self.width;
        let (j, sv) = guide::sample(&self.row_cdf, &self.row_guide, u.y);
        let g = guide::buckets(w) + 1;
        let (i, su) = guide::sample(
            &self.col_cdf[j * (w + 1)..(j + 1) * (w + 1)],
            &self.col_guide[j * g..(j + 1) * g],
            u.x,
        );
        let pdf = self.cell_pdf_at(j * (w + 1) + i);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        // u of the lat-long map (φ / 2π, a half texel on from the cell's corner) and cos θ
        let x = (i as f32 + su + 0.5) / w as f32;
        let (c0, c1) = (self.cos_theta[j], self.cos_theta[j + 1]);
        let cos_t = c0 + (c1 - c0) * sv;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (sin_p, cos_p) = specula_bsdf::math::sincos_2pi(x);
        let d_local = Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p);
        let wi = (self.to_world * d_local).normalize();
        // the radiance at the sampled point, from its lat-long coordinates directly (what
        // `direction_to_uv(d_local)` gives up to rounding, without its atan2)
        let uv = Vec2::new(x, cos_t.clamp(-1.0, 1.0).acos() * (1.0 / PI));
        Some(DirectionSample {
            wi,
            dist: f32::INFINITY,
            radiance: self.eval_uv(uv),
            pdf,
            is_delta: false,
        })
    }
}

/// A texture given to an emitter as a nested `<texture name=…>` or a `<ref name=… id=…>`.
#[derive(Clone, Debug)]
pub struct NamedTexture {
    /// The parameter it sets.
    pub name: String,
    pub texture: Arc<dyn Texture>,
    /// Where it was given.
    pub loc: Loc,
}

/// The texture named `name` among `textures`; an error at any texture whose name `accepted`
/// does not hold.
fn take_textures<'a>(
    n: &Node,
    textures: &'a [NamedTexture],
    accepted: &[&str],
) -> Result<Vec<(&'a str, &'a Arc<dyn Texture>)>> {
    let mut out = vec![];
    for t in textures {
        if !accepted.contains(&t.name.as_str()) {
            return Err(SceneError::new(
                Some(t.loc.clone()),
                format!(
                    "{} has no texture parameter '{}' (textures it accepts: {})",
                    n.describe(),
                    t.name,
                    accepted.join(", ")
                ),
            ));
        }
        if n.has(&t.name) {
            return Err(SceneError::new(
                Some(t.loc.clone()),
                format!("'{}' is given twice", t.name),
            ));
        }
        out.push((t.name.as_str(), &t.texture));
    }
    Ok(out)
}

/// Mitsuba's `spot` (see the module documentation).
#[derive(Clone, Debug)]
pub struct SpotLight {
    pub position: Vec3,
    /// World → local (the inverse of `to_world`).
    to_local: Mat4,
    pub intensity: Rgb,
    /// `intensity` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
    texture: Option<Arc<dyn Texture>>,
    /// Radians.
    cutoff: f32,
    cos_cutoff: f32,
    cos_beam: f32,
    inv_transition: f32,
    /// tan(cutoff): scales the texture's uv.
    uv_factor: f32,
}

impl SpotLight {
    /// `cutoff_angle` and `beam_width` in degrees; errors are messages for the caller.
    pub fn new(
        to_world: &Mat4,
        intensity: Rgb,
        cutoff_angle: f32,
        beam_width: f32,
        texture: Option<Arc<dyn Texture>>,
    ) -> std::result::Result<Self, String> {
        if !(cutoff_angle > 0.0 && cutoff_angle < 180.0) {
            return Err(format!(
                "cutoff_angle must lie in (0, 180) degrees, got {cutoff_angle}"
            ));
        }
        if !(beam_width >= 0.0 && beam_width.is_finite()) {
            return Err(format!(
                "beam_width must be a non-negative angle in degrees, got {beam_width}"
            ));
        }
        let to_local = to_world.inverse();
        if !to_local.is_finite() {
            return Err("the spot's to_world transform is singular".into());
        }
        let (cutoff, beam) = (cutoff_angle.to_radians(), beam_width.to_radians());
        Ok(SpotLight {
            position: to_world.transform_point3(Vec3::ZERO),
            to_local,
            intensity,
            spectrum: None,
            texture,
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: 1.0 / (cutoff - beam),
            uv_factor: cutoff.tan(),
        })
    }

    /// Intensity towards local direction `local` (any length), falloff and texture included.
    pub fn falloff(&self, local: Vec3) -> Rgb {
        let d = local.normalize_or_zero();
        let cos_t = d.z;
        // (NaN fails too)
        if cos_t.is_nan() || cos_t <= self.cos_cutoff {
            return Rgb::ZERO;
        }
        let mut v = self.intensity;
        if let Some(t) = self.texture_at(d) {
            v *= t;
        }
        if cos_t >= self.cos_beam {
            v
        } else {
            v * ((self.cutoff - cos_t.min(1.0).acos()) * self.inv_transition)
        }
    }

    /// The texture's value towards the unit local direction `d` (z > 0); `None` without a
    /// texture.
    fn texture_at(&self, d: Vec3) -> Option<Rgb> {
        let t = self.texture.as_ref()?;
        let k = 0.5 / (d.z * self.uv_factor);
        let uv = Vec2::new(0.5 + d.x * k, 0.5 + d.y * k);
        Some(t.eval(&ShadingPoint {
            uv,
            ..Default::default()
        }))
    }

    /// The texture's value on a ray from the light along world direction `d`; `None` without
    /// a texture or outside the cone.
    pub fn texture_towards(&self, d: Vec3) -> Option<Rgb> {
        let d = self.to_local.transform_vector3(d).normalize_or_zero();
        if d.z.is_nan() || d.z <= self.cos_cutoff {
            return None;
        }
        self.texture_at(d)
    }

    fn sample(&self, ref_p: Vec3) -> Option<DirectionSample> {
        let d = self.position - ref_p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if dist <= 0.0 || !dist.is_finite() {
            return None;
        }
        let radiance = self.falloff(self.to_local.transform_point3(ref_p)) * (1.0 / dist2);
        if radiance.is_black() {
            return None;
        }
        Some(DirectionSample {
            wi: d / dist,
            dist,
            radiance,
            pdf: 1.0,
            is_delta: true,
        })
    }
}

/// Mitsuba's `projector` (see the module documentation).
#[derive(Clone, Debug)]
pub struct ProjectorLight {
    pub position: Vec3,
    to_local: Mat4,
    /// `to_world` · (0, 0, 1), not normalised.
    n_world: Vec3,
    irradiance: Rgb,
    /// `irradiance` as a `<spectrum>` (no image), for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
    texture: Option<Arc<dyn Texture>>,
    pub scale: f32,
    /// tan(fov_x / 2).
    tan_half_x: f32,
    /// Image width / height.
    aspect: f32,
}

impl ProjectorLight {
    /// `tan_half_x` = tan(fov_x / 2) for an image of aspect `aspect`; the image is `texture`
    /// or, without one, the constant `irradiance`.
    pub fn new(
        to_world: &Mat4,
        irradiance: Rgb,
        texture: Option<Arc<dyn Texture>>,
        scale: f32,
        tan_half_x: f32,
        aspect: f32,
    ) -> std::result::Result<Self, String> {
        let to_local = to_world.inverse();
        if !to_local.is_finite() {
            return Err("the projector's to_world transform is singular".into());
        }
        if !scale.is_finite() {
            return Err(format!("scale must be finite, got {scale}"));
        }
        Ok(ProjectorLight {
            position: to_world.transform_point3(Vec3::ZERO),
            to_local,
            n_world: to_world.transform_vector3(Vec3::Z),
            irradiance,
            spectrum: None,
            texture,
            scale,
            tan_half_x,
            aspect,
        })
    }

    fn sample(&self, ref_p: Vec3) -> Option<DirectionSample> {
        let local = self.to_local.transform_point3(ref_p);
        if local.z.is_nan() || local.z <= 0.0 {
            return None;
        }
        let k = 0.5 / (local.z * self.tan_half_x);
        let uv = Vec2::new(0.5 - local.x * k, 0.5 - local.y * self.aspect * k);
        if !(uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()) {
            return None;
        }
        let d = self.position - ref_p;
        let dist = d.length();
        if !(dist > 0.0 && dist.is_finite()) {
            return None;
        }
        let wi = d / dist;
        let cos = -self.n_world.dot(wi);
        if cos.is_nan() || cos <= 0.0 {
            return None;
        }
        let e = match &self.texture {
            Some(t) => t.eval(&ShadingPoint {
                uv,
                ..Default::default()
            }),
            None => self.irradiance,
        };
        let radiance = e * (PI * self.scale / (local.z * local.z * cos));
        if radiance.is_black() {
            return None;
        }
        Some(DirectionSample {
            wi,
            dist,
            radiance,
            pdf: 1.0,
            is_delta: true,
        })
    }
}

impl Emitter {
    /// [`Emitter::from_node`] for an emitter given textures (nested `<texture name=…>` or
    /// `<ref name=…>` elements, built by the caller): `spot`'s `texture`, `projector`'s
    /// `irradiance`. Other emitters take no textures (their nested elements are errors).
    pub fn from_node_textured(n: &Node, base: &Path, textures: &[NamedTexture]) -> Result<Self> {
        match n.plugin_type.as_str() {
            "spot" => Emitter::spot_from_node(n, textures),
            "projector" => Emitter::projector_from_node(n, textures),
            _ => Emitter::from_node(n, base),
        }
    }

    /// Mitsuba's `spot` from its node and textures.
    fn spot_from_node(n: &Node, textures: &[NamedTexture]) -> Result<Self> {
        let texture = take_textures(n, textures, &["texture"])?
            .first()
            .map(|(_, t)| Arc::clone(t));
        let intensity = light_rgb(n, "intensity")?;
        let cutoff = n.float("cutoff_angle", 20.0)?;
        let beam = n.float("beam_width", cutoff * 0.75)?;
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        n.check_unused(&["intensity", "cutoff_angle", "beam_width", "to_world"])?;
        SpotLight::new(&to_world, intensity, cutoff, beam, texture)
            .map(|l| Emitter::Spot(Box::new(l)))
            .map_err(|m| n.error(format!("spot: {m}")))?
            .with_spectrum(n, "intensity")
    }

    /// Mitsuba's `projector` from its node and textures.
    fn projector_from_node(n: &Node, textures: &[NamedTexture]) -> Result<Self> {
        let texture = take_textures(n, textures, &["irradiance"])?
            .first()
            .map(|(_, t)| Arc::clone(t));
        let irradiance = light_rgb(n, "irradiance")?;
        let scale = n.float("scale", 1.0)?;
        let (w, h) = texture.as_ref().map_or((1, 1), |t| t.resolution());
        let aspect = w as f64 / h as f64;
        let tan_half_x = crate::camera::parse_fov(n, aspect)?;
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        n.check_unused(&[
            "irradiance",
            "scale",
            "fov",
            "fov_axis",
            "focal_length",
            "to_world",
        ])?;
        ProjectorLight::new(
            &to_world,
            irradiance,
            texture,
            scale,
            tan_half_x,
            aspect as f32,
        )
        .map(|l| Emitter::Projector(Box::new(l)))
        .map_err(|m| n.error(format!("projector: {m}")))?
        .with_spectrum(n, "irradiance")
    }
}

/// A light's colour parameter (`radiance`, `intensity`, `irradiance`; default 1): finite and
/// non-negative in every channel, or an error at the property. Negative or infinite light
/// gives negative or NaN pixels, so it is refused (Mitsuba accepts it).
pub fn light_rgb(n: &Node, name: &str) -> Result<Rgb> {
    let v = n.emission_rgb(name, [1.0; 3])?;
    if v.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Ok(Rgb(v));
    }
    let loc = n.prop(name).map_or(&n.loc, |p| &p.loc);
    Err(SceneError::new(
        Some(loc.clone()),
        format!(
            "{}: '{name}' must be finite and non-negative, not ({}, {}, {})",
            n.plugin_type, v[0], v[1], v[2]
        ),
    ))
}

/// The `<spectrum>` an emitter's value parameter `name` was given as, kept for spectral
/// mode (Mitsuba's spectral variants emit it as it is; see [`crate::xml::spectrum`]);
/// `None` for `<rgb>`, `<float>` and absent values. A tabulated spectrum with a negative
/// value is an error at the property, as a negative RGB light is.
pub fn light_spectrum(n: &Node, name: &str) -> Result<Option<EmissionSpectrum>> {
    let Some(p) = n.prop(name) else {
        return Ok(None);
    };
    let crate::xml::PropValue::Spectrum(s) = &p.value else {
        return Ok(None);
    };
    if let Some(m) = s.min_sample().filter(|m| *m < 0.0) {
        return Err(SceneError::new(
            Some(p.loc.clone()),
            format!(
                "{}: the '{name}' spectrum must be non-negative at every wavelength, not {m}",
                n.plugin_type
            ),
        ));
    }
    Ok(Some(s.curve()))
}

#[cfg(test)]
mod tests {
    /// Uniform numbers in [0, 1) from a 64-bit LCG seeded with `seed` (the tests' fixed
    /// sequences).
    fn lcg(mut seed: u64) -> impl FnMut() -> f32 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// The guided search returns exactly the whole-CDF binary search's bin and offset, on
    /// CDFs with empty bins, flat runs, steps and a single bin.
    #[test]
    fn guided_cdf_search_is_exact() {
        let mut rnd = lcg(1);
        let mut cases: Vec<Vec<f64>> =
            vec![vec![1.0], vec![0.0, 1.0], vec![1.0, 0.0, 0.0, 0.0, 0.0]];
        for n in [2usize, 3, 5, 7, 16, 33, 100, 513] {
            cases.push((0..n).map(|_| rnd() as f64).collect());
            // mostly empty with a bright spot (a sun), and flat runs of equal weights
            cases.push(
                (0..n)
                    .map(|i| {
                        if i == n / 3 {
                            1e6
                        } else if i % 5 == 0 {
                            0.0
                        } else {
                            1e-3
                        }
                    })
                    .collect(),
            );
            cases.push((0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect());
        }
        for w in &cases {
            let total: f64 = w.iter().sum();
            let mut cdf = vec![0.0f32];
            let mut acc = 0.0;
            for x in w {
                acc += x;
                cdf.push(if acc >= total {
                    1.0
                } else {
                    (acc / total) as f32
                });
            }
            let mut g = vec![];
            super::guide::build(&cdf, &mut g);
            assert_eq!(g.len(), super::guide::buckets(w.len()) + 1);
            let mut us: Vec<f32> = (0..2000).map(|_| rnd()).collect();
            // the CDF's own values, the bucket edges and their neighbours
            for &c in &cdf {
                us.extend([
                    c,
                    f32::from_bits(c.to_bits().saturating_sub(1)),
                    f32::from_bits(c.to_bits() + 1),
                ]);
            }
            let m = g.len() - 1;
            for k in 0..=m {
                let t = k as f32 / m as f32;
                us.extend([
                    t,
                    f32::from_bits(t.to_bits().saturating_sub(1)),
                    f32::from_bits(t.to_bits() + 1),
                ]);
            }
            us.extend([0.0, 1.0 - f32::EPSILON / 2.0]);
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let a = super::sample_cdf(&cdf, u);
                let b = super::guide::sample(&cdf, &g, u);
                assert_eq!(a, b, "u = {u}, cdf {cdf:?}");
            }
        }
    }

    use super::*;
    use specula_bsdf::rng::Pcg32;
    use std::f32::consts::FRAC_1_SQRT_2;

    fn asset(name: &str) -> Option<std::path::PathBuf> {
        specula_testdata::shared(&format!("scenes/assets/{name}"))
    }

    fn envmap(name: &str, scale: f32, to_world: Mat4) -> Option<Emitter> {
        asset(name).map(|p| Emitter::envmap_from_file(&p, scale, &to_world).unwrap())
    }

    fn close(a: Rgb, b: [f32; 3], tol: f32) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol * b[i].abs().max(1e-3))
    }

    /// A direction from Mitsuba's lat-long coordinates.
    fn uv_dir(u: f64, v: f64) -> Vec3 {
        let (th, ph) = (v * std::f64::consts::PI, u * 2.0 * std::f64::consts::PI);
        Vec3::new(
            (ph.sin() * th.sin()) as f32,
            th.cos() as f32,
            (-ph.cos() * th.sin()) as f32,
        )
    }

    #[test]
    fn envmap_eval_matches_mitsuba() {
        let Some(e) = envmap("sky.exr", 1.0, Mat4::IDENTITY) else {
            return;
        };
        // Mitsuba 3.9.1 (scalar_rgb) envmap.eval(si) with si.wi = −d. Pixel (x, y) of the
        // 512×256 file sits at u = (x + ½)/512, v = y/255; (153, 60) is the sun, (400, 360, 300).
        let at_pixels = [
            ((0, 0), [0.250006, 0.450004, 0.899999]),
            ((10, 20), [0.260312, 0.456346, 0.898414]),
            ((153, 60), [399.998, 359.999, 299.999]),
            ((100, 128), [0.18, 0.15, 0.12]),
            ((300, 1), [0.250055, 0.450034, 0.899992]),
        ];
        for ((x, y), want) in at_pixels {
            let d = uv_dir((x as f64 + 0.5) / 512.0, y as f64 / 255.0);
            let got = e.eval_direction(d);
            assert!(
                close(got, want, 1e-4),
                "pixel ({x}, {y}): {got:?} vs {want:?}"
            );
        }
        let dirs = [
            (Vec3::new(0.0, 1.0, 0.0), [0.250006, 0.450004, 0.899999]),
            (Vec3::new(0.0, -1.0, 0.0), [0.18, 0.15, 0.12]),
            (Vec3::new(1.0, 0.0, 0.0), [0.514542, 0.484334, 0.463917]),
            (Vec3::new(0.0, 0.0, 1.0), [0.514542, 0.484334, 0.463917]),
            (Vec3::new(0.3, 0.5, -0.2), [0.315389, 0.490239, 0.88994]),
            (Vec3::new(-0.7, 0.1, 0.4), [0.672467, 0.70998, 0.835005]),
        ];
        for (d, want) in dirs {
            let got = e.eval_direction(d.normalize());
            assert!(close(got, want, 1e-4), "{d}: {got:?} vs {want:?}");
        }
        // sky_soft.exr (no sun).
        let Some(e) = envmap("sky_soft.exr", 1.0, Mat4::IDENTITY) else {
            return;
        };
        for (d, want) in [
            (Vec3::new(0.64, 0.74, 0.21), [0.341861, 0.50653, 0.885867]),
            (Vec3::new(0.0, 0.2, 1.0), [0.61274, 0.673224, 0.844194]),
            (Vec3::new(0.1, -0.9, 0.3), [0.18, 0.15, 0.12]),
        ] {
            let got = e.eval_direction(d.normalize());
            assert!(close(got, want, 1e-4), "soft {d}: {got:?} vs {want:?}");
        }
    }

    #[test]
    fn envmap_to_world_and_scale_match_mitsuba() {
        // Mitsuba 3.9.1: scale 2.5, to_world = rotate(y, 90°)·rotate(x, −30°).
        let m =
            Mat4::from_rotation_y(90f32.to_radians()) * Mat4::from_rotation_x(-30f32.to_radians());
        let Some(e) = envmap("sky.exr", 2.5, m) else {
            return;
        };
        for (d, want) in [
            (Vec3::new(0.3, 0.5, -0.2), [1.15095, 1.44866, 2.16908]),
            (Vec3::new(-0.7, 0.1, 0.4), [1.06083, 1.3932, 2.18295]),
            (Vec3::new(0.64, 0.74, 0.21), [1.33156, 1.55981, 2.1413]),
            (Vec3::new(0.1, -0.9, 0.3), [0.45, 0.375, 0.3]),
            (Vec3::new(0.0, 0.2, 1.0), [1.58171, 1.71374, 2.10281]),
        ] {
            let got = e.eval_direction(d.normalize());
            assert!(close(got, want, 2e-4), "{d}: {got:?} vs {want:?}");
        }
        check_sampling(&e, 11);
    }

    /// ∫ pdf dω and ∫ L dω over the sphere. The pdf is integrated on a (u, cos θ) grid aligned
    /// with the sampling cells (exact for a per-cell constant), the radiance on a (u, v) grid
    /// aligned with the lookup's cells (8 × 8 midpoints each; smooth per piece).
    fn integrals(env: &Envmap) -> (f64, [f64; 3]) {
        let (w, h) = (env.width, env.height);
        let (nu, sub) = (8 * w, 8);
        let mut pdf = 0.0f64;
        for j in 0..h - 1 {
            let (z1, z0) = (env.cos_theta[j] as f64, env.cos_theta[j + 1] as f64);
            for k in 0..sub {
                let z = z0 + (z1 - z0) * (k as f64 + 0.5) / sub as f64;
                let r = (1.0 - z * z).max(0.0).sqrt();
                for a in 0..nu {
                    let phi = 2.0 * std::f64::consts::PI * (a as f64 + 0.5) / nu as f64;
                    let d = Vec3::new((phi.sin() * r) as f32, z as f32, (-phi.cos() * r) as f32);
                    let dw = 2.0 * std::f64::consts::PI / nu as f64 * (z1 - z0) / sub as f64;
                    pdf += env.pdf(env.to_world * d) as f64 * dw;
                }
            }
        }
        let nv = 8 * (h - 1);
        let mut l = [0.0f64; 3];
        for b in 0..nv {
            let v = (b as f64 + 0.5) / nv as f64;
            let jac = 2.0 * std::f64::consts::PI.powi(2) * (v * std::f64::consts::PI).sin();
            for a in 0..nu {
                let u = (a as f64 + 0.5) / nu as f64;
                let r = env.eval(env.to_world * uv_dir(u, v));
                for c in 0..3 {
                    l[c] += r[c] as f64 * jac / (nu * nv) as f64;
                }
            }
        }
        (pdf, l)
    }

    /// Length of the overlap of [a0, a1] with [b0, b1].
    fn overlap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
        (a1.min(b1) - a0.max(b0)).max(0.0)
    }

    /// Sample/pdf consistency, a histogram (χ²) test and an unbiasedness test.
    fn check_sampling(e: &Emitter, seed: u64) {
        let Emitter::Envmap(env) = e else {
            unreachable!()
        };
        let (w, h) = (env.width, env.height);
        let (integral, reference) = integrals(env);
        assert!((integral - 1.0).abs() < 1e-4, "∫ pdf = {integral}");

        let mut rng = Pcg32::new(seed, 3);
        let n = 400_000;
        // Histogram over equal-area bins of the local (u, z = cos θ).
        let (bu, bv) = (24usize, 12usize);
        let mut hist = vec![0u32; bu * bv];
        let mut mismatched = 0;
        let mut est = [0f64; 3];
        for _ in 0..n {
            let s = e
                .sample_direction(Vec3::new(1.0, 2.0, 3.0), rng.next_vec2())
                .unwrap();
            assert!(s.pdf > 0.0 && s.dist == f32::INFINITY && !s.is_delta);
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            let p = e.pdf_direction(s.wi);
            let l = e.eval_direction(s.wi);
            let (l2, p2) = e.eval_pdf_direction(s.wi);
            assert_eq!(
                (l.0.map(f32::to_bits), p.to_bits()),
                (l2.0.map(f32::to_bits), p2.to_bits())
            );
            if (p - s.pdf).abs() > 1e-3 * s.pdf || !close(l, s.radiance.0, 1e-3) {
                mismatched += 1;
            }
            for (c, acc) in est.iter_mut().enumerate() {
                *acc += (s.radiance[c] / s.pdf) as f64;
            }
            let d = (env.to_local * s.wi).normalize();
            let u = Envmap::direction_to_uv(d).x;
            let a = ((u - u.floor()) * bu as f32) as usize;
            let b = ((1.0 - d.y.clamp(-1.0, 1.0)) * 0.5 * bv as f32) as usize;
            hist[b.min(bv - 1) * bu + a.min(bu - 1)] += 1;
        }
        // Samples on cell boundaries may round into the neighbouring cell.
        assert!(
            mismatched < n / 1000,
            "{mismatched} samples disagree with pdf/eval"
        );

        // Expected bin masses, exactly: each cell is a rectangle in (u, z) with uniform density.
        let mut expect = vec![0f64; bu * bv];
        for j in 0..h - 1 {
            let (z1, z0) = (env.cos_theta[j] as f64, env.cos_theta[j + 1] as f64);
            let omega = 2.0 * std::f64::consts::PI / w as f64 * (z1 - z0);
            for i in 0..w {
                let mass = env.cell_pdf(j * w + i) as f64 * omega;
                if mass == 0.0 {
                    continue;
                }
                let (u0, u1) = ((i as f64 + 0.5) / w as f64, (i as f64 + 1.5) / w as f64);
                for b in 0..bv {
                    let (bz1, bz0) = (
                        1.0 - 2.0 * b as f64 / bv as f64,
                        1.0 - 2.0 * (b + 1) as f64 / bv as f64,
                    );
                    let fz = overlap(z0, z1, bz0, bz1) / (z1 - z0);
                    if fz == 0.0 {
                        continue;
                    }
                    for a in 0..bu {
                        let (a0, a1) = (a as f64 / bu as f64, (a + 1) as f64 / bu as f64);
                        let fu = (overlap(u0, u1, a0, a1) + overlap(u0 - 1.0, u1 - 1.0, a0, a1))
                            * w as f64;
                        expect[b * bu + a] += mass * fz * fu;
                    }
                }
            }
        }
        let mut chi2 = 0.0;
        let mut dof = 0.0f64;
        for (k, (&o, &p)) in hist.iter().zip(&expect).enumerate() {
            let ex = p * n as f64;
            assert!(
                (o as f64 - ex).abs() < 6.0 * ex.sqrt() + 3.0,
                "bin {k}: {o} vs {ex:.1}"
            );
            if ex > 5.0 {
                chi2 += (o as f64 - ex).powi(2) / ex;
                dof += 1.0;
            }
        }
        assert!(
            chi2 < dof + 5.0 * (2.0 * dof).sqrt(),
            "χ² = {chi2} ({dof} bins)"
        );

        // E[L/pdf] = ∫ L dω.
        for c in 0..3 {
            let mc = est[c] / n as f64;
            assert!(
                (mc / reference[c] - 1.0).abs() < 0.01,
                "channel {c}: {mc} vs {}",
                reference[c]
            );
        }
    }

    #[test]
    fn envmap_sampling_is_consistent_and_finds_the_sun() {
        let Some(e) = envmap("sky.exr", 1.0, Mat4::IDENTITY) else {
            return;
        };
        check_sampling(&e, 1);
        // The sun (a few very bright pixels, < 0.1 % of the sphere) carries a large part of
        // the power; sampling sends that part of the samples into its cells.
        let Emitter::Envmap(env) = &e else {
            unreachable!()
        };
        let (w, h) = (env.width, env.height);
        let bright = |j: usize, i: usize| {
            [(j, i), (j, i + 1), (j + 1, i), (j + 1, i + 1)]
                .iter()
                .any(|&(y, x)| env.texel(y * (w + 1) + x).luminance() > 10.0)
        };
        let (mut sun_mass, mut sun_area) = (0.0f64, 0.0f64);
        for j in 0..h - 1 {
            let omega = 2.0 * std::f64::consts::PI / w as f64
                * (env.cos_theta[j] - env.cos_theta[j + 1]) as f64;
            for i in 0..w {
                if bright(j, i) {
                    sun_mass += env.cell_pdf(j * w + i) as f64 * omega;
                    sun_area += omega / (4.0 * std::f64::consts::PI);
                }
            }
        }
        assert!(
            sun_area < 1e-3 && sun_mass > 0.2,
            "sun: area {sun_area}, mass {sun_mass}"
        );
        let mut rng = Pcg32::new(7, 0);
        let n = 20_000;
        let hits = (0..n)
            .filter(|_| {
                let s = e.sample_direction(Vec3::ZERO, rng.next_vec2()).unwrap();
                let c = env.cell(env.to_local * s.wi);
                bright(c / w, c % w)
            })
            .count();
        let frac = hits as f64 / n as f64;
        assert!(
            (frac - sun_mass).abs() < 0.02,
            "{frac} of samples hit the sun, expected {sun_mass}"
        );
        if let Some(soft) = envmap("sky_soft.exr", 1.0, Mat4::IDENTITY) {
            check_sampling(&soft, 2);
        }
    }

    /// The prefetch's coarse cell is the lookup's cell, or a neighbour of it, for directions
    /// all over the sphere (a rotated 1024 × 512 map; poles, the seam and axes included).
    #[test]
    fn envmap_coarse_cell_is_the_lookup_cell_or_a_neighbour() {
        let (w, h) = (1024usize, 512usize);
        let img = Image {
            width: w,
            height: h,
            channels: 1,
            data: (0..w * h).map(|i| (i % 7) as f32 + 0.5).collect(),
        };
        let to_world = Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(0.3);
        let e = Envmap::new(&img, false, 1.0, &to_world).unwrap();
        let mut dirs = vec![Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
        let mut rnd = lcg(7);
        for _ in 0..200_000 {
            let (z, phi) = (2.0 * rnd() - 1.0, 2.0 * PI * rnd());
            let r = (1.0 - z * z).max(0.0).sqrt();
            dirs.push(Vec3::new(r * phi.cos(), z, r * phi.sin()));
        }
        let (mut exact, mut off) = (0, 0);
        for d in dirs {
            let want = e.bilinear_cell(Envmap::direction_to_uv(e.local(d))).0;
            let got = e.coarse_cell(d);
            let (wx, wy) = (want % (w + 1), want / (w + 1));
            let (gx, gy) = (got % (w + 1), got / (w + 1));
            let dx = wx.abs_diff(gx).min(w - wx.abs_diff(gx));
            assert!(
                dx <= 1 && wy.abs_diff(gy) <= 1,
                "{d:?}: ({wx}, {wy}) vs ({gx}, {gy})"
            );
            if got == want {
                exact += 1;
            } else {
                off += 1;
            }
        }
        // measured: 99.5 % exact
        assert!(exact > 50 * off, "{exact} exact, {off} off by one");
    }

    #[test]
    fn envmap_from_small_image_and_black_map() {
        let img = Image {
            width: 4,
            height: 3,
            channels: 1,
            data: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 0.0, 0.0, 0.0, 0.0],
        };
        let e = Emitter::Envmap(Box::new(
            Envmap::new(&img, false, 1.0, &Mat4::IDENTITY).unwrap(),
        ));
        // Pixel (1, 1) sits at u = 1.5/4, on the horizon.
        let got = e.eval_direction(uv_dir(1.5 / 4.0, 0.5));
        assert!(close(got, [6.0; 3], 1e-5), "{got:?}");
        // Halfway between pixels (3, 1) and the wrapped (0, 1).
        let got = e.eval_direction(uv_dir(0.0, 0.5));
        assert!(close(got, [6.5; 3], 1e-5), "{got:?}");
        check_sampling(&e, 5);

        // Black bottom rows: the last cell rows are empty and must never be drawn.
        let mut data = vec![0.0; 16];
        data[..4].copy_from_slice(&[1.0, 2.0, 3.0, 4.0]);
        let img = Image {
            width: 4,
            height: 4,
            channels: 1,
            data,
        };
        let e = Emitter::Envmap(Box::new(
            Envmap::new(&img, false, 1.0, &Mat4::IDENTITY).unwrap(),
        ));
        for u in [0.0, 0.5, 1.0 - f32::EPSILON / 2.0] {
            let s = e.sample_direction(Vec3::ZERO, Vec2::new(u, u)).unwrap();
            assert!(s.pdf > 0.0 && s.wi.y > 0.49, "{s:?}");
        }
        check_sampling(&e, 6);

        let black = Image {
            width: 4,
            height: 3,
            channels: 3,
            data: vec![0.0; 36],
        };
        let e = Emitter::Envmap(Box::new(
            Envmap::new(&black, false, 1.0, &Mat4::IDENTITY).unwrap(),
        ));
        assert!(e.sample_direction(Vec3::ZERO, Vec2::splat(0.5)).is_none());
        assert_eq!(e.pdf_direction(Vec3::Y), 0.0);

        // A very dark map (subnormal values, black bottom row) samples as its bright twin: the
        // density scale W / (2π Σ weights) is about 3e39, beyond f32, and must not overflow
        // (subnormal values carry ~1e-4 and their luminance ~2e-3 relative rounding).
        let bright: Vec<f32> = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 0.0, 0.0, 0.0, 0.0];
        let [b, d] = [1.0f32, 1e-41].map(|k| {
            let img = Image {
                width: 4,
                height: 3,
                channels: 1,
                data: bright.iter().map(|v| v * k).collect(),
            };
            Emitter::Envmap(Box::new(
                Envmap::new(&img, false, 1.0, &Mat4::IDENTITY).unwrap(),
            ))
        });
        let mut rng = Pcg32::new(3, 1);
        for _ in 0..200 {
            let dir = square_to_uniform_sphere(rng.next_vec2());
            let (pb, pd) = (b.pdf_direction(dir), d.pdf_direction(dir));
            assert!(
                pd.is_finite() && (pd - pb).abs() <= 1e-2 * pb,
                "{dir}: {pd} vs {pb}"
            );
        }
        check_sampling(&d, 7);
        assert!(Envmap::new(
            &Image {
                width: 2,
                height: 2,
                channels: 1,
                data: vec![1.0; 4]
            },
            false,
            1.0,
            &Mat4::IDENTITY
        )
        .is_err());
        let missing =
            Emitter::envmap_from_file(Path::new("/nonexistent/env.exr"), 1.0, &Mat4::IDENTITY);
        assert!(missing.unwrap_err().to_string().contains("env.exr"));
    }

    #[test]
    fn delta_lights_match_mitsuba() {
        // Mitsuba 3.9.1: point at (1, 2, 3), intensity (10, 20, 30), seen from the origin:
        // d = (0.267261, 0.534522, 0.801784), dist 3.74166, weight (0.714286, 1.42857, 2.14286).
        let p = Emitter::point(Vec3::new(1.0, 2.0, 3.0), Rgb::new(10.0, 20.0, 30.0));
        let s = p.sample_direction(Vec3::ZERO, Vec2::splat(0.5)).unwrap();
        assert!((s.wi - Vec3::new(0.267261, 0.534522, 0.801784)).length() < 1e-5);
        assert!((s.dist - 3.741_657).abs() < 1e-5);
        assert!(close(s.radiance, [0.714286, 1.42857, 2.14286], 1e-5));
        assert!(s.is_delta && s.pdf == 1.0 && p.is_delta() && !p.is_infinite());
        assert_eq!(p.eval_direction(s.wi), Rgb::ZERO);
        assert_eq!(p.pdf_direction(s.wi), 0.0);
        assert!(p
            .sample_direction(Vec3::new(1.0, 2.0, 3.0), Vec2::ZERO)
            .is_none());
        let q = Emitter::point_from_to_world(
            &Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)),
            Rgb::ONE,
        );
        assert!(matches!(q, Emitter::Point(l) if l.position == Vec3::new(1.0, 2.0, 3.0)));

        // directional, direction (0, −1, −1), irradiance (1, 2, 3): d = (0, 0.707107, 0.707107).
        let d = Emitter::directional(Vec3::new(0.0, -1.0, -1.0), Rgb::new(1.0, 2.0, 3.0));
        let s = d
            .sample_direction(Vec3::new(5.0, 5.0, 5.0), Vec2::ZERO)
            .unwrap();
        assert!((s.wi - Vec3::new(0.0, FRAC_1_SQRT_2, FRAC_1_SQRT_2)).length() < 1e-5);
        assert_eq!(
            (s.radiance, s.pdf, s.dist),
            (Rgb::new(1.0, 2.0, 3.0), 1.0, f32::INFINITY)
        );
        assert!(s.is_delta && d.is_delta() && !d.is_infinite());
        // to_world maps local +z onto the travel direction.
        let m = Mat4::from_rotation_x(90f32.to_radians());
        let d2 = Emitter::directional_from_to_world(&m, Rgb::ONE);
        let s = d2.sample_direction(Vec3::ZERO, Vec2::ZERO).unwrap();
        assert!((s.wi - Vec3::Y).length() < 1e-6, "{}", s.wi);
    }

    fn node(body: &str) -> Result<Emitter> {
        let text = format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n");
        let root = crate::xml::parse_scene_str(&text, "test.xml", Path::new("."), &[])?;
        Emitter::from_node(&root.children[0], &specula_testdata::root().join("scenes"))
    }

    /// A `<spectrum>` value is kept for spectral mode beside its RGB value (RGB mode reads
    /// only the latter); `<rgb>` values and `envmap` have none; a negative emission spectrum
    /// is an error at the property.
    #[test]
    fn spectrum_values_are_kept_for_spectral_mode() {
        let w = specula_bsdf::Wavelengths([450.0, 500.0, 700.0]);
        for (xml, want) in [
            (
                r#"<emitter type="point"><spectrum name="intensity" value="400:0.2, 500:1.5, 600:0.3"/></emitter>"#,
                [0.85, 1.5, 0.0],
            ),
            (
                r#"<emitter type="directional"><spectrum name="irradiance" value="0.5"/></emitter>"#,
                [0.5; 3],
            ),
            (
                r#"<emitter type="constant"><spectrum name="radiance" type="uniform"><float name="value" value="2"/></spectrum></emitter>"#,
                [2.0; 3],
            ),
            (
                r#"<emitter type="spot"><spectrum name="intensity" value="400:1, 800:1"/></emitter>"#,
                [1.0; 3],
            ),
            (
                r#"<emitter type="projector"><spectrum name="irradiance" value="400:3, 800:3"/></emitter>"#,
                [3.0; 3],
            ),
        ] {
            let e = node(xml).unwrap();
            let (curve, rgb) = e.spectrum().unwrap_or_else(|| panic!("{xml}"));
            let v = curve.eval_at(&w);
            for (x, y) in v.0.iter().zip(want) {
                assert!((x - y).abs() < 1e-6, "{xml}: {v:?}");
            }
            // the RGB value RGB mode uses is the converted spectrum's
            assert!(rgb.max_component() > 0.0, "{xml}");
        }
        let e = node(r#"<emitter type="point"><rgb name="intensity" value="1, 2, 3"/></emitter>"#);
        assert!(e.unwrap().spectrum().is_none());
        let e = node(
            r#"<emitter type="point">
                <spectrum name="intensity" value="400:1, 500:-0.5, 600:1"/></emitter>"#,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("test.xml:3:17") && e.contains("non-negative"),
            "{e}"
        );
    }

    #[test]
    fn builds_from_xml_nodes() {
        let e = node(r#"<emitter type="point"><point name="position" value="1, 2, 3"/><rgb name="intensity" value="10, 20, 30"/></emitter>"#).unwrap();
        assert!(
            matches!(e, Emitter::Point(l) if l.position == Vec3::new(1.0, 2.0, 3.0) && l.intensity == Rgb::new(10.0, 20.0, 30.0))
        );
        let e = node(r#"<emitter type="point"><transform name="to_world"><translate x="4"/></transform></emitter>"#).unwrap();
        assert!(
            matches!(e, Emitter::Point(l) if l.position == Vec3::new(4.0, 0.0, 0.0) && l.intensity == Rgb::ONE)
        );
        // a constant emission spectrum is 3 · XYZ→sRGB(1, 1, 1) in Mitsuba 3.9's RGB variants
        let e = node(r#"<emitter type="directional"><vector name="direction" value="0, 0, -2"/><spectrum name="irradiance" value="3"/></emitter>"#).unwrap();
        let want = Rgb::new(3.6143818, 2.844873, 2.7267482);
        assert!(
            matches!(&e, Emitter::Directional(l) if l.direction == -Vec3::Z && (0..3).all(|k| (l.irradiance.0[k] / want.0[k] - 1.0).abs() < 1e-6)),
            "{e:?}"
        );
        let e = node(
            r#"<emitter type="constant"><rgb name="radiance" value="0.25, 0.27, 0.3"/></emitter>"#,
        )
        .unwrap();
        assert!(matches!(e, Emitter::Constant(l) if l.radiance == Rgb::new(0.25, 0.27, 0.3)));
        let err = node(r#"<emitter type="constant"><rgb name="radiant" value="1"/></emitter>"#)
            .unwrap_err();
        assert!(
            err.to_string().contains("radiant") && err.loc.is_some(),
            "{err}"
        );
        let err = node(r#"<emitter type="sunsky"/>"#).unwrap_err();
        assert!(err.to_string().contains("not supported"), "{err}");
        let err = node(
            r#"<emitter type="envmap"><string name="filename" value="assets/none.exr"/></emitter>"#,
        )
        .unwrap_err();
        assert!(
            err.to_string().contains("none.exr") && err.loc.is_some(),
            "{err}"
        );
        if asset("sky.exr").is_some() {
            let e = node(r#"<emitter type="envmap"><string name="filename" value="assets/sky.exr"/><float name="scale" value="2"/></emitter>"#).unwrap();
            let got = e.eval_direction(Vec3::Y);
            assert!(close(got, [0.500012, 0.900008, 1.799998], 1e-4), "{got:?}");
            assert!(e.is_infinite() && !e.is_delta());
        }
    }

    #[test]
    fn constant_samples_the_sphere_uniformly() {
        // Mitsuba 3.9.1: pdf 0.0795775 = 1/4π, weight = radiance/pdf.
        let c = Emitter::constant(Rgb::new(0.25, 0.27, 0.3));
        let mut rng = Pcg32::new(9, 9);
        let mut mean = Vec3::ZERO;
        for _ in 0..10_000 {
            let s = c.sample_direction(Vec3::ZERO, rng.next_vec2()).unwrap();
            assert!((s.pdf - 0.079_577_47).abs() < 1e-7);
            assert_eq!(s.pdf, c.pdf_direction(s.wi));
            assert_eq!(s.radiance, c.eval_direction(s.wi));
            assert!((s.wi.length() - 1.0).abs() < 1e-5 && s.dist == f32::INFINITY);
            mean += s.wi;
        }
        assert!((mean / 10_000.0).length() < 0.03);
        assert!(!c.is_delta() && c.is_infinite());
    }

    /// A 2×2 nearest-neighbour texture: red, green / blue, white (top row first), or a
    /// constant w×h one.
    fn tex(w: usize, h: usize) -> Arc<dyn Texture> {
        use crate::texture::{Bitmap, FilterType, WrapMode};
        let data = if (w, h) == (2, 2) {
            vec![1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.]
        } else {
            vec![1.0; w * h * 3]
        };
        let img = Image {
            width: w,
            height: h,
            channels: 3,
            data,
        };
        Arc::new(Bitmap::from_image(
            &img,
            false,
            FilterType::parse("nearest").unwrap(),
            WrapMode::parse("repeat").unwrap(),
            false,
            Mat3::IDENTITY,
        ))
    }

    fn at(e: &Emitter, p: [f32; 3]) -> Rgb {
        e.sample_direction(Vec3::from(p), Vec2::splat(0.5))
            .map_or(Rgb::ZERO, |s| {
                assert!(s.is_delta && s.pdf == 1.0);
                assert!((s.wi * s.dist + Vec3::from(p) - e_position(e)).length() < 1e-5);
                s.radiance
            })
    }

    fn e_position(e: &Emitter) -> Vec3 {
        match e {
            Emitter::Spot(l) => l.position,
            Emitter::Projector(l) => l.position,
            _ => unreachable!(),
        }
    }

    #[test]
    fn spot_matches_mitsuba() {
        // Mitsuba 3.9.1 scalar_rgb: spot at the origin along +z, intensity (1, 2, 3), cutoff
        // 30° (beam 22.5°), seen from distance 2 at angle θ: sample_direction's weight.
        let e = node(r#"<emitter type="spot"><rgb name="intensity" value="1, 2, 3"/><float name="cutoff_angle" value="30"/></emitter>"#).unwrap();
        assert!(e.is_delta() && !e.is_infinite());
        for (deg, want) in [
            (0.0f32, [0.25, 0.5, 0.75]),
            (20.0, [0.25, 0.5, 0.75]),
            (22.5, [0.25, 0.5, 0.75]),
            (25.0, [0.166667, 0.333334, 0.500001]),
            (29.0, [0.0333335, 0.066667, 0.1]),
            (29.9, [0.00333336, 0.00666672, 0.0100001]),
            (30.0, [0.0; 3]),
            (31.0, [0.0; 3]),
        ] {
            let t = deg.to_radians();
            let got = at(&e, [2.0 * t.sin(), 0.0, 2.0 * t.cos()]);
            assert!(close(got, want, 2e-4), "{deg}: {got:?}");
        }
        // the 1/dist² is in world units: translate (1, 0, 0) · scale 2, seen from (1, 0, 2)
        let e = node(r#"<emitter type="spot"><transform name="to_world"><scale value="2"/><translate x="1"/></transform></emitter>"#).unwrap();
        assert!(close(at(&e, [1.0, 0.0, 2.0]), [0.25; 3], 1e-5));
        // a negative beam_width (which Mitsuba takes as a falloff starting before 0°) is refused
        let e = node(r#"<emitter type="spot"><float name="beam_width" value="-5"/></emitter>"#);
        assert!(e.unwrap_err().to_string().contains("beam_width"));
        // textured: uv = ½ + ½ (x, y) / (z tan cutoff), no flip
        let spot = SpotLight::new(&Mat4::IDENTITY, Rgb::ONE, 30.0, 22.5, Some(tex(2, 2))).unwrap();
        let e = Emitter::Spot(Box::new(spot));
        for (p, want) in [
            ([0.3, 0.3, 1.0], [0.792119; 3]),
            ([-0.3, 0.3, 1.0], [0.0, 0.0, 0.792119]),
            ([0.3, -0.3, 1.0], [0.0, 0.792119, 0.0]),
            ([-0.3, -0.3, 1.0], [0.792119, 0.0, 0.0]),
            ([0.5, 0.0, 1.0], [0.366396; 3]),
        ] {
            assert!(close(at(&e, p), want, 2e-5), "{p:?}: {:?}", at(&e, p));
        }
    }

    #[test]
    fn projector_matches_mitsuba() {
        // Mitsuba 3.9.1 scalar_rgb: projector at the origin along +z; weights of
        // sample_direction from the given points.
        let proj = |texture, irradiance: Rgb, scale: f32, fov: f32, aspect: f32, m: Mat4| {
            let t =
                crate::camera::tan_half_fov_x(fov as f64, crate::camera::FovAxis::X, aspect as f64)
                    as f32;
            Emitter::Projector(Box::new(
                ProjectorLight::new(&m, irradiance, texture, scale, t, aspect).unwrap(),
            ))
        };
        let e = proj(Some(tex(2, 2)), Rgb::ONE, 1.0, 40.0, 1.0, Mat4::IDENTITY);
        assert!(e.is_delta() && !e.is_infinite());
        for (p, want) in [
            ([0.3, 0.2, 1.0], [3.33956, 0.0, 0.0]),
            ([-0.3, 0.2, 1.0], [0.0, 3.33956, 0.0]),
            ([0.3, -0.2, 1.0], [0.0, 0.0, 3.33956]),
            ([-0.3, -0.2, 1.0], [3.33956; 3]),
            ([0.0, 0.0, 1.0], [PI; 3]),
            ([0.0, 0.0, 2.0], [std::f32::consts::FRAC_PI_4; 3]),
            ([0.5, 0.0, 1.0], [0.0; 3]),
            ([0.0, 0.0, -1.0], [0.0; 3]),
            ([0.36, 0.0, 1.0], [0.0, 0.0, 3.33897]),
            ([0.37, 0.0, 1.0], [0.0; 3]),
        ] {
            assert!(close(at(&e, p), want, 2e-5), "{p:?}: {:?}", at(&e, p));
        }
        let e = proj(
            None,
            Rgb::new(1.0, 2.0, 3.0),
            2.0,
            40.0,
            1.0,
            Mat4::IDENTITY,
        );
        assert!(close(
            at(&e, [0.2, 0.1, 1.0]),
            [6.43835, 12.8767, 19.315],
            2e-5
        ));
        // a 30×10 image: the aspect ratio narrows the vertical field of view
        let e = proj(Some(tex(30, 10)), Rgb::ONE, 1.0, 40.0, 3.0, Mat4::IDENTITY);
        assert!(close(at(&e, [0.2, 0.1, 1.0]), [3.21917; 3], 2e-5));
        assert_eq!(at(&e, [0.0, 0.2, 1.0]), Rgb::ZERO);
        // a scaled to_world: Mitsuba's unnormalised normal and local depth
        let m = Mat4::from_scale(Vec3::splat(2.0));
        let e = proj(None, Rgb::ONE, 1.0, 40.0, 1.0, m);
        assert!(close(at(&e, [0.2, 0.1, 1.0]), [6.43835; 3], 2e-5));
        // from XML: focal length 35 mm on a 30×10 image, translated and rotated
        let root = crate::xml::parse_scene_str(
            r#"<scene version="3.0.0"><emitter type="projector"><string name="focal_length" value="35mm"/><transform name="to_world"><rotate y="1" angle="30"/><translate x="1" y="2" z="3"/></transform></emitter></scene>"#,
            "test.xml",
            Path::new("."),
            &[],
        )
        .unwrap();
        let textures = [NamedTexture {
            name: "irradiance".into(),
            texture: tex(30, 10),
            loc: Loc::default(),
        }];
        let e = Emitter::from_node_textured(&root.children[0], Path::new("."), &textures).unwrap();
        assert!(close(at(&e, [1.5, 2.1, 4.0]), [2.53696; 3], 2e-5));
        // a texture under another name is an error at that texture
        let bad = [NamedTexture {
            name: "radiance".into(),
            texture: tex(2, 2),
            loc: Loc {
                file: "x.xml".into(),
                line: 3,
                col: 4,
            },
        }];
        let err = Emitter::from_node_textured(&root.children[0], Path::new("."), &bad).unwrap_err();
        assert!(
            err.to_string().contains("x.xml:3:4") && err.to_string().contains("irradiance"),
            "{err}"
        );
    }

    #[test]
    fn spot_and_projector_parameters_are_checked() {
        for (body, want) in [
            (
                r#"<emitter type="spot"><float name="cutoff_angle" value="0"/></emitter>"#,
                "cutoff_angle",
            ),
            (
                r#"<emitter type="spot"><float name="cutoff_angle" value="180"/></emitter>"#,
                "cutoff_angle",
            ),
            (
                r#"<emitter type="spot"><float name="cutoff"  value="10"/></emitter>"#,
                "cutoff",
            ),
            (
                r#"<emitter type="spot"><transform name="to_world"><scale value="0"/></transform></emitter>"#,
                "singular",
            ),
            (
                r#"<emitter type="projector"><float name="fov" value="30"/><string name="focal_length" value="50mm"/></emitter>"#,
                "not both",
            ),
            (
                r#"<emitter type="projector"><float name="fov" value="190"/></emitter>"#,
                "(0, 180)",
            ),
            (
                r#"<emitter type="projector"><float name="intensity" value="1"/></emitter>"#,
                "intensity",
            ),
        ] {
            let err = node(body).unwrap_err().to_string();
            assert!(
                err.contains(want) && err.contains("test.xml:2:"),
                "{body}: {err}"
            );
        }
        // a beam wider than the cutoff is a hard edge at the cutoff (as in Mitsuba)
        let e = node(r#"<emitter type="spot"><float name="cutoff_angle" value="20"/><float name="beam_width" value="25"/></emitter>"#).unwrap();
        let t = 19f32.to_radians();
        assert!(close(at(&e, [t.sin(), 0.0, t.cos()]), [1.0; 3], 1e-5));
    }
}
