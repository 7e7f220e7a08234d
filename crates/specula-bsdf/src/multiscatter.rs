//! Energy compensation for rough microfacet models (`multiscatter=true`), after Kulla & Conty
//! 2017, "Revisiting physically based shading at Imageworks" (SIGGRAPH course), with the
//! dielectric extension of their slides made reciprocal.
//!
//! A single-scattering microfacet BSDF loses the light that the Smith microsurface shadows
//! after its first reflection or refraction: a white GGX conductor at α = 1 (separable
//! masking-shadowing, as Mitsuba) reflects 0.31 of the light at normal incidence, 0.56 at 85°,
//! 0.38 hemispherically averaged. The compensation adds a lobe that returns
//! exactly the missing energy.
//!
//! # Method
//!
//! **Tables.** E(μ, α) = ∫ f_ss(μ, ωo) |cosθo| dωo, the directional albedo of the white
//! single-scattering model, is computed by Specula's own quadrature on first use: a
//! [`quad_res`]² Gauss–Legendre rule over the visible-normal sample space, accumulated in f64,
//! at [`MU_RES`] nodes uniform in t = √μ (dense at grazing angles, where E changes fastest;
//! dielectrics: [`DIEL_MU_RES`] nodes uniform in v = (2/π) asin √μ, also dense near the normal,
//! where E from inside has a kink in θ, `mu_node_arc`) and, for tables that cover textured
//! roughness, [`ALPHA_RES`] nodes uniform in √α, α ∈ [0, 1]. E is interpolated linearly in
//! (√α, t or v); E_avg(α) = 2∫E μ dμ is the *exact* integral of that
//! interpolant, so the compensation lobe below returns exactly 1 − E_table(μ), and the
//! furnace error is only the table's (interpolation and quadrature), below 0.2 % (tests).
//! Conductor tables (one per distribution) are global ([`conductor_table`]); dielectric ones
//! depend on η and are built per η when a material is built ([`DielectricEnergy::get`],
//! cached).
//!
//! **Conductors.** Kulla and Conty's lobe is f = f_ss + C(μi) C(μo) / (π C_avg) per channel,
//! where C(μ) is the energy the single-scattering model misses for light from μ *with the
//! conductor's Fresnel*, and C_avg = 2∫C(μ)μ dμ: symmetric in (ωi, ωo) (reciprocal),
//! integrating to C(μi), and separable, diffuse-like. Specula replaces its constant 1/π by a
//! shape Ŝ(α; μi, μo, Δφ) measured from the random walk ([`lobe`]: the walk's deficit lobe,
//! tabulated, symmetric, normalised by Sinkhorn scaling):
//! f = f_ss + C(μi) C(μo) Ŝ / √(ρ(μi) ρ(μo)), with ρ(μ) = ∫ C(μo) Ŝ(μ, ωo) μo dωo the row
//! integral (for a white conductor C = 1 − E and ρ = 1 − E_avg; for a constant colour ρ is
//! made exact per μ bin by the same scaling, per channel, when the material is built; for a
//! textured one it is the row integral itself, exact to second order in its variation). The
//! lobe stays reciprocal and returns C(μi), and now peaks around the specular direction at
//! grazing incidence, as the walk's multiply scattered light does. For a coloured one
//! Kulla and Conty's C = (1 − E(μ)) F_avg² E_avg / (1 − F_avg (1 − E_avg)) is 5–26 % short of
//! the random walk in low-reflectance channels (gold's blue and green, chromium, copper at
//! α = 1), for two reasons, measured against the walk: (i) the model's separable G1·G1 loses
//! more in single scattering than the walk's height-correlated first order, and that part
//! should carry the first bounce's Fresnel, not F_ms; (ii) the light that reaches a second
//! bounce meets microfacets at more grazing angles than F_avg assumes and escapes after it
//! more often than E_avg says (e.g. GGX α = 0.8, normal incidence: 61 % escape after each later
//! bounce, against E_avg = 51 %; from 85°: 89 %). Specula's C(μ) therefore follows the walk
//! order by order:
//!
//! C(μ) = [E_corr(μ; F) − E_ss(μ; F)] + Σ_k F_k M_k(μ) Σ_j F_j [esc_kj(μ) + cont_kj(μ) R₃(F)]
//!
//! - E_ss, E_corr: the separable (model's) and height-correlated (exact) single-scattering
//!   albedos with the Fresnel F, and M = ∫ D_ωi(m) F(ωi·m) dm − E_corr, the energy reaching a
//!   second bounce: Gauss–Legendre quadrature, as the white tables; F_k are the coefficients
//!   of the Fresnel fit below and M_k the quantity for its k-th basis function;
//! - esc_kj, cont_kj: per unit of first-bounce basis k reaching the second bounce, the part
//!   with second-bounce basis j that escapes right after it, and the part that goes on —
//!   statistics of Heitz et al.'s random walk ([`crate::models::microsurface_walk`]),
//!   [`WALKS_PER_NODE`] white walks per node of a 9 × 9 grid over (√α, √μ), fixed seeds, on
//!   first use (≈ 1–2 s of one core per distribution, shared among the cores), interpolated;
//! - R₃ = F₃ ε₃ / (1 − F₃ (1 − ε₃)): the later bounces as Kulla–Conty's series, with the walk's
//!   mean Fresnel F₃ and escape probability ε₃ per bounce after the second (per roughness,
//!   the incidences pooled with the cosine-weighted measure).
//!
//! Everything is linear in the Fresnel F, so F is fitted per channel on a basis of three
//! functions of the microfacet cosine c ([`FresnelFit`]: the weighted least-squares fit of F on
//! 1, (1 − c)⁵ and c(1 − c)⁶, exact for Schlick's Fresnel) and the
//! tables hold each quantity per basis function (products for the averages): any conductor
//! and any textured parameter read the same global tables. For a white conductor esc₂ + cont₂
//! = 1 and R₃ = 1 exactly, so the walk's sampling noise cannot move the white furnace.
//! Measured against the walk (`tests/multiscatter.rs`, `coloured_survey`: gold, copper,
//! chromium, aluminium × GGX, Beckmann × α ∈ {0.1, 0.3, 0.6, 1} × θi ∈ {0, 45, 70, 85}°,
//! 200 000 samples each): every channel within 0.7 % of the walk's albedo with Beckmann and
//! within 1.1 % with GGX (the worst at α = 1, normal incidence, 1.0–1.1 % high: copper's green
//! and blue, gold's and chromium's blue). With Hoffman's two-point F82 fit of F (exact at
//! normal incidence and at 82°) instead of the least-squares one, gold's blue was 2.2 % low and
//! chromium's blue 2.1 % high at GGX α = 1: that fit carried 9.4 % too little second- and
//! later-bounce light for gold's blue (measured by weighting the same walks' bounces with the
//! exact Fresnel and with the fit). Kulla–Conty's F_avg term was up to 26 % low.
//!
//! **Dielectrics.** `roughdielectric` with `multiscatter=true` uses the height-correlated
//! masking-shadowing in its single-scattering part
//! ([`MicrofacetDistribution::g2_correlated`]: 1/(1 + Λi + Λo) for reflection,
//! B(1 + Λi, 1 + Λo) for transmission), which is exactly the random walk's first event; the
//! separable G1(ωi)G1(ωo) (Mitsuba's, kept with `multiscatter=false`) transmits *more* than
//! the walk at grazing incidence on rough surfaces, a deficit no added lobe can remove (see
//! the limits). `principled`'s transmissive part and `roughplastic`'s coat do the same under
//! `multiscatter=true`. The tables are built for the model's own single scattering
//! ([`DielectricEnergy::get`]'s `correlated`, [`dielectric_albedo`]), as is the lobe shape
//! ([`dielectric_lobe`] holds both measurements). From outside the interface loses
//! 1 − E_o(μ) (E_o = R + T of the single-scattering model with η), from inside 1 − E_i(μ)
//! (with 1/η). Kulla and Conty split the
//! missing energy into a reflection lobe on the incident side and a transmission lobe on the
//! other, each of the same separable form:
//!
//! - reflection outside: (1 − E_o_avg − x)(1 − E_o(μi))(1 − E_o(μo)) / (π (1 − E_o_avg)²)
//! - reflection inside: (1 − E_i_avg − x/η²)(1 − E_i(μi))(1 − E_i(μo)) / (π (1 − E_i_avg)²)
//! - transmission outside → inside: x (1 − E_o(μi))(1 − E_i(μo)) / (π (1 − E_o_avg)(1 − E_i_avg))
//! - transmission inside → outside: the same divided by η²,
//!
//! (importance transport; radiance divides transmission by η_rel² as the single-scattering
//! lobe does). The outside → inside value is η² times the inside → outside one, which is
//! exactly the generalised reciprocity of refraction, and every lobe integrates to the
//! missing energy, so R + T = 1 from both sides. x, the hemispherically averaged energy that
//! multiple scattering carries across, is Kulla and Conty's "fraction transmitted as in single
//! scattering": x = min(t_o (1 − E_o_avg), η² t_i (1 − E_i_avg)) with t = T_avg / E_avg of the
//! single-scattering model on each side (the minimum keeps both reflection weights ≥ 0).
//!
//! Specula replaces the constant 1/π-shapes by shapes measured from the random walk
//! ([`dielectric_lobe`]): the four lobes are c(μi) c(μo) M(μi, μo, Δφ) (c = 1 − E on each
//! direction's side, M divided by η² from inside), with M one symmetric matrix over the μ bins
//! of both sides (which keeps reciprocity and its η² generalisation exactly), interpolated in
//! cos θc = √(1 − 1/η²) and √α from the walk's deficit lobes, and scaled symmetrically
//! (Sinkhorn) against the material's own tables so that every row integrates to 1 − E(μi)
//! exactly, R + T = 1 from both sides. The split between R and T then follows the walk per incidence (Kulla and
//! Conty's lobes above are M's constant blocks, its value without the data); the crossing
//! energy x is the measured lobes' ([`DielectricLobe::x`]), used by `roughplastic`'s coat,
//! whose compensation reflects only.
//!
//! **Sampling.** A model picks the compensation with probability 1 − E(μi) (the white energy
//! it carries) and reports the pdf of the mixture, so that sample weights are f·|cosθo| / pdf
//! exactly. `roughconductor` samples its measured lobe from the table ([`LobeTable::sample`],
//! whose density is exactly Ŝ μo / Z), `roughdielectric` and `principled`'s transmission
//! their measured dielectric lobes likewise ([`DielectricLobe::sample`], density M |μo| / Z,
//! both sides); `principled`'s metallic lobe, the anisotropic conductor tables and
//! `roughplastic`'s coat lobe are cosine-sampled (the coat's with the diffuse base, whose
//! cosine sampling dominates it).
//!
//! # Known limits
//!
//! - Lobe shape against the exact random walk ([`crate::models::microsurface_walk`],
//!   `specula brdf multiscatter`; total variation between the binned lobes, 200 000 samples):
//!   white conductors with the measured shape, GGX and Beckmann, α 0.1–1, θi 0–85°, at most
//!   0.018 above the distance of identical lobes (the noise, 0.002–0.019): 0.028 (noise
//!   0.015) for GGX α = 1 at 85°, 0.020 (noise 0.002) for Beckmann α = 0.1 at 85°; Kulla–Conty's
//!   separable lobe was up to 0.14 (GGX α = 1, 85°) and 0.08 (Beckmann α = 0.1, 85°). White
//!   albedo (R + T) within 0.2 % throughout.
//! - Dielectric lobes with the measured shapes, against the walk (`dielectric_survey` in
//!   `tests/multiscatter.rs`: GGX and Beckmann, α ∈ {0.1, 0.3, 0.6, 1}, η ∈ {1.16, 1.33, 1.5,
//!   2.4} (between the η nodes), θi ∈ {0, 45, 75, 85}° from outside and inside, 200 000
//!   samples each): R + T within 0.5 % of the walk's, the transmitted part within 0.012 of the
//!   walk's; 16 of the 256 cases are more than 0.02 above the noise. At η = 1.33, 1.5 and 2.4
//!   4 of 192 (12 with the former 5 η nodes, up to 0.033 above the noise, η = 1.33 between the
//!   nodes 1.25 and 1.5): Beckmann α = 0.1 from inside at 95° (0.027, the Δφ bins below) and
//!   Beckmann α = 0.6, η = 1.33 at 105° (0.020). At η = 1.16, 12 of 64, up to 0.054 above the
//!   noise (Beckmann α = 1 from inside at 95°), rough surfaces at grazing incidence; that is
//!   not the interpolation in η: at the nodes 1.1391 and 1.1853 themselves 24 of 128 cases
//!   fail, up to 0.064 (Beckmann α = 1, 95°). Low η (≲ 1.2) near grazing is the open case.
//!   Before the height-correlated single scattering: 30 of 192, up to 0.185 above the noise
//!   (Beckmann α = 1, η = 1.33, 85°); Kulla–Conty's separable lobes: 121 of 192.
//!   With the separable single scattering of Mitsuba's model the deficit f_walk − f_ss is
//!   negative where that model transmits more than the walk (rough, grazing), which no
//!   non-negative lobe can fix ([`dielectric_lobe::negative_deficit`]: GGX α = 1, η = 1.5 at
//!   85° N = 0.175, distance 0.182; now 0.032 against noise 0.018); the height-correlated
//!   single scattering of `roughdielectric multiscatter=true` is the walk's own first event,
//!   so its deficit is non-negative; the same holds for `principled`'s transmissive part and
//!   `roughplastic`'s coat, which use it too (tests `principled_agrees_with_the_walk`,
//!   `plastic_coat_agrees_with_the_walk`). The separable measurement is kept for the survey's
//!   bound.
//! - The dielectric shapes are piecewise constant over 16 θ bins per side and 16 Δφ bins,
//!   interpolated linearly in cos θc = √(1 − 1/η²) between 12 nodes uniform in it (1.05 … 3,
//!   [`dielectric_lobe::DIEL_ETAS`]; beyond them the nearest node, η < 1 the nodes of 1/η with
//!   the sides exchanged) and in √α between 7 nodes
//!   (α = 0.028 … 1), and scaled against each material's own tables (exact energy for any η
//!   and constant α). A textured roughness normalises them at 17 roughness nodes (33 for the
//!   height-correlated model of `roughdielectric`): its rows are exact there and within
//!   0.3 % between them. The narrow deficit lobes of smooth
//!   surfaces at grazing incidence are resolved only to the bins (Beckmann α = 0.1 from inside
//!   at 95°: 0.029 against noise 0.003, Kulla–Conty 0.083). That is the Δφ bins
//!   (`dielectric_bin_probe`: the walk's own multiple scattering made piecewise constant over
//!   the table's cells is 0.020 from the walk, noise 0.002; with 32 θ bins still 0.020, with
//!   32 Δφ bins 0.004): the lobe is narrower than 11.25° in azimuth around the specular
//!   direction. 32 Δφ bins would double the table (to ≈ 10 MB) and each material's lobes.
//! - The measured shape is piecewise constant over its cells (16 θ bins of 5.6° for each of
//!   θi and θo, 16 Δφ bins of 11.25°) and linear in √α between 17 nodes; an anisotropic
//!   constant roughness keeps Kulla–Conty's separable shape over its azimuthal tables.
//! - Coloured conductors: within 1.1 % of the walk (above); what remains is the fit of F
//!   (within 2.4 % of the multiply scattered light), the pooling of the later bounces over
//!   incidences and the walk statistics' noise (≈ 1 % of the second-bounce energy; 8 times
//!   the walks moved no case by more than 0.3 %).
//! - Constant anisotropic roughness (α_u ≠ α_v) gets its own table over (azimuth, √μ)
//!   ([`conductor_tables_aniso`], [`PHI_RES`] azimuths, built with the material) and E_avg
//!   averaged over azimuths; the compensation lobe then depends on the azimuths of ωi and ωo
//!   (still separable and reciprocal). *Textured* anisotropic roughness reads the isotropic
//!   tables at √(α_u α_v), which is approximate (≈ 2 % low at α = 0.4/0.6, normal incidence).
//! - Roughness above 1 uses the tables at α = 1 (compensation then is approximate).
//! - The tables are computed with the exact Smith G1; `smith_g1=rational` (Beckmann) differs
//!   from it by < 0.35 %, which the compensation does not correct.
//! - Dielectric compensation lobes are tinted by `specular_reflectance` and
//!   `specular_transmittance` as the single-scattering ones are.

