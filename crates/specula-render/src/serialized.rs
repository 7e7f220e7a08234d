//! Mitsuba's `serialized` mesh format: zlib-compressed indexed triangle meshes, several per
//! file, as Mitsuba 3's `serialized` shape plugin reads them.
//!
//! **Plugin** (`<shape type="serialized">`): `filename` (required), `shape_index` (default 0:
//! the first mesh of the file), `face_normals` (default false), `flip_normals` (default false),
//! `to_world` (default identity). [`load_serialized`] returns the raw object-space data of one
//! mesh; [`crate::geometry::Geometry::mesh`] applies the rest, as for OBJ and PLY.
//!
//! **Format** (little endian). Each mesh is a `u16` magic `0x041C` and a `u16` version (3 or
//! 4), then a zlib stream holding: `u32` flags (`0x0001` vertex normals, `0x0002` texture
//! coordinates, `0x0008` vertex colours, `0x0010` face normals, `0x1000` single precision,
//! `0x2000` double precision); in version 4 only, the mesh's name as a NUL-terminated string;
//! `u64` vertex count, `u64` triangle count; the positions (x, y, z per vertex), then the
//! normals, texture coordinates and colours when their flag is set, each as `f32`, or `f64`
//! with `0x2000`; then the triangles as three `u32` indices each. Meshes are concatenated; the
//! file ends with the byte offset of every mesh (`u32` each in version 3, `u64` in version 4)
//! and a `u32` mesh count. Mitsuba reads the table only for `shape_index` > 0, the version
//! from the file's first header.
//!
//! **As in Mitsuba 3:** vertex colours are read and dropped; the `0x0010` flag is ignored (only
//! the `face_normals` parameter selects face normals); meshes without normals get Mitsuba's
//! angle-weighted vertex normals; double-precision data is rounded to `f32`.
//!
//! **Deviations.** Mitsuba's documentation allows `u64` indices for meshes of more than 2³²
//! vertices (Mitsuba 3 itself always reads `u32`); such meshes are refused here (they would
//! need over 48 GB of positions). Mitsuba accepts `shape_index` equal to the mesh count (and
//! then reads past the table); Specula reports it out of range. Bad input (wrong magic,
//! truncated or corrupt data, counts larger than the file can hold, an offset table pointing
//! nowhere, indices out of range, non-finite values) gives one error naming the file; counts
//! are checked against what the compressed data can expand to before anything is allocated,
//! and decompression stops at the size the counts imply.

use crate::core::{Result, SceneError};
use crate::mesh_io::MeshData;
use flate2::read::ZlibDecoder;
use glam::{Vec2, Vec3};
use std::io::Read;
use std::path::Path;

/// The file format identifier.
pub const MAGIC: u16 = 0x041C;

const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE_PRECISION: u32 = 0x2000;

/// DEFLATE expands at most about 1032:1; allow a little more plus room for the header fields.
const MAX_EXPANSION: u64 = 1040;
/// Longest mesh name read (version 4).
const MAX_NAME: u64 = 1 << 16;

/// Reads mesh `shape_index` (0 = the first) of the `.serialized` file at `path`: object-space
/// positions, normals and texture coordinates as stored, triangles as `u32` index triples.
pub fn load_serialized(path: &Path, shape_index: i64) -> Result<MeshData> {
    let bytes = std::fs::read(path).map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => SceneError::file(path, "file not found"),
        _ => SceneError::file(path, format!("cannot read file: {e}")),
    })?;
    parse(&bytes, shape_index).map_err(|m| {
        SceneError::file(
            path,
            format!("invalid serialized mesh (shape_index {shape_index}): {m}"),
        )
    })
}

fn corrupt(e: std::io::Error) -> String {
    format!("corrupt compressed data ({e})")
}

/// A little-endian unsigned integer of `n` ≤ 8 bytes from the decompressed stream.
fn read_u64(z: &mut impl Read, n: usize, what: &str) -> std::result::Result<u64, String> {
    let mut word = [0u8; 8];
    z.read_exact(&mut word[..n]).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => format!("the data ends inside the {what}"),
        _ => corrupt(e),
    })?;
    Ok(u64::from_le_bytes(word))
}

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}
fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}
fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}

