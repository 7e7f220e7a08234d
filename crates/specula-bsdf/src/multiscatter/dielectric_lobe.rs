//! The shapes of the dielectric compensation lobes, measured from Heitz et al.'s random walk:
//! the dielectric analogue of [`super::lobe`].
//!
//! A rough dielectric interface loses 1 − E_o(μ) of the light arriving from outside and
//! 1 − E_i(μ) of the light arriving from inside (E: R + T of the single-scattering model with
//! η and 1/η). Specula returns it with four lobes (importance transport; radiance divides the
//! transmission by η_rel² as the single-scattering lobe does), c_o = 1 − E_o, c_i = 1 − E_i:
//!
//! - reflection outside: c_o(μi) c_o(μo) M_oo(μi, μo, Δφ)
//! - transmission outside → inside: c_o(μi) c_i(μo) M_oi(μi, μo, Δφ)
//! - transmission inside → outside: c_i(μi) c_o(μo) M_oi(μo, μi, Δφ) / η²
//! - reflection inside: c_i(μi) c_i(μo) M_ii(μi, μo, Δφ) / η²
//!
//! with M measured over [`LOBE_MU`] bins of μ on each side that narrow towards the horizon
//! ([`mu_edges`]) and [`LOBE_PHI`] bins of the azimuth difference Δφ ∈ [0, π] that narrow
//! towards π ([`phi_edge`]), and interpolated piecewise linearly between the bins' centres —
//! in x = μ² for μi and μo, in Δφ — with hat functions, constant beyond the outer centres (a
//! piecewise-constant lobe lost the peak of grazing incidences to its bins). Seen as one
//! matrix over the 2 × [`LOBE_MU`] μ nodes of both sides (outside first), M is symmetric: the
//! reflection lobes are reciprocal, and the transmission outside → inside is exactly η² times the reverse one, the generalised
//! reciprocity of refraction. Kulla and Conty's separable lobes (with their hemispherically
//! averaged crossing energy x, see [`super`]) are the constant blocks
//! M_oo = (1 − E_o,avg − x) / (π (1 − E_o,avg)²), M_oi = x / (π (1 − E_o,avg)(1 − E_i,avg)),
//! M_ii = (η² (1 − E_i,avg) − x) / (π (1 − E_i,avg)²).
//!
//! **Measurement** ([`dielectric_joint_from_walk`], run once by the ignored test
//! `generate_dielectric_lobe_table` of `tests/multiscatter.rs`, which writes
//! `dielectric_lobe.bin` next to this file): white dielectric walks at [`DIEL_ETAS`] ×
//! [`DIEL_ALPHAS`] nodes (η uniform in cos θc = √(1 − 1/η²) over [1.05, 3], α uniform in
//! √α: 13 nodes, of which 12 measured; 7 left Beckmann α = 0.6 at η = 1.16 0.03 from the
//! walk at grazing incidence, twice its error at the neighbouring nodes), from μi
//! distributed ∝ μ within each bin of each side, fixed seeds (150 000 walks per (node, incident
//! bin) for GGX, 50 000 for Beckmann, whose walk costs ~10× more; 4.9 MB). Every walk that scatters twice or
//! more counts with weight 1. One that leaves after its first event is the walk's
//! (height-correlated) single scattering: the escape probability after the event is
//! P = (1 + Λi)/(1 + Λi + Λo) after a reflection and (1 + Λi) B(1 + Λi, 1 + Λo) after a
//! refraction (the heights the ray meets, C1 uniform, density (1 + Λi) C1^Λi, escape upwards
//! C1^Λo, downwards (1 − C1)^Λo), i.e. masking-shadowing G1(ωi) P =
//! [`crate::microfacet::MicrofacetDistribution::g2_correlated`] (checked against the walk by
//! `dielectric_first_event_is_height_correlated`). Two joints come from the same walks:
//!
//! - against the **height-correlated** single-scattering model (`multiscatter=true` of
//!   `roughdielectric`, `principled`'s transmissive part and `roughplastic`'s coat), which has
//!   exactly that first event, such a walk counts 0: the deficit is the walk's multiple
//!   scattering, non-negative;
//! - against the **separable** G1(ωi)G1(ωo) it counts with the part the model lacks,
//!   1 − G1(ωo)/P: positive after a reflection, negative after a refraction (the separable
//!   model transmits *more* in single scattering than the walk; no non-negative lobe can then
//!   match the walk closer than that negative part, [`negative_deficit`], the survey's bound).
//!   No material compensates the separable model, so this joint is not stored (its tables get
//!   Kulla–Conty's lobes).
//!
//! Each histogram is the exact deficit lobe f_walk − f_ss in expectation; weighted by the
//! incident bin's projected solid angle, with the rows of the inside incidences multiplied by
//! η², it is a joint over both sides that reciprocity makes symmetric, and it is symmetrised.
//! The file stores the height-correlated joint per (distribution, η node, roughness node) as
//! 16-bit square roots of the upper triangle.
//!
//! **Normalisation** (`DielectricLobe::build`, per material, when its energy tables are
//! built): the joint is interpolated linearly in cos θc and √α between the nodes (each node's
//! joint normalised to unit total; η < 1 reads the nodes of 1/η with the sides exchanged,
//! η outside [1.05, 3] the nearest node). Its cells are integrals over bins of
//! c(μi) c(μo) M μi μo; the nodal values V of the interpolated M whose integrals over the bins
//! they are follow from three small linear solves (**histopolation**, `Axis::histopolation`:
//! J = W V Wᵀ along μi and μo, W_rb = ∫ over bin r of h_b(μ²) c(μ) μ dμ with this material's
//! own c, and likewise along Δφ). Taking each bin's mean as its node's value instead smoothed
//! the lobe: Beckmann α = 1 at η = 1.14 (a node) seen from inside at 85° lost 0.032 of its
//! energy at μo 0.08–0.17 to μo 0.17–0.33, 0.037 above the noise; with histopolation 0.013.
//! In the hats' weights, J_rs = V_rs ν_r ν_s A_c. Where the solve undershoots next to a peak V
//! is negative: such values become 0, and each row's parts on the two sides are scaled back
//! to the sums they had before (`block_scaling`: J_rs ← f_r,side(s) J_rs f_s,side(r), which
//! keeps J symmetric). Clamping alone put the negative mass back into the small blocks: the
//! reflected part of grazing incidences on rough low-index interfaces rose by a quarter to a
//! third (GGX α = 1, η = 1.19, 85°: 0.0157 of the deficit, the walk's 0.0113; restored:
//! 0.0112), so `roughplastic`'s coat reflected up to 6.5 % more than the walk at 85° between
//! the η nodes (GGX α = 1, η = 1.2; now within 1.7 % in the cases tried). The joint is then scaled to the material's
//! total deficit and blended with 1 % of Kulla–Conty's lobes, then scaled symmetrically, J_rs ← d_r J_rs d_s
//! (Sinkhorn iteration), until every row r holds the deficit ν_r = ∫ h_r(μ²) c(μ) μ dμ of its
//! node's hat h_r (times η² for the inside rows) — from this material's own tables — and
//! M = J / (ν_r ν_s A_c), A_c = 2 ∫ h_c(Δφ) dΔφ. Each node's row then integrates to 1
//! against c(μo), the hats of μi are a partition of unity, and so every lobe row integrates to
//! exactly c(μi) for every μi (c follows E continuously), R + T = 1 from both sides, for any η
//! and, for a constant roughness, any α; between the roughness nodes of a textured roughness
//! to second order. The R/T split of each incidence is the walk's, not a constant: the
//! hemispherically averaged crossing energy x is the measured one.
//!
//! **Sampling**: a (roughness node, μi node) pair with probability ∝ their weights × the
//! node row's total Z, a (side and μ node, Δφ node) from the row's discrete distribution
//! ∝ M m_s A_c (m_s = ∫ h_s(μ²) μ dμ), then x = μ² ∝ the μ node's hat (piecewise linear in x)
//! and Δφ ∝ the Δφ node's hat (either sign): the density is exactly the interpolated
//! M |μo| / Z, which the models report.
//!
//! **`roughplastic`'s coat** reflects only (the light its compensation transmits enters the
//! diffuse base, which has no shape of its own to give it): its lobe is the outside
//! reflection block of the same normalised lobes, and [`DielectricLobe::reflected_share`] is
//! the part of each outside row it holds (the walk's reflect/transmit split of that
//! incidence); the coat adds the rest, c_o(μ)(1 − share(μ)), to its transmittance into the
//! base, so the base's energy balance stays exact.

use super::lobe::{
    azimuth, damped_scaling, decode_symmetric, encode_symmetric, kind_index, symmetrise, KC_BLEND,
    LOBE_MU, LOBE_PHI,
};
use super::{alpha_node, gauss_legendre, parallel_rows, DielectricEnergy};
use crate::microfacet::MicrofacetType;
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::OnceLock;

