//! The material models, one file each, and the [`Bsdf`] enum that dispatches to them without
//! virtual calls or allocation.

mod albedo;
pub mod blend;
pub mod bumpmap;
pub mod conductor;
pub mod dielectric;
pub mod diffuse;
pub mod irawan;
pub mod mask;
pub mod microsurface_walk;
pub mod normalmap;
pub mod null;
pub mod perturbed;
pub mod plastic;
pub mod principled;
pub mod principledthin;
pub mod roughconductor;
pub mod roughdielectric;
pub mod roughplastic;
pub mod sheen;
pub mod thindielectric;
pub mod twosided;
pub mod velvet;

pub use blend::Blend;
pub use bumpmap::BumpMap;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use irawan::Irawan;
pub use mask::Mask;
pub use normalmap::NormalMap;
pub use null::Null;
pub use plastic::Plastic;
pub use principled::Principled;
pub use principledthin::PrincipledThin;
pub use roughconductor::RoughConductor;
pub use roughdielectric::RoughDielectric;
pub use roughplastic::RoughPlastic;
pub use sheen::Sheen;
pub use thindielectric::ThinDielectric;
pub use twosided::TwoSided;
pub use velvet::Velvet;

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
    /// Mitsuba's `principled` (the Disney BSDF).
    Principled(Box<Principled>),
    /// Mitsuba's `principledthin`.
    PrincipledThin(Box<PrincipledThin>),
    TwoSided(Box<TwoSided>),
    Blend(Box<Blend>),
    /// Mitsuba's `measured`: an RGL tensor file (Dupuy & Jakob 2018), shared between copies.
    Measured(std::sync::Arc<crate::measured::rgl::Rgl>),
    /// A MERL table (Matusik et al. 2003), Specula's `merl` plugin.
    Merl(crate::measured::merl::Merl),
    BumpMap(Box<BumpMap>),
    NormalMap(Box<NormalMap>),
    Mask(Box<Mask>),
    Null(Null),
    /// Irawan & Marschner's woven cloth (Mitsuba 0.6's `irawan`).
    Irawan(Box<Irawan>),
    /// Ashikhmin & Premože's distribution-based velvet (a Specula extension).
    Velvet(Velvet),
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
            Bsdf::Principled($b) => $e,
            Bsdf::PrincipledThin($b) => $e,
            Bsdf::TwoSided($b) => $e,
            Bsdf::Blend($b) => $e,
            Bsdf::Measured($b) => $e,
            Bsdf::Merl($b) => $e,
            Bsdf::BumpMap($b) => $e,
            Bsdf::NormalMap($b) => $e,
            Bsdf::Mask($b) => $e,
            Bsdf::Null($b) => $e,
            Bsdf::Irawan($b) => $e,
            Bsdf::Velvet($b) => $e,
        }
    };
}

impl Bsdf {
    /// Whether evaluating or sampling the model reads the shading point's local surface
    /// geometry ([`ShadingPoint::dp_du`], [`ShadingPoint::dp_dv`], [`ShadingPoint::n_geo`]):
    /// `bumpmap` does (its frame is built from them), and so does every model that nests one;
    /// no other model or texture reads them. A renderer may leave those three fields at their
    /// defaults for a model that answers false (it saves three frame changes per bounce).
    #[inline]
    pub fn reads_local_geometry(&self) -> bool {
        match self {
            Bsdf::BumpMap(_) => true,
            // one comparison for the common leaf models; the wrappers ask what they nest
            Bsdf::NormalMap(b) => Bsdf::any_reads_local_geometry(&[&b.nested]),
            Bsdf::Mask(b) => Bsdf::any_reads_local_geometry(&[&b.nested]),
            Bsdf::TwoSided(b) => Bsdf::any_reads_local_geometry(&[&b.front, &b.back]),
            Bsdf::Blend(b) => Bsdf::any_reads_local_geometry(&[&b.bsdfs[0], &b.bsdfs[1]]),
            Bsdf::Diffuse(_)
            | Bsdf::Conductor(_)
            | Bsdf::RoughConductor(_)
            | Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::RoughDielectric(_)
            | Bsdf::Plastic(_)
            | Bsdf::RoughPlastic(_)
            | Bsdf::Sheen(_)
            | Bsdf::Principled(_)
            | Bsdf::PrincipledThin(_)
            | Bsdf::Measured(_)
            | Bsdf::Merl(_)
            | Bsdf::Null(_)
            | Bsdf::Irawan(_)
            | Bsdf::Velvet(_) => false,
        }
    }

