//! `principledthin`: the thin-surface variant of the Disney principled BSDF (Burley 2015,
//! "Extending the Disney BRDF to a BSDF with Integrated Subsurface Scattering"), for leaves,
//! paper and sheets of glass modelled as a single surface, with Mitsuba 3's parameters,
//! defaults and formulas. The surface has no inside: it responds the same from both sides
//! (directions from below are mirrored through the origin), and transmitted light leaves
//! unrefracted (η of the sample is 1).
//!
//! Parameters (all textures or constants except the sampling rates; defaults 0 unless stated):
//! `base_color` (0.5), `roughness` (0.5), `anisotropic`, `spec_trans`, `eta` (1.5),
//! `spec_tint`, `sheen`, `sheen_tint`, `flatness`, `diff_trans` (in [0, 2]: the share of the
//! diffuse energy transmitted, 2 = all), and the sampling rates
//! `specular_reflectance_sampling_rate`, `specular_transmittance_sampling_rate`,
//! `diffuse_reflectance_sampling_rate`, `diffuse_transmittance_sampling_rate` (default 1).
//!
//! Lobes (f without the cosine, with wi' the incident direction mirrored to the front side):
//! - specular reflection, weight spec_trans: lerp(F, F_schlick(tinted), spec_tint)·D·G/(4ci co),
//!   GGX with α from `roughness`/`anisotropic` as in `principled`;
//! - specular transmission, weight spec_trans: base·(1 − F)·D·G/(4ci|co|) with the roughness
//!   scaled by 0.65η − 0.35 (Burley 2015, fig. 15), about the mirror image of wo;
//! - diffuse reflection, weight (1 − spec_trans)(1 − diff_trans/2): the principled diffuse,
//!   retro-reflection, fake subsurface (`flatness`) and sheen;
//! - diffuse transmission, weight (1 − spec_trans)·diff_trans/2: base/π.
//!
//! Lobes are sampled with Mitsuba's probabilities (spec_trans/2 each for the specular
//! lobes, the diffuse weights for the cosine-weighted ones), so `pdf` is Mitsuba's.
//!
//! As in Mitsuba the specular transmission is not reciprocal: a pair (wi, wo) is kept when
//! wi·h > 0 and wo·h < 0 (h the half vector of wi and the mirror image of wo), conditions that
//! are not symmetric in wi and wo. The other lobes are.
//!
//! Spectral mode: the tints use Mitsuba's spectral luminance, as `principled`'s do
//! (`principled::tint_luminance`).
//!
//! Deliberate differences from Mitsuba 3.9: [`BsdfModel::flags`] lists only the lobes that
//! exist (Mitsuba always lists diffuse transmission and glossy reflection); constant weights
//! outside their ranges are errors.

use super::principled::{
    calc_schlick, compatible, diffuse_factor, ggx, schlick_r0, schlick_weight, sheen_color, tint,
    tint_luminance,
};
use crate::bsdf::*;
use crate::frame::reflect;
use crate::fresnel::fresnel_dielectric;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug)]
pub struct PrincipledThin {
    pub base_color: SpectrumParam,
    pub roughness: FloatParam,
    pub anisotropic: FloatParam,
    pub spec_trans: FloatParam,
    pub eta: FloatParam,
    pub spec_tint: FloatParam,
    pub sheen: FloatParam,
    pub sheen_tint: FloatParam,
    pub flatness: FloatParam,
    pub diff_trans: FloatParam,
    /// `spec_trans` was given and is not the constant 0: the specular lobes exist.
    pub has_spec_trans: bool,
    /// `diff_trans` was given and is not the constant 0.
    pub has_diff_trans: bool,
    pub spec_refl_srate: f32,
    pub spec_trans_srate: f32,
    pub diff_refl_srate: f32,
    pub diff_trans_srate: f32,
}

/// Normalised lobe probabilities (specular reflection, specular transmission, diffuse
/// reflection, diffuse transmission).
#[derive(Clone, Copy, Debug)]
struct Probs {
    sr: f32,
    st: f32,
    dr: f32,
    dt: f32,
}

