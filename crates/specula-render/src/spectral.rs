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
//!    texels are upsampled, [`specula_bsdf::SpectrumParam`]; a `<spectrum>` value of the
//!    scene file is used as the spectrum it is, `SpectrumParam::Spectral`); emitted RGB
//!    radiance (area, point, spot, directional, constant, projector — whatever an emitter
//!    returns) is converted where the integrator receives it, by [`emission`] (Mitsuba's `d65`
//!    spectrum: an RGB-white emitter is D65), and an emitter whose value is a `<spectrum>`
//!    emits that spectrum instead ([`AreaRadiance::emission`], `Scene::light_weight`,
//!    [`infinite_emission`]); an `envmap` upsamples its texels and interpolates as Mitsuba's
//!    does ([`crate::emitters::Envmap::eval_spectral`]);
//! 3. the film receives the result developed to linear sRGB through the CIE 1931 observer
//!    ([`cie::develop`], Mitsuba's normalisation), so reconstruction filters and the output
//!    files are the same as in RGB mode.
//!
//! `<spectrum>` values ([`crate::xml::spectrum`]): the scene loads the same way in both modes;
//! a parameter given a `<spectrum>` keeps its RGB conversion (what RGB mode uses, unchanged)
//! beside the spectrum itself (what spectral mode evaluates at the path's wavelengths), so
//! switching modes needs no reload.
//!
//! `depth` and `aov` (as Mitsuba 3.9.1's `*_spectral` variants render them, probed): the
//! `depth` integrator's value t is a spectrum like any other, flat at t, and is developed
//! like radiance (so its image tends to t × (1.2049, 0.9482, 0.9093), the colour of an
//! equal-energy spectrum, with colour noise, exactly as in Mitsuba); the `aov` integrator's
//! nested integrators are spectral and developed, its `albedo` output is the diffuse
//! reflectance at the wavelengths, developed the same way (no D65 weighting: a white albedo
//! also tends to (1.2049, 0.9482, 0.9093)), and its other outputs (depth, position, normals,
//! uv, partial derivatives, indices) are geometric and the same as in RGB mode.
//!
//! Participating media evaluate their coefficients at the wavelengths
//! ([`crate::media::spectral`]); a medium with a `raw` RGB grid (no spectrum) is refused by
//! [`Scene::set_spectral`].

use crate::core::{Hit, Ray, Result, SceneError};
use crate::emitters::Emitter;
use crate::integrator::{Counters, Integrator, LightSample, RayDifferentials};
use crate::sampler::{PixelSampler, Sampler};
use crate::scene::{AreaRadiance, Light, Scene};
use glam::{Vec2, Vec3};
use specula_bsdf::spectral::{cie, upsample};
use specula_bsdf::{Rgb, Spectrum, Wavelengths};

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
/// envmap's own spectral lookup ([`crate::emitters::Envmap::eval_spectral`], as Mitsuba), a
/// `<spectrum>` radiance's values, any other's [`emission`].
#[inline]
pub fn infinite_emission(e: &Emitter, d: Vec3, le: Rgb, wl: Option<&Wavelengths>) -> Rgb {
    match (e, wl) {
        (_, None) => le,
        (Emitter::Envmap(m), Some(w)) => m.eval_spectral(d, w),
        (Emitter::Constant(c), Some(w)) if c.spectrum.is_some() => {
            c.spectrum.as_ref().map_or(Rgb::ZERO, |s| s.eval_at(w))
        }
        (_, Some(w)) => upsample::illuminant(le, w),
    }
}

/// `spectrum` scaled as `weight` scales `value` (a light sample's weight is the emitter's value
/// times a positive factor: geometry, pdf): the factor is read off `value`'s largest channel.
#[inline]
fn scaled_like(spectrum: Spectrum, value: Rgb, weight: Rgb) -> Spectrum {
    let v = value.0;
    let k = if v[0] >= v[1] && v[0] >= v[2] {
        0
    } else if v[1] >= v[2] {
        1
    } else {
        2
    };
    if v[k] > 0.0 {
        spectrum * (weight.0[k] / v[k])
    } else {
        Spectrum::ZERO
    }
}