    /// Whether evaluating or sampling the model may read the shading point's uv
    /// ([`ShadingPoint::uv`]): false only for the models below whose parameters are all
    /// constants or spectra (no texture); every other model answers true, whatever its
    /// parameters. A renderer may leave uv unset (and skip computing it) for a model that
    /// answers false.
    pub fn reads_uv(&self) -> bool {
        match self {
            Bsdf::Diffuse(b) => b.reflectance.is_texture(),
            Bsdf::Conductor(b) => {
                b.eta.is_texture() || b.k.is_texture() || b.specular_reflectance.is_texture()
            }
            Bsdf::RoughConductor(b) => {
                b.alpha_u.is_texture()
                    || b.alpha_v.is_texture()
                    || b.eta.is_texture()
                    || b.k.is_texture()
                    || b.specular_reflectance.is_texture()
            }
            Bsdf::Dielectric(b) => {
                b.specular_reflectance.is_texture() || b.specular_transmittance.is_texture()
            }
            Bsdf::TwoSided(b) => b.front.reads_uv() || b.back.reads_uv(),
            _ => true,
        }
    }

    /// Whether any of the BSDFs a wrapper nests reads the local geometry (out of line, so
    /// that the leaf models' answer stays one inlined comparison).
    #[inline(never)]
    fn any_reads_local_geometry(nested: &[&Bsdf]) -> bool {
        nested.iter().any(|b| b.reads_local_geometry())
    }

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
            Bsdf::Principled(_) => "principled",
            Bsdf::PrincipledThin(_) => "principledthin",
            Bsdf::TwoSided(_) => "twosided",
            Bsdf::Blend(_) => "blendbsdf",
            Bsdf::Measured(_) => "measured",
            Bsdf::Merl(_) => "merl",
            Bsdf::BumpMap(_) => "bumpmap",
            Bsdf::NormalMap(_) => "normalmap",
            Bsdf::Mask(_) => "mask",
            Bsdf::Null(_) => "null",
            Bsdf::Irawan(_) => "irawan",
            Bsdf::Velvet(_) => "velvet",
        }
    }
}

impl BsdfModel for Bsdf {
    #[inline]
    fn flags(&self) -> LobeFlags {
        dispatch!(self, b => b.flags())
    }
    #[inline]
    fn sample_reads_u1(&self) -> bool {
        dispatch!(self, b => b.sample_reads_u1())
    }
    #[inline]
    fn sample_reads_u2(&self) -> bool {
        dispatch!(self, b => b.sample_reads_u2())
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
    fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        dispatch!(self, b => b.eval_pdf(ctx, sp, wi, wo))
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

/// 2∫₀¹ F(μ) μ dμ for a Fresnel formula and relative index `eta`, by 128-point
/// Gauss–Legendre quadrature. For η < 1 the integrand is 1 below the critical cosine
/// √(1 − η²) (total internal reflection), which contributes (1 − η²) exactly; the smooth
/// remainder is integrated separately so the kink costs no accuracy.
pub(crate) fn hemispherical_fresnel(mode: FresnelMode, eta: f32) -> f32 {
    let mu_c = if eta < 1.0 {
        (1.0 - (eta as f64).powi(2)).sqrt()
    } else {
        0.0
    };
    let (x, w) = gauss_legendre(128);
    let half = 0.5 * (1.0 - mu_c);
    let mut s = mu_c * mu_c;
    for (x, w) in x.iter().zip(&w) {
        let mu = mu_c + half * (x + 1.0);
        s += w * half * 2.0 * mu * mode.eval(mu as f32, eta).r as f64;
    }
    s as f32
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn hemispherical_fresnel_obeys_stokes_relation() {
        // 1 − F_dr(η) = η² (1 − F_dr(1/η)) for the exact Fresnel equations
        for eta in [1.2f32, 1.333, 1.5, 2.0, 2.4] {
            let ext = hemispherical_fresnel(FresnelMode::Exact, eta) as f64;
            let int = hemispherical_fresnel(FresnelMode::Exact, 1.0 / eta) as f64;
            let lhs = 1.0 - ext;
            let rhs = (eta as f64).powi(2) * (1.0 - int);
            assert!((lhs - rhs).abs() < 2e-5 * lhs, "η={eta}: {lhs} vs {rhs}");
            // and the published fits agree to their stated accuracy
            let fit = crate::fresnel::fresnel_diffuse_reflectance(1.0 / eta) as f64;
            assert!(
                (fit - int).abs() < 0.01 * int,
                "η={eta}: fit {fit} vs {int}"
            );
        }
    }
}
