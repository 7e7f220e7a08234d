//! Spectral mode (`specula render --mode spectral`, [`Scene::set_spectral`]): every path
//! carries radiance at three wavelengths instead of three linear-sRGB channels, as Mitsuba 3's
//! `*_spectral` variants do. RGB mode stays the default and is unchanged.
//!
//! Per camera sample (see [`specula_bsdf::spectral`] for the pieces):
//! 1. one uniform number picks the hero wavelength and two more rotated by a third of the
//!    sampling density's range ([`cie::sample_wavelengths`]: Mitsuba's `sample_rgb_spectrum`
//!    density on 360…830 nm). The number of a pixel's k-th sample is frac(o + k·φ⁻¹), φ the
//!    golden ratio, o a random offset per pixel drawn from the sampler's dimension
//!    [`WAVELENGTH_DIMENSION`] (apart from the integrator's, so RGB and spectral renders share
//!    the rest of their random sequence): unbiased, and a pixel's samples spread evenly over
//!    the spectrum, which keeps colour noise low with three wavelengths per path (Mitsuba
//!    draws its four independently per sample);
//! 2. the integrator (`path`, `direct` or `volpath`) runs unchanged with the wavelengths in
//!    every [`specula_bsdf::ShadingPoint`]: BSDF parameters evaluate at them (RGB constants and
//!    texels are upsampled, [`specula_bsdf::SpectrumParam`]); emitted RGB radiance (area,
//!    point, spot, directional, constant, projector — whatever an emitter returns) is converted
//!    where the integrator receives it, by [`emission`] (Mitsuba's `d65` spectrum: an
//!    RGB-white emitter is D65); an `envmap` upsamples its texels and interpolates as
//!    Mitsuba's does ([`crate::emitters::Envmap::eval_spectral`]);
//! 3. the film receives the result developed to linear sRGB through the CIE 1931 observer
//!    ([`cie::develop`], Mitsuba's normalisation), so reconstruction filters and the output
//!    files are the same as in RGB mode.
//!
//! Not supported (an error from [`Scene::set_spectral`]): the `aov` and `depth` integrators
//! (their channels are not radiance). Participating media evaluate their coefficients at the
//! wavelengths ([`crate::media::spectral`]). `<spectrum>` values in the scene file are still converted to
//! RGB when the scene loads and then upsampled like any RGB value.

use crate::core::{Hit, Ray, Result, SceneError};
use crate::emitters::Emitter;
use crate::integrator::{Counters, Integrator, LightSample};
use crate::sampler::{PixelSampler, Sampler};
use crate::scene::{Light, Scene};
use glam::Vec3;
use specula_bsdf::spectral::{cie, upsample};
use specula_bsdf::{Rgb, Wavelengths};

/// The sampler dimension the wavelength sample is drawn from (far from the integrator's).
pub const WAVELENGTH_DIMENSION: u32 = 0x5eec_0000;

/// A pixel's random offset of its wavelength samples (drawn from the pixel's sampler at
/// [`WAVELENGTH_DIMENSION`] before its first sample).
#[inline]
pub fn pixel_offset<S: PixelSampler>(sampler: &mut S) -> f64 {
    sampler.start_sample(0, WAVELENGTH_DIMENSION);
    sampler.next_1d() as f64
}

/// The wavelength sample of sample `sample` of a pixel with offset `offset`: a randomly
/// shifted Kronecker (golden-ratio) sequence, so that a pixel's samples cover the spectrum
/// evenly (each sample alone is uniform, so the estimate is unbiased; the colour noise of a
/// few wavelengths per path falls much faster than with independent draws).
#[inline]
pub fn wavelength_u(offset: f64, sample: u32) -> f32 {
    const GOLDEN: f64 = 0.618_033_988_749_894_8;
    ((offset + sample as f64 * GOLDEN).fract() as f32).min(1.0 - f32::EPSILON)
}

/// An emitted RGB radiance (or a light sample's weight, radiance over a pdf) as seen by a
/// path: unchanged in RGB mode (`wl` = `None`), Mitsuba's illuminant upsampling at the
/// wavelengths otherwise. Positively homogeneous, so it may be applied after dividing by a
/// pdf.
#[inline]
pub fn emission(rgb: Rgb, wl: Option<&Wavelengths>) -> Rgb {
    match wl {
        None => rgb,
        Some(w) => upsample::illuminant(rgb, w),
    }
}

/// An infinite emitter's radiance `le` (its RGB value along `d`) at the wavelengths: the
/// envmap's own spectral lookup ([`crate::emitters::Envmap::eval_spectral`], as Mitsuba), any
/// other's [`emission`].
#[inline]
pub fn infinite_emission(e: &Emitter, d: Vec3, le: Rgb, wl: Option<&Wavelengths>) -> Rgb {
    match (e, wl) {
        (_, None) => le,
        (Emitter::Envmap(m), Some(w)) => m.eval_spectral(d, w),
        (_, Some(w)) => upsample::illuminant(le, w),
    }
}

impl Scene {
    /// A light sample's weight (radiance / pdf) at the wavelengths (see
    /// [`infinite_emission`]).
    #[inline]
    pub(crate) fn light_weight(&self, ls: &LightSample, wl: Option<&Wavelengths>) -> Rgb {
        let Some(w) = wl else {
            return ls.weight;
        };
        match &self.lights[ls.light as usize] {
            Light::Other(Emitter::Envmap(m)) => m.eval_spectral(ls.wi, w) * (1.0 / ls.pdf),
            _ => upsample::illuminant(ls.weight, w),
        }
    }

