//! Parsing: XML → [`Node`] tree, with parameter substitution, includes, transforms and the
//! Mitsuba 0.6 upgrade.

use super::transform as xf;
use super::{Node, Prop, PropValue};
use crate::core::{Loc, Result, SceneError};
use glam::{DMat4, DVec3};
use roxmltree::{Document, ParsingOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Mitsuba 3's limit on nested `<include>`s.
const MAX_INCLUDE_DEPTH: usize = 15;
/// The deepest nesting of plugin elements (`<bsdf>` in `<bsdf>` in `<shape>` …, counted across
/// includes) a scene may have. Real scenes stay below 10; the limit keeps every recursive
/// pass over the scene tree (parsing, building, dropping it) far from the end of the stack.
pub const MAX_NESTING_DEPTH: usize = 64;

/// Elements that become plugin nodes.
const PLUGIN_TAGS: &[&str] = &[
    "shape",
    "bsdf",
    "texture",
    "emitter",
    "sensor",
    "film",
    "rfilter",
    "sampler",
    "integrator",
    "medium",
    "phase",
    "volume",
];
/// Elements that become properties.
const PROPERTY_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];
/// Other elements valid inside the scene or a plugin.
const OTHER_TAGS: &[&str] = &["ref", "default", "include"];
/// Elements valid only inside `<transform>`.
const TRANSFORM_OPS: &[&str] = &["translate", "rotate", "scale", "lookat", "matrix"];

/// Parses the scene file at `path`. `overrides` are `-D name=value` pairs that replace the
/// scene's `<default>`s; naming a parameter the scene neither declares nor uses is an error.
/// Locations name the file as `path` is written.
pub fn load_scene(path: &Path, overrides: &[(String, String)]) -> Result<Node> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::file(path, e))?;
    let base_dir = path.parent().unwrap_or(Path::new(""));
    let label = path.display().to_string();
    parse_main(&text, &label, base_dir, overrides, Some(path))
}

/// Parses scene text; `file_label` names it in locations, and `<include>`s resolve against
/// `base_dir`.
pub fn parse_scene_str(
    text: &str,
    file_label: &str,
    base_dir: &Path,
    overrides: &[(String, String)],
) -> Result<Node> {
    parse_main(text, file_label, base_dir, overrides, None)
}

fn parse_main(
    text: &str,
    label: &str,
    base_dir: &Path,
    overrides: &[(String, String)],
    main_path: Option<&Path>,
) -> Result<Node> {
    let mut parser = Parser::new(overrides, base_dir)?;
    if let Some(p) = main_path {
        parser.include_stack.push(canonical(p));
    }
    let doc = parse_xml(text, label)?;
    let root = doc.root_element();
    let root_loc = loc_of(&doc, label, root);
    let tag = root.tag_name().name();
    if tag != "scene" {
        return Err(SceneError::new(
            Some(root_loc),
            format!(
                "the root element must be <scene version=\"3.0.0\">, found <{tag}> \
                 (Specula renders whole scenes, not single plugins)"
            ),
        ));
    }
    let upgrade = parser.read_version(&doc, label, root, true)?;
    let ctx = FileCtx {
        doc: &doc,
        label: label.to_string(),
        dir: base_dir.to_path_buf(),
        upgrade,
    };
    let e = parser.elem(&ctx, root)?;
    e.check_attrs(&["version", "type", "id"])?;
    if let Some(t) = e.get("type") {
        if t != "scene" {
            return Err(e.err(format!("<scene> has type=\"{t}\"; only \"scene\" is valid")));
        }
    }
    let mut node = Node {
        tag: "scene".into(),
        plugin_type: String::new(),
        id: e.get("id").map(str::to_string),
        name: None,
        props: Vec::new(),
        children: Vec::new(),
        loc: e.loc.clone(),
    };
    parser.children(&ctx, root, &mut node)?;
    parser.check_overrides(&root_loc)?;
    Ok(node)
}

fn canonical(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
}