/// η nodes of the measurement (η ≥ 1; η < 1 reads 1/η with the sides exchanged): uniform in
/// the cosine of the critical angle, [`eta_coordinate`] u = cos θc = √(1 − 1/η²), from 1.05 to
/// 3 (Δu = 0.058, rounded to 4 decimals), in which the joints are interpolated linearly. The
/// lobes change with u at a roughly constant rate, not with ln η: the largest row distance
/// between the joint measured at the ln-midpoint of two of the former nodes {1.05, 1.25, 1.5,
/// 2, 3} and their mean (`dielectric_eta_interpolation_probe` of `tests/multiscatter.rs`, GGX
/// and Beckmann, α = 0.44 and 1, coarse bins, times the row's deficit) was 0.12–0.31 for
/// 1.05–1.25, 0.025–0.05 for 1.25–1.5, 0.012–0.044 for 1.5–2 and 0.004–0.019 for 2–3: per
/// Δu² 1.4–3.5, 1.2–2.4, 0.8–3.0, 0.7–3.2, but per (Δ ln η)² 0.66–9 (noise 0.002–0.017).
pub const DIEL_ETAS: [f32; 12] = [
    1.05, 1.0732, 1.1024, 1.1391, 1.1853, 1.2441, 1.3202, 1.4218, 1.5639, 1.7779, 2.1462, 3.0,
];

/// The coordinate u = cos θc = √(1 − 1/η²) (η ≥ 1) in which the η nodes are uniform.
pub fn eta_coordinate(eta: f32) -> f32 {
    (1.0 - 1.0 / (eta * eta)).max(0.0).sqrt()
}
/// Roughness nodes of the measurement, uniform in √α on [0, 1] (node 0, a smooth surface, has
/// no deficit).
pub const DIEL_ALPHAS: usize = 13;
/// Roughness nodes, uniform in √α on [0, 1], of the normalised lobes of a textured roughness
/// (every second node of the albedo tables): the normalisation holds exactly at each, to second
/// order between them.
pub const TEXTURED_ALPHAS: usize = 17;
/// [`TEXTURED_ALPHAS`] for the height-correlated model (every node of the albedo tables): its
/// deficit at grazing incidence is mostly the walk's multiple transmission, which changes
/// faster with α, and 17 nodes left 0.4 % between them (GGX, η = 1.5, α = 0.6, μ = 0.03).
pub const TEXTURED_ALPHAS_CORRELATED: usize = 33;
/// μ bins of both sides: outside (0..LOBE_MU), then inside.
pub const NR: usize = 2 * LOBE_MU;
/// Cells of one row (μ bin of either side, Δφ bin).
const DROW: usize = NR * LOBE_PHI;
/// Cells of one node.
const DSLICE: usize = NR * DROW;
/// Measured nodes per distribution (η × roughness node 1..).
const MEASURED: usize = DIEL_ETAS.len() * (DIEL_ALPHAS - 1);

/// ln Γ(x) for x ≥ 1 (Stirling's series after shifting x above 7; ~1e-10).
pub(crate) fn ln_gamma(x: f64) -> f64 {
    // Γ(x) = Γ(x + k) / (x (x + 1) … (x + k − 1)): the shifts' product (at most 7⁶) and one
    // logarithm of it rather than one per shift (the height-correlated G2 of every
    // transmission evaluates three of these)
    let (mut x, mut shifts) = (x, 1.0f64);
    while x < 7.0 {
        shifts *= x;
        x += 1.0;
    }
    let (z, z2) = (x, x * x);
    -shifts.ln() + (z - 0.5) * z.ln() - z
        + 0.5 * (2.0 * std::f64::consts::PI).ln()
        + (1.0 / 12.0 - (1.0 / 360.0 - 1.0 / (1260.0 * z2)) / z2) / z
}

/// The weight of a walk that leaves after its first event (see the module): the part of the
/// walk's height-correlated single scattering that the separable model lacks (`correlated`:
/// the height-correlated model's, which lacks none of it).
fn single_deficit(
    walk: &crate::models::microsurface_walk::MicrosurfaceWalk,
    wi: Vec3,
    wo: Vec3,
    correlated: bool,
) -> f64 {
    if correlated {
        return 0.0;
    }
    let up = |w: Vec3| DVec3::new(w.x as f64, w.y as f64, (w.z as f64).abs()).normalize();
    let li = walk.lambda(up(wi));
    let lo = walk.lambda(up(wo));
    if wi.z * wo.z > 0.0 {
        li * lo / ((1.0 + li) * (1.0 + lo))
    } else {
        // escape downwards after a refraction: (1 + Λi) B(1 + Λi, 1 + Λo)
        let (a, b) = (1.0 + li, 1.0 + lo);
        let p = a * (ln_gamma(a) + ln_gamma(b) - ln_gamma(a + b)).exp();
        1.0 - 1.0 / (b * p)
    }
}

/// The symmetrised joints of the white dielectric's deficit lobes of a distribution (see the
/// module): per measured node (η node major, roughness node 1.. minor) [`NR`] × [`NR`] ×
/// [`LOBE_PHI`] values, from `walks` walks per (node, incident bin), fixed seeds; element 0
/// against the separable single-scattering model, element 1 against the height-correlated one
/// (the same walks). Also the relative asymmetry of the unsymmetrised estimate per node
/// (Σ|J − Jᵀ| / 2Σ|J|), a check of the walk's (generalised) reciprocity and of the estimate's
/// noise.
pub fn dielectric_joint_from_walk(kind: MicrofacetType, walks: usize) -> [(Vec<f64>, Vec<f64>); 2] {
    let nodes: Vec<(f32, f32)> = (0..MEASURED)
        .map(|node| {
            let eta = DIEL_ETAS[node / (DIEL_ALPHAS - 1)];
            (eta, alpha_node(node % (DIEL_ALPHAS - 1) + 1, DIEL_ALPHAS))
        })
        .collect();
    walk_joints(kind, &nodes, walks, 1)
}

/// The symmetrised joints (separable, height-correlated) of one (η, α) pair measured like
/// [`dielectric_joint_from_walk`]'s nodes (`walks` walks per incident bin, seeds from `seed`):
/// for probing the interpolation between the nodes.
pub fn dielectric_joint_at(
    kind: MicrofacetType,
    eta: f32,
    alpha: f32,
    walks: usize,
    seed: u64,
) -> [Vec<f64>; 2] {
    walk_joints(kind, &[(eta, alpha)], walks, seed).map(|(j, _)| j)
}

/// [`dielectric_joint_from_walk`] for any (η, α) nodes; the walks of row `r` of node `n` use
/// the seed `seed + n NR + r`.
fn walk_joints(
    kind: MicrofacetType,
    nodes: &[(f32, f32)],
    walks: usize,
    seed: u64,
) -> [(Vec<f64>, Vec<f64>); 2] {
    use crate::models::microsurface_walk::{MicrosurfaceWalk, WalkMaterial};
    let rows = parallel_rows(nodes.len() * NR, |n| {
        let (node, r) = (n / NR, n % NR);
        let (eta, alpha) = nodes[node];
        let walk = MicrosurfaceWalk::new(kind, alpha, alpha, WalkMaterial::Dielectric { eta });
        let mut rng = crate::rng::Pcg32::new(n as u64 + seed, 0x6469_656c);
        let (inside, i) = (r >= LOBE_MU, r % LOBE_MU);
        let (m0, m1) = mu_edges(i);
        let mut h = vec![0.0f64; 2 * DROW];
        for _ in 0..walks {
            let mu = (m0 * m0 + rng.next_f64() * (m1 * m1 - m0 * m0))
                .sqrt()
                .max(1e-4);
            let z = if inside { -mu } else { mu };
            let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt() as f32, 0.0, z as f32);
            let Some(s) = walk.sample(wi, &mut rng) else {
                continue;
            };
            if s.wo.z == 0.0 || !s.wo.is_finite() {
                continue;
            }
            let ro = mu_bin(s.wo.z.abs()) + if s.wo.z < 0.0 { LOBE_MU } else { 0 };
            let cell = ro * LOBE_PHI + dphi_bin(delta_phi(wi, s.wo));
            for (k, correlated) in [false, true].into_iter().enumerate() {
                h[k * DROW + cell] += if s.bounces == 1 {
                    single_deficit(&walk, wi, s.wo, correlated)
                } else {
                    1.0
                };
            }
        }
        let scale = bin_m(i) / walks as f64 * if inside { (eta * eta) as f64 } else { 1.0 };
        h.iter_mut().for_each(|v| *v *= scale);
        h
    });
    std::array::from_fn(|k| {
        let mut joint = vec![0.0f64; nodes.len() * DSLICE];
        for (n, h) in rows.iter().enumerate() {
            let (node, r) = (n / NR, n % NR);
            joint[node * DSLICE + r * DROW..][..DROW].copy_from_slice(&h[k * DROW..][..DROW]);
        }
        symmetrised(joint)
    })
}

/// The joint made symmetric (the mean of it and its transpose, per node), with the relative
/// asymmetry it had per node.
fn symmetrised(mut joint: Vec<f64>) -> (Vec<f64>, Vec<f64>) {
    let asym = joint
        .chunks_exact_mut(DSLICE)
        .map(|node| symmetrise(node, NR))
        .collect();
    (joint, asym)
}

