//! `volpath`: Mitsuba 3's volumetric path tracer — unidirectional path tracing through
//! participating media ([`crate::media`]) with next-event estimation at surfaces and at
//! scattering events in media, and multiple importance sampling (power heuristic).
//!
//! Parameters (Mitsuba's): `max_depth` (default −1 = unbounded; 1 = only directly visible
//! emitters, 2 = direct lighting), `rr_depth` (default 5), `hide_emitters` (default false).
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
//! Deviations from Mitsuba (same expectation, different noise): free-flight distances are
//! sampled with a channel drawn per segment and weighted by the channels' average density
//! (see [`crate::media::homogeneous`]); shadow rays use the exact transmittance of homogeneous
//! media instead of a track-length estimate; emitting spheres are sampled by area rather than
//! by the cone they subtend.

use crate::accel::{offset_ray_origin, SHADOW_EPSILON};
use crate::core::{Hit, Ray, Result, SceneError};
use crate::integrator::Counters;
use crate::media::{is_null_bsdf, FreeFlight};
use crate::scene::{Light, PathSettings, Scene};
use crate::xml::Node;
use glam::Vec3;
use specula_bsdf::rng::Pcg32;
use specula_bsdf::{BsdfContext, BsdfModel, LobeFlags, Rgb, ShadingPoint};

