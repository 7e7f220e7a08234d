//! Participating media (Mitsuba 3's `<medium>` and `<phase>` plugins).
//!
//! - [`homogeneous`]: the `homogeneous` medium (free-flight sampling, transmittance);
//! - [`phase`]: the `isotropic`, `hg`, `rayleigh` and `blendphase` phase functions.
//!
//! A medium is declared at the top level (`<medium type="homogeneous" id="fog">`), nested in
//! a shape as its `interior` or `exterior` (`<medium name="interior" …>`), referenced from a
//! shape (`<ref name="exterior" id="fog"/>`), or nested in / referenced from the sensor (the
//! camera is inside it). Media are rendered by the `volpath` integrator
//! ([`crate::volpath`]); Specula's `path` refuses a scene with media.
//!
//! Deviations from Mitsuba: `heterogeneous` media and `gridvolume`s are not supported yet
//! (clear errors); see the plugins' docs for per-parameter notes.

pub mod homogeneous;
pub mod phase;
pub mod volume;

pub use homogeneous::{FreeFlight, Homogeneous};
pub use phase::{PhaseFunction, PhaseSample};

use crate::core::{Result, SceneError};
use crate::xml::{Node, PropValue};
use specula_bsdf::Rgb;

/// A participating medium.
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    Homogeneous(Homogeneous),
}

impl Medium {
    #[inline]
    pub fn phase(&self) -> &PhaseFunction {
        match self {
            Medium::Homogeneous(m) => &m.phase,
        }
    }
    /// Whether scattering events use next-event estimation (`sample_emitters`).
    #[inline]
    pub fn sample_emitters(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.sample_emitters,
        }
    }
    #[inline]
    pub fn sample_free_flight(
        &self,
        o: glam::Vec3,
        d: glam::Vec3,
        t_max: f32,
        channel: usize,
        u: f32,
    ) -> FreeFlight {
        match self {
            Medium::Homogeneous(m) => m.sample_free_flight(o, d, t_max, channel, u),
        }
    }
    /// Transmittance along a segment of length `d` inside the medium.
    #[inline]
    pub fn transmittance(&self, d: f32) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.transmittance(d),
        }
    }
}

fn err(n: &Node, msg: impl Into<String>) -> SceneError {
    SceneError::new(Some(n.loc.clone()), msg.into())
}

/// A spectrum-valued medium parameter: a float, rgb or spectrum property, or a nested
/// `<volume type="constvolume" name=…>` with its `value`.
fn volume_param(n: &Node, name: &str, default: f32) -> Result<Rgb> {
    if let Some(v) = n.children.iter().find(|c| c.name.as_deref() == Some(name)) {
        if v.tag != "volume" {
            return Err(err(
                v,
                format!("'{name}' of a medium must be a <volume>, a float or an rgb value"),
            ));
        }
        return match v.plugin_type.as_str() {
            "constvolume" => {
                let val = volume_param(v, "value", 1.0)?;
                v.check_unused(&["value"])?;
                Ok(val)
            }
            "gridvolume" => Err(err(
                v,
                format!("a gridvolume cannot give '{name}' of a homogeneous medium (only its albedo may vary in space)"),
            )),
            other => Err(err(
                v,
                format!("volume '{other}' is not supported (supported: constvolume, gridvolume)"),
            )),
        };
    }
    match n.prop(name).map(|p| &p.value) {
        None => Ok(Rgb::splat(default)),
        Some(PropValue::Float(_)) | Some(PropValue::Int(_)) => {
            Ok(Rgb::splat(n.float(name, default)?))
        }
        Some(PropValue::Spectrum(_)) => Ok(Rgb(n
            .color_opt(name, crate::xml::Usage::Unbounded)?
            .unwrap_or([default; 3]))),
        Some(_) => Ok(Rgb(n.rgb(name, [default; 3])?)),
    }
}