/// Parses mesh `shape_index` of a whole file; errors are messages without the file name.
pub fn parse(bytes: &[u8], shape_index: i64) -> std::result::Result<MeshData, String> {
    if shape_index < 0 {
        return Err("shape_index must be nonnegative".into());
    }
    let (Some(magic), Some(version)) = (u16_at(bytes, 0), u16_at(bytes, 2)) else {
        return Err(format!(
            "the file is {} bytes long, too short for a header",
            bytes.len()
        ));
    };
    if magic != MAGIC {
        return Err(format!(
            "not a Mitsuba serialized mesh (the file starts with 0x{magic:04X}, expected 0x{MAGIC:04X})"
        ));
    }
    if version != 3 && version != 4 {
        return Err(format!(
            "format version {version} is not supported (Mitsuba reads versions 3 and 4)"
        ));
    }
    let start = if shape_index == 0 {
        0
    } else {
        mesh_offset(bytes, version, shape_index as u64)?
    };
    // the compressed stream of this mesh runs from after its header to (at most) the file end
    let compressed = &bytes[start + 4..];
    let mut z = ZlibDecoder::new(compressed);
    let flags = read_u64(&mut z, 4, "flags")? as u32;
    if version == 4 {
        // the mesh's name, NUL-terminated (not used)
        let mut len = 0u64;
        while read_u64(&mut z, 1, "mesh name")? != 0 {
            len += 1;
            if len > MAX_NAME {
                return Err(format!("the mesh name is longer than {MAX_NAME} bytes"));
            }
        }
    }
    let vertices = read_u64(&mut z, 8, "vertex count")?;
    let triangles = read_u64(&mut z, 8, "triangle count")?;
    if vertices > u32::MAX as u64 {
        return Err(format!(
            "{vertices} vertices: meshes of more than 2^32 vertices (u64 indices) are not supported"
        ));
    }
    let double = flags & DOUBLE_PRECISION != 0;
    let fsize: usize = if double { 8 } else { 4 };
    let (has_n, has_uv, has_c) = (
        flags & HAS_NORMALS != 0,
        flags & HAS_TEXCOORDS != 0,
        flags & HAS_COLORS != 0,
    );
    let per_vertex = 3 + 3 * has_n as u128 + 2 * has_uv as u128 + 3 * has_c as u128;
    let need = vertices as u128 * per_vertex * fsize as u128 + triangles as u128 * 12;
    let can_hold = compressed.len() as u128 * MAX_EXPANSION as u128;
    if need > can_hold {
        return Err(format!(
            "{vertices} vertices and {triangles} triangles need {need} bytes of mesh data, more \
             than the {} compressed bytes of the file can hold",
            compressed.len()
        ));
    }
    let need = need as usize;
    // sized for `need` up front (no regrowth and copying) when that is moderate; a larger
    // claim grows with the data actually decompressed, never beyond `need`
    let mut body = Vec::with_capacity(need.min(1 << 26));
    z.take(need as u64)
        .read_to_end(&mut body)
        .map_err(corrupt)?;
    if body.len() < need {
        return Err(format!(
            "truncated: {vertices} vertices and {triangles} triangles need {need} bytes of mesh \
             data, the compressed stream holds {}",
            body.len()
        ));
    }
    let n = vertices as usize;
    let mut rest = &body[..];
    let mut floats = |count: usize| -> Vec<f32> {
        let (head, tail) = rest.split_at(count * fsize);
        rest = tail;
        if double {
            head.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().unwrap()) as f32)
                .collect()
        } else {
            head.chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
                .collect()
        }
    };
    let vec3s = |v: Vec<f32>| -> Vec<Vec3> { v.chunks_exact(3).map(Vec3::from_slice).collect() };
    let positions = vec3s(floats(3 * n));
    let normals = has_n.then(|| vec3s(floats(3 * n)));
    let uvs = has_uv.then(|| {
        floats(2 * n)
            .chunks_exact(2)
            .map(Vec2::from_slice)
            .collect::<Vec<_>>()
    });
    if has_c {
        // vertex colours: read and dropped, as Mitsuba does
        floats(3 * n);
    }
    let indices = rest
        .chunks_exact(12)
        .map(|c| {
            let i = |k: usize| u32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap());
            [i(0), i(1), i(2)]
        })
        .collect();
    let data = MeshData {
        positions,
        normals,
        uvs,
        indices,
        attributes: Vec::new(),
    };
    data.validate("the mesh")?;
    if data.indices.is_empty() {
        return Err("the mesh has no triangles".into());
    }
    Ok(data)
}

