//! Participating media (Mitsuba 3's `<medium>` and `<phase>` plugins).
//!
//! - [`homogeneous`]: the `homogeneous` medium (free-flight sampling, transmittance);
//! - [`heterogeneous`]: the `heterogeneous` medium (delta tracking, ratio tracking);
//! - [`volume`]: the `constvolume` and `gridvolume` volumes that parameterise them;
//! - [`phase`]: the `isotropic`, `hg`, `rayleigh` and `blendphase` phase functions.
//!
//! A medium is declared at the top level (`<medium type="homogeneous" id="fog">`), nested in
//! a shape as its `interior` or `exterior` (`<medium name="interior" …>`), referenced from a
//! shape (`<ref name="exterior" id="fog"/>`), or nested in / referenced from the sensor (the
//! camera is inside it). Media are rendered by the `volpath` integrator
//! ([`crate::volpath`]) and `volpathmis`; Specula's `path` refuses a scene with media.
//!
//! In spectral mode ([`crate::spectral`]) the coefficients are evaluated at the path's
//! wavelengths ([`spectral`]: how Mitsuba's spectral variants read rgb and float values and
//! RGB grids), and the integrators' hero channel is a wavelength's index.
//!
//! Deviations from Mitsuba: see the plugins' docs for per-parameter notes.

pub mod heterogeneous;
pub mod homogeneous;
pub mod phase;
pub mod spectral;
pub mod volume;

pub use heterogeneous::Heterogeneous;
pub use homogeneous::{FreeFlight, Homogeneous};
pub use phase::{PhaseFunction, PhaseSample};

use crate::core::{Result, SceneError};
use crate::sampler::Sampler;
use crate::xml::{Node, PropValue};
use specula_bsdf::{Rgb, Wavelengths};
use volume::Volume;

/// A participating medium.
#[derive(Clone, Debug, PartialEq)]
pub enum Medium {
    Homogeneous(Homogeneous),
    Heterogeneous(Heterogeneous),
}