fn parse_xml<'i>(text: &'i str, label: &str) -> Result<Document<'i>> {
    let opts = ParsingOptions {
        allow_dtd: true,
        ..ParsingOptions::default()
    };
    Document::parse_with_options(text, opts).map_err(|e| {
        let pos = e.pos();
        let msg = e.to_string().replace(&format!(" at {pos}"), "");
        SceneError::new(
            Some(Loc {
                file: label.to_string(),
                line: pos.row,
                col: pos.col,
            }),
            format!("malformed XML: {msg}"),
        )
    })
}

fn loc_of(doc: &Document, label: &str, n: roxmltree::Node) -> Loc {
    let p = doc.text_pos_at(n.range().start);
    Loc {
        file: label.to_string(),
        line: p.row,
        col: p.col,
    }
}

/// Mitsuba 3's upgrade of 0.6 property names: a run of capitals directly after a lower-case
/// letter becomes `_` plus the run in lower case (`maxDepth` → `max_depth`, `intIOR` →
/// `int_ior`, `toWorld` → `to_world`); anything else is kept (`XYZabc`, `a2B`).
pub(crate) fn to_snake_case(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 4);
    let (mut prev_lower, mut in_run) = (false, false);
    for c in s.chars() {
        if c.is_ascii_uppercase() {
            if prev_lower {
                out.push('_');
                out.push(c.to_ascii_lowercase());
                in_run = true;
            } else if in_run {
                out.push(c.to_ascii_lowercase());
            } else {
                out.push(c);
            }
            prev_lower = false;
        } else {
            in_run = false;
            prev_lower = c.is_ascii_lowercase();
            out.push(c);
        }
    }
    out
}

/// A scene parameter: from `-D` (override) and/or a `<default>`.
struct Param {
    name: String,
    value: String,
    from_override: bool,
    /// Declared by a `<default>`.
    declared: bool,
    /// Referenced by a `$name`.
    referenced: bool,
}

struct Parser {
    params: Vec<Param>,
    /// Plugin ids seen so far, with where.
    ids: HashMap<String, Loc>,
    /// Canonical paths of the files being parsed (cycle detection).
    include_stack: Vec<PathBuf>,
    /// The main scene's directory: includes fall back to it, as Mitsuba's file resolver does.
    main_dir: PathBuf,
    /// Plugin elements open around the one being parsed (see [`MAX_NESTING_DEPTH`]).
    depth: usize,
}

/// The file being parsed.
struct FileCtx<'a, 'i> {
    doc: &'a Document<'i>,
    label: String,
    dir: PathBuf,
    /// Whether to apply the Mitsuba 0.6 → 3 upgrade (`version` < 2.0.0).
    upgrade: bool,
}

/// An element with its tag (upgraded) and attributes (substituted, upgraded).
struct Elem {
    tag: String,
    loc: Loc,
    attrs: Vec<(String, String)>,
}

impl Elem {
    fn err(&self, msg: impl Into<String>) -> SceneError {
        SceneError::new(Some(self.loc.clone()), msg)
    }

