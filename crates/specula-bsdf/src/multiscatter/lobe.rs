//! The shape of the conductor compensation lobe, measured from Heitz et al.'s random walk.
//!
//! Kulla and Conty's lobe (1 − E(μi))(1 − E(μo)) / (π (1 − E_avg)) is separable and
//! diffuse-like, whereas the energy the single-scattering model misses leaves the surface
//! around the specular direction at grazing incidence. Specula keeps Kulla and Conty's
//! factors and replaces their constant 1/π by a tabulated symmetric shape Ŝ:
//!
//! f_ms(ωi, ωo) = (1 − E(μi)) (1 − E(μo)) Ŝ(α; μi, μo, Δφ) / (1 − E_avg)
//!
//! with Ŝ piecewise constant over [`LOBE_MU`] bins uniform in θ for each of μi and μo and
//! [`LOBE_PHI`] bins of the azimuth difference Δφ ∈ [0, π], at [`LOBE_ALPHAS`] roughness nodes
//! uniform in √α (every second node of the albedo tables), interpolated linearly between them
//! (Ŝ ≡ 1/π is Kulla and Conty's lobe).
//!
//! **Measurement** ([`lobe_joint_from_walk`], run once by the ignored test
//! `generate_lobe_table` of `tests/multiscatter.rs`, which writes `lobe.bin` next to this
//! file): white walks from μi distributed ∝ μ within each bin (cosine-weighted incidence), at
//! fixed seeds; every walk that scatters twice or more counts with weight 1, a walk that
//! escapes after its first bounce with weight ΛiΛo / ((1 + Λi)(1 + Λo)) = 1 − G1(ωi)G1(ωo)/G2
//! (the part of the walk's height-correlated single scattering that the model's separable
//! G1·G1 misses). The histogram is thus the exact deficit lobe f_walk − f_ss in expectation;
//! weighted by the incident bin's projected solid angle it is a joint distribution of (μi,
//! μo, Δφ) which reciprocity makes symmetric, and it is symmetrised. The file stores it per
//! roughness node as 16-bit square roots of the upper triangle (≈ 74 KB per distribution).
//!
//! **Normalisation** ([`LobeTable`], built on first use from that file and the albedo table):
//! Ŝ = joint / (m_i m_b A_c), with m_b = ∫ (1 − E(μ)) μ dμ over μ bin b and A_c = 2π/[`LOBE_PHI`]
//! the azimuth measure of a folded Δφ bin, blended with 1 % of Kulla–Conty's 1/π (so that the
//! lobe is positive everywhere), then scaled symmetrically, Ŝ_ibc ← d_i Ŝ_ibc d_b (Sinkhorn
//! iteration), until every row integrates to 1 − E_avg: Σ_bc Ŝ_ibc m_b A_c = 1 − E_avg. At a
//! roughness node the lobe then returns exactly 1 − E(μi) for every μi (within a bin the
//! factor 1 − E(μi) follows E continuously), and it is symmetric in (ωi, ωo) (reciprocal).
//! Between roughness nodes the normalisation holds to second order (furnace tests).
//!
//! **Sampling**: a roughness node with probability ∝ its weight × its row total Z, a cell
//! (μ bin, Δφ bin) from the row's discrete distribution ∝ Ŝ M_b A_c (M_b = ∫ μ dμ over the bin),
//! μ ∝ μ within the bin and Δφ uniform within the cell (either sign): the density of what is
//! sampled is exactly Ŝ(α; μi, μo, Δφ) μo / Z(α, μi), which the model reports.

use super::{
    alpha_node, gauss_legendre, parallel_rows, ConductorMs, ConductorTables, ALPHA_RES, NQ,
};
use crate::microfacet::MicrofacetType;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::OnceLock;

/// Roughness nodes, uniform in √α on [0, 1] (node k is node 2k of the albedo tables).
pub const LOBE_ALPHAS: usize = 17;
/// Bins of μ (uniform in θ), for μi and μo.
pub const LOBE_MU: usize = 16;
/// Bins of the azimuth difference Δφ ∈ [0, π].
pub const LOBE_PHI: usize = 16;
const ROW: usize = LOBE_MU * LOBE_PHI;
const SLICE: usize = LOBE_MU * ROW;
/// Weight of Kulla–Conty's constant shape blended into the measured one.
pub(crate) const KC_BLEND: f64 = 0.01;

/// The μ bin of a cosine.
#[inline]
pub(crate) fn mu_bin(mu: f32) -> usize {
    let k = (mu.clamp(0.0, 1.0).acos() * (2.0 * FRAC_1_PI * LOBE_MU as f32)) as usize;
    LOBE_MU - 1 - k.min(LOBE_MU - 1)
}

/// The μ range of bin `b`.
pub(crate) fn mu_edges(b: usize) -> (f64, f64) {
    let step = std::f64::consts::FRAC_PI_2 / LOBE_MU as f64;
    let lo = ((LOBE_MU - b) as f64 * step).cos().max(0.0);
    let hi = if b == LOBE_MU - 1 {
        1.0
    } else {
        ((LOBE_MU - 1 - b) as f64 * step).cos()
    };
    (lo, hi)
}

