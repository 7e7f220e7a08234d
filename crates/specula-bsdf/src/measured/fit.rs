//! Fitting analytic models to a measured (MERL) BRDF: a compact representation of a table of
//! 1.46 million values by a handful of parameters that renders as a standard Mitsuba 3 material.
//!
//! # Families
//!
//! - [`Family::Conductor`]: a microfacet metal plus a Lambertian term,
//!   f = F(cosθd; η, k)·D·G / (4 cosθi cosθo) + kd/π, per RGB channel a complex index of
//!   refraction η + ik and a diffuse albedo kd, one roughness α. η and k are parameterised by
//!   Gulbrandsen's "artist friendly" pair (F0, edge tint) ∈ [0, 1)² (*Artist Friendly Metallic
//!   Fresnel*, JCGT 2014), so that the normal-incidence reflectance F0 (the F0 of Schlick's
//!   approximation) is a parameter and every pair is a valid conductor. The material is
//!   Mitsuba's `roughconductor` (`eta`, `k`), blended with a `diffuse` when kd > 0.
//! - [`Family::Plastic`]: Specula's and Mitsuba's `roughplastic` (diffuse reflectance per
//!   channel, α, and the coat's `int_ior` η > 1, `specular_reflectance` 1), so that the
//!   parameters of a plastic map back exactly.
//!
//! Both use the microfacet distribution chosen by the caller (GGX or Beckmann, exact Smith G1).
//! For a given α (and η) each model is linear in its diffuse parameter and the specular part
//! factorises into the shared D·G/(4 cosθi cosθo) of the sample and a Fresnel term that
//! depends on θd only; the fit evaluates the models that way (the same functions the models
//! call, checked against their `eval` by the unit tests), and the reported error is always that
//! of the finished material evaluated through its own [`BsdfModel::eval`].
//!
//! # Data and metric
//!
//! Samples are the centres of a subset of the MERL bins (every θh bin, every
//! `theta_d_stride`-th θd and `phi_d_stride`-th φd bin), with both directions above the horizon
//! and every channel measured (negative entries are skipped). Each sample has the weight of
//! the solid angle its bin covers in (ωi, ωo) space, dωi dωo = 4 cosθd dωh dωd, i.e.
//! w ∝ cosθd sinθh sinθd Δθh (Δθd, Δφd and the integral over φh are constant), normalised
//! to Σw = 1. The error compares the reflected-radiance integrand f·cosθi·cosθo after a
//! compressing map g (cube root, or log(1 + x)), which keeps the specular peak from
//! outweighing the rest of the lobe (Ngan et al. 2005; Löw et al. 2012):
//!
//! E = √( Σₖ wₖ · ⅓ Σ_c [g(f_c cosθi cosθo) − g(m_c cosθi cosθo)]² ).
//!
//! The relative RMS figure is √(Σ w (f − m)² c² / Σ w m² c²) with c = cosθi cosθo, over all
//! channels.
//!
//! # Optimiser
//!
//! Variable projection: for the roughness (and, for plastics, η) an outer Nelder–Mead search
//! in (ln α, η), started from the local minima of a grid of 13 α values (the cube-root error
//! is not convex in α) and confined to the α interval around each; inside it, for each
//! channel separately, a bounded Levenberg–Marquardt solve of the channel's parameters
//! (F0, edge tint, kd, or the diffuse reflectance) with analytic normal equations,
//! warm-started from the best solution so far. Grid points and runs are spread over the
//! available cores; the result does not depend on their number. Bounds: α ∈ [0.001, 1],
//! F0 ∈ [10⁻⁴, 0.995], edge tint ∈ [0, 1], kd ∈ [0, 0.95], η ∈ [1.001, 3], diffuse
//! reflectance ∈ [0, 1] (albedos above 1 would create energy; the plastic's bound uses the
//! coat's internal reflectance from a 32² quadrature during the search and the model's own
//! at the end).

use crate::bsdf::{BsdfContext, BsdfModel, ShadingPoint};
use crate::fresnel::{fresnel_conductor_f64, FresnelMode};
use crate::measured::merl::{
    bin_centre_dirs, theta_d_centre, theta_h_centre, Merl, RES_PHI_D, RES_THETA_D, RES_THETA_H,
    SCALE,
};
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::models::roughplastic::{
    rough_specular_albedo, rough_specular_transmittance, TRANSMITTANCE_RES,
};
use crate::models::Bsdf;
use crate::spec::parse_spec;
use glam::Vec3;
use std::f64::consts::FRAC_1_PI;
use std::fmt;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Smallest roughness the fit considers.
pub const ALPHA_MIN: f64 = 1e-3;
/// Largest roughness the fit considers.
pub const ALPHA_MAX: f64 = 1.0;
/// Range of the plastic's relative index of refraction.
pub const ETA_RANGE: (f64, f64) = (1.001, 3.0);
/// Range of a conductor channel's normal-incidence reflectance F0.
pub const F0_RANGE: (f64, f64) = (1e-4, 0.995);
/// Largest diffuse albedo of the conductor family (kept below 1 so that the blend that
/// expresses it has a finite specular scale).
pub const KD_MAX: f64 = 0.95;
/// Exterior index of refraction assumed by the plastic family (Mitsuba's default `air`).
pub const AIR_IOR: f64 = 1.000277;
/// Relative index of refraction of the plastic coat (η = int_ior / ext_ior) on the α grid.
const ETA_START: f64 = 1.5;
/// Roughness values of the starting grid (log-spaced over [ALPHA_MIN, ALPHA_MAX]).
const ALPHA_GRID: usize = 13;
/// Most Nelder–Mead runs, one from each of the best local minima of the grid.
const RESTARTS: usize = 2;
/// Convergence of the outer search: simplex size in ln α (and η).
const XTOL: f64 = 1e-4;
/// Most evaluations of one Nelder–Mead run.
const MAX_EVALS: usize = 300;

/// The compressing map applied before comparing f·cosθi·cosθo.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Metric {
    /// Cube root (Ngan et al. 2005).
    Cbrt,
    /// ln(1 + x) (Löw et al. 2012).
    Log,
}

impl Metric {
    pub fn name(self) -> &'static str {
        match self {
            Metric::Cbrt => "cbrt",
            Metric::Log => "log",
        }
    }
    /// The map g, written out.
    pub fn formula(self) -> &'static str {
        match self {
            Metric::Cbrt => "∛x",
            Metric::Log => "ln(1 + x)",
        }
    }
    #[inline]
    fn g(self, x: f64) -> f64 {
        match self {
            Metric::Cbrt => x.cbrt(),
            Metric::Log => x.ln_1p(),
        }
    }
    /// g(x) and, when asked, g′(x), bounded near 0 for the cube root (values of f·cos
    /// below 1e-6 are negligible).
    #[inline]
    fn g_dg(self, x: f64, derivative: bool) -> (f64, f64) {
        match self {
            Metric::Cbrt => {
                let c = fast_cbrt(x);
                let cd = c.max(1e-2);
                (
                    c,
                    if derivative {
                        1.0 / (3.0 * cd * cd)
                    } else {
                        0.0
                    },
                )
            }
            Metric::Log => (x.ln_1p(), 1.0 / (1.0 + x)),
        }
    }
}

