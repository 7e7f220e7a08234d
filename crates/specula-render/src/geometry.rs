//! Shapes: triangle meshes (OBJ, PLY, rectangle, cube) and analytic spheres and disks, with
//! Mitsuba 3's conventions for positions, normals, texture coordinates and shading frames.
//!
//! Everything is stored in world space. The conventions below were checked against Mitsuba
//! 3.9.1 (`scalar_rgb`) by shooting rays at small scenes (see the tests):
//!
//! - **Meshes.** The geometric normal is `normalize((p1 - p0) × (p2 - p0))` of the world-space
//!   vertices (so a mirroring `to_world` flips it, as in Mitsuba). Vertex normals are
//!   transformed by the inverse transpose of `to_world`, normalised, interpolated with the
//!   barycentrics and normalised again. Without normals in the file (and without
//!   `face_normals`) vertex normals are recomputed in world space, weighting each face normal
//!   by the angle of the face at the vertex (Mitsuba's `recompute_vertex_normals`); vertices
//!   are not merged by position. `face_normals` uses the geometric normal for shading even if
//!   the file has normals. Without texture coordinates `uv = (b1, b2)` (the barycentrics) and
//!   `∂p/∂u = p1 - p0`; with them `∂p/∂u` comes from the uv parameterisation, or from
//!   `coordinate_system(n)` when the uv triangle is degenerate.
//! - **Shading frame.** `s = normalize(∂p/∂u - n (n·∂p/∂u))` with `n` the shading normal,
//!   `t = n × s`; when `∂p/∂u = 0` (poles, disk centre) `s` comes from `Frame::from_normal`
//!   (Mitsuba's `coordinate_system`).
//! - **flip_normals** negates the geometric and the shading normal (so `t` flips, `s` does
//!   not).
//! - **Derivatives** (`SurfaceGeometry::dp_du`, `dp_dv`, what `bumpmap` uses; checked against
//!   Mitsuba by `tests/surface_derivatives.rs`): meshes with uvs solve the uv parameterisation
//!   (`∂p/∂v = (dp1·Δuv0.x − dp0·Δuv1.x) / det`), without uvs `∂p/∂u = p1 − p0`,
//!   `∂p/∂v = p2 − p0`, degenerate uvs `coordinate_system(n)`; sphere
//!   `∂p/∂v = π M · (z cos φ, z sin φ, −r)`; disk `∂p/∂v = 2π to_world · (−y, x, 0)`;
//!   cylinder `∂p/∂v = M · (0, 0, 1)`; instances carry their member's to world space.
//! - **Rectangle**: the square `[-1, 1]²` at z = 0, two triangles with vertex normals +z and
//!   `uv = ((x + 1) / 2, (y + 1) / 2)`; sampled analytically like Mitsuba.
//! - **Cube**: `[-1, 1]³`, Mitsuba's 24-vertex / 12-triangle layout, per-face uv (e.g. the +z
//!   face has `u = (y + 1) / 2, v = (x + 1) / 2`).
//! - **Disk**: the unit disk at z = 0; `uv = (r, φ / 2π)` with φ in [0, 2π) in object space;
//!   `∂p/∂u = to_world · (cos φ, sin φ, 0)`; the normal is `to_world`'s inverse transpose
//!   applied to +z (not flipped by a mirroring transform).
//! - **Sphere**: with `M = to_world · translate(center) · scale(radius)`, the world centre is
//!   `M · 0` and the world radius `|M · (1, 0, 0)|`; `uv = (φ / 2π, θ / π)` of
//!   `local = M⁻¹ · p` (θ from drjit's `unit_angle_z`), `∂p/∂u = 2π M · (-y, x, 0)`; the
//!   normal points outwards. (Mitsuba only warns about a shearing or non-uniformly scaling
//!   `M`; such spheres are not expected to match it exactly.)
//! - **Cylinder** (open, no caps): with `M = to_world · translate(p0) · to_frame(p1 − p0) ·
//!   scale(radius, radius, |p1 − p0|)` (`to_frame` from Mitsuba's `coordinate_system`), the unit
//!   cylinder x² + y² = 1, 0 ≤ z ≤ 1 of `local = M⁻¹ · p`; `uv = (φ / 2π, z)`,
//!   `∂p/∂u = 2π M · (−y, x, 0)`; the normal is `M`'s inverse transpose applied to (x, y, 0)
//!   (outwards); a sampled point's normal is `normalize(∂p/∂u × ∂p/∂v)`, which points inwards
//!   when `M` mirrors — both as Mitsuba 3.9 does. Area `2π |M·x| |M·z|` (exact without shear
//!   or non-uniform x/y scaling, which Mitsuba only warns about). A negative radius turns the
//!   parameterisation by π, as in Mitsuba.
//! - **Instance** (`shapegroup` + `instance`): a [`ShapeGroup`] holds its shapes in the
//!   group's own space, their BSDFs and one BVH over them, shared (`Arc`) by every instance.
//!   An instance of a group of k shapes occupies k consecutive scene shape slots (one per
//!   group shape, so that a hit's shape index names the right BSDF), of which only the first
//!   is put in the scene's BVH: one primitive whose box is the transformed group box and
//!   whose intersection carries the ray into the group's BVH. The surface is the group
//!   shape's, carried to world space: `p`, ∂p/∂u and ∂p/∂v by `to_world`, the normals by its
//!   inverse transpose, `s` from the world ∂p/∂u (as Mitsuba's `instance`); `mesh_attribute`
//!   reads the group shape's attributes. Instances cannot emit (Mitsuba forbids emitters in
//!   shape groups) and are never sampled by area (area 0, like Mitsuba's, which does not
//!   implement it). An instance costs one `Geometry` (a few hundred bytes) per group shape
//!   and one primitive in the scene's BVH; the group's meshes and BVH exist once.

use crate::core::{Hit, PositionSample, Ray, Result, SceneError, SurfaceGeometry};
use crate::mesh_io::{MeshAttribute, MeshData};
use glam::{Mat3, Mat4, Vec2, Vec3};
use specula_bsdf::frame::Frame;
use specula_bsdf::{Rgb, SurfaceData};
use std::f32::consts::PI;
use std::sync::Arc;

const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
const INV_TWO_PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;

/// A shape of the scene, in world space.
#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriMesh),
    Sphere(Sphere),
    Disk(Disk),
    Cylinder(Cylinder),
    Instance(Instance),
}

/// An indexed triangle mesh in world space (treat as read-only: the sampling tables are
/// computed at construction).
#[derive(Clone, Debug)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    /// Unit world-space vertex normals (shading normals); `None` with `face_normals`.
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    pub indices: Vec<[u32; 3]>,
    pub flip_normals: bool,
    /// Vertex and face attributes of a PLY file (for `mesh_attribute`).
    pub attributes: Vec<MeshAttribute>,
    /// Cumulative triangle areas (`cdf[i]` = area of triangles `0..=i`).
    cdf: Vec<f64>,
    /// First and last triangle with a non-zero area.
    valid: (usize, usize),
    area: f32,
    /// Set for rectangles, which are sampled analytically like Mitsuba's.
    rect: Option<RectSampling>,
    /// Per-triangle constant surface data of the built-in flat-faced meshes (rectangle,
    /// cube), whose vertex normals equal the face normal and whose uvs are affine on each
    /// face: the hit then only interpolates p and uv (see [`TriMesh::precompute_flat`]).
    flat: Option<Box<[FlatFace]>>,
}

/// What [`TriMesh::surface`] computes for one triangle of a flat-faced mesh that does not
/// depend on the point hit.
#[derive(Clone, Copy, Debug)]
struct FlatFace {
    n_geo: Vec3,
    sh_frame: Frame,
    dp_du: Vec3,
    dp_dv: Vec3,
}

#[derive(Clone, Copy, Debug)]
struct RectSampling {
    to_world: Mat4,
    /// Normal of sampled points (flip included).
    n: Vec3,
}

/// An analytic sphere.
#[derive(Clone, Debug)]
pub struct Sphere {
    /// World-space centre.
    pub center: Vec3,
    /// World-space radius.
    pub radius: f32,
    pub flip_normals: bool,
    /// Object (unit sphere) to world: `to_world · translate(center) · scale(radius)`.
    pub to_world: Mat4,
    pub to_object: Mat4,
}

/// An analytic disk: the unit disk at z = 0 in object space, any affine `to_world`.
#[derive(Clone, Debug)]
pub struct Disk {
    pub to_world: Mat4,
    pub to_object: Mat4,
    pub flip_normals: bool,
    /// Unit world-space normal (`to_world`'s inverse transpose applied to +z), not flipped.
    n: Vec3,
    area: f32,
}

/// An analytic open cylinder: the unit cylinder x² + y² = 1, 0 ≤ z ≤ 1 in object space, any
/// affine `to_world` (see the module docs).
#[derive(Clone, Debug)]
pub struct Cylinder {
    pub to_world: Mat4,
    pub to_object: Mat4,
    pub flip_normals: bool,
    /// `to_world`'s inverse transpose (3×3).
    nm: Mat3,
    /// Sign of `to_world`'s determinant (sampled normals follow ∂p/∂u × ∂p/∂v).
    det_sign: f32,
    area: f32,
}

/// Mitsuba's `shapegroup`: shapes in the group's own space with their scene BSDF indices, and
/// one BVH over them that every [`Instance`] of the group shares.
#[derive(Debug)]
pub struct ShapeGroup {
    pub shapes: Vec<Geometry>,
    /// Scene BSDF index of each shape.
    pub bsdfs: Vec<u32>,
    pub accel: crate::accel::Bvh,
    /// Bounds of the group's shapes (min, max); empty (min > max) for an empty group.
    bounds: (Vec3, Vec3),
}

impl ShapeGroup {
    /// A group of `shapes` (which must not be instances) with their scene BSDF indices.
    pub fn new(shapes: Vec<Geometry>, bsdfs: Vec<u32>) -> ShapeGroup {
        let accel = crate::accel::Bvh::build(&shapes);
        let bounds = shapes
            .iter()
            .map(Geometry::bounds)
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| {
                (lo.min(a), hi.max(b))
            });
        ShapeGroup {
            shapes,
            bsdfs,
            accel,
            bounds,
        }
    }
}

/// One scene slot of an instance of a [`ShapeGroup`]: it stands for the group's shape
/// `member`; the slot of member 0 is the one in the scene's BVH (see the module docs).
#[derive(Clone, Debug)]
pub struct Instance {
    pub group: Arc<ShapeGroup>,
    pub member: u32,
    pub to_world: Mat4,
    pub to_object: Mat4,
    /// `to_world`'s inverse transpose (3×3).
    nm: Mat3,
}

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// Mitsuba's `Interaction::initialize_sh_frame`: `s` is ∂p/∂u made orthogonal to `n`.
fn shading_frame(n: Vec3, dp_du: Vec3) -> Frame {
    let s = dp_du - n * n.dot(dp_du);
    let len2 = s.length_squared();
    let s = if dp_du == Vec3::ZERO || !(len2 > 0.0 && len2.is_finite()) {
        Frame::from_normal(n).s
    } else {
        s / len2.sqrt()
    };
    Frame {
        s,
        t: n.cross(s),
        n,
    }
}

/// The angle between two unit vectors, accurate near 0 and π (drjit's `unit_angle`).
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        PI - 2.0 * ((a + b).length() * 0.5).min(1.0).asin()
    } else {
        2.0 * ((a - b).length() * 0.5).min(1.0).asin()
    }
}

fn normal_matrix(to_world: &Mat4) -> Mat3 {
    Mat3::from_mat4(*to_world).inverse().transpose()
}

/// `atan2(y, x)` mapped to [0, 2π).
fn phi_positive(y: f32, x: f32) -> f32 {
    let phi = specula_bsdf::math::atan2(y, x);
    if phi < 0.0 {
        phi + 2.0 * PI
    } else {
        phi
    }
}

/// Mitsuba's `warp::square_to_uniform_disk_concentric`.
fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let x = 2.0 * u.x - 1.0;
    let y = 2.0 * u.y - 1.0;
    let quadrant_1_or_3 = x.abs() < y.abs();
    let r = if quadrant_1_or_3 { y } else { x };
    let rp = if quadrant_1_or_3 { x } else { y };
    let mut phi = 0.25 * PI * rp / r;
    if quadrant_1_or_3 {
        phi = 0.5 * PI - phi;
    }
    if x == 0.0 && y == 0.0 {
        phi = 0.0;
    }
    let (s, c) = phi.sin_cos();
    Vec2::new(r * c, r * s)
}

/// drjit's `unit_angle_z`: the angle between `v` and +z, accurate near the poles (for a
/// non-unit `v` this is what Mitsuba computes, too).
fn unit_angle_z(v: Vec3) -> f32 {
    let w = v.z.abs() - 1.0;
    let t = 2.0
        * (0.5 * (v.x * v.x + v.y * v.y + w * w).sqrt())
            .min(1.0)
            .asin();
    if v.z >= 0.0 {
        t
    } else {
        PI - t
    }
}

// ---------------------------------------------------------------------------------------------
// Constructors
// ---------------------------------------------------------------------------------------------

impl Geometry {
    /// A triangle mesh (OBJ/PLY data) placed by `to_world`. `face_normals` shades with the
    /// flat triangle normal even when the data has vertex normals; missing vertex normals are
    /// recomputed otherwise (angle-weighted, in world space). Errors on inconsistent data
    /// (index out of range, attribute counts, non-finite values) or a mesh without faces.
    pub fn mesh(
        data: MeshData,
        to_world: Mat4,
        face_normals: bool,
        flip_normals: bool,
    ) -> Result<Geometry> {
        data.validate("invalid mesh")
            .map_err(|m| SceneError::new(None, m))?;
        if data.indices.is_empty() {
            return Err(SceneError::new(None, "invalid mesh: no faces"));
        }
        if !to_world.is_finite() {
            return Err(SceneError::new(
                None,
                "invalid mesh: non-finite to_world transform",
            ));
        }
        let MeshData {
            positions,
            normals,
            uvs,
            indices,
            attributes,
        } = data;
        let positions: Vec<Vec3> = positions
            .into_iter()
            .map(|p| to_world.transform_point3(p))
            .collect();
        let normals = if face_normals {
            None
        } else if let Some(normals) = normals {
            let nm = normal_matrix(&to_world);
            Some(
                normals
                    .into_iter()
                    .map(|n| (nm * n).normalize_or_zero())
                    .collect(),
            )
        } else {
            Some(recompute_vertex_normals(&positions, &indices))
        };
        let mut mesh = TriMesh::new(positions, normals, uvs, indices, flip_normals);
        mesh.attributes = attributes;
        Ok(Geometry::Mesh(mesh))
    }

