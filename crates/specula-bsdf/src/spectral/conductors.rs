//! Named conductors' measured complex index of refraction η(λ) + i k(λ), for spectral mode:
//! the same names as the RGB table of [`crate::data::NAMED_CONDUCTORS`] (`Au`, `Cu`, `Al`, …,
//! plus the extraordinary-ray tables `Se-e`, `Te-e`, `TiO2-e` and their `_palik` copies that
//! Mitsuba also ships).
//!
//! Source: Mitsuba 3's `data/ior/<name>.eta.spd` and `<name>.k.spd` (the luxpop.com database,
//! mostly Palik, *Handbook of Optical Constants of Solids*), converted to Rust data by
//! `scripts/gen_conductor_spectra.py` into `conductor_data.rs`.
//!
//! Evaluation is linear interpolation between the tabulated wavelengths, as Mitsuba's
//! `IrregularSpectrum` does. Deviation: outside a table's range (e.g. `AlSb` ends at 590 nm,
//! `d-C` at 656 nm) Mitsuba's spectrum is 0, which makes its conductor's Fresnel term NaN;
//! Specula holds the nearest tabulated value instead.

mod table {
    include!("conductor_data.rs");
}

/// A named conductor's tabulated η(λ), k(λ).
#[derive(Clone, Copy, Debug)]
pub struct ConductorSpectrum {
    pub name: &'static str,
    /// Wavelengths in nm, increasing.
    pub wavelengths: &'static [f32],
    pub eta: &'static [f32],
    pub k: &'static [f32],
}

impl ConductorSpectrum {
    /// (η, k) at `lambda_nm`, linearly interpolated (clamped outside the table).
    #[inline]
    pub fn eta_k(&self, lambda_nm: f32) -> (f32, f32) {
        let w = self.wavelengths;
        let n = w.len();
        if lambda_nm <= w[0] || lambda_nm.is_nan() {
            return (self.eta[0], self.k[0]);
        }
        if lambda_nm >= w[n - 1] {
            return (self.eta[n - 1], self.k[n - 1]);
        }
        // first index with w[i] > λ (1 ≤ i ≤ n−1)
        let i = w.partition_point(|&x| x <= lambda_nm);
        let t = (lambda_nm - w[i - 1]) / (w[i] - w[i - 1]);
        let lerp = |v: &[f32]| v[i - 1] * (1.0 - t) + v[i] * t;
        (lerp(self.eta), lerp(self.k))
    }

    /// The tabulated range (nm).
    pub fn range(&self) -> (f32, f32) {
        (
            self.wavelengths[0],
            self.wavelengths[self.wavelengths.len() - 1],
        )
    }
}

/// The tabulated spectra of the conductor `name` (case-sensitive, as Mitsuba's file names).
pub fn lookup(name: &str) -> Option<ConductorSpectrum> {
    table::TABLE
        .iter()
        .find(|(n, ..)| *n == name)
        .map(|&(name, wavelengths, eta, k)| ConductorSpectrum {
            name,
            wavelengths,
            eta,
            k,
        })
}

/// (η, k) of the conductor `name` at `lambda_nm`; `none` is the ideal mirror (η = 0, k = 1)
/// at every wavelength; `None` for an unknown name.
pub fn eta_k(name: &str, lambda_nm: f32) -> Option<(f32, f32)> {
    if name == "none" {
        return Some((0.0, 1.0));
    }
    lookup(name).map(|c| c.eta_k(lambda_nm))
}

/// Every conductor name in the table.
pub fn names() -> impl Iterator<Item = &'static str> {
    table::TABLE.iter().map(|(n, ..)| *n)
}

#[cfg(test)]
#[allow(clippy::excessive_precision)] // the .spd files' digits
mod tests {
    use super::*;

    /// Normal-incidence reflectance of a conductor.
    fn r0(eta: f32, k: f32) -> f32 {
        ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k)
    }

    #[test]
    fn table_values_are_the_spd_values() {
        // lines of Mitsuba 3.9.1's data/ior/Cu.eta.spd / Cu.k.spd and Au.*.spd
        assert_eq!(eta_k("Cu", 302.400421), Some((1.38, 1.687)));
        let (e, k) = eta_k("Au", 298.757050).unwrap();
        assert_eq!((e, k), (1.795, 1.920375));
        // half-way between two lines: the mean
        let c = lookup("Cu").unwrap();
        let (w, i) = (c.wavelengths, 10);
        let (e, k) = c.eta_k(0.5 * (w[i] + w[i + 1]));
        assert!((e - 0.5 * (c.eta[i] + c.eta[i + 1])).abs() < 1e-5);
        assert!((k - 0.5 * (c.k[i] + c.k[i + 1])).abs() < 1e-5);
        assert_eq!(eta_k("none", 500.0), Some((0.0, 1.0)));
        assert_eq!(eta_k("Unobtainium", 500.0), None);
    }

    #[test]
    fn names_cover_the_rgb_table() {
        for (n, ..) in crate::data::NAMED_CONDUCTORS {
            assert!(lookup(n).is_some(), "{n} has no spectral data");
        }
        assert_eq!(names().count(), 71);
    }

    /// Normal-incidence reflectance from the interpolated η, k against Mitsuba 3.9.1's
    /// `scalar_spectral` conductor (its sample weight at normal incidence) at the same
    /// wavelengths, off the tabulated points.
    #[test]
    fn reflectance_matches_mitsuba_spectral() {
        let lambdas = [400.0, 450.5, 550.0, 633.3, 700.0, 777.7, 380.0, 830.0];
        let mitsuba: [(&str, [f32; 8]); 5] = [
            (
                "Au",
                [
                    0.391063, 0.385647, 0.847478, 0.933265, 0.962363, 0.972072, 0.380857, 0.975411,
                ],
            ),
            (
                "Cu",
                [
                    0.492904, 0.553040, 0.634138, 0.928365, 0.954199, 0.959928, 0.478500, 0.964477,
                ],
            ),
            (
                "Ag",
                [
                    0.866433, 0.918783, 0.959808, 0.968548, 0.973819, 0.979163, 0.819033, 0.981688,
                ],
            ),
            (
                "Al",
                [
                    0.924147, 0.924019, 0.921027, 0.913686, 0.904763, 0.878187, 0.924338, 0.868405,
                ],
            ),
            (
                "Cr",
                [
                    0.686839, 0.702707, 0.658557, 0.642243, 0.638797, 0.634991, 0.667072, 0.632739,
                ],
            ),
        ];
        for (name, refl) in mitsuba {
            for (l, r) in lambdas.iter().zip(refl) {
                let (e, k) = eta_k(name, *l).unwrap();
                assert!(
                    (r0(e, k) - r).abs() < 2e-5,
                    "{name} at {l}: {} vs {r}",
                    r0(e, k)
                );
            }
        }
    }

    #[test]
    fn outside_the_range_holds_the_end_values() {
        let c = lookup("AlSb").unwrap();
        let (lo, hi) = c.range();
        assert!(hi < 600.0);
        assert_eq!(c.eta_k(700.0), c.eta_k(hi));
        assert_eq!(c.eta_k(lo - 10.0), c.eta_k(lo));
    }
}
