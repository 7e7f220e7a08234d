//! Mitsuba's `disk`: an analytic disk.
//!
//! **Disk**: the unit disk at z = 0; `uv = (r, φ / 2π)` with φ in [0, 2π) in object space;
//! `∂p/∂u = to_world · (cos φ, sin φ, 0)`; the normal is `to_world`'s inverse transpose
//! applied to +z (not flipped by a mirroring transform).

use super::*;

/// An analytic disk: the unit disk at z = 0 in object space, any affine `to_world`.
#[derive(Clone, Debug)]
pub struct Disk {
    pub to_world: Mat4,
    pub to_object: Mat4,
    pub flip_normals: bool,
    /// Unit world-space normal (`to_world`'s inverse transpose applied to +z), not flipped.
    pub(super) n: Vec3,
    pub(super) area: f32,
}

impl Disk {
    /// Unit world-space normal on the front side (flip included).
    pub fn normal(&self) -> Vec3 {
        if self.flip_normals {
            -self.n
        } else {
            self.n
        }
    }

    /// Position, uv and ∂p/∂u of the object-space point (x, y).
    pub(super) fn at_local(&self, x: f32, y: f32) -> (Vec3, Vec2, Vec3) {
        let p = self.to_world.transform_point3(Vec3::new(x, y, 0.0));
        let r = (x * x + y * y).sqrt();
        let phi = phi_positive(y, x);
        let uv = Vec2::new(r, phi * INV_TWO_PI);
        let dp_du = if r > 0.0 {
            self.to_world
                .transform_vector3(Vec3::new(x / r, y / r, 0.0))
        } else {
            Vec3::ZERO
        };
        (p, uv, dp_du)
    }

    #[inline(always)]
    pub(super) fn surface(&self, hit: &Hit) -> SurfaceGeometry {
        let (x, y) = (hit.u, hit.v);
        let (p, uv, dp_du) = self.at_local(x, y);
        // ∂p/∂v with v = φ/2π: 2π·(−y, x, 0) in object space (Mitsuba's, zero at the centre)
        let dp_dv = self
            .to_world
            .transform_vector3(Vec3::new(-y, x, 0.0) * (2.0 * PI));
        let n = self.normal();
        SurfaceGeometry {
            p,
            n_geo: n,
            sh_frame: shading_frame(n, dp_du),
            uv,
            dp_du,
            dp_dv,
        }
    }

    #[inline(always)]
    pub(super) fn sample_position(&self, u: Vec2) -> PositionSample {
        let d = square_to_uniform_disk_concentric(u);
        let (p, uv, _) = self.at_local(d.x, d.y);
        let pdf = if self.area > 0.0 {
            1.0 / self.area
        } else {
            0.0
        };
        PositionSample {
            p,
            n: self.normal(),
            uv,
            pdf,
        }
    }

    /// World-space bounds of the (elliptical) disk.
    pub(super) fn bounds(&self) -> (Vec3, Vec3) {
        let c = self.to_world.transform_point3(Vec3::ZERO);
        let a = self.to_world.transform_vector3(Vec3::X);
        let b = self.to_world.transform_vector3(Vec3::Y);
        let h = (a * a + b * b).map(f32::sqrt);
        (c - h, c + h)
    }
}
