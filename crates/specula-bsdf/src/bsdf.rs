//! The BSDF interface shared by every model.
//!
//! Directions are in the local shading frame (z = shading normal) and point away from the
//! surface. `wi` is the direction the path arrived from (towards the camera when tracing
//! radiance, Mitsuba's `si.wi`); `wo` is the other direction (towards the light).
//!
//! - [`BsdfModel::eval`] returns the BSDF value f(wi, wo) **without** the cosine factor
//!   (Mitsuba's `eval` includes |cosθo|; Specula keeps the textbook quantity, so a Lambertian
//!   surface returns ρ/π).
//! - [`BsdfModel::sample`] returns a direction with its solid-angle pdf and the weight
//!   f·|cosθo|/pdf; for Dirac lobes the pdf is the discrete probability of the chosen lobe.
//! - [`BsdfModel::pdf`] returns the solid-angle density of `sample` (0 for Dirac lobes).

use crate::spectrum::{Spectrum, Wavelengths};
use glam::{Vec2, Vec3};
use std::fmt;
use std::sync::Arc;

/// Whether radiance (from lights, traced from the camera) or importance (from the camera,
/// traced from lights) is being transported. Refraction scales radiance by (η_i/η_t)²;
/// importance is not scaled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TransportMode {
    #[default]
    Radiance,
    Importance,
}

/// Evaluation context.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BsdfContext {
    pub mode: TransportMode,
}

impl BsdfContext {
    pub const RADIANCE: BsdfContext = BsdfContext {
        mode: TransportMode::Radiance,
    };
    pub const IMPORTANCE: BsdfContext = BsdfContext {
        mode: TransportMode::Importance,
    };
}

/// A set of lobe kinds (bit flags): {diffuse, glossy, delta} × {reflection, transmission}.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct LobeFlags(pub u8);

impl LobeFlags {
    pub const NONE: LobeFlags = LobeFlags(0);
    pub const DIFFUSE_REFLECTION: LobeFlags = LobeFlags(1);
    pub const DIFFUSE_TRANSMISSION: LobeFlags = LobeFlags(2);
    pub const GLOSSY_REFLECTION: LobeFlags = LobeFlags(4);
    pub const GLOSSY_TRANSMISSION: LobeFlags = LobeFlags(8);
    pub const DELTA_REFLECTION: LobeFlags = LobeFlags(16);
    pub const DELTA_TRANSMISSION: LobeFlags = LobeFlags(32);
    /// Mitsuba's `Null`: light passes through unchanged (wo = −wi, weight 1), as through the
    /// transparent part of a `mask` or a `null` surface. A Dirac transmission lobe.
    pub const NULL: LobeFlags = LobeFlags(64);
    pub const REFLECTION: LobeFlags = LobeFlags(1 | 4 | 16);
    pub const TRANSMISSION: LobeFlags = LobeFlags(2 | 8 | 32 | 64);
    pub const DIFFUSE: LobeFlags = LobeFlags(1 | 2);
    pub const GLOSSY: LobeFlags = LobeFlags(4 | 8);
    pub const DELTA: LobeFlags = LobeFlags(16 | 32 | 64);
    pub const SMOOTH: LobeFlags = LobeFlags(1 | 2 | 4 | 8);

    #[inline]
    pub fn contains(self, o: LobeFlags) -> bool {
        self.0 & o.0 == o.0
    }
    #[inline]
    pub fn intersects(self, o: LobeFlags) -> bool {
        self.0 & o.0 != 0
    }
    #[inline]
    pub fn is_delta(self) -> bool {
        self.intersects(Self::DELTA)
    }
    /// True when every lobe is a Dirac delta (no `eval`/`pdf` contribution at all).
    #[inline]
    pub fn is_all_delta(self) -> bool {
        self.0 != 0 && self.0 & !Self::DELTA.0 == 0
    }
    #[inline]
    pub fn has_transmission(self) -> bool {
        self.intersects(Self::TRANSMISSION)
    }
}

impl std::ops::BitOr for LobeFlags {
    type Output = LobeFlags;
    fn bitor(self, o: LobeFlags) -> LobeFlags {
        LobeFlags(self.0 | o.0)
    }
}