/// The negative part N of the white dielectric's deficit lobe f_walk − f_ss for incidence
/// `wi`, in the bins of [`crate::models::microsurface_walk::compare`] (per unit incident
/// energy, `samples` walks): where the separable model's single scattering exceeds the walk's
/// (its refraction, see the module). Any non-negative compensation lobe C added to f_ss is at
/// least N from the walk in that comparison's total variation: ½Σ|C − D| ≥ N when ΣC = ΣD.
/// `correlated`: against the height-correlated single-scattering model, whose deficit has no
/// negative part (N = 0 up to the walk's agreement with it).
pub fn negative_deficit(
    walk: &crate::models::microsurface_walk::MicrosurfaceWalk,
    wi: Vec3,
    samples: usize,
    seed: u64,
    correlated: bool,
) -> f64 {
    use crate::models::microsurface_walk::{lobe_bin, LOBE_MU_BINS, LOBE_PHI_BINS};
    let mut h = vec![0.0f64; 2 * LOBE_MU_BINS * LOBE_PHI_BINS];
    let mut rng = crate::rng::Pcg32::new(seed, 23);
    for _ in 0..samples {
        let Some(s) = walk.sample(wi, &mut rng) else {
            continue;
        };
        let w = if s.bounces == 1 {
            single_deficit(walk, wi, s.wo, correlated)
        } else {
            1.0
        };
        h[lobe_bin(s.wo)] += w;
    }
    h.iter().map(|v| (-v).max(0.0)).sum::<f64>() / samples as f64
}

const MAGIC: &[u8; 8] = b"SPMSDIE6";
/// Values of a node's upper triangle.
const TRI: usize = NR * (NR + 1) / 2 * LOBE_PHI;

/// The data file for the joints of GGX and Beckmann against the height-correlated
/// single-scattering model (in that order): the magic, then per joint set and measured node
/// `encode_symmetric`'s record (rows, rows, Δφ).
pub fn encode_dielectric_tables(joints: [&[f64]; 2]) -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    for j in joints {
        for node in 0..MEASURED {
            encode_symmetric(&mut out, &j[node * DSLICE..][..DSLICE], NR);
        }
    }
    out
}

/// The joints of one distribution from [`encode_dielectric_tables`]'s bytes, each normalised
/// to unit total (`None`: no or a malformed file).
fn decode_dielectric_table(bytes: &[u8], kind: MicrofacetType) -> Option<Vec<f32>> {
    let per = MEASURED * (4 + 2 * TRI);
    if bytes.len() != MAGIC.len() + 2 * per || &bytes[..MAGIC.len()] != MAGIC {
        return None;
    }
    let k = kind_index(kind);
    let mut p = MAGIC.len() + k * per;
    let mut joint = vec![0.0f32; MEASURED * DSLICE];
    let mut node64 = vec![0.0f64; DSLICE];
    for node in 0..MEASURED {
        decode_symmetric(bytes, &mut p, &mut node64, NR)?;
        let mut total = 0.0f64;
        for r in 0..NR {
            for q in r..NR {
                for c in 0..LOBE_PHI {
                    let v = node64[r * DROW + q * LOBE_PHI + c];
                    total += if r == q { v } else { 2.0 * v };
                }
            }
        }
        let s = &mut joint[node * DSLICE..][..DSLICE];
        for (d, &v) in s.iter_mut().zip(&node64) {
            *d = v as f32;
        }
        if total > 0.0 {
            let inv = (1.0 / total) as f32;
            s.iter_mut().for_each(|v| *v *= inv);
        }
    }
    Some(joint)
}

/// The committed measurement (see the module; regenerate with `cargo test --release -p
/// specula-bsdf --test multiscatter generate_dielectric_lobe_table -- --ignored`).
const DIELECTRIC_DATA: &[u8] = include_bytes!("dielectric_lobe.bin");

/// Walks per (node, incident bin) of the committed data, per distribution (Beckmann's walk
/// costs ~10× GGX's: its visible-slope sampler inverts a CDF by bisection).
pub fn dielectric_walks(kind: MicrofacetType) -> usize {
    match kind {
        MicrofacetType::Ggx => 150_000,
        MicrofacetType::Beckmann => 50_000,
    }
}

/// Measured nodes per distribution in the data file.
pub const DIEL_MEASURED_NODES: usize = MEASURED;

/// The data file's record of measured node `node` (η node major, roughness node 1.. minor) of
/// a distribution, computed afresh: the same walks, seeds and encoding as
/// [`dielectric_joint_from_walk`] and [`encode_dielectric_tables`] with `walks` walks, for one
/// node (a test regenerates a few and compares them with the committed bytes).
pub fn dielectric_node_record(kind: MicrofacetType, node: usize, walks: usize) -> Vec<u8> {
    let eta = DIEL_ETAS[node / (DIEL_ALPHAS - 1)];
    let alpha = alpha_node(node % (DIEL_ALPHAS - 1) + 1, DIEL_ALPHAS);
    let [_, (joint, _)] = walk_joints(kind, &[(eta, alpha)], walks, 1 + (node * NR) as u64);
    let mut out = Vec::new();
    encode_symmetric(&mut out, &joint, NR);
    out
}

/// The committed record of measured node `node` of a distribution (`None` without data).
pub fn committed_dielectric_node_record(
    kind: MicrofacetType,
    node: usize,
) -> Option<&'static [u8]> {
    let per = MEASURED * (4 + 2 * TRI);
    if DIELECTRIC_DATA.len() != MAGIC.len() + 2 * per || node >= MEASURED {
        return None;
    }
    let k = kind_index(kind);
    let start = MAGIC.len() + k * per + node * (4 + 2 * TRI);
    DIELECTRIC_DATA.get(start..start + 4 + 2 * TRI)
}

/// The decoded joints of a distribution against the height-correlated single-scattering model
/// (`None` without data, and for the separable model, which no material compensates:
/// Kulla–Conty's lobes).
fn measured_joints(kind: MicrofacetType, correlated: bool) -> Option<&'static [f32]> {
    static CELLS: [OnceLock<Option<Vec<f32>>>; 2] = [const { OnceLock::new() }; 2];
    if !correlated {
        return None;
    }
    let k = kind_index(kind);
    CELLS[k]
        .get_or_init(|| decode_dielectric_table(DIELECTRIC_DATA, kind))
        .as_deref()
}

/// Whether the committed data decodes (false: the lobes are Kulla–Conty's).
pub fn dielectric_data_present() -> bool {
    [MicrofacetType::Ggx, MicrofacetType::Beckmann]
        .into_iter()
        .all(|k| measured_joints(k, true).is_some())
}

/// The interpolated, unit-total joint at (η, α) of a joint set `j` (η < 1: the nodes of 1/η
/// with the sides exchanged), added into `out` (`DSLICE` values).
fn interpolated_joint(j: &[f32], eta: f32, alpha: f32, out: &mut [f64]) {
    let swap = eta < 1.0;
    let e = if swap { 1.0 / eta } else { eta };
    let le = eta_coordinate(e.clamp(DIEL_ETAS[0], DIEL_ETAS[DIEL_ETAS.len() - 1]));
    let k = (0..DIEL_ETAS.len() - 1)
        .find(|&k| le <= eta_coordinate(DIEL_ETAS[k + 1]))
        .unwrap_or(DIEL_ETAS.len() - 2);
    let (l0, l1) = (
        eta_coordinate(DIEL_ETAS[k]),
        eta_coordinate(DIEL_ETAS[k + 1]),
    );
    let we = ((le - l0) / (l1 - l0)).clamp(0.0, 1.0);
    let x = alpha.clamp(0.0, 1.0).sqrt() * (DIEL_ALPHAS - 1) as f32;
    let a = (x as usize).min(DIEL_ALPHAS - 2);
    let wa = x - a as f32;
    let row = |r: usize| if swap { (r + LOBE_MU) % NR } else { r };
    for (ek, wek) in [(k, 1.0 - we), (k + 1, we)] {
        for (ak, wak) in [(a, 1.0 - wa), (a + 1, wa)] {
            let w = (wek * wak) as f64;
            if w <= 0.0 || ak == 0 {
                // node 0 (a smooth surface) has no deficit: the shape is its neighbour's
                continue;
            }
            let node = ek * (DIEL_ALPHAS - 1) + ak - 1;
            let s = &j[node * DSLICE..][..DSLICE];
            for r in 0..NR {
                for q in 0..NR {
                    let src = &s[row(r) * DROW + row(q) * LOBE_PHI..][..LOBE_PHI];
                    let dst = &mut out[r * DROW + q * LOBE_PHI..][..LOBE_PHI];
                    for (d, v) in dst.iter_mut().zip(src) {
                        *d += w * *v as f64;
                    }
                }
            }
        }
    }
}

