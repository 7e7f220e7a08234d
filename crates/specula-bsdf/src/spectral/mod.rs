//! Spectral rendering support: in spectral mode every [`crate::Spectrum`] holds values at the
//! three wavelengths of [`crate::spectrum::Wavelengths`] instead of linear-sRGB channels.
//!
//! - [`cie`]: the CIE 1931 observer and film development (spectral samples → XYZ → sRGB);
//! - [`upsample`]: RGB → smooth spectra (Jakob & Hanika 2019);
//! - [`conductors`]: named conductors' measured η(λ), k(λ);
//! - [`dispersion`]: wavelength-dependent indices of refraction (Sellmeier, Cauchy, Abbe).
//!
//! # Spectral mode (design)
//! A path carries three wavelengths (channel 0 the hero) drawn per camera sample from
//! Mitsuba's `sample_rgb_spectrum` density on 360…830 nm, the other two rotated by a third of
//! its CDF, each weighted 1/p(λ) ([`cie::sample_wavelengths`]); the renderer draws a pixel's
//! samples as a randomly shifted golden-ratio sequence so they cover the spectrum evenly
//! (`specula_render::spectral`). Models are unchanged: they receive the wavelengths in
//! `ShadingPoint::wavelengths` and every parameter evaluates at them —
//! [`crate::SpectrumParam`] upsamples RGB constants and texels ([`upsample::unbounded`]:
//! Jakob–Hanika sigmoid-quadratic spectra from a coefficient table this crate computes at the
//! first use, never loaded), evaluates measured curves (`SpectrumParam::Spectral`: a named
//! conductor's η(λ), k(λ) from [`conductors`], via [`NamedConductor`]), and the measured
//! BSDFs upsample their RGB values. The renderer converts emitted RGB as Mitsuba's `d65`
//! spectrum ([`upsample::illuminant`]) and develops each sample's radiance to linear sRGB
//! through the CIE 1931 observer ([`cie::develop`], Mitsuba's normalisation) before the film.
//! RGB mode (`wavelengths` = `None`) is the default and takes none of these branches.

pub mod cie;
pub mod conductors;
pub mod dispersion;
pub mod upsample;

/// η(λ) (`k` false) or k(λ) (`k` true) of a named conductor, as a
/// [`crate::bsdf::SpectralCurve`] (what `conductor`/`roughconductor` with `material="Au"` etc.
/// evaluate in spectral mode).
#[derive(Clone, Copy, Debug)]
pub struct NamedConductor {
    pub c: conductors::ConductorSpectrum,
    pub k: bool,
}

impl crate::bsdf::SpectralCurve for NamedConductor {
    #[inline]
    fn eval(&self, lambda: f32) -> f32 {
        let (eta, k) = self.c.eta_k(lambda);
        if self.k {
            k
        } else {
            eta
        }
    }
}