    fn get(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    fn req(&self, name: &str) -> Result<&str> {
        self.get(name).ok_or_else(|| {
            self.err(format!(
                "missing required attribute '{name}' in <{}>",
                self.tag
            ))
        })
    }

    /// `<float name="radius">`, `<rotate>`: how messages name this element.
    fn describe(&self) -> String {
        match self.get("name") {
            Some(n) => format!("<{} name=\"{n}\">", self.tag),
            None => format!("<{}>", self.tag),
        }
    }

    fn check_attrs(&self, allowed: &[&str]) -> Result<()> {
        for (k, _) in &self.attrs {
            if !allowed.contains(&k.as_str()) {
                return Err(self.err(format!(
                    "unexpected attribute '{k}' in <{}>; valid attributes: {}",
                    self.tag,
                    allowed.join(", ")
                )));
            }
        }
        Ok(())
    }

    fn num(&self, attr: &str, s: &str) -> Result<f64> {
        let t = s.trim();
        match t.parse::<f64>() {
            Ok(v) if !v.is_nan() => Ok(v),
            _ => Err(self.err(format!(
                "invalid {attr}=\"{s}\" in {}: expected a number",
                self.describe()
            ))),
        }
    }

    fn req_num(&self, attr: &str) -> Result<f64> {
        self.num(attr, self.req(attr)?)
    }

    /// A list of numbers separated by commas and/or whitespace.
    fn list(&self, attr: &str, s: &str) -> Result<Vec<f64>> {
        s.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                t.parse::<f64>()
                    .ok()
                    .filter(|v| !v.is_nan())
                    .ok_or_else(|| {
                        self.err(format!(
                            "invalid {attr}=\"{s}\" in {}: '{t}' is not a number",
                            self.describe()
                        ))
                    })
            })
            .collect()
    }

    /// Three numbers (or one, splatted).
    fn vec3(&self, attr: &str, s: &str) -> Result<DVec3> {
        let v = self.list(attr, s)?;
        match v.len() {
            1 => Ok(DVec3::splat(v[0])),
            3 => Ok(DVec3::new(v[0], v[1], v[2])),
            n => Err(self.err(format!(
                "invalid {attr}=\"{s}\" in {}: expected 1 or 3 numbers, found {n}",
                self.describe()
            ))),
        }
    }

    /// A vector given either as one of `list_attrs` (`value="x, y, z"`) or as `x=`/`y=`/`z=`
    /// attributes, missing components taking `default`. `None` when nothing is given.
    fn xyz(&self, list_attrs: &[&str], default: f64) -> Result<Option<DVec3>> {
        let given: Vec<&&str> = list_attrs
            .iter()
            .filter(|a| self.get(a).is_some())
            .collect();
        let has_xyz = ["x", "y", "z"].iter().any(|a| self.get(a).is_some());
        match given.as_slice() {
            [] if !has_xyz => Ok(None),
            [] => {
                let c = |a: &str| self.get(a).map_or(Ok(default), |s| self.num(a, s));
                Ok(Some(DVec3::new(c("x")?, c("y")?, c("z")?)))
            }
            [a] if !has_xyz => Ok(Some(self.vec3(a, self.get(a).unwrap_or_default())?)),
            [a] => Err(self.err(format!(
                "<{}> cannot mix the '{a}' attribute with x=/y=/z= attributes",
                self.tag
            ))),
            _ => Err(self.err(format!(
                "<{}> cannot have both {} attributes",
                self.tag,
                given
                    .iter()
                    .map(|a| format!("'{a}'"))
                    .collect::<Vec<_>>()
                    .join(" and ")
            ))),
        }
    }
}

impl Parser {
    fn new(overrides: &[(String, String)], main_dir: &Path) -> Result<Self> {
        let mut params: Vec<Param> = Vec::new();
        for (name, value) in overrides {
            if name.is_empty() || name.contains('$') {
                return Err(SceneError::new(
                    None,
                    format!("invalid parameter name '{name}' in override '{name}={value}'"),
                ));
            }
            match params.iter_mut().find(|p| &p.name == name) {
                Some(p) => p.value = value.clone(),
                None => params.push(Param {
                    name: name.clone(),
                    value: value.clone(),
                    from_override: true,
                    declared: false,
                    referenced: false,
                }),
            }
        }
        Ok(Parser {
            params,
            ids: HashMap::new(),
            include_stack: Vec::new(),
            main_dir: main_dir.to_path_buf(),
            depth: 0,
        })
    }

    fn declared_list(&self) -> String {
        let names: Vec<&str> = self
            .params
            .iter()
            .filter(|p| p.declared)
            .map(|p| p.name.as_str())
            .collect();
        if names.is_empty() {
            "the scene declares no parameters".into()
        } else {
            format!("declared parameters: {}", names.join(", "))
        }
    }

    /// Every override must name a parameter the scene declares (or at least uses).
    fn check_overrides(&self, root_loc: &Loc) -> Result<()> {
        match self
            .params
            .iter()
            .find(|p| p.from_override && !p.declared && !p.referenced)
        {
            None => Ok(()),
            Some(p) => Err(SceneError::new(
                Some(root_loc.clone()),
                format!(
                    "parameter '{}' given as an override (-D {}={}) is not declared by the \
                     scene; {}",
                    p.name,
                    p.name,
                    p.value,
                    self.declared_list()
                ),
            )),
        }
    }