impl AreaRadiance {
    /// The radiance emitted at a surface point (texture coordinates `uv`, position `p`) as a
    /// path sees it: the RGB value in RGB mode (`wl` = `None`); in spectral mode a `<spectrum>`
    /// radiance's values at the wavelengths, and any other value's [`emission`].
    #[inline]
    pub fn emission(&self, uv: Vec2, p: Vec3, wl: Option<&Wavelengths>) -> Rgb {
        match (self, wl) {
            (AreaRadiance::Spectral { curve, .. }, Some(w)) => curve.eval_at(w),
            _ => emission(self.eval(uv, p), wl),
        }
    }
}

impl Scene {
    /// The radiance of area light `light` (index into [`Scene::lights`], with `radiance` its
    /// [`AreaRadiance`]) at a surface point, as a path sees it: [`AreaRadiance::emission`],
    /// from the prepared colour where there is one.
    #[inline]
    pub(crate) fn area_emission_at(
        &self,
        light: u32,
        radiance: &AreaRadiance,
        uv: Vec2,
        p: Vec3,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        match (wl, self.light_colours.get(light as usize)) {
            (Some(w), Some(Some(c))) => c.scaled(radiance.eval(uv, p), w),
            _ => radiance.emission(uv, p, wl),
        }
    }

    /// [`infinite_emission`] of light `light` (index into [`Scene::lights`]), from the
    /// prepared colour where there is one.
    #[inline]
    pub(crate) fn infinite_emission_of(
        &self,
        light: u32,
        e: &Emitter,
        d: Vec3,
        le: Rgb,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        match (wl, self.light_colours.get(light as usize)) {
            (Some(w), Some(Some(c))) => c.scaled(le, w),
            _ => infinite_emission(e, d, le, wl),
        }
    }

    /// A light sample's weight (radiance / pdf) at the wavelengths (see
    /// [`infinite_emission`]).
    #[inline(always)]
    pub(crate) fn light_weight(&self, ls: &LightSample, wl: Option<&Wavelengths>) -> Rgb {
        match wl {
            None => ls.weight,
            Some(w) => self.light_weight_at(ls, w),
        }
    }

    /// [`Scene::light_weight`] in spectral mode (out of line: RGB paths never call it).
    #[inline(never)]
    fn light_weight_at(&self, ls: &LightSample, w: &Wavelengths) -> Rgb {
        if let Some(Some(c)) = self.light_colours.get(ls.light as usize) {
            return c.scaled(ls.weight, w);
        }
        match &self.lights[ls.light as usize] {
            Light::Other(Emitter::Envmap(m)) => m.eval_spectral(ls.wi, w) * (1.0 / ls.pdf),
            Light::Area {
                radiance: AreaRadiance::Spectral { rgb, curve },
                ..
            } => scaled_like(curve.eval_at(w), *rgb, ls.weight),
            Light::Other(e) => match e.spectrum() {
                None => upsample::illuminant(ls.weight, w),
                Some((curve, value)) => match e {
                    // a spot's texture (an RGB image) is upsampled as a reflectance, as Mitsuba
                    // does, and multiplies the spectrum
                    Emitter::Spot(l) => match l.texture_towards(-ls.wi) {
                        Some(t) => scaled_like(
                            curve.eval_at(w) * upsample::unbounded(t, w),
                            value * t,
                            ls.weight,
                        ),
                        None => scaled_like(curve.eval_at(w), value, ls.weight),
                    },
                    _ => scaled_like(curve.eval_at(w), value, ls.weight),
                },
            },
            _ => upsample::illuminant(ls.weight, w),
        }
    }

    /// Switches the scene to spectral (`true`) or RGB (`false`) rendering. Spectral mode
    /// computes the upsampling table the first time (about 3 s on two cores; once per
    /// process). Fails for media with a `raw` RGB grid (no spectrum); upsamples the media's
    /// coefficients.
    pub fn set_spectral(&mut self, on: bool) -> Result<()> {
        if on {
            for (i, m) in self.media.iter_mut().enumerate() {
                m.prepare_spectral()
                    .map_err(|e| SceneError::new(None, format!("medium {i}: {e}")))?;
            }
            upsample::table();
            self.light_colours = self
                .lights
                .iter()
                .map(|l| match l {
                    Light::Area {
                        radiance: AreaRadiance::Rgb(c),
                        ..
                    } => Some(upsample::Illuminant::new(*c)),
                    Light::Other(e) => e.constant_colour().map(upsample::Illuminant::new),
                    _ => None,
                })
                .collect();
        } else {
            self.light_colours.clear();
        }
        self.spectral = on;
        Ok(())
    }