/// Cube root of x ≥ 0 to a relative 1e-15: an exponent-splitting first guess (≈ 5 %) and three
/// Halley steps (the error cubes at each); several times faster than the library `cbrt`.
#[inline]
fn fast_cbrt(x: f64) -> f64 {
    if !(x > 1e-200 && x < 1e200) {
        return x.cbrt();
    }
    let mut y = f64::from_bits(x.to_bits() / 3 + 0x2a9f_7893_782d_a1ce);
    for _ in 0..3 {
        let y3 = y * y * y;
        y *= (y3 + 2.0 * x) / (2.0 * y3 + x);
    }
    y
}

/// Which analytic model to fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// `roughconductor` (per-channel η, k) plus a Lambertian kd per channel.
    Conductor,
    /// `roughplastic` (diffuse reflectance per channel, α, int_ior).
    Plastic,
}

impl Family {
    pub const ALL: [Family; 2] = [Family::Conductor, Family::Plastic];
    pub fn name(self) -> &'static str {
        match self {
            Family::Conductor => "conductor",
            Family::Plastic => "plastic",
        }
    }
}

/// What to fit and how.
#[derive(Clone, Debug)]
pub struct FitOptions {
    pub distribution: MicrofacetType,
    pub metric: Metric,
    /// `None`: fit every family and keep the one with the lowest error.
    pub family: Option<Family>,
    /// Use every n-th θd bin (default 3).
    pub theta_d_stride: usize,
    /// Use every n-th φd bin (default 6).
    pub phi_d_stride: usize,
}

impl Default for FitOptions {
    fn default() -> Self {
        FitOptions {
            distribution: MicrofacetType::Ggx,
            metric: Metric::Cbrt,
            family: None,
            theta_d_stride: 3,
            phi_d_stride: 6,
        }
    }
}

/// Why a table cannot be fitted. The message names the table's file.
#[derive(Debug, thiserror::Error)]
#[error("{file}: cannot fit: {reason}")]
pub struct FitError {
    pub file: String,
    pub reason: String,
}

/// How well a material matches the data.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quality {
    pub metric: Metric,
    /// E, the weighted RMS difference after the metric's map (see the module documentation).
    pub value: f64,
    /// √(Σ w (f − m)² c² / Σ w m² c²), c = cosθi cosθo.
    pub rel_rms: f64,
    /// Number of bins compared.
    pub bins: usize,
}

/// Accumulates the error sums of [`Quality`].
#[derive(Default)]
struct ErrorSums {
    w: f64,
    dg2: f64,
    df2: f64,
    m2: f64,
    bins: usize,
}

impl ErrorSums {
    #[inline]
    fn add(&mut self, metric: Metric, w: f64, c: f64, f: [f64; 3], m: [f64; 3]) {
        self.w += w;
        self.bins += 1;
        for ch in 0..3 {
            let d = metric.g(f[ch] * c) - metric.g(m[ch] * c);
            self.dg2 += w * d * d / 3.0;
            self.df2 += w * ((f[ch] - m[ch]) * c).powi(2);
            self.m2 += w * (m[ch] * c).powi(2);
        }
    }
    fn quality(&self, metric: Metric) -> Quality {
        Quality {
            metric,
            value: (self.dg2 / self.w.max(f64::MIN_POSITIVE)).sqrt(),
            rel_rms: if self.m2 > 0.0 {
                (self.df2 / self.m2).sqrt()
            } else {
                f64::INFINITY
            },
            bins: self.bins,
        }
    }
}

/// Unnormalised solid-angle weight of bin (i, j, ·): cosθd sinθh sinθd Δθh.
fn bin_weight(i: usize, j: usize) -> f64 {
    let (u0, u1) = (i as f64 / 90.0, (i + 1) as f64 / 90.0);
    let dth = (u1 * u1 - u0 * u0) * std::f64::consts::FRAC_PI_2;
    let (th, td) = (theta_h_centre(i), theta_d_centre(j));
    td.cos() * th.sin() * td.sin() * dth
}

fn to_vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// The measured values of bin (i, j, k) when the bin is measured in every channel and both of
/// its directions lie above the horizon: (wi, wo, cosθi cosθo, BRDF).
fn measured_bin(merl: &Merl, i: usize, j: usize, k: usize) -> Option<(Vec3, Vec3, f64, [f64; 3])> {
    let (wi, wo) = bin_centre_dirs(i, j, k);
    if wi[2] <= 0.0 || wo[2] <= 0.0 {
        return None;
    }
    let raw = merl.raw(i, j, k);
    if raw.iter().any(|&v| v < 0.0) {
        return None;
    }
    let (wi32, wo32) = (to_vec3(wi), to_vec3(wo));
    if wi32.z <= 0.0 || wo32.z <= 0.0 {
        return None;
    }
    Some((
        wi32,
        wo32,
        wi[2] * wo[2],
        std::array::from_fn(|c| raw[c] * SCALE[c]),
    ))
}

/// The error of `bsdf` against every measured bin of `merl` (no subsampling).
pub fn table_quality<B: BsdfModel + ?Sized>(merl: &Merl, bsdf: &B, metric: Metric) -> Quality {
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut sums = ErrorSums::default();
    for i in 0..RES_THETA_H {
        for j in 0..RES_THETA_D {
            let w = bin_weight(i, j);
            for k in 0..RES_PHI_D {
                if let Some((wi, wo, c, m)) = measured_bin(merl, i, j, k) {
                    let f = bsdf.eval(&ctx, &sp, wi, wo).0.map(|v| v as f64);
                    sums.add(metric, w, c, f, m);
                }
            }
        }
    }
    sums.quality(metric)
}

/// The samples a fit works on (see the module documentation).
pub struct FitData {
    name: String,
    metric: Metric,
    wi: Vec<Vec3>,
    wo: Vec<Vec3>,
    /// √w (normalised weights).
    sw: Vec<f64>,
    /// cosθi cosθo.
    cos: Vec<f64>,
    /// Index into `cos_d` of the sample's θd.
    td: Vec<u16>,
    /// cosθd of the θd bins used.
    cos_d: Vec<f64>,
    /// Measured BRDF per channel.
    meas: Vec<[f64; 3]>,
    /// g(m cosθi cosθo) per channel.
    target: [Vec<f64>; 3],
    /// Bins of the whole table that are measured and above the horizon.
    pub measured_bins: usize,
}

