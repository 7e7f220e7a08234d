//! `velvet` (a Specula extension; Mitsuba has no such plugin): the velvet of Ashikhmin &
//! Premože, "Distribution-based BRDFs" (University of Utah technical report, 2007), a
//! microfacet ("flake") model whose facets are the sides of fibres standing up from the
//! cloth. Their normals follow the paper's inverted-Gaussian distribution,
//!   D(h) = N (1 + A exp(−cot²θh / σ²) / sin⁴θh),   N = 1 / (π (1 + A σ²)),
//! normalised so that ∫ D(h) cosθh dωh = 1 (the Gaussian term integrates to π σ²), and
//! the BRDF replaces the Smith shadowing and the 1/(cosθi cosθo) of Cook–Torrance by the
//! paper's smooth, reciprocal denominator:
//!   f(ωi, ωo) = reflectance · D(h) / (4 (cosθi + cosθo − cosθi cosθo)).
//! The fibres' grazing facets (the Gaussian term, width σ, weight A) give velvet its bright
//! rim and dark centre; the constant term is a diffuse-like floor. Combine it with a
//! `diffuse` base in a `blendbsdf` for the dyed pile underneath.
//!
//! **Parameters:** `reflectance` (colour or texture, default 1): the fibres' colour;
//! `sigma` (float or texture, default 0.35, clamped to [0.01, 4]): the spread σ of the
//! fibre directions about the normal (small: upright pile, a sharp grazing rim);
//! `amplitude` (float, default 4, ≥ 0): A, the weight of the fibres against the floor.
//!
//! **Energy:** reciprocal by construction; not energy-normalised. The denominator is at
//! least max(cosθi, cosθo), which bounds the albedo at normal incidence by 1; with the
//! default A = 4 the white-furnace albedo stays below 0.6 for σ from 0.05 to 2, but a
//! heavy pile (large A) can reflect more than it receives at grazing incidence (A = 20,
//! σ = 0.2: 1.22 at θi = 89°), which the property suite's `energy` check reports.
//!
//! **Sampling:** half of the samples are cosine-weighted, half reflect ωi about a normal
//! drawn exactly from D(h) cosθh (the floor by cosine sampling, the fibre term by inverting
//! cot²θh ~ Exponential(σ²)); `pdf` is the mixture's density.

use crate::bsdf::*;
use crate::frame::reflect;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Debug)]
pub struct Velvet {
    pub reflectance: SpectrumParam,
    pub sigma: FloatParam,
    pub amplitude: f32,
}

/// The probability of drawing a cosine-weighted sample (the rest sample D).
const COSINE_FRACTION: f32 = 0.5;

/// D(h) for spread σ and amplitude A.
#[inline]
pub fn velvet_d(cos_h: f32, sigma: f32, amplitude: f32) -> f32 {
    if cos_h <= 0.0 {
        return 0.0;
    }
    let s2 = sigma * sigma;
    let norm = FRAC_1_PI / (1.0 + amplitude * s2);
    let sin2 = (1.0 - cos_h * cos_h).max(0.0);
    let fibres = if sin2 < 1e-7 {
        0.0
    } else {
        let cot2 = cos_h * cos_h / sin2;
        amplitude * (-cot2 / s2).exp() / (sin2 * sin2)
    };
    norm * (1.0 + fibres)
}

impl Velvet {
    #[inline]
    fn sigma(&self, sp: &ShadingPoint) -> f32 {
        self.sigma.eval(sp).clamp(0.01, 4.0)
    }

    /// Density of the mixture sampler for `wo`.
    #[inline]
    fn mixture_pdf(&self, sigma: f32, wi: Vec3, wo: Vec3) -> f32 {
        if wo.z <= 0.0 {
            return 0.0;
        }
        let cosine = wo.z * FRAC_1_PI;
        let h = (wi + wo).normalize();
        let wih = wi.dot(h);
        let microfacet = if wih > 0.0 {
            velvet_d(h.z, sigma, self.amplitude) * h.z / (4.0 * wih)
        } else {
            0.0
        };
        COSINE_FRACTION * cosine + (1.0 - COSINE_FRACTION) * microfacet
    }

    /// A normal drawn with density D(h) cosθh; `u1` ∈ [0, 1) picks the term.
    #[inline]
    fn sample_normal(&self, sigma: f32, u1: f32, u2: Vec2) -> Vec3 {
        let s2 = sigma * sigma;
        let p_floor = 1.0 / (1.0 + self.amplitude * s2);
        if u1 < p_floor {
            return warp::square_to_cosine_hemisphere(u2);
        }
        // cot²θ is exponential with mean σ²
        let t = sigma * (-(1.0 - u2.x).max(1e-30).ln()).sqrt();
        let inv = 1.0 / (1.0 + t * t).sqrt();
        let (cos_t, sin_t) = (t * inv, inv);
        let (s, c) = crate::math::sincos_2pi(u2.y);
        Vec3::new(sin_t * c, sin_t * s, cos_t)
    }
}

