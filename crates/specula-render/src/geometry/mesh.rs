//! Triangle meshes: OBJ, PLY and `serialized` files, and the built-in `rectangle` and `cube`.
//!
//! **Meshes.** The geometric normal is `normalize((p1 - p0) × (p2 - p0))` of the world-space
//! vertices (so a mirroring `to_world` flips it, as in Mitsuba). Vertex normals are
//! transformed by the inverse transpose of `to_world`, normalised, interpolated with the
//! barycentrics and normalised again. Without normals in the file (and without
//! `face_normals`) vertex normals are recomputed in world space, weighting each face normal
//! by the angle of the face at the vertex (Mitsuba's `recompute_vertex_normals`); vertices
//! are not merged by position. `face_normals` uses the geometric normal for shading even if
//! the file has normals. Without texture coordinates `uv = (b1, b2)` (the barycentrics) and
//! `∂p/∂u = p1 - p0`; with them `∂p/∂u` comes from the uv parameterisation, or from
//! `coordinate_system(n)` when the uv triangle is degenerate.
//!
//! **Rectangle**: the square `[-1, 1]²` at z = 0, two triangles with vertex normals +z and
//! `uv = ((x + 1) / 2, (y + 1) / 2)`; sampled analytically like Mitsuba.
//!
//! **Cube**: `[-1, 1]³`, Mitsuba's 24-vertex / 12-triangle layout, per-face uv (e.g. the +z
//! face has `u = (y + 1) / 2, v = (x + 1) / 2`).

use super::*;

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
    pub(super) cdf: Vec<f64>,
    /// First and last triangle with a non-zero area.
    pub(super) valid: (usize, usize),
    pub(super) area: f32,
    /// Set for rectangles, which are sampled analytically like Mitsuba's.
    pub(super) rect: Option<RectSampling>,
    /// Per-triangle constant surface data of the built-in flat-faced meshes (rectangle,
    /// cube), whose vertex normals equal the face normal and whose uvs are affine on each
    /// face: the hit then only interpolates p and uv (see [`TriMesh::precompute_flat`]).
    pub(super) flat: Option<Box<[FlatFace]>>,
    /// Whether a hit's uv is read where the scene's analysis decides it (set by the scene,
    /// see `Geometry::surface_uv`): false lets the path loop skip a flat-faced mesh's uv
    /// interpolation (its uv is then zero, and nothing reads it).
    pub uv: bool,
}

/// What [`TriMesh::surface`] computes for one triangle of a flat-faced mesh that does not
/// depend on the point hit.
#[derive(Clone, Copy, Debug)]
pub(super) struct FlatFace {
    pub(super) n_geo: Vec3,
    pub(super) sh_frame: Frame,
    pub(super) dp_du: Vec3,
    pub(super) dp_dv: Vec3,
}

#[derive(Clone, Copy, Debug)]
pub(super) struct RectSampling {
    pub(super) to_world: Mat4,
    /// Normal of sampled points (flip included).
    pub(super) n: Vec3,
}

/// Angle-weighted vertex normals (Mitsuba's `Mesh::recompute_vertex_normals`).
pub(super) fn recompute_vertex_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
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
    pub(super) fn new(
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
            uv: true,
        }
    }

    /// Fills [`TriMesh::flat`] for a mesh whose every face is flat (vertex normals equal to
    /// the face normal, uvs affine over each triangle: `rectangle` and `cube`), evaluating
    /// the general [`TriMesh::surface`] once per triangle at its centroid. The general
    /// path's geometric normal, ∂p/∂u and ∂p/∂v depend on the triangle only, and its
    /// shading normal (the interpolated vertex normals, all equal) differs from the one
    /// stored by rounding only, so hits see the same geometry.
    pub(super) fn precompute_flat(&mut self) {
        self.flat = None;
        let faces = (0..self.indices.len())
            .map(|i| {
                let sg = self.surface(
                    &Hit {
                        t: 0.0,
                        shape: 0,
                        prim: i as u32,
                        u: 1.0 / 3.0,
                        v: 1.0 / 3.0,
                        vertices: None,
                    },
                    true,
                );
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

    #[inline(always)]
    pub(super) fn sample_position(&self, u: Vec2) -> PositionSample {
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

    /// The surface at `hit`; `uv` false skips a flat-faced mesh's uv (left at zero) for a
    /// caller that does not read it.
    #[inline(always)]
    pub(super) fn surface(&self, hit: &Hit, uv: bool) -> SurfaceGeometry {
        let tri = hit.prim as usize;
        let [p0, p1, p2] = hit.vertices.unwrap_or_else(|| self.triangle(tri));
        let (b1, b2) = (hit.u, hit.v);
        let b0 = 1.0 - b1 - b2;
        let dp0 = p1 - p0;
        let dp1 = p2 - p0;
        let p = p2 * b2 + (p1 * b1 + p0 * b0);
        if let (Some(flat), Some(uvs)) = (&self.flat, &self.uvs) {
            let f = &flat[tri];
            let uv = if uv {
                let [i0, i1, i2] = self.indices[tri].map(|k| k as usize);
                uvs[i2] * b2 + (uvs[i1] * b1 + uvs[i0] * b0)
            } else {
                Vec2::ZERO
            };
            return SurfaceGeometry {
                p,
                n_geo: f.n_geo,
                sh_frame: f.sh_frame,
                uv,
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
