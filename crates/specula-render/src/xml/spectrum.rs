//! `<spectrum>` values: their conversion to linear sRGB, as Mitsuba 3's RGB variants
//! (`scalar_rgb`, `llvm_ad_rgb`) do it, and their values at any wavelength, as Mitsuba 3's
//! spectral variants (`scalar_spectral`, `llvm_ad_spectral`) use them
//! ([`Spectrum`] is a [`SpectralCurve`]).
//!
//! # Forms (what the XML reader produces)
//! - `value="v"`: a constant ([`Spectrum::Constant`]).
//! - `value="λ1:v1, λ2:v2, …"` (nm, strictly increasing, any spacing, at least two pairs) and
//!   `filename="x.spd"` (Mitsuba's text format: one `wavelength value` pair per line, `#`
//!   comments, blank lines ignored): [`Spectrum::Sampled`], linear between the samples and zero
//!   outside them.
//! - `<spectrum type="…" name="…">` with nested parameters, Mitsuba's spectrum plugins:
//!   `uniform` (`value`), `d65` (`color` (rgb, default 1), `scale` (default 1)), `srgb`
//!   (`color`, `unbounded` (default false)), `blackbody` (`temperature` in K, required;
//!   `wavelength_min`/`wavelength_max`, default 360/830 nm), `regular` (`wavelength_min`,
//!   `wavelength_max`, `values`: a list of at least two numbers, evenly spaced) and
//!   `irregular` (`wavelengths`, `values`: lists of equal length).
//!
//! # Conversion (Mitsuba 3.9.1's `Properties::get_texture_impl` and `spectrum_list_to_srgb`)
//! A parameter reads a spectrum in one of three ways ([`Usage`]), as Mitsuba's plugins call
//! `get_texture`, `get_unbounded_texture` or `get_emissive_texture`:
//! - **Sampled spectra** are integrated against the CIE 1931 2° colour-matching functions:
//!   1000 wavelengths w_i = 360 + (i/999)·470 nm (i = 0…999); those outside
//!   [first, last sample] are skipped; the spectrum is interpolated linearly; for
//!   reflectances and other non-emission parameters it is also multiplied by the CIE D65
//!   illuminant (normalised to unit luminance: table value / 98.99741751876255); the sum of
//!   xyz(w_i)·v(w_i)(·d65(w_i)) is scaled by 470/1000 and by 1/106.7502593994140625 (so that a
//!   unit spectrum has luminance ≈ 1), and converted to linear sRGB with Mitsuba's XYZ→sRGB
//!   matrix. The CIE curves and D65 are Mitsuba's 5 nm tables (360…830 nm, 95 entries),
//!   interpolated linearly. Then: [`Usage::Reflectance`] clamps to [0, 1],
//!   [`Usage::Unbounded`] and [`Usage::Emission`] clamp negative channels to 0. So a flat
//!   reflectance of 0.5 becomes ≈ (0.5, 0.5, 0.5), while a flat emission spectrum of 1 over
//!   360…830 nm becomes (1.20488, 0.948228, 0.909267): D65 is the white point of sRGB, so
//!   an equal-energy emitter looks purple-ish, exactly as in Mitsuba's spectral variants.
//! - **Constants** stay grey (v, v, v) except in emission, where Mitsuba 3.9 uses
//!   v · XYZ→sRGB(1, 1, 1) = v · (1.204794, 0.948291, 0.908916) for the same reason. (A
//!   `<float>` or `<rgb>` emission value is not converted.)
//! - **Plugins** are Mitsuba objects and are used as they evaluate in RGB mode: `uniform` →
//!   (v, v, v); `d65` → color × scale; `srgb` → color (outside [0, 1] an error unless
//!   `unbounded`, as in Mitsuba). Where Mitsuba's
//!   RGB variants load `blackbody`, `regular` and `irregular` but fail when rendering ("Not
//!   implemented for non-spectral modes"), Specula converts them as a wavelength list in the
//!   same place would be (the answer of Mitsuba's spectral variants): `regular`/`irregular`
//!   exactly like `value="λ:v, …"`; `blackbody` by evaluating Planck's law (W·m⁻²·sr⁻¹·nm⁻¹,
//!   Mitsuba's constants) at the 1000 wavelengths; `blackbody` is accepted only for emission.
//!
//! # Spectral mode (Mitsuba 3.9.1's `*_spectral` variants, probed with its Python bindings)
//! A parameter given a `<spectrum>` keeps both values: its RGB conversion above, used in RGB
//! mode, and the spectrum itself ([`Spectrum::curve`]), used in spectral mode
//! (`specula_bsdf::SpectrumParam::Spectral` for BSDF parameters, the emitters' `spectrum`
//! fields and `AreaRadiance::Spectral` for lights). At wavelength λ, whatever the parameter:
//! - wavelength lists, `.spd` files, `regular`, `irregular`: the linear interpolant, zero
//!   outside the sampled range, *not* clamped (a reflectance of 1.5 at 500 nm stays 1.5, as
//!   in Mitsuba's spectral variants, where the RGB variants clamp the colour to [0, 1]);
//! - `value="v"` and `uniform`: v at every wavelength, emitters included (Mitsuba: a
//!   `<spectrum value="0.5">` radiance is 0.5 everywhere, not 0.5 × D65; an `<rgb>` or
//!   `<float>` radiance of 0.5 is 0.5 × D65);
//! - `blackbody`: Planck's law in W·m⁻²·sr⁻¹·nm⁻¹, unnormalised, zero outside
//!   [`wavelength_min`, `wavelength_max`];
//! - `d65`: the normalised D65 illuminant × `scale`, with `color` Mitsuba's upsampled emission
//!   spectrum of the colour ([`upsample::illuminant`]), for emitters and BSDFs alike;
//! - `srgb`: the colour's upsampled reflectance spectrum ([`upsample::unbounded`]), also on an
//!   emitter (no D65 factor: Mitsuba's `srgb` plugin is a reflectance spectrum wherever it is
//!   used).
//!
//! An emitter's `<spectrum>` must not be negative anywhere (an error, as a negative RGB
//! light is); a `blackbody` stays an emission-only spectrum (Mitsuba's spectral variants would
//! take one as a reflectance too).

