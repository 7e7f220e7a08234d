//! `volpath`: Mitsuba 3's volumetric path tracer — unidirectional path tracing through
//! participating media ([`crate::media`]) with next-event estimation at surfaces and at
//! scattering events in media, and multiple importance sampling (power heuristic).
//!
//! Parameters (Mitsuba's): `max_depth` (default −1 = unbounded; 1 = only directly visible
//! emitters, 2 = direct lighting), `rr_depth` (default 5), `hide_emitters` (default false).
//!
//! `volpathmis` (Mitsuba's volumetric path tracer with spectral MIS) takes the same parameters
//! and `use_spectral_mis` (bool, default true), and is rendered by this same integrator, whose
//! free-flight sampling already weighs the channels by spectral MIS: the image has
//! `volpathmis`'s expectation (which is `volpath`'s). Deviation: Mitsuba's `volpathmis` also
//! combines next-event estimation with the null-scattering paths of unidirectional sampling by
//! MIS (Miller et al. 2019); Specula weighs them as `volpath` does (same expectation, other
//! noise), and `use_spectral_mis = false` changes nothing.
//!
//! Semantics follow Mitsuba 3.9's `volpath`:
//! - a path's depth grows at every real scattering event — a BSDF that is not `null`, or a
//!   scattering event in a medium; passing through a `null` surface does not count;
//! - Russian roulette once depth > `rr_depth`, with survival probability
//!   min(max(throughput)·η², 0.95);
//! - emitters hit directly (depth 0), after a chain of Dirac bounces, or after a medium
//!   scattering event that did not sample emitters (`sample_emitters` false) count in full;
//!   otherwise they are weighted against next-event estimation from the last real
//!   scattering event; `hide_emitters` hides what is seen at depth 0 (also through `null`
//!   surfaces);
//! - a shadow ray passes through `null` surfaces (changing medium where one is attached) and
//!   is attenuated by the transmittance of every medium it crosses; any other surface blocks it;
//! - crossing a surface with media attached enters its exterior when leaving on the side of the
//!   geometric normal, else its interior (Mitsuba's `target_medium`); a surface with no media
//!   attached leaves the medium unchanged; the camera starts in the sensor's medium.
//!
//! - free-flight sampling in a `heterogeneous` medium is delta tracking against its majorant,
//!   and the transmittance of shadow rays through it ratio tracking
//!   ([`crate::media::heterogeneous`]); next-event estimation samples emitters as the `path`
//!   integrator does (the same light selection, area sampling, and cone sampling of spheres).
//!
//! Spectral mode ([`crate::spectral`], `wl` given): the media's coefficients are evaluated at
//! the path's three wavelengths ([`crate::media::spectral`]), the hero channel is a wavelength's
//! index and the spectral MIS below weighs wavelengths exactly as it weighs RGB channels. After
//! a dispersive Dirac refraction keeps one wavelength, the rest of the path (surfaces, media,
//! emitters) is shaded at it, as in `path` (the dead channels carry no throughput; their
//! densities in the spectral MIS are then those of the surviving wavelength, which is what the
//! sampling does had one of them been the hero).
//!
//! Deviations from Mitsuba (same expectation, different noise): free-flight distances are
//! sampled with a hero channel drawn per path, as Mitsuba does, but weighted by the average of
//! the channels' path densities (spectral MIS, as Mitsuba's `volpathmis`; see
//! [`crate::media::homogeneous`]); shadow rays use the exact transmittance of homogeneous
//! media instead of a track-length estimate; null collisions of delta tracking do not meet
//! Russian roulette (Mitsuba's loop plays it at every null collision too).

use crate::accel::{offset_ray_origin, SHADOW_EPSILON};
use crate::core::{Hit, Ray, Result, SceneError};
use crate::integrator::{Counters, LightSample};
use crate::media::{is_null_bsdf, FreeFlight};
use crate::sampler::Sampler;
use crate::scene::{Light, PathSettings, Scene};
use crate::xml::Node;
use glam::Vec3;
use specula_bsdf::spectral::dispersion::collapse_dead_channels;
use specula_bsdf::{Bsdf, BsdfContext, BsdfModel, LobeFlags, Rgb, ShadingPoint, Wavelengths};