impl FitData {
    /// Extract the samples of a table. Errors when nothing (or nothing but zeros) is measured.
    pub fn new(merl: &Merl, opts: &FitOptions) -> Result<FitData, FitError> {
        let err = |reason: String| FitError {
            file: merl.name().to_string(),
            reason,
        };
        let sd = opts.theta_d_stride.clamp(1, RES_THETA_D);
        let sp = opts.phi_d_stride.clamp(1, RES_PHI_D);
        let js: Vec<usize> = (sd / 2..RES_THETA_D).step_by(sd).collect();
        let mut d = FitData {
            name: merl.name().to_string(),
            metric: opts.metric,
            wi: Vec::new(),
            wo: Vec::new(),
            sw: Vec::new(),
            cos: Vec::new(),
            td: Vec::new(),
            cos_d: js.iter().map(|&j| theta_d_centre(j).cos()).collect(),
            meas: Vec::new(),
            target: [Vec::new(), Vec::new(), Vec::new()],
            measured_bins: 0,
        };
        let mut positive = false;
        for i in 0..RES_THETA_H {
            for j in 0..RES_THETA_D {
                let w = bin_weight(i, j);
                let sampled_j = js.iter().position(|&x| x == j);
                for k in 0..RES_PHI_D {
                    let Some((wi, wo, c, m)) = measured_bin(merl, i, j, k) else {
                        continue;
                    };
                    if let Some(bad) = m.iter().find(|v| !v.is_finite()) {
                        return Err(err(format!(
                            "bin (θh {i}, θd {j}, φd {k}) holds {bad}, not a finite value"
                        )));
                    }
                    d.measured_bins += 1;
                    positive |= m.iter().any(|&v| v > 0.0);
                    let Some(jj) = sampled_j else { continue };
                    if k % sp != sp / 2 {
                        continue;
                    }
                    d.wi.push(wi);
                    d.wo.push(wo);
                    d.sw.push(w);
                    d.cos.push(c);
                    d.td.push(jj as u16);
                    d.meas.push(m);
                }
            }
        }
        if d.measured_bins == 0 {
            return Err(err(
                "no bin is measured with both directions above the horizon".into(),
            ));
        }
        if !positive {
            return Err(err("every measured value is zero".into()));
        }
        if d.wi.len() < 100 {
            return Err(err(format!(
                "only {} measured samples at the chosen strides; use smaller strides",
                d.wi.len()
            )));
        }
        let total: f64 = d.sw.iter().sum();
        for s in &mut d.sw {
            *s = (*s / total).sqrt();
        }
        for c in 0..3 {
            d.target[c] = d
                .meas
                .iter()
                .zip(&d.cos)
                .map(|(m, &cs)| opts.metric.g(m[c] * cs))
                .collect();
        }
        Ok(d)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.wi.len()
    }

    pub fn is_empty(&self) -> bool {
        self.wi.is_empty()
    }

    /// The error of `bsdf` (through its own `eval`) on these samples.
    pub fn quality<B: BsdfModel + ?Sized>(&self, bsdf: &B) -> Quality {
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        let mut sums = ErrorSums::default();
        for s in 0..self.len() {
            let f = bsdf
                .eval(&ctx, &sp, self.wi[s], self.wo[s])
                .0
                .map(|v| v as f64);
            sums.add(
                self.metric,
                self.sw[s] * self.sw[s],
                self.cos[s],
                f,
                self.meas[s],
            );
        }
        sums.quality(self.metric)
    }

    /// D·G/(4 cosθi cosθo) of every sample, as the microfacet models compute it (f32).
    fn microfacet_term(&self, kind: MicrofacetType, alpha: f64, out: &mut Vec<f64>) {
        let distr = MicrofacetDistribution::new(kind, alpha as f32, alpha as f32, true);
        out.clear();
        out.extend(self.wi.iter().zip(&self.wo).map(|(&wi, &wo)| {
            let h = (wi + wo).normalize();
            let d = distr.eval(h);
            if d == 0.0 {
                return 0.0;
            }
            (d * distr.g(wi, wo, h) / (4.0 * wi.z * wo.z)) as f64
        }));
    }

    /// Cost Σ r² and the normal equations (JᵀJ, Jᵀr) of one channel for the model
    /// f = a·F[θd] + l·d, where F and its derivatives with respect to the first P − 1
    /// parameters are tabulated over θd (`df[j][q]`) and d is the last parameter.
    #[allow(clippy::too_many_arguments, clippy::needless_range_loop)]
    fn channel_normal_equations<const P: usize>(
        &self,
        ch: usize,
        a: &[f64],
        l: &[f64],
        f_tab: &[f64],
        df_tab: &[[f64; P]],
        d: f64,
        jacobian: bool,
    ) -> (f64, [[f64; P]; P], [f64; P]) {
        let mut cost = 0.0;
        let mut jtj = [[0.0; P]; P];
        let mut jtr = [0.0; P];
        let target = &self.target[ch];
        for s in 0..self.len() {
            let j = self.td[s] as usize;
            let f = a[s] * f_tab[j] + l[s] * d;
            let x = f * self.cos[s];
            let (g, dg) = self.metric.g_dg(x, jacobian);
            let r = self.sw[s] * (g - target[s]);
            cost += r * r;
            if jacobian {
                let scale = self.sw[s] * dg * self.cos[s];
                let mut row = [0.0; P];
                for q in 0..P - 1 {
                    row[q] = scale * a[s] * df_tab[j][q];
                }
                row[P - 1] = scale * l[s];
                for p in 0..P {
                    jtr[p] += row[p] * r;
                    for q in 0..=p {
                        jtj[p][q] += row[p] * row[q];
                    }
                }
            }
        }
        for p in 0..P {
            for q in p + 1..P {
                jtj[p][q] = jtj[q][p];
            }
        }
        (cost, jtj, jtr)
    }
}

// ---------------------------------------------------------------------------------------
// Parameterisations
// ---------------------------------------------------------------------------------------

/// Gulbrandsen's mapping from (F0, edge tint) to a complex index of refraction (η, k).
pub fn conductor_ior(f0: f64, edge_tint: f64) -> (f64, f64) {
    let r = f0.clamp(0.0, F0_RANGE.1);
    let g = edge_tint.clamp(0.0, 1.0);
    let sr = r.sqrt();
    let n_min = (1.0 - r) / (1.0 + r);
    let n_max = (1.0 + sr) / (1.0 - sr);
    let n = g * n_min + (1.0 - g) * n_max;
    let k2 = (r * (n + 1.0).powi(2) - (n - 1.0).powi(2)) / (1.0 - r);
    (n, k2.max(0.0).sqrt())
}

fn conductor_fresnel(cos: f64, f0: f64, tint: f64) -> f64 {
    let (n, k) = conductor_ior(f0, tint);
    fresnel_conductor_f64(cos, n, k)
}

/// The coat transmittance table of `roughplastic` (same nodes, quadrature and interpolation).
fn coat_transmittance(kind: MicrofacetType, alpha: f64, eta: f64) -> [f32; TRANSMITTANCE_RES] {
    let distr = MicrofacetDistribution::new(kind, alpha as f32, alpha as f32, true);
    let eta = eta as f32;
    let mut t = [0.0f32; TRANSMITTANCE_RES];
    for (i, ti) in t.iter_mut().enumerate() {
        let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let res = if eta > 1.0 { 32 } else { 128 };
        *ti = rough_specular_transmittance(&distr, FresnelMode::Exact, wi, eta, res);
    }
    t
}

/// The coat's hemispherical internal reflectance as `roughplastic` computes it, but with a
/// coarser quadrature (`res`² instead of 128² nodes): used only for the upper bound of the
/// diffuse term during the search.
fn coat_internal_reflectance(kind: MicrofacetType, alpha: f64, eta: f64, res: usize) -> f64 {
    let distr = MicrofacetDistribution::new(kind, alpha as f32, alpha as f32, true);
    let inv_eta = 1.0 / eta as f32;
    let mut sum = 0.0f64;
    for i in 0..TRANSMITTANCE_RES {
        let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        sum += (rough_specular_albedo(&distr, FresnelMode::Exact, wi, inv_eta, res) * mu) as f64;
    }
    2.0 * sum / TRANSMITTANCE_RES as f64
}

