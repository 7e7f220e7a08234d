//! Physical property checks: reciprocity, energy conservation, consistency of `sample` with
//! `eval`/`pdf`, and non-negativity/finiteness on random and degenerate inputs.

use crate::bsdf::{BsdfContext, BsdfModel, ShadingPoint};
use crate::rng::Pcg32;
use crate::spectrum::Spectrum;
use crate::warp::square_to_uniform_sphere;
use glam::{Vec2, Vec3};

fn rel_err(a: f32, b: f32) -> f64 {
    let (a, b) = (a as f64, b as f64);
    let m = a.abs().max(b.abs());
    if m == 0.0 {
        0.0
    } else {
        (a - b).abs() / m
    }
}

fn rel_err_rgb(a: Spectrum, b: Spectrum) -> f64 {
    (0..3).map(|i| rel_err(a[i], b[i])).fold(0.0, f64::max)
}

/// A random direction, uniform on the sphere, or on the upper hemisphere when `upper`.
fn random_dir(rng: &mut Pcg32, upper: bool) -> Vec3 {
    let w = square_to_uniform_sphere(rng.next_vec2());
    if upper {
        Vec3::new(w.x, w.y, w.z.abs())
    } else {
        w
    }
}

/// Result of [`reciprocity`].
#[derive(Clone, Debug, Default)]
pub struct ReciprocityResult {
    pub pairs: usize,
    /// Largest relative difference over the pairs where the BSDF is non-negligible.
    pub max_rel_err: f64,
    pub worst: Option<(Vec3, Vec3, Spectrum, Spectrum)>,
}

/// Helmholtz reciprocity over random pairs of directions.
///
/// Reflection pairs must satisfy f(wi, wo) = f(wo, wi). Transmission pairs (on opposite
/// sides) of a dielectric interface with relative index `eta` must satisfy the generalised
/// relation f(wi, wo)/n(wi)² = f(wo, wi)/n(wo)² for radiance transport (Veach 1997, §5.2),
/// where n(w) is the index on the side of w (1 above, `eta` below). Pairs where both values are below
/// `1e-6 × (largest value seen)` are skipped: there relative error measures float noise.
pub fn reciprocity<B: BsdfModel + ?Sized>(
    bsdf: &B,
    sp: &ShadingPoint,
    eta: Option<f32>,
    pairs: usize,
    seed: u64,
) -> ReciprocityResult {
    reciprocity_channels(bsdf, sp, eta.map(|e| [e; 3]), pairs, seed)
}

/// [`reciprocity`] with a relative index per channel (a dispersive material in spectral
/// mode, where channel j refracts with its own η_j).
pub fn reciprocity_channels<B: BsdfModel + ?Sized>(
    bsdf: &B,
    sp: &ShadingPoint,
    eta: Option<[f32; 3]>,
    pairs: usize,
    seed: u64,
) -> ReciprocityResult {
    let ctx = BsdfContext::RADIANCE;
    let mut rng = Pcg32::new(seed, 7);
    let two_sided = eta.is_some() || bsdf.flags().has_transmission();
    let mut vals = Vec::with_capacity(pairs);
    for _ in 0..pairs {
        let wi = random_dir(&mut rng, !two_sided);
        let wo = random_dir(&mut rng, !two_sided);
        let mut a = bsdf.eval(&ctx, sp, wi, wo);
        let mut b = bsdf.eval(&ctx, sp, wo, wi);
        if wi.z * wo.z < 0.0 {
            let e = eta.unwrap_or([1.0; 3]);
            for (c, &ec) in e.iter().enumerate() {
                let n = |w: Vec3| if w.z > 0.0 { 1.0 } else { ec };
                a.0[c] /= n(wi) * n(wi);
                b.0[c] /= n(wo) * n(wo);
            }
        }
        vals.push((wi, wo, a, b));
    }
    let scale = vals
        .iter()
        .map(|v| v.2.max_component().max(v.3.max_component()))
        .fold(0.0f32, f32::max);
    let mut r = ReciprocityResult {
        pairs,
        ..Default::default()
    };
    for (wi, wo, a, b) in vals {
        if a.max_component().max(b.max_component()) < 1e-6 * scale {
            continue;
        }
        let e = rel_err_rgb(a, b);
        if e > r.max_rel_err {
            r.max_rel_err = e;
            r.worst = Some((wi, wo, a, b));
        }
    }
    r
}

/// Result of [`albedo`].
#[derive(Clone, Copy, Debug)]
pub struct AlbedoResult {
    /// Directional albedo ∫ f |cosθo| dωo (Dirac lobes included) per channel.
    pub mean: Spectrum,
    /// Standard error of the estimate per channel.
    pub std_err: Spectrum,
}

/// Directional albedo for incidence `wi`, estimated with the model's own importance sampling
/// (the mean sample weight; trustworthy once the χ² test has validated the sampler).
pub fn albedo<B: BsdfModel + ?Sized>(
    bsdf: &B,
    ctx: &BsdfContext,
    sp: &ShadingPoint,
    wi: Vec3,
    samples: usize,
    seed: u64,
) -> AlbedoResult {
    let mut rng = Pcg32::new(seed, 11);
    let (mut s1, mut s2) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..samples {
        let u1 = rng.next_f32();
        let u2 = rng.next_vec2();
        if let Some(s) = bsdf.sample(ctx, sp, wi, u1, u2) {
            for c in 0..3 {
                let v = s.weight[c] as f64;
                s1[c] += v;
                s2[c] += v * v;
            }
        }
    }
    let n = samples as f64;
    let mean = s1.map(|v| v / n);
    let var = [0, 1, 2].map(|c| (s2[c] / n - mean[c] * mean[c]).max(0.0));
    AlbedoResult {
        mean: Spectrum::new(mean[0] as f32, mean[1] as f32, mean[2] as f32),
        std_err: Spectrum::new(
            (var[0] / n).sqrt() as f32,
            (var[1] / n).sqrt() as f32,
            (var[2] / n).sqrt() as f32,
        ),
    }
}