    /// Mitsuba's `rectangle`: the square [-1, 1]² in the z = 0 plane, normal +z.
    pub fn rectangle(to_world: Mat4, flip_normals: bool) -> Geometry {
        let positions: Vec<Vec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|&(x, y)| to_world.transform_point3(Vec3::new(x, y, 0.0)))
            .collect();
        let uvs = vec![
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(0.0, 1.0),
        ];
        let n = (normal_matrix(&to_world) * Vec3::Z).normalize_or_zero();
        let normals = vec![n; 4];
        let mut mesh = TriMesh::new(
            positions,
            Some(normals),
            Some(uvs),
            vec![[0, 1, 3], [1, 2, 3]],
            flip_normals,
        );
        mesh.rect = Some(RectSampling {
            to_world,
            n: if flip_normals { -n } else { n },
        });
        mesh.precompute_flat();
        Geometry::Mesh(mesh)
    }

    /// Mitsuba's `cube`: [-1, 1]³ with outward normals, 24 vertices and 12 triangles laid
    /// out as in Mitsuba's plugin (same per-face texture coordinates).
    pub fn cube(to_world: Mat4, flip_normals: bool) -> Geometry {
        #[rustfmt::skip]
        const V: [[f32; 3]; 24] = [
            [1.0, -1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0], [-1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0],
            [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, -1.0, 1.0],
            [-1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0], [1.0, -1.0, -1.0], [-1.0, -1.0, -1.0], [-1.0, 1.0, -1.0],
        ];
        const FACE_N: [[f32; 3]; 6] = [
            [0.0, -1.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [-1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
        ];
        const UV: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
        let nm = normal_matrix(&to_world);
        let positions = V
            .iter()
            .map(|&p| to_world.transform_point3(Vec3::from(p)))
            .collect();
        let normals = (0..24)
            .map(|i| (nm * Vec3::from(FACE_N[i / 4])).normalize_or_zero())
            .collect();
        let uvs = (0..24).map(|i| Vec2::from(UV[i % 4])).collect();
        let indices = (0..6u32)
            .flat_map(|f| {
                let b = 4 * f;
                [[b, b + 1, b + 2], [b + 3, b, b + 2]]
            })
            .collect();
        let mut mesh = TriMesh::new(positions, Some(normals), Some(uvs), indices, flip_normals);
        mesh.precompute_flat();
        Geometry::Mesh(mesh)
    }

    /// Mitsuba's `disk`: the unit disk at z = 0, normal +z (analytic; any affine `to_world`).
    pub fn disk(to_world: Mat4, flip_normals: bool) -> Geometry {
        let n = (normal_matrix(&to_world) * Vec3::Z).normalize_or_zero();
        let dp_du = to_world.transform_vector3(Vec3::X);
        let dp_dv = to_world.transform_vector3(Vec3::Y);
        let area = PI * dp_du.cross(dp_dv).length();
        Geometry::Disk(Disk {
            to_world,
            to_object: to_world.inverse(),
            flip_normals,
            n,
            area,
        })
    }

    /// Mitsuba's `sphere`: `center` and `radius` in object space, then `to_world` (which may
    /// rotate, translate and scale uniformly).
    pub fn sphere(center: Vec3, radius: f32, to_world: Mat4, flip_normals: bool) -> Geometry {
        let m = to_world * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
        let c = m.transform_point3(Vec3::ZERO);
        let r = m.transform_vector3(Vec3::X).length();
        let obj_to_world = m;
        Geometry::Sphere(Sphere {
            center: c,
            radius: r,
            flip_normals,
            to_world: obj_to_world,
            to_object: obj_to_world.inverse(),
        })
    }
}

impl Geometry {
    /// Mitsuba's `cylinder` from `p0` to `p1` with `radius`, then `to_world`. Errors when the
    /// axis or the radius is degenerate or the transform is not invertible.
    pub fn cylinder(
        p0: Vec3,
        p1: Vec3,
        radius: f32,
        to_world: Mat4,
        flip_normals: bool,
    ) -> Result<Geometry> {
        let d = p1 - p0;
        let len = d.length();
        if !(len > 0.0 && len.is_finite()) {
            return Err(SceneError::new(
                None,
                format!("cylinder: p0 {p0} and p1 {p1} must be distinct finite points"),
            ));
        }
        if !(radius != 0.0 && radius.is_finite()) {
            return Err(SceneError::new(
                None,
                format!("cylinder: radius must be nonzero and finite, got {radius}"),
            ));
        }
        let f = Frame::from_normal(d / len);
        let frame = Mat4::from_cols(
            f.s.extend(0.0),
            f.t.extend(0.0),
            f.n.extend(0.0),
            glam::Vec4::W,
        );
        let m = to_world
            * Mat4::from_translation(p0)
            * frame
            * Mat4::from_scale(Vec3::new(radius, radius, len));
        let det = Mat3::from_mat4(m).determinant();
        if !(det != 0.0 && det.is_finite() && m.is_finite()) {
            return Err(SceneError::new(
                None,
                "cylinder: to_world is not invertible",
            ));
        }
        let r = m.transform_vector3(Vec3::X).length();
        let l = m.transform_vector3(Vec3::Z).length();
        Ok(Geometry::Cylinder(Cylinder {
            to_world: m,
            to_object: m.inverse(),
            flip_normals,
            nm: normal_matrix(&m),
            det_sign: det.signum(),
            area: 2.0 * PI * r * l,
        }))
    }

    /// The scene slots of one instance of `group` placed by `to_world`: one per group shape
    /// (see the module docs). Errors when `to_world` is not invertible.
    pub fn instance(group: &Arc<ShapeGroup>, to_world: Mat4) -> Result<Vec<Geometry>> {
        let det = Mat3::from_mat4(to_world).determinant();
        if !(det != 0.0 && det.is_finite() && to_world.is_finite()) {
            return Err(SceneError::new(
                None,
                "instance: to_world is not invertible",
            ));
        }
        let to_object = to_world.inverse();
        let nm = normal_matrix(&to_world);
        Ok((0..group.shapes.len() as u32)
            .map(|member| {
                Geometry::Instance(Instance {
                    group: group.clone(),
                    member,
                    to_world,
                    to_object,
                    nm,
                })
            })
            .collect())
    }
}

impl Geometry {
    /// For Mitsuba's `merge`: the key under which this shape may be concatenated with other
    /// meshes — (has vertex normals, has texture coordinates, flip_normals) — or `None` for a
    /// shape that is not a triangle mesh in Mitsuba (spheres, disks, cylinders, instances;
    /// rectangles and cubes are meshes there too). A merged rectangle loses its analytic
    /// sampling, which only an emitting rectangle uses, and emitters are never merged.
    pub fn merge_key(&self) -> Option<(bool, bool, bool)> {
        match self {
            Geometry::Mesh(m) => Some((m.normals.is_some(), m.uvs.is_some(), m.flip_normals)),
            _ => None,
        }
    }

    /// Concatenates meshes that share a [`Geometry::merge_key`] into one mesh (vertices,
    /// normals, texture coordinates and triangles in order). Errors if there are none, the
    /// keys differ, or the result would exceed 2³² vertices.
    pub fn merge_meshes(shapes: Vec<Geometry>) -> Result<Geometry> {
        let key = shapes.first().and_then(Geometry::merge_key);
        let Some((has_n, has_uv, flip)) = key else {
            return Err(SceneError::new(None, "merge: no mesh to merge"));
        };
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        let mut indices = Vec::new();
        for g in shapes {
            if g.merge_key() != key {
                return Err(SceneError::new(None, "merge: meshes of different kinds"));
            }
            let Geometry::Mesh(m) = g else {
                unreachable!("merge_key is Some for meshes only")
            };
            let base = u32::try_from(positions.len())
                .ok()
                .filter(|b| (*b as u64) + (m.positions.len() as u64) <= u32::MAX as u64)
                .ok_or_else(|| {
                    SceneError::new(None, "merge: more than 2^32 vertices in one merged mesh")
                })?;
            positions.extend_from_slice(&m.positions);
            normals.extend(m.normals.into_iter().flatten());
            uvs.extend(m.uvs.into_iter().flatten());
            indices.extend(m.indices.iter().map(|t| t.map(|i| i + base)));
        }
        Ok(Geometry::Mesh(TriMesh::new(
            positions,
            has_n.then_some(normals),
            has_uv.then_some(uvs),
            indices,
            flip,
        )))
    }
}

/// Angle-weighted vertex normals (Mitsuba's `Mesh::recompute_vertex_normals`).
fn recompute_vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    for tri in indices {
        let v = tri.map(|i| positions[i as usize]);
        let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        if !n.is_finite() {
            continue;
        }
        for j in 0..3 {
            let side1 = (v[(j + 1) % 3] - v[j]).normalize();
            let side2 = (v[(j + 2) % 3] - v[j]).normalize();
            let angle = unit_angle(side1, side2);
            if angle.is_finite() {
                acc[tri[j] as usize] += n * angle;
            }
        }
    }
    acc.into_iter()
        .map(|n| {
            let len = n.length();
            if len > 0.0 {
                n / len
            } else {
                Vec3::X
            }
        })
        .collect()
}

impl TriMesh {
    fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
        flip_normals: bool,
    ) -> TriMesh {
        let mut cdf = Vec::with_capacity(indices.len());
        let mut sum = 0f64;
        let mut first = usize::MAX;
        let mut last = 0;
        for (i, tri) in indices.iter().enumerate() {
            let [p0, p1, p2] = tri.map(|k| positions[k as usize]);
            let a = 0.5 * (p1 - p0).cross(p2 - p0).length();
            if a > 0.0 && a.is_finite() {
                sum += a as f64;
                first = first.min(i);
                last = i;
            }
            cdf.push(sum);
        }
        TriMesh {
            positions,
            normals,
            uvs,
            indices,
            flip_normals,
            attributes: Vec::new(),
            cdf,
            valid: (first.min(last), last),
            area: sum as f32,
            rect: None,
            flat: None,
        }
    }

    /// Fills [`TriMesh::flat`] for a mesh whose every face is flat (vertex normals equal to
    /// the face normal, uvs affine over each triangle: `rectangle` and `cube`), evaluating
    /// the general [`TriMesh::surface`] once per triangle at its centroid. The general
    /// path's geometric normal, ∂p/∂u and ∂p/∂v depend on the triangle only, and its
    /// shading normal (the interpolated vertex normals, all equal) differs from the one
    /// stored by rounding only, so hits see the same geometry.
    fn precompute_flat(&mut self) {
        self.flat = None;
        let faces = (0..self.indices.len())
            .map(|i| {
                let sg = self.surface(&Hit {
                    t: 0.0,
                    shape: 0,
                    prim: i as u32,
                    u: 1.0 / 3.0,
                    v: 1.0 / 3.0,
                    vertices: None,
                });
                FlatFace {
                    n_geo: sg.n_geo,
                    sh_frame: sg.sh_frame,
                    dp_du: sg.dp_du,
                    dp_dv: sg.dp_dv,
                }
            })
            .collect();
        self.flat = Some(faces);
    }

    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.indices[i].map(|k| self.positions[k as usize])
    }

    fn sample_position(&self, u: Vec2) -> PositionSample {
        let pdf = if self.area > 0.0 {
            1.0 / self.area
        } else {
            0.0
        };
        if let Some(rect) = &self.rect {
            let p =
                rect.to_world
                    .transform_point3(Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0));
            return PositionSample {
                p,
                n: rect.n,
                uv: u,
                pdf,
            };
        }
        // Pick a triangle by area, reusing u.y (Mitsuba's DiscreteDistribution::sample_reuse).
        let total = self.cdf.last().copied().unwrap_or(0.0);
        let target = u.y as f64 * total;
        let i = self
            .cdf
            .partition_point(|&c| c < target)
            .clamp(self.valid.0, self.valid.1);
        let prev = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let a = self.cdf[i] - prev;
        let uy = if a > 0.0 {
            ((target - prev) / a).clamp(0.0, 1.0) as f32
        } else {
            0.5
        };
        // warp::square_to_uniform_triangle
        let t = (1.0 - u.x).max(0.0).sqrt();
        let (b1, b2) = (1.0 - t, t * uy);
        let b0 = 1.0 - b1 - b2;
        let [i0, i1, i2] = self.indices[i].map(|k| k as usize);
        let (p0, p1, p2) = (self.positions[i0], self.positions[i1], self.positions[i2]);
        let e0 = p1 - p0;
        let e1 = p2 - p0;
        let p = e0 * b1 + (e1 * b2 + p0);
        let ng = e0.cross(e1).normalize_or_zero();
        let mut n = match &self.normals {
            Some(ns) => {
                let n = (ns[i0] * b0 + ns[i1] * b1 + ns[i2] * b2).normalize_or_zero();
                if n == Vec3::ZERO {
                    ng
                } else {
                    n
                }
            }
            None => ng,
        };
        if self.flip_normals {
            n = -n;
        }
        let uv = match &self.uvs {
            Some(uv) => uv[i0] * b0 + uv[i1] * b1 + uv[i2] * b2,
            None => Vec2::new(b1, b2),
        };
        PositionSample { p, n, uv, pdf }
    }

    fn surface(&self, hit: &Hit) -> SurfaceGeometry {
        let tri = hit.prim as usize;
        let [p0, p1, p2] = hit.vertices.unwrap_or_else(|| self.triangle(tri));
        let (b1, b2) = (hit.u, hit.v);
        let b0 = 1.0 - b1 - b2;
        let dp0 = p1 - p0;
        let dp1 = p2 - p0;
        let p = p2 * b2 + (p1 * b1 + p0 * b0);
        if let (Some(flat), Some(uvs)) = (&self.flat, &self.uvs) {
            let f = &flat[tri];
            let [i0, i1, i2] = self.indices[tri].map(|k| k as usize);
            return SurfaceGeometry {
                p,
                n_geo: f.n_geo,
                sh_frame: f.sh_frame,
                uv: uvs[i2] * b2 + (uvs[i1] * b1 + uvs[i0] * b0),
                dp_du: f.dp_du,
                dp_dv: f.dp_dv,
            };
        }
        let mut n = dp0.cross(dp1).normalize_or_zero();
        let index = || self.indices[tri].map(|k| k as usize);
        let (uv, dp_du, dp_dv) = match &self.uvs {
            Some(uvs) => {
                let [i0, i1, i2] = index();
                let (uv0, uv1, uv2) = (uvs[i0], uvs[i1], uvs[i2]);
                let uv = uv2 * b2 + (uv1 * b1 + uv0 * b0);
                let duv0 = uv1 - uv0;
                let duv1 = uv2 - uv0;
                let det = duv0.x * duv1.y - duv0.y * duv1.x;
                let (dp_du, dp_dv) = if det != 0.0 {
                    let inv = 1.0 / det;
                    (
                        (dp0 * duv1.y - dp1 * duv0.y) * inv,
                        (dp1 * duv0.x - dp0 * duv1.x) * inv,
                    )
                } else {
                    let f = Frame::from_normal(n);
                    (f.s, f.t)
                };
                (uv, dp_du, dp_dv)
            }
            None => (Vec2::new(b1, b2), dp0, dp1),
        };
        let mut sn = match &self.normals {
            Some(ns) => {
                let [i0, i1, i2] = index();
                let sn = (ns[i0] * b0 + ns[i1] * b1 + ns[i2] * b2).normalize_or_zero();
                if sn == Vec3::ZERO {
                    n
                } else {
                    sn
                }
            }
            None => n,
        };
        if self.flip_normals {
            n = -n;
            sn = -sn;
        }
        SurfaceGeometry {
            p,
            n_geo: n,
            sh_frame: shading_frame(sn, dp_du),
            uv,
            dp_du,
            dp_dv,
        }
    }
}

impl TriMesh {
    /// The attribute called `name`, if the mesh has it.
    pub fn attribute(&self, name: &str) -> Option<&MeshAttribute> {
        self.attributes.iter().find(|a| a.name == name)
    }
}

impl SurfaceData for TriMesh {
    /// Mitsuba's `Mesh::eval_attribute`: vertex attributes interpolated with the barycentrics
    /// (b0 v0 + b1 v1 + b2 v2), face attributes constant per triangle; 1 channel in all three
    /// (4-channel colours lose their alpha, which `mesh_attribute` refuses at load).
    fn attribute(&self, name: &str, prim: u32, bary: Vec2) -> Option<Rgb> {
        let a = TriMesh::attribute(self, name)?;
        let d = a.dim;
        let get = |i: usize| -> Rgb {
            let v = &a.data[i * d..i * d + d];
            if d >= 3 {
                Rgb::new(v[0], v[1], v[2])
            } else {
                Rgb::splat(v[0])
            }
        };
        let prim = prim as usize;
        if a.is_face() {
            return (prim < self.indices.len()).then(|| get(prim));
        }
        let [i0, i1, i2] = self.indices.get(prim)?.map(|k| k as usize);
        let (b1, b2) = (bary.x, bary.y);
        let b0 = 1.0 - b1 - b2;
        Some(get(i0) * b0 + get(i1) * b1 + get(i2) * b2)
    }
}

impl Sphere {
    /// The uv of a world point on the sphere, and ∂p/∂u, ∂p/∂v there (Mitsuba's: with `l`
    /// the unit-sphere point, `2π M·(−l.y, l.x, 0)` and `π M·(l.z cos φ, l.z sin φ, −r)`,
    /// r = √(l.x² + l.y²); at the poles ∂p/∂u = 0 and ∂p/∂v = `π M·(1, 0, 0)`).
    fn param(&self, p: Vec3) -> (Vec2, Vec3, Vec3) {
        let local = self.to_object.transform_point3(p);
        let rd2 = local.x * local.x + local.y * local.y;
        let theta = unit_angle_z(local);
        let phi = phi_positive(local.y, local.x);
        let uv = Vec2::new(phi * INV_TWO_PI, theta * INV_PI);
        let (dp_du, dp_dv) = if rd2 > 0.0 {
            let rd = rd2.sqrt();
            let (cos_phi, sin_phi) = (local.x / rd, local.y / rd);
            (
                self.to_world
                    .transform_vector3(Vec3::new(-local.y, local.x, 0.0))
                    * (2.0 * PI),
                self.to_world.transform_vector3(Vec3::new(
                    local.z * cos_phi,
                    local.z * sin_phi,
                    -rd,
                )) * PI,
            )
        } else {
            (Vec3::ZERO, self.to_world.transform_vector3(Vec3::X) * PI)
        };
        (uv, dp_du, dp_dv)
    }

    fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        let p = ray.at(hit.t);
        // Re-project onto the sphere (as Mitsuba does) to reduce the error of o + t·d.
        let mut n = (p - self.center).normalize_or(Vec3::Z);
        let p = self.center + n * self.radius;
        let (uv, dp_du, dp_dv) = self.param(p);
        if self.flip_normals {
            n = -n;
        }
        SurfaceGeometry {
            p,
            n_geo: n,
            sh_frame: shading_frame(n, dp_du),
            uv,
            dp_du,
            dp_dv,
        }
    }

    fn sample_position(&self, u: Vec2) -> PositionSample {
        // warp::square_to_uniform_sphere
        let z = 1.0 - 2.0 * u.y;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (s, c) = (2.0 * PI * u.x).sin_cos();
        let local = Vec3::new(r * c, r * s, z);
        let p = local * self.radius + self.center;
        let (uv, _, _) = self.param(p);
        let n = if self.flip_normals { -local } else { local };
        let area = self.area();
        PositionSample {
            p,
            n,
            uv,
            pdf: if area > 0.0 { 1.0 / area } else { 0.0 },
        }
    }

    fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }
}

impl Disk {
    /// Unit world-space normal on the front side (flip included).
    pub fn normal(&self) -> Vec3 {
        if self.flip_normals {
            -self.n
        } else {
            self.n
        }
    }

    /// Position, uv and ∂p/∂u of the object-space point (x, y).
    fn at_local(&self, x: f32, y: f32) -> (Vec3, Vec2, Vec3) {
        let p = self.to_world.transform_point3(Vec3::new(x, y, 0.0));
        let r = (x * x + y * y).sqrt();
        let phi = phi_positive(y, x);
        let uv = Vec2::new(r, phi * INV_TWO_PI);
        let dp_du = if r > 0.0 {
            self.to_world
                .transform_vector3(Vec3::new(x / r, y / r, 0.0))
        } else {
            Vec3::ZERO
        };
        (p, uv, dp_du)
    }

    fn surface(&self, hit: &Hit) -> SurfaceGeometry {
        let (x, y) = (hit.u, hit.v);
        let (p, uv, dp_du) = self.at_local(x, y);
        // ∂p/∂v with v = φ/2π: 2π·(−y, x, 0) in object space (Mitsuba's, zero at the centre)
        let dp_dv = self
            .to_world
            .transform_vector3(Vec3::new(-y, x, 0.0) * (2.0 * PI));
        let n = self.normal();
        SurfaceGeometry {
            p,
            n_geo: n,
            sh_frame: shading_frame(n, dp_du),
            uv,
            dp_du,
            dp_dv,
        }
    }

