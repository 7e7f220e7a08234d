//! `sobol` (Specula's own; not a Mitsuba plugin): Owen-scrambled Sobol points, padded in 2D
//! blocks and one 4D block (Burley 2020, "Practical Hash-based Owen Scrambling"). Parameters:
//! `sample_count` (4, any value: the sequence is progressive, best at powers of two), `seed` (0).
//! It is the sampler of a scene that names none (Mitsuba's default there is `independent`; a
//! scene's own `<sampler>` is always honoured).
//!
//! Every 2D dimension takes the first two dimensions of Sobol's sequence (a (0,2)-sequence),
//! each Owen-scrambled (nested uniform scrambling by a Laine–Karras-style hash) with seeds drawn
//! per pixel and per dimension; 1D dimensions use the first. The sample order is shuffled per
//! dimension by Owen-scrambling the sample index's bits, which maps the first 2^m indices onto
//! an aligned block of 2^m indices of the sequence: every power-of-two prefix of a pixel's
//! samples stays a (0,m,2)-net in every 2D dimension, and dimensions are decorrelated.
//!
//! One exception, a 4D block: dimension 0 (the film position) and dimension 2 (the
//! integrator's first 2D sample: the first light sample of `path`) are the four first
//! dimensions of one Owen-scrambled Sobol point (Joe and Kuo's direction numbers), with one
//! index shuffle for both. Where a pixel sees a small light through a glossy reflection, the
//! light sample and the position in the pixel are then stratified jointly rather than paired at
//! random (measured: relMSE −15 % at 16 spp and −35 % at 64 spp on `veach_mis`, unchanged
//! within noise on `cbox`, `mat_rough_copper`, `envmap_spheres`). Dimension 2's own 2D
//! projection is a (t,m,2)-net with t ≤ 2 (t = 1 for most m) instead of t = 0.
//!
//! Compared with `ldsampler`, the Owen scrambling randomises every digit (not only a digital
//! shift), which lowers the error on smooth integrands and removes the structured patterns, and
//! no rounding of the sample count is needed.

use super::{
    byte_tables, pixel_seed, u32_to_unit, xor_bytes, PixelSampler, Sampler, SamplerSettings,
};
use glam::Vec2;

/// The dimensions of the 4D block: (sampler dimension, first Sobol dimension).
const BLOCK: [(u32, usize); 2] = [(0, 0), (2, 2)];

/// Joe and Kuo's direction numbers (file "new-joe-kuo-6.21201", its dimensions 2–4): degree s
/// of the primitive polynomial, its coefficients a, the initial direction numbers m_1 … m_s.
const JOE_KUO: [(usize, u32, [u32; 3]); 3] =
    [(1, 0, [1, 0, 0]), (2, 1, [1, 3, 0]), (3, 1, [1, 3, 1])];

/// Sobol dimensions with generator matrices here.
pub const SOBOL_DIMS: usize = 4;

/// `MATRICES[j][k]`: the direction number of Sobol dimension j for bit k (least significant
/// first) of the index, as a 32-bit fraction.
static MATRICES: [[u32; 32]; SOBOL_DIMS] = matrices();

const fn matrices() -> [[u32; 32]; SOBOL_DIMS] {
    let mut out = [[0u32; 32]; SOBOL_DIMS];
    let mut k = 0;
    while k < 32 {
        out[0][k] = 1 << (31 - k);
        k += 1;
    }
    let mut j = 1;
    while j < SOBOL_DIMS {
        let (s, a, m) = JOE_KUO[j - 1];
        // v[k] for k = 1 … 32 (1-based, as in Joe and Kuo's description)
        let mut v = [0u32; 33];
        let mut k = 1;
        while k <= 32 {
            if k <= s {
                v[k] = m[k - 1] << (32 - k);
            } else {
                let mut x = v[k - s] ^ (v[k - s] >> s);
                let mut i = 1;
                while i < s {
                    if (a >> (s - 1 - i)) & 1 != 0 {
                        x ^= v[k - i];
                    }
                    i += 1;
                }
                v[k] = x;
            }
            out[j][k - 1] = v[k];
            k += 1;
        }
        j += 1;
    }
    out
}

