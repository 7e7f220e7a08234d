//! Sample generators: Mitsuba 3's `<sampler>` plugins and one of Specula's own.
//!
//! An integrator sees an infinite-dimensional sample point one piece at a time through
//! [`Sampler::next_1d`] and [`Sampler::next_2d`]. The renderer drives a [`PixelSampler`]: it
//! starts each pixel ([`PixelSampler::start_pixel`]) and each of the pixel's samples at a given
//! dimension ([`PixelSampler::start_sample`]); the camera takes dimension 0 (a 2D film
//! position) and 1 (a thin lens's aperture sample), the integrator dimensions 2 onwards.
//! Every sampler but `independent` is a function of (seed, pixel index, sample index,
//! dimension); `independent` draws from one stream per pixel, in the fixed order the renderer
//! traces the pixel's samples. Either way images do not depend on the thread count.
//!
//! | plugin | parameters (Mitsuba's defaults) | sample count rounded to | design |
//! |---|---|---|---|
//! | `independent` | `sample_count` (4), `seed` (0) | as given | PCG32, one stream per pixel |
//! | `stratified` | + `jitter` (true) | the next square n² | each dimension: the n² strata (1D) or n×n cells (2D) in a per-pixel, per-dimension random order (Kensler's permutation) |
//! | `multijitter` | + `jitter` (true) | ⌊√N⌋ × ⌈N / ⌊√N⌋⌉ | Kensler's correlated multi-jittered sampling (2D and 1D stratified), order shuffled per dimension |
//! | `orthogonal` | + `jitter` (true), `strength` (2) | p² for the next prime p | Jarosz et al.'s orthogonal arrays (Bose construction for strength 2, Bush otherwise), multi-jittered within strata: every pair of dimensions is stratified |
//! | `ldsampler` | `sample_count`, `seed` | the next power of two that is a square (4, 16, 64, …) | Kollig–Keller: the (0,2)-sequence (van der Corput, Sobol) per 2D dimension, XOR-scrambled and shuffled per dimension |
//! | `sobol` (Specula's own) | `sample_count`, `seed` | as given (best at powers of two) | Owen-scrambled Sobol (0,2)-sequence per 2D dimension, its order shuffled by a nested uniform scramble of the index (Burley 2020): progressive, each power-of-two prefix a (0,m,2)-net; the film position and the first light sample form one 4D Owen-scrambled Sobol block |
//!
//! A sensor without `<sampler>` gets `sobol` with Mitsuba's default count (4): Mitsuba would
//! use `independent`; the expected image is the same and its noise lower (for Mitsuba's own
//! noise, name `independent` in the scene or pass `--sampler independent`). A scene's
//! `<sampler>` is always honoured.
//!
//! Deviations from Mitsuba: the sequences are not bit-identical to Mitsuba's (same designs and
//! parameters, different hashing); `seed` offsets the render's seed; the 1D dimensions of
//! `ldsampler` use the van der Corput sequence with a per-dimension scramble (Mitsuba shares one
//! scramble between dimensions); `orthogonal` requires `strength` ≥ 1 and p^strength < 2³².

mod independent;
mod ldsampler;
mod multijitter;
mod orthogonal;
mod sobol;
mod stratified;

pub use independent::Independent;
pub use ldsampler::LowDiscrepancy;
pub use multijitter::MultiJitter;
pub use orthogonal::Orthogonal;
pub use sobol::Sobol;
pub use stratified::Stratified;

use crate::core::{Result, SceneError};
use crate::xml::Node;
use glam::Vec2;
use specula_bsdf::rng::Pcg32;

/// A source of sample values in \[0, 1).
pub trait Sampler {
    fn next_1d(&mut self) -> f32;
    fn next_2d(&mut self) -> Vec2;
    /// Steps over a 1D dimension whose value would not be used: the dimensions after it
    /// get the values they get after `next_1d` (a sampler that can skip the value's
    /// computation overrides this).
    #[inline]
    fn skip_1d(&mut self) {
        self.next_1d();
    }
    /// [`Sampler::skip_1d`] for a 2D dimension.
    #[inline]
    fn skip_2d(&mut self) {
        self.next_2d();
    }
}

