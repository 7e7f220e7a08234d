//! Ray intersection: one 8-wide BVH over every triangle, sphere and disk of the scene.
//!
//! **Structure.** A binary tree is built top-down with the surface area heuristic over
//! centroid bins along all three axes ([`build::build_tree`]): 32 bins per axis for ranges of more
//! than 1024 primitives, 16 down to 33 and 8 below ([`build::bins_for`]), the two halves of ranges
//! of at least 16 k primitives built in parallel (the same tree for any number of threads).
//! A range of at most 8 triangles is one leaf, unless it holds triangles of several shapes
//! that the SAH finds clearly better apart ([`build::split_small`]: e.g. a room's walls, whose
//! common box is the room). The build is O(n log n) on
//! any input: identical centroids and subtrees deeper than [`build::MAX_SAH_DEPTH`] are split at
//! the object median, and the heuristic is evaluated in double precision, so degenerate,
//! zero-area and huge-coordinate geometry build as fast as any other. The binary tree is
//! then collapsed into nodes of up to 8 children (greedily opening the child with the
//! largest surface area); [`Bvh::sah_cost`] gives the result's SAH cost.
//!
//! Each node stores its children's boxes as arrays of f32 (one array per plane), so one ray
//! is tested against all 8 boxes at once; leaves of at most 8 triangles are one or two `TriPacket`s (4 triangles' vertices, one array per
//! coordinate), tested 4 at a time, or both packets as 8 lanes with AVX2 (leaves of 8 rather
//! than 4 triangles: one node level less, ~6 % faster on meshes.xml). Nodes and packets are
//! laid out depth-first. Closest-hit queries visit
//! the children nearest first and skip stacked subtrees that lie beyond the closest hit so far;
//! occlusion queries stop at the first hit. In a tree that holds analytic shapes the walks
//! make a ray's triangle-test constants at its first triangle leaf rather than up front
//! ([`TriRayCell`]; a shadow ray towards a sphere light often meets no triangle).
//!
//! **Packets.** [`Intersector::intersect_packet`] traces up to 8 rays of one direction octant
//! (a pixel's camera rays) together with AVX2: each child box is tested against all the rays
//! at once (one ray per lane), a stacked child carries the rays that entered it and where, and
//! a leaf is tested by each of those rays with the single-ray test, so each ray gets exactly
//! the hit a single-ray query gives it. Other ISAs, or rays of several octants, are traced
//! one by one.
//!
//! **Instruction sets.** The box and triangle tests have a portable scalar implementation and
//! SSE2 (always present on x86-64) and AVX2 + FMA (picked at run time when the CPU has them)
//! ones ([`Bvh::set_isa`] selects one, for tests and benchmarks). The triangle tests perform
//! the same IEEE operations in the same order everywhere (no fused multiply-add), so hits are
//! bit-identical; the AVX2 box test computes t = p·(1/d) − o·(1/d) with one fused
//! multiply-subtract where the others compute (p − o)·(1/d), which can only change which
//! boxes a ray grazes (both are conservative), hence at most which of two triangles hit at
//! exactly the same t is reported. The tests check that all of them agree.
//!
//! **Ownership.** [`Bvh::build`] copies what intersection needs (triangle vertices, sphere
//! centres and radii, disk transforms) into its own arrays; the `Geometry` slice may be
//! dropped or moved afterwards. A [`Hit`] names the shape by its index in that slice (`shape`)
//! and the primitive within it (`prim`), so the caller keeps the shapes to compute
//! [`crate::geometry::Geometry::surface`].
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
//! boxes are padded slightly before the build and the box test widens its exit distance by a
//! few ulps, so rounding never culls a box that holds a hit; boxes are entered from t = 0.
//! Traversal keeps its stack in a fixed array (no heap allocation per ray; a stack deeper than
//! the array, which only a pathologically deep tree could need, spills to the heap).
//!
//! **Files.** This file: the [`Intersector`] API, ray spawning, [`Bvh`] (gathering the
//! primitives, collapsing the binary tree into 8-wide nodes and packets, the closest-hit,
//! any-hit and packet walks, the analytic shapes); `build.rs`: the binary SAH build; `x86.rs`:
//! the SSE2 and AVX2 box and triangle tests and the AVX2 entry points; `tests.rs`.

use crate::core::{Hit, Ray};
use crate::geometry::{Geometry, ShapeGroup};
use glam::{DVec3, Mat3, Vec3, Vec3A};
use std::mem::MaybeUninit;
use std::sync::Arc;

mod build;
#[cfg(test)]
mod tests;
#[cfg(target_arch = "x86_64")]
mod x86;

use build::{build_tree, half_area_f64, BNode, PrimBox};

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
    /// `hits[i] = intersect(&rays[i])` for every ray (`hits` at least as long as `rays`); a
    /// backend may trace coherent rays (a pixel's camera rays) together.
    fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        intersect_each(self, rays, hits);
    }
}

/// `intersect_packet` one ray at a time.
fn intersect_each<I: Intersector + ?Sized>(accel: &I, rays: &[Ray], hits: &mut [Option<Hit>]) {
    for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
        *hit = accel.intersect(ray);
    }
}

/// Mitsuba's `Interaction::offset_p`: `p` moved along the geometric normal `n`, to the side
/// of `d`, by `(1 + max(|p.x|, |p.y|, |p.z|)) · RAY_EPSILON`.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3, d: Vec3) -> Vec3 {
    // (a hit point has no NaN; one that did gives a NaN origin either way, which no walk
    // accepts)
    let a = p.abs();
    let mag = (1.0 + crate::core::max3(a.x, a.y, a.z)) * RAY_EPSILON;
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
    Sphere {
        center: Vec3,
        radius: f32,
    },
    /// World to object: `local = m · p + t`; the disk is x² + y² ≤ 1 at z = 0.
    Disk {
        m: Mat3,
        t: Vec3,
    },
    /// World to object as for a disk; the open cylinder x² + y² = 1, 0 ≤ z ≤ 1.
    Cylinder {
        m: Mat3,
        t: Vec3,
    },
    /// An instance of shape group `group` (index into `Bvh::groups`), world to group space
    /// as for a disk.
    Instance {
        m: Mat3,
        t: Vec3,
        group: u32,
    },
}

