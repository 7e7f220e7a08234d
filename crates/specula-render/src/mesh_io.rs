//! Triangle mesh files: Wavefront OBJ (through `tobj`) and Stanford PLY (own parser: ascii,
//! binary little and big endian).
//!
//! Both loaders return the raw, untransformed data of the file as one indexed triangle list
//! ([`MeshData`]); [`crate::geometry::Geometry::mesh`] applies `to_world`, `face_normals`,
//! `flip_normals` and computes missing normals the way Mitsuba 3 does.
//!
//! Conventions (checked against Mitsuba 3.9.1):
//! - OBJ texture coordinates are stored as `(u, 1 - v)` (Mitsuba's OBJ loader flips v);
//!   PLY texture coordinates are kept as they are in the file.
//! - OBJ vertices are unique per `(v, vt, vn)` index triple over the whole file (objects,
//!   groups and materials are merged into one mesh), polygons are fanned from their first
//!   vertex: `(0, i, i + 1)`. PLY polygons are fanned the same way.

use crate::core::{Result, SceneError};
use glam::{Vec2, Vec3};
use std::path::Path;

/// An indexed triangle mesh as read from a file (object space, no transform applied).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    pub positions: Vec<Vec3>,
    /// Per-vertex normals, as in the file (not necessarily unit length).
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates, in Mitsuba's convention (see the module docs).
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
    /// Extra per-vertex and per-face properties of a PLY file (vertex colours, …), named and
    /// grouped as Mitsuba names them (see [`MeshAttribute`]).
    pub attributes: Vec<MeshAttribute>,
}

/// A PLY vertex or face property (group) beyond positions, normals and texture coordinates,
/// as Mitsuba 3's PLY loader groups them:
/// - `r g b [a]` or `red green blue [alpha]` → `vertex_color` / `face_color`;
/// - consecutive properties `{prefix}_{x|y|z}`, `{prefix}_{r|g|b}`, `{prefix}_{0|1|2}` or
///   `{prefix}_{1|2|3}` → `vertex_{prefix}` (`vertex_{prefix}_color` for `r|g|b`), 1 or 3 of
///   them (other counts are ignored, as Mitsuba ignores them with a warning);
/// - properties without a `_` suffix are ignored (Mitsuba: with a warning).
///
/// Values are stored as read, integers converted to float without normalisation (Mitsuba
/// 3.9.1 does the same). Face attributes of polygons apply to every triangle of the fan.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// `vertex_…` or `face_…`.
    pub name: String,
    /// Channels: 1, 3, or 4 (colour with alpha).
    pub dim: usize,
    /// `dim` values per vertex (or per triangle).
    pub data: Vec<f32>,
}

impl MeshAttribute {
    /// Whether the attribute is per face (else per vertex).
    pub fn is_face(&self) -> bool {
        self.name.starts_with("face_")
    }
}

impl MeshData {
    /// Checks lengths, index ranges and that every value is finite. `what` names the source
    /// in error messages.
    pub fn validate(&self, what: &str) -> std::result::Result<(), String> {
        let n = self.positions.len();
        if let Some(normals) = &self.normals {
            if normals.len() != n {
                return Err(format!(
                    "{what}: {} normals for {n} vertices",
                    normals.len()
                ));
            }
        }
        if let Some(uvs) = &self.uvs {
            if uvs.len() != n {
                return Err(format!(
                    "{what}: {} texture coordinates for {n} vertices",
                    uvs.len()
                ));
            }
        }
        for (i, p) in self.positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(format!("{what}: vertex {i} has a non-finite position {p}"));
            }
        }
        if let Some(normals) = &self.normals {
            for (i, v) in normals.iter().enumerate() {
                if !v.is_finite() {
                    return Err(format!("{what}: vertex {i} has a non-finite normal {v}"));
                }
            }
        }
        if let Some(uvs) = &self.uvs {
            for (i, v) in uvs.iter().enumerate() {
                if !v.is_finite() {
                    return Err(format!(
                        "{what}: vertex {i} has a non-finite texture coordinate {v}"
                    ));
                }
            }
        }
        for a in &self.attributes {
            let count = if a.is_face() { self.indices.len() } else { n };
            if a.data.len() != count * a.dim {
                return Err(format!(
                    "{what}: attribute '{}' has {} values for {count} {} of {} channels",
                    a.name,
                    a.data.len(),
                    if a.is_face() { "faces" } else { "vertices" },
                    a.dim
                ));
            }
            if let Some(i) = a.data.iter().position(|v| !v.is_finite()) {
                return Err(format!(
                    "{what}: attribute '{}' has a non-finite value at {}",
                    a.name,
                    i / a.dim
                ));
            }
        }
        for (f, tri) in self.indices.iter().enumerate() {
            for &i in tri {
                if i as usize >= n {
                    return Err(format!(
                        "{what}: face {f} refers to vertex {i}, but there are only {n} vertices"
                    ));
                }
            }
        }
        Ok(())
    }
}

fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => SceneError::file(path, "file not found"),
        _ => SceneError::file(path, format!("cannot read file: {e}")),
    })
}

// ---------------------------------------------------------------------------------------------
// OBJ
// ---------------------------------------------------------------------------------------------

/// Loads a Wavefront OBJ file: all objects and groups merged into one mesh, polygons
/// triangulated as fans, v texture coordinate flipped (`1 - v`) as Mitsuba does.
pub fn load_obj(path: &Path) -> Result<MeshData> {
    let bytes = read_file(path)?;
    parse_obj(&bytes).map_err(|m| SceneError::file(path, m))
}

/// Checks every vertex reference of a face, line or point statement (`f 1/2/3 -1//-2 …`):
/// positive indices at most the number of such elements in the file, negative ones at most
/// the number defined so far, never 0. `tobj` does unchecked index arithmetic that overflows
/// on such references (a panic in builds with debug assertions), so they are rejected here.
fn check_obj_refs(
    line_no: usize,
    words: std::str::SplitWhitespace<'_>,
    so_far: [usize; 3],
    total: [usize; 3],
) -> std::result::Result<(), String> {
    const KIND: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    for corner in words {
        for (k, part) in corner.split('/').enumerate() {
            if part.is_empty() {
                continue;
            }
            if k > 2 {
                return Err(format!("line {line_no}: malformed face corner '{corner}'"));
            }
            let x: i64 = part
                .parse()
                .map_err(|_| format!("line {line_no}: malformed face corner '{corner}'"))?;
            let ok = if x < 0 {
                x.unsigned_abs() <= so_far[k] as u64
            } else {
                x >= 1 && x as u64 <= total[k] as u64
            };
            if !ok {
                return Err(format!(
                    "line {line_no}: face refers to {} {x}, but {}",
                    KIND[k],
                    if x < 0 {
                        format!("only {} come before this line", so_far[k])
                    } else {
                        format!("the file has {} (numbered from 1)", total[k])
                    }
                ));
            }
        }
    }
    Ok(())
}

/// [`load_obj`] on the bytes of a file; the error says what is wrong (the caller names the
/// file).
///
/// Files of the common statements only (see [`parse_obj_fast`]) are read in one pass; any
/// other file, and any file with a problem, goes through [`parse_obj_general`] (tobj), which
/// gives the same mesh and the errors.
pub fn parse_obj(bytes: &[u8]) -> std::result::Result<MeshData, String> {
    match parse_obj_fast(bytes) {
        Some(data) => Ok(data),
        None => parse_obj_general(bytes),
    }
}