impl Medium {
    #[inline]
    pub fn phase(&self) -> &PhaseFunction {
        match self {
            Medium::Homogeneous(m) => &m.phase,
            Medium::Heterogeneous(m) => &m.phase,
        }
    }
    /// Whether scattering events use next-event estimation (`sample_emitters`).
    #[inline]
    pub fn sample_emitters(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.sample_emitters,
            Medium::Heterogeneous(m) => m.sample_emitters,
        }
    }
    /// Samples where the ray `o + t·d` (unit `d`, t < `t_max`, possibly infinite) first
    /// scatters, with hero channel `channel` (a homogeneous medium takes one sample of `rng`,
    /// a heterogeneous one as many as delta tracking needs). `wl`: `None` in RGB mode, the
    /// path's wavelengths in spectral mode (`channel` is then a wavelength's index).
    #[inline]
    pub fn sample_free_flight<S: Sampler + ?Sized>(
        &self,
        o: glam::Vec3,
        d: glam::Vec3,
        t_max: f32,
        channel: usize,
        wl: Option<&Wavelengths>,
        rng: &mut S,
    ) -> FreeFlight {
        match self {
            Medium::Homogeneous(m) => m.sample_free_flight(o, d, t_max, channel, rng.next_1d(), wl),
            Medium::Heterogeneous(m) => m.sample_free_flight(o, d, t_max, channel, wl, rng),
        }
    }
    /// Transmittance along the segment `o + t·d`, 0 ≤ t < `dist` (possibly infinite): exact
    /// for a homogeneous medium (no sample taken), a ratio-tracking estimate otherwise. `wl`:
    /// as for [`Medium::sample_free_flight`].
    #[inline]
    pub fn transmittance<S: Sampler + ?Sized>(
        &self,
        o: glam::Vec3,
        d: glam::Vec3,
        dist: f32,
        wl: Option<&Wavelengths>,
        rng: &mut S,
    ) -> Rgb {
        match self {
            Medium::Homogeneous(m) => m.transmittance(dist, wl),
            Medium::Heterogeneous(m) => m.transmittance(o, d, dist, wl, rng),
        }
    }
    /// Spectral mode: upsamples the medium's coefficients once (see [`spectral`]); fails for
    /// a `raw` RGB grid, which has no spectrum.
    pub fn prepare_spectral(&mut self) -> std::result::Result<(), String> {
        match self {
            Medium::Homogeneous(m) => m.prepare_spectral(),
            Medium::Heterogeneous(m) => m.prepare_spectral(),
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

/// A medium parameter that may vary in space (Mitsuba's `props.volume`): a nested `<volume>`
/// (`constvolume` with `value` and `to_world`, or `gridvolume`) named `name`, or a float, rgb
/// or spectrum property (a constant over the unit cube), or `default`.
fn volume_from_param(n: &Node, name: &str, default: f32) -> Result<Volume> {
    if let Some(v) = n.children.iter().find(|c| c.name.as_deref() == Some(name)) {
        if v.tag != "volume" {
            return Err(err(
                v,
                format!("'{name}' of a medium must be a <volume>, a float or an rgb value"),
            ));
        }
        return match v.plugin_type.as_str() {
            "constvolume" => {
                let value = volume_param(v, "value", 1.0)?;
                let to_world = v.transform("to_world")?.unwrap_or(glam::Mat4::IDENTITY);
                v.check_unused(&["value", "to_world"])?;
                if !(value.is_finite() && value.min_component() >= 0.0) {
                    return Err(err(
                        v,
                        format!(
                            "constvolume: 'value' must be finite and non-negative, got {:?}",
                            value.0
                        ),
                    ));
                }
                Ok(Volume::Const {
                    value,
                    bbox: volume::unit_cube_bbox(to_world),
                    spec: None,
                })
            }
            "gridvolume" => Ok(Volume::Grid(std::sync::Arc::new(
                volume::GridVolume::from_node(v, &|f| std::path::PathBuf::from(f))?,
            ))),
            other => Err(err(
                v,
                format!("volume '{other}' is not supported (supported: constvolume, gridvolume)"),
            )),
        };
    }
    let value = volume_param(n, name, default)?;
    if !(value.is_finite() && value.min_component() >= 0.0) {
        return Err(err(
            n,
            format!(
                "'{name}' must be finite and non-negative, got {:?}",
                value.0
            ),
        ));
    }
    Ok(Volume::constant(value))
}

/// The nested `<phase>` of a medium (default isotropic); any other nested element but the
/// named `<volume>`s `volumes` is an error.
fn medium_phase(n: &Node, volumes: &[&str]) -> Result<PhaseFunction> {
    let mut phase = PhaseFunction::Isotropic;
    let mut n_phase = 0;
    for c in &n.children {
        match c.tag.as_str() {
            "phase" => {
                phase = phase_from_node(c)?;
                n_phase += 1;
            }
            "volume" if c.name.as_deref().is_some_and(|v| volumes.contains(&v)) => {}
            other => {
                return Err(err(
                    c,
                    format!(
                        "<{other}>{} cannot be nested in a {} medium",
                        c.name
                            .as_deref()
                            .map_or(String::new(), |v| format!(" named '{v}'")),
                        n.plugin_type
                    ),
                ))
            }
        }
    }
    if n_phase > 1 {
        return Err(err(n, "a medium takes at most one <phase>"));
    }
    Ok(phase)
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
        "heterogeneous" => {
            let sigma_t = volume_from_param(n, "sigma_t", 1.0)?;
            let albedo = volume_from_param(n, "albedo", 0.75)?;
            let scale = n.float("scale", 1.0)?;
            let sample_emitters = n.bool("sample_emitters", true)?;
            let _ = n.bool("has_spectral_extinction", true)?;
            if !(scale >= 0.0 && scale.is_finite()) {
                return Err(err(
                    n,
                    format!("scale must be finite and non-negative, got {scale}"),
                ));
            }
            if albedo.max() > 1.0 {
                return Err(err(
                    n,
                    format!(
                        "albedo must lie in [0, 1], its largest value is {}",
                        albedo.max()
                    ),
                ));
            }
            let majorant = scale * sigma_t.max();
            if !majorant.is_finite() {
                return Err(err(
                    n,
                    format!("scale × the largest sigma_t overflows ({majorant})"),
                ));
            }
            let phase = medium_phase(n, &["sigma_t", "albedo"])?;
            let depth = (majorant * (sigma_t.bbox().1 - sigma_t.bbox().0).length()) as f64;
            if depth > heterogeneous::MAX_MAJORANT_DEPTH as f64 {
                return Err(err(
                    n,
                    format!("the medium's majorant optical depth across its volume's box is {depth:.3e} (scale × the largest sigma_t × the box's diagonal; at most {:e}): delta tracking would take that many steps per ray", heterogeneous::MAX_MAJORANT_DEPTH),
                ));
            }
            n.check_unused(&[
                "sigma_t",
                "albedo",
                "scale",
                "sample_emitters",
                "has_spectral_extinction",
            ])?;
            let mut m = Heterogeneous::new(sigma_t, albedo, scale, phase);
            m.sample_emitters = sample_emitters;
            Ok(Medium::Heterogeneous(m))
        }
        other => Err(err(
            n,
            format!("medium '{other}' is not supported (supported: homogeneous, heterogeneous)"),
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

    /// Media are rendered by `volpath` (or `volpathmis`) only: Mitsuba 3's `path` silently ignores them, Specula
    /// refuses the scene instead.
    pub fn check_integrator(&self, root: &Node) -> Result<()> {
        match (&self.first, self.volpath) {
            (Some(at), false) => Err(SceneError::new(
                Some(root.loc.clone()),
                format!("the scene has a participating medium (declared at {at}) but its integrator is not 'volpath' (or 'volpathmis'); the 'path' integrator cannot render media (Mitsuba 3's would ignore them): use <integrator type=\"volpath\">"),
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
        let Medium::Homogeneous(m) = parse(r#"<medium type="homogeneous"/>"#).unwrap() else {
            panic!("not homogeneous")
        };
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
        .unwrap() else {
            panic!("not homogeneous")
        };
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

    /// Writes a `.vol` file (x fastest) into the temp directory.
    fn write_vol(name: &str, res: [i32; 3], ch: i32, data: &[f32]) -> std::path::PathBuf {
        let mut b = b"VOL\x03".to_vec();
        for v in [1, res[0], res[1], res[2], ch] {
            b.extend(v.to_le_bytes());
        }
        for v in [0f32, 0., 0., 1., 1., 1.].iter().chain(data) {
            b.extend(v.to_le_bytes());
        }
        let p =
            std::env::temp_dir().join(format!("specula-media-{}-{name}.vol", std::process::id()));
        std::fs::write(&p, b).unwrap();
        p
    }

    #[test]
    fn heterogeneous_parameters_and_defaults() {
        let Medium::Heterogeneous(m) = parse(r#"<medium type="heterogeneous"/>"#).unwrap() else {
            panic!("not heterogeneous")
        };
        // Mitsuba: sigma_t 1 and albedo 0.75 as constvolumes over the unit cube
        assert_eq!(m.sigma_t, Volume::constant(Rgb::splat(1.0)));
        assert_eq!(m.albedo, Volume::constant(Rgb::splat(0.75)));
        assert_eq!((m.scale, m.majorant), (1.0, 1.0));
        assert_eq!(m.bbox, (glam::Vec3::ZERO, glam::Vec3::ONE));
        assert!(m.sample_emitters);
        assert_eq!(m.phase, PhaseFunction::Isotropic);
        let grid = write_vol("params", [2, 1, 1], 3, &[0.5, 1.0, 2.0, 4.0, 0.0, 1.0]);
        let body = format!(
            r#"<medium type="heterogeneous">
            <volume type="gridvolume" name="sigma_t"><string name="filename" value="{}"/>
                <transform name="to_world"><rotate z="1" angle="45"/><scale value="2"/></transform></volume>
            <volume type="constvolume" name="albedo"><rgb name="value" value="0.5, 0.25, 0"/></volume>
            <float name="scale" value="3"/><boolean name="sample_emitters" value="false"/>
            <boolean name="has_spectral_extinction" value="false"/>
            <phase type="hg"><float name="g" value="0.3"/></phase></medium>"#,
            grid.display()
        );
        let Medium::Heterogeneous(m) = parse(&body).unwrap() else {
            panic!("not heterogeneous")
        };
        // the majorant is scale × the grid's largest value over all channels
        assert_eq!(m.majorant, 12.0);
        // the world box of the rotated, scaled unit cube (Mitsuba 3.9.1 prints
        // [-1.41421, 0, 0] – [1.41421, 2.82843, 2])
        let (lo, hi) = m.bbox;
        let r2 = 2f32.sqrt();
        for (a, b) in [(lo, [-r2, 0.0, 0.0]), (hi, [r2, 2.0 * r2, 2.0])] {
            assert!(
                (a - glam::Vec3::from(b)).abs().max_element() < 1e-4,
                "{lo} {hi}"
            );
        }
        assert_eq!(m.albedo.eval(glam::Vec3::ZERO), Rgb::new(0.5, 0.25, 0.0));
        assert!(!m.sample_emitters);
        assert_eq!(m.phase, PhaseFunction::HenyeyGreenstein { g: 0.3 });
        let Medium::Heterogeneous(m) = parse(
            r#"<medium type="heterogeneous"><rgb name="sigma_t" value="1, 2, 3"/><float name="albedo" value="0.5"/></medium>"#,
        )
        .unwrap() else {
            panic!("not heterogeneous")
        };
        assert_eq!(m.majorant, 3.0);
        assert_eq!(m.albedo, Volume::constant(Rgb::splat(0.5)));
        std::fs::remove_file(grid).ok();
    }

    #[test]
    fn bad_heterogeneous_media_are_errors_with_locations() {
        let nan = write_vol("nan", [2, 1, 1], 1, &[1.0, f32::NAN]);
        let neg = write_vol("neg", [1, 1, 2], 1, &[1.0, -0.5]);
        let two = write_vol("two", [1, 1, 1], 2, &[1.0, 0.5]);
        let high = write_vol("high", [1, 1, 1], 1, &[1.5]);
        let grid = |name: &str, p: &std::path::Path| {
            format!(
                r#"<medium type="heterogeneous"><volume type="gridvolume" name="{name}"><string name="filename" value="{}"/></volume></medium>"#,
                p.display()
            )
        };
        for (body, want) in [
            (grid("sigma_t", Path::new("missing.vol")), "missing.vol".to_string()),
            (grid("sigma_t", &nan), "finite and non-negative".into()),
            (grid("sigma_t", &neg), "finite and non-negative".into()),
            (grid("sigma_t", &two), "channels".into()),
            (grid("albedo", &high), "albedo must lie in [0, 1]".into()),
            (
                r#"<medium type="heterogeneous"><float name="sigma_t" value="-1"/></medium>"#.into(),
                "sigma_t".into(),
            ),
            (
                r#"<medium type="heterogeneous"><rgb name="sigma_t" value="1, nan, 1"/></medium>"#.into(),
                "sigma_t".into(),
            ),
            (
                r#"<medium type="heterogeneous"><volume type="constvolume" name="sigma_t"><float name="value" value="-2"/></volume></medium>"#.into(),
                "constvolume".into(),
            ),
            (
                r#"<medium type="heterogeneous"><float name="scale" value="-1"/></medium>"#.into(),
                "scale".into(),
            ),
            (
                r#"<medium type="heterogeneous"><float name="density" value="1"/></medium>"#.into(),
                "density".into(),
            ),
            (
                r#"<medium type="heterogeneous"><float name="sigma_t" value="1e4"/><float name="scale" value="1e3"/></medium>"#.into(),
                "optical depth".into(),
            ),
            (
                r#"<medium type="heterogeneous"><volume type="gridvolume" name="sigma_t"/></medium>"#.into(),
                "filename".into(),
            ),
            (
                r#"<medium type="heterogeneous"><volume type="checker" name="sigma_t"/></medium>"#.into(),
                "not supported".into(),
            ),
            (
                r#"<medium type="heterogeneous"><volume type="constvolume" name="density"/></medium>"#.into(),
                "named 'density'".into(),
            ),
            (
                r#"<medium type="heterogeneous"><phase type="isotropic"/><phase type="isotropic"/></medium>"#.into(),
                "at most one".into(),
            ),
        ] {
            let e = parse(&body).unwrap_err().to_string();
            assert!(e.contains(&want) && e.contains("<t>:1:"), "{body}: {e}");
        }
        for p in [nan, neg, two, high] {
            std::fs::remove_file(p).ok();
        }
    }
}