/// Builds a `<phase>` node.
pub fn phase_from_node(n: &Node) -> Result<PhaseFunction> {
    let p = match n.plugin_type.as_str() {
        "isotropic" => PhaseFunction::Isotropic,
        "hg" => {
            let g = n.float("g", 0.8)?;
            if !(g > -1.0 && g < 1.0) {
                return Err(err(n, format!("hg: g must lie in (−1, 1), got {g}")));
            }
            PhaseFunction::HenyeyGreenstein { g }
        }
        "rayleigh" => PhaseFunction::Rayleigh,
        "blendphase" => {
            let weight = n.float("weight", 0.5)?;
            if !(0.0..=1.0).contains(&weight) {
                return Err(err(n, format!("blendphase: weight must lie in [0, 1], got {weight}")));
            }
            let nested: Vec<&Node> = n.children.iter().filter(|c| c.tag == "phase").collect();
            if let Some(c) = n.children.iter().find(|c| c.tag != "phase") {
                return Err(err(c, format!("<{}> cannot be nested in a blendphase", c.tag)));
            }
            if nested.len() != 2 {
                return Err(err(
                    n,
                    format!("blendphase needs exactly two nested <phase>s, got {}", nested.len()),
                ));
            }
            PhaseFunction::Blend {
                weight,
                first: Box::new(phase_from_node(nested[0])?),
                second: Box::new(phase_from_node(nested[1])?),
            }
        }
        other => {
            return Err(err(
                n,
                format!("phase function '{other}' is not supported (supported: isotropic, hg, rayleigh, blendphase)"),
            ))
        }
    };
    if p.plugin_name() != "blendphase" {
        if let Some(c) = n.children.first() {
            return Err(err(
                c,
                format!(
                    "<{}> cannot be nested in a {} phase function",
                    c.tag, n.plugin_type
                ),
            ));
        }
    }
    match &p {
        PhaseFunction::HenyeyGreenstein { .. } => n.check_unused(&["g"])?,
        PhaseFunction::Blend { .. } => n.check_unused(&["weight"])?,
        _ => n.check_unused(&[])?,
    }
    Ok(p)
}

/// Builds a `<medium>` node.
pub fn medium_from_node(n: &Node) -> Result<Medium> {
    match n.plugin_type.as_str() {
        "homogeneous" => {
            let sigma_t = volume_param(n, "sigma_t", 1.0)?;
            let grid = match n.child_named("albedo") {
                Some(v) if v.tag == "volume" && v.plugin_type == "gridvolume" => Some(
                    std::sync::Arc::new(volume::GridVolume::from_node(v, &|f| {
                        std::path::PathBuf::from(f)
                    })?),
                ),
                _ => None,
            };
            let albedo = if grid.is_some() {
                Rgb::splat(0.75)
            } else {
                volume_param(n, "albedo", 0.75)?
            };
            let scale = n.float("scale", 1.0)?;
            let sample_emitters = n.bool("sample_emitters", true)?;
            let _ = n.bool("has_spectral_extinction", true)?;
            if !(sigma_t.min_component() >= 0.0
                && sigma_t.is_finite()
                && scale >= 0.0
                && scale.is_finite())
            {
                return Err(err(n, "sigma_t and scale must be finite and non-negative"));
            }
            if !(albedo.min_component() >= 0.0 && albedo.max_component() <= 1.0) {
                return Err(err(n, "albedo must lie in [0, 1]"));
            }
            let mut phase = PhaseFunction::Isotropic;
            let mut n_phase = 0;
            for c in &n.children {
                match c.tag.as_str() {
                    "phase" => {
                        phase = phase_from_node(c)?;
                        n_phase += 1;
                    }
                    "volume" if matches!(c.name.as_deref(), Some("sigma_t") | Some("albedo")) => {}
                    other => {
                        return Err(err(
                            c,
                            format!("<{other}> cannot be nested in a homogeneous medium"),
                        ))
                    }
                }
            }
            if n_phase > 1 {
                return Err(err(n, "a medium takes at most one <phase>"));
            }
            n.check_unused(&[
                "sigma_t",
                "albedo",
                "scale",
                "sample_emitters",
                "has_spectral_extinction",
            ])?;
            let mut m = Homogeneous::new(sigma_t, albedo, scale, phase);
            m.sample_emitters = sample_emitters;
            m.albedo_grid = grid;
            Ok(Medium::Homogeneous(m))
        }
        "heterogeneous" => Err(err(
            n,
            "medium 'heterogeneous' is not supported yet (supported: homogeneous)",
        )),
        other => Err(err(
            n,
            format!("medium '{other}' is not supported (supported: homogeneous)"),
        )),
    }
}