/// The words of an ASCII line, as `str::split_whitespace` splits it (its whitespace among
/// ASCII characters includes vertical tab, unlike `split_ascii_whitespace`'s).
#[inline]
fn ascii_words(line: &str) -> impl Iterator<Item = &str> {
    line.split([' ', '\t', '\n', '\x0B', '\x0C', '\r'])
        .filter(|w| !w.is_empty())
}

/// One pass over an ASCII OBJ file of `v`, `vt`, `vn` and `f` statements (and the comments,
/// groups, objects, materials and other statements that tobj ignores or [`parse_obj_general`]
/// drops), giving exactly [`parse_obj_general`]'s mesh: one vertex per distinct (v, vt, vn)
/// reference in order of first use, polygons as fans, v flipped. `None` (read it with
/// [`parse_obj_general`]) for anything else: non-ASCII text, `l` and `p` statements, faces of
/// fewer than 3 corners, positions with w or colours, and every problem (bad numbers,
/// references out of range), so that the errors are that function's.
fn parse_obj_fast(bytes: &[u8]) -> Option<MeshData> {
    const MISSING: u32 = u32::MAX;
    if !bytes.is_ascii() {
        return None;
    }
    let text = std::str::from_utf8(bytes).ok()?;
    let mut pos: Vec<Vec3> = Vec::new();
    let mut tex: Vec<Vec2> = Vec::new();
    let mut nrm: Vec<Vec3> = Vec::new();
    // every face corner's (v, vt, vn), 0-based or MISSING, and each face's corner count
    let mut corners: Vec<[u32; 3]> = Vec::new();
    let mut faces: Vec<u32> = Vec::new();
    // the largest positive reference of each kind, checked against the counts at the end
    let mut max_ref = [0u64; 3];
    let float = |w: Option<&str>| w.and_then(|w| w.parse::<f32>().ok());
    for line in text.lines() {
        let mut words = ascii_words(line);
        match words.next() {
            None | Some("#" | "o" | "g" | "usemtl" | "mtllib") => {}
            Some("v") => {
                let p = [
                    float(words.next())?,
                    float(words.next())?,
                    float(words.next())?,
                ];
                if words.next().is_some() {
                    return None; // w or a colour
                }
                pos.push(Vec3::from_array(p));
            }
            Some("vt") => {
                // (a third coordinate is ignored, as tobj does)
                tex.push(Vec2::new(float(words.next())?, float(words.next())?));
            }
            Some("vn") => {
                let n = [
                    float(words.next())?,
                    float(words.next())?,
                    float(words.next())?,
                ];
                nrm.push(Vec3::from_array(n));
            }
            Some("f") => {
                let so_far = [pos.len() as u64, tex.len() as u64, nrm.len() as u64];
                let first = corners.len();
                for corner in words {
                    let mut c = [MISSING; 3];
                    for (k, part) in corner.split('/').enumerate() {
                        if part.is_empty() {
                            continue;
                        }
                        if k > 2 {
                            return None;
                        }
                        let x: i64 = part.parse().ok()?;
                        let i = if x < 0 {
                            so_far[k].checked_sub(x.unsigned_abs())?
                        } else if x > 0 {
                            max_ref[k] = max_ref[k].max(x as u64);
                            x as u64 - 1
                        } else {
                            return None;
                        };
                        c[k] = u32::try_from(i).ok().filter(|&i| i != MISSING)?;
                    }
                    corners.push(c);
                }
                let n = corners.len() - first;
                if n < 3 {
                    return None;
                }
                faces.push(n as u32);
            }
            Some("l" | "p") => return None,
            Some(_) => {} // ignored by tobj
        }
    }
    let counts = [pos.len() as u64, tex.len() as u64, nrm.len() as u64];
    if (0..3).any(|k| max_ref[k] > counts[k]) {
        return None;
    }
    // one vertex per distinct reference, numbered in order of first use; the vertices made
    // from the same position are chained, so a lookup compares a few (vt, vn) pairs, no hash
    let mut first_of_pos = vec![MISSING; pos.len()];
    let mut next_same_pos: Vec<u32> = Vec::new();
    let mut refs: Vec<[u32; 3]> = Vec::new();
    let mut vertex_of = |c: [u32; 3]| -> u32 {
        let mut v = first_of_pos[c[0] as usize];
        let mut last = MISSING;
        while v != MISSING {
            if refs[v as usize] == c {
                return v;
            }
            last = v;
            v = next_same_pos[v as usize];
        }
        let new = refs.len() as u32;
        refs.push(c);
        next_same_pos.push(MISSING);
        if last == MISSING {
            first_of_pos[c[0] as usize] = new;
        } else {
            next_same_pos[last as usize] = new;
        }
        new
    };
    let triangles: usize = faces.iter().map(|&n| n as usize - 2).sum();
    let mut indices = Vec::with_capacity(triangles);
    let mut at = 0;
    for &n in &faces {
        let face = &corners[at..at + n as usize];
        at += n as usize;
        // a fan: (0, 1, 2), (0, 2, 3), … — each corner numbered when first met, in this order
        let a = vertex_of(face[0]);
        let mut b = vertex_of(face[1]);
        for &c in &face[2..] {
            let c = vertex_of(c);
            indices.push([a, b, c]);
            b = c;
        }
    }
    let mut data = MeshData {
        positions: refs.iter().map(|r| pos[r[0] as usize]).collect(),
        indices,
        ..MeshData::default()
    };
    // texture coordinates and normals only when every vertex has them (and the file has some)
    if !tex.is_empty() && !refs.is_empty() && refs.iter().all(|r| r[1] != MISSING) {
        data.uvs = Some(
            refs.iter()
                .map(|r| {
                    let t = tex[r[1] as usize];
                    Vec2::new(t.x, 1.0 - t.y)
                })
                .collect(),
        );
    }
    if !nrm.is_empty() && !refs.is_empty() && refs.iter().all(|r| r[2] != MISSING) {
        data.normals = Some(refs.iter().map(|r| nrm[r[2] as usize]).collect());
    }
    if data.validate("invalid OBJ file").is_err() || data.indices.is_empty() {
        return None;
    }
    Some(data)
}

