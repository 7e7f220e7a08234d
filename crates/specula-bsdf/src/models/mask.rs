//! `mask`: a nested BSDF made partly transparent by an opacity (Mitsuba 3 `mask`), for leaves,
//! fences and cut-outs.
//!
//! Parameters: one nested BSDF; `opacity` (float or texture, clamped to [0, 1], default 0.5).
//!
//! With opacity α the model is α·f plus a null lobe of weight 1 − α: light passes through
//! unchanged (`wo = −wi`, weight 1, probability 1 − α, [`LobeFlags::NULL`], a Dirac
//! transmission). `eval` and `pdf` are α times the nested ones; a nested sample is chosen
//! with probability α (reusing `u1`), keeps its weight and reports its pdf times α, as in
//! Mitsuba 3.9.
//!
//! In a renderer the null lobe is followed like any Dirac lobe: it counts as a bounce (path
//! depth, Russian roulette), and an emitter seen through it gets full weight. Mitsuba's `path`
//! integrator traces shadow rays without looking at materials, so a masked surface blocks
//! shadow rays even where it is transparent (the light arriving through it is found by the
//! pass-through paths instead); Specula's path tracer does the same, which keeps its images
//! equal to Mitsuba's in expectation.

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

use super::Bsdf;

#[derive(Clone, Debug)]
pub struct Mask {
    pub opacity: FloatParam,
    pub nested: Bsdf,
}

impl Mask {
    #[inline]
    fn opacity(&self, sp: &ShadingPoint) -> f32 {
        self.opacity.eval(sp).clamp(0.0, 1.0)
    }
}

/// The pass-through sample of a null lobe chosen with probability `pdf`.
#[inline]
pub fn null_sample(wi: Vec3, pdf: f32) -> BsdfSample {
    BsdfSample {
        wo: -wi,
        weight: Spectrum::ONE,
        pdf,
        lobe: LobeFlags::NULL,
        eta: 1.0,
    }
}

impl BsdfModel for Mask {
    fn flags(&self) -> LobeFlags {
        self.nested.flags() | LobeFlags::NULL
    }
    #[inline]
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.nested.eval(ctx, sp, wi, wo) * self.opacity(sp)
    }
    #[inline]
    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        self.nested.pdf(ctx, sp, wi, wo) * self.opacity(sp)
    }
    #[inline]
    fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        let a = self.opacity(sp);
        let (f, pdf) = self.nested.eval_pdf(ctx, sp, wi, wo);
        (f * a, pdf * a)
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
        let a = self.opacity(sp);
        if u1 < a {
            let mut s = self
                .nested
                .sample(ctx, sp, wi, (u1 / a).min(0.999_999_94), u2)?;
            s.pdf *= a;
            Some(s)
        } else {
            Some(null_sample(wi, 1.0 - a))
        }
    }
}
