//! Mitsuba's `cylinder`: an analytic open cylinder.
//!
//! **Cylinder** (open, no caps): with `M = to_world · translate(p0) · to_frame(p1 − p0) ·
//! scale(radius, radius, |p1 − p0|)` (`to_frame` from Mitsuba's `coordinate_system`), the unit
//! cylinder x² + y² = 1, 0 ≤ z ≤ 1 of `local = M⁻¹ · p`; `uv = (φ / 2π, z)`,
//! `∂p/∂u = 2π M · (−y, x, 0)`; the normal is `M`'s inverse transpose applied to (x, y, 0)
//! (outwards); a sampled point's normal is `normalize(∂p/∂u × ∂p/∂v)`, which points inwards
//! when `M` mirrors — both as Mitsuba 3.9 does. Area `2π |M·x| |M·z|` (exact without shear
//! or non-uniform x/y scaling, which Mitsuba only warns about). A negative radius turns the
//! parameterisation by π, as in Mitsuba.

use super::*;

/// An analytic open cylinder: the unit cylinder x² + y² = 1, 0 ≤ z ≤ 1 in object space, any
/// affine `to_world` (see the module docs).
#[derive(Clone, Debug)]
pub struct Cylinder {
    pub to_world: Mat4,
    pub to_object: Mat4,
    pub flip_normals: bool,
    /// `to_world`'s inverse transpose (3×3).
    pub(super) nm: Mat3,
    /// Sign of `to_world`'s determinant (sampled normals follow ∂p/∂u × ∂p/∂v).
    pub(super) det_sign: f32,
    pub(super) area: f32,
}

impl Cylinder {
    #[inline(never)]
    pub(super) fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        let local = self.to_object.transform_point3(ray.at(hit.t));
        // re-project onto the surface (Mitsuba shifts p along the normal by the same amount)
        let rxy = (local.x * local.x + local.y * local.y).sqrt();
        let (x, y) = if rxy > 0.0 {
            (local.x / rxy, local.y / rxy)
        } else {
            (1.0, 0.0)
        };
        let p = self.to_world.transform_point3(Vec3::new(x, y, local.z));
        let phi = phi_positive(y, x);
        let uv = Vec2::new(phi * INV_TWO_PI, local.z);
        let dp_du = self
            .to_world
            .transform_vector3(Vec3::new(-y, x, 0.0) * (2.0 * PI));
        let mut n = (self.nm * Vec3::new(x, y, 0.0)).normalize_or(Vec3::Z);
        if self.flip_normals {
            n = -n;
        }
        SurfaceGeometry {
            p,
            n_geo: n,
            sh_frame: shading_frame(n, dp_du),
            uv,
            dp_du,
            // v is the object-space height
            dp_dv: self.to_world.transform_vector3(Vec3::Z),
        }
    }

    #[inline(never)]
    pub(super) fn sample_position(&self, u: Vec2) -> PositionSample {
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        let p = self.to_world.transform_point3(Vec3::new(c, s, u.x));
        // normalize(∂p/∂u × ∂p/∂v) = sign(det) · normalize(nm · (cos, sin, 0))
        let mut n = (self.nm * Vec3::new(c, s, 0.0)).normalize_or(Vec3::Z) * self.det_sign;
        if self.flip_normals {
            n = -n;
        }
        PositionSample {
            p,
            n,
            uv: Vec2::new(u.y, u.x),
            pdf: if self.area > 0.0 {
                1.0 / self.area
            } else {
                0.0
            },
        }
    }

    /// World-space bounds: the box of the two end circles.
    pub(super) fn bounds(&self) -> (Vec3, Vec3) {
        let p0 = self.to_world.transform_point3(Vec3::ZERO);
        let p1 = self.to_world.transform_point3(Vec3::Z);
        let a = self.to_world.transform_vector3(Vec3::X);
        let b = self.to_world.transform_vector3(Vec3::Y);
        let h = (a * a + b * b).map(f32::sqrt);
        ((p0 - h).min(p1 - h), (p0 + h).max(p1 + h))
    }
}
