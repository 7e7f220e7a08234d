//! `roughconductor`: a Cook–Torrance microfacet metal, f = F·D·G / (4 cosθi cosθo), with
//! Beckmann or GGX, isotropic or anisotropic (brushed metal: α_u ≠ α_v), visible-normal
//! sampling by default (Mitsuba 3 `roughconductor`).
//!
//! Specula option `multiscatter` (default `false`, Mitsuba's model): add an energy-
//! compensation lobe (after Kulla & Conty 2017), so that a white rough conductor reflects all
//! the light at every roughness and incidence; its shape is measured from the random walk on
//! the microsurface (tabulated, reciprocal, sampled from its table; Kulla & Conty's
//! separable lobe for a constant anisotropic roughness), its colour follows the walk order by
//! order (exact first bounce, walk statistics of the second) instead of Kulla & Conty's
//! F_avg term (see [`crate::multiscatter`] for the method, its accuracy and its limits).

use crate::bsdf::*;
use crate::frame::reflect;
use crate::fresnel::fresnel_conductor_rgb;
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::multiscatter::lobe::LOBE_MU;
use crate::multiscatter::{
    conductor_tables, conductor_tables_aniso, folded_phi, lobe_table, table_alpha, ConductorMs,
    ConductorTables, FresnelFit,
};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

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
    /// Kulla–Conty energy compensation (Specula's `multiscatter`).
    pub multiscatter: bool,
    /// The Fresnel fit of the compensation ([`FresnelFit::conductor`]) when `eta`, `k` and
    /// `specular_reflectance` are constant (see [`RoughConductor::with_multiscatter`]);
    /// computed per evaluation otherwise.
    /// With it, the compensation's colour when the roughness is constant too, and then, for
    /// an isotropic roughness, the measured lobe's row integrals ρ per μ bin made exact
    /// ([`crate::multiscatter::LobeTable::rho_bins`]).
    #[allow(clippy::type_complexity)]
    pub ms_f_avg: Option<(
        FresnelFit,
        Option<ConductorMs>,
        Option<Arc<[Spectrum; LOBE_MU]>>,
    )>,
    /// The tables of a constant anisotropic roughness (built by `with_multiscatter`).
    pub ms_aniso: Option<Arc<ConductorTables>>,
}

impl RoughConductor {
    /// Switch the energy compensation on or off (precomputing the Fresnel average when the
    /// parameters are constant).
    pub fn with_multiscatter(mut self, on: bool) -> Self {
        self.multiscatter = on;
        if on {
            crate::multiscatter::prepare_conductor(self.distribution);
        }
        self.ms_aniso = match (&self.alpha_u, &self.alpha_v) {
            (FloatParam::Const(u), FloatParam::Const(v)) if on && u != v => Some(Arc::new(
                conductor_tables_aniso(self.distribution, u.min(1.0), v.min(1.0)),
            )),
            _ => None,
        };
        // (RGB mode only; spectral mode evaluates the optical constants at the wavelengths)
        self.ms_f_avg = match (
            self.eta.rgb_constant(),
            self.k.rgb_constant(),
            self.specular_reflectance.rgb_constant(),
        ) {
            (Some(e), Some(k), Some(s)) if on => {
                let fit = FresnelFit::conductor(e, k, s);
                let ms = match (&self.alpha_u, &self.alpha_v, &self.ms_aniso) {
                    (_, _, Some(t)) => Some(t.ms(0.0, &fit)),
                    (FloatParam::Const(u), FloatParam::Const(v), None) => {
                        Some(conductor_tables(self.distribution).ms(table_alpha(*u, *v), &fit))
                    }
                    _ => None,
                };
                let rho = match (&ms, &self.alpha_u, &self.alpha_v, &self.ms_aniso) {
                    (Some(ms), FloatParam::Const(u), FloatParam::Const(v), None) => {
                        Some(Arc::new(lobe_table(self.distribution).rho_bins(
                            conductor_tables(self.distribution),
                            table_alpha(*u, *v),
                            ms,
                        )))
                    }
                    _ => None,
                };
                Some((fit, ms, rho))
            }
            _ => None,
        };
        self
    }

