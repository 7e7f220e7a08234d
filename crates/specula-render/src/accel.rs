//! Ray intersection: one compressed wide BVH (obvhs' CWBVH, built with PLOC + reinsertion)
//! over every triangle, sphere and disk of the scene.
//!
//! **Ownership.** [`Bvh::build`] copies what intersection needs (triangle vertices, sphere
//! centres and radii, disk transforms) into its own primitive array, laid out in BVH leaf
//! order; the `Geometry` slice may be dropped or moved afterwards. A [`Hit`] names the shape by
//! its index in that slice (`shape`) and the primitive within it (`prim`), so the caller keeps
//! the shapes to compute [`crate::geometry::Geometry::surface`].
//!
//! **Epsilons.** Intersections are reported for t in the open interval (0, `t_max`), with no
//! epsilon: the caller must move ray origins off the surface they leave. Use
//! [`offset_ray_origin`] / [`spawn_ray`] / [`spawn_ray_to`], which reproduce Mitsuba 3's
//! `Interaction::spawn_ray(_to)`: the origin moves along the geometric normal, towards the
//! side of the new direction, by `(1 + max|p|) · RAY_EPSILON`, and shadow rays stop
//! `SHADOW_EPSILON` (relative) short of their target.
//!
//! **Robustness.** Triangles use the watertight test of Woop, Benthin and Wald (JCGT 2013):
//! rays through an edge or vertex shared by several triangles hit one of them. Primitive
//! boxes are padded slightly before the build, and the traversal works around obvhs' node test
//! ignoring boxes closer than t = 1e-4 (it traverses from an origin moved back along the ray),
//! so nothing near the origin is culled. Traversal uses a fixed 32-entry stack (no heap
//! allocation per ray).

use crate::core::{Hit, Ray};
use crate::geometry::Geometry;
use glam::{DVec3, Mat3, UVec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::cwbvh::{firstbithigh, CwBvh};
use obvhs::BvhBuildParams;

/// Mitsuba's `math::RayEpsilon<float>`: 1500 · 2⁻²⁴ ≈ 8.94e-5.
pub const RAY_EPSILON: f32 = 1500.0 / 16_777_216.0;
/// Mitsuba's `math::ShadowEpsilon<float>`: 10 · `RAY_EPSILON`.
pub const SHADOW_EPSILON: f32 = RAY_EPSILON * 10.0;

/// Closest-hit and any-hit queries.
pub trait Intersector: Send + Sync {
    /// The closest intersection with t in (0, `ray.t_max`), if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Whether anything intersects the ray with t in (0, `ray.t_max`).
    fn occluded(&self, ray: &Ray) -> bool;
}

/// Mitsuba's `Interaction::offset_p`: `p` moved along the geometric normal `n`, to the side
/// of `d`, by `(1 + max(|p.x|, |p.y|, |p.z|)) · RAY_EPSILON`.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    let mag = (1.0 + p.abs().max_element()) * RAY_EPSILON;
    let mag = mag.copysign(n.dot(d));
    n * mag + p
}

/// Mitsuba's `Interaction::spawn_ray`: a ray leaving the surface point `p` (geometric normal
/// `n`) in direction `d`, with an unbounded `t_max`.
#[inline]
pub fn spawn_ray(p: Vec3, n: Vec3, d: Vec3) -> Ray {
    Ray {
        o: offset_ray_origin(p, n, d),
        d,
        t_max: f32::INFINITY,
    }
}

/// Mitsuba's `Interaction::spawn_ray_to`: a unit-direction ray from the surface point `p`
/// (geometric normal `n`) to `target`, stopping `SHADOW_EPSILON` (relative) before it.
#[inline]
pub fn spawn_ray_to(p: Vec3, n: Vec3, target: Vec3) -> Ray {
    let o = offset_ray_origin(p, n, target - p);
    let d = target - o;
    let dist = d.length();
    Ray {
        o,
        d: d / dist,
        t_max: dist * (1.0 - SHADOW_EPSILON),
    }
}

#[derive(Clone, Copy, Debug)]
enum PrimShape {
    Triangle([Vec3; 3]),
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// World to object: `local = m · p + t`; the disk is x² + y² ≤ 1 at z = 0.
    Disk {
        m: Mat3,
        t: Vec3,
    },
}

