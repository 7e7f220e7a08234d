//! χ² goodness-of-fit test of a BSDF's `sample` against its `pdf`.
//!
//! The whole sphere of outgoing directions is cut into an odd number of bins in θ and in φ
//! (so that neither the normal nor the horizon lies on a bin edge). Sampled directions are
//! histogrammed; the expected count of each cell is N·∫pdf over the cell, integrated by
//! adaptive Gauss–Legendre cubature. Samples from Dirac lobes and failed samples form one more
//! outcome, expected N·(1 − ∫pdf over the sphere), so a sampler that loses or invents mass is
//! caught too. Cells expected to receive fewer than 5 samples are pooled. The statistic is
//! compared with the χ² distribution of (cells − 1) degrees of freedom.

use crate::bsdf::{BsdfContext, BsdfModel, ShadingPoint};
use crate::check::stats::chi2_sf;
use crate::rng::Pcg32;
use glam::{Vec2, Vec3};
use std::f64::consts::PI;

/// Settings of a χ² test.
#[derive(Clone, Copy, Debug)]
pub struct Chi2Config {
    /// Bins in θ ∈ [0, π] (odd).
    pub res_theta: usize,
    /// Bins in φ ∈ [0, 2π) (odd).
    pub res_phi: usize,
    /// Number of samples drawn.
    pub samples: usize,
    /// RNG seed (the test is deterministic for a given seed).
    pub seed: u64,
}

impl Default for Chi2Config {
    fn default() -> Self {
        Chi2Config {
            res_theta: 101,
            res_phi: 201,
            samples: 1_000_000,
            seed: 0x5eed,
        }
    }
}

/// Outcome of a χ² test.
#[derive(Clone, Debug)]
pub struct Chi2Result {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Samples that came from non-Dirac lobes.
    pub continuous_samples: usize,
    /// ∫ pdf over the sphere (the probability of a non-Dirac sample).
    pub pdf_integral: f64,
    /// Cells left after pooling.
    pub cells: usize,
    /// The cells that contribute most to the statistic: (θ bin, φ bin, observed, expected).
    pub worst: Vec<(usize, usize, f64, f64)>,
}

impl Chi2Result {
    pub fn passes(&self, significance: f64) -> bool {
        self.p_value >= significance
    }
}

/// Tensor Gauss–Legendre rule for `f(θ, φ) sinθ` over one cell.
fn gl_rule(
    f: &dyn Fn(f64, f64) -> f64,
    gl: &[(f64, f64)],
    t0: f64,
    t1: f64,
    p0: f64,
    p1: f64,
) -> f64 {
    let (ht, hp) = (0.5 * (t1 - t0), 0.5 * (p1 - p0));
    let (ct, cp) = (0.5 * (t1 + t0), 0.5 * (p1 + p0));
    let mut s = 0.0;
    for (xt, wt) in gl {
        let t = ct + ht * xt;
        let st = t.sin();
        for (xp, wp) in gl {
            s += wt * wp * f(t, cp + hp * xp) * st;
        }
    }
    s * ht * hp
}

/// Integral of `f(θ, φ) sinθ` over a cell whose one-rule estimate is `coarse`, refined
/// adaptively (quartering) until the change is below `tol` (absolute) or 1e-5 (relative), or
/// the depth runs out. Each quarter's rule is passed down as its `coarse`, so no rule is
/// evaluated twice.
#[allow(clippy::too_many_arguments)]
fn refine_cell(
    f: &dyn Fn(f64, f64) -> f64,
    t0: f64,
    t1: f64,
    p0: f64,
    p1: f64,
    coarse: f64,
    gl: &[(f64, f64)],
    depth: u32,
    tol: f64,
) -> f64 {
    let rule = |t0: f64, t1: f64, p0: f64, p1: f64| gl_rule(f, gl, t0, t1, p0, p1);
    let (tm, pm) = (0.5 * (t0 + t1), 0.5 * (p0 + p1));
    let quads = [
        (t0, tm, p0, pm),
        (tm, t1, p0, pm),
        (t0, tm, pm, p1),
        (tm, t1, pm, p1),
    ];
    let parts: [f64; 4] = quads.map(|(a, b, c, d)| rule(a, b, c, d));
    let fine: f64 = parts.iter().sum();
    if depth == 0 || (fine - coarse).abs() <= (1e-5 * fine.abs()).max(tol) {
        return fine;
    }
    quads
        .iter()
        .zip(parts)
        .map(|(&(a, b, c, d), part)| refine_cell(f, a, b, c, d, part, gl, depth - 1, 0.25 * tol))
        .sum()
}

