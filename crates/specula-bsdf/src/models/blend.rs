//! `blendbsdf`: a linear blend (1 − w)·f₀ + w·f₁ of two BSDFs (Mitsuba 3 `blendbsdf`), with
//! a constant or textured weight w ∈ [0, 1].
//!
//! Sampling picks a component with probability (1 − w, w). For non-Dirac lobes it reports the
//! blend's density (1 − w)p₀ + w·p₁ and weight f·|cosθo|/p, so that `sample`, `pdf` and `eval`
//! agree (as Mitsuba 3.9 does). A Dirac lobe of one component is reported with its discrete
//! probability times the selection probability; the blend factor and the selection
//! probability cancel in its weight.
//!
//! `dirac_mixing` (a Specula extension, a string): `exact` (the default, as above) or
//! `mitsuba`, which reproduces how Mitsuba 3.9's `blendbsdf` weights a sample of a Dirac lobe.
//! Mitsuba 3.9 computes every sample's weight as the blend's value over the blend's density at
//! the sampled direction, and for a Dirac lobe it mixes the lobe's discrete probability P and
//! value V (its sample weight × P) with the other component's continuous density p and value
//! f·|cos θo| as if they were of one measure:
//! weight = (q·V + (1 − q)·f·|cos θo|) / (q·P + (1 − q)·p), with q the lobe's blend factor.
//! Its expectation is not the blend's: where p ≈ P (a rough lobe beside a mirror) the Dirac
//! lobe's share comes out ≈ q² instead of q, an energy loss (measured with
//! `scripts/probe_blendbsdf_dirac.py`). `specula render --mitsuba-compat` sets it on every
//! `blendbsdf`, so that scenes that blend a Dirac lobe match Mitsuba 3.9's images.

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

use super::Bsdf;

#[derive(Clone, Debug)]
pub struct Blend {
    /// Weight of the second BSDF.
    pub weight: FloatParam,
    pub bsdfs: [Bsdf; 2],
    /// Weight Dirac-lobe samples as Mitsuba 3.9 does (`dirac_mixing="mitsuba"`), not by the
    /// blend's definition.
    pub mitsuba_dirac_mixing: bool,
}

impl Blend {
    #[inline]
    fn w(&self, sp: &ShadingPoint) -> f32 {
        self.weight.eval(sp).clamp(0.0, 1.0)
    }
}

impl BsdfModel for Blend {
    fn flags(&self) -> LobeFlags {
        self.bsdfs[0].flags() | self.bsdfs[1].flags()
    }
    #[inline]
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        let w = self.w(sp);
        self.bsdfs[0].eval(ctx, sp, wi, wo) * (1.0 - w) + self.bsdfs[1].eval(ctx, sp, wi, wo) * w
    }
    #[inline]
    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        let w = self.w(sp);
        self.bsdfs[0].pdf(ctx, sp, wi, wo) * (1.0 - w) + self.bsdfs[1].pdf(ctx, sp, wi, wo) * w
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
        let w = self.w(sp);
        // choose a component and reuse u1 for it
        let (idx, prob, u1r) = if u1 < w {
            (1usize, w, u1 / w)
        } else {
            (0usize, 1.0 - w, (u1 - w) / (1.0 - w))
        };
        let mut s = self.bsdfs[idx].sample(ctx, sp, wi, u1r.min(0.999_999_94), u2)?;
        if s.lobe.is_delta() {
            if self.mitsuba_dirac_mixing {
                // Mitsuba 3.9: the blend's value over the blend's density, with the Dirac
                // lobe's discrete probability and value mixed into the other's continuous ones
                let other = &self.bsdfs[1 - idx];
                let value = s.weight * s.pdf;
                let num =
                    value * prob + other.eval(ctx, sp, wi, s.wo) * (s.wo.z.abs() * (1.0 - prob));
                let den = s.pdf * prob + other.pdf(ctx, sp, wi, s.wo) * (1.0 - prob);
                if den.is_nan() || den <= 0.0 || den.is_infinite() {
                    return None;
                }
                s.weight = num * (1.0 / den);
                s.pdf = den;
                return Some(s);
            }
            // a Dirac lobe of one component: probability of choosing it, blend factor cancels
            s.pdf *= prob;
            return Some(s);
        }
        let pdf = self.pdf(ctx, sp, wi, s.wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        s.weight = self.eval(ctx, sp, wi, s.wo) * (s.wo.z.abs() / pdf);
        s.pdf = pdf;
        Some(s)
    }
}