/// A primitive kept by the build: shape `geom` of the scene and, for a mesh, its triangle
/// `index` (whose vertices the packets copy from the mesh when they are made), or the
/// analytic shape `analytic` of the build's list ([`NOT_ANALYTIC`] for a triangle). Twelve
/// bytes, whatever the shape: a million triangles' records take 12 MB while the tree is built.
#[derive(Clone, Copy, Debug)]
struct Prim {
    geom: u32,
    index: u32,
    analytic: u32,
}

/// [`Prim::analytic`] of a triangle.
const NOT_ANALYTIC: u32 = u32::MAX;

impl Prim {
    /// The vertices of triangle primitive `self` of `geoms`.
    fn triangle(&self, geoms: &[Geometry]) -> [Vec3; 3] {
        match &geoms[self.geom as usize] {
            Geometry::Mesh(m) => m.triangle(self.index as usize),
            _ => unreachable!("a triangle primitive lies on a mesh"),
        }
    }
}

/// Children per node.
const WIDTH: usize = 8;
/// Triangles per packet.
const LANES: usize = 4;
/// Ranges of at most this many triangles (and nothing else) become one leaf (2 packets), unless
/// [`build::split_small`] splits them.
const LEAF_TRIS: u32 = 8;

// A child reference (`u32`): a node index; or `LEAF | (packets − 1) << COUNT_SHIFT | first
// packet`; or `LEAF | ANALYTIC | index` of an analytic shape.
const LEAF: u32 = 1 << 31;
const ANALYTIC: u32 = 1 << 30;
const COUNT_SHIFT: u32 = 27;
const INDEX_MASK: u32 = (1 << COUNT_SHIFT) - 1;
const MAX_LEAF_PACKETS: usize = 8;

/// A node: the boxes of up to 8 children, one array per plane (`b[2·axis]` the lower and
/// `b[2·axis + 1]` the upper bounds), and their references. Unused slots have empty boxes
/// (lower +∞, upper −∞), which no ray hits.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    b: [[f32; WIDTH]; 6],
    child: [u32; WIDTH],
}

impl Node {
    const EMPTY: Node = Node {
        b: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [0; WIDTH],
    };
}

/// Up to 4 triangles: `v[vertex][axis][lane]`; unused lanes are NaN (never hit).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
struct TriPacket {
    v: [[[f32; LANES]; 3]; 3],
}

impl TriPacket {
    /// The vertices of the triangle in `lane`.
    #[inline]
    fn vertices(&self, lane: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|k| Vec3::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]))
    }
}

/// Which implementation of the box and triangle tests a [`Bvh`] uses (see the module docs on
/// how far their results agree).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// Portable scalar code.
    Scalar,
    /// SSE2: 4-wide triangle tests, 8 boxes as two halves (x86-64 only).
    Sse2,
    /// AVX2 and FMA: 8 boxes at once (x86-64 CPUs that have both).
    Avx2,
}

impl Isa {
    /// The fastest implementation this CPU supports.
    pub fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
            {
                return Isa::Avx2;
            }
            return Isa::Sse2;
        }
        #[allow(unreachable_code)]
        Isa::Scalar
    }

    /// Every implementation this CPU supports, slowest first.
    pub fn available() -> Vec<Isa> {
        [Isa::Scalar, Isa::Sse2, Isa::Avx2]
            .into_iter()
            .filter(|i| i.supported())
            .collect()
    }

    /// Whether this CPU can run it.
    pub fn supported(self) -> bool {
        match self {
            Isa::Scalar => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Sse2 => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }
}

/// An 8-wide BVH over all primitives of a list of shapes. See the module docs for the layout,
/// ownership and epsilon conventions.
#[derive(Clone, Debug)]
pub struct Bvh {
    /// Depth-first; the root is node 0 (none when the scene is empty).
    nodes: Vec<Node>,
    packets: Vec<TriPacket>,
    /// Per packet lane: (shape, primitive index), read only for the closest hit.
    packet_ids: Vec<[(u32, u32); LANES]>,
    analytic: Vec<PrimShape>,
    analytic_ids: Vec<(u32, u32)>,
    /// The shape groups that `PrimShape::Instance`s refer to (shared with the scene's shapes).
    groups: Vec<Arc<ShapeGroup>>,
    primitives: usize,
    isa: Isa,
    /// Whether the walks make a ray's triangle constants lazily (see [`TriRayCell`]): set
    /// when the tree holds analytic shapes.
    lazy: bool,
}

impl Default for Bvh {
    fn default() -> Self {
        Bvh {
            nodes: Vec::new(),
            packets: Vec::new(),
            packet_ids: Vec::new(),
            analytic: Vec::new(),
            analytic_ids: Vec::new(),
            groups: Vec::new(),
            primitives: 0,
            isa: Isa::detect(),
            lazy: false,
        }
    }
}

/// Bound on |1/d| in box tests (a zero component gets +MAX_INV_DIR).
const MAX_INV_DIR: f32 = 1e18;
/// Box exit distances are scaled by this (a few ulps more than 1), so that rounding in the
/// slab test never culls a box the ray touches (Ize, *Robust BVH Ray Traversal*, JCGT 2013).
const EXIT_SCALE: f32 = 1.0 + 4.0 * f32::EPSILON;