#[inline]
fn interp_transmittance(t: &[f32; TRANSMITTANCE_RES], cos: f32) -> f32 {
    let x = cos * (TRANSMITTANCE_RES - 1) as f32;
    let i = (x.max(0.0) as usize).min(TRANSMITTANCE_RES - 2);
    let w1 = x - i as f32;
    (1.0 - w1) * t[i] + w1 * t[i + 1]
}

// ---------------------------------------------------------------------------------------
// Optimisers
// ---------------------------------------------------------------------------------------

/// Bounded Levenberg–Marquardt: minimises Σ r² given a function returning the cost and the
/// normal equations (JᵀJ, Jᵀr). Parameters at a bound whose gradient points outwards are held
/// there (an active set); other steps are clipped to the box. Returns the parameters and cost.
#[allow(clippy::needless_range_loop)]
pub fn levenberg_marquardt<const P: usize>(
    p0: [f64; P],
    lo: [f64; P],
    hi: [f64; P],
    max_iter: usize,
    mut f: impl FnMut(&[f64; P], bool) -> (f64, [[f64; P]; P], [f64; P]),
) -> ([f64; P], f64) {
    let clamp = |p: [f64; P]| -> [f64; P] { std::array::from_fn(|i| p[i].clamp(lo[i], hi[i])) };
    let mut p = clamp(p0);
    let (mut cost, mut jtj, mut jtr) = f(&p, true);
    let mut lambda = 1e-3;
    for _ in 0..max_iter {
        let free: [bool; P] = std::array::from_fn(|i| {
            !((p[i] <= lo[i] && jtr[i] > 0.0) || (p[i] >= hi[i] && jtr[i] < 0.0))
        });
        if !free.iter().any(|&x| x) {
            break;
        }
        let max_diag = (0..P).map(|i| jtj[i][i]).fold(0.0f64, f64::max);
        if max_diag <= 0.0 || !max_diag.is_finite() {
            break;
        }
        let mut accepted = false;
        let mut converged = false;
        while lambda < 1e12 {
            let mut m = jtj;
            let mut b = [0.0; P];
            for i in 0..P {
                m[i][i] += lambda * jtj[i][i].max(1e-9 * max_diag);
                b[i] = -jtr[i];
                if !free[i] {
                    for q in 0..P {
                        m[i][q] = 0.0;
                        m[q][i] = 0.0;
                    }
                    m[i][i] = 1.0;
                    b[i] = 0.0;
                }
            }
            let Some(delta) = crate::math::solve(m, b) else {
                lambda *= 10.0;
                continue;
            };
            let next = clamp(std::array::from_fn(|i| p[i] + delta[i]));
            if (0..P).all(|i| (next[i] - p[i]).abs() <= 1e-9 * (1.0 + p[i].abs())) {
                converged = true;
                break;
            }
            let (c, _, _) = f(&next, false);
            if c.is_finite() && c < cost {
                converged = cost - c <= 1e-8 * cost;
                p = next;
                (cost, jtj, jtr) = f(&p, true);
                lambda = (lambda * 0.3).max(1e-12);
                accepted = true;
                break;
            }
            lambda *= 5.0;
        }
        if converged || !accepted {
            break;
        }
    }
    (p, cost)
}