use crate::frame::{reflect, refract};
use crate::fresnel::{fresnel_conductor, FresnelMode};
use crate::microfacet::{MicrofacetDistribution, MicrofacetType, MIN_ALPHA};
use crate::quad::gauss_legendre;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::{Arc, Mutex, OnceLock};

pub mod dielectric_lobe;
pub mod lobe;
pub use dielectric_lobe::DielectricLobe;
pub use lobe::{lobe_table, LobeTable};

/// Nodes of the tables over t = √μ.
pub const MU_RES: usize = 32;
/// Nodes of the dielectric tables over v = (2/π) asin √μ (`mu_node_arc`).
pub const DIEL_MU_RES: usize = 48;
/// Nodes of the tables over α ∈ [0, 1] (for textured or anisotropic roughness).
pub const ALPHA_RES: usize = 33;
/// Gauss–Legendre nodes per dimension of the visible-normal quadrature (GGX's nodes are
/// cheaper; Beckmann's sampler inverts its CDF by Newton iteration): both reach ~1e-3 against
/// a 2.5× finer rule, also across total internal reflection (tests).
pub fn quad_res(kind: MicrofacetType) -> usize {
    match kind {
        MicrofacetType::Ggx => 64,
        MicrofacetType::Beckmann => 48,
    }
}

/// `f(i)` for i in 0..n, shared among the available cores (table rows are independent).
fn parallel_rows<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let threads = std::thread::available_parallelism()
        .map(|t| t.get())
        .unwrap_or(1)
        .min(n)
        .max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut out: Vec<(usize, T)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let mut v = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if i >= n {
                            break v;
                        }
                        v.push((i, f(i)));
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().expect("table worker"))
            .collect()
    });
    out.sort_by_key(|(i, _)| *i);
    out.into_iter().map(|(_, v)| v).collect()
}
/// The smallest μ a table node is computed at (t = 0 stands for it).
const MU_MIN: f32 = 1e-3;

/// A directional-albedo table over (α, √μ), with the hemispherical average of its interpolant.
#[derive(Debug, Clone)]
pub struct EnergyTable {
    /// Row nodes: one (a fixed roughness), or roughness nodes uniform in √α on [0, 1], or
    /// (`azimuthal`) azimuth nodes uniform on [0, π/2] for one anisotropic roughness.
    alpha_nodes: usize,
    azimuthal: bool,
    /// The μ axis: [`MU_RES`] nodes uniform in t = √μ, or (`arc`) [`DIEL_MU_RES`] nodes uniform
    /// in v = (2/π) asin √μ (`mu_node_arc`).
    arc: bool,
    /// E per α node, `res()` values uniform on the μ axis.
    e: Vec<f32>,
    /// 2∫E μ dμ of the interpolant, per α node.
    e_avg: Vec<f32>,
}

/// The μ of table node `j`.
fn mu_node(j: usize) -> f32 {
    let t = j as f32 / (MU_RES - 1) as f32;
    (t * t).max(MU_MIN)
}