/// Reads a `<integrator type="volpath">` node.
pub fn settings_from_node(n: &Node) -> Result<PathSettings> {
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
    n.check_unused(&["max_depth", "rr_depth", "hide_emitters"])?;
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

/// A light sample: direction, distance, radiance / pdf, pdf (with selection), Dirac or not.
struct EmitterSample {
    wi: Vec3,
    dist: f32,
    weight: Rgb,
    pdf: f32,
    is_delta: bool,
}

/// Bound on the surfaces a shadow ray passes through (null boundaries), against loops on
/// degenerate geometry.
const MAX_SHADOW_CROSSINGS: usize = 256;

impl Scene {
    #[inline]
    fn vp_select_pdf(&self) -> f32 {
        1.0 / self.lights.len() as f32
    }

    /// Solid-angle pdf (with selection) that [`Scene::vp_sample_emitter`] picks the point
    /// `p_light` (normal `n_light`) on shape `shape` from `x`.
    fn vp_area_pdf(&self, shape: u32, x: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
        let g = &self.geometry[shape as usize];
        let d = p_light - x;
        let dist2 = d.length_squared();
        let cos_l = n_light.dot(d).abs() / dist2.sqrt();
        if cos_l <= 0.0 {
            return 0.0;
        }
        g.pdf_position() * dist2 / cos_l * self.vp_select_pdf()
    }

    fn vp_sample_emitter(&self, x: Vec3, rng: &mut Pcg32) -> Option<EmitterSample> {
        let n = self.lights.len();
        let u_sel = rng.next_f32();
        let u = rng.next_vec2();
        if n == 0 {
            return None;
        }
        let sel = self.vp_select_pdf();
        match &self.lights[((u_sel * n as f32) as usize).min(n - 1)] {
            Light::Area { shape, radiance } => {
                let ps = self.geometry[*shape as usize].sample_position(u);
                let d = ps.p - x;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_l = -ps.n.dot(wi);
                if cos_l <= 0.0 || ps.pdf <= 0.0 {
                    return None;
                }
                let pdf = ps.pdf * dist2 / cos_l * sel;
                Some(EmitterSample {
                    wi,
                    dist,
                    weight: *radiance / pdf,
                    pdf,
                    is_delta: false,
                })
            }
            Light::Other(e) => {
                let ds = e.sample_direction(x, u)?;
                if ds.pdf <= 0.0 {
                    return None;
                }
                let pdf = ds.pdf * sel;
                Some(EmitterSample {
                    wi: ds.wi,
                    dist: ds.dist,
                    weight: ds.radiance / pdf,
                    pdf,
                    is_delta: ds.is_delta,
                })
            }
        }
    }

    /// Transmittance from `o` along `d` over `dist` (infinite: to infinity), starting in
    /// `medium`, through `null` surfaces; zero when anything else is in the way.
    fn vp_transmittance(
        &self,
        mut o: Vec3,
        d: Vec3,
        mut dist: f32,
        mut medium: Option<u32>,
        counters: &mut Counters,
    ) -> Rgb {
        let mut tr = Rgb::ONE;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            counters.rays += 1;
            let ray = Ray { o, d, t_max: dist };
            let hit = self.intersect(&ray);
            let seg = hit.as_ref().map_or(dist, |h| h.t);
            if let Some(m) = medium {
                tr *= self.media[m as usize].transmittance(seg);
            }
            let Some(h) = hit else {
                return tr;
            };
            let shape = h.shape as usize;
            if tr.is_black() || !is_null_bsdf(&self.bsdfs[self.shape_bsdf[shape] as usize]) {
                return Rgb::ZERO;
            }
            let si = self.geometry[shape].surface(&ray, &h);
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
    fn vp_nee_medium(
        &self,
        x: Vec3,
        medium: Option<u32>,
        rng: &mut Pcg32,
        counters: &mut Counters,
    ) -> Option<(EmitterSample, Rgb)> {
        let ls = self.vp_sample_emitter(x, rng)?;
        let dist = if ls.dist.is_finite() {
            ls.dist * (1.0 - SHADOW_EPSILON)
        } else {
            f32::INFINITY
        };
        let tr = self.vp_transmittance(x, ls.wi, dist, medium, counters);
        if tr.is_black() {
            return None;
        }
        Some((ls, tr))
    }

    /// Radiance along a camera ray (one sample) with Mitsuba's `volpath`; `hit` is
    /// `intersect(&ray)`.
    pub fn li_volpath(
        &self,
        mut ray: Ray,
        hit: Option<Hit>,
        rng: &mut Pcg32,
        counters: &mut Counters,
    ) -> Rgb {
        let settings = self.integrator;
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
        let mut specular_chain = !settings.hide_emitters;
        let mut last_p = ray.o;
        let mut last_pdf = 1.0f32;
        counters.rays += 1;
        let mut next_hit = Some(hit);
        loop {
            if throughput.is_black() {
                break;
            }
            if depth > rr_depth {
                let q = (throughput.max_component() * eta * eta).min(0.95);
                if rng.next_f32() >= q {
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
                let (u_c, u_t) = (rng.next_f32(), rng.next_f32());
                match m.sample_free_flight(t_max, u_c, u_t) {
                    FreeFlight::Scatter { t, weight } => {
                        throughput *= weight;
                        depth += 1;
                        if depth >= max_depth || throughput.is_black() {
                            break;
                        }
                        let p = ray.at(t);
                        let wi = -ray.d;
                        let phase = m.phase();
                        if m.sample_emitters() {
                            specular_chain = false;
                            if let Some((ls, tr)) = self.vp_nee_medium(p, medium, rng, counters) {
                                let f = phase.eval(wi, ls.wi);
                                let w = if ls.is_delta {
                                    1.0
                                } else {
                                    mis(ls.pdf, phase.pdf(wi, ls.wi))
                                };
                                result += throughput * ls.weight * tr * (f * w);
                            }
                        } else {
                            specular_chain = true;
                        }
                        let Some(ps) = phase.sample(wi, rng.next_f32(), rng.next_vec2()) else {
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
                    FreeFlight::Pass { weight } => throughput *= weight,
                }
            }

            // ------------------------- the surface ------------------------
            let count_direct = depth == 0 || specular_chain;
            let show = !(depth == 0 && settings.hide_emitters);
            let Some(hit) = hit else {
                if show {
                    for &li in &self.infinite_lights {
                        if let Light::Other(e) = &self.lights[li as usize] {
                            let le = e.eval_direction(ray.d);
                            if le.is_black() {
                                continue;
                            }
                            let w = if count_direct {
                                1.0
                            } else {
                                mis(last_pdf, e.pdf_direction(ray.d) * self.vp_select_pdf())
                            };
                            result += throughput * le * w;
                        }
                    }
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
                                self.vp_area_pdf(hit.shape, last_p, si.p, si.n_geo),
                            )
                        };
                        result += throughput * *radiance * w;
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
            let sp = ShadingPoint { uv: si.uv, p: si.p };

            // next-event estimation
            if bsdf.flags().intersects(LobeFlags::SMOOTH) && depth + 1 < max_depth {
                let ls = self.vp_sample_emitter(si.p, rng);
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
                        let tr = self.vp_transmittance(o, ls.wi, dist, start, counters);
                        if !tr.is_black() {
                            let w = if ls.is_delta {
                                1.0
                            } else {
                                mis(ls.pdf, bsdf_pdf)
                            };
                            result += throughput * f * ls.weight * tr * (wo.z.abs() * w);
                        }
                    }
                }
            }

            // BSDF sampling
            let Some(bs) = bsdf.sample(&ctx, &sp, wi, rng.next_f32(), rng.next_vec2()) else {
                break;
            };
            let d = si.sh_frame.to_world(bs.wo).normalize();
            throughput *= bs.weight;
            eta *= bs.eta;
            depth += 1;
            last_p = si.p;
            last_pdf = bs.pdf;
            if bs.lobe.is_delta() {
                specular_chain = true;
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
