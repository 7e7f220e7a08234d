//! `thindielectric`: a thin slab of dielectric (a window pane, a soap film without
//! interference). Light is either mirror-reflected or passes straight through; the
//! reflectance sums all internal bounces, R' = R + T²R/(1−R²) = 2R/(1+R)
//! (Mitsuba 3 `thindielectric`). Two-sided.

use crate::bsdf::*;
use crate::frame::reflect_z;
use crate::fresnel::FresnelMode;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct ThinDielectric {
    pub eta: f32,
    pub specular_reflectance: SpectrumParam,
    pub specular_transmittance: SpectrumParam,
    pub fresnel: FresnelMode,
}

impl ThinDielectric {
    pub fn new(eta: f32) -> Self {
        ThinDielectric {
            eta,
            specular_reflectance: 1.0.into(),
            specular_transmittance: 1.0.into(),
            fresnel: FresnelMode::Exact,
        }
    }
    /// Total reflectance of the slab for a cosine of incidence.
    pub fn reflectance(&self, cos_theta_i: f32) -> f32 {
        let r = self.fresnel.eval(cos_theta_i.abs(), self.eta).r;
        if r < 1.0 {
            2.0 * r / (1.0 + r)
        } else {
            r
        }
    }
}

impl BsdfModel for ThinDielectric {
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
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let r = self.reflectance(wi.z);
        if u1 < r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                weight: self.specular_reflectance.eval(sp),
                pdf: r,
                lobe: LobeFlags::DELTA_REFLECTION,
                eta: 1.0,
            })
        } else {
            Some(BsdfSample {
                wo: -wi,
                weight: self.specular_transmittance.eval(sp),
                pdf: 1.0 - r,
                lobe: LobeFlags::DELTA_TRANSMISSION,
                eta: 1.0,
            })
        }
    }
}