/// The range of t = √μ of bin `b`.
pub(crate) fn t_edges(b: usize) -> (f64, f64) {
    let (a, c) = mu_edges(b);
    (a.sqrt(), c.sqrt())
}

/// ∫ μ dμ over bin `b`.
pub(crate) fn bin_m(b: usize) -> f64 {
    let (a, c) = mu_edges(b);
    0.5 * (c * c - a * a)
}

/// Azimuth measure of a folded Δφ bin (both signs).
pub(crate) const A_C: f64 = 2.0 * std::f64::consts::PI / LOBE_PHI as f64;

/// The cosine and sine of the azimuth of `w` ((1, 0) when it has none).
#[inline]
pub(crate) fn azimuth(w: Vec3) -> (f32, f32) {
    let l2 = w.x * w.x + w.y * w.y;
    if l2 > 1e-20 {
        let inv = l2.sqrt().recip();
        (w.x * inv, w.y * inv)
    } else {
        (1.0, 0.0)
    }
}

/// The Δφ bin of (wi, wo).
#[inline]
pub(crate) fn phi_bin(wi: Vec3, wo: Vec3) -> usize {
    let (ci, si) = azimuth(wi);
    let (co, so) = azimuth(wo);
    let cos = (ci * co + si * so).clamp(-1.0, 1.0);
    ((cos.acos() * (LOBE_PHI as f32 * FRAC_1_PI)) as usize).min(LOBE_PHI - 1)
}

/// The symmetrised joint distribution of the white conductor's deficit lobe (see the module)
/// per roughness node, `LOBE_ALPHAS × LOBE_MU × LOBE_MU × LOBE_PHI` values (node 0, a smooth
/// surface, is all zero), from `walks` walks per (roughness node, μi bin), fixed seeds.
/// Also returns the relative asymmetry of the unsymmetrised estimate (Σ|J − Jᵀ| / 2ΣJ) per
/// node, a check of the walk's reciprocity and of the estimate's noise.
pub fn lobe_joint_from_walk(kind: MicrofacetType, walks: usize) -> (Vec<f64>, Vec<f64>) {
    let rows = lobe_rows(kind, 1..LOBE_ALPHAS, walks);
    let mut joint = vec![0.0f64; LOBE_ALPHAS * SLICE];
    let mut asym = vec![0.0f64; LOBE_ALPHAS];
    for (n, h) in rows.iter().enumerate() {
        let (a, i) = (n / LOBE_MU + 1, n % LOBE_MU);
        joint[a * SLICE + i * ROW..][..ROW].copy_from_slice(h);
    }
    for a in 1..LOBE_ALPHAS {
        asym[a] = symmetrise(&mut joint[a * SLICE..][..SLICE], LOBE_MU);
    }
    (joint, asym)
}

/// Walks per (roughness node, μi bin) of the committed `lobe.bin`.
pub const LOBE_WALKS: usize = 400_000;

/// The data file's record of roughness node `a` (1 … [`LOBE_ALPHAS`] − 1) of a distribution,
/// computed afresh: the same walks, seeds and encoding as [`lobe_joint_from_walk`] and
/// [`encode_lobe_tables`] with `walks` walks, for one node (a test regenerates some and
/// compares them with the committed bytes).
pub fn lobe_node_record(kind: MicrofacetType, a: usize, walks: usize) -> Vec<u8> {
    let mut joint: Vec<f64> = lobe_rows(kind, a..a + 1, walks).concat();
    symmetrise(&mut joint, LOBE_MU);
    let mut out = Vec::new();
    encode_symmetric(&mut out, &joint, LOBE_MU);
    out
}

/// The committed record of roughness node `a` of a distribution (`None` without data).
pub fn committed_lobe_node_record(kind: MicrofacetType, a: usize) -> Option<&'static [u8]> {
    let per = LOBE_ALPHAS * (4 + 2 * TRI);
    if LOBE_DATA.len() != MAGIC.len() + 2 * per || a >= LOBE_ALPHAS {
        return None;
    }
    let start = MAGIC.len() + kind_index(kind) * per + a * (4 + 2 * TRI);
    LOBE_DATA.get(start..start + 4 + 2 * TRI)
}

/// Makes one node's joint (`n` × `n` rows of [`LOBE_PHI`] values) symmetric, the mean of it and
/// its transpose; returns the relative asymmetry it had, Σ|J − Jᵀ| / 2Σ|J|.
pub(super) fn symmetrise(s: &mut [f64], n: usize) -> f64 {
    let (mut diff, mut total) = (0.0, 0.0);
    for i in 0..n {
        for b in i..n {
            for c in 0..LOBE_PHI {
                let (p, q) = ((i * n + b) * LOBE_PHI + c, (b * n + i) * LOBE_PHI + c);
                let m = 0.5 * (s[p] + s[q]);
                diff += (s[p] - s[q]).abs();
                total += s[p].abs() + if p != q { s[q].abs() } else { 0.0 };
                s[p] = m;
                s[q] = m;
            }
        }
    }
    if total > 0.0 {
        0.5 * diff / total
    } else {
        0.0
    }
}

