//! `dielectric`: a smooth interface between two dielectrics (glass, water, diamond), with
//! Snell's law, exact Fresnel (or Schlick's approximation) and total internal reflection
//! (Mitsuba 3 `dielectric`). Light may arrive from either side; `eta` = η_int / η_ext.

use crate::bsdf::*;
use crate::frame::{reflect_z, refract};
use crate::fresnel::FresnelMode;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Dielectric {
    /// Relative index of refraction η_int / η_ext.
    pub eta: f32,
    pub specular_reflectance: SpectrumParam,
    pub specular_transmittance: SpectrumParam,
    pub fresnel: FresnelMode,
}

impl Dielectric {
    pub fn new(eta: f32) -> Self {
        Dielectric {
            eta,
            specular_reflectance: 1.0.into(),
            specular_transmittance: 1.0.into(),
            fresnel: FresnelMode::Exact,
        }
    }
}

impl BsdfModel for Dielectric {
    fn flags(&self) -> LobeFlags {
        LobeFlags::DELTA_REFLECTION | LobeFlags::DELTA_TRANSMISSION
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
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let f = self.fresnel.eval(wi.z, self.eta);
        if u1 < f.r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                weight: self.specular_reflectance.eval(sp),
                pdf: f.r,
                lobe: LobeFlags::DELTA_REFLECTION,
                eta: 1.0,
            })
        } else {
            let scale = match ctx.mode {
                TransportMode::Radiance => f.eta_ti * f.eta_ti,
                TransportMode::Importance => 1.0,
            };
            Some(BsdfSample {
                wo: refract(wi, Vec3::Z, f.cos_theta_t, f.eta_ti),
                weight: self.specular_transmittance.eval(sp) * scale,
                pdf: 1.0 - f.r,
                lobe: LobeFlags::DELTA_TRANSMISSION,
                eta: f.eta_it,
            })
        }
    }
}