use specula_bsdf::bsdf::SpectralCurve;
use specula_bsdf::spectral::upsample;
use specula_bsdf::{Rgb, Wavelengths};
use std::fmt;
use std::sync::Arc;

/// Shortest wavelength of the CIE tables (nm).
pub const CIE_MIN: f64 = 360.0;
/// Longest wavelength of the CIE tables (nm).
pub const CIE_MAX: f64 = 830.0;
/// Number of entries of the CIE and D65 tables (5 nm steps).
pub const CIE_SAMPLES: usize = 95;
/// 1 / ∫ȳ(λ)dλ over the tables: makes a unit spectrum integrate to luminance 1 (Mitsuba's
/// `MI_CIE_Y_NORMALIZATION`).
pub const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
/// Scales the D65 table to unit luminance (Mitsuba's `MI_CIE_D65_NORMALIZATION`).
pub const D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;
/// Wavelengths at which Mitsuba's `spectrum_list_to_srgb` samples a spectrum.
pub const INTEGRATION_STEPS: usize = 1000;

// The CIE 1931 2° observer x̄, ȳ, z̄ and the D65 illuminant at 360, 365, …, 830 nm: one copy,
// in the material library (its spectral mode uses them too).
pub use specula_bsdf::spectral::cie::{CIE_X, CIE_Y, CIE_Z, D65};

/// Mitsuba's XYZ → linear sRGB (ITU-R BT.709, D65 white) matrix, rows.
#[rustfmt::skip]
const XYZ_TO_SRGB: [[f32; 3]; 3] = [
    [ 3.240479, -1.53715,  -0.498535],
    [-0.969256,  1.875991,  0.041556],
    [ 0.055648, -0.204043,  1.057311],
];

/// Linear interpolation in one of the 5 nm tables, as Mitsuba does it; 0 outside 360…830 nm.
fn table_lookup(tables: &[&[f32; CIE_SAMPLES]], w: f64, out: &mut [f64]) {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        out.iter_mut().for_each(|o| *o = 0.0);
        return;
    }
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    let w1 = t - i0 as f64;
    let w0 = 1.0 - w1;
    for (o, tab) in out.iter_mut().zip(tables) {
        *o = w0.mul_add(tab[i0] as f64, w1 * tab[i0 + 1] as f64);
    }
}