impl fmt::Display for LobeFlags {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = [
            "diffuse-reflection",
            "diffuse-transmission",
            "glossy-reflection",
            "glossy-transmission",
            "delta-reflection",
            "delta-transmission",
            "null",
        ];
        let mut first = true;
        for (i, n) in names.iter().enumerate() {
            if self.0 & (1 << i) != 0 {
                if !first {
                    f.write_str("|")?;
                }
                f.write_str(n)?;
                first = false;
            }
        }
        if first {
            f.write_str("none")?;
        }
        Ok(())
    }
}

/// The result of [`BsdfModel::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Sampled direction (local frame).
    pub wo: Vec3,
    /// f·|cosθo| / pdf (for Dirac lobes: the lobe's value divided by its selection probability).
    pub weight: Spectrum,
    /// Solid-angle density, or the discrete probability of a Dirac lobe.
    pub pdf: f32,
    /// The lobe that produced the sample (exactly one flag).
    pub lobe: LobeFlags,
    /// Relative index of refraction η_t/η_i crossed by the sample (1 for reflection).
    pub eta: f32,
}

impl BsdfSample {
    /// The sample of direction `wo` from its value f (without the cosine) and density:
    /// weight f·|cosθo|/pdf; `None` where the density is not a positive finite number (the
    /// direction cannot be sampled).
    #[inline]
    pub fn from_value(
        wo: Vec3,
        value: Spectrum,
        pdf: f32,
        lobe: LobeFlags,
        eta: f32,
    ) -> Option<BsdfSample> {
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: value * (wo.z.abs() / pdf),
            pdf,
            lobe,
            eta,
        })
    }
}

/// Per-primitive data of the surface that was hit, for textures that read it (Mitsuba's
/// `mesh_attribute`): implemented by the renderer's meshes.
pub trait SurfaceData: Send + Sync + fmt::Debug {
    /// The attribute `name` (`vertex_…` or `face_…`) of primitive `prim` at barycentric
    /// coordinates `bary` = (b1, b2): vertex attributes interpolated, face attributes constant;
    /// a 1-channel attribute is returned in all three channels. `None` when the surface has no
    /// such attribute.
    fn attribute(&self, name: &str, prim: u32, bary: Vec2) -> Option<Spectrum>;
}

/// Where on a surface a BSDF is evaluated: what textured parameters are looked up with, and
/// the differential geometry that `bumpmap` needs.
///
/// `dp_du`, `dp_dv` and `n_geo` are expressed in the local shading frame (the frame the
/// directions given to a BSDF are in, shading normal +z). [`ShadingPoint::default`] is a flat
/// surface with the unit parameterisation of that frame (`dp_du` = x, `dp_dv` = y,
/// `n_geo` = z) and uv (0, 0): what `specula brdf check` evaluates materials at.
#[derive(Clone, Copy, Debug)]
pub struct ShadingPoint<'a> {
    /// Surface texture coordinates.
    pub uv: Vec2,
    /// World-space position (for procedural 3-D textures).
    pub p: Vec3,
    /// ∂p/∂u in the local shading frame (not normalised, not projected).
    pub dp_du: Vec3,
    /// ∂p/∂v in the local shading frame.
    pub dp_dv: Vec3,
    /// The unit geometric normal in the local shading frame (on the shape's front side).
    pub n_geo: Vec3,
    /// Index of the primitive (triangle) hit, and its barycentric coordinates (b1, b2).
    pub prim: u32,
    pub bary: Vec2,
    /// The shape's per-primitive data, when it has any.
    pub surface: Option<&'a dyn SurfaceData>,
    /// In spectral mode, the wavelengths (nm) that the channels of every [`Spectrum`] at this
    /// point stand for (channel 0 is the path's hero wavelength); `None` in RGB mode.
    pub wavelengths: Option<Wavelengths>,
}

impl Default for ShadingPoint<'_> {
    fn default() -> Self {
        ShadingPoint {
            uv: Vec2::ZERO,
            p: Vec3::ZERO,
            dp_du: Vec3::X,
            dp_dv: Vec3::Y,
            n_geo: Vec3::Z,
            prim: 0,
            bary: Vec2::ZERO,
            surface: None,
            wavelengths: None,
        }
    }
}