/// Nelder–Mead simplex minimisation from `x0` with initial steps `step`; stops when the
/// simplex is smaller than `xtol` in every coordinate (or after `max_evals`). Returns the best
/// point, its value and the number of evaluations.
pub fn nelder_mead(
    x0: &[f64],
    step: &[f64],
    xtol: f64,
    max_evals: usize,
    mut f: impl FnMut(&[f64]) -> f64,
) -> (Vec<f64>, f64, usize) {
    let n = x0.len();
    let mut evals = 0;
    let mut eval = |x: &[f64], evals: &mut usize| {
        *evals += 1;
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((x0.to_vec(), eval(x0, &mut evals)));
    for i in 0..n {
        let mut x = x0.to_vec();
        x[i] += step[i];
        let v = eval(&x, &mut evals);
        simplex.push((x, v));
    }
    while evals < max_evals {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let size = (0..n)
            .map(|i| {
                simplex
                    .iter()
                    .map(|(x, _)| (x[i] - simplex[0].0[i]).abs())
                    .fold(0.0, f64::max)
            })
            .fold(0.0, f64::max);
        if size < xtol {
            break;
        }
        let centroid: Vec<f64> = (0..n)
            .map(|i| simplex[..n].iter().map(|(x, _)| x[i]).sum::<f64>() / n as f64)
            .collect();
        let along = |t: f64| -> Vec<f64> {
            (0..n)
                .map(|i| centroid[i] + t * (simplex[n].0[i] - centroid[i]))
                .collect()
        };
        let xr = along(-1.0);
        let fr = eval(&xr, &mut evals);
        if fr < simplex[0].1 {
            let xe = along(-2.0);
            let fe = eval(&xe, &mut evals);
            simplex[n] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[n - 1].1 {
            simplex[n] = (xr, fr);
        } else {
            let (xc, fc) = if fr < simplex[n].1 {
                let x = along(-0.5);
                let v = eval(&x, &mut evals);
                (x, v)
            } else {
                let x = along(0.5);
                let v = eval(&x, &mut evals);
                (x, v)
            };
            if fc < simplex[n].1.min(fr) {
                simplex[n] = (xc, fc);
            } else {
                // shrink towards the best point
                let best = simplex[0].0.clone();
                for s in simplex.iter_mut().skip(1) {
                    let x: Vec<f64> = (0..n).map(|i| best[i] + 0.5 * (s.0[i] - best[i])).collect();
                    let v = eval(&x, &mut evals);
                    *s = (x, v);
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (x, v) = simplex.swap_remove(0);
    (x, v, evals)
}

// ---------------------------------------------------------------------------------------
// The families
// ---------------------------------------------------------------------------------------

/// The fitted parameters of a family.
#[derive(Clone, Debug, PartialEq)]
pub enum FitParams {
    Conductor {
        /// Normal-incidence reflectance per channel (Schlick's F0).
        f0: [f32; 3],
        /// Gulbrandsen's edge tint per channel.
        edge_tint: [f32; 3],
        /// The complex index of refraction they stand for.
        eta: [f32; 3],
        k: [f32; 3],
        /// Lambertian albedo kd per channel (f = … + kd/π).
        diffuse: [f32; 3],
    },
    Plastic {
        /// Interior index of refraction (exterior: air, 1.000277).
        int_ior: f32,
        diffuse_reflectance: [f32; 3],
    },
}

/// One fitted material.
#[derive(Clone, Debug)]
pub struct Fit {
    pub family: Family,
    pub distribution: MicrofacetType,
    pub alpha: f32,
    pub params: FitParams,
    /// Error of [`Fit::bsdf`] (its own `eval`) on the fit's samples.
    pub quality: Quality,
    /// The material, built from [`Fit::spec`].
    pub bsdf: Bsdf,
    /// Evaluations of the outer objective.
    pub evaluations: usize,
    pub elapsed: Duration,
}

fn rgb_str(c: [f32; 3], sep: &str) -> String {
    format!("{}{sep}{}{sep}{}", c[0], c[1], c[2])
}

/// Conductor diffuse albedos below this are dropped from the material (f below 3e-6).
const KD_NEGLIGIBLE: f32 = 1e-5;

impl Fit {
    /// The fitted parameters as `name=value` lines (RGB as `r,g,b`).
    pub fn param_lines(&self) -> Vec<String> {
        let mut v = vec![format!("alpha={}", self.alpha)];
        match &self.params {
            FitParams::Conductor {
                f0,
                edge_tint,
                eta,
                k,
                diffuse,
            } => {
                v.push(format!("f0={}", rgb_str(*f0, ",")));
                v.push(format!("edge_tint={}", rgb_str(*edge_tint, ",")));
                v.push(format!("eta={}", rgb_str(*eta, ",")));
                v.push(format!("k={}", rgb_str(*k, ",")));
                v.push(format!("diffuse={}", rgb_str(*diffuse, ",")));
            }
            FitParams::Plastic {
                int_ior,
                diffuse_reflectance,
            } => {
                v.push(format!("int_ior={int_ior}"));
                v.push(format!(
                    "diffuse_reflectance={}",
                    rgb_str(*diffuse_reflectance, ",")
                ));
            }
        }
        v
    }

    /// For the conductor family with a diffuse term: the blend weight w of the conductor,
    /// the diffuse reflectance ρ = kd/(1 − w) and the conductor's scale 1/w, with
    /// w = 1 − max kd so that max ρ = 1.
    fn blend(&self) -> Option<(f32, [f32; 3], f32)> {
        let FitParams::Conductor { diffuse, .. } = &self.params else {
            return None;
        };
        let m = diffuse.iter().copied().fold(0.0f32, f32::max);
        if m < KD_NEGLIGIBLE {
            return None;
        }
        let w = 1.0 - m;
        Some((w, diffuse.map(|d| d / m), 1.0 / w))
    }

    /// The material as a Specula spec (what `specula brdf eval` and friends take).
    pub fn spec(&self) -> String {
        let d = self.distribution.name();
        match &self.params {
            FitParams::Conductor { eta, k, .. } => {
                let metal = format!(
                    "roughconductor distribution={d} alpha={} eta={} k={}",
                    self.alpha,
                    rgb_str(*eta, ","),
                    rgb_str(*k, ",")
                );
                match self.blend() {
                    None => metal,
                    Some((w, rho, s)) => format!(
                        "blendbsdf weight={w} {{ diffuse reflectance={} }} {{ {metal} specular_reflectance={s} }}",
                        rgb_str(rho, ",")
                    ),
                }
            }
            FitParams::Plastic {
                int_ior,
                diffuse_reflectance,
            } => format!(
                "roughplastic distribution={d} alpha={} int_ior={int_ior} diffuse_reflectance={}",
                self.alpha,
                rgb_str(*diffuse_reflectance, ",")
            ),
        }
    }

    /// The material as a Mitsuba 3 `<bsdf>` element.
    pub fn mitsuba_xml(&self) -> String {
        let d = self.distribution.name();
        let mut x = String::new();
        match &self.params {
            FitParams::Conductor { eta, k, .. } => {
                let blend = self.blend();
                let ind = if blend.is_some() { "    " } else { "" };
                if let Some((w, rho, _)) = blend {
                    x.push_str("<bsdf type=\"blendbsdf\">\n");
                    x.push_str(&format!("    <float name=\"weight\" value=\"{w}\"/>\n"));
                    x.push_str("    <bsdf type=\"diffuse\">\n");
                    x.push_str(&format!(
                        "        <rgb name=\"reflectance\" value=\"{}\"/>\n",
                        rgb_str(rho, ", ")
                    ));
                    x.push_str("    </bsdf>\n");
                }
                x.push_str(&format!("{ind}<bsdf type=\"roughconductor\">\n"));
                x.push_str(&format!(
                    "{ind}    <string name=\"distribution\" value=\"{d}\"/>\n"
                ));
                x.push_str(&format!(
                    "{ind}    <float name=\"alpha\" value=\"{}\"/>\n",
                    self.alpha
                ));
                x.push_str(&format!(
                    "{ind}    <rgb name=\"eta\" value=\"{}\"/>\n",
                    rgb_str(*eta, ", ")
                ));
                x.push_str(&format!(
                    "{ind}    <rgb name=\"k\" value=\"{}\"/>\n",
                    rgb_str(*k, ", ")
                ));
                if let Some((_, _, s)) = blend {
                    x.push_str(&format!(
                        "{ind}    <float name=\"specular_reflectance\" value=\"{s}\"/>\n"
                    ));
                }
                x.push_str(&format!("{ind}</bsdf>\n"));
                if blend.is_some() {
                    x.push_str("</bsdf>\n");
                }
            }
            FitParams::Plastic {
                int_ior,
                diffuse_reflectance,
            } => {
                x.push_str("<bsdf type=\"roughplastic\">\n");
                x.push_str(&format!(
                    "    <string name=\"distribution\" value=\"{d}\"/>\n"
                ));
                x.push_str(&format!(
                    "    <float name=\"alpha\" value=\"{}\"/>\n",
                    self.alpha
                ));
                x.push_str(&format!(
                    "    <float name=\"int_ior\" value=\"{int_ior}\"/>\n"
                ));
                x.push_str(&format!(
                    "    <rgb name=\"diffuse_reflectance\" value=\"{}\"/>\n",
                    rgb_str(*diffuse_reflectance, ", ")
                ));
                x.push_str("</bsdf>\n");
            }
        }
        x
    }
}

impl fmt::Display for Fit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.spec())
    }
}

/// State shared by the outer objective of one family.
struct Problem<'a> {
    data: &'a FitData,
    kind: MicrofacetType,
    a: Vec<f64>,
    l: Vec<f64>,
    evaluations: usize,
}

/// Per-channel parameters of a family at one point of the outer search.
type Conductor3 = [[f64; 3]; 3];

const CONDUCTOR_STARTS: [[f64; 3]; 2] = [[0.9, 0.5, 0.0], [0.04, 0.0, 0.1]];

impl<'a> Problem<'a> {
    fn new(data: &'a FitData, kind: MicrofacetType) -> Self {
        Problem {
            data,
            kind,
            a: Vec::with_capacity(data.len()),
            l: Vec::with_capacity(data.len()),
            evaluations: 0,
        }
    }

    /// Best (F0, tint, kd) per channel at roughness α; `warm` replaces the cold starts.
    fn conductor(&mut self, alpha: f64, warm: Option<&Conductor3>) -> (f64, Conductor3) {
        self.evaluations += 1;
        self.data.microfacet_term(self.kind, alpha, &mut self.a);
        self.l.clear();
        self.l.resize(self.data.len(), FRAC_1_PI);
        let nd = self.data.cos_d.len();
        let mut f_tab = vec![0.0; nd];
        let mut df_tab = vec![[0.0; 3]; nd];
        let lo = [F0_RANGE.0, 0.0, 0.0];
        let hi = [F0_RANGE.1, 1.0, KD_MAX];
        let mut total = 0.0;
        let mut out = [[0.0; 3]; 3];
        for ch in 0..3 {
            let starts: Vec<[f64; 3]> = match warm {
                Some(w) => vec![w[ch]],
                None => CONDUCTOR_STARTS.to_vec(),
            };
            let mut best = ([0.0; 3], f64::INFINITY);
            for p0 in starts {
                let res = levenberg_marquardt(p0, lo, hi, 100, |p, jac| {
                    let (r, g) = (p[0], p[1]);
                    // central differences inside the box, one-sided at its edges
                    let hr = 1e-6;
                    let (r0, r1) = ((r - hr).max(lo[0]), (r + hr).min(hi[0]));
                    let (g0, g1) = ((g - hr).max(0.0), (g + hr).min(1.0));
                    for (jj, &cd) in self.data.cos_d.iter().enumerate() {
                        f_tab[jj] = conductor_fresnel(cd, r, g);
                        if jac {
                            df_tab[jj] = [
                                (conductor_fresnel(cd, r1, g) - conductor_fresnel(cd, r0, g))
                                    / (r1 - r0),
                                (conductor_fresnel(cd, r, g1) - conductor_fresnel(cd, r, g0))
                                    / (g1 - g0),
                                0.0,
                            ];
                        }
                    }
                    self.data.channel_normal_equations::<3>(
                        ch, &self.a, &self.l, &f_tab, &df_tab, p[2], jac,
                    )
                });
                if res.1 < best.1 {
                    best = res;
                }
            }
            total += best.1;
            out[ch] = best.0;
        }
        (total, out)
    }

    /// Best scaled diffuse term d = ρ/(η²(1 − R_int)) per channel of a `roughplastic` at
    /// (α, η); `warm` replaces the cold start.
    fn plastic(&mut self, alpha: f64, eta: f64, warm: Option<&[f64; 3]>) -> (f64, [f64; 3]) {
        self.evaluations += 1;
        self.data.microfacet_term(self.kind, alpha, &mut self.a);
        let t = coat_transmittance(self.kind, alpha, eta);
        self.l.clear();
        self.l
            .extend(self.data.wi.iter().zip(&self.data.wo).map(|(wi, wo)| {
                (interp_transmittance(&t, wi.z) * interp_transmittance(&t, wo.z)) as f64 * FRAC_1_PI
            }));
        let f_tab: Vec<f64> = self
            .data
            .cos_d
            .iter()
            .map(|&c| FresnelMode::Exact.eval(c as f32, eta as f32).r as f64)
            .collect();
        let df_tab = vec![[0.0; 1]; f_tab.len()];
        // diffuse reflectance ρ = d·η²(1 − R_int) ≤ 1
        let rint = coat_internal_reflectance(self.kind, alpha, eta, 32);
        let d_max = 1.0 / (eta * eta * (1.0 - rint).max(1e-6));
        let mut total = 0.0;
        let mut out = [0.0; 3];
        for ch in 0..3 {
            let p0 = warm.map_or(0.2 * d_max, |w| w[ch]);
            let (p, c) = levenberg_marquardt([p0], [0.0], [d_max], 100, |p, jac| {
                self.data
                    .channel_normal_equations::<1>(ch, &self.a, &self.l, &f_tab, &df_tab, p[0], jac)
            });
            total += c;
            out[ch] = p[0];
        }
        (total, out)
    }
}

fn alpha_of(x: f64) -> f64 {
    x.exp().clamp(ALPHA_MIN, ALPHA_MAX)
}

/// Penalty that keeps the simplex near the box: the cost at the clamped point, times one plus
/// the squared distance outside.
fn outside(x: f64, lo: f64, hi: f64) -> f64 {
    if x < lo {
        lo - x
    } else if x > hi {
        x - hi
    } else {
        0.0
    }
}

/// Starting points of the outer search: the grid points that are local minima of the cost
/// along the α grid, best first, at most [`RESTARTS`] (a multi-start over the basins of a
/// non-convex error).
fn basins(costs: &[f64]) -> Vec<usize> {
    let n = costs.len();
    let mut minima: Vec<usize> = (0..n)
        .filter(|&i| {
            (i == 0 || costs[i] <= costs[i - 1]) && (i + 1 == n || costs[i] <= costs[i + 1])
        })
        .collect();
    minima.sort_by(|&a, &b| costs[a].total_cmp(&costs[b]));
    minima.truncate(RESTARTS);
    if minima.is_empty() {
        minima.push(0);
    }
    minima
}

fn alpha_grid() -> Vec<f64> {
    let (l0, l1) = (ALPHA_MIN.ln(), ALPHA_MAX.ln());
    (0..ALPHA_GRID)
        .map(|i| l0 + (l1 - l0) * i as f64 / (ALPHA_GRID - 1) as f64)
        .collect()
}

fn internal_error(data: &FitData, what: String) -> FitError {
    FitError {
        file: data.name.clone(),
        reason: what,
    }
}

/// The objective of the outer search: the cost at x (clamped) and the inner parameters there,
/// given a warm start.
type OuterEval<'d, S> = dyn Fn(&mut Problem<'d>, &[f64], Option<&S>) -> (f64, S) + Sync;

/// `f` over `items` on the available cores (results in the order of `items`).
fn par_map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(items.len());
    if threads <= 1 {
        return items.iter().map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let results: Vec<Mutex<Option<R>>> = items.iter().map(|_| Mutex::new(None)).collect();
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(item) = items.get(i) else { break };
                let r = f(item);
                *results[i].lock().unwrap_or_else(|e| e.into_inner()) = Some(r);
            });
        }
    });
    results
        .into_iter()
        .map(|m| {
            m.into_inner()
                .unwrap_or_else(|e| e.into_inner())
                .expect("every item was mapped")
        })
        .collect()
}

