//! Adaptive sampling (`specula render --adaptive`; Specula's own, Mitsuba has none): the same
//! number of samples in total, spent where the image is still noisy.
//!
//! A pixel's error falls as 1/n with its sample count n, so the total relative squared error
//! Σⱼ eⱼ/nⱼ of an image whose pixel j has error eⱼ at one sample is least, for a fixed budget
//! Σⱼ nⱼ, when nⱼ ∝ √eⱼ. The render runs in two passes:
//!
//! 1. **Pilot.** Every pixel takes n₀ samples (a quarter of the budget, rounded down to a power
//!    of two so that a progressive sampler's prefix is a net). Besides the film, each pixel keeps
//!    the sums of its own sample values over the first and the second half of them. The two
//!    half means A and B estimate the pilot's error as |A − B|²/4 — the error of the estimator
//!    the sampler actually gives (a low-discrepancy sampler converges faster than 1/n on an
//!    edge or a smooth gradient; the samples' variance would not see that) — made relative as
//!    the relMSE metric does: ÷ (m² + 0.01) with m the pixel's mean (Rousselle et al. 2011), and
//!    averaged over the channels. One pixel's estimate has one degree of freedom, so it is
//!    smoothed over the 5 × 5 pixels around it (a box filter).
//! 2. **Adaptive pass.** The rest of the budget is shared out: nⱼ ∝ √eⱼ, raised so that no
//!    pixel takes fewer than half its neighbours' counts, clamped to [n₀ + 1, 16·spp], scaled
//!    (bisection) so that Σ nⱼ = spp × pixels, rounded with the remainder carried along each
//!    row. Pixel j takes its samples n₀ … nⱼ − 1 (the sampler continues where the pilot
//!    stopped), each splatted with weight 1/(nⱼ − n₀). This pass runs on 8 × 8 tiles, so
//!    that the threads share unequal pixels evenly to the end.
//!
//! **Why the weights, and why two films.** The film splats each sample into the pixels around
//! it (the reconstruction filter). Were samples weighted equally, a pixel next to a densely
//! sampled one would lean towards its neighbour's radiance: the expected image would depend on
//! the sample density. Weighting each of pixel j's samples by 1/(its count) makes every pixel
//! contribute the same total weight, so the adaptive pass's film Q has the uniform render's
//! expected value; so has the pilot's film P (uniform weights). The image is the blend
//! α·P + (1 − α)·Q per pixel with inverse-variance weights: α = Var Q/(Var P + Var Q), the
//! variances computed from the filter's weights over the neighbouring pixels and their counts
//! (`pilot_share`; α = n₀/nⱼ where the counts are locally even).
//!
//! **What it is not.** The allocation depends on the pilot's values, so the estimate is
//! consistent rather than unbiased (the dependence is through a 25-pixel average and vanishes
//! as the budget grows; the same holds for every adaptive renderer). Renders stay deterministic
//! and independent of the thread count. It needs a progressive sampler (`sobol`, the default,
//! or `independent`); below 8 samples per pixel it renders uniformly (a pilot of fewer than two
//! samples cannot measure anything).

use crate::film::{Film, RFilter};
use crate::render::{
    in_pool, output, render_pass, render_with, tiles, Pass, PassSettings, PixelSamples, PixelStats,
    RenderOptions, RenderOutput, TILE,
};
use crate::sampler::{Independent, PixelSampler, SamplerKind, Sobol};
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

/// The offset ε of the relative error, (error)² / (m² + ε) (the relMSE of Rousselle et al.
/// 2011 and of `../shared/README.md`).
pub const RELATIVE_EPSILON: f32 = 0.01;
/// The most samples one pixel may take, as a multiple of the mean.
pub const MAX_FACTOR: u32 = 16;
/// Half the width of the box that smooths the per-pixel error estimates.
const SMOOTH_RADIUS: usize = 2;
/// The adaptive pass's tile edge: its pixels take from n₀ + 1 to 16·spp samples, so its tiles
/// are small for the threads to share the work evenly to the end.
const SMALL_TILE: usize = 8;
/// The smallest mean sample count that is rendered adaptively.
pub const MIN_SPP: u32 = 8;

