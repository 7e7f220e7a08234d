//! `sobol` (Specula's own; not a Mitsuba plugin): Owen-scrambled Sobol points with shuffled
//! padding (Burley 2020, "Practical Hash-based Owen Scrambling"). Parameters: `sample_count`
//! (4, any value: the sequence is progressive, best at powers of two), `seed` (0).
//!
//! Every 2D dimension takes the first two dimensions of Sobol's sequence (a (0,2)-sequence),
//! each Owen-scrambled (nested uniform scrambling by a Laine–Karras-style hash) with seeds drawn
//! per pixel and per dimension; 1D dimensions use the first. The sample order is shuffled per
//! dimension by Owen-scrambling the sample index's bits, which maps the first 2^m indices onto
//! an aligned block of 2^m indices of the sequence: every power-of-two prefix of a pixel's
//! samples stays a (0,m,2)-net in every 2D dimension, and dimensions are decorrelated. Compared
//! with `ldsampler`, the Owen scrambling randomises every digit (not only a digital shift),
//! which lowers the error on smooth integrands and removes the structured patterns, and no
//! rounding of the sample count is needed.

use super::ldsampler::sobol_2;
use super::{hash2, pixel_seed, u32_to_unit, PixelSampler, Sampler, SamplerSettings};
use glam::Vec2;

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

/// Owen scrambling of a 32-bit fraction (most significant bit first).
#[inline]
pub fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

pub struct Sobol {
    seed: u64,
    pixel_seed: u32,
    sample: u32,
    dim: u32,
}

impl Sobol {
    /// The shuffled index of the current sample and the seed of the next dimension.
    #[inline]
    fn next_index(&mut self) -> (u32, u32) {
        let h = hash2(self.pixel_seed, self.dim);
        self.dim += 1;
        // the index's bits scrambled as a fraction's: bit b of the result depends on the bits
        // ≥ b of the index, so indices below 2^m map onto one aligned block of 2^m
        (owen_scramble(self.sample, h), h)
    }
}

impl Sampler for Sobol {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let (i, h) = self.next_index();
        u32_to_unit(owen_scramble(i.reverse_bits(), hash2(h, 0xa511e9b3)))
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let (i, h) = self.next_index();
        Vec2::new(
            u32_to_unit(owen_scramble(i.reverse_bits(), hash2(h, 0x63d83595))),
            u32_to_unit(owen_scramble(sobol_2(i), hash2(h, 0x8f0ad3d7))),
        )
    }
}

impl PixelSampler for Sobol {
    fn new(settings: &SamplerSettings, _spp: u32, seed: u64) -> Self {
        Sobol {
            seed: seed.wrapping_add(settings.seed),
            pixel_seed: 0,
            sample: 0,
            dim: 0,
        }
    }
    fn start_pixel(&mut self, pixel: u64) {
        self.pixel_seed = (pixel_seed(self.seed, pixel) >> 32) as u32;
    }
    #[inline]
    fn start_sample(&mut self, sample: u32, dimension: u32) {
        self.sample = sample;
        self.dim = dimension;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::*;
    use super::super::SamplerKind;
    use super::*;

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
    fn every_power_of_two_prefix_is_a_0_m_2_net() {
        let s = SamplerSettings::new(SamplerKind::Sobol, 64);
        for dim in [0, 1, 3, 10] {
            let p = points::<Sobol>(&s, 64, 5, dim, true);
            for m in [2u32, 4, 6] {
                let n = 1usize << m;
                for k in 0..=m {
                    let (nx, ny) = (1usize << k, 1usize << (m - k));
                    assert!(
                        stratified_2d(&p[..n], nx, ny),
                        "dim {dim}, {n} points, {nx}×{ny}"
                    );
                }
            }
            let p = points::<Sobol>(&s, 32, 5, dim, false);
            assert!(stratified_1d(p.iter().map(|q| q.x), 32));
        }
    }
}
