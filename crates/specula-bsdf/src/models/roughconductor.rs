//! `roughconductor`: a Cook–Torrance microfacet metal, f = F·D·G / (4 cosθi cosθo), with
//! Beckmann or GGX, isotropic or anisotropic (brushed metal: α_u ≠ α_v), visible-normal
//! sampling by default (Mitsuba 3 `roughconductor`).

use crate::bsdf::*;
use crate::frame::reflect;
use crate::fresnel::fresnel_conductor_rgb;
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct RoughConductor {
    pub distribution: MicrofacetType,
    pub alpha_u: FloatParam,
    pub alpha_v: FloatParam,
    pub sample_visible: bool,
    /// Beckmann: Mitsuba's rational approximation of G1 instead of the exact one.
    pub rational_g1: bool,
    pub eta: SpectrumParam,
    pub k: SpectrumParam,
    pub specular_reflectance: SpectrumParam,
}

impl RoughConductor {
    #[inline]
    fn distr(&self, sp: &ShadingPoint) -> MicrofacetDistribution {
        MicrofacetDistribution::new(
            self.distribution,
            self.alpha_u.eval(sp),
            self.alpha_v.eval(sp),
            self.sample_visible,
        )
        .with_rational_g1(self.rational_g1)
    }
    #[inline]
    fn fresnel(&self, sp: &ShadingPoint, cos: f32) -> Spectrum {
        fresnel_conductor_rgb(cos, self.eta.eval(sp), self.k.eval(sp))
            * self.specular_reflectance.eval(sp)
    }
}

impl BsdfModel for RoughConductor {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION
    }

    #[inline]
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(ctx, sp, wi, wo).0
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let m = (wi + wo).normalize();
        let (dwi, dwo) = (wi.dot(m), wo.dot(m));
        if dwi <= 0.0 || dwo <= 0.0 {
            return 0.0;
        }
        self.distr(sp).pdf(wi, m) / (4.0 * dwo)
    }

    /// The value and the pdf, sharing the half vector, D and G1(wi) (`eval` is its value;
    /// `pdf` alone skips the Fresnel term).
    #[inline]
    fn eval_pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let h = (wi + wo).normalize();
        let distr = self.distr(sp);
        let d = distr.eval(h);
        if d == 0.0 {
            // no microfacet there: nothing reflected, nor sampled
            return (Spectrum::ZERO, 0.0);
        }
        let (dwi, dwo) = (wi.dot(h), wo.dot(h));
        let g1_i = distr.smith_g1(wi, h);
        let g = g1_i * distr.smith_g1(wo, h);
        let value = self.fresnel(sp, dwi) * (d * g / (4.0 * wi.z * wo.z));
        let pdf = if dwi <= 0.0 || dwo <= 0.0 {
            0.0
        } else if distr.sample_visible {
            d * g1_i * dwi.abs() / wi.z / (4.0 * dwo)
        } else {
            d * h.z / (4.0 * dwo)
        };
        (value, pdf)
    }

    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        _: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let distr = self.distr(sp);
        let (m, pdf_m) = distr.sample(wi, u2);
        let wo = reflect(wi, m);
        let dwo = wo.dot(m);
        if pdf_m <= 0.0 || wo.z <= 0.0 || dwo <= 0.0 {
            return None;
        }
        let w = if distr.sample_visible {
            distr.smith_g1(wo, m)
        } else {
            distr.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        Some(BsdfSample {
            wo,
            weight: self.fresnel(sp, wi.dot(m)) * w,
            pdf: pdf_m / (4.0 * dwo),
            lobe: LobeFlags::GLOSSY_REFLECTION,
            eta: 1.0,
        })
    }
}