/// The outer search over x = (ln α, …): `eval` at every point of the α grid (the other
/// coordinates at `tail`), then a Nelder–Mead run from each of the best basins of the grid,
/// confined to the α interval between the basin's grid neighbours, warm-starting the inner solves from the best point of the run; grid points and runs in
/// parallel, each a deterministic function of its start. `eval` receives x clamped to
/// [lo, hi]; the simplex is kept near the box by a penalty. Returns the best x, the inner
/// parameters there and the number of evaluations.
fn search<'d, S: Copy + Send + Sync>(
    data: &'d FitData,
    kind: MicrofacetType,
    tail: &[f64],
    lo: &[f64],
    hi: &[f64],
    eval: &OuterEval<'d, S>,
) -> (Vec<f64>, S, usize) {
    let grid: Vec<Vec<f64>> = alpha_grid()
        .into_iter()
        .map(|x| std::iter::once(x).chain(tail.iter().copied()).collect())
        .collect();
    let step: Vec<f64> = std::iter::once(0.5 * (grid[1][0] - grid[0][0]))
        .chain(tail.iter().map(|_| 0.2))
        .collect();
    let pts = par_map(&grid, |x| eval(&mut Problem::new(data, kind), x, None));
    let costs: Vec<f64> = pts.iter().map(|p| p.0).collect();
    let runs = par_map(&basins(&costs), |&i| {
        // each run stays in its basin: ln α between the neighbours of its grid point
        let mut lo = lo.to_vec();
        let mut hi = hi.to_vec();
        lo[0] = lo[0].max(grid[i.saturating_sub(1)][0]);
        hi[0] = hi[0].min(grid[(i + 1).min(grid.len() - 1)][0]);
        let mut prob = Problem::new(data, kind);
        let mut best = (grid[i].clone(), pts[i].0, pts[i].1);
        nelder_mead(&grid[i], &step, XTOL, MAX_EVALS, |x| {
            let xc: Vec<f64> = (0..x.len()).map(|d| x[d].clamp(lo[d], hi[d])).collect();
            let (c, s) = eval(&mut prob, &xc, Some(&best.2));
            if c < best.1 {
                best = (xc, c, s);
            }
            let out: f64 = (0..x.len())
                .map(|d| outside(x[d], lo[d], hi[d]).powi(2))
                .sum();
            c * (1.0 + out)
        });
        (best, prob.evaluations)
    });
    let evaluations = grid.len() + runs.iter().map(|r| r.1).sum::<usize>();
    let best = runs
        .into_iter()
        .map(|r| r.0)
        .reduce(|a, b| if b.1 < a.1 { b } else { a })
        .expect("at least one basin");
    (best.0, best.2, evaluations)
}

