//! `dielectric`: a smooth interface between two dielectrics (glass, water, diamond), with
//! Snell's law, exact Fresnel (or Schlick's approximation) and total internal reflection
//! (Mitsuba 3 `dielectric`). Light may arrive from either side; `eta` = η_int / η_ext.
//!
//! Parameters (Mitsuba's): `int_ior` (default `bk7`), `ext_ior` (default `air`),
//! `specular_reflectance`, `specular_transmittance` (default 1), and Specula's `fresnel`
//! (`exact`/`schlick`). Specula's dispersion parameters (`dispersion`, `abbe_number`,
//! `cauchy_*`, `sellmeier_*`, see [`crate::build`]) make the interior index depend on the
//! wavelength ([`Dispersion`]).
//!
//! **Dispersion.** In RGB mode a dispersive interface refracts with its index at the d line
//! (587.56 nm). In spectral mode (`sp.wavelengths` given) each channel j has its own relative
//! index η_j, reflectance R_j and refracted direction t_j. Reflection is shared by every
//! channel; a refracted direction only by the channels with the same index. Sampling picks
//! reflection with probability R̄ = mean_j R_j (weight R_j/R̄ per channel), otherwise the
//! refraction of channel h with probability (1 − R_h)/3, i.e. a uniformly chosen channel h
//! refracting with its own Fresnel term: the discrete probability of producing t_h is then
//! p = Σ_{j: η_j = η_h} (1 − R_j)/3, and the weights are (1 − R_j)·(η-scaling)/p for those
//! channels and 0 for the others (a Dirac direction that only one wavelength can take). Every
//! channel's estimate stays unbiased; with three equal indices this is the plain model.
use crate::bsdf::*;
use crate::frame::{reflect_z, refract};
use crate::fresnel::FresnelMode;
use crate::spectral::dispersion::{channel_etas, Dispersion};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Dielectric {
    /// Relative index of refraction η_int / η_ext (at the d line when dispersive).
    pub eta: f32,
    /// The wavelength-dependent relative index, when the interior is dispersive.
    pub dispersion: Option<Dispersion>,
    pub specular_reflectance: SpectrumParam,
    pub specular_transmittance: SpectrumParam,
    pub fresnel: FresnelMode,
}

impl Dielectric {
    pub fn new(eta: f32) -> Self {
        Dielectric {
            eta,
            dispersion: None,
            specular_reflectance: 1.0.into(),
            specular_transmittance: 1.0.into(),
            fresnel: FresnelMode::Exact,
        }
    }
}

impl BsdfModel for Dielectric {
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
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        if let Some(etas) = channel_etas(&self.dispersion, sp.wavelengths) {
            return self.sample_dispersive(ctx, sp, wi, u1, etas);
        }
        let f = self.fresnel.eval(wi.z, self.eta);
        if u1 < f.r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                weight: self.specular_reflectance.eval(sp),
                pdf: f.r,
                lobe: LobeFlags::DELTA_REFLECTION,
                eta: 1.0,
            })
        } else {
            let scale = match ctx.mode {
                TransportMode::Radiance => f.eta_ti * f.eta_ti,
                TransportMode::Importance => 1.0,
            };
            Some(BsdfSample {
                wo: refract(wi, Vec3::Z, f.cos_theta_t, f.eta_ti),
                weight: self.specular_transmittance.eval(sp) * scale,
                pdf: 1.0 - f.r,
                lobe: LobeFlags::DELTA_TRANSMISSION,
                eta: f.eta_it,
            })
        }
    }
}

