//! Mitsuba 3's `perspective` sensor: a pinhole camera looking along +z of its `to_world`
//! frame, +y up, with camera +x towards the *left* of the image (Mitsuba's look-at convention).

use crate::core::Ray;
use glam::{Mat4, Vec2, Vec3};

/// Which image axis `fov` spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            _ => return None,
        })
    }
}

#[derive(Clone, Debug)]
pub struct PerspectiveCamera {
    pub to_world: Mat4,
    origin: Vec3,
    /// tan(fov_x / 2)
    tan_half_x: f32,
    aspect: f32,
    pub near_clip: f32,
    pub far_clip: f32,
}

impl PerspectiveCamera {
    /// `fov` in degrees along `axis`, for a film of `width` × `height` pixels.
    pub fn new(
        to_world: Mat4,
        fov: f32,
        axis: FovAxis,
        width: usize,
        height: usize,
        near_clip: f32,
        far_clip: f32,
    ) -> Self {
        let (w, h) = (width as f32, height as f32);
        let aspect = w / h;
        let t = (0.5 * fov.to_radians()).tan();
        let tan_half_x = match axis {
            FovAxis::X => t,
            FovAxis::Y => t * aspect,
            FovAxis::Diagonal => t * w / (w * w + h * h).sqrt(),
            FovAxis::Smaller => {
                if w > h {
                    t * aspect
                } else {
                    t
                }
            }
            FovAxis::Larger => {
                if w > h {
                    t
                } else {
                    t * aspect
                }
            }
        };
        PerspectiveCamera {
            to_world,
            origin: to_world.transform_point3(Vec3::ZERO),
            tan_half_x,
            aspect,
            near_clip,
            far_clip,
        }
    }

    /// The primary ray through normalised film position `s` ∈ \[0,1\]² ((0,0) = top-left).
    #[inline]
    pub fn ray(&self, s: Vec2) -> Ray {
        let x = (1.0 - 2.0 * s.x) * self.tan_half_x;
        let y = (1.0 - 2.0 * s.y) / self.aspect * self.tan_half_x;
        let d_cam = Vec3::new(x, y, 1.0);
        let inv_len = 1.0 / d_cam.length();
        let d = self.to_world.transform_vector3(d_cam * inv_len).normalize();
        // the clip planes are perpendicular to the viewing axis
        let near_t = self.near_clip * inv_len.recip();
        let far_t = self.far_clip * inv_len.recip();
        Ray {
            o: self.origin + d * near_t,
            d,
            t_max: far_t - near_t,
        }
    }
}
