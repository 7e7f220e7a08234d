//! `multijitter`: correlated multi-jittered sampling (Kensler 2013), as Mitsuba 3 defines it.
//! Parameters: `sample_count` (4, rounded up to rx × ry with ry = ⌊√N⌋, rx = ⌈N / ry⌉), `seed`
//! (0), `jitter` (true).
//!
//! A 2D dimension puts one sample in each cell of the rx × ry grid *and* in each of the rx·ry
//! columns and rows of the fine grid (stratified in 2D and in both 1D projections): the
//! canonical arrangement's sub-strata are shuffled by permutations shared by a whole row or
//! column (the "correlated" variant). A 1D dimension is stratified in rx·ry strata. The order of
//! the samples is shuffled per pixel and per dimension.

use super::{
    jitter_value, permute, pixel_seed, PixelSampler, Sampler, SamplerSettings, ONE_MINUS_EPS,
};
use glam::Vec2;

/// Grid (rx, ry) for (at least) `spp` samples.
pub(super) fn resolution(spp: u32) -> (u32, u32) {
    let mut ry = (spp as f64).sqrt() as u32;
    while (ry + 1) * (ry + 1) <= spp {
        ry += 1;
    }
    while ry * ry > spp {
        ry -= 1;
    }
    let ry = ry.max(1);
    (spp.div_ceil(ry), ry)
}

pub struct MultiJitter {
    seed: u64,
    rx: u32,
    ry: u32,
    count: u32,
    inv_count: f32,
    jitter: bool,
    perm_seed: u32,
    sample: u32,
    dim: u32,
    /// per-pixel hash seed of the jitter
    jitter_seed: u64,
}

impl MultiJitter {
    #[inline]
    fn jitter(&mut self, axis: u32) -> f32 {
        if self.jitter {
            jitter_value(self.jitter_seed, self.sample, self.dim, axis)
        } else {
            0.5
        }
    }
    #[inline]
    fn dim_seed(&mut self) -> u32 {
        let s = self
            .perm_seed
            .wrapping_add(self.dim.wrapping_mul(0x9e37_79b9));
        self.dim += 1;
        s
    }
}

impl Sampler for MultiJitter {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let seed = self.dim_seed();
        let p = permute(self.sample, self.count, seed.wrapping_mul(0x45fbe943));
        ((p as f32 + self.jitter(0)) * self.inv_count).min(ONE_MINUS_EPS)
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let seed = self.dim_seed();
        let s = permute(self.sample, self.count, seed.wrapping_mul(0x51633e2d));
        let (x, y) = (s % self.rx, s / self.rx);
        let sx = permute(x, self.rx, seed.wrapping_mul(0x68bc21eb));
        let sy = permute(y, self.ry, seed.wrapping_mul(0x02e5be93));
        let jx = self.jitter(0);
        let jy = self.jitter(1);
        Vec2::new(
            ((x * self.ry + sy) as f32 + jx) * self.inv_count,
            ((y * self.rx + sx) as f32 + jy) * self.inv_count,
        )
        .min(Vec2::splat(ONE_MINUS_EPS))
    }
}

impl PixelSampler for MultiJitter {
    fn new(settings: &SamplerSettings, spp: u32, seed: u64) -> Self {
        let (rx, ry) = resolution(spp);
        MultiJitter {
            seed: seed.wrapping_add(settings.seed),
            rx,
            ry,
            count: rx * ry,
            inv_count: 1.0 / (rx * ry) as f32,
            jitter: settings.jitter,
            perm_seed: 0,
            sample: 0,
            dim: 0,
            jitter_seed: 0,
        }
    }
    fn start_pixel(&mut self, pixel: u64) {
        let s = pixel_seed(self.seed, pixel);
        self.perm_seed = (s >> 32) as u32;
        self.jitter_seed = s;
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
    fn stratified_in_2d_and_in_both_projections() {
        for n in [16u32, 12, 20] {
            let s = SamplerSettings::new(SamplerKind::MultiJitter, n);
            let (rx, ry) = resolution(n);
            assert_eq!(rx * ry, n);
            for dim in [0, 2, 5] {
                let p = points::<MultiJitter>(&s, n, 9, dim, true);
                assert!(stratified_2d(&p, rx as usize, ry as usize), "{n} {dim}");
                assert!(stratified_1d(p.iter().map(|q| q.x), n as usize));
                assert!(stratified_1d(p.iter().map(|q| q.y), n as usize));
                let p = points::<MultiJitter>(&s, n, 9, dim, false);
                assert!(stratified_1d(p.iter().map(|q| q.x), n as usize));
            }
        }
    }
}
