//! The material models, one file each, and the [`Bsdf`] enum that dispatches to them without
//! virtual calls or allocation.

pub mod blend;
pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod plastic;
pub mod roughconductor;
pub mod roughdielectric;
pub mod roughplastic;
pub mod sheen;
pub mod thindielectric;
pub mod twosided;

pub use blend::Blend;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use plastic::Plastic;
pub use roughconductor::RoughConductor;
pub use roughdielectric::RoughDielectric;
pub use roughplastic::RoughPlastic;
pub use sheen::Sheen;
pub use thindielectric::ThinDielectric;
pub use twosided::TwoSided;

use crate::bsdf::*;
use crate::fresnel::FresnelMode;
use crate::quad::gauss_legendre;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// Any Specula material.
#[derive(Clone, Debug)]
pub enum Bsdf {
    Diffuse(Diffuse),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    Dielectric(Dielectric),
    ThinDielectric(ThinDielectric),
    RoughDielectric(RoughDielectric),
    Plastic(Plastic),
    RoughPlastic(Box<RoughPlastic>),
    Sheen(Sheen),
    TwoSided(Box<TwoSided>),
    Blend(Box<Blend>),
}

macro_rules! dispatch {
    ($self:ident, $b:ident => $e:expr) => {
        match $self {
            Bsdf::Diffuse($b) => $e,
            Bsdf::Conductor($b) => $e,
            Bsdf::RoughConductor($b) => $e,
            Bsdf::Dielectric($b) => $e,
            Bsdf::ThinDielectric($b) => $e,
            Bsdf::RoughDielectric($b) => $e,
            Bsdf::Plastic($b) => $e,
            Bsdf::RoughPlastic($b) => $e,
            Bsdf::Sheen($b) => $e,
            Bsdf::TwoSided($b) => $e,
            Bsdf::Blend($b) => $e,
        }
    };
}

impl Bsdf {
    /// The Mitsuba plugin name of the model.
    pub fn plugin_name(&self) -> &'static str {
        match self {
            Bsdf::Diffuse(_) => "diffuse",
            Bsdf::Conductor(_) => "conductor",
            Bsdf::RoughConductor(_) => "roughconductor",
            Bsdf::Dielectric(_) => "dielectric",
            Bsdf::ThinDielectric(_) => "thindielectric",
            Bsdf::RoughDielectric(_) => "roughdielectric",
            Bsdf::Plastic(_) => "plastic",
            Bsdf::RoughPlastic(_) => "roughplastic",
            Bsdf::Sheen(_) => "sheen",
            Bsdf::TwoSided(_) => "twosided",
            Bsdf::Blend(_) => "blendbsdf",
        }
    }
}

impl BsdfModel for Bsdf {
    #[inline]
    fn flags(&self) -> LobeFlags {
        dispatch!(self, b => b.flags())
    }
    #[inline]
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        dispatch!(self, b => b.eval(ctx, sp, wi, wo))
    }
    #[inline]
    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        dispatch!(self, b => b.pdf(ctx, sp, wi, wo))
    }
    #[inline]
    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        dispatch!(self, b => b.sample(ctx, sp, wi, u1, u2))
    }
}

/// 2∫₀¹ F(μ) μ dμ for a Fresnel formula, by 256-point Gauss–Legendre quadrature.
pub(crate) fn hemispherical_fresnel(mode: FresnelMode, eta: f32) -> f32 {
    let (x, w) = gauss_legendre(256);
    let mut s = 0.0f64;
    for (x, w) in x.iter().zip(&w) {
        let mu = 0.5 * (x + 1.0);
        s += w * 0.5 * 2.0 * mu * mode.eval(mu as f32, eta).r as f64;
    }
    s as f32
}