/// A PCG32 stream is an independent sampler (dimensions are not tracked).
impl Sampler for Pcg32 {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        self.next_f32()
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        self.next_vec2()
    }
}

/// A sampler the renderer drives pixel by pixel and sample by sample.
pub trait PixelSampler: Sampler + Send {
    /// A sampler for `spp` samples per pixel (already rounded by
    /// [`SamplerSettings::sample_count`]) and the render's `seed`.
    fn new(settings: &SamplerSettings, spp: u32, seed: u64) -> Self;
    /// Start the pixel with linear index `pixel`.
    fn start_pixel(&mut self, pixel: u64);
    /// Continue sample `sample` (< spp) of the current pixel at dimension `dimension`.
    fn start_sample(&mut self, sample: u32, dimension: u32);
    /// Start the pixel with linear index `pixel` for its samples from `first` on: a renderer
    /// that takes a pixel's samples in two passes (adaptive sampling) starts it twice. The
    /// samplers whose values are a function of the sample index need nothing more than
    /// [`PixelSampler::start_pixel`]; `independent`, one stream per pixel, starts another
    /// stream so that the second pass does not repeat the first.
    fn start_pixel_from(&mut self, pixel: u64, first: u32) {
        let _ = first;
        self.start_pixel(pixel);
    }
}

/// Which sampler.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    Independent,
    Stratified,
    MultiJitter,
    Orthogonal,
    LowDiscrepancy,
    Sobol,
}

impl SamplerKind {
    /// Plugin names, as in scene files and `--sampler`.
    pub const NAMES: [&'static str; 6] = [
        "independent",
        "stratified",
        "multijitter",
        "orthogonal",
        "ldsampler",
        "sobol",
    ];

    /// Whether the sampler is progressive: sample i of a pixel does not depend on how many
    /// samples the pixel takes, and any prefix is well distributed (`independent`, `sobol`).
    /// Adaptive sampling needs it; the stratified designs fix their strata by the count.
    pub fn progressive(self) -> bool {
        matches!(self, SamplerKind::Independent | SamplerKind::Sobol)
    }

    pub fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "independent" => SamplerKind::Independent,
            "stratified" => SamplerKind::Stratified,
            "multijitter" => SamplerKind::MultiJitter,
            "orthogonal" => SamplerKind::Orthogonal,
            "ldsampler" => SamplerKind::LowDiscrepancy,
            "sobol" => SamplerKind::Sobol,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Stratified => "stratified",
            SamplerKind::MultiJitter => "multijitter",
            SamplerKind::Orthogonal => "orthogonal",
            SamplerKind::LowDiscrepancy => "ldsampler",
            SamplerKind::Sobol => "sobol",
        }
    }
}

/// A scene's `<sampler>`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplerSettings {
    pub kind: SamplerKind,
    /// `sample_count` as given (see [`SamplerSettings::sample_count`] for what is rendered).
    pub sample_count: u32,
    /// `seed`: added to the render's seed.
    pub seed: u64,
    /// `jitter` (stratified, multijitter, orthogonal).
    pub jitter: bool,
    /// `strength` (orthogonal).
    pub strength: u32,
}

impl Default for SamplerSettings {
    /// What a sensor without `<sampler>` uses: `sobol` with 4 samples (Mitsuba's default is
    /// `independent`, with the same count; the expected image is the same, with less noise).
    fn default() -> Self {
        SamplerSettings::new(SamplerKind::Sobol, 4)
    }
}

impl SamplerSettings {
    pub fn new(kind: SamplerKind, sample_count: u32) -> Self {
        SamplerSettings {
            kind,
            sample_count,
            seed: 0,
            jitter: true,
            strength: 2,
        }
    }