impl Bvh {
    /// Builds the BVH over every primitive of `geoms` (copying their data).
    pub fn build(geoms: &[Geometry]) -> Bvh {
        // one pass over the shapes: the primitives that are kept and their boxes, in shape
        // order, in arrays of the right size (no regrowth, no second copy)
        let total: usize = geoms
            .iter()
            .map(|g| match g {
                Geometry::Mesh(m) => m.indices.len(),
                Geometry::Instance(inst) if inst.member != 0 => 0,
                _ => 1,
            })
            .sum();
        let mut kept: Vec<Prim> = Vec::with_capacity(total);
        let mut pb: Vec<PrimBox> = Vec::with_capacity(total);
        let mut groups: Vec<Arc<ShapeGroup>> = Vec::new();
        let mut shapes: Vec<PrimShape> = Vec::new();
        // Drops primitives that can never be hit or would poison the build; an analytic
        // `shape` is listed.
        let mut keep = |geom: u32, index: u32, shape: Option<PrimShape>, lo: Vec3, hi: Vec3| {
            if !(lo.is_finite() && hi.is_finite()) {
                return;
            }
            // Pad by a few ulps of the coordinates (and of the extent) so that rounding in the
            // box tests never rejects a ray that hits the primitive.
            let scale = lo.abs().max(hi.abs()).max_element();
            let pad = Vec3::splat(scale * 4e-7 + (hi - lo).max_element() * 1e-6 + 1e-30);
            // (clamped: padding a box near ±f32::MAX must not make it infinite)
            let lo = (lo - pad).max(Vec3::splat(f32::MIN));
            let hi = (hi + pad).min(Vec3::splat(f32::MAX));
            pb.push(PrimBox::new(
                lo,
                hi,
                shape.is_none().then_some(geom),
                kept.len() as u32,
            ));
            let analytic = match shape {
                Some(shape) => {
                    shapes.push(shape);
                    shapes.len() as u32 - 1
                }
                None => NOT_ANALYTIC,
            };
            kept.push(Prim {
                geom,
                index,
                analytic,
            });
        };
        for (g, geom) in geoms.iter().enumerate() {
            let g = g as u32;
            match geom {
                Geometry::Mesh(m) => {
                    for i in 0..m.indices.len() {
                        let v = m.triangle(i);
                        let (lo, hi) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
                        keep(g, i as u32, None, lo, hi);
                    }
                }
                Geometry::Sphere(s) => {
                    let (center, radius) = (s.center, s.radius.abs());
                    let shape = PrimShape::Sphere { center, radius };
                    let (lo, hi) = (center - Vec3::splat(radius), center + Vec3::splat(radius));
                    keep(g, 0, Some(shape), lo, hi);
                }
                Geometry::Disk(d) => {
                    let m = Mat3::from_mat4(d.to_object);
                    let t = d.to_object.w_axis.truncate();
                    let (lo, hi) = geom.bounds();
                    keep(g, 0, Some(PrimShape::Disk { m, t }), lo, hi);
                }
                Geometry::Cylinder(c) => {
                    let m = Mat3::from_mat4(c.to_object);
                    let t = c.to_object.w_axis.truncate();
                    let (lo, hi) = geom.bounds();
                    keep(g, 0, Some(PrimShape::Cylinder { m, t }), lo, hi);
                }
                // one primitive per instance, on the slot of its first group shape
                Geometry::Instance(inst) if inst.member == 0 => {
                    let group = match groups.iter().position(|x| Arc::ptr_eq(x, &inst.group)) {
                        Some(i) => i,
                        None => {
                            groups.push(inst.group.clone());
                            groups.len() - 1
                        }
                    } as u32;
                    let m = Mat3::from_mat4(inst.to_object);
                    let t = inst.to_object.w_axis.truncate();
                    let (lo, hi) = geom.bounds();
                    keep(g, 0, Some(PrimShape::Instance { m, t, group }), lo, hi);
                }
                Geometry::Instance(_) => {}
            }
        }
        let mut out = Bvh {
            primitives: kept.len(),
            groups,
            ..Bvh::default()
        };
        if kept.is_empty() {
            return out;
        }
        let (tree, order) = build_tree(&mut pb);
        drop(pb);
        out.collapse(&tree, &order, &kept, &shapes, geoms);
        out.lazy = !out.analytic.is_empty();
        out
    }

    /// Number of primitives (triangles, spheres, disks) in the BVH.
    pub fn primitive_count(&self) -> usize {
        self.primitives
    }

