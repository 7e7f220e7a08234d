//! Medium coefficients in spectral mode ([`crate::spectral`]): how the RGB values of `sigma_t`
//! and `albedo` become functions of wavelength, as Mitsuba 3.9.1's `*_spectral` variants read
//! them (probed with `scalar_spectral` / `llvm_ad_spectral`):
//!
//! - a **float** (`<float name="sigma_t" value="2"/>`, a one-channel grid, a grey colour) is a
//!   constant spectrum (Mitsuba's `uniform`);
//! - an **rgb** constant (`<rgb>` given directly or as a `constvolume`'s `value`, for
//!   `sigma_t` as for `albedo`) is Mitsuba's bounded `srgb` reflectance spectrum: the
//!   Jakob–Hanika sigmoid ρ(λ) of the colour ([`upsample::reflectance`], the same upsampling
//!   as BSDF colours). Mitsuba refuses a colour above 1 there ("Invalid RGB reflectance
//!   value"), even for `sigma_t`; Specula upsamples such a `sigma_t` as an unbounded colour
//!   s·ρ(rgb/s), s = 2·max(rgb) ([`upsample::unbounded`]; a deviation: Mitsuba has no image);
//! - a 3-channel **`gridvolume`** (unless `raw`) upsamples *each texel* when loaded as
//!   s·ρ(rgb/s) with s = 2·max(rgb) of that texel, whatever its range (Mitsuba stores the
//!   three coefficients and s as 4 channels), and a lookup interpolates the texels' spectra
//!   at the path's wavelengths (trilinear or nearest, as in RGB mode); greys stay exact.
//!   A `raw` 3-channel grid has no spectrum (Mitsuba fails when it is evaluated); Specula
//!   refuses it in [`crate::scene::Scene::set_spectral`].
//!
//! Every such spectrum is s·σ(c₀t² + c₁t + c₂), t = (λ − 360 nm)/470 nm ([`Sigmoid`]); a
//! constant v is c = 0, s = 2v (σ(0) = ½ exactly). Its largest value over 360…830 nm is exact
//! ([`Sigmoid::max`]: σ is increasing, so it is σ of the quadratic's maximum on [0, 1]), which
//! keeps the delta-tracking majorant of a heterogeneous medium valid at every wavelength.
//! (Mitsuba's majorant of an RGB grid is the largest s, twice the largest channel; of an rgb
//! `constvolume` a value below the spectrum's maximum — σn then goes negative there. Specula's
//! tighter and valid bounds change only the noise.)

use specula_bsdf::spectral::{cie, upsample};
use specula_bsdf::{Rgb, Wavelengths};

/// A spectrum s·σ(c₀t² + c₁t + c₂), t = (λ − 360)/470 (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sigmoid {
    pub c: [f32; 3],
    pub s: f32,
}

impl Sigmoid {
    /// The constant spectrum `v`.
    #[inline]
    pub fn constant(v: f32) -> Sigmoid {
        Sigmoid {
            c: [0.0; 3],
            s: 2.0 * v,
        }
    }

    /// Mitsuba's `srgb` reflectance spectrum of `rgb` (clamped to [0, 1]); exact for greys.
    pub fn reflectance(rgb: Rgb) -> Sigmoid {
        let [r, g, b] = rgb.0;
        if r == g && g == b {
            return Sigmoid::constant(r.clamp(0.0, 1.0));
        }
        match upsample::coefficients(rgb) {
            Some(c) => Sigmoid { c, s: 1.0 },
            None => Sigmoid::constant(0.0),
        }
    }

    /// A constant medium colour: [`Sigmoid::reflectance`] within [0, 1] (Mitsuba), s·ρ(rgb/s)
    /// with s = 2·max(rgb) above (Specula's extension; see the module docs).
    pub fn unbounded(rgb: Rgb) -> Sigmoid {
        let rgb = rgb.map(|v| v.max(0.0));
        let m = rgb.max_component();
        if m <= 1.0 {
            return Sigmoid::reflectance(rgb);
        }
        if rgb[0] == rgb[1] && rgb[1] == rgb[2] {
            return Sigmoid::constant(m);
        }
        Sigmoid::scaled(rgb, 2.0 * m)
    }

    /// A grid texel as Mitsuba's `gridvolume` upsamples it: s·ρ(rgb/s), s = 2·max(rgb).
    pub fn texel(rgb: Rgb) -> Sigmoid {
        let rgb = rgb.map(|v| v.max(0.0));
        let [r, g, b] = rgb.0;
        if r == g && g == b {
            return Sigmoid::constant(r);
        }
        Sigmoid::scaled(rgb, 2.0 * rgb.max_component())
    }

    fn scaled(rgb: Rgb, s: f32) -> Sigmoid {
        match upsample::coefficients(rgb / s) {
            Some(c) => Sigmoid { c, s },
            None => Sigmoid::constant(0.0),
        }
    }