    /// Replaces `$name` (and `${name}`) by parameter values. Like Mitsuba, `$name` matches the
    /// longest parameter name the text continues with (`$spp_x` with only `spp` declared is
    /// `spp`'s value followed by `_x`).
    fn subst(&mut self, s: &str, attr: &str, tag: &str, loc: &Loc) -> Result<String> {
        if !s.contains('$') {
            return Ok(s.to_string());
        }
        let undefined = |parser: &Parser, name: &str| {
            let hint = if name.is_empty() {
                "a parameter name must follow '$'".to_string()
            } else {
                format!(
                    "declare it with <default name=\"{name}\" value=\"...\"/> before its use, \
                     or pass -D {name}=VALUE"
                )
            };
            let known: Vec<&str> = parser.params.iter().map(|p| p.name.as_str()).collect();
            let known = if known.is_empty() {
                "no parameters are defined".to_string()
            } else {
                format!("defined parameters: {}", known.join(", "))
            };
            SceneError::new(
                Some(loc.clone()),
                format!(
                    "undefined parameter '${name}' in {attr}=\"{s}\" of <{tag}>: {hint} \
                     ({known})"
                ),
            )
        };
        let mut out = String::with_capacity(s.len());
        let mut rest = s;
        while let Some(i) = rest.find('$') {
            out.push_str(&rest[..i]);
            let after = &rest[i + 1..];
            let (idx, consumed) = if let Some(braced) = after.strip_prefix('{') {
                let Some(end) = braced.find('}') else {
                    return Err(SceneError::new(
                        Some(loc.clone()),
                        format!("unterminated '${{' in {attr}=\"{s}\" of <{tag}>"),
                    ));
                };
                let name = &braced[..end];
                match self.params.iter().position(|p| p.name == name) {
                    Some(idx) => (idx, end + 2),
                    None => return Err(undefined(self, name)),
                }
            } else {
                let best = self
                    .params
                    .iter()
                    .enumerate()
                    .filter(|(_, p)| after.starts_with(p.name.as_str()))
                    .max_by_key(|(_, p)| p.name.len());
                match best {
                    Some((idx, p)) => (idx, p.name.len()),
                    None => {
                        let name: String = after
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        return Err(undefined(self, &name));
                    }
                }
            };
            let p = &mut self.params[idx];
            p.referenced = true;
            out.push_str(&p.value);
            rest = &after[consumed..];
        }
        out.push_str(rest);
        Ok(out)
    }

    /// Reads an element: tag and attributes, substituted and (for 0.6 scenes) upgraded.
    fn elem(&mut self, ctx: &FileCtx, n: roxmltree::Node) -> Result<Elem> {
        let loc = loc_of(ctx.doc, &ctx.label, n);
        let raw_tag = n.tag_name().name();
        let tag = if ctx.upgrade && raw_tag == "lookAt" {
            "lookat"
        } else {
            raw_tag
        }
        .to_string();
        let mut attrs = Vec::new();
        for a in n.attributes() {
            let mut v = self.subst(a.value(), a.name(), &tag, &loc)?;
            if ctx.upgrade && a.name() == "name" && tag != "default" {
                v = to_snake_case(&v);
            }
            attrs.push((a.name().to_string(), v));
        }
        Ok(Elem { tag, loc, attrs })
    }

    /// Reads and checks the `version` attribute; returns whether to upgrade from 0.6.
    fn read_version(
        &mut self,
        doc: &Document,
        label: &str,
        root: roxmltree::Node,
        is_main: bool,
    ) -> Result<bool> {
        let loc = loc_of(doc, label, root);
        let Some(raw) = root.attribute("version") else {
            let what = if is_main {
                "the scene"
            } else {
                "an included file"
            };
            return Err(SceneError::new(
                Some(loc),
                format!(
                    "missing 'version' attribute on <{}>, the root element of {what} \
                     (e.g. version=\"3.0.0\")",
                    root.tag_name().name()
                ),
            ));
        };
        let v = self.subst(raw, "version", root.tag_name().name(), &loc)?;
        let parts: Vec<Option<u32>> = v.trim().split('.').map(|p| p.parse().ok()).collect();
        match parts.as_slice() {
            [Some(major), Some(_), Some(_)] => Ok(*major < 2),
            _ => Err(SceneError::new(
                Some(loc),
                format!("invalid version=\"{v}\": expected major.minor.patch, e.g. \"3.0.0\""),
            )),
        }
    }

