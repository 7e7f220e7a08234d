//! Warps from the unit square to directions, with their densities (solid angle measure).

use crate::math::{sincos_2pi, sincos_quarter};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};

/// Shirley–Chiu concentric map from the square to the unit disk.
#[inline]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let x = 2.0 * u.x - 1.0;
    let y = 2.0 * u.y - 1.0;
    if x == 0.0 && y == 0.0 {
        return Vec2::ZERO;
    }
    // φ = π/4·(y/x), or π/2 − π/4·(x/y) (sin φ and cos φ of the reduced angle swapped)
    let (r, s, c) = if x.abs() > y.abs() {
        let (s, c) = sincos_quarter(FRAC_PI_4 * (y / x));
        (x, s, c)
    } else {
        let (s, c) = sincos_quarter(FRAC_PI_4 * (x / y));
        (y, c, s)
    };
    Vec2::new(r * c, r * s)
}

/// Cosine-weighted hemisphere (Malley's method on the concentric disk).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let p = square_to_uniform_disk_concentric(u);
    let z = (1.0 - p.length_squared()).max(0.0).sqrt();
    Vec3::new(p.x, p.y, z)
}
#[inline]
pub fn square_to_cosine_hemisphere_pdf(w: Vec3) -> f32 {
    if w.z > 0.0 {
        w.z * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform hemisphere around +z.
#[inline]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sincos_2pi(u.y);
    Vec3::new(r * c, r * s, z)
}
#[inline]
pub fn square_to_uniform_hemisphere_pdf(w: Vec3) -> f32 {
    if w.z > 0.0 {
        0.5 * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (s, c) = sincos_2pi(u.y);
    Vec3::new(r * c, r * s, z)
}
pub const UNIFORM_SPHERE_PDF: f32 = 0.25 * FRAC_1_PI;
