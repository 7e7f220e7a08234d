//! Emitters other than area lights, in world space, as Mitsuba 3 defines them: `point`,
//! `directional`, `constant`, `envmap`, `spot` and `projector`.
//!
//! Mitsuba 3.9.1 conventions (checked with its Python bindings; numbers in the tests):
//! - `point`: radiance-like value intensity / dist² from `position` (or the `to_world`
//!   translation).
//! - `directional`: `irradiance` arriving from −direction, where direction is `direction` or
//!   `to_world` · (0, 0, 1).
//! - `constant`: uniform-sphere sampling, pdf 1/4π.
//!
//! A `<spectrum>` value of `point`, `directional`, `constant`, `spot` or `projector` (without
//! an image) is kept beside its RGB value (`spectrum` fields, [`light_spectrum`]): RGB mode
//! uses the RGB value (the spectrum converted as Mitsuba's RGB variants do), spectral mode
//! emits the spectrum itself (`crate::spectral`); a spot's texture then multiplies it as an
//! upsampled reflectance, as in Mitsuba.
//!
//! **Files**: `envmap.rs`, `spot.rs` and `projector.rs` hold those emitters (each with its
//! conventions at its top); this file [`Emitter`] (parsing and the interface the renderer
//! calls) and the three small ones; `tests.rs` the tests.

use crate::core::{Loc, Result, SceneError};
use crate::image_io::{srgb_to_linear, Image};
use crate::xml::Node;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use specula_bsdf::bsdf::SpectralCurve;
use specula_bsdf::warp::{square_to_uniform_sphere, UNIFORM_SPHERE_PDF};
use specula_bsdf::{Rgb, ShadingPoint, Texture};
use std::f32::consts::PI;
use std::path::Path;
use std::sync::Arc;

mod envmap;
mod projector;
mod spot;
#[cfg(test)]
mod tests;

#[cfg(test)]
use envmap::{guide, sample_cdf};
pub use envmap::{Envmap, Lookup as EnvmapLookup};
pub use projector::ProjectorLight;
pub use spot::SpotLight;

/// A direction towards a light, sampled from a reference point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionSample {
    /// Unit vector from the reference point towards the light.
    pub wi: Vec3,
    /// Distance to the light; `f32::INFINITY` for infinitely distant lights.
    pub dist: f32,
    /// Incident radiance along `wi` (for delta lights, the arriving irradiance-like value:
    /// intensity/dist² or irradiance).
    pub radiance: Rgb,
    /// Solid-angle density of `wi`; 1 for delta lights.
    pub pdf: f32,
    pub is_delta: bool,
}

/// An emitter's value given as a `<spectrum>` (see [`light_spectrum`]): what spectral mode
/// emits instead of the RGB value upsampled.
pub type EmissionSpectrum = Arc<dyn SpectralCurve>;

/// Mitsuba's `point`.
#[derive(Clone, Debug)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr).
    pub intensity: Rgb,
    /// `intensity` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
}

/// Mitsuba's `directional`.
#[derive(Clone, Debug)]
pub struct DirectionalLight {
    /// Unit direction in which the light travels.
    pub direction: Vec3,
    pub irradiance: Rgb,
    /// `irradiance` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
}

/// Mitsuba's `constant`.
#[derive(Clone, Debug)]
pub struct ConstantLight {
    pub radiance: Rgb,
    /// `radiance` as a `<spectrum>`, for spectral mode.
    pub spectrum: Option<EmissionSpectrum>,
}

/// A non-area light source.
#[derive(Clone, Debug)]
pub enum Emitter {
    Point(PointLight),
    Directional(DirectionalLight),
    Constant(ConstantLight),
    Envmap(Box<Envmap>),
    Spot(Box<SpotLight>),
    Projector(Box<ProjectorLight>),
}

impl Emitter {
    pub fn point(position: Vec3, intensity: Rgb) -> Self {
        Emitter::Point(PointLight {
            position,
            intensity,
            spectrum: None,
        })
    }

    /// A `point` placed by its `to_world` transform (the translation).
    pub fn point_from_to_world(to_world: &Mat4, intensity: Rgb) -> Self {
        Emitter::point(to_world.transform_point3(Vec3::ZERO), intensity)
    }

