//! Parsing: XML → [`Node`] tree, with parameter substitution, includes, transforms and the
//! Mitsuba 0.6 upgrade.

use super::spectrum::{Sampled, Spectrum, CIE_MAX, CIE_MIN};
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
const OTHER_TAGS: &[&str] = &["ref", "default", "include", "path", "alias"];
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
    resolve_aliases(&mut node, &parser.aliases);
    inline_definitions(&mut node)?;
    order_by_references(&mut node)?;
    Ok(node)
}

/// Ids referenced by `<ref>`s anywhere inside `n`.
fn referenced_ids(n: &Node) -> Vec<&str> {
    let mut out = vec![];
    let mut stack = vec![n];
    while let Some(m) = stack.pop() {
        if m.tag == "ref" {
            if let Some(id) = &m.id {
                out.push(id.as_str());
            }
        }
        stack.extend(m.children.iter());
    }
    out
}

/// Mitsuba lets a `<ref>` name a plugin declared later in the file (it instantiates plugins
/// in dependency order). The scene builder reads the top level in order, so the top-level
/// plugins are reordered here: each after the plugins it references, otherwise in document
/// order. A reference cycle is an error.
fn order_by_references(root: &mut Node) -> Result<()> {
    let n = root.children.len();
    let index: HashMap<&str, usize> = root
        .children
        .iter()
        .enumerate()
        .filter_map(|(i, c)| c.id.as_deref().filter(|_| c.tag != "ref").map(|id| (id, i)))
        .collect();
    let deps: Vec<Vec<usize>> = root
        .children
        .iter()
        .map(|c| {
            referenced_ids(c)
                .into_iter()
                .filter_map(|id| index.get(id).copied())
                .collect()
        })
        .collect();
    if deps
        .iter()
        .enumerate()
        .all(|(i, d)| d.iter().all(|&j| j < i))
    {
        return Ok(()); // already in order (the common case)
    }
    // iterative depth-first topological sort, visiting in document order
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        Open,
        Done,
    }
    let mut mark = vec![Mark::New; n];
    let mut order = Vec::with_capacity(n);
    for start in 0..n {
        if mark[start] != Mark::New {
            continue;
        }
        let mut stack = vec![(start, 0usize)];
        mark[start] = Mark::Open;
        while let Some(&mut (i, ref mut next)) = stack.last_mut() {
            if let Some(&j) = deps[i].get(*next) {
                *next += 1;
                match mark[j] {
                    Mark::New => {
                        mark[j] = Mark::Open;
                        stack.push((j, 0));
                    }
                    Mark::Open if j == i => {}
                    Mark::Open => {
                        let c = &root.children[i];
                        return Err(SceneError::new(
                            Some(c.loc.clone()),
                            format!(
                                "{} references '{}' (declared at {}), which depends on it in turn",
                                c.describe(),
                                root.children[j].id.as_deref().unwrap_or(""),
                                root.children[j].loc
                            ),
                        ));
                    }
                    Mark::Done => {}
                }
            } else {
                mark[i] = Mark::Done;
                order.push(i);
                stack.pop();
            }
        }
    }
    let mut slots: Vec<Option<Node>> = std::mem::take(&mut root.children)
        .into_iter()
        .map(Some)
        .collect();
    root.children = order.into_iter().filter_map(|i| slots[i].take()).collect();
    Ok(())
}

/// Rewrites every `<ref>` to an alias so that it names the aliased plugin's own id.
fn resolve_aliases(node: &mut Node, aliases: &[(String, String, Loc)]) {
    if aliases.is_empty() {
        return;
    }
    let target = |id: &str| {
        let mut id = id.to_string();
        // aliases of aliases: follow the chain (bounded by the number of aliases)
        for _ in 0..=aliases.len() {
            match aliases.iter().find(|(a, _, _)| *a == id) {
                Some((_, t, _)) => id = t.clone(),
                None => break,
            }
        }
        id
    };
    let mut stack = vec![node];
    while let Some(n) = stack.pop() {
        if n.tag == "ref" {
            if let Some(id) = &n.id {
                n.id = Some(target(id));
            }
        }
        stack.extend(n.children.iter_mut());
    }
}

