//! `sheen` (a Specula extension; Mitsuba 3 has no such plugin): the "Charlie" microfiber
//! sheen of Estevez & Kulla 2017, "Production Friendly Microfacet Sheen BRDF" (SIGGRAPH
//! course notes), for velvet, satin and nylon. Fibres standing up from the surface give an
//! inverted-Gaussian-like distribution of normals,
//!   D(m) = (2 + 1/r) sin(θm)^(1/r) / (2π),
//! shadowed by a fitted, height-correlated Smith term G = 1 / (1 + Λ(wi) + Λ(wo)) with the
//! paper's terminator softening Λ(μ)^(1 + 2(1−μ)^8), and no Fresnel factor:
//!   f = reflectance · D(h) G / (4 cosθi cosθo).
//! Sampled uniformly over the hemisphere (the lobe is brightest at grazing angles, where
//! cosine sampling would be poor). Combine it with `diffuse` in a `blendbsdf` for velvet.

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Debug)]
pub struct Sheen {
    /// Colour of the sheen (default 1).
    pub reflectance: SpectrumParam,
    /// Fibre roughness r ∈ (0, 1] (default 0.5); clamped to [1e-3, 1].
    pub roughness: FloatParam,
}

/// The paper's fit L(x) = a/(1 + b x^c) + d x + e, its coefficients interpolated between
/// r = 1 and r = 0 with t = (1 − r)².
#[inline]
fn charlie_l(x: f32, r: f32) -> f32 {
    let t = (1.0 - r) * (1.0 - r);
    let mix = |p1: f32, p0: f32| p1 + (p0 - p1) * t;
    let a = mix(21.5473, 25.3245);
    let b = mix(3.82987, 3.32435);
    let c = mix(0.19823, 0.16801);
    let d = mix(-1.97760, -1.27393);
    let e = mix(-4.32054, -4.85967);
    a / (1.0 + b * x.powf(c)) + d * x + e
}

/// Λ(μ) with the terminator softening.
#[inline]
fn charlie_lambda(mu: f32, r: f32) -> f32 {
    let mu = mu.clamp(0.0, 1.0);
    let l = if mu < 0.5 {
        charlie_l(mu, r).exp()
    } else {
        (2.0 * charlie_l(0.5, r) - charlie_l(1.0 - mu, r)).exp()
    };
    l.powf(1.0 + 2.0 * (1.0 - mu).powi(8))
}

/// D(m) for fibre roughness r.
#[inline]
pub fn charlie_d(m: Vec3, r: f32) -> f32 {
    let inv_r = 1.0 / r;
    let sin2 = (1.0 - m.z * m.z).max(0.0);
    (2.0 + inv_r) * sin2.powf(0.5 * inv_r) / (2.0 * PI)
}

impl Sheen {
    #[inline]
    fn roughness(&self, sp: &ShadingPoint) -> f32 {
        self.roughness.eval(sp).clamp(1e-3, 1.0)
    }
}

impl BsdfModel for Sheen {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let r = self.roughness(sp);
        let h = (wi + wo).normalize();
        let g = 1.0 / (1.0 + charlie_lambda(wi.z, r) + charlie_lambda(wo.z, r));
        self.reflectance.eval(sp) * (charlie_d(h, r) * g / (4.0 * wi.z * wo.z))
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        warp::square_to_uniform_hemisphere_pdf(wo)
    }

    #[inline]
    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        _: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = warp::square_to_uniform_hemisphere(u2);
        let pdf = warp::square_to_uniform_hemisphere_pdf(wo);
        if wo.z <= 0.0 {
            return None;
        }
        let weight = self.eval(ctx, sp, wi, wo) * (wo.z / pdf);
        Some(BsdfSample {
            wo,
            weight,
            pdf,
            lobe: LobeFlags::GLOSSY_REFLECTION,
            eta: 1.0,
        })
    }
}