    /// Processes the element children of `xml` into `parent`.
    fn children(&mut self, ctx: &FileCtx, xml: roxmltree::Node, parent: &mut Node) -> Result<()> {
        // Text and comments are ignored, as Mitsuba does.
        for child in xml.children().filter(|c| c.is_element()) {
            let e = self.elem(ctx, child)?;
            let tag = e.tag.as_str();
            if PLUGIN_TAGS.contains(&tag) {
                let node = self.plugin(ctx, child, e, &[])?;
                add_child(parent, node)?;
            } else if PROPERTY_TAGS.contains(&tag) {
                let prop = self.property(ctx, child, &e)?;
                add_prop(parent, prop)?;
            } else {
                match tag {
                    "ref" => {
                        e.check_attrs(&["id", "name"])?;
                        let node = Node {
                            tag: "ref".into(),
                            plugin_type: String::new(),
                            id: Some(e.req("id")?.to_string()),
                            name: e.get("name").map(str::to_string),
                            props: Vec::new(),
                            children: Vec::new(),
                            loc: e.loc.clone(),
                        };
                        add_child(parent, node)?;
                    }
                    "default" => {
                        e.check_attrs(&["name", "value"])?;
                        let name = e.req("name")?;
                        let value = e.req("value")?;
                        if name.is_empty() || name.contains('$') {
                            return Err(e.err(format!("invalid parameter name '{name}'")));
                        }
                        // The first definition wins: an override, or an earlier <default>
                        // (e.g. in the including file), as in Mitsuba.
                        match self.params.iter_mut().find(|p| p.name == name) {
                            Some(p) => p.declared = true,
                            None => self.params.push(Param {
                                name: name.to_string(),
                                value: value.to_string(),
                                from_override: false,
                                declared: true,
                                referenced: false,
                            }),
                        }
                    }
                    "include" => {
                        e.check_attrs(&["filename"])?;
                        self.include(ctx, &e, parent)?;
                    }
                    "scene" => {
                        return Err(e.err("<scene> can only be the root element of a file"));
                    }
                    t if TRANSFORM_OPS.contains(&t) => {
                        return Err(e.err(format!("<{t}> is only valid inside <transform>")));
                    }
                    "alias" | "path" | "resource" | "tensor" => {
                        return Err(e.err(format!("<{tag}> elements are not supported")));
                    }
                    "srgb" => {
                        return Err(e.err(
                            "<srgb> (a Mitsuba 0.6 element) is not supported, as in Mitsuba 3; \
                             use <rgb> with linear values",
                        ));
                    }
                    _ => {
                        let mut valid: Vec<&str> = PLUGIN_TAGS.to_vec();
                        valid.extend_from_slice(PROPERTY_TAGS);
                        valid.extend_from_slice(OTHER_TAGS);
                        let hint = if tag == "lookAt" {
                            " (in a version 3 scene it is spelled <lookat>)"
                        } else {
                            ""
                        };
                        return Err(e.err(format!(
                            "unknown element <{tag}>{hint}; valid elements: {}",
                            valid.join(", ")
                        )));
                    }
                }
            }
        }
        Ok(())
    }

    fn plugin(
        &mut self,
        ctx: &FileCtx,
        xml: roxmltree::Node,
        e: Elem,
        extra_attrs: &[&str],
    ) -> Result<Node> {
        let mut allowed = vec!["type", "id", "name"];
        allowed.extend_from_slice(extra_attrs);
        e.check_attrs(&allowed)?;
        let plugin_type = e.req("type")?.to_string();
        let id = e.get("id").map(str::to_string);
        if let Some(id) = &id {
            if let Some(prev) = self.ids.get(id) {
                return Err(e.err(format!("duplicate id '{id}' (first defined at {prev})")));
            }
            self.ids.insert(id.clone(), e.loc.clone());
        }
        let mut node = Node {
            tag: e.tag.clone(),
            plugin_type,
            id,
            name: e.get("name").map(str::to_string),
            props: Vec::new(),
            children: Vec::new(),
            loc: e.loc.clone(),
        };
        if self.depth >= MAX_NESTING_DEPTH {
            return Err(e.err(format!(
                "plugins nested more than {MAX_NESTING_DEPTH} deep (the limit)"
            )));
        }
        self.depth += 1;
        let r = self.children(ctx, xml, &mut node);
        self.depth -= 1;
        r?;
        if ctx.upgrade {
            upgrade_node(&mut node)?;
        }
        Ok(node)
    }