/// Point `index` of Sobol's sequence in dimension `dim` (< [`SOBOL_DIMS`]), a 32-bit fraction
/// (the definition the sampler's tables are tested against).
#[cfg(test)]
fn sobol(dim: usize, mut index: u32) -> u32 {
    match dim {
        0 => index.reverse_bits(),
        1 => super::ldsampler::sobol_2(index),
        _ => {
            let m = &MATRICES[dim];
            let mut r = 0;
            let mut k = 0;
            while index != 0 {
                if index & 1 != 0 {
                    r ^= m[k];
                }
                index >>= 1;
                k += 1;
            }
            r
        }
    }
}

/// `REVERSED[j − 1][k][b]`: Sobol dimension j's contribution, bit-reversed, of byte k of the
/// index when it equals b (j = 1 … 3): the XOR over an index's bytes is `sobol(j, i)` with its
/// bits reversed, which is what the Owen scrambling hashes, so that no reversal is needed
/// before it.
static REVERSED: [[[u32; 256]; 4]; SOBOL_DIMS - 1] = reversed_tables();

const fn reversed_tables() -> [[[u32; 256]; 4]; SOBOL_DIMS - 1] {
    let mut t = [[[0u32; 256]; 4]; SOBOL_DIMS - 1];
    let mut j = 1;
    while j < SOBOL_DIMS {
        t[j - 1] = byte_tables(&MATRICES[j], true);
        j += 1;
    }
    t
}

/// `sobol(j, i).reverse_bits()` for j = 1 … 3, from [`REVERSED`] (one lookup for the
/// indices below 256 that a pixel's first 256 samples use).
#[inline]
fn sobol_reversed(j: usize, i: u32) -> u32 {
    let t = &REVERSED[j - 1];
    if i < 256 {
        return t[0][i as usize];
    }
    xor_bytes(t, i)
}

/// A hash in which every output bit depends only on the same and less significant input bits
/// (Laine and Karras 2011, with the constants of Vegdahl's improvement): applied to a
/// bit-reversed fraction it is a nested uniform (Owen) scramble.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x05526c56);
    x ^= x.wrapping_mul(0x53a22864);
    x
}

/// Owen scrambling of a 32-bit fraction (most significant bit first); the sampler applies it
/// in the reversed-bit domain (see `value`).
#[cfg(test)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

pub struct Sobol {
    seed: u64,
    /// the current pixel's 64-bit hash
    pixel_seed: u64,
    /// The pixel's per-dimension hashes (`pixel_seed(pixel_seed, d)`) of the dimensions
    /// whose bit is set in `cached`, and that of the 4D block's index shuffle: a pixel's
    /// samples use the same ones, so each is hashed once per pixel instead of once per sample.
    hashes: [u64; CACHED_DIMS],
    cached: u64,
    block_hash: u64,
    sample: u32,
    /// `sample` with its bits reversed (what the index shuffle hashes)
    sample_reversed: u32,
    dim: u32,
    /// 2^bits − 1 with 2^bits ≥ the sample count
    mask: u32,
    /// the current sample's shuffled index in the 4D block
    block_index: u32,
}

/// Dimension key of the 4D block's index shuffle (no sampler dimension reaches it).
const BLOCK_KEY: u32 = u32::MAX;

/// Dimensions whose hashes a sampler keeps per pixel (a path of 8 bounces uses about 32; at
/// most 64, one bit each in `Sobol::cached`).
const CACHED_DIMS: usize = 48;

/// Three 32-bit seeds (index shuffle, first and second coordinate) from a dimension's hash.
#[inline]
fn split_seeds(z: u64) -> (u32, u32, u32) {
    let (lo, hi) = (z as u32, (z >> 32) as u32);
    (lo, hi, lo ^ hi.rotate_left(13))
}

impl Sobol {
    /// Three 32-bit seeds for dimension `d` of the current pixel (index shuffle, first and
    /// second coordinate) from one 64-bit hash.
    #[inline]
    fn seeds(&mut self, d: u32) -> (u32, u32, u32) {
        let z = match self.hashes.get_mut(d as usize) {
            Some(h) if self.cached >> d & 1 != 0 => *h,
            Some(h) => {
                *h = pixel_seed(self.pixel_seed, d as u64);
                self.cached |= 1 << d;
                *h
            }
            None => pixel_seed(self.pixel_seed, d as u64),
        };
        split_seeds(z)
    }