/// Byte offset of mesh `index` (> 0) from the end-of-file table, checked to hold a header.
fn mesh_offset(bytes: &[u8], version: u16, index: u64) -> std::result::Result<usize, String> {
    let len = bytes.len();
    let count = len
        .checked_sub(4)
        .and_then(|at| u32_at(bytes, at))
        .ok_or("the file is too short for its table of meshes")? as u64;
    if index >= count {
        return Err(format!(
            "out of range: the file holds {count} mesh{}",
            if count == 1 { "" } else { "es" }
        ));
    }
    let entry = if version == 4 { 8 } else { 4 };
    let table = count * entry + 4;
    if table > len as u64 - 4 {
        return Err(format!(
            "the file ({len} bytes) is too short for a table of {count} meshes"
        ));
    }
    let at = len - 4 - ((count - index) * entry) as usize;
    let offset = if version == 4 {
        u64_at(bytes, at).unwrap()
    } else {
        u32_at(bytes, at).unwrap() as u64
    };
    let table_start = (len as u64) - table;
    if offset + 4 > table_start {
        return Err(format!(
            "the table of meshes gives offset {offset} for it, beyond the mesh data ({table_start} bytes)"
        ));
    }
    let offset = offset as usize;
    if u16_at(bytes, offset) != Some(MAGIC) {
        return Err(format!(
            "the table of meshes gives offset {offset} for it, where there is no mesh header"
        ));
    }
    Ok(offset)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::write::ZlibEncoder;
    use flate2::Compression;
    use std::io::Write;

    /// One mesh to write: positions, optional normals, uvs and colours, triangles.
    #[derive(Clone)]
    struct Mesh {
        p: Vec<[f64; 3]>,
        n: Option<Vec<[f64; 3]>>,
        uv: Option<Vec<[f64; 2]>>,
        colors: bool,
        tris: Vec<[u32; 3]>,
    }

    fn quad() -> Mesh {
        Mesh {
            p: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.5],
                [0.0, 1.0, 0.1],
            ],
            n: Some(vec![[0.0, 0.0, 1.0]; 4]),
            uv: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
            colors: true,
            tris: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    fn tri(z: f64) -> Mesh {
        Mesh {
            p: vec![[0.0, 0.0, z], [2.0, 0.0, z], [0.0, 3.0, z]],
            n: None,
            uv: None,
            colors: false,
            tris: vec![[0, 1, 2]],
        }
    }

    /// Writes meshes in Mitsuba's format (version 3 or 4, f32 or f64).
    fn write(meshes: &[Mesh], version: u16, double: bool) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for (k, m) in meshes.iter().enumerate() {
            offsets.push(out.len() as u64);
            out.extend(MAGIC.to_le_bytes());
            out.extend(version.to_le_bytes());
            let mut body = Vec::new();
            let flags = ((m.n.is_some() as u32) * HAS_NORMALS)
                | ((m.uv.is_some() as u32) * HAS_TEXCOORDS)
                | ((m.colors as u32) * HAS_COLORS)
                | if double { DOUBLE_PRECISION } else { 0x1000 };
            body.extend(flags.to_le_bytes());
            if version == 4 {
                body.extend(format!("mesh{k}").bytes());
                body.push(0);
            }
            body.extend((m.p.len() as u64).to_le_bytes());
            body.extend((m.tris.len() as u64).to_le_bytes());
            let mut put = |v: f64| {
                if double {
                    body.extend(v.to_le_bytes())
                } else {
                    body.extend((v as f32).to_le_bytes())
                }
            };
            m.p.iter().flatten().for_each(|&v| put(v));
            if let Some(n) = &m.n {
                n.iter().flatten().for_each(|&v| put(v));
            }
            if let Some(uv) = &m.uv {
                uv.iter().flatten().for_each(|&v| put(v));
            }
            if m.colors {
                (0..3 * m.p.len()).for_each(|i| put(i as f64 * 0.1));
            }
            for t in &m.tris {
                t.iter().for_each(|i| body.extend(i.to_le_bytes()));
            }
            let mut enc = ZlibEncoder::new(Vec::new(), Compression::default());
            enc.write_all(&body).unwrap();
            out.extend(enc.finish().unwrap());
        }
        for o in &offsets {
            if version == 4 {
                out.extend(o.to_le_bytes());
            } else {
                out.extend((*o as u32).to_le_bytes());
            }
        }
        out.extend((meshes.len() as u32).to_le_bytes());
        out
    }

    fn check(d: &MeshData, m: &Mesh) {
        let p: Vec<Vec3> =
            m.p.iter()
                .map(|v| Vec3::from(v.map(|x| x as f32)))
                .collect();
        assert_eq!(d.positions, p);
        assert_eq!(
            d.normals,
            m.n.as_ref()
                .map(|n| n.iter().map(|v| Vec3::from(v.map(|x| x as f32))).collect())
        );
        assert_eq!(
            d.uvs,
            m.uv.as_ref()
                .map(|n| n.iter().map(|v| Vec2::from(v.map(|x| x as f32))).collect())
        );
        assert_eq!(d.indices, m.tris);
    }

    #[test]
    fn round_trip_every_version_precision_and_index() {
        let meshes = [quad(), tri(1.0), tri(2.0)];
        for version in [3, 4] {
            for double in [false, true] {
                let file = write(&meshes, version, double);
                for (i, m) in meshes.iter().enumerate() {
                    let d = parse(&file, i as i64).unwrap();
                    check(&d, m);
                }
                let e = parse(&file, 3).unwrap_err();
                assert!(e.contains("out of range: the file holds 3 meshes"), "{e}");
                assert!(parse(&file, -1).unwrap_err().contains("nonnegative"));
            }
        }
    }

    #[test]
    fn double_precision_is_rounded_to_f32() {
        let mut m = tri(0.0);
        m.p[1][0] = 1.0 + 1e-12;
        let d = parse(&write(&[m], 4, true), 0).unwrap();
        assert_eq!(d.positions[1].x, 1.0);
    }

    #[test]
    fn bad_headers() {
        let good = write(&[quad()], 4, false);
        assert!(parse(&[], 0).unwrap_err().contains("too short"));
        assert!(parse(&good[..3], 0).unwrap_err().contains("too short"));
        let mut bad = good.clone();
        bad[0] = 0x1D;
        assert!(parse(&bad, 0)
            .unwrap_err()
            .contains("not a Mitsuba serialized mesh"));
        let mut bad = good.clone();
        bad[2] = 5;
        assert!(parse(&bad, 0).unwrap_err().contains("version 5"));
        let e = parse(b"ply\nformat ascii 1.0\n", 0).unwrap_err();
        assert!(e.contains("not a Mitsuba serialized mesh"), "{e}");
    }

    #[test]
    fn every_truncation_and_corruption_is_an_error() {
        for version in [3, 4] {
            let file = write(&[quad(), tri(1.0)], version, false);
            for cut in 0..file.len() {
                // the first mesh does not need the table; everything shorter than its data fails
                let r0 = parse(&file[..cut], 0);
                let r1 = parse(&file[..cut], 1);
                assert!(r1.is_err(), "cut {cut}: mesh 1 read from a truncated file");
                if let Ok(d) = r0 {
                    check(&d, &quad());
                }
            }
            // flip every byte in turn: never a panic (errors or, rarely, other valid data)
            for i in 0..file.len() {
                let mut bad = file.clone();
                bad[i] ^= 0xA5;
                let _ = parse(&bad, 0);
                let _ = parse(&bad, 1);
            }
        }
    }

    #[test]
    fn absurd_counts_are_refused_before_allocating() {
        // a tiny file claiming 2^31 vertices and 2^40 triangles
        let mut body = Vec::new();
        body.extend(0x1000u32.to_le_bytes());
        body.extend((1u64 << 31).to_le_bytes());
        body.extend((1u64 << 40).to_le_bytes());
        let mut enc = ZlibEncoder::new(Vec::new(), Compression::default());
        enc.write_all(&body).unwrap();
        let mut file = Vec::new();
        file.extend(MAGIC.to_le_bytes());
        file.extend(3u16.to_le_bytes());
        file.extend(enc.finish().unwrap());
        let e = parse(&file, 0).unwrap_err();
        assert!(e.contains("more than the"), "{e}");
        // more than 2^32 vertices
        let mut body = Vec::new();
        body.extend(0x1000u32.to_le_bytes());
        body.extend((1u64 << 33).to_le_bytes());
        body.extend(1u64.to_le_bytes());
        let mut enc = ZlibEncoder::new(Vec::new(), Compression::default());
        enc.write_all(&body).unwrap();
        file.truncate(4);
        file.extend(enc.finish().unwrap());
        assert!(parse(&file, 0).unwrap_err().contains("2^32"));
        // counts that fit the expansion bound but not the data: truncated, small allocation
        let mut body = Vec::new();
        body.extend(0x1000u32.to_le_bytes());
        body.extend(1000u64.to_le_bytes());
        body.extend(10u64.to_le_bytes());
        body.extend([0u8; 100]);
        let mut enc = ZlibEncoder::new(Vec::new(), Compression::default());
        enc.write_all(&body).unwrap();
        file.truncate(4);
        file.extend(enc.finish().unwrap());
        assert!(parse(&file, 0).unwrap_err().contains("truncated"));
    }

    #[test]
    fn bad_indices_tables_and_values() {
        let mut m = tri(0.0);
        m.tris[0][2] = 3;
        let e = parse(&write(&[m], 4, false), 0).unwrap_err();
        assert!(e.contains("refers to vertex 3"), "{e}");
        let mut m = tri(0.0);
        m.p[0][1] = f64::NAN;
        assert!(parse(&write(&[m], 4, true), 0)
            .unwrap_err()
            .contains("non-finite"));
        let mut m = tri(0.0);
        m.p[0][1] = 1e300; // beyond f32
        assert!(parse(&write(&[m], 4, true), 0)
            .unwrap_err()
            .contains("non-finite"));
        let mut m = tri(0.0);
        m.tris.clear();
        assert!(parse(&write(&[m], 3, false), 0)
            .unwrap_err()
            .contains("no triangles"));
        // a table entry pointing past the data, or not at a header
        for (version, entry) in [(3u16, 4usize), (4, 8)] {
            let mut file = write(&[tri(0.0), tri(1.0)], version, false);
            let at = file.len() - 4 - entry;
            file[at] = 0xFF;
            file[at + 1] = 0xFF;
            assert!(
                parse(&file, 1).unwrap_err().contains("beyond"),
                "v{version}"
            );
            let mut file = write(&[tri(0.0), tri(1.0)], version, false);
            let at = file.len() - 4 - entry;
            file[at] = 1;
            assert!(parse(&file, 1).unwrap_err().contains("no mesh header"));
            // a count larger than the file
            let mut file = write(&[tri(0.0), tri(1.0)], version, false);
            let n = file.len();
            file[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
            assert!(parse(&file, 1)
                .unwrap_err()
                .contains("too short for a table"));
        }
    }

    #[test]
    fn load_names_the_file() {
        let e = load_serialized(Path::new("/nonexistent/x.serialized"), 0).unwrap_err();
        assert!(
            e.to_string().contains("x.serialized: file not found"),
            "{e}"
        );
        let dir = std::env::temp_dir().join(format!("specula-ser-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.serialized");
        std::fs::write(&path, b"garbage!").unwrap();
        let e = load_serialized(&path, 2).unwrap_err().to_string();
        assert!(
            e.contains("bad.serialized") && e.contains("shape_index 2"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The mesh file of Mitsuba's material-preview scenes (version 3, three meshes).
    #[test]
    fn matpreview_meshes_load_with_sane_bounds() {
        let Some(path) =
            specula_testdata::shared("mitsuba-data/common/meshes/matpreview.serialized")
        else {
            return;
        };
        let mut counts = vec![];
        for i in 0..3 {
            let d = load_serialized(&path, i).unwrap();
            let (lo, hi) = d.positions.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), &p| (lo.min(p), hi.max(p)),
            );
            // the plane, the interior sphere and the outer object: each within a few units
            assert!(lo.cmpgt(Vec3::splat(-20.0)).all() && hi.cmplt(Vec3::splat(20.0)).all());
            assert!((hi - lo).max_element() > 0.5, "mesh {i}: {lo} {hi}");
            assert!(d.normals.is_some() && d.uvs.is_some());
            counts.push((d.positions.len(), d.indices.len()));
        }
        assert_eq!(counts[0], (289, 512));
        assert!(load_serialized(&path, 3).is_err());
    }
}
