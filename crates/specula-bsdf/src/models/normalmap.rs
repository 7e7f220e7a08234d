//! `normalmap`: replaces the shading normal of a nested BSDF with one read from an RGB
//! texture in tangent space (Mitsuba 3 `normalmap`).
//!
//! Parameters: one nested BSDF; `normalmap` (a 3-channel texture, normally a `bitmap` with
//! `raw=true`; a constant RGB is accepted too); `flip_invalid_normals` and
//! `use_shadowing_function` (booleans, default true), see [`super::perturbed`].
//!
//! The texture's colour `c` encodes the normal `2c − 1` in the local shading frame (x along
//! the shading tangent, i.e. ∂p/∂u made orthogonal to the normal, z along the shading
//! normal), as Mitsuba reads it. On the default [`ShadingPoint`] (`specula brdf check`) the
//! texture is looked up at uv (0, 0).

use crate::bsdf::*;
use glam::Vec3;

use super::perturbed::{Perturbation, Perturbed};

/// The tangent-space normal texture of a normal map.
#[derive(Clone, Debug)]
pub struct NormalTexture {
    pub normalmap: SpectrumParam,
}

impl Perturbation for NormalTexture {
    #[inline]
    fn perturbation(&self, sp: &ShadingPoint) -> Vec3 {
        let c = self.normalmap.eval(sp);
        Vec3::new(2.0 * c[0] - 1.0, 2.0 * c[1] - 1.0, 2.0 * c[2] - 1.0)
    }
}

/// Mitsuba's `normalmap`.
pub type NormalMap = Perturbed<NormalTexture>;
