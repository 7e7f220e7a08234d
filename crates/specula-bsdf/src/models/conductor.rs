//! `conductor`: a perfectly smooth metal (Mitsuba 3 `conductor`). Reflectance from the
//! complex-IOR Fresnel equations; `material=none` is an ideal mirror (η = 0, k = 1, R = 1).

use crate::bsdf::*;
use crate::frame::reflect_z;
use crate::fresnel::fresnel_conductor_rgb;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Conductor {
    /// Real part η of the relative complex index of refraction.
    pub eta: SpectrumParam,
    /// Imaginary part k (extinction coefficient).
    pub k: SpectrumParam,
    /// Extra multiplier (not physical; default 1).
    pub specular_reflectance: SpectrumParam,
}

impl Conductor {
    /// An ideal mirror.
    pub fn mirror() -> Self {
        Conductor {
            eta: 0.0.into(),
            k: 1.0.into(),
            specular_reflectance: 1.0.into(),
        }
    }
    /// Reflectance for a cosine of incidence.
    pub fn reflectance(&self, sp: &ShadingPoint, cos_theta_i: f32) -> Spectrum {
        fresnel_conductor_rgb(cos_theta_i, self.eta.eval(sp), self.k.eval(sp))
            * self.specular_reflectance.eval(sp)
    }
}

impl BsdfModel for Conductor {
    fn flags(&self) -> LobeFlags {
        LobeFlags::DELTA_REFLECTION
    }
    fn sample_reads_u1(&self) -> bool {
        false
    }
    fn sample_reads_u2(&self) -> bool {
        false
    }
    fn eval(&self, _: &BsdfContext, _: &ShadingPoint, _: Vec3, _: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        _: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo: reflect_z(wi),
            weight: self.reflectance(sp, wi.z),
            pdf: 1.0,
            lobe: LobeFlags::DELTA_REFLECTION,
            eta: 1.0,
        })
    }
}