/// Applies the inverse bin-integral matrices to a joint of bin integrals (`Axis::histopolation`):
/// `w_inv` per side to both μ indices (its rows and its columns, so a symmetric joint stays
/// symmetric), `u_inv` to Δφ.
fn histopolate(joint: &mut [f64], w_inv: &[[[f64; 16]; 16]; 2], u_inv: &[[f64; 16]; 16]) {
    const { assert!(LOBE_MU == 16 && LOBE_PHI == 16) };
    // x ← m x for the 16 values joint[base + j stride]
    let apply = |m: &[[f64; 16]; 16], base: usize, stride: usize, joint: &mut [f64]| {
        let x: [f64; 16] = std::array::from_fn(|j| joint[base + j * stride]);
        for (k, row) in m.iter().enumerate() {
            joint[base + k * stride] = row.iter().zip(&x).map(|(v, x)| v * x).sum();
        }
    };
    // every row index first, then every column index
    for (side, m) in w_inv.iter().enumerate() {
        for col in 0..DROW {
            apply(m, side * LOBE_MU * DROW + col, DROW, joint);
        }
    }
    for (side, m) in w_inv.iter().enumerate() {
        for r in 0..NR {
            for c in 0..LOBE_PHI {
                apply(m, r * DROW + side * LOBE_MU * LOBE_PHI + c, LOBE_PHI, joint);
            }
        }
    }
    for rs in 0..NR * NR {
        apply(u_inv, rs * LOBE_PHI, 1, joint);
    }
}

/// Symmetric scaling of a symmetric non-negative matrix `k` (NR × NR, the Δφ cells summed,
/// [`cell_sums`]) to row sums `target`: the d with d_r Σ_s k_rs d_s = target_r (rows with a
/// zero target get d = 0).
fn sym_scaling(k: &[f64], target: &[f64]) -> Vec<f64> {
    damped_scaling(target, 5000, 1e-10, |r, d| {
        (0..NR).map(|s| k[r * NR + s] * d[s]).sum()
    })
}

/// Scaling of a symmetric non-negative matrix `k` (NR × NR, the Δφ cells summed) by one factor
/// per row node and side: entry (r, s) is multiplied by f[2r + side(s)] f[2s + side(r)] (side 0
/// outside, 1 inside), so the matrix stays symmetric, until row r's part on side b sums to
/// `target[2r + b]` (Sinkhorn's iteration per block: the diagonal blocks are scaled
/// symmetrically, the crossing block by its rows and columns, whose targets have the same
/// total when they come from a symmetric matrix). Parts with a zero target get factor 0.
fn block_scaling(k: &[f64], target: &[f64]) -> Vec<f64> {
    damped_scaling(target, 2000, 1e-9, |rb, f| {
        let (r, b) = (rb / 2, rb % 2);
        (b * LOBE_MU..(b + 1) * LOBE_MU)
            .map(|s| k[r * NR + s] * f[2 * s + r / LOBE_MU])
            .sum()
    })
}

/// Per (row node, column node): the sum of a joint's Δφ cells (NR × NR values).
fn cell_sums(joint: &[f64]) -> Vec<f64> {
    (0..NR * NR)
        .map(|rs| {
            let (r, s) = (rs / NR, rs % NR);
            joint[r * DROW + s * LOBE_PHI..][..LOBE_PHI].iter().sum()
        })
        .collect()
}

/// The inverse of a 16 × 16 matrix, a column per unit vector by [`crate::math::solve`]; a row
/// that is (relatively) zero, with its column, is left out: that unknown gets 0 and that bin's
/// value is ignored (a zero matrix if the rest is singular).
fn invert16(mut a: [[f64; 16]; 16]) -> [[f64; 16]; 16] {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let live: Vec<bool> = a
        .iter()
        .map(|row| row.iter().any(|v| v.abs() > 1e-13 * scale))
        .collect();
    for k in (0..16).filter(|&k| !live[k]) {
        // the unknown k is 0: an identity row, and a zero column elsewhere
        for (r, row) in a.iter_mut().enumerate() {
            row[k] = if r == k { 1.0 } else { 0.0 };
        }
        a[k] = [0.0; 16];
        a[k][k] = 1.0;
    }
    let mut inv = [[0.0f64; 16]; 16];
    for k in (0..16).filter(|&k| live[k]) {
        let mut unit = [0.0f64; 16];
        unit[k] = 1.0;
        let Some(col) = crate::math::solve(a, unit) else {
            return [[0.0; 16]; 16];
        };
        for (row, v) in inv.iter_mut().zip(col) {
            row[k] = v;
        }
    }
    inv
}

/// The exponent of the μ bins: edge k (k = 0 … [`LOBE_MU`]) lies at the elevation
/// ψ_k = (π/2)(k / [`LOBE_MU`])^[`MU_POWER`] above the horizon (μ = sin ψ), so the bins narrow
/// towards grazing (from 8.3° at the normal to 1.4° at the horizon), where the multiple
/// scattering of a grazing incidence peaks close to the horizon and moves with the
/// incidence: with 16 bins uniform in θ, a rough interface of η = 1.16 seen from inside at 85°
/// spread its lobe over μo (0.106 of the energy at μo 0.083–0.167 where the walk has 0.142).
pub const MU_POWER: f64 = 1.5;

/// The μ range of bin `b` (bin 0 is the grazing one).
pub fn mu_edges(b: usize) -> (f64, f64) {
    let edge = |k: usize| {
        if k >= LOBE_MU {
            1.0
        } else {
            (std::f64::consts::FRAC_PI_2 * (k as f64 / LOBE_MU as f64).powf(MU_POWER)).sin()
        }
    };
    (edge(b), edge(b + 1))
}

/// The μ bin of a cosine.
#[inline]
pub fn mu_bin(mu: f32) -> usize {
    let psi = mu.clamp(0.0, 1.0).asin() * (2.0 * FRAC_1_PI);
    ((LOBE_MU as f32 * psi.powf((1.0 / MU_POWER) as f32)) as usize).min(LOBE_MU - 1)
}

/// ∫ μ dμ over bin `b`.
pub fn bin_m(b: usize) -> f64 {
    let (a, c) = mu_edges(b);
    0.5 * (c * c - a * a)
}

/// The exponent of the Δφ bins: edge k (k = 0 … [`LOBE_PHI`]) lies at π − π (1 − k /
/// [`LOBE_PHI`])^[`PHI_POWER`], so the bins narrow towards Δφ = π, where the reflected and the
/// transmitted multiple scattering of a grazing incidence peak (from 16.6° at Δφ = 0 to 2.8°
/// at π). With 16 uniform bins the peak of a Beckmann α = 0.1 interface seen from inside at 85°
/// was narrower than its bin (`dielectric_bin_probe`: the best piecewise-constant lobe 0.020
/// from the walk; 0.004 with 32 uniform bins).
pub const PHI_POWER: f64 = 1.5;

/// Edge `k` of the Δφ bins (0 … [`LOBE_PHI`], ascending from 0 to π).
pub fn phi_edge(k: usize) -> f64 {
    let d = 1.0 - k as f64 / LOBE_PHI as f64;
    std::f64::consts::PI * (1.0 - d.max(0.0).powf(PHI_POWER))
}

/// The Δφ bin of `dphi` ∈ [0, π].
#[inline]
pub fn dphi_bin(dphi: f32) -> usize {
    let d = ((PI - dphi) * FRAC_1_PI).clamp(0.0, 1.0);
    let k = (LOBE_PHI as f32 * (1.0 - d.powf((1.0 / PHI_POWER) as f32))) as usize;
    k.min(LOBE_PHI - 1)
}

/// One axis of the interpolation of the lobes between the centres of their bins: hat
/// functions (piecewise linear, a partition of unity) with nodes at the bins' centres,
/// constant beyond the outer nodes. The μ axis is x = μ² on each side (x is uniform under the
/// projected solid angle, μ dμ = dx / 2), the Δφ axis Δφ ∈ [0, π] itself.
#[derive(Debug, Clone)]
struct Axis {
    /// The domain's ends.
    lo: f32,
    hi: f32,
    /// Node positions, ascending.
    nodes: [f32; 16],
}

impl Axis {
    /// The μ axis: nodes at the centres in x = μ² of the μ bins (bin 0, the grazing one, first).
    fn mu() -> Self {
        const { assert!(LOBE_MU == 16) };
        Axis {
            lo: 0.0,
            hi: 1.0,
            nodes: std::array::from_fn(|b| {
                let (lo, hi) = mu_edges(b);
                (0.5 * (lo * lo + hi * hi)) as f32
            }),
        }
    }

    /// The Δφ axis: nodes at the centres of the Δφ bins ([`phi_edge`]).
    fn phi() -> Self {
        const { assert!(LOBE_PHI == 16) };
        Axis {
            lo: 0.0,
            hi: PI,
            nodes: std::array::from_fn(|c| (0.5 * (phi_edge(c) + phi_edge(c + 1))) as f32),
        }
    }

    /// The two nodes around `v`, (k, t): weight 1 − t at node k, t at node k + 1.
    #[inline]
    fn at(&self, v: f32) -> (usize, f32) {
        let n = &self.nodes;
        let last = n.len() - 1;
        if v <= n[0] {
            return (0, 0.0);
        }
        if v >= n[last] {
            return (last - 1, 1.0);
        }
        let k = (n.partition_point(|&e| e <= v) - 1).min(last - 1);
        (k, ((v - n[k]) / (n[k + 1] - n[k])).clamp(0.0, 1.0))
    }

