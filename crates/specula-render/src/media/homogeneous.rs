//! `homogeneous`: a participating medium with the same extinction and albedo everywhere
//! (Mitsuba 3's `homogeneous`).
//!
//! Parameters (Mitsuba's names and defaults):
//! - `sigma_t` (float, rgb or a nested `<volume type="constvolume">`, default 1): extinction
//!   coefficient σt per unit length, before `scale`;
//! - `albedo` (float, rgb or a nested `<volume>`: `constvolume`, or a `gridvolume` for an
//!   albedo that varies in space, default 0.75): the single-scattering albedo σs/σt;
//! - `scale` (float, default 1): multiplies `sigma_t` (so σt = scale·sigma_t, σs =
//!   albedo·σt);
//! - `sample_emitters` (bool, default true): next-event estimation at scattering events;
//! - `has_spectral_extinction` (bool, default true): accepted; Specula always handles a
//!   per-channel σt (it only changes Mitsuba's speed when σt is grey);
//! - a nested `<phase>` (default `isotropic`).
//!
//! **Chromatic extinction.** Free-flight distances are sampled with one colour channel's σt
//! (the path's *hero* channel, drawn uniformly once per path, as Mitsuba 3's `volpath` does).
//! [`Homogeneous::sample_free_flight`] returns, per channel, the path contribution factor and
//! the density that channel would have given the same event; the integrator divides the path's
//! contribution by the *average* over channels of the path densities (spectral MIS with the
//! balance heuristic, Mitsuba's `volpathmis`), so a channel with a σt far from the hero's
//! never gets an unbounded weight. This is unbiased like Mitsuba 3's `volpath` (which weights
//! by the hero channel's density alone), has the same expectation, and far lower variance.
//!
//! **Spectral mode** ([`crate::spectral`]): σt and the albedo are evaluated at the path's
//! wavelengths (an rgb value is Mitsuba's `srgb` reflectance spectrum, a float a constant; see
//! [`super::spectral`]) and the hero channel is the hero wavelength; everything else is the
//! same. [`Homogeneous::prepare_spectral`] upsamples them once.
//!
//! Deviations from Mitsuba: a spatially varying `sigma_t` (a `gridvolume`) is refused with a
//! clear error (Mitsuba's `homogeneous` evaluates it at one point; use `heterogeneous`).

use super::phase::PhaseFunction;
use super::spectral::Sigmoid;
use super::volume::GridVolume;
use glam::Vec3;
use specula_bsdf::{Rgb, Wavelengths};
use std::sync::Arc;

#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    /// σt after `scale`.
    pub sigma_t: Rgb,
    pub albedo: Rgb,
    /// A spatially varying albedo, replacing `albedo` where present.
    pub albedo_grid: Option<Arc<GridVolume>>,
    pub sample_emitters: bool,
    pub phase: PhaseFunction,
    /// `sigma_t` before `scale`, and `scale` (spectral mode upsamples the former).
    pub sigma_t_unscaled: Rgb,
    pub scale: f32,
    /// Spectral mode: σt (after `scale`) and the albedo as spectra, filled by
    /// [`Homogeneous::prepare_spectral`] (upsampled on the fly before).
    pub spec: Option<[Sigmoid; 2]>,
}

/// Outcome of sampling a free-flight distance along a segment: `value` is the contribution
/// factor per channel and `pdf` the density (or probability) of the same event had each channel
/// been the one sampled with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FreeFlight {
    /// A real scattering event at distance `t`: value σs·Tr(t), pdf σt·Tr(t).
    Scatter { t: f32, value: Rgb, pdf: Rgb },
    /// The segment was crossed: value and pdf Tr(t_max).
    Pass { value: Rgb, pdf: Rgb },
}

impl FreeFlight {
    /// The weight value / (average pdf) of a single event.
    pub fn mis_weight(&self) -> Rgb {
        let (v, p) = match self {
            FreeFlight::Scatter { value, pdf, .. } | FreeFlight::Pass { value, pdf } => {
                (value, pdf)
            }
        };
        let m = p.mean();
        if m > 0.0 {
            *v / m
        } else {
            Rgb::ZERO
        }
    }
}