/// The CIE 1931 colour-matching functions (x̄, ȳ, z̄) at wavelength `w` (nm); 0 outside
/// 360…830 nm.
pub fn cie1931_xyz(w: f64) -> [f64; 3] {
    let mut out = [0.0; 3];
    table_lookup(&[&CIE_X, &CIE_Y, &CIE_Z], w, &mut out);
    out
}

/// The D65 illuminant at wavelength `w` (nm), normalised to unit luminance; 0 outside
/// 360…830 nm.
pub fn cie_d65(w: f64) -> f64 {
    let mut out = [0.0];
    table_lookup(&[&D65], w, &mut out);
    out[0] * D65_NORMALIZATION
}

/// XYZ tristimulus values to linear sRGB (Mitsuba's matrix).
pub fn xyz_to_srgb(xyz: [f64; 3]) -> [f64; 3] {
    XYZ_TO_SRGB.map(|row| row[0] as f64 * xyz[0] + row[1] as f64 * xyz[1] + row[2] as f64 * xyz[2])
}

/// Planck's law: black-body spectral radiance in W·m⁻²·sr⁻¹·nm⁻¹ at wavelength `w` (nm) and
/// temperature `t` (K), with the constants of Mitsuba's `blackbody` plugin.
pub fn planck(w: f64, t: f64) -> f64 {
    const C: f64 = 2.997_924_58e8; // speed of light, m/s
    const H: f64 = 6.626_070_04e-34; // Planck constant, J·s
    const K: f64 = 1.380_648_52e-23; // Boltzmann constant, J/K
    let l = w * 1e-9;
    1e-9 * (2.0 * H * C * C) / (l.powi(5) * ((H * C / (K * l * t)).exp_m1()))
}

/// How a parameter reads a spectrum (Mitsuba's `get_texture`, `get_unbounded_texture`,
/// `get_emissive_texture`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Usage {
    /// A reflectance or transmittance: D65-weighted, clamped to [0, 1].
    Reflectance,
    /// An unbounded non-emission value (IOR `eta`/`k`, roughness `alpha`): D65-weighted,
    /// negative channels clamped to 0.
    Unbounded,
    /// Radiance, intensity or irradiance of an emitter: not D65-weighted, negative channels
    /// clamped to 0.
    Emission,
}

