//! `plastic`: a diffuse base under a smooth dielectric coat (Mitsuba 3 `plastic`, after
//! Weidlich & Wilkie 2007). The coat reflects specularly with Fresnel F; light entering it
//! reaches the Lambertian base, whose internal inter-reflections under the coat are summed
//! in closed form: f_d = ρ / (1 − F_dr,int) · (1−F(θi))(1−F(θo)) / (η²π), with
//! `nonlinear=true` replacing F_dr,int by ρ·F_dr,int (colour shift of wet-looking materials).
//!
//! F_dr,int, the hemispherical average of the coat's internal Fresnel reflectance, is computed
//! by quadrature of the Fresnel formula in use. With it a white base under a lossless coat
//! reflects exactly all light (the Stokes relation 1 − F_dr,ext = η²(1 − F_dr,int) makes the
//! albedo F + (1 − F) = 1). Mitsuba instead uses Egan & Hilgeman's polynomial fit, whose
//! ~0.1 % error makes such a plastic reflect about 0.1 % more than it receives;
//! `diffuse_fresnel=fit` selects Mitsuba's fit for bit-compatible renders.

use crate::bsdf::*;
use crate::frame::reflect_z;
use crate::fresnel::{fresnel_diffuse_reflectance, FresnelMode};
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug)]
pub struct Plastic {
    pub diffuse_reflectance: SpectrumParam,
    pub specular_reflectance: SpectrumParam,
    /// Relative index η_int / η_ext of the coat.
    pub eta: f32,
    pub nonlinear: bool,
    pub fresnel: FresnelMode,
    /// Hemispherical average of the coat's internal Fresnel reflectance.
    pub fdr_int: f32,
    /// Probability weight of the specular lobe when sampling.
    pub specular_sampling_weight: f32,
}

impl Plastic {
    pub fn new(
        diffuse_reflectance: SpectrumParam,
        specular_reflectance: SpectrumParam,
        eta: f32,
        nonlinear: bool,
        fresnel: FresnelMode,
        fdr_fit: bool,
    ) -> Self {
        let fdr_int = match (fresnel, fdr_fit) {
            (FresnelMode::Exact, true) => fresnel_diffuse_reflectance(1.0 / eta),
            _ => super::hemispherical_fresnel(fresnel, 1.0 / eta),
        };
        let specular_sampling_weight = sampling_weight(&diffuse_reflectance, &specular_reflectance);
        Plastic {
            diffuse_reflectance,
            specular_reflectance,
            eta,
            nonlinear,
            fresnel,
            fdr_int,
            specular_sampling_weight,
        }
    }

    /// (probability of the specular lobe, probability of the diffuse lobe) for cosθi.
    #[inline]
    fn lobe_probs(&self, f_i: f32) -> (f32, f32) {
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        let ps = ps / (ps + pd);
        (ps, 1.0 - ps)
    }

    #[inline]
    fn diffuse_value(&self, sp: &ShadingPoint, f_i: f32, f_o: f32) -> Spectrum {
        let rho = self.diffuse_reflectance.eval(sp);
        let denom = if self.nonlinear {
            1.0 - rho * self.fdr_int
        } else {
            Spectrum::splat(1.0 - self.fdr_int)
        };
        rho / denom * ((1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta) * FRAC_1_PI)
    }
}

/// Mitsuba's lobe-selection weight s̄ / (d̄ + s̄) from the parameters' means.
pub(crate) fn sampling_weight(diffuse: &SpectrumParam, specular: &SpectrumParam) -> f32 {
    let d = diffuse.mean().mean();
    let s = specular.mean().mean();
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.5
    }
}

impl BsdfModel for Plastic {
    fn flags(&self) -> LobeFlags {
        LobeFlags::DELTA_REFLECTION | LobeFlags::DIFFUSE_REFLECTION
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let f_i = self.fresnel.eval(wi.z, self.eta).r;
        let f_o = self.fresnel.eval(wo.z, self.eta).r;
        self.diffuse_value(sp, f_i, f_o)
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let f_i = self.fresnel.eval(wi.z, self.eta).r;
        self.lobe_probs(f_i).1 * warp::square_to_cosine_hemisphere_pdf(wo)
    }

    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let f_i = self.fresnel.eval(wi.z, self.eta).r;
        let (ps, pd) = self.lobe_probs(f_i);
        if u1 < ps {
            Some(BsdfSample {
                wo: reflect_z(wi),
                weight: self.specular_reflectance.eval(sp) * (f_i / ps),
                pdf: ps,
                lobe: LobeFlags::DELTA_REFLECTION,
                eta: 1.0,
            })
        } else {
            let wo = warp::square_to_cosine_hemisphere(u2);
            let pdf = pd * warp::square_to_cosine_hemisphere_pdf(wo);
            if pdf.is_nan() || pdf <= 0.0 {
                return None;
            }
            let f_o = self.fresnel.eval(wo.z, self.eta).r;
            Some(BsdfSample {
                wo,
                weight: self.diffuse_value(sp, f_i, f_o) * (wo.z / pdf),
                pdf,
                lobe: LobeFlags::DIFFUSE_REFLECTION,
                eta: 1.0,
            })
        }
    }
}