    /// The compensation lobe (without cosine), the white energy it adds for `wi`, 1 − E(μi)
    /// (the probability of sampling it), and the density of its sampling at `wo`.
    #[inline]
    fn ms_lobe(&self, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32, f32) {
        let (t, xi, xo, a) = match &self.ms_aniso {
            Some(t) => (&**t, folded_phi(wi), folded_phi(wo), 0.0),
            None => {
                let a = table_alpha(self.alpha_u.eval(sp), self.alpha_v.eval(sp));
                (conductor_tables(self.distribution), a, a, a)
            }
        };
        let (ms, rho) = match self.ms_f_avg.as_ref().filter(|_| sp.wavelengths.is_none()) {
            Some((_, Some(ms), rho)) => (*ms, rho.as_deref()),
            _ => (t.ms(a, &self.ms_fit(sp)), None),
        };
        let c_i = ms.energy(&t.at(xi, wi.z));
        let c_o = ms.energy(&t.at(xo, wo.z));
        // the measured shape (isotropic roughness), or Kulla–Conty's 1/π, cosine-sampled
        let (lobe, pdf) = match &self.ms_aniso {
            Some(_) => (ms.lobe(c_i, c_o), wo.z * FRAC_1_PI),
            None => {
                let lt = lobe_table(self.distribution);
                let (shape, pdf) = lt.eval(a, wi, wo);
                let (r_i, r_o) = match rho {
                    Some(r) => (r[lt.bin(wi.z)], r[lt.bin(wo.z)]),
                    None => (lt.rho(a, wi.z, &ms), lt.rho(a, wo.z, &ms)),
                };
                (ms.lobe_measured(c_i, c_o, shape, r_i, r_o), pdf)
            }
        };
        (lobe, 1.0 - t.e(xi, wi.z), pdf)
    }

    /// The white energy the compensation adds for `wi`: 1 − E(μi).
    #[inline]
    fn ms_white(&self, sp: &ShadingPoint, wi: Vec3) -> f32 {
        let e = match &self.ms_aniso {
            Some(t) => t.e(folded_phi(wi), wi.z),
            None => conductor_tables(self.distribution).e(
                table_alpha(self.alpha_u.eval(sp), self.alpha_v.eval(sp)),
                wi.z,
            ),
        };
        1.0 - e
    }

    #[inline]
    fn ms_fit(&self, sp: &ShadingPoint) -> FresnelFit {
        match self.ms_f_avg.as_ref().filter(|_| sp.wavelengths.is_none()) {
            Some((f, _, _)) => *f,
            None => FresnelFit::conductor(
                self.eta.eval(sp),
                self.k.eval(sp),
                self.specular_reflectance.eval(sp),
            ),
        }
    }

    /// The single-scattering value and pdf.
    #[inline]
    fn eval_pdf_ss(&self, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
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

    /// `eval_pdf` with the compensation lobe (wi, wo above the surface).
    fn eval_pdf_ms(&self, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let (v, p) = self.eval_pdf_ss(sp, wi, wo);
        let (lobe, p_ms, pdf_ms) = self.ms_lobe(sp, wi, wo);
        (v + lobe, (1.0 - p_ms) * p + p_ms * pdf_ms)
    }

    fn sample_ms(&self, sp: &ShadingPoint, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let p_ms = self.ms_white(sp, wi);
        let wo = if u1 < p_ms {
            match &self.ms_aniso {
                Some(_) => crate::warp::square_to_cosine_hemisphere(u2),
                None => lobe_table(self.distribution).sample(
                    table_alpha(self.alpha_u.eval(sp), self.alpha_v.eval(sp)),
                    wi,
                    u1 / p_ms,
                    u2,
                ),
            }
        } else {
            let (m, pdf_m) = self.distr(sp).sample(wi, u2);
            let wo = reflect(wi, m);
            if pdf_m <= 0.0 || wo.dot(m) <= 0.0 {
                return None;
            }
            wo
        };
        if wo.z <= 0.0 {
            return None;
        }
        let (value, pdf) = self.eval_pdf_ms(sp, wi, wo);
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: value * (wo.z / pdf),
            pdf,
            lobe: LobeFlags::GLOSSY_REFLECTION,
            eta: 1.0,
        })
    }

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
    /// The single-scattering lobe samples with `u2` alone; the multiple-scattering one
    /// picks between its lobes with `u1`.
    fn sample_reads_u1(&self) -> bool {
        self.multiscatter
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
        if self.multiscatter {
            return self.eval_pdf_ms(sp, wi, wo).1;
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
        if self.multiscatter {
            return self.eval_pdf_ms(sp, wi, wo);
        }
        self.eval_pdf_ss(sp, wi, wo)
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
        if self.multiscatter {
            return self.sample_ms(sp, wi, u1, u2);
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