    fn sample_position(&self, u: Vec2) -> PositionSample {
        let d = square_to_uniform_disk_concentric(u);
        let (p, uv, _) = self.at_local(d.x, d.y);
        let pdf = if self.area > 0.0 {
            1.0 / self.area
        } else {
            0.0
        };
        PositionSample {
            p,
            n: self.normal(),
            uv,
            pdf,
        }
    }

    /// World-space bounds of the (elliptical) disk.
    fn bounds(&self) -> (Vec3, Vec3) {
        let c = self.to_world.transform_point3(Vec3::ZERO);
        let a = self.to_world.transform_vector3(Vec3::X);
        let b = self.to_world.transform_vector3(Vec3::Y);
        let h = (a * a + b * b).map(f32::sqrt);
        (c - h, c + h)
    }
}

impl Cylinder {
    fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        let local = self.to_object.transform_point3(ray.at(hit.t));
        // re-project onto the surface (Mitsuba shifts p along the normal by the same amount)
        let rxy = (local.x * local.x + local.y * local.y).sqrt();
        let (x, y) = if rxy > 0.0 {
            (local.x / rxy, local.y / rxy)
        } else {
            (1.0, 0.0)
        };
        let p = self.to_world.transform_point3(Vec3::new(x, y, local.z));
        let phi = phi_positive(y, x);
        let uv = Vec2::new(phi * INV_TWO_PI, local.z);
        let dp_du = self
            .to_world
            .transform_vector3(Vec3::new(-y, x, 0.0) * (2.0 * PI));
        let mut n = (self.nm * Vec3::new(x, y, 0.0)).normalize_or(Vec3::Z);
        if self.flip_normals {
            n = -n;
        }
        SurfaceGeometry {
            p,
            n_geo: n,
            sh_frame: shading_frame(n, dp_du),
            uv,
            dp_du,
            // v is the object-space height
            dp_dv: self.to_world.transform_vector3(Vec3::Z),
        }
    }

    fn sample_position(&self, u: Vec2) -> PositionSample {
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        let p = self.to_world.transform_point3(Vec3::new(c, s, u.x));
        // normalize(∂p/∂u × ∂p/∂v) = sign(det) · normalize(nm · (cos, sin, 0))
        let mut n = (self.nm * Vec3::new(c, s, 0.0)).normalize_or(Vec3::Z) * self.det_sign;
        if self.flip_normals {
            n = -n;
        }
        PositionSample {
            p,
            n,
            uv: Vec2::new(u.y, u.x),
            pdf: if self.area > 0.0 {
                1.0 / self.area
            } else {
                0.0
            },
        }
    }

    /// World-space bounds: the box of the two end circles.
    fn bounds(&self) -> (Vec3, Vec3) {
        let p0 = self.to_world.transform_point3(Vec3::ZERO);
        let p1 = self.to_world.transform_point3(Vec3::Z);
        let a = self.to_world.transform_vector3(Vec3::X);
        let b = self.to_world.transform_vector3(Vec3::Y);
        let h = (a * a + b * b).map(f32::sqrt);
        ((p0 - h).min(p1 - h), (p0 + h).max(p1 + h))
    }
}