impl PrincipledThin {
    #[inline]
    fn weights(&self, sp: &ShadingPoint) -> (f32, f32) {
        let st = if self.has_spec_trans {
            self.spec_trans.eval(sp)
        } else {
            0.0
        };
        let dt = if self.has_diff_trans {
            0.5 * self.diff_trans.eval(sp)
        } else {
            0.0
        };
        (st, dt)
    }

    #[inline]
    fn probs(&self, st: f32, dt: f32) -> Probs {
        let (mut sr, mut stp) = if self.has_spec_trans {
            (
                0.5 * st * self.spec_refl_srate,
                0.5 * st * self.spec_trans_srate,
            )
        } else {
            (0.0, 0.0)
        };
        let mut dr = self.diff_refl_srate * (1.0 - st) * (1.0 - dt);
        let mut dtp = if self.has_diff_trans {
            self.diff_trans_srate * (1.0 - st) * dt
        } else {
            0.0
        };
        let total = sr + stp + dr + dtp;
        // all sampling rates 0 where every lobe is: nothing is sampled
        let inv = if total > 0.0 { 1.0 / total } else { 0.0 };
        sr *= inv;
        stp *= inv;
        dr *= inv;
        dtp *= inv;
        Probs {
            sr,
            st: stp,
            dr,
            dt: dtp,
        }
    }

    #[inline]
    fn eval_pdf_impl<const VALUE: bool>(
        &self,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        let ci = wi.z;
        if ci == 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        // mirror both directions so that wi is on the front side
        let (wi, wo) = if ci < 0.0 { (-wi, -wo) } else { (wi, wo) };
        let (ci, co) = (wi.z, wo.z);
        let reflect = co > 0.0;
        let refract = co < 0.0;
        if !reflect && !refract {
            return (Spectrum::ZERO, 0.0);
        }
        let (st, dt) = self.weights(sp);
        let p = self.probs(st, dt);
        let roughness = self.roughness.eval(sp);
        let wo_r = Vec3::new(wo.x, wo.y, wo.z.abs());
        let wh = (wi + wo_r).normalize();
        let mut value = Spectrum::ZERO;
        let mut pdf = 0.0;
        let base = if VALUE {
            self.base_color.eval(sp)
        } else {
            Spectrum::ZERO
        };
        if self.has_spec_trans && wh.is_finite() && compatible(wh, wi, wo, ci, reflect) {
            let aniso = self.anisotropic.eval(sp);
            let eta = self.eta.eval(sp);
            let distr = if reflect {
                ggx(aniso, roughness)
            } else {
                ggx(aniso, (0.65 * eta - 0.35) * roughness)
            };
            let dwh_dwo = (1.0 / (4.0 * wo_r.dot(wh))).abs();
            let lobe_p = if reflect { p.sr } else { p.st };
            pdf += lobe_p * distr.pdf(wi, wh) * dwh_dwo;
            if VALUE && st > 0.0 {
                let f = fresnel_dielectric(wi.dot(wh), eta).r;
                let d = distr.eval(wh);
                let g = distr.smith_g1(wi, wh) * distr.smith_g1(wo, wh);
                let k = d * g / (4.0 * ci * co.abs());
                if reflect {
                    let spec_tint = self.spec_tint.eval(sp);
                    let f_thin = if spec_tint != 0.0 {
                        let lum = tint_luminance(&self.base_color, base, sp);
                        let r0 = tint(base, lum) * schlick_r0(eta);
                        let fs = calc_schlick(r0, wi.dot(wh), eta);
                        Spectrum::splat(f * (1.0 - spec_tint)) + fs * spec_tint
                    } else {
                        Spectrum::splat(f)
                    };
                    value += f_thin * (st * k);
                } else {
                    value += base * (st * (1.0 - f) * k);
                }
            }
        }
        if reflect {
            pdf += p.dr * warp::square_to_cosine_hemisphere_pdf(wo);
            if VALUE && st < 1.0 && dt < 1.0 {
                let flatness = self.flatness.eval(sp);
                let cos_d = wh.dot(wo);
                let w = (1.0 - st) * (1.0 - dt);
                let kd = diffuse_factor(ci, co, cos_d, roughness, flatness);
                value += base * (w * FRAC_1_PI * kd);
                let sheen = self.sheen.eval(sp);
                if sheen > 0.0 {
                    let c = sheen_color(base, self.sheen_tint.eval(sp), || {
                        tint_luminance(&self.base_color, base, sp)
                    });
                    value += c * (sheen * w * schlick_weight(cos_d.abs()));
                }
            }
        } else if self.has_diff_trans {
            pdf += p.dt * warp::square_to_cosine_hemisphere_pdf(-wo);
            if VALUE && st < 1.0 && dt > 0.0 {
                value += base * ((1.0 - st) * dt * FRAC_1_PI);
            }
        }
        (value, pdf)
    }
}

