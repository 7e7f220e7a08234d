//! `thindielectric`: a thin slab of dielectric (a window pane, a soap film without
//! interference). Light is either mirror-reflected or passes straight through; the
//! reflectance sums all internal bounces, R' = R + T²R/(1−R²) = 2R/(1+R)
//! (Mitsuba 3 `thindielectric`). Two-sided.
//!
//! Parameters as `dielectric` (`int_ior` default `bk7`, `ext_ior`, `specular_reflectance`,
//! `specular_transmittance`, Specula's `fresnel` and dispersion parameters).
//!
//! **Dispersion.** Both directions are the same for every wavelength (the slab does not
//! deviate light), so only the reflectance R'_j differs per channel in spectral mode:
//! reflection is sampled with probability R̄ = mean_j R'_j and weighted R'_j/R̄, transmission
//! with 1 − R̄ and weighted (1 − R'_j)/(1 − R̄). In RGB mode the index at the d line is used.
use crate::bsdf::*;
use crate::frame::reflect_z;
use crate::fresnel::FresnelMode;
use crate::spectral::dispersion::{channel_etas, Dispersion};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct ThinDielectric {
    /// Relative index η_int / η_ext (at the d line when dispersive).
    pub eta: f32,
    /// The wavelength-dependent relative index, when the interior is dispersive.
    pub dispersion: Option<Dispersion>,
    pub specular_reflectance: SpectrumParam,
    pub specular_transmittance: SpectrumParam,
    pub fresnel: FresnelMode,
}

impl ThinDielectric {
    pub fn new(eta: f32) -> Self {
        ThinDielectric {
            eta,
            dispersion: None,
            specular_reflectance: 1.0.into(),
            specular_transmittance: 1.0.into(),
            fresnel: FresnelMode::Exact,
        }
    }
    /// Total reflectance of the slab for a cosine of incidence.
    pub fn reflectance(&self, cos_theta_i: f32) -> f32 {
        self.reflectance_eta(cos_theta_i, self.eta)
    }
    /// Total reflectance of the slab for a relative index `eta`.
    #[inline]
    pub fn reflectance_eta(&self, cos_theta_i: f32, eta: f32) -> f32 {
        let r = self.fresnel.eval(cos_theta_i.abs(), eta).r;
        if r < 1.0 {
            2.0 * r / (1.0 + r)
        } else {
            r
        }
    }
}

impl BsdfModel for ThinDielectric {
    fn flags(&self) -> LobeFlags {
        LobeFlags::DELTA_REFLECTION | LobeFlags::DELTA_TRANSMISSION
    }
    fn sample_reads_u2(&self) -> bool {
        false
    }
    fn eval(&self, _: &BsdfContext, _: &ShadingPoint, _: Vec3, _: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        if let Some(etas) = channel_etas(&self.dispersion, sp.wavelengths) {
            let rj = Spectrum::from(etas.map(|e| self.reflectance_eta(wi.z, e)));
            let r = rj.mean();
            return Some(if u1 < r {
                BsdfSample {
                    wo: reflect_z(wi),
                    weight: self.specular_reflectance.eval(sp) * (rj / r),
                    pdf: r,
                    lobe: LobeFlags::DELTA_REFLECTION,
                    eta: 1.0,
                }
            } else {
                BsdfSample {
                    wo: -wi,
                    weight: self.specular_transmittance.eval(sp)
                        * ((Spectrum::splat(1.0) - rj) / (1.0 - r)),
                    pdf: 1.0 - r,
                    lobe: LobeFlags::DELTA_TRANSMISSION,
                    eta: 1.0,
                }
            });
        }
        let r = self.reflectance(wi.z);
        if u1 < r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                weight: self.specular_reflectance.eval(sp),
                pdf: r,
                lobe: LobeFlags::DELTA_REFLECTION,
                eta: 1.0,
            })
        } else {
            Some(BsdfSample {
                wo: -wi,
                weight: self.specular_transmittance.eval(sp),
                pdf: 1.0 - r,
                lobe: LobeFlags::DELTA_TRANSMISSION,
                eta: 1.0,
            })
        }
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // per-channel sums read best indexed
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::spectral::dispersion::glass;
    use crate::spectrum::Wavelengths;

    /// Per channel the expected reflected weight is R'_j and the transmitted 1 − R'_j.
    #[test]
    fn spectral_sampling_is_unbiased_per_channel() {
        let ior = glass("sf11").unwrap().ior;
        let t = ThinDielectric {
            dispersion: Some(Dispersion { int: ior, ext: 1.0 }),
            ..ThinDielectric::new(ior.n_d())
        };
        let w = [400.0f32, 530.0, 700.0];
        let sp = ShadingPoint {
            wavelengths: Some(Wavelengths(w)),
            ..Default::default()
        };
        let wi = Vec3::new(0.8, 0.0, 0.6);
        let mut rng = Pcg32::new(3, 1);
        let n = 200_000;
        let (mut refl, mut trans) = ([0.0f64; 3], [0.0f64; 3]);
        for _ in 0..n {
            let s = t
                .sample(&BsdfContext::RADIANCE, &sp, wi, rng.next_f32(), Vec2::ZERO)
                .unwrap();
            let acc = if s.wo.z > 0.0 { &mut refl } else { &mut trans };
            for c in 0..3 {
                acc[c] += s.weight[c] as f64 / n as f64;
            }
        }
        let r_mean = (0..3)
            .map(|j| t.reflectance_eta(wi.z, ior.at(w[j])))
            .sum::<f32>()
            / 3.0;
        for j in 0..3 {
            let r = t.reflectance_eta(wi.z, ior.at(w[j])) as f64;
            // binomial noise of the lobe choice
            let tol =
                5.0 * (r_mean as f64 * (1.0 - r_mean as f64) / n as f64).sqrt() / r_mean as f64;
            assert!((refl[j] - r).abs() < tol * r, "{j}: {} vs {r}", refl[j]);
            assert!((trans[j] - (1.0 - r)).abs() < tol * r, "{j}: {}", trans[j]);
        }
        assert!(t.reflectance_eta(wi.z, ior.at(400.0)) > t.reflectance_eta(wi.z, ior.at(700.0)));
    }
}