impl BsdfModel for Velvet {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let h = (wi + wo).normalize();
        let d = velvet_d(h.z, self.sigma(sp), self.amplitude);
        let denom = 4.0 * (wi.z + wo.z - wi.z * wo.z);
        self.reflectance.eval(sp) * (d / denom)
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        self.mixture_pdf(self.sigma(sp), wi, wo)
    }

    #[inline]
    fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        (self.eval(ctx, sp, wi, wo), self.pdf(ctx, sp, wi, wo))
    }

    #[inline]
    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let sigma = self.sigma(sp);
        let wo = if u1 < COSINE_FRACTION {
            warp::square_to_cosine_hemisphere(u2)
        } else {
            let u = (u1 - COSINE_FRACTION) / (1.0 - COSINE_FRACTION);
            let h = self.sample_normal(sigma, u, u2);
            if wi.dot(h) <= 0.0 {
                return None;
            }
            reflect(wi, h)
        };
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.mixture_pdf(sigma, wi, wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let weight = self.eval(ctx, sp, wi, wo) * (wo.z / pdf);
        Some(BsdfSample {
            wo,
            weight,
            pdf,
            lobe: LobeFlags::GLOSSY_REFLECTION,
            eta: 1.0,
        })
    }
}

impl Velvet {
    /// Builds the plugin from its parameters.
    pub fn build(p: &crate::props::Props) -> Result<Self, crate::props::BuildError> {
        let v = Velvet {
            reflectance: p.spectrum("reflectance", 1.0)?,
            sigma: p.float_param("sigma", 0.35)?,
            amplitude: p.float("amplitude", 4.0)?,
        };
        if let FloatParam::Const(s) = v.sigma {
            if s.is_nan() || s <= 0.0 {
                return Err(crate::props::BuildError::new(
                    p.loc.clone(),
                    format!("'velvet': 'sigma' must be positive, got {s}"),
                ));
            }
        }
        if v.amplitude < 0.0 {
            return Err(crate::props::BuildError::new(
                p.loc.clone(),
                format!(
                    "'velvet': 'amplitude' must not be negative, got {}",
                    v.amplitude
                ),
            ));
        }
        Ok(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::{run_suite, SuiteConfig, Verdict};
    use crate::parse_spec;

    /// ∫ D(h) cosθh dωh = 1 for every σ and A (midpoint rule in θ, D is isotropic).
    #[test]
    fn distribution_is_normalised() {
        for (sigma, a) in [
            (0.05f32, 4.0f32),
            (0.2, 4.0),
            (0.5, 1.0),
            (1.5, 10.0),
            (0.3, 0.0),
        ] {
            let n = 200_000;
            let dt = std::f64::consts::FRAC_PI_2 / n as f64;
            let mut s = 0.0f64;
            for i in 0..n {
                let t = (i as f64 + 0.5) * dt;
                let d = velvet_d(t.cos() as f32, sigma, a) as f64;
                s += d * t.cos() * t.sin() * dt * 2.0 * std::f64::consts::PI;
            }
            assert!((s - 1.0).abs() < 2e-3, "σ = {sigma}, A = {a}: {s}");
        }
    }

    #[test]
    fn property_suite_passes() {
        for spec in [
            "velvet",
            "velvet reflectance=0.8,0.2,0.3 sigma=0.1",
            "velvet sigma=1 amplitude=1",
        ] {
            let b = parse_spec(spec).unwrap();
            let cfg = SuiteConfig {
                samples: 60_000,
                threads: 1,
                ..Default::default()
            };
            let r = run_suite(&b, &cfg, &|_, _| {});
            for o in &r.outcomes {
                assert_eq!(
                    o.verdict,
                    Verdict::Pass,
                    "{spec}: {}: {}",
                    o.name,
                    o.summary
                );
            }
        }
    }

    /// The fibres light the rim: at grazing view the lobe outshines normal view.
    #[test]
    fn grazing_rim() {
        let b = parse_spec("velvet sigma=0.3").unwrap();
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        let dir = |deg: f32| {
            let (s, c) = deg.to_radians().sin_cos();
            Vec3::new(s, 0.0, c)
        };
        let normal = b.eval(&ctx, &sp, dir(0.0), dir(0.0)).r();
        let grazing = b.eval(&ctx, &sp, dir(80.0), dir(80.0)).r();
        assert!(grazing > 3.0 * normal, "{grazing} vs {normal}");
    }

    #[test]
    fn parameter_errors() {
        let e = parse_spec("velvet sigma=0").unwrap_err().to_string();
        assert!(e.contains("'sigma' must be positive"), "{e}");
        let e = parse_spec("velvet amplitude=-1").unwrap_err().to_string();
        assert!(e.contains("'amplitude' must not be negative"), "{e}");
        let e = parse_spec("velvet roughness=0.3").unwrap_err().to_string();
        assert!(e.contains("unknown parameter 'roughness'"), "{e}");
    }
}