/// Run the test for incident direction `wi`.
pub fn chi2_test<B: BsdfModel + ?Sized>(
    bsdf: &B,
    ctx: &BsdfContext,
    sp: &ShadingPoint,
    wi: Vec3,
    cfg: &Chi2Config,
) -> Chi2Result {
    let (nt, np) = (cfg.res_theta, cfg.res_phi);
    let cell_of = |w: Vec3| -> usize {
        let t = (w.z as f64).clamp(-1.0, 1.0).acos();
        let mut p = (w.y as f64).atan2(w.x as f64);
        if p < 0.0 {
            p += 2.0 * PI;
        }
        let it = ((t / PI * nt as f64) as usize).min(nt - 1);
        let ip = ((p / (2.0 * PI) * np as f64) as usize).min(np - 1);
        it * np + ip
    };

    // histogram
    let mut observed = vec![0.0f64; nt * np + 1];
    let mut rng = Pcg32::new(cfg.seed, 0xc42);
    let mut continuous = 0usize;
    for _ in 0..cfg.samples {
        let u1 = rng.next_f32();
        let u2 = Vec2::new(rng.next_f32(), rng.next_f32());
        match bsdf.sample(ctx, sp, wi, u1, u2) {
            Some(s) if !s.lobe.is_delta() && s.pdf > 0.0 => {
                observed[cell_of(s.wo)] += 1.0;
                continuous += 1;
            }
            _ => observed[nt * np] += 1.0,
        }
    }

    // expected counts
    let (x, w) = crate::quad::gauss_legendre(4);
    let gl: Vec<(f64, f64)> = x.into_iter().zip(w).collect();
    let pdf = |t: f64, p: f64| -> f64 {
        let (st, ct) = t.sin_cos();
        let wo = Vec3::new((st * p.cos()) as f32, (st * p.sin()) as f32, ct as f32);
        bsdf.pdf(ctx, sp, wi, wo) as f64
    };
    let mut expected = vec![0.0f64; nt * np + 1];
    let n = cfg.samples as f64;
    let mut total = 0.0;
    for it in 0..nt {
        let (t0, t1) = (PI * it as f64 / nt as f64, PI * (it + 1) as f64 / nt as f64);
        for ip in 0..np {
            let (p0, p1) = (
                2.0 * PI * ip as f64 / np as f64,
                2.0 * PI * (ip + 1) as f64 / np as f64,
            );
            // Integration error only needs to be small next to the cell's Poisson noise: 1 % of
            // its standard deviation adds at most 1e-4 to the cell's χ² term.
            let coarse = gl_rule(&pdf, &gl, t0, t1, p0, p1);
            let rough = refine_cell(&pdf, t0, t1, p0, p1, coarse, &gl, 0, 0.0);
            let tol = 0.01 * (rough * n).max(1.0).sqrt() / n;
            let v = refine_cell(&pdf, t0, t1, p0, p1, coarse, &gl, 7, tol);
            expected[it * np + ip] = v * n;
            total += v;
        }
    }
    expected[nt * np] = (1.0 - total).max(0.0) * n;

    // pool cells with small expectation
    let mut idx: Vec<usize> = (0..expected.len()).collect();
    idx.sort_by(|&a, &b| expected[a].partial_cmp(&expected[b]).unwrap());
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    let mut cells: Vec<(usize, f64, f64)> = Vec::new();
    for &i in &idx {
        if expected[i] < 5.0 {
            pool_o += observed[i];
            pool_e += expected[i];
        } else {
            cells.push((i, observed[i], expected[i]));
        }
    }
    if pool_e > 0.0 || pool_o > 0.0 {
        if pool_e < 5.0 && !cells.is_empty() {
            // fold an undersized pool into the smallest regular cell
            cells[0].1 += pool_o;
            cells[0].2 += pool_e;
        } else {
            cells.push((usize::MAX, pool_o, pool_e));
        }
    }
    let mut stat = 0.0;
    let mut contrib: Vec<(usize, usize, f64, f64, f64)> = Vec::new();
    for &(i, o, e) in &cells {
        let c = if e > 0.0 {
            (o - e) * (o - e) / e
        } else if o > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        stat += c;
        let (it, ip) = if i == usize::MAX || i == nt * np {
            (usize::MAX, usize::MAX)
        } else {
            (i / np, i % np)
        };
        contrib.push((it, ip, o, e, c));
    }
    contrib.sort_by(|a, b| b.4.partial_cmp(&a.4).unwrap_or(std::cmp::Ordering::Equal));
    let dof = cells.len().saturating_sub(1).max(1);
    Chi2Result {
        statistic: stat,
        dof,
        p_value: if stat.is_finite() {
            chi2_sf(stat, dof as f64)
        } else {
            0.0
        },
        continuous_samples: continuous,
        pdf_integral: total,
        cells: cells.len(),
        worst: contrib
            .iter()
            .take(5)
            .map(|c| (c.0, c.1, c.2, c.3))
            .collect(),
    }
}