/// Plugin kinds that a scene declares once at the top level (with an `id`) and uses through
/// `<ref>` elsewhere, and that are not objects of the scene themselves: each such `<ref>` is
/// replaced by a copy of the declaration (named by the ref's `name`), and the declarations
/// leave the top level. Top-level `area` emitters are treated the same way (Mitsuba attaches
/// them to the shapes that reference them). BSDFs, textures, shapes, other emitters and media
/// keep their refs: the scene builder shares those.
const DEFINITION_TAGS: &[&str] = &["sampler", "film", "rfilter", "phase", "volume", "spectrum"];

fn inline_definitions(root: &mut Node) -> Result<()> {
    let mut defs: HashMap<String, Node> = HashMap::new();
    let mut kept = Vec::with_capacity(root.children.len());
    for c in std::mem::take(&mut root.children) {
        // an `area` emitter exists only attached to the shapes that reference it
        let is_area = c.tag == "emitter" && c.plugin_type == "area";
        match &c.id {
            Some(id) if DEFINITION_TAGS.contains(&c.tag.as_str()) || is_area => {
                defs.insert(id.clone(), c);
            }
            _ => kept.push(c),
        }
    }
    root.children = kept;
    if defs.is_empty() {
        return Ok(());
    }
    // iterative walk (no recursion: scenes may nest deeply)
    let mut stack: Vec<&mut Node> = root.children.iter_mut().collect();
    while let Some(n) = stack.pop() {
        for c in n.children.iter_mut() {
            if c.tag != "ref" {
                continue;
            }
            let Some(def) = c.id.as_ref().and_then(|id| defs.get(id)) else {
                continue;
            };
            let mut copy = def.clone();
            copy.id = None;
            copy.name = c.name.clone().or(copy.name);
            copy.loc = def.loc.clone();
            *c = copy;
        }
        stack.extend(n.children.iter_mut());
    }
    Ok(())
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
    /// Folders added by `<path value=…>`, the most recent first (Mitsuba's file resolver
    /// prepends them, so the latest takes precedence).
    search_paths: Vec<PathBuf>,
    /// `<alias id="a" as="b"/>`: b → a.
    aliases: Vec<(String, String, Loc)>,
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
            search_paths: Vec::new(),
            aliases: Vec::new(),
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
                    "path" => {
                        e.check_attrs(&["value"])?;
                        self.add_search_path(ctx, &e)?;
                    }
                    "alias" => {
                        e.check_attrs(&["id", "as"])?;
                        let id = e.req("id")?.to_string();
                        let alias = e.req("as")?.to_string();
                        if let Some(prev) = self.ids.get(&alias) {
                            return Err(e.err(format!(
                                "<alias as=\"{alias}\">: id '{alias}' is already defined at {prev}"
                            )));
                        }
                        if !self.ids.contains_key(&id) {
                            return Err(e.err(format!(
                                "<alias id=\"{id}\">: no plugin with id '{id}' is defined before it"
                            )));
                        }
                        self.ids.insert(alias.clone(), e.loc.clone());
                        self.aliases.push((alias, id, e.loc.clone()));
                    }
                    "resource" | "tensor" => {
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
                let v = e.req("value")?;
                if e.get("name") == Some("filename") {
                    PropValue::Str(self.resolve_file(ctx, v))
                } else {
                    PropValue::Str(v.to_string())
                }
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
            "spectrum" => PropValue::Spectrum(self.spectrum(ctx, xml, e)?),
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

    /// A `<spectrum>`: `value="v"`, `value="λ:v, …"`, `filename="x.spd"` (resolved like an
    /// `<include>`: against the file's directory, the `<path>` folders, then the main
    /// scene's), or a spectrum plugin
    /// `<spectrum type="…">` with nested parameters (see [`super::spectrum`]).
    fn spectrum(&mut self, ctx: &FileCtx, xml: roxmltree::Node, e: &Elem) -> Result<Spectrum> {
        if let Some(kind) = e.get("type") {
            e.check_attrs(&["name", "type"])?;
            let mut node = Node {
                tag: "spectrum".into(),
                plugin_type: kind.to_string(),
                id: None,
                name: e.get("name").map(str::to_string),
                props: Vec::new(),
                children: Vec::new(),
                loc: e.loc.clone(),
            };
            self.children(ctx, xml, &mut node)?;
            return spectrum_plugin(&node);
        }
        e.check_attrs(&["name", "value", "filename"])?;
        match (e.get("value"), e.get("filename")) {
            (Some(_), Some(_)) | (None, None) => Err(e.err(format!(
                "{} needs either a 'value' or a 'filename' attribute (not both)",
                e.describe()
            ))),
            (Some(s), None) if !s.contains(':') => {
                let v = e.list("value", s)?;
                match v.as_slice() {
                    [v] => Ok(Spectrum::Constant(*v)),
                    _ => Err(e.err(format!(
                        "invalid value=\"{s}\" in {}: expected one number or \
                         wavelength:value pairs (e.g. \"400:0.1, 500:0.5\")",
                        e.describe()
                    ))),
                }
            }
            (Some(s), None) => Sampled::parse_pairs(s)
                .map(Spectrum::Sampled)
                .map_err(|why| e.err(format!("invalid value in {}: {why}", e.describe()))),
            (None, Some(filename)) => {
                let rel = Path::new(filename);
                let mut candidates = vec![ctx.dir.join(rel)];
                if rel.is_relative() {
                    for dir in self
                        .search_paths
                        .iter()
                        .chain(std::iter::once(&self.main_dir))
                    {
                        let alt = dir.join(rel);
                        if !candidates.contains(&alt) {
                            candidates.push(alt);
                        }
                    }
                }
                let Some(path) = candidates.iter().find(|p| p.is_file()) else {
                    let looked: Vec<String> =
                        candidates.iter().map(|p| p.display().to_string()).collect();
                    return Err(e.err(format!(
                        "spectrum file '{filename}' not found (looked for {})",
                        looked.join(" and ")
                    )));
                };
                let text = std::fs::read_to_string(path).map_err(|err| {
                    e.err(format!(
                        "cannot read spectrum file '{}': {err}",
                        path.display()
                    ))
                })?;
                Sampled::parse_spd(&text)
                    .map(Spectrum::Sampled)
                    .map_err(|why| {
                        e.err(format!("invalid spectrum file '{}': {why}", path.display()))
                    })
            }
        }
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

    /// `<path value="dir"/>`: adds a folder to the file search path, as Mitsuba's parser does:
    /// a relative folder is looked for relative to the file that declares it, then in the
    /// search path (earlier `<path>`s, the main scene's folder); it must exist.
    fn add_search_path(&mut self, ctx: &FileCtx, e: &Elem) -> Result<()> {
        let value = e.req("value")?;
        let p = Path::new(value);
        let candidates: Vec<PathBuf> = if p.is_absolute() {
            vec![p.to_path_buf()]
        } else {
            std::iter::once(&ctx.dir)
                .chain(self.search_paths.iter())
                .chain(std::iter::once(&self.main_dir))
                .map(|d| d.join(p))
                .collect()
        };
        let Some(dir) = candidates.iter().find(|c| c.is_dir()).cloned() else {
            let looked: Vec<String> = candidates.iter().map(|c| c.display().to_string()).collect();
            return Err(e.err(format!(
                "<path value=\"{value}\">: folder not found (looked for {})",
                looked.join(", ")
            )));
        };
        let dir = std::path::absolute(&dir).unwrap_or(dir);
        self.search_paths.retain(|d| d != &dir);
        self.search_paths.insert(0, dir);
        Ok(())
    }

    /// A `filename` parameter resolved as Mitsuba's file resolver does: relative to the file
    /// that declares it, then each `<path>` folder (the most recent first), then the main
    /// scene's folder. The first that exists is returned as an absolute path; when none
    /// exists the name is returned unchanged (the plugin reports the missing file).
    fn resolve_file(&self, ctx: &FileCtx, name: &str) -> String {
        let p = Path::new(name);
        if p.is_absolute() || name.is_empty() {
            return name.to_string();
        }
        std::iter::once(&ctx.dir)
            .chain(self.search_paths.iter())
            .chain(std::iter::once(&self.main_dir))
            .map(|d| d.join(p))
            .find(|c| c.exists())
            .map(|c| {
                std::path::absolute(&c)
                    .unwrap_or(c)
                    .to_string_lossy()
                    .into_owned()
            })
            .unwrap_or_else(|| name.to_string())
    }

    fn include(&mut self, ctx: &FileCtx, e: &Elem, parent: &mut Node) -> Result<()> {
        let filename = e.req("filename")?;
        let rel = Path::new(filename);
        let mut candidates = vec![ctx.dir.join(rel)];
        if rel.is_relative() {
            for dir in self
                .search_paths
                .iter()
                .chain(std::iter::once(&self.main_dir))
            {
                let alt = dir.join(rel);
                if !candidates.contains(&alt) {
                    candidates.push(alt);
                }
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

/// A spectrum plugin (`<spectrum type="…">`) from its parsed parameters, with Mitsuba 3's
/// parameter names and defaults.
fn spectrum_plugin(n: &Node) -> Result<Spectrum> {
    if let Some(c) = n.children.first() {
        return Err(c.error(format!(
            "<{}> cannot be nested in <spectrum type=\"{}\">",
            c.tag, n.plugin_type
        )));
    }
    let req = |name: &str| {
        n.float_opt(name)?
            .map(f64::from)
            .ok_or_else(|| n.error(format!("spectrum '{}' needs '{name}'", n.plugin_type)))
    };
    // an rgb parameter of a spectrum plugin must be an <rgb> (as in Mitsuba)
    let rgb = |name: &str| match n.prop(name) {
        None => Ok(None),
        Some(p) => match &p.value {
            PropValue::Rgb(c) => Ok(Some(c.map(f64::from))),
            other => Err(SceneError::new(
                Some(p.loc.clone()),
                format!(
                    "parameter '{name}' of spectrum '{}': expected rgb, found {}",
                    n.plugin_type,
                    other.type_name()
                ),
            )),
        },
    };
    let list = |name: &str| -> Result<Vec<f64>> {
        let s = n
            .string_opt(name)?
            .ok_or_else(|| n.error(format!("spectrum '{}' needs '{name}'", n.plugin_type)))?;
        s.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|t| !t.is_empty())
            .map(|t| {
                t.parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        n.error(format!(
                            "'{name}' of spectrum '{}': '{t}' is not a number",
                            n.plugin_type
                        ))
                    })
            })
            .collect()
    };
    let sampled = |r: std::result::Result<Sampled, String>| {
        r.map(Spectrum::Sampled)
            .map_err(|why| n.error(format!("spectrum '{}': {why}", n.plugin_type)))
    };
    let s = match n.plugin_type.as_str() {
        "uniform" => {
            let v = req("value")?;
            n.check_unused(&["value"])?;
            Spectrum::Uniform(v)
        }
        "d65" => {
            let color = rgb("color")?.unwrap_or([1.0; 3]);
            let scale = n.float("scale", 1.0)? as f64;
            n.check_unused(&["color", "scale"])?;
            Spectrum::D65 { color, scale }
        }
        "srgb" => {
            let color = rgb("color")?.ok_or_else(|| n.error("spectrum 'srgb' needs 'color'"))?;
            let unbounded = n.bool("unbounded", false)?;
            n.check_unused(&["color", "unbounded"])?;
            Spectrum::Srgb { color, unbounded }
        }
        "blackbody" => {
            let temperature = req("temperature")?;
            let lo = n.float("wavelength_min", CIE_MIN as f32)? as f64;
            let hi = n.float("wavelength_max", CIE_MAX as f32)? as f64;
            n.check_unused(&["temperature", "wavelength_min", "wavelength_max"])?;
            if !(temperature > 0.0 && temperature.is_finite()) {
                return Err(n.error(format!(
                    "spectrum 'blackbody': the temperature must be positive (kelvin), got \
                     {temperature}"
                )));
            }
            if lo.partial_cmp(&hi) != Some(std::cmp::Ordering::Less) {
                return Err(n.error(format!(
                    "spectrum 'blackbody': wavelength_min ({lo}) must be below wavelength_max \
                     ({hi})"
                )));
            }
            Spectrum::Blackbody {
                temperature,
                range: [lo, hi],
            }
        }
        "regular" => {
            let lo = req("wavelength_min")?;
            let hi = req("wavelength_max")?;
            let values = list("values")?;
            n.check_unused(&["wavelength_min", "wavelength_max", "values"])?;
            sampled(Sampled::regular(lo, hi, values))?
        }
        "irregular" => {
            let wl = list("wavelengths")?;
            let values = list("values")?;
            n.check_unused(&["wavelengths", "values"])?;
            sampled(Sampled::new(wl, values))?
        }
        other => {
            return Err(n.error(format!(
                "spectrum type '{other}' is not supported (supported: uniform, d65, srgb, \
                 blackbody, regular, irregular)"
            )))
        }
    };
    Ok(s)
}
