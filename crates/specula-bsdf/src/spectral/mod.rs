//! Spectral rendering support: in spectral mode every [`crate::Spectrum`] holds values at the
//! three wavelengths of [`crate::spectrum::Wavelengths`] instead of linear-sRGB channels.
//!
//! - [`cie`]: the CIE 1931 observer and film development (spectral samples → XYZ → sRGB);
//! - [`upsample`]: RGB → smooth spectra (Jakob & Hanika 2019);
//! - [`conductors`]: named conductors' measured η(λ), k(λ);
//! - [`dispersion`]: wavelength-dependent indices of refraction (Sellmeier, Cauchy, Abbe).

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
