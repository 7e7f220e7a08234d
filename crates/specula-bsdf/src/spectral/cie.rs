//! The CIE 1931 2° standard observer, the D65 illuminant, wavelength sampling and film
//! development for spectral mode.
//!
//! # Data
//! [`CIE_X`], [`CIE_Y`], [`CIE_Z`]: the CIE 1931 2° colour-matching functions x̄, ȳ, z̄ and
//! [`D65`]: the CIE standard illuminant D65, at 360, 365, …, 830 nm (95 entries; CIE 015:2018
//! Table 1 and CIE S 014-2/E:2006, in the single-precision values Mitsuba 3 tabulates), looked
//! up with linear interpolation and zero outside 360…830 nm, as Mitsuba does.
//!
//! # Wavelength sampling
//! [`sample_wavelengths`] draws the three wavelengths of a path from one uniform number `u`:
//! the hero wavelength from `u` and two more from `u + 1/3` and `u + 2/3` (mod 1), each by
//! inverting the density that Mitsuba's spectral variants use for RGB content
//! (`sample_rgb_spectrum`, after Radziszewski et al. 2009):
//! p(λ) = 0.0039398042 / cosh²(0.0072 (λ − 538 nm)) on 360…830 nm (it integrates to 1 there).
//! Each channel's weight is 1/p(λ). (Mitsuba traces four wavelengths per path; Specula's
//! `Spectrum` has three channels, so three. Both are unbiased; only the noise differs.)
//!
//! # Film development
//! [`develop`] turns a path's radiance at its three wavelengths into linear sRGB exactly as
//! Mitsuba's spectral `hdrfilm` does: XYZ = mean over the channels of
//! (x̄, ȳ, z̄)(λᵢ) · Lᵢ / p(λᵢ), times 1/∫ȳ dλ ([`CIE_Y_NORMALIZATION`]), then Mitsuba's XYZ →
//! linear sRGB matrix. So a spectrum equal to the (normalised) D65 illuminant develops to
//! sRGB white (1, 1, 1) and a constant spectrum 1 to ≈ (1.205, 0.948, 0.909).