/// Fit one family to the samples.
pub fn fit_family(data: &FitData, family: Family, kind: MicrofacetType) -> Result<Fit, FitError> {
    let start = Instant::now();
    let (lx0, lx1) = (ALPHA_MIN.ln(), ALPHA_MAX.ln());
    let (alpha, params, evaluations) = match family {
        Family::Conductor => {
            let (x, p, evaluations) = search(data, kind, &[], &[lx0], &[lx1], &|prob, x, warm| {
                prob.conductor(alpha_of(x[0]), warm)
            });
            let alpha = alpha_of(x[0]) as f32;
            let mut diffuse: [f32; 3] = std::array::from_fn(|c| p[c][2] as f32);
            if diffuse.iter().all(|&d| d < KD_NEGLIGIBLE) {
                diffuse = [0.0; 3]; // below f32 resolution of the specular lobe: no blend
            }
            let f0: [f32; 3] = std::array::from_fn(|c| p[c][0] as f32);
            let tint: [f32; 3] = std::array::from_fn(|c| p[c][1] as f32);
            let ior: [(f64, f64); 3] = std::array::from_fn(|c| conductor_ior(p[c][0], p[c][1]));
            (
                alpha,
                FitParams::Conductor {
                    f0,
                    edge_tint: tint,
                    eta: ior.map(|v| v.0 as f32),
                    k: ior.map(|v| v.1 as f32),
                    diffuse,
                },
                evaluations,
            )
        }
        Family::Plastic => {
            let (e0, e1) = ETA_RANGE;
            let (x, d, evaluations) = search(
                data,
                kind,
                &[ETA_START],
                &[lx0, e0],
                &[lx1, e1],
                &|prob, x, warm| prob.plastic(alpha_of(x[0]), x[1], warm),
            );
            let alpha = alpha_of(x[0]) as f32;
            let eta = x[1];
            // ρ = d·η²·(1 − R_int), with the coat's internal reflectance of the real model
            let probe = parse_spec(&format!(
                "roughplastic distribution={} alpha={alpha} int_ior={} diffuse_reflectance=0.5",
                kind.name(),
                (eta * AIR_IOR) as f32
            ))
            .map_err(|e| internal_error(data, format!("fitted plastic does not build: {e}")))?;
            let Bsdf::RoughPlastic(rp) = &probe else {
                unreachable!("a roughplastic spec builds a roughplastic")
            };
            let scale = rp.eta as f64 * rp.eta as f64 * (1.0 - rp.internal_reflectance() as f64);
            (
                alpha,
                FitParams::Plastic {
                    int_ior: (eta * AIR_IOR) as f32,
                    // the search bounded ρ with a coarser R_int: clamp what that leaves over
                    diffuse_reflectance: d.map(|d| (d * scale).min(1.0) as f32),
                },
                evaluations,
            )
        }
    };
    let mut fit = Fit {
        family,
        distribution: kind,
        alpha,
        params,
        quality: Quality {
            metric: data.metric,
            value: f64::NAN,
            rel_rms: f64::NAN,
            bins: 0,
        },
        bsdf: Bsdf::Diffuse(Default::default()),
        evaluations,
        elapsed: Duration::ZERO,
    };
    let finite = fit.alpha.is_finite()
        && match &fit.params {
            FitParams::Conductor {
                f0,
                edge_tint,
                eta,
                k,
                diffuse,
            } => [f0, edge_tint, eta, k, diffuse]
                .iter()
                .all(|v| v.iter().all(|x| x.is_finite())),
            FitParams::Plastic {
                int_ior,
                diffuse_reflectance,
            } => int_ior.is_finite() && diffuse_reflectance.iter().all(|x| x.is_finite()),
        };
    if !finite {
        return Err(internal_error(
            data,
            format!("the {} fit diverged ({:?})", family.name(), fit.params),
        ));
    }
    fit.bsdf = parse_spec(&fit.spec()).map_err(|e| {
        internal_error(
            data,
            format!("fitted material '{}' does not build: {e}", fit.spec()),
        )
    })?;
    fit.quality = data.quality(&fit.bsdf);
    fit.elapsed = start.elapsed();
    Ok(fit)
}

