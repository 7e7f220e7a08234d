//! The whole battery of property checks on one material, as `specula brdf check` runs it:
//!
//! | check | what | criterion |
//! |---|---|---|
//! | `non-negative` | [`finite_nonnegative`] on random and degenerate directions | every f, pdf, sample finite and ≥ 0 |
//! | `reciprocity` | `reciprocity` over random pairs (η² relation for refraction) | max relative error ≤ [`RECIPROCITY_TOL`] |
//! | `energy` | white-furnace albedo ([`albedo`], importance transport) per θi and channel | one-sided z-test of albedo ≤ 1 |
//! | `sampling-chi2` | [`chi2_test`] of `sample` against `pdf` per θi | p ≥ per-test significance |
//! | `lobe-selection` | instead of χ² for materials made only of Dirac lobes ([`lobe_selection_test`]) | p ≥ per-test significance |
//! | `sample-weights` | [`sample_consistency`]: weight = f·\|cosθo\|/pdf and sampled pdf = `pdf()`, both transport modes | max relative error ≤ [`CONSISTENCY_TOL`] |
//!
//! The statistical tests (χ² or lobe selection: one per incidence angle; energy: one per
//! angle and colour channel) form one family whose significance is Šidák-corrected, so that
//! a correct material fails any of them with probability `family_alpha` (0.01 by default).
//! Every test uses its own fixed seed derived from [`SuiteConfig::seed`]: the report is a
//! deterministic function of the material and the configuration, whatever the thread count.
//!
//! With [`SuiteConfig::wavelengths`] the material is checked in spectral mode at those three
//! wavelengths (the channels of every value): the χ² test then judges the density of the
//! spectral sampler (for a dispersive material, the mixture over the wavelengths), energy is
//! judged per wavelength, and reciprocity uses each channel's own relative index.

use crate::bsdf::{BsdfContext, BsdfModel, ShadingPoint};
use crate::check::chi2::{chi2_test, Chi2Config, Chi2Result};
use crate::check::lobe::{lobe_selection_test, LobeSelectionResult};
use crate::check::props::{
    albedo, finite_nonnegative, reciprocity_channels, sample_consistency, AlbedoResult,
    ConsistencyResult, ReciprocityResult,
};
use crate::check::stats::{normal_sf, sidak};
use crate::rng::Pcg32;
use crate::spectrum::Wavelengths;
use glam::Vec3;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Largest relative reciprocity error accepted (the analytic models reach 1e-5; a real
/// asymmetry shows at the per-cent level).
pub const RECIPROCITY_TOL: f64 = 1e-4;
/// Largest relative difference accepted between a sample's weight and f·|cosθo|/pdf, and
/// between its pdf and `pdf()` of its direction.
pub const CONSISTENCY_TOL: f64 = 1e-4;
/// Allowance for float rounding in the albedo bound: a lossless material's weights are 1 up
/// to single-precision rounding, so its mean may exceed 1 by ~1e-7 with zero variance.
pub const ALBEDO_ROUNDING: f64 = 1e-5;
/// Default incidence angles (degrees from the normal) on the side of the normal; the mirror
/// angles 180° − θ below the surface are added for materials that respond from below.
pub const DEFAULT_ANGLES: [f32; 4] = [0.0, 30.0, 60.0, 85.0];
/// Azimuth of the incident direction (radians): off the principal axes, so that an
/// anisotropic material is not tested only on its symmetry planes.
pub const PHI_I: f32 = 0.5;

/// How reciprocity is checked.
pub enum Reciprocity<'a> {
    /// Evaluate the material itself.
    Test,
    /// Evaluate another model that shares the material's data (e.g. a MERL table with
    /// interpolated lookup, whose nearest-bin lookup jumps where rounding crosses a bin edge);
    /// `note` says so in the report.
    Substitute {
        model: &'a (dyn BsdfModel + Sync),
        note: String,
    },
    /// Not judged, for the stated reason (the error is still measured and reported).
    Skip(String),
}