/// Reads a `<integrator type="volpath">` or `<integrator type="volpathmis">` node.
pub fn settings_from_node(n: &Node) -> Result<PathSettings> {
    let mis_params: &[&str] = if n.plugin_type == "volpathmis" {
        let _ = n.bool("use_spectral_mis", true)?;
        &["use_spectral_mis"]
    } else {
        &[]
    };
    let s = PathSettings {
        max_depth: n.int("max_depth", -1)? as i32,
        rr_depth: n.int("rr_depth", 5)? as i32,
        hide_emitters: n.bool("hide_emitters", false)?,
    };
    if s.max_depth < -1 || s.rr_depth <= 0 {
        return Err(SceneError::new(
            Some(n.loc.clone()),
            "max_depth must be ≥ −1 and rr_depth ≥ 1",
        ));
    }
    if let Some(c) = n.children.first() {
        return Err(SceneError::new(
            Some(c.loc.clone()),
            format!("<{}> cannot be nested in an integrator", c.tag),
        ));
    }
    let mut known = vec!["max_depth", "rr_depth", "hide_emitters"];
    known.extend_from_slice(mis_params);
    n.check_unused(&known)?;
    Ok(s)
}

#[inline]
fn mis(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    let w = a2 / (a2 + b2);
    if w.is_finite() {
        w
    } else if a2.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// What a shadow ray travelling along `d` keeps when it crosses a surface with `bsdf` (Mitsuba's
/// `eval_null_transmission`): everything through `null`, the slab transmittance
/// (1 − R)·`specular_transmittance` through `thindielectric`; `None` (blocked) otherwise.
#[inline]
fn null_transmission(
    bsdf: &Bsdf,
    si: &crate::core::SurfaceGeometry,
    d: Vec3,
    wl: Option<&Wavelengths>,
) -> Option<Rgb> {
    if is_null_bsdf(bsdf) {
        return Some(Rgb::ONE);
    }
    match bsdf {
        Bsdf::ThinDielectric(t) => {
            let sp = ShadingPoint {
                uv: si.uv,
                p: si.p,
                wavelengths: wl.copied(),
                ..Default::default()
            };
            let r = t.reflectance(si.sh_frame.n.dot(d));
            Some(t.specular_transmittance.eval(&sp) * (1.0 - r))
        }
        _ => None,
    }
}

/// Bound on the surfaces a shadow ray passes through (null boundaries), against loops on
/// degenerate geometry.
const MAX_SHADOW_CROSSINGS: usize = 256;

impl Scene {
    /// Transmittance from `o` along `d` over `dist` (infinite: to infinity), starting in
    /// `medium`, through `null` surfaces; zero when anything else is in the way. Heterogeneous
    /// media estimate it by ratio tracking with samples of `rng`.
    #[allow(clippy::too_many_arguments)]
    fn vp_transmittance<S: Sampler>(
        &self,
        mut o: Vec3,
        d: Vec3,
        mut dist: f32,
        mut medium: Option<u32>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        let mut tr = Rgb::ONE;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            counters.rays += 1;
            let ray = Ray { o, d, t_max: dist };
            let hit = self.intersect(&ray);
            let seg = hit.as_ref().map_or(dist, |h| h.t);
            if let Some(m) = medium {
                tr *= self.media[m as usize].transmittance(o, d, seg, wl, rng);
            }
            let Some(h) = hit else {
                return tr;
            };
            let shape = h.shape as usize;
            if tr.is_black() {
                return Rgb::ZERO;
            }
            let si = self.geometry[shape].surface(&ray, &h);
            let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
            match null_transmission(bsdf, &si, d, wl) {
                Some(t) => tr *= t,
                None => return Rgb::ZERO,
            }
            let sm = self.shape_media[shape];
            if sm.is_transition() {
                medium = sm.target(si.n_geo, d);
            }
            let next = offset_ray_origin(si.p, si.n_geo, d);
            dist -= (next - o).length();
            o = next;
            if dist <= 0.0 {
                return tr;
            }
        }
        Rgb::ZERO
    }

    /// Next-event estimation from a point `x` inside `medium`: the sampled light and the
    /// transmittance towards it (`None` when blocked).
    fn vp_nee_medium<S: Sampler>(
        &self,
        x: Vec3,
        medium: Option<u32>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Option<(LightSample, Rgb)> {
        let ls = self.sample_light(x, rng.next_2d())?;
        let dist = if ls.dist.is_finite() {
            ls.dist * (1.0 - SHADOW_EPSILON)
        } else {
            f32::INFINITY
        };
        let tr = self.vp_transmittance(x, ls.wi, dist, medium, rng, counters, wl);
        if tr.is_black() {
            return None;
        }
        Some((ls, tr))
    }

    /// Radiance along a camera ray (one sample) with Mitsuba's `volpath`; `hit` is
    /// `intersect(&ray)`.
    pub fn li_volpath<S: Sampler>(
        &self,
        settings: &PathSettings,
        mut ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        let ctx = BsdfContext::RADIANCE;
        let max_depth = if settings.max_depth < 0 {
            u32::MAX
        } else {
            settings.max_depth as u32
        };
        let rr_depth = settings.rr_depth.max(0) as u32;
        let mut result = Rgb::ZERO;
        let mut throughput = Rgb::ONE;
        let mut eta = 1.0f32;
        let mut depth = 0u32;
        let mut medium = self.camera_medium;
        // spectral MIS over the hero channel (see crate::media::homogeneous): `throughput` is
        // f / p_hero and `r_u` is p_c / p_hero; contributions are divided by mean(r_u)
        let hero = ((rng.next_1d() * 3.0) as usize).min(2);
        let mut r_u = Rgb::ONE;
        let mut specular_chain = !settings.hide_emitters;
        let mut last_p = ray.o;
        let mut last_pdf = 1.0f32;
        counters.rays += 1;
        let mut next_hit = Some(hit);
        // the wavelengths the rest of the path is shaded at: after a dispersive Dirac
        // refraction keeps one channel, the dead ones take its wavelength (as in `path`, see
        // `collapse_dead_channels`); the film keeps `wl`
        let mut wl_path = wl.copied();
        loop {
            let wl = wl_path.as_ref();
            if throughput.is_black() {
                break;
            }
            if depth > rr_depth {
                let q = (throughput.max_component() / r_u.mean() * eta * eta).min(0.95);
                if rng.next_1d() >= q {
                    break;
                }
                throughput /= q;
            }
            if depth >= max_depth {
                break;
            }
            let hit = match next_hit.take() {
                Some(h) => h,
                None => {
                    counters.rays += 1;
                    self.intersect(&ray)
                }
            };

            // ------------------------- the medium -------------------------
            if let Some(mi) = medium {
                let m = &self.media[mi as usize];
                let t_max = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
                let ff = m.sample_free_flight(ray.o, ray.d, t_max, hero, wl, rng);
                let (FreeFlight::Scatter { value, pdf, .. } | FreeFlight::Pass { value, pdf }) = ff;
                let ph = pdf[hero];
                if ph <= 0.0 || ph.is_nan() {
                    break;
                }
                throughput *= value / ph;
                r_u *= pdf / ph;
                match ff {
                    FreeFlight::Scatter { t, .. } => {
                        depth += 1;
                        if depth >= max_depth || throughput.is_black() {
                            break;
                        }
                        let p = ray.at(t);
                        let wi = -ray.d;
                        let phase = m.phase();
                        if m.sample_emitters() {
                            specular_chain = false;
                            if let Some((ls, tr)) = self.vp_nee_medium(p, medium, rng, counters, wl)
                            {
                                let f = phase.eval(wi, ls.wi);
                                let w = if ls.is_delta {
                                    1.0
                                } else {
                                    mis(ls.pdf, phase.pdf(wi, ls.wi))
                                };
                                let lw = self.light_weight(&ls, wl);
                                result += throughput * lw * tr * (f * w / r_u.mean());
                            }
                        } else {
                            specular_chain = true;
                        }
                        let Some(ps) = phase.sample(wi, rng.next_1d(), rng.next_2d()) else {
                            break;
                        };
                        throughput *= ps.weight;
                        last_p = p;
                        last_pdf = ps.pdf;
                        ray = Ray {
                            o: p,
                            d: ps.wo,
                            t_max: f32::INFINITY,
                        };
                        continue;
                    }
                    FreeFlight::Pass { .. } => {}
                }
            }

            // ------------------------- the surface ------------------------
            let count_direct = depth == 0 || specular_chain;
            let show = !(depth == 0 && settings.hide_emitters);
            let Some(hit) = hit else {
                if show {
                    let pdf = (!count_direct).then_some(last_pdf);
                    let le = self.infinite_radiance(ray.d, pdf, 1.0, wl);
                    result += throughput * le * (1.0 / r_u.mean());
                }
                break;
            };
            let shape = hit.shape as usize;
            let si = self.geometry[shape].surface(&ray, &hit);
            let wi = si.sh_frame.to_local(-ray.d);
            if let (Some(li), true) = (self.shape_light[shape], show) {
                if let Light::Area { radiance, .. } = &self.lights[li as usize] {
                    if wi.z > 0.0 {
                        let w = if count_direct {
                            1.0
                        } else {
                            mis(
                                last_pdf,
                                self.area_light_pdf(hit.shape, last_p, si.p, si.n_geo),
                            )
                        };
                        let le = self.area_emission_at(li, radiance, si.uv, si.p, wl);
                        result += throughput * le * (w / r_u.mean());
                    }
                }
            }
            let sm = self.shape_media[shape];
            let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
            if is_null_bsdf(bsdf) {
                // an index-matched boundary: go straight on, possibly into another medium
                if sm.is_transition() {
                    medium = sm.target(si.n_geo, ray.d);
                }
                ray = Ray {
                    o: offset_ray_origin(si.p, si.n_geo, ray.d),
                    d: ray.d,
                    t_max: f32::INFINITY,
                };
                continue;
            }
            let mut sp = si.shading_point(
                &hit,
                self.geometry[shape].surface_data(),
                bsdf.reads_local_geometry(),
            );
            sp.wavelengths = wl.copied();

            // next-event estimation
            if bsdf.flags().intersects(LobeFlags::SMOOTH) && depth + 1 < max_depth {
                let ls = self.sample_light(si.p, rng.next_2d());
                if let Some(ls) = ls {
                    let wo = si.sh_frame.to_local(ls.wi);
                    let (f, bsdf_pdf) = bsdf.eval_pdf(&ctx, &sp, wi, wo);
                    if !f.is_black() {
                        let start = if sm.is_transition() {
                            sm.target(si.n_geo, ls.wi)
                        } else {
                            medium
                        };
                        let o = offset_ray_origin(si.p, si.n_geo, ls.wi);
                        let dist = if ls.dist.is_finite() {
                            ls.dist * (1.0 - SHADOW_EPSILON)
                        } else {
                            f32::INFINITY
                        };
                        let tr = self.vp_transmittance(o, ls.wi, dist, start, rng, counters, wl);
                        if !tr.is_black() {
                            let w = if ls.is_delta {
                                1.0
                            } else {
                                mis(ls.pdf, bsdf_pdf)
                            };
                            let lw = self.light_weight(&ls, wl);
                            result += throughput * f * lw * tr * (wo.z.abs() * w / r_u.mean());
                        }
                    }
                }
            }

            // BSDF sampling
            let Some(bs) = bsdf.sample(&ctx, &sp, wi, rng.next_1d(), rng.next_2d()) else {
                break;
            };
            let d = si.sh_frame.to_world(bs.wo).normalize();
            throughput *= bs.weight;
            if let Some(w) = wl_path.as_mut() {
                collapse_dead_channels(w, throughput.0);
            }
            eta *= bs.eta;
            // a `Null` lobe (`null`, `mask`; Mitsuba's `thindielectric` transmission) is not a bounce
            let null_event = bs.lobe == LobeFlags::NULL
                || (matches!(bsdf, Bsdf::ThinDielectric(_))
                    && bs.lobe == LobeFlags::DELTA_TRANSMISSION);
            if !null_event {
                depth += 1;
                last_p = si.p;
                last_pdf = bs.pdf;
                if bs.lobe.is_delta() {
                    specular_chain = true;
                }
            }
            if bs.lobe.intersects(LobeFlags::SMOOTH) {
                specular_chain = false;
            }
            if sm.is_transition() {
                medium = sm.target(si.n_geo, d);
            }
            ray = Ray {
                o: offset_ray_origin(si.p, si.n_geo, d),
                d,
                t_max: f32::INFINITY,
            };
        }
        result
    }
}

#[cfg(test)]
mod tests {
    use crate::render::{render, RenderOptions};
    use crate::scene::Scene;
    use std::path::Path;
    use std::sync::atomic::AtomicBool;

    fn scene(
        body: &str,
        sensor_extra: &str,
        origin: &str,
        integrator: &str,
    ) -> crate::core::Result<Scene> {
        scene_fov(body, sensor_extra, origin, integrator, 60.0)
    }

    fn scene_fov(
        body: &str,
        sensor_extra: &str,
        origin: &str,
        integrator: &str,
        fov: f32,
    ) -> crate::core::Result<Scene> {
        let text = format!(
            r#"<scene version="3.0.0">
    <integrator type="{integrator}"/>
    {body}
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world"><lookat origin="{origin}" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
        {sensor_extra}
    </sensor>
</scene>"#
        );
        Scene::from_xml_str(&text, "<test>", Path::new("."), &[])
    }

    fn mean(s: &Scene, spp: u32) -> [f64; 3] {
        let out = render(
            s,
            &RenderOptions {
                spp,
                seed: 3,
                threads: 1,
            },
            &AtomicBool::new(false),
            &|_, _| {},
        );
        assert_eq!(out.counters.invalid, 0);
        let mut m = [0f64; 3];
        for px in out.rgb.chunks(3) {
            for c in 0..3 {
                m[c] += px[c] as f64;
            }
        }
        m.map(|v| v / (out.rgb.len() / 3) as f64)
    }

    const FURNACE: &str = r#"
    <emitter type="constant"><rgb name="radiance" value="0.5, 0.7, 1.0"/></emitter>
    <medium type="homogeneous" id="m">
        <rgb name="sigma_t" value="0.5, 2, 4"/>
        <float name="albedo" value="1"/>
        <phase type="hg"><float name="g" value="0.4"/></phase>
    </medium>
    <shape type="sphere"><float name="radius" value="1.5"/><bsdf type="null"/><ref name="interior" id="m"/></shape>"#;

    /// A volumetric furnace: a non-absorbing (albedo 1) medium bounded by an invisible `null`
    /// sphere under uniform light of radiance L keeps radiance L everywhere and in every
    /// direction (chromatic extinction, anisotropic phase function), seen from inside (the
    /// camera's medium) and from outside. 8×8 pixels, 16 renders (seeds 0–15) × 512 spp: the
    /// mean is within 4 standard errors of L per channel, and the standard error below 0.6 %
    /// (the blue channel, σt = 4 with albedo 1, has heavy-tailed weights).
    #[test]
    fn volumetric_furnace() {
        let want = [0.5, 0.7, 1.0];
        for (extra, origin) in [(r#"<ref id="m"/>"#, "0, 0.2, 0.1"), ("", "0, 0, -4")] {
            let s = scene(FURNACE, extra, origin, "volpath").unwrap();
            assert!(s.volpath && s.media.len() == 1);
            let (m, se) = mean_se(&s, 512, 16);
            for c in 0..3 {
                assert!(
                    (m[c] - want[c]).abs() < 4.0 * se[c] && se[c] < 0.006 * want[c],
                    "camera at {origin}: {m:?} ± {se:?} vs {want:?}"
                );
            }
        }
    }

    /// An absorbing medium (albedo 0) seen through its null boundary: the image is the
    /// environment times exp(−σt·chord); at the sphere's centre line the chord is 2r.
    #[test]
    fn absorbing_sphere_attenuates_by_beer_lambert() {
        let body = r#"
    <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
    <shape type="sphere"><float name="radius" value="1"/><bsdf type="null"/>
        <medium type="homogeneous" name="interior"><rgb name="sigma_t" value="0.1, 0.5, 1.5"/><float name="albedo" value="0"/></medium>
    </shape>"#;
        let s = scene_fov(body, "", "0, 0, -4", "volpath", 0.5).unwrap();
        // 262,144 samples: the relative standard error of the red channel is about 0.4 %
        let m = mean(&s, 4096);
        for (c, st) in [0.1f64, 0.5, 1.5].iter().enumerate() {
            let want = (-st * 2.0).exp();
            assert!(
                (m[c] / want - 1.0).abs() < 0.01,
                "channel {c}: {} vs {want}",
                m[c]
            );
        }
    }

    #[test]
    fn path_refuses_media_and_bad_refs_are_errors() {
        let e = scene(FURNACE, "", "0, 0, -4", "path")
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("volpath") && e.contains("<test>:"), "{e}");
        let e = scene(
            r#"<shape type="sphere"><ref name="interior" id="nope"/></shape>"#,
            "",
            "0, 0, -4",
            "volpath",
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("'nope'") && e.contains("<test>:"), "{e}");
        let e = scene(
            r#"<shape type="sphere"><medium type="homogeneous" name="inside"/></shape>"#,
            "",
            "0, 0, -4",
            "volpath",
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains("interior") && e.contains("<test>:"), "{e}");
        let e = scene(FURNACE, "", "0, 0, -4", "volpath")
            .map(|_| ())
            .and_then(|_| {
                scene(
                    r#"<integrator type="volpath"><integer name="depth" value="3"/></integrator>"#,
                    "",
                    "0, 0, -4",
                    "volpath",
                )
                .map(|_| ())
            })
            .err()
            .unwrap()
            .to_string();
        assert!(!e.is_empty());
    }

    /// Nested volumes: an absorbing sphere inside a larger absorbing sphere (inner's exterior is
    /// the outer medium). Along the centre line the light crosses 2 units of the inner medium
    /// and 2·(2 − 1) of the outer: exp(−(2σ_in + 2σ_out)).
    #[test]
    fn nested_media() {
        let body = r#"
    <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
    <medium type="homogeneous" id="outer"><float name="sigma_t" value="0.3"/><float name="albedo" value="0"/></medium>
    <shape type="sphere"><float name="radius" value="2"/><bsdf type="null"/><ref name="interior" id="outer"/></shape>
    <shape type="sphere"><float name="radius" value="1"/><bsdf type="null"/>
        <medium type="homogeneous" name="interior"><float name="sigma_t" value="0.8"/><float name="albedo" value="0"/></medium>
        <ref name="exterior" id="outer"/>
    </shape>"#;
        let s = scene_fov(body, "", "0, 0, -6", "volpath", 0.3).unwrap();
        // a path survives with probability T ≈ 0.11 and weight 1: 524,288 samples give a
        // relative standard error of 0.4 %
        let m = mean(&s, 8192);
        let want = (-(2.0 * 0.8 + 2.0 * 0.3f64)).exp();
        for c in m {
            assert!((c / want - 1.0).abs() < 0.02, "{c} vs {want}");
        }
    }

    /// A `thindielectric` sheet between a light and a floor (direct lighting only): shadow rays
    /// pass through it, attenuated by the slab transmittance 1 − 2R/(1 + R) (R = 0.04 at normal
    /// incidence for η = 1.5: 0.9231), as in Mitsuba's `volpath`, where `path` would see a
    /// shadow. The light is small and far, so every incidence is within 3° of normal.
    #[test]
    fn thindielectric_lets_shadow_rays_through() {
        let sheet = r#"<shape type="rectangle"><transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/><translate y="1"/></transform><bsdf type="thindielectric"/></shape>"#;
        let body = |extra: &str| {
            format!(
                r#"<shape type="rectangle"><transform name="to_world"><scale value="2"/><rotate x="1" angle="-90"/></transform><bsdf type="diffuse"/></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="0.05"/><rotate x="1" angle="90"/><translate y="3"/></transform>
        <emitter type="area"><rgb name="radiance" value="100, 100, 100"/></emitter></shape>
    {extra}"#
            )
        };
        let render_mean = |b: String| {
            let text = format!(
                r#"<scene version="3.0.0"><integrator type="volpath"><integer name="max_depth" value="2"/></integrator>{b}
    <sensor type="perspective"><float name="fov" value="20"/>
        <transform name="to_world"><lookat origin="0, 0.5, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor></scene>"#
            );
            mean(
                &Scene::from_xml_str(&text, "<test>", Path::new("."), &[]).unwrap(),
                256,
            )
        };
        let (with, without) = (render_mean(body(sheet)), render_mean(body("")));
        let r = 0.04f64;
        let want = 1.0 - 2.0 * r / (1.0 + r);
        for c in 0..3 {
            assert!(
                (with[c] / without[c] - want).abs() < 0.005,
                "{with:?} / {without:?} vs {want}"
            );
        }
    }

    /// `volpathmis` reads `volpath`'s parameters and `use_spectral_mis`, refuses others, and
    /// renders with the same estimator: the same image, bit for bit, for the same seed.
    #[test]
    fn volpathmis_is_volpath_with_spectral_mis() {
        let a = scene(FURNACE, "", "0, 0, -4", "volpath").unwrap();
        let b = scene(FURNACE, "", "0, 0, -4", "volpathmis").unwrap();
        assert!(b.volpath);
        let opts = RenderOptions {
            spp: 4,
            seed: 1,
            threads: 1,
        };
        let img = |s: &Scene| render(s, &opts, &AtomicBool::new(false), &|_, _| {}).rgb;
        assert_eq!(img(&a), img(&b));
        let text = |integrator: &str| {
            format!(
                r#"<scene version="3.0.0">{integrator}<emitter type="constant"/><sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor></scene>"#
            )
        };
        let ok = Scene::from_xml_str(
            &text(r#"<integrator type="volpathmis"><integer name="max_depth" value="4"/><boolean name="use_spectral_mis" value="false"/></integrator>"#),
            "<test>",
            Path::new("."),
            &[],
        )
        .unwrap();
        assert!(
            matches!(ok.integrator, crate::integrator::Integrator::Volpath(p) if p.max_depth == 4)
        );
        for bad in [
            r#"<integrator type="volpath"><boolean name="use_spectral_mis" value="true"/></integrator>"#,
            r#"<integrator type="volpathmis"><integer name="depth" value="4"/></integrator>"#,
        ] {
            let e = Scene::from_xml_str(&text(bad), "<test>", Path::new("."), &[])
                .err()
                .unwrap()
                .to_string();
            assert!(e.contains("<test>:1:"), "{bad}: {e}");
        }
    }

    /// Per-channel mean and standard error of the image mean over `seeds` renders of `spp`.
    fn mean_se(s: &Scene, spp: u32, seeds: u64) -> ([f64; 3], [f64; 3]) {
        let (mut m, mut m2) = ([0f64; 3], [0f64; 3]);
        for seed in 0..seeds {
            let out = render(
                s,
                &RenderOptions {
                    spp,
                    seed,
                    threads: 1,
                },
                &AtomicBool::new(false),
                &|_, _| {},
            );
            assert_eq!(out.counters.invalid, 0);
            let mut v = [0f64; 3];
            for px in out.rgb.chunks(3) {
                for c in 0..3 {
                    v[c] += px[c] as f64 / (out.rgb.len() / 3) as f64;
                }
            }
            for c in 0..3 {
                m[c] += v[c] / seeds as f64;
                m2[c] += v[c] * v[c] / seeds as f64;
            }
        }
        let se = [0, 1, 2].map(|c| ((m2[c] - m[c] * m[c]).max(0.0) / (seeds - 1) as f64).sqrt());
        (m, se)
    }

    /// A `heterogeneous` medium whose `sigma_t` and `albedo` are `constvolume`s covering its
    /// `null` cube renders the same image as the `homogeneous` one (chromatic σt, anisotropic
    /// phase function, an area light and an environment, so that delta tracking, ratio
    /// tracking and spectral MIS all take part): the image means of 12 renders (seeds 0–11,
    /// 8×8 pixels × 128 spp) of each agree per channel within 4 combined standard errors
    /// (two-sided, about 6·10⁻⁵ false-alarm probability per channel under normal errors).
    #[test]
    fn heterogeneous_constvolume_equals_homogeneous() {
        let medium = |kind: &str| {
            let params = if kind == "homogeneous" {
                r#"<rgb name="sigma_t" value="0.4, 1.2, 2.5"/><rgb name="albedo" value="0.9, 0.7, 0.8"/>"#.to_string()
            } else {
                let box_ = r#"<transform name="to_world"><scale value="2"/><translate value="-1, -1, -1"/></transform>"#;
                format!(
                    r#"<volume type="constvolume" name="sigma_t"><rgb name="value" value="0.2, 0.6, 1.25"/>{box_}</volume>
                    <volume type="constvolume" name="albedo"><rgb name="value" value="0.9, 0.7, 0.8"/></volume>
                    <float name="scale" value="2"/>"#
                )
            };
            format!(
                r#"<emitter type="constant"><rgb name="radiance" value="0.3, 0.4, 0.5"/></emitter>
    <shape type="rectangle"><transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate y="2.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="8, 8, 8"/></emitter></shape>
    <shape type="cube"><bsdf type="null"/>
        <medium type="{kind}" name="interior">{params}<phase type="hg"><float name="g" value="0.5"/></phase></medium></shape>"#
            )
        };
        let hom = scene_fov(&medium("homogeneous"), "", "0.5, 1, -4", "volpath", 40.0).unwrap();
        let het = scene_fov(&medium("heterogeneous"), "", "0.5, 1, -4", "volpath", 40.0).unwrap();
        assert!(matches!(
            het.media[0],
            crate::media::Medium::Heterogeneous(_)
        ));
        let (a, sa) = mean_se(&hom, 128, 12);
        let (b, sb) = mean_se(&het, 128, 12);
        for c in 0..3 {
            let se = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
            assert!(
                (a[c] - b[c]).abs() < 4.0 * se && se < 0.01 * a[c],
                "channel {c}: homogeneous {} ± {}, heterogeneous {} ± {}",
                a[c],
                sa[c],
                b[c],
                sb[c]
            );
        }
    }

    /// As in Mitsuba 3, a float `sigma_t` is a constvolume over the unit cube [0, 1]³ only: an
    /// absorbing heterogeneous medium inside a null sphere of radius 2, seen along the line
    /// x = y = 0.5, attenuates by exp(−σt·1) (the cube's depth), not exp(−σt·chord); and the
    /// line x = y = −0.5 (outside the cube) is not attenuated at all.
    #[test]
    fn float_sigma_t_fills_only_the_unit_cube() {
        let body = r#"
    <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
    <shape type="sphere"><float name="radius" value="2"/><bsdf type="null"/>
        <medium type="heterogeneous" name="interior"><float name="sigma_t" value="0.7"/><float name="albedo" value="0"/></medium>
    </shape>"#;
        for (x, want) in [(0.5f32, (-0.7f64).exp()), (-0.5, 1.0)] {
            let cam = format!(
                r#"<sensor type="perspective"><float name="fov" value="0.5"/>
        <transform name="to_world"><lookat origin="{x}, {x}, -4" target="{x}, {x}, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>"#
            );
            let text = format!(
                r#"<scene version="3.0.0"><integrator type="volpath"/>{body}{cam}</scene>"#
            );
            let s = Scene::from_xml_str(&text, "<test>", Path::new("."), &[]).unwrap();
            // the pass probability is exp(−0.7) ≈ 0.5 with weight 1: 262,144 samples give a
            // relative standard error of 0.2 %
            let m = mean(&s, 4096);
            for c in m {
                assert!((c / want - 1.0).abs() < 0.01, "x = {x}: {c} vs {want}");
            }
        }
    }

    /// Spectral mode: a white (albedo 1) medium in a white furnace stays white. The constant
    /// white environment is D65, which develops to (1, 1, 1); a non-absorbing medium keeps the
    /// radiance at every wavelength whatever its extinction, here chromatic: an rgb `sigma_t`
    /// (upsampled, the hero channel a wavelength) in a homogeneous medium, and an RGB grid
    /// (each texel upsampled, delta and ratio tracking against the spectral majorant) in a
    /// heterogeneous one. 8×8 pixels, 8 renders (seeds 0–7) × 256 spp, camera inside the
    /// medium: each channel's mean within 4 standard errors plus 0.3 % (the develop's
    /// quadrature) of 1, the standard error below 0.8 %.
    #[test]
    fn spectral_volumetric_furnace_stays_white() {
        let dir = std::env::temp_dir().join(format!("specula_volpath_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let vol = dir.join("chroma.vol");
        let mut b = b"VOL\x03".to_vec();
        for v in [1i32, 2, 2, 2, 3] {
            b.extend(v.to_le_bytes());
        }
        let texels = [
            [0.9f32, 0.1, 0.1],
            [0.1, 0.9, 0.2],
            [0.1, 0.1, 0.9],
            [0.5, 0.4, 0.05],
        ];
        for v in [0f32, 0., 0., 1., 1., 1.]
            .into_iter()
            .chain((0..8).flat_map(|i| texels[i % 4]))
        {
            b.extend(v.to_le_bytes());
        }
        std::fs::write(&vol, b).unwrap();
        let media = [
            r#"<medium type="homogeneous" id="m"><rgb name="sigma_t" value="0.125, 0.5, 1"/>
                <float name="scale" value="2"/><float name="albedo" value="1"/>
                <phase type="hg"><float name="g" value="0.4"/></phase></medium>"#
                .to_string(),
            format!(
                r#"<medium type="heterogeneous" id="m">
                <volume type="gridvolume" name="sigma_t"><string name="filename" value="{}"/>
                    <transform name="to_world"><scale value="4"/><translate value="-2, -2, -2"/></transform></volume>
                <float name="scale" value="3"/><float name="albedo" value="1"/></medium>"#,
                vol.display()
            ),
        ];
        for medium in &media {
            let body = format!(
                r#"<emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>{medium}
    <shape type="sphere"><float name="radius" value="1.5"/><bsdf type="null"/><ref name="interior" id="m"/></shape>"#
            );
            let mut s = scene(&body, r#"<ref id="m"/>"#, "0, 0.2, 0.1", "volpath").unwrap();
            s.set_spectral(true).unwrap();
            let (m, se) = mean_se(&s, 256, 8);
            for c in 0..3 {
                assert!(
                    (m[c] - 1.0).abs() < 4.0 * se[c] + 0.003 && se[c] < 0.008,
                    "{}: {m:?} ± {se:?}",
                    &medium[..40]
                );
            }
        }
        // a raw RGB grid has no spectrum: spectral mode refuses it, RGB mode renders it
        let raw = media[1].replace(
            r#"<string name="filename""#,
            r#"<boolean name="raw" value="true"/><string name="filename""#,
        );
        let body = format!(
            r#"{raw}<shape type="sphere"><bsdf type="null"/><ref name="interior" id="m"/></shape>"#
        );
        let mut s = scene(&body, "", "0, 0, -4", "volpath").unwrap();
        let e = s.set_spectral(true).unwrap_err().to_string();
        assert!(e.contains("raw"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Spectral mode behind dispersive interfaces: a `dielectric` sphere with SF11's
    /// dispersion (each wavelength refracts on its own; after a Dirac refraction keeps one,
    /// the rest of the path is shaded at it, as in `path`) under a coloured environment and an
    /// area light renders the same image with `volpath` as with `path`: the image means of 10
    /// renders (seeds 0–9, 8×8 pixels × 128 spp) agree per channel within 4 combined standard
    /// errors.
    #[test]
    fn spectral_dispersion_volpath_equals_path() {
        let body = r#"<emitter type="constant"><rgb name="radiance" value="0.2, 0.5, 0.9"/></emitter>
    <shape type="rectangle"><transform name="to_world"><scale value="0.6"/><rotate x="1" angle="90"/><translate y="2"/></transform>
        <emitter type="area"><rgb name="radiance" value="9, 6, 3"/></emitter></shape>
    <shape type="sphere"><bsdf type="dielectric"><string name="dispersion" value="sf11"/></bsdf></shape>"#;
        let mut means = Vec::new();
        for integrator in ["path", "volpath"] {
            let mut s = scene_fov(body, "", "0.3, 0.5, -4", integrator, 35.0).unwrap();
            s.set_spectral(true).unwrap();
            means.push(mean_se(&s, 128, 10));
        }
        let ((a, sa), (b, sb)) = (means[0], means[1]);
        for c in 0..3 {
            let se = (sa[c] * sa[c] + sb[c] * sb[c]).sqrt();
            assert!(
                (a[c] - b[c]).abs() < 4.0 * se && se < 0.02 * a[c],
                "channel {c}: path {} ± {}, volpath {} ± {}",
                a[c],
                sa[c],
                b[c],
                sb[c]
            );
        }
    }
}