impl Instance {
    /// The group shape's surface at the hit, carried to world space.
    fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        let local_ray = Ray {
            o: self.to_object.transform_point3(ray.o),
            d: self.to_object.transform_vector3(ray.d),
            t_max: ray.t_max,
        };
        let inner = Hit {
            t: hit.t,
            shape: self.member,
            prim: hit.prim,
            u: hit.u,
            v: hit.v,
            vertices: None,
        };
        let s = self.group.shapes[self.member as usize].surface(&local_ray, &inner);
        let n_geo = (self.nm * s.n_geo).normalize_or(s.n_geo);
        let n = (self.nm * s.sh_frame.n).normalize_or(n_geo);
        let dp_du = self.to_world.transform_vector3(s.dp_du);
        // s from the world ∂p/∂u, as Mitsuba; the group shape's own s where ∂p/∂u vanishes
        let s_dir = if dp_du == Vec3::ZERO {
            self.to_world.transform_vector3(s.sh_frame.s)
        } else {
            dp_du
        };
        SurfaceGeometry {
            p: self.to_world.transform_point3(s.p),
            n_geo,
            sh_frame: shading_frame(n, s_dir),
            uv: s.uv,
            dp_du,
            dp_dv: self.to_world.transform_vector3(s.dp_dv),
        }
    }

    /// World-space bounds of the whole group (the transformed corners of its box).
    fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.group.bounds;
        if !(lo.cmple(hi).all()) {
            return (lo, hi);
        }
        (0..8).fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), i| {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let p = self.to_world.transform_point3(c);
            (a.min(p), b.max(p))
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Common interface
// ---------------------------------------------------------------------------------------------

impl Geometry {
    /// World-space axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self {
            Geometry::Mesh(m) => m.positions.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), &p| (lo.min(p), hi.max(p)),
            ),
            Geometry::Sphere(s) => {
                let r = Vec3::splat(s.radius.abs());
                (s.center - r, s.center + r)
            }
            Geometry::Disk(d) => d.bounds(),
            Geometry::Cylinder(c) => c.bounds(),
            Geometry::Instance(i) => i.bounds(),
        }
    }

    /// World-space surface area.
    pub fn area(&self) -> f32 {
        match self {
            Geometry::Mesh(m) => m.area,
            Geometry::Sphere(s) => s.area(),
            Geometry::Disk(d) => d.area,
            Geometry::Cylinder(c) => c.area,
            // not sampled: instances cannot emit
            Geometry::Instance(_) => 0.0,
        }
    }

    /// A point drawn uniformly by area over the whole shape, from `u` in [0, 1)². Uses the
    /// same warps as Mitsuba (so the same `u` gives the same point for untransformed shapes).
    /// `pdf` is 1 / area (0 for a shape without area).
    pub fn sample_position(&self, u: Vec2) -> PositionSample {
        match self {
            Geometry::Mesh(m) => m.sample_position(u),
            Geometry::Sphere(s) => s.sample_position(u),
            Geometry::Disk(d) => d.sample_position(u),
            Geometry::Cylinder(c) => c.sample_position(u),
            // not sampled (instances cannot emit): a point of the group shape, density 0
            Geometry::Instance(i) => {
                let ps = i.group.shapes[i.member as usize].sample_position(u);
                PositionSample {
                    p: i.to_world.transform_point3(ps.p),
                    n: (i.nm * ps.n).normalize_or(ps.n),
                    uv: ps.uv,
                    pdf: 0.0,
                }
            }
        }
    }

    /// Density of [`Geometry::sample_position`] with respect to area: 1 / area (0 when the
    /// shape has no area).
    pub fn pdf_position(&self) -> f32 {
        let a = self.area();
        if a > 0.0 {
            1.0 / a
        } else {
            0.0
        }
    }

    /// Local geometry at a hit reported by the acceleration structure for this shape; `ray`
    /// must be the ray that produced `hit` (spheres re-evaluate `o + t·d`).
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        match self {
            Geometry::Mesh(m) => m.surface(hit),
            Geometry::Sphere(s) => s.surface(ray, hit),
            Geometry::Disk(d) => d.surface(hit),
            Geometry::Cylinder(c) => c.surface(ray, hit),
            Geometry::Instance(i) => i.surface(ray, hit),
        }
    }

    /// Number of primitives the acceleration structure holds for this shape (triangles for a
    /// mesh, 1 for an analytic shape).
    pub fn primitive_count(&self) -> usize {
        match self {
            Geometry::Mesh(m) => m.indices.len(),
            Geometry::Sphere(_) | Geometry::Disk(_) | Geometry::Cylinder(_) => 1,
            // the instance as a whole is one primitive, held by its first slot
            Geometry::Instance(i) => (i.member == 0) as usize,
        }
    }

    /// The shape's per-primitive data for textures that read it (`mesh_attribute`): meshes
    /// with attributes.
    #[inline]
    pub fn surface_data(&self) -> Option<&dyn SurfaceData> {
        match self {
            Geometry::Mesh(m) if !m.attributes.is_empty() => Some(m),
            // the group shape's (the hit's primitive is the group shape's)
            Geometry::Instance(i) => i.group.shapes[i.member as usize].surface_data(),
            _ => None,
        }
    }

    /// Whether `flip_normals` was set.
    pub fn flip_normals(&self) -> bool {
        match self {
            Geometry::Mesh(m) => m.flip_normals,
            Geometry::Sphere(s) => s.flip_normals,
            Geometry::Disk(d) => d.flip_normals,
            Geometry::Cylinder(c) => c.flip_normals,
            Geometry::Instance(_) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    //! Reference values in this module were obtained from Mitsuba 3.9.1 (`scalar_rgb`): small
    //! scenes built with `mi.load_dict`, rays shot with `scene.ray_intersect(mi.Ray3f(o, d))`
    //! reading `si.t, si.p, si.n, si.sh_frame.{n,s,t}, si.uv`, and `shape.sample_position(0,
    //! u)` reading `ps.p, ps.n, ps.uv, ps.pdf`. Transforms are spelled the same way on both
    //! sides (Mitsuba's `ScalarTransform4f().translate(..).rotate(axis, deg).scale(..)`).
    use super::*;
    use crate::accel::{Bvh, Intersector};
    use crate::mesh_io::{load_obj, load_ply};
    use std::path::PathBuf;

    struct Case {
        o: [f32; 3],
        d: [f32; 3],
        t: f32,
        p: [f32; 3],
        n: [f32; 3],
        sn: [f32; 3],
        ss: [f32; 3],
        st: [f32; 3],
        uv: [f32; 2],
    }

    struct SCase {
        u: [f32; 2],
        p: [f32; 3],
        n: [f32; 3],
        uv: [f32; 2],
        pdf: f32,
    }

    const QUAD_OBJ: &str = r#"v -1 -1 0
v 1 -1 0.2
v 1 1 0
v -1 1 -0.3
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
vn 0.3 0 1
vn 0 0.3 1
vn -0.2 -0.2 1
f 1/1/1 2/2/2 3/3/3 4/4/4
"#;
    const QUAD_NONORMAL_OBJ: &str = r#"v -1 -1 0
v 1 -1 0.2
v 1 1 0
v -1 1 -0.3
v 0 0 0.5
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
f 1/1 2/2 5/5
f 2/2 3/3 5/5
f 3/3 4/4 5/5
f 4/4 1/1 5/5
"#;
    const TENT_OBJ: &str = r#"v -1 -1 0
v 0 -1 0.5
v 0 1 0.5
v -1 1 0
v 1 -1 0
v 1 1 0
vt 0 0
vt 0.5 0
vt 0.5 1
vt 0 1
vt 0.6 0
vt 0.6 1
vt 1 0
vt 1 1
f 1/1 2/2 3/3
f 1/1 3/3 4/4
f 2/5 5/7 6/8
f 2/5 6/8 3/6
"#;
    const TENT_SHARED_OBJ: &str = r#"v -1 -1 0
v 0 -1 0.5
v 0 1 0.5
v -1 1 0
v 1 -1 0
v 1 1 0
f 1 2 3
f 1 3 4
f 2 5 6
f 2 6 3
"#;
    const DEGEN_OBJ: &str = r#"v -1 -1 0
v 1 -1 0.2
v 1 1 0
vt 0.5 0.5
vn 0 0 1
f 1/1/1 2/1/1 3/1/1
"#;
    const QUAD_PLY: &str = r#"ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
property float nx
property float ny
property float nz
property float u
property float v
element face 2
property list uchar int vertex_indices
end_header
-1 -1 0 0 0 1 0 0
1 -1 0.2 0.3 0 1 1 0
1 1 0 0 0.3 1 1 1
-1 1 -0.3 -0.2 -0.2 1 0 1
3 0 1 2
3 0 2 3
"#;

    const RECT: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.3, -0.5, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, 1.0, 0.0],
            uv: [0.65, 0.25],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [-0.6, 0.7, 0.0],
            n: [0.0, -0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, 1.0, 0.0],
            uv: [0.2, 0.85],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.55, 0.45, 0.0],
            n: [0.0, -0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, 1.0, 0.0],
            uv: [0.775, 0.725],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.0,
            p: [-0.1, 0.04999995, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, 1.0, 0.0],
            uv: [0.45, 0.525],
        },
    ];
    const RECT_FLIP: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.3, -0.5, 0.0],
            n: [-0.0, -0.0, -1.0],
            sn: [-0.0, -0.0, -1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.65, 0.25],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [-0.6, 0.7, 0.0],
            n: [-0.0, 0.0, -1.0],
            sn: [-0.0, -0.0, -1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.2, 0.85],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.55, 0.45, 0.0],
            n: [-0.0, 0.0, -1.0],
            sn: [-0.0, -0.0, -1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.775, 0.725],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.0,
            p: [-0.1, 0.04999995, 0.0],
            n: [-0.0, -0.0, -1.0],
            sn: [-0.0, -0.0, -1.0],
            ss: [1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.45, 0.525],
        },
    ];
    const RECT_XF: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.181985,
            p: [0.3, -0.5, -0.1819851],
            n: [0.0, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396926],
            ss: [1.0, 0.0, 0.0],
            st: [-0.0, 0.9396926, 0.3420201],
            uv: [0.575, 0.2339556],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.745221,
            p: [-0.5999999, 0.7, 0.2547791],
            n: [-5.94381e-09, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396926],
            ss: [1.0, 0.0, 0.0],
            st: [-0.0, 0.9396926, 0.3420201],
            uv: [0.35, 0.8724622],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.836214,
            p: [0.5499998, 0.4500001, 0.1637866],
            n: [-5.94381e-09, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396927],
            ss: [1.0, 0.0, 0.0],
            st: [-0.0, 0.9396927, 0.3420201],
            uv: [0.6374999, 0.73944],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.018399,
            p: [-0.09963179, 0.05055188, 0.01839938],
            n: [-5.94381e-09, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396926],
            ss: [1.0, 0.0, 0.0],
            st: [-0.0, 0.9396926, 0.3420201],
            uv: [0.4750921, 0.5268981],
        },
    ];
    const RECT_MIRROR: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.3, -0.5, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.35, 0.25],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [-0.6, 0.7, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.8, 0.85],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.55, 0.45, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.225, 0.725],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.0,
            p: [-0.09999999, 0.04999992, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-1.0, 0.0, 0.0],
            st: [0.0, -1.0, 0.0],
            uv: [0.55, 0.525],
        },
    ];
    const DISK: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.3, -0.5, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [0.5144958, -0.8574929, 0.0],
            st: [0.8574929, 0.5144958, -0.0],
            uv: [0.5830952, 0.8360105],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [-0.6, 0.7, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-0.6507914, 0.7592566, 0.0],
            st: [-0.7592566, -0.6507914, 0.0],
            uv: [0.9219545, 0.3627814],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.55, 0.45, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [0.7739573, 0.6332378, 0.0],
            st: [-0.6332378, 0.7739573, 0.0],
            uv: [0.7106335, 0.1091372],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.0,
            p: [-0.1, 0.05, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-0.8944273, 0.4472136, 0.0],
            st: [-0.4472136, -0.8944273, 0.0],
            uv: [0.1118034, 0.4262082],
        },
    ];
    const DISK_FLIP: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.3, -0.5, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, -1.0],
            ss: [0.5144958, -0.857493, 0.0],
            st: [-0.857493, -0.5144958, -0.0],
            uv: [0.5830951, 0.8360105],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [-0.6, 0.7, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, -1.0],
            ss: [-0.6507914, 0.7592566, 0.0],
            st: [0.7592566, 0.6507914, 0.0],
            uv: [0.9219544, 0.3627814],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.55, 0.45, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, -1.0],
            ss: [0.7739573, 0.6332378, 0.0],
            st: [0.6332378, -0.7739573, 0.0],
            uv: [0.7106334, 0.1091372],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.0,
            p: [-0.1, 0.05, 0.0],
            n: [0.0, 0.0, -1.0],
            sn: [0.0, 0.0, -1.0],
            ss: [-0.8944272, 0.4472135, 0.0],
            st: [0.4472135, 0.8944272, 0.0],
            uv: [0.1118034, 0.4262082],
        },
    ];
    const DISK_XF: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.181985,
            p: [0.3, -0.4999999, -0.1819851],
            n: [0.0, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396927],
            ss: [0.4911315, -0.8185526, -0.2979287],
            st: [0.8710855, 0.4615127, 0.1679769],
            uv: [0.5528277, 0.7937321],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.745221,
            p: [-0.6, 0.6999999, 0.2547791],
            n: [0.0, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396927],
            ss: [-0.6272801, 0.7318268, 0.2663631],
            st: [-0.7787938, -0.5894506, -0.2145424],
            uv: [0.8030643, 0.310933],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.836214,
            p: [0.55, 0.4499999, 0.1637866],
            n: [0.0, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396927],
            ss: [0.754185, 0.6170605, 0.2245916],
            st: [-0.6566622, 0.7087021, 0.2579464],
            uv: [0.5522237, 0.1670364],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.018399,
            p: [-0.09963202, 0.05055192, 0.01839939],
            n: [0.0, -0.3420201, 0.9396927],
            sn: [0.0, -0.3420201, 0.9396927],
            ss: [-0.8799238, 0.4464617, 0.1624987],
            st: [-0.4751146, -0.826858, -0.3009517],
            uv: [0.07331898, 0.3688891],
        },
    ];
    const DISK_MIRROR: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.3, -0.5, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [0.5144958, -0.857493, 0.0],
            st: [0.857493, 0.5144958, -0.0],
            uv: [0.5830951, 0.6639895],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [-0.6, 0.7, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-0.6507914, 0.7592566, 0.0],
            st: [-0.7592566, -0.6507914, 0.0],
            uv: [0.9219544, 0.1372186],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.0,
            p: [0.55, 0.45, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [0.7739573, 0.6332378, 0.0],
            st: [-0.6332378, 0.7739573, 0.0],
            uv: [0.7106334, 0.3908628],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.0,
            p: [-0.1, 0.05, 0.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-0.8944272, 0.4472135, 0.0],
            st: [-0.4472135, -0.8944272, 0.0],
            uv: [0.1118034, 0.07379178],
        },
    ];
    const SPHERE: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.187596,
            p: [0.3, -0.5000001, 0.8124038],
            n: [0.3, -0.5000001, 0.8124038],
            sn: [0.3, -0.5000001, 0.8124038],
            ss: [0.8574929, 0.5144958, 1.321699e-08],
            st: [-0.4179783, 0.6966305, 0.5830953],
            uv: [0.8360105, 0.1981585],
        },
        Case {
            o: [0.2, 0.1, -5.0],
            d: [0.0, 0.0, 1.0],
            t: 4.025321,
            p: [0.2, 0.1, -0.9746795],
            n: [0.2, 0.1, -0.9746795],
            sn: [0.2, 0.1, -0.9746795],
            ss: [-0.4472136, 0.8944271, 0.0],
            st: [0.8717797, 0.4358899, 0.2236068],
            uv: [0.07379179, 0.9282168],
        },
        Case {
            o: [5.0, 0.3, 0.2],
            d: [-1.0, 0.0, 0.0],
            t: 4.067262,
            p: [0.9327379, 0.3, 0.2],
            n: [0.9327379, 0.3, 0.2],
            sn: [0.9327379, 0.3, 0.2],
            ss: [-0.3061862, 0.9519716, 0.0],
            st: [-0.1903943, -0.06123726, 0.9797959],
            uv: [0.04952651, 0.4359058],
        },
        Case {
            o: [0.1, 0.2, 0.0],
            d: [0.3, -0.4, 0.5],
            t: 1.482028,
            p: [0.5446083, -0.392811, 0.7410138],
            n: [0.5446083, -0.392811, 0.7410138],
            sn: [0.5446083, -0.392811, 0.7410138],
            ss: [0.5849843, 0.8110446, 0.0],
            st: [-0.6009952, 0.4334814, 0.6714899],
            uv: [0.9005504, 0.2343453],
        },
        Case {
            o: [0.05, -0.3, -3.0],
            d: [0.1, 0.2, 1.0],
            t: 2.038785,
            p: [0.2538785, 0.107757, -0.9612149],
            n: [0.2538785, 0.107757, -0.9612149],
            sn: [0.2538785, 0.107757, -0.9612149],
            ss: [-0.3907064, 0.9205153, 0.0],
            st: [0.884813, 0.3755528, 0.2758003],
            uv: [0.06388458, 0.9110571],
        },
    ];
    const SPHERE_FLIP: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.187596,
            p: [0.3, -0.5000001, 0.8124038],
            n: [-0.3, 0.5000001, -0.8124038],
            sn: [-0.3, 0.5000001, -0.8124038],
            ss: [0.8574929, 0.5144958, 1.321699e-08],
            st: [0.4179783, -0.6966305, -0.5830953],
            uv: [0.8360105, 0.1981585],
        },
        Case {
            o: [0.2, 0.1, -5.0],
            d: [0.0, 0.0, 1.0],
            t: 4.025321,
            p: [0.2, 0.1, -0.9746795],
            n: [-0.2, -0.1, 0.9746795],
            sn: [-0.2, -0.1, 0.9746795],
            ss: [-0.4472136, 0.8944271, 0.0],
            st: [-0.8717797, -0.4358899, -0.2236068],
            uv: [0.07379179, 0.9282168],
        },
        Case {
            o: [5.0, 0.3, 0.2],
            d: [-1.0, 0.0, 0.0],
            t: 4.067262,
            p: [0.9327379, 0.3, 0.2],
            n: [-0.9327379, -0.3, -0.2],
            sn: [-0.9327379, -0.3, -0.2],
            ss: [-0.3061862, 0.9519716, 0.0],
            st: [0.1903943, 0.06123726, -0.9797959],
            uv: [0.04952651, 0.4359058],
        },
        Case {
            o: [0.1, 0.2, 0.0],
            d: [0.3, -0.4, 0.5],
            t: 1.482028,
            p: [0.5446083, -0.392811, 0.7410138],
            n: [-0.5446083, 0.392811, -0.7410138],
            sn: [-0.5446083, 0.392811, -0.7410138],
            ss: [0.5849843, 0.8110446, 0.0],
            st: [0.6009952, -0.4334814, -0.6714899],
            uv: [0.9005504, 0.2343453],
        },
        Case {
            o: [0.05, -0.3, -3.0],
            d: [0.1, 0.2, 1.0],
            t: 2.038785,
            p: [0.2538785, 0.107757, -0.9612149],
            n: [-0.2538785, -0.107757, 0.9612149],
            sn: [-0.2538785, -0.107757, 0.9612149],
            ss: [-0.3907064, 0.9205153, 0.0],
            st: [-0.884813, -0.3755528, -0.2758003],
            uv: [0.06388458, 0.9110571],
        },
    ];
    const SPHERE_XF: &[Case] = &[
        Case {
            o: [0.7, 0.2, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.119451,
            p: [0.7, 0.2, 0.8805494],
            n: [0.1017337, 0.02326633, 0.9945395],
            sn: [0.1017337, 0.02326633, 0.9945395],
            ss: [-0.7788382, -0.6201144, 0.09417613],
            st: [0.6189194, -0.7841663, -0.04496583],
            uv: [0.3515976, 0.2061414],
        },
        Case {
            o: [0.5, -0.5, -5.0],
            d: [0.05, 0.0, 1.0],
            t: 3.698742,
            p: [0.6849371, -0.4999999, -1.301258],
            n: [0.08918131, -0.560067, -0.8236333],
            sn: [0.08918131, -0.560067, -0.8236333],
            ss: [0.8529338, 0.4699712, -0.2272244],
            st: [0.5143448, -0.6822405, 0.5196127],
            uv: [0.8174959, 0.6090214],
        },
        Case {
            o: [5.0, 0.3, 0.2],
            d: [-1.0, 0.0, 0.0],
            t: 3.344782,
            p: [1.655218, 0.3, 0.2],
            n: [0.8977488, 0.1065997, 0.4274149],
            sn: [0.8977488, 0.1065997, 0.4274149],
            ss: [-0.3797287, 0.6790745, 0.6282229],
            st: [-0.2232782, -0.7262881, 0.6501173],
            uv: [0.09105502, 0.2589221],
        },
        Case {
            o: [0.9, 0.1, 0.0],
            d: [0.3, -0.4, 0.5],
            t: 1.104784,
            p: [1.231435, -0.3419137, 0.5523922],
            n: [0.5445965, -0.4283285, 0.7210751],
            sn: [0.5445965, -0.4283285, 0.7210751],
            ss: [0.003619103, 0.8609474, 0.5086812],
            st: [-0.8386903, -0.2744164, 0.4704191],
            uv: [0.02031524, 0.03312843],
        },
    ];
    const CUBE: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.0,
            p: [0.3, -0.5, 1.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-0.0, 1.0, -0.0],
            st: [-1.0, 0.0, 0.0],
            uv: [0.25, 0.65],
        },
        Case {
            o: [0.3, -0.5, -5.0],
            d: [0.0, 0.0, 1.0],
            t: 4.0,
            p: [0.3, -0.5, -1.0],
            n: [0.0, -0.0, -1.0],
            sn: [0.0, 0.0, -1.0],
            ss: [-0.0, -1.0, 0.0],
            st: [-1.0, 0.0, 0.0],
            uv: [0.75, 0.65],
        },
        Case {
            o: [5.0, 0.3, 0.2],
            d: [-1.0, 0.0, 0.0],
            t: 4.0,
            p: [1.0, 0.3, 0.2],
            n: [1.0, 0.0, 0.0],
            sn: [1.0, 0.0, 0.0],
            ss: [0.0, 1.0, 0.0],
            st: [0.0, 0.0, 1.0],
            uv: [0.65, 0.4],
        },
        Case {
            o: [-5.0, 0.3, 0.2],
            d: [1.0, 0.0, 0.0],
            t: 4.0,
            p: [-1.0, 0.3, 0.2],
            n: [-1.0, 0.0, 0.0],
            sn: [-1.0, 0.0, 0.0],
            ss: [0.0, 1.0, -0.0],
            st: [-0.0, 0.0, -1.0],
            uv: [0.65, 0.6],
        },
        Case {
            o: [0.3, 5.0, 0.2],
            d: [0.0, -1.0, 0.0],
            t: 4.0,
            p: [0.3, 1.0, 0.2],
            n: [0.0, 1.0, 0.0],
            sn: [0.0, 1.0, 0.0],
            ss: [-1.0, -0.0, 0.0],
            st: [0.0, -0.0, 1.0],
            uv: [0.35, 0.4],
        },
        Case {
            o: [0.3, -5.0, 0.2],
            d: [0.0, 1.0, 0.0],
            t: 4.0,
            p: [0.3, -1.0, 0.2],
            n: [0.0, -1.0, 0.0],
            sn: [0.0, -1.0, 0.0],
            ss: [-0.0, 0.0, 1.0],
            st: [-1.0, -0.0, 0.0],
            uv: [0.6, 0.65],
        },
        Case {
            o: [-0.7, 0.6, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.0,
            p: [-0.7, 0.6, 1.0],
            n: [0.0, 0.0, 1.0],
            sn: [0.0, 0.0, 1.0],
            ss: [-0.0, 1.0, -0.0],
            st: [-1.0, 0.0, 0.0],
            uv: [0.8, 0.15],
        },
        Case {
            o: [0.1, 0.2, 0.3],
            d: [0.4, -0.3, 0.2],
            t: 2.25,
            p: [1.0, -0.475, 0.7499999],
            n: [1.0, -0.0, 0.0],
            sn: [1.0, 0.0, 0.0],
            ss: [-0.0, 1.0, 0.0],
            st: [0.0, -0.0, 1.0],
            uv: [0.2625, 0.125],
        },
    ];
    const CUBE_XF: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 3.975272,
            p: [0.3000001, -0.5, 1.024728],
            n: [-0.3535534, -0.06698734, -0.9330128],
            sn: [-0.3535534, -0.06698731, -0.9330128],
            ss: [-0.3535534, 0.9330128, 0.06698729],
            st: [0.8660256, 0.3535534, -0.3535534],
            uv: [0.162364, 0.3898292],
        },
        Case {
            o: [0.3, -0.5, -5.0],
            d: [0.0, 0.0, 1.0],
            t: 4.524213,
            p: [0.3, -0.5000004, -0.4757874],
            n: [0.3535534, 0.06698728, 0.9330128],
            sn: [0.3535534, 0.06698731, 0.9330128],
            ss: [0.3535534, -0.9330128, -0.0669873],
            st: [0.8660256, 0.3535535, -0.3535534],
            uv: [0.8878939, 0.5666666],
        },
        Case {
            o: [5.0, 0.3, 0.2],
            d: [-1.0, 0.0, 0.0],
            t: 3.249599,
            p: [1.750401, 0.3000001, 0.2],
            n: [-0.8660253, -0.3535534, 0.3535535],
            sn: [-0.8660254, -0.3535534, 0.3535534],
            ss: [-0.3535534, 0.9330128, 0.06698729],
            st: [-0.3535534, -0.06698729, -0.9330127],
            uv: [0.2515489, 0.1450697],
        },
        Case {
            o: [-5.0, 0.3, 0.2],
            d: [1.0, 0.0, 0.0],
            t: 3.36505,
            p: [-1.63495, 0.3, 0.2],
            n: [0.3535534, 0.06698734, 0.9330128],
            sn: [0.3535534, 0.06698731, 0.9330128],
            ss: [0.3535534, -0.9330128, -0.06698732],
            st: [0.8660256, 0.3535535, -0.3535535],
            uv: [0.15, 0.02273332],
        },
        Case {
            o: [0.3, 5.0, 0.2],
            d: [0.0, -1.0, 0.0],
            t: 3.645236,
            p: [0.3, 1.354764, 0.2000001],
            n: [0.3535534, -0.9330127, -0.06698733],
            sn: [0.3535534, -0.9330128, -0.0669873],
            ss: [-0.8660254, -0.3535534, 0.3535534],
            st: [-0.3535534, -0.06698731, -0.9330128],
            uv: [0.2943896, 0.4608829],
        },
        Case {
            o: [0.3, -5.0, 0.2],
            d: [0.0, 1.0, 0.0],
            t: 4.21117,
            p: [0.2999999, -0.7888297, 0.2],
            n: [-0.3535534, 0.9330127, 0.06698733],
            sn: [-0.3535534, 0.9330127, 0.0669873],
            ss: [0.3535534, 0.06698731, 0.9330127],
            st: [0.8660254, 0.3535534, -0.3535534],
            uv: [0.4365502, 0.4529854],
        },
        Case {
            o: [-0.7, 0.6, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 3.675311,
            p: [-0.7000002, 0.6000001, 1.324689],
            n: [-0.3535534, -0.06698731, -0.9330127],
            sn: [-0.3535534, -0.06698731, -0.9330128],
            ss: [-0.3535534, 0.9330128, 0.06698731],
            st: [0.8660256, 0.3535535, -0.3535534],
            uv: [0.8623446, 0.1954395],
        },
        Case {
            o: [0.1, 0.2, 0.3],
            d: [0.4, -0.3, 0.2],
            t: 2.273261,
            p: [1.009305, -0.4819783, 0.7546521],
            n: [-0.3535534, -0.06698734, -0.9330128],
            sn: [-0.3535534, -0.06698731, -0.9330128],
            ss: [-0.3535534, 0.9330128, 0.06698729],
            st: [0.8660256, 0.3535534, -0.3535534],
            uv: [0.03633694, 0.6285404],
        },
    ];
    const OBJ_QUAD: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.92,
            p: [0.3, -0.5, 0.08],
            n: [-0.09901475, 0.09901475, 0.9901475],
            sn: [0.1170476, 0.07315475, 0.9904283],
            ss: [0.9930983, -0.01610631, -0.1161735],
            st: [0.007453505, 0.9971905, -0.07453507],
            uv: [0.65, 0.75],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.195,
            p: [-0.6, 0.7, -0.195],
            n: [-0.1467348, 0.1467348, 0.978232],
            sn: [-0.1279814, -0.06918468, 0.9893606],
            ss: [0.9917235, 0.001397588, 0.1283848],
            st: [-0.01026498, 0.997603, 0.0684332],
            uv: [0.2, 0.15],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.99,
            p: [0.55, 0.45, 0.00999999],
            n: [-0.09901475, 0.09901475, 0.9901475],
            sn: [0.01451839, 0.2105169, 0.9774824],
            ss: [0.9996724, -0.02366485, -0.009751362],
            st: [0.02107915, 0.9773038, -0.2107915],
            uv: [0.775, 0.275],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 4.977533,
            p: [-0.1004493, 0.04932594, -0.02246629],
            n: [-0.1467348, 0.1467348, 0.978232],
            sn: [-0.01463121, 0.1165754, 0.9930741],
            ss: [0.9997407, -0.01562479, 0.01656361],
            st: [0.01744749, 0.9930589, -0.1163166],
            uv: [0.4497753, 0.475337],
        },
    ];
    const OBJ_QUAD_FACE: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.92,
            p: [0.3, -0.5, 0.08],
            n: [-0.09901475, 0.09901475, 0.9901475],
            sn: [-0.09901475, 0.09901475, 0.9901475],
            ss: [0.9950371, 0.0, 0.09950372],
            st: [0.009852336, 0.9950859, -0.09852336],
            uv: [0.65, 0.75],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.195,
            p: [-0.6, 0.7, -0.195],
            n: [-0.1467348, 0.1467348, 0.978232],
            sn: [-0.1467348, 0.1467348, 0.978232],
            ss: [0.9889364, -0.0, 0.1483405],
            st: [0.02176671, 0.9891759, -0.1451114],
            uv: [0.2, 0.15],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.99,
            p: [0.55, 0.45, 0.00999999],
            n: [-0.09901475, 0.09901475, 0.9901475],
            sn: [-0.09901475, 0.09901475, 0.9901475],
            ss: [0.9950371, 0.0, 0.09950372],
            st: [0.009852336, 0.9950859, -0.09852336],
            uv: [0.775, 0.275],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 4.977533,
            p: [-0.1004493, 0.04932594, -0.02246629],
            n: [-0.1467348, 0.1467348, 0.978232],
            sn: [-0.1467348, 0.1467348, 0.978232],
            ss: [0.9889364, -0.0, 0.1483405],
            st: [0.02176671, 0.9891759, -0.1451114],
            uv: [0.4497753, 0.475337],
        },
    ];
    const OBJ_QUAD_FLIP: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.92,
            p: [0.3, -0.5, 0.08],
            n: [0.09901475, -0.09901475, -0.9901475],
            sn: [-0.1170476, -0.07315475, -0.9904283],
            ss: [0.9930983, -0.01610631, -0.1161735],
            st: [-0.007453505, -0.9971905, 0.07453507],
            uv: [0.65, 0.75],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.195,
            p: [-0.6, 0.7, -0.195],
            n: [0.1467348, -0.1467348, -0.978232],
            sn: [0.1279814, 0.06918468, -0.9893606],
            ss: [0.9917235, 0.001397588, 0.1283848],
            st: [0.01026498, -0.997603, -0.0684332],
            uv: [0.2, 0.15],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.99,
            p: [0.55, 0.45, 0.00999999],
            n: [0.09901475, -0.09901475, -0.9901475],
            sn: [-0.01451839, -0.2105169, -0.9774824],
            ss: [0.9996724, -0.02366485, -0.009751362],
            st: [-0.02107915, -0.9773038, 0.2107915],
            uv: [0.775, 0.275],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 4.977533,
            p: [-0.1004493, 0.04932594, -0.02246629],
            n: [0.1467348, -0.1467348, -0.978232],
            sn: [0.01463121, -0.1165754, -0.9930741],
            ss: [0.9997407, -0.01562479, 0.01656361],
            st: [-0.01744749, -0.9930589, 0.1163166],
            uv: [0.4497753, 0.475337],
        },
    ];
    const OBJ_QUAD_XF: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.980604,
            p: [0.3, -0.5, 0.01939582],
            n: [-0.03412503, 0.01828755, 0.9992502],
            sn: [0.003401943, 0.04623993, 0.9989246],
            ss: [0.9611723, 0.2754832, -0.01602541],
            st: [-0.2759279, 0.9601932, -0.04350736],
            uv: [0.4399519, 0.7540063],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.049952,
            p: [-0.6, 0.7000001, -0.04995191],
            n: [-0.05113966, 0.02740566, 0.9983153],
            sn: [-0.02648943, 0.02529353, 0.999329],
            ss: [0.9608078, 0.2765996, 0.01846747],
            st: [-0.2759469, 0.9606523, -0.03162919],
            uv: [0.5450962, 0.1218911],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.989453,
            p: [0.55, 0.4500001, 0.01054728],
            n: [-0.03412503, 0.01828755, 0.9992502],
            sn: [-0.0164846, 0.0886577, 0.9959257],
            ss: [0.9616348, 0.2742012, -0.008492478],
            st: [-0.273837, 0.9575768, -0.08977643],
            uv: [0.7315785, 0.3738942],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 4.993504,
            p: [-0.1001298, 0.04980532, -0.006496495],
            n: [-0.05113966, 0.02740566, 0.9983153],
            sn: [-0.01908047, 0.05748999, 0.9981637],
            ss: [0.9614202, 0.2750727, 0.002535084],
            st: [-0.2744218, 0.9597031, -0.06052056],
            uv: [0.4907726, 0.4659174],
        },
    ];
    const OBJ_QUAD_MIRROR: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.98,
            p: [0.3, -0.5, 0.02],
            n: [-0.09901475, -0.09901475, -0.9901475],
            sn: [-0.02907577, 0.07268943, 0.9969307],
            ss: [-0.9995505, -0.009391086, -0.02846743],
            st: [0.007292981, -0.9973103, 0.07292981],
            uv: [0.35, 0.75],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.015,
            p: [-0.6, 0.7, -0.015],
            n: [-0.1467348, -0.1467348, -0.978232],
            sn: [0.009727045, 0.2226486, 0.9748502],
            ss: [-0.999397, -0.03033304, 0.01689982],
            st: [0.0333329, -0.9744267, 0.2222193],
            uv: [0.8, 0.15],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.15,
            p: [0.55, 0.45, -0.15],
            n: [-0.1467348, -0.1467348, -0.978232],
            sn: [0.09850046, -0.03231836, 0.9946121],
            ss: [-0.9951253, 0.001622176, 0.09860399],
            st: [-0.004800155, -0.9994762, -0.03200103],
            uv: [0.225, 0.275],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.004975,
            p: [-0.09990036, 0.05014908, 0.004975132],
            n: [-0.09901475, -0.09901475, -0.9901475],
            sn: [-0.007231738, 0.1526473, 0.9882543],
            ss: [-0.9998572, -0.01619945, -0.004814456],
            st: [0.01527426, -0.988148, 0.1527426],
            uv: [0.5499502, 0.4749255],
        },
    ];
    const OBJ_NONORMAL: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.67,
            p: [0.3, -0.5, 0.33],
            n: [-0.09245003, -0.3698001, 0.9245003],
            sn: [-0.02729966, -0.02012217, 0.9994248],
            ss: [0.9996253, 0.001458291, 0.02733449],
            st: [-0.002007482, 0.9997965, 0.02007482],
            uv: [0.65, 0.75],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.045,
            p: [-0.6, 0.7, -0.04499999],
            n: [-0.1247836, 0.5407287, 0.8318904],
            sn: [-0.2553759, 0.279028, 0.9257033],
            ss: [0.9659436, 0.03236835, 0.2567205],
            st: [0.04166871, 0.9597374, -0.2777914],
            uv: [0.2, 0.15],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.765,
            p: [0.55, 0.45, 0.235],
            n: [0.3698001, 0.09245003, 0.9245003],
            sn: [0.01871341, 0.2176774, 0.9758413],
            ss: [0.9961079, 0.0800226, -0.03695242],
            st: [-0.08613306, 0.9727347, -0.2153327],
            uv: [0.775, 0.275],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 5.431164,
            p: [-0.09137672, 0.06293494, 0.4311649],
            n: [-0.5407287, 0.1247836, 0.8318904],
            sn: [-0.1238551, 0.1172105, 0.9853535],
            ss: [0.9897662, -0.0563298, 0.1311104],
            st: [0.07087228, 0.9915082, -0.1090343],
            uv: [0.4543116, 0.4685325],
        },
    ];
    const OBJ_TENT: &[Case] = &[
        Case {
            o: [-0.1, 0.2, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.55,
            p: [-0.1, 0.2, 0.45],
            n: [-0.4472136, 0.0, 0.8944272],
            sn: [-0.4472136, 0.0, 0.8944273],
            ss: [0.8944272, 0.0, 0.4472136],
            st: [0.0, 1.0, -0.0],
            uv: [0.45, 0.4],
        },
        Case {
            o: [0.1, 0.2, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.55,
            p: [0.1, 0.2, 0.45],
            n: [0.4472136, -0.0, 0.8944272],
            sn: [0.4472136, 0.0, 0.8944273],
            ss: [0.8944272, -0.0, -0.4472136],
            st: [0.0, 1.0, -0.0],
            uv: [0.64, 0.4],
        },
    ];
    const OBJ_TENT_SHARED: &[Case] = &[
        Case {
            o: [-0.1, 0.2, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.55,
            p: [-0.1, 0.2, 0.45],
            n: [-0.4472136, 0.0, 0.8944272],
            sn: [-0.04515243, 0.0, 0.9989801],
            ss: [0.99898, 0.0, 0.04515243],
            st: [0.0, 0.9999999, -0.0],
            uv: [0.3, 0.6],
        },
        Case {
            o: [0.1, 0.2, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.55,
            p: [0.1, 0.2, 0.45],
            n: [0.4472136, -0.0, 0.8944272],
            sn: [0.04515244, 0.0, 0.9989801],
            ss: [0.4544121, 0.8905548, -0.02053877],
            st: [-0.8896466, 0.454876, 0.04021073],
            uv: [0.1, 0.5],
        },
    ];
    const OBJ_DEGEN_UV: &[Case] = &[Case {
        o: [0.5, -0.5, 5.0],
        d: [0.0, 0.0, -1.0],
        t: 4.9,
        p: [0.5, -0.5, 0.1],
        n: [-0.09901475, 0.09901475, 0.9901475],
        sn: [0.0, 0.0, 1.0],
        ss: [0.9999878, 0.004950556, 0.0],
        st: [-0.004950556, 0.9999878, 0.0],
        uv: [0.5, 0.5],
    }];
    const PLY_QUAD: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.92,
            p: [0.3, -0.5, 0.08],
            n: [-0.09901475, 0.09901475, 0.9901475],
            sn: [0.1170476, 0.07315475, 0.9904283],
            ss: [0.9930983, -0.01610631, -0.1161735],
            st: [0.007453505, 0.9971905, -0.07453507],
            uv: [0.65, 0.25],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.195,
            p: [-0.6, 0.7, -0.195],
            n: [-0.1467348, 0.1467348, 0.978232],
            sn: [-0.1279814, -0.06918468, 0.9893606],
            ss: [0.9917235, 0.001397588, 0.1283848],
            st: [-0.01026498, 0.997603, 0.0684332],
            uv: [0.2, 0.85],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.99,
            p: [0.55, 0.45, 0.00999999],
            n: [-0.09901475, 0.09901475, 0.9901475],
            sn: [0.01451839, 0.2105169, 0.9774824],
            ss: [0.9996724, -0.02366485, -0.009751362],
            st: [0.02107915, 0.9773038, -0.2107915],
            uv: [0.775, 0.725],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 4.977533,
            p: [-0.1004493, 0.04932594, -0.02246629],
            n: [-0.1467348, 0.1467348, 0.978232],
            sn: [-0.01463121, 0.1165754, 0.9930741],
            ss: [0.9997407, -0.01562479, 0.01656361],
            st: [0.01744749, 0.9930589, -0.1163166],
            uv: [0.4497753, 0.524663],
        },
    ];
    const PLY_QUAD_XF: &[Case] = &[
        Case {
            o: [0.3, -0.5, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.980604,
            p: [0.3, -0.5, 0.01939582],
            n: [-0.03412503, 0.01828755, 0.9992502],
            sn: [0.003401943, 0.04623993, 0.9989246],
            ss: [0.9611723, 0.2754832, -0.01602541],
            st: [-0.2759279, 0.9601932, -0.04350736],
            uv: [0.4399519, 0.2459937],
        },
        Case {
            o: [-0.6, 0.7, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 5.049952,
            p: [-0.6, 0.7000001, -0.04995191],
            n: [-0.05113966, 0.02740566, 0.9983153],
            sn: [-0.02648943, 0.02529353, 0.999329],
            ss: [0.9608078, 0.2765996, 0.01846747],
            st: [-0.2759469, 0.9606523, -0.03162919],
            uv: [0.5450962, 0.878109],
        },
        Case {
            o: [0.55, 0.45, 5.0],
            d: [0.0, 0.0, -1.0],
            t: 4.989453,
            p: [0.55, 0.4500001, 0.01054728],
            n: [-0.03412503, 0.01828755, 0.9992502],
            sn: [-0.0164846, 0.0886577, 0.9959257],
            ss: [0.9616348, 0.2742012, -0.008492478],
            st: [-0.273837, 0.9575768, -0.08977643],
            uv: [0.7315785, 0.6261057],
        },
        Case {
            o: [-0.2, -0.1, -5.0],
            d: [0.02, 0.03, 1.0],
            t: 4.993504,
            p: [-0.1001298, 0.04980532, -0.006496495],
            n: [-0.05113966, 0.02740566, 0.9983153],
            sn: [-0.01908047, 0.05748999, 0.9981637],
            ss: [0.9614202, 0.2750727, 0.002535084],
            st: [-0.2744218, 0.9597031, -0.06052056],
            uv: [0.4907726, 0.5340825],
        },
    ];
    const KNOT: &[Case] = &[
        Case {
            o: [2.0197, 4.5613, 3.2111],
            d: [-2.9782, -4.1454, -3.1537],
            t: 0.9027179,
            p: [-0.6687734, 0.8191742, 0.3642],
            n: [0.8210258, -0.5063517, -0.2636752],
            sn: [-0.8372357, 0.4904799, 0.2417974],
            ss: [-0.1457037, -0.6262711, 0.7658688],
            st: [0.527074, 0.6059819, 0.5958013],
            uv: [0.5390279, 0.1044928],
        },
        // miss: o=(3.9262, 2.3109, 2.3511) d=(-5.1143, -1.9509, -2.4573)
        // miss: o=(-0.2211, 2.3278, 5.2542) d=(-1.0997, -0.7048, -5.8561)
        Case {
            o: [-3.179, -1.5556, 4.4186],
            d: [2.6953, 2.779, -4.5839],
            t: 0.9370797,
            p: [-0.6532888, 1.048544, 0.1231206],
            n: [0.8457205, -0.3588014, -0.3949919],
            sn: [-0.861039, 0.3435775, 0.3749219],
            ss: [-0.01928538, -0.7587838, 0.651057],
            st: [0.5081732, 0.5533549, 0.6599684],
            uv: [0.5096986, 0.08691362],
        },
        Case {
            o: [-0.1983, 0.8924, -6.5525],
            d: [-0.4282, -0.129, 5.9833],
            t: 1.155261,
            p: [-0.6929829, 0.7433713, 0.3597754],
            n: [0.985975, -0.04058294, 0.1618836],
            sn: [-0.9888022, 0.07835705, -0.1270057],
            ss: [-0.1486739, -0.5907985, 0.7930025],
            st: [-0.01289744, 0.8030051, 0.5958325],
            uv: [0.5430979, 0.1120345],
        },
        // miss: o=(-1.4737, 2.6143, 5.7244) d=(0.7795, -2.0251, -5.5938)
        // miss: o=(-4.9052, 4.3078, -3.2408) d=(3.7816, -3.9073, 2.5362)
        Case {
            o: [-2.8476, -2.4739, 4.9241],
            d: [1.5317, 3.2765, -4.7872],
            t: 1.212288,
            p: [-0.9907389, 1.498161, -0.8793637],
            n: [0.3184189, 0.5167279, -0.7947336],
            sn: [-0.3230838, -0.5457859, 0.773133],
            ss: [0.7786721, 0.3109876, 0.5449373],
            st: [-0.5378538, 0.7780775, 0.3245132],
            uv: [0.3948505, 0.9039505],
        },
    ];
    const ICO: &[Case] = &[
        Case {
            o: [-0.1903, 6.7066, 0.8746],
            d: [1.8258, -5.6474, -0.8793],
            t: 0.9067315,
            p: [1.46521, 1.585925, 0.07731107],
            n: [0.08228444, 0.9807703, -0.1769712],
            sn: [0.09317633, 0.9800949, -0.1753059],
            ss: [-0.5161843, -0.1030099, -0.8502603],
            st: [-0.851394, 0.1697143, 0.4963115],
            uv: [0.2740752, 0.09290217],
        },
        Case {
            o: [-4.0636, 0.1634, -1.3598],
            d: [5.7637, 0.9202, 1.3902],
            t: 0.8465527,
            p: [0.815676, 0.9423978, -0.1829223],
            n: [-0.835537, 0.07355803, -0.544488],
            sn: [-0.8348664, 0.06057692, -0.5471091],
            ss: [0.5054109, -0.309414, -0.8054954],
            st: [-0.2180777, -0.9489959, 0.2277032],
            uv: [0.3339587, 0.6501563],
        },
        Case {
            o: [1.6098, 1.358, -6.0668],
            d: [-0.2753, -0.2523, 5.9884],
            t: 0.9359185,
            p: [1.352142, 1.121868, -0.462146],
            n: [-0.08714786, 0.3209378, -0.9430823],
            sn: [-0.06837231, 0.3169693, -0.9459682],
            ss: [-0.9299296, -0.3636558, -0.05463853],
            st: [-0.3613256, 0.875948, 0.3196231],
            uv: [0.03793642, 0.03230118],
        },
        Case {
            o: [7.3499, 2.574, 0.4664],
            d: [-5.8153, -1.4623, -0.208],
            t: 0.9179711,
            p: [2.011622, 1.231651, 0.275462],
            n: [0.8755172, 0.472672, 0.100253],
            sn: [0.8739525, 0.4738987, 0.1078283],
            ss: [0.09281335, 0.05504179, -0.994161],
            st: [-0.4770667, 0.8788574, 0.004119781],
            uv: [0.0968115, 0.3968321],
        },
        Case {
            o: [0.6642, 3.0822, -5.2828],
            d: [0.892, -2.1067, 5.5467],
            t: 0.8777982,
            p: [1.447196, 1.232943, -0.413917],
            n: [0.08613022, 0.4810928, -0.8724284],
            sn: [0.06742473, 0.475646, -0.877049],
            ss: [-0.9476575, 0.3054973, 0.09282608],
            st: [0.3120885, 0.8248833, 0.4713476],
            uv: [0.9512838, 0.001398928],
        },
        Case {
            o: [4.9393, -4.1395, 1.1542],
            d: [-3.1836, 5.0188, -0.8229],
            t: 0.9324774,
            p: [1.970665, 0.540417, 0.3868643],
            n: [0.8070367, -0.523736, 0.2727496],
            sn: [0.8153383, -0.5137547, 0.2669826],
            ss: [0.2271225, -0.1403571, -0.9636987],
            st: [0.5325776, 0.8463781, 0.002246767],
            uv: [0.2701862, 0.7153591],
        },
    ];
    const BUMPY: &[Case] = &[
        Case {
            o: [0.3, 3.0, 0.2],
            d: [0.05, -1.0, 0.1],
            t: 2.82173,
            p: [0.4410865, 0.1782697, 0.4821731],
            n: [-0.354524, 0.9293579, 0.1029877],
            sn: [-0.354524, 0.9293579, 0.1029877],
            ss: [0.6945023, 0.1879712, 0.6945023],
            st: [0.6260825, 0.317743, -0.7120816],
            uv: [0.08590744, 0.7370464],
        },
        Case {
            o: [-2.0, 4.0, 1.0],
            d: [0.3, -1.0, -0.2],
            t: 4.29678,
            p: [-0.710966, -0.2967795, 0.1406441],
            n: [-0.3000896, 0.9536102, -0.02395466],
            sn: [-0.3000896, 0.9536102, -0.02395466],
            ss: [0.0, 0.02511205, 0.9996846],
            st: [0.9539111, 0.299995, -0.007535866],
            uv: [0.4503047, 0.4498172],
        },
        Case {
            o: [2.5, 3.0, -3.0],
            d: [-0.1, -1.0, 0.4],
            t: 3.041054,
            p: [2.195895, -0.04105386, -1.783578],
            n: [-0.06316145, 0.9800376, -0.1885122],
            sn: [-0.06316145, 0.9800376, -0.1885122],
            ss: [0.0, 0.1888894, 0.9819984],
            st: [0.9980033, 0.06202444, -0.01193053],
            uv: [0.5313726, 0.05372548],
        },
        Case {
            o: [1.0, -3.0, 0.5],
            d: [0.0, 1.0, 0.0],
            t: 3.324913,
            p: [1.0, 0.324913, 0.5],
            n: [-0.1430799, 0.9703242, 0.1949341],
            sn: [-0.1430799, 0.9703242, 0.1949341],
            ss: [0.7066025, -0.0377609, 0.7066025],
            st: [0.6929943, 0.2388415, -0.6802306],
            uv: [0.2, 0.2],
        },
    ];
    const S_QUAD: &[SCase] = &[
        SCase {
            u: [0.3, 0.6],
            p: [-0.6733201, -0.3306012, -0.05140783],
            n: [-0.03340261, 0.01413691, 0.9993421],
            uv: [0.16334, 0.6653006],
            pdf: 0.2460384,
        },
        SCase {
            u: [0.8, 0.1],
            p: [0.2855477, -0.8200251, 0.1105573],
            n: [0.161079, 0.02622186, 0.9865931],
            uv: [0.6427739, 0.9100125],
            pdf: 0.2460384,
        },
        SCase {
            u: [0.05, 0.95],
            p: [-0.9493588, 0.8062367, -0.2633393],
            n: [-0.1700039, -0.1626819, 0.9719225],
            uv: [0.02532059, 0.09688163],
            pdf: 0.2460384,
        },
        SCase {
            u: [0.5, 0.5],
            p: [-0.4142135, -0.4057041, -0.001276409],
            n: [-0.0008262544, 0.08410049, 0.9964569],
            uv: [0.2928932, 0.7028521],
            pdf: 0.2460384,
        },
    ];
    const S_QUAD_FACE_FLIP: &[SCase] = &[
        SCase {
            u: [0.3, 0.6],
            p: [-0.6733201, -0.3306012, -0.05140783],
            n: [0.1467348, -0.1467348, -0.978232],
            uv: [0.16334, 0.6653006],
            pdf: 0.2460384,
        },
        SCase {
            u: [0.8, 0.1],
            p: [0.2855477, -0.8200251, 0.1105573],
            n: [0.09901475, -0.09901475, -0.9901475],
            uv: [0.6427739, 0.9100125],
            pdf: 0.2460384,
        },
        SCase {
            u: [0.05, 0.95],
            p: [-0.9493588, 0.8062367, -0.2633393],
            n: [0.1467348, -0.1467348, -0.978232],
            uv: [0.02532059, 0.09688163],
            pdf: 0.2460384,
        },
        SCase {
            u: [0.5, 0.5],
            p: [-0.4142135, -0.4057041, -0.001276409],
            n: [0.1467348, -0.1467348, -0.978232],
            uv: [0.2928932, 0.7028521],
            pdf: 0.2460384,
        },
    ];
    const S_RECT: &[SCase] = &[
        SCase {
            u: [0.3, 0.6],
            p: [-0.8, 0.1879386, 0.06840404],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.3, 0.6],
            pdf: 0.125,
        },
        SCase {
            u: [0.8, 0.1],
            p: [1.2, -0.7517542, -0.2736161],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.8, 0.1],
            pdf: 0.125,
        },
        SCase {
            u: [0.05, 0.95],
            p: [-1.8, 0.8457234, 0.3078181],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.05, 0.95],
            pdf: 0.125,
        },
        SCase {
            u: [0.5, 0.5],
            p: [0.0, 0.0, 0.0],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.5, 0.5],
            pdf: 0.125,
        },
    ];
    const S_DISK: &[SCase] = &[
        SCase {
            u: [0.3, 0.6],
            p: [-0.7391035, 0.143842, 0.05235419],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.3999999, 0.4375],
            pdf: 0.1591549,
        },
        SCase {
            u: [0.8, 0.1],
            p: [0.8889126, -0.6250607, -0.2275034],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.8, 0.8437501],
            pdf: 0.1591549,
        },
        SCase {
            u: [0.05, 0.95],
            p: [-1.272792, 0.5980167, 0.2176603],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.9, 0.3750001],
            pdf: 0.1591549,
        },
        SCase {
            u: [0.5, 0.5],
            p: [0.0, 0.0, 0.0],
            n: [0.0, -0.3420201, 0.9396927],
            uv: [0.0, 0.0],
            pdf: 0.1591549,
        },
    ];
    const S_SPHERE: &[SCase] = &[
        SCase {
            u: [0.3, 0.6],
            p: [-0.04221899, 0.845473, -0.46],
            n: [-0.3027737, 0.9318412, -0.2],
            uv: [0.3, 0.5640942],
            pdf: 0.1243398,
        },
        SCase {
            u: [0.8, 0.1],
            p: [0.3483282, -0.3565071, 0.34],
            n: [0.1854103, -0.5706338, 0.8],
            uv: [0.8, 0.2048327],
            pdf: 0.1243398,
        },
        SCase {
            u: [0.05, 0.95],
            p: [0.5316448, 0.2077579, -1.02],
            n: [0.414556, 0.1346974, -0.9],
            uv: [0.04999999, 0.8564337],
            pdf: 0.1243398,
        },
        SCase {
            u: [0.5, 0.5],
            p: [-0.6, 0.09999993, -0.3],
            n: [-1.0, -8.742278e-08, 0.0],
            uv: [0.5, 0.5000001],
            pdf: 0.1243398,
        },
    ];
    const S_CUBE: &[SCase] = &[
        SCase {
            u: [0.3, 0.6],
            p: [-0.6733201, -0.6653359, 1.0],
            n: [0.0, 0.0, 1.0],
            uv: [0.1673321, 0.16334],
            pdf: 0.04166667,
        },
        SCase {
            u: [0.8, 0.1],
            p: [0.1055728, -1.0, -0.8211145],
            n: [0.0, -1.0, 0.0],
            uv: [0.08944272, 0.5527864],
            pdf: 0.04166667,
        },
        SCase {
            u: [0.05, 0.95],
            p: [-0.9493588, 0.2202574, -1.0],
            n: [0.0, 0.0, -1.0],
            uv: [0.3898713, 0.02532059],
            pdf: 0.04166667,
        },
        SCase {
            u: [0.5, 0.5],
            p: [1.0, 0.4142133, 0.4142135],
            n: [1.0, 0.0, 0.0],
            uv: [0.7071066, 0.2928932],
            pdf: 0.04166667,
        },
    ];

    // Generated by scripts/gen_shape_cases.py (Mitsuba 3.9.1, scalar_rgb).
    #[rustfmt::skip]
    #[allow(clippy::approx_constant)]
    mod mitsuba_cases {
        use super::{Case, SCase};
    pub const CYL: &[Case] = &[
        Case { o: [-2.227051, -1.363356, 0.9], d: [1.418034, 0.775571, -0.6], t: 0.9999999, p: [-0.8090169, -0.5877855, 0.3], n: [-0.8090168, -0.5877855, 0.0], sn: [-0.8090168, -0.5877855, 0.0], ss: [0.5877855, -0.8090168, 0.0], st: [0.0, 0.0, 1.0], uv: [0.6, 0.3] },
        Case { o: [0.0, 0.0, 0.5], d: [-0.8090168, -0.5877855, -0.2], t: 1.0, p: [-0.8090169, -0.5877855, 0.3], n: [-0.8090168, -0.5877854, 0.0], sn: [-0.8090168, -0.5877854, 0.0], ss: [0.5877854, -0.8090168, 0.0], st: [0.0, 0.0, 0.9999999], uv: [0.6, 0.3] },
        Case { o: [1.127051, 3.25317, 1.3], d: [-0.8180339, -2.302113, -0.6], t: 1.0, p: [0.309017, 0.9510566, 0.7], n: [0.309017, 0.9510565, -0.0], sn: [0.309017, 0.9510565, -0.0], ss: [-0.9510565, 0.309017, 0.0], st: [0.0, 0.0, 1.0], uv: [0.2, 0.6999999] },
        Case { o: [0.0, 0.0, 0.5], d: [0.309017, 0.9510565, 0.2], t: 1.0, p: [0.309017, 0.9510566, 0.7], n: [0.309017, 0.9510565, -0.0], sn: [0.309017, 0.9510565, -0.0], ss: [-0.9510565, 0.309017, 0.0], st: [0.0, 0.0, 1.0], uv: [0.2, 0.6999999] },
        Case { o: [2.627051, -1.363356, 1.1], d: [-1.818034, 0.7755706, -0.6], t: 0.9999999, p: [0.8090171, -0.5877854, 0.5000001], n: [0.8090169, -0.5877852, 0.0], sn: [0.8090169, -0.5877852, 0.0], ss: [0.5877852, 0.8090169, 0.0], st: [-0.0, 0.0, 0.9999998], uv: [0.9, 0.5] },
        Case { o: [0.0, 0.0, 0.5], d: [0.809017, -0.5877853, 0.0], t: 1.0, p: [0.8090171, -0.5877854, 0.5], n: [0.809017, -0.5877853, 0.0], sn: [0.809017, -0.5877853, 0.0], ss: [0.5877853, 0.809017, 0.0], st: [-0.0, 0.0, 1.0], uv: [0.9, 0.5] },
    ];
    pub const S_CYL: &[SCase] = &[
        SCase { u: [0.3, 0.6], p: [-0.8090168, -0.5877855, 0.3], n: [-0.8090169, -0.5877855, 0.0], uv: [0.6, 0.3], pdf: 0.1591549 },
        SCase { u: [0.8, 0.1], p: [0.809017, 0.5877852, 0.8], n: [0.8090171, 0.5877852, 0.0], uv: [0.1, 0.8], pdf: 0.1591549 },
    ];
    pub const CYL_P: &[Case] = &[
        Case { o: [-1.165902, -0.683917, 2.571463], d: [1.188722, 0.6991336, -1.529171], t: 1.0, p: [0.02281952, 0.01521659, 1.042293], n: [-0.6943609, -0.5495668, 0.4645852], sn: [-0.6943609, -0.5495668, 0.4645852], ss: [0.5514913, -0.8211149, -0.1470633], st: [0.462299, 0.1540997, 0.8732314], uv: [0.6, 0.3] },
        Case { o: [0.55, 0.35, 1.15], d: [-0.5271804, -0.3347834, -0.1077074], t: 0.9999999, p: [0.02281949, 0.01521654, 1.042293], n: [-0.6943608, -0.5495668, 0.4645851], sn: [-0.6943608, -0.5495668, 0.4645851], ss: [0.5514914, -0.8211148, -0.1470634], st: [0.4622989, 0.1540996, 0.8732313], uv: [0.6, 0.3] },
        Case { o: [1.523979, 3.12812, 1.366461], d: [-0.675183, -2.254496, -0.02116859], t: 1.0, p: [0.8487958, 0.8736242, 1.345292], n: [0.2375916, 0.9272479, -0.2894158], sn: [0.2375916, 0.9272479, -0.2894158], ss: [-0.8543009, 0.341269, 0.3920529], st: [0.4622989, 0.1540997, 0.8732314], uv: [0.2, 0.7] },
        Case { o: [0.55, 0.35, 1.15], d: [0.2987957, 0.5236239, 0.1952922], t: 1.0, p: [0.8487958, 0.8736241, 1.345292], n: [0.2375914, 0.927248, -0.2894157], sn: [0.2375914, 0.927248, -0.2894157], ss: [-0.8543009, 0.3412689, 0.392053], st: [0.462299, 0.1540997, 0.8732314], uv: [0.2, 0.7] },
        Case { o: [2.597672, -0.7777535, 1.041425], d: [-1.678137, 0.8222028, -0.03313971], t: 1.0, p: [0.9195343, 0.04444933, 1.008285], n: [0.7390687, -0.6111013, -0.2834302], sn: [0.7390687, -0.6111013, -0.2834302], ss: [0.4899563, 0.7764075, -0.3964017], st: [0.462299, 0.1540997, 0.8732314], uv: [0.9, 0.5] },
        Case { o: [0.55, 0.35, 1.15], d: [0.3695343, -0.3055507, -0.141715], t: 1.0, p: [0.9195343, 0.0444493, 1.008285], n: [0.7390687, -0.6111014, -0.2834302], sn: [0.7390687, -0.6111014, -0.2834302], ss: [0.4899563, 0.7764074, -0.3964017], st: [0.462299, 0.1540997, 0.8732314], uv: [0.9, 0.5] },
    ];
    pub const S_CYL_P: &[SCase] = &[
        SCase { u: [0.3, 0.6], p: [0.02281957, 0.01521661, 1.042293], n: [-0.6943609, -0.5495668, 0.4645852], uv: [0.6, 0.3], pdf: 0.1635048 },
        SCase { u: [0.8, 0.1], p: [1.167181, 0.7147833, 1.427707], n: [0.694361, 0.5495666, -0.4645852], uv: [0.1, 0.8], pdf: 0.1635048 },
    ];
    pub const CYL_FLIP: &[Case] = &[
        Case { o: [0.5910857, 2.869221, 1.1], d: [-0.5128685, -2.375377, -0.6], t: 1.0, p: [0.07821715, 0.4938443, 0.5], n: [-0.1564343, -0.9876883, 0.0], sn: [-0.1564343, -0.9876883, 0.0], ss: [-0.9876883, 0.1564343, 0.0], st: [-0.0, 0.0, -0.9999999], uv: [0.6, 0.3] },
        Case { o: [0.0, 0.0, 0.7], d: [0.07821712, 0.4938442, -0.2], t: 1.0, p: [0.07821713, 0.4938442, 0.5], n: [-0.1564343, -0.9876884, 0.0], sn: [-0.1564343, -0.9876884, 0.0], ss: [-0.9876884, 0.1564343, 0.0], st: [-0.0, 0.0, -1.0], uv: [0.6, 0.3] },
        Case { o: [1.334976, -1.827516, 1.5], d: [-1.107981, 1.382013, -0.6], t: 1.0, p: [0.2269953, -0.4455034, 0.9], n: [-0.4539905, 0.8910065, -0.0], sn: [-0.4539905, 0.8910065, -0.0], ss: [0.8910065, 0.4539905, 0.0], st: [0.0, 0.0, -1.0], uv: [0.2, 0.6999999] },
        Case { o: [0.0, 0.0, 0.7], d: [0.2269952, -0.4455033, 0.2], t: 1.0, p: [0.2269953, -0.4455033, 0.9], n: [-0.4539904, 0.8910065, -0.0], sn: [-0.4539904, 0.8910065, -0.0], ss: [0.8910065, 0.4539904, 0.0], st: [0.0, 0.0, -0.9999998], uv: [0.2, 0.6999999] },
        Case { o: [-2.269221, 0.008914143, 1.3], d: [1.775377, -0.08713132, -0.6], t: 1.0, p: [-0.4938443, -0.07821721, 0.7], n: [0.9876884, 0.1564344, -0.0], sn: [0.9876884, 0.1564344, -0.0], ss: [0.1564344, -0.9876884, 0.0], st: [0.0, -0.0, -1.0], uv: [0.9, 0.5] },
        Case { o: [0.0, 0.0, 0.7], d: [-0.4938442, -0.07821718, 0.0], t: 1.0, p: [-0.4938442, -0.07821719, 0.7], n: [0.9876884, 0.1564344, -0.0], sn: [0.9876884, 0.1564344, -0.0], ss: [0.1564344, -0.9876884, 0.0], st: [0.0, -0.0, -1.0], uv: [0.9, 0.5] },
    ];
    pub const S_CYL_FLIP: &[SCase] = &[
        SCase { u: [0.3, 0.6], p: [0.07821712, 0.4938442, 0.5], n: [-0.1564343, -0.9876884, 0.0], uv: [0.6, 0.3], pdf: 0.3183099 },
        SCase { u: [0.8, 0.1], p: [-0.07821727, -0.4938442, 1.0], n: [0.1564346, 0.9876884, -0.0], uv: [0.1, 0.8], pdf: 0.3183099 },
    ];
    pub const CYL_XF: &[Case] = &[
        Case { o: [-3.036067, -1.860654, -0.0631839], d: [1.418034, 0.7046754, -0.1979311], t: 0.9999998, p: [-1.618034, -1.155979, -0.261115], n: [-0.8090169, -0.5523377, -0.2010345], sn: [-0.8090169, -0.5523377, -0.2010345], ss: [0.5877855, -0.7602272, -0.2767], st: [-1.310599e-08, -0.3420201, 0.9396927], uv: [0.6, 0.3000002] },
        Case { o: [1.436068, 3.855096, 2.230014], d: [-0.8180339, -2.187402, -1.250561], t: 0.9999999, p: [0.6180341, 1.667695, 0.9794535], n: [0.309017, 0.8937008, 0.3252805], sn: [0.309017, 0.8937008, 0.3252805], ss: [-0.9510565, 0.290381, 0.10569], st: [1.854872e-11, -0.3420201, 0.9396927], uv: [0.2, 0.7000002] },
        Case { o: [3.436068, -1.894855, 0.03078561], d: [-1.818034, 0.7046751, -0.1979312], t: 0.9999999, p: [1.618034, -1.19018, -0.1671456], n: [0.809017, -0.5523375, -0.2010344], sn: [0.809017, -0.5523375, -0.2010344], ss: [0.5877852, 0.7602273, 0.2767], st: [1.791199e-08, -0.3420201, 0.9396926], uv: [0.9, 0.5000001] },
    ];
    pub const S_CYL_XF: &[SCase] = &[
        SCase { u: [0.3, 0.6], p: [-1.618034, -1.155978, -0.261115], n: [-0.8090168, -0.5523377, -0.2010345], uv: [0.6, 0.3], pdf: 0.1591549 },
        SCase { u: [0.8, 0.1], p: [1.618034, 0.9678669, 0.7779458], n: [0.8090171, 0.5523375, 0.2010344], uv: [0.1, 0.8], pdf: 0.1591549 },
    ];
    pub const CYL_MIRROR: &[Case] = &[
        Case { o: [1.413525, -0.4816782, 0.9], d: [-1.818034, 0.775571, -0.6], t: 0.5068316, p: [0.4920883, -0.08859434, 0.5959011], n: [0.9841769, -0.1771888, -0.0], sn: [0.9841769, -0.1771888, -0.0], ss: [-0.1771888, -0.9841769, 0.0], st: [-0.0, 0.0, -1.0], uv: [0.02835017, 0.595901] },
        Case { o: [-0.2635255, 1.826585, 1.3], d: [0.418034, -2.302113, -0.6], t: 0.5764674, p: [-0.02254255, 0.4994918, 0.9541196], n: [-0.04508507, 0.9989832, -0.0], sn: [-0.04508507, 0.9989832, -0.0], ss: [0.9989832, 0.04508507, 0.0], st: [0.0, 0.0, -1.0], uv: [0.7428221, 0.9541194] },
        Case { o: [-1.013525, -0.481678, 1.1], d: [1.418034, 0.7755706, -0.6], t: 0.3863399, p: [-0.4656823, -0.1820441, 0.8681961], n: [-0.9313645, -0.3640881, 0.0], sn: [-0.9313645, -0.3640881, 0.0], ss: [-0.3640881, 0.9313645, 0.0], st: [-0.0, 0.0, -0.9999999], uv: [0.4406904, 0.868196] },
    ];
    pub const S_CYL_MIRROR: &[SCase] = &[
        SCase { u: [0.3, 0.6], p: [-0.4045084, 0.2938927, 0.3], n: [0.8090168, -0.5877855, 0.0], uv: [0.6, 0.3], pdf: 0.3183099 },
        SCase { u: [0.8, 0.1], p: [0.4045085, -0.2938926, 0.8], n: [-0.8090171, 0.5877853, -0.0], uv: [0.1, 0.8], pdf: 0.3183099 },
    ];
    pub const INSTANCE: &[Case] = &[
        // SmoothDiffuse
        Case { o: [1.5, 2.5, 10.0], d: [0.01, 0.02, -1.0], t: 6.055532, p: [1.560555, 2.621111, 3.944468], n: [-0.3054701, 0.1211105, 0.9444683], sn: [-0.3054701, 0.1211105, 0.9444683], ss: [-0.3685623, -0.9296031, 0.0], st: [0.8779806, -0.3480954, 0.3286027], uv: [0.3565917, 0.1065777] },
        // SmoothDiffuse
        Case { o: [2.0, 4.0, 10.0], d: [-0.1, -0.1, -1.0], t: 6.824534, p: [1.317546, 3.317547, 3.175466], n: [-0.5484789, 0.8175467, 0.1754661], sn: [-0.5484789, 0.8175467, 0.1754661], ss: [-0.8304304, -0.5571224, 6.763075e-09], st: [0.09775611, -0.1457124, 0.9844855], uv: [0.2607139, 0.4438568] },
        // SmoothConductor
        Case { o: [-4.5, 5.0, 2.0], d: [0.0, -5.0, -2.0], t: 0.7027082, p: [-4.5, 1.486459, 0.5945837], n: [0.0, -0.6427876, 0.7660444], sn: [0.0, -0.6427876, 0.7660444], ss: [1.0, 0.0, 0.0], st: [-0.0, 0.7660444, 0.6427876], uv: [0.75, 0.8802212] },
        // SmoothConductor
        Case { o: [-5.3, 0.2, -6.0], d: [0.0, 0.0, 1.0], t: 5.515117, p: [-5.3, 0.2000003, -0.4848835], n: [0.0, -0.6427876, 0.7660444], sn: [0.0, -0.6427876, 0.7660444], ss: [1.0, 0.0, 0.0], st: [-0.0, 0.7660444, 0.6427876], uv: [0.3499999, 0.460383] },
        // SmoothConductor
        Case { o: [-4.4, 6.0, 0.1], d: [0.0, -1.0, 0.0], t: 5.102963, p: [-4.4, 0.8970373, 0.09999996], n: [0.0, -0.6427876, 0.7660444], sn: [0.0, -0.6427876, 0.7660444], ss: [1.0, 0.0, 0.0], st: [-0.0, 0.7660444, 0.6427876], uv: [0.8, 0.6878623] },
        // SmoothDiffuse
        Case { o: [-4.45, 0.1, 5.0], d: [0.0, 0.0, -1.0], t: 4.609482, p: [-4.45, 0.09999976, 0.3905177], n: [0.0529444, -0.5730222, 0.8178279], sn: [0.0529444, -0.5730222, 0.8178279], ss: [-0.8535301, 0.3991425, 0.3349203], st: [-0.5183467, -0.7157729, -0.4679593], uv: [0.2028509, 0.1112892] },
    ];
    }
    use mitsuba_cases::*;

    /// The XML of `INSTANCE` (see scripts/gen_shape_cases.py).
    const INSTANCE_XML: &str = r#"<shape type="shapegroup" id="g">
        <shape type="sphere"><point name="center" x="0.5" y="0" z="0"/><float name="radius" value="0.5"/>
            <bsdf type="diffuse"/></shape>
        <shape type="rectangle"><transform name="to_world"><translate z="-1"/></transform>
            <bsdf type="conductor"/></shape>
    </shape>
    <shape type="instance"><ref id="g"/>
        <transform name="to_world"><scale value="2"/><rotate z="1" angle="30"/><translate x="1" y="2" z="3"/></transform>
    </shape>
    <shape type="instance"><ref id="g"/>
        <transform name="to_world"><scale x="1" y="2" z="0.5"/><rotate x="1" angle="40"/><translate x="-5"/></transform>
    </shape>"#;

    fn tmp_file(name: &str, contents: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("specula-geometry-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join(name);
        std::fs::write(&p, contents).unwrap();
        p
    }

    fn asset(name: &str) -> PathBuf {
        specula_testdata::root().join("scenes/assets").join(name)
    }

    fn rot(axis: [f32; 3], deg: f32) -> Mat4 {
        Mat4::from_axis_angle(Vec3::from(axis).normalize(), deg.to_radians())
    }
    fn tr(v: [f32; 3]) -> Mat4 {
        Mat4::from_translation(Vec3::from(v))
    }
    fn sc(v: [f32; 3]) -> Mat4 {
        Mat4::from_scale(Vec3::from(v))
    }
    fn nonuni() -> Mat4 {
        rot([1.0, 0.0, 0.0], 20.0) * sc([2.0, 1.0, 0.5])
    }
    fn mirror() -> Mat4 {
        sc([-1.0, 1.0, 1.0])
    }

    fn close3(what: &str, name: &str, i: usize, got: Vec3, want: [f32; 3]) {
        let want = Vec3::from(want);
        assert!(
            (got - want).abs().max_element() < 1e-4,
            "{name} case {i}: {what} = {got}, Mitsuba: {want}"
        );
    }

    fn check(name: &str, geom: Geometry, cases: &[Case]) {
        assert!(!cases.is_empty());
        let bvh = Bvh::build(std::slice::from_ref(&geom));
        for (i, c) in cases.iter().enumerate() {
            let ray = Ray::new(Vec3::from(c.o), Vec3::from(c.d));
            let hit = bvh
                .intersect(&ray)
                .unwrap_or_else(|| panic!("{name} case {i}: no hit, Mitsuba hit at t = {}", c.t));
            assert!(
                (hit.t - c.t).abs() <= 1e-4 * c.t.max(1.0),
                "{name} case {i}: t = {}, Mitsuba: {}",
                hit.t,
                c.t
            );
            let sg = geom.surface(&ray, &hit);
            close3("p", name, i, sg.p, c.p);
            close3("n", name, i, sg.n_geo, c.n);
            close3("sh_frame.n", name, i, sg.sh_frame.n, c.sn);
            close3("sh_frame.s", name, i, sg.sh_frame.s, c.ss);
            close3("sh_frame.t", name, i, sg.sh_frame.t, c.st);
            let uv = Vec2::from(c.uv);
            assert!(
                (sg.uv - uv).abs().max_element() < 1e-4,
                "{name} case {i}: uv = {}, Mitsuba: {uv}",
                sg.uv
            );
            assert!(bvh.occluded(&ray), "{name} case {i}: not occluded");
            let short = Ray {
                t_max: hit.t * 0.999,
                ..ray
            };
            assert!(!bvh.occluded(&short) && bvh.intersect(&short).is_none());
        }
    }

    fn check_samples(name: &str, geom: &Geometry, cases: &[SCase]) {
        for (i, c) in cases.iter().enumerate() {
            let ps = geom.sample_position(Vec2::from(c.u));
            close3("p", name, i, ps.p, c.p);
            close3("n", name, i, ps.n, c.n);
            let uv = Vec2::from(c.uv);
            assert!(
                (ps.uv - uv).abs().max_element() < 1e-4,
                "{name} sample {i}: uv = {}, Mitsuba: {uv}",
                ps.uv
            );
            assert!(
                (ps.pdf - c.pdf).abs() < 1e-4 * c.pdf,
                "{name} sample {i}: pdf {}",
                ps.pdf
            );
            assert!((geom.pdf_position() - c.pdf).abs() < 1e-4 * c.pdf);
        }
    }

    fn obj(contents: &str, name: &str) -> MeshData {
        load_obj(&tmp_file(name, contents)).unwrap()
    }

    #[test]
    fn mitsuba_rectangle() {
        check("rect", Geometry::rectangle(Mat4::IDENTITY, false), RECT);
        check(
            "rect flip",
            Geometry::rectangle(Mat4::IDENTITY, true),
            RECT_FLIP,
        );
        check("rect xf", Geometry::rectangle(nonuni(), false), RECT_XF);
        check(
            "rect mirror",
            Geometry::rectangle(mirror(), false),
            RECT_MIRROR,
        );
        check_samples("rect", &Geometry::rectangle(nonuni(), false), S_RECT);
    }

    /// The flat-face shortcut of `rectangle` and `cube` gives the general mesh path's
    /// surface (the same p, uv, n_geo, ∂p/∂u, ∂p/∂v; the shading frame within rounding).
    #[test]
    fn flat_faces_match_general_surface() {
        let shapes = [
            Geometry::rectangle(nonuni(), false),
            Geometry::rectangle(mirror(), true),
            Geometry::cube(nonuni(), false),
            Geometry::cube(mirror(), true),
        ];
        for g in shapes {
            let Geometry::Mesh(fast) = g else { panic!() };
            assert!(fast.flat.is_some());
            let mut general = fast.clone();
            general.flat = None;
            for prim in 0..fast.indices.len() as u32 {
                for (u, v) in [(0.1, 0.2), (0.7, 0.25), (0.0, 1.0), (0.3, 0.3)] {
                    let hit = Hit {
                        t: 1.0,
                        shape: 0,
                        prim,
                        u,
                        v,
                        vertices: None,
                    };
                    let (a, b) = (fast.surface(&hit), general.surface(&hit));
                    assert_eq!((a.p, a.uv, a.n_geo), (b.p, b.uv, b.n_geo));
                    assert_eq!((a.dp_du, a.dp_dv), (b.dp_du, b.dp_dv));
                    for (x, y) in [
                        (a.sh_frame.n, b.sh_frame.n),
                        (a.sh_frame.s, b.sh_frame.s),
                        (a.sh_frame.t, b.sh_frame.t),
                    ] {
                        assert!((x - y).abs().max_element() < 1e-6, "{x} vs {y}");
                    }
                }
            }
        }
    }

    #[test]
    fn mitsuba_disk() {
        check("disk", Geometry::disk(Mat4::IDENTITY, false), DISK);
        check("disk flip", Geometry::disk(Mat4::IDENTITY, true), DISK_FLIP);
        check("disk xf", Geometry::disk(nonuni(), false), DISK_XF);
        check("disk mirror", Geometry::disk(mirror(), false), DISK_MIRROR);
        check_samples("disk", &Geometry::disk(nonuni(), false), S_DISK);
    }

    #[test]
    fn mitsuba_sphere() {
        check(
            "sphere",
            Geometry::sphere(Vec3::ZERO, 1.0, Mat4::IDENTITY, false),
            SPHERE,
        );
        check(
            "sphere flip",
            Geometry::sphere(Vec3::ZERO, 1.0, Mat4::IDENTITY, true),
            SPHERE_FLIP,
        );
        let xf = tr([0.5, -0.2, 0.1]) * rot([1.0, 1.0, 0.0], 40.0) * sc([1.5; 3]);
        check(
            "sphere xf",
            Geometry::sphere(Vec3::new(0.2, 0.1, -0.3), 0.8, xf, false),
            SPHERE_XF,
        );
        let s = Geometry::sphere(Vec3::new(0.2, 0.1, -0.3), 0.8, Mat4::IDENTITY, false);
        check_samples("sphere", &s, S_SPHERE);
    }

    fn cyl(p0: [f32; 3], p1: [f32; 3], r: f32, m: Mat4, flip: bool) -> Geometry {
        Geometry::cylinder(Vec3::from(p0), Vec3::from(p1), r, m, flip).unwrap()
    }

    #[test]
    fn mitsuba_cylinder() {
        let (o, z) = ([0.0; 3], [0.0, 0.0, 1.0]);
        let cases: [(&str, Geometry, &[Case], &[SCase]); 5] = [
            ("cyl", cyl(o, z, 1.0, Mat4::IDENTITY, false), CYL, S_CYL),
            (
                "cyl p0 p1",
                cyl([0.1, 0.2, 0.3], [1.0, 0.5, 2.0], 0.5, Mat4::IDENTITY, false),
                CYL_P,
                S_CYL_P,
            ),
            (
                "cyl flip",
                cyl(o, z, 0.5, rot(z, 225.0) * tr([0.0, 0.0, 0.2]), true),
                CYL_FLIP,
                S_CYL_FLIP,
            ),
            (
                "cyl xf",
                cyl(
                    o,
                    z,
                    1.0,
                    rot([1.0, 0.0, 0.0], 20.0) * sc([2.0, 2.0, 0.5]),
                    false,
                ),
                CYL_XF,
                S_CYL_XF,
            ),
            (
                "cyl mirror",
                cyl(o, z, -0.5, mirror(), false),
                CYL_MIRROR,
                S_CYL_MIRROR,
            ),
        ];
        for (name, g, c, sc) in cases {
            check_samples(name, &g, sc);
            check(name, g, c);
        }
        // bounds hold every sampled point and are tight for an axis-aligned cylinder
        let g = cyl([0.1, 0.2, 0.3], [1.0, 0.5, 2.0], 0.5, Mat4::IDENTITY, false);
        let (lo, hi) = g.bounds();
        for i in 0..100 {
            let p = g
                .sample_position(Vec2::new(i as f32 / 100.0, (i * 37 % 100) as f32 / 100.0))
                .p;
            assert!(p.cmpge(lo - 1e-5).all() && p.cmple(hi + 1e-5).all());
        }
        let (lo, hi) = cyl(o, z, 2.0, Mat4::IDENTITY, false).bounds();
        assert_eq!(
            (lo, hi),
            (Vec3::new(-2.0, -2.0, 0.0), Vec3::new(2.0, 2.0, 1.0))
        );
        // open: a ray along the axis passes through
        let g = cyl(o, z, 1.0, Mat4::IDENTITY, false);
        let bvh = Bvh::build(std::slice::from_ref(&g));
        assert!(bvh
            .intersect(&Ray::new(Vec3::new(0.2, 0.0, -3.0), Vec3::Z))
            .is_none());
        // ...and one that misses the finite length
        assert!(bvh
            .intersect(&Ray::new(Vec3::new(3.0, 0.0, 1.5), -Vec3::X))
            .is_none());
        for (p0, p1, r) in [
            (o, o, 1.0),
            (o, z, 0.0),
            (o, z, f32::NAN),
            (o, [f32::INFINITY, 0.0, 0.0], 1.0),
        ] {
            assert!(
                Geometry::cylinder(Vec3::from(p0), Vec3::from(p1), r, Mat4::IDENTITY, false)
                    .is_err()
            );
        }
        assert!(Geometry::cylinder(Vec3::ZERO, Vec3::Z, 1.0, sc([1.0, 0.0, 1.0]), false).is_err());
    }

    #[test]
    fn mitsuba_instances() {
        use crate::scene::Scene;
        let text = format!(
            r#"<scene version="3.0.0">
    <sensor type="perspective"><float name="fov" value="40"/>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    {INSTANCE_XML}
</scene>"#
        );
        let scene = Scene::from_xml_str(&text, "<test>", std::path::Path::new("."), &[]).unwrap();
        // two instances of two shapes: four slots, one BVH primitive per instance
        assert_eq!(scene.geometry.len(), 4);
        assert_eq!(scene.accel.primitive_count(), 2);
        let bsdf_names: Vec<String> = scene.bsdfs.iter().map(|b| format!("{b:?}")).collect();
        for (i, c) in INSTANCE.iter().enumerate() {
            let ray = Ray::new(Vec3::from(c.o), Vec3::from(c.d));
            let hit = scene
                .intersect(&ray)
                .unwrap_or_else(|| panic!("instance case {i}: no hit"));
            assert!(
                (hit.t - c.t).abs() <= 1e-4 * c.t.max(1.0),
                "case {i}: t {} vs {}",
                hit.t,
                c.t
            );
            let sg = scene.geometry[hit.shape as usize].surface(&ray, &hit);
            close3("p", "instance", i, sg.p, c.p);
            close3("n", "instance", i, sg.n_geo, c.n);
            close3("sh_frame.n", "instance", i, sg.sh_frame.n, c.sn);
            close3("sh_frame.s", "instance", i, sg.sh_frame.s, c.ss);
            close3("sh_frame.t", "instance", i, sg.sh_frame.t, c.st);
            assert!(
                (sg.uv - Vec2::from(c.uv)).abs().max_element() < 1e-4,
                "case {i}: uv {}",
                sg.uv
            );
            // the BSDF of the group shape hit: the sphere's diffuse, the rectangle's conductor
            let want = if matches!(i, 0 | 1 | 5) {
                "Diffuse"
            } else {
                "Conductor"
            };
            let got = &bsdf_names[scene.shape_bsdf[hit.shape as usize] as usize];
            assert!(got.starts_with(want), "case {i}: bsdf {got}");
            assert!(scene.shape_light[hit.shape as usize].is_none());
            // shadow rays: blocked up to the hit, free before it
            assert!(scene.occluded(&ray));
            assert!(!scene.occluded(&Ray {
                t_max: hit.t * 0.999,
                ..ray
            }));
        }
        // a ray between the instances hits nothing
        assert!(scene
            .intersect(&Ray::new(Vec3::new(-2.0, 0.0, 10.0), -Vec3::Z))
            .is_none());
    }

    /// 10⁴ instances of a 10⁴-triangle mesh: one group, shared. The scene BVH holds one
    /// primitive per instance and no triangle; every slot shares the group's mesh and BVH.
    /// (Memory, measured with `scripts/gen_instances_scene.py` and `/usr/bin/time -v`: see the
    /// README.)
    #[test]
    fn ten_thousand_instances_share_one_group() {
        // a 100 × 50 height field: 10⁴ triangles
        let (nx, ny) = (101u32, 51u32);
        let positions = (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (i, j)))
            .map(|(i, j)| {
                let (x, y) = (i as f32 / 100.0, j as f32 / 50.0);
                Vec3::new(x, y, 0.05 * (9.0 * x).sin() * (7.0 * y).cos())
            })
            .collect();
        let indices = (0..ny - 1)
            .flat_map(|j| (0..nx - 1).map(move |i| (i, j)))
            .flat_map(|(i, j)| {
                let a = j * nx + i;
                [[a, a + 1, a + nx], [a + 1, a + nx + 1, a + nx]]
            })
            .collect::<Vec<_>>();
        assert_eq!(indices.len(), 10_000);
        let data = MeshData {
            positions,
            normals: None,
            uvs: None,
            indices,
            attributes: vec![],
        };
        let mesh = Geometry::mesh(data, Mat4::IDENTITY, false, false).unwrap();
        let group = Arc::new(ShapeGroup::new(vec![mesh], vec![0]));
        let mut shapes = Vec::new();
        for k in 0..10_000 {
            let (i, j) = ((k % 100) as f32, (k / 100) as f32);
            let m = tr([2.0 * i, 2.0 * j, 0.0]) * rot([0.0, 0.0, 1.0], k as f32);
            shapes.extend(Geometry::instance(&group, m).unwrap());
        }
        let bvh = Bvh::build(&shapes);
        assert_eq!(shapes.len(), 10_000);
        assert_eq!(bvh.primitive_count(), 10_000);
        // the slots and the scene BVH hold the only other references to the group
        assert_eq!(Arc::strong_count(&group), 1 + 10_000 + 1);
        // rays straight down onto every 97th instance hit it, at its own slot
        for k in (0..10_000).step_by(97) {
            let (i, j) = ((k % 100) as f32, (k / 100) as f32);
            let m = tr([2.0 * i, 2.0 * j, 0.0]) * rot([0.0, 0.0, 1.0], k as f32);
            let c = m.transform_point3(Vec3::new(0.5, 0.5, 0.0));
            let ray = Ray::new(c + Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
            let hit = bvh.intersect(&ray).expect("instance hit");
            assert_eq!(hit.shape, k);
            let sg = shapes[k as usize].surface(&ray, &hit);
            assert!((sg.p - c).truncate().length() < 1e-3 && sg.n_geo.z > 0.9);
            assert!(bvh.occluded(&ray));
        }
    }

    /// Mitsuba 3.9 merges the three diffuse meshes (two cubes and the rectangle: 26
    /// triangles) and keeps the conductor cube, the emitting cube and the sphere apart: 4
    /// shapes (checked with `mi.load_string` of the same shapes). The
    /// image is that of the unmerged scene: every ray hits the same point with the same
    /// normals and BSDF.
    #[test]
    fn merge_like_mitsuba() {
        use crate::scene::{Light, Scene};
        let shapes = r#"
 <shape type="cube"><transform name="to_world"><translate x="3"/></transform><ref id="b"/></shape>
 <shape type="cube"><transform name="to_world"><translate x="-3"/></transform><ref id="b"/></shape>
 <shape type="cube"><transform name="to_world"><translate y="3"/></transform><bsdf type="conductor"/></shape>
 <shape type="sphere"><ref id="b"/></shape>
 <shape type="rectangle"><transform name="to_world"><translate z="5"/></transform><ref id="b"/></shape>
 <shape type="cube"><transform name="to_world"><translate z="-3"/></transform><emitter type="area"/></shape>"#;
        let scene = |body: &str| {
            let text = format!(
                r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/></sensor>
<bsdf type="diffuse" id="b"/>{body}</scene>"#
            );
            Scene::from_xml_str(&text, "<t>", std::path::Path::new("."), &[]).unwrap()
        };
        let merged = scene(&format!(r#"<shape type="merge">{shapes}</shape>"#));
        let plain = scene(shapes);
        let counts: Vec<usize> = merged
            .geometry
            .iter()
            .map(Geometry::primitive_count)
            .collect();
        assert_eq!(counts, [1, 12, 26, 12]);
        assert_eq!(merged.lights.len(), 1);
        let Light::Area { shape, .. } = &merged.lights[0] else {
            panic!()
        };
        assert_eq!(merged.shape_light[*shape as usize], Some(0));
        assert_eq!(merged.geometry[*shape as usize].area(), 24.0);
        let mut rng = 1u64;
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3::new(lcg(&mut rng), lcg(&mut rng), lcg(&mut rng)) * 16.0 - 8.0;
            let d = Vec3::new(lcg(&mut rng), lcg(&mut rng), lcg(&mut rng)) * 8.0 - 4.0 - o;
            let ray = Ray::new(o, d);
            let (a, b) = (merged.intersect(&ray), plain.intersect(&ray));
            assert_eq!(a.is_some(), b.is_some());
            let (Some(a), Some(b)) = (a, b) else { continue };
            hits += 1;
            assert_eq!(a.t, b.t);
            let sa = merged.geometry[a.shape as usize].surface(&ray, &a);
            let sb = plain.geometry[b.shape as usize].surface(&ray, &b);
            assert_eq!(
                (sa.p, sa.n_geo, sa.sh_frame.n, sa.uv),
                (sb.p, sb.n_geo, sb.sh_frame.n, sb.uv)
            );
            let name = |s: &Scene, h: &Hit| {
                format!("{:?}", s.bsdfs[s.shape_bsdf[h.shape as usize] as usize])
            };
            assert_eq!(name(&merged, &a), name(&plain, &b));
            assert_eq!(
                merged.shape_light[a.shape as usize].is_some(),
                plain.shape_light[b.shape as usize].is_some()
            );
        }
        assert!(hits > 500, "{hits}");
    }

    #[test]
    fn shapegroup_errors_are_mitsubas() {
        use crate::scene::Scene;
        let load = |body: &str| {
            let text = format!(
                "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/></sensor>\n<shape type=\"sphere\"/>\n{body}</scene>"
            );
            Scene::from_xml_str(&text, "<t>", std::path::Path::new("."), &[])
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        let g = r#"<shape type="shapegroup" id="g"><shape type="sphere"/></shape>"#;
        for (body, want) in [
            (
                r#"<shape type="shapegroup" id="g"><shape type="sphere"><emitter type="area"/></shape></shape>"#.to_string(),
                "<t>:4:",
            ),
            (r#"<shape type="shapegroup" id="g"><shape type="sphere"><emitter type="area"/></shape></shape>"#.into(), "Instancing of emitters is not supported"),
            (r#"<shape type="shapegroup" id="g"><shape type="shapegroup" id="h"/></shape>"#.into(), "Nested ShapeGroup is not permitted"),
            (format!(r#"{g}<shape type="shapegroup" id="h"><shape type="instance"><ref id="g"/></shape></shape>"#), "Nested instancing is not permitted"),
            (r#"<shape type="shapegroup" id="g"><bsdf type="diffuse"/></shape>"#.into(), "cannot be nested in a shapegroup"),
            (r#"<shape type="instance"/>"#.into(), "A reference to a 'shapegroup' must be specified"),
            (r#"<bsdf type="diffuse" id="b"/><shape type="instance"><ref id="b"/></shape>"#.into(), "is a bsdf, not a shapegroup"),
            (r#"<shape type="instance"><ref id="nope"/></shape>"#.into(), "undefined id 'nope'"),
            (format!(r#"{g}<shape type="instance"><ref id="g"/><bsdf type="diffuse"/></shape>"#), "Only a shapegroup can be specified"),
            (format!(r#"{g}<shape type="instance"><ref id="g"/><boolean name="flip_normals" value="true"/></shape>"#), "unknown parameter 'flip_normals'"),
            (r#"<shape type="shapegroup" id="g"><shape type="sphere"/><transform name="to_world"/></shape>"#.into(), "unknown parameter 'to_world'"),
            (format!(r#"{g}<shape type="instance"><ref id="g"/><transform name="to_world"><scale x="0"/></transform></shape>"#), "not invertible"),
            (r#"<shape type="cylinder"><point name="p1" x="0" y="0" z="0"/></shape>"#.into(), "must be distinct"),
            (r#"<shape type="cylinder"><float name="height" value="2"/></shape>"#.into(), "unknown parameter 'height'"),
        ] {
            let e = load(&body);
            assert!(e.contains(want), "{body}: {e:?} lacks {want:?}");
        }
        // an empty group and an unused group are fine (as in Mitsuba)
        assert_eq!(
            load(
                r#"<shape type="shapegroup" id="g"/><shape type="instance"><ref id="g"/></shape>"#
            ),
            ""
        );
        assert_eq!(load(g), "");
    }

    #[test]
    fn mitsuba_cube() {
        check("cube", Geometry::cube(Mat4::IDENTITY, false), CUBE);
        let xf = tr([0.1, 0.2, 0.3]) * rot([0.0, 1.0, 1.0], 30.0) * sc([1.5, 1.0, 0.7]);
        check("cube xf flip", Geometry::cube(xf, true), CUBE_XF);
        check_samples("cube", &Geometry::cube(Mat4::IDENTITY, false), S_CUBE);
    }

    #[test]
    fn mitsuba_obj_and_ply() {
        let quad = obj(QUAD_OBJ, "quad.obj");
        let m = |d: &MeshData, xf: Mat4, face: bool, flip: bool| {
            Geometry::mesh(d.clone(), xf, face, flip).unwrap()
        };
        check("obj quad", m(&quad, Mat4::IDENTITY, false, false), OBJ_QUAD);
        check(
            "obj quad face_normals",
            m(&quad, Mat4::IDENTITY, true, false),
            OBJ_QUAD_FACE,
        );
        check(
            "obj quad flip",
            m(&quad, Mat4::IDENTITY, false, true),
            OBJ_QUAD_FLIP,
        );
        let xf = sc([2.0, 1.0, 0.5]) * rot([0.0, 0.0, 1.0], 30.0);
        check("obj quad xf", m(&quad, xf, false, false), OBJ_QUAD_XF);
        check(
            "obj quad mirror",
            m(&quad, mirror(), false, false),
            OBJ_QUAD_MIRROR,
        );
        check_samples("obj quad", &m(&quad, Mat4::IDENTITY, false, false), S_QUAD);
        check_samples(
            "obj quad face flip",
            &m(&quad, Mat4::IDENTITY, true, true),
            S_QUAD_FACE_FLIP,
        );
        let nonormal = obj(QUAD_NONORMAL_OBJ, "quad_nonormal.obj");
        check(
            "obj recomputed normals",
            m(&nonormal, Mat4::IDENTITY, false, false),
            OBJ_NONORMAL,
        );
        let tent = obj(TENT_OBJ, "tent.obj");
        check(
            "obj tent (uv seam)",
            m(&tent, Mat4::IDENTITY, false, false),
            OBJ_TENT,
        );
        let tent_shared = obj(TENT_SHARED_OBJ, "tent_shared.obj");
        check(
            "obj tent (no uv)",
            m(&tent_shared, Mat4::IDENTITY, false, false),
            OBJ_TENT_SHARED,
        );
        let degen = obj(DEGEN_OBJ, "degen.obj");
        check(
            "obj degenerate uv",
            m(&degen, Mat4::IDENTITY, false, false),
            OBJ_DEGEN_UV,
        );
        let ply = load_ply(&tmp_file("quad.ply", QUAD_PLY)).unwrap();
        check("ply quad", m(&ply, Mat4::IDENTITY, false, false), PLY_QUAD);
        check("ply quad xf", m(&ply, xf, false, false), PLY_QUAD_XF);
    }

    #[test]
    fn mitsuba_shared_assets() {
        let knot = load_obj(&asset("torusknot.obj")).unwrap();
        let xf = tr([-1.2, 1.1, 0.0]) * sc([0.9; 3]);
        check(
            "torusknot",
            Geometry::mesh(knot, xf, false, false).unwrap(),
            KNOT,
        );
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let xf = tr([1.4, 0.9, 0.2]) * sc([0.7; 3]);
        check(
            "icosphere",
            Geometry::mesh(ico, xf, false, false).unwrap(),
            ICO,
        );
        let bumpy = load_obj(&asset("bumpy.obj")).unwrap();
        check(
            "bumpy",
            Geometry::mesh(bumpy, sc([5.0; 3]), true, false).unwrap(),
            BUMPY,
        );
    }

    #[test]
    fn areas() {
        let close = |a: f32, b: f32| (a - b).abs() <= 1e-5 * b.abs().max(1.0);
        assert!(close(
            Geometry::rectangle(Mat4::IDENTITY, false).area(),
            4.0
        ));
        assert!(close(Geometry::rectangle(nonuni(), false).area(), 8.0));
        assert!(close(Geometry::cube(Mat4::IDENTITY, false).area(), 24.0));
        assert!(close(
            Geometry::cube(sc([2.0, 1.0, 1.0]), false).area(),
            2.0 * (8.0 + 8.0 + 4.0)
        ));
        assert!(close(Geometry::disk(Mat4::IDENTITY, false).area(), PI));
        assert!(close(Geometry::disk(nonuni(), false).area(), PI * 2.0));
        let s = Geometry::sphere(Vec3::ONE, 0.5, sc([3.0; 3]), false);
        assert!(close(s.area(), 4.0 * PI * 1.5 * 1.5));
        assert!(close(s.pdf_position(), 1.0 / (9.0 * PI)));
        // Unit icosphere (radius 1): area close to, and below, 4π.
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let g = Geometry::mesh(ico, sc([2.0; 3]), false, false).unwrap();
        let a = g.area();
        assert!(a < 16.0 * PI && a > 16.0 * PI * 0.995, "icosphere area {a}");
    }

    /// A small deterministic generator for tests.
    fn lcg(state: &mut u64) -> f32 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 40) as f32) / (1u64 << 24) as f32
    }

    #[test]
    fn sample_position_distribution() {
        let mut rng = 12345u64;
        let n = 200_000;
        // Sphere: mean position ≈ centre, all points on the surface, normals outward.
        let c = Vec3::new(0.3, -1.0, 2.0);
        let s = Geometry::sphere(c, 0.7, rot([0.0, 1.0, 0.0], 30.0), false);
        let cw = rot([0.0, 1.0, 0.0], 30.0).transform_point3(c);
        let mut mean = Vec3::ZERO;
        for _ in 0..n {
            let ps = s.sample_position(Vec2::new(lcg(&mut rng), lcg(&mut rng)));
            assert!(((ps.p - cw).length() - 0.7).abs() < 1e-5);
            assert!((ps.n - (ps.p - cw) / 0.7).length() < 1e-4);
            mean += ps.p;
        }
        mean /= n as f32;
        assert!(
            (mean - cw).length() < 0.01,
            "sphere sample mean {mean} vs centre {cw}"
        );
        // Cube: each face gets 1/6 of the samples; the mean is the centre.
        let cube = Geometry::cube(tr([1.0, 2.0, 3.0]), false);
        let mut counts = [0usize; 6];
        let mut mean = Vec3::ZERO;
        for _ in 0..n {
            let ps = cube.sample_position(Vec2::new(lcg(&mut rng), lcg(&mut rng)));
            let k = (0..3).find(|&k| ps.n[k].abs() > 0.5).unwrap();
            counts[2 * k + (ps.n[k] > 0.0) as usize] += 1;
            mean += ps.p;
        }
        mean /= n as f32;
        assert!(
            (mean - Vec3::new(1.0, 2.0, 3.0)).length() < 0.01,
            "cube mean {mean}"
        );
        for c in counts {
            let f = c as f32 / n as f32;
            assert!(
                (f - 1.0 / 6.0).abs() < 0.005,
                "cube face fractions {counts:?}"
            );
        }
        // A mesh with triangles of very different areas: samples fall on triangles in
        // proportion to their area (two triangles of area 1 and 3).
        let data = MeshData {
            positions: vec![
                Vec3::ZERO,
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(6.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
            ],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2], [3, 4, 5]],
            attributes: Vec::new(),
        };
        let g = Geometry::mesh(data, Mat4::IDENTITY, false, false).unwrap();
        assert!((g.area() - 4.0).abs() < 1e-6);
        let mut top = 0;
        for _ in 0..n {
            let ps = g.sample_position(Vec2::new(lcg(&mut rng), lcg(&mut rng)));
            top += (ps.p.z > 0.5) as usize;
        }
        let f = top as f32 / n as f32;
        assert!((f - 0.75).abs() < 0.005, "fraction on the big triangle {f}");
        // Disk: uniform in area (mean radius² = 1/2).
        let d = Geometry::disk(Mat4::IDENTITY, false);
        let mut r2 = 0.0;
        for _ in 0..n {
            let ps = d.sample_position(Vec2::new(lcg(&mut rng), lcg(&mut rng)));
            r2 += ps.p.length_squared();
        }
        assert!((r2 / n as f32 - 0.5).abs() < 0.005);
    }

    #[test]
    fn mesh_errors() {
        let mut data = MeshData {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 3]],
            attributes: Vec::new(),
        };
        let e = Geometry::mesh(data.clone(), Mat4::IDENTITY, false, false).unwrap_err();
        assert!(e.to_string().contains("vertex 3"), "{e}");
        data.indices.clear();
        assert!(Geometry::mesh(data.clone(), Mat4::IDENTITY, false, false).is_err());
        data.indices.push([0, 1, 2]);
        data.normals = Some(vec![Vec3::Z]);
        assert!(Geometry::mesh(data, Mat4::IDENTITY, false, false).is_err());
    }
}