/// v = (2/π) asin t for t = √μ ∈ [0, 1], the axis of [`mu_node_arc`], by Abramowitz and Stegun's
/// 4.4.45, asin t = π/2 − √(1 − t) (a₀ + a₁t + a₂t² + a₃t³), |error| ≤ 5e-5 rad (in v, with
/// f32 rounding, 4.3e-5 measured: 2e-3 of a node interval; test): cheaper than `asin`, which
/// every compensated dielectric evaluation would call two to four times.
#[inline]
fn arc_coordinate(t: f32) -> f32 {
    let p = 1.570_728_8 + t * (-0.212_114_4 + t * (0.074_261_0 - 0.018_729_3 * t));
    1.0 - std::f32::consts::FRAC_2_PI * (1.0 - t).max(0.0).sqrt() * p
}

/// The μ of node `j` of a table uniform in v = (2/π) asin √μ, μ = sin²(πv/2) (the dielectric
/// tables): like t = √μ it is proportional to √μ at grazing, where E changes fastest, and near
/// the normal it is linear in θ, in which the albedo from inside a low-index interface has a
/// kink at θ = 0 (total internal reflection sets in symmetrically about the normal): over t
/// the last interval spans θ 0–20° and interpolating E linearly in t put it 0.008 above the
/// quadrature at 11.5° (Beckmann α = 1, η = 1/1.139; the compensated interface then lost
/// 0.8 % of the energy there, above the furnace target of 0.5 %). v is coarser than t below
/// μ ≈ 0.6 (by up to π/2 at grazing), so these tables have [`DIEL_MU_RES`] nodes rather than
/// [`MU_RES`]: with 32, Beckmann α = 0.6, η = 1/1.1 at 80° came out 0.53 % low.
fn mu_node_arc(j: usize) -> f32 {
    let v = j as f64 / (DIEL_MU_RES - 1) as f64;
    ((std::f64::consts::FRAC_PI_2 * v).sin().powi(2) as f32).max(MU_MIN)
}

/// Roughness of α node `i` of a table of `n` nodes covering [0, 1], uniform in √α (the
/// albedo changes fastest with α at small roughness).
fn alpha_node(i: usize, n: usize) -> f32 {
    let s = i as f32 / (n - 1) as f32;
    (s * s).max(MIN_ALPHA)
}

/// ∫₀¹ E(u) w(u) du of the piecewise-linear E through `row` (nodes uniform on [0, 1]), by
/// `points`-point Gauss–Legendre on each interval.
fn interpolant_integral(row: &[f32], points: usize, w: impl Fn(f64) -> f64) -> f64 {
    let (x, wt) = gauss_legendre(points);
    let h = 1.0 / (row.len() - 1) as f64;
    let mut sum = 0.0f64;
    for (j, pair) in row.windows(2).enumerate() {
        for (xk, wk) in x.iter().zip(&wt) {
            let s = 0.5 * (xk + 1.0);
            let ev = pair[0] as f64 * (1.0 - s) + pair[1] as f64 * s;
            sum += ev * w((j as f64 + s) * h) * wk * 0.5 * h;
        }
    }
    sum
}

impl EnergyTable {
    /// Tabulate `f(μ)` for each roughness (E clamped to [0, 1]).
    fn from_rows(rows: Vec<[f64; MU_RES]>) -> Self {
        Self::from_rows_axis(rows, false)
    }

    /// Tabulate `f(μ)` at the [`DIEL_MU_RES`] nodes of `mu_node_arc` for each roughness
    /// (E clamped to [0, 1]).
    fn from_rows_arc(rows: Vec<[f64; DIEL_MU_RES]>) -> Self {
        let e: Vec<f32> = rows
            .iter()
            .flatten()
            .map(|v| v.clamp(0.0, 1.0) as f32)
            .collect();
        // 2∫E μ dμ = 2∫ E(v) sin²(πv/2) (π/2) sin(πv) dv
        let half_pi = std::f64::consts::FRAC_PI_2;
        let e_avg = e
            .chunks_exact(DIEL_MU_RES)
            .map(|row| {
                interpolant_integral(row, 8, |v| {
                    2.0 * (half_pi * v).sin().powi(2) * half_pi * (2.0 * half_pi * v).sin()
                }) as f32
            })
            .collect();
        EnergyTable {
            alpha_nodes: rows.len(),
            azimuthal: false,
            arc: true,
            e,
            e_avg,
        }
    }

    /// Nodes per row.
    #[inline]
    fn res(&self) -> usize {
        if self.arc {
            DIEL_MU_RES
        } else {
            MU_RES
        }
    }

    fn from_rows_axis(rows: Vec<[f64; MU_RES]>, azimuthal: bool) -> Self {
        let mut e = Vec::with_capacity(rows.len() * MU_RES);
        let mut e_avg = Vec::with_capacity(rows.len());
        for row in &rows {
            let row: Vec<f32> = row.iter().map(|v| v.clamp(0.0, 1.0) as f32).collect();
            // 4∫₀¹ E(t) t³ dt, E linear on each segment: 3-point Gauss–Legendre is exact
            let avg = interpolant_integral(&row, 3, |t| 4.0 * t * t * t);
            e.extend_from_slice(&row);
            e_avg.push(avg as f32);
        }
        EnergyTable {
            alpha_nodes: rows.len(),
            azimuthal,
            arc: false,
            e,
            e_avg,
        }
    }

    /// α (or folded azimuth) node and weight.
    #[inline]
    fn alpha_coord(&self, alpha: f32) -> (usize, f32) {
        if self.alpha_nodes == 1 {
            return (0, 0.0);
        }
        let s = if self.azimuthal {
            alpha.clamp(0.0, std::f32::consts::FRAC_PI_2) / std::f32::consts::FRAC_PI_2
        } else {
            alpha.clamp(0.0, 1.0).sqrt()
        };
        let x = s * (self.alpha_nodes - 1) as f32;
        let i = (x as usize).min(self.alpha_nodes - 2);
        (i, x - i as f32)
    }

    /// E(μ) at α (interpolated); μ = |cosθ|.
    #[inline]
    pub fn e(&self, alpha: f32, mu: f32) -> f32 {
        let (i, wa) = self.alpha_coord(alpha);
        let t = mu.abs().min(1.0).sqrt();
        let t = if self.arc { arc_coordinate(t) } else { t };
        let res = self.res();
        let x = t * (res - 1) as f32;
        let j = (x as usize).min(res - 2);
        let wt = x - j as f32;
        let row = |i: usize| {
            let r = &self.e[i * res..];
            r[j] + (r[j + 1] - r[j]) * wt
        };
        if self.alpha_nodes == 1 || wa == 0.0 {
            row(i)
        } else {
            row(i) + (row(i + 1) - row(i)) * wa
        }
    }

    /// E_avg of an azimuthal table: the mean over azimuths of its interpolant (trapezoids).
    pub fn e_aniso_avg(&self) -> f32 {
        let n = self.alpha_nodes;
        let inner: f32 = self.e_avg[1..n - 1].iter().sum();
        (inner + 0.5 * (self.e_avg[0] + self.e_avg[n - 1])) / (n - 1) as f32
    }

    /// E_avg = 2∫E(μ)μ dμ at α.
    #[inline]
    pub fn e_avg(&self, alpha: f32) -> f32 {
        let (i, wa) = self.alpha_coord(alpha);
        if self.alpha_nodes == 1 || wa == 0.0 {
            self.e_avg[i]
        } else {
            self.e_avg[i] + (self.e_avg[i + 1] - self.e_avg[i]) * wa
        }
    }
}

/// ∫ g(m) D_wi(m) dm over the normals visible from `wi` (upper hemisphere), by `res`²-point
/// Gauss–Legendre quadrature over the visible-normal sample space, in f64.
pub fn vndf_quadrature<const N: usize>(
    distr: &MicrofacetDistribution,
    wi: Vec3,
    res: usize,
    g: impl Fn(Vec3) -> [f64; N],
) -> [f64; N] {
    let mut vd = *distr;
    vd.sample_visible = true;
    let (x, w) = gauss_legendre(res);
    let mut sum = [0.0f64; N];
    for (xj, wj) in x.iter().zip(&w) {
        for (xk, wk) in x.iter().zip(&w) {
            let u = Vec2::new((0.5 * xj + 0.5) as f32, (0.5 * xk + 0.5) as f32);
            let m = match distr.kind {
                MicrofacetType::Ggx => ggx_vndf_polar(distr, wi, u),
                MicrofacetType::Beckmann => vd.sample(wi, u).0,
            };
            let v = g(m);
            for (s, v) in sum.iter_mut().zip(v) {
                *s += v * wj * wk * 0.25;
            }
        }
    }
    sum
}