/// [`parse_obj`] through tobj, for every file (the reference for [`parse_obj_fast`], and the
/// reader of what it leaves, errors included).
fn parse_obj_general(bytes: &[u8]) -> std::result::Result<MeshData, String> {
    let text = String::from_utf8_lossy(bytes);
    let kind = |first: &str| match first {
        "v" => Some(0),
        "vt" => Some(1),
        "vn" => Some(2),
        _ => None,
    };
    let mut total = [0usize; 3];
    for line in text.lines() {
        if let Some(k) = kind(line.split_whitespace().next().unwrap_or("")) {
            total[k] += 1;
        }
    }
    let mut so_far = [0usize; 3];
    // tobj starts a new model (with its own vertex numbering) at every `o`, `g` and material
    // change, which would split vertices shared between groups. Mitsuba builds one mesh over
    // the whole file, so drop those statements (and material libraries, which we never use).
    let mut filtered = String::with_capacity(text.len());
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let first = words.next().unwrap_or("");
        if matches!(first, "o" | "g" | "usemtl" | "mtllib") {
            continue;
        }
        if let Some(k) = kind(first) {
            so_far[k] += 1;
        }
        if matches!(first, "f" | "l" | "p") {
            check_obj_refs(n + 1, words, so_far, total)?;
        }
        filtered.push_str(line);
        filtered.push('\n');
    }
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::Cursor::new(filtered.as_bytes());
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| format!("invalid OBJ file: {e}"))?;

    let mut data = MeshData::default();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut all_normals = true;
    let mut all_uvs = true;
    for model in &models {
        let m = &model.mesh;
        let base = data.positions.len() as u32;
        let nv = m.positions.len() / 3;
        data.positions.extend(
            m.positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        if m.normals.len() == nv * 3 && nv > 0 {
            normals.extend(
                m.normals
                    .chunks_exact(3)
                    .map(|c| Vec3::new(c[0], c[1], c[2])),
            );
        } else {
            all_normals = false;
        }
        if m.texcoords.len() == nv * 2 && nv > 0 {
            uvs.extend(
                m.texcoords
                    .chunks_exact(2)
                    .map(|c| Vec2::new(c[0], 1.0 - c[1])),
            );
        } else {
            all_uvs = false;
        }
        data.indices.extend(
            m.indices
                .chunks_exact(3)
                .map(|c| [c[0] + base, c[1] + base, c[2] + base]),
        );
    }
    if all_normals && !data.positions.is_empty() {
        data.normals = Some(normals);
    }
    if all_uvs && !data.positions.is_empty() {
        data.uvs = Some(uvs);
    }
    data.validate("invalid OBJ file")?;
    if data.indices.is_empty() {
        return Err("OBJ file contains no faces".into());
    }
    Ok(data)
}

// ---------------------------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------------------------

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Debug)]
enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: PropKind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Offset of the first byte after `end_header` and its line ending.
    body: usize,
}

fn next_line<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a str> {
    if *pos >= bytes.len() {
        return None;
    }
    let start = *pos;
    while *pos < bytes.len() && bytes[*pos] != b'\n' {
        *pos += 1;
    }
    let end = *pos;
    if *pos < bytes.len() {
        *pos += 1; // the '\n'
    }
    let line = &bytes[start..end];
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    Some(std::str::from_utf8(line).unwrap_or("\u{fffd}"))
}

fn parse_header(bytes: &[u8]) -> std::result::Result<Header, String> {
    let mut pos = 0usize;
    match next_line(bytes, &mut pos) {
        Some(l) if l.trim() == "ply" => {}
        _ => return Err("not a PLY file (missing 'ply' magic line)".into()),
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 1;
    loop {
        line_no += 1;
        let Some(line) = next_line(bytes, &mut pos) else {
            return Err("bad PLY header: missing 'end_header'".into());
        };
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let rest: Vec<&str> = words.collect();
        match keyword {
            "comment" | "obj_info" => {}
            "format" => {
                format = Some(match rest.first().copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    other => {
                        return Err(format!(
                            "bad PLY header (line {line_no}): unknown format {:?}",
                            other.unwrap_or("")
                        ))
                    }
                });
            }
            "element" => {
                let (Some(name), Some(count)) = (rest.first(), rest.get(1)) else {
                    return Err(format!(
                        "bad PLY header (line {line_no}): malformed element '{line}'"
                    ));
                };
                let count: usize = count.parse().map_err(|_| {
                    format!("bad PLY header (line {line_no}): bad element count '{count}'")
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(format!(
                        "bad PLY header (line {line_no}): property before any element"
                    ));
                };
                let bad_type = |t: &str| {
                    format!("bad PLY header (line {line_no}): unknown property type '{t}'")
                };
                let prop = if rest.first() == Some(&"list") {
                    let (Some(ct), Some(it), Some(name)) = (rest.get(1), rest.get(2), rest.get(3))
                    else {
                        return Err(format!(
                            "bad PLY header (line {line_no}): malformed list property '{line}'"
                        ));
                    };
                    let count = Scalar::parse(ct).ok_or_else(|| bad_type(ct))?;
                    let item = Scalar::parse(it).ok_or_else(|| bad_type(it))?;
                    if !count.is_integer() {
                        return Err(format!(
                            "bad PLY header (line {line_no}): list count type must be an integer"
                        ));
                    }
                    Property {
                        name: name.to_string(),
                        kind: PropKind::List { count, item },
                    }
                } else {
                    let (Some(t), Some(name)) = (rest.first(), rest.get(1)) else {
                        return Err(format!(
                            "bad PLY header (line {line_no}): malformed property '{line}'"
                        ));
                    };
                    let s = Scalar::parse(t).ok_or_else(|| bad_type(t))?;
                    Property {
                        name: name.to_string(),
                        kind: PropKind::Scalar(s),
                    }
                };
                element.props.push(prop);
            }
            "end_header" => break,
            other => {
                return Err(format!(
                    "bad PLY header (line {line_no}): unknown keyword '{other}'"
                ))
            }
        }
    }
    let format = format.ok_or("bad PLY header: missing 'format' line")?;
    // Every element needs some bytes of body: reject counts the file cannot hold before any
    // storage is reserved (a 200-byte header may declare 2^32 faces).
    let available = bytes.len().saturating_sub(pos);
    let mut needed = 0usize;
    for el in &elements {
        let per = min_element_bytes(el, format);
        needed = needed.saturating_add(el.count.saturating_mul(per));
        if needed > available.saturating_add(1) {
            return Err(format!(
                "bad PLY header: element '{}' declares {} entries of at least {per} bytes each, \
                 but the file has only {available} bytes of data",
                el.name, el.count
            ));
        }
    }
    Ok(Header {
        format,
        elements,
        body: pos,
    })
}

/// The fewest bytes one entry of `el` takes in the body: the sizes of its scalars and list
/// counts in binary files; two characters (a digit and a separator) per value in ascii ones.
fn min_element_bytes(el: &Element, format: Format) -> usize {
    el.props
        .iter()
        .map(|p| match (format, &p.kind) {
            (Format::Ascii, _) => 2,
            (_, PropKind::Scalar(t)) => t.size(),
            (_, PropKind::List { count, .. }) => count.size(),
        })
        .sum()
}

/// A source of values for the PLY body, ascii or binary.
trait Body {
    /// Reads one value of type `t`; an error at the end of the data or on a malformed token.
    fn read(&mut self, t: Scalar) -> std::result::Result<f64, String>;
    /// Skips one value of type `t`.
    fn skip(&mut self, t: Scalar) -> std::result::Result<(), String> {
        self.read(t).map(|_| ())
    }
}

struct BinaryBody<'a> {
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
}

impl BinaryBody<'_> {
    fn take<const N: usize>(&mut self) -> std::result::Result<[u8; N], String> {
        let end = self.pos + N;
        if end > self.data.len() {
            return Err("unexpected end of file (truncated data)".into());
        }
        let mut b = [0u8; N];
        b.copy_from_slice(&self.data[self.pos..end]);
        self.pos = end;
        if self.big_endian {
            b.reverse();
        }
        Ok(b)
    }
}

