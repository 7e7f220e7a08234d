//! Mitsuba's `direct` integrator (see the module documentation of [`crate::integrator`]).

use super::*;

impl Scene {
    /// Mitsuba's `direct` integrator.
    pub fn li_direct<S: Sampler>(
        &self,
        settings: &DirectSettings,
        ray: Ray,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        wl: Option<&Wavelengths>,
    ) -> Rgb {
        counters.rays += 1;
        let Some(hit) = hit else {
            return if settings.hide_emitters {
                Rgb::ZERO
            } else {
                self.infinite_radiance(ray.d, None, 1.0, wl)
            };
        };
        let shape = hit.shape as usize;
        let si = self.geometry[shape].surface(&ray, &hit);
        let wi = si.sh_frame.to_local(-ray.d);
        let mut result = Rgb::ZERO;
        if !settings.hide_emitters {
            if let Some(le) = self.area_emission(shape, &si, wi, wl) {
                result += le;
            }
        }
        let (ne, nb) = (settings.emitter_samples, settings.bsdf_samples);
        let total = (ne + nb).max(1) as f32;
        let (frac_lum, frac_bsdf) = (ne as f32 / total, nb as f32 / total);
        let ctx = BsdfContext::RADIANCE;
        let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
        let mut sp = si.shading_point(
            &hit,
            self.geometry[shape].surface_data(),
            bsdf.reads_local_geometry(),
        );
        sp.wavelengths = wl.copied();
        let smooth = bsdf.flags().intersects(specula_bsdf::LobeFlags::SMOOTH);

        // emitter sampling
        for _ in 0..ne {
            let u = rng.next_2d();
            if !smooth {
                continue;
            }
            let Some(ls) = self.sample_light(si.p, u) else {
                continue;
            };
            let wo = si.sh_frame.to_local(ls.wi);
            let (f, bsdf_pdf) = bsdf.eval_pdf(&ctx, &sp, wi, wo);
            if f.is_black() {
                continue;
            }
            let o = offset_ray_origin(si.p, si.n_geo, ls.wi);
            let t_max = if ls.dist.is_finite() {
                ls.dist * (1.0 - SHADOW_EPSILON)
            } else {
                f32::INFINITY
            };
            counters.rays += 1;
            if self.occluded(&Ray { o, d: ls.wi, t_max }) {
                continue;
            }
            let w = if ls.is_delta {
                1.0
            } else {
                mis(ls.pdf * frac_lum, bsdf_pdf * frac_bsdf)
            };
            result += f * self.light_weight(&ls, wl) * (wo.z.abs() * w / ne as f32);
        }

        // BSDF sampling
        for _ in 0..nb {
            let u1 = rng.next_1d();
            let u2 = rng.next_2d();
            let Some(bs) = bsdf.sample(&ctx, &sp, wi, u1, u2) else {
                continue;
            };
            if bs.pdf <= 0.0 && !bs.lobe.is_delta() {
                continue;
            }
            let d = si.sh_frame.to_world(bs.wo).normalize();
            let r = Ray {
                o: offset_ray_origin(si.p, si.n_geo, d),
                d,
                t_max: f32::INFINITY,
            };
            counters.rays += 1;
            let delta = bs.lobe.is_delta();
            let bsdf_pdf = if delta {
                None
            } else {
                Some(bs.pdf * frac_bsdf)
            };
            let le = match self.intersect(&r) {
                None => self.infinite_radiance(d, bsdf_pdf, frac_lum, wl),
                Some(h2) => {
                    let s2 = h2.shape as usize;
                    let si2 = self.geometry[s2].surface(&r, &h2);
                    let wi2 = si2.sh_frame.to_local(-d);
                    match self.area_emission(s2, &si2, wi2, wl) {
                        None => Rgb::ZERO,
                        Some(le) => {
                            let w = match bsdf_pdf {
                                None => 1.0,
                                Some(p) => mis(
                                    p,
                                    self.area_light_pdf(h2.shape, si.p, si2.p, si2.n_geo)
                                        * frac_lum,
                                ),
                            };
                            le * w
                        }
                    }
                }
            };
            if !le.is_black() {
                result += bs.weight * le * (1.0 / nb as f32);
            }
        }
        result
    }
}