/// Settings of [`run_suite`].
pub struct SuiteConfig<'a> {
    /// Samples per statistical test (χ², lobe selection, albedo); the consistency check draws
    /// a tenth of it per angle and transport mode, reciprocity a tenth of it pairs.
    pub samples: usize,
    pub seed: u64,
    /// Family-wise significance of the statistical tests.
    pub family_alpha: f64,
    /// Incidence angles θi in degrees (0–180, beyond 90 below the surface); `None`: the
    /// [`DEFAULT_ANGLES`], mirrored below when the material responds from below.
    pub angles: Option<Vec<f32>>,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    pub reciprocity: Reciprocity<'a>,
    /// Texture coordinates the material is evaluated at (textured parameters, bump and normal
    /// maps), on the flat shading point of [`ShadingPoint::default`] (∂p/∂u, ∂p/∂v and the
    /// geometric normal along the local x, y and z axes).
    pub uv: glam::Vec2,
    /// Spectral mode: the wavelengths (nm) of the three channels; `None`: RGB mode.
    pub wavelengths: Option<Wavelengths>,
}

impl Default for SuiteConfig<'_> {
    fn default() -> Self {
        SuiteConfig {
            samples: 200_000,
            seed: 1,
            family_alpha: 0.01,
            angles: None,
            threads: 0,
            reciprocity: Reciprocity::Test,
            uv: glam::Vec2::ZERO,
            wavelengths: None,
        }
    }
}

/// The verdict of one check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    Pass,
    Fail,
    /// Not applicable or not judged; the outcome's summary says why.
    Skip,
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Verdict::Pass => "PASS",
            Verdict::Fail => "FAIL",
            Verdict::Skip => "SKIP",
        })
    }
}

/// One line of the report.
#[derive(Clone, Debug)]
pub struct CheckOutcome {
    /// `non-negative`, `reciprocity`, `energy`, `sampling-chi2` or `lobe-selection`,
    /// `sample-weights`.
    pub name: &'static str,
    pub verdict: Verdict,
    /// The figures the verdict rests on, one line.
    pub summary: String,
    /// Where it went wrong (failed checks), one line each.
    pub details: Vec<String>,
}

/// Everything [`run_suite`] found.
#[derive(Clone, Debug)]
pub struct SuiteReport {
    pub outcomes: Vec<CheckOutcome>,
    /// Incidence angles tested (degrees), at azimuth [`PHI_I`].
    pub angles: Vec<f32>,
    pub samples: usize,
    pub seed: u64,
    pub family_alpha: f64,
    /// Number of statistical tests in the family.
    pub family_size: usize,
    /// Šidák-corrected significance of each statistical test.
    pub per_test_alpha: f64,
    /// θ × φ bins of the χ² tests (when run).
    pub chi2_bins: Option<(usize, usize)>,
}

impl SuiteReport {
    /// True when no check failed.
    pub fn passed(&self) -> bool {
        self.outcomes.iter().all(|o| o.verdict != Verdict::Fail)
    }

    pub fn outcome(&self, name: &str) -> Option<&CheckOutcome> {
        self.outcomes.iter().find(|o| o.name == name)
    }
}

/// The incident direction at polar angle `theta_deg` and azimuth [`PHI_I`].
pub fn incidence(theta_deg: f32) -> Vec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = PHI_I.sin_cos();
    Vec3::new(st * cp, st * sp, ct).normalize()
}

/// An odd χ² resolution in θ for `samples` samples: about 40 samples per cell on average
/// (φ gets twice as many bins), between 11 and 101 bins.
pub fn chi2_resolution(samples: usize) -> (usize, usize) {
    let t = ((samples as f64 / 80.0).sqrt() as usize).clamp(11, 101) | 1;
    (t, 2 * t - 1)
}