#[derive(Clone, Copy, Debug)]
struct Prim {
    shape: PrimShape,
    geom: u32,
    index: u32,
}

/// A CWBVH over all primitives of a list of shapes. See the module docs for ownership and
/// epsilon conventions.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    bvh: CwBvh,
    /// Triangle vertices per leaf slot (slot k of the CWBVH), zero for analytic slots: the
    /// only primitive data traversal touches for meshes, kept compact for the cache.
    tris: Vec<[Vec3; 3]>,
    /// Per slot: `TRIANGLE`, or the index of the analytic shape in `analytic`.
    kind: Vec<u32>,
    /// Per slot: (shape, primitive index), read only for the closest hit.
    ids: Vec<(u32, u32)>,
    analytic: Vec<PrimShape>,
}

const TRIANGLE: u32 = u32::MAX;

/// How far (in units of t) the traversal origin is moved back along the ray, so that obvhs'
/// node test, which ignores boxes with exit distance below 1e-4, never culls a box that holds
/// a hit at t > 0.
const TRAVERSAL_SHIFT: f32 = 2e-4;
/// Bound on |1/d| in box tests (instead of obvhs' 1/f32::EPSILON for tiny components).
const MAX_INV_DIR: f32 = 1e18;

impl Bvh {
    /// Builds the BVH over every primitive of `geoms` (copying their data).
    pub fn build(geoms: &[Geometry]) -> Bvh {
        let mut prims = Vec::new();
        for (g, geom) in geoms.iter().enumerate() {
            let g = g as u32;
            match geom {
                Geometry::Mesh(m) => {
                    prims.reserve(m.indices.len());
                    for i in 0..m.indices.len() {
                        prims.push(Prim {
                            shape: PrimShape::Triangle(m.triangle(i)),
                            geom: g,
                            index: i as u32,
                        });
                    }
                }
                Geometry::Sphere(s) => prims.push(Prim {
                    shape: PrimShape::Sphere {
                        center: s.center,
                        radius: s.radius.abs(),
                    },
                    geom: g,
                    index: 0,
                }),
                Geometry::Disk(d) => {
                    let m = Mat3::from_mat4(d.to_object);
                    let t = d.to_object.w_axis.truncate();
                    prims.push(Prim {
                        shape: PrimShape::Disk { m, t },
                        geom: g,
                        index: 0,
                    })
                }
            }
        }
        // Drop primitives that can never be hit or would poison the build.
        let mut aabbs = Vec::with_capacity(prims.len());
        let mut kept = Vec::with_capacity(prims.len());
        for p in prims {
            let (lo, hi) = match p.shape {
                PrimShape::Triangle(v) => (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2])),
                PrimShape::Sphere { center, radius } => {
                    (center - Vec3::splat(radius), center + Vec3::splat(radius))
                }
                PrimShape::Disk { .. } => geoms[p.geom as usize].bounds(),
            };
            if !(lo.is_finite() && hi.is_finite()) {
                continue;
            }
            // Pad by a few ulps of the coordinates (and of the extent) so that rounding in the
            // quantised box tests never rejects a ray that hits the primitive.
            let scale = lo.abs().max(hi.abs()).max_element();
            let pad = Vec3::splat(scale * 4e-7 + (hi - lo).max_element() * 1e-6 + 1e-30);
            aabbs.push(Aabb::new(Vec3A::from(lo - pad), Vec3A::from(hi + pad)));
            kept.push(p);
        }
        if kept.is_empty() {
            return Bvh::default();
        }
        let config = BvhBuildParams::slow_build();
        let indices = (0..kept.len() as u32).collect();
        let mut bvh2 = config.ploc_search_distance.build(
            &aabbs,
            indices,
            config.sort_precision,
            config.search_depth_threshold,
        );
        // a thorough reinsertion pass: ~8 % faster traversal on meshes.xml than the medium preset
        ReinsertionOptimizer::run(&mut bvh2, config.reinsertion_batch_ratio, None);
        let bvh = bvh2_to_cwbvh(&bvh2, 3, true, false);
        let n = bvh.primitive_indices.len();
        let mut out = Bvh {
            tris: Vec::with_capacity(n),
            kind: Vec::with_capacity(n),
            ids: Vec::with_capacity(n),
            analytic: Vec::new(),
            bvh: CwBvh::default(),
        };
        for &i in &bvh.primitive_indices {
            let p = kept[i as usize];
            out.ids.push((p.geom, p.index));
            match p.shape {
                PrimShape::Triangle(v) => {
                    out.tris.push(v);
                    out.kind.push(TRIANGLE);
                }
                other => {
                    out.tris.push([Vec3::ZERO; 3]);
                    out.kind.push(out.analytic.len() as u32);
                    out.analytic.push(other);
                }
            }
        }
        out.bvh = bvh;
        out
    }

    /// Number of primitives (triangles, spheres, disks) in the BVH.
    pub fn primitive_count(&self) -> usize {
        self.kind.len()
    }

    /// Walks the BVH, calling `visit(prim, t_max)` for every primitive whose box the ray
    /// enters before `*t_max`. `visit` may lower `*t_max`; returning `true` stops the walk.
    #[inline(always)]
    fn traverse<F: FnMut(usize, &mut f32) -> bool>(
        &self,
        ray: &Ray,
        t_max: &mut f32,
        mut visit: F,
    ) {
        if self.bvh.nodes.is_empty() {
            return;
        }
        let d = ray.d;
        // +0 for zero components, so the octant (picked by `d < 0`) matches the inverse.
        let dir = Vec3A::new(d.x + 0.0, d.y + 0.0, d.z + 0.0);
        let inv = |c: f32| {
            if c == 0.0 {
                MAX_INV_DIR
            } else if c < 0.0 {
                (1.0 / c).max(-MAX_INV_DIR)
            } else {
                (1.0 / c).min(MAX_INV_DIR)
            }
        };
        let shifted_tmax = |t: f32| t * (1.0 + 4.0 * f32::EPSILON) + TRAVERSAL_SHIFT;
        let mut tray = obvhs::ray::Ray {
            origin: Vec3A::from(ray.o) - dir * TRAVERSAL_SHIFT,
            direction: dir,
            inv_direction: Vec3A::new(inv(dir.x), inv(dir.y), inv(dir.z)),
            tmin: 0.0,
            tmax: shifted_tmax(*t_max),
        };
        let mut state = self.bvh.new_traversal(dir);
        loop {
            while state.primitive_group.y != 0 {
                let local = firstbithigh(state.primitive_group.y);
                state.primitive_group.y &= !(1u32 << local);
                let slot = (state.primitive_group.x + local) as usize;
                if visit(slot, t_max) {
                    return;
                }
                tray.tmax = shifted_tmax(*t_max);
            }
            state.primitive_group = UVec2::ZERO;

            if state.current_group.y & 0xff00_0000 != 0 {
                let hits_imask = state.current_group.y;
                let child_index_offset = firstbithigh(hits_imask);
                let child_index_base = state.current_group.x;
                state.current_group.y &= !(1u32 << child_index_offset);
                if state.current_group.y & 0xff00_0000 != 0 {
                    state.stack.push(state.current_group);
                }
                let slot_index = (child_index_offset - 24) ^ (state.oct_inv4 & 0xff);
                let relative_index = (hits_imask & !(0xffff_ffffu32 << slot_index)).count_ones();
                let child_node_index = child_index_base + relative_index;
                let node = &self.bvh.nodes[child_node_index as usize];
                let hitmask = node.intersect_ray(&tray, state.oct_inv4);
                state.current_group.x = node.child_base_idx;
                state.primitive_group.x = node.primitive_base_idx;
                state.current_group.y = (hitmask & 0xff00_0000) | (node.imask as u32);
                state.primitive_group.y = hitmask & 0x00ff_ffff;
            } else {
                state.current_group = UVec2::ZERO;
            }

            if state.primitive_group.y == 0 && (state.current_group.y & 0xff00_0000) == 0 {
                if state.stack.is_empty() {
                    return;
                }
                state.current_group = state.stack.pop_fast();
            }
        }
    }
}