    /// Reads a `<sampler>` node.
    pub fn from_node(n: &Node) -> Result<Self> {
        let kind = SamplerKind::parse(&n.plugin_type).ok_or_else(|| {
            SceneError::new(
                Some(n.loc.clone()),
                format!(
                    "sampler '{}' is not supported (supported: {})",
                    n.plugin_type,
                    SamplerKind::NAMES.join(", ")
                ),
            )
        })?;
        let count = n.int("sample_count", 4)?;
        if !(1..=1 << 24).contains(&count) {
            return Err(SceneError::new(
                Some(n.loc.clone()),
                format!("sample_count must lie in [1, 2^24], got {count}"),
            ));
        }
        let seed = n.int("seed", 0)?;
        let mut s = SamplerSettings::new(kind, count as u32);
        s.seed = seed as u64;
        let mut valid = vec!["sample_count", "seed"];
        if matches!(
            kind,
            SamplerKind::Stratified | SamplerKind::MultiJitter | SamplerKind::Orthogonal
        ) {
            s.jitter = n.bool("jitter", true)?;
            valid.push("jitter");
        }
        if kind == SamplerKind::Orthogonal {
            let strength = n.int("strength", 2)?;
            if !(1..=32).contains(&strength) {
                return Err(SceneError::new(
                    Some(n.loc.clone()),
                    format!("strength must lie in [1, 32], got {strength}"),
                ));
            }
            s.strength = strength as u32;
            valid.push("strength");
        }
        n.check_unused(&valid)?;
        s.check(s.sample_count)
            .map_err(|m| SceneError::new(Some(n.loc.clone()), m))?;
        Ok(s)
    }

    /// Whether `spp` samples (rounded) can be generated; the error says why not.
    pub fn check(&self, spp: u32) -> std::result::Result<(), String> {
        if spp == 0 {
            return Err("the sample count must be positive".into());
        }
        if self.kind == SamplerKind::Orthogonal {
            let p = orthogonal::resolution(spp) as u64;
            if p.checked_pow(self.strength)
                .is_none_or(|n| n > u32::MAX as u64)
            {
                return Err(format!(
                    "orthogonal: {p}^strength ({p}^{}) does not fit in 32 bits",
                    self.strength
                ));
            }
        }
        Ok(())
    }

    /// The number of samples per pixel this sampler takes when asked for `spp` (Mitsuba's
    /// rounding: squares for `stratified`, a near-square grid for `multijitter`, squares of
    /// primes for `orthogonal`, square powers of two for `ldsampler`).
    pub fn sample_count(&self, spp: u32) -> u32 {
        let spp = spp.max(1);
        match self.kind {
            SamplerKind::Independent | SamplerKind::Sobol => spp,
            SamplerKind::Stratified => stratified::resolution(spp).pow(2),
            SamplerKind::MultiJitter => {
                let (x, y) = multijitter::resolution(spp);
                x * y
            }
            SamplerKind::Orthogonal => orthogonal::resolution(spp).pow(2),
            SamplerKind::LowDiscrepancy => ldsampler::resolution(spp).pow(2),
        }
    }
}

/// A 64-bit mix of the seed and the pixel index (SplitMix64 finaliser).
#[inline]
pub fn pixel_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed.wrapping_add(index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A GF(2) generator matrix (`v[k]`: the direction number of index bit k) as byte tables:
/// `t[k][b]` is the XOR of the direction numbers of byte k's set bits when it equals b, with
/// its bits reversed when `reversed`, so that [`xor_bytes`] gives the point (reversed) of an
/// index with four lookups instead of a loop over its bits.
pub(crate) const fn byte_tables(v: &[u32; 32], reversed: bool) -> [[u32; 256]; 4] {
    let mut t = [[0u32; 256]; 4];
    let mut byte = 0;
    while byte < 4 {
        let mut b = 0;
        while b < 256 {
            let mut r = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if b >> bit & 1 != 0 {
                    r ^= v[byte * 8 + bit];
                }
                bit += 1;
            }
            t[byte][b] = if reversed { r.reverse_bits() } else { r };
            b += 1;
        }
        byte += 1;
    }
    t
}

