//! Plugin parameters as a scene file or a command line gives them, before they become a model.
//!
//! The renderer's XML loader and the spec-string parser ([`crate::spec`]) both fill a
//! [`Props`]; [`crate::build::build_bsdf`] consumes it. Every parameter remembers where it came
//! from (e.g. `scene.xml:12:5`), and a parameter that no model reads is an error.

use crate::bsdf::{FloatParam, SpectralCurve, SpectrumParam, Texture};
use crate::models::Bsdf;
use crate::spectrum::Spectrum;
use std::cell::Cell;
use std::fmt;
use std::sync::Arc;

/// A parameter value.
#[derive(Clone, Debug)]
pub enum Value {
    Float(f64),
    Int(i64),
    Bool(bool),
    Str(String),
    Rgb(Spectrum),
    Texture(Arc<dyn Texture>),
    /// A spectrum known at every wavelength (a scene file's `<spectrum>` list, `.spd` file,
    /// blackbody, …): `rgb` in RGB mode, `curve` in spectral mode (a colour parameter reads
    /// it as [`SpectrumParam::Spectral`]).
    Spectral {
        rgb: Spectrum,
        curve: Arc<dyn SpectralCurve>,
    },
}

impl Value {
    pub fn type_name(&self) -> &'static str {
        match self {
            Value::Float(_) => "float",
            Value::Int(_) => "integer",
            Value::Bool(_) => "boolean",
            Value::Str(_) => "string",
            Value::Rgb(_) => "rgb",
            Value::Texture(_) => "texture",
            Value::Spectral { .. } => "spectrum",
        }
    }
}

/// A build error: what went wrong and, when known, where (`file:line:col`).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct BuildError {
    pub loc: Option<String>,
    pub msg: String,
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(l) => write!(f, "{l}: {}", self.msg),
            None => f.write_str(&self.msg),
        }
    }
}

impl BuildError {
    pub fn new(loc: Option<String>, msg: impl Into<String>) -> Self {
        BuildError {
            loc,
            msg: msg.into(),
        }
    }
}

#[derive(Debug)]
struct Prop {
    name: String,
    value: Value,
    loc: Option<String>,
    used: Cell<bool>,
}

/// The parameters and nested BSDFs of one plugin instance.
#[derive(Debug)]
pub struct Props {
    pub plugin: String,
    /// Where the plugin was declared.
    pub loc: Option<String>,
    props: Vec<Prop>,
    /// Nested BSDFs in declaration order, with where each was declared.
    pub children: Vec<(Bsdf, Option<String>)>,
}

impl Props {
    pub fn new(plugin: impl Into<String>, loc: Option<String>) -> Self {
        Props {
            plugin: plugin.into(),
            loc,
            props: Vec::new(),
            children: Vec::new(),
        }
    }

    /// Add a parameter; a name given twice is an error.
    pub fn set(&mut self, name: &str, value: Value, loc: Option<String>) -> Result<(), BuildError> {
        if let Some(p) = self.props.iter().find(|p| p.name == name) {
            return Err(BuildError::new(
                loc,
                format!(
                    "parameter '{name}' of '{}' is given twice (first at {})",
                    self.plugin,
                    p.loc.as_deref().unwrap_or("?")
                ),
            ));
        }
        self.props.push(Prop {
            name: name.to_string(),
            value,
            loc,
            used: Cell::new(false),
        });
        Ok(())
    }