/// Mitsuba's `spectrum_list_to_srgb` applied to a spectrum given as a function: `f(w)` is its
/// value at `w` nm, or `None` where it is not defined (skipped, i.e. zero). `bounded` clamps to
/// [0, 1] (else only negative channels are clamped); `d65` weights by the D65 illuminant.
pub fn integrate_to_srgb(f: impl Fn(f64) -> Option<f64>, bounded: bool, d65: bool) -> [f64; 3] {
    let mut xyz = [0.0f64; 3];
    for i in 0..INTEGRATION_STEPS {
        let w = CIE_MIN + (i as f64 / (INTEGRATION_STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        let Some(v) = f(w) else { continue };
        let weight = v * if d65 { cie_d65(w) } else { 1.0 };
        let c = cie1931_xyz(w);
        for k in 0..3 {
            xyz[k] += c[k] * weight;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) / INTEGRATION_STEPS as f64 * CIE_Y_NORMALIZATION;
    let rgb = xyz_to_srgb(xyz.map(|v| v * scale));
    if bounded {
        rgb.map(|v| v.clamp(0.0, 1.0))
    } else {
        rgb.map(|v| v.max(0.0))
    }
}

/// A spectrum tabulated at strictly increasing wavelengths (nm), linear in between.
#[derive(Clone, Debug, PartialEq)]
pub struct Sampled {
    wavelengths: Vec<f64>,
    values: Vec<f64>,
}

impl Sampled {
    /// Checks Mitsuba's rules (at least two samples, strictly increasing wavelengths) and, in
    /// addition, that every number is finite.
    pub fn new(wavelengths: Vec<f64>, values: Vec<f64>) -> Result<Self, String> {
        if wavelengths.len() != values.len() {
            return Err(format!(
                "{} wavelengths but {} values",
                wavelengths.len(),
                values.len()
            ));
        }
        if wavelengths.len() < 2 {
            return Err(format!(
                "a spectrum needs at least two wavelength:value pairs, found {}",
                wavelengths.len()
            ));
        }
        if let Some(v) = wavelengths.iter().chain(&values).find(|v| !v.is_finite()) {
            return Err(format!("{v} is not a finite number"));
        }
        if let Some(w) = wavelengths.windows(2).find(|w| w[1] <= w[0]) {
            return Err(format!(
                "wavelengths must increase strictly ({} nm is followed by {} nm)",
                w[0], w[1]
            ));
        }
        Ok(Sampled {
            wavelengths,
            values,
        })
    }

    /// Parses `value="λ1:v1, λ2:v2, …"` (pairs separated by commas and/or whitespace).
    pub fn parse_pairs(s: &str) -> Result<Self, String> {
        let (mut wl, mut vals) = (Vec::new(), Vec::new());
        for tok in s
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
        {
            let Some((a, b)) = tok.split_once(':') else {
                return Err(format!("'{tok}' is not a wavelength:value pair"));
            };
            let num = |x: &str| {
                x.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| format!("'{tok}' is not a wavelength:value pair of numbers"))
            };
            wl.push(num(a)?);
            vals.push(num(b)?);
        }
        Self::new(wl, vals)
    }

    /// Parses the text of an `.spd` file: one `wavelength value` pair per line (separated by
    /// whitespace), `#` comments, blank lines ignored. Errors name the 1-based line.
    pub fn parse_spd(text: &str) -> Result<Self, String> {
        let (mut wl, mut vals) = (Vec::new(), Vec::new());
        for (i, line) in text.lines().enumerate() {
            let line = line.split('#').next().unwrap_or("");
            let toks: Vec<&str> = line.split_whitespace().collect();
            if toks.is_empty() {
                continue;
            }
            let num = |x: &str| x.parse::<f64>().ok().filter(|v| v.is_finite());
            match toks.as_slice() {
                [a, b] => match (num(a), num(b)) {
                    (Some(a), Some(b)) => {
                        wl.push(a);
                        vals.push(b);
                    }
                    _ => {
                        return Err(format!(
                            "line {}: '{}' is not a pair of numbers",
                            i + 1,
                            line.trim()
                        ))
                    }
                },
                _ => {
                    return Err(format!(
                        "line {}: expected 'wavelength value', found '{}'",
                        i + 1,
                        line.trim()
                    ))
                }
            }
        }
        Self::new(wl, vals).map_err(|e| format!("{e} (in the file as a whole)"))
    }

    /// `n ≥ 2` values evenly spaced from `min` to `max` nm (Mitsuba's `regular` spectrum).
    pub fn regular(min: f64, max: f64, values: Vec<f64>) -> Result<Self, String> {
        if values.len() < 2 {
            return Err(format!(
                "a regular spectrum needs at least two values, found {}",
                values.len()
            ));
        }
        let step = (max - min) / (values.len() - 1) as f64;
        let wl = (0..values.len()).map(|i| min + step * i as f64).collect();
        Self::new(wl, values)
    }

    pub fn wavelengths(&self) -> &[f64] {
        &self.wavelengths
    }

    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// The linear interpolant at `w` nm; `None` outside the sampled range.
    pub fn eval(&self, w: f64) -> Option<f64> {
        let (first, last) = (self.wavelengths[0], *self.wavelengths.last()?);
        if !(first..=last).contains(&w) {
            return None;
        }
        // the last sample with wavelength <= w, as the start of an interval
        let i = self
            .wavelengths
            .partition_point(|&x| x <= w)
            .clamp(1, self.wavelengths.len() - 1)
            - 1;
        let (w0, w1) = (self.wavelengths[i], self.wavelengths[i + 1]);
        let (v0, v1) = (self.values[i], self.values[i + 1]);
        Some(((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1))
    }
}

/// A `<spectrum>` value as written in the scene (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// `value="v"`.
    Constant(f64),
    /// Wavelength:value pairs (`value="λ:v, …"`, `filename=`, `regular`, `irregular`).
    Sampled(Sampled),
    /// `<spectrum type="uniform">`.
    Uniform(f64),
    /// `<spectrum type="d65">` (in RGB modes: `color` × `scale`).
    D65 { color: [f64; 3], scale: f64 },
    /// `<spectrum type="srgb">`.
    Srgb { color: [f64; 3], unbounded: bool },
    /// `<spectrum type="blackbody">`: temperature (K) and wavelength range (nm).
    Blackbody { temperature: f64, range: [f64; 2] },
}

impl Spectrum {
    /// The value a parameter that takes a plain number sees, for the forms Mitsuba treats as
    /// one (`value="v"`, `uniform`).
    pub fn as_constant(&self) -> Option<f64> {
        match self {
            Spectrum::Constant(v) | Spectrum::Uniform(v) => Some(*v),
            _ => None,
        }
    }

    /// Linear sRGB as Mitsuba's RGB variants use this spectrum for a parameter read as `usage`
    /// (see the module docs). Errors say why the value is unusable there.
    pub fn to_rgb(&self, usage: Usage) -> Result<[f32; 3], String> {
        let f = |c: [f64; 3]| c.map(|v| v as f32);
        Ok(match self {
            Spectrum::Constant(v) if usage == Usage::Emission => {
                // Mitsuba: const_value * xyz_to_srgb(Color3f(1.0)), in single precision
                let white = XYZ_TO_SRGB.map(|r| r[0] + r[1] + r[2]);
                white.map(|w| (*v * w as f64) as f32)
            }
            Spectrum::Constant(v) | Spectrum::Uniform(v) => [*v as f32; 3],
            Spectrum::Sampled(s) => f(integrate_to_srgb(
                |w| s.eval(w),
                usage == Usage::Reflectance,
                usage != Usage::Emission,
            )),
            Spectrum::D65 { color, scale } => f(color.map(|c| c * scale)),
            Spectrum::Srgb { color, unbounded } => {
                if !unbounded && color.iter().any(|c| !(0.0..=1.0).contains(c)) {
                    return Err(format!(
                        "srgb colour [{}, {}, {}] is outside [0, 1]; set \
                         <boolean name=\"unbounded\" value=\"true\"/> (as Mitsuba requires)",
                        color[0], color[1], color[2]
                    ));
                }
                f(*color)
            }
            Spectrum::Blackbody { temperature, range } => {
                if usage != Usage::Emission {
                    return Err("a blackbody spectrum is an emission spectrum: it can only \
                                set an emitter's radiance, intensity or irradiance"
                        .into());
                }
                let [lo, hi] = *range;
                f(integrate_to_srgb(
                    |w| (lo..=hi).contains(&w).then(|| planck(w, *temperature)),
                    false,
                    false,
                ))
            }
        })
    }
}

impl Spectrum {
    /// The spectrum as spectral mode evaluates it (see the module docs), shared.
    pub fn curve(&self) -> Arc<dyn SpectralCurve> {
        Arc::new(self.clone())
    }

    /// The smallest value of a tabulated spectrum (for the emitters' non-negativity check);
    /// `None` for the other forms (which are non-negative by construction, or checked where
    /// they are parsed).
    pub fn min_sample(&self) -> Option<f64> {
        match self {
            Spectrum::Sampled(s) => s.values.iter().copied().reduce(f64::min),
            Spectrum::Constant(v) | Spectrum::Uniform(v) => Some(*v),
            _ => None,
        }
    }
}

impl SpectralCurve for Spectrum {
    #[inline]
    fn eval(&self, lambda: f32) -> f32 {
        match self {
            Spectrum::Constant(v) | Spectrum::Uniform(v) => *v as f32,
            Spectrum::Sampled(s) => s.eval(lambda as f64).unwrap_or(0.0) as f32,
            Spectrum::Blackbody { temperature, range } => {
                let w = lambda as f64;
                if (range[0]..=range[1]).contains(&w) {
                    planck(w, *temperature) as f32
                } else {
                    0.0
                }
            }
            Spectrum::D65 { .. } | Spectrum::Srgb { .. } => {
                self.eval_at(&Wavelengths([lambda; 3])).0[0]
            }
        }
    }

    #[inline]
    fn eval_at(&self, w: &Wavelengths) -> Rgb {
        let rgb = |c: &[f64; 3]| Rgb(c.map(|v| v as f32));
        match self {
            Spectrum::D65 { color, scale } => upsample::illuminant(rgb(color), w) * *scale as f32,
            Spectrum::Srgb { color, .. } => upsample::unbounded(rgb(color), w),
            _ => Rgb(w.0.map(|l| self.eval(l))),
        }
    }
}

impl fmt::Display for Spectrum {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Spectrum::Constant(v) => write!(f, "{v}"),
            Spectrum::Sampled(s) => write!(
                f,
                "a spectrum of {} samples over {}..{} nm",
                s.wavelengths.len(),
                s.wavelengths[0],
                s.wavelengths[s.wavelengths.len() - 1]
            ),
            Spectrum::Uniform(v) => write!(f, "a uniform spectrum of {v}"),
            Spectrum::D65 { color, scale } => {
                write!(f, "a d65 spectrum ({color:?} x {scale})")
            }
            Spectrum::Srgb { color, .. } => write!(f, "an srgb spectrum {color:?}"),
            Spectrum::Blackbody { temperature, .. } => {
                write!(f, "a {temperature} K blackbody spectrum")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_spectra() {
        // a flat reflectance is (almost) grey: D65 is sRGB's white point
        let s = Spectrum::Sampled(Sampled::parse_pairs("360:0.5, 830:0.5").unwrap());
        let c = s.to_rgb(Usage::Reflectance).unwrap();
        for v in c {
            assert!((v - 0.5).abs() < 1e-3, "{c:?}");
        }
        // a flat emission spectrum is not (Mitsuba 3.9.1 scalar_rgb, a point emitter's
        // intensity from this <spectrum>, read back with mi.traverse)
        let s = Spectrum::Sampled(Sampled::parse_pairs("360:1, 830:1").unwrap());
        let c = s.to_rgb(Usage::Emission).unwrap();
        let want = [1.2048837, 0.9482282, 0.9092668];
        for k in 0..3 {
            assert!((c[k] / want[k] - 1.0).abs() < 1e-6, "{c:?}");
        }
        // constants: grey, except in emission
        assert_eq!(
            Spectrum::Constant(2.0).to_rgb(Usage::Reflectance),
            Ok([2.0; 3])
        );
        let c = Spectrum::Constant(2.0).to_rgb(Usage::Emission).unwrap();
        for (v, w) in c.iter().zip([2.4095879, 1.896582, 1.8178321]) {
            assert!((v / w - 1.0).abs() < 1e-6, "{c:?}");
        }
        assert_eq!(Spectrum::Uniform(2.0).to_rgb(Usage::Emission), Ok([2.0; 3]));
    }

    #[test]
    fn clamping_by_usage() {
        let s = Spectrum::Sampled(Sampled::parse_pairs("400:3, 700:3").unwrap());
        assert_eq!(s.to_rgb(Usage::Reflectance), Ok([1.0; 3]));
        // Mitsuba: conductor eta from "400:3, 700:3" is [2.98603, 2.99927, 2.98473]
        let c = s.to_rgb(Usage::Unbounded).unwrap();
        for (v, w) in c.iter().zip([2.98603, 2.99927, 2.98473]) {
            assert!((v - w).abs() < 1e-5, "{c:?}");
        }
        // a narrow band at 400-500 nm has a negative red component: clamped to 0
        let s = Spectrum::Sampled(Sampled::parse_pairs("400:0.5, 500:0.7").unwrap());
        let c = s.to_rgb(Usage::Emission).unwrap();
        assert_eq!(c[0], 0.0);
        assert!(c[2] > 0.0);
    }

    #[test]
    fn interpolation_and_tables() {
        let s = Sampled::parse_pairs("400:1 500:3, 700:2").unwrap();
        assert_eq!(s.eval(399.0), None);
        assert_eq!(s.eval(400.0), Some(1.0));
        assert_eq!(s.eval(450.0), Some(2.0));
        assert_eq!(s.eval(600.0), Some(2.5));
        assert_eq!(s.eval(700.0), Some(2.0));
        assert_eq!(s.eval(700.5), None);
        assert_eq!(cie1931_xyz(555.0)[1], 1.0);
        assert_eq!(cie1931_xyz(359.0), [0.0; 3]);
        assert!((cie_d65(560.0) - 100.0 * D65_NORMALIZATION).abs() < 1e-12);
        // Mitsuba's blackbody plugin (scalar_spectral) at 500 nm, 5000 K: 12107.1689453125
        assert!((planck(500.0, 5000.0) / 12107.1689453125 - 1.0).abs() < 1e-6);
    }

    /// Values in spectral mode (Mitsuba 3.9.1 `scalar_spectral`, a diffuse reflectance or an
    /// area emitter's radiance of each form evaluated at fixed wavelengths; the fixture test
    /// `tests/spectral_xml.rs` compares many more).
    #[test]
    fn spectral_mode_values() {
        let at = |s: &Spectrum, w: [f32; 3]| s.eval_at(&Wavelengths(w)).0;
        // a list: its interpolant, zero outside, not clamped
        let s = Spectrum::Sampled(Sampled::parse_pairs("400:0.2, 500:1.5, 600:0.3").unwrap());
        assert_eq!(at(&s, [450.0, 500.0, 650.0]), [0.85, 1.5, 0.0]);
        assert_eq!(s.eval(380.0), 0.0);
        // constants and uniform: flat, on emitters too (not D65)
        assert_eq!(
            at(&Spectrum::Constant(0.5), [400.0, 555.0, 700.0]),
            [0.5; 3]
        );
        assert_eq!(at(&Spectrum::Uniform(0.7), [400.0, 555.0, 700.0]), [0.7; 3]);
        // blackbody: Planck's law, zero outside the range
        let b = Spectrum::Blackbody {
            temperature: 5000.0,
            range: [450.0, 650.0],
        };
        let v = at(&b, [400.0, 500.0, 600.0]);
        assert_eq!(v[0], 0.0);
        assert!((v[1] / 12107.169 - 1.0).abs() < 1e-5, "{v:?}");
        assert!((v[2] / 12762.37 - 1.0).abs() < 1e-5, "{v:?}");
        // d65: the normalised illuminant × scale (0.83593, 1.104615, 0.909177 at scale 1)
        let d = Spectrum::D65 {
            color: [1.0; 3],
            scale: 2.0,
        };
        let v = at(&d, [400.0, 500.0, 600.0]);
        for (x, m) in v.iter().zip([0.83593, 1.104615, 0.909177]) {
            assert!((x / (2.0 * m) - 1.0).abs() < 1e-5, "{v:?}");
        }
        // srgb: an upsampled reflectance (grey exactly flat), also on emitters
        let g = Spectrum::Srgb {
            color: [0.25; 3],
            unbounded: false,
        };
        assert_eq!(at(&g, [400.0, 500.0, 600.0]), [0.25; 3]);
        assert_eq!(g.eval(500.0), 0.25);
        // what an emitter's check reads
        assert_eq!(s.min_sample(), Some(0.2));
        assert_eq!(b.min_sample(), None);
    }

    #[test]
    fn malformed() {
        for (s, msg) in [
            ("", "at least two"),
            ("400:0.5", "at least two"),
            ("400:0.5, 400:0.6", "increase strictly"),
            ("500:0.5, 400:0.6", "increase strictly"),
            ("400:0.5, 500", "'500' is not a wavelength:value pair"),
            (
                "400:0.5, 500:nan",
                "'500:nan' is not a wavelength:value pair of numbers",
            ),
            ("400:0.5, 500:inf", "of numbers"),
            ("400:0.5, a:1", "of numbers"),
            ("400:0.5:1, 500:1", "of numbers"),
        ] {
            let e = Sampled::parse_pairs(s).unwrap_err();
            assert!(e.contains(msg), "{s}: {e}");
        }
        let e = Sampled::parse_spd("# c\n400 0.5\n\n500 x\n").unwrap_err();
        assert!(e.contains("line 4"), "{e}");
        let e = Sampled::parse_spd("400 0.5 7\n500 1\n").unwrap_err();
        assert!(e.contains("line 1"), "{e}");
        let e = Sampled::parse_spd("# only comments\n").unwrap_err();
        assert!(e.contains("at least two"), "{e}");
        let ok = Sampled::parse_spd("# c\r\n 400 0.5 # trailing\r\n500\t1\r\n").unwrap();
        assert_eq!(ok.values(), &[0.5, 1.0]);
        let e = Spectrum::Blackbody {
            temperature: 5000.0,
            range: [CIE_MIN, CIE_MAX],
        }
        .to_rgb(Usage::Reflectance)
        .unwrap_err();
        assert!(e.contains("emission spectrum"), "{e}");
        let e = Spectrum::Srgb {
            color: [2.0, 0.0, 0.0],
            unbounded: false,
        }
        .to_rgb(Usage::Reflectance)
        .unwrap_err();
        assert!(e.contains("outside [0, 1]"), "{e}");
    }
}