/// Per-ray constants of the watertight ray/triangle test.
struct TriRay {
    o: Vec3,
    /// Axis permutation (kx, ky, kz), each < 3.
    k: [usize; 3],
    s: Vec3,
}

impl TriRay {
    #[inline]
    fn new(ray: &Ray) -> TriRay {
        let a = ray.d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if ray.d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = ray.d[kz];
        TriRay {
            o: ray.o,
            k: [kx, ky, kz],
            s: Vec3::new(ray.d[kx] / dz, ray.d[ky] / dz, 1.0 / dz),
        }
    }

    /// Watertight intersection (Woop, Benthin, Wald 2013): (t, b1, b2) for t in (0, t_max),
    /// b1 and b2 the barycentric weights of the second and third vertices.
    #[inline(always)]
    fn intersect(&self, v: &[Vec3; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = self.k;
        let a = (v[0] - self.o).to_array();
        let b = (v[1] - self.o).to_array();
        let c = (v[2] - self.o).to_array();
        let (a, b, c) = (
            Vec3::new(a[kx], a[ky], a[kz]),
            Vec3::new(b[kx], b[ky], b[kz]),
            Vec3::new(c[kx], c[ky], c[kz]),
        );
        let ax = a.x - self.s.x * a.z;
        let ay = a.y - self.s.y * a.z;
        let bx = b.x - self.s.x * b.z;
        let by = b.y - self.s.y * b.z;
        let cx = c.x - self.s.x * c.z;
        let cy = c.y - self.s.y * c.z;
        let mut u = cx * by - cy * bx;
        let mut v_ = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v_ == 0.0 || w == 0.0 {
            let (ax, ay, bx, by, cx, cy) = (
                ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
            );
            u = (cx * by - cy * bx) as f32;
            v_ = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v_ < 0.0 || w < 0.0) && (u > 0.0 || v_ > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v_ + w;
        if det == 0.0 {
            return None;
        }
        let az = self.s.z * a.z;
        let bz = self.s.z * b.z;
        let cz = self.s.z * c.z;
        let t_scaled = u * az + v_ * bz + w * cz;
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        Some((t, v_ * inv_det, w * inv_det))
    }
}

/// Ray/sphere in double precision (as Mitsuba does on the CPU): the nearest root in
/// (0, t_max).
#[inline]
fn intersect_sphere(ray: &Ray, center: Vec3, radius: f32, t_max: f32) -> Option<f32> {
    let o = (ray.o - center).as_dvec3();
    let d: DVec3 = ray.d.as_dvec3();
    let r = radius as f64;
    let a = d.length_squared();
    let b = 2.0 * o.dot(d);
    let c = o.length_squared() - r * r;
    let disc = b * b - 4.0 * a * c;
    if a == 0.0 || disc < 0.0 {
        return None;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (r0, r1) = (q / a, c / q);
    let (x0, x1) = if r0 <= r1 { (r0, r1) } else { (r1, r0) };
    let tm = t_max as f64;
    for x in [x0, x1] {
        if x > 0.0 && x < tm {
            let t = x as f32;
            if t > 0.0 && t < t_max {
                return Some(t);
            }
        }
    }
    None
}

/// Ray/disk in object space: (t, local x, local y).
#[inline]
fn intersect_disk(ray: &Ray, m: &Mat3, tr: Vec3, t_max: f32) -> Option<(f32, f32, f32)> {
    let lo = *m * ray.o + tr;
    let ld = *m * ray.d;
    if ld.z == 0.0 {
        return None;
    }
    let t = -lo.z / ld.z;
    if !(t > 0.0 && t < t_max) {
        return None;
    }
    let x = lo.x + ld.x * t;
    let y = lo.y + ld.y * t;
    if x * x + y * y <= 1.0 {
        Some((t, x, y))
    } else {
        None
    }
}

#[inline(always)]
fn intersect_shape(
    shape: &PrimShape,
    ray: &Ray,
    tri: &TriRay,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    match shape {
        PrimShape::Triangle(v) => tri.intersect(v, t_max),
        PrimShape::Sphere { center, radius } => {
            Some((intersect_sphere(ray, *center, *radius, t_max)?, 0.0, 0.0))
        }
        PrimShape::Disk { m, t } => intersect_disk(ray, m, *t, t_max),
    }
}

impl Bvh {
    /// Intersect the primitive in leaf slot `slot`: (t, u, v).
    #[inline(always)]
    fn intersect_slot(
        &self,
        slot: usize,
        ray: &Ray,
        tri: &TriRay,
        t_max: f32,
    ) -> Option<(f32, f32, f32)> {
        let k = self.kind[slot];
        if k == TRIANGLE {
            tri.intersect(&self.tris[slot], t_max)
        } else {
            intersect_shape(&self.analytic[k as usize], ray, tri, t_max)
        }
    }
}

fn valid_ray(ray: &Ray) -> bool {
    ray.o.is_finite() && ray.d.is_finite() && ray.d != Vec3::ZERO && ray.t_max > 0.0
}

impl Intersector for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !valid_ray(ray) {
            return None;
        }
        let tri = TriRay::new(ray);
        let mut t_max = ray.t_max;
        // the closest hit so far: (slot, t, u, v); ids are looked up once, at the end
        let mut best: Option<(usize, f32, f32, f32)> = None;
        self.traverse(ray, &mut t_max, |slot, t_max| {
            if let Some((t, u, v)) = self.intersect_slot(slot, ray, &tri, *t_max) {
                *t_max = t;
                best = Some((slot, t, u, v));
            }
            false
        });
        best.map(|(slot, t, u, v)| {
            let (shape, prim) = self.ids[slot];
            Hit {
                t,
                shape,
                prim,
                u,
                v,
            }
        })
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !valid_ray(ray) {
            return false;
        }
        let tri = TriRay::new(ray);
        let mut hit = false;
        let mut t_max = ray.t_max;
        self.traverse(ray, &mut t_max, |slot, t_max| {
            hit = self.intersect_slot(slot, ray, &tri, *t_max).is_some();
            hit
        });
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh_io::{load_obj, load_ply};
    use glam::{Mat4, Vec2};
    use std::path::Path;

    fn asset(name: &str) -> std::path::PathBuf {
        Path::new("/work/shared/scenes/assets").join(name)
    }

    struct Rng(u64);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((self.0 >> 40) as f32) / (1u64 << 24) as f32
        }
        fn dir(&mut self) -> Vec3 {
            let z = 1.0 - 2.0 * self.f();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * self.f();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }
        fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
            lo + (hi - lo) * Vec3::new(self.f(), self.f(), self.f())
        }
    }

    /// The scene of /work/shared/scenes/meshes.xml plus analytic shapes.
    fn scene() -> Vec<Geometry> {
        let knot = load_obj(&asset("torusknot.obj")).unwrap();
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let bumpy = load_obj(&asset("bumpy.obj")).unwrap();
        vec![
            Geometry::mesh(bumpy, Mat4::from_scale(Vec3::splat(5.0)), true, false).unwrap(),
            Geometry::mesh(
                knot,
                Mat4::from_translation(Vec3::new(-1.2, 1.1, 0.0))
                    * Mat4::from_scale(Vec3::splat(0.9)),
                false,
                false,
            )
            .unwrap(),
            Geometry::mesh(
                ico,
                Mat4::from_translation(Vec3::new(1.4, 0.9, 0.2))
                    * Mat4::from_scale(Vec3::splat(0.7)),
                false,
                false,
            )
            .unwrap(),
            Geometry::sphere(Vec3::new(0.2, 1.5, -1.0), 0.4, Mat4::IDENTITY, false),
            Geometry::disk(
                Mat4::from_translation(Vec3::new(0.0, 2.5, 1.0))
                    * Mat4::from_rotation_x(0.3)
                    * Mat4::from_scale(Vec3::new(1.5, 0.7, 1.0)),
                false,
            ),
            Geometry::rectangle(Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0)), false),
            Geometry::cube(
                Mat4::from_translation(Vec3::new(2.5, 0.5, -1.5))
                    * Mat4::from_scale(Vec3::splat(0.3)),
                false,
            ),
        ]
    }

    /// Every primitive of `geoms`, tested one by one with the same primitive routines.
    fn brute_force(geoms: &[Geometry], ray: &Ray) -> Option<Hit> {
        brute_force_bvh(&Bvh::build(geoms), ray)
    }

    /// Every leaf slot of `bvh`, tested one by one (no traversal).
    fn brute_force_bvh(bvh: &Bvh, ray: &Ray) -> Option<Hit> {
        let tri = TriRay::new(ray);
        let mut best: Option<Hit> = None;
        for slot in 0..bvh.primitive_count() {
            let t_max = best.map_or(ray.t_max, |h| h.t);
            if let Some((t, u, v)) = bvh.intersect_slot(slot, ray, &tri, t_max) {
                let (shape, prim) = bvh.ids[slot];
                best = Some(Hit {
                    t,
                    shape,
                    prim,
                    u,
                    v,
                });
            }
        }
        best
    }

    #[test]
    fn bvh_matches_brute_force() {
        let geoms = scene();
        let bvh = Bvh::build(&geoms);
        let total: usize = geoms.iter().map(|g| g.primitive_count()).sum();
        assert_eq!(bvh.primitive_count(), total);
        let mut rng = Rng(7);
        let (lo, hi) = (Vec3::new(-4.0, -1.0, -4.0), Vec3::new(4.0, 4.0, 4.0));
        let mut hits = 0;
        for i in 0..3000 {
            let o = rng.in_box(lo, hi);
            // Half the rays aim at the objects, half go anywhere; some are short.
            let d = if i % 2 == 0 {
                (rng.in_box(Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.5, 2.0, 1.0)) - o).normalize()
            } else {
                rng.dir()
            };
            let t_max = if i % 5 == 0 {
                2.0 * rng.f()
            } else {
                f32::INFINITY
            };
            let ray = Ray { o, d, t_max };
            let want = brute_force_bvh(&bvh, &ray);
            let got = bvh.intersect(&ray);
            match (got, want) {
                (None, None) => {}
                (Some(g), Some(w)) => {
                    hits += 1;
                    assert_eq!(g.t, w.t, "ray {i}: {ray:?}");
                    if (g.shape, g.prim) != (w.shape, w.prim) {
                        // Only a tie (a ray through a shared edge) may differ.
                        assert_eq!(g.t, w.t);
                    }
                }
                _ => panic!("ray {i}: bvh {got:?}, brute force {want:?} ({ray:?})"),
            }
            assert_eq!(bvh.occluded(&ray), want.is_some(), "ray {i}");
        }
        assert!(hits > 1000, "only {hits} hits");
    }

    #[test]
    fn watertight_closed_mesh_and_shared_vertices() {
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let g = Geometry::mesh(ico.clone(), Mat4::IDENTITY, false, false).unwrap();
        let geoms = [g];
        let bvh = Bvh::build(&geoms);
        // From the centre of the closed mesh every ray must hit it.
        let mut rng = Rng(99);
        for _ in 0..20000 {
            let ray = Ray::new(Vec3::new(0.01, -0.02, 0.015), rng.dir());
            assert!(bvh.intersect(&ray).is_some(), "escaped: {ray:?}");
        }
        // Rays from outside through every vertex and every edge midpoint.
        let Geometry::Mesh(m) = &geoms[0] else {
            unreachable!()
        };
        let mut targets: Vec<Vec3> = m.positions.clone();
        for tri in m.indices.iter().take(3000) {
            for k in 0..3 {
                let a = m.positions[tri[k] as usize];
                let b = m.positions[tri[(k + 1) % 3] as usize];
                targets.push((a + b) * 0.5);
            }
        }
        for (i, t) in targets.iter().enumerate() {
            let o = *t * 3.0 + Vec3::new(0.3, 0.7, -0.2) * ((i % 7) as f32 * 0.1);
            let ray = Ray::new(o, (*t - o).normalize());
            let h = bvh
                .intersect(&ray)
                .unwrap_or_else(|| panic!("missed target {i}"));
            assert!(h.t <= (*t - o).length() * (1.0 + 1e-5));
        }
    }

    #[test]
    fn triangle_test_agrees_with_moller_trumbore() {
        let mut rng = Rng(3);
        let mut n = 0;
        for _ in 0..20000 {
            let v = [rng.dir(), rng.dir(), rng.dir()];
            let o = rng.dir() * 3.0;
            let d = (rng.dir() * 0.5 - o).normalize();
            let ray = Ray::new(o, d);
            // f64 Möller–Trumbore.
            let (o64, d64) = (o.as_dvec3(), d.as_dvec3());
            let (p0, p1, p2) = (v[0].as_dvec3(), v[1].as_dvec3(), v[2].as_dvec3());
            let e1 = p1 - p0;
            let e2 = p2 - p0;
            let pv = d64.cross(e2);
            let det = e1.dot(pv);
            let tv = o64 - p0;
            let u = tv.dot(pv) / det;
            let qv = tv.cross(e1);
            let w = d64.dot(qv) / det;
            let t = e2.dot(qv) / det;
            let inside = u >= 0.0 && w >= 0.0 && u + w <= 1.0 && t > 0.0;
            let margin = u.abs().min(w.abs()).min((1.0 - u - w).abs());
            let got = TriRay::new(&ray).intersect(&v, f32::INFINITY);
            if margin < 1e-5 {
                continue;
            }
            match got {
                Some((tt, b1, b2)) => {
                    assert!(inside);
                    assert!((tt as f64 - t).abs() < 1e-5 * t.max(1.0));
                    assert!((b1 as f64 - u).abs() < 1e-5 && (b2 as f64 - w).abs() < 1e-5);
                    n += 1;
                }
                None => assert!(!inside, "missed: {ray:?} {v:?}"),
            }
        }
        assert!(n > 1000);
    }

    #[test]
    fn near_hits_t_max_and_spawned_rays() {
        let geoms = scene();
        let bvh = Bvh::build(&geoms);
        // A hit 5e-5 in front of the origin (below obvhs' node epsilon) is found.
        let ray = Ray::new(Vec3::new(0.2, -0.3, 3.0 + 5e-5), Vec3::new(0.0, 0.0, -1.0));
        let h = bvh.intersect(&ray).unwrap();
        assert_eq!(h.shape, 5);
        assert!((h.t - 5e-5).abs() < 1e-6, "{h:?}");
        // Axis-aligned rays (zero direction components) and non-unit directions.
        let ray = Ray::new(Vec3::new(0.2, -0.3, -10.0), Vec3::new(0.0, 0.0, 2.0));
        let h = bvh.intersect(&ray).unwrap();
        assert_eq!(brute_force(&geoms, &ray).map(|h| h.t), Some(h.t));
        // t_max is exclusive.
        let ray = Ray::new(Vec3::new(0.2, -0.3, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let h = bvh.intersect(&ray).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!(bvh.intersect(&Ray { t_max: h.t, ..ray }).is_none());
        assert!(!bvh.occluded(&Ray { t_max: h.t, ..ray }));
        assert!(bvh.occluded(&Ray {
            t_max: h.t * 1.0001,
            ..ray
        }));
        // Rays spawned from hits never hit the surface they leave at a tiny distance:
        // outwards from the convex icosphere and sphere nothing is hit on the same shape;
        // inwards the far side is hit.
        // (The icosphere and the sphere alone: in the full scene the ground cuts the ball.)
        let geoms = vec![geoms[2].clone(), geoms[3].clone()];
        let bvh = Bvh::build(&geoms);
        let mut rng = Rng(5);
        for shape in [0u32, 1] {
            let c = match &geoms[shape as usize] {
                Geometry::Sphere(s) => s.center,
                _ => Vec3::new(1.4, 0.9, 0.2),
            };
            let mut n = 0;
            for _ in 0..5000 {
                let o = c + rng.dir() * 3.0;
                let ray = Ray::new(o, (c + rng.dir() * 0.2 - o).normalize());
                let Some(h) = bvh.intersect(&ray) else {
                    continue;
                };
                if h.shape != shape {
                    continue;
                }
                n += 1;
                let sg = geoms[shape as usize].surface(&ray, &h);
                let mut d = rng.dir();
                if d.dot(sg.n_geo) < 0.0 {
                    d = -d;
                }
                let out = spawn_ray(sg.p, sg.n_geo, d);
                if let Some(h2) = bvh.intersect(&out) {
                    assert_ne!(h2.shape, shape, "self-intersection leaving outwards");
                }
                let inward = spawn_ray(sg.p, sg.n_geo, -d);
                let h2 = bvh
                    .intersect(&inward)
                    .expect("inward ray must hit the far side");
                assert_eq!(h2.shape, shape);
                assert!(h2.t > 1e-3, "inward self-hit at t = {}", h2.t);
                // Shadow ray back to the origin of the camera ray: unoccluded by the shape.
                let sh = spawn_ray_to(sg.p, sg.n_geo, o);
                if bvh.occluded(&sh) {
                    let h3 = bvh.intersect(&sh).unwrap();
                    assert_ne!(h3.shape, shape);
                }
            }
            assert!(n > 500);
        }
    }

    #[test]
    fn small_and_empty_bvhs() {
        let empty = Bvh::build(&[]);
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert!(empty.intersect(&ray).is_none() && !empty.occluded(&ray));
        let one = [Geometry::sphere(
            Vec3::new(3.0, 0.0, 0.0),
            1.0,
            Mat4::IDENTITY,
            false,
        )];
        let bvh = Bvh::build(&one);
        let h = bvh.intersect(&ray).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6 && h.shape == 0 && h.prim == 0);
        // From inside the sphere: the far side.
        let h = bvh
            .intersect(&Ray::new(Vec3::new(3.0, 0.0, 0.0), Vec3::Y))
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        let two = [
            Geometry::rectangle(Mat4::IDENTITY, true),
            Geometry::disk(Mat4::IDENTITY, false),
        ];
        let bvh = Bvh::build(&two);
        let h = bvh
            .intersect(&Ray::new(Vec3::new(0.1, 0.2, 1.0), -Vec3::Z))
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        // Degenerate rays.
        assert!(bvh.intersect(&Ray::new(Vec3::ZERO, Vec3::ZERO)).is_none());
        assert!(bvh.intersect(&Ray::new(Vec3::NAN, Vec3::Z)).is_none());
        let _ = Vec2::ZERO;
    }

    #[test]
    fn offset_matches_mitsuba() {
        // Mitsuba: p + n · mulsign((1 + max|p|) · RayEpsilon, n·d), RayEpsilon = 2⁻²⁴ · 1500.
        assert_eq!(RAY_EPSILON, 8.940697e-5);
        let p = Vec3::new(-3.0, 1.0, 2.0);
        let o = offset_ray_origin(p, Vec3::Z, Vec3::new(0.0, 1.0, -1.0));
        assert!((o - (p - Vec3::Z * 4.0 * RAY_EPSILON)).length() < 1e-7);
        let r = spawn_ray_to(p, Vec3::Z, Vec3::new(-3.0, 1.0, 7.0));
        assert!((r.d - Vec3::Z).length() < 1e-6);
        assert!((r.t_max - (5.0 - 4.0 * RAY_EPSILON) * (1.0 - SHADOW_EPSILON)).abs() < 1e-5);
    }

    /// Throughput on the meshes.xml scene: `cargo test --release -p specula-render
    /// accel::tests::throughput -- --ignored --nocapture`.
    #[test]
    #[ignore]
    fn throughput() {
        let geoms = scene();
        let t0 = std::time::Instant::now();
        let bvh = Bvh::build(&geoms);
        let build = t0.elapsed();
        let mut rng = Rng(11);
        let n = 2_000_000;
        let rays: Vec<Ray> = (0..n)
            .map(|_| {
                let o = Vec3::new(0.0, 2.2, -6.5) + rng.in_box(Vec3::splat(-0.1), Vec3::splat(0.1));
                let target = rng.in_box(Vec3::new(-3.0, -0.5, -1.0), Vec3::new(3.0, 2.5, 1.0));
                Ray::new(o, (target - o).normalize())
            })
            .collect();
        let t0 = std::time::Instant::now();
        let hits = rays.iter().filter(|r| bvh.intersect(r).is_some()).count();
        let dt = t0.elapsed().as_secs_f64();
        let t1 = std::time::Instant::now();
        let occ = rays.iter().filter(|r| bvh.occluded(r)).count();
        let dt_occ = t1.elapsed().as_secs_f64();
        assert_eq!(hits, occ);
        // Incoherent secondary rays: random origins and directions inside the scene bounds.
        let rays2: Vec<Ray> = (0..n)
            .map(|_| {
                Ray::new(
                    rng.in_box(Vec3::new(-3.0, 0.0, -2.0), Vec3::new(3.0, 2.0, 2.0)),
                    rng.dir(),
                )
            })
            .collect();
        let t2 = std::time::Instant::now();
        let hits2 = rays2.iter().filter(|r| bvh.intersect(r).is_some()).count();
        let dt2 = t2.elapsed().as_secs_f64();
        println!(
            "{} primitives, build {:.1} ms; primary closest-hit {:.2} Mrays/s ({} hits), \
any-hit {:.2} Mrays/s, random closest-hit {:.2} Mrays/s ({} hits) [1 thread]",
            bvh.primitive_count(),
            build.as_secs_f64() * 1e3,
            n as f64 / dt / 1e6,
            hits,
            n as f64 / dt_occ / 1e6,
            n as f64 / dt2 / 1e6,
            hits2
        );
    }
}