#[cfg(test)]
mod tests {
    use crate::bsdf::{BsdfContext, BsdfModel, ShadingPoint};
    use crate::spec::parse_spec;
    use glam::{Vec2, Vec3};

    /// A rough plastic (black base) blended with a smooth conductor, as probed in Mitsuba 3.9
    /// by `scripts/probe_blendbsdf_dirac.py` (θi = 0.5 rad, sample2 = (0.3, 0.7)).
    fn blend(w: f32, mixing: &str) -> super::super::Bsdf {
        parse_spec(&format!(
            "blendbsdf weight={w} dirac_mixing={mixing} \
             {{ roughplastic distribution=ggx alpha=0.3 diffuse_reflectance=0,0,0 }} \
             {{ conductor eta=0.2,0.9,1.1 k=3.5,2.3,1.9 }}"
        ))
        .unwrap()
    }

    #[test]
    fn mitsuba_dirac_mixing_reproduces_mitsuba_39_sample_weights() {
        let wi = Vec3::new(0.5f32.sin(), 0.0, 0.5f32.cos());
        let (ctx, sp) = (BsdfContext::default(), ShadingPoint::default());
        // (weight, u1) → Mitsuba 3.9's sample weight of the conductor's Dirac lobe
        let cases = [
            (0.25, 0.1, [0.264_885_7, 0.178_526_7, 0.142_788_1]),
            (0.5, 0.1, [0.490_236_4, 0.317_481_4, 0.245_988_9]),
            (0.8, 0.6, [0.760_784_8, 0.484_305_6, 0.369_888_2]),
        ];
        for (w, u1, want) in cases {
            let b = blend(w, "mitsuba");
            let s = b.sample(&ctx, &sp, wi, u1, Vec2::new(0.3, 0.7)).unwrap();
            assert!(s.lobe.is_delta());
            for (c, want) in want.iter().enumerate() {
                assert!(
                    (s.weight[c] - want).abs() < 2e-4,
                    "w={w}: channel {c}: {} vs Mitsuba {want}",
                    s.weight[c],
                );
            }
            // the exact blend weights the Dirac sample by the conductor's Fresnel alone
            let e = blend(w, "exact")
                .sample(&ctx, &sp, wi, u1, Vec2::new(0.3, 0.7))
                .unwrap();
            assert!((e.weight[0] - 0.941_227_7).abs() < 2e-4, "{:?}", e.weight);
        }
    }

    #[test]
    fn dirac_mixing_only_changes_dirac_samples() {
        let wi = Vec3::new(0.5f32.sin(), 0.0, 0.5f32.cos());
        let (ctx, sp) = (BsdfContext::default(), ShadingPoint::default());
        let (a, b) = (blend(0.5, "exact"), blend(0.5, "mitsuba"));
        let sa = a.sample(&ctx, &sp, wi, 0.9, Vec2::new(0.3, 0.7)).unwrap();
        let sb = b.sample(&ctx, &sp, wi, 0.9, Vec2::new(0.3, 0.7)).unwrap();
        assert!(!sa.lobe.is_delta());
        assert_eq!((sa.wo, sa.pdf, sa.weight), (sb.wo, sb.pdf, sb.weight));
        // Mitsuba reports 0.0400964 for this rough-plastic sample
        assert!((sa.weight[0] - 0.040_096_4).abs() < 2e-4, "{:?}", sa.weight);
    }
}
