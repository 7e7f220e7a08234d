//! `twosided`: makes a one-sided reflectance model two-sided (Mitsuba 3 `twosided`). Light
//! arriving from below is handled by the back BSDF (the front one unless two are given), with
//! both directions mirrored to its upper hemisphere. Models with transmission cannot be nested.

use crate::bsdf::*;
use crate::frame::flip_z;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

use super::Bsdf;

#[derive(Clone, Debug)]
pub struct TwoSided {
    pub front: Bsdf,
    pub back: Bsdf,
}

impl BsdfModel for TwoSided {
    fn flags(&self) -> LobeFlags {
        self.front.flags() | self.back.flags()
    }
    fn sample_reads_u1(&self) -> bool {
        self.front.sample_reads_u1() || self.back.sample_reads_u1()
    }
    fn sample_reads_u2(&self) -> bool {
        self.front.sample_reads_u2() || self.back.sample_reads_u2()
    }
    #[inline]
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z > 0.0 {
            self.front.eval(ctx, sp, wi, wo)
        } else if wi.z < 0.0 {
            self.back.eval(ctx, sp, flip_z(wi), flip_z(wo))
        } else {
            Spectrum::ZERO
        }
    }
    #[inline]
    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z > 0.0 {
            self.front.pdf(ctx, sp, wi, wo)
        } else if wi.z < 0.0 {
            self.back.pdf(ctx, sp, flip_z(wi), flip_z(wo))
        } else {
            0.0
        }
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
        if wi.z > 0.0 {
            self.front.sample(ctx, sp, wi, u1, u2)
        } else if wi.z < 0.0 {
            let mut s = self.back.sample(ctx, sp, flip_z(wi), u1, u2)?;
            s.wo = flip_z(s.wo);
            Some(s)
        } else {
            None
        }
    }
}
