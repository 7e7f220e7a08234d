//! Mitsuba's `projector`.
//!
//! `projector`: a point light at the `to_world` origin projecting the `irradiance` image
//! (texture or colour, default 1) × `scale` (default 1) along +z with Mitsuba's
//! field-of-view rules (`fov`/`fov_axis`/`focal_length`, default 50 mm; the aspect ratio is
//! the image's). A point at local p (z > 0) sees uv = ½ − ½ (x, y·aspect) / (z tan(fov_x/2))
//! (u = 0 towards local +x, as a camera image; uv outside [0, 1] is dark) and receives the
//! radiance-like value E(uv) · scale · π / (z² · cos), cos = −n·d between the light's
//! `to_world` · (0, 0, 1) (not normalised, as Mitsuba) and the direction d from the light to
//! the point: irradiance E·scale·π on a plane facing the projector at unit depth.

use super::*;

/// Mitsuba's `projector` (see the module documentation).
#[derive(Clone, Debug)]
pub struct ProjectorLight {
    pub position: Vec3,
    pub(super) to_local: Mat4,
    /// `to_world` · (0, 0, 1), not normalised.
    pub(super) n_world: Vec3,
    pub(super) irradiance: Rgb,
    /// `irradiance` as a `<spectrum>` (no image), for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
    pub(super) texture: Option<Arc<dyn Texture>>,
    pub scale: f32,
    /// tan(fov_x / 2).
    pub(super) tan_half_x: f32,
    /// Image width / height.
    pub(super) aspect: f32,
}

impl ProjectorLight {
    /// `tan_half_x` = tan(fov_x / 2) for an image of aspect `aspect`; the image is `texture`
    /// or, without one, the constant `irradiance`.
    pub fn new(
        to_world: &Mat4,
        irradiance: Rgb,
        texture: Option<Arc<dyn Texture>>,
        scale: f32,
        tan_half_x: f32,
        aspect: f32,
    ) -> std::result::Result<Self, String> {
        let to_local = to_world.inverse();
        if !to_local.is_finite() {
            return Err("the projector's to_world transform is singular".into());
        }
        if !scale.is_finite() {
            return Err(format!("scale must be finite, got {scale}"));
        }
        Ok(ProjectorLight {
            position: to_world.transform_point3(Vec3::ZERO),
            to_local,
            n_world: to_world.transform_vector3(Vec3::Z),
            irradiance,
            spectrum: None,
            texture,
            scale,
            tan_half_x,
            aspect,
        })
    }

    pub(super) fn sample(&self, ref_p: Vec3) -> Option<DirectionSample> {
        let local = self.to_local.transform_point3(ref_p);
        if local.z.is_nan() || local.z <= 0.0 {
            return None;
        }
        let k = 0.5 / (local.z * self.tan_half_x);
        let uv = Vec2::new(0.5 - local.x * k, 0.5 - local.y * self.aspect * k);
        if !(uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()) {
            return None;
        }
        let d = self.position - ref_p;
        let dist = d.length();
        if !(dist > 0.0 && dist.is_finite()) {
            return None;
        }
        let wi = d / dist;
        let cos = -self.n_world.dot(wi);
        if cos.is_nan() || cos <= 0.0 {
            return None;
        }
        let e = match &self.texture {
            Some(t) => t.eval(&ShadingPoint {
                uv,
                ..Default::default()
            }),
            None => self.irradiance,
        };
        let radiance = e * (PI * self.scale / (local.z * local.z * cos));
        if radiance.is_black() {
            return None;
        }
        Some(DirectionSample {
            wi,
            dist,
            radiance,
            pdf: 1.0,
            is_delta: true,
        })
    }
}