/// GGX visible normals by Heitz's (2018) projected-hemisphere construction with the *polar*
/// disk map: the same distribution as the renderer's sampler, but a smooth function of the
/// sample (the concentric map has kinks along the diagonals, which slow quadrature down).
fn ggx_vndf_polar(distr: &MicrofacetDistribution, wi: Vec3, u: Vec2) -> Vec3 {
    let v = Vec3::new(distr.alpha_u * wi.x, distr.alpha_v * wi.y, wi.z).normalize();
    let len2 = v.x * v.x + v.y * v.y;
    let t1 = if len2 > 0.0 {
        Vec3::new(-v.y, v.x, 0.0) / len2.sqrt()
    } else {
        Vec3::X
    };
    let t2 = v.cross(t1);
    let r = u.x.sqrt();
    let (sp, cp) = (2.0 * std::f32::consts::PI * u.y).sin_cos();
    let (p1, p2) = (r * cp, r * sp);
    let s = 0.5 * (1.0 + v.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let n = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * v;
    Vec3::new(distr.alpha_u * n.x, distr.alpha_v * n.y, n.z.max(0.0)).normalize()
}

/// The incident direction of cosine μ (in the xz plane).
fn wi_of(mu: f32) -> Vec3 {
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// Directional albedo of the white single-scattering conductor: ∫ G1(ωo, m) D_ωi(m) dm.
pub fn conductor_albedo(distr: &MicrofacetDistribution, mu: f32, res: usize) -> f64 {
    conductor_albedo_dir(distr, wi_of(mu), res)
}

/// [`conductor_albedo`] for a direction `wi` (upper hemisphere).
pub fn conductor_albedo_dir(distr: &MicrofacetDistribution, wi: Vec3, res: usize) -> f64 {
    vndf_quadrature(distr, wi, res, |m| {
        let wo = reflect(wi, m);
        if wo.z <= 0.0 {
            return [0.0; 2];
        }
        [distr.smith_g1(wo, m) as f64, 0.0]
    })[0]
}

/// Reflected and transmitted albedo (R, T) of the white single-scattering dielectric interface
/// of relative index `eta`, for light arriving from the side of the normal at cosine μ, with
/// the separable masking-shadowing G1(ωi)G1(ωo) or (`correlated`) the height-correlated one
/// ([`MicrofacetDistribution::g2_correlated`]).
pub fn dielectric_albedo(
    distr: &MicrofacetDistribution,
    fresnel: FresnelMode,
    eta: f32,
    mu: f32,
    res: usize,
    correlated: bool,
) -> [f64; 2] {
    let wi = wi_of(mu);
    vndf_quadrature(distr, wi, res, |m| {
        let dwi = wi.dot(m);
        if dwi <= 0.0 {
            return [0.0; 2];
        }
        // G / G1(ωi): the visible-normal density carries G1(ωi)
        let g_out = |wo: Vec3| -> f64 {
            if correlated {
                let gi = distr.smith_g1(wi, m) as f64;
                if gi > 0.0 {
                    distr.g2_correlated(wi, wo, m) as f64 / gi
                } else {
                    0.0
                }
            } else {
                distr.smith_g1(wo, m) as f64
            }
        };
        let f = fresnel.eval(dwi, eta);
        let wr = reflect(wi, m);
        let r = if wr.z > 0.0 {
            f.r as f64 * g_out(wr)
        } else {
            0.0
        };
        let t = if f.t > 0.0 {
            let wt = refract(wi, m, f.cos_theta_t, f.eta_ti);
            if wt.z < 0.0 {
                // T from both cosines, as the model evaluates it
                let tt = fresnel.transmittance_pair(dwi, (-wt.dot(m)).max(0.0), eta);
                tt as f64 * g_out(wt)
            } else {
                0.0
            }
        } else {
            0.0
        };
        [r, t]
    })
}

/// The albedo table of the white conductor for a distribution (computed on first use).
pub fn conductor_table(kind: MicrofacetType) -> &'static EnergyTable {
    static GGX: OnceLock<EnergyTable> = OnceLock::new();
    static BECKMANN: OnceLock<EnergyTable> = OnceLock::new();
    let cell = match kind {
        MicrofacetType::Ggx => &GGX,
        MicrofacetType::Beckmann => &BECKMANN,
    };
    cell.get_or_init(|| {
        let t = conductor_tables(kind);
        let rows = (0..t.rows)
            .map(|i| std::array::from_fn(|j| t.nodes[i * MU_RES + j][SS] as f64))
            .collect();
        EnergyTable::from_rows(rows)
    })
}

/// Number of Fresnel basis functions: 1, (1 − c)⁵ and c(1 − c)⁶ (see [`FresnelFit`]).
pub const NB: usize = 3;

/// The Fresnel basis functions at c = cos(ray, microfacet normal).
#[inline]
pub fn fresnel_basis(c: f32) -> [f32; NB] {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    let m5 = m2 * m2 * m;
    [1.0, m5, c.clamp(0.0, 1.0) * m5 * m]
}

/// Components of a conductor table node (index ranges of `NB` each).
const SS: usize = 0;
const CORR: usize = NB;
const FIRST: usize = 2 * NB;
/// esc_kj and cont_kj, NB × NB each (see [`WalkStats`]).
const ESC: usize = 3 * NB;
const CONT: usize = 3 * NB + NB * NB;
/// Components per node.
const NC: usize = 3 * NB + 2 * NB * NB;
/// Row averages: the NC components, then M_k·esc_kj and M_k·cont_kj (M_k = first_k − corr_k).
const NA: usize = NC + 2 * NB * NB;

/// First-bounce quantities of a conductor microsurface for light from `wi`, per Fresnel basis
/// function b_k(c) (c = wi·m): the separable single-scattering albedo ∫ D_wi b_k G1(ωo)
/// (the model's), the height-correlated one ∫ D_wi b_k (1 + Λi)/(1 + Λi + Λo) (the exact
/// first order of the walk), and the first-bounce energy ∫ D_wi b_k.
pub fn conductor_moments(distr: &MicrofacetDistribution, wi: Vec3, res: usize) -> [f64; 3 * NB] {
    vndf_quadrature(distr, wi, res, |m| {
        let b = fresnel_basis(wi.dot(m)).map(f64::from);
        let wo = reflect(wi, m);
        let (sep, corr) = if wo.z > 0.0 {
            let g1o = distr.smith_g1(wo, m) as f64;
            let g1i = distr.smith_g1(wi, m) as f64;
            // escape after the first bounce, height-correlated: G2/G1(ωi)
            let corr = if g1o > 0.0 && g1i > 0.0 {
                g1o / (g1i + g1o - g1i * g1o)
            } else {
                0.0
            };
            (g1o, corr)
        } else {
            (0.0, 0.0)
        };
        std::array::from_fn(|i| b[i % NB] * [sep, corr, 1.0][i / NB])
    })
}

/// What the random walk does after the first bounce, from white walks at one (α, μ), over the
/// walks that reach a second bounce: esc_kj = E[b_k(c₁) b_j(c₂) · escape after bounce 2] /
/// E[b_k(c₁)] and cont_kj the same for going on (so the first bounce's Fresnel weights what
/// follows, keeping their correlation; Σ_j over the white basis gives esc_k0 + cont_k0 = 1);
/// and the sums over later bounces (of b_k(c), of escapes, of events) for the per-roughness
/// averages.
#[derive(Clone, Copy, Debug, Default)]
struct WalkStats {
    esc: [[f64; NB]; NB],
    cont: [[f64; NB]; NB],
    later: [f64; NB],
    later_n: f64,
    later_esc: f64,
}

/// Walks per node of the coarse (α, μ) grid the walk statistics are computed on.
pub const WALKS_PER_NODE: usize = 4000;
/// The coarse grid: nodes uniform in √α and in √μ.
const WALK_RES: usize = 9;

#[allow(clippy::needless_range_loop)]
fn walk_stats(kind: MicrofacetType, alpha: f32, mu: f32, seed: u64) -> WalkStats {
    use crate::models::microsurface_walk::{MicrosurfaceWalk, WalkMaterial};
    let walk = MicrosurfaceWalk::new(
        kind,
        alpha,
        alpha,
        WalkMaterial::Conductor {
            eta: Spectrum::splat(0.0),
            k: Spectrum::splat(1.0),
            reflectance: Spectrum::splat(1.0),
        },
    );
    let wi = wi_of(mu);
    let mut rng = crate::rng::Pcg32::new(seed, 0x6d73);
    let mut st = WalkStats::default();
    let mut norm = [0.0f64; NB];
    for _ in 0..WALKS_PER_NODE {
        let mut b1 = [0.0f64; NB];
        let mut b2 = [0.0f64; NB];
        let mut later = [0.0f64; NB];
        let mut later_n = 0.0;
        let mut last = 0;
        let done = walk.sample_visit(wi, &mut rng, |b, c| {
            last = b;
            let f = fresnel_basis(c as f32).map(f64::from);
            if b == 1 {
                b1 = f;
            } else if b == 2 {
                b2 = f;
            } else if b > 2 {
                for k in 0..NB {
                    later[k] += f[k];
                }
                later_n += 1.0;
            }
        });
        if done.is_none() || last < 2 {
            continue;
        }
        let dst = if last == 2 { &mut st.esc } else { &mut st.cont };
        for k in 0..NB {
            norm[k] += b1[k];
            for j in 0..NB {
                dst[k][j] += b1[k] * b2[j];
            }
            st.later[k] += later[k];
        }
        st.later_n += later_n;
        if last > 2 {
            st.later_esc += 1.0;
        }
    }
    for k in 0..NB {
        if norm[k] > 0.0 {
            for j in 0..NB {
                st.esc[k][j] /= norm[k];
                st.cont[k][j] /= norm[k];
            }
        } else {
            // nothing reaches a second bounce (a smooth surface): any split, weighted by nothing
            st.esc[k] = [0.0; NB];
            st.esc[k][0] = 1.0;
        }
    }
    st
}

/// A conductor's tables over (α or azimuth, √μ): the first-bounce moments of
/// [`conductor_moments`] and the walk statistics of the second bounce per node, and per row
/// their hemispherical averages and those of the products the compensation needs, with the
/// later-bounce Fresnel moments and escape probability.
#[derive(Debug, Clone)]
pub struct ConductorTables {
    rows: usize,
    azimuthal: bool,
    nodes: Vec<[f32; NC]>,
    avg: Vec<[f32; NA]>,
    /// Per row: mean b_k(c) over the bounces after the second, and the escape probability
    /// per such bounce.
    later: Vec<[f32; NB + 1]>,
}

/// The coarse walk statistics of a distribution (computed on first use): per (√α, √μ) node.
struct WalkGrid {
    nodes: Vec<WalkStats>,
}

fn walk_grid(kind: MicrofacetType) -> &'static WalkGrid {
    static GGX: OnceLock<WalkGrid> = OnceLock::new();
    static BECKMANN: OnceLock<WalkGrid> = OnceLock::new();
    let cell = match kind {
        MicrofacetType::Ggx => &GGX,
        MicrofacetType::Beckmann => &BECKMANN,
    };
    cell.get_or_init(|| {
        let nodes = parallel_rows(WALK_RES * WALK_RES, |n| {
            let (i, j) = (n / WALK_RES, n % WALK_RES);
            let a = alpha_node(i, WALK_RES);
            let t = j as f32 / (WALK_RES - 1) as f32;
            walk_stats(kind, a, (t * t).max(MU_MIN), n as u64 + 1)
        });
        WalkGrid { nodes }
    })
}