/// The measured rows (μi bins) of roughness nodes `nodes`, in order; row n of the whole
/// measurement ((node − 1) × [`LOBE_MU`] + bin) walks with seed n + 1.
fn lobe_rows(kind: MicrofacetType, nodes: std::ops::Range<usize>, walks: usize) -> Vec<Vec<f64>> {
    use crate::models::microsurface_walk::{MicrosurfaceWalk, WalkMaterial};
    let first = (nodes.start - 1) * LOBE_MU;
    parallel_rows(nodes.len() * LOBE_MU, |n| {
        let n = n + first;
        let (a, i) = (n / LOBE_MU + 1, n % LOBE_MU);
        let alpha = alpha_node(a, LOBE_ALPHAS);
        let walk = MicrosurfaceWalk::new(
            kind,
            alpha,
            alpha,
            WalkMaterial::Conductor {
                eta: crate::spectrum::Spectrum::splat(0.0),
                k: crate::spectrum::Spectrum::splat(1.0),
                reflectance: crate::spectrum::Spectrum::splat(1.0),
            },
        );
        let mut rng = crate::rng::Pcg32::new(n as u64 + 1, 0x6c6f6265);
        let (m0, m1) = mu_edges(i);
        let mut h = vec![0.0f64; ROW];
        for _ in 0..walks {
            let mu = (m0 * m0 + rng.next_f64() * (m1 * m1 - m0 * m0))
                .sqrt()
                .max(1e-4);
            let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt() as f32, 0.0, mu as f32);
            let Some(s) = walk.sample(wi, &mut rng) else {
                continue;
            };
            if s.wo.z <= 0.0 {
                continue;
            }
            let w = if s.bounces == 1 {
                let li = walk.lambda(wi.as_dvec3());
                let lo = walk.lambda(s.wo.as_dvec3().normalize());
                li * lo / ((1.0 + li) * (1.0 + lo))
            } else {
                1.0
            };
            h[mu_bin(s.wo.z) * LOBE_PHI + phi_bin(wi, s.wo)] += w;
        }
        let scale = bin_m(i) / walks as f64;
        h.iter_mut().for_each(|v| *v *= scale);
        h
    })
}

const MAGIC: &[u8; 8] = b"SPMSLOB1";
/// Values of a node's upper triangle.
const TRI: usize = LOBE_MU * (LOBE_MU + 1) / 2 * LOBE_PHI;

pub(super) fn kind_index(kind: MicrofacetType) -> usize {
    match kind {
        MicrofacetType::Ggx => 0,
        MicrofacetType::Beckmann => 1,
    }
}

/// Appends one node of a symmetric joint (`n` × `n` rows of [`LOBE_PHI`] values, row-major):
/// a little-endian f32 scale (the largest value), then the upper triangle (rows r ≤ s, then
/// Δφ) as u16 q with value = scale (q / 65535)² (negative values as 0).
pub(super) fn encode_symmetric(out: &mut Vec<u8>, s: &[f64], n: usize) {
    let max = s.iter().cloned().fold(0.0f64, f64::max);
    out.extend_from_slice(&(max as f32).to_le_bytes());
    for r in 0..n {
        for q in r..n {
            for c in 0..LOBE_PHI {
                let v = s[(r * n + q) * LOBE_PHI + c];
                let code = if max > 0.0 {
                    ((v / max).max(0.0).sqrt() * 65535.0).round() as u16
                } else {
                    0
                };
                out.extend_from_slice(&code.to_le_bytes());
            }
        }
    }
}

/// Reads one node written by `encode_symmetric` from `bytes` at `*p` (advanced past it) into
/// `s` (both triangles); `None` if the bytes end early.
pub(super) fn decode_symmetric(bytes: &[u8], p: &mut usize, s: &mut [f64], n: usize) -> Option<()> {
    let scale = f32::from_le_bytes(bytes.get(*p..*p + 4)?.try_into().ok()?) as f64;
    *p += 4;
    for r in 0..n {
        for q in r..n {
            for c in 0..LOBE_PHI {
                let b = bytes.get(*p..*p + 2)?;
                let x = u16::from_le_bytes([b[0], b[1]]) as f64 / 65535.0;
                *p += 2;
                let v = scale * x * x;
                s[(r * n + q) * LOBE_PHI + c] = v;
                s[(q * n + r) * LOBE_PHI + c] = v;
            }
        }
    }
    Some(())
}

/// The data file for the joints of GGX and Beckmann (in that order): the magic, then per
/// distribution and roughness node `encode_symmetric`'s record (μi, μo bins, then Δφ).
pub fn encode_lobe_tables(joints: [&[f64]; 2]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    for j in joints {
        for a in 0..LOBE_ALPHAS {
            encode_symmetric(&mut out, &j[a * SLICE..][..SLICE], LOBE_MU);
        }
    }
    out
}

/// The joint of one distribution from [`encode_lobe_tables`]'s bytes (`None`: no or a
/// malformed file).
fn decode_lobe_table(bytes: &[u8], kind: MicrofacetType) -> Option<Vec<f64>> {
    let per = LOBE_ALPHAS * (4 + 2 * TRI);
    if bytes.len() != MAGIC.len() + 2 * per || &bytes[..MAGIC.len()] != MAGIC {
        return None;
    }
    let mut p = MAGIC.len() + kind_index(kind) * per;
    let mut joint = vec![0.0f64; LOBE_ALPHAS * SLICE];
    for a in 0..LOBE_ALPHAS {
        decode_symmetric(bytes, &mut p, &mut joint[a * SLICE..][..SLICE], LOBE_MU)?;
    }
    Some(joint)
}