/// The point of index `i` from its matrix's [`byte_tables`].
#[inline]
pub(crate) fn xor_bytes(t: &[[u32; 256]; 4], i: u32) -> u32 {
    t[0][(i & 255) as usize]
        ^ t[1][((i >> 8) & 255) as usize]
        ^ t[2][((i >> 16) & 255) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// A 32-bit hash of two words (for per-dimension seeds).
#[inline]
pub(crate) fn hash2(a: u32, b: u32) -> u32 {
    (pixel_seed(a as u64, b as u64 + 1) >> 32) as u32
}

/// A random jitter in [0, 1) for sample `sample`, dimension `dim`, axis `axis` of the pixel
/// whose hash seed is `h` (random access: independent of the order samples are drawn in).
#[inline]
pub(crate) fn jitter_value(h: u64, sample: u32, dim: u32, axis: u32) -> f32 {
    let key = ((sample as u64) << 32) | (dim as u64) << 1 | axis as u64;
    u32_to_unit((pixel_seed(h, key) >> 32) as u32)
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPS: f32 = 1.0 - f32::EPSILON / 2.0;

/// A 32-bit fixed-point fraction as a float in \[0, 1).
#[inline]
pub(crate) fn u32_to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Kensler's hash-based permutation of \[0, n) ("Correlated Multi-Jittered Sampling", Pixar
/// tech memo 13-01): a bijection on the next power of two, cycle-walked into \[0, n), then
/// rotated by the seed. Returns `i`'s image under the permutation chosen by `seed`.
#[inline]
pub fn permute(mut i: u32, n: u32, seed: u32) -> u32 {
    debug_assert!(n > 0 && i < n);
    if n <= 1 {
        return 0;
    }
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    let p = seed;
    loop {
        i ^= p;
        i = i.wrapping_mul(0xe170893d);
        i ^= p >> 16;
        i ^= (i & w) >> 4;
        i ^= p >> 8;
        i = i.wrapping_mul(0x0929eb3f);
        i ^= p >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | p >> 27);
        i = i.wrapping_mul(0x6935fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dcb303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e501cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            break;
        }
    }
    ((i as u64 + p as u64) % n as u64) as u32
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The first `count` samples of dimensions `dims` (2D) of pixel `pixel`.
    pub fn points<S: PixelSampler>(
        s: &SamplerSettings,
        count: u32,
        pixel: u64,
        dim: u32,
        two_d: bool,
    ) -> Vec<Vec2> {
        let mut smp = S::new(s, count, 7);
        smp.start_pixel(pixel);
        (0..count)
            .map(|i| {
                smp.start_sample(i, dim);
                if two_d {
                    smp.next_2d()
                } else {
                    Vec2::new(smp.next_1d(), 0.5)
                }
            })
            .collect()
    }

    /// `skip_1d` steps over a dimension exactly as `next_1d` does: the values after it are
    /// the same, for every sampler (those overriding it and those that do not).
    fn skip_matches_next<S: PixelSampler>(kind: SamplerKind) {
        let s = SamplerSettings::new(kind, 16);
        let (mut a, mut b) = (S::new(&s, 16, 3), S::new(&s, 16, 3));
        for pixel in [0u64, 77] {
            a.start_pixel(pixel);
            b.start_pixel(pixel);
            for sample in 0..16 {
                a.start_sample(sample, 0);
                b.start_sample(sample, 0);
                for d in 0..12 {
                    if d % 3 == 1 {
                        a.next_1d();
                        b.skip_1d();
                    } else if d % 4 == 2 {
                        a.next_2d();
                        b.skip_2d();
                    } else {
                        assert_eq!(a.next_2d(), b.next_2d(), "{kind:?} {pixel} {sample} {d}");
                    }
                }
                assert_eq!(a.next_1d(), b.next_1d(), "{kind:?}");
            }
        }
    }

    #[test]
    fn skipping_a_dimension_keeps_the_others() {
        skip_matches_next::<Independent>(SamplerKind::Independent);
        skip_matches_next::<Stratified>(SamplerKind::Stratified);
        skip_matches_next::<MultiJitter>(SamplerKind::MultiJitter);
        skip_matches_next::<Orthogonal>(SamplerKind::Orthogonal);
        skip_matches_next::<LowDiscrepancy>(SamplerKind::LowDiscrepancy);
        skip_matches_next::<Sobol>(SamplerKind::Sobol);
    }

    /// Every one of the `n` 1D strata holds exactly one of the values.
    pub fn stratified_1d(v: impl Iterator<Item = f32>, n: usize) -> bool {
        let mut seen = vec![0u32; n];
        for x in v {
            assert!((0.0..1.0).contains(&x), "{x}");
            seen[(x * n as f32) as usize] += 1;
        }
        seen.iter().all(|&c| c == 1)
    }

    /// Every cell of an nx × ny grid holds exactly one point.
    pub fn stratified_2d(p: &[Vec2], nx: usize, ny: usize) -> bool {
        let mut seen = vec![0u32; nx * ny];
        for q in p {
            assert!(q.x >= 0.0 && q.x < 1.0 && q.y >= 0.0 && q.y < 1.0, "{q}");
            seen[(q.y * ny as f32) as usize * nx + (q.x * nx as f32) as usize] += 1;
        }
        seen.iter().all(|&c| c == 1)
    }

    /// Mean of f over the sampler's points in dimensions (d, d+1), averaged over pixels.
    pub fn rms_error<S: PixelSampler>(
        s: &SamplerSettings,
        spp: u32,
        f: impl Fn(Vec2) -> f64,
        exact: f64,
    ) -> f64 {
        let mut smp = S::new(s, spp, 1);
        let mut e2 = 0.0;
        let pixels = 256;
        for px in 0..pixels {
            smp.start_pixel(px);
            let mut acc = 0.0;
            for i in 0..spp {
                smp.start_sample(i, 3);
                acc += f(smp.next_2d());
            }
            e2 += (acc / spp as f64 - exact).powi(2);
        }
        (e2 / pixels as f64).sqrt()
    }

    #[test]
    fn permute_is_a_bijection() {
        for n in [1u32, 2, 3, 7, 16, 25, 100, 1000] {
            for seed in [0u32, 1, 0xdead_beef, 12345] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let j = permute(i, n, seed) as usize;
                    assert!(!seen[j], "n {n} seed {seed}");
                    seen[j] = true;
                }
            }
        }
        // different seeds, different orders
        let a: Vec<u32> = (0..16).map(|i| permute(i, 16, 1)).collect();
        let b: Vec<u32> = (0..16).map(|i| permute(i, 16, 2)).collect();
        assert_ne!(a, b);
    }

    #[test]
    fn sample_counts_round_as_mitsuba() {
        // values printed by Mitsuba 3.9.1's `sample_count()` after loading each plugin
        let cases: [(SamplerKind, &[(u32, u32)]); 4] = [
            (
                SamplerKind::Stratified,
                &[
                    (1, 1),
                    (2, 4),
                    (5, 9),
                    (10, 16),
                    (17, 25),
                    (50, 64),
                    (128, 144),
                ],
            ),
            (
                SamplerKind::MultiJitter,
                &[
                    (2, 2),
                    (3, 3),
                    (5, 6),
                    (10, 12),
                    (17, 20),
                    (50, 56),
                    (128, 132),
                ],
            ),
            (
                SamplerKind::Orthogonal,
                &[(1, 4), (5, 9), (10, 25), (30, 49), (64, 121), (128, 169)],
            ),
            (
                SamplerKind::LowDiscrepancy,
                &[(1, 4), (5, 16), (32, 64), (128, 256), (256, 256)],
            ),
        ];
        for (kind, c) in cases {
            let s = SamplerSettings::new(kind, 4);
            for &(n, want) in c {
                assert_eq!(s.sample_count(n), want, "{kind:?} {n}");
            }
        }
        let s = SamplerSettings::new(SamplerKind::Sobol, 4);
        assert_eq!(s.sample_count(10), 10);
    }

    #[test]
    fn every_sampler_is_a_function_of_pixel_sample_and_dimension() {
        fn check<S: PixelSampler>(kind: SamplerKind) {
            let s = SamplerSettings::new(kind, 16);
            let spp = s.sample_count(16);
            let mut a = S::new(&s, spp, 3);
            let mut b = S::new(&s, spp, 3);
            a.start_pixel(5);
            b.start_pixel(5);
            // b visits the samples in another order: values agree, except for the
            // independent sampler's, which is a plain stream
            let mut va = vec![];
            for i in 0..spp {
                a.start_sample(i, 1);
                va.push((a.next_1d(), a.next_2d()));
            }
            let mut vb = vec![(0.0, Vec2::ZERO); spp as usize];
            for i in (0..spp).rev() {
                b.start_sample(i, 1);
                vb[i as usize] = (b.next_1d(), b.next_2d());
            }
            if kind != SamplerKind::Independent {
                assert_eq!(va, vb, "{kind:?}");
            }
            // another pixel, other values
            b.start_pixel(6);
            b.start_sample(0, 1);
            assert_ne!(va[0].0, b.next_1d(), "{kind:?}");
        }
        check::<Independent>(SamplerKind::Independent);
        check::<Stratified>(SamplerKind::Stratified);
        check::<MultiJitter>(SamplerKind::MultiJitter);
        check::<Orthogonal>(SamplerKind::Orthogonal);
        check::<LowDiscrepancy>(SamplerKind::LowDiscrepancy);
        check::<Sobol>(SamplerKind::Sobol);
    }

    #[test]
    fn stratified_samplers_beat_independent_on_a_smooth_integrand() {
        // ∫∫ x·y² over the unit square = 1/6; an edge (a disc) adds a discontinuity
        let f = |p: Vec2| (p.x as f64) * (p.y as f64).powi(2);
        let disc = |p: Vec2| ((p - Vec2::splat(0.5)).length() < 0.4) as u32 as f64;
        let area = std::f64::consts::PI * 0.16;
        let e = |kind, spp| {
            let s = SamplerSettings::new(kind, spp);
            let n = s.sample_count(spp);
            let run = |f: &dyn Fn(Vec2) -> f64, exact| match kind {
                SamplerKind::Independent => rms_error::<Independent>(&s, n, f, exact),
                SamplerKind::Stratified => rms_error::<Stratified>(&s, n, f, exact),
                SamplerKind::MultiJitter => rms_error::<MultiJitter>(&s, n, f, exact),
                SamplerKind::Orthogonal => rms_error::<Orthogonal>(&s, n, f, exact),
                SamplerKind::LowDiscrepancy => rms_error::<LowDiscrepancy>(&s, n, f, exact),
                SamplerKind::Sobol => rms_error::<Sobol>(&s, n, f, exact),
            };
            (run(&f, 1.0 / 6.0), run(&disc, area))
        };
        let (ind_s, ind_d) = e(SamplerKind::Independent, 64);
        for kind in [
            SamplerKind::Stratified,
            SamplerKind::MultiJitter,
            SamplerKind::Orthogonal,
            SamplerKind::LowDiscrepancy,
            SamplerKind::Sobol,
        ] {
            let (es, ed) = e(kind, 64);
            println!("{kind:?}: smooth {es:.2e} (independent {ind_s:.2e}), disc {ed:.2e} (independent {ind_d:.2e})");
            assert!(es < ind_s / 4.0, "{kind:?}: {es} vs {ind_s}");
            assert!(ed < ind_d / 1.5, "{kind:?}: {ed} vs {ind_d}");
        }
    }
}