    /// A `directional` light travelling along `direction` (normalised here; must be non-zero).
    pub fn directional(direction: Vec3, irradiance: Rgb) -> Self {
        Emitter::Directional(DirectionalLight {
            direction: direction.normalize(),
            irradiance,
            spectrum: None,
        })
    }

    /// A `directional` light oriented by `to_world`: it travels along to_world · (0, 0, 1).
    pub fn directional_from_to_world(to_world: &Mat4, irradiance: Rgb) -> Self {
        Emitter::directional(to_world.transform_vector3(Vec3::Z), irradiance)
    }

    pub fn constant(radiance: Rgb) -> Self {
        Emitter::Constant(ConstantLight {
            radiance,
            spectrum: None,
        })
    }

    /// The `<spectrum>` the emitter's value was given as, with that value's RGB (`point`,
    /// `directional`, `spot`: intensity or irradiance; `constant`: radiance; `projector`:
    /// irradiance without an image); `None` for RGB values and for `envmap`.
    pub fn spectrum(&self) -> Option<(&EmissionSpectrum, Rgb)> {
        match self {
            Emitter::Point(l) => l.spectrum.as_ref().map(|s| (s, l.intensity)),
            Emitter::Directional(l) => l.spectrum.as_ref().map(|s| (s, l.irradiance)),
            Emitter::Constant(l) => l.spectrum.as_ref().map(|s| (s, l.radiance)),
            Emitter::Spot(l) => l.spectrum.as_ref().map(|s| (s, l.intensity)),
            Emitter::Projector(l) => l.spectrum.as_ref().map(|s| (s, l.irradiance)),
            Emitter::Envmap(_) => None,
        }
    }

    /// The emitter's colour when every light sample's weight is a multiple of it (no image, no
    /// `<spectrum>`, not an environment map): what spectral mode prepares once
    /// ([`specula_bsdf::spectral::upsample::Illuminant`]).
    pub fn constant_colour(&self) -> Option<Rgb> {
        if self.spectrum().is_some() {
            return None;
        }
        match self {
            Emitter::Point(l) => Some(l.intensity),
            Emitter::Directional(l) => Some(l.irradiance),
            Emitter::Constant(l) => Some(l.radiance),
            Emitter::Spot(l) => l.texture.is_none().then_some(l.intensity),
            Emitter::Projector(l) => l.texture.is_none().then_some(l.irradiance),
            Emitter::Envmap(_) => None,
        }
    }

    /// Reads the `<spectrum>` of the emitter's value parameter `name` ([`light_spectrum`]) into
    /// the emitter built from node `n`.
    fn with_spectrum(mut self, n: &Node, name: &str) -> Result<Self> {
        let s = light_spectrum(n, name)?;
        match &mut self {
            Emitter::Point(l) => l.spectrum = s,
            Emitter::Directional(l) => l.spectrum = s,
            Emitter::Constant(l) => l.spectrum = s,
            Emitter::Spot(l) => l.spectrum = s,
            // an image replaces the irradiance value
            Emitter::Projector(l) if l.texture.is_none() => l.spectrum = s,
            Emitter::Projector(_) | Emitter::Envmap(_) => {}
        }
        Ok(self)
    }

    /// An `envmap` from an EXR/HDR (or PNG/JPEG, linearised) lat-long image.
    pub fn envmap_from_file(path: &Path, scale: f32, to_world: &Mat4) -> Result<Self> {
        let (img, srgb) = {
            let _t = crate::timings::span(crate::timings::Phase::Textures);
            let raw = crate::image_io::read_image_raw_prefetched(path)?;
            let srgb = raw.srgb;
            (raw.into_image(), srgb)
        };
        Envmap::new(&img, srgb, scale, to_world)
            .map(|e| Emitter::Envmap(Box::new(e)))
            .map_err(|msg| SceneError::file(path, msg))
    }