    /// One spectral sample of the integrator along the camera ray `ray` (intersection `hit`,
    /// differentials `differentials` for the `aov` integrator's `duv_dx`/`duv_dy`): the
    /// wavelengths are drawn from `u_wavelength`, the result is developed to linear sRGB; an
    /// `aov` integrator writes its channels into `aovs` (see [`Scene::sample`]).
    #[allow(clippy::too_many_arguments)]
    pub fn sample_spectral<S: Sampler>(
        &self,
        integrator: &Integrator,
        ray: Ray,
        differentials: Option<&RayDifferentials>,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        u_wavelength: f32,
        aovs: &mut [f32],
    ) -> Rgb {
        let (wl, weight) = cie::sample_wavelengths(u_wavelength);
        self.sample_at_wavelengths(
            integrator,
            ray,
            differentials,
            hit,
            rng,
            counters,
            (&wl, &weight),
            aovs,
        )
    }

    /// [`Scene::sample_spectral`] at given wavelengths `wl.0` (weights 1/p(λ) `wl.1`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sample_at_wavelengths<S: Sampler>(
        &self,
        integrator: &Integrator,
        ray: Ray,
        differentials: Option<&RayDifferentials>,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        (wl, weight): (&Wavelengths, &[f32; 3]),
        aovs: &mut [f32],
    ) -> Rgb {
        let w = Some(wl);
        let l = match integrator {
            Integrator::Path(p) => self.li_path(p, ray, hit, rng, counters, w),
            Integrator::Volpath(p) => self.li_volpath(p, ray, hit, rng, counters, w),
            Integrator::Direct(d) => self.li_direct(d, ray, hit, rng, counters, w),
            // a flat spectrum of value t, developed like radiance (as Mitsuba's spectral
            // variants do)
            Integrator::Depth => {
                counters.rays += 1;
                Spectrum::splat(hit.map_or(0.0, |h| h.t))
            }
            Integrator::Aov(a) => {
                return self.li_aov(
                    a,
                    ray,
                    differentials,
                    hit,
                    rng,
                    counters,
                    aovs,
                    Some((wl, weight)),
                )
            }
        };
        cie::develop(l, wl, weight)
    }
}

#[cfg(test)]
mod tests {
    use crate::render::{render, RenderOptions};
    use crate::scene::Scene;
    use std::sync::atomic::AtomicBool;

    /// Renders `s` with `spp` samples per pixel and seed `seed` on all threads.
    fn render_at(s: &Scene, spp: u32, seed: u64) -> crate::render::RenderOutput {
        render(
            s,
            &RenderOptions {
                spp,
                seed,
                threads: 0,
            },
            &AtomicBool::new(false),
            &|_, _| {},
        )
    }

    fn scene(body: &str) -> Scene {
        scene_sampled(body, "independent")
    }