    /// The value at one wavelength (nm).
    #[inline]
    pub fn at(&self, l: f32) -> f32 {
        self.s * upsample::eval_coefficients(self.c, l)
    }

    /// The values at the path's wavelengths.
    #[inline]
    pub fn eval(&self, w: &Wavelengths) -> Rgb {
        if self.c == [0.0; 3] {
            // a constant: σ(0) = ½ exactly, without the square root
            return Rgb::splat(self.s * 0.5);
        }
        Rgb(w.0.map(|l| self.at(l)))
    }

    /// The largest value over 360…830 nm (exact up to rounding, see the module docs).
    pub fn max(&self) -> f32 {
        let [a, b, c] = self.c;
        let q = |t: f32| a.mul_add(t, b).mul_add(t, c);
        let mut best = if q(1.0) > q(0.0) { 1.0 } else { 0.0 };
        if a < 0.0 {
            let tv = -b / (2.0 * a);
            if (0.0..=1.0).contains(&tv) && q(tv) > q(best) {
                best = tv;
            }
        }
        self.at(cie::CIE_MIN + best * (cie::CIE_MAX - cie::CIE_MIN))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wl(a: f32, b: f32, c: f32) -> Wavelengths {
        Wavelengths([a, b, c])
    }

    /// Mitsuba 3.9.1 (`scalar_spectral`): a 2×1×1 `gridvolume` with texels (0.9, 0.1, 0.1) and
    /// (0.1, 0.1, 0.9), evaluated at 450, 550 and 650 nm, at x = 0 (the first texel), 1 (the
    /// second) and 0.5 (their average): the texels are upsampled as s·ρ(rgb/s), s = 2·max, and
    /// the spectra interpolated. Within 2 % (the coefficient tables differ slightly).
    #[test]
    fn grid_texels_match_mitsuba() {
        let w = wl(450.0, 550.0, 650.0);
        let a = Sigmoid::texel(Rgb::new(0.9, 0.1, 0.1)).eval(&w);
        let b = Sigmoid::texel(Rgb::new(0.1, 0.1, 0.9)).eval(&w);
        let mid = (a + b) * 0.5;
        for (got, want) in [
            (a, [0.110297, 0.139309, 1.49238]),
            (b, [0.849476, 0.131624, 0.0877191]),
            (mid, [0.479886, 0.135466, 0.790051]),
        ] {
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() < 0.02 * want[c].max(0.1),
                    "{got:?} vs {want:?}"
                );
            }
        }
        // a constant rgb is Mitsuba's bounded srgb reflectance: (0.9, 0.1, 0.1) at 650 nm is
        // 0.965504 there (and 0.101807, 0.117833 at 450, 550)
        let r = Sigmoid::reflectance(Rgb::new(0.9, 0.1, 0.1)).eval(&w);
        for (c, want) in [0.101807f32, 0.117833, 0.965504].into_iter().enumerate() {
            assert!((r[c] - want).abs() < 0.02 * want, "{r:?}");
        }
        // the same as the BSDFs' upsampling, bit for bit
        let rgb = Rgb::new(0.3, 0.6, 0.2);
        assert_eq!(
            Sigmoid::reflectance(rgb).eval(&w),
            upsample::reflectance(rgb, &w)
        );
        let big = Rgb::new(3.0, 1.0, 0.5);
        assert_eq!(
            Sigmoid::unbounded(big).eval(&w),
            upsample::unbounded(big, &w)
        );
    }

    /// Greys and constants are exact; `max` bounds the spectrum on a 0.25 nm scan and is
    /// attained.
    #[test]
    fn constants_and_max() {
        let w = wl(400.0, 555.5, 800.0);
        for v in [0.0, 0.35, 1.0, 7.5] {
            assert_eq!(Sigmoid::constant(v).eval(&w), Rgb::splat(v));
            assert_eq!(Sigmoid::texel(Rgb::splat(v)).eval(&w), Rgb::splat(v));
            assert_eq!(Sigmoid::constant(v).max(), v);
        }
        assert_eq!(Sigmoid::reflectance(Rgb::ZERO).eval(&w), Rgb::ZERO);
        for rgb in [
            [0.9, 0.1, 0.1],
            [0.1, 0.9, 0.1],
            [0.1, 0.1, 0.9],
            [0.07, 0.4, 1.0],
            [0.95, 0.8, 0.55],
            [0.5, 0.05, 0.5],
        ] {
            for s in [
                Sigmoid::reflectance(Rgb(rgb)),
                Sigmoid::texel(Rgb(rgb) * 3.0),
            ] {
                let m = s.max();
                let scan = (0..=1880)
                    .map(|i| s.at(360.0 + i as f32 * 0.25))
                    .fold(0f32, f32::max);
                assert!(scan <= m * (1.0 + 1e-6), "{rgb:?}: scan {scan} > max {m}");
                assert!(scan >= m * (1.0 - 1e-4), "{rgb:?}: scan {scan} ≪ max {m}");
            }
        }
    }
}