    /// Builds a top-level `<emitter>` (point, directional, constant, envmap) with Mitsuba 3's
    /// parameters and defaults; relative filenames resolve against `base`. Errors carry the
    /// node's location. (`area` emitters belong to shapes and are built by the scene.)
    pub fn from_node(n: &Node, base: &Path) -> Result<Self> {
        if let Some(c) = n.children.first() {
            return Err(c.error(format!(
                "<{}> cannot be nested in {} (textured emitters are not supported)",
                c.tag,
                n.describe()
            )));
        }
        let rgb = |name: &str| light_rgb(n, name);
        let e = match n.plugin_type.as_str() {
            "point" => {
                let intensity = rgb("intensity")?;
                let position = n.point_opt("position")?;
                let to_world = n.transform("to_world")?;
                n.check_unused(&["intensity", "position", "to_world"])?;
                let e = match (position, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(
                            n.error("point: give either 'position' or 'to_world', not both")
                        )
                    }
                    (Some(p), None) => Emitter::point(p, intensity),
                    (None, Some(m)) => Emitter::point_from_to_world(&m, intensity),
                    (None, None) => Emitter::point(Vec3::ZERO, intensity),
                }
                .with_spectrum(n, "intensity")?;
                if let Emitter::Point(l) = &e {
                    if !l.position.is_finite() {
                        return Err(n.error(format!(
                            "point: the position {} is not finite",
                            l.position
                        )));
                    }
                }
                e
            }
            "directional" => {
                let irradiance = rgb("irradiance")?;
                let direction = n.vector_opt("direction")?;
                let to_world = n.transform("to_world")?;
                n.check_unused(&["irradiance", "direction", "to_world"])?;
                let d = match (direction, to_world) {
                    (Some(_), Some(_)) => {
                        return Err(n.error(
                            "directional: give either 'direction' or 'to_world', not both",
                        ))
                    }
                    (Some(d), None) => d,
                    (None, Some(m)) => m.transform_vector3(Vec3::Z),
                    (None, None) => Vec3::Z,
                };
                if !(d.length_squared() > 0.0 && d.is_finite()) {
                    return Err(n.error("directional: the direction must be a non-zero vector"));
                }
                Emitter::directional(d, irradiance).with_spectrum(n, "irradiance")?
            }
            "constant" => {
                let radiance = rgb("radiance")?;
                n.check_unused(&["radiance"])?;
                Emitter::constant(radiance).with_spectrum(n, "radiance")?
            }
            "envmap" => {
                let file = n
                    .string_opt("filename")?
                    .ok_or_else(|| n.error("envmap needs a 'filename'"))?;
                let scale = n.float("scale", 1.0)?;
                if !(scale.is_finite() && scale >= 0.0) {
                    let loc = n.prop("scale").map_or(&n.loc, |p| &p.loc);
                    return Err(SceneError::new(
                        Some(loc.clone()),
                        format!("envmap: 'scale' must be finite and non-negative, not {scale}"),
                    ));
                }
                let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
                // Only changes how Mitsuba samples the map (unbiased either way).
                let _ = n.bool("mis_compensation", false)?;
                n.check_unused(&["filename", "scale", "to_world", "mis_compensation"])?;
                let p = Path::new(&file);
                let path = if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    base.join(p)
                };
                Emitter::envmap_from_file(&path, scale, &to_world)
                    .map_err(|e| n.error(e.to_string()))?
            }
            "spot" => Emitter::spot_from_node(n, &[])?,
            "projector" => Emitter::projector_from_node(n, &[])?,
            "area" => {
                return Err(n.error("an 'area' emitter must be nested in the shape that emits"))
            }
            other => {
                return Err(n.error(format!(
                    "emitter '{other}' is not supported (supported: point, directional, constant, envmap, spot, projector, and area inside shapes)"
                )))
            }
        };
        Ok(e)
    }

    /// True for delta lights (`point`, `directional`, `spot`, `projector`), which only next-event estimation can
    /// reach.
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Emitter::Point(_) | Emitter::Directional(_) | Emitter::Spot(_) | Emitter::Projector(_)
        )
    }

    /// True for environment lights (`constant`, `envmap`): infinitely distant and seen by rays
    /// that escape the scene (`eval_direction`). `directional` is also at infinity
    /// (`sample_direction` reports `dist = ∞`) but, being a delta light, is never seen, so it
    /// is not counted here.
    pub fn is_infinite(&self) -> bool {
        matches!(self, Emitter::Constant(_) | Emitter::Envmap(_))
    }

    /// Samples a direction from `ref_p` towards the light. `None` when nothing can be sampled
    /// (reference point on a point light, black environment). Allocation-free.
    pub fn sample_direction(&self, ref_p: Vec3, u: Vec2) -> Option<DirectionSample> {
        match self {
            Emitter::Point(l) => {
                let d = l.position - ref_p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                if dist <= 0.0 || !dist.is_finite() {
                    return None;
                }
                Some(DirectionSample {
                    wi: d / dist,
                    dist,
                    radiance: l.intensity * (1.0 / dist2),
                    pdf: 1.0,
                    is_delta: true,
                })
            }
            Emitter::Directional(l) => Some(DirectionSample {
                wi: -l.direction,
                dist: f32::INFINITY,
                radiance: l.irradiance,
                pdf: 1.0,
                is_delta: true,
            }),
            Emitter::Constant(l) => Some(DirectionSample {
                wi: square_to_uniform_sphere(u),
                dist: f32::INFINITY,
                radiance: l.radiance,
                pdf: UNIFORM_SPHERE_PDF,
                is_delta: false,
            }),
            Emitter::Envmap(e) => e.sample(u),
            Emitter::Spot(l) => l.sample(ref_p),
            Emitter::Projector(l) => l.sample(ref_p),
        }
    }

    /// Radiance arriving from world direction `d` (pointing away from the receiver, towards
    /// the light); 0 for delta lights.
    pub fn eval_direction(&self, d_world: Vec3) -> Rgb {
        match self {
            Emitter::Point(_)
            | Emitter::Directional(_)
            | Emitter::Spot(_)
            | Emitter::Projector(_) => Rgb::ZERO,
            Emitter::Constant(l) => l.radiance,
            Emitter::Envmap(e) => e.eval(d_world),
        }
    }

    /// [`Emitter::eval_direction`] and [`Emitter::pdf_direction`] together.
    pub fn eval_pdf_direction(&self, d_world: Vec3) -> (Rgb, f32) {
        match self {
            Emitter::Envmap(e) => e.eval_pdf(d_world),
            _ => (self.eval_direction(d_world), self.pdf_direction(d_world)),
        }
    }

    /// Solid-angle density with which `sample_direction` produces `d` (0 for delta lights).
    pub fn pdf_direction(&self, d_world: Vec3) -> f32 {
        match self {
            Emitter::Point(_)
            | Emitter::Directional(_)
            | Emitter::Spot(_)
            | Emitter::Projector(_) => 0.0,
            Emitter::Constant(_) => UNIFORM_SPHERE_PDF,
            Emitter::Envmap(e) => e.pdf(d_world),
        }
    }
}

