//! `bumpmap`: perturbs the shading frame of a nested BSDF with the gradient of a height-field
//! texture (Mitsuba 3 `bumpmap`).
//!
//! Parameters: one nested BSDF; one nested texture of any name (the height field — in
//! Mitsuba, and here, only `bitmap` provides the texture-space gradient this needs: with
//! bilinear filtering the exact derivative of the bilinear interpolant of the texels'
//! luminances, with nearest filtering zero); `scale` (float, default 1), a gradient
//! multiplier; `flip_invalid_normals` and `use_shadowing_function` (booleans, default true),
//! see [`super::perturbed`].
//!
//! With `g = scale · ∇h(u, v)` and the shading normal `n`, the perturbed tangents are
//! `∂p/∂u + n (g_u − n·∂p/∂u)` and `∂p/∂v + n (g_v − n·∂p/∂v)`; their cross product, turned
//! to the side of the geometric normal, is the perturbed normal (Mitsuba's formulation, which
//! ignores the derivative of the base normal, so only variations of the height field count).
//! `∂p/∂u`, `∂p/∂v` and the geometric normal come from the [`ShadingPoint`]; on its default
//! (the flat frame `specula brdf check` uses) they are the local x, y and z axes.

use crate::bsdf::*;
use glam::Vec3;
use std::sync::Arc;

use super::perturbed::{Perturbation, Perturbed};

/// The height field of a bump map and its gradient multiplier.
#[derive(Clone, Debug)]
pub struct Bump {
    pub texture: Arc<dyn Texture>,
    pub scale: f32,
}

impl Perturbation for Bump {
    #[inline]
    fn perturbation(&self, sp: &ShadingPoint) -> Vec3 {
        let g = self.texture.eval_1_grad(sp).unwrap_or_default() * self.scale;
        // the tangents with their normal component replaced by the height gradient (the local
        // shading normal is +z)
        let du = Vec3::new(sp.dp_du.x, sp.dp_du.y, g.x);
        let dv = Vec3::new(sp.dp_dv.x, sp.dp_dv.y, g.y);
        let n = du.cross(dv);
        if sp.n_geo.dot(n) < 0.0 {
            -n
        } else {
            n
        }
    }
}

/// Mitsuba's `bumpmap`.
pub type BumpMap = Perturbed<Bump>;
