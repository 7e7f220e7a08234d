//! Mitsuba's `aov` integrator (see the module documentation of [`crate::integrator`]).

use super::*;

impl Scene {
    /// Mitsuba's `aov` integrator.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn li_aov<S: Sampler>(
        &self,
        a: &AovSettings,
        ray: Ray,
        differentials: Option<&RayDifferentials>,
        hit: Option<Hit>,
        rng: &mut S,
        counters: &mut Counters,
        out: &mut [f32],
        spectral: Option<(&Wavelengths, &[f32; 3])>,
    ) -> Rgb {
        let mut k = 0;
        let mut image = Rgb::ZERO;
        for (i, (_, inner)) in a.integrators.iter().enumerate() {
            // in spectral mode, at the sample's wavelengths and developed
            let l = match spectral {
                None => self.sample(inner, ray, hit, rng, counters, &mut []),
                Some(w) => {
                    self.sample_at_wavelengths(inner, ray, None, hit, rng, counters, w, &mut [])
                }
            };
            let hide = match inner {
                Integrator::Path(p) => p.hide_emitters,
                Integrator::Direct(d) => d.hide_emitters,
                _ => true,
            };
            let valid = hit.is_some() || (!hide && !self.infinite_lights.is_empty());
            if i == 0 {
                image = l;
            }
            if out.len() >= k + 4 {
                out[k..k + 3].copy_from_slice(&l.0);
                out[k + 3] = valid as u32 as f32;
            }
            k += 4;
        }
        if a.integrators.is_empty() {
            counters.rays += 1;
        }
        let si = hit.map(|h| (h, self.geometry[h.shape as usize].surface(&ray, &h)));
        // ∂uv/∂x and ∂uv/∂y, computed once for both AOVs
        let mut uv_partials = None;
        let mut partials = |s: &SurfaceGeometry| {
            *uv_partials.get_or_insert_with(|| {
                differentials.map_or((Vec2::ZERO, Vec2::ZERO), |d| d.uv_partials(s))
            })
        };
        for (_, t) in &a.aovs {
            let v: [f32; 3] = match (&si, t) {
                (None, _) => [0.0; 3],
                (Some((h, s)), AovType::Albedo) => {
                    let shape = h.shape as usize;
                    let bsdf = &self.bsdfs[self.shape_bsdf[shape] as usize];
                    let mut sp = s.shading_point(
                        h,
                        self.geometry[shape].surface_data(),
                        bsdf.reads_local_geometry(),
                    );
                    // spectral mode: the reflectance at the wavelengths, developed (Mitsuba)
                    sp.wavelengths = spectral.map(|(w, _)| *w);
                    let r = bsdf.diffuse_reflectance(&sp, s.sh_frame.to_local(-ray.d));
                    match spectral {
                        None => r.0,
                        Some((w, weight)) => specula_bsdf::spectral::cie::develop(r, w, weight).0,
                    }
                }
                (Some((_, s)), AovType::DpDu) => s.dp_du.to_array(),
                (Some((_, s)), AovType::DpDv) => s.dp_dv.to_array(),
                (Some((_, s)), AovType::DuvDx) => {
                    let d = partials(s).0;
                    [d.x, d.y, 0.0]
                }
                (Some((_, s)), AovType::DuvDy) => {
                    let d = partials(s).1;
                    [d.x, d.y, 0.0]
                }
                (Some((h, _)), AovType::Depth) => [h.t, 0.0, 0.0],
                (Some((_, s)), AovType::Position) => s.p.to_array(),
                (Some((_, s)), AovType::Uv) => [s.uv.x, s.uv.y, 0.0],
                (Some((_, s)), AovType::GeoNormal) => s.n_geo.to_array(),
                (Some((_, s)), AovType::ShNormal) => s.sh_frame.n.to_array(),
                (Some((h, _)), AovType::PrimIndex) => [h.prim as f32, 0.0, 0.0],
                (Some((h, _)), AovType::ShapeIndex) => [(h.shape + 1) as f32, 0.0, 0.0],
            };
            let n = t.suffixes().len();
            if out.len() >= k + n {
                out[k..k + n].copy_from_slice(&v[..n]);
            }
            k += n;
        }
        image
    }
}