impl Homogeneous {
    pub fn new(sigma_t: Rgb, albedo: Rgb, scale: f32, phase: PhaseFunction) -> Self {
        Homogeneous {
            sigma_t: sigma_t * scale,
            albedo,
            albedo_grid: None,
            sample_emitters: true,
            phase,
            sigma_t_unscaled: sigma_t,
            scale,
            spec: None,
        }
    }

    fn spectra(&self) -> [Sigmoid; 2] {
        let mut st = Sigmoid::unbounded(self.sigma_t_unscaled);
        st.s *= self.scale;
        [st, Sigmoid::unbounded(self.albedo)]
    }

    /// Spectral mode: upsamples σt and the albedo once (see [`super::spectral`]).
    pub fn prepare_spectral(&mut self) -> std::result::Result<(), String> {
        self.spec = Some(self.spectra());
        match &mut self.albedo_grid {
            Some(g) => GridVolume::prepare_shared(g),
            None => Ok(()),
        }
    }

    /// σt (after `scale`) in RGB mode (`wl` = `None`) or at the wavelengths `wl`.
    #[inline]
    pub fn sigma_t_at(&self, wl: Option<&Wavelengths>) -> Rgb {
        match (wl, &self.spec) {
            (None, _) => self.sigma_t,
            (Some(w), Some(s)) => s[0].eval(w),
            (Some(w), None) => self.spectra()[0].eval(w),
        }
    }

    #[inline]
    fn albedo_at(&self, p: Vec3, wl: Option<&Wavelengths>) -> Rgb {
        match (&self.albedo_grid, wl, &self.spec) {
            (Some(g), None, _) => g.eval(p),
            (Some(g), Some(w), _) => g.eval_spectral(p, w),
            (None, None, _) => self.albedo,
            (None, Some(w), Some(s)) => s[1].eval(w),
            (None, Some(w), None) => self.spectra()[1].eval(w),
        }
    }

    /// Transmittance exp(−σt·d) per channel (`wl`: see [`Homogeneous::sigma_t_at`]).
    #[inline]
    pub fn transmittance(&self, d: f32, wl: Option<&Wavelengths>) -> Rgb {
        beer_lambert(self.sigma_t_at(wl), d)
    }

    /// Samples a distance along the segment `o + t·d`, t < `t_max` (may be infinite), with
    /// channel `channel`'s σt from `u` (`wl`: see [`Homogeneous::sigma_t_at`]).
    #[inline]
    pub fn sample_free_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        channel: usize,
        u: f32,
        wl: Option<&Wavelengths>,
    ) -> FreeFlight {
        let sigma_t = self.sigma_t_at(wl);
        let s = sigma_t[channel];
        let t = if s > 0.0 {
            -(1.0 - u).ln() / s
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let tr = beer_lambert(sigma_t, t);
            let albedo = self.albedo_at(o + d * t, wl);
            FreeFlight::Scatter {
                t,
                value: sigma_t * albedo * tr,
                pdf: sigma_t * tr,
            }
        } else {
            let tr = beer_lambert(sigma_t, t_max);
            FreeFlight::Pass { value: tr, pdf: tr }
        }
    }
}

/// exp(−σt·d) per channel (d may be infinite).
#[inline]
fn beer_lambert(sigma_t: Rgb, d: f32) -> Rgb {
    if d.is_infinite() {
        return sigma_t.map(|s| if s > 0.0 { 0.0 } else { 1.0 });
    }
    sigma_t.map(|s| (-s * d).exp())
}

#[cfg(test)]
mod tests {
    use super::*;
    use specula_bsdf::rng::Pcg32;

    /// A channel drawn uniformly per event (so that one event's average-pdf weight is unbiased).
    fn chan(rng: &mut Pcg32) -> usize {
        ((rng.next_f32() * 3.0) as usize).min(2)
    }