/// Interior and exterior medium of a shape (indices into [`crate::scene::Scene::media`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShapeMedia {
    pub interior: Option<u32>,
    pub exterior: Option<u32>,
}

impl ShapeMedia {
    /// Whether crossing the surface can change the medium (Mitsuba: a medium is attached).
    #[inline]
    pub fn is_transition(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }
    /// The medium a ray leaving the surface in direction `d` enters: the exterior when `d` is on
    /// the side of the geometric normal `n_geo`, else the interior (Mitsuba's `target_medium`).
    #[inline]
    pub fn target(&self, n_geo: glam::Vec3, d: glam::Vec3) -> Option<u32> {
        if n_geo.dot(d) > 0.0 {
            self.exterior
        } else {
            self.interior
        }
    }
}

/// The media of a scene being built: declarations, per-shape attachments, the camera's medium.
#[derive(Debug, Default)]
pub struct SceneMedia {
    pub media: Vec<Medium>,
    /// id → index of top-level media.
    ids: Vec<(String, u32)>,
    pub shape_media: Vec<ShapeMedia>,
    pub camera_medium: Option<u32>,
    pub volpath: bool,
    /// Where the first medium was declared (for the error of a non-`volpath` integrator).
    first: Option<crate::core::Loc>,
}

impl SceneMedia {
    fn push(&mut self, n: &Node) -> Result<u32> {
        let m = medium_from_node(n)?;
        self.media.push(m);
        if self.first.is_none() {
            self.first = Some(n.loc.clone());
        }
        Ok(self.media.len() as u32 - 1)
    }

    /// A top-level `<medium id=…>`.
    pub fn declare(&mut self, n: &Node) -> Result<()> {
        let i = self.push(n)?;
        if let Some(id) = &n.id {
            self.ids.push((id.clone(), i));
        }
        Ok(())
    }

    fn lookup(&self, r: &Node) -> Result<u32> {
        let id = r.id.as_deref().unwrap_or_default();
        self.ids
            .iter()
            .find(|(k, _)| k == id)
            .map(|&(_, i)| i)
            .ok_or_else(|| {
                err(
                    r,
                    format!("'{id}' is not a medium declared before this point (a <ref name=\"{}\"> must name a top-level <medium id=…>)", r.name.as_deref().unwrap_or("")),
                )
            })
    }

    /// The media nested in or referenced from `n`: a shape's `interior`/`exterior` (when
    /// `shape`), or a sensor's medium (any name; returned second).
    pub fn attached(&mut self, n: &Node, shape: bool) -> Result<(ShapeMedia, Option<u32>)> {
        let mut sm = ShapeMedia::default();
        let mut cam = None;
        for c in &n.children {
            let is_medium_ref = c.tag == "ref"
                && (!shape || matches!(c.name.as_deref(), Some("interior" | "exterior")));
            let i = match c.tag.as_str() {
                "medium" => self.push(c)?,
                "ref" if is_medium_ref => self.lookup(c)?,
                _ => continue,
            };
            if shape {
                match c.name.as_deref() {
                    Some("interior") => sm.interior = Some(i),
                    Some("exterior") => sm.exterior = Some(i),
                    other => {
                        return Err(err(
                            c,
                            format!(
                                "a medium in a shape needs name=\"interior\" or name=\"exterior\", got {}",
                                other.map_or("none".to_string(), |o| format!("'{o}'"))
                            ),
                        ))
                    }
                }
            } else {
                if cam.is_some() {
                    return Err(err(c, "a sensor takes at most one medium"));
                }
                cam = Some(i);
            }
        }
        Ok((sm, cam))
    }

