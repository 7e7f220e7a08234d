//! `stratified`: jittered stratified sampling, as Mitsuba 3 defines it. Parameters:
//! `sample_count` (4, rounded up to a square n²), `seed` (0), `jitter` (true: a random position
//! in each stratum; false: its centre).
//!
//! Every dimension is stratified on its own: a 1D dimension places the pixel's samples one per
//! stratum of [0, 1) split n² ways, a 2D dimension one per cell of an n × n grid. Which sample
//! gets which stratum is a random permutation (Kensler's), drawn per pixel and per dimension,
//! so that dimensions are not correlated ("padding").

use super::{
    jitter_value, permute, pixel_seed, PixelSampler, Sampler, SamplerSettings, ONE_MINUS_EPS,
};
use glam::Vec2;

/// Strata per axis for (at least) `spp` samples: ⌈√spp⌉.
pub(super) fn resolution(spp: u32) -> u32 {
    let mut r = (spp as f64).sqrt() as u32;
    while r * r < spp {
        r += 1;
    }
    r.max(1)
}

pub struct Stratified {
    seed: u64,
    res: u32,
    count: u32,
    inv_count: f32,
    inv_res: f32,
    jitter: bool,
    perm_seed: u32,
    sample: u32,
    dim: u32,
    /// per-pixel hash seed of the jitter
    jitter_seed: u64,
}

impl Stratified {
    #[inline]
    fn jitter(&mut self, axis: u32) -> f32 {
        if self.jitter {
            jitter_value(self.jitter_seed, self.sample, self.dim, axis)
        } else {
            0.5
        }
    }
    #[inline]
    fn next_index(&mut self) -> u32 {
        let p = permute(
            self.sample,
            self.count,
            self.perm_seed
                .wrapping_add(self.dim.wrapping_mul(0x9e37_79b9)),
        );
        self.dim += 1;
        p
    }
}

impl Sampler for Stratified {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        let p = self.next_index();
        ((p as f32 + self.jitter(0)) * self.inv_count).min(ONE_MINUS_EPS)
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        let p = self.next_index();
        let (y, x) = (p / self.res, p % self.res);
        let jx = self.jitter(0);
        let jy = self.jitter(1);
        Vec2::new(
            ((x as f32 + jx) * self.inv_res).min(ONE_MINUS_EPS),
            ((y as f32 + jy) * self.inv_res).min(ONE_MINUS_EPS),
        )
    }
}

impl PixelSampler for Stratified {
    fn new(settings: &SamplerSettings, spp: u32, seed: u64) -> Self {
        let res = resolution(spp);
        Stratified {
            seed: seed.wrapping_add(settings.seed),
            res,
            count: res * res,
            inv_count: 1.0 / (res * res) as f32,
            inv_res: 1.0 / res as f32,
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
    fn each_dimension_is_stratified() {
        for jitter in [true, false] {
            let mut s = SamplerSettings::new(SamplerKind::Stratified, 16);
            s.jitter = jitter;
            for dim in [0, 1, 7] {
                let p = points::<Stratified>(&s, 16, 3, dim, true);
                assert!(stratified_2d(&p, 4, 4), "dim {dim}: {p:?}");
                let p = points::<Stratified>(&s, 16, 3, dim, false);
                assert!(stratified_1d(p.iter().map(|q| q.x), 16));
            }
            // centres without jitter
            if !jitter {
                let p = points::<Stratified>(&s, 16, 3, 0, true);
                assert!(p.iter().all(|q| ((q.x * 4.0).fract() - 0.5).abs() < 1e-6));
            }
        }
        // dimensions are shuffled independently
        let s = SamplerSettings::new(SamplerKind::Stratified, 16);
        let a = points::<Stratified>(&s, 16, 3, 0, true);
        let b = points::<Stratified>(&s, 16, 3, 1, true);
        let cells = |p: &[Vec2]| -> Vec<u32> {
            p.iter()
                .map(|q| (q.y * 4.0) as u32 * 4 + (q.x * 4.0) as u32)
                .collect()
        };
        assert_ne!(cells(&a), cells(&b));
    }
}