impl BsdfModel for PrincipledThin {
    fn flags(&self) -> LobeFlags {
        let mut f = LobeFlags::DIFFUSE_REFLECTION;
        if self.has_diff_trans {
            f = f | LobeFlags::DIFFUSE_TRANSMISSION;
        }
        if self.has_spec_trans {
            f = f | LobeFlags::GLOSSY_REFLECTION | LobeFlags::GLOSSY_TRANSMISSION;
        }
        f
    }

    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf_impl::<true>(sp, wi, wo).0
    }

    fn pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf_impl::<false>(sp, wi, wo).1
    }

    fn eval_pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        self.eval_pdf_impl::<true>(sp, wi, wo)
    }

    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi_in: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let ci = wi_in.z;
        if ci == 0.0 {
            return None;
        }
        let wi = if ci < 0.0 { -wi_in } else { wi_in };
        let (st, dt) = self.weights(sp);
        let p = self.probs(st, dt);
        let (wo, lobe) = if self.has_spec_trans && u1 < p.sr + p.st {
            let aniso = self.anisotropic.eval(sp);
            let roughness = self.roughness.eval(sp);
            let transmit = u1 >= p.sr;
            let distr = if transmit {
                let eta = self.eta.eval(sp);
                ggx(aniso, (0.65 * eta - 0.35) * roughness)
            } else {
                ggx(aniso, roughness)
            };
            let (m, _) = distr.sample(wi, u2);
            let mut wo = reflect(wi, m);
            if wo.z <= 0.0 {
                return None;
            }
            // transmission: the mirror image of the reflection, unrefracted
            if transmit {
                wo.z = -wo.z;
            }
            if !compatible(m, wi, wo, wi.z, !transmit) {
                return None;
            }
            let lobe = if transmit {
                LobeFlags::GLOSSY_TRANSMISSION
            } else {
                LobeFlags::GLOSSY_REFLECTION
            };
            (wo, lobe)
        } else if u1 < p.sr + p.st + p.dr || !self.has_diff_trans {
            (
                warp::square_to_cosine_hemisphere(u2),
                LobeFlags::DIFFUSE_REFLECTION,
            )
        } else {
            (
                -warp::square_to_cosine_hemisphere(u2),
                LobeFlags::DIFFUSE_TRANSMISSION,
            )
        };
        if wo.z == 0.0 {
            return None;
        }
        let wo = if ci < 0.0 { -wo } else { wo };
        let (value, pdf) = self.eval_pdf_impl::<true>(sp, wi_in, wo);
        BsdfSample::from_value(wo, value, pdf, lobe, 1.0)
    }
}