    /// The tree's expected traversal cost under the surface area heuristic, relative to its
    /// root box: Σ over 8-wide nodes of area(node)/area(root) · 1 plus Σ over leaves of
    /// area(leaf)/area(root) · (its packets, or 1 for an analytic shape). A measure of tree
    /// quality for comparing builders (lower is better); 0 for an empty tree.
    pub fn sah_cost(&self) -> f64 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        // the box of slot `s` of a node
        let slot = |n: &Node, s: usize| {
            let plane = |k: usize| Vec3::new(n.b[k][s], n.b[k + 2][s], n.b[k + 4][s]);
            (plane(0), plane(1))
        };
        let area = |n: &Node, s: usize| {
            let (lo, hi) = slot(n, s);
            half_area_f64(lo, hi)
        };
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for s in 0..WIDTH {
            let (l, h) = slot(root, s);
            (lo, hi) = (lo.min(l), hi.max(h));
        }
        let root_area = half_area_f64(lo, hi);
        if root_area <= 0.0 {
            return 0.0;
        }
        // the root is always visited; every other node and leaf when its box in its parent is
        let mut cost = 1.0;
        for n in &self.nodes {
            for s in 0..WIDTH {
                if n.b[0][s] > n.b[1][s] {
                    continue; // unused slot
                }
                let c = n.child[s];
                // an inner node or an analytic shape: 1; a leaf of triangles: its packets
                let weight = if c & LEAF == 0 || c & ANALYTIC != 0 {
                    1.0
                } else {
                    ((c & !LEAF) >> COUNT_SHIFT) as f64 + 1.0
                };
                cost += area(n, s) / root_area * weight;
            }
        }
        cost
    }

    /// The implementation of the box and triangle tests in use.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Selects the implementation of the box and triangle tests.
    /// Panics if this CPU does not support it.
    pub fn set_isa(&mut self, isa: Isa) {
        assert!(isa.supported(), "{isa:?} is not supported by this CPU");
        self.isa = isa;
    }

    /// Turns the binary tree into 8-wide nodes and packets, depth-first.
    fn collapse(
        &mut self,
        tree: &[BNode],
        order: &[u32],
        prims: &[Prim],
        shapes: &[PrimShape],
        geoms: &[Geometry],
    ) {
        // (binary node, parent node, slot): inner nodes still to emit
        let mut todo: Vec<(u32, u32, usize)> = vec![(0, u32::MAX, 0)];
        let mut leaf_prims: Vec<u32> = Vec::new();
        let mut walk: Vec<u32> = Vec::new();
        while let Some((b, parent, slot)) = todo.pop() {
            let index = self.nodes.len() as u32;
            if parent != u32::MAX {
                self.nodes[parent as usize].child[slot] = index;
            }
            self.nodes.push(Node::EMPTY);
            // children: open the largest-area inner child until there are 8
            let mut kids: Vec<u32> = if tree[b as usize].is_leaf() {
                vec![b]
            } else {
                tree[b as usize].kids.to_vec()
            };
            while kids.len() < WIDTH {
                let best = kids
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| !tree[k as usize].is_leaf())
                    .max_by(|a, b| {
                        let (aa, ba) = (
                            tree[*a.1 as usize].half_area(),
                            tree[*b.1 as usize].half_area(),
                        );
                        aa.total_cmp(&ba)
                    })
                    .map(|(i, _)| i);
                let Some(i) = best else { break };
                let k = kids[i] as usize;
                kids[i] = tree[k].kids[0];
                kids.insert(i + 1, tree[k].kids[1]);
            }
            let mut inner = Vec::new();
            for (s, &k) in kids.iter().enumerate() {
                let kn = &tree[k as usize];
                let node = &mut self.nodes[index as usize];
                for a in 0..3 {
                    node.b[2 * a][s] = kn.lo[a];
                    node.b[2 * a + 1][s] = kn.hi[a];
                }
                if !kn.is_leaf() {
                    inner.push((k, index, s));
                    continue;
                }
                // gather the leaf's primitives
                leaf_prims.clear();
                walk.clear();
                walk.push(k);
                while let Some(w) = walk.pop() {
                    let wn = &tree[w as usize];
                    if wn.is_leaf() {
                        let first = wn.kids[0] as usize;
                        leaf_prims.extend_from_slice(&order[first..first + wn.count as usize]);
                    } else {
                        walk.push(wn.kids[1]);
                        walk.push(wn.kids[0]);
                    }
                }
                let code = match leaf_prims[..] {
                    [p] if prims[p as usize].analytic != NOT_ANALYTIC => {
                        let pr = &prims[p as usize];
                        let code = LEAF | ANALYTIC | self.analytic.len() as u32;
                        self.analytic.push(shapes[pr.analytic as usize]);
                        self.analytic_ids.push((pr.geom, pr.index));
                        code
                    }
                    _ => self.push_packets(&leaf_prims, prims, geoms),
                };
                self.nodes[index as usize].child[s] = code;
            }
            // depth-first: the first child's subtree comes next
            todo.extend(inner.into_iter().rev());
        }
    }

    /// Packs triangles into consecutive packets; returns the leaf reference.
    fn push_packets(&mut self, tris: &[u32], prims: &[Prim], geoms: &[Geometry]) -> u32 {
        let first = self.packets.len();
        for chunk in tris.chunks(LANES) {
            let mut p = TriPacket {
                v: [[[f32::NAN; LANES]; 3]; 3],
            };
            let mut ids = [(u32::MAX, u32::MAX); LANES];
            for (lane, &t) in chunk.iter().enumerate() {
                let pr = &prims[t as usize];
                for (vi, vert) in pr.triangle(geoms).iter().enumerate() {
                    for a in 0..3 {
                        p.v[vi][a][lane] = vert[a];
                    }
                }
                ids[lane] = (pr.geom, pr.index);
            }
            self.packets.push(p);
            self.packet_ids.push(ids);
        }
        let n = self.packets.len() - first;
        assert!((1..=MAX_LEAF_PACKETS).contains(&n) && first <= INDEX_MASK as usize);
        LEAF | ((n as u32 - 1) << COUNT_SHIFT) | first as u32
    }
}

/// Per-ray constants of the watertight ray/triangle test.
struct TriRay {
    o: Vec3,
    /// Axis permutation (kx, ky, kz), each < 3.
    k: [usize; 3],
    /// The origin permuted: (o[kx], o[ky], o[kz]).
    ok: [f32; 3],
    s: Vec3,
}

/// A ray's [`TriRay`], made at once (`LAZY` false) or when the walk reaches its first
/// triangle leaf (`LAZY` true). The walks are lazy in trees that hold analytic shapes: there a
/// ray often tests a node or two and a sphere or disk, and no triangle (a shadow ray towards
/// a sphere light), and the constants (a division and the permutation) were a good part of
/// its cost; in trees of triangles alone nearly every ray reaches a triangle leaf, and the
/// constants made up front are cheaper to reuse (measured, `count_instructions.py`: lazy
/// walks cost `meshes` 1.3 % and `cbox` 0.4 % more instructions, and save 1.5–3.9 % on
/// `veach_mis`, `envmap_spheres` and `mat_rough_copper`).
struct TriRayCell<const LAZY: bool> {
    ready: bool,
    tr: MaybeUninit<TriRay>,
}

impl<const LAZY: bool> TriRayCell<LAZY> {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        if LAZY {
            TriRayCell {
                ready: false,
                tr: MaybeUninit::uninit(),
            }
        } else {
            TriRayCell {
                ready: true,
                tr: MaybeUninit::new(TriRay::new(ray)),
            }
        }
    }

    /// The ray's triangle constants (made on the first call when `LAZY`).
    #[inline(always)]
    fn get(&mut self, ray: &Ray) -> &TriRay {
        if LAZY && !self.ready {
            self.tr.write(TriRay::new(ray));
            self.ready = true;
        }
        // SAFETY: written by `new` (not `LAZY`) or above on the first call (`LAZY`)
        unsafe { self.tr.assume_init_ref() }
    }
}