    fn property(&mut self, ctx: &FileCtx, xml: roxmltree::Node, e: &Elem) -> Result<Prop> {
        let value = match e.tag.as_str() {
            "float" => {
                e.check_attrs(&["name", "value"])?;
                PropValue::Float(e.req_num("value")?)
            }
            "integer" => {
                e.check_attrs(&["name", "value"])?;
                let s = e.req("value")?;
                PropValue::Int(s.trim().parse().map_err(|_| {
                    e.err(format!(
                        "invalid value=\"{s}\" in {}: expected an integer",
                        e.describe()
                    ))
                })?)
            }
            "boolean" => {
                e.check_attrs(&["name", "value"])?;
                let s = e.req("value")?;
                let t = s.trim();
                if t.eq_ignore_ascii_case("true") {
                    PropValue::Bool(true)
                } else if t.eq_ignore_ascii_case("false") {
                    PropValue::Bool(false)
                } else {
                    return Err(e.err(format!(
                        "invalid value=\"{s}\" in {}: expected \"true\" or \"false\"",
                        e.describe()
                    )));
                }
            }
            "string" => {
                e.check_attrs(&["name", "value"])?;
                PropValue::Str(e.req("value")?.to_string())
            }
            "rgb" => {
                e.check_attrs(&["name", "value"])?;
                let s = e.req("value")?;
                let v = e.list("value", s)?;
                match v.len() {
                    1 => PropValue::Rgb([v[0] as f32; 3]),
                    3 => PropValue::Rgb([v[0] as f32, v[1] as f32, v[2] as f32]),
                    n => {
                        return Err(e.err(format!(
                            "invalid value=\"{s}\" in {}: expected 1 or 3 numbers, found {n}",
                            e.describe()
                        )))
                    }
                }
            }
            "spectrum" => {
                e.check_attrs(&["name", "value", "filename"])?;
                const ONLY: &str = "only constant spectra (a single value, e.g. \
                                    value=\"0.5\") are supported in RGB mode; use <rgb> for \
                                    coloured values";
                if e.get("filename").is_some() {
                    return Err(e.err(format!("spectrum files are not supported: {ONLY}")));
                }
                let s = e.req("value")?;
                if s.contains(':') {
                    return Err(e.err(format!(
                        "{}: wavelength:value lists are not supported: {ONLY}",
                        e.describe()
                    )));
                }
                let v = e.list("value", s)?;
                if v.len() != 1 {
                    return Err(e.err(format!("invalid value=\"{s}\" in {}: {ONLY}", e.describe())));
                }
                PropValue::Spectrum(v[0] as f32)
            }
            "point" | "vector" => {
                e.check_attrs(&["name", "value", "x", "y", "z"])?;
                let v = e.xyz(&["value"], 0.0)?.ok_or_else(|| {
                    e.err(format!(
                        "{} needs value=\"x, y, z\" or x=/y=/z= attributes",
                        e.describe()
                    ))
                })?;
                let v = v.as_vec3();
                if e.tag == "point" {
                    PropValue::Point(v)
                } else {
                    PropValue::Vector(v)
                }
            }
            "transform" => {
                e.check_attrs(&["name"])?;
                e.req("name")?;
                PropValue::Transform(self.transform(ctx, xml)?.as_mat4())
            }
            other => unreachable!("not a property element: {other}"),
        };
        Ok(Prop::new(e.req("name")?, value, e.loc.clone()))
    }