impl PrincipledThin {
    /// Builds the model from its parameters (Mitsuba 3's names and defaults).
    pub fn from_props(p: &crate::props::Props) -> Result<Self, crate::props::BuildError> {
        use super::principled::{sampling_rate, weight_param};
        let (roughness, _) = weight_param(p, "roughness", 0.5, 0.0, f32::MAX)?;
        let (anisotropic, _) = weight_param(p, "anisotropic", 0.0, 0.0, 1.0)?;
        let (spec_trans, has_spec_trans) = weight_param(p, "spec_trans", 0.0, 0.0, 1.0)?;
        let (eta, _) = weight_param(p, "eta", 1.5, 0.0, f32::MAX)?;
        if matches!(eta, FloatParam::Const(e) if e <= 0.0) {
            return Err(crate::props::BuildError::new(
                p.loc.clone(),
                "'principledthin': 'eta' must be positive",
            ));
        }
        let (spec_tint, _) = weight_param(p, "spec_tint", 0.0, 0.0, 1.0)?;
        let (sheen, _) = weight_param(p, "sheen", 0.0, 0.0, f32::MAX)?;
        let (sheen_tint, _) = weight_param(p, "sheen_tint", 0.0, 0.0, 1.0)?;
        let (flatness, _) = weight_param(p, "flatness", 0.0, 0.0, 1.0)?;
        let (diff_trans, has_diff_trans) = weight_param(p, "diff_trans", 0.0, 0.0, 2.0)?;
        let b = PrincipledThin {
            base_color: p.spectrum("base_color", 0.5)?,
            roughness,
            anisotropic,
            spec_trans,
            eta,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
            diff_trans,
            has_spec_trans,
            has_diff_trans,
            spec_refl_srate: sampling_rate(p, "specular_reflectance_sampling_rate")?,
            spec_trans_srate: sampling_rate(p, "specular_transmittance_sampling_rate")?,
            diff_refl_srate: sampling_rate(p, "diffuse_reflectance_sampling_rate")?,
            diff_trans_srate: sampling_rate(p, "diffuse_transmittance_sampling_rate")?,
        };
        Ok(b)
    }
}

/// Parameters of `principledthin`.
pub const PARAMS: &[&str] = &[
    "base_color",
    "roughness",
    "anisotropic",
    "spec_trans",
    "eta",
    "spec_tint",
    "sheen",
    "sheen_tint",
    "flatness",
    "diff_trans",
    "specular_reflectance_sampling_rate",
    "specular_transmittance_sampling_rate",
    "diffuse_reflectance_sampling_rate",
    "diffuse_transmittance_sampling_rate",
];

#[cfg(test)]
mod tests {
    use crate::bsdf::*;
    use crate::parse_spec;
    use glam::Vec3;

    #[test]
    fn the_surface_responds_alike_from_both_sides() {
        let b = parse_spec(
            "principledthin base_color=0.7,0.5,0.3 roughness=0.4 spec_trans=0.6 diff_trans=0.8",
        )
        .unwrap();
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        let wi = Vec3::new(0.3, 0.2, 0.9).normalize();
        for wo in [Vec3::new(-0.4, 0.1, 0.8), Vec3::new(-0.3, -0.1, -0.9)] {
            let wo = wo.normalize();
            let a = b.eval_pdf(&ctx, &sp, wi, wo);
            let c = b.eval_pdf(&ctx, &sp, -wi, -wo);
            assert_eq!(a, c);
            assert!(a.1 > 0.0 && a.0.max_component() > 0.0);
        }
    }

    #[test]
    fn lobes_follow_the_parameters() {
        let b = parse_spec("principledthin").unwrap();
        assert_eq!(b.flags(), LobeFlags::DIFFUSE_REFLECTION);
        let b = parse_spec("principledthin spec_trans=0 diff_trans=0").unwrap();
        assert_eq!(b.flags(), LobeFlags::DIFFUSE_REFLECTION);
        let b = parse_spec("principledthin spec_trans=0.2 diff_trans=1").unwrap();
        assert!(b
            .flags()
            .contains(LobeFlags::GLOSSY_TRANSMISSION | LobeFlags::DIFFUSE_TRANSMISSION));
        for bad in [
            "principledthin eta=0",
            "principledthin diff_trans=2.5",
            "principledthin spec_trans=-0.1",
            "principledthin specular=0.5",
        ] {
            assert!(parse_spec(bad).is_err(), "{bad}");
        }
    }
}