impl TriRay {
    #[inline(always)]
    fn new(ray: &Ray) -> TriRay {
        let d = ray.d;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        // (kx, ky): the next two axes after kz, swapped when d[kz] < 0 (keeps the winding)
        const K: [[[usize; 2]; 2]; 3] = [[[1, 2], [2, 1]], [[2, 0], [0, 2]], [[0, 1], [1, 0]]];
        // four-element copies indexed by `k & 3`: no bounds checks (and no panicking
        // `Vec3` index) on this per-ray path
        let dv = [d.x, d.y, d.z, 0.0];
        let ov = [ray.o.x, ray.o.y, ray.o.z, 0.0];
        let dz = dv[kz & 3];
        let [kx, ky] = K[kz][(dz < 0.0) as usize];
        let (kx, ky) = (kx & 3, ky & 3);
        // the three quotients in one division (each lane the same IEEE quotient as alone)
        let s = Vec3A::new(dv[kx], dv[ky], 1.0) / Vec3A::splat(dz);
        TriRay {
            o: ray.o,
            k: [kx, ky, kz],
            ok: [ov[kx], ov[ky], ov[kz & 3]],
            s: s.into(),
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
            (u, v_, w) = edge_functions_f64(ax, ay, bx, by, cx, cy);
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

/// The edge functions in double precision, for rays through an edge or a vertex.
#[cold]
#[inline(never)]
fn edge_functions_f64(ax: f32, ay: f32, bx: f32, by: f32, cx: f32, cy: f32) -> (f32, f32, f32) {
    let (ax, ay, bx, by, cx, cy) = (
        ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
    );
    (
        (cx * by - cy * bx) as f32,
        (ax * cy - ay * cx) as f32,
        (bx * ay - by * ax) as f32,
    )
}

/// Results of a packet test: per lane t and the barycentrics b1, b2 (meaningful for the lanes
/// set in the returned mask).
#[derive(Clone, Copy)]
#[repr(C, align(16))]
struct TriOut {
    t: [f32; 2 * LANES],
    b1: [f32; 2 * LANES],
    b2: [f32; 2 * LANES],
}

/// Per-ray constants of the box test.
#[derive(Clone, Copy)]
struct BoxRay {
    o: [f32; 3],
    inv: [f32; 3],
    /// Per axis, the plane arrays (`Node::b` indices) met first and last.
    near: [usize; 3],
    far: [usize; 3],
    /// The same as offsets in floats from the start of `Node::b` (`plane · WIDTH`).
    near_at: [usize; 3],
    far_at: [usize; 3],
}

impl BoxRay {
    #[inline(always)]
    fn new(ray: &Ray) -> BoxRay {
        // +0 for zero components (including −0), which get +MAX_INV_DIR
        let d = Vec3A::from(ray.d) + Vec3A::ZERO;
        let max = Vec3A::splat(MAX_INV_DIR);
        let inv = (Vec3A::ONE / d).clamp(-max, max);
        let inv = Vec3A::select(d.cmpeq(Vec3A::ZERO), max, inv);
        let neg = inv.cmplt(Vec3A::ZERO).bitmask() as usize;
        let n = |a: usize| (neg >> a) & 1;
        BoxRay {
            o: ray.o.to_array(),
            inv: inv.to_array(),
            near: [n(0), 2 + n(1), 4 + n(2)],
            far: [1 - n(0), 3 - n(1), 5 - n(2)],
            near_at: [n(0), 2 + n(1), 4 + n(2)].map(|p| p * WIDTH),
            far_at: [1 - n(0), 3 - n(1), 5 - n(2)].map(|p| p * WIDTH),
        }
    }
}

/// The 8-box slab test.
trait BoxTest {
    /// Bit i set when the ray enters child i's box at some t in [0, t_max]; `tnear[i]` is
    /// where it enters (at least 0).
    unsafe fn test(n: &Node, r: &BoxRay, t_max: f32, tnear: &mut [f32; WIDTH]) -> u32;
}

/// The 4-triangle watertight test.
trait PacketTest {
    /// Bit i set when lane i is hit at t in (0, t_max); `out` gets t, b1, b2 per lane
    /// (`out[..4]`).
    unsafe fn test(p: &TriPacket, tr: &TriRay, t_max: f32, out: &mut TriOut) -> u32;
    /// Two packets as 8 lanes (`p[0]` lanes 0–3, `p[1]` lanes 4–7).
    #[inline(always)]
    unsafe fn test2(p: *const TriPacket, tr: &TriRay, t_max: f32, out: &mut TriOut) -> u32 {
        let m0 = Self::test(&*p, tr, t_max, out);
        let mut hi = *out;
        let m1 = Self::test(&*p.add(1), tr, t_max, &mut hi);
        out.t[LANES..].copy_from_slice(&hi.t[..LANES]);
        out.b1[LANES..].copy_from_slice(&hi.b1[..LANES]);
        out.b2[LANES..].copy_from_slice(&hi.b2[..LANES]);
        m0 | m1 << LANES
    }
}

/// Portable scalar tests.
struct Scalar;

impl BoxTest for Scalar {
    #[inline(always)]
    unsafe fn test(n: &Node, r: &BoxRay, t_max: f32, tnear: &mut [f32; WIDTH]) -> u32 {
        let mut mask = 0;
        for (i, tnear) in tnear.iter_mut().enumerate() {
            let tn = |a: usize| (n.b[r.near[a]][i] - r.o[a]) * r.inv[a];
            let tf = |a: usize| (n.b[r.far[a]][i] - r.o[a]) * r.inv[a];
            let t0 = tn(0).max(tn(1)).max(tn(2)).max(0.0);
            let t1 = (tf(0).min(tf(1)).min(tf(2)) * EXIT_SCALE).min(t_max);
            *tnear = t0;
            mask |= ((t0 <= t1) as u32) << i;
        }
        mask
    }
}

impl PacketTest for Scalar {
    #[inline(always)]
    unsafe fn test(p: &TriPacket, tr: &TriRay, t_max: f32, out: &mut TriOut) -> u32 {
        let mut mask = 0;
        for lane in 0..LANES {
            let v = p.vertices(lane);
            if let Some((t, b1, b2)) = tr.intersect(&v, t_max) {
                out.t[lane] = t;
                out.b1[lane] = b1;
                out.b2[lane] = b2;
                mask |= 1 << lane;
            }
        }
        mask
    }
}

/// The closest hit so far: (analytic leaf reference, or packet index · LANES + lane; whether
/// analytic; b1; b2; for an instance, the group shape and primitive hit).
type Best = Option<(u32, bool, f32, f32, (u32, u32))>;

/// An analytic hit: t, two surface parameters, and for an instance the group shape and
/// primitive hit ((0, 0) otherwise).
type AnalyticHit = (f32, f32, f32, (u32, u32));

/// A traversal stack entry: a child reference and where the ray enters its box.
#[derive(Clone, Copy)]
struct Entry {
    code: u32,
    t: f32,
}

/// Entries kept in the fixed array; a deeper stack spills to the heap.
const STACK: usize = 128;

/// A traversal stack of up to `N` entries in place, deeper ones on the heap.
struct Stack<E: Copy, const N: usize> {
    len: usize,
    items: [MaybeUninit<E>; N],
    spill: Vec<E>,
}

impl<E: Copy, const N: usize> Stack<E, N> {
    #[inline(always)]
    fn new() -> Self {
        Stack {
            len: 0,
            items: [MaybeUninit::uninit(); N],
            spill: Vec::new(),
        }
    }
    #[inline(always)]
    fn push(&mut self, e: E) {
        if self.len < N {
            self.items[self.len] = MaybeUninit::new(e);
        } else {
            self.spill.push(e);
        }
        self.len += 1;
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<E> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        if self.len < N {
            // SAFETY: entries below `len` (and below N) were written by `push`.
            Some(unsafe { self.items[self.len].assume_init() })
        } else {
            self.spill.pop()
        }
    }
}

/// A packet traversal stack entry: a child, the rays of the packet that enter its box
/// (`mask`) and where (`t`, per lane), and the distance it is ordered by.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct PacketEntry {
    t: [f32; 8],
    code: u32,
    mask: u32,
    key: f32,
}

impl PacketEntry {
    const EMPTY: PacketEntry = PacketEntry {
        t: [0.0; 8],
        code: 0,
        mask: 0,
        key: 0.0,
    };
}

/// Inserts `e` into `es[..n]`, kept sorted by decreasing distance.
#[inline(always)]
fn insert_desc(es: &mut [Entry; WIDTH], n: &mut usize, e: Entry) {
    let mut j = *n;
    while j > 0 && es[j - 1].t < e.t {
        es[j] = es[j - 1];
        j -= 1;
    }
    es[j] = e;
    *n += 1;
}

impl Bvh {
    /// Asks for the cache lines of a child.
    #[inline(always)]
    fn prefetch(&self, code: u32) {
        #[cfg(target_arch = "x86_64")]
        unsafe {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            if code & LEAF == 0 {
                let p = self.nodes.as_ptr().add(code as usize) as *const i8;
                for k in 0..4 {
                    _mm_prefetch::<_MM_HINT_T0>(p.add(64 * k));
                }
            } else if code & ANALYTIC == 0 {
                let p = self.packets.as_ptr().add((code & INDEX_MASK) as usize) as *const i8;
                for k in 0..3 {
                    _mm_prefetch::<_MM_HINT_T0>(p.add(64 * k));
                }
            }
        }
    }

    /// Asks the cache for packet `p`'s entry of `packet_ids`.
    #[inline(always)]
    fn prefetch_ids(&self, p: usize) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `p` is a packet index (in bounds); a prefetch never faults
        unsafe {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            _mm_prefetch::<_MM_HINT_T0>(self.packet_ids.as_ptr().add(p) as *const i8);
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = p;
    }

    /// Intersects an analytic shape.
    #[inline(never)]
    fn intersect_analytic(&self, code: u32, ray: &Ray, t_max: f32) -> Option<AnalyticHit> {
        let with0 = |(t, u, v)| (t, u, v, (0, 0));
        match &self.analytic[(code & !(LEAF | ANALYTIC)) as usize] {
            PrimShape::Sphere { center, radius } => Some((
                intersect_sphere(ray, *center, *radius, t_max)?,
                0.0,
                0.0,
                (0, 0),
            )),
            PrimShape::Disk { m, t } => intersect_disk(ray, m, *t, t_max).map(with0),
            PrimShape::Cylinder { m, t } => {
                Some((intersect_cylinder(ray, m, *t, t_max)?, 0.0, 0.0, (0, 0)))
            }
            PrimShape::Instance { m, t, group } => {
                let local = instance_ray(ray, m, *t, t_max);
                let h = self.groups[*group as usize].accel.intersect(&local)?;
                Some((h.t, h.u, h.v, (h.shape, h.prim)))
            }
        }
    }

    /// Whether an analytic shape blocks the ray before `t_max`.
    #[inline(never)]
    fn occluded_analytic(&self, code: u32, ray: &Ray, t_max: f32) -> bool {
        match &self.analytic[(code & !(LEAF | ANALYTIC)) as usize] {
            PrimShape::Instance { m, t, group } => self.groups[*group as usize]
                .accel
                .occluded(&instance_ray(ray, m, *t, t_max)),
            _ => self.intersect_analytic(code, ray, t_max).is_some(),
        }
    }

    /// Closest hit: nearest child first, stacked subtrees beyond the closest hit skipped.
    #[inline(always)]
    unsafe fn closest<B: BoxTest, P: PacketTest, const LAZY: bool>(
        &self,
        ray: &Ray,
    ) -> Option<Hit> {
        let br = BoxRay::new(ray);
        let mut tr = TriRayCell::<LAZY>::new(ray);
        let mut t_max = ray.t_max;
        let mut best: Best = None;
        let mut stack: Stack<Entry, STACK> = Stack::new();
        let mut tnear = [0f32; WIDTH];
        let mut out = TriOut {
            t: [0.0; 2 * LANES],
            b1: [0.0; 2 * LANES],
            b2: [0.0; 2 * LANES],
        };
        let mut cur = 0u32;
        'walk: loop {
            if cur & LEAF == 0 {
                let node = self.nodes.get_unchecked(cur as usize);
                let mut mask = B::test(node, &br, t_max, &mut tnear);
                if mask & mask.wrapping_sub(1) != 0 {
                    // several children: ask for all their lines at once
                    let mut m = mask;
                    while m != 0 {
                        let i = m.trailing_zeros() as usize;
                        m &= m - 1;
                        self.prefetch(node.child[i]);
                    }
                }
                if mask != 0 {
                    let i0 = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        cur = node.child[i0];
                        continue 'walk;
                    }
                    let i1 = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    let e0 = Entry {
                        code: node.child[i0],
                        t: tnear[i0],
                    };
                    let e1 = Entry {
                        code: node.child[i1],
                        t: tnear[i1],
                    };
                    if mask == 0 {
                        let (near, far) = if e1.t < e0.t { (e1, e0) } else { (e0, e1) };
                        stack.push(far);
                        cur = near.code;
                        continue 'walk;
                    }
                    // three or more: sorted by decreasing distance
                    let mut es = [e0; WIDTH];
                    let mut n = 1;
                    insert_desc(&mut es, &mut n, e1);
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let e = Entry {
                            code: node.child[i],
                            t: tnear[i],
                        };
                        insert_desc(&mut es, &mut n, e);
                    }
                    for e in &es[..n - 1] {
                        stack.push(*e);
                    }
                    cur = es[n - 1].code;
                    continue 'walk;
                }
            } else {
                self.leaf_closest::<P, LAZY>(cur, ray, &mut tr, &mut t_max, &mut best, &mut out);
            }
            // next: the nearest stacked subtree the ray may still hit before t_max
            loop {
                match stack.pop() {
                    None => break 'walk,
                    Some(e) if e.t <= t_max => {
                        cur = e.code;
                        continue 'walk;
                    }
                    Some(_) => {}
                }
            }
        }
        self.make_hit(best, t_max)
    }

    /// Tests leaf `cur` (triangle packets or an analytic shape) for a hit closer than
    /// `t_max`, updating `t_max` and `best`.
    #[inline(always)]
    unsafe fn leaf_closest<P: PacketTest, const LAZY: bool>(
        &self,
        cur: u32,
        ray: &Ray,
        tr: &mut TriRayCell<LAZY>,
        t_max: &mut f32,
        best: &mut Best,
        out: &mut TriOut,
    ) {
        if cur & ANALYTIC != 0 {
            if let Some((t, u, v, sub)) = self.intersect_analytic(cur, ray, *t_max) {
                *t_max = t;
                *best = Some((cur, true, u, v, sub));
            }
            return;
        }
        let tr = tr.get(ray);
        let first = (cur & INDEX_MASK) as usize;
        let count = ((cur >> COUNT_SHIFT) & 7) as usize + 1;
        let end = first + count;
        let mut pi = first;
        while pi < end {
            // two packets at a time where there are two (8 lanes with AVX2)
            let pair = pi + 1 < end;
            let packet = self.packets.as_ptr().add(pi);
            let mut m = if pair {
                P::test2(packet, tr, *t_max, out)
            } else {
                P::test(&*packet, tr, *t_max, out)
            };
            if m != 0 {
                let mut lane = m.trailing_zeros() as usize;
                m &= m - 1;
                while m != 0 {
                    let l = m.trailing_zeros() as usize;
                    m &= m - 1;
                    if out.t[l] < out.t[lane] {
                        lane = l;
                    }
                }
                *t_max = out.t[lane];
                let code = pi * LANES + lane;
                // the hit's shape and primitive ids live in an array of their own, which
                // only the final hit reads (`make_hit`): ask for its line now, so that it
                // arrives while the rest of the tree is walked rather than after
                self.prefetch_ids(code / LANES);
                // lanes 4–7 of a pair are those of the next packet
                *best = Some((code as u32, false, out.b1[lane], out.b2[lane], (0, 0)));
            }
            pi += 1 + pair as usize;
        }
    }

    /// The hit recorded as `best` at distance `t`.
    #[inline(always)]
    fn make_hit(&self, best: Best, t: f32) -> Option<Hit> {
        // `?`, not `Option::map`: the closure was compiled out of line, and the hit it
        // wrote piecewise was read back whole (a store-forwarding stall on every ray)
        let (code, analytic, u, v, sub) = best?;
        let (shape, prim, vertices) = if analytic {
            let i = (code & !(LEAF | ANALYTIC)) as usize;
            let (shape, prim) = self.analytic_ids[i];
            if let PrimShape::Instance { .. } = self.analytic[i] {
                // the slot of the group shape hit, and its primitive
                (shape + sub.0, sub.1, None)
            } else {
                (shape, prim, None)
            }
        } else {
            let (p, lane) = (code as usize / LANES, code as usize % LANES);
            let (shape, prim) = self.packet_ids[p][lane];
            (shape, prim, Some(self.packets[p].vertices(lane)))
        };
        Some(Hit {
            t,
            shape,
            prim,
            u,
            v,
            vertices,
        })
    }

    /// Any hit: children in slot order, stopping at the first hit.
    #[inline(always)]
    unsafe fn any_hit<B: BoxTest, P: PacketTest, const LAZY: bool>(&self, ray: &Ray) -> bool {
        let br = BoxRay::new(ray);
        let mut tr = TriRayCell::<LAZY>::new(ray);
        let t_max = ray.t_max;
        let mut stack: Stack<Entry, STACK> = Stack::new();
        let mut tnear = [0f32; WIDTH];
        let mut out = TriOut {
            t: [0.0; 2 * LANES],
            b1: [0.0; 2 * LANES],
            b2: [0.0; 2 * LANES],
        };
        let mut cur = 0u32;
        loop {
            if cur & LEAF == 0 {
                let node = self.nodes.get_unchecked(cur as usize);
                let mut mask = B::test(node, &br, t_max, &mut tnear);
                if mask != 0 {
                    let i0 = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        self.prefetch(node.child[i]);
                        stack.push(Entry {
                            code: node.child[i],
                            t: 0.0,
                        });
                    }
                    cur = node.child[i0];
                    continue;
                }
            } else if cur & ANALYTIC != 0 {
                if self.occluded_analytic(cur, ray, t_max) {
                    return true;
                }
            } else {
                let tr = tr.get(ray);
                let first = (cur & INDEX_MASK) as usize;
                let count = ((cur >> COUNT_SHIFT) & 7) as usize + 1;
                let end = first + count;
                let mut pi = first;
                while pi < end {
                    let packet = self.packets.as_ptr().add(pi);
                    let m = if pi + 1 < end {
                        pi += 2;
                        P::test2(packet, tr, t_max, &mut out)
                    } else {
                        pi += 1;
                        P::test(&*packet, tr, t_max, &mut out)
                    };
                    if m != 0 {
                        return true;
                    }
                }
            }
            match stack.pop() {
                None => return false,
                Some(e) => cur = e.code,
            }
        }
    }
}

