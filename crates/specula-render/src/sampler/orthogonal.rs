//! `orthogonal`: orthogonal-array sampling (Jarosz et al. 2019, "Orthogonal Array Sampling for
//! Monte Carlo Rendering"), as Mitsuba 3 defines it. Parameters: `sample_count` (4, rounded up
//! to p² for the smallest prime p ≥ 2 that reaches it), `strength` (2), `seed` (0), `jitter`
//! (true).
//!
//! With strength 2 (Bose's construction) the p² samples, projected onto any two of the first
//! p + 1 dimensions, put one sample in each cell of a p × p grid, and every 1D projection is
//! stratified in p² strata: the values are multi-jittered within their strata (the sub-stratum
//! comes from the partner column of the array). Dimension j uses column j of the array, whose
//! strata are relabelled by a permutation drawn per pixel and per dimension; the row order (the
//! sample order) is shuffled per pixel. Other strengths use Bush's construction over p^strength
//! rows (as in Mitsuba, of which a pixel's p² samples are a random subset; Mitsuba does not
//! recommend it).

use super::{
    jitter_value, permute, pixel_seed, PixelSampler, Sampler, SamplerSettings, ONE_MINUS_EPS,
};
use glam::Vec2;

/// The smallest prime p ≥ 2 with p² ≥ spp.
pub(super) fn resolution(spp: u32) -> u32 {
    let is_prime = |x: u32| (2..).take_while(|d| d * d <= x).all(|d| x % d != 0);
    let mut p = 2u32;
    while (p as u64 * p as u64) < spp as u64 || !is_prime(p) {
        p += 1;
    }
    p
}

pub struct Orthogonal {
    seed: u64,
    p: u32,
    count: u32,
    strength: u32,
    /// p^strength (Bush).
    rows: u32,
    inv_p: f32,
    jitter: bool,
    perm_seed: u32,
    sample: u32,
    /// The current sample's row of the array (its index, permuted).
    row: u32,
    dim: u32,
    /// per-pixel hash seed of the jitter
    jitter_seed: u64,
}

impl Orthogonal {
    #[inline]
    fn jitter(&mut self, axis: u32) -> f32 {
        if self.jitter {
            jitter_value(self.jitter_seed, self.sample, self.dim, axis)
        } else {
            0.5
        }
    }

    /// Bose construction (strength 2): dimension `j` of the current sample.
    #[inline]
    fn bose(&mut self, j: u32) -> f32 {
        let p = self.p;
        let i = self.row;
        let (a0, a1) = (i / p, i % p);
        let col = |c: u32| -> u32 {
            match c {
                0 => a0,
                1 => a1,
                _ => ((a0 as u64 + ((c - 1) % p) as u64 * a1 as u64) % p as u64) as u32,
            }
        };
        let k = if j % 2 == 1 { j - 1 } else { j + 1 };
        let (aj, ak) = (col(j), col(k));
        let s = self.perm_seed.wrapping_mul(j.wrapping_add(1));
        let stratum = permute(aj, p, s.wrapping_mul(0x51633e2d));
        let sub = permute(ak, p, s.wrapping_mul(0x68bc21eb));
        let v = (stratum as f32 + (sub as f32 + self.jitter(0)) * self.inv_p) * self.inv_p;
        v.min(ONE_MINUS_EPS)
    }

    /// Bush construction (any strength t): dimension `j` of the current sample.
    #[inline]
    fn bush(&mut self, j: u32) -> f32 {
        let p = self.p;
        let i = self.row;
        // the base-p digits of i are the coefficients of a polynomial, evaluated at j mod p
        let x = (j % p) as u64;
        let mut digits = i;
        let mut pow = 1u64;
        let mut phi = 0u64;
        for _ in 0..self.strength {
            phi = (phi + (digits % p) as u64 * pow) % p as u64;
            pow = pow * x % p as u64;
            digits /= p;
        }
        let stm = self.rows / p;
        let s = self.perm_seed.wrapping_mul(j.wrapping_add(1));
        let stratum = permute(phi as u32, p, s.wrapping_mul(0x51633e2d));
        let sub = permute((i / p) % stm, stm, s.wrapping_mul(0x68bc21eb));
        let v = (stratum as f32 + (sub as f32 + self.jitter(0)) / stm as f32) * self.inv_p;
        v.min(ONE_MINUS_EPS)
    }
}

