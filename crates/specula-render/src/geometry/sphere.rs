//! Mitsuba's `sphere`: an analytic sphere.
//!
//! **Sphere**: with `M = to_world · translate(center) · scale(radius)`, the world centre is
//! `M · 0` and the world radius `|M · (1, 0, 0)|`; `uv = (φ / 2π, θ / π)` of
//! `local = M⁻¹ · p` (θ from drjit's `unit_angle_z`), `∂p/∂u = 2π M · (-y, x, 0)`; the
//! normal points outwards. (Mitsuba only warns about a shearing or non-uniformly scaling
//! `M`; such spheres are not expected to match it exactly.)

use super::*;

/// An analytic sphere.
#[derive(Clone, Debug)]
pub struct Sphere {
    /// World-space centre.
    pub center: Vec3,
    /// World-space radius.
    pub radius: f32,
    pub flip_normals: bool,
    /// Object (unit sphere) to world: `to_world · translate(center) · scale(radius)`.
    pub to_world: Mat4,
    pub to_object: Mat4,
    /// Whether the renderer reads the uv of the sphere's points (its BSDF's textures, a
    /// textured emission, an AOV); the scene sets it false when nothing does, and the path
    /// loop's [`crate::geometry::Geometry::surface_uv`] then skips the uv's trigonometry
    /// (∂p/∂u, ∂p/∂v and so the shading frame need none, and are computed either way).
    /// [`crate::geometry::Geometry::surface`] always computes the uv.
    pub uv: bool,
}

impl Sphere {
    /// The uv of a world point on the sphere, and ∂p/∂u, ∂p/∂v there (Mitsuba's: with `l`
    /// the unit-sphere point, `2π M·(−l.y, l.x, 0)` and `π M·(l.z cos φ, l.z sin φ, −r)`,
    /// r = √(l.x² + l.y²); at the poles ∂p/∂u = 0 and ∂p/∂v = `π M·(1, 0, 0)`).
    pub(super) fn param(&self, p: Vec3, uv: bool) -> (Vec2, Vec3, Vec3) {
        let local = self.to_object.transform_point3(p);
        let rd2 = local.x * local.x + local.y * local.y;
        let uv = if uv {
            let theta = unit_angle_z(local);
            let phi = phi_positive(local.y, local.x);
            Vec2::new(phi * INV_TWO_PI, theta * INV_PI)
        } else {
            Vec2::ZERO
        };
        let (dp_du, dp_dv) = if rd2 > 0.0 {
            let rd = rd2.sqrt();
            let (cos_phi, sin_phi) = (local.x / rd, local.y / rd);
            (
                self.to_world
                    .transform_vector3(Vec3::new(-local.y, local.x, 0.0))
                    * (2.0 * PI),
                self.to_world.transform_vector3(Vec3::new(
                    local.z * cos_phi,
                    local.z * sin_phi,
                    -rd,
                )) * PI,
            )
        } else {
            (Vec3::ZERO, self.to_world.transform_vector3(Vec3::X) * PI)
        };
        (uv, dp_du, dp_dv)
    }

    #[inline(always)]
    pub(super) fn surface(&self, ray: &Ray, hit: &Hit, uv: bool) -> SurfaceGeometry {
        let p = ray.at(hit.t);
        // Re-project onto the sphere (as Mitsuba does) to reduce the error of o + t·d.
        let mut n = (p - self.center).normalize_or(Vec3::Z);
        let p = self.center + n * self.radius;
        let (uv, dp_du, dp_dv) = self.param(p, uv);
        if self.flip_normals {
            n = -n;
        }
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
        // warp::square_to_uniform_sphere
        let z = 1.0 - 2.0 * u.y;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = (2.0 * PI * u.x).sin_cos();
        let local = Vec3::new(r * c, r * s, z);
        let p = local * self.radius + self.center;
        let (uv, _, _) = self.param(p, true);
        let n = if self.flip_normals { -local } else { local };
        let area = self.area();
        PositionSample {
            p,
            n,
            uv,
            pdf: if area > 0.0 { 1.0 / area } else { 0.0 },
        }
    }

    pub(super) fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }
}
