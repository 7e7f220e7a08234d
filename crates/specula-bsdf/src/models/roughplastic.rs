//! `roughplastic`: a diffuse base under a rough dielectric coat (Mitsuba 3 `roughplastic`,
//! after Weidlich & Wilkie 2007). The coat's glossy reflection is a microfacet lobe
//! F·D·G/(4cosθi cosθo); the base is seen through the coat's rough *transmittance*
//! T(θ) = ∫ (1−F)·G1(refracted)·D_wi dm (the light that crosses the coat), precomputed in a
//! 64-entry table over cosθ and interpolated linearly, and its inter-reflections are summed with the coat's hemispherical
//! internal reflectance, exactly as Mitsuba does so that renders match.

use crate::bsdf::*;
use crate::frame::{reflect, refract};
use crate::fresnel::FresnelMode;
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// Resolution of the transmittance table over cosθ.
pub const TRANSMITTANCE_RES: usize = 64;

#[derive(Clone, Debug)]
pub struct RoughPlastic {
    pub distribution: MicrofacetType,
    pub alpha: f32,
    pub sample_visible: bool,
    /// Beckmann: Mitsuba's rational approximation of G1 instead of the exact one.
    pub rational_g1: bool,
    pub diffuse_reflectance: SpectrumParam,
    pub specular_reflectance: SpectrumParam,
    pub eta: f32,
    pub nonlinear: bool,
    pub fresnel: FresnelMode,
    specular_sampling_weight: f32,
    external_transmittance: [f32; TRANSMITTANCE_RES],
    internal_reflectance: f32,
}

/// ∫ g(m) D_wi(m) dm over the normals visible from `wi` (upper hemisphere), by Gauss–Legendre
/// quadrature over the visible-normal sample space (`res`² nodes).
fn visible_normal_quadrature(
    distr: &MicrofacetDistribution,
    wi: Vec3,
    res: usize,
    g: impl Fn(Vec3) -> f32,
) -> f32 {
    let (x, w) = crate::quad::gauss_legendre_cached(res);
    let us: Vec<f32> = x.iter().map(|xj| (0.5 * xj + 0.5) as f32).collect();
    let mut sum = 0.0f64;
    distr.visible_normal_grid(wi, &us, |j, k, m| {
        sum += g(m) as f64 * w[j] * w[k] * 0.25;
    });
    sum as f32
}

/// Specular albedo of a rough dielectric interface seen from direction `wi` (upper
/// hemisphere): ∫ F(wi·m) G1(wo,m) D_wi(m) dm, with wo the mirror direction about m.
pub fn rough_specular_albedo(
    distr: &MicrofacetDistribution,
    fresnel: FresnelMode,
    wi: Vec3,
    eta: f32,
    res: usize,
) -> f32 {
    visible_normal_quadrature(distr, wi, res, |m| {
        let wo = reflect(wi, m);
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        fresnel.eval(wi.dot(m), eta).r * distr.smith_g1(wo, m)
    })
}

/// Transmittance of a rough dielectric interface for light arriving from `wi` (upper
/// hemisphere): ∫ (1 − F(wi·m)) G1(wt,m) D_wi(m) dm, with wt the direction refracted by m.
/// This is the energy that actually crosses the coat: 1 − albedo would also count the light
/// the microsurface shadows after reflection as transmitted.
pub fn rough_specular_transmittance(
    distr: &MicrofacetDistribution,
    fresnel: FresnelMode,
    wi: Vec3,
    eta: f32,
    res: usize,
) -> f32 {
    visible_normal_quadrature(distr, wi, res, |m| {
        let f = fresnel.eval(wi.dot(m), eta);
        let wt = refract(wi, m, f.cos_theta_t, f.eta_ti);
        if wt.z * wi.z >= 0.0 {
            return 0.0;
        }
        (1.0 - f.r) * distr.smith_g1(wt, m)
    })
}

/// The coat's transmittance table over cosθ and its hemispherical internal reflectance, for
/// one (distribution, α, G1 form, η, Fresnel): computed once per process (materials that
/// share them share the work), the table's entries spread over the available cores.
fn coat_tables(
    distr: &MicrofacetDistribution,
    distribution: MicrofacetType,
    rational_g1: bool,
    eta: f32,
    fresnel: FresnelMode,
) -> ([f32; TRANSMITTANCE_RES], f32) {
    use std::sync::{Mutex, OnceLock};
    type Key = (bool, u32, bool, u32, bool);
    type Tables = Vec<(Key, ([f32; TRANSMITTANCE_RES], f32))>;
    static CACHE: OnceLock<Mutex<Tables>> = OnceLock::new();
    let key = (
        distribution == MicrofacetType::Ggx,
        distr.alpha_u.to_bits(),
        rational_g1,
        eta.to_bits(),
        fresnel == FresnelMode::Schlick,
    );
    let cache = CACHE.get_or_init(Default::default);
    if let Some((_, t)) = cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .iter()
        .find(|(k, _)| *k == key)
    {
        return *t;
    }
    // per node: (transmittance, internal reflectance × μ)
    let node = |i: usize| {
        let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let res_ext = if eta > 1.0 { 32 } else { 128 };
        let res_int = if 1.0 / eta > 1.0 { 32 } else { 128 };
        (
            rough_specular_transmittance(distr, fresnel, wi, eta, res_ext),
            (rough_specular_albedo(distr, fresnel, wi, 1.0 / eta, res_int) * mu) as f64,
        )
    };
    let mut nodes = [(0.0f32, 0.0f64); TRANSMITTANCE_RES];
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(TRANSMITTANCE_RES);
    let chunk = TRANSMITTANCE_RES.div_ceil(threads);
    std::thread::scope(|scope| {
        for (c, part) in nodes.chunks_mut(chunk).enumerate() {
            let node = &node;
            scope.spawn(move || {
                for (j, v) in part.iter_mut().enumerate() {
                    *v = node(c * chunk + j);
                }
            });
        }
    });
    let mut external_transmittance = [0.0; TRANSMITTANCE_RES];
    let mut internal = 0.0f64;
    for (t, (ti, ri)) in external_transmittance.iter_mut().zip(nodes) {
        *t = ti;
        internal += ri;
    }
    // Mitsuba's estimate of the hemispherical average 2∫R(μ)μ dμ: twice the mean over the
    // table's nodes
    let internal_reflectance = (2.0 * internal / TRANSMITTANCE_RES as f64) as f32;
    let t = (external_transmittance, internal_reflectance);
    cache
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .push((key, t));
    t
}

