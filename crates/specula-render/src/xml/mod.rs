//! The Mitsuba 3 XML scene reader.
//!
//! [`load_scene`] parses a scene file into a generic, fully resolved plugin tree of [`Node`]s:
//! `<default>` parameters and `$name` references are substituted (with command-line overrides
//! taking precedence), `<include>`d files are spliced in place, `<transform>` blocks are
//! evaluated to matrices, Mitsuba 0.6 scenes (`version` < 2.0.0) are upgraded the way Mitsuba 3
//! upgrades them, and every node and property remembers the `file:line:col` it came from.
//! `<ref>` elements stay in the tree (tag `"ref"`) for the scene builder to resolve.
//! `<spectrum>` values (constants, wavelength:value lists, `.spd` files, spectrum plugins) are
//! kept as [`Spectrum`]s and become RGB when read, by the rule of the parameter's use
//! ([`Node::rgb_opt`] for reflectances, [`Node::emission_rgb`] for emitters,
//! [`Node::color_opt`] with [`Usage::Unbounded`] for IOR-like values; see [`spectrum`]).
//!
//! The scene builder reads properties through the typed accessors on [`Node`] (which record
//! what was read) and finishes each plugin with [`Node::check_unused`], so that a misspelt or
//! unsupported parameter is an error rather than a silently ignored value.

mod parse;
pub mod spectrum;
mod transform;

#[cfg(test)]
mod tests;

#[cfg(test)]
mod resolver_tests;

use crate::core::{Loc, Result, SceneError};
use glam::{Mat4, Vec3};
use std::cell::Cell;
use std::fmt;

pub use parse::{load_scene, parse_scene_str};
pub use spectrum::{Spectrum, Usage};

/// The value of a property element.
#[derive(Clone, Debug, PartialEq)]
pub enum PropValue {
    /// `<float>`.
    Float(f64),
    /// `<integer>`.
    Int(i64),
    /// `<boolean>`.
    Bool(bool),
    /// `<string>`.
    Str(String),
    /// `<rgb>` (a single value is splatted to all three channels).
    Rgb([f32; 3]),
    /// `<spectrum>`: a constant, wavelength:value pairs (inline or from an `.spd` file) or a
    /// spectrum plugin (`blackbody`, `d65`, …); see [`spectrum`] for how each becomes RGB.
    Spectrum(Spectrum),
    /// `<point>`.
    Point(Vec3),
    /// `<vector>`.
    Vector(Vec3),
    /// `<transform>`: the composed matrix (column vectors, `p' = M · p`).
    Transform(Mat4),
}

impl PropValue {
    /// The XML element that produces this kind of value (`"float"`, `"rgb"`, …).
    pub fn type_name(&self) -> &'static str {
        match self {
            PropValue::Float(_) => "float",
            PropValue::Int(_) => "integer",
            PropValue::Bool(_) => "boolean",
            PropValue::Str(_) => "string",
            PropValue::Rgb(_) => "rgb",
            PropValue::Spectrum(_) => "spectrum",
            PropValue::Point(_) => "point",
            PropValue::Vector(_) => "vector",
            PropValue::Transform(_) => "transform",
        }
    }
}

impl fmt::Display for PropValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PropValue::Float(v) => write!(f, "{v}"),
            PropValue::Int(v) => write!(f, "{v}"),
            PropValue::Bool(v) => write!(f, "{v}"),
            PropValue::Str(v) => write!(f, "\"{v}\""),
            PropValue::Rgb([r, g, b]) => write!(f, "[{r}, {g}, {b}]"),
            PropValue::Spectrum(s) => write!(f, "{s}"),
            PropValue::Point(v) | PropValue::Vector(v) => write!(f, "[{}, {}, {}]", v.x, v.y, v.z),
            PropValue::Transform(_) => f.write_str("a 4x4 matrix"),
        }
    }
}

/// A named property of a plugin, with where it was written and whether the scene builder has
/// read it (see [`Node::check_unused`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Prop {
    pub name: String,
    pub value: PropValue,
    pub loc: Loc,
    used: Cell<bool>,
}

impl Prop {
    pub fn new(name: impl Into<String>, value: PropValue, loc: Loc) -> Self {
        Prop {
            name: name.into(),
            value,
            loc,
            used: Cell::new(false),
        }
    }
    /// Whether an accessor (or [`Prop::mark_used`]) has read this property.
    pub fn is_used(&self) -> bool {
        self.used.get()
    }
    pub fn mark_used(&self) {
        self.used.set(true);
    }
}