/// The committed measurement (see the module; regenerate with `cargo test --release -p
/// specula-bsdf --test multiscatter generate_lobe_table -- --ignored`).
const LOBE_DATA: &[u8] = include_bytes!("lobe.bin");

/// The normalised lobe shape of one distribution (see the module).
#[derive(Debug)]
pub struct LobeTable {
    /// Ŝ per (roughness node, μi bin, μo bin, Δφ bin).
    s: Vec<f32>,
    /// Z = Σ_bc Ŝ M_b A_c per (roughness node, μi bin).
    z: Vec<f32>,
    /// Σ_b R_ib ∫_b q(μ) μ dμ per (roughness node of the albedo tables, μi bin), with
    /// R_ib = Σ_c Ŝ_ibc A_c and q the components of C(μ) ([`NQ`]): ρ(μi) of any Fresnel fit
    /// is their combination.
    q: Vec<[f32; NQ]>,
    /// Per (roughness node, μi bin): the cumulative distribution of the cells (μo bin, Δφ
    /// bin) ∝ Ŝ M_b A_c.
    cdf: Vec<f32>,
    /// Whether the shape came from the measurement (false: Kulla–Conty's 1/π).
    pub measured: bool,
    bins: FastBins,
}

/// The μ and Δφ bins by comparisons, without `acos`: the lower μ edges of bins 1..
/// (ascending), and the cosines of the Δφ edges 1.. (descending).
#[derive(Debug, Clone)]
pub(crate) struct FastBins {
    mu_lo: [f32; LOBE_MU - 1],
    phi_cos: [f32; LOBE_PHI - 1],
}

impl FastBins {
    pub(crate) fn new() -> Self {
        FastBins {
            mu_lo: std::array::from_fn(|b| mu_edges(b + 1).0 as f32),
            phi_cos: std::array::from_fn(|c| {
                ((c + 1) as f64 * std::f64::consts::PI / LOBE_PHI as f64).cos() as f32
            }),
        }
    }

    /// The μ bin of a cosine ([`mu_bin`] by comparisons).
    #[inline]
    pub(crate) fn mu(&self, mu: f32) -> usize {
        self.mu_lo.partition_point(|&e| e <= mu)
    }

    /// The Δφ bin of (wi, wo) ([`phi_bin`] by comparisons).
    #[inline]
    pub(crate) fn phi(&self, wi: Vec3, wo: Vec3) -> usize {
        let li2 = wi.x * wi.x + wi.y * wi.y;
        let lo2 = wo.x * wo.x + wo.y * wo.y;
        if lo2 <= 1e-20 {
            return 0;
        }
        let cos = if li2 <= 1e-20 {
            wo.x / lo2.sqrt()
        } else {
            (wi.x * wo.x + wi.y * wo.y) / (li2 * lo2).sqrt()
        };
        self.phi_cos.partition_point(|&e| cos < e)
    }
}