    /// The two pieces of hat `b`: (start, end, value at start, value at end).
    #[inline]
    fn pieces(&self, b: usize) -> [(f32, f32, f32, f32); 2] {
        let n = &self.nodes;
        let left = if b == 0 {
            (self.lo, n[0], 1.0, 1.0)
        } else {
            (n[b - 1], n[b], 0.0, 1.0)
        };
        let right = if b == n.len() - 1 {
            (n[b], self.hi, 1.0, 1.0)
        } else {
            (n[b], n[b + 1], 1.0, 0.0)
        };
        [left, right]
    }

    /// ∫ h_b(v) g(v) dv by Gauss–Legendre over each piece (nodes `gx`, weights `gw` on
    /// [−1, 1]).
    fn integrate(&self, b: usize, gx: &[f64], gw: &[f64], g: impl Fn(f64) -> f64) -> f64 {
        self.integrate_over(b, f64::NEG_INFINITY, f64::INFINITY, gx, gw, g)
    }

    /// ∫ h_b(v) g(v) dv over [a, c] ∩ the domain, by Gauss–Legendre over each piece's part.
    fn integrate_over(
        &self,
        b: usize,
        a: f64,
        c: f64,
        gx: &[f64],
        gw: &[f64],
        g: impl Fn(f64) -> f64,
    ) -> f64 {
        let mut sum = 0.0;
        for (v0, v1, h0, h1) in self.pieces(b) {
            let (v0, v1, h0, h1) = (v0 as f64, v1 as f64, h0 as f64, h1 as f64);
            let (p0, p1) = (v0.max(a), v1.min(c));
            if p1 <= p0 {
                continue;
            }
            let hat = |v: f64| h0 + (h1 - h0) * (v - v0) / (v1 - v0);
            for (p, w) in gx.iter().zip(gw) {
                let v = p0 + (p1 - p0) * 0.5 * (p + 1.0);
                sum += hat(v) * g(v) * w * 0.5 * (p1 - p0);
            }
        }
        sum
    }

    /// The inverse of the matrix T_rb = ∫ over bin r of h_b(v) g(v) dv (`edges`: the 17 bin
    /// edges on this axis), which maps the nodal values of Σ_b v_b h_b to the bins' integrals
    /// of (Σ_b v_b h_b) g: applied to measured bin integrals it gives the nodal values whose
    /// interpolant has those integrals (histopolation), where taking each bin's mean as its
    /// node's value would smooth a peak narrower than a few bins. A bin where g vanishes
    /// (its row 0) gets the value 0.
    fn histopolation(
        &self,
        edges: &[f64; 17],
        gx: &[f64],
        gw: &[f64],
        g: impl Fn(f64) -> f64,
    ) -> [[f64; 16]; 16] {
        let mut t = [[0.0f64; 16]; 16];
        for (r, row) in t.iter_mut().enumerate() {
            for (b, v) in row.iter_mut().enumerate() {
                *v = self.integrate_over(b, edges[r], edges[r + 1], gx, gw, &g);
            }
        }
        invert16(t)
    }

    /// ∫ h_b(v) dv.
    fn mass(&self, b: usize) -> f64 {
        self.pieces(b)
            .iter()
            .map(|&(v0, v1, h0, h1)| 0.5 * (v1 - v0) as f64 * (h0 + h1) as f64)
            .sum()
    }

    /// v distributed ∝ h_b(v) from `u`.
    #[inline]
    fn sample(&self, b: usize, u: f32) -> f32 {
        let [l, r] = self.pieces(b);
        let area = |p: (f32, f32, f32, f32)| (p.1 - p.0) * (p.2 + p.3);
        let (al, ar) = (area(l), area(r));
        let pl = al / (al + ar);
        let (p, w) = if u < pl {
            (l, u / pl)
        } else {
            (r, ((u - pl) / (1.0 - pl)).min(1.0))
        };
        let (v0, v1, h0, h1) = p;
        let v = if h0 == h1 {
            v0 + w * (v1 - v0)
        } else if h1 > h0 {
            // rising from 0: density ∝ v − v0
            v0 + (v1 - v0) * w.sqrt()
        } else {
            v1 - (v1 - v0) * (1.0 - w).max(0.0).sqrt()
        };
        v.clamp(self.lo, self.hi)
    }
}

/// The two axes of the interpolation.
#[derive(Debug, Clone)]
struct Hats {
    mu: Axis,
    phi: Axis,
}

impl Hats {
    fn new() -> Self {
        Hats {
            mu: Axis::mu(),
            phi: Axis::phi(),
        }
    }
}

/// Δφ ∈ [0, π] between the azimuths of `wi` and `wo` (0 when `wo` has none).
#[inline]
fn delta_phi(wi: Vec3, wo: Vec3) -> f32 {
    let li2 = wi.x * wi.x + wi.y * wi.y;
    let lo2 = wo.x * wo.x + wo.y * wo.y;
    if lo2 <= 1e-20 {
        return 0.0;
    }
    // an incidence without azimuth has the sampler's (1, 0) ([`azimuth`])
    let (cross, dot) = if li2 <= 1e-20 {
        (wo.y, wo.x)
    } else {
        (wi.x * wo.y - wi.y * wo.x, wi.x * wo.x + wi.y * wo.y)
    };
    cross.abs().atan2(dot)
}

/// The measured (or, without data, Kulla–Conty's) compensation lobes of one material (one η,
/// one distribution), normalised against its energy tables (see the module).
#[derive(Debug, Clone)]
pub struct DielectricLobe {
    eta2: f32,
    /// Roughness of each node: one for a constant roughness, else the [`TEXTURED_ALPHAS`]
    /// nodes uniform in √α.
    nodes: usize,
    /// M per (roughness node, row node, row node, Δφ node).
    m: Vec<f32>,
    /// Z = Σ M m_s A_c per (roughness node, row node), m_s = ∫ h_s(μ²) μ dμ.
    z: Vec<f32>,
    /// Per (roughness node, row node): the cumulative distribution of the (row, Δφ) nodes
    /// ∝ M m_s A_c.
    cdf: Vec<f32>,
    /// Per (roughness node, outside μ node): the fraction of that row's compensation energy
    /// that is reflected (the coat, `roughplastic`, lets the rest into its base).
    share: Vec<f32>,
    /// The hemispherically averaged energy the compensation carries across, x (as
    /// [`DielectricEnergy`] defines it), per node.
    pub x: Vec<f32>,
    /// Whether the shapes came from the measurement (false: Kulla–Conty's).
    pub measured: bool,
    hats: Hats,
}

impl DielectricLobe {
    /// A placeholder (no nodes) until [`Self::build`] runs.
    pub(super) fn empty() -> Self {
        DielectricLobe {
            eta2: 1.0,
            nodes: 0,
            m: Vec::new(),
            z: Vec::new(),
            cdf: Vec::new(),
            share: Vec::new(),
            x: Vec::new(),
            measured: false,
            hats: Hats::new(),
        }
    }

