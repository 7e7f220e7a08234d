//! Mitsuba's `spot`.
//!
//! `spot`: a point light at the `to_world` origin shining along its +z: `intensity`
//! (default 1) / dist² × falloff(θ) × `texture`(uv) (optional, nested or referenced). The
//! falloff is 1 up to `beam_width` (degrees, default ¾ `cutoff_angle`), falls linearly *in angle* to 0
//! at `cutoff_angle` (degrees, default 20; must lie in (0, 180)), and is 0 beyond (strictly:
//! cos θ > cos cutoff). The texture is looked up at uv = ½ + ½ (x, y) / (z tan cutoff) of the
//! local direction (x, y, z) (u grows towards local +x, v towards +y; no flip). θ comes from
//! the direction in the light's local frame, the 1/dist² from the world distance.

use super::*;

/// Mitsuba's `spot` (see the module documentation).
#[derive(Clone, Debug)]
pub struct SpotLight {
    pub position: Vec3,
    /// World → local (the inverse of `to_world`).
    pub(super) to_local: Mat4,
    pub intensity: Rgb,
    /// `intensity` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
    pub(super) texture: Option<Arc<dyn Texture>>,
    /// Radians.
    pub(super) cutoff: f32,
    pub(super) cos_cutoff: f32,
    pub(super) cos_beam: f32,
    pub(super) inv_transition: f32,
    /// tan(cutoff): scales the texture's uv.
    pub(super) uv_factor: f32,
}

impl SpotLight {
    /// `cutoff_angle` and `beam_width` in degrees; errors are messages for the caller.
    pub fn new(
        to_world: &Mat4,
        intensity: Rgb,
        cutoff_angle: f32,
        beam_width: f32,
        texture: Option<Arc<dyn Texture>>,
    ) -> std::result::Result<Self, String> {
        if !(cutoff_angle > 0.0 && cutoff_angle < 180.0) {
            return Err(format!(
                "cutoff_angle must lie in (0, 180) degrees, got {cutoff_angle}"
            ));
        }
        if !(beam_width >= 0.0 && beam_width.is_finite()) {
            return Err(format!(
                "beam_width must be a non-negative angle in degrees, got {beam_width}"
            ));
        }
        let to_local = to_world.inverse();
        if !to_local.is_finite() {
            return Err("the spot's to_world transform is singular".into());
        }
        let (cutoff, beam) = (cutoff_angle.to_radians(), beam_width.to_radians());
        Ok(SpotLight {
            position: to_world.transform_point3(Vec3::ZERO),
            to_local,
            intensity,
            spectrum: None,
            texture,
            cutoff,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            inv_transition: 1.0 / (cutoff - beam),
            uv_factor: cutoff.tan(),
        })
    }

    /// Intensity towards local direction `local` (any length), falloff and texture included.
    pub fn falloff(&self, local: Vec3) -> Rgb {
        let d = local.normalize_or_zero();
        let cos_t = d.z;
        // (NaN fails too)
        if cos_t.is_nan() || cos_t <= self.cos_cutoff {
            return Rgb::ZERO;
        }
        let mut v = self.intensity;
        if let Some(t) = self.texture_at(d) {
            v *= t;
        }
        if cos_t >= self.cos_beam {
            v
        } else {
            v * ((self.cutoff - cos_t.min(1.0).acos()) * self.inv_transition)
        }
    }

    /// The texture's value towards the unit local direction `d` (z > 0); `None` without a
    /// texture.
    pub(super) fn texture_at(&self, d: Vec3) -> Option<Rgb> {
        let t = self.texture.as_ref()?;
        let k = 0.5 / (d.z * self.uv_factor);
        let uv = Vec2::new(0.5 + d.x * k, 0.5 + d.y * k);
        Some(t.eval(&ShadingPoint {
            uv,
            ..Default::default()
        }))
    }

    /// The texture's value on a ray from the light along world direction `d`; `None` without
    /// a texture or outside the cone.
    pub fn texture_towards(&self, d: Vec3) -> Option<Rgb> {
        let d = self.to_local.transform_vector3(d).normalize_or_zero();
        if d.z.is_nan() || d.z <= self.cos_cutoff {
            return None;
        }
        self.texture_at(d)
    }

    pub(super) fn sample(&self, ref_p: Vec3) -> Option<DirectionSample> {
        let d = self.position - ref_p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        if dist <= 0.0 || !dist.is_finite() {
            return None;
        }
        let radiance = self.falloff(self.to_local.transform_point3(ref_p)) * (1.0 / dist2);
        if radiance.is_black() {
            return None;
        }
        Some(DirectionSample {
            wi: d / dist,
            dist,
            radiance,
            pdf: 1.0,
            is_delta: true,
        })
    }
}