impl LobeTable {
    /// Build from a joint (or Kulla–Conty's constant shape without one) and the albedo table
    /// the compensation reads (rows at the α nodes of [`alpha_node`] over `ALPHA_RES`).
    fn build(joint: Option<&[f64]>, e: &ConductorTables) -> Self {
        let (gx, gw) = gauss_legendre(12);
        let mut s = vec![0.0f32; LOBE_ALPHAS * SLICE];
        let mut z = vec![0.0f32; LOBE_ALPHAS * LOBE_MU];
        let mut cdf = vec![0.0f32; LOBE_ALPHAS * SLICE];
        for a in 0..LOBE_ALPHAS {
            let alpha = alpha_node(a, LOBE_ALPHAS);
            // m_b = ∫ (1 − E) μ dμ over each bin (in t = √μ: 2t³ (1 − E(t²)) dt)
            let m: Vec<f64> = (0..LOBE_MU)
                .map(|b| {
                    let (t0, t1) = t_edges(b);
                    gx.iter()
                        .zip(&gw)
                        .map(|(x, w)| {
                            let t = t0 + (t1 - t0) * 0.5 * (x + 1.0);
                            let mu = t * t;
                            let ev = e.e(alpha, mu as f32) as f64;
                            2.0 * t * mu * (1.0 - ev) * w * 0.5 * (t1 - t0)
                        })
                        .sum()
                })
                .collect();
            let target = 2.0 * m.iter().sum::<f64>();
            let kc = 1.0 / std::f64::consts::PI;
            let mut sh = vec![kc; SLICE];
            let j = joint.map(|j| &j[a * SLICE..][..SLICE]);
            let total: f64 = j.map_or(0.0, |j| j.iter().sum());
            if let (Some(j), true) = (j, target > 1e-5 && total > 0.0) {
                // the measured shape, scaled as a whole to the right energy, blended with 1/π
                let mut raw = vec![0.0f64; SLICE];
                let mut energy = 0.0;
                for i in 0..LOBE_MU {
                    for b in 0..LOBE_MU {
                        for c in 0..LOBE_PHI {
                            let k = i * ROW + b * LOBE_PHI + c;
                            let den = (m[i] * m[b]).max(1e-12) * A_C;
                            raw[k] = j[k] / den;
                            energy += raw[k] * m[i] * m[b] * A_C;
                        }
                    }
                }
                let want: f64 = m.iter().map(|mi| mi * target).sum();
                let g = want / energy;
                for k in 0..SLICE {
                    sh[k] = (1.0 - KC_BLEND) * g * raw[k] + KC_BLEND * kc;
                }
                sinkhorn(&mut sh, &m, target);
            }
            for i in 0..LOBE_MU {
                let row = &sh[i * ROW..][..ROW];
                let mut acc = 0.0f64;
                let base = a * SLICE + i * ROW;
                for b in 0..LOBE_MU {
                    for c in 0..LOBE_PHI {
                        let k = b * LOBE_PHI + c;
                        s[base + k] = row[k] as f32;
                        acc += row[k] * bin_m(b) * A_C;
                        cdf[base + k] = acc as f32;
                    }
                }
                z[a * LOBE_MU + i] = acc as f32;
                for v in &mut cdf[base..base + ROW] {
                    *v = (*v as f64 / acc) as f32;
                }
                cdf[base + ROW - 1] = 1.0;
            }
        }
        // ρ's components at every roughness node of the albedo tables (C is linear in √α
        // between them)
        let q = (0..ALPHA_RES)
            .flat_map(|k| {
                let alpha = alpha_node(k, ALPHA_RES);
                let (a, w) = Self::alpha_coord(alpha);
                let qb: Vec<[f64; NQ]> = (0..LOBE_MU)
                    .map(|b| {
                        let (t0, t1) = t_edges(b);
                        let mut acc = [0.0f64; NQ];
                        for (x, wt) in gx.iter().zip(&gw) {
                            let t = t0 + (t1 - t0) * 0.5 * (x + 1.0);
                            let mu = t * t;
                            let c = e.at(alpha, mu as f32).components();
                            for (a, c) in acc.iter_mut().zip(c) {
                                *a += 2.0 * t * mu * c as f64 * wt * 0.5 * (t1 - t0);
                            }
                        }
                        acc
                    })
                    .collect();
                let s = &s;
                (0..LOBE_MU).map(move |i| {
                    let mut qi = [0.0f64; NQ];
                    for (b, qb) in qb.iter().enumerate() {
                        let r: f64 = (0..LOBE_PHI)
                            .map(|c| {
                                let k = i * ROW + b * LOBE_PHI + c;
                                let (x, y) = (s[a * SLICE + k], s[(a + 1) * SLICE + k]);
                                (x + (y - x) * w) as f64
                            })
                            .sum::<f64>()
                            * A_C;
                        for (x, y) in qi.iter_mut().zip(qb) {
                            *x += r * y;
                        }
                    }
                    qi.map(|v| v as f32)
                })
            })
            .collect();
        LobeTable {
            bins: FastBins::new(),
            s,
            z,
            q,
            cdf,
            measured: joint.is_some(),
        }
    }

    /// Roughness node and weight.
    #[inline]
    fn alpha_coord(alpha: f32) -> (usize, f32) {
        let x = alpha.clamp(0.0, 1.0).sqrt() * (LOBE_ALPHAS - 1) as f32;
        let i = (x as usize).min(LOBE_ALPHAS - 2);
        (i, x - i as f32)
    }

    #[inline]
    fn mu_bin_fast(&self, mu: f32) -> usize {
        self.bins.mu(mu)
    }

    #[inline]
    fn phi_bin_fast(&self, wi: Vec3, wo: Vec3) -> usize {
        self.bins.phi(wi, wo)
    }

    /// Ŝ(α; μi, μo, Δφ) and the density of [`Self::sample`] at wo over solid angle, Ŝ μo / Z
    /// (both wi and wo above the surface).
    #[inline]
    pub fn eval(&self, alpha: f32, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let (a, w) = Self::alpha_coord(alpha);
        let i = self.mu_bin_fast(wi.z);
        let k = i * ROW + self.mu_bin_fast(wo.z) * LOBE_PHI + self.phi_bin_fast(wi, wo);
        let (s0, s1) = (self.s[a * SLICE + k], self.s[(a + 1) * SLICE + k]);
        let (z0, z1) = (self.z[a * LOBE_MU + i], self.z[(a + 1) * LOBE_MU + i]);
        let s = s0 + (s1 - s0) * w;
        let z = z0 + (z1 - z0) * w;
        (s, s * wo.z / z)
    }

    /// ρ(μ) = Σ_b R_ib ∫_b C(μo) μo dμo for the compensation colour `ms` (the row integral
    /// of C_o Ŝ over ωo; 1 − E_avg for a white conductor).
    #[inline]
    pub fn rho(&self, alpha: f32, mu: f32, ms: &ConductorMs) -> Spectrum {
        let x = alpha.clamp(0.0, 1.0).sqrt() * (ALPHA_RES - 1) as f32;
        let a = (x as usize).min(ALPHA_RES - 2);
        let w = x - a as f32;
        let i = self.mu_bin_fast(mu);
        let (q0, q1) = (&self.q[a * LOBE_MU + i], &self.q[(a + 1) * LOBE_MU + i]);
        let q: [f32; NQ] = std::array::from_fn(|k| q0[k] + (q1[k] - q0[k]) * w);
        ms.combine(&q)
    }