impl WalkGrid {
    /// (esc, cont) interpolated at (α, μ), bilinear in (√α, √μ).
    #[allow(clippy::type_complexity)]
    fn at(&self, alpha: f32, mu: f32) -> ([[f64; NB]; NB], [[f64; NB]; NB]) {
        let coord = |s: f32| {
            let x = s.clamp(0.0, 1.0) * (WALK_RES - 1) as f32;
            let i = (x as usize).min(WALK_RES - 2);
            (i, (x - i as f32) as f64)
        };
        let (i, wa) = coord(alpha.clamp(0.0, 1.0).sqrt());
        let (j, wm) = coord(mu.clamp(0.0, 1.0).sqrt());
        let mut esc = [[0.0; NB]; NB];
        let mut cont = [[0.0; NB]; NB];
        for (di, wi) in [(0, 1.0 - wa), (1, wa)] {
            for (dj, wj) in [(0, 1.0 - wm), (1, wm)] {
                let s = &self.nodes[(i + di) * WALK_RES + j + dj];
                for k in 0..NB {
                    for l in 0..NB {
                        esc[k][l] += wi * wj * s.esc[k][l];
                        cont[k][l] += wi * wj * s.cont[k][l];
                    }
                }
            }
        }
        (esc, cont)
    }

    /// Later-bounce moments at α (the μ nodes pooled with the cosine-weighted measure of
    /// incidence, 4t³dt in t = √μ, as C_avg weighs them; linear in √α between rows).
    #[allow(clippy::needless_range_loop)]
    fn later(&self, alpha: f32) -> [f32; NB + 1] {
        let row = |i: usize| {
            let mut s = WalkStats::default();
            for j in 0..WALK_RES {
                let n = &self.nodes[i * WALK_RES + j];
                let t = j as f64 / (WALK_RES - 1) as f64;
                let w = t * t * t;
                for k in 0..NB {
                    s.later[k] += w * n.later[k];
                }
                s.later_n += w * n.later_n;
                s.later_esc += w * n.later_esc;
            }
            let mut out = [0.0f32; NB + 1];
            if s.later_n > 0.0 {
                for k in 0..NB {
                    out[k] = (s.later[k] / s.later_n) as f32;
                }
                out[NB] = (s.later_esc / s.later_n) as f32;
            } else {
                out[0] = 1.0;
                out[NB] = 1.0;
            }
            out
        };
        let x = alpha.clamp(0.0, 1.0).sqrt() * (WALK_RES - 1) as f32;
        let i = (x as usize).min(WALK_RES - 2);
        let w = x - i as f32;
        let (a, b) = (row(i), row(i + 1));
        std::array::from_fn(|k| a[k] + (b[k] - a[k]) * w)
    }
}

impl ConductorTables {
    /// Tables from per-row moment nodes, with the walk statistics read at `alpha_of(row)`.
    fn build(
        kind: MicrofacetType,
        moments: Vec<[[f64; 3 * NB]; MU_RES]>,
        azimuthal: bool,
        alpha_of: impl Fn(usize) -> f32,
    ) -> Self {
        let grid = walk_grid(kind);
        let rows = moments.len();
        let mut nodes = Vec::with_capacity(rows * MU_RES);
        let mut avg = Vec::with_capacity(rows);
        let mut later = Vec::with_capacity(rows);
        let (gx, gw) = gauss_legendre(3);
        let h = 1.0 / (MU_RES - 1) as f64;
        for (r, row) in moments.iter().enumerate() {
            let a = alpha_of(r);
            let mut vals: Vec<[f64; NA]> = Vec::with_capacity(MU_RES);
            for (j, m) in row.iter().enumerate() {
                let (esc, cont) = grid.at(a, mu_node(j));
                let mut v = [0.0f64; NA];
                for k in 0..NB {
                    v[SS + k] = m[k].clamp(0.0, 1.0);
                    v[CORR + k] = m[NB + k].clamp(0.0, 1.0);
                    v[FIRST + k] = m[2 * NB + k].clamp(0.0, 1.0);
                    for jj in 0..NB {
                        v[ESC + k * NB + jj] = esc[k][jj];
                        v[CONT + k * NB + jj] = cont[k][jj];
                    }
                }
                for k in 0..NB {
                    let mk = v[FIRST + k] - v[CORR + k];
                    for jj in 0..NB {
                        v[NC + k * NB + jj] = mk * esc[k][jj];
                        v[NC + NB * NB + k * NB + jj] = mk * cont[k][jj];
                    }
                }
                nodes.push(std::array::from_fn(|c| v[c] as f32));
                vals.push(v);
            }
            // 4∫₀¹ v(t) t³ dt of the linear interpolant (exact with 3-point Gauss–Legendre)
            let mut s = [0.0f64; NA];
            for j in 0..MU_RES - 1 {
                for (xk, wk) in gx.iter().zip(&gw) {
                    let u = 0.5 * (xk + 1.0);
                    let t = (j as f64 + u) * h;
                    let wt = 4.0 * t * t * t * wk * 0.5 * h;
                    for c in 0..NA {
                        s[c] += wt * (vals[j][c] * (1.0 - u) + vals[j + 1][c] * u);
                    }
                }
            }
            avg.push(std::array::from_fn(|c| s[c] as f32));
            later.push(grid.later(a));
        }
        ConductorTables {
            rows,
            azimuthal,
            nodes,
            avg,
            later,
        }
    }

    /// Row coordinate (α uniform in √α, or the folded azimuth) and weight.
    #[inline]
    fn row_coord(&self, x: f32) -> (usize, f32) {
        if self.rows == 1 {
            return (0, 0.0);
        }
        let s = if self.azimuthal {
            x.clamp(0.0, std::f32::consts::FRAC_PI_2) / std::f32::consts::FRAC_PI_2
        } else {
            x.clamp(0.0, 1.0).sqrt()
        };
        let x = s * (self.rows - 1) as f32;
        let i = (x as usize).min(self.rows - 2);
        (i, x - i as f32)
    }

    /// The node components at `x` (α, or the folded azimuth of an anisotropic table) and μ.
    #[inline]
    pub fn at(&self, x: f32, mu: f32) -> TableNode {
        let (i, wa) = self.row_coord(x);
        let t = mu.abs().min(1.0).sqrt() * (MU_RES - 1) as f32;
        let j = (t as usize).min(MU_RES - 2);
        let wt = t - j as f32;
        let n = |i: usize, j: usize| &self.nodes[i * MU_RES + j];
        let mut out = [0.0f32; NC];
        let (a0, a1) = (n(i, j), n(i, j + 1));
        for c in 0..NC {
            out[c] = a0[c] + (a1[c] - a0[c]) * wt;
        }
        if wa > 0.0 {
            let (b0, b1) = (n(i + 1, j), n(i + 1, j + 1));
            for c in 0..NC {
                let v = b0[c] + (b1[c] - b0[c]) * wt;
                out[c] += (v - out[c]) * wa;
            }
        }
        TableNode(out)
    }

    /// The white single-scattering albedo E(μ) at `x` (the compensation's sampling weight is
    /// 1 − E).
    #[inline]
    pub fn e(&self, x: f32, mu: f32) -> f32 {
        let (i, wa) = self.row_coord(x);
        let t = mu.abs().min(1.0).sqrt() * (MU_RES - 1) as f32;
        let j = (t as usize).min(MU_RES - 2);
        let wt = t - j as f32;
        let row = |i: usize| {
            let (a, b) = (
                self.nodes[i * MU_RES + j][SS],
                self.nodes[i * MU_RES + j + 1][SS],
            );
            a + (b - a) * wt
        };
        if wa > 0.0 {
            row(i) + (row(i + 1) - row(i)) * wa
        } else {
            row(i)
        }
    }

    /// The compensation's colour for a Fresnel `fit` at roughness `alpha` (ignored for an
    /// azimuthal table, which averages its rows).
    pub fn ms(&self, alpha: f32, fit: &FresnelFit) -> ConductorMs {
        let (avg, later) = if self.azimuthal {
            let n = self.rows;
            let mut avg = [0.0f32; NA];
            for (r, a) in self.avg.iter().enumerate() {
                let w = if r == 0 || r == n - 1 { 0.5 } else { 1.0 } / (n - 1) as f32;
                for c in 0..NA {
                    avg[c] += w * a[c];
                }
            }
            (avg, self.later[0])
        } else {
            let (i, w) = self.row_coord(alpha);
            let lerp = |a: &[f32], b: &[f32], c: usize| a[c] + (b[c] - a[c]) * w;
            (
                std::array::from_fn(|c| {
                    lerp(&self.avg[i], &self.avg[(i + 1).min(self.rows - 1)], c)
                }),
                std::array::from_fn(|c| {
                    lerp(&self.later[i], &self.later[(i + 1).min(self.rows - 1)], c)
                }),
            )
        };
        let c = &fit.c;
        // the bounces after the second: mean Fresnel F₃ and escape probability ε₃ each
        let f3 = (0..NB)
            .fold(Spectrum::ZERO, |s, k| s + c[k] * later[k])
            .map(|v| v.clamp(0.0, 1.0));
        let eps = later[NB];
        let r3 = (f3 * eps) / (Spectrum::ONE - f3 * (1.0 - eps)).map(|v| v.max(1e-6));
        let mut total = Spectrum::ZERO;
        for k in 0..NB {
            total += c[k] * (avg[CORR + k] - avg[SS + k]);
            for j in 0..NB {
                let e = avg[NC + k * NB + j];
                let t = avg[NC + NB * NB + k * NB + j];
                total += c[k] * c[j] * (r3 * t + Spectrum::splat(e));
            }
        }
        ConductorMs {
            c: *c,
            r3,
            avg: total,
        }
    }
}