/// The pilot's sample count for a mean of `spp`: the largest power of two ≤ spp/4.
pub fn pilot_spp(spp: u32) -> u32 {
    let q = (spp / 4).max(1);
    1 << (31 - q.leading_zeros())
}

/// Renders `scene` with `opts.spp` samples per pixel on average, spent adaptively (see the
/// module's docs). Errors when the scene's sampler is not progressive.
pub fn render_adaptive(
    scene: &Scene,
    opts: &RenderOptions,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<RenderOutput, String> {
    match scene.sampler.kind {
        SamplerKind::Sobol => Ok(adaptive_with::<Sobol>(scene, opts, stop, progress)),
        SamplerKind::Independent => Ok(adaptive_with::<Independent>(scene, opts, stop, progress)),
        k => Err(format!(
            "adaptive sampling needs a progressive sampler (sobol or independent); the scene's \
             is '{}' (pass --sampler sobol)",
            k.name()
        )),
    }
}

fn adaptive_with<S: PixelSampler>(
    scene: &Scene,
    opts: &RenderOptions,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> RenderOutput {
    let spp = opts.spp.max(1);
    if spp < MIN_SPP {
        return render_with::<S>(scene, opts, stop, progress);
    }
    let start = Instant::now();
    let (fw, fh) = (scene.film.width, scene.film.height);
    let ntiles = tiles(scene, TILE).len();
    let small = tiles(scene, SMALL_TILE).len();
    let n0 = pilot_spp(spp);
    let pilot_plan = |_| PixelSamples {
        first: 0,
        count: n0,
        weight: 1.0,
    };
    let settings = PassSettings {
        sampler_spp: spp.saturating_mul(MAX_FACTOR),
        differential_spp: spp,
        seed: opts.seed,
        stats_half: Some(n0 / 2),
        tile: TILE,
    };
    in_pool(opts.threads, || {
        let pilot = render_pass::<S, _>(scene, settings, &pilot_plan, stop, &|n| {
            progress(n, 2 * ntiles)
        });
        let counts = if pilot.complete {
            allocate(&pilot, fw, fh, spp, n0)
        } else {
            vec![n0; fw * fh]
        };
        let plan = |j: usize| {
            let extra = counts[j] - n0;
            PixelSamples {
                first: n0,
                count: extra,
                weight: if extra > 0 { 1.0 / extra as f32 } else { 0.0 },
            }
        };
        let second = if pilot.complete {
            let s = PassSettings {
                stats_half: None,
                tile: SMALL_TILE,
                ..settings
            };
            render_pass::<S, _>(scene, s, &plan, stop, &|n| {
                progress(ntiles + n * ntiles / small, 2 * ntiles)
            })
        } else {
            Pass {
                film: scene.film.clone(),
                aov_films: Vec::new(),
                counters: Default::default(),
                complete: false,
                errors: Vec::new(),
            }
        };
        let mut alpha = pilot_share(&scene.film.filter, &counts, fw, fh, n0);
        if !second.complete {
            // interrupted: where the second pass left nothing, the pilot alone
            for (a, &w) in alpha.iter_mut().zip(second.film.weights()) {
                if w == 0.0 {
                    *a = 1.0;
                }
            }
        }
        let (rgb, overflowed) = blend(
            &pilot.film.develop_counting(),
            &second.film.develop_counting(),
            &alpha,
        );
        let aovs = pilot
            .aov_films
            .iter()
            .enumerate()
            .map(|(k, p)| {
                // no second pass (interrupted pilot): α = 1, the pilot alone
                let p = p.develop_counting();
                let q = second.aov_films.get(k).map(Film::develop_counting);
                blend(&p, q.as_ref().unwrap_or(&p), &alpha).0
            })
            .collect();
        let mut counters = pilot.counters;
        counters.add(&second.counters);
        output(
            scene,
            (rgb, overflowed),
            aovs,
            counters,
            start,
            pilot.complete && second.complete,
            spp,
        )
    })
}

/// α·P + (1 − α)·Q per pixel of two developed RGB images; a pixel that overflowed in either
/// film is black and counted.
fn blend(
    (p, p_over): &(Vec<f32>, usize),
    (q, q_over): &(Vec<f32>, usize),
    alpha: &[f32],
) -> (Vec<f32>, usize) {
    let mut out = vec![0.0f32; p.len()];
    let mut overflowed = 0;
    let pixels = out
        .chunks_exact_mut(3)
        .zip(p.chunks_exact(3))
        .zip(q.chunks_exact(3));
    for (((o, p), q), &a) in pixels.zip(alpha) {
        for c in 0..3 {
            o[c] = a * p[c] + (1.0 - a) * q[c];
        }
        if !o.iter().all(|v| v.is_finite()) {
            o.fill(0.0);
            overflowed += 1;
        }
    }
    (out, overflowed.max(*p_over).max(*q_over))
}

impl PixelStats {
    /// The pixel's relative squared error at the pilot's sample count, from its two half
    /// means A and B: |A − B|²/4 ÷ (m² + ε) averaged over the channels (m = the pixel's mean);
    /// 0 where a half has no finite sample or the value is not finite.
    pub(crate) fn relative_error(&self) -> f32 {
        let (na, nb) = (self.n[0] as f32, self.n[1] as f32);
        if na == 0.0 || nb == 0.0 {
            return 0.0;
        }
        let mut e = 0.0;
        for c in 0..3 {
            let (a, b) = (self.sum[0][c] / na, self.sum[1][c] / nb);
            let m = (self.sum[0][c] + self.sum[1][c]) / (na + nb);
            // the variance of A − B is 4× that of the mean (equal halves)
            e += (a - b) * (a - b) / 4.0 / (m * m + RELATIVE_EPSILON);
        }
        let e = e / 3.0;
        if e.is_finite() {
            e
        } else {
            0.0
        }
    }
}

/// A (2r + 1)² box filter over a `w` × `h` image (clamped at the borders: each output is the
/// mean of the pixels of its box that lie on the film).
fn smooth(v: &[f32], w: usize, h: usize, r: usize) -> Vec<f32> {
    let pass = |src: &[f32], stride_out: usize, len: usize, lines: usize, along: usize| {
        // 1D box along an axis: `along` = 1 for rows, w for columns
        let mut out = vec![0.0f32; src.len()];
        for line in 0..lines {
            let base = line * stride_out;
            for i in 0..len {
                let (lo, hi) = (i.saturating_sub(r), (i + r).min(len - 1));
                let mut s = 0.0f64;
                for k in lo..=hi {
                    s += src[base + k * along] as f64;
                }
                out[base + i * along] = (s / (hi - lo + 1) as f64) as f32;
            }
        }
        out
    };
    let rows = pass(v, w, w, h, 1);
    pass(&rows, 1, h, w, w)
}

/// How many samples each pixel takes in all (row-major), from the pilot's statistics: pixel
/// j's relative error eⱼ (smoothed) gives nⱼ ∝ √eⱼ (the least Σ eⱼ/nⱼ for Σ nⱼ fixed), spread
/// so that no pixel takes fewer than half its neighbours' counts (a sparse neighbour would
/// otherwise dominate the noise of a dense pixel's filtered value), clamped to
/// [n₀ + 1, 16·spp] and scaled (bisection) so that Σ nⱼ = spp × pixels. Rounded with the
/// remainder carried along the scan, so the total is kept to within one sample.
fn allocate(pilot: &Pass, w: usize, h: usize, spp: u32, n0: u32) -> Vec<u32> {
    let error = smooth(&pilot.errors, w, h, SMOOTH_RADIUS);
    let mut score: Vec<f32> = error.iter().map(|&e| e.max(0.0).sqrt()).collect();
    for _ in 0..SMOOTH_RADIUS {
        score = spread(&score, w, h, 0.5);
    }
    counts_for(&score, spp, n0)
}

/// nⱼ = clamp(λ·scoreⱼ, n₀ + 1, 16·spp) with Σ nⱼ = spp × pixels (see [`allocate`]); uniform
/// where every score is 0.
fn counts_for(score: &[f32], spp: u32, n0: u32) -> Vec<u32> {
    let s: Vec<f64> = score.iter().map(|&x| x as f64).collect();
    let n = s.len();
    let (lo, hi) = ((n0 + 1) as f64, spp.saturating_mul(MAX_FACTOR) as f64);
    let total = |lambda: f64| -> f64 {
        s.par_chunks(4096)
            .map(|s| s.iter().map(|&x| (lambda * x).clamp(lo, hi)).sum::<f64>())
            .collect::<Vec<f64>>()
            .iter()
            .sum()
    };
    let budget = spp as f64 * n as f64;
    let sum_s: f64 = s.iter().sum();
    if !(sum_s > 0.0 && sum_s.is_finite()) {
        return vec![spp; n];
    }
    // total(λ) rises from lo·n to hi·n as λ grows; bisect on λ in log space
    let (mut a, mut b) = (budget / sum_s * 1e-9, budget / sum_s * 1e9);
    for _ in 0..100 {
        let m = (a * b).sqrt();
        if total(m) < budget {
            a = m;
        } else {
            b = m;
        }
    }
    let mut out = Vec::with_capacity(n);
    let (mut want, mut given) = (0.0f64, 0.0f64);
    for &x in &s {
        want += (b * x).clamp(lo, hi);
        let k = (want - given).round().clamp(lo, hi);
        given += k;
        out.push(k as u32);
    }
    out
}

/// Each value raised to at least `ratio` × the largest of its 3 × 3 neighbours'.
fn spread(v: &[f32], w: usize, h: usize, ratio: f32) -> Vec<f32> {
    let mut out = v.to_vec();
    for y in 0..h {
        for x in 0..w {
            let mut m = 0.0f32;
            for yy in y.saturating_sub(1)..=(y + 1).min(h - 1) {
                for xx in x.saturating_sub(1)..=(x + 1).min(w - 1) {
                    m = m.max(v[yy * w + xx]);
                }
            }
            let o = &mut out[y * w + x];
            *o = o.max(ratio * m);
        }
    }
    out
}

/// The pilot's share α of each pixel's blend α·P + (1 − α)·Q: inverse-variance weights. P's
/// value at pixel p averages its neighbours' n₀ samples each, with the weights W_pk the
/// reconstruction filter gives pixel k (its integral over pixel k); Q's averages their
/// nₖ − n₀ samples with the same total weights. For one variance σ² per sample,
/// Var P ∝ Σ W²/n₀ and Var Q ∝ Σ W²/(nₖ − n₀), so α = Var Q / (Var P + Var Q).
fn pilot_share(filter: &RFilter, counts: &[u32], w: usize, h: usize, n0: u32) -> Vec<f32> {
    // 1D weights of the pixels at offsets −r … r: the filter integrated over each
    let r = (filter.radius() + 0.5).ceil() as i64;
    let g: Vec<f64> = (-r..=r)
        .map(|d| {
            if let RFilter::Box = filter {
                return if d == 0 { 1.0 } else { 0.0 };
            }
            (0..64)
                .map(|i| filter.eval(d as f32 + (i as f32 + 0.5) / 64.0 - 0.5) as f64)
                .sum::<f64>()
                / 64.0
        })
        .collect();
    let mut alpha = vec![0.0f32; w * h];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let (mut sum_w2, mut sum_w2_q) = (0.0f64, 0.0f64);
            for dy in -r..=r {
                let yy = y + dy;
                if yy < 0 || yy >= h as i64 {
                    continue;
                }
                for dx in -r..=r {
                    let xx = x + dx;
                    if xx < 0 || xx >= w as i64 {
                        continue;
                    }
                    let wk = g[(dx + r) as usize] * g[(dy + r) as usize];
                    let extra = counts[yy as usize * w + xx as usize].saturating_sub(n0);
                    sum_w2 += wk * wk;
                    if extra > 0 {
                        sum_w2_q += wk * wk / extra as f64;
                    } else if wk > 0.0 {
                        sum_w2_q = f64::INFINITY;
                    }
                }
            }
            let var_p = sum_w2 / n0 as f64;
            alpha[y as usize * w + x as usize] = if sum_w2_q.is_finite() {
                (sum_w2_q / (var_p + sum_w2_q)) as f32
            } else {
                1.0
            };
        }
    }
    alpha
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pilot_counts_are_powers_of_two() {
        assert_eq!(pilot_spp(8), 2);
        assert_eq!(pilot_spp(16), 4);
        assert_eq!(pilot_spp(64), 16);
        assert_eq!(pilot_spp(100), 16);
        assert_eq!(pilot_spp(128), 32);
    }

    #[test]
    fn relative_error_from_half_means() {
        let mut s = PixelStats::default();
        // no samples: no information
        assert_eq!(s.relative_error(), 0.0);
        // halves of 2 samples with means 1 and 3 in every channel: |A − B|²/4 = 1, m = 2
        s.sum = [[2.0; 3], [6.0; 3]];
        s.n = [2, 2];
        let want = 1.0 / (4.0 + RELATIVE_EPSILON);
        assert!((s.relative_error() - want).abs() < 1e-7);
        // equal halves: no error seen; a black pixel with noise: ÷ ε
        s.sum = [[4.0; 3], [4.0; 3]];
        assert_eq!(s.relative_error(), 0.0);
        s.sum = [[0.2, 0.0, 0.0], [-0.2, 0.0, 0.0]];
        let want = (0.1f32 * 0.1) / RELATIVE_EPSILON / 3.0;
        assert!((s.relative_error() - want).abs() < 1e-6);
        s.sum[0][1] = f32::INFINITY;
        assert_eq!(s.relative_error(), 0.0);
    }

    #[test]
    fn counts_keep_the_budget_and_follow_the_scores() {
        let (spp, n0) = (16, 4);
        // scores 1 … 1000 in a ramp, one zero
        let score: Vec<f32> = (0..1000).map(|i| i as f32).collect();
        let n = counts_for(&score, spp, n0);
        let total: u64 = n.iter().map(|&k| k as u64).sum();
        assert!(total.abs_diff(16 * 1000) <= 1, "{total}");
        assert!(n.iter().all(|&k| (n0 + 1..=16 * spp).contains(&k)));
        // unclamped counts are proportional to the score (up to rounding)
        let (a, b) = (n[400] as f32, n[800] as f32);
        assert!((b / a - 2.0).abs() < 0.02, "{a} {b}");
        assert_eq!(n[0], n0 + 1);
        // no information: uniform
        assert_eq!(counts_for(&[0.0; 10], spp, n0), vec![spp; 10]);
        // one hot pixel is capped at 16·spp, the rest share what is left
        let mut one = vec![1e-6f32; 100];
        one[7] = 1.0;
        let n = counts_for(&one, spp, n0);
        assert_eq!(n[7], 16 * spp);
        let total: u64 = n.iter().map(|&k| k as u64).sum();
        assert!(total.abs_diff(16 * 100) <= 1, "{total}");
    }

    #[test]
    fn box_smoothing_and_spreading() {
        // a single 25 at the centre of 5 × 5 becomes 1 everywhere within radius 2
        let mut v = vec![0.0f32; 25];
        v[12] = 25.0;
        let s = smooth(&v, 5, 5, 2);
        assert!((s[12] - 1.0).abs() < 1e-6, "{}", s[12]);
        // a corner's box holds 3 × 3 on-film pixels: 25/9
        assert!((s[0] - 25.0 / 9.0).abs() < 1e-5, "{}", s[0]);
        let sum: f32 = smooth(&[1.0; 35], 7, 5, 2).iter().sum();
        assert!((sum - 35.0).abs() < 1e-4);
        // spreading: neighbours of an 8 rise to 4, others keep their value
        let mut v = vec![1.0f32; 25];
        v[12] = 8.0;
        let s = spread(&v, 5, 5, 0.5);
        assert_eq!(s[12], 8.0);
        assert_eq!(s[6], 4.0);
        assert_eq!(s[0], 1.0);
    }

    #[test]
    fn pilot_share_is_the_inverse_variance_weight() {
        // equal counts everywhere: Var P ∝ 1/n₀, Var Q ∝ 1/(n − n₀), so α = n₀/n
        let f = RFilter::default();
        let a = pilot_share(&f, &[20; 64], 8, 8, 4);
        assert!(a.iter().all(|&a| (a - 0.2).abs() < 1e-6), "{a:?}");
        let a = pilot_share(&RFilter::Box, &[12; 16], 4, 4, 4);
        assert!(a.iter().all(|&a| (a - 1.0 / 3.0).abs() < 1e-6));
        // a pixel next to a sparse one leans on its pilot more than its own count says
        let mut c = vec![100u32; 64];
        c[27] = 5;
        let a = pilot_share(&f, &c, 8, 8, 4);
        assert!(a[28] > 4.0 / 100.0 * 1.5, "{}", a[28]);
        assert!((a[0] - 0.04).abs() < 1e-6);
    }
}
