//! `roughplastic`: a diffuse base under a rough dielectric coat (Mitsuba 3 `roughplastic`,
//! after Weidlich & Wilkie 2007). The coat's glossy reflection is a microfacet lobe
//! F·D·G/(4cosθi cosθo); the base is seen through the coat's rough *transmittance*
//! T(θ) = ∫ (1−F)·G1(refracted)·D_wi dm (the light that crosses the coat), precomputed in a
//! 64-entry table over cosθ and interpolated linearly, and its inter-reflections are summed with the coat's hemispherical
//! internal reflectance, exactly as Mitsuba does so that renders match.
//!
//! Specula option `multiscatter` (default `false`, Mitsuba's model): the coat becomes an
//! energy-compensated rough interface ([`crate::multiscatter`]), the same as
//! `roughdielectric multiscatter=true`: its single-scattering reflection is the random walk's
//! first event, height-correlated ([`MicrofacetDistribution::g2_correlated`] in place of
//! G1·G1), and the energy it loses, 1 − E(μ) (E: R + T of that model), is split as the
//! measured compensation lobes split it for that incidence
//! ([`crate::multiscatter::dielectric_lobe`]): the reflected part is the lobes' outside
//! reflection block, added to the coat's glossy reflection (cosine-sampled with the diffuse
//! base), the transmitted part enters the base (the base has no shape to give it): the coat
//! transmittance becomes T(μ) = T_ss(μ) + (1 − E(μ))(1 − share(μ)), evaluated exactly rather
//! than from the 64-entry table, and the internal reflectance is the one that reciprocity
//! implies, 1 − (2∫T(μ)μ dμ)/η², so that a white base under the coat reflects all the light
//! (white furnace 1 ± 0.5 %). With a black base the coat alone is a rough dielectric
//! interface whose transmitted light is absorbed: its reflection agrees with the random walk's
//! (test `plastic_coat_agrees_with_the_walk`).

use crate::bsdf::*;
use crate::frame::{reflect, refract};
use crate::fresnel::FresnelMode;
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::multiscatter::lobe::LOBE_MU;
use crate::multiscatter::DielectricEnergy;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::Arc;

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
    /// The coat's energy tables when `multiscatter` is on.
    multiscatter: Option<Arc<DielectricEnergy>>,
}