    /// Composes a `<transform>`'s operations: each left-multiplies the matrix so far.
    fn transform(&mut self, ctx: &FileCtx, xml: roxmltree::Node) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for child in xml.children().filter(|c| c.is_element()) {
            let e = self.elem(ctx, child)?;
            let op = match e.tag.as_str() {
                "translate" => {
                    e.check_attrs(&["value", "x", "y", "z"])?;
                    xf::translate(e.xyz(&["value"], 0.0)?.unwrap_or(DVec3::ZERO))
                }
                "scale" => {
                    e.check_attrs(&["value", "x", "y", "z"])?;
                    xf::scale(e.xyz(&["value"], 1.0)?.unwrap_or(DVec3::ONE))
                }
                "rotate" => {
                    e.check_attrs(&["value", "axis", "x", "y", "z", "angle"])?;
                    let axis = e.xyz(&["value", "axis"], 0.0)?.unwrap_or(DVec3::ZERO);
                    if axis == DVec3::ZERO {
                        return Err(e.err(
                            "<rotate> needs a non-zero axis: x=/y=/z= attributes or \
                             value=\"x, y, z\"",
                        ));
                    }
                    xf::rotate(axis, e.req_num("angle")?)
                }
                "lookat" => {
                    e.check_attrs(&["origin", "target", "up"])?;
                    let origin = e.vec3("origin", e.req("origin")?)?;
                    let target = e.vec3("target", e.req("target")?)?;
                    let up = match e.get("up") {
                        Some(s) => Some(e.vec3("up", s)?),
                        None => None,
                    };
                    xf::look_at(origin, target, up)
                        .map_err(|why| e.err(format!("invalid <lookat>: {why}")))?
                }
                "matrix" => {
                    e.check_attrs(&["value"])?;
                    let s = e.req("value")?;
                    let v = e.list("value", s)?;
                    xf::matrix(&v).ok_or_else(|| {
                        e.err(format!(
                            "invalid value in <matrix>: expected 16 (4x4) or 9 (3x3) numbers in \
                             row-major order, found {}",
                            v.len()
                        ))
                    })?
                }
                other => {
                    let hint = if other == "lookAt" {
                        " (in a version 3 scene it is spelled <lookat>)"
                    } else {
                        ""
                    };
                    return Err(e.err(format!(
                        "unexpected <{other}> inside <transform>{hint}; valid elements: {}",
                        TRANSFORM_OPS.join(", ")
                    )));
                }
            };
            m = op * m;
        }
        Ok(m)
    }

    fn include(&mut self, ctx: &FileCtx, e: &Elem, parent: &mut Node) -> Result<()> {
        let filename = e.req("filename")?;
        let rel = Path::new(filename);
        let mut candidates = vec![ctx.dir.join(rel)];
        if rel.is_relative() {
            let alt = self.main_dir.join(rel);
            if !candidates.contains(&alt) {
                candidates.push(alt);
            }
        }
        let Some(path) = candidates.iter().find(|p| p.is_file()).cloned() else {
            let looked: Vec<String> = candidates.iter().map(|p| p.display().to_string()).collect();
            return Err(e.err(format!(
                "included file '{filename}' not found (looked for {})",
                looked.join(" and ")
            )));
        };
        if self.include_stack.len() > MAX_INCLUDE_DEPTH {
            return Err(e.err(format!(
                "includes nested more than {MAX_INCLUDE_DEPTH} levels deep"
            )));
        }
        let canon = canonical(&path);
        if self.include_stack.contains(&canon) {
            return Err(e.err(format!(
                "include cycle: '{}' includes itself (directly or indirectly)",
                path.display()
            )));
        }
        let text = std::fs::read_to_string(&path).map_err(|err| {
            e.err(format!(
                "cannot read included file '{}': {err}",
                path.display()
            ))
        })?;
        self.include_stack.push(canon);
        let label = path.display().to_string();
        let result = self.include_doc(&text, &label, &path, parent);
        self.include_stack.pop();
        result.map_err(|mut err| {
            err.msg = format!("{} (in a file included at {})", err.msg, e.loc);
            err
        })
    }

    fn include_doc(
        &mut self,
        text: &str,
        label: &str,
        path: &Path,
        parent: &mut Node,
    ) -> Result<()> {
        let doc = parse_xml(text, label)?;
        let root = doc.root_element();
        let upgrade = self.read_version(&doc, label, root, false)?;
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        let ctx = FileCtx {
            doc: &doc,
            label: label.to_string(),
            dir,
            upgrade,
        };
        let e = self.elem(&ctx, root)?;
        if e.tag == "scene" {
            e.check_attrs(&["version", "type", "id"])?;
            self.children(&ctx, root, parent)
        } else if PLUGIN_TAGS.contains(&e.tag.as_str()) {
            let node = self.plugin(&ctx, root, e, &["version"])?;
            add_child(parent, node)
        } else {
            Err(e.err(format!(
                "the root element of an included file must be <scene> or a plugin, found <{}>",
                e.tag
            )))
        }
    }
}