/// Shortest wavelength of the tables and of spectral rendering (nm).
pub const CIE_MIN: f32 = 360.0;
/// Longest wavelength of the tables and of spectral rendering (nm).
pub const CIE_MAX: f32 = 830.0;
/// Number of entries of the CIE and D65 tables (5 nm steps).
pub const CIE_SAMPLES: usize = 95;
/// 1 / ∫ȳ(λ)dλ over the tables: makes a unit spectrum integrate to luminance 1 (Mitsuba's
/// `MI_CIE_Y_NORMALIZATION`).
pub const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Scales the D65 table to unit luminance (Mitsuba's `MI_CIE_D65_NORMALIZATION`).
pub const D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;

// CIE 1931 2° standard observer colour-matching functions x̄, ȳ, z̄ at 360, 365, …, 830 nm
// (CIE 015:2018, Table 1; the values as tabulated in single precision by Mitsuba 3,
// src/core/spectrum.cpp `cie1931_tbl`).
#[rustfmt::skip]
pub static CIE_X: [f32; CIE_SAMPLES] = [
    0.0001299, 0.0002321, 0.0004149, 0.0007416, 0.001368, 0.002236, 0.004243, 0.00765,
    0.01431, 0.02319, 0.04351, 0.07763, 0.13438, 0.21477, 0.2839, 0.3285,
    0.34828, 0.34806, 0.3362, 0.3187, 0.2908, 0.2511, 0.19536, 0.1421,
    0.09564, 0.05795001, 0.03201, 0.0147, 0.0049, 0.0024, 0.0093, 0.0291,
    0.06327, 0.1096, 0.1655, 0.2257499, 0.2904, 0.3597, 0.4334499, 0.5120501,
    0.5945, 0.6784, 0.7621, 0.8425, 0.9163, 0.9786, 1.0263, 1.0567,
    1.0622, 1.0456, 1.0026, 0.9384, 0.8544499, 0.7514, 0.6424, 0.5419,
    0.4479, 0.3608, 0.2835, 0.2187, 0.1649, 0.1212, 0.0874, 0.0636,
    0.04677, 0.0329, 0.0227, 0.01584, 0.01135916, 0.008110916, 0.005790346, 0.004109457,
    0.002899327, 0.00204919, 0.001439971, 0.0009999493, 0.0006900786, 0.0004760213, 0.0003323011, 0.0002348261,
    0.0001661505, 0.000117413, 0.00008307527, 0.00005870652, 0.00004150994, 0.00002935326, 0.00002067383, 0.00001455977,
    0.00001025398, 0.000007221456, 0.000005085868, 0.000003581652, 0.000002522525, 0.000001776509, 0.000001251141,
];
#[rustfmt::skip]
pub static CIE_Y: [f32; CIE_SAMPLES] = [
    0.000003917, 0.000006965, 0.00001239, 0.00002202, 0.000039, 0.000064, 0.00012, 0.000217,
    0.000396, 0.00064, 0.00121, 0.00218, 0.004, 0.0073, 0.0116, 0.01684,
    0.023, 0.0298, 0.038, 0.048, 0.06, 0.0739, 0.09098, 0.1126,
    0.13902, 0.1693, 0.20802, 0.2586, 0.323, 0.4073, 0.503, 0.6082,
    0.71, 0.7932, 0.862, 0.9148501, 0.954, 0.9803, 0.9949501, 1.0,
    0.995, 0.9786, 0.952, 0.9154, 0.87, 0.8163, 0.757, 0.6949,
    0.631, 0.5668, 0.503, 0.4412, 0.381, 0.321, 0.265, 0.217,
    0.175, 0.1382, 0.107, 0.0816, 0.061, 0.04458, 0.032, 0.0232,
    0.017, 0.01192, 0.00821, 0.005723, 0.004102, 0.002929, 0.002091, 0.001484,
    0.001047, 0.00074, 0.00052, 0.0003611, 0.0002492, 0.0001719, 0.00012, 0.0000848,
    0.00006, 0.0000424, 0.00003, 0.0000212, 0.00001499, 0.0000106, 0.0000074657, 0.0000052578,
    0.0000037029, 0.0000026078, 0.0000018366, 0.0000012934, 0.00000091093, 0.00000064153, 0.00000045181,
];
#[rustfmt::skip]
pub static CIE_Z: [f32; CIE_SAMPLES] = [
    0.0006061, 0.001086, 0.001946, 0.003486, 0.006450001, 0.01054999, 0.02005001, 0.03621,
    0.06785001, 0.1102, 0.2074, 0.3713, 0.6456, 1.0390501, 1.3856, 1.62296,
    1.74706, 1.7826, 1.77211, 1.7441, 1.6692, 1.5281, 1.28764, 1.0419,
    0.8129501, 0.6162, 0.46518, 0.3533, 0.272, 0.2123, 0.1582, 0.1117,
    0.07824999, 0.05725001, 0.04216, 0.02984, 0.0203, 0.0134, 0.008749999, 0.005749999,
    0.0039, 0.002749999, 0.0021, 0.0018, 0.001650001, 0.0014, 0.0011, 0.001,
    0.0008, 0.0006, 0.00034, 0.00024, 0.00019, 0.0001, 0.00004999999, 0.00003,
    0.00002, 0.00001, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
];
// CIE standard illuminant D65, relative spectral power (100 at 560 nm), 360…830 nm in 5 nm
// steps (CIE S 014-2/E:2006; as tabulated by Mitsuba 3, include/mitsuba/core/spectrum.h
// `d65_table`).
#[rustfmt::skip]
pub static D65: [f32; CIE_SAMPLES] = [
    46.6383, 49.3637, 52.0891, 51.0323, 49.9755, 52.3118, 54.6482, 68.7015, 82.7549, 87.1204,
    91.486, 92.4589, 93.4318, 90.057, 86.6823, 95.7736, 104.865, 110.936, 117.008, 117.41,
    117.812, 116.336, 114.861, 115.392, 115.923, 112.367, 108.811, 109.082, 109.354, 108.578,
    107.802, 106.296, 104.79, 106.239, 107.689, 106.047, 104.405, 104.225, 104.046, 102.023,
    100.0, 98.1671, 96.3342, 96.0611, 95.788, 92.2368, 88.6856, 89.3459, 90.0062, 89.8026,
    89.5991, 88.6489, 87.6987, 85.4936, 83.2886, 83.4939, 83.6992, 81.863, 80.0268, 80.1207,
    80.2146, 81.2462, 82.2778, 80.281, 78.2842, 74.0027, 69.7213, 70.6652, 71.6091, 72.979,
    74.349, 67.9765, 61.604, 65.7448, 69.8856, 72.4863, 75.087, 69.3398, 63.5927, 55.0054,
    46.4182, 56.6118, 66.8054, 65.0941, 63.3828, 63.8434, 64.304, 61.8779, 59.4519, 55.7054,
    51.959, 54.6998, 57.4406, 58.8765, 60.3125,
];

/// Mitsuba's XYZ → linear sRGB (ITU-R BT.709, D65 white) matrix, rows.
#[rustfmt::skip]
pub const XYZ_TO_SRGB: [[f32; 3]; 3] = [
    [ 3.240479, -1.53715,  -0.498535],
    [-0.969256,  1.875991,  0.041556],
    [ 0.055648, -0.204043,  1.057311],
];

/// Index and fraction of wavelength `w` in the 5 nm tables; `None` outside 360…830 nm.
#[inline]
fn table_pos(w: f32) -> Option<(usize, f32)> {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return None;
    }
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f32 / (CIE_MAX - CIE_MIN));
    let i = (t as usize).min(CIE_SAMPLES - 2);
    Some((i, t - i as f32))
}