    /// The lobes of `e` (its tables must be complete; its own `lobe` is not read) at `alphas`
    /// (one roughness, or the [`TEXTURED_ALPHAS`] nodes).
    pub(super) fn build(kind: MicrofacetType, e: &DielectricEnergy, alphas: &[f32]) -> Self {
        let data = measured_joints(kind, e.correlated);
        let eta = e.eta;
        let eta2 = (eta * eta) as f64;
        let nodes = alphas.len();
        let hats = Hats::new();
        // ∫ h_s(μ²) μ dμ per μ node, and the azimuth measure of each Δφ node's hat, both signs
        let mass: Vec<f64> = (0..LOBE_MU).map(|b| 0.5 * hats.mu.mass(b)).collect();
        let a_c: Vec<f64> = (0..LOBE_PHI).map(|c| 2.0 * hats.phi.mass(c)).collect();
        // the measured joint's cells are integrals over bins, and the lobe's value at a node
        // is its bin's mean: in the hats' weights each cell is multiplied by A_c / Ā_c
        // (Ā_c = 2 × the bin's width); the μ weights differ from the bins' by a factor per row,
        // which the symmetric scaling below finds itself
        let (gx, gw) = gauss_legendre(12);
        let x_edges: [f64; 17] = std::array::from_fn(|k| match k {
            LOBE_MU => 1.0,
            _ => mu_edges(k).0.powi(2),
        });
        let phi_edges: [f64; 17] = std::array::from_fn(phi_edge);
        let u_inv = hats.phi.histopolation(&phi_edges, &gx, &gw, |_| 2.0);
        let mut m = vec![0.0f32; nodes * DSLICE];
        let mut z = vec![0.0f32; nodes * NR];
        let mut cdf = vec![0.0f32; nodes * DSLICE];
        let mut share = vec![1.0f32; nodes * LOBE_MU];
        let mut xs = vec![0.0f32; nodes];
        let mut joint = vec![0.0f64; DSLICE];
        for (n, &alpha) in alphas.iter().enumerate() {
            let q = e.at_kc(alpha);
            // ν_r = ∫ h_r(μ²) c(μ) μ dμ per row node (in x = μ²: ½ ∫ h_r(x) c(√x) dx), both
            // sides
            let c_of = |r: usize, mu: f64| (1.0 - e.e(&q, r < LOBE_MU, mu as f32) as f64).max(0.0);
            let nu: Vec<f64> = (0..NR)
                .map(|r| {
                    0.5 * hats
                        .mu
                        .integrate(r % LOBE_MU, &gx, &gw, |x| c_of(r, x.sqrt()))
                })
                .collect();
            let target: Vec<f64> = (0..NR)
                .map(|r| nu[r] * if r < LOBE_MU { 1.0 } else { eta2 })
                .collect();
            let total: f64 = target.iter().sum();
            let (miss_o, miss_i) = (1.0 - q.e_out_avg as f64, 1.0 - q.e_in_avg as f64);
            if total <= 1e-9 || miss_o <= 1e-6 || miss_i <= 1e-6 {
                continue;
            }
            // Kulla–Conty's lobes in joint form (their rows hold the targets exactly)
            let x = q.x as f64;
            let kc = |r: usize, s: usize| {
                FRAC_1_PI as f64
                    * match (r < LOBE_MU, s < LOBE_MU) {
                        (true, true) => (miss_o - x) / (miss_o * miss_o),
                        (false, false) => (eta2 * miss_i - x) / (miss_i * miss_i),
                        _ => x / (miss_o * miss_i),
                    }
                    .max(0.0)
            };
            joint.iter_mut().for_each(|v| *v = 0.0);
            if let Some(j) = data {
                interpolated_joint(j, eta, alpha, &mut joint);
            }
            // nodal values V whose interpolant has the measured cells as its bins' integrals
            // (J = W_μ V W_μᵀ per Δφ, times U along Δφ, W weighted by c of each side), then
            // in the weights of the hats: J ← V ν_r ν_s A_c
            let w_inv = [
                hats.mu
                    .histopolation(&x_edges, &gx, &gw, |x| 0.5 * c_of(0, x.sqrt())),
                hats.mu
                    .histopolation(&x_edges, &gx, &gw, |x| 0.5 * c_of(LOBE_MU, x.sqrt())),
            ];
            histopolate(&mut joint, &w_inv, &u_inv);
            for r in 0..NR {
                for s in 0..NR {
                    let cells = &mut joint[r * DROW + s * LOBE_PHI..][..LOBE_PHI];
                    for (cell, a) in cells.iter_mut().zip(&a_c) {
                        *cell *= nu[r] * nu[s] * a;
                    }
                }
            }
            // at the normal Δφ is undefined and the lobe does not depend on it: the μ node
            // nearest the normal (constant up to μ = 1) gets the Δφ mean of its bin, whose
            // incidences reach 8.3° and bring an azimuthal bias with them (in both places it
            // occurs, so M stays symmetric)
            let a_total: f64 = a_c.iter().sum();
            for r in 0..NR {
                for t in 0..NR {
                    if r % LOBE_MU == LOBE_MU - 1 || t % LOBE_MU == LOBE_MU - 1 {
                        let cells = &mut joint[r * DROW + t * LOBE_PHI..][..LOBE_PHI];
                        let sum: f64 = cells.iter().sum();
                        for (cell, a) in cells.iter_mut().zip(&a_c) {
                            *cell = sum * a / a_total;
                        }
                    }
                }
            }
            // the solve undershoots next to a peak: negative values become 0, and each row's
            // part on either side is scaled back to what it held before (one factor per row
            // node and side, applied to both indices, so M stays symmetric). Clamping alone
            // added the negative mass back to the small blocks: it raised the reflected share
            // of grazing incidences on rough low-index interfaces by a quarter (GGX α = 1,
            // η = 1.19, 85°: 0.0157 of the deficit against the walk's 0.0115)
            let held: Vec<f64> = (0..2 * NR)
                .map(|rb| {
                    let (r, side) = (rb / 2, rb % 2);
                    joint[r * DROW + side * LOBE_MU * LOBE_PHI..][..LOBE_MU * LOBE_PHI]
                        .iter()
                        .sum::<f64>()
                        .max(0.0)
                })
                .collect();
            joint.iter_mut().for_each(|v| *v = v.max(0.0));
            let f = block_scaling(&cell_sums(&joint), &held);
            for r in 0..NR {
                for t in 0..NR {
                    let k = f[2 * r + t / LOBE_MU] * f[2 * t + r / LOBE_MU];
                    for cell in &mut joint[r * DROW + t * LOBE_PHI..][..LOBE_PHI] {
                        *cell *= k;
                    }
                }
            }
            let jt: f64 = joint.iter().sum();
            let g = if jt > 0.0 {
                (1.0 - KC_BLEND) * total / jt
            } else {
                0.0
            };
            let wkc = if jt > 0.0 { KC_BLEND } else { 1.0 };
            for r in 0..NR {
                for s in 0..NR {
                    let v = wkc * kc(r, s) * nu[r] * nu[s];
                    let cells = &mut joint[r * DROW + s * LOBE_PHI..][..LOBE_PHI];
                    for (cell, a) in cells.iter_mut().zip(&a_c) {
                        *cell = g * *cell + v * a;
                    }
                }
            }
            // symmetric scaling to the deficits of the row nodes
            let d = sym_scaling(&cell_sums(&joint), &target);
            for r in 0..NR {
                for s in 0..NR {
                    for cell in &mut joint[r * DROW + s * LOBE_PHI..][..LOBE_PHI] {
                        *cell *= d[r] * d[s];
                    }
                }
            }
            // the measured crossing energy, hemispherically averaged (from outside): 2 ∫ c(μ)
            // μ T(μ) dμ with T the interpolated rows' crossing part, i.e. 2 Σ_r ν_r T_r
            let xm: f64 = 2.0
                * (0..LOBE_MU)
                    .map(|r| {
                        joint[r * DROW + LOBE_MU * LOBE_PHI..][..LOBE_MU * LOBE_PHI]
                            .iter()
                            .sum::<f64>()
                    })
                    .sum::<f64>();
            xs[n] = xm as f32;
            let base = n * DSLICE;
            for r in 0..NR {
                let mut acc = 0.0f64;
                for s in 0..NR {
                    for (c, &ac) in a_c.iter().enumerate() {
                        let den = nu[r] * nu[s] * ac;
                        let k = r * DROW + s * LOBE_PHI + c;
                        let v = if den > 1e-30 { joint[k] / den } else { 0.0 };
                        m[base + k] = v as f32;
                        acc += v * mass[s % LOBE_MU] * ac;
                        cdf[base + k] = acc as f32;
                    }
                }
                z[n * NR + r] = acc as f32;
                let row = &mut cdf[base + r * DROW..][..DROW];
                if acc > 0.0 {
                    row.iter_mut().for_each(|v| *v = (*v as f64 / acc) as f32);
                }
                row[DROW - 1] = 1.0;
            }
            // the reflected part of each outside row node (its total is the row's target)
            for r in 0..LOBE_MU {
                let refl: f64 = joint[r * DROW..][..LOBE_MU * LOBE_PHI].iter().sum();
                let all: f64 = joint[r * DROW..][..DROW].iter().sum();
                if all > 0.0 {
                    share[n * LOBE_MU + r] = (refl / all).clamp(0.0, 1.0) as f32;
                }
            }
        }
        DielectricLobe {
            eta2: eta2 as f32,
            nodes,
            m,
            z,
            cdf,
            share,
            x: xs,
            measured: data.is_some(),
            hats,
        }
    }

    /// Node and weight at roughness `alpha`.
    #[inline]
    fn node(&self, alpha: f32) -> (usize, f32) {
        if self.nodes == 1 {
            return (0, 0.0);
        }
        let x = alpha.clamp(0.0, 1.0).sqrt() * (self.nodes - 1) as f32;
        let i = (x as usize).min(self.nodes - 2);
        (i, x - i as f32)
    }

    /// x at roughness `alpha`.
    #[inline]
    pub fn x_at(&self, alpha: f32) -> f32 {
        let (a, w) = self.node(alpha);
        if w == 0.0 {
            self.x[a]
        } else {
            self.x[a] + (self.x[a + 1] - self.x[a]) * w
        }
    }

    /// The (roughness node, weight) pairs at `alpha` that count (one or two).
    #[inline]
    fn roughness_nodes(&self, alpha: f32) -> [(usize, f32); 2] {
        let (a, w) = self.node(alpha);
        if w > 0.0 {
            [(a, 1.0 - w), (a + 1, w)]
        } else {
            [(a, 1.0), (a, 0.0)]
        }
    }

    /// The two row nodes of a direction (inside rows after the outside ones) and the weight of
    /// the second.
    #[inline]
    fn rows(&self, w: Vec3) -> (usize, f32) {
        let (k, t) = self.hats.mu.at(w.z * w.z);
        (k + if w.z < 0.0 { LOBE_MU } else { 0 }, t)
    }

