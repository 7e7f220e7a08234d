//! What `bumpmap` and `normalmap` share (Mitsuba 3.9's `PerturbedBSDF`): the nested BSDF is
//! evaluated in a perturbed shading frame, given by a perturbed normal expressed in the
//! unperturbed local frame.
//!
//! With `n` the perturbed normal (unnormalised, local coordinates):
//! - `flip_invalid_normals` (default true): where `cosθi · (wi · n) ≤ 0` the normal is
//!   mirrored to `(−n.x, −n.y, n.z)`, keeping it on the side of the incident direction
//!   (Schüssler et al. 2017);
//! - `n` is normalised (a zero or non-finite `n` becomes +z); the perturbed frame's tangent is
//!   the local x axis made orthogonal to `n` (+y where that degenerates);
//! - `wi` and `wo` are rotated into the perturbed frame; `wo` must lie on the same side of both
//!   frames, otherwise the value, the density and the sample are zero;
//! - `use_shadowing_function` (default true) multiplies values and sample weights by the
//!   shadowing term of Estevez et al. 2019 (“A Microfacet-Based Shadowing Function to Solve
//!   the Bump Terminator Problem”): `G = 2 / (1 + √(1 + α² tan²θo))` with
//!   `α² = min(tan²θn / 8, 1)`.
//!
//! Specula's `eval` excludes the cosine factor, while the nested BSDF's cosine belongs to the
//! perturbed frame: the value reported is `f(wi′, wo′)·|cosθo′| / |cosθo|`, so that
//! `eval · |cosθo|` (what a renderer multiplies by) is Mitsuba's `eval`. `pdf` is the nested
//! density of `wo′` (a rotation keeps solid angle). Neither model is reciprocal (the shadowing
//! term depends on `wo` only, the flip on `wi`).
//!
//! The differential geometry of the [`ShadingPoint`] (`dp_du`, `dp_dv`, `n_geo`, given in the
//! unperturbed frame) is handed to the nested BSDF re-expressed in the perturbed frame, so that
//! perturbations nest as in Mitsuba.

use crate::bsdf::*;
use crate::frame::Frame;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

use super::Bsdf;

/// How a perturbing model computes its normal.
pub trait Perturbation {
    /// The perturbed shading normal in the local (unperturbed) frame, not necessarily unit.
    fn perturbation(&self, sp: &ShadingPoint) -> Vec3;
}

/// A nested BSDF seen through a perturbed shading frame.
#[derive(Clone, Debug)]
pub struct Perturbed<P> {
    pub perturbation: P,
    pub nested: Bsdf,
    pub flip_invalid_normals: bool,
    pub use_shadowing_function: bool,
}

/// tan²θ of a unit direction in the local frame.
#[inline]
fn tan2_theta(v: Vec3) -> f32 {
    let z2 = v.z * v.z;
    (1.0 - z2).max(0.0) / z2
}

/// Estevez et al.'s shadowing term for perturbed normal `n` and direction `wo` (both local).
#[inline]
pub fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let alpha2 = (0.125 * tan2_theta(n)).min(1.0);
    if alpha2 <= 0.0 {
        return 1.0;
    }
    2.0 / (1.0 + (1.0 + alpha2 * tan2_theta(wo)).sqrt())
}

impl<P: Perturbation> Perturbed<P> {
    /// The perturbed frame in local coordinates.
    #[inline]
    pub fn frame(&self, sp: &ShadingPoint, wi: Vec3) -> Frame {
        let mut n = self.perturbation.perturbation(sp);
        if self.flip_invalid_normals && wi.z * wi.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        let inv_len = 1.0 / n.length_squared().sqrt();
        let n = if inv_len > 0.0 && inv_len.is_finite() {
            n * inv_len
        } else {
            Vec3::Z
        };
        let s = Vec3::X - n * n.x;
        let inv_st = 1.0 / s.length_squared().sqrt();
        let s = if inv_st.is_finite() {
            s * inv_st
        } else {
            Vec3::Y
        };
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    /// The shading point as the nested BSDF sees it (its geometry in the perturbed frame).
    #[inline]
    fn nested_point<'a>(sp: &ShadingPoint<'a>, f: &Frame) -> ShadingPoint<'a> {
        ShadingPoint {
            dp_du: f.to_local(sp.dp_du),
            dp_dv: f.to_local(sp.dp_dv),
            n_geo: f.to_local(sp.n_geo),
            ..*sp
        }
    }

    #[inline]
    fn shadowing(&self, f: &Frame, wo: Vec3) -> f32 {
        if self.use_shadowing_function {
            shadow_terminator(f.n, wo)
        } else {
            1.0
        }
    }
}

impl<P: Perturbation> BsdfModel for Perturbed<P> {
    fn flags(&self) -> LobeFlags {
        self.nested.flags()
    }
    #[inline]
    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(ctx, sp, wi, wo).0
    }
    #[inline]
    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        let f = self.frame(sp, wi);
        let (pwi, pwo) = (f.to_local(wi), f.to_local(wo));
        if !(wo.z * pwo.z > 0.0) {
            return 0.0;
        }
        self.nested.pdf(ctx, &Self::nested_point(sp, &f), pwi, pwo)
    }
    #[inline]
    fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        let f = self.frame(sp, wi);
        let (pwi, pwo) = (f.to_local(wi), f.to_local(wo));
        if !(wo.z * pwo.z > 0.0) {
            return (Spectrum::ZERO, 0.0);
        }
        let nsp = Self::nested_point(sp, &f);
        let (v, pdf) = self.nested.eval_pdf(ctx, &nsp, pwi, pwo);
        let scale = self.shadowing(&f, wo) * pwo.z.abs() / wo.z.abs();
        (v * scale, pdf)
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
        let f = self.frame(sp, wi);
        let nsp = Self::nested_point(sp, &f);
        let mut s = self.nested.sample(ctx, &nsp, f.to_local(wi), u1, u2)?;
        if s.weight.is_black() {
            return None;
        }
        let wo = f.to_world(s.wo);
        if !(s.wo.z * wo.z > 0.0) {
            return None;
        }
        s.wo = wo;
        s.weight = s.weight * self.shadowing(&f, wo);
        Some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_terminator_limits() {
        // unperturbed normal: no shadowing
        assert_eq!(
            shadow_terminator(Vec3::Z, Vec3::new(0.9, 0.0, 0.1).normalize()),
            1.0
        );
        // perturbed normal: 1 at normal incidence, falling towards grazing
        let n = Vec3::new(0.5, 0.0, 0.8).normalize();
        assert!((shadow_terminator(n, Vec3::Z) - 1.0).abs() < 1e-6);
        let g = shadow_terminator(n, Vec3::new(0.999, 0.0, 0.01).normalize());
        assert!(g > 0.0 && g < 0.2, "{g}");
    }
}