impl Bvh {
    /// The closest-hit walk with the scalar tests (out of line: see `closest_sse2`).
    #[inline(never)]
    fn closest_scalar<const LAZY: bool>(&self, ray: &Ray) -> Option<Hit> {
        // SAFETY: the scalar tests need nothing.
        unsafe { self.closest::<Scalar, Scalar, LAZY>(ray) }
    }

    /// The any-hit walk with the scalar tests (out of line).
    #[inline(never)]
    fn any_hit_scalar<const LAZY: bool>(&self, ray: &Ray) -> bool {
        // SAFETY: the scalar tests need nothing.
        unsafe { self.any_hit::<Scalar, Scalar, LAZY>(ray) }
    }
}

/// Whether the ray can be traced: finite origin and direction, a non-zero direction and a
/// positive extent (the component tests as one vector comparison each).
#[inline(always)]
fn valid_ray(ray: &Ray) -> bool {
    let (o, d) = (Vec3A::from(ray.o), Vec3A::from(ray.d));
    let inf = Vec3A::splat(f32::INFINITY);
    // |x| < ∞ is false for ±∞ and NaN
    (o.abs().cmplt(inf) & d.abs().cmplt(inf)).all() && d.cmpne(Vec3A::ZERO).any() && ray.t_max > 0.0
}

