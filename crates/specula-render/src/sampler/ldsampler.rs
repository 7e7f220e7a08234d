//! `ldsampler`: the low-discrepancy sampler of Mitsuba (Kollig and Keller 2002, "Efficient
//! multidimensional sampling"). Parameters: `sample_count` (4, rounded up to a square power of
//! two: 4, 16, 64, 256, …), `seed` (0).
//!
//! Every 2D dimension takes the pixel's samples from the same (0,2)-sequence (van der Corput ×
//! Sobol's second dimension), randomised by an XOR scramble (a random digital shift) and shuffled
//! by a random permutation of the sample order, both drawn per pixel and per dimension; 1D
//! dimensions use the scrambled, shuffled van der Corput sequence. Without jitter, each 1D
//! projection is perfectly stratified. Deviation: Mitsuba shares the scramble between dimensions
//! (only the permutation changes); here each dimension has its own.

use super::{hash2, permute, pixel_seed, u32_to_unit, PixelSampler, Sampler, SamplerSettings};
use glam::Vec2;

/// Points per axis for (at least) `spp` samples: the smallest power of two r ≥ 2 with r² ≥ spp.
pub(super) fn resolution(spp: u32) -> u32 {
    let mut r = 2u32;
    while r * r < spp {
        r *= 2;
    }
    r
}

/// The second dimension of Sobol's sequence as a 32-bit fraction (generator matrix: each
/// direction number is the previous one XOR itself shifted right by one), by bytes of `i`.
#[inline]
pub(super) fn sobol_2(i: u32) -> u32 {
    super::xor_bytes(&SOBOL_2, i)
}

/// `SOBOL_2[k][b]`: the contribution of byte k of the index when it equals b.
static SOBOL_2: [[u32; 256]; 4] = sobol_2_tables();

const fn sobol_2_tables() -> [[u32; 256]; 4] {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    super::byte_tables(&v, false)
}

pub struct LowDiscrepancy {
    seed: u64,
    count: u32,
    pixel_seed: u32,
    sample: u32,
    dim: u32,
}

impl LowDiscrepancy {
    /// The shuffled index of the current sample and the scramble of the next dimension.
    #[inline]
    fn next_index(&mut self) -> (u32, u32) {
        let h = hash2(self.pixel_seed, self.dim);
        self.dim += 1;
        (permute(self.sample, self.count, h), h)
    }
}

impl Sampler for LowDiscrepancy {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let (i, h) = self.next_index();
        u32_to_unit(i.reverse_bits() ^ hash2(h, 0x48bc48eb))
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let (i, h) = self.next_index();
        Vec2::new(
            u32_to_unit(i.reverse_bits() ^ hash2(h, 0x98bc51ab)),
            u32_to_unit(sobol_2(i) ^ hash2(h, 0x2e5be93)),
        )
    }
}

impl PixelSampler for LowDiscrepancy {
    fn new(settings: &SamplerSettings, spp: u32, seed: u64) -> Self {
        LowDiscrepancy {
            seed: seed.wrapping_add(settings.seed),
            count: resolution(spp).pow(2),
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
        self.sample = sample % self.count;
        self.dim = dimension;
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::*;
    use super::super::SamplerKind;
    use super::*;

    #[test]
    fn sobol_tables_match_the_direction_numbers() {
        let slow = |mut i: u32| {
            let (mut v, mut r) = (1u32 << 31, 0u32);
            while i != 0 {
                if i & 1 != 0 {
                    r ^= v;
                }
                i >>= 1;
                v ^= v >> 1;
            }
            r
        };
        for i in [0u32, 1, 2, 3, 255, 256, 12345, 0xdead_beef, u32::MAX] {
            assert_eq!(sobol_2(i), slow(i), "{i}");
        }
        // the first points: 1/2, 1/4, 3/4, …
        assert_eq!(sobol_2(1), 1 << 31);
        assert_eq!(sobol_2(2), 3 << 30);
        assert_eq!(sobol_2(3), 1 << 30);
    }

    #[test]
    fn every_dimension_is_a_0_m_2_net() {
        let s = SamplerSettings::new(SamplerKind::LowDiscrepancy, 16);
        for dim in [0, 1, 4, 9] {
            let p = points::<LowDiscrepancy>(&s, 16, 2, dim, true);
            // every elementary interval of area 1/16
            for (nx, ny) in [(16, 1), (8, 2), (4, 4), (2, 8), (1, 16)] {
                assert!(stratified_2d(&p, nx, ny), "dim {dim}: {nx}×{ny}");
            }
            let p = points::<LowDiscrepancy>(&s, 16, 2, dim, false);
            assert!(stratified_1d(p.iter().map(|q| q.x), 16));
        }
    }
}