    /// The μ bin of a cosine (the index of [`Self::rho_bins`]).
    #[inline]
    pub fn bin(&self, mu: f32) -> usize {
        self.mu_bin_fast(mu)
    }

    /// ρ per μ bin for one roughness and compensation colour, made exact: the symmetric
    /// scaling ρ_i = C_avg / d_i² per channel (Sinkhorn iteration) for which every row of
    /// C(μi) C(μo) Ŝ / √(ρ_i ρ_o) integrates to C(μi) exactly (with [`ConductorMs::lobe_measured`]).
    pub fn rho_bins(
        &self,
        t: &ConductorTables,
        alpha: f32,
        ms: &ConductorMs,
    ) -> [Spectrum; LOBE_MU] {
        let (a, w) = Self::alpha_coord(alpha);
        let lerp = |x: f32, y: f32| (x + (y - x) * w) as f64;
        // n_b = ∫_b C(μ) μ dμ at this roughness, as the model evaluates C
        let (gx, gw) = gauss_legendre(12);
        let n: Vec<[f64; 3]> = (0..LOBE_MU)
            .map(|b| {
                let (t0, t1) = t_edges(b);
                let mut acc = [0.0f64; 3];
                for (x, wt) in gx.iter().zip(&gw) {
                    let tt = t0 + (t1 - t0) * 0.5 * (x + 1.0);
                    let mu = tt * tt;
                    let c = ms.energy(&t.at(alpha, mu as f32));
                    for ch in 0..3 {
                        acc[ch] += 2.0 * tt * mu * c[ch] as f64 * wt * 0.5 * (t1 - t0);
                    }
                }
                acc
            })
            .collect();
        let r: Vec<f64> = (0..LOBE_MU * LOBE_MU)
            .map(|ib| {
                (0..LOBE_PHI)
                    .map(|c| {
                        let k = ib * LOBE_PHI + c;
                        lerp(self.s[a * SLICE + k], self.s[(a + 1) * SLICE + k])
                    })
                    .sum::<f64>()
                    * A_C
            })
            .collect();
        let mut out = [Spectrum::ZERO; LOBE_MU];
        for ch in 0..3 {
            let nb: Vec<f64> = n.iter().map(|v| v[ch].max(0.0)).collect();
            let k = 2.0 * nb.iter().sum::<f64>();
            if k <= 1e-9 {
                continue;
            }
            let d = damped_scaling(&[k; LOBE_MU], 20000, 1e-9, |i, d| {
                (0..LOBE_MU)
                    .map(|b| r[i * LOBE_MU + b] * d[b] * nb[b])
                    .sum()
            });
            for i in 0..LOBE_MU {
                out[i].0[ch] = (k / (d[i] * d[i])) as f32;
            }
        }
        out
    }

    /// A direction distributed with the density [`Self::eval`] reports, from `u` (the
    /// roughness node) and `u2`.
    #[inline]
    pub fn sample(&self, alpha: f32, wi: Vec3, u: f32, u2: Vec2) -> Vec3 {
        let (a, w) = Self::alpha_coord(alpha);
        let i = self.mu_bin_fast(wi.z);
        let z0 = self.z[a * LOBE_MU + i] * (1.0 - w);
        let z1 = self.z[(a + 1) * LOBE_MU + i] * w;
        let node = if u * (z0 + z1) < z0 { a } else { a + 1 };
        let cdf = &self.cdf[node * SLICE + i * ROW..][..ROW];
        let ux = u2.x.min(1.0 - f32::EPSILON);
        let k = cdf.partition_point(|&c| c <= ux).min(ROW - 1);
        let lo = if k == 0 { 0.0 } else { cdf[k - 1] };
        let frac = ((ux - lo) / (cdf[k] - lo).max(1e-30)).clamp(0.0, 1.0);
        let (b, c) = (k / LOBE_PHI, k % LOBE_PHI);
        let (m0, m1) = mu_edges(b);
        let (m0, m1) = (m0 as f32, m1 as f32);
        let mu = (m0 * m0 + frac * (m1 * m1 - m0 * m0)).sqrt();
        let v = 2.0 * u2.y;
        let (sign, f) = if v < 1.0 { (1.0, v) } else { (-1.0, v - 1.0) };
        let dphi = sign * (c as f32 + f) * (PI / LOBE_PHI as f32);
        let (ci, si) = azimuth(wi);
        let (sd, cd) = dphi.sin_cos();
        let r = (1.0 - mu * mu).max(0.0).sqrt();
        Vec3::new(r * (ci * cd - si * sd), r * (si * cd + ci * sd), mu)
    }
}