/// One element of the plugin tree: the `<scene>`, a plugin (`<shape>`, `<bsdf>`, …) or a
/// `<ref>`.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// `"scene"`, `"shape"`, `"bsdf"`, `"emitter"`, `"sensor"`, `"film"`, `"sampler"`,
    /// `"integrator"`, `"rfilter"`, `"texture"`, `"medium"`, `"phase"`, `"volume"` or `"ref"`.
    pub tag: String,
    /// The `type` attribute (`""` for the scene and for refs).
    pub plugin_type: String,
    /// The `id` attribute; for a ref, the id it refers to.
    pub id: Option<String>,
    /// The `name` attribute (e.g. `<texture name="reflectance">`, `<ref name="bsdf">`).
    pub name: Option<String>,
    /// Properties, in document order; names are unique within a node.
    pub props: Vec<Prop>,
    /// Nested plugins and refs, in document order (includes spliced in place).
    pub children: Vec<Node>,
    /// Where the element starts.
    pub loc: Loc,
}

impl Node {
    /// `shape 'sphere'`, `bsdf 'diffuse'`, `scene`, `ref 'white'`: how messages name this node.
    pub fn describe(&self) -> String {
        if self.tag == "ref" {
            format!("ref '{}'", self.id.as_deref().unwrap_or(""))
        } else if self.plugin_type.is_empty() {
            self.tag.clone()
        } else {
            format!("{} '{}'", self.tag, self.plugin_type)
        }
    }

    /// An error located at this node.
    pub fn error(&self, msg: impl Into<String>) -> SceneError {
        SceneError::new(Some(self.loc.clone()), msg)
    }

    /// The property called `name`, marking it as used.
    pub fn prop(&self, name: &str) -> Option<&Prop> {
        let p = self.props.iter().find(|p| p.name == name)?;
        p.mark_used();
        Some(p)
    }

    /// Whether a property called `name` exists (does not mark it as used).
    pub fn has(&self, name: &str) -> bool {
        self.props.iter().any(|p| p.name == name)
    }

    /// The nested plugin or ref with the `name` attribute `name`
    /// (e.g. `<texture name="reflectance">`).
    pub fn child_named(&self, name: &str) -> Option<&Node> {
        self.children
            .iter()
            .find(|c| c.name.as_deref() == Some(name))
    }