    /// The index of sample `i` in a pixel's sequence, shuffled by `seed`: bit b of the result
    /// depends on the bits ≥ b of `i` (the index's bits scrambled as a fraction's), so indices
    /// below 2^m map onto one aligned block of 2^m. For the pixel's samples the bits above the
    /// sample count's are the same for all (a digital shift, which the Owen scrambling of the
    /// values absorbs), so they are dropped: the Sobol points then need fewer bits.
    /// Applied to the current sample (`owen_scramble(sample, seed)`, from the sample's
    /// reversed bits kept by `start_sample`).
    ///
    /// Up to 256 samples per pixel the masked index is the reversal of the hash's top byte
    /// (`rev(h) & mask = REV8[h >> 24] & mask` for mask < 256): one lookup instead of a
    /// 32-bit bit reversal, which x86-64's baseline has no instruction for.
    #[inline]
    fn shuffle(&self, seed: u32) -> u32 {
        let h = laine_karras(self.sample_reversed, seed);
        if self.sample <= self.mask {
            if self.mask < 256 {
                REV8[(h >> 24) as usize] as u32 & self.mask
            } else {
                h.reverse_bits() & self.mask
            }
        } else {
            h.reverse_bits()
        }
    }

    /// (shuffled index, first Sobol dimension, value seeds) of the next dimension.
    #[inline]
    fn next(&mut self) -> (u32, usize, u32, u32) {
        let d = self.dim;
        self.dim += 1;
        let (shuffle, sx, sy) = self.seeds(d);
        // the block's two entries tested one by one: `BLOCK.iter().find` is not unrolled
        // here and costs 1.8 % of a sobol render's instructions (callgrind, cbox)
        if d == BLOCK[0].0 {
            (self.block_index, BLOCK[0].1, sx, sy)
        } else if d == BLOCK[1].0 {
            (self.block_index, BLOCK[1].1, sx, sy)
        } else {
            (self.shuffle(shuffle), 0, sx, sy)
        }
    }
}

/// Owen-scrambled Sobol dimension `j` at index `i` as a float in [0, 1):
/// `owen_scramble(sobol(j, i), seed)`, i.e. the hash of the value's reversed bits, reversed;
/// the reversed value of dimension 0 (van der Corput) is the index itself, those of the others
/// come from [`REVERSED`].
#[inline]
fn value(j: usize, i: u32, seed: u32) -> f32 {
    u32_to_unit(laine_karras(reversed(j, i), seed).reverse_bits())
}

/// `sobol(j, i).reverse_bits()`: the index itself for dimension 0 (van der Corput), from
/// [`REVERSED`] for the others.
#[inline]
fn reversed(j: usize, i: u32) -> u32 {
    if j == 0 {
        i
    } else {
        sobol_reversed(j, i)
    }
}

/// `(value(j, i, sx), value(j + 1, i, sy))` with the two hashes bit-reversed together as one
/// 64-bit word (one reversal's shifts and masks instead of two).
#[inline]
fn values2(j: usize, i: u32, sx: u32, sy: u32) -> Vec2 {
    let hx = laine_karras(reversed(j, i), sx) as u64;
    let hy = laine_karras(reversed(j + 1, i), sy) as u64;
    let r = (hx << 32 | hy).reverse_bits();
    Vec2::new(u32_to_unit(r as u32), u32_to_unit((r >> 32) as u32))
}

/// Bit reversal of a byte.
static REV8: [u8; 256] = rev8();

const fn rev8() -> [u8; 256] {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        t[b] = (b as u8).reverse_bits();
        b += 1;
    }
    t
}

impl Sampler for Sobol {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let (i, j, sx, _) = self.next();
        value(j, i, sx)
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let (i, j, sx, sy) = self.next();
        values2(j, i, sx, sy)
    }
    /// A dimension's value depends on its index alone: stepping over it is counting it.
    #[inline]
    fn skip_1d(&mut self) {
        self.dim += 1;
    }
    #[inline]
    fn skip_2d(&mut self) {
        self.dim += 1;
    }
}