    /// Switches the scene to spectral (`true`) or RGB (`false`) rendering. Spectral mode
    /// computes the upsampling table the first time (about 3 s on two cores; once per
    /// process). Fails for integrators whose output is not radiance (`aov`, `depth`) and for
    /// media with a `raw` RGB grid (no spectrum); upsamples the media's coefficients.
    pub fn set_spectral(&mut self, on: bool) -> Result<()> {
        if on {
            let bad = match &self.integrator {
                Integrator::Aov(_) => Some("aov"),
                Integrator::Depth => Some("depth"),
                _ => None,
            };
            if let Some(b) = bad {
                return Err(SceneError::new(
                    None,
                    format!("spectral mode renders radiance; the '{b}' integrator is RGB-only"),
                ));
            }
            for (i, m) in self.media.iter_mut().enumerate() {
                m.prepare_spectral()
                    .map_err(|e| SceneError::new(None, format!("medium {i}: {e}")))?;
            }
            upsample::table();
        }
        self.spectral = on;
        Ok(())
    }

    /// One spectral sample of the integrator along the camera ray `ray` (intersection `hit`):
    /// the wavelengths are drawn from `u_wavelength`, the result is developed to linear sRGB.
    pub fn sample_spectral<S: Sampler>(
        &self,
        integrator: &Integrator,
        ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        u_wavelength: f32,
    ) -> Rgb {
        let (wl, weight) = cie::sample_wavelengths(u_wavelength);
        let w = Some(&wl);
        let l = match integrator {
            Integrator::Path(p) => self.li_path(p, ray, hit, rng, counters, w),
            Integrator::Volpath(p) => self.li_volpath(p, ray, hit, rng, counters, w),
            Integrator::Direct(d) => self.li_direct(d, ray, hit, rng, counters, w),
            // refused by set_spectral
            Integrator::Depth | Integrator::Aov(_) => return Rgb::ZERO,
        };
        cie::develop(l, &wl, &weight)
    }
}

#[cfg(test)]
mod tests {
    use crate::render::{render, RenderOptions};
    use crate::scene::Scene;
    use std::sync::atomic::AtomicBool;

    fn scene(body: &str) -> Scene {
        let xml = format!(
            r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="30"/>
              <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
              <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
                <rfilter type="box"/></film>
              <sampler type="independent"/></sensor>
            {body}</scene>"#
        );
        let dir = std::env::temp_dir().join(format!("specula_spectral_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("s{}.xml", xml.len()));
        std::fs::write(&path, xml).unwrap();
        Scene::load(&path, &[]).unwrap()
    }

    /// White furnace: a diffuse white sphere in a constant white environment stays white (1, 1,
    /// 1 everywhere) in spectral mode: the environment is D65, which develops to white, and a
    /// reflectance of 1 upsamples to the constant 1.
    #[test]
    fn white_furnace_stays_white() {
        let mut s = scene(
            r#"<integrator type="path"><integer name="max_depth" value="64"/><integer name="rr_depth" value="64"/></integrator>
            <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
            <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="1, 1, 1"/></bsdf></shape>"#,
        );
        s.set_spectral(true).unwrap();
        let out = render(
            &s,
            &RenderOptions {
                spp: 256,
                seed: 1,
                threads: 0,
            },
            &AtomicBool::new(false),
            &|_, _| {},
        );
        let n = (out.width * out.height) as f64;
        for k in 0..3 {
            let mean: f64 = out.rgb.chunks(3).map(|p| p[k] as f64).sum::<f64>() / n;
            assert!((mean - 1.0).abs() < 0.01, "channel {k}: mean {mean}");
        }
        // the only noise is the wavelengths' (every path carries D65 back): no pixel strays far
        for p in out.rgb.chunks(3) {
            for &v in p {
                assert!((v - 1.0).abs() < 0.4, "{p:?}");
            }
        }
    }

    /// A coloured emitter and a coloured diffuse surface keep their colour in spectral mode
    /// (the upsampled spectra integrate back to the RGB values): direct view of an emitter of
    /// radiance (0.8, 0.4, 0.2) and of a constant environment through a red-ish reflector.
    #[test]
    fn coloured_emitter_keeps_its_colour() {
        let mut s = scene(
            r#"<integrator type="path"><integer name="max_depth" value="2"/></integrator>
            <emitter type="constant"><rgb name="radiance" value="0.8, 0.4, 0.2"/></emitter>"#,
        );
        s.set_spectral(true).unwrap();
        let out = render(
            &s,
            &RenderOptions {
                spp: 512,
                seed: 2,
                threads: 0,
            },
            &AtomicBool::new(false),
            &|_, _| {},
        );
        let n = (out.width * out.height) as f64;
        let want = [0.8, 0.4, 0.2];
        for k in 0..3 {
            let mean: f64 = out.rgb.chunks(3).map(|p| p[k] as f64).sum::<f64>() / n;
            assert!((mean - want[k]).abs() < 0.01 * 0.8, "channel {k}: {mean}");
        }
    }

    #[test]
    fn rgb_only_integrators_are_refused() {
        let mut s = scene(r#"<integrator type="depth"/><shape type="sphere"/>"#);
        let e = s.set_spectral(true).unwrap_err();
        assert!(e.to_string().contains("depth"), "{e}");
    }
}
