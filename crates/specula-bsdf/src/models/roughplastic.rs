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
use crate::multiscatter::{DielectricEnergy, DielectricMs};
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
    /// The coat's energy tables and their quantities at its roughness when `multiscatter` is
    /// on.
    multiscatter: Option<(Arc<DielectricEnergy>, DielectricMs)>,
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
        albedo_integrand(distr, fresnel, wi, eta, m)
    })
}

/// The integrand of [`rough_specular_albedo`] at the microfacet normal `m`.
#[inline(always)]
fn albedo_integrand(
    distr: &MicrofacetDistribution,
    fresnel: FresnelMode,
    wi: Vec3,
    eta: f32,
    m: Vec3,
) -> f32 {
    let wo = reflect(wi, m);
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    fresnel.eval(wi.dot(m), eta).r * distr.smith_g1(wo, m)
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
        transmittance_integrand(distr, fresnel, wi, eta, m)
    })
}

/// The integrand of [`rough_specular_transmittance`] at the microfacet normal `m`.
#[inline(always)]
fn transmittance_integrand(
    distr: &MicrofacetDistribution,
    fresnel: FresnelMode,
    wi: Vec3,
    eta: f32,
    m: Vec3,
) -> f32 {
    let f = fresnel.eval(wi.dot(m), eta);
    let wt = refract(wi, m, f.cos_theta_t, f.eta_ti);
    if wt.z * wi.z >= 0.0 {
        return 0.0;
    }
    (1.0 - f.r) * distr.smith_g1(wt, m)
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

/// The part of [`visible_normal_quadrature`]'s rule (`res` Gauss–Legendre nodes per
/// coordinate of the visible-normal sample space) that does not depend on the incidence,
/// folded by the rule's mirror symmetry for incidences in the xz-plane (`wi.y` = 0), which is
/// exact by construction: the Gauss–Legendre nodes are symmetric about the middle of [0, 1],
/// and the sample coordinate u ↦ 1 − u that maps a node to its partner mirrors the visible
/// normal across the xz-plane (Beckmann: the cross slope erfinv(2u − 1) is odd in the second
/// coordinate; GGX: the concentric disk point's x, which becomes the normal's y, is odd in the
/// first). Both integrands read the normal's y only through its square when `wi.y` = 0 (they
/// see it through `wi`·m, in which it meets wi.y = 0, and through squared lengths), so one node
/// of each pair is evaluated, with twice the weight.
struct CoatGrid {
    /// All sample coordinates (0.5 x + 0.5 for the Gauss–Legendre nodes x on [−1, 1]), as
    /// [`visible_normal_quadrature`] forms them.
    us: Vec<f32>,
    /// The weights of the coordinate that is not folded, w/2 (the rule on [0, 1]).
    row_weights: Vec<f64>,
    /// Beckmann: (unit-roughness cross slope y ≥ 0, w/2 × multiplicity) for the kept nodes of
    /// the second coordinate.
    cross: Vec<(f32, f64)>,
    /// GGX: the concentric disk point (x ≥ 0, y, √(1 − x²)) of every kept node (first
    /// coordinate in the upper half, second any) and its weight w_j w_k / 4 × multiplicity.
    disk: Vec<(f32, f32, f32, f64)>,
}

impl CoatGrid {
    fn new(kind: MicrofacetType, res: usize) -> Self {
        let (x, w) = crate::quad::gauss_legendre_cached(res);
        let us: Vec<f32> = x.iter().map(|xj| (0.5 * xj + 0.5) as f32).collect();
        let row_weights: Vec<f64> = w.iter().map(|wj| 0.5 * wj).collect();
        // the kept half: node j stands for itself and its partner res − 1 − j
        let kept = |j: usize| {
            let partner = res - 1 - j;
            (partner <= j).then_some(if partner == j { 1.0 } else { 2.0 })
        };
        let mut cross = Vec::new();
        let mut disk = Vec::new();
        match kind {
            MicrofacetType::Beckmann => {
                for (k, &u) in us.iter().enumerate() {
                    if let Some(mult) = kept(k) {
                        let y = crate::microfacet::beckmann_cross_slope(u);
                        cross.push((y, row_weights[k] * mult));
                    }
                }
            }
            MicrofacetType::Ggx => {
                for (j, &uj) in us.iter().enumerate() {
                    if let Some(mult) = kept(j) {
                        for (k, &uk) in us.iter().enumerate() {
                            let p = warp::square_to_uniform_disk_concentric(Vec2::new(uj, uk));
                            let h = (1.0 - p.x * p.x).max(0.0).sqrt();
                            disk.push((p.x, p.y, h, row_weights[j] * row_weights[k] * mult));
                        }
                    }
                }
            }
        }
        CoatGrid {
            us,
            row_weights,
            cross,
            disk,
        }
    }
}

/// [`visible_normal_quadrature`] over a [`CoatGrid`], for an incidence `wi` in the xz-plane
/// (`wi.y` = 0) and one of the coat tables' integrands: the same nodes and weights, the
/// visible normals computed directly (one normalisation of the unstretched normal instead of
/// two, the concentric disk points and the cross slopes shared by all incidences), each
/// mirrored pair evaluated once, the integrand evaluated on blocks of normals
/// ([`CoatIntegrand::eval_block`]). Equal to [`visible_normal_quadrature`] up to rounding
/// (`fast_coat_tables_match_the_straightforward_rule`).
fn coat_quadrature(
    distr: &MicrofacetDistribution,
    grid: &CoatGrid,
    integrand: &CoatIntegrand,
) -> f32 {
    let wi = integrand.wi;
    debug_assert!(wi.y == 0.0 && distr.is_isotropic());
    let alpha = distr.alpha_u;
    // the view in the configuration of unit roughness
    let wi_s = Vec3::new(alpha * wi.x, 0.0, wi.z).normalize();
    let mut block = NormalBlock::new();
    let mut sum = 0.0f64;
    match distr.kind {
        MicrofacetType::Beckmann => {
            // unstretched normal ∝ (−α x, −α y, 1) for the visible slopes (x along the view's
            // azimuth, +x here; y across it)
            let mut slope_x = vec![0.0f32; grid.us.len()];
            crate::microfacet::beckmann_view_slopes(
                wi_s.z.clamp(1e-6, 1.0),
                &grid.us,
                &mut slope_x,
            );
            for (&x, &wj) in slope_x.iter().zip(&grid.row_weights) {
                let mx = -alpha * x;
                let row = mx * mx + 1.0;
                let mut cross = &grid.cross[..];
                while !cross.is_empty() {
                    // as much of the row as the block holds
                    let (n0, len) = (block.n, cross.len().min(BLOCK - block.n));
                    let lanes = n0..n0 + len;
                    let (bx, by, bz) = (
                        &mut block.x[lanes.clone()],
                        &mut block.y[lanes.clone()],
                        &mut block.z[lanes.clone()],
                    );
                    let bw = &mut block.w[lanes];
                    for (k, &(y, wk)) in cross[..len].iter().enumerate() {
                        let my = alpha * y;
                        let inv = 1.0 / (row + my * my).sqrt();
                        (bx[k], by[k], bz[k], bw[k]) = (mx * inv, my * inv, inv, wj * wk);
                    }
                    block.n += len;
                    cross = &cross[len..];
                    if block.n == BLOCK {
                        sum += integrand.eval_block(&block);
                        block.n = 0;
                    }
                }
            }
        }
        MicrofacetType::Ggx => {
            // Heitz's (2018) construction: the disk point's upper half compressed by the view's
            // projection, lifted onto the hemisphere around the view
            let len2 = wi_s.x * wi_s.x;
            let t1 = if len2 > 0.0 {
                Vec3::new(0.0, wi_s.x / len2.sqrt(), 0.0)
            } else {
                Vec3::X
            };
            let t2 = wi_s.cross(t1);
            let s = 0.5 * (1.0 + wi_s.z);
            for &(px, py, h, w) in &grid.disk {
                let py = (1.0 - s) * h + s * py;
                let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
                let m_s = px * t1 + py * t2 + pz * wi_s;
                let m = Vec3::new(alpha * m_s.x, alpha * m_s.y, m_s.z.max(0.0)).normalize();
                if block.push(m, w) {
                    sum += integrand.eval_block(&block);
                    block.n = 0;
                }
            }
        }
    }
    if block.n > 0 {
        sum += integrand.eval_block(&block);
    }
    sum as f32
}

/// From this a = 1/(α tanθ) on, Beckmann's exact G1 = 1/(1 + Λ(a)) is 1 in single precision
/// (Λ < 2⁻²⁵; Λ vanishes from a = 9 on): checked for every f32 up to 9 by
/// `beckmann_g1_is_one_from_the_threshold` (the first a below 9 where it is not is 3.31).
const BECKMANN_G1_IS_ONE: f32 = 3.5;

/// The number of normals [`CoatIntegrand::eval_block`] evaluates at once.
const BLOCK: usize = 64;

/// Visible normals (structure of arrays) and their quadrature weights; the first `n` are set.
struct NormalBlock {
    x: [f32; BLOCK],
    y: [f32; BLOCK],
    z: [f32; BLOCK],
    w: [f64; BLOCK],
    n: usize,
}

impl NormalBlock {
    fn new() -> Self {
        NormalBlock {
            x: [0.0; BLOCK],
            y: [0.0; BLOCK],
            z: [1.0; BLOCK],
            w: [0.0; BLOCK],
            n: 0,
        }
    }

    /// Append a normal; true when the block is full.
    #[inline]
    fn push(&mut self, m: Vec3, w: f64) -> bool {
        let i = self.n;
        self.x[i] = m.x;
        self.y[i] = m.y;
        self.z[i] = m.z;
        self.w[i] = w;
        self.n = i + 1;
        self.n == BLOCK
    }
}

/// One of the coat tables' integrands for an incidence `wi` in the xz-plane:
/// [`transmittance_integrand`] (`transmit`) or [`albedo_integrand`], the same expressions
/// written without branches so that a block of normals is evaluated in SIMD lanes, except
/// Beckmann's exact Λ (two exponentials), which is evaluated afterwards only where G1 differs
/// from 1 (a = 1/(α tanθ) < [`BECKMANN_G1_IS_ONE`]).
#[derive(Clone, Copy, Debug)]
struct CoatIntegrand {
    wi: Vec3,
    eta: f32,
    alpha: f32,
    transmit: bool,
    schlick: bool,
    g1: G1Form,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum G1Form {
    BeckmannExact,
    BeckmannRational,
    Ggx,
}

impl CoatIntegrand {
    fn new(
        distr: &MicrofacetDistribution,
        fresnel: FresnelMode,
        wi: Vec3,
        eta: f32,
        transmit: bool,
    ) -> Self {
        CoatIntegrand {
            wi,
            eta,
            alpha: distr.alpha_u,
            transmit,
            schlick: fresnel == FresnelMode::Schlick,
            g1: match distr.kind {
                MicrofacetType::Ggx => G1Form::Ggx,
                MicrofacetType::Beckmann if distr.rational_g1 => G1Form::BeckmannRational,
                MicrofacetType::Beckmann => G1Form::BeckmannExact,
            },
        }
    }

    /// Σ integrand × weight over the block's normals.
    fn eval_block(&self, b: &NormalBlock) -> f64 {
        let mut out = [0.0f32; BLOCK];
        let mut a = [0.0f32; BLOCK];
        macro_rules! lanes {
            ($($t:literal, $s:literal, $g:literal;)*) => {
                match (self.transmit, self.schlick, self.g1 as u8) {
                    $(($t, $s, $g) => self.lanes::<$t, $s, $g>(b, &mut out, &mut a),)*
                    _ => unreachable!(),
                }
            };
        }
        lanes! {
            false, false, 0; false, false, 1; false, false, 2;
            false, true, 0; false, true, 1; false, true, 2;
            true, false, 0; true, false, 1; true, false, 2;
            true, true, 0; true, true, 1; true, true, 2;
        }
        let n = b.n;
        if self.g1 == G1Form::BeckmannExact {
            // the lanes where G1 < 1, listed first (the exponentials are pure: under a
            // condition, the compiler would evaluate them for every lane)
            let mut need = [0u8; BLOCK];
            let mut m = 0;
            for (i, &a) in a[..n].iter().enumerate() {
                need[m] = i as u8;
                m += (a < BECKMANN_G1_IS_ONE) as usize;
            }
            for &i in &need[..m] {
                let i = i as usize;
                out[i] *= 1.0 / (1.0 + crate::microfacet::beckmann_lambda(a[i]));
            }
        }
        out[..n]
            .iter()
            .zip(&b.w[..n])
            .map(|(&v, &w)| v as f64 * w)
            .sum()
    }

    /// The integrand in every lane (`G`: a [`G1Form`] as u8). For Beckmann's exact G1 the
    /// lanes hold the integrand without G1 and `a_out` holds a = 1/(α tanθ) of the outgoing
    /// direction (+∞ where G1 = 1 or the integrand is 0).
    #[inline(always)]
    fn lanes<const TRANSMIT: bool, const SCHLICK: bool, const G: u8>(
        &self,
        b: &NormalBlock,
        out: &mut [f32; BLOCK],
        a_out: &mut [f32; BLOCK],
    ) {
        let (wx, wz) = (self.wi.x, self.wi.z);
        let eta = self.eta;
        let inv_eta = 1.0 / eta;
        let alpha = self.alpha;
        let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        for i in 0..BLOCK {
            let (mx, my, mz) = (b.x[i], b.y[i], b.z[i]);
            let c = wx * mx + wz * mz;
            // fresnel_dielectric
            let outside = c >= 0.0;
            let eta_it = if outside { eta } else { inv_eta };
            let eta_ti = if outside { inv_eta } else { eta };
            let cos_t_sqr = 1.0 - (1.0 - c * c) * eta_ti * eta_ti;
            let ci = c.abs();
            let ct = cos_t_sqr.max(0.0).sqrt();
            let tir = ci == 0.0 || cos_t_sqr <= 0.0;
            let (ds, dp) = (ci + eta_it * ct, ct + eta_it * ci);
            let r = if SCHLICK {
                // fresnel_schlick: 1 where the exact transmittance is 0
                let k = 2.0 * eta_it * ci * ct;
                let t = k / (ds * ds) + k / (dp * dp);
                let cs = if eta_it >= 1.0 { ci } else { ct };
                let r = f0 + (1.0 - f0) * (1.0 - cs).powi(5);
                if tir || t <= 0.0 {
                    1.0
                } else {
                    r
                }
            } else {
                let a_s = (ci - eta_it * ct) / ds;
                let a_p = (ct - eta_it * ci) / dp;
                let r = 0.5 * (a_s * a_s + a_p * a_p);
                if tir {
                    1.0
                } else {
                    r
                }
            };
            let r = if eta == 1.0 { 0.0 } else { r };
            // the outgoing direction: refracted (refract) or reflected (reflect) by m
            let (ox, oy, oz, valid, f) = if TRANSMIT {
                let cos_theta_t = if outside { -ct } else { ct };
                let k = c * eta_ti + cos_theta_t;
                let (ox, oy, oz) = (mx * k - wx * eta_ti, my * k, mz * k - wz * eta_ti);
                // not (wt.z·wi.z ≥ 0), NaN included as in the scalar integrand
                let p = oz * wz;
                (ox, oy, oz, p < 0.0 || p.is_nan(), 1.0 - r)
            } else {
                let c2 = 2.0 * c;
                let (ox, oy, oz) = (c2 * mx - wx, c2 * my, c2 * mz - wz);
                (ox, oy, oz, oz > 0.0 && wz > 0.0, r)
            };
            // smith_g1(o, m)
            let p = (ox * mx + oy * my + oz * mz) * oz;
            let valid = valid && (p > 0.0 || p.is_nan());
            let xy = (alpha * ox).powi(2) + (alpha * oy).powi(2);
            let tan2 = xy / (oz * oz);
            let g1 = match G {
                0 => {
                    let a = 1.0 / tan2.sqrt();
                    a_out[i] = if valid && xy != 0.0 { a } else { f32::INFINITY };
                    1.0
                }
                1 => {
                    let a = 1.0 / tan2.sqrt();
                    let a2 = a * a;
                    let g = (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2);
                    if a >= 1.6 || xy == 0.0 {
                        1.0
                    } else {
                        g
                    }
                }
                _ => {
                    let g = 2.0 / (1.0 + (1.0 + tan2).sqrt());
                    if xy == 0.0 {
                        1.0
                    } else {
                        g
                    }
                }
            };
            out[i] = if valid { f * g1 } else { 0.0 };
        }
    }
}

/// [`coat_tables`]' computation.
fn compute_coat_tables(
    distr: &MicrofacetDistribution,
    eta: f32,
    fresnel: FresnelMode,
) -> ([f32; TRANSMITTANCE_RES], f32) {
    let res_ext = if eta > 1.0 { 32 } else { 128 };
    let res_int = if 1.0 / eta > 1.0 { 32 } else { 128 };
    let grid_ext = CoatGrid::new(distr.kind, res_ext);
    let grid_int = (res_int != res_ext).then(|| CoatGrid::new(distr.kind, res_int));
    let grid_int = grid_int.as_ref().unwrap_or(&grid_ext);
    // per node: (transmittance, internal reflectance × μ)
    let node = |i: usize| {
        let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let inv_eta = 1.0 / eta;
        let transmittance = CoatIntegrand::new(distr, fresnel, wi, eta, true);
        let albedo = CoatIntegrand::new(distr, fresnel, wi, inv_eta, false);
        (
            coat_quadrature(distr, &grid_ext, &transmittance),
            (coat_quadrature(distr, grid_int, &albedo) * mu) as f64,
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
fn coat_transmittance(ms: &DielectricEnergy, q: &DielectricMs, mu: f32) -> f32 {
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
        // (the 64-entry table is not read any more: `transmittance` evaluates T exactly)
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
        self.multiscatter = Some((ms, q));
        self
    }

    /// The coat's compensation lobe for (wi, wo) (reflection, outside: the measured lobes'
    /// reflection block, [`DielectricEnergy::lobe_eval`]) and its energy for `wi`.
    #[inline]
    fn ms_lobe(&self, ms: &DielectricEnergy, q: &DielectricMs, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let (fr, _) = ms.lobe_eval(q, wi, wo);
        let energy = ms.reflected_share(q, wi.z) * (1.0 - ms.e(q, true, wi.z));
        (fr, energy)
    }

    /// The coat's transmittance for a cosine: linear interpolation in the table (Mitsuba's);
    /// with `multiscatter`, its exact value (see `coat_transmittance`).
    #[inline]
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        if let Some((ms, q)) = &self.multiscatter {
            return coat_transmittance(ms, q, cos_theta);
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
            Some((ms, q)) => self.ms_lobe(ms, q, wi, wo).1,
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
            Some((ms, q)) => self.ms_lobe(ms, q, wi, wo),
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
            Some((ms, q)) => self.ms_lobe(ms, q, wi, wi).1,
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

    /// The coat tables as [`compute_coat_tables`] computed them before [`coat_quadrature`]:
    /// every entry by the straightforward evaluation of the rule ([`visible_normal_grid`]'s
    /// normals, the integrands through [`rough_specular_transmittance`] and
    /// [`rough_specular_albedo`]).
    ///
    /// [`visible_normal_grid`]: MicrofacetDistribution::visible_normal_grid
    fn reference_coat_tables(
        distr: &MicrofacetDistribution,
        eta: f32,
        fresnel: FresnelMode,
    ) -> ([f32; TRANSMITTANCE_RES], f32) {
        let mut t = [0.0f32; TRANSMITTANCE_RES];
        let mut internal = 0.0f64;
        for (i, ti) in t.iter_mut().enumerate() {
            let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let res_ext = if eta > 1.0 { 32 } else { 128 };
            let res_int = if 1.0 / eta > 1.0 { 32 } else { 128 };
            *ti = rough_specular_transmittance(distr, fresnel, wi, eta, res_ext);
            internal += (rough_specular_albedo(distr, fresnel, wi, 1.0 / eta, res_int) * mu) as f64;
        }
        (t, (2.0 * internal / TRANSMITTANCE_RES as f64) as f32)
    }

    /// The folded quadrature of the coat tables ([`coat_quadrature`]) agrees with the
    /// straightforward evaluation of the same rule to rounding, over distributions, G1 forms,
    /// roughness α 0.001…1, η 1.1…3 and 1/η, and both Fresnel modes: the internal reflectance
    /// within 1e-6 relative, and so every transmittance entry of a coat denser than the
    /// outside (η > 1). For η < 1 light from outside meets a critical angle, where 1 − F has a
    /// square-root edge (∝ cosθt) that turns rounding-level differences of the normals near it
    /// into larger ones: there the entries agree within 1e-5 absolute (the largest change,
    /// 4.4e-6 of 0.218, is at the entry next to the critical angle with α = 0.001).
    #[test]
    fn fast_coat_tables_match_the_straightforward_rule() {
        let mut cases = Vec::new();
        for (kind, rational) in [
            (MicrofacetType::Beckmann, false),
            (MicrofacetType::Beckmann, true),
            (MicrofacetType::Ggx, false),
        ] {
            for alpha in [0.001f32, 0.005, 0.02, 0.1, 0.3, 1.0] {
                for eta in [1.1f32, 1.5, 2.0, 3.0, 1.0 / 1.1, 1.0 / 1.5, 1.0 / 3.0] {
                    for fresnel in [FresnelMode::Exact, FresnelMode::Schlick] {
                        cases.push((kind, rational, alpha, eta, fresnel));
                    }
                }
            }
        }
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        // the largest relative change of T (η > 1) and of R, the largest absolute one of T
        // (η < 1)
        let worst = std::sync::Mutex::new([0.0f64; 3]);
        std::thread::scope(|scope| {
            for part in cases.chunks(cases.len().div_ceil(threads)) {
                let worst = &worst;
                scope.spawn(move || {
                    for &(kind, rational, alpha, eta, fresnel) in part {
                        let case = format!("{kind:?} rational {rational} α {alpha} η {eta}");
                        let distr = MicrofacetDistribution::new(kind, alpha, alpha, true)
                            .with_rational_g1(rational);
                        let (t, r) = compute_coat_tables(&distr, eta, fresnel);
                        let (t_ref, r_ref) = reference_coat_tables(&distr, eta, fresnel);
                        // (an entry that is exactly zero, at grazing incidence, must stay so)
                        let rel = |a: f32, b: f32| {
                            assert!(b >= 0.0 && a.is_finite(), "{case}: {a} vs {b}");
                            if a == b {
                                0.0
                            } else {
                                ((a as f64 - b as f64) / b as f64).abs()
                            }
                        };
                        let mut w = worst.lock().unwrap();
                        for (i, (&a, &b)) in t.iter().zip(&t_ref).enumerate() {
                            if eta > 1.0 {
                                let d = rel(a, b);
                                assert!(d <= 1e-6, "{case} {fresnel:?} T[{i}] {a} vs {b}");
                                w[0] = w[0].max(d);
                            } else {
                                let d = (a as f64 - b as f64).abs();
                                assert!(d <= 1e-5, "{case} {fresnel:?} T[{i}] {a} vs {b}");
                                w[2] = w[2].max(d);
                            }
                        }
                        let d = rel(r, r_ref);
                        assert!(d <= 1e-6, "{case} {fresnel:?} R {r} vs {r_ref}");
                        w[1] = w[1].max(d);
                    }
                });
            }
        });
        let w = worst.into_inner().unwrap();
        eprintln!(
            "largest change: T (η > 1) {:.2e} relative, R {:.2e} relative, T (η < 1) {:.2e} absolute",
            w[0], w[1], w[2]
        );
    }

    /// [`BECKMANN_G1_IS_ONE`]: for every f32 a from it up to 9 (and beyond, where Λ = 0),
    /// Beckmann's exact G1 = 1/(1 + Λ(a)) is exactly 1, as [`MicrofacetDistribution::smith_g1`]
    /// computes it; just below 3.31 it is not (the threshold is not vacuous).
    #[test]
    fn beckmann_g1_is_one_from_the_threshold() {
        use crate::microfacet::beckmann_lambda;
        let g1 = |a: f32| 1.0 / (1.0 + beckmann_lambda(a));
        let mut a = BECKMANN_G1_IS_ONE;
        let mut count = 0u32;
        while a <= 9.5 {
            assert_eq!(g1(a), 1.0, "a = {a}");
            a = f32::from_bits(a.to_bits() + 1);
            count += 1;
        }
        assert!(count > 10_000_000);
        assert!(g1(3.3) < 1.0);
        // the same through smith_g1: a direction with 1/(α tanθ) at the threshold
        let distr = MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.1, 0.1, true);
        let tan = 1.0 / (0.1 * BECKMANN_G1_IS_ONE);
        let v = Vec3::new(tan, 0.0, 1.0).normalize();
        assert_eq!(distr.smith_g1(v, Vec3::Z), 1.0);
        let v = Vec3::new(1.0 / (0.1 * 3.3), 0.0, 1.0).normalize();
        assert!(distr.smith_g1(v, Vec3::Z) < 1.0);
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