    /// (M × the side factor (1/η² from inside), density of [`Self::sample`] at wo over solid
    /// angle).
    #[inline]
    pub fn eval(&self, alpha: f32, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let (ri, ti) = self.rows(wi);
        let (ro, to) = self.rows(wo);
        let (pc, tp) = self.hats.phi.at(delta_phi(wi, wo));
        let (mut s, mut z) = (0.0f32, 0.0f32);
        for (a, wa) in self.roughness_nodes(alpha) {
            if wa <= 0.0 {
                continue;
            }
            for (r, wr) in [(ri, 1.0 - ti), (ri + 1, ti)] {
                if wr <= 0.0 {
                    continue;
                }
                let w = wa * wr;
                z += w * self.z[a * NR + r];
                let row = &self.m[a * DSLICE + r * DROW..][..DROW];
                for (q, wq) in [(ro, 1.0 - to), (ro + 1, to)] {
                    let cell = &row[q * LOBE_PHI + pc..][..2];
                    s += w * wq * (cell[0] + (cell[1] - cell[0]) * tp);
                }
            }
        }
        let side = if wi.z < 0.0 { 1.0 / self.eta2 } else { 1.0 };
        if z <= 0.0 {
            // no lobe for this row: the sampler falls back to the cosine on wi's side
            let pdf = if wi.z * wo.z > 0.0 {
                wo.z.abs() * FRAC_1_PI
            } else {
                0.0
            };
            return (0.0, pdf);
        }
        (s * side, s * wo.z.abs() / z)
    }

    /// Of the compensation energy for an incidence from outside at cosine `mu`, the fraction
    /// reflected (interpolated between the row nodes like the lobes, whose outside rows all
    /// hold the same total: the ratio of the reflected part of the interpolated row to its
    /// total; the rest is transmitted).
    #[inline]
    pub fn reflected_share(&self, alpha: f32, mu: f32) -> f32 {
        if self.nodes == 0 {
            return 1.0;
        }
        let (k, t) = self.hats.mu.at(mu * mu);
        let mut s = 0.0;
        for (a, wa) in self.roughness_nodes(alpha) {
            let sh = &self.share[a * LOBE_MU..][..LOBE_MU];
            s += wa * (sh[k] + (sh[k + 1] - sh[k]) * t);
        }
        s
    }

    /// A direction distributed with the density [`Self::eval`] reports, from `u` (the
    /// roughness and row nodes) and `u2`: a (roughness node, row node) pair ∝ its weights
    /// × Z, a (row node, Δφ node) of that row ∝ M m_s A_c, then μ ∝ h_s(μ²) μ and Δφ ∝ its
    /// hat, either sign.
    #[inline]
    pub fn sample(&self, alpha: f32, wi: Vec3, u: f32, u2: Vec2) -> Vec3 {
        let (ri, ti) = self.rows(wi);
        let [(a0, wa0), (a1, wa1)] = self.roughness_nodes(alpha);
        let pairs = [
            (a0, ri, wa0 * (1.0 - ti)),
            (a0, ri + 1, wa0 * ti),
            (a1, ri, wa1 * (1.0 - ti)),
            (a1, ri + 1, wa1 * ti),
        ]
        .map(|(a, r, w)| (a, r, if w > 0.0 { w * self.z[a * NR + r] } else { 0.0 }));
        let total: f32 = pairs.iter().map(|p| p.2).sum();
        if total <= 0.0 {
            let up = crate::warp::square_to_cosine_hemisphere(u2);
            return if wi.z < 0.0 { -up } else { up };
        }
        let mut pick = u * total;
        let mut chosen = pairs[0];
        for p in pairs {
            if p.2 <= 0.0 {
                continue;
            }
            chosen = p;
            if pick < p.2 {
                break;
            }
            pick -= p.2;
        }
        let (node, r, _) = chosen;
        let cdf = &self.cdf[node * DSLICE + r * DROW..][..DROW];
        let ux = u2.x.min(1.0 - f32::EPSILON);
        let k = cdf.partition_point(|&c| c <= ux).min(DROW - 1);
        let lo = if k == 0 { 0.0 } else { cdf[k - 1] };
        let frac = ((ux - lo) / (cdf[k] - lo).max(1e-30)).clamp(0.0, 1.0);
        let (s, c) = (k / LOBE_PHI, k % LOBE_PHI);
        let mu = self.hats.mu.sample(s % LOBE_MU, frac).sqrt();
        let v = 2.0 * u2.y;
        let (sign, f) = if v < 1.0 { (1.0, v) } else { (-1.0, v - 1.0) };
        let dphi = sign * self.hats.phi.sample(c, f);
        let (ci, si) = azimuth(wi);
        let (sd, cd) = dphi.sin_cos();
        let rr = (1.0 - mu * mu).max(0.0).sqrt();
        let zo = if s < LOBE_MU { mu } else { -mu };
        Vec3::new(rr * (ci * cd - si * sd), rr * (si * cd + ci * sd), zo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fresnel::FresnelMode;

    /// The breakpoints of the lobes' interpolation on an axis: the domain's ends and the
    /// nodes (between two of them the lobe is linear in x = μ² and in Δφ).
    fn breaks(axis: &Axis) -> Vec<f64> {
        let mut v = vec![axis.lo as f64];
        v.extend(axis.nodes.iter().map(|&n| n as f64));
        v.push(axis.hi as f64);
        v
    }

    /// ∫ f_ms(ωi, ωo) |μo| dωo over both sides as the model evaluates it (f |μo| dωo = f dx
    /// dΔφ over x = μo² ∈ [0, 1] and Δφ ∈ [0, π], both signs), by Gauss–Legendre between the
    /// interpolation's breakpoints (16 nodes in x, where c(μo) varies; 2 in Δφ, where the lobe
    /// is linear), split into (reflected, transmitted); and c(μi) = 1 − E(μi).
    fn row_integral(e: &DielectricEnergy, alpha: f32, wi: Vec3) -> (f64, f64, f64) {
        let q = e.at(alpha);
        let hats = Hats::new();
        let (gx, gw) = gauss_legendre(16);
        let (px, pw) = gauss_legendre(2);
        let (xb, pb) = (breaks(&hats.mu), breaks(&hats.phi));
        let (mut r, mut t) = (0.0f64, 0.0f64);
        for side in [1.0f32, -1.0] {
            for xs in xb.windows(2) {
                for (x, w) in gx.iter().zip(&gw) {
                    let xo = xs[0] + (xs[1] - xs[0]) * 0.5 * (x + 1.0);
                    let wx = w * 0.5 * (xs[1] - xs[0]);
                    let mu = xo.sqrt();
                    for ps in pb.windows(2) {
                        for (y, v) in px.iter().zip(&pw) {
                            let phi = (ps[0] + (ps[1] - ps[0]) * 0.5 * (y + 1.0)) as f32;
                            let wp = v * 0.5 * (ps[1] - ps[0]);
                            let s = (1.0 - mu * mu).max(0.0).sqrt() as f32;
                            let wo = Vec3::new(s * phi.cos(), s * phi.sin(), side * mu as f32);
                            let (f, _) = e.lobe_eval(&q, wi, wo);
                            let val = f as f64 * wx * wp;
                            if wi.z * wo.z > 0.0 {
                                r += val;
                            } else {
                                t += val;
                            }
                        }
                    }
                }
            }
        }
        let c = 1.0 - e.e(&q, wi.z > 0.0, wi.z) as f64;
        (r, t, c)
    }

    /// The η nodes are what their documentation says: from 1.05 to 3, uniform in cos θc (the
    /// rounding to 4 decimals moves a node by < 0.2 % of the step).
    #[test]
    fn eta_nodes_are_uniform_in_the_critical_cosine() {
        let (u0, u1) = (eta_coordinate(1.05), eta_coordinate(3.0));
        let step = (u1 - u0) / (DIEL_ETAS.len() - 1) as f32;
        for (k, &e) in DIEL_ETAS.iter().enumerate() {
            let off = (eta_coordinate(e) - (u0 + k as f32 * step)).abs();
            assert!(off < 2e-3 * step, "node {k} ({e}) off by {off}");
        }
        assert!((eta_coordinate(2.0) - 0.75f32.sqrt()).abs() < 1e-6);
        assert_eq!(eta_coordinate(1.0), 0.0);
    }

    /// The committed data decodes; every row of the compensation lobes integrates to the energy
    /// the single-scattering model misses, 1 − E(μi), from both sides, for indices on and off
    /// the nodes (η < 1 included) and a constant roughness (1e-3: the quadrature of the bins'
    /// deficits), and to within 3e-3 for a textured roughness between its nodes (second order);
    /// the lobes are reciprocal (the transmission η² times the reverse one, importance
    /// transport), and the R/T split is not Kulla–Conty's constant one.
    #[test]
    fn rows_integrate_to_the_deficit() {
        assert!(dielectric_data_present(), "dielectric_lobe.bin");
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            // correlated: the compensated models' tables, measured lobes; separable: Kulla–Conty's
            for (eta, alpha, textured, tol, correlated) in [
                (1.5f32, 1.0f32, false, 1e-3, true),
                (1.33, 0.3, false, 1e-3, true),
                (1.16, 0.6, false, 1e-3, true),
                (2.4, 0.6, false, 1e-3, true),
                (1.0 / 1.5, 0.5, false, 1e-3, true),
                (1.5, 0.6, true, 3e-3, true),
                (1.5, 1.0, false, 1e-3, false),
            ] {
                let e = DielectricEnergy::get(
                    kind,
                    eta,
                    FresnelMode::Exact,
                    (!textured).then_some(alpha),
                    correlated,
                );
                // the separable model (no material compensates it) has Kulla–Conty's lobes
                assert_eq!(e.lobe.measured, correlated);
                let mut splits = Vec::new();
                for mu in [0.03f32, 0.2, 0.5, 0.8, 0.99] {
                    for side in [1.0f32, -1.0] {
                        let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, side * mu);
                        let (r, t, c) = row_integral(&e, alpha, wi);
                        assert!(
                            (r + t - c).abs() < tol,
                            "{kind:?} η={eta} α={alpha} μi={}: ∫ = {} (R {r}, T {t}), 1 − E = {c}",
                            wi.z,
                            r + t
                        );
                        if side > 0.0 && c > 1e-3 {
                            splits.push(r / c);
                        }
                    }
                }
                let (lo, hi) = splits
                    .iter()
                    .fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
                assert!(
                    !correlated || hi - lo > 0.01,
                    "{kind:?} η={eta} α={alpha}: split {splits:?}"
                );
                // reciprocity
                let q = e.at(alpha);
                let mut rng = crate::rng::Pcg32::new(3, 4);
                for _ in 0..2000 {
                    let a = crate::warp::square_to_cosine_hemisphere(rng.next_vec2());
                    let b = crate::warp::square_to_cosine_hemisphere(rng.next_vec2());
                    let b = if rng.next_f32() < 0.5 { -b } else { b };
                    let (f1, _) = e.lobe_eval(&q, a, b);
                    let (f2, _) = e.lobe_eval(&q, b, a);
                    let want = if b.z < 0.0 { f2 * eta * eta } else { f2 };
                    assert!(
                        (f1 - want).abs() <= 1e-5 * f1.abs().max(1e-3),
                        "{kind:?} η={eta} α={alpha}: {a} {b}: {f1} vs {want}"
                    );
                }
            }
        }
    }