/// Calls the walk (closest-hit or any-hit: its AVX2, SSE2 and scalar entry points) for the
/// tree's instruction set, in the variant that makes the triangle constants lazily or up
/// front (`Bvh::lazy`). Each variant is a function of its own: one function holding both
/// paid the larger one's prologue and register pressure on every ray.
macro_rules! walk {
    ($bvh:ident, $ray:ident, $avx2:ident, $sse2:ident, $scalar:ident) => {{
        let lazy = $bvh.lazy;
        match $bvh.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `set_isa` and `Isa::detect` only select AVX2 on CPUs with AVX2 and FMA.
            Isa::Avx2 if lazy => unsafe { $bvh.$avx2::<true>($ray) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: as above.
            Isa::Avx2 => unsafe { $bvh.$avx2::<false>($ray) },
            #[cfg(target_arch = "x86_64")]
            Isa::Sse2 if lazy => $bvh.$sse2::<true>($ray),
            #[cfg(target_arch = "x86_64")]
            Isa::Sse2 => $bvh.$sse2::<false>($ray),
            _ if lazy => $bvh.$scalar::<true>($ray),
            _ => $bvh.$scalar::<false>($ray),
        }
    }};
}

impl Intersector for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !valid_ray(ray) || self.nodes.is_empty() {
            return None;
        }
        walk!(self, ray, closest_avx2, closest_sse2, closest_scalar)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !valid_ray(ray) || self.nodes.is_empty() {
            return false;
        }
        walk!(self, ray, occluded_avx2, occluded_sse2, any_hit_scalar)
    }

    fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        #[cfg(target_arch = "x86_64")]
        if self.isa == Isa::Avx2
            && (2..=8).contains(&rays.len())
            && hits.len() >= rays.len()
            && !self.nodes.is_empty()
            // SAFETY: AVX2 and FMA are present (`isa`); 2 to 8 rays, as many hits, a tree.
            // It checks the rays' validity and octant itself, and writes nothing without.
            && unsafe {
                if self.lazy {
                    self.closest_packet_avx2::<true>(rays, hits)
                } else {
                    self.closest_packet_avx2::<false>(rays, hits)
                }
            }
        {
            return;
        }
        intersect_each(self, rays, hits);
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