    fn medium(st: [f32; 3], albedo: [f32; 3]) -> Homogeneous {
        Homogeneous::new(Rgb(st), Rgb(albedo), 1.0, PhaseFunction::Isotropic)
    }

    /// Transmittance through an absorbing slab of thickness d is exp(−σt·d) per channel, both
    /// as evaluated and as estimated by free-flight sampling (the mean of the pass weights,
    /// counting a scattering event as 0): 400,000 samples, fixed seed, within 4 standard errors.
    #[test]
    fn slab_transmittance_is_beer_lambert() {
        let m = medium([0.2, 1.0, 3.0], [0.0; 3]);
        let d = 0.8;
        let want = [(-0.2f32 * d).exp(), (-d).exp(), (-3.0f32 * d).exp()];
        let tr = m.transmittance(d, None);
        for c in 0..3 {
            assert!((tr[c] - want[c]).abs() < 1e-6);
        }
        let mut rng = Pcg32::new(1, 2);
        let n = 400_000;
        let (mut sum, mut sum2) = ([0f64; 3], [0f64; 3]);
        for _ in 0..n {
            let ff =
                m.sample_free_flight(Vec3::ZERO, Vec3::Z, d, chan(&mut rng), rng.next_f32(), None);
            if let FreeFlight::Pass { .. } = ff {
                let weight = ff.mis_weight();
                for c in 0..3 {
                    sum[c] += weight[c] as f64;
                    sum2[c] += (weight[c] as f64).powi(2);
                }
            }
        }
        for c in 0..3 {
            let mean = sum[c] / n as f64;
            let se = ((sum2[c] / n as f64 - mean * mean) / n as f64).sqrt();
            assert!(
                (mean - want[c] as f64).abs() < 4.0 * se + 1e-6,
                "channel {c}: {mean} vs {} (se {se})",
                want[c]
            );
        }
    }

    /// The mean free path (mean sampled distance in an unbounded medium) is 1/σt: grey σt = 2.5,
    /// 400,000 samples, within 4 standard errors; and with albedo 1 every scattering weight is 1.
    #[test]
    fn mean_free_path_is_inverse_sigma_t() {
        let m = medium([2.5; 3], [1.0; 3]);
        let mut rng = Pcg32::new(5, 9);
        let n = 400_000;
        let (mut s, mut s2) = (0f64, 0f64);
        for _ in 0..n {
            let ff = m.sample_free_flight(
                Vec3::ZERO,
                Vec3::Z,
                f32::INFINITY,
                chan(&mut rng),
                rng.next_f32(),
                None,
            );
            let weight = ff.mis_weight();
            match ff {
                FreeFlight::Scatter { t, .. } => {
                    assert!((weight.max_component() - 1.0).abs() < 1e-5);
                    assert!((weight.min_component() - 1.0).abs() < 1e-5);
                    s += t as f64;
                    s2 += (t as f64).powi(2);
                }
                FreeFlight::Pass { .. } => panic!("escaped an unbounded medium"),
            }
        }
        let mean = s / n as f64;
        let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
        assert!(
            (mean - 0.4).abs() < 4.0 * se,
            "mean free path {mean} (se {se})"
        );
    }

    /// The estimator is unbiased per channel for chromatic extinction: the expected scattering
    /// weight density integrates with the pass weight to the analytic single-scatter albedo
    /// split: E[scatter weight] = albedo·(1 − Tr(d)), E[pass weight] = Tr(d).
    #[test]
    fn chromatic_extinction_unbiased() {
        let m = medium([0.1, 0.9, 4.0], [0.9, 0.5, 0.2]);
        let d = 1.3;
        let mut rng = Pcg32::new(77, 1);
        let n = 400_000;
        let (mut sc, mut pa) = ([0f64; 3], [0f64; 3]);
        for _ in 0..n {
            let ff =
                m.sample_free_flight(Vec3::ZERO, Vec3::Z, d, chan(&mut rng), rng.next_f32(), None);
            let weight = ff.mis_weight();
            match ff {
                FreeFlight::Scatter { .. } => (0..3).for_each(|c| sc[c] += weight[c] as f64),
                FreeFlight::Pass { .. } => (0..3).for_each(|c| pa[c] += weight[c] as f64),
            }
        }
        for c in 0..3 {
            let tr = (-(m.sigma_t[c] * d) as f64).exp();
            let want_s = m.albedo[c] as f64 * (1.0 - tr);
            assert!(
                (sc[c] / n as f64 - want_s).abs() < 0.01,
                "channel {c} scatter {} vs {want_s}",
                sc[c] / n as f64
            );
            assert!(
                (pa[c] / n as f64 - tr).abs() < 0.01,
                "channel {c} pass {} vs {tr}",
                pa[c] / n as f64
            );
        }
    }