/// Interpolated node components of a [`ConductorTables`].
#[derive(Clone, Copy, Debug)]
pub struct TableNode([f32; NC]);

/// The quantities C(μ) is linear in, for any Fresnel fit: D_k = E_corr,k − E_ss,k, and
/// X_kj = M_k esc_kj, Y_kj = M_k cont_kj ([`ConductorMs::combine`]).
pub const NQ: usize = NB + 2 * NB * NB;

impl TableNode {
    /// The components of [`NQ`] at this node.
    pub fn components(&self) -> [f32; NQ] {
        let n = &self.0;
        let mut q = [0.0f32; NQ];
        for k in 0..NB {
            q[k] = n[CORR + k] - n[SS + k];
            let reach = n[FIRST + k] - n[CORR + k];
            for j in 0..NB {
                q[NB + k * NB + j] = reach * n[ESC + k * NB + j];
                q[NB + NB * NB + k * NB + j] = reach * n[CONT + k * NB + j];
            }
        }
        q
    }
}

/// The colour of a conductor's compensation at one roughness: C(μ) per channel is the exact
/// first-order difference (height-correlated minus separable single scattering) plus the
/// energy reaching a second bounce times what leaves after it (the second bounce's Fresnel and
/// escape from the walk statistics, the later bounces as a series in F₃ and ε₃); the lobe is
/// C(μi) C(μo) / (π C_avg).
#[derive(Clone, Copy, Debug)]
pub struct ConductorMs {
    c: [Spectrum; NB],
    r3: Spectrum,
    /// C_avg = 2∫C(μ)μ dμ.
    avg: Spectrum,
}

impl ConductorMs {
    /// C(μ) from the table node at μ.
    #[inline]
    pub fn energy(&self, n: &TableNode) -> Spectrum {
        let n = &n.0;
        let c = &self.c;
        let mut total = Spectrum::ZERO;
        for k in 0..NB {
            // the first bounce's difference, and what reaches the second and leaves after it
            let reach = n[FIRST + k] - n[CORR + k];
            let mut after = Spectrum::ZERO;
            for j in 0..NB {
                let e = n[ESC + k * NB + j];
                let t = n[CONT + k * NB + j];
                after += c[j] * (self.r3 * t + Spectrum::splat(e));
            }
            total += c[k] * (after * reach + Spectrum::splat(n[CORR + k] - n[SS + k]));
        }
        total.map(|v| v.max(0.0))
    }

    /// Σ_k c_k D_k + Σ_kj c_k c_j (X_kj + R₃ Y_kj) of components (or of their integrals)
    /// [`NQ`]: C(μ) of a node's components, without the clamp of [`Self::energy`].
    #[inline]
    pub fn combine(&self, q: &[f32; NQ]) -> Spectrum {
        let c = &self.c;
        let mut total = Spectrum::ZERO;
        for k in 0..NB {
            let mut after = Spectrum::ZERO;
            for j in 0..NB {
                after += c[j]
                    * (self.r3 * q[NB + NB * NB + k * NB + j]
                        + Spectrum::splat(q[NB + k * NB + j]));
            }
            total += c[k] * (after + Spectrum::splat(q[k]));
        }
        total
    }

    /// The lobe with the measured shape Ŝ ([`lobe`]): C(μi) C(μo) Ŝ / √(ρ(μi) ρ(μo)), where
    /// ρ(μ) = ∫ C(μo) Ŝ(μ, ωo) μo dωo is the row integral of C_o Ŝ ([`LobeTable::rho`]):
    /// symmetric, and integrating to C(μi) to the extent that ρ varies slowly over the lobe
    /// (for a white conductor ρ = 1 − E_avg and the integral is exact).
    #[inline]
    pub fn lobe_measured(
        &self,
        c_i: Spectrum,
        c_o: Spectrum,
        shape: f32,
        rho_i: Spectrum,
        rho_o: Spectrum,
    ) -> Spectrum {
        let r = rho_i * rho_o;
        c_i * c_o * r.map(|v| if v > 1e-12 { shape / v.sqrt() } else { 0.0 })
    }

    /// The lobe C(μi) C(μo) / (π C_avg) (without cosine): symmetric, and integrating to C(μi).
    #[inline]
    pub fn lobe(&self, c_i: Spectrum, c_o: Spectrum) -> Spectrum {
        self.lobe_shaped(c_i, c_o, FRAC_1_PI)
    }

    /// The lobe C(μi) C(μo) Ŝ / C_avg with the tabulated shape Ŝ ([`lobe`]) in place of
    /// Kulla–Conty's 1/π.
    #[inline]
    pub fn lobe_shaped(&self, c_i: Spectrum, c_o: Spectrum, shape: f32) -> Spectrum {
        let inv = self.avg.map(|v| if v > 1e-6 { shape / v } else { 0.0 });
        c_i * c_o * inv
    }
}

/// The conductor tables of a distribution over α ∈ [0, 1] (computed on first use).
pub fn conductor_tables(kind: MicrofacetType) -> &'static ConductorTables {
    static GGX: OnceLock<ConductorTables> = OnceLock::new();
    static BECKMANN: OnceLock<ConductorTables> = OnceLock::new();
    let cell = match kind {
        MicrofacetType::Ggx => &GGX,
        MicrofacetType::Beckmann => &BECKMANN,
    };
    cell.get_or_init(|| {
        let rows = parallel_rows(ALPHA_RES, |i| {
            let a = alpha_node(i, ALPHA_RES);
            let distr = MicrofacetDistribution::new(kind, a, a, true);
            std::array::from_fn(|j| conductor_moments(&distr, wi_of(mu_node(j)), quad_res(kind)))
        });
        ConductorTables::build(kind, rows, false, |i| alpha_node(i, ALPHA_RES))
    })
}

/// Azimuth nodes of a per-material anisotropic table.
pub const PHI_RES: usize = 9;

/// The conductor tables for one anisotropic roughness (α_u ≠ α_v), over (azimuth folded
/// into [0, π/2], √μ); read at [`folded_phi`], averaged over azimuths. The walk statistics are
/// the isotropic ones at √(α_u α_v).
pub fn conductor_tables_aniso(kind: MicrofacetType, alpha_u: f32, alpha_v: f32) -> ConductorTables {
    let distr = MicrofacetDistribution::new(kind, alpha_u, alpha_v, true);
    let rows = parallel_rows(PHI_RES, |i| {
        let phi = i as f32 / (PHI_RES - 1) as f32 * std::f32::consts::FRAC_PI_2;
        let (s, c) = phi.sin_cos();
        std::array::from_fn(|j| {
            let w = wi_of(mu_node(j));
            conductor_moments(&distr, Vec3::new(w.x * c, w.x * s, w.z), quad_res(kind))
        })
    });
    let a = table_alpha(alpha_u, alpha_v);
    ConductorTables::build(kind, rows, true, |_| a)
}

/// The azimuth of `w` folded into [0, π/2] (the anisotropic distributions are symmetric
/// about both axes).
#[inline]
pub fn folded_phi(w: Vec3) -> f32 {
    w.y.abs().atan2(w.x.abs())
}

/// The roughness the global tables are read at for anisotropic textured roughness:
/// √(α_u α_v), at most 1.
#[inline]
pub fn table_alpha(alpha_u: f32, alpha_v: f32) -> f32 {
    (alpha_u * alpha_v).max(0.0).sqrt().min(1.0)
}

/// Build everything a compensated conductor of this distribution reads (its tables and the
/// Fresnel-average rule), so that evaluation never initialises (allocates) anything.
pub fn prepare_conductor(kind: MicrofacetType) {
    conductor_tables(kind);
    lobe_table(kind);
    conductor_fresnel_avg(Spectrum::splat(1.0), Spectrum::splat(1.0));
}

/// Cosine-weighted hemispherical average 2∫F(μ)μ dμ of a conductor's Fresnel reflectance.
pub fn conductor_fresnel_avg(eta: Spectrum, k: Spectrum) -> Spectrum {
    static RULE: OnceLock<(Vec<f64>, Vec<f64>)> = OnceLock::new();
    let (x, w) = RULE.get_or_init(|| gauss_legendre(24));
    let mut s = [0.0f32; 3];
    for (xj, wj) in x.iter().zip(w) {
        let mu = (0.5 * xj + 0.5) as f32;
        for c in 0..3 {
            s[c] += *wj as f32 * mu * fresnel_conductor(mu, eta[c], k[c]);
        }
    }
    Spectrum::new(s[0], s[1], s[2])
}

/// A Fresnel reflectance per channel as F(c) ≈ Σ c_k b_k(c) over the basis 1, (1 − c)⁵,
/// c(1 − c)⁶ ([`fresnel_basis`]; Hoffman's "F82" form F₀ + (1 − F₀)(1 − c)⁵ − β c(1 − c)⁶ is a
/// member). A conductor's coefficients are the weighted least-squares fit over c ∈ [0, 1] with
/// weight c ([`FIT_NODES`] Gauss–Legendre nodes): the fit only carries the multiply scattered
/// light, whose bounces see cosines spread over the whole interval (few near grazing; measured
/// from the walk, GGX and Beckmann, α 0.3–1), so it is fitted where they fall rather than made
/// exact at two points. Against the walk with each bounce's exact Fresnel, the light of the
/// second and later bounces carried by the fit is within 2.4 % for gold, copper, chromium,
/// aluminium, silver and tungsten (α 0.3–1, θi 0–85°); Hoffman's two-point form (exact at
/// normal incidence and at 82°) was up to 9.4 % low (gold's blue) and 4.9 % high (chromium's
/// red). Exact for Schlick's Fresnel and for a white reflector, which lie in the span.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FresnelFit {
    pub c: [Spectrum; NB],
}

