//! Unidirectional path tracing with next-event estimation and multiple importance sampling
//! (power heuristic), following the structure and depth semantics of Mitsuba 3's `path`
//! integrator: `max_depth` counts path segments (1 = only directly visible emitters, 2 =
//! direct lighting, −1 = unbounded) and Russian roulette starts at `rr_depth`.

use crate::core::{Hit, Ray, SurfaceGeometry};
use crate::geometry::Geometry;
use crate::scene::{Light, Scene};
use glam::{Vec2, Vec3};
use specula_bsdf::rng::Pcg32;
use specula_bsdf::{BsdfContext, BsdfModel, Rgb};

use crate::accel::{offset_ray_origin, SHADOW_EPSILON};

/// Per-thread counters.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counters {
    pub rays: u64,
    pub samples: u64,
    /// Samples whose estimate was NaN or infinite and was discarded.
    pub invalid: u64,
}

impl Counters {
    pub fn add(&mut self, o: &Counters) {
        self.rays += o.rays;
        self.samples += o.samples;
        self.invalid += o.invalid;
    }
}

#[inline]
fn mis(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && a2.is_finite() {
        a2 / (a2 + b2)
    } else if a2.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// The cone of directions a sphere subtends from an outside point: (unit axis, distance to the
/// centre, 1 − cosθmax). `None` from inside (or on) the sphere, or for inward-facing spheres,
/// where uniform area sampling is used instead.
#[inline]
fn sphere_cone(g: &Geometry, x: Vec3) -> Option<(glam::DVec3, f64, f64)> {
    let Geometry::Sphere(sph) = g else {
        return None;
    };
    if sph.flip_normals {
        return None;
    }
    let to_c = sph.center.as_dvec3() - x.as_dvec3();
    let d2 = to_c.length_squared();
    let r = sph.radius as f64;
    if d2 <= r * r * (1.0 + 1e-6) {
        return None;
    }
    let dist = d2.sqrt();
    let sin2 = r * r / d2;
    // 1 − cos without cancellation for small spheres
    let one_minus_cos = sin2 / (1.0 + (1.0 - sin2).sqrt());
    Some((to_c / dist, dist, one_minus_cos))
}

/// A light sample as seen from a shading point.
struct LightSample {
    wi: Vec3,
    dist: f32,
    /// radiance / (solid-angle pdf · selection probability)
    weight: Rgb,
    /// solid-angle pdf including the light selection probability
    pdf: f32,
    is_delta: bool,
}

impl Scene {
    #[inline]
    fn light_select_pdf(&self) -> f32 {
        1.0 / self.lights.len() as f32
    }

    /// Solid-angle pdf that next-event estimation samples a point at `p_light` (normal `n_light`)
    /// on shape `shape` from `x`, including the light selection probability.
    #[inline]
    fn area_light_pdf(&self, shape: u32, x: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
        let g = &self.geometry[shape as usize];
        if let Some((_, _, omc)) = sphere_cone(g, x) {
            return (1.0 / (2.0 * std::f64::consts::PI * omc)) as f32 * self.light_select_pdf();
        }
        let d = p_light - x;
        let dist2 = d.length_squared();
        let cos_l = n_light.dot(d).abs() / dist2.sqrt();
        if cos_l <= 0.0 {
            return 0.0;
        }
        g.pdf_position() * dist2 / cos_l * self.light_select_pdf()
    }

    fn sample_light(&self, x: Vec3, u_sel: f32, u: Vec2) -> Option<LightSample> {
        let n = self.lights.len();
        if n == 0 {
            return None;
        }
        let idx = ((u_sel * n as f32) as usize).min(n - 1);
        let sel = self.light_select_pdf();
        match &self.lights[idx] {
            Light::Area { shape, radiance } => {
                let g: &Geometry = &self.geometry[*shape as usize];
                if let (Some((axis, dist_c, omc)), Geometry::Sphere(sph)) = (sphere_cone(g, x), g) {
                    // uniform over the cone of directions the sphere subtends (as Mitsuba)
                    // with a = 1 − cosθ: sin²θ = a(2 − a), free of cancellation
                    let a = u.x as f64 * omc;
                    let cos_t = 1.0 - a;
                    let sin_t = (a * (2.0 - a)).max(0.0).sqrt();
                    let phi = 2.0 * std::f64::consts::PI * u.y as f64;
                    let f = specula_bsdf::frame::Frame::from_normal(axis.as_vec3());
                    let local = glam::DVec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
                    let d = (f.s.as_dvec3() * local.x
                        + f.t.as_dvec3() * local.y
                        + f.n.as_dvec3() * local.z)
                        .normalize();
                    // nearest intersection with the sphere along d
                    let b = d.dot(axis) * dist_c;
                    let r = sph.radius as f64;
                    let disc = (b * b - (dist_c * dist_c - r * r)).max(0.0);
                    let t = b - disc.sqrt();
                    let pdf = (1.0 / (2.0 * std::f64::consts::PI * omc)) as f32 * sel;
                    if t.is_nan() || t <= 0.0 || !pdf.is_finite() {
                        return None;
                    }
                    let wi = d.as_vec3();
                    return Some(LightSample {
                        wi,
                        dist: t as f32,
                        weight: radiance.eval_along(g, x, wi, t as f32) / pdf,
                        pdf,
                        is_delta: false,
                    });
                }
                let ps = g.sample_position(u);
                let d = ps.p - x;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                // emits from the front side only
                let cos_l = -ps.n.dot(wi);
                if cos_l <= 0.0 || ps.pdf <= 0.0 {
                    return None;
                }
                let pdf = ps.pdf * dist2 / cos_l * sel;
                Some(LightSample {
                    wi,
                    dist,
                    weight: radiance.eval(ps.uv, ps.p) / pdf,
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
                Some(LightSample {
                    wi: ds.wi,
                    dist: ds.dist,
                    weight: ds.radiance / pdf,
                    pdf,
                    is_delta: ds.is_delta,
                })
            }
        }
    }

    /// Radiance carried along `ray` from the camera (one path sample).
    pub fn li(&self, ray: Ray, rng: &mut Pcg32, counters: &mut Counters) -> Rgb {
        let hit = self.intersect(&ray);
        self.li_from(ray, hit, rng, counters)
    }

    /// [`Scene::li`] with the camera ray's intersection already found (`hit`, as
    /// `intersect(&ray)` returns it).
    pub fn li_from(
        &self,
        mut ray: Ray,
        hit: Option<Hit>,
        rng: &mut Pcg32,
        counters: &mut Counters,
    ) -> Rgb {
        let settings = self.integrator;
        let ctx = BsdfContext::RADIANCE;
        let mut result = Rgb::ZERO;
        let mut throughput = Rgb::ONE;
        let mut eta = 1.0f32;
        let mut depth: i32 = 0;
        let mut prev_bsdf_pdf = 1.0f32;
        let mut prev_bsdf_delta = true;
        let mut prev_p = ray.o;
        let max_depth = if settings.max_depth < 0 {
            i32::MAX
        } else {
            settings.max_depth
        };
        // the camera ray (traced by the caller); each bounce traces the next at its end
        counters.rays += 1;
        let mut next = hit;
        loop {
            let hit = next;
            let show_emitters = depth > 0 || !settings.hide_emitters;
            let Some(hit) = hit else {
                // escaped: infinitely distant lights
                if show_emitters {
                    for &li in &self.infinite_lights {
                        if let Light::Other(e) = &self.lights[li as usize] {
                            let le = e.eval_direction(ray.d);
                            if le.is_black() {
                                continue;
                            }
                            let w = if prev_bsdf_delta {
                                1.0
                            } else {
                                mis(
                                    prev_bsdf_pdf,
                                    e.pdf_direction(ray.d) * self.light_select_pdf(),
                                )
                            };
                            result += throughput * le * w;
                        }
                    }
                }
                break;
            };
            let shape = hit.shape as usize;
            let si: SurfaceGeometry = self.geometry[shape].surface(&ray, &hit);
            let wi = si.sh_frame.to_local(-ray.d);

            // emission of an area light hit by the previous bounce
            if let (Some(li), true) = (self.shape_light[shape], show_emitters) {
                if let Light::Area { radiance, .. } = &self.lights[li as usize] {
                    if wi.z > 0.0 {
                        let w = if prev_bsdf_delta {
                            1.0
                        } else {
                            mis(
                                prev_bsdf_pdf,
                                self.area_light_pdf(hit.shape, prev_p, si.p, si.n_geo),
                            )
                        };
                        result += throughput * radiance.eval(si.uv, si.p) * w;
                    }
                }
            }

            if depth + 1 >= max_depth {
                break;
            }
            let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
            let sp = si.shading_point(&hit, self.geometry[shape].surface_data());
            let flags = bsdf.flags();

            // next-event estimation
            if flags.intersects(specula_bsdf::LobeFlags::SMOOTH) {
                let u_sel = rng.next_f32();
                let u = rng.next_vec2();
                if let Some(ls) = self.sample_light(si.p, u_sel, u) {
                    let wo = si.sh_frame.to_local(ls.wi);
                    let (f, bsdf_pdf) = bsdf.eval_pdf(&ctx, &sp, wi, wo);
                    if !f.is_black() {
                        let o = offset_ray_origin(si.p, si.n_geo, ls.wi);
                        let t_max = if ls.dist.is_finite() {
                            ls.dist * (1.0 - SHADOW_EPSILON)
                        } else {
                            f32::INFINITY
                        };
                        counters.rays += 1;
                        if !self.occluded(&Ray { o, d: ls.wi, t_max }) {
                            let w = if ls.is_delta {
                                1.0
                            } else {
                                mis(ls.pdf, bsdf_pdf)
                            };
                            result += throughput * f * ls.weight * (wo.z.abs() * w);
                        }
                    }
                }
            } else {
                // keep the random sequence aligned regardless of the material
                rng.next_f32();
                rng.next_vec2();
            }

            // BSDF sampling
            let u1 = rng.next_f32();
            let u2 = rng.next_vec2();
            let Some(bs) = bsdf.sample(&ctx, &sp, wi, u1, u2) else {
                break;
            };
            let d = si.sh_frame.to_world(bs.wo).normalize();
            throughput *= bs.weight;
            eta *= bs.eta;
            prev_bsdf_pdf = bs.pdf;
            prev_bsdf_delta = bs.lobe.is_delta();
            prev_p = si.p;
            ray = Ray {
                o: offset_ray_origin(si.p, si.n_geo, d),
                d,
                t_max: f32::INFINITY,
            };

            depth += 1;
            let tmax = throughput.max_component();
            if tmax <= 0.0 {
                break;
            }
            if depth >= settings.rr_depth {
                let q = (tmax * eta * eta).min(0.95);
                if rng.next_f32() >= q {
                    break;
                }
                throughput /= q;
            }
            counters.rays += 1;
            next = self.intersect(&ray);
        }
        result
    }
}