/// Sinkhorn's iteration with damped (square-root) updates, shared by the conductor
/// lobes' normalisations and the dielectric lobes' `sym_scaling` and `block_scaling`: factors f_i (0 where `target[i]` is 0, else starting at 1) updated in
/// turn by f_i ← f_i √(target_i / (f_i part(i, f))), where `part(i, f)` is the sum that f_i
/// multiplies, until every ratio is within `tol` of 1 or after `iterations` sweeps.
pub(crate) fn damped_scaling(
    target: &[f64],
    iterations: usize,
    tol: f64,
    part: impl Fn(usize, &[f64]) -> f64,
) -> Vec<f64> {
    let mut f: Vec<f64> = target
        .iter()
        .map(|&t| if t <= 1e-14 { 0.0 } else { 1.0 })
        .collect();
    for _ in 0..iterations {
        let mut worst = 0.0f64;
        for i in 0..f.len() {
            if f[i] == 0.0 {
                continue;
            }
            let p = part(i, &f);
            if p <= 0.0 {
                continue;
            }
            let ratio = target[i] / (f[i] * p);
            worst = worst.max((ratio - 1.0).abs());
            f[i] *= ratio.sqrt();
        }
        if worst < tol {
            break;
        }
    }
    f
}

/// Symmetric Sinkhorn scaling of a symmetric shape: Ŝ_ibc ← d_i Ŝ_ibc d_b until every row
/// satisfies Σ_bc Ŝ_ibc m_b A_c = target.
fn sinkhorn(sh: &mut [f64], m: &[f64], target: f64) {
    let r: Vec<f64> = (0..LOBE_MU * LOBE_MU)
        .map(|ib| sh[ib * LOBE_PHI..][..LOBE_PHI].iter().sum::<f64>() * A_C)
        .collect();
    let d = damped_scaling(&[target; LOBE_MU], 2000, 1e-9, |i, d| {
        (0..LOBE_MU).map(|b| r[i * LOBE_MU + b] * d[b] * m[b]).sum()
    });
    for i in 0..LOBE_MU {
        for b in 0..LOBE_MU {
            for c in 0..LOBE_PHI {
                sh[i * ROW + b * LOBE_PHI + c] *= d[i] * d[b];
            }
        }
    }
}

/// The lobe shape of a distribution (built on first use from the committed measurement and
/// the albedo table, a few milliseconds).
pub fn lobe_table(kind: MicrofacetType) -> &'static LobeTable {
    static GGX: OnceLock<LobeTable> = OnceLock::new();
    static BECKMANN: OnceLock<LobeTable> = OnceLock::new();
    let cell = match kind {
        MicrofacetType::Ggx => &GGX,
        MicrofacetType::Beckmann => &BECKMANN,
    };
    cell.get_or_init(|| {
        let joint = decode_lobe_table(LOBE_DATA, kind);
        LobeTable::build(joint.as_deref(), super::conductor_tables(kind))
    })
}