impl FresnelFit {
    /// The fit of a conductor's Fresnel reflectance (complex index η + ik) times `reflectance`.
    pub fn conductor(eta: Spectrum, k: Spectrum, reflectance: Spectrum) -> Self {
        let p = fit_projection();
        let mut c = [[0.0f32; 3]; NB];
        for ch in 0..3 {
            // the reflectance at the nodes, a loop the compiler vectorises
            let mut f = [0.0f32; FIT_NODES];
            for (fi, &x) in f.iter_mut().zip(&p.nodes) {
                *fi = crate::fresnel::fresnel_conductor(x, eta[ch], k[ch]);
            }
            for (ck, row) in c.iter_mut().zip(&p.rows) {
                ck[ch] = row.iter().zip(&f).map(|(r, f)| r * f).sum::<f32>() * reflectance[ch];
            }
        }
        FresnelFit {
            c: c.map(|[r, g, b]| Spectrum::new(r, g, b)),
        }
    }
    /// Schlick's Fresnel of normal reflectance `r0` (exactly representable).
    pub fn schlick(r0: Spectrum) -> Self {
        FresnelFit {
            c: [r0, Spectrum::ONE - r0, Spectrum::ZERO],
        }
    }
    /// A white perfect reflector.
    pub const WHITE: FresnelFit = FresnelFit {
        c: [Spectrum::ONE, Spectrum::ZERO, Spectrum::ZERO],
    };
    /// The fit at c.
    #[inline]
    pub fn eval(&self, c: f32) -> Spectrum {
        let b = fresnel_basis(c);
        self.c[0] * b[0] + self.c[1] * b[1] + self.c[2] * b[2]
    }
    /// The hemispherical average 2∫F(μ)μ dμ = c₀ + c₁/21 + c₂/126.
    #[inline]
    pub fn avg(&self) -> Spectrum {
        self.c[0] + self.c[1] * (1.0 / 21.0) + self.c[2] * (1.0 / 126.0)
    }
}

/// Gauss–Legendre nodes of [`FresnelFit::conductor`]'s least-squares fit.
pub const FIT_NODES: usize = 8;

/// The fit's projection: coefficients c_k = Σ_i rows[k][i] F(nodes[i]), the solution of the
/// normal equations of Σ_i w_i c_i (F(c_i) − Σ_k c_k b_k(c_i))² on [0, 1].
struct FitProjection {
    nodes: [f32; FIT_NODES],
    rows: [[f32; FIT_NODES]; NB],
}

fn fit_projection() -> &'static FitProjection {
    static P: OnceLock<FitProjection> = OnceLock::new();
    P.get_or_init(|| {
        let (x, w) = crate::quad::gauss_legendre(FIT_NODES);
        let c: Vec<f64> = x.iter().map(|x| 0.5 * (x + 1.0)).collect();
        let wt: Vec<f64> = w.iter().zip(&c).map(|(w, c)| 0.5 * w * c).collect();
        let b: Vec<[f64; NB]> = c
            .iter()
            .map(|&c| fresnel_basis(c as f32).map(f64::from))
            .collect();
        let mut a = [[0.0f64; NB]; NB];
        for (bi, wi) in b.iter().zip(&wt) {
            for p in 0..NB {
                for q in 0..NB {
                    a[p][q] += wi * bi[p] * bi[q];
                }
            }
        }
        let mut rows = [[0.0f32; FIT_NODES]; NB];
        for i in 0..FIT_NODES {
            let rhs: [f64; NB] = std::array::from_fn(|p| wt[i] * b[i][p]);
            let col = crate::math::solve(a, rhs).expect("the Fresnel basis is independent");
            for k in 0..NB {
                rows[k][i] = col[k] as f32;
            }
        }
        FitProjection {
            nodes: std::array::from_fn(|i| c[i] as f32),
            rows,
        }
    })
}

/// Energy tables of a rough dielectric interface (one η, one distribution) from both sides.
#[derive(Debug)]
pub struct DielectricEnergy {
    pub eta: f32,
    /// R + T and T from outside (η) and inside (1/η).
    pub e_out: EnergyTable,
    pub t_out: EnergyTable,
    pub e_in: EnergyTable,
    pub t_in: EnergyTable,
    /// Kulla–Conty's averaged energy multiple scattering carries across, per α node (see the
    /// module; the measured lobes carry their own, [`DielectricLobe::x`]).
    x: Vec<f32>,
    /// The roughness of a one-node table.
    fixed_alpha: Option<f32>,
    /// The compensation lobes' shapes ([`dielectric_lobe`]).
    pub lobe: DielectricLobe,
    /// Whether the single-scattering model these tables compensate uses the height-correlated
    /// masking-shadowing ([`MicrofacetDistribution::g2_correlated`]: every compensated model)
    /// rather than the separable G1(ωi)G1(ωo).
    pub correlated: bool,
}

/// The quantities of the dielectric compensation at one roughness.
#[derive(Clone, Copy, Debug)]
pub struct DielectricMs {
    pub e_out_avg: f32,
    pub e_in_avg: f32,
    pub x: f32,
    pub alpha: f32,
}

impl DielectricEnergy {
    /// The tables for (distribution, η, Fresnel), at the single roughness `alpha` when it is
    /// `Some` (a constant isotropic α), over α ∈ [0, 1] otherwise, of the single-scattering
    /// model with separable or (`correlated`) height-correlated masking-shadowing; built once
    /// per key and shared.
    pub fn get(
        kind: MicrofacetType,
        eta: f32,
        fresnel: FresnelMode,
        alpha: Option<f32>,
        correlated: bool,
    ) -> Arc<DielectricEnergy> {
        type Key = (MicrofacetType, u32, FresnelMode, Option<u32>, bool);
        static CACHE: Mutex<Vec<(Key, Arc<DielectricEnergy>)>> = Mutex::new(Vec::new());
        let alpha = alpha.map(|a| a.clamp(MIN_ALPHA, 1.0));
        let key = (
            kind,
            eta.to_bits(),
            fresnel,
            alpha.map(f32::to_bits),
            correlated,
        );
        if let Some((_, t)) = CACHE.lock().unwrap().iter().find(|(k, _)| *k == key) {
            return t.clone();
        }
        let t = Arc::new(Self::build(kind, eta, fresnel, alpha, correlated));
        let mut cache = CACHE.lock().unwrap();
        if cache.len() > 64 {
            cache.remove(0);
        }
        cache.push((key, t.clone()));
        t
    }

    fn build(
        kind: MicrofacetType,
        eta: f32,
        fresnel: FresnelMode,
        alpha: Option<f32>,
        correlated: bool,
    ) -> Self {
        let alphas: Vec<f32> = match alpha {
            Some(a) => vec![a],
            None => (0..ALPHA_RES).map(|i| alpha_node(i, ALPHA_RES)).collect(),
        };
        let side = |eta: f32| {
            // one job per (α, μ) node: a one-roughness table has only DIEL_MU_RES of them
            let nodes = parallel_rows(alphas.len() * DIEL_MU_RES, |n| {
                let a = alphas[n / DIEL_MU_RES];
                let distr = MicrofacetDistribution::new(kind, a, a, true);
                dielectric_albedo(
                    &distr,
                    fresnel,
                    eta,
                    mu_node_arc(n % DIEL_MU_RES),
                    quad_res(kind),
                    correlated,
                )
            });
            let rows = |k: usize| -> Vec<[f64; DIEL_MU_RES]> {
                nodes
                    .chunks(DIEL_MU_RES)
                    .map(|c| {
                        std::array::from_fn(|j| if k == 0 { c[j][0] + c[j][1] } else { c[j][1] })
                    })
                    .collect()
            };
            (
                EnergyTable::from_rows_arc(rows(0)),
                EnergyTable::from_rows_arc(rows(1)),
            )
        };
        let (e_out, t_out) = side(eta);
        let (e_in, t_in) = side(1.0 / eta);
        let x = (0..alphas.len())
            .map(|i| {
                let (eo, ei) = (e_out.e_avg[i], e_in.e_avg[i]);
                let to = if eo > 0.0 { t_out.e_avg[i] / eo } else { 0.0 };
                let ti = if ei > 0.0 { t_in.e_avg[i] / ei } else { 0.0 };
                (to * (1.0 - eo)).min(eta * eta * ti * (1.0 - ei)).max(0.0)
            })
            .collect();
        let mut t = DielectricEnergy {
            eta,
            e_out,
            t_out,
            e_in,
            t_in,
            x,
            fixed_alpha: alpha,
            lobe: DielectricLobe::empty(),
            correlated,
        };
        let lobe_alphas: Vec<f32> = match alpha {
            Some(a) => vec![a],
            None => {
                let n = if correlated {
                    dielectric_lobe::TEXTURED_ALPHAS_CORRELATED
                } else {
                    dielectric_lobe::TEXTURED_ALPHAS
                };
                (0..n).map(|k| alpha_node(k, n)).collect()
            }
        };
        t.lobe = DielectricLobe::build(kind, &t, &lobe_alphas);
        t
    }

    /// The averaged quantities at roughness `alpha` (ignored for a one-roughness table), with
    /// the crossing energy x of the compensation lobes.
    #[inline]
    pub fn at(&self, alpha: f32) -> DielectricMs {
        let mut q = self.at_kc(alpha);
        q.x = self.lobe.x_at(q.alpha);
        q
    }