/// Whether the material scatters light arriving from below the surface (two-sided or
/// transmissive models); one-sided models produce no sample there.
pub fn responds_from_below<B: BsdfModel + ?Sized>(bsdf: &B) -> bool {
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut rng = Pcg32::new(0x5ca1e, 1);
    [100.0f32, 135.0, 180.0].iter().any(|&t| {
        let wi = incidence(t);
        (0..256).any(|_| {
            let u1 = rng.next_f32();
            let u2 = rng.next_vec2();
            bsdf.sample(&ctx, &sp, wi, u1, u2)
                .is_some_and(|s| s.weight.max_component() > 0.0)
        })
    })
}

/// The relative index of refraction (below over above) a transmissive material refracts
/// with, found from its samples; `None` when it produces no refracted sample.
pub fn relative_ior<B: BsdfModel + ?Sized>(bsdf: &B) -> Option<f32> {
    relative_ior_at(bsdf, &ShadingPoint::default())
}

/// [`relative_ior`] at a shading point (in spectral mode, at its wavelengths).
pub fn relative_ior_at<B: BsdfModel + ?Sized>(bsdf: &B, sp: &ShadingPoint) -> Option<f32> {
    let ctx = BsdfContext::RADIANCE;
    let mut rng = Pcg32::new(0x10f, 2);
    for t in [0.0f32, 30.0, 60.0] {
        let wi = incidence(t);
        for _ in 0..1024 {
            let u1 = rng.next_f32();
            let u2 = rng.next_vec2();
            if let Some(s) = bsdf.sample(&ctx, sp, wi, u1, u2) {
                if s.wo.z < 0.0 && s.eta.is_finite() && s.eta > 0.0 {
                    return Some(s.eta);
                }
            }
        }
    }
    None
}