/// A texture given to an emitter as a nested `<texture name=…>` or a `<ref name=… id=…>`.
#[derive(Clone, Debug)]
pub struct NamedTexture {
    /// The parameter it sets.
    pub name: String,
    pub texture: Arc<dyn Texture>,
    /// Where it was given.
    pub loc: Loc,
}

/// The texture named `name` among `textures`; an error at any texture whose name `accepted`
/// does not hold.
fn take_textures<'a>(
    n: &Node,
    textures: &'a [NamedTexture],
    accepted: &[&str],
) -> Result<Vec<(&'a str, &'a Arc<dyn Texture>)>> {
    let mut out = vec![];
    for t in textures {
        if !accepted.contains(&t.name.as_str()) {
            return Err(SceneError::new(
                Some(t.loc.clone()),
                format!(
                    "{} has no texture parameter '{}' (textures it accepts: {})",
                    n.describe(),
                    t.name,
                    accepted.join(", ")
                ),
            ));
        }
        if n.has(&t.name) {
            return Err(SceneError::new(
                Some(t.loc.clone()),
                format!("'{}' is given twice", t.name),
            ));
        }
        out.push((t.name.as_str(), &t.texture));
    }
    Ok(out)
}

impl Emitter {
    /// [`Emitter::from_node`] for an emitter given textures (nested `<texture name=…>` or
    /// `<ref name=…>` elements, built by the caller): `spot`'s `texture`, `projector`'s
    /// `irradiance`. Other emitters take no textures (their nested elements are errors).
    pub fn from_node_textured(n: &Node, base: &Path, textures: &[NamedTexture]) -> Result<Self> {
        match n.plugin_type.as_str() {
            "spot" => Emitter::spot_from_node(n, textures),
            "projector" => Emitter::projector_from_node(n, textures),
            _ => Emitter::from_node(n, base),
        }
    }