/// Result of [`sample_consistency`].
#[derive(Clone, Debug, Default)]
pub struct ConsistencyResult {
    pub samples: usize,
    /// max relative |weight − eval·|cosθo|/pdf| over non-Dirac samples.
    pub max_weight_err: f64,
    /// max relative |pdf(wo) − sampled pdf| over non-Dirac samples.
    pub max_pdf_err: f64,
    pub worst: Option<String>,
}

/// Check that `sample`'s weight equals eval·|cosθo|/pdf and that `pdf(sampled wo)` equals the
/// pdf `sample` reported, for every non-Dirac sample.
pub fn sample_consistency<B: BsdfModel + ?Sized>(
    bsdf: &B,
    ctx: &BsdfContext,
    sp: &ShadingPoint,
    wi: Vec3,
    samples: usize,
    seed: u64,
) -> ConsistencyResult {
    let mut rng = Pcg32::new(seed, 13);
    let mut r = ConsistencyResult {
        samples,
        ..Default::default()
    };
    let mut worst = 0.0;
    for _ in 0..samples {
        let u1 = rng.next_f32();
        let u2 = rng.next_vec2();
        let Some(s) = bsdf.sample(ctx, sp, wi, u1, u2) else {
            continue;
        };
        if s.lobe.is_delta() {
            continue;
        }
        let pdf = bsdf.pdf(ctx, sp, wi, s.wo);
        let expect_w = bsdf.eval(ctx, sp, wi, s.wo) * (s.wo.z.abs() / s.pdf);
        let ew = rel_err_rgb(s.weight, expect_w);
        let ep = rel_err(pdf, s.pdf);
        r.max_weight_err = r.max_weight_err.max(ew);
        r.max_pdf_err = r.max_pdf_err.max(ep);
        if ew.max(ep) > worst {
            worst = ew.max(ep);
            r.worst = Some(format!(
                "wi={wi:?} wo={:?} weight={:?} eval·cos/pdf={:?} pdf={} pdf()={}",
                s.wo, s.weight, expect_w, s.pdf, pdf
            ));
        }
    }
    r
}

/// Evaluate, sample and query the pdf on random and degenerate configurations; return the
/// first value that is negative, NaN or infinite.
pub fn finite_nonnegative<B: BsdfModel + ?Sized>(
    bsdf: &B,
    sp: &ShadingPoint,
    trials: usize,
    seed: u64,
) -> Result<usize, String> {
    let mut rng = Pcg32::new(seed, 17);
    let z = Vec3::Z;
    let grazing = Vec3::new(1.0, 0.0, 0.0);
    let near_grazing = Vec3::new(1.0, 0.0, 1e-7).normalize();
    let mut dirs: Vec<(Vec3, Vec3)> = vec![
        (z, z),
        (z, -z),
        (grazing, grazing),
        (grazing, -grazing),
        (grazing, z),
        (z, grazing),
        (near_grazing, near_grazing),
        (
            near_grazing,
            Vec3::new(-near_grazing.x, 0.0, near_grazing.z),
        ),
        (-z, z),
        (-z, -z),
        (Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.6, 0.0, -0.8)),
        (Vec3::new(0.6, 0.0, -0.8), Vec3::new(0.6, 0.0, -0.8)),
    ];
    for _ in 0..trials {
        let a = random_dir(&mut rng, false);
        let b = random_dir(&mut rng, false);
        dirs.push((a, b));
        dirs.push((a, -a));
    }
    let us = [
        Vec2::ZERO,
        Vec2::new(0.999_999_9, 0.999_999_9),
        Vec2::new(0.5, 0.0),
        Vec2::new(0.0, 0.5),
    ];
    let mut checked = 0;
    for ctx in [BsdfContext::RADIANCE, BsdfContext::IMPORTANCE] {
        for (k, &(wi, wo)) in dirs.iter().enumerate() {
            let f = bsdf.eval(&ctx, sp, wi, wo);
            let p = bsdf.pdf(&ctx, sp, wi, wo);
            if !f.is_finite() || f.min_component() < 0.0 {
                return Err(format!("eval(wi={wi:?}, wo={wo:?}) = {f:?}"));
            }
            if !p.is_finite() || p < 0.0 {
                return Err(format!("pdf(wi={wi:?}, wo={wo:?}) = {p}"));
            }
            let u2 = if k < us.len() * 3 {
                us[k % us.len()]
            } else {
                rng.next_vec2()
            };
            for u1 in [0.0, 0.5, 0.999_999_9, rng.next_f32()] {
                if let Some(s) = bsdf.sample(&ctx, sp, wi, u1, u2) {
                    let ok = s.weight.is_finite()
                        && s.weight.min_component() >= 0.0
                        && s.pdf.is_finite()
                        && s.pdf > 0.0
                        && s.wo.is_finite()
                        && (s.wo.length() - 1.0).abs() < 1e-3
                        && s.eta.is_finite()
                        && s.eta > 0.0;
                    if !ok {
                        return Err(format!("sample(wi={wi:?}, u1={u1}, u2={u2:?}) = {s:?}"));
                    }
                }
                checked += 1;
            }
        }
    }
    Ok(checked)
}