impl Sampler for Orthogonal {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let j = self.dim;
        self.dim += 1;
        if self.strength == 2 {
            self.bose(j)
        } else {
            self.bush(j)
        }
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

impl PixelSampler for Orthogonal {
    fn new(settings: &SamplerSettings, spp: u32, seed: u64) -> Self {
        let p = resolution(spp);
        // SamplerSettings::check refuses p^strength beyond 32 bits
        let rows = (p as u64)
            .checked_pow(settings.strength)
            .filter(|&n| n <= u32::MAX as u64)
            .unwrap_or(u32::MAX as u64) as u32;
        Orthogonal {
            seed: seed.wrapping_add(settings.seed),
            p,
            count: p * p,
            strength: settings.strength,
            rows,
            inv_p: 1.0 / p as f32,
            jitter: settings.jitter,
            perm_seed: 0,
            sample: 0,
            row: 0,
            dim: 0,
            jitter_seed: 0,
        }
    }
    fn start_pixel(&mut self, pixel: u64) {
        let s = pixel_seed(self.seed, pixel);
        self.perm_seed = (s >> 32) as u32 | 1;
        self.jitter_seed = s;
    }
    #[inline]
    fn start_sample(&mut self, sample: u32, dimension: u32) {
        self.sample = sample % self.count;
        self.dim = dimension;
        let rows = if self.strength == 2 {
            self.count
        } else {
            self.rows
        };
        self.row = permute(self.sample, rows, self.perm_seed);
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::*;
    use super::super::SamplerKind;
    use super::*;

    #[test]
    fn primes() {
        assert_eq!(resolution(1), 2);
        assert_eq!(resolution(25), 5);
        assert_eq!(resolution(26), 7);
        assert_eq!(resolution(64), 11);
    }

    #[test]
    fn every_pair_of_dimensions_is_stratified() {
        let s = SamplerSettings::new(SamplerKind::Orthogonal, 25);
        let n = 25u32;
        let mut smp = Orthogonal::new(&s, n, 4);
        smp.start_pixel(11);
        // all 6 dimensions (p + 1 = 6 orthogonal columns) of each sample
        let v: Vec<Vec<f32>> = (0..n)
            .map(|i| {
                smp.start_sample(i, 0);
                (0..6).map(|_| smp.next_1d()).collect()
            })
            .collect();
        for a in 0..6 {
            assert!(stratified_1d(v.iter().map(|x| x[a]), 25), "dim {a}");
            for b in a + 1..6 {
                let p: Vec<Vec2> = v.iter().map(|x| Vec2::new(x[a], x[b])).collect();
                assert!(stratified_2d(&p, 5, 5), "dims {a}, {b}");
            }
        }
    }

    #[test]
    fn bush_strength_3_is_uniform_and_in_range() {
        let mut s = SamplerSettings::new(SamplerKind::Orthogonal, 9);
        s.strength = 3;
        assert!(s.check(9).is_ok());
        let mut smp = Orthogonal::new(&s, 9, 1);
        let mut mean = 0.0;
        for px in 0..500 {
            smp.start_pixel(px);
            for i in 0..9 {
                smp.start_sample(i, 1);
                let v = smp.next_2d();
                assert!(v.x >= 0.0 && v.x < 1.0 && v.y >= 0.0 && v.y < 1.0);
                mean += (v.x + v.y) as f64 / 2.0;
            }
        }
        mean /= 4500.0;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        s.strength = 32;
        assert!(s.check(9).is_err());
    }
}