    /// Mitsuba's `spot` from its node and textures.
    fn spot_from_node(n: &Node, textures: &[NamedTexture]) -> Result<Self> {
        let texture = take_textures(n, textures, &["texture"])?
            .first()
            .map(|(_, t)| Arc::clone(t));
        let intensity = light_rgb(n, "intensity")?;
        let cutoff = n.float("cutoff_angle", 20.0)?;
        let beam = n.float("beam_width", cutoff * 0.75)?;
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        n.check_unused(&["intensity", "cutoff_angle", "beam_width", "to_world"])?;
        SpotLight::new(&to_world, intensity, cutoff, beam, texture)
            .map(|l| Emitter::Spot(Box::new(l)))
            .map_err(|m| n.error(format!("spot: {m}")))?
            .with_spectrum(n, "intensity")
    }

    /// Mitsuba's `projector` from its node and textures.
    fn projector_from_node(n: &Node, textures: &[NamedTexture]) -> Result<Self> {
        let texture = take_textures(n, textures, &["irradiance"])?
            .first()
            .map(|(_, t)| Arc::clone(t));
        let irradiance = light_rgb(n, "irradiance")?;
        let scale = n.float("scale", 1.0)?;
        let (w, h) = texture.as_ref().map_or((1, 1), |t| t.resolution());
        let aspect = w as f64 / h as f64;
        let tan_half_x = crate::camera::parse_fov(n, aspect)?;
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        n.check_unused(&[
            "irradiance",
            "scale",
            "fov",
            "fov_axis",
            "focal_length",
            "to_world",
        ])?;
        ProjectorLight::new(
            &to_world,
            irradiance,
            texture,
            scale,
            tan_half_x,
            aspect as f32,
        )
        .map(|l| Emitter::Projector(Box::new(l)))
        .map_err(|m| n.error(format!("projector: {m}")))?
        .with_spectrum(n, "irradiance")
    }
}

/// A light's colour parameter (`radiance`, `intensity`, `irradiance`; default 1): finite and
/// non-negative in every channel, or an error at the property. Negative or infinite light
/// gives negative or NaN pixels, so it is refused (Mitsuba accepts it).
pub fn light_rgb(n: &Node, name: &str) -> Result<Rgb> {
    let v = n.emission_rgb(name, [1.0; 3])?;
    if v.iter().all(|c| c.is_finite() && *c >= 0.0) {
        return Ok(Rgb(v));
    }
    let loc = n.prop(name).map_or(&n.loc, |p| &p.loc);
    Err(SceneError::new(
        Some(loc.clone()),
        format!(
            "{}: '{name}' must be finite and non-negative, not ({}, {}, {})",
            n.plugin_type, v[0], v[1], v[2]
        ),
    ))
}

/// The `<spectrum>` an emitter's value parameter `name` was given as, kept for spectral
/// mode (Mitsuba's spectral variants emit it as it is; see [`crate::xml::spectrum`]);
/// `None` for `<rgb>`, `<float>` and absent values. A tabulated spectrum with a negative
/// value is an error at the property, as a negative RGB light is.
pub fn light_spectrum(n: &Node, name: &str) -> Result<Option<EmissionSpectrum>> {
    let Some(p) = n.prop(name) else {
        return Ok(None);
    };
    let crate::xml::PropValue::Spectrum(s) = &p.value else {
        return Ok(None);
    };
    if let Some(m) = s.min_sample().filter(|m| *m < 0.0) {
        return Err(SceneError::new(
            Some(p.loc.clone()),
            format!(
                "{}: the '{name}' spectrum must be non-negative at every wavelength, not {m}",
                n.plugin_type
            ),
        ));
    }
    Ok(Some(s.curve()))
}