    /// [`scene`] with another sampler.
    fn scene_sampled(body: &str, sampler: &str) -> Scene {
        let xml = format!(
            r#"<scene version="3.0.0">
            <sensor type="perspective"><float name="fov" value="30"/>
              <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
              <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/>
                <rfilter type="box"/></film>
              <sampler type="{sampler}"/></sensor>
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
        let out = render_at(&s, 256, 1);
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
        let out = render_at(&s, 512, 2);
        let n = (out.width * out.height) as f64;
        let want = [0.8, 0.4, 0.2];
        for k in 0..3 {
            let mean: f64 = out.rgb.chunks(3).map(|p| p[k] as f64).sum::<f64>() / n;
            assert!((mean - want[k]).abs() < 0.01 * 0.8, "channel {k}: {mean}");
        }
    }

    /// Mean of each channel of `rgb` (interleaved, `stride` values a pixel) over the pixels
    /// where `keep` holds.
    fn channel_means(v: &[f32], stride: usize, keep: impl Fn(usize) -> bool) -> Vec<f64> {
        let mut sum = vec![0.0f64; stride];
        let mut n = 0usize;
        for (i, p) in v.chunks(stride).enumerate() {
            if keep(i) {
                n += 1;
                for (s, x) in sum.iter_mut().zip(p) {
                    *s += *x as f64;
                }
            }
        }
        sum.iter().map(|s| s / n as f64).collect()
    }

    /// The `depth` integrator in spectral mode (Mitsuba 3.9.1's `scalar_spectral`): its value t
    /// is developed as a flat spectrum, t × (1.2049, 0.9482, 0.9093) in expectation (Mitsuba
    /// renders t = 4.125 as (4.92, 3.93, 3.77) at 256 spp: colour noise around that). A plane
    /// facing the camera at distance 5 fills the image.
    #[test]
    fn depth_integrator_is_developed_as_a_flat_spectrum() {
        let mut s = scene(
            r#"<integrator type="depth"/>
            <shape type="rectangle"><transform name="to_world"><scale value="10"/></transform></shape>"#,
        );
        let rgb_mode = render_at(&s, 4, 1);
        s.set_spectral(true).unwrap();
        let out = render_at(&s, 256, 1);
        let t = channel_means(&rgb_mode.rgb, 3, |_| true);
        let m = channel_means(&out.rgb, 3, |_| true);
        let white_e = [1.204_884, 0.948_228, 0.909_267];
        for k in 0..3 {
            assert!((t[k] - t[0]).abs() < 1e-6 && t[0] > 5.0, "{t:?}");
            assert!(
                (m[k] / (t[0] * white_e[k]) - 1.0).abs() < 0.01,
                "channel {k}: {m:?}"
            );
        }
    }

    /// The `aov` integrator in spectral mode: the geometric outputs are those of RGB mode, the
    /// nested `path` integrator is spectral (its image keeps its colour), and `albedo` is the
    /// reflectance at the wavelengths developed without D65 (a grey 0.5 tends to 0.5 × the
    /// equal-energy white; Mitsuba 3.9.1 `scalar_spectral` renders the same way).
    #[test]
    fn aov_integrator_in_spectral_mode() {
        let xml = r#"<integrator type="aov">
              <string name="aovs" value="dd:depth, nn:sh_normal, alb:albedo, uv:uv"/>
              <integrator type="path" name="img"><integer name="max_depth" value="2"/></integrator>
            </integrator>
            <emitter type="constant"><rgb name="radiance" value="0.8, 0.4, 0.2"/></emitter>
            <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>"#;
        // (a sampler that keeps the camera rays of RGB mode: the wavelengths come from a
        // dimension of their own)
        let mut s = scene_sampled(xml, "stratified");
        let rgb_mode = render_at(&s, 512, 3);
        s.set_spectral(true).unwrap();
        let out = render_at(&s, 512, 3);
        let names: Vec<&str> = out.aovs.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(
            names,
            [
                "img.R", "img.G", "img.B", "img.A", "dd.T", "nn.X", "nn.Y", "nn.Z", "alb.R",
                "alb.G", "alb.B", "uv.U", "uv.V"
            ]
        );
        let ch = |o: &crate::render::RenderOutput, name: &str| {
            o.aovs.iter().find(|(n, _)| n == name).unwrap().1.clone()
        };
        // geometric channels and alpha: as in RGB mode (box filter, same camera rays)
        for name in ["img.A", "dd.T", "nn.X", "nn.Y", "nn.Z", "uv.U", "uv.V"] {
            for (a, b) in ch(&out, name).iter().zip(ch(&rgb_mode, name)) {
                assert!((a - b).abs() < 1e-4 * (1.0 + b.abs()), "{name}: {a} {b}");
            }
        }
        let mean =
            |name: &str, keep: &dyn Fn(usize) -> bool| channel_means(&ch(&out, name), 1, keep)[0];
        // the albedo: RGB mode's (0.5 × the sphere's coverage of each pixel) × the
        // equal-energy white
        let white_e = [1.204_884, 0.948_228, 0.909_267];
        for (k, c) in ["alb.R", "alb.G", "alb.B"].into_iter().enumerate() {
            let (a, b) = (
                mean(c, &|_| true),
                channel_means(&ch(&rgb_mode, c), 1, |_| true)[0],
            );
            assert!(
                b > 0.1 && (a / (b * white_e[k]) - 1.0).abs() < 0.02,
                "{c}: {a} {b}"
            );
        }
        let depth = ch(&rgb_mode, "dd.T");
        let off = |i: usize| depth[i] == 0.0;
        assert!((0..depth.len()).any(off));
        // the background of the nested image: the environment's colour
        for (c, want) in [("img.R", 0.8), ("img.G", 0.4), ("img.B", 0.2)] {
            let m = mean(c, &off);
            assert!((m / want - 1.0).abs() < 0.02, "{c}: {m}");
        }
        // the image is the nested integrator's
        for (k, c) in ["img.R", "img.G", "img.B"].into_iter().enumerate() {
            let img = channel_means(&out.rgb, 3, |_| true)[k];
            assert!((img - mean(c, &|_| true)).abs() < 1e-4, "{c}");
        }
    }
}