/// `LobeTable::build` from a joint in memory (the generator's check before writing).
pub fn lobe_table_from(kind: MicrofacetType, joint: &[f64]) -> LobeTable {
    LobeTable::build(Some(joint), super::conductor_tables(kind))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The committed file decodes and re-encodes to the same bytes (the shared record
    /// format of `encode_symmetric` / [`decode_symmetric`]), and a truncated one is refused.
    #[test]
    fn lobe_file_round_trips_byte_for_byte() {
        let g = decode_lobe_table(LOBE_DATA, MicrofacetType::Ggx).unwrap();
        let b = decode_lobe_table(LOBE_DATA, MicrofacetType::Beckmann).unwrap();
        assert!(encode_lobe_tables([&g, &b]) == LOBE_DATA);
        assert!(
            decode_lobe_table(&LOBE_DATA[..LOBE_DATA.len() - 1], MicrofacetType::Ggx).is_none()
        );
    }

    /// The committed data is the output of Specula's own generator: a smooth and a rough
    /// roughness node of each distribution, regenerated with the committed walk count and
    /// seeds, encode to the committed bytes exactly (each row's walks are a deterministic
    /// function of its seed).
    #[test]
    fn committed_data_is_the_generators_output() {
        for (kind, a) in [
            (MicrofacetType::Ggx, 3),
            (MicrofacetType::Ggx, LOBE_ALPHAS - 1),
            (MicrofacetType::Beckmann, LOBE_ALPHAS - 5),
        ] {
            let committed = committed_lobe_node_record(kind, a).expect("data");
            let fresh = lobe_node_record(kind, a, LOBE_WALKS);
            let differing = fresh.iter().zip(committed).filter(|(x, y)| x != y).count();
            assert!(
                fresh.len() == committed.len() && differing == 0,
                "{kind:?} node {a}: {differing} of {} bytes differ",
                committed.len()
            );
        }
    }

    use crate::multiscatter::{conductor_tables, FresnelFit};

    /// ∫ f_ms(ωi, ωo) μo dωo of the white conductor's compensation lobe as the model
    /// evaluates it (C_i C_o Ŝ / √(ρ_i ρ_o)), by quadrature exact for the piecewise-constant
    /// shape (Gauss–Legendre within each μ bin, one node per Δφ bin).
    fn row_integral(kind: MicrofacetType, alpha: f32, mu_i: f32) -> (f64, f64) {
        let t = conductor_tables(kind);
        let lt = lobe_table(kind);
        let ms = t.ms(alpha, &FresnelFit::WHITE);
        let wi = Vec3::new((1.0 - mu_i * mu_i).sqrt(), 0.0, mu_i);
        let c_i = ms.energy(&t.at(alpha, mu_i));
        let r_i = lt.rho(alpha, mu_i, &ms);
        let (gx, gw) = gauss_legendre(16);
        let mut sum = 0.0f64;
        for b in 0..LOBE_MU {
            let (m0, m1) = mu_edges(b);
            for (x, w) in gx.iter().zip(&gw) {
                let mu = m0 + (m1 - m0) * 0.5 * (x + 1.0);
                let wmu = w * 0.5 * (m1 - m0);
                let c_o = ms.energy(&t.at(alpha, mu as f32));
                let r_o = lt.rho(alpha, mu as f32, &ms);
                for c in 0..LOBE_PHI {
                    let phi = (c as f32 + 0.5) * PI / LOBE_PHI as f32;
                    let s = (1.0 - mu * mu).sqrt() as f32;
                    let wo = Vec3::new(s * phi.cos(), s * phi.sin(), mu as f32);
                    let (shape, _) = lt.eval(alpha, wi, wo);
                    let f = ms.lobe_measured(c_i, c_o, shape, r_i, r_o)[0] as f64;
                    sum += f * mu * wmu * A_C;
                }
            }
        }
        (sum, c_i[0] as f64)
    }

    /// The committed data decodes; every row of the white lobe integrates to the energy the
    /// single-scattering model misses, 1 − E(μi), with ρ as a textured roughness reads it: to
    /// 1e-3 at the roughness nodes (the quadrature of the tables), within 0.2 % of the total
    /// between them (second order in the node spacing; the white furnace allows 0.5 %); the
    /// shape is symmetric.
    #[test]
    fn rows_integrate_to_the_deficit() {
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            assert!(decode_lobe_table(LOBE_DATA, kind).is_some(), "lobe.bin");
            let lt = lobe_table(kind);
            assert!(lt.measured);
            for (alpha, tol) in [
                (1.0f32, 1e-3),
                (0.5625, 1e-3),
                (0.3, 2e-3),
                (0.8, 2e-3),
                (0.05, 2e-3),
            ] {
                for mu in [0.02f32, 0.09, 0.3, 0.55, 0.8, 0.99] {
                    let (got, want) = row_integral(kind, alpha, mu);
                    assert!(
                        (got - want).abs() < tol,
                        "{kind:?} α={alpha} μ={mu}: ∫ = {got}, 1 − E = {want}"
                    );
                }
            }
            for a in [4usize, 10, 16] {
                let base = a * SLICE;
                for i in 0..LOBE_MU {
                    for b in 0..LOBE_MU {
                        for c in 0..LOBE_PHI {
                            let (p, q) = (i * ROW + b * LOBE_PHI + c, b * ROW + i * LOBE_PHI + c);
                            let (x, y) = (lt.s[base + p], lt.s[base + q]);
                            assert!((x - y).abs() <= 1e-6 * x.abs().max(1e-6), "{x} {y}");
                        }
                    }
                }
            }
        }
    }

    /// `sample` draws directions with the density `eval` reports: the histogram of 400 000
    /// samples over the table's cells against the integral of the density (χ²-like bound).
    #[test]
    fn sampling_matches_the_density() {
        let lt = lobe_table(MicrofacetType::Ggx);
        let mut rng = crate::rng::Pcg32::new(5, 7);
        for (alpha, mu_i) in [(0.7f32, 0.1f32), (0.3, 0.6), (1.0, 0.97)] {
            let wi = Vec3::new((1.0 - mu_i * mu_i).sqrt(), 0.0, mu_i);
            let n = 400_000;
            let mut hist = vec![0.0f64; ROW];
            for _ in 0..n {
                let wo = lt.sample(alpha, wi, rng.next_f32(), rng.next_vec2());
                assert!(wo.z >= 0.0 && (wo.length() - 1.0).abs() < 1e-4);
                hist[mu_bin(wo.z) * LOBE_PHI + phi_bin(wi, wo)] += 1.0;
            }
            // the density is constant × μo in each cell: its mass is density/μo × M_b A_c
            let mut worst = 0.0f64;
            for b in 0..LOBE_MU {
                let (m0, m1) = mu_edges(b);
                let mu = (0.5 * (m0 + m1)) as f32;
                for c in 0..LOBE_PHI {
                    let phi = (c as f32 + 0.5) * PI / LOBE_PHI as f32;
                    let s = (1.0 - mu * mu).sqrt();
                    let wo = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
                    let (_, pdf) = lt.eval(alpha, wi, wo);
                    let p = pdf as f64 / mu as f64 * bin_m(b) * A_C;
                    let got = hist[b * LOBE_PHI + c] / n as f64;
                    let sigma = (p / n as f64).sqrt();
                    worst = worst.max((got - p).abs() / (sigma + 1e-9));
                    assert!(
                        (got - p).abs() < 5.0 * sigma + 1e-5,
                        "α={alpha} μi={mu_i} cell {b},{c}: {got} vs {p}"
                    );
                }
            }
            assert!(worst > 0.5, "the test has noise: {worst}");
        }
    }
}