impl Body for BinaryBody<'_> {
    fn read(&mut self, t: Scalar) -> std::result::Result<f64, String> {
        Ok(match t {
            Scalar::I8 => i8::from_le_bytes(self.take::<1>()?) as f64,
            Scalar::U8 => u8::from_le_bytes(self.take::<1>()?) as f64,
            Scalar::I16 => i16::from_le_bytes(self.take::<2>()?) as f64,
            Scalar::U16 => u16::from_le_bytes(self.take::<2>()?) as f64,
            Scalar::I32 => i32::from_le_bytes(self.take::<4>()?) as f64,
            Scalar::U32 => u32::from_le_bytes(self.take::<4>()?) as f64,
            Scalar::F32 => f32::from_le_bytes(self.take::<4>()?) as f64,
            Scalar::F64 => f64::from_le_bytes(self.take::<8>()?),
        })
    }
    fn skip(&mut self, t: Scalar) -> std::result::Result<(), String> {
        let end = self.pos + t.size();
        if end > self.data.len() {
            return Err("unexpected end of file (truncated data)".into());
        }
        self.pos = end;
        Ok(())
    }
}

struct AsciiBody<'a> {
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Body for AsciiBody<'_> {
    fn read(&mut self, t: Scalar) -> std::result::Result<f64, String> {
        let tok = self
            .tokens
            .next()
            .ok_or_else(|| "unexpected end of file (truncated data)".to_string())?;
        let v: f64 = if t.is_integer() {
            tok.parse::<i64>()
                .map(|i| i as f64)
                .or_else(|_| tok.parse::<f64>())
                .map_err(|_| format!("malformed number '{tok}'"))?
        } else {
            tok.parse::<f64>()
                .map_err(|_| format!("malformed number '{tok}'"))?
        };
        Ok(v)
    }
}

/// Which slot of the output a vertex property feeds.
#[derive(Clone, Copy)]
enum Slot {
    Skip,
    Pos(usize),
    Normal(usize),
    Uv(usize),
    /// Channel of an attribute.
    Attr(usize, usize),
}

/// Groups the scalar properties of a PLY element (except `reserved` ones) into attributes the
/// way Mitsuba 3's PLY loader does (see [`MeshAttribute`]); `kind` is `vertex_` or `face_`.
/// Returns (name, property index of each channel).
fn group_attributes(el: &Element, kind: &str, reserved: &[&str]) -> Vec<(String, Vec<usize>)> {
    let scalar: Vec<(usize, &str)> = el
        .props
        .iter()
        .enumerate()
        .filter(|(_, p)| matches!(p.kind, PropKind::Scalar(_)))
        .map(|(i, p)| (i, p.name.as_str()))
        .collect();
    let find = |n: &str| scalar.iter().find(|(_, m)| *m == n).map(|(i, _)| *i);
    let mut out: Vec<(String, Vec<usize>)> = Vec::new();
    let mut skip: Vec<&str> = reserved.to_vec();
    for names in [["r", "g", "b", "a"], ["red", "green", "blue", "alpha"]] {
        if let (Some(r), Some(g), Some(b)) = (find(names[0]), find(names[1]), find(names[2])) {
            let mut idx = vec![r, g, b];
            idx.extend(find(names[3]));
            out.push((format!("{kind}color"), idx));
            skip.extend(names);
            break;
        }
    }
    skip.extend(["r", "g", "b", "a"]);
    const POSTFIX: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];
    let mut seen: Vec<String> = Vec::new();
    // the attribute being read: prefix, postfix category, property indices
    let mut cur: Option<(String, usize, Vec<usize>)> = None;
    let flush = |cur: &mut Option<(String, usize, Vec<usize>)>,
                 out: &mut Vec<(String, Vec<usize>)>,
                 seen: &mut Vec<String>| {
        if let Some((prefix, cat, idx)) = cur.take() {
            if idx.len() == 1 || idx.len() == 3 {
                let color = if cat == 1 { "_color" } else { "" };
                out.push((format!("{kind}{prefix}{color}"), idx));
                seen.push(prefix);
            }
        }
    };
    let mut skip_prefix: Option<String> = None;
    for &(i, name) in &scalar {
        if skip.contains(&name) {
            continue;
        }
        if let Some(p) = &skip_prefix {
            if name.starts_with(p.as_str()) {
                continue;
            }
            skip_prefix = None;
        }
        let Some(pos) = name.rfind('_') else {
            flush(&mut cur, &mut out, &mut seen);
            continue;
        };
        let (prefix, postfix) = (&name[..pos], &name[pos + 1..]);
        if postfix.len() != 1 {
            flush(&mut cur, &mut out, &mut seen);
            continue;
        }
        let ch = postfix.as_bytes()[0];
        if cur.as_ref().is_some_and(|(p, _, _)| p != prefix) {
            flush(&mut cur, &mut out, &mut seen);
        }
        match &mut cur {
            None => {
                if seen.iter().any(|p| p == prefix) {
                    skip_prefix = Some(prefix.to_string());
                    continue;
                }
                if let Some(cat) = POSTFIX[0].iter().position(|&c| c == ch) {
                    cur = Some((prefix.to_string(), cat, vec![i]));
                }
            }
            Some((_, cat, idx)) => {
                if idx.len() < 4 && POSTFIX[idx.len()][*cat] == ch {
                    idx.push(i);
                } else {
                    // an invalid sequence: the attribute is ignored
                    cur = None;
                    skip_prefix = Some(prefix.to_string());
                }
            }
        }
    }
    flush(&mut cur, &mut out, &mut seen);
    out
}

/// The attributes of an element and the slot of every property that feeds one.
fn attribute_slots(
    el: &Element,
    kind: &str,
    reserved: &[&str],
    slots: &mut [Slot],
) -> Vec<MeshAttribute> {
    group_attributes(el, kind, reserved)
        .into_iter()
        .enumerate()
        .map(|(k, (name, idx))| {
            for (c, &i) in idx.iter().enumerate() {
                slots[i] = Slot::Attr(k, c);
            }
            MeshAttribute {
                name,
                dim: idx.len(),
                data: Vec::with_capacity(el.count * idx.len()),
            }
        })
        .collect()
}

/// The texture-coordinate property names of a vertex element, if it has a pair.
fn uv_pair(el: &Element) -> Option<[&'static str; 2]> {
    let has = |n: &str| el.props.iter().any(|p| p.name == n);
    [
        ["u", "v"],
        ["s", "t"],
        ["texture_u", "texture_v"],
        ["texture_s", "texture_t"],
    ]
    .into_iter()
    .find(|[a, b]| has(a) && has(b))
}

fn vertex_slots(el: &Element) -> (Vec<Slot>, bool, bool) {
    let names: Vec<&str> = el.props.iter().map(|p| p.name.as_str()).collect();
    let has = |n: &str| names.contains(&n);
    let has_normals = has("nx") && has("ny") && has("nz");
    let uv_names = [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ]
    .into_iter()
    .find(|(a, b)| has(a) && has(b));
    let slots = el
        .props
        .iter()
        .map(|p| {
            if !matches!(p.kind, PropKind::Scalar(_)) {
                return Slot::Skip;
            }
            match p.name.as_str() {
                "x" => Slot::Pos(0),
                "y" => Slot::Pos(1),
                "z" => Slot::Pos(2),
                "nx" if has_normals => Slot::Normal(0),
                "ny" if has_normals => Slot::Normal(1),
                "nz" if has_normals => Slot::Normal(2),
                n => match uv_names {
                    Some((a, _)) if n == a => Slot::Uv(0),
                    Some((_, b)) if n == b => Slot::Uv(1),
                    _ => Slot::Skip,
                },
            }
        })
        .collect();
    (slots, has_normals, uv_names.is_some())
}