    /// [`Self::at`] with Kulla–Conty's crossing energy x.
    #[inline]
    pub fn at_kc(&self, alpha: f32) -> DielectricMs {
        let alpha = self.fixed_alpha.unwrap_or(alpha);
        let x = if self.x.len() == 1 {
            self.x[0]
        } else {
            let (i, w) = self.e_out.alpha_coord(alpha);
            self.x[i] + (self.x[i + 1] - self.x[i]) * w
        };
        DielectricMs {
            e_out_avg: self.e_out.e_avg(alpha),
            e_in_avg: self.e_in.e_avg(alpha),
            x,
            alpha,
        }
    }

    /// E(μ) on the side `outside`.
    #[inline]
    pub fn e(&self, ms: &DielectricMs, outside: bool, mu: f32) -> f32 {
        if outside {
            self.e_out.e(ms.alpha, mu)
        } else {
            self.e_in.e(ms.alpha, mu)
        }
    }

    /// The compensation lobe for (wi, wo) (either side each): its value in importance
    /// transport (without the tints), c(μi) c(μo) M ([`DielectricLobe`]), and the density of
    /// [`Self::sample_lobe`] at wo over solid angle.
    #[inline]
    pub fn lobe_eval(&self, ms: &DielectricMs, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let (s, pdf) = self.lobe.eval(ms.alpha, wi, wo);
        let ci = 1.0 - self.e(ms, wi.z > 0.0, wi.z);
        let co = 1.0 - self.e(ms, wo.z > 0.0, wo.z);
        (ci.max(0.0) * co.max(0.0) * s, pdf)
    }

    /// The compensation lobes for `wi` (side of `wi.z`): (reflection value, transmission value
    /// in importance transport), one of them 0.
    #[inline]
    pub fn lobes(&self, ms: &DielectricMs, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let (v, _) = self.lobe_eval(ms, wi, wo);
        if wi.z * wo.z > 0.0 {
            (v, 0.0)
        } else {
            (0.0, v)
        }
    }

    /// A direction from the compensation lobe for `wi` (either side), with the density
    /// [`Self::lobe_eval`] reports; `u` picks a roughness node of a textured roughness.
    #[inline]
    pub fn sample_lobe(&self, ms: &DielectricMs, wi: Vec3, u: f32, u2: Vec2) -> Vec3 {
        self.lobe.sample(ms.alpha, wi, u, u2)
    }

    /// Of the compensation energy for an incidence from outside at cosine `mu`, the part
    /// its lobes reflect ([`DielectricLobe::reflected_share`]).
    #[inline]
    pub fn reflected_share(&self, ms: &DielectricMs, mu: f32) -> f32 {
        self.lobe.reflected_share(ms.alpha, mu)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quadrature has converged: the tables' resolution against a 2.5× finer rule
    /// (conductor, and the dielectric from both sides, where total internal reflection adds
    /// a kink): within 2.5e-3, half the furnace target.
    #[test]
    fn quadrature_converges() {
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            let (n1, n2) = (quad_res(kind), 5 * quad_res(kind) / 2);
            for a in [0.3f32, 1.0] {
                let d = MicrofacetDistribution::new(kind, a, a, true);
                for mu in [MU_MIN, 0.05, 0.5, 1.0] {
                    let e1 = conductor_albedo(&d, mu, n1);
                    let e2 = conductor_albedo(&d, mu, n2);
                    assert!(
                        (e1 - e2).abs() < 1e-3,
                        "{kind:?} α={a} μ={mu}: {e1} vs {e2}"
                    );
                    for eta in [1.5f32, 1.0 / 1.5] {
                        for c in [false, true] {
                            let r1 = dielectric_albedo(&d, FresnelMode::Exact, eta, mu, n1, c);
                            let r2 = dielectric_albedo(&d, FresnelMode::Exact, eta, mu, n2, c);
                            let (t1, t2) = (r1[0] + r1[1], r2[0] + r2[1]);
                            assert!(
                                (t1 - t2).abs() < 2.5e-3,
                                "{kind:?} α={a} η={eta} μ={mu} correlated={c}: {t1} vs {t2}"
                            );
                        }
                    }
                }
            }
        }
    }

    /// `arc_coordinate` is (2/π) asin within 5e-5 on [0, 1] and reproduces the nodes.
    #[test]
    fn arc_coordinate_is_accurate() {
        let mut worst = 0.0f64;
        for k in 0..=10_000 {
            let t = k as f64 / 10_000.0;
            let exact = t.asin() * std::f64::consts::FRAC_2_PI;
            worst = worst.max((arc_coordinate(t as f32) as f64 - exact).abs());
        }
        assert!(worst < 5e-5, "{worst}");
        for j in 1..DIEL_MU_RES {
            let v = arc_coordinate(mu_node_arc(j).sqrt()) * (DIEL_MU_RES - 1) as f32;
            assert!((v - j as f32).abs() < 2e-3, "node {j}: {v}");
        }
    }

    /// The table interpolates the albedo to within 0.2 % between its nodes (measured: ≤ 1.1e-3).
    #[test]
    fn interpolation_error_is_small() {
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            let t = conductor_table(kind);
            for a in [0.05f32, 0.37, 0.71, 1.0] {
                let d = MicrofacetDistribution::new(kind, a, a, true);
                for mu in [0.002f32, 0.013, 0.07, 0.23, 0.61, 0.97] {
                    let exact = conductor_albedo(&d, mu, quad_res(kind)) as f32;
                    let tab = t.e(a, mu);
                    assert!(
                        (exact - tab).abs() < 2e-3,
                        "{kind:?} α={a} μ={mu}: table {tab} vs {exact}"
                    );
                }
            }
        }
    }

    #[test]
    fn known_values() {
        // E_avg of the interpolant against 2∫E μ dμ integrated directly (24-point rule)
        let t = conductor_table(MicrofacetType::Ggx);
        let avg = t.e_avg(1.0);
        let d = MicrofacetDistribution::new(MicrofacetType::Ggx, 1.0, 1.0, true);
        let (x, w) = gauss_legendre(24);
        let direct: f64 = x
            .iter()
            .zip(&w)
            .map(|(x, w)| {
                let mu = 0.5 * x + 0.5;
                w * mu * conductor_albedo(&d, mu as f32, 64)
            })
            .sum();
        assert!((avg as f64 - direct).abs() < 2e-3, "{avg} vs {direct}");
        // the white GGX conductor at α = 1 keeps only ~38 % of the light (Smith, separable G)
        assert!((0.36..0.40).contains(&avg), "E_avg(1) = {avg}");
        assert!(t.e_avg(0.0) > 0.999 && t.e(0.0, 0.5) > 0.999);
        // F_avg of a perfect mirror is 1, of an index-matched dielectric-like conductor 0
        let f = conductor_fresnel_avg(Spectrum::splat(0.0), Spectrum::splat(1.0));
        assert!((f[0] - 1.0).abs() < 1e-4, "{f:?}");
    }

    /// The conductor fit is the weighted least-squares one: exact on the basis's span (the
    /// projection reproduces each basis function and hence Schlick's Fresnel and a white
    /// reflector), and for real metals its weighted error is below Hoffman's two-point F82 form
    /// (F₀ + (1 − F₀)(1 − c)⁵ − β c(1 − c)⁶, exact at c = 1 and 1/7), which it replaced.
    #[test]
    fn fresnel_fit_is_least_squares() {
        let p = fit_projection();
        for k in 0..NB {
            for j in 0..NB {
                let cj: f32 = (0..FIT_NODES)
                    .map(|i| p.rows[j][i] * fresnel_basis(p.nodes[i])[k])
                    .sum();
                let want = if j == k { 1.0 } else { 0.0 };
                assert!(
                    (cj - want).abs() < 1e-4,
                    "basis {k} → coefficient {j}: {cj}"
                );
            }
        }
        let white =
            FresnelFit::conductor(Spectrum::splat(0.0), Spectrum::splat(1.0), Spectrum::ONE);
        for c in [0.0f32, 0.3, 1.0] {
            assert!((white.eval(c)[0] - 1.0).abs() < 1e-4, "{:?}", white.eval(c));
        }
        let (x, w) = gauss_legendre(64);
        for name in ["Au", "Cu", "Cr", "Al"] {
            let (e, k) = crate::data::lookup_conductor(name).unwrap();
            let (eta, k) = (
                Spectrum::new(e[0], e[1], e[2]),
                Spectrum::new(k[0], k[1], k[2]),
            );
            let ls = FresnelFit::conductor(eta, k, Spectrum::ONE);
            let f0 = crate::fresnel::fresnel_conductor_rgb(1.0, eta, k);
            let b82 = fresnel_basis(1.0 / 7.0);
            let f82 = crate::fresnel::fresnel_conductor_rgb(1.0 / 7.0, eta, k);
            let hoffman = FresnelFit {
                c: [
                    f0,
                    Spectrum::ONE - f0,
                    (f82 - f0 - (Spectrum::ONE - f0) * b82[1]) * (1.0 / b82[2]),
                ],
            };
            for ch in 0..3 {
                let err = |fit: &FresnelFit| -> f64 {
                    x.iter()
                        .zip(&w)
                        .map(|(x, w)| {
                            let c = 0.5 * (x + 1.0);
                            let f = crate::fresnel::fresnel_conductor_rgb(c as f32, eta, k)[ch];
                            0.5 * w * c * ((fit.eval(c as f32)[ch] - f) as f64).powi(2)
                        })
                        .sum::<f64>()
                        .sqrt()
                };
                let (a, b) = (err(&ls), err(&hoffman));
                assert!(
                    a <= b * 1.0001 && a < 0.01,
                    "{name} channel {ch}: least squares {a}, F82 {b}"
                );
            }
        }
    }
}