fn duplicate(parent: &Node, name: &str, loc: &Loc) -> Option<SceneError> {
    let prev = parent
        .props
        .iter()
        .find(|p| p.name == name)
        .map(|p| &p.loc)
        .or_else(|| {
            parent
                .children
                .iter()
                .find(|c| c.name.as_deref() == Some(name))
                .map(|c| &c.loc)
        })?;
    Some(SceneError::new(
        Some(loc.clone()),
        format!(
            "duplicate parameter '{name}' in {} (first given at {prev})",
            parent.describe()
        ),
    ))
}

fn add_prop(parent: &mut Node, prop: Prop) -> Result<()> {
    if let Some(err) = duplicate(parent, &prop.name, &prop.loc) {
        return Err(err);
    }
    parent.props.push(prop);
    Ok(())
}

fn add_child(parent: &mut Node, child: Node) -> Result<()> {
    if let Some(name) = &child.name {
        if let Some(err) = duplicate(parent, name, &child.loc) {
            return Err(err);
        }
    }
    parent.children.push(child);
    Ok(())
}

/// The parts of Mitsuba 3's 0.6 upgrade that go beyond renaming (applied per plugin, after its
/// children): `diffuse`'s `diffuse_reflectance` becomes `reflectance`, and the texture
/// parameters `uoffset`/`voffset`/`uscale`/`vscale` become a `to_uv` transform
/// (`scale(uscale, vscale) · translate(uoffset, voffset)`).
fn upgrade_node(node: &mut Node) -> Result<()> {
    if node.tag == "bsdf" && node.plugin_type == "diffuse" {
        let old = "diffuse_reflectance";
        let new = "reflectance";
        let old_loc = node
            .props
            .iter()
            .find(|p| p.name == old)
            .map(|p| p.loc.clone())
            .or_else(|| {
                node.children
                    .iter()
                    .find(|c| c.name.as_deref() == Some(old))
                    .map(|c| c.loc.clone())
            });
        if let Some(loc) = old_loc {
            if let Some(err) = duplicate(node, new, &loc) {
                return Err(err);
            }
            for p in node.props.iter_mut().filter(|p| p.name == old) {
                p.name = new.into();
            }
            for c in node
                .children
                .iter_mut()
                .filter(|c| c.name.as_deref() == Some(old))
            {
                c.name = Some(new.into());
            }
        }
    }
    const UV: [&str; 4] = ["uoffset", "voffset", "uscale", "vscale"];
    let is_uv = |p: &Prop| {
        UV.contains(&p.name.as_str()) && matches!(p.value, PropValue::Float(_) | PropValue::Int(_))
    };
    if let Some(first) = node.props.iter().position(is_uv) {
        let loc = node.props[first].loc.clone();
        let get = |name: &str, default: f64| {
            node.props
                .iter()
                .find(|p| p.name == name)
                .map_or(default, |p| match p.value {
                    PropValue::Float(v) => v,
                    PropValue::Int(v) => v as f64,
                    _ => default,
                })
        };
        let m = xf::scale(DVec3::new(get("uscale", 1.0), get("vscale", 1.0), 1.0))
            * xf::translate(DVec3::new(get("uoffset", 0.0), get("voffset", 0.0), 0.0));
        node.props.retain(|p| !is_uv(p));
        if let Some(err) = duplicate(node, "to_uv", &loc) {
            return Err(err);
        }
        node.props.insert(
            first,
            Prop::new("to_uv", PropValue::Transform(m.as_mat4()), loc),
        );
    }
    Ok(())
}