fn parse_body(header: &Header, body: &mut dyn Body) -> std::result::Result<MeshData, String> {
    let mut data = MeshData::default();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut seen_vertex = false;
    let mut has_n = false;
    let mut has_uv = false;
    let mut faces_seen = false;
    for el in &header.elements {
        match el.name.as_str() {
            "vertex" if !seen_vertex => {
                seen_vertex = true;
                let (mut slots, hn, huv) = vertex_slots(el);
                let mut reserved = vec!["x", "y", "z", "nx", "ny", "nz"];
                if let Some(pair) = uv_pair(el) {
                    reserved.extend(pair);
                }
                let mut attrs = attribute_slots(el, "vertex_", &reserved, &mut slots);
                let mut values = vec![0f32; attrs.iter().map(|a| a.dim).sum::<usize>()];
                let offsets: Vec<usize> = attrs
                    .iter()
                    .scan(0, |o, a| {
                        let r = *o;
                        *o += a.dim;
                        Some(r)
                    })
                    .collect();
                for axis in ["x", "y", "z"] {
                    if !el.props.iter().any(|p| p.name == axis) {
                        return Err(format!("vertex element has no '{axis}' property"));
                    }
                }
                has_n = hn;
                has_uv = huv;
                data.positions.reserve(el.count);
                for i in 0..el.count {
                    let mut p = [0f32; 3];
                    let mut n = [0f32; 3];
                    let mut uv = [0f32; 2];
                    for (prop, slot) in el.props.iter().zip(&slots) {
                        let ctx = |e: String| format!("vertex {i}: {e}");
                        match (&prop.kind, *slot) {
                            (PropKind::Scalar(t), Slot::Pos(k)) => {
                                p[k] = body.read(*t).map_err(ctx)? as f32
                            }
                            (PropKind::Scalar(t), Slot::Normal(k)) => {
                                n[k] = body.read(*t).map_err(ctx)? as f32
                            }
                            (PropKind::Scalar(t), Slot::Uv(k)) => {
                                uv[k] = body.read(*t).map_err(ctx)? as f32
                            }
                            (PropKind::Scalar(t), Slot::Attr(k, c)) => {
                                values[offsets[k] + c] = body.read(*t).map_err(ctx)? as f32
                            }
                            (PropKind::Scalar(t), Slot::Skip) => body.skip(*t).map_err(ctx)?,
                            (PropKind::List { count, item }, _) => {
                                skip_list(body, *count, *item).map_err(ctx)?
                            }
                        }
                    }
                    for (a, &o) in attrs.iter_mut().zip(&offsets) {
                        a.data.extend_from_slice(&values[o..o + a.dim]);
                    }
                    let p = Vec3::from(p);
                    if !p.is_finite() {
                        return Err(format!("vertex {i} has a non-finite position {p}"));
                    }
                    data.positions.push(p);
                    if has_n {
                        normals.push(Vec3::from(n));
                    }
                    if has_uv {
                        uvs.push(Vec2::from(uv));
                    }
                }
                data.attributes.extend(attrs);
            }
            "face" if !faces_seen => {
                faces_seen = true;
                let idx_prop = el.props.iter().position(|p| {
                    matches!(p.kind, PropKind::List { .. })
                        && (p.name == "vertex_indices" || p.name == "vertex_index")
                });
                let Some(idx_prop) = idx_prop else {
                    return Err(
                        "face element has no 'vertex_indices' or 'vertex_index' list".into(),
                    );
                };
                data.indices.reserve(el.count);
                let mut slots = vec![Slot::Skip; el.props.len()];
                let mut attrs = attribute_slots(el, "face_", &[], &mut slots);
                let dims: Vec<usize> = attrs.iter().map(|a| a.dim).collect();
                let mut values: Vec<Vec<f32>> = dims.iter().map(|&d| vec![0f32; d]).collect();
                let mut poly: Vec<u32> = Vec::with_capacity(8);
                for f in 0..el.count {
                    let before = data.indices.len();
                    for (j, prop) in el.props.iter().enumerate() {
                        let ctx = |e: String| format!("face {f}: {e}");
                        match &prop.kind {
                            PropKind::Scalar(t) => match slots[j] {
                                Slot::Attr(k, c) => {
                                    values[k][c] = body.read(*t).map_err(ctx)? as f32
                                }
                                _ => body.skip(*t).map_err(ctx)?,
                            },
                            PropKind::List { count, item } if j == idx_prop => {
                                let c = read_count(body, *count).map_err(ctx)?;
                                poly.clear();
                                for _ in 0..c {
                                    let v = body.read(*item).map_err(ctx)?;
                                    if !(v >= 0.0 && v <= u32::MAX as f64 && v.fract() == 0.0) {
                                        return Err(format!("face {f}: invalid vertex index {v}"));
                                    }
                                    poly.push(v as u32);
                                }
                                for k in 1..poly.len().saturating_sub(1) {
                                    data.indices.push([poly[0], poly[k], poly[k + 1]]);
                                }
                            }
                            PropKind::List { count, item } => {
                                skip_list(body, *count, *item).map_err(ctx)?
                            }
                        }
                    }
                    // one value per triangle of the face's fan
                    for _ in before..data.indices.len() {
                        for (a, v) in attrs.iter_mut().zip(&values) {
                            a.data.extend_from_slice(v);
                        }
                    }
                }
                data.attributes.extend(attrs);
            }
            _ if el.props.is_empty() => {}
            _ => {
                for i in 0..el.count {
                    for prop in &el.props {
                        let ctx = |e: String| format!("element '{}' #{i}: {e}", el.name);
                        match &prop.kind {
                            PropKind::Scalar(t) => body.skip(*t).map_err(ctx)?,
                            PropKind::List { count, item } => {
                                skip_list(body, *count, *item).map_err(ctx)?
                            }
                        }
                    }
                }
            }
        }
    }
    if !seen_vertex {
        return Err("no 'vertex' element".into());
    }
    if has_n {
        data.normals = Some(normals);
    }
    if has_uv {
        data.uvs = Some(uvs);
    }
    Ok(data)
}

fn read_count(body: &mut dyn Body, t: Scalar) -> std::result::Result<usize, String> {
    let c = body.read(t)?;
    if !(c >= 0.0 && c.fract() == 0.0 && c <= 1e9) {
        return Err(format!("invalid list length {c}"));
    }
    Ok(c as usize)
}

fn skip_list(body: &mut dyn Body, count: Scalar, item: Scalar) -> std::result::Result<(), String> {
    let c = read_count(body, count)?;
    for _ in 0..c {
        body.skip(item)?;
    }
    Ok(())
}

/// Loads a Stanford PLY file (ascii, binary little or big endian). Vertex properties `x y z`,
/// optionally `nx ny nz` and texture coordinates (`u v`, `s t`, `texture_u texture_v` or
/// `texture_s texture_t`), of any scalar type; further vertex and face properties become
/// [`MeshAttribute`]s (grouped and named as Mitsuba does); list properties other than the
/// face indices, and other elements, are skipped.
/// Faces come from the list property `vertex_indices` (or `vertex_index`); polygons are
/// fanned into triangles.
pub fn load_ply(path: &Path) -> Result<MeshData> {
    let bytes = read_file(path)?;
    parse_ply(&bytes).map_err(|m| SceneError::file(path, m))
}

