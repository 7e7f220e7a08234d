//! Mitsuba's `path` integrator (see the module documentation of [`crate::integrator`]).

use super::*;
use crate::emitters::{Emitter, Envmap, EnvmapLookup};

impl Scene {
    /// Mitsuba's `path` integrator. `wl`: the path's wavelengths in spectral mode (the result
    /// is then the radiance at them, see [`crate::spectral`]), `None` in RGB mode.
    pub fn li_path<S: Sampler>(
        &self,
        settings: &PathSettings,
        mut ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        // The wavelengths the rest of the path is shaded at: after a dispersive Dirac refraction
        // keeps one channel, the dead ones take its wavelength (see `collapse_dead_channels`),
        // so later dispersive interfaces do not split the path again. The film keeps `wl`.
        let mut wl_path = wl.copied();
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
        // the environment map's lookup along `ray` when `prefetch_infinite` made it (the
        // camera ray, traced by the caller, has none)
        let mut lookup = None;
        loop {
            let wl = wl_path.as_ref();
            let hit = next;
            let show_emitters = depth > 0 || !settings.hide_emitters;
            let Some(hit) = hit else {
                // escaped: infinitely distant lights (the one environment map's lookup found
                // before the ray was traced, when there is one, finished here)
                if show_emitters {
                    let bsdf_pdf = (!prev_bsdf_delta).then_some(prev_bsdf_pdf);
                    result += throughput
                        * match (lookup, wl) {
                            (Some((e, l)), None) => self.envmap_radiance_at(e, l, bsdf_pdf),
                            _ => self.infinite_radiance(ray.d, bsdf_pdf, 1.0, wl),
                        };
                }
                break;
            };
            let shape = hit.shape as usize;
            // (the uv of spheres whose uv nothing here reads is left at zero)
            let si: SurfaceGeometry = self.geometry[shape].surface_uv(&ray, &hit, false);
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
                        result +=
                            throughput * self.area_emission_at(li, radiance, si.uv, si.p, wl) * w;
                    }
                }
            }

            if depth + 1 >= max_depth {
                break;
            }
            let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
            let mut sp = si.shading_point(
                &hit,
                self.geometry[shape].surface_data(),
                bsdf.reads_local_geometry(),
            );
            sp.wavelengths = wl.copied();
            let flags = bsdf.flags();

            // the random numbers in the order they have always been drawn (light, then
            // BSDF); the light is sampled first and the BSDF sampled before the light sample
            // is evaluated, so that the CPU overlaps the light sampler's table lookups
            // (cache misses on a large environment map) with the BSDF's arithmetic
            let smooth = flags.intersects(specula_bsdf::LobeFlags::SMOOTH);
            // (values that nothing reads — the light sample of a material without smooth
            // lobes, the lobe choice of a one-lobe model, the direction of a Dirac-only one —
            // are stepped over, not computed: the other dimensions keep their values)
            let u_light = if smooth {
                rng.next_2d()
            } else {
                rng.skip_2d();
                Vec2::ZERO
            };
            let u1 = if bsdf.sample_reads_u1() {
                rng.next_1d()
            } else {
                rng.skip_1d();
                0.5
            };
            let u2 = if bsdf.sample_reads_u2() {
                rng.next_2d()
            } else {
                rng.skip_2d();
                Vec2::splat(0.5)
            };
            let light = if smooth {
                self.sample_light(si.p, u_light)
            } else {
                None
            };
            let sampled = bsdf.sample(&ctx, &sp, wi, u1, u2);

            // next-event estimation
            // (`light` is None for a material without smooth lobes)
            if let Some(ls) = light {
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
                        result += throughput * f * self.light_weight(&ls, wl) * (wo.z.abs() * w);
                    }
                }
            }

            // BSDF sampling
            let Some(bs) = sampled else {
                break;
            };
            let d = si.sh_frame.to_world(bs.wo).normalize();
            throughput *= bs.weight;
            if let Some(w) = wl_path.as_mut() {
                collapse_dead_channels(w, throughput.0);
            }
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
            // (with a NaN channel the path ends here or goes on to a sample that the film
            // discards as NaN)
            let [r, g, b] = throughput.0;
            let tmax = crate::core::max3(r, g, b);
            if tmax <= 0.0 {
                break;
            }
            if depth >= settings.rr_depth {
                let q = (tmax * eta * eta).min(0.95);
                if rng.next_1d() >= q {
                    break;
                }
                throughput /= q;
            }
            counters.rays += 1;
            lookup = self.prefetch_infinite(ray.d);
            next = self.intersect(&ray);
        }
        result
    }

    /// Asks the cache for what evaluating the environment maps along `d` will read, should
    /// the ray about to be traced escape (see [`crate::emitters::Envmap::prefetch`]). Where
    /// that map is the scene's one infinite light, its exact lookup is made now and returned
    /// (with the map), for [`Scene::envmap_radiance_at`] to finish if the ray escapes.
    #[inline(always)]
    pub(super) fn prefetch_infinite(&self, d: Vec3) -> Option<(&Envmap, EnvmapLookup)> {
        if self.prefetched_maps.is_empty() {
            return None;
        }
        self.prefetch_infinite_maps(d)
    }

    #[inline(never)]
    fn prefetch_infinite_maps(&self, d: Vec3) -> Option<(&Envmap, EnvmapLookup)> {
        if let ([li], [lj]) = (&self.prefetched_maps[..], &self.infinite_lights[..]) {
            if let (Light::Other(Emitter::Envmap(e)), true) = (&self.lights[*li as usize], li == lj)
            {
                return e.prefetch_lookup(d).map(|l| (&**e, l));
            }
        }
        for &li in &self.prefetched_maps {
            if let Light::Other(Emitter::Envmap(e)) = &self.lights[li as usize] {
                e.prefetch(d);
            }
        }
        None
    }

    /// [`Scene::infinite_radiance`] (RGB mode, `light_frac` 1) where the scene's one infinite
    /// light is the environment map `e` and `l` its lookup along the ray: that function's
    /// single-light case from the lookup on (the same weighting, `weighted_infinite`).
    #[inline]
    pub(super) fn envmap_radiance_at(
        &self,
        e: &Envmap,
        l: EnvmapLookup,
        bsdf_pdf: Option<f32>,
    ) -> Rgb {
        let (le, pdf) = match bsdf_pdf {
            Some(_) => e.eval_pdf_at(l),
            None => (e.eval_at(l), 0.0),
        };
        self.weighted_infinite(le, pdf, bsdf_pdf, 1.0)
    }
}