    /// The nested plugins and refs with the given tag (`"bsdf"`, `"ref"`, …).
    pub fn children_with_tag<'a>(&'a self, tag: &'a str) -> impl Iterator<Item = &'a Node> + 'a {
        self.children.iter().filter(move |c| c.tag == tag)
    }

    fn type_error(&self, p: &Prop, expected: &str) -> SceneError {
        SceneError::new(
            Some(p.loc.clone()),
            format!(
                "parameter '{}' of {}: expected {expected}, found {} ({})",
                p.name,
                self.describe(),
                p.value.type_name(),
                p.value
            ),
        )
    }

    /// A `<float>` (an `<integer>` is accepted and converted).
    pub fn float_opt(&self, name: &str) -> Result<Option<f32>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                PropValue::Float(v) => Ok(Some(v as f32)),
                PropValue::Int(v) => Ok(Some(v as f32)),
                _ => Err(self.type_error(p, "float")),
            },
        }
    }

    /// A `<float>` (or `<integer>`), `default` when absent.
    pub fn float(&self, name: &str, default: f32) -> Result<f32> {
        Ok(self.float_opt(name)?.unwrap_or(default))
    }

    /// An `<integer>`.
    pub fn int_opt(&self, name: &str) -> Result<Option<i64>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                PropValue::Int(v) => Ok(Some(v)),
                _ => Err(self.type_error(p, "integer")),
            },
        }
    }

    /// An `<integer>`, `default` when absent.
    pub fn int(&self, name: &str, default: i64) -> Result<i64> {
        Ok(self.int_opt(name)?.unwrap_or(default))
    }

    /// A `<boolean>`.
    pub fn bool_opt(&self, name: &str) -> Result<Option<bool>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                PropValue::Bool(v) => Ok(Some(v)),
                _ => Err(self.type_error(p, "boolean")),
            },
        }
    }

    /// A `<boolean>`, `default` when absent.
    pub fn bool(&self, name: &str, default: bool) -> Result<bool> {
        Ok(self.bool_opt(name)?.unwrap_or(default))
    }

    /// A `<string>`.
    pub fn string_opt(&self, name: &str) -> Result<Option<String>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                PropValue::Str(v) => Ok(Some(v.clone())),
                _ => Err(self.type_error(p, "string")),
            },
        }
    }

    /// A `<string>`, `default` when absent.
    pub fn string(&self, name: &str, default: &str) -> Result<String> {
        Ok(self
            .string_opt(name)?
            .unwrap_or_else(|| default.to_string()))
    }

    /// A colour read as a reflectance (Mitsuba's `get_texture`): `<rgb>`, `<float>` (grey) or
    /// `<spectrum>`, converted as [`Usage::Reflectance`] (wavelength lists clamped to [0, 1]).
    pub fn rgb_opt(&self, name: &str) -> Result<Option<[f32; 3]>> {
        self.color_opt(name, Usage::Reflectance)
    }

    /// A colour (see [`Node::rgb_opt`]), `default` when absent.
    pub fn rgb(&self, name: &str, default: [f32; 3]) -> Result<[f32; 3]> {
        Ok(self.rgb_opt(name)?.unwrap_or(default))
    }

    /// An emitter's radiance, intensity or irradiance (Mitsuba's `get_emissive_texture`):
    /// `<rgb>`, `<float>` or `<spectrum>` converted as [`Usage::Emission`] (not D65-weighted;
    /// a constant spectrum becomes v · XYZ→sRGB(1, 1, 1)); `default` when absent.
    pub fn emission_rgb(&self, name: &str, default: [f32; 3]) -> Result<[f32; 3]> {
        Ok(self.color_opt(name, Usage::Emission)?.unwrap_or(default))
    }

    /// A colour read the way `usage` says (the three accessors above, and
    /// [`Usage::Unbounded`] for IOR-like values).
    pub fn color_opt(&self, name: &str, usage: Usage) -> Result<Option<[f32; 3]>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match &p.value {
                PropValue::Rgb(v) => Ok(Some(*v)),
                PropValue::Spectrum(s) => s.to_rgb(usage).map(Some).map_err(|why| {
                    SceneError::new(
                        Some(p.loc.clone()),
                        format!("parameter '{}' of {}: {why}", p.name, self.describe()),
                    )
                }),
                PropValue::Float(v) => Ok(Some([*v as f32; 3])),
                _ => Err(self.type_error(p, "rgb, spectrum or float")),
            },
        }
    }

    /// A `<point>` (Mitsuba 3 does not distinguish `<point>` from `<vector>`; both are accepted).
    pub fn point_opt(&self, name: &str) -> Result<Option<Vec3>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                PropValue::Point(v) | PropValue::Vector(v) => Ok(Some(v)),
                _ => Err(self.type_error(p, "point")),
            },
        }
    }

    /// A `<point>` (or `<vector>`), `default` when absent.
    pub fn point(&self, name: &str, default: Vec3) -> Result<Vec3> {
        Ok(self.point_opt(name)?.unwrap_or(default))
    }

    /// A `<vector>` (a `<point>` is accepted too, as in Mitsuba 3).
    pub fn vector_opt(&self, name: &str) -> Result<Option<Vec3>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                PropValue::Point(v) | PropValue::Vector(v) => Ok(Some(v)),
                _ => Err(self.type_error(p, "vector")),
            },
        }
    }

    /// A `<vector>` (or `<point>`), `default` when absent.
    pub fn vector(&self, name: &str, default: Vec3) -> Result<Vec3> {
        Ok(self.vector_opt(name)?.unwrap_or(default))
    }

    /// A `<transform>`'s composed matrix.
    pub fn transform(&self, name: &str) -> Result<Option<Mat4>> {
        match self.prop(name) {
            None => Ok(None),
            Some(p) => match p.value {
                PropValue::Transform(m) => Ok(Some(m)),
                _ => Err(self.type_error(p, "transform")),
            },
        }
    }

    /// Marks every property as used (for a builder that forwards all of them elsewhere).
    pub fn mark_all_used(&self) {
        self.props.iter().for_each(Prop::mark_used);
    }

    /// Fails on the first property that no accessor has read and whose name is not in `valid`
    /// (the parameters this plugin accepts, read or not), naming it, the plugin and the valid
    /// parameters, at the property's location. Mitsuba 3 likewise rejects unreferenced
    /// properties, so a misspelt parameter never goes unnoticed.
    pub fn check_unused(&self, valid: &[&str]) -> Result<()> {
        let Some(p) = self
            .props
            .iter()
            .find(|p| !p.is_used() && !valid.contains(&p.name.as_str()))
        else {
            return Ok(());
        };
        let msg = if valid.is_empty() {
            format!(
                "unknown parameter '{}' for {}; it takes no parameters",
                p.name,
                self.describe()
            )
        } else {
            format!(
                "unknown parameter '{}' for {}; valid parameters: {}",
                p.name,
                self.describe(),
                valid.join(", ")
            )
        };
        Err(SceneError::new(Some(p.loc.clone()), msg))
    }
}