#[inline]
fn lerp_table(tab: &[f32; CIE_SAMPLES], i: usize, f: f32) -> f32 {
    (1.0 - f).mul_add(tab[i], f * tab[i + 1])
}

/// The colour-matching functions (x̄, ȳ, z̄) at `w` nm (not normalised; ȳ peaks at 1 near
/// 555 nm); zero outside 360…830 nm.
#[inline]
pub fn xyz_bar(w: f32) -> [f32; 3] {
    match table_pos(w) {
        Some((i, f)) => [
            lerp_table(&CIE_X, i, f),
            lerp_table(&CIE_Y, i, f),
            lerp_table(&CIE_Z, i, f),
        ],
        None => [0.0; 3],
    }
}

/// The D65 illuminant at `w` nm, normalised to unit luminance (so that it develops to sRGB
/// white (1, 1, 1)); zero outside 360…830 nm.
#[inline]
pub fn d65(w: f32) -> f32 {
    match table_pos(w) {
        Some((i, f)) => lerp_table(&D65, i, f) * D65_NORMALIZATION as f32,
        None => 0.0,
    }
}

/// XYZ tristimulus values to linear sRGB.
#[inline]
pub fn xyz_to_srgb(xyz: [f32; 3]) -> [f32; 3] {
    XYZ_TO_SRGB.map(|r| r[0] * xyz[0] + r[1] * xyz[1] + r[2] * xyz[2])
}

const PDF_SCALE: f32 = 0.003_939_804;
const PDF_K: f32 = 0.0072;
const PDF_CENTRE: f32 = 538.0;

/// Density (per nm) with which [`sample_wavelengths`] draws each wavelength; zero outside
/// 360…830 nm.
#[inline]
pub fn wavelength_pdf(w: f32) -> f32 {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return 0.0;
    }
    let c = (PDF_K * (w - PDF_CENTRE)).cosh();
    PDF_SCALE / (c * c)
}

