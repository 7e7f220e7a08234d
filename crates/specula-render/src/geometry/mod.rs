//! Shapes: triangle meshes (OBJ, PLY, `serialized`, rectangle, cube), analytic spheres, disks
//! and cylinders, and instances of shape groups, with Mitsuba 3's conventions for positions,
//! normals, texture coordinates and shading frames.
//!
//! Everything is stored in world space. The conventions below, and those at the top of each
//! shape's file, were checked against Mitsuba 3.9.1 (`scalar_rgb`) by shooting rays at small
//! scenes (see the tests):
//!
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
//!
//! **Files**, one shape each, its conventions at its top: `mesh.rs` (triangle meshes: OBJ, PLY,
//! `serialized`, `rectangle`, `cube`), `sphere.rs`, `disk.rs`, `cylinder.rs`, `instance.rs`
//! (`shapegroup` and `instance`); this file holds [`Geometry`], the constructors and the
//! interface the renderer calls; `tests.rs` the tests.

use crate::core::{Hit, PositionSample, Ray, Result, SceneError, SurfaceGeometry};
use crate::mesh_io::{MeshAttribute, MeshData};
use glam::{Mat3, Mat4, Vec2, Vec3};
use specula_bsdf::frame::Frame;
use specula_bsdf::{Rgb, SurfaceData};
use std::f32::consts::PI;
use std::sync::Arc;

const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
const INV_TWO_PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;

mod cylinder;
mod disk;
mod instance;
mod mesh;
mod sphere;
#[cfg(test)]
mod tests;

pub use cylinder::Cylinder;
pub use disk::Disk;
pub use instance::{Instance, ShapeGroup};
pub use mesh::TriMesh;
use mesh::{recompute_vertex_normals, RectSampling};
pub use sphere::Sphere;

/// A shape of the scene, in world space.
#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriMesh),
    Sphere(Sphere),
    Disk(Disk),
    Cylinder(Cylinder),
    Instance(Instance),
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
            uv: true,
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
    ///
    /// Inlined where it is called (light sampling, once a bounce) for the shapes that usually
    /// emit, so that the sample stays in registers: returned through memory, it was read back
    /// before the callee's stores could be forwarded (a stall of about a dozen cycles).
    /// (Cylinders and instances rarely emit: their methods stay out of line.)
    #[inline(always)]
    pub fn sample_position(&self, u: Vec2) -> PositionSample {
        match self {
            Geometry::Mesh(m) => m.sample_position(u),
            Geometry::Sphere(s) => s.sample_position(u),
            Geometry::Disk(d) => d.sample_position(u),
            Geometry::Cylinder(c) => c.sample_position(u),
            Geometry::Instance(i) => i.sample_position(u),
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
    ///
    /// Inlined into the path loops for meshes, spheres and disks, so that the result stays in
    /// registers (see [`Geometry::sample_position`]).
    /// (Cylinders' and instances' methods stay out of line.)
    #[inline(always)]
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceGeometry {
        self.surface_uv(ray, hit, true)
    }

    /// The flag of a sphere or mesh that says whether its hits' uv is computed for the path
    /// loop (`Sphere::uv`, `TriMesh::uv`; None for the other shapes, which always compute
    /// it): what the scene's analysis sets ([`crate::scene`]'s `skip_unread_uv`, and
    /// `Scene::set_bsdf`).
    pub(crate) fn uv_flag_mut(&mut self) -> Option<&mut bool> {
        match self {
            Geometry::Sphere(s) => Some(&mut s.uv),
            Geometry::Mesh(m) => Some(&mut m.uv),
            _ => None,
        }
    }

    /// [`Geometry::surface`], where `all_uv` false leaves the uv of a sphere or flat-faced
    /// mesh that the scene marked unread (`Sphere::uv`, `TriMesh::uv`, see [`crate::scene`])
    /// at zero: for a caller that reads uv only as the scene's analysis assumes (BSDF
    /// textures, emission; the path loop).
    #[inline(always)]
    pub fn surface_uv(&self, ray: &Ray, hit: &Hit, all_uv: bool) -> SurfaceGeometry {
        match self {
            Geometry::Mesh(m) => m.surface(hit, all_uv || m.uv),
            Geometry::Sphere(s) => s.surface(ray, hit, all_uv || s.uv),
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
