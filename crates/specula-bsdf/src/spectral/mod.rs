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