/// The CDF of [`wavelength_pdf`] at `w` nm (0 at 360 nm, 1 at 830 nm): the uniform number
/// [`sample_wavelength`] maps to `w`.
#[inline]
pub fn wavelength_cdf(w: f32) -> f32 {
    let a = (PDF_K * (CIE_MIN - PDF_CENTRE)).tanh();
    let b = (PDF_K * (CIE_MAX - PDF_CENTRE)).tanh();
    let x = (PDF_K * (w.clamp(CIE_MIN, CIE_MAX) - PDF_CENTRE)).tanh();
    ((x - a) / (b - a)).clamp(0.0, 1.0)
}

/// Inverts the CDF of [`wavelength_pdf`]: the wavelength of the uniform number `u` ∈ [0, 1).
#[inline]
pub fn sample_wavelength(u: f32) -> f32 {
    // CDF(λ) = (tanh(k(λ−538)) − tanh(k(360−538))) · scale/k; solved for λ
    let a = (PDF_K * (CIE_MIN - PDF_CENTRE)).tanh();
    let b = (PDF_K * (CIE_MAX - PDF_CENTRE)).tanh();
    let x = a + u * (b - a);
    (PDF_CENTRE + x.atanh() / PDF_K).clamp(CIE_MIN, CIE_MAX)
}

/// The three wavelengths of a path from one uniform number `u` (hero wavelength from `u`,
/// the others from `u + 1/3` and `u + 2/3` mod 1), and their weights 1/p(λ).
#[inline]
pub fn sample_wavelengths(u: f32) -> (crate::Wavelengths, [f32; 3]) {
    let mut w = [0.0f32; 3];
    let mut weight = [0.0f32; 3];
    for i in 0..3 {
        let mut ui = u + i as f32 * (1.0 / 3.0);
        if ui >= 1.0 {
            ui -= 1.0;
        }
        w[i] = sample_wavelength(ui);
        weight[i] = 1.0 / wavelength_pdf(w[i]);
    }
    (crate::Wavelengths(w), weight)
}

/// Develops the radiance `l` carried at the wavelengths `w` (drawn with weights `weight` =
/// 1/p(λ)) to linear sRGB, as Mitsuba's spectral film does (see the module docs).
#[inline]
pub fn develop(l: crate::Spectrum, w: &crate::Wavelengths, weight: &[f32; 3]) -> crate::Rgb {
    let mut xyz = [0.0f32; 3];
    for ((&li, &wi), &lambda) in l.0.iter().zip(weight).zip(&w.0) {
        let v = li * wi;
        let c = xyz_bar(lambda);
        for (x, ck) in xyz.iter_mut().zip(c) {
            *x += ck * v;
        }
    }
    let s = (CIE_Y_NORMALIZATION / 3.0) as f32;
    crate::Rgb(xyz_to_srgb(xyz.map(|v| v * s)))
}

