//! `null`: an invisible surface (Mitsuba 3 `null`): every ray passes through unchanged
//! (`wo = −wi`, weight 1, a [`LobeFlags::NULL`] Dirac lobe); `eval` and `pdf` are zero. It
//! takes no parameters. Used for the boundaries of participating media and for shapes that
//! only emit. As with `mask`, a pass-through counts as a bounce, and Mitsuba's `path`
//! integrator (like Specula's) lets such a surface block shadow rays.

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

use super::mask::null_sample;

#[derive(Clone, Copy, Debug, Default)]
pub struct Null;

impl BsdfModel for Null {
    fn flags(&self) -> LobeFlags {
        LobeFlags::NULL
    }
    fn sample_reads_u1(&self) -> bool {
        false
    }
    fn sample_reads_u2(&self) -> bool {
        false
    }
    #[inline]
    fn eval(&self, _: &BsdfContext, _: &ShadingPoint, _: Vec3, _: Vec3) -> Spectrum {
        Spectrum::ZERO
    }
    #[inline]
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, _: Vec3, _: Vec3) -> f32 {
        0.0
    }
    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        _: &ShadingPoint,
        wi: Vec3,
        _: f32,
        _: Vec2,
    ) -> Option<BsdfSample> {
        Some(null_sample(wi, 1.0))
    }
}