    /// `invert16` inverts (A A⁻¹ = I within 1e-12 for a diagonally dominant tridiagonal A, the
    /// shape of the histopolation matrices), and a zero row gives its unknown and its bin 0.
    #[test]
    fn invert16_inverts_and_drops_dead_rows() {
        let mut a = [[0.0f64; 16]; 16];
        for (k, row) in a.iter_mut().enumerate() {
            row[k] = 0.75 + 0.01 * k as f64;
            if k > 0 {
                row[k - 1] = 0.125;
            }
            if k < 15 {
                row[k + 1] = 0.1;
            }
        }
        let inv = invert16(a);
        for (r, row) in a.iter().enumerate() {
            for c in 0..16 {
                let v: f64 = row.iter().zip(&inv).map(|(x, i)| x * i[c]).sum();
                assert!(
                    (v - if r == c { 1.0 } else { 0.0 }).abs() < 1e-12,
                    "{r} {c}: {v}"
                );
            }
        }
        a[5] = [0.0; 16];
        let inv = invert16(a);
        assert!((0..16).all(|k| inv[5][k] == 0.0 && inv[k][5] == 0.0));
        assert!(inv[4][4] != 0.0 && inv.iter().flatten().all(|v| v.is_finite()));
    }

    /// The committed data is the output of Specula's own generator: measured nodes of both
    /// distributions (low and high η, a rough and a smoother node), regenerated with the
    /// committed walk counts and seeds, encode to the committed bytes exactly (each row's walks
    /// are a deterministic function of its seed).
    #[test]
    fn committed_data_is_the_generators_output() {
        for (kind, node) in [
            (MicrofacetType::Ggx, 11),
            (MicrofacetType::Ggx, DIEL_MEASURED_NODES - 4),
            (MicrofacetType::Beckmann, 2 * (DIEL_ALPHAS - 1) + 7),
        ] {
            let committed = committed_dielectric_node_record(kind, node).expect("data");
            let fresh = dielectric_node_record(kind, node, dielectric_walks(kind));
            let differing = fresh.iter().zip(committed).filter(|(a, b)| a != b).count();
            assert!(
                fresh.len() == committed.len() && differing == 0,
                "{kind:?} node {node}: {differing} of {} bytes differ",
                committed.len()
            );
        }
    }

    /// `sample` draws directions with the density `eval` reports: the histogram of 400 000
    /// samples over the table's cells (both sides) against the integral of the density, within
    /// 5σ per cell (two-sided, 1024 cells: a false failure has probability < 1e-3).
    #[test]
    fn sampling_matches_the_density() {
        let mut rng = crate::rng::Pcg32::new(5, 7);
        for (kind, eta, alpha, textured, mu_i, correlated) in [
            (MicrofacetType::Ggx, 1.5f32, 0.7f32, false, 0.1f32, true),
            (MicrofacetType::Ggx, 1.5, 0.7, false, -0.4, false),
            (MicrofacetType::Beckmann, 2.4, 0.45, true, 0.8, true),
        ] {
            let e = DielectricEnergy::get(
                kind,
                eta,
                FresnelMode::Exact,
                (!textured).then_some(alpha),
                correlated,
            );
            let lt = &e.lobe;
            let wi = Vec3::new((1.0 - mu_i * mu_i).sqrt(), 0.0, mu_i);
            let n = 400_000;
            let mut hist = vec![0.0f64; DROW];
            for _ in 0..n {
                let wo = lt.sample(alpha, wi, rng.next_f32(), rng.next_vec2());
                assert!((wo.length() - 1.0).abs() < 1e-4);
                let row = mu_bin(wo.z.abs()) + if wo.z < 0.0 { LOBE_MU } else { 0 };
                hist[row * LOBE_PHI + dphi_bin(delta_phi(wi, wo))] += 1.0;
            }
            // a cell's probability ∫∫ pdf dμo dΔφ (both signs) = ∫∫ (pdf / μo) dx dΔφ, the
            // integrand bilinear between the bin's edges and its centre (the node) on both
            // axes: two Gauss–Legendre nodes per half
            let (gx, gw) = gauss_legendre(2);
            let halves = |a: f64, b: f64, m: f64| [(a, m), (m, b)];
            let mut worst = 0.0f64;
            for r in 0..NR {
                let b = r % LOBE_MU;
                let (m0, m1) = mu_edges(b);
                for c in 0..LOBE_PHI {
                    let mut p = 0.0f64;
                    for (x0, x1) in halves(m0 * m0, m1 * m1, lt.hats.mu.nodes[b] as f64) {
                        for (f0, f1) in
                            halves(phi_edge(c), phi_edge(c + 1), lt.hats.phi.nodes[c] as f64)
                        {
                            for (u, wu) in gx.iter().zip(&gw) {
                                for (v, wv) in gx.iter().zip(&gw) {
                                    let x = x0 + (x1 - x0) * 0.5 * (u + 1.0);
                                    let phi = (f0 + (f1 - f0) * 0.5 * (v + 1.0)) as f32;
                                    let mu = x.sqrt() as f32;
                                    let s = (1.0 - mu * mu).max(0.0).sqrt();
                                    let z = if r < LOBE_MU { mu } else { -mu };
                                    // wi's azimuth is 0
                                    let wo = Vec3::new(s * phi.cos(), s * phi.sin(), z);
                                    let (_, pdf) = lt.eval(alpha, wi, wo);
                                    p += pdf as f64 / mu as f64
                                        * wu
                                        * 0.5
                                        * (x1 - x0)
                                        * wv
                                        * 0.5
                                        * (f1 - f0);
                                }
                            }
                        }
                    }
                    let got = hist[r * LOBE_PHI + c] / n as f64;
                    let sigma = (p / n as f64).sqrt();
                    worst = worst.max((got - p).abs() / (sigma + 1e-9));
                    assert!(
                        (got - p).abs() < 5.0 * sigma + 1e-5,
                        "{kind:?} α={alpha} μi={mu_i} cell {r},{c}: {got} vs {p}"
                    );
                }
            }
            assert!(worst > 0.5, "the test has noise: {worst}");
        }
    }

    /// ln Γ against known values.
    #[test]
    fn ln_gamma_is_accurate() {
        for (x, want) in [
            (1.0f64, 0.0f64),
            (2.0, 0.0),
            (1.5, -0.120_782_237_635_245_2),
            (3.7, 1.428_072_326_665_388_3),
            (25.0, 54.784_729_398_112_32),
        ] {
            assert!((ln_gamma(x) - want).abs() < 1e-9, "{x}: {}", ln_gamma(x));
        }
    }
}
