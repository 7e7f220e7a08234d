//! `roughdielectric`: a rough interface between two dielectrics (frosted glass), after
//! Walter et al. 2007, "Microfacet models for refraction through rough surfaces", with
//! Beckmann or GGX, isotropic or anisotropic (Mitsuba 3 `roughdielectric`).
//!
//! Reflection: f_r = F·D·G / (4|cosθi||cosθo|).
//! Transmission: f_t = |wi·m||wo·m| / (|cosθi||cosθo|) · η²(1−F)·D·G / (wi·m + η wo·m)²,
//! scaled by 1/η² when transporting radiance (the solid-angle compression at the interface).

use crate::bsdf::*;
use crate::frame::{reflect, refract};
use crate::fresnel::FresnelMode;
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct RoughDielectric {
    pub distribution: MicrofacetType,
    pub alpha_u: FloatParam,
    pub alpha_v: FloatParam,
    pub sample_visible: bool,
    /// Relative index η_int / η_ext.
    pub eta: f32,
    pub specular_reflectance: SpectrumParam,
    pub specular_transmittance: SpectrumParam,
    pub fresnel: FresnelMode,
}

/// The half vector of a reflection or refraction pair, oriented to the macro-normal's side,
/// with the relative index η_t/η_i seen from `wi`'s side.
#[inline]
fn half_vector(wi: Vec3, wo: Vec3, eta_rel: f32) -> Option<(Vec3, bool, f32)> {
    let reflect = wi.z * wo.z > 0.0;
    let eta = if wi.z > 0.0 { eta_rel } else { 1.0 / eta_rel };
    let h = wi + wo * if reflect { 1.0 } else { eta };
    let len2 = h.length_squared();
    if len2 == 0.0 || !len2.is_finite() {
        return None;
    }
    let m = h / len2.sqrt();
    Some((if m.z < 0.0 { -m } else { m }, reflect, eta))
}

impl RoughDielectric {
    #[inline]
    fn distr(&self, sp: &ShadingPoint) -> MicrofacetDistribution {
        MicrofacetDistribution::new(
            self.distribution,
            self.alpha_u.eval(sp),
            self.alpha_v.eval(sp),
            self.sample_visible,
        )
    }
    /// The distribution microfacet normals are drawn from: the model's own with visible-normal
    /// sampling, otherwise Walter et al.'s widened one (α scaled by 1.2 − 0.2√|cosθi|).
    #[inline]
    fn sample_distr(
        &self,
        distr: &MicrofacetDistribution,
        cos_theta_i: f32,
    ) -> MicrofacetDistribution {
        let mut d = *distr;
        if !d.sample_visible {
            d.scale_alpha(1.2 - 0.2 * cos_theta_i.abs().sqrt());
        }
        d
    }
}

impl BsdfModel for RoughDielectric {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION | LobeFlags::GLOSSY_TRANSMISSION
    }

    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        let (cos_i, cos_o) = (wi.z, wo.z);
        if cos_i == 0.0 || cos_o == 0.0 {
            return Spectrum::ZERO;
        }
        let Some((m, reflect, eta)) = half_vector(wi, wo, self.eta) else {
            return Spectrum::ZERO;
        };
        let distr = self.distr(sp);
        let d = distr.eval(m);
        if d == 0.0 {
            return Spectrum::ZERO;
        }
        let (dwi, dwo) = (wi.dot(m), wo.dot(m));
        let f = self.fresnel.eval(dwi, self.eta).r;
        let g = distr.g(wi, wo, m);
        if reflect {
            self.specular_reflectance.eval(sp) * (f * d * g / (4.0 * (cos_i * cos_o).abs()))
        } else {
            let scale = match ctx.mode {
                TransportMode::Radiance => 1.0 / (eta * eta),
                TransportMode::Importance => 1.0,
            };
            let denom = dwi + eta * dwo;
            let v =
                scale * (1.0 - f) * d * g * eta * eta * dwi * dwo / (cos_i * cos_o * denom * denom);
            self.specular_transmittance.eval(sp) * v.abs()
        }
    }

    fn pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        let (cos_i, cos_o) = (wi.z, wo.z);
        if cos_i == 0.0 || cos_o == 0.0 {
            return 0.0;
        }
        let Some((m, reflect, eta)) = half_vector(wi, wo, self.eta) else {
            return 0.0;
        };
        let (dwi, dwo) = (wi.dot(m), wo.dot(m));
        // micro- and macro-surface must agree on the side (as in G1)
        if dwi * cos_i <= 0.0 || dwo * cos_o <= 0.0 {
            return 0.0;
        }
        let dwh_dwo = if reflect {
            1.0 / (4.0 * dwo)
        } else {
            let denom = dwi + eta * dwo;
            eta * eta * dwo / (denom * denom)
        };
        let distr = self.distr(sp);
        let sdistr = self.sample_distr(&distr, cos_i);
        let wi_up = if cos_i < 0.0 { -wi } else { wi };
        let f = self.fresnel.eval(dwi, self.eta).r;
        let prob = sdistr.pdf(wi_up, m) * if reflect { f } else { 1.0 - f };
        (prob * dwh_dwo).abs()
    }

    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let distr = self.distr(sp);
        let sdistr = self.sample_distr(&distr, cos_i);
        let wi_up = if cos_i < 0.0 { -wi } else { wi };
        let (m, pdf_m) = sdistr.sample(wi_up, u2);
        if !(pdf_m > 0.0) {
            return None;
        }
        let dwi = wi.dot(m);
        let f = self.fresnel.eval(dwi, self.eta);
        let (wo, lobe, sel_pdf, eta_s, dwh_dwo, mut weight);
        if u1 < f.r {
            wo = reflect(wi, m);
            if cos_i * wo.z <= 0.0 {
                return None;
            }
            lobe = LobeFlags::GLOSSY_REFLECTION;
            sel_pdf = f.r;
            eta_s = 1.0;
            dwh_dwo = 1.0 / (4.0 * wo.dot(m));
            weight = self.specular_reflectance.eval(sp);
        } else {
            wo = refract(wi, m, f.cos_theta_t, f.eta_ti);
            if cos_i * wo.z >= 0.0 {
                return None;
            }
            lobe = LobeFlags::GLOSSY_TRANSMISSION;
            sel_pdf = 1.0 - f.r;
            eta_s = f.eta_it;
            let denom = dwi + eta_s * wo.dot(m);
            dwh_dwo = eta_s * eta_s * wo.dot(m) / (denom * denom);
            let scale = match ctx.mode {
                TransportMode::Radiance => f.eta_ti * f.eta_ti,
                TransportMode::Importance => 1.0,
            };
            weight = self.specular_transmittance.eval(sp) * scale;
        }
        let pdf = (pdf_m * sel_pdf * dwh_dwo).abs();
        if !(pdf > 0.0) || !pdf.is_finite() {
            return None;
        }
        if distr.sample_visible {
            weight *= distr.smith_g1(wo, m);
        } else {
            // widened sampling distribution: use the general ratio
            weight = self.eval(ctx, sp, wi, wo) * wo.z.abs() / pdf;
        }
        Some(BsdfSample {
            wo,
            weight,
            pdf,
            lobe,
            eta: eta_s,
        })
    }
}