/// [`load_ply`] on the bytes of a file; the error says what is wrong (the caller names the
/// file).
pub fn parse_ply(bytes: &[u8]) -> std::result::Result<MeshData, String> {
    let header = parse_header(bytes)?;
    let body = &bytes[header.body.min(bytes.len())..];
    let result = match header.format {
        Format::Ascii => {
            let text = std::str::from_utf8(body).map_err(|_| "ascii PLY body is not valid text")?;
            let mut b = AsciiBody {
                tokens: text.split_ascii_whitespace(),
            };
            parse_body(&header, &mut b)
        }
        Format::BinaryLe | Format::BinaryBe => {
            let mut b = BinaryBody {
                data: body,
                pos: 0,
                big_endian: header.format == Format::BinaryBe,
            };
            parse_body(&header, &mut b)
        }
    };
    let data = result.map_err(|m| format!("invalid PLY file: {m}"))?;
    data.validate("invalid PLY file")?;
    if data.indices.is_empty() {
        return Err("PLY file contains no faces".into());
    }
    Ok(data)
}

/// Writes `mesh` as a PLY file (used by tests; handy for debugging).
pub fn write_ply(path: &Path, mesh: &MeshData, binary: bool) -> std::io::Result<()> {
    use std::io::Write;
    let mut out: Vec<u8> = Vec::new();
    let fmt = if binary {
        "binary_little_endian"
    } else {
        "ascii"
    };
    writeln!(
        out,
        "ply\nformat {fmt} 1.0\nelement vertex {}",
        mesh.positions.len()
    )?;
    writeln!(out, "property float x\nproperty float y\nproperty float z")?;
    if mesh.normals.is_some() {
        writeln!(
            out,
            "property float nx\nproperty float ny\nproperty float nz"
        )?;
    }
    if mesh.uvs.is_some() {
        writeln!(out, "property float u\nproperty float v")?;
    }
    writeln!(out, "element face {}", mesh.indices.len())?;
    writeln!(out, "property list uchar uint vertex_indices\nend_header")?;
    for i in 0..mesh.positions.len() {
        let mut vals = mesh.positions[i].to_array().to_vec();
        if let Some(n) = &mesh.normals {
            vals.extend(n[i].to_array());
        }
        if let Some(uv) = &mesh.uvs {
            vals.extend(uv[i].to_array());
        }
        if binary {
            for v in vals {
                out.extend(v.to_le_bytes());
            }
        } else {
            let s: Vec<String> = vals.iter().map(|v| format!("{v:?}")).collect();
            writeln!(out, "{}", s.join(" "))?;
        }
    }
    for tri in &mesh.indices {
        if binary {
            out.push(3);
            for i in tri {
                out.extend(i.to_le_bytes());
            }
        } else {
            writeln!(out, "3 {} {} {}", tri[0], tri[1], tri[2])?;
        }
    }
    std::fs::write(path, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn tmp_dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("specula-mesh-io-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn assets() -> PathBuf {
        specula_testdata::root().join("scenes/assets")
    }

    fn small_mesh() -> MeshData {
        MeshData {
            positions: vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.25),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, -0.5),
            ],
            normals: Some(vec![
                Vec3::Z,
                Vec3::new(0.3, 0.0, 1.0),
                Vec3::new(0.0, 0.3, 1.0),
                Vec3::new(-0.2, -0.2, 1.0),
            ]),
            uvs: Some(vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(1.0, 1.0),
                Vec2::new(0.0, 0.1),
            ]),
            indices: vec![[0, 1, 2], [0, 2, 3]],
            attributes: Vec::new(),
        }
    }

    #[test]
    fn ply_attributes_grouped_as_mitsuba() {
        // Mitsuba 3.9.1 on this file lists: vertex_color [255, 128, 0, …] (uchar, not
        // normalised), vertex_foo (x, y, z), vertex_bar (bar_0), vertex_baz_color (r, g, b);
        // `lone` (no postfix) and q_1, q_2 (two fields) are ignored; face_color (color_0..2)
        // and face_w (w_1).
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
property float foo_x\nproperty float foo_y\nproperty float foo_z\nproperty float bar_0\n\
property float baz_r\nproperty float baz_g\nproperty float baz_b\nproperty float lone\n\
property float q_1\nproperty float q_2\nelement face 2\nproperty list uchar int vertex_indices\n\
property float color_0\nproperty float color_1\nproperty float color_2\nproperty uchar w_1\n\
end_header\n\
0 0 0 255 128 0 1 2 3 0.5 0.1 0.2 0.3 7 1 2\n\
1 0 0 0 255 64 4 5 6 0.25 0.4 0.5 0.6 8 3 4\n\
0 1 0 10 20 30 7 8 9 0.125 0.7 0.8 0.9 9 5 6\n\
3 0 1 2 0.3 0.6 0.9 128\n\
4 0 1 2 1 0.1 0.2 0.4 7\n";
        let dir = tmp_dir("ply_attributes");
        let path = dir.join("attr.ply");
        std::fs::write(&path, text).unwrap();
        // the quad is fanned into two triangles, which share its face attributes
        let d = load_ply(&path).unwrap();
        assert_eq!(d.indices.len(), 3);
        let get = |n: &str| {
            d.attributes
                .iter()
                .find(|a| a.name == n)
                .unwrap_or_else(|| panic!("{n}: {:?}", d.attributes))
        };
        assert_eq!(
            get("vertex_color").data,
            [255.0, 128.0, 0.0, 0.0, 255.0, 64.0, 10.0, 20.0, 30.0]
        );
        assert_eq!(get("vertex_foo").dim, 3);
        assert_eq!(get("vertex_foo").data[3..6], [4.0, 5.0, 6.0]);
        assert_eq!(get("vertex_bar").data, [0.5, 0.25, 0.125]);
        assert_eq!(get("vertex_baz_color").data[6..], [0.7, 0.8, 0.9]);
        assert_eq!(
            get("face_color").data,
            [0.3, 0.6, 0.9, 0.1, 0.2, 0.4, 0.1, 0.2, 0.4]
        );
        assert_eq!(get("face_w").data, [128.0, 7.0, 7.0]);
        let names: Vec<&str> = d.attributes.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names.len(), 6, "{names:?}");
        assert!(d.positions.len() == 3 && d.validate("x").is_ok());
        // binary round trip keeps positions; attribute lengths are validated
        let mut bad = d.clone();
        bad.attributes[0].data.pop();
        assert!(bad.validate("bad").unwrap_err().contains("vertex_color"));
    }

    #[test]
    fn ply_round_trip_ascii_and_binary() {
        let dir = tmp_dir("roundtrip");
        let mesh = small_mesh();
        for binary in [false, true] {
            let p = dir.join(if binary { "b.ply" } else { "a.ply" });
            write_ply(&p, &mesh, binary).unwrap();
            let back = load_ply(&p).unwrap();
            assert_eq!(back, mesh, "binary = {binary}");
        }
        let mut no_attr = small_mesh();
        no_attr.normals = None;
        no_attr.uvs = None;
        let p = dir.join("plain.ply");
        write_ply(&p, &no_attr, true).unwrap();
        assert_eq!(load_ply(&p).unwrap(), no_attr);
    }

    #[test]
    fn ply_big_endian_mixed_types_polygons_and_extra_elements() {
        // double positions, uchar 's t' texture coordinates (converted to f32), an extra
        // per-vertex property and list, a quad and a pentagon, an unknown element.
        let mut out = Vec::new();
        out.extend_from_slice(
            b"ply\r\nformat binary_big_endian 1.0\r\ncomment test\r\nelement vertex 5\r\n\
property double x\r\nproperty double y\r\nproperty double z\r\nproperty short extra\r\n\
property uchar s\r\nproperty uchar t\r\nproperty list uchar float junk\r\n\
element face 2\r\nproperty uchar flags\r\nproperty list ushort int16 vertex_index\r\n\
element edge 1\r\nproperty int a\r\nproperty int b\r\nend_header\r\n",
        );
        let verts: [[f64; 3]; 5] = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 2.0, 0.0],
        ];
        for (i, v) in verts.iter().enumerate() {
            for c in v {
                out.extend(c.to_be_bytes());
            }
            out.extend(7i16.to_be_bytes());
            out.push(i as u8);
            out.push(2 * i as u8);
            out.push(2);
            out.extend(1.5f32.to_be_bytes());
            out.extend(2.5f32.to_be_bytes());
        }
        out.push(0);
        out.extend(4u16.to_be_bytes());
        for i in [0i16, 1, 2, 3] {
            out.extend(i.to_be_bytes());
        }
        out.push(1);
        out.extend(5u16.to_be_bytes());
        for i in [0i16, 1, 2, 4, 3] {
            out.extend(i.to_be_bytes());
        }
        out.extend(0i32.to_be_bytes());
        out.extend(1i32.to_be_bytes());
        let dir = tmp_dir("bigendian");
        let p = dir.join("be.ply");
        std::fs::write(&p, &out).unwrap();
        let m = load_ply(&p).unwrap();
        assert_eq!(m.positions.len(), 5);
        assert_eq!(m.positions[4], Vec3::new(0.5, 2.0, 0.0));
        assert!(m.normals.is_none());
        assert_eq!(m.uvs.as_ref().unwrap()[3], Vec2::new(3.0, 6.0));
        assert_eq!(
            m.indices,
            vec![[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 4], [0, 4, 3]]
        );
    }

    #[test]
    fn ply_errors_name_file_and_problem() {
        let dir = tmp_dir("errors");
        let mesh = small_mesh();
        let p = dir.join("full.ply");
        write_ply(&p, &mesh, true).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        // Truncated binary data.
        let t = dir.join("truncated.ply");
        std::fs::write(&t, &bytes[..bytes.len() - 5]).unwrap();
        let e = load_ply(&t).unwrap_err().to_string();
        assert!(
            e.contains("truncated.ply") && e.contains("truncated"),
            "{e}"
        );
        // Truncated ascii data.
        let a = dir.join("a.ply");
        write_ply(&a, &mesh, false).unwrap();
        let text = std::fs::read_to_string(&a).unwrap();
        let ta = dir.join("truncated_ascii.ply");
        std::fs::write(&ta, &text[..text.len() - 8]).unwrap();
        let e = load_ply(&ta).unwrap_err().to_string();
        assert!(
            e.contains("truncated_ascii.ply") && e.contains("truncated"),
            "{e}"
        );
        // Bad header.
        let h = dir.join("header.ply");
        std::fs::write(
            &h,
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n",
        )
        .unwrap();
        let e = load_ply(&h).unwrap_err().to_string();
        assert!(e.contains("header.ply") && e.contains("flot"), "{e}");
        let h2 = dir.join("nomagic.ply");
        std::fs::write(&h2, b"plx\n").unwrap();
        assert!(load_ply(&h2).unwrap_err().to_string().contains("magic"));
        let h3 = dir.join("noend.ply");
        std::fs::write(&h3, b"ply\nformat ascii 1.0\nelement vertex 1\n").unwrap();
        assert!(load_ply(&h3)
            .unwrap_err()
            .to_string()
            .contains("end_header"));
        // Index out of range.
        let mut bad = small_mesh();
        bad.indices[1][2] = 9;
        let o = dir.join("range.ply");
        write_ply(&o, &bad, false).unwrap();
        let e = load_ply(&o).unwrap_err().to_string();
        assert!(e.contains("range.ply") && e.contains("vertex 9"), "{e}");
        // NaN coordinates.
        let mut nan = small_mesh();
        nan.positions[2].y = f32::NAN;
        let n = dir.join("nan.ply");
        write_ply(&n, &nan, true).unwrap();
        let e = load_ply(&n).unwrap_err().to_string();
        assert!(e.contains("nan.ply") && e.contains("non-finite"), "{e}");
        // Missing file.
        let e = load_ply(&dir.join("missing.ply")).unwrap_err().to_string();
        assert!(e.contains("missing.ply") && e.contains("not found"), "{e}");
    }

    #[test]
    fn obj_missing_file_and_bad_data() {
        let dir = tmp_dir("obj");
        let e = load_obj(&dir.join("nope.obj")).unwrap_err().to_string();
        assert!(e.contains("nope.obj") && e.contains("not found"), "{e}");
        let bad = dir.join("bad.obj");
        std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap();
        let e = load_obj(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.obj"), "{e}");
        let nan = dir.join("nan.obj");
        std::fs::write(&nan, "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let e = load_obj(&nan).unwrap_err().to_string();
        assert!(e.contains("nan.obj") && e.contains("non-finite"), "{e}");
    }

    #[test]
    fn obj_groups_merge_quads_fan_and_v_flip() {
        let dir = tmp_dir("objgroups");
        let p = dir.join("g.obj");
        std::fs::write(
            &p,
            "mtllib nothere.mtl\no a\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
vt 0 1\nusemtl red\nf 1/1 2/2 3/3 4/4\ng b\nf 2/2 3/3 1/1\n",
        )
        .unwrap();
        let m = load_obj(&p).unwrap();
        // One vertex per (v, vt) pair over the whole file: 4 vertices, 3 triangles.
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [1, 2, 0]]);
        assert!(m.normals.is_none());
        assert_eq!(m.uvs.as_ref().unwrap()[3], Vec2::new(0.0, 0.0));
        assert_eq!(m.uvs.as_ref().unwrap()[0], Vec2::new(0.0, 1.0));
    }

    #[test]
    fn shared_assets_load() {
        let knot = load_obj(&assets().join("torusknot.obj")).unwrap();
        assert_eq!(knot.indices.len(), 48000);
        assert!(knot.normals.is_some() && knot.uvs.is_some());
        let bumpy = load_obj(&assets().join("bumpy.obj")).unwrap();
        assert_eq!(bumpy.indices.len(), 8192);
        assert!(bumpy.normals.is_none() && bumpy.uvs.is_none());
        let ico = load_ply(&assets().join("icosphere.ply")).unwrap();
        assert_eq!(ico.positions.len(), 10242);
        assert_eq!(ico.indices.len(), 20480);
        assert!(ico.normals.is_some() && ico.uvs.is_none());
    }

    /// Reproducers of `../shared/robustness/ply`: header counts the file cannot hold are
    /// rejected before any storage is reserved (these aborted on 25 and 51 GB allocations).
    #[test]
    fn ply_counts_beyond_the_file_length_are_rejected() {
        let bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483648\n\
            property float x\nproperty float y\nproperty float z\nelement face 1\n\
            property list uchar int vertex_indices\nend_header\n\0\0\0\0\0\0\0\0\0\0\0\0";
        let e = parse_ply(bin).unwrap_err();
        assert!(
            e.contains("'vertex' declares 2147483648 entries of at least 12 bytes")
                && e.contains("12 bytes of data"),
            "{e}"
        );
        let ascii = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
            property float y\nproperty float z\nelement face 4294967295\n\
            property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let e = parse_ply(ascii).unwrap_err();
        assert!(e.contains("'face' declares 4294967295 entries"), "{e}");
        // an element without properties takes no bytes: skipped, whatever its count
        let empty = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
            property float y\nproperty float z\nelement nothing 18446744073709551615\n\
            element face 1\nproperty list uchar int vertex_indices\nend_header\n\
            0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(parse_ply(empty).unwrap().indices, vec![[0, 1, 2]]);
        for name in ["huge_vertices.ply", "huge_faces.ply"] {
            let Some(p) = specula_testdata::shared(&format!("robustness/ply/{name}")) else {
                continue;
            };
            let e = load_ply(&p).unwrap_err().to_string();
            assert!(e.contains(name) && e.contains("bytes of data"), "{e}");
        }
    }

    /// `f 1//-31` (reproducer `robustness/obj/tobj_index_mul_overflow_debug_only.obj`)
    /// overflowed inside tobj in debug builds: out-of-range references are rejected first,
    /// with the line.
    #[test]
    fn obj_out_of_range_references_are_rejected_with_the_line() {
        let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//-31 2//1 3//1\n";
        let e = parse_obj(obj).unwrap_err();
        assert_eq!(
            e,
            "line 5: face refers to normal -31, but only 1 come before this line"
        );
        let cases: [(&[u8], &str); 4] = [
            (b"v 0 0 0\nf 0 1 1\n", "vertex 0"),
            (b"v 0 0 0\nf 1 1 9223372036854775807\n", "the file has 1"),
            (
                b"v 0 0 0\nvt 0 0\nf 1/-2 1/1 1/1\n",
                "texture coordinate -2",
            ),
            (b"v 0 0 0\nf 1///1 1 1\n", "malformed face corner"),
        ];
        for (obj, what) in cases {
            let e = parse_obj(obj).unwrap_err();
            assert!(e.starts_with("line ") && e.contains(what), "{e}");
        }
        // relative and forward references within range still load
        let ok = b"v 0 0 0\nv 1 0 0\nf -2 -1 3\nv 0 1 0\n";
        assert_eq!(parse_obj(ok).unwrap().indices.len(), 1);
        if let Some(p) =
            specula_testdata::shared("robustness/obj/tobj_index_mul_overflow_debug_only.obj")
        {
            let e = load_obj(&p).unwrap_err().to_string();
            assert!(e.contains("line 5: face refers to normal -31"), "{e}");
        }
    }

    /// The one-pass reader gives tobj's mesh (through `parse_obj_general`) bit for bit on
    /// the shared OBJ files and on files that exercise it (quads and larger polygons, negative
    /// and forward references, vertices shared with different texture coordinates, faces with
    /// and without normals, groups and materials, comments, CRLF, vertical tabs, a third
    /// texture coordinate), and leaves every other file to tobj, which reports its problems.
    #[test]
    fn one_pass_obj_reader_is_tobj() {
        let mut files: Vec<Vec<u8>> = ["torusknot.obj", "bumpy.obj"]
            .iter()
            .map(|f| std::fs::read(assets().join(f)).unwrap())
            .collect();
        for f in ["meshes/rectangle.obj", "meshes/sphere.obj"] {
            if let Some(p) = specula_testdata::shared(&format!("mitsuba-data/common/{f}")) {
                files.push(std::fs::read(p).unwrap());
            }
        }
        let same: [&[u8]; 6] = [
            b"# quad, pentagon\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\n\
              f 1 2 3 4\nf 1 2 3 4 5\nf -5 -4 -3\n",
            b"mtllib m.mtl\r\no a\r\nv 0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nvt 0 0\r\n\
              vt 1 0 0.5\r\nvt 1 1\r\nusemtl x\r\nf 1/1 2/2 3/3\r\ng b\r\n\
              f 3/1 2/2 1/3\r\ns 1\r\nf 1/1 2/2 3/3\r\n",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nvn 0 0 -1\n\
              f 1//1 2//1 3//1\nf 1//2 3//2 2//2\nf 1//1 3//1 4//1\nv 2 2 0\n",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\nf 1 2 3\n",
            b"v\x0b0 0 0\nv 1\t0 0\n  v 1 1 0  \nf 1 2 3\n#f 1 1 1\nvp 1 2\n",
            b"v 0 0 0\nv 1e0 0 0\nv 0 +1 0\nvt 0.25 0.75\nf 1/1 2/1 3/1\nf 3/1 2/1 1/1\n",
        ];
        files.extend(same.iter().map(|b| b.to_vec()));
        for (i, bytes) in files.iter().enumerate() {
            let want = parse_obj_general(bytes).unwrap();
            let got = parse_obj_fast(bytes).unwrap_or_else(|| panic!("file {i} not read"));
            assert_eq!(got, want, "file {i}");
        }
        // left to tobj: what they give is tobj's (mesh or error)
        let others: [&[u8]; 10] = [
            b"v 0 0 0 2\nv 1 0 0\nv 1 1 0\nf 1 2 3\n", // w
            b"v 0 0 0 1 0 0\nv 1 0 0 1 0 0\nv 1 1 0 1 0 0\nf 1 2 3\n", // colours
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nl 1 2\n",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2\nf 1 2 3\n",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 4\n",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 -4\n",
            b"v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1/1 2/1 3/1\n",
            b"v 0 0 0\nv 1 x 0\nv 1 1 0\nf 1 2 3\n",
            b"v 0 0 0\nv 1 nan 0\nv 1 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1\u{3000}0 0\nv 1 1 0\nf 1 2 3\n".as_bytes(),
        ];
        for (i, bytes) in others.iter().enumerate() {
            assert!(parse_obj_fast(bytes).is_none(), "case {i}");
            let (a, b) = (parse_obj(bytes), parse_obj_general(bytes));
            assert_eq!(a, b, "case {i}");
        }
        assert!(parse_obj(others[4]).unwrap_err().contains("line 4"));
    }

    /// One polygon of 90 000 corners (`robustness/obj/big_polygon_bvh_hang.obj`) loads as a
    /// fan in well under a second (the BVH over it is tested in `accel`).
    #[test]
    fn obj_huge_polygon_loads_as_a_fan() {
        let n = 90_000;
        let mut obj = String::new();
        for i in 0..n {
            let a = i as f32 / n as f32 * std::f32::consts::TAU;
            obj += &format!("v {} {} 0\n", a.cos(), a.sin());
        }
        obj += "f";
        for i in 1..=n {
            obj += &format!(" {i}");
        }
        obj += "\n";
        let t = std::time::Instant::now();
        let m = parse_obj(obj.as_bytes()).unwrap();
        assert_eq!(m.indices.len(), n - 2);
        assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
    }
}