/// The linear-sRGB colour of a unit-power monochromatic spectrum at `w` nm (Y normalised as
/// in [`develop`]): what the film converges to for light of that single wavelength.
pub fn monochromatic_srgb(w: f32) -> crate::Rgb {
    let c = xyz_bar(w);
    crate::Rgb(xyz_to_srgb(c.map(|v| v * CIE_Y_NORMALIZATION as f32)))
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::{Rgb, Wavelengths};

    #[test]
    fn sampling_matches_mitsuba_and_integrates_to_one() {
        // Mitsuba 3.9.1: mi.sample_rgb_spectrum(0.3) = (493.6856, 280.5481),
        // mi.pdf_rgb_spectrum(538) = 0.0039398042
        let w = sample_wavelength(0.3);
        assert!((w - 493.6856).abs() < 0.02, "{w}");
        assert!((1.0 / wavelength_pdf(w) - 280.5481).abs() < 0.05);
        assert!((wavelength_pdf(538.0) - 0.003_939_804).abs() < 1e-8);
        // ∫p = 1 over 360…830 nm (midpoint rule, 0.01 nm)
        let n = 47_000;
        let s: f64 = (0..n)
            .map(|i| wavelength_pdf(360.0 + (i as f32 + 0.5) * 0.01) as f64 * 0.01)
            .sum();
        assert!((s - 1.0).abs() < 1e-3, "{s}");
        // the inverse CDF is monotone and covers the range
        assert!((sample_wavelength(0.0) - 360.0).abs() < 0.05);
        assert!((sample_wavelength(0.999_999) - 830.0).abs() < 0.5);
        let (wl, wt) = sample_wavelengths(0.9);
        assert_eq!(wl.0[0], sample_wavelength(0.9));
        assert!((wl.0[1] - sample_wavelength(0.9 + 1.0 / 3.0 - 1.0)).abs() < 1e-3);
        assert!(wt.iter().all(|&v| v > 0.0 && v.is_finite()));
    }

    /// A monochromatic spectrum (radiance concentrated at λ₀, represented by a narrow box of
    /// unit power) develops, by Monte Carlo over the film's own wavelength sampling, to the
    /// CIE colour of λ₀: XYZ = (x̄, ȳ, z̄)(λ₀)/∫ȳ, in sRGB.
    #[test]
    fn monochromatic_spectrum_develops_to_its_cie_colour() {
        for &w0 in &[450.0f32, 520.0, 580.0, 640.0] {
            let half = 0.5f32; // box of 1 nm around w0, height 1/(1 nm): unit power
                               // stratified u: the film's estimator integrated by quadrature
            let n = 300_000;
            let mut acc = [0.0f64; 3];
            for j in 0..n {
                let (wl, wt) = sample_wavelengths((j as f32 + 0.5) / n as f32);
                let l = Rgb(wl.0.map(|w| if (w - w0).abs() < half { 1.0 } else { 0.0 }));
                let c = develop(l, &wl, &wt);
                for k in 0..3 {
                    acc[k] += c.0[k] as f64 / n as f64;
                }
            }
            let want = monochromatic_srgb(w0);
            let scale = want.0.iter().map(|v| v.abs()).fold(0.0f32, f32::max) as f64;
            for k in 0..3 {
                assert!(
                    (acc[k] - want.0[k] as f64).abs() < 0.01 * scale,
                    "{w0} nm channel {k}: {} vs {}",
                    acc[k],
                    want.0[k]
                );
            }
            // the CIE chromaticity of the wavelength itself (x̄, ȳ, z̄ at λ₀), independent of
            // the tables' interpolation: e.g. 580 nm is yellow (x ≈ 0.512, y ≈ 0.487)
            if w0 == 580.0 {
                let c = xyz_bar(580.0);
                let s = c[0] + c[1] + c[2];
                assert!((c[0] / s - 0.5125).abs() < 1e-3 && (c[1] / s - 0.4866).abs() < 1e-3);
            }
        }
    }

    #[test]
    fn d65_develops_to_white_and_flat_spectrum_to_mitsubas_colour() {
        let mut rng = Pcg32::new(3, 1);
        let n = 200_000;
        let (mut d, mut f) = ([0.0f64; 3], [0.0f64; 3]);
        for _ in 0..n {
            let (wl, wt) = sample_wavelengths(rng.next_f32());
            let a = develop(Rgb(wl.0.map(d65)), &wl, &wt);
            let b = develop(Rgb::ONE, &wl, &wt);
            for k in 0..3 {
                d[k] += a.0[k] as f64 / n as f64;
                f[k] += b.0[k] as f64 / n as f64;
            }
        }
        for k in 0..3 {
            assert!((d[k] - 1.0).abs() < 0.01, "D65 → {d:?}");
        }
        // Mitsuba: a flat emission spectrum 1 is (1.20488, 0.948228, 0.909267) in sRGB
        let want = [1.20488, 0.948228, 0.909267];
        for k in 0..3 {
            assert!((f[k] - want[k]).abs() < 0.01, "flat → {f:?}");
        }
        let _ = Wavelengths([500.0; 3]);
    }
}