    /// Spectral mode: an absorbing slab's transmittance at each wavelength is exp(−σt(λ)·d)
    /// with σt(λ) = `scale` × the upsampled rgb `sigma_t` (Mitsuba's `srgb` reflectance
    /// spectrum, the BSDFs' upsampling), as evaluated, and as estimated by free-flight sampling
    /// with the hero channel a wavelength index drawn uniformly and the spectral-MIS weight
    /// (400,000 samples, fixed seed, within 4 standard errors) — and the scattering weight
    /// integrates to albedo(λ)·(1 − Tr(λ)) with the upsampled albedo.
    #[test]
    fn spectral_slab_is_beer_lambert_per_wavelength() {
        use specula_bsdf::spectral::upsample;
        let (st, albedo, scale) = (Rgb::new(0.07, 0.4, 1.0), Rgb::new(0.95, 0.8, 0.55), 2.6);
        let mut m = Homogeneous::new(st, albedo, scale, PhaseFunction::Isotropic);
        let d = 0.9;
        for prepared in [false, true] {
            if prepared {
                m.prepare_spectral().unwrap();
            }
            for w in [[450.0, 550.0, 650.0], [380.0, 700.0, 820.0]] {
                let w = Wavelengths(w);
                let s_l = upsample::reflectance(st, &w) * scale;
                let a_l = upsample::reflectance(albedo, &w);
                // chromatic at these wavelengths, and different from the RGB channels'
                assert!(s_l.max_component() > 1.5 * s_l.min_component());
                let tr = m.transmittance(d, Some(&w));
                for c in 0..3 {
                    let want = (-s_l[c] * d).exp();
                    assert!((tr[c] - want).abs() < 1e-5, "{w:?}: {tr:?} vs {want}");
                }
                let mut rng = Pcg32::new(3, 17);
                let n = 400_000;
                let mut acc = [[0f64; 3]; 4];
                for _ in 0..n {
                    let ch = chan(&mut rng);
                    let ff =
                        m.sample_free_flight(Vec3::ZERO, Vec3::Z, d, ch, rng.next_f32(), Some(&w));
                    let weight = ff.mis_weight();
                    let k = if matches!(ff, FreeFlight::Pass { .. }) {
                        0
                    } else {
                        2
                    };
                    for c in 0..3 {
                        acc[k][c] += weight[c] as f64;
                        acc[k + 1][c] += (weight[c] as f64).powi(2);
                    }
                }
                for c in 0..3 {
                    let tr = (-(s_l[c] * d) as f64).exp();
                    for (k, want) in [(0, tr), (2, a_l[c] as f64 * (1.0 - tr))] {
                        let mean = acc[k][c] / n as f64;
                        let se = ((acc[k + 1][c] / n as f64 - mean * mean) / n as f64).sqrt();
                        assert!(
                            (mean - want).abs() < 4.0 * se + 1e-6,
                            "{w:?} channel {c} ({}): {mean} vs {want} (se {se})",
                            if k == 0 { "pass" } else { "scatter" }
                        );
                    }
                }
            }
        }
        // RGB mode is untouched by the spectral data
        assert_eq!(m.transmittance(d, None), st.map(|s| (-s * scale * d).exp()));
    }
}
