//! Local shading frame helpers. In the local frame the shading normal is +z; all BSDF methods
//! take and return directions in this frame, pointing away from the surface.

use glam::Vec3;

#[inline]
pub fn cos_theta(w: Vec3) -> f32 {
    w.z
}
#[inline]
pub fn cos2_theta(w: Vec3) -> f32 {
    w.z * w.z
}
#[inline]
pub fn sin2_theta(w: Vec3) -> f32 {
    (1.0 - w.z * w.z).max(0.0)
}
#[inline]
pub fn sin_theta(w: Vec3) -> f32 {
    sin2_theta(w).sqrt()
}
/// (sin φ, cos φ) of a direction; (0, 1) at the pole.
#[inline]
pub fn sincos_phi(w: Vec3) -> (f32, f32) {
    let r2 = w.x * w.x + w.y * w.y;
    if r2 <= 0.0 {
        return (0.0, 1.0);
    }
    let inv = 1.0 / r2.sqrt();
    ((w.y * inv).clamp(-1.0, 1.0), (w.x * inv).clamp(-1.0, 1.0))
}
/// Mirror reflection about the local normal (+z).
#[inline]
pub fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}
/// Mirror reflection of `w` about the (unit) direction `m`.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    2.0 * w.dot(m) * m - w
}
/// Refraction of `wi` through a surface with normal `m`, given the signed cosine of the
/// transmitted direction (negative on the opposite side of `m` from `wi`) and the relative
/// index `eta_ti = η_incident / η_transmitted`, as returned by
/// [`crate::fresnel::fresnel_dielectric`].
#[inline]
pub fn refract(wi: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_theta_t) - wi * eta_ti
}
/// Flip a direction to the other side of the local surface.
#[inline]
pub fn flip_z(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// An orthonormal frame (s, t, n); converts between world and local coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around `n` built without branches on its sign (Duff et al. 2017).
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}