impl RoughPlastic {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        distribution: MicrofacetType,
        alpha: f32,
        sample_visible: bool,
        rational_g1: bool,
        diffuse_reflectance: SpectrumParam,
        specular_reflectance: SpectrumParam,
        eta: f32,
        nonlinear: bool,
        fresnel: FresnelMode,
    ) -> Self {
        let distr = MicrofacetDistribution::new(distribution, alpha, alpha, true)
            .with_rational_g1(rational_g1);
        let (external_transmittance, internal_reflectance) =
            coat_tables(&distr, distribution, rational_g1, eta, fresnel);
        let specular_sampling_weight =
            super::plastic::sampling_weight(&diffuse_reflectance, &specular_reflectance);
        RoughPlastic {
            distribution,
            alpha: distr.alpha_u,
            sample_visible,
            rational_g1,
            diffuse_reflectance,
            specular_reflectance,
            eta,
            nonlinear,
            fresnel,
            specular_sampling_weight,
            external_transmittance,
            internal_reflectance,
        }
    }

    /// The coat's transmittance for a cosine (linear interpolation in the table).
    #[inline]
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        let x = cos_theta * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x.max(0.0) as usize).min(TRANSMITTANCE_RES - 2);
        let w1 = x - i as f32;
        (1.0 - w1) * self.external_transmittance[i] + w1 * self.external_transmittance[i + 1]
    }

    /// Hemispherical internal reflectance of the coat.
    pub fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }

    #[inline]
    fn distr(&self) -> MicrofacetDistribution {
        MicrofacetDistribution::new(
            self.distribution,
            self.alpha,
            self.alpha,
            self.sample_visible,
        )
        .with_rational_g1(self.rational_g1)
    }

    #[inline]
    fn lobe_probs(&self, t_i: f32) -> (f32, f32) {
        let ps = (1.0 - t_i) * self.specular_sampling_weight;
        let pd = t_i * (1.0 - self.specular_sampling_weight);
        let ps = ps / (ps + pd);
        (ps, 1.0 - ps)
    }
}

impl BsdfModel for RoughPlastic {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION | LobeFlags::DIFFUSE_REFLECTION
    }

    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(ctx, sp, wi, wo).0
    }

    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        let (ci, co) = (wi.z, wo.z);
        if ci <= 0.0 || co <= 0.0 {
            return 0.0;
        }
        let (ps, pd) = self.lobe_probs(self.transmittance(ci));
        let h = (wi + wo).normalize();
        let distr = self.distr();
        let spec = if self.sample_visible {
            distr.eval(h) * distr.smith_g1(wi, h) / (4.0 * ci)
        } else {
            distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        ps * spec + pd * warp::square_to_cosine_hemisphere_pdf(wo)
    }

    /// The value and the pdf, sharing the half vector, D, G1(wi) and the coat's transmittance
    /// (`eval` is its value; `pdf` alone skips the value's Fresnel and G1(wo)).
    fn eval_pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let (ci, co) = (wi.z, wo.z);
        if ci <= 0.0 || co <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let distr = self.distr();
        let h = (wi + wo).normalize();
        let d = distr.eval(h);
        let g1_i = distr.smith_g1(wi, h);
        let f = self.fresnel.eval(wi.dot(h), self.eta).r;
        let g = g1_i * distr.smith_g1(wo, h);
        let spec = self.specular_reflectance.eval(sp) * (f * d * g / (4.0 * ci * co));
        let t_i = self.transmittance(ci);
        let t_o = self.transmittance(co);
        let rho = self.diffuse_reflectance.eval(sp);
        let denom = if self.nonlinear {
            1.0 - rho * self.internal_reflectance
        } else {
            Spectrum::splat(1.0 - self.internal_reflectance)
        };
        let value = spec + rho / denom * (FRAC_1_PI / (self.eta * self.eta) * t_i * t_o);
        let (ps, pd) = self.lobe_probs(t_i);
        let spec_pdf = if self.sample_visible {
            d * g1_i / (4.0 * ci)
        } else {
            distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        let pdf = ps * spec_pdf + pd * warp::square_to_cosine_hemisphere_pdf(wo);
        (value, pdf)
    }

    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let (ps, _) = self.lobe_probs(self.transmittance(wi.z));
        let (wo, lobe) = if u1 < ps {
            let (m, _) = self.distr().sample(wi, u2);
            (reflect(wi, m), LobeFlags::GLOSSY_REFLECTION)
        } else {
            (
                warp::square_to_cosine_hemisphere(u2),
                LobeFlags::DIFFUSE_REFLECTION,
            )
        };
        if wo.z <= 0.0 {
            return None;
        }
        let (value, pdf) = self.eval_pdf(ctx, sp, wi, wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let weight = value * (wo.z / pdf);
        Some(BsdfSample {
            wo,
            weight,
            pdf,
            lobe,
            eta: 1.0,
        })
    }
}