/// A seed per test, mixed from the configured seed (SplitMix64 finaliser).
fn derive_seed(seed: u64, tag: u64, index: usize) -> u64 {
    let mut z = seed
        .wrapping_add(tag.wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_add((index as u64).wrapping_mul(0xD1B5_4A32_D192_ED03));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[derive(Clone, Copy, Debug)]
enum Job {
    Finite,
    Reciprocity,
    Sampling(usize),
    Albedo(usize),
    Consistency(usize),
}

enum JobResult {
    Finite(Result<usize, String>),
    Reciprocity(ReciprocityResult),
    Chi2(Chi2Result),
    Lobe(LobeSelectionResult),
    Albedo(AlbedoResult),
    Consistency(Box<[ConsistencyResult; 2]>),
}

/// A p-value for a table: fixed-point when readable, scientific when small.
pub fn fmt_p(p: f64) -> String {
    if p == 0.0 {
        "0".into()
    } else if p >= 0.01 {
        format!("{p:.3}")
    } else {
        format!("{p:.1e}")
    }
}

/// A standard error: two significant digits.
fn fmt_se(se: f64) -> String {
    if se == 0.0 {
        "0".into()
    } else {
        format!("{se:.1e}")
    }
}

fn fmt_deg(t: f32) -> String {
    format!("{t}°")
}

/// Run every check on `bsdf`; `progress(done, total)` is called after each of the suite's
/// jobs (from worker threads).
pub fn run_suite<B: BsdfModel + Sync + ?Sized>(
    bsdf: &B,
    cfg: &SuiteConfig,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> SuiteReport {
    let sp = ShadingPoint {
        wavelengths: cfg.wavelengths,
        ..ShadingPoint::at_uv(cfg.uv.x, cfg.uv.y)
    };
    let flags = bsdf.flags();
    let all_delta = flags.is_all_delta();
    let angles: Vec<f32> = match &cfg.angles {
        Some(a) => a.clone(),
        None => {
            let mut a = DEFAULT_ANGLES.to_vec();
            if responds_from_below(bsdf) {
                a.extend(DEFAULT_ANGLES.iter().map(|t| 180.0 - t));
            }
            a
        }
    };
    let n = cfg.samples.max(1);
    let small = (n / 10).max(1000);
    let (res_theta, res_phi) = chi2_resolution(n);
    // the family: one sampling test per angle, one energy test per angle and channel
    let family_size = 4 * angles.len();
    let alpha = sidak(cfg.family_alpha, family_size);
    // each channel's relative index, found at its own wavelength alone
    let eta: Option<[f32; 3]> = match cfg.wavelengths {
        None => relative_ior(bsdf).map(|e| [e; 3]),
        Some(w) => {
            let at = |l: f32| {
                let spl = ShadingPoint {
                    wavelengths: Some(Wavelengths([l; 3])),
                    ..sp
                };
                relative_ior_at(bsdf, &spl)
            };
            match (at(w.0[0]), at(w.0[1]), at(w.0[2])) {
                (Some(a), Some(b), Some(c)) => Some([a, b, c]),
                _ => None,
            }
        }
    };

    let mut jobs: Vec<Job> = (0..angles.len()).map(Job::Sampling).collect();
    jobs.extend((0..angles.len()).map(Job::Albedo));
    jobs.extend((0..angles.len()).map(Job::Consistency));
    jobs.push(Job::Reciprocity);
    jobs.push(Job::Finite);

    let run_job = |job: Job| -> JobResult {
        match job {
            Job::Finite => JobResult::Finite(finite_nonnegative(
                bsdf,
                &sp,
                small.min(5000),
                derive_seed(cfg.seed, 1, 0),
            )),
            Job::Reciprocity => {
                let seed = derive_seed(cfg.seed, 2, 0);
                JobResult::Reciprocity(match &cfg.reciprocity {
                    Reciprocity::Substitute { model, .. } => {
                        reciprocity_channels(*model, &sp, eta, small, seed)
                    }
                    _ => reciprocity_channels(bsdf, &sp, eta, small, seed),
                })
            }
            Job::Sampling(i) => {
                let wi = incidence(angles[i]);
                let seed = derive_seed(cfg.seed, 3, i);
                let ctx = BsdfContext::RADIANCE;
                if all_delta {
                    JobResult::Lobe(lobe_selection_test(bsdf, &ctx, &sp, wi, n as u64, seed))
                } else {
                    let c = Chi2Config {
                        res_theta,
                        res_phi,
                        samples: n,
                        seed,
                    };
                    JobResult::Chi2(chi2_test(bsdf, &ctx, &sp, wi, &c))
                }
            }
            Job::Albedo(i) => JobResult::Albedo(albedo(
                bsdf,
                &BsdfContext::IMPORTANCE,
                &sp,
                incidence(angles[i]),
                n,
                derive_seed(cfg.seed, 4, i),
            )),
            Job::Consistency(i) => {
                let wi = incidence(angles[i]);
                let seed = derive_seed(cfg.seed, 5, i);
                JobResult::Consistency(Box::new([
                    sample_consistency(bsdf, &BsdfContext::RADIANCE, &sp, wi, small, seed),
                    sample_consistency(bsdf, &BsdfContext::IMPORTANCE, &sp, wi, small, seed),
                ]))
            }
        }
    };

    // a work queue over the jobs; results land in their job's slot
    let threads = if cfg.threads > 0 {
        cfg.threads
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
    .min(jobs.len());
    let next = AtomicUsize::new(0);
    let done = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<JobResult>>> = Mutex::new((0..jobs.len()).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(&job) = jobs.get(k) else { break };
                let r = run_job(job);
                slots.lock().unwrap_or_else(|e| e.into_inner())[k] = Some(r);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, jobs.len());
            });
        }
    });
    let results: Vec<JobResult> = slots
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.expect("every job ran"))
        .collect();

    let mut finite = None;
    let mut recip = None;
    let mut sampling: Vec<Option<JobResult>> = (0..angles.len()).map(|_| None).collect();
    let mut albedos: Vec<Option<AlbedoResult>> = vec![None; angles.len()];
    let mut consistency: Vec<Option<Box<[ConsistencyResult; 2]>>> =
        (0..angles.len()).map(|_| None).collect();
    for (job, r) in jobs.iter().zip(results) {
        match (job, r) {
            (Job::Finite, JobResult::Finite(r)) => finite = Some(r),
            (Job::Reciprocity, JobResult::Reciprocity(r)) => recip = Some(r),
            (Job::Sampling(i), r) => sampling[*i] = Some(r),
            (Job::Albedo(i), JobResult::Albedo(r)) => albedos[*i] = Some(r),
            (Job::Consistency(i), JobResult::Consistency(r)) => consistency[*i] = Some(r),
            _ => unreachable!("job and result kinds match"),
        }
    }

    let mut outcomes = Vec::new();
    outcomes.push(finite_outcome(finite.expect("finite ran")));
    outcomes.push(reciprocity_outcome(
        recip.expect("reciprocity ran"),
        all_delta,
        eta,
        &cfg.reciprocity,
    ));
    let albedos: Vec<AlbedoResult> = albedos.into_iter().map(|a| a.expect("ran")).collect();
    let channels = match cfg.wavelengths {
        Some(w) => w.0.map(|l| format!("{l} nm")),
        None => CHANNELS.map(String::from),
    };
    outcomes.push(energy_outcome(&angles, &albedos, alpha, &channels));
    let sampling: Vec<JobResult> = sampling.into_iter().map(|a| a.expect("ran")).collect();
    outcomes.push(sampling_outcome(
        &angles,
        &sampling,
        alpha,
        (res_theta, res_phi),
    ));
    let consistency: Vec<Box<[ConsistencyResult; 2]>> =
        consistency.into_iter().map(|a| a.expect("ran")).collect();
    outcomes.push(consistency_outcome(&angles, &consistency, all_delta));

    SuiteReport {
        outcomes,
        angles,
        samples: n,
        seed: cfg.seed,
        family_alpha: cfg.family_alpha,
        family_size,
        per_test_alpha: alpha,
        chi2_bins: (!all_delta).then_some((res_theta, res_phi)),
    }
}