/// Fit the family given in `opts` (or every family) and return the fits, best (lowest error)
/// first.
pub fn fit(merl: &Merl, opts: &FitOptions) -> Result<Vec<Fit>, FitError> {
    let data = FitData::new(merl, opts)?;
    let families: Vec<Family> = match opts.family {
        Some(f) => vec![f],
        None => Family::ALL.to_vec(),
    };
    let mut fits = families
        .into_iter()
        .map(|f| fit_family(&data, f, opts.distribution))
        .collect::<Result<Vec<_>, _>>()?;
    fits.sort_by(|a, b| a.quality.value.total_cmp(&b.quality.value));
    Ok(fits)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::warp;

    #[test]
    fn gulbrandsen_mapping_has_the_given_f0() {
        for f0 in [0.01, 0.04, 0.3, 0.6, 0.95] {
            for tint in [0.0, 0.3, 1.0] {
                let (n, k) = conductor_ior(f0, tint);
                assert!(n > 0.0 && k >= 0.0);
                let f = fresnel_conductor_f64(1.0, n, k);
                assert!((f - f0).abs() < 1e-9, "{f0} {tint}: {f}");
                let f32v = crate::fresnel::fresnel_conductor(0.7, n as f32, k as f32) as f64;
                assert!((fresnel_conductor_f64(0.7, n, k) - f32v).abs() < 1e-5);
            }
        }
        // tint 0 is a dielectric-like conductor (k = 0)
        assert!(conductor_ior(0.04, 0.0).1 < 1e-6);
    }

    fn random_pairs(n: usize) -> Vec<(Vec3, Vec3)> {
        let mut rng = Pcg32::new(7, 9);
        (0..n)
            .map(|_| {
                let a = warp::square_to_uniform_hemisphere(rng.next_vec2());
                let b = warp::square_to_uniform_hemisphere(rng.next_vec2());
                (a, b)
            })
            .collect()
    }

    /// The factorised plastic (a·F + l·d) equals the real `roughplastic` eval.
    #[test]
    fn factorised_plastic_matches_the_model() {
        for (kind, alpha, eta) in [
            (MicrofacetType::Ggx, 0.1, 1.49 / AIR_IOR),
            (MicrofacetType::Beckmann, 0.35, 1.8),
        ] {
            let rho = [0.6f32, 0.15, 0.1];
            let spec = format!(
                "roughplastic distribution={} alpha={alpha} int_ior={} diffuse_reflectance={},{},{}",
                kind.name(),
                (eta * AIR_IOR) as f32,
                rho[0],
                rho[1],
                rho[2]
            );
            let b = parse_spec(&spec).unwrap();
            let Bsdf::RoughPlastic(rp) = &b else { panic!() };
            let scale = rp.eta as f64 * rp.eta as f64 * (1.0 - rp.internal_reflectance() as f64);
            let t = coat_transmittance(kind, alpha, rp.eta as f64);
            let distr = MicrofacetDistribution::new(kind, alpha as f32, alpha as f32, true);
            for (wi, wo) in random_pairs(2000) {
                let f = b.eval(&BsdfContext::RADIANCE, &ShadingPoint::default(), wi, wo);
                let h = (wi + wo).normalize();
                let a = (distr.eval(h) * distr.g(wi, wo, h) / (4.0 * wi.z * wo.z)) as f64;
                let fr = FresnelMode::Exact.eval(wi.dot(h), rp.eta).r as f64;
                let l = (interp_transmittance(&t, wi.z) * interp_transmittance(&t, wo.z)) as f64
                    * FRAC_1_PI;
                for c in 0..3 {
                    let mine = a * fr + l * rho[c] as f64 / scale;
                    let want = f[c] as f64;
                    assert!(
                        (mine - want).abs() <= 2e-5 * want + 1e-9,
                        "{spec}: {wi} {wo}: {mine} vs {want}"
                    );
                }
            }
        }
    }

    /// The factorised conductor (a·F(cosθd) + kd/π) equals the real material the fit writes.
    #[test]
    fn factorised_conductor_matches_the_material() {
        let p = [[0.95, 0.2, 0.01], [0.6, 0.7, 0.03], [0.5, 0.9, 0.0]];
        let ior: [(f64, f64); 3] = std::array::from_fn(|c| conductor_ior(p[c][0], p[c][1]));
        let fit = Fit {
            family: Family::Conductor,
            distribution: MicrofacetType::Ggx,
            alpha: 0.25,
            params: FitParams::Conductor {
                f0: std::array::from_fn(|c| p[c][0] as f32),
                edge_tint: std::array::from_fn(|c| p[c][1] as f32),
                eta: ior.map(|v| v.0 as f32),
                k: ior.map(|v| v.1 as f32),
                diffuse: std::array::from_fn(|c| p[c][2] as f32),
            },
            quality: Quality {
                metric: Metric::Cbrt,
                value: 0.0,
                rel_rms: 0.0,
                bins: 0,
            },
            bsdf: Bsdf::Diffuse(Default::default()),
            evaluations: 0,
            elapsed: Duration::ZERO,
        };
        let b = parse_spec(&fit.spec()).unwrap();
        assert_eq!(b.plugin_name(), "blendbsdf");
        let distr = MicrofacetDistribution::new(MicrofacetType::Ggx, 0.25, 0.25, true);
        for (wi, wo) in random_pairs(2000) {
            let f = b.eval(&BsdfContext::RADIANCE, &ShadingPoint::default(), wi, wo);
            let h = (wi + wo).normalize();
            let a = (distr.eval(h) * distr.g(wi, wo, h) / (4.0 * wi.z * wo.z)) as f64;
            for c in 0..3 {
                let mine =
                    a * conductor_fresnel(wi.dot(h) as f64, p[c][0], p[c][1]) + p[c][2] * FRAC_1_PI;
                let want = f[c] as f64;
                assert!(
                    (mine - want).abs() <= 1e-5 * want + 1e-8,
                    "{wi} {wo} ch {c}: {mine} vs {want}"
                );
            }
        }
        // without a diffuse term the material is a plain roughconductor
        let mut plain = fit.clone();
        if let FitParams::Conductor { diffuse, .. } = &mut plain.params {
            *diffuse = [0.0; 3];
        }
        assert!(plain.spec().starts_with("roughconductor "));
        assert!(plain
            .mitsuba_xml()
            .starts_with("<bsdf type=\"roughconductor\">"));
        assert!(fit.mitsuba_xml().starts_with("<bsdf type=\"blendbsdf\">"));
    }

    #[test]
    fn fast_cube_root() {
        let mut rng = Pcg32::new(1, 1);
        for _ in 0..100_000 {
            let x = 10f64.powf(rng.next_f32() as f64 * 40.0 - 20.0) * (1.0 + rng.next_f32() as f64);
            let (a, b) = (fast_cbrt(x), x.cbrt());
            assert!((a - b).abs() <= 1e-15 * b, "{x}: {a} vs {b}");
        }
        for x in [0.0, 1e-300, 1.0, 8.0, 1e250] {
            assert!((fast_cbrt(x) - x.cbrt()).abs() <= 1e-15 * x.cbrt(), "{x}");
        }
    }

    #[test]
    fn levenberg_marquardt_respects_bounds() {
        // minimise (x − 3)² + (y + 1)² over x ∈ [0, 2], y ∈ [−5, 5]
        let f = |p: &[f64; 2], _: bool| {
            let r = [p[0] - 3.0, p[1] + 1.0];
            (r[0] * r[0] + r[1] * r[1], [[1.0, 0.0], [0.0, 1.0]], r)
        };
        let (p, c) = levenberg_marquardt([1.0, 4.0], [0.0, -5.0], [2.0, 5.0], 50, f);
        assert!(
            (p[0] - 2.0).abs() < 1e-12 && (p[1] + 1.0).abs() < 1e-9,
            "{p:?}"
        );
        assert!((c - 1.0).abs() < 1e-9);
    }

    #[test]
    fn nelder_mead_finds_the_rosenbrock_minimum() {
        let (x, v, evals) = nelder_mead(&[-1.2, 1.0], &[0.5, 0.5], 1e-9, 5000, |x| {
            (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2)
        });
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4,
            "{x:?} {v} {evals}"
        );
    }

    #[test]
    fn empty_and_black_tables_are_errors() {
        let none = Merl::from_fn(|_, _, _| crate::Spectrum::splat(-1.0)).with_name("none.binary");
        let e = FitData::new(&none, &FitOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.starts_with("none.binary: cannot fit: no bin is measured"),
            "{e}"
        );
        let black = Merl::from_fn(|_, _, _| crate::Spectrum::ZERO).with_name("black.binary");
        let e = FitData::new(&black, &FitOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert_eq!(e, "black.binary: cannot fit: every measured value is zero");
    }
}