    pub fn add_child(&mut self, bsdf: Bsdf, loc: Option<String>) {
        self.children.push((bsdf, loc));
    }

    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    fn get(&self, name: &str) -> Option<&Prop> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.used.set(true);
        Some(p)
    }

    fn err(&self, p: &Prop, msg: String) -> BuildError {
        BuildError::new(p.loc.clone().or_else(|| self.loc.clone()), msg)
    }

    fn type_err(&self, p: &Prop, expected: &str) -> BuildError {
        self.err(
            p,
            format!(
                "parameter '{}' of '{}' must be {expected}, got {}",
                p.name,
                self.plugin,
                p.value.type_name()
            ),
        )
    }

    fn finite(&self, p: &Prop, v: f64) -> Result<f64, BuildError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(
                p,
                format!(
                    "parameter '{}' of '{}' is not a finite number ({v})",
                    p.name, self.plugin
                ),
            ))
        }
    }

    /// A float (integers accepted).
    pub fn float(&self, name: &str, default: f32) -> Result<f32, BuildError> {
        match self.get(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                Value::Float(v) => Ok(self.finite(p, *v)? as f32),
                Value::Int(v) => Ok(*v as f32),
                _ => Err(self.type_err(p, "a float")),
            },
        }
    }

    /// A float that must be given.
    pub fn float_required(&self, name: &str) -> Result<f32, BuildError> {
        if !self.has(name) {
            return Err(BuildError::new(
                self.loc.clone(),
                format!("'{}' needs parameter '{name}'", self.plugin),
            ));
        }
        self.float(name, 0.0)
    }

    pub fn bool(&self, name: &str, default: bool) -> Result<bool, BuildError> {
        match self.get(name) {
            None => Ok(default),
            Some(p) => match &p.value {
                Value::Bool(v) => Ok(*v),
                _ => Err(self.type_err(p, "a boolean (true or false)")),
            },
        }
    }

    pub fn string(&self, name: &str, default: &str) -> Result<String, BuildError> {
        match self.get(name) {
            None => Ok(default.to_string()),
            Some(p) => match &p.value {
                Value::Str(v) => Ok(v.clone()),
                _ => Err(self.type_err(p, "a string")),
            },
        }
    }

    /// One of a fixed set of strings.
    pub fn choice(&self, name: &str, default: &str, valid: &[&str]) -> Result<String, BuildError> {
        let v = self.string(name, default)?;
        if valid.contains(&v.as_str()) {
            Ok(v)
        } else {
            let p = self.get(name).expect("choice of a given parameter");
            Err(self.err(
                p,
                format!(
                    "parameter '{name}' of '{}' is '{v}'; valid values: {}",
                    self.plugin,
                    valid.join(", ")
                ),
            ))
        }
    }

    /// A colour: a float (grey), an rgb triple, a texture or a spectrum
    /// ([`Value::Spectral`]).
    pub fn spectrum(&self, name: &str, default: f32) -> Result<SpectrumParam, BuildError> {
        match self.get(name) {
            None => Ok(SpectrumParam::Const(Spectrum::splat(default))),
            Some(p) => match &p.value {
                Value::Float(v) => Ok(SpectrumParam::Const(Spectrum::splat(
                    self.finite(p, *v)? as f32
                ))),
                Value::Int(v) => Ok(SpectrumParam::Const(Spectrum::splat(*v as f32))),
                Value::Rgb(c) => {
                    if c.is_finite() {
                        Ok(SpectrumParam::Const(*c))
                    } else {
                        Err(self.err(
                            p,
                            format!(
                                "parameter '{name}' of '{}' has a non-finite channel",
                                self.plugin
                            ),
                        ))
                    }
                }
                Value::Texture(t) => Ok(SpectrumParam::Texture(t.clone())),
                Value::Spectral { rgb, curve } if rgb.is_finite() => Ok(SpectrumParam::Spectral {
                    rgb: *rgb,
                    curve: curve.clone(),
                }),
                Value::Spectral { .. } => Err(self.err(
                    p,
                    format!(
                        "parameter '{name}' of '{}' has a non-finite channel",
                        self.plugin
                    ),
                )),
                _ => Err(self.type_err(p, "a float, an rgb colour or a texture")),
            },
        }
    }

    /// A scalar that may be textured.
    pub fn float_param(&self, name: &str, default: f32) -> Result<FloatParam, BuildError> {
        match self.get(name).map(|p| &p.value) {
            Some(Value::Texture(t)) => Ok(FloatParam::Texture(t.clone())),
            // numbers (and type errors) are handled by `float`
            _ => Ok(FloatParam::Const(self.float(name, default)?)),
        }
    }

    /// An index of refraction: a number or a material name (`water`, `bk7`, …).
    pub fn ior(&self, name: &str, default: &str) -> Result<f32, BuildError> {
        let lookup = |n: &str, p: Option<&Prop>| {
            crate::data::lookup_ior(n).ok_or_else(|| {
                let valid: Vec<&str> = crate::data::NAMED_IORS.iter().map(|(n, _)| *n).collect();
                BuildError::new(
                    p.and_then(|p| p.loc.clone()).or_else(|| self.loc.clone()),
                    format!(
                        "unknown index of refraction '{n}' for '{name}'; known: {}",
                        valid.join(", ")
                    ),
                )
            })
        };
        let v = match self.get(name) {
            None => lookup(default, None)?,
            Some(p) => match &p.value {
                Value::Float(v) => self.finite(p, *v)? as f32,
                Value::Int(v) => *v as f32,
                Value::Str(s) => lookup(s, Some(p))?,
                _ => return Err(self.type_err(p, "a float or a material name")),
            },
        };
        if v <= 0.0 {
            let p = self.get(name);
            return Err(BuildError::new(
                p.and_then(|p| p.loc.clone()).or_else(|| self.loc.clone()),
                format!("'{name}' of '{}' must be positive, got {v}", self.plugin),
            ));
        }
        Ok(v)
    }

    /// Every texture-valued parameter whatever its name, in declaration order (for plugins
    /// that take one nested texture of any name, like Mitsuba's `bumpmap`), each marked used:
    /// (name, texture, where it was given).
    pub fn textures(&self) -> Vec<(String, Arc<dyn Texture>, Option<String>)> {
        self.props
            .iter()
            .filter_map(|p| match &p.value {
                Value::Texture(t) => {
                    p.used.set(true);
                    Some((p.name.clone(), t.clone(), p.loc.clone()))
                }
                _ => None,
            })
            .collect()
    }

    /// Error out on any parameter that was never read.
    pub fn finish(&self, valid: &[&str]) -> Result<(), BuildError> {
        if let Some(p) = self.props.iter().find(|p| !p.used.get()) {
            return Err(self.err(
                p,
                format!(
                    "unknown parameter '{}' for plugin '{}'; valid parameters: {}",
                    p.name,
                    self.plugin,
                    valid.join(", ")
                ),
            ));
        }
        Ok(())
    }
}