impl PixelSampler for Sobol {
    fn new(settings: &SamplerSettings, spp: u32, seed: u64) -> Self {
        let bits = 32 - (spp.max(1) - 1).leading_zeros();
        Sobol {
            seed: seed.wrapping_add(settings.seed),
            pixel_seed: 0,
            hashes: [0; CACHED_DIMS],
            cached: 0,
            block_hash: 0,
            sample: 0,
            sample_reversed: 0,
            dim: 0,
            mask: ((1u64 << bits) - 1) as u32,
            block_index: 0,
        }
    }
    fn start_pixel(&mut self, pixel: u64) {
        self.pixel_seed = pixel_seed(self.seed, pixel);
        self.cached = 0;
        self.block_hash = pixel_seed(self.pixel_seed, BLOCK_KEY as u64);
    }
    #[inline]
    fn start_sample(&mut self, sample: u32, dimension: u32) {
        self.sample = sample;
        self.sample_reversed = sample.reverse_bits();
        self.dim = dimension;
        if dimension <= BLOCK[1].0 {
            self.block_index = self.shuffle(split_seeds(self.block_hash).0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::*;
    use super::super::SamplerKind;
    use super::*;

    /// The smallest t for which every elementary interval of area 2^(t−m) (nx·ny = 2^(m−t)
    /// cells) holds exactly 2^t of the 2^m points (x, y), given as 32-bit fractions.
    fn t_value(p: &[(u32, u32)]) -> u32 {
        let m = p.len().trailing_zeros();
        assert_eq!(p.len(), 1 << m);
        (0..=m)
            .find(|&t| {
                (0..=m - t).all(|kx| {
                    let ky = m - t - kx;
                    let mut count = vec![0u32; 1 << (m - t)];
                    for &(x, y) in p {
                        let cx = if kx == 0 { 0 } else { x >> (32 - kx) };
                        let cy = if ky == 0 { 0 } else { y >> (32 - ky) };
                        count[((cy << kx) | cx) as usize] += 1;
                    }
                    count.iter().all(|&c| c == 1 << t)
                })
            })
            .unwrap()
    }

    #[test]
    fn sobol_matrices_give_the_published_points() {
        // Joe and Kuo's first 3D points (in Gray-code order: point n is index n ^ (n >> 1))
        let first: [[f64; 3]; 10] = [
            [0.0, 0.0, 0.0],
            [0.5, 0.5, 0.5],
            [0.75, 0.25, 0.25],
            [0.25, 0.75, 0.75],
            [0.375, 0.375, 0.625],
            [0.875, 0.875, 0.125],
            [0.625, 0.125, 0.875],
            [0.125, 0.625, 0.375],
            [0.1875, 0.3125, 0.9375],
            [0.6875, 0.8125, 0.4375],
        ];
        for (n, want) in first.iter().enumerate() {
            let i = (n ^ (n >> 1)) as u32;
            for (j, &w) in want.iter().enumerate() {
                assert_eq!(sobol(j, i) as f64 / 4294967296.0, w, "point {n}, dim {j}");
            }
        }
        // the table and the byte-table fast paths of dimensions 0 and 1 agree
        for (j, matrix) in MATRICES.iter().enumerate().take(2) {
            for i in [1u32, 2, 3, 77, 1000, 65535, 0xdead_beef] {
                let r = (0..32)
                    .filter(|k| i >> k & 1 != 0)
                    .fold(0, |r, k| r ^ matrix[k]);
                assert_eq!(sobol(j, i), r);
            }
        }
        // every dimension is a (0,1)-sequence: each power-of-two prefix is stratified
        for j in 0..SOBOL_DIMS {
            for m in 0..12 {
                let n = 1u32 << m;
                let v = (0..n).map(|i| (sobol(j, i) as f64 / 4294967296.0) as f32);
                assert!(stratified_1d(v, n as usize), "dim {j}, 2^{m}");
            }
        }
        // dimensions (2, 3), the 4D block's second pair, have t ≤ 2 (computed from the
        // direction numbers independently: 0, 1, 2, 0, 1, 1, 1, 1, 1, 1 for m = 1 … 10)
        let t: Vec<u32> = (1..=10)
            .map(|m| {
                let p: Vec<(u32, u32)> =
                    (0..1u32 << m).map(|i| (sobol(2, i), sobol(3, i))).collect();
                t_value(&p)
            })
            .collect();
        assert_eq!(t, [0, 1, 2, 0, 1, 1, 1, 1, 1, 1]);
    }

    /// The reversed-bit tables and the scrambled values built on them are `sobol` and
    /// `owen_scramble` as written out, bit for bit.
    #[test]
    fn values_are_owen_scrambled_sobol_points() {
        let mut h = 0x2545_f491_4f6c_dd1du64;
        for n in 0..20_000u32 {
            h = pixel_seed(h, n as u64);
            // small indices (one table) and large ones (all four bytes)
            let i = if n % 2 == 0 { n % 300 } else { h as u32 };
            let seed = (h >> 32) as u32;
            for j in 0..SOBOL_DIMS {
                let want = u32_to_unit(owen_scramble(sobol(j, i), seed));
                assert_eq!(
                    value(j, i, seed).to_bits(),
                    want.to_bits(),
                    "dim {j}, index {i}"
                );
                if j > 0 {
                    assert_eq!(sobol_reversed(j, i), sobol(j, i).reverse_bits());
                }
            }
            // the paired form gives both coordinates bit for bit
            let sy = h as u32;
            for j in 0..SOBOL_DIMS - 1 {
                let v = values2(j, i, seed, sy);
                assert_eq!(v.x.to_bits(), value(j, i, seed).to_bits(), "dim {j}, {i}");
                assert_eq!(v.y.to_bits(), value(j + 1, i, sy).to_bits(), "dim {j}, {i}");
            }
        }
    }

    #[test]
    fn cached_dimension_hashes_give_the_same_values() {
        // one sampler over pixels and samples (its cache filled, reset per pixel, deeper
        // than it holds, samples starting at other dimensions) against a fresh sampler per
        // sample, which hashes every dimension anew
        let settings = SamplerSettings::new(SamplerKind::Sobol, 16);
        let mut kept = Sobol::new(&settings, 16, 11);
        for pixel in [5u64, 9, 5] {
            kept.start_pixel(pixel);
            for sample in 0..16 {
                let first = if sample % 5 == 4 { 3 } else { 0 };
                let mut fresh = Sobol::new(&settings, 16, 11);
                fresh.start_pixel(pixel);
                fresh.start_sample(sample, first);
                kept.start_sample(sample, first);
                for d in first..CACHED_DIMS as u32 + 8 {
                    let (a, b) = if d % 3 == 0 {
                        (Vec2::splat(kept.next_1d()), Vec2::splat(fresh.next_1d()))
                    } else {
                        (kept.next_2d(), fresh.next_2d())
                    };
                    assert_eq!(a, b, "pixel {pixel}, sample {sample}, dimension {d}");
                }
            }
        }
    }

    #[test]
    fn shuffled_index_byte_path_is_the_masked_reversal() {
        // every sample count's mask up to 2^10 (byte lookup below 256, reversal above), and
        // samples beyond the count (unmasked)
        for bits in 0..=10u32 {
            let spp = 1u32 << bits;
            let mut s = Sobol::new(&SamplerSettings::new(SamplerKind::Sobol, spp), spp, 7);
            s.start_pixel(3);
            for sample in 0..3 * spp + 5 {
                s.start_sample(sample, 5);
                for seed in [0u32, 1, 0x9e37_79b9, 0xdead_beef, u32::MAX] {
                    let h = laine_karras(sample.reverse_bits(), seed).reverse_bits();
                    let want = if sample <= s.mask { h & s.mask } else { h };
                    assert_eq!(s.shuffle(seed), want, "spp {spp}, sample {sample}, {seed}");
                }
            }
        }
        for b in 0..=255u8 {
            assert_eq!(REV8[b as usize], b.reverse_bits());
        }
    }

    #[test]
    fn owen_scramble_is_a_bijection_preserving_prefixes() {
        // on 8-bit prefixes: fractions sharing their top k bits still share them
        let seed = 0x1234_5678;
        let a = owen_scramble(0b1010_0000 << 24, seed);
        let b = owen_scramble(0b1010_1111 << 24, seed);
        assert_eq!(a >> 28, b >> 28);
        let mut seen = std::collections::HashSet::new();
        for x in 0..4096u32 {
            assert!(seen.insert(owen_scramble(x << 20, seed) >> 20));
        }
    }

    #[test]
    fn every_power_of_two_prefix_is_a_net() {
        let s = SamplerSettings::new(SamplerKind::Sobol, 64);
        let q = |v: f32| (v as f64 * 4294967296.0) as u32;
        for dim in [0, 1, 2, 3, 10] {
            let p = points::<Sobol>(&s, 64, 5, dim, true);
            for m in 1..=6u32 {
                let n = 1usize << m;
                let pts: Vec<(u32, u32)> = p[..n].iter().map(|v| (q(v.x), q(v.y))).collect();
                // (0,m,2)-nets, but for the 4D block's second pair (dimension 2): t ≤ 2
                let max_t = if dim == 2 { 2 } else { 0 };
                assert!(t_value(&pts) <= max_t, "dim {dim}, {n} points");
            }
            let p = points::<Sobol>(&s, 32, 5, dim, false);
            assert!(stratified_1d(p.iter().map(|q| q.x), 32), "dim {dim}");
        }
    }

    #[test]
    fn the_film_position_and_the_first_light_sample_are_stratified_jointly() {
        // Within the 4D block, the cross projections (film x or y against the light sample's
        // u or v) are nets with small t; padded dimensions are paired at random, which leaves
        // many of the 2^m cells of a cross projection empty (t near m/2 and above). 64 samples,
        // several pixels.
        let spp = 64;
        let s = SamplerSettings::new(SamplerKind::Sobol, spp);
        let q = |v: f32| (v as f64 * 4294967296.0) as u32;
        let mut worst_padded = 0;
        for pixel in 0..8 {
            let film = points::<Sobol>(&s, spp, pixel, 0, true);
            let light = points::<Sobol>(&s, spp, pixel, 2, true);
            let other = points::<Sobol>(&s, spp, pixel, 4, true);
            for (a, b) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let cross = |u: &[Vec2], v: &[Vec2]| {
                    let p: Vec<(u32, u32)> =
                        u.iter().zip(v).map(|(u, v)| (q(u[a]), q(v[b]))).collect();
                    t_value(&p)
                };
                assert!(cross(&film, &light) <= 2, "pixel {pixel}, axes {a}, {b}");
                worst_padded = worst_padded.max(cross(&film, &other));
            }
        }
        assert!(worst_padded >= 3, "{worst_padded}");
    }

    #[test]
    fn values_are_uniform_over_pixels() {
        // the first sample of dimensions 0, 2 and 5 in 8192 pixels, 32 bins per axis: χ² with
        // 31 degrees of freedom stays below 61.1 (significance 0.001) for each axis
        let s = SamplerSettings::new(SamplerKind::Sobol, 16);
        let mut smp = Sobol::new(&s, 16, 11);
        for dim in [0u32, 2, 5] {
            let mut bins = [[0u32; 32]; 2];
            let n = 8192;
            for px in 0..n {
                smp.start_pixel(px);
                smp.start_sample(3, dim);
                let v = smp.next_2d();
                bins[0][(v.x * 32.0) as usize] += 1;
                bins[1][(v.y * 32.0) as usize] += 1;
            }
            for b in bins {
                let e = n as f64 / 32.0;
                let chi2: f64 = b.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
                assert!(chi2 < 61.1, "dim {dim}: χ² {chi2}");
            }
        }
    }

    #[test]
    fn sample_indices_beyond_the_count_stay_distinct() {
        // the shuffle drops the high bits only for indices within the sample count
        let s = SamplerSettings::new(SamplerKind::Sobol, 4);
        let mut smp = Sobol::new(&s, 4, 0);
        smp.start_pixel(9);
        let mut seen = std::collections::HashSet::new();
        for i in 0..64 {
            smp.start_sample(i, 4);
            let v = smp.next_2d();
            assert!(seen.insert((v.x.to_bits(), v.y.to_bits())), "{i}");
        }
    }
}