impl ShadingPoint<'_> {
    /// The flat default point at texture coordinates (u, v).
    pub fn at_uv(u: f32, v: f32) -> Self {
        ShadingPoint {
            uv: Vec2::new(u, v),
            ..Default::default()
        }
    }
}

/// A spatially varying parameter source, implemented by the renderer (bitmaps, checkerboards…).
pub trait Texture: Send + Sync + fmt::Debug {
    /// Colour at a shading point.
    fn eval(&self, sp: &ShadingPoint) -> Spectrum;
    /// Scalar value at a shading point (roughness maps, blend weights): luminance by default.
    fn eval_1(&self, sp: &ShadingPoint) -> f32 {
        self.eval(sp).luminance()
    }
    /// Average over the texture (used to balance lobe sampling probabilities).
    fn mean(&self) -> Spectrum;
    /// Resolution (width, height) of an image texture; (1, 1) for others (Mitsuba's
    /// `Texture::resolution`, which sets e.g. a `projector`'s aspect ratio).
    fn resolution(&self) -> (usize, usize) {
        (1, 1)
    }
    /// Gradient (∂/∂u, ∂/∂v) of [`Texture::eval_1`] in texture coordinates (Mitsuba's
    /// `eval_1_grad`, what `bumpmap` perturbs the normal with); `None` for textures that do not
    /// provide one (as in Mitsuba, only `bitmap` does).
    fn eval_1_grad(&self, _sp: &ShadingPoint) -> Option<Vec2> {
        None
    }
    /// Number of channels of the data (1 for a monochromatic bitmap, 3 otherwise).
    fn channels(&self) -> usize {
        3
    }
    /// The mesh attribute the texture reads (Mitsuba's `mesh_attribute`), so that a scene
    /// loader can check the shapes it is used on.
    fn mesh_attribute(&self) -> Option<&str> {
        None
    }
    /// In spectral mode, the texture's value at the wavelengths `w` when it holds spectra of
    /// its own (a `checkerboard` whose colours are `<spectrum>` values); `None` (the default)
    /// to have its RGB value upsampled like any other.
    fn eval_spectral(&self, _sp: &ShadingPoint, _w: &Wavelengths) -> Option<Spectrum> {
        None
    }
}

/// A spectrum known at every wavelength (a named conductor's measured η(λ) or k(λ), a
/// `<spectrum>` list): what [`SpectrumParam::Spectral`] evaluates in spectral mode.
pub trait SpectralCurve: Send + Sync + fmt::Debug {
    /// The value at wavelength `lambda` (nm).
    fn eval(&self, lambda: f32) -> f32;
    /// The values at the three wavelengths of a path (by default [`SpectralCurve::eval`] at
    /// each; a curve defined through an RGB upsampling evaluates all three at once).
    #[inline]
    fn eval_at(&self, w: &Wavelengths) -> Spectrum {
        Spectrum::new(self.eval(w.0[0]), self.eval(w.0[1]), self.eval(w.0[2]))
    }
}

/// A colour parameter: a constant or a texture, looked up per shading point.
///
/// In spectral mode (`sp.wavelengths` is `Some`), RGB constants and texture values are
/// upsampled to smooth spectra at the point's wavelengths
/// ([`crate::spectral::upsample::unbounded`]: a reflectance within [0, 1], a scaled one
/// above), and a [`SpectrumParam::Spectral`] curve is evaluated at them.
#[derive(Clone, Debug)]
pub enum SpectrumParam {
    Const(Spectrum),
    Texture(Arc<dyn Texture>),
    /// Known at every wavelength: `rgb` in RGB mode, `curve` at the wavelengths in spectral
    /// mode.
    Spectral {
        rgb: Spectrum,
        curve: Arc<dyn SpectralCurve>,
    },
}

