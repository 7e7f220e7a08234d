//! `diffuse`: the Lambertian BRDF f = ρ/π (Mitsuba 3 `diffuse`, one-sided).

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug)]
pub struct Diffuse {
    /// ρ, the albedo (default 0.5).
    pub reflectance: SpectrumParam,
}

impl Default for Diffuse {
    fn default() -> Self {
        Diffuse {
            reflectance: 0.5.into(),
        }
    }
}

impl BsdfModel for Diffuse {
    fn flags(&self) -> LobeFlags {
        LobeFlags::DIFFUSE_REFLECTION
    }
    fn sample_reads_u1(&self) -> bool {
        false
    }
    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.reflectance.eval(sp) * FRAC_1_PI
    }
    #[inline]
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        warp::square_to_cosine_hemisphere_pdf(wo)
    }
    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        _u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = warp::square_to_cosine_hemisphere(u2);
        let pdf = warp::square_to_cosine_hemisphere_pdf(wo);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: self.reflectance.eval(sp),
            pdf,
            lobe: LobeFlags::DIFFUSE_REFLECTION,
            eta: 1.0,
        })
    }
}