/// The ray in an instance's group space (`local = m · p + t`); the parameter t is unchanged.
#[inline]
fn instance_ray(ray: &Ray, m: &Mat3, tr: Vec3, t_max: f32) -> Ray {
    Ray {
        o: *m * ray.o + tr,
        d: *m * ray.d,
        t_max,
    }
}

/// Ray/open cylinder (x² + y² = 1, 0 ≤ z ≤ 1 in object space), solved in double precision as
/// Mitsuba does on the CPU: the nearer root in (0, t_max) whose z lies in [0, 1].
#[inline]
fn intersect_cylinder(ray: &Ray, m: &Mat3, tr: Vec3, t_max: f32) -> Option<f32> {
    let o = (*m * ray.o + tr).as_dvec3();
    let d = (*m * ray.d).as_dvec3();
    let a = d.x * d.x + d.y * d.y;
    let b = 2.0 * (d.x * o.x + d.y * o.y);
    let c = o.x * o.x + o.y * o.y - 1.0;
    let disc = b * b - 4.0 * a * c;
    if a == 0.0 || disc.is_nan() || disc < 0.0 {
        return None;
    }
    let q = -0.5 * (b + disc.sqrt().copysign(b));
    let (r0, r1) = (q / a, c / q);
    let (x0, x1) = if r0 <= r1 { (r0, r1) } else { (r1, r0) };
    let tm = t_max as f64;
    for x in [x0, x1] {
        let z = o.z + d.z * x;
        if x > 0.0 && x < tm && (0.0..=1.0).contains(&z) {
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