impl SpectrumParam {
    #[inline]
    pub fn eval(&self, sp: &ShadingPoint) -> Spectrum {
        match self {
            SpectrumParam::Const(c) => match &sp.wavelengths {
                None => *c,
                Some(w) => crate::spectral::upsample::unbounded(*c, w),
            },
            SpectrumParam::Texture(t) => match &sp.wavelengths {
                None => t.eval(sp),
                Some(w) => t
                    .eval_spectral(sp, w)
                    .unwrap_or_else(|| crate::spectral::upsample::unbounded(t.eval(sp), w)),
            },
            SpectrumParam::Spectral { rgb, curve } => match &sp.wavelengths {
                None => *rgb,
                Some(w) => curve.eval_at(w),
            },
        }
    }
    pub fn mean(&self) -> Spectrum {
        match self {
            SpectrumParam::Const(c) => *c,
            SpectrumParam::Texture(t) => t.mean(),
            SpectrumParam::Spectral { rgb, .. } => *rgb,
        }
    }
    /// The RGB value of a parameter that does not vary over the surface (a constant, or a
    /// spectral curve's RGB-mode value); `None` for a texture.
    pub fn rgb_constant(&self) -> Option<Spectrum> {
        match self {
            SpectrumParam::Const(c) | SpectrumParam::Spectral { rgb: c, .. } => Some(*c),
            SpectrumParam::Texture(_) => None,
        }
    }
    pub fn is_const(&self) -> bool {
        matches!(self, SpectrumParam::Const(_))
    }
    /// Whether the value comes from a texture (which may read the shading point's uv);
    /// constants and spectra do not.
    pub fn is_texture(&self) -> bool {
        matches!(self, SpectrumParam::Texture(_))
    }
}

impl From<Spectrum> for SpectrumParam {
    fn from(s: Spectrum) -> Self {
        SpectrumParam::Const(s)
    }
}
impl From<f32> for SpectrumParam {
    fn from(s: f32) -> Self {
        SpectrumParam::Const(Spectrum::splat(s))
    }
}

/// A scalar parameter (roughness, blend weight): a constant or a texture.
#[derive(Clone, Debug)]
pub enum FloatParam {
    Const(f32),
    Texture(Arc<dyn Texture>),
}

impl FloatParam {
    #[inline]
    pub fn eval(&self, sp: &ShadingPoint) -> f32 {
        match self {
            FloatParam::Const(c) => *c,
            FloatParam::Texture(t) => t.eval_1(sp),
        }
    }
    pub fn mean(&self) -> f32 {
        match self {
            FloatParam::Const(c) => *c,
            FloatParam::Texture(t) => t.mean().luminance(),
        }
    }
    /// Whether the value comes from a texture (which may read the shading point's uv).
    pub fn is_texture(&self) -> bool {
        matches!(self, FloatParam::Texture(_))
    }
}

impl From<f32> for FloatParam {
    fn from(v: f32) -> Self {
        FloatParam::Const(v)
    }
}

/// The interface every material model implements. Implementations must not allocate.
pub trait BsdfModel {
    /// Which lobes the model has.
    fn flags(&self) -> LobeFlags;
    /// f(wi, wo) for the non-Dirac lobes (no cosine factor).
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum;
    /// Solid-angle density with which `sample` produces `wo` through its non-Dirac lobes.
    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32;
    /// Importance-sample a direction. `u1` picks a lobe, `u2` the direction within it.
    /// Returns `None` when no direction can be produced (e.g. `wi` below a one-sided surface).
    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample>;
    /// Whether `sample` reads `u1` at all (a model with one lobe does not): a renderer may
    /// then leave the value undrawn (its sampler still steps over the dimension, so the
    /// other dimensions keep their values). `true` unless the model says otherwise.
    #[inline]
    fn sample_reads_u1(&self) -> bool {
        true
    }
    /// Whether `sample` reads `u2` (a Dirac-only model does not), as [`Self::sample_reads_u1`].
    #[inline]
    fn sample_reads_u2(&self) -> bool {
        true
    }
    /// `eval` and `pdf` together (models that share work between them override this; a
    /// renderer needs both for multiple importance sampling).
    #[inline]
    fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        (self.eval(ctx, sp, wi, wo), self.pdf(ctx, sp, wi, wo))
    }
    /// f(wi, wo)·|cosθo|, what a renderer multiplies by incident radiance.
    #[inline]
    fn eval_cos(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval(ctx, sp, wi, wo) * wo.z.abs()
    }
}
