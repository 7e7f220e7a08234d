//! `independent`: independent uniform samples, one PCG32 stream per pixel (Mitsuba 3's default
//! sampler). Parameters: `sample_count` (4), `seed` (0). Dimensions are not tracked: a pixel's
//! samples draw from its stream in the order they are traced, which the renderer keeps fixed.

use super::{pixel_seed, PixelSampler, Sampler, SamplerSettings};
use glam::Vec2;
use specula_bsdf::rng::Pcg32;

pub struct Independent {
    seed: u64,
    rng: Pcg32,
}

impl Sampler for Independent {
    #[inline]
    fn next_1d(&mut self) -> f32 {
        self.rng.next_f32()
    }
    #[inline]
    fn next_2d(&mut self) -> Vec2 {
        self.rng.next_vec2()
    }
}

impl PixelSampler for Independent {
    fn new(settings: &SamplerSettings, _spp: u32, seed: u64) -> Self {
        let seed = seed.wrapping_add(settings.seed);
        Independent {
            seed,
            rng: Pcg32::new(seed, 0),
        }
    }
    #[inline]
    fn start_pixel(&mut self, pixel: u64) {
        self.rng = Pcg32::new(pixel_seed(self.seed, pixel), pixel);
    }
    #[inline]
    fn start_sample(&mut self, _sample: u32, _dimension: u32) {}
    fn start_pixel_from(&mut self, pixel: u64, first: u32) {
        // samples from `first` on draw from their own stream (`first` = 0: the pixel's usual one)
        let key = pixel_seed(self.seed, pixel).wrapping_add((first as u64) << 32);
        self.rng = Pcg32::new(key, pixel);
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::*;
    use super::super::SamplerKind;
    use super::*;

    #[test]
    fn uniform_and_seeded() {
        let s = SamplerSettings::new(SamplerKind::Independent, 4);
        let p = points::<Independent>(&s, 4096, 0, 0, true);
        let mean = p.iter().fold(Vec2::ZERO, |a, &b| a + b) / p.len() as f32;
        assert!(
            (mean - Vec2::splat(0.5)).abs().max_element() < 0.02,
            "{mean}"
        );
        let mut t = s;
        t.seed = 1;
        assert_ne!(p[..4], points::<Independent>(&t, 4096, 0, 0, true)[..4]);
    }
}