/// ∫ g(m) D_wi(m) dm over the normals visible from `wi` (upper hemisphere), by Gauss–Legendre
/// quadrature over the visible-normal sample space (`res`² nodes).
///
/// `g` must give the same bits for a normal and its mirror image across the xz-plane when `wi`
/// lies in that plane (`wi.y` = +0) and the normal has m.z > 0: the integrands below do (they
/// read m through products with `wi`, whose y is 0, and through dot products and squares of
/// directions mirrored with it; every sum they form ends in a nonzero z term, so not even the
/// sign of a zero differs). Then the nodes of each row of the grid that are mirror images,
/// bit for bit, of nodes before them (the Gauss–Legendre nodes are symmetric) reuse those
/// values: half the evaluations, the same sum in the same order, so the same result.
fn visible_normal_quadrature(
    distr: &MicrofacetDistribution,
    wi: Vec3,
    res: usize,
    g: impl Fn(Vec3) -> f32,
) -> f32 {
    let (x, w) = crate::quad::gauss_legendre_cached(res);
    let us: Vec<f32> = x.iter().map(|xj| (0.5 * xj + 0.5) as f32).collect();
    let in_plane = wi.y.to_bits() == 0;
    // this row's normals and values so far (the grid is visited row by row, k ascending)
    let mut row = vec![(Vec3::ZERO, 0.0f32); res];
    let mut sum = 0.0f64;
    distr.visible_normal_grid(wi, &us, |j, k, m| {
        let mirror = res - 1 - k;
        let v = match row.get(mirror) {
            Some(&(mm, v))
                if in_plane
                    && mirror < k
                    && m.z > 0.0
                    && m.y != 0.0
                    && mm.x.to_bits() == m.x.to_bits()
                    && mm.y.to_bits() == (-m.y).to_bits()
                    && mm.z.to_bits() == m.z.to_bits() =>
            {
                v
            }
            _ => g(m),
        };
        row[k] = (m, v);
        sum += v as f64 * w[j] * w[k] * 0.25;
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
/// share them share the work; a thread that asks for tables another thread is computing
/// waits for them rather than computing them again), the table's entries spread over the
/// available cores. (Scene loaders start them early by building the BSDF on another thread:
/// `specula_render`'s `scene` module.)
fn coat_tables(
    distr: &MicrofacetDistribution,
    distribution: MicrofacetType,
    rational_g1: bool,
    eta: f32,
    fresnel: FresnelMode,
) -> ([f32; TRANSMITTANCE_RES], f32) {
    use std::sync::{Mutex, OnceLock};
    type Key = (bool, u32, bool, u32, bool);
    type Tables = ([f32; TRANSMITTANCE_RES], f32);
    type Cache = Vec<(Key, Arc<OnceLock<Tables>>)>;
    static CACHE: OnceLock<Mutex<Cache>> = OnceLock::new();
    let key = (
        distribution == MicrofacetType::Ggx,
        distr.alpha_u.to_bits(),
        rational_g1,
        eta.to_bits(),
        fresnel == FresnelMode::Schlick,
    );
    let entry = {
        let mut cache = CACHE
            .get_or_init(Default::default)
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        match cache.iter().find(|(k, _)| *k == key) {
            Some((_, e)) => e.clone(),
            None => {
                let e = Arc::new(OnceLock::new());
                cache.push((key, e.clone()));
                e
            }
        }
    };
    *entry.get_or_init(|| compute_coat_tables(distr, eta, fresnel))
}

/// [`coat_tables`]' computation.
fn compute_coat_tables(
    distr: &MicrofacetDistribution,
    eta: f32,
    fresnel: FresnelMode,
) -> ([f32; TRANSMITTANCE_RES], f32) {
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
    (external_transmittance, internal_reflectance)
}

/// With `multiscatter`: the light that crosses the compensated coat from outside at cosine
/// `mu`, T_ss(μ) + (1 − E(μ))(1 − share(μ)): the height-correlated single-scattering
/// transmission and the part of the lost energy the measured lobes transmit.
#[inline]
fn coat_transmittance(
    ms: &DielectricEnergy,
    q: &crate::multiscatter::DielectricMs,
    mu: f32,
) -> f32 {
    let c = (1.0 - ms.e(q, true, mu)).max(0.0);
    ms.t_out.e(q.alpha, mu) + c * (1.0 - ms.reflected_share(q, mu))
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
            multiscatter: None,
        }
    }

    /// Switch the coat's energy compensation on (Specula's `multiscatter`; see the module).
    pub fn with_multiscatter(mut self, on: bool) -> Self {
        if !on {
            return self;
        }
        let alpha = self.alpha.min(1.0);
        let ms =
            DielectricEnergy::get(self.distribution, self.eta, self.fresnel, Some(alpha), true);
        let q = ms.at(alpha);
        for (i, t) in self.external_transmittance.iter_mut().enumerate() {
            let mu = i as f32 / (TRANSMITTANCE_RES - 1) as f32;
            *t = coat_transmittance(&ms, &q, mu);
        }
        // 2∫T(μ)μ dμ of the transmittance the model evaluates (piecewise smooth: Gauss–Legendre
        // within each μ bin of the lobe's shares)
        let (gx, gw) = crate::quad::gauss_legendre_cached(8);
        let mut t_avg = 0.0f64;
        for b in 0..LOBE_MU {
            let (m0, m1) = crate::multiscatter::lobe::mu_edges(b);
            for (x, w) in gx.iter().zip(gw.iter()) {
                let mu = m0 + (m1 - m0) * 0.5 * (x + 1.0);
                let t = coat_transmittance(&ms, &q, mu as f32) as f64;
                t_avg += 2.0 * t * mu * w * 0.5 * (m1 - m0);
            }
        }
        self.internal_reflectance = (1.0 - t_avg / (self.eta as f64).powi(2)) as f32;
        self.multiscatter = Some(ms);
        self
    }

    /// The coat's compensation lobe for (wi, wo) (reflection, outside: the measured lobes'
    /// reflection block, [`DielectricEnergy::lobe_eval`]) and its energy for `wi`.
    #[inline]
    fn ms_lobe(&self, ms: &DielectricEnergy, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let q = ms.at(self.alpha);
        let (fr, _) = ms.lobe_eval(&q, wi, wo);
        let energy = ms.reflected_share(&q, wi.z) * (1.0 - ms.e(&q, true, wi.z));
        (fr, energy)
    }

    /// The coat's transmittance for a cosine: linear interpolation in the table (Mitsuba's);
    /// with `multiscatter`, its exact value (see [`coat_transmittance`]).
    #[inline]
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        if let Some(ms) = &self.multiscatter {
            return coat_transmittance(ms, &ms.at(self.alpha), cos_theta);
        }
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

    /// (specular, cosine) sampling probabilities; `ms_energy`: the energy of the compensation
    /// lobe for wi (0 without `multiscatter`), which cosine sampling covers.
    #[inline]
    fn lobe_probs(&self, t_i: f32, ms_energy: f32) -> (f32, f32) {
        let ps = (1.0 - t_i) * self.specular_sampling_weight;
        let pd =
            t_i * (1.0 - self.specular_sampling_weight) + ms_energy * self.specular_sampling_weight;
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
        let ms_energy = match &self.multiscatter {
            Some(ms) => self.ms_lobe(ms, wi, wo).1,
            None => 0.0,
        };
        let (ps, pd) = self.lobe_probs(self.transmittance(ci), ms_energy);
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
        // with `multiscatter` the coat's single scattering is the walk's first event,
        // height-correlated (see the module)
        let g = if self.multiscatter.is_some() {
            distr.g2_correlated(wi, wo, h)
        } else {
            g1_i * distr.smith_g1(wo, h)
        };
        let (ms_value, ms_energy) = match &self.multiscatter {
            Some(ms) => self.ms_lobe(ms, wi, wo),
            None => (0.0, 0.0),
        };
        let spec = self.specular_reflectance.eval(sp) * (f * d * g / (4.0 * ci * co) + ms_value);
        let t_i = self.transmittance(ci);
        let t_o = self.transmittance(co);
        let rho = self.diffuse_reflectance.eval(sp);
        let denom = if self.nonlinear {
            1.0 - rho * self.internal_reflectance
        } else {
            Spectrum::splat(1.0 - self.internal_reflectance)
        };
        let value = spec + rho / denom * (FRAC_1_PI / (self.eta * self.eta) * t_i * t_o);
        let (ps, pd) = self.lobe_probs(t_i, ms_energy);
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
        let ms_energy = match &self.multiscatter {
            Some(ms) => self.ms_lobe(ms, wi, wi).1,
            None => 0.0,
        };
        let (ps, _) = self.lobe_probs(self.transmittance(wi.z), ms_energy);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// [`visible_normal_quadrature`] without the mirror shortcut: every node evaluated.
    fn quadrature_every_node(
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

    /// The coat tables' integrals with the mirror shortcut are the same bits as with every
    /// node evaluated, over distributions, roughness, G1 forms, Fresnel modes, both sides of
    /// the interface and the table's incidence cosines (and it is taken: about half the
    /// integrand's calls are saved).
    #[test]
    fn mirrored_nodes_give_the_same_bits() {
        use std::cell::Cell;
        let (mut calls, mut all) = (Cell::new(0usize), 0usize);
        let calls_ref = &calls;
        for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
            for alpha in [0.001f32, 0.05, 0.1, 0.3, 0.7, 1.5] {
                for rational in [false, true] {
                    let distr = MicrofacetDistribution::new(kind, alpha, alpha, true)
                        .with_rational_g1(rational);
                    for fresnel in [FresnelMode::Exact, FresnelMode::Schlick] {
                        for eta in [1.5f32, 1.0 / 1.5, 2.0, 0.5, 1.0001] {
                            for i in (0..TRANSMITTANCE_RES).step_by(3).chain([63]) {
                                let mu = (i as f32 / 63.0).max(1e-6);
                                let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                                let res = if (i + kind as usize).is_multiple_of(2) {
                                    16
                                } else {
                                    32
                                };
                                let albedo = |m: Vec3| {
                                    calls_ref.set(calls_ref.get() + 1);
                                    let wo = reflect(wi, m);
                                    if wo.z <= 0.0 {
                                        return 0.0;
                                    }
                                    fresnel.eval(wi.dot(m), eta).r * distr.smith_g1(wo, m)
                                };
                                let a = visible_normal_quadrature(&distr, wi, res, albedo);
                                let b = quadrature_every_node(&distr, wi, res, |m| {
                                    let wo = reflect(wi, m);
                                    if wo.z <= 0.0 {
                                        return 0.0;
                                    }
                                    fresnel.eval(wi.dot(m), eta).r * distr.smith_g1(wo, m)
                                });
                                all += res * res;
                                assert_eq!(
                                    a.to_bits(),
                                    b.to_bits(),
                                    "{kind:?} α {alpha} η {eta} μ {mu}"
                                );
                                let t = rough_specular_transmittance(&distr, fresnel, wi, eta, res);
                                let u = quadrature_every_node(&distr, wi, res, |m| {
                                    let f = fresnel.eval(wi.dot(m), eta);
                                    let wt = refract(wi, m, f.cos_theta_t, f.eta_ti);
                                    if wt.z * wi.z >= 0.0 {
                                        return 0.0;
                                    }
                                    (1.0 - f.r) * distr.smith_g1(wt, m)
                                });
                                assert_eq!(
                                    t.to_bits(),
                                    u.to_bits(),
                                    "{kind:?} α {alpha} η {eta} μ {mu}"
                                );
                                assert_eq!(
                                    rough_specular_albedo(&distr, fresnel, wi, eta, res).to_bits(),
                                    a.to_bits()
                                );
                            }
                        }
                    }
                }
            }
        }
        let calls = *calls.get_mut();
        eprintln!("integrand calls: {calls} of {all} nodes");
        assert!(calls * 10 < all * 9, "{calls} of {all}");
    }
}