impl Dielectric {
    /// `sample` with a relative index per channel (see the module documentation).
    fn sample_dispersive(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        etas: [f32; 3],
    ) -> Option<BsdfSample> {
        let f = etas.map(|e| self.fresnel.eval(wi.z, e));
        let r = Spectrum::new(f[0].r, f[1].r, f[2].r);
        let r_mean = (f[0].r + f[1].r + f[2].r) / 3.0;
        if u1 < r_mean {
            return Some(BsdfSample {
                wo: reflect_z(wi),
                weight: self.specular_reflectance.eval(sp) * (r / r_mean),
                pdf: r_mean,
                lobe: LobeFlags::DELTA_REFLECTION,
                eta: 1.0,
            });
        }
        // the channel whose refraction is taken, with probability (1 − R_h)/3 overall
        let t = [1.0 - f[0].r, 1.0 - f[1].r, 1.0 - f[2].r];
        let target = (u1 - r_mean) * 3.0;
        let h = if target < t[0] || (t[1] == 0.0 && t[2] == 0.0) {
            0
        } else if target < t[0] + t[1] || t[2] == 0.0 {
            1
        } else {
            2
        };
        if t[h] <= 0.0 {
            return None;
        }
        let fh = f[h];
        let mut weight = Spectrum::ZERO;
        let mut p = 0.0;
        for j in 0..3 {
            if etas[j] == etas[h] {
                p += t[j] / 3.0;
                weight.0[j] = match ctx.mode {
                    TransportMode::Radiance => t[j] * f[j].eta_ti * f[j].eta_ti,
                    TransportMode::Importance => t[j],
                };
            }
        }
        Some(BsdfSample {
            wo: refract(wi, Vec3::Z, fh.cos_theta_t, fh.eta_ti),
            weight: self.specular_transmittance.eval(sp) * weight / p,
            pdf: p,
            lobe: LobeFlags::DELTA_TRANSMISSION,
            eta: fh.eta_it,
        })
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // per-channel sums read best indexed
mod tests {
    use super::*;
    use crate::rng::Pcg32;
    use crate::spectral::dispersion::{glass, Ior};
    use crate::spectrum::Wavelengths;

    fn bk7() -> Dielectric {
        Dielectric {
            dispersion: Some(Dispersion {
                int: glass("bk7").unwrap().ior,
                ext: 1.0,
            }),
            ..Dielectric::new(glass("bk7").unwrap().ior.n_d())
        }
    }

    fn at(w: [f32; 3]) -> ShadingPoint<'static> {
        ShadingPoint {
            wavelengths: Some(Wavelengths(w)),
            ..Default::default()
        }
    }

    #[test]
    fn one_wavelength_is_the_plain_model_at_that_index() {
        let d = bk7();
        let wi = Vec3::new(0.6, 0.0, 0.8);
        for l in [450.0f32, 550.0, 650.0] {
            let plain = Dielectric::new(glass("bk7").unwrap().ior.at(l));
            for u in [0.01f32, 0.03, 0.2, 0.7, 0.99] {
                for ctx in [BsdfContext::RADIANCE, BsdfContext::IMPORTANCE] {
                    let a = d.sample(&ctx, &at([l; 3]), wi, u, Vec2::ZERO).unwrap();
                    let b = plain
                        .sample(&ctx, &ShadingPoint::default(), wi, u, Vec2::ZERO)
                        .unwrap();
                    assert!((a.wo - b.wo).length() < 1e-6 && a.lobe == b.lobe);
                    assert!((a.pdf - b.pdf).abs() < 1e-6 && (a.eta - b.eta).abs() < 1e-6);
                    assert!(
                        (a.weight - b.weight).map(f32::abs).max_component() < 1e-5,
                        "{a:?} {b:?}"
                    );
                }
            }
        }
        // RGB mode: the index at the d line
        let s = d
            .sample(
                &BsdfContext::RADIANCE,
                &ShadingPoint::default(),
                wi,
                0.9,
                Vec2::ZERO,
            )
            .unwrap();
        assert!((s.eta - 1.5168).abs() < 1e-4);
    }

    /// Per channel, the expected weight of the reflection is R_j and that of the refraction
    /// towards t_j is (1 − R_j)/η_j² (radiance), from either side; the other channels'
    /// refractions carry nothing.
    #[test]
    fn spectral_sampling_is_unbiased_per_channel() {
        let d = bk7();
        let w = [420.0f32, 540.0, 680.0];
        let sp = at(w);
        let n = 300_000;
        for wi in [
            Vec3::new(0.6, 0.0, 0.8),
            Vec3::new(0.3, 0.0, -(1.0f32 - 0.09).sqrt()),
        ] {
            let mut rng = Pcg32::new(7, 1);
            let (mut refl, mut trans) = ([0.0f64; 3], [[0.0f64; 3]; 3]);
            let dirs: Vec<Vec3> = (0..3)
                .map(|j| {
                    let e = glass("bk7").unwrap().ior.at(w[j]);
                    Dielectric::new(e)
                        .sample(
                            &BsdfContext::RADIANCE,
                            &ShadingPoint::default(),
                            wi,
                            0.999,
                            Vec2::ZERO,
                        )
                        .unwrap()
                        .wo
                })
                .collect();
            for _ in 0..n {
                let s = d
                    .sample(&BsdfContext::RADIANCE, &sp, wi, rng.next_f32(), Vec2::ZERO)
                    .unwrap();
                if s.lobe == LobeFlags::DELTA_REFLECTION {
                    for c in 0..3 {
                        refl[c] += s.weight[c] as f64;
                    }
                } else {
                    let k = dirs
                        .iter()
                        .position(|t| (*t - s.wo).length() < 1e-6)
                        .unwrap();
                    for c in 0..3 {
                        trans[k][c] += s.weight[c] as f64;
                    }
                }
            }
            let fs: Vec<_> = (0..3)
                .map(|j| {
                    let e = glass("bk7").unwrap().ior.at(w[j]);
                    crate::fresnel::fresnel_dielectric(wi.z, e)
                })
                .collect();
            let r_mean = fs.iter().map(|f| f.r as f64).sum::<f64>() / 3.0;
            for j in 0..3 {
                let f = fs[j];
                let r = refl[j] / n as f64;
                // binomial noise of the reflect/refract choice, 5σ
                let tol = 5.0 * (r_mean * (1.0 - r_mean) / n as f64).sqrt() / r_mean;
                assert!(
                    (r - f.r as f64).abs() < tol * f.r as f64,
                    "R {j}: {r} vs {}",
                    f.r
                );
                let expect = (f.t * f.eta_ti * f.eta_ti) as f64;
                for k in 0..3 {
                    let got = trans[k][j] / n as f64;
                    if k == j {
                        // binomial noise of the channel choice: σ ≈ √(2/n)·expect
                        assert!((got - expect).abs() < 6.0 * (2.2 / n as f64).sqrt() * expect);
                    } else {
                        assert_eq!(got, 0.0);
                    }
                }
            }
        }
    }

    #[test]
    fn constant_ior_in_spectral_mode_is_unchanged() {
        let d = Dielectric::new(1.5);
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let a = d.sample(
            &BsdfContext::RADIANCE,
            &at([400.0, 500.0, 600.0]),
            wi,
            0.5,
            Vec2::ZERO,
        );
        let b = d.sample(
            &BsdfContext::RADIANCE,
            &ShadingPoint::default(),
            wi,
            0.5,
            Vec2::ZERO,
        );
        assert_eq!(a, b);
        let c = Dielectric {
            dispersion: Some(Dispersion {
                int: Ior::Constant(1.5),
                ext: 1.0,
            }),
            ..d
        };
        let s = c
            .sample(
                &BsdfContext::RADIANCE,
                &at([400.0, 500.0, 600.0]),
                wi,
                0.5,
                Vec2::ZERO,
            )
            .unwrap();
        let b = b.unwrap();
        assert_eq!((s.wo, s.lobe), (b.wo, b.lobe));
        assert!((s.weight - b.weight).map(f32::abs).max_component() < 1e-6);
    }
}