fn finite_outcome(r: Result<usize, String>) -> CheckOutcome {
    match r {
        Ok(n) => CheckOutcome {
            name: "non-negative",
            verdict: Verdict::Pass,
            summary: format!(
                "eval, pdf and sample finite and ≥ 0 on {n} random and degenerate queries"
            ),
            details: vec![],
        },
        Err(e) => CheckOutcome {
            name: "non-negative",
            verdict: Verdict::Fail,
            summary: "a value is negative, NaN or infinite".into(),
            details: vec![e],
        },
    }
}

fn reciprocity_outcome(
    r: ReciprocityResult,
    all_delta: bool,
    eta: Option<[f32; 3]>,
    mode: &Reciprocity,
) -> CheckOutcome {
    let name = "reciprocity";
    if all_delta {
        return CheckOutcome {
            name,
            verdict: Verdict::Skip,
            summary: "all lobes are Dirac deltas: f is 0 for every pair of directions".into(),
            details: vec![],
        };
    }
    let eta_note = match eta {
        Some(e) if e[0] == e[1] && e[0] == e[2] && e[0] != 1.0 => {
            format!(", η² relation for refraction with η = {:.4}", e[0])
        }
        Some(e) if e[0] != e[1] || e[0] != e[2] => format!(
            ", η² relation for refraction with η = {:.4}, {:.4}, {:.4} per channel",
            e[0], e[1], e[2]
        ),
        _ => String::new(),
    };
    let figures = format!(
        "max relative error {:.2e} over {} pairs (tolerance {:.0e}{eta_note})",
        r.max_rel_err, r.pairs, RECIPROCITY_TOL
    );
    let worst = r.worst.map(|(wi, wo, a, b)| {
        format!(
            "worst pair: wi = ({:.4}, {:.4}, {:.4}), wo = ({:.4}, {:.4}, {:.4}): f(wi, wo) = {:?}, f(wo, wi) = {:?}",
            wi.x, wi.y, wi.z, wo.x, wo.y, wo.z, a.0, b.0
        )
    });
    match mode {
        Reciprocity::Skip(reason) => CheckOutcome {
            name,
            verdict: Verdict::Skip,
            summary: format!("not judged: {reason}; {figures}"),
            details: vec![],
        },
        _ => {
            let ok = r.max_rel_err <= RECIPROCITY_TOL;
            let note = match mode {
                Reciprocity::Substitute { note, .. } => format!(" [{note}]"),
                _ => String::new(),
            };
            CheckOutcome {
                name,
                verdict: if ok { Verdict::Pass } else { Verdict::Fail },
                summary: format!("{figures}{note}"),
                details: if ok {
                    vec![]
                } else {
                    worst.into_iter().collect()
                },
            }
        }
    }
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

fn energy_outcome(
    angles: &[f32],
    albedos: &[AlbedoResult],
    alpha: f64,
    channel_names: &[String; 3],
) -> CheckOutcome {
    // one-sided test of H0: albedo ≤ 1 (+ rounding) per angle and channel
    let mut worst_p = (f64::INFINITY, 0, 0);
    let mut largest = (f64::NEG_INFINITY, 0, 0);
    let mut details = Vec::new();
    for (i, a) in albedos.iter().enumerate() {
        for (c, channel) in channel_names.iter().enumerate() {
            let (m, se) = (a.mean[c] as f64, a.std_err[c] as f64);
            let excess = m - 1.0 - ALBEDO_ROUNDING;
            let p = if se > 0.0 {
                normal_sf(excess / se)
            } else if excess > 0.0 {
                0.0
            } else {
                1.0
            };
            if p < worst_p.0 {
                worst_p = (p, i, c);
            }
            if m > largest.0 {
                largest = (m, i, c);
            }
            if p < alpha {
                details.push(format!(
                    "θi = {}: albedo ({}) {:.5} ± {} exceeds 1 (p = {})",
                    fmt_deg(angles[i]),
                    channel,
                    m,
                    fmt_se(se),
                    fmt_p(p)
                ));
            }
        }
    }
    if details.len() > 4 {
        let more = details.len() - 3;
        details.truncate(3);
        details.push(format!("… and {more} more angle/channel combinations"));
    }
    let (m, i, c) = largest;
    let a = &albedos[i];
    CheckOutcome {
        name: "energy",
        verdict: if details.is_empty() {
            Verdict::Pass
        } else {
            Verdict::Fail
        },
        summary: format!(
            "largest albedo {:.4} ± {} ({}) at θi = {}; min p = {} (at θi = {}, {}) vs α = {:.2e}",
            m,
            fmt_se(a.std_err[c] as f64),
            channel_names[c],
            fmt_deg(angles[i]),
            fmt_p(worst_p.0),
            fmt_deg(angles[worst_p.1]),
            channel_names[worst_p.2],
            alpha
        ),
        details,
    }
}

fn sampling_outcome(
    angles: &[f32],
    results: &[JobResult],
    alpha: f64,
    bins: (usize, usize),
) -> CheckOutcome {
    let mut ps = Vec::new();
    let mut details = Vec::new();
    let mut lobe = false;
    for (t, r) in angles.iter().zip(results) {
        match r {
            JobResult::Chi2(r) => {
                ps.push(r.p_value);
                if !r.passes(alpha) {
                    details.push(format!(
                        "θi = {}: χ² = {:.1}, dof = {}, p = {}, ∫pdf = {:.5}; worst cells (θ bin, φ bin, observed, expected): {}",
                        fmt_deg(*t),
                        r.statistic,
                        r.dof,
                        fmt_p(r.p_value),
                        r.pdf_integral,
                        r.worst
                            .iter()
                            .take(3)
                            .map(|(a, b, o, e)| if *a == usize::MAX {
                                format!("(pooled/Dirac, {o:.0}, {e:.1})")
                            } else {
                                format!("({a}, {b}, {o:.0}, {e:.1})")
                            })
                            .collect::<Vec<_>>()
                            .join(" ")
                    ));
                }
            }
            JobResult::Lobe(r) => {
                lobe = true;
                ps.push(r.p_value);
                if !r.passes(alpha) {
                    details.push(format!(
                        "θi = {}: reflected {:.5} of {} samples, the model states {:.5} (p = {})",
                        fmt_deg(*t),
                        r.observed_fraction(),
                        r.samples,
                        r.expected_fraction,
                        fmt_p(r.p_value)
                    ));
                }
            }
            _ => unreachable!("sampling jobs give χ² or lobe results"),
        }
    }
    let min_p = ps.iter().copied().fold(f64::INFINITY, f64::min);
    let list = ps.iter().map(|p| fmt_p(*p)).collect::<Vec<_>>().join(" ");
    let summary = if lobe {
        format!(
            "Dirac lobes only: binomial test of reflect/refract frequency, p = {list}; min {} vs α = {alpha:.2e}",
            fmt_p(min_p)
        )
    } else {
        format!(
            "χ² p = {list}; min {} vs α = {alpha:.2e} ({}×{} θ×φ bins)",
            fmt_p(min_p),
            bins.0,
            bins.1
        )
    };
    CheckOutcome {
        name: if lobe {
            "lobe-selection"
        } else {
            "sampling-chi2"
        },
        verdict: if details.is_empty() {
            Verdict::Pass
        } else {
            Verdict::Fail
        },
        summary,
        details,
    }
}

fn consistency_outcome(
    angles: &[f32],
    results: &[Box<[ConsistencyResult; 2]>],
    all_delta: bool,
) -> CheckOutcome {
    let name = "sample-weights";
    if all_delta {
        return CheckOutcome {
            name,
            verdict: Verdict::Skip,
            summary: "all lobes are Dirac deltas: no f or pdf to compare the weights with".into(),
            details: vec![],
        };
    }
    let (mut we, mut pe, mut samples) = (0.0f64, 0.0f64, 0usize);
    let mut details = Vec::new();
    for (t, pair) in angles.iter().zip(results) {
        for (mode, r) in ["radiance", "importance"].iter().zip(pair.iter()) {
            we = we.max(r.max_weight_err);
            pe = pe.max(r.max_pdf_err);
            samples += r.samples;
            if r.max_weight_err > CONSISTENCY_TOL || r.max_pdf_err > CONSISTENCY_TOL {
                details.push(format!(
                    "θi = {} ({mode}): weight error {:.2e}, pdf error {:.2e}; {}",
                    fmt_deg(*t),
                    r.max_weight_err,
                    r.max_pdf_err,
                    r.worst.clone().unwrap_or_default()
                ));
            }
        }
    }
    CheckOutcome {
        name,
        verdict: if details.is_empty() {
            Verdict::Pass
        } else {
            Verdict::Fail
        },
        summary: format!(
            "max relative error: weight vs f·|cosθo|/pdf {we:.2e}, sampled pdf vs pdf() {pe:.2e} over {samples} samples (tolerance {CONSISTENCY_TOL:.0e})"
        ),
        details,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_resolution_is_odd_and_bounded() {
        for n in [1, 1000, 200_000, 1_000_000, 100_000_000] {
            let (t, p) = chi2_resolution(n);
            assert!(
                t % 2 == 1 && p % 2 == 1 && (11..=101).contains(&t),
                "{n}: {t}×{p}"
            );
        }
        assert_eq!(chi2_resolution(1_000_000), (101, 201));
    }

    #[test]
    fn seeds_differ_per_test() {
        let mut s: Vec<u64> = (0..3)
            .flat_map(|tag| (0..8).map(move |i| derive_seed(1, tag, i)))
            .collect();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), 24);
    }
}
