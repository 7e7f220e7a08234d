//! `blendbsdf`: a linear blend (1 − w)·f₀ + w·f₁ of two BSDFs (Mitsuba 3 `blendbsdf`), with
//! a constant or textured weight w ∈ [0, 1].
//!
//! Sampling picks a component with probability (1 − w, w). For non-Dirac lobes it reports the
//! blend's density (1 − w)p₀ + w·p₁ and weight f·|cosθo|/p, so that `sample`, `pdf` and `eval`
//! agree (as Mitsuba 3.9 does). A Dirac lobe of one component is reported with its discrete
//! probability times the selection probability; the blend factor and the selection
//! probability cancel in its weight.

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

use super::Bsdf;

#[derive(Clone, Debug)]
pub struct Blend {
    /// Weight of the second BSDF.
    pub weight: FloatParam,
    pub bsdfs: [Bsdf; 2],
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