    /// Media are rendered by `volpath` only: Mitsuba 3's `path` silently ignores them, Specula
    /// refuses the scene instead.
    pub fn check_integrator(&self, root: &Node) -> Result<()> {
        match (&self.first, self.volpath) {
            (Some(at), false) => Err(SceneError::new(
                Some(root.loc.clone()),
                format!("the scene has a participating medium (declared at {at}) but its integrator is not 'volpath'; the 'path' integrator cannot render media (Mitsuba 3's would ignore them): use <integrator type=\"volpath\">"),
            )),
            _ => Ok(()),
        }
    }
}

/// Whether a BSDF is an index-matched, invisible boundary (`null`): `volpath` passes through
/// it without counting a bounce, and lets shadow rays through.
#[inline]
pub fn is_null_bsdf(b: &specula_bsdf::Bsdf) -> bool {
    matches!(b, specula_bsdf::Bsdf::Null(_))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn parse(body: &str) -> Result<Medium> {
        let text = format!("<scene version=\"3.0.0\">{body}</scene>");
        let root = crate::xml::parse_scene_str(&text, "<t>", Path::new("."), &[])?;
        medium_from_node(&root.children[0])
    }

    #[test]
    fn homogeneous_parameters_and_defaults() {
        let Medium::Homogeneous(m) = parse(r#"<medium type="homogeneous"/>"#).unwrap();
        assert_eq!(m.sigma_t, Rgb::splat(1.0));
        assert_eq!(m.albedo, Rgb::splat(0.75));
        assert!(m.sample_emitters);
        assert_eq!(m.phase, PhaseFunction::Isotropic);
        let Medium::Homogeneous(m) = parse(
            r#"<medium type="homogeneous"><rgb name="sigma_t" value="1, 2, 3"/><float name="scale" value="2"/>
            <volume type="constvolume" name="albedo"><rgb name="value" value="0.5, 0.25, 0"/></volume>
            <boolean name="sample_emitters" value="false"/>
            <phase type="blendphase"><float name="weight" value="0.25"/><phase type="hg"><float name="g" value="-0.2"/></phase><phase type="rayleigh"/></phase></medium>"#,
        )
        .unwrap();
        assert_eq!(m.sigma_t, Rgb([2.0, 4.0, 6.0]));
        assert_eq!(m.albedo, Rgb([0.5, 0.25, 0.0]));
        assert!(!m.sample_emitters);
        assert_eq!(m.phase.plugin_name(), "blendphase");
    }

    #[test]
    fn bad_media_are_errors_with_locations() {
        for (body, want) in [
            (
                r#"<medium type="homogeneous"><float name="sigma_s" value="1"/></medium>"#,
                "sigma_s",
            ),
            (
                r#"<medium type="homogeneous"><phase type="hg"><float name="g" value="1"/></phase></medium>"#,
                "g must",
            ),
            (
                r#"<medium type="homogeneous"><phase type="blendphase"><phase type="hg"/></phase></medium>"#,
                "two nested",
            ),
            (r#"<medium type="fog"/>"#, "not supported"),
            (
                r#"<medium type="homogeneous"><float name="albedo" value="2"/></medium>"#,
                "albedo",
            ),
            (
                r#"<medium type="homogeneous"><volume type="gridvolume" name="sigma_t"><string name="filename" value="x.vol"/></volume></medium>"#,
                "only its albedo",
            ),
            (
                r#"<medium type="homogeneous"><volume type="gridvolume" name="albedo"><string name="filename" value="x.vol"/></volume></medium>"#,
                "x.vol",
            ),
        ] {
            let e = parse(body).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("<t>:1:"), "{body}: {e}");
        }
    }
}
