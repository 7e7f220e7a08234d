//! Ray intersection: one 8-wide BVH over every triangle, sphere and disk of the scene.
//!
//! **Structure.** A binary tree is built top-down with the surface area heuristic over
//! centroid bins along all three axes ([`build_tree`]): 32 bins per axis for ranges of more
//! than 1024 primitives, 16 down to 33 and 8 below ([`bins_for`]), the two halves of ranges
//! of at least 16 k primitives built in parallel (the same tree for any number of threads).
//! A range of at most 8 triangles is not split: it is one leaf. The build is O(n log n) on
//! any input: identical centroids and subtrees deeper than [`MAX_SAH_DEPTH`] are split at
//! the object median, and the heuristic is evaluated in double precision, so degenerate,
//! zero-area and huge-coordinate geometry build as fast as any other. The binary tree is
//! then collapsed into nodes of up to 8 children (greedily opening the child with the
//! largest surface area); [`Bvh::sah_cost`] gives the result's SAH cost.
//!
//! Each node stores its children's boxes as arrays of f32 (one array per plane), so one ray
//! is tested against all 8 boxes at once; subtrees of at most 8 triangles become leaves of one or two `TriPacket`s (4 triangles' vertices, one array per
//! coordinate), tested 4 at a time, or both packets as 8 lanes with AVX2 (leaves of 8 rather
//! than 4 triangles: one node level less, ~6 % faster on meshes.xml). Nodes and packets are
//! laid out depth-first. Closest-hit queries visit
//! the children nearest first and skip stacked subtrees that lie beyond the closest hit so far;
//! occlusion queries stop at the first hit.
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

use crate::core::{Hit, Ray};
use crate::geometry::{Geometry, ShapeGroup};
use glam::{DVec3, Mat3, Vec3, Vec3A};
use std::mem::MaybeUninit;
use std::sync::Arc;

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
/// Subtrees with at most this many triangles (and nothing else) become one leaf (2 packets).
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
        }
    }
}

/// Bound on |1/d| in box tests (a zero component gets +MAX_INV_DIR).
const MAX_INV_DIR: f32 = 1e18;
/// Box exit distances are scaled by this (a few ulps more than 1), so that rounding in the
/// slab test never culls a box the ray touches (Ize, *Robust BVH Ray Traversal*, JCGT 2013).
const EXIT_SCALE: f32 = 1.0 + 4.0 * f32::EPSILON;

/// A node of the binary build tree. A leaf holds one primitive, or up to [`LEAF_TRIS`]
/// triangles: the `count` entries of the build's primitive order from `kids[0]` on.
#[derive(Clone, Copy)]
struct BNode {
    lo: Vec3,
    hi: Vec3,
    /// Children (inner nodes), or `[first, NO_CHILD]` for a leaf (`first`: its first entry in
    /// the primitive order that [`build_tree`] returns).
    kids: [u32; 2],
    /// Primitives in the subtree.
    count: u32,
    /// Whether all of them are triangles.
    tris_only: bool,
}

const NO_CHILD: u32 = u32::MAX;

impl BNode {
    fn half_area(&self) -> f32 {
        let e = (self.hi - self.lo).max(Vec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
    fn is_leaf(&self) -> bool {
        self.kids[1] == NO_CHILD
    }
}

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
            pb.push(PrimBox::new(lo, hi, shape.is_none(), kept.len() as u32));
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
        let leaf_like = |b: &BNode| b.is_leaf() || (b.tris_only && b.count <= LEAF_TRIS);
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
            let mut kids: Vec<u32> = if leaf_like(&tree[b as usize]) {
                vec![b]
            } else {
                tree[b as usize].kids.to_vec()
            };
            while kids.len() < WIDTH {
                let best = kids
                    .iter()
                    .enumerate()
                    .filter(|(_, &k)| !leaf_like(&tree[k as usize]))
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
                if !leaf_like(kn) {
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
                debug_assert_eq!(pr.analytic, NOT_ANALYTIC, "packets hold triangles only");
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

/// Centroid bins per axis of the SAH build at most (see [`bins_for`]).
const BINS: usize = 32;
/// Centroid bins per axis for a range of `n` primitives: [`BINS`] above 1024, 16 down to
/// 33, 8 below. Small ranges leave most of 32 bins empty, and sweeping them costs as much as
/// binning the primitives: with fewer bins the build of meshes.xml takes ~9 % fewer
/// instructions, and the trees' SAH cost ([`Bvh::sah_cost`]) hardly changes (meshes.xml
/// 8.2156 → 8.2195, bsdf_roughplastic_nopreserve 5.5015 → 5.4407).
fn bins_for(n: usize) -> usize {
    if n <= 32 {
        8
    } else if n <= 1024 {
        16
    } else {
        BINS
    }
}

/// Subtrees deeper than this are split at the object median rather than by the surface area
/// heuristic, which bounds the build at O(n log n) even where the heuristic keeps splitting
/// off one primitive at a time (exponentially spaced geometry); ordinary scenes of millions
/// of triangles stay well above it.
const MAX_SAH_DEPTH: u32 = 48;

/// Surface area (halved) of a box, in double precision (no overflow for huge boxes).
fn half_area_f64(lo: Vec3, hi: Vec3) -> f64 {
    let e = (hi.as_dvec3() - lo.as_dvec3()).max(DVec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// What the build reads of a primitive, in half a cache line: its (padded) box, with its
/// index (the bits of `lo[3]`) and whether it is a triangle (`hi[3]` 1 or 0) in the boxes'
/// fourth lanes, so that each corner is one aligned 16-byte load. The box's centroid, in
/// double precision as the bins are placed, is computed from the corners where it is needed
/// (the same bits every time: f32 → f64 is exact). The build partitions these records
/// themselves (not indices to them), so each node's primitives lie consecutively in memory;
/// 32 bytes a record instead of 64 with a stored centroid halve both the build's memory
/// traffic and its peak memory (32 MB less for a million triangles).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct PrimBox {
    lo: [f32; 4],
    hi: [f32; 4],
}

/// The smaller of two centroids, per axis (no NaN is ever built: `f64::min` without its NaN
/// handling).
#[inline]
fn dmin(a: DVec3, b: DVec3) -> DVec3 {
    let m = |x: f64, y: f64| if y < x { y } else { x };
    DVec3::new(m(a.x, b.x), m(a.y, b.y), m(a.z, b.z))
}

/// The larger of two centroids, per axis (see [`dmin`]).
#[inline]
fn dmax(a: DVec3, b: DVec3) -> DVec3 {
    let m = |x: f64, y: f64| if y > x { y } else { x };
    DVec3::new(m(a.x, b.x), m(a.y, b.y), m(a.z, b.z))
}

impl PrimBox {
    /// The record of a primitive with the (padded, finite) box `lo..hi`.
    #[inline]
    fn new(lo: Vec3, hi: Vec3, tri: bool, index: u32) -> PrimBox {
        PrimBox {
            lo: [lo.x, lo.y, lo.z, f32::from_bits(index)],
            hi: [hi.x, hi.y, hi.z, if tri { 1.0 } else { 0.0 }],
        }
    }

    /// A corner as a SIMD vector (its fourth lane carries the record's extra data, which
    /// `Vec3A` arithmetic never mixes into x, y, z).
    #[inline(always)]
    fn corner(c: &[f32; 4]) -> Vec3A {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE2 is part of the x86-64 baseline; `c` is 16-byte aligned (the
            // record is 32-byte aligned and its corners lie at offsets 0 and 16)
            unsafe { Vec3A::from(std::arch::x86_64::_mm_load_ps(c.as_ptr())) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Vec3A::new(c[0], c[1], c[2])
        }
    }

    #[inline(always)]
    fn lo(&self) -> Vec3A {
        Self::corner(&self.lo)
    }

    #[inline(always)]
    fn hi(&self) -> Vec3A {
        Self::corner(&self.hi)
    }

    /// The box's centroid along `axis`.
    #[inline(always)]
    fn c_axis(&self, axis: usize) -> f64 {
        (self.lo[axis] as f64 + self.hi[axis] as f64) * 0.5
    }

    /// The box's centroid.
    #[inline(always)]
    fn c(&self) -> DVec3 {
        DVec3::new(self.c_axis(0), self.c_axis(1), self.c_axis(2))
    }

    #[inline(always)]
    fn tri(&self) -> bool {
        self.hi[3] != 0.0
    }

    #[inline(always)]
    fn index(&self) -> u32 {
        self.lo[3].to_bits()
    }
}

/// [`build_tree`] over `boxes` (finite; `tris[i]`: whether primitive i is a triangle).
#[cfg(test)]
fn build_binary(boxes: &[(Vec3, Vec3)], tris: &[bool]) -> (Vec<BNode>, Vec<u32>) {
    let mut pb: Vec<PrimBox> = boxes
        .iter()
        .zip(tris)
        .enumerate()
        .map(|(i, (&(lo, hi), &tri))| PrimBox::new(lo, hi, tri, i as u32))
        .collect();
    build_tree(&mut pb)
}

/// The binary build tree over the primitives' build records (at least one), root first,
/// parents before children, counts filled in, and the primitives in the order its leaves
/// refer to. Leaves hold one primitive, or a range of at most [`LEAF_TRIS`] triangles (which
/// `collapse` makes one leaf anyway: it is not split further), listed depth-first, first
/// child first. The build writes into 2n − 1 slots (a subtree of m primitives owns 2m − 1
/// consecutive ones, so parallel parts write disjoint slices) that are never initialised
/// beforehand: the slots after a subtree's last node (most of them, since leaves hold up to
/// [`LEAF_TRIS`] triangles) are never written, so their memory is never touched (a fresh
/// allocation of that size is mapped lazily), and the nodes are then copied out in order.
/// Each node's primitive count and triangles-only flag are known when it is made (its range
/// and that range's bounds), so no pass over the slots sums them.
///
/// Top-down binned SAH: each node bins its primitives' centroids into [`bins_for`] slots
/// along each axis of the centroid bounds and splits at the cheapest bin boundary (cost: area ×
/// count on each side). Primitives whose centroids coincide, and subtrees deeper than
/// [`MAX_SAH_DEPTH`], are split at the object median; every split is a partition of an index
/// range, so the whole build is O(n log n) with an explicit stack (no recursion).
fn build_tree(pb: &mut [PrimBox]) -> (Vec<BNode>, Vec<u32>) {
    let n = pb.len();
    // a binary tree with one primitive per leaf has 2n − 1 nodes, and each subtree of m
    // primitives at most 2m − 1 (root first): every part of the build writes its own slice
    // of one array
    let mut slots: Box<[MaybeUninit<BNode>]> = Box::new_uninit_slice(2 * n - 1);
    build_range(pb, 0, None, 0, &mut slots, 0);
    // the nodes reachable from the root, depth-first: (slot, parent in `tree`, which child)
    let mut tree: Vec<BNode> = Vec::with_capacity(n.div_ceil(2));
    let mut todo: Vec<(u32, u32, usize)> = vec![(0, NO_CHILD, 0)];
    while let Some((slot, parent, which)) = todo.pop() {
        // SAFETY: the root's slot and every slot a written node names as a child were
        // written by `build_range` (a node is written before its children are made, and
        // each child's slot is set in its parent when the child is written)
        let node = unsafe { slots[slot as usize].assume_init_read() };
        let index = tree.len() as u32;
        if parent != NO_CHILD {
            tree[parent as usize].kids[which] = index;
        }
        tree.push(node);
        if !node.is_leaf() {
            todo.push((node.kids[1], index, 1));
            todo.push((node.kids[0], index, 0));
        }
    }
    (tree, pb.iter().map(PrimBox::index).collect())
}

/// Ranges at least this large build their two halves in parallel.
const PARALLEL_BUILD: usize = 1 << 14;

/// The box bounds (`lo..hi`) and centroid bounds (`clo..chi`) of a set of primitives. Boxes
/// and centroids are finite and never −0 (boxes are padded away from their coordinates), so
/// these minima and maxima are the same bits whatever order the primitives come in.
#[derive(Clone, Copy, Debug)]
struct RangeBounds {
    lo: Vec3A,
    hi: Vec3A,
    clo: DVec3,
    chi: DVec3,
    /// Whether every primitive is a triangle.
    tris: bool,
}

impl RangeBounds {
    const EMPTY: RangeBounds = RangeBounds {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        clo: DVec3::INFINITY,
        chi: DVec3::NEG_INFINITY,
        tris: true,
    };

    #[inline]
    fn add(&mut self, p: &PrimBox) {
        self.lo = self.lo.min(p.lo());
        self.hi = self.hi.max(p.hi());
        let c = p.c();
        self.clo = dmin(self.clo, c);
        self.chi = dmax(self.chi, c);
        self.tris &= p.tri();
    }

    fn of(range: &[PrimBox]) -> RangeBounds {
        let mut b = RangeBounds::EMPTY;
        for p in range {
            b.add(p);
        }
        b
    }
}

/// How a node's range is split: the length of the first part and, when the split computed
/// them on the way, the bounds of both parts.
type Split = (usize, Option<[RangeBounds; 2]>);

/// The node over `range` (at least one primitive, the first at `first` in the primitive
/// order; `bounds` its bounds when known) and its split; a single primitive, or at most
/// [`LEAF_TRIS`] triangles, give a leaf and no split.
fn node_and_split(
    range: &mut [PrimBox],
    first: u32,
    bounds: Option<RangeBounds>,
    depth: u32,
) -> (BNode, Option<Split>) {
    if range.len() == 1 {
        let b = &range[0];
        let leaf = BNode {
            lo: b.lo().into(),
            hi: b.hi().into(),
            kids: [first, NO_CHILD],
            count: 1,
            tris_only: b.tri(),
        };
        return (leaf, None);
    }
    let RangeBounds {
        lo,
        hi,
        clo,
        chi,
        tris,
    } = bounds.unwrap_or_else(|| RangeBounds::of(range));
    // A range of at most LEAF_TRIS triangles becomes one leaf (see `collapse`) as it stands.
    if range.len() <= LEAF_TRIS as usize && tris {
        let leaf = BNode {
            lo: lo.into(),
            hi: hi.into(),
            kids: [first, NO_CHILD],
            count: range.len() as u32,
            tris_only: true,
        };
        return (leaf, None);
    }
    let node = BNode {
        lo: lo.into(),
        hi: hi.into(),
        kids: [NO_CHILD, NO_CHILD],
        count: range.len() as u32,
        tris_only: tris,
    };
    let split = split(range, clo, chi, depth);
    (node, Some(split))
}

/// The binary tree over the primitives `range` (root first, then the first part's subtree,
/// then the second's; `first` the position of `range[0]` in the whole primitive order,
/// `bounds` the range's bounds when known), written to `out` (its 2·len − 1 slots, the
/// last ones left unused where leaves hold several triangles; `base` is the index of
/// `out[0]` in the whole tree, which child indices refer to). Large ranges build their halves
/// in parallel; the tree is the same whatever the number of threads.
fn build_range(
    range: &mut [PrimBox],
    first: u32,
    bounds: Option<RangeBounds>,
    depth: u32,
    out: &mut [MaybeUninit<BNode>],
    base: u32,
) {
    debug_assert_eq!(out.len(), 2 * range.len() - 1);
    if range.len() >= PARALLEL_BUILD {
        let (mut node, split) = node_and_split(range, first, bounds, depth);
        let (mid, parts) = split.expect("a large range splits");
        let [ba, bb] = parts.map_or([None, None], |[a, b]| [Some(a), Some(b)]);
        let (a, b) = range.split_at_mut(mid);
        let (root, rest) = out.split_at_mut(1);
        let (oa, ob) = rest.split_at_mut(2 * mid - 1);
        let second = base + 1 + oa.len() as u32;
        node.kids = [base + 1, second];
        root[0].write(node);
        rayon::join(
            || build_range(a, first, ba, depth + 1, oa, base + 1),
            || build_range(b, first + mid as u32, bb, depth + 1, ob, second),
        );
        return;
    }
    let mut next = 0usize;
    // (first, end, parent, which child, depth, bounds)
    let mut todo: Vec<(usize, usize, u32, usize, u32, Option<RangeBounds>)> =
        vec![(0, range.len(), NO_CHILD, 0, depth, bounds)];
    while let Some((s, e, parent, which, depth, bounds)) = todo.pop() {
        let index = next;
        if parent != NO_CHILD {
            // SAFETY: a parent is written before its children are queued
            unsafe { out[parent as usize].assume_init_mut() }.kids[which] = base + index as u32;
        }
        let (node, split) = node_and_split(&mut range[s..e], first + s as u32, bounds, depth);
        out[index].write(node);
        next += 1;
        if let Some((mid, parts)) = split {
            let [ba, bb] = parts.map_or([None, None], |[a, b]| [Some(a), Some(b)]);
            todo.push((s + mid, e, index as u32, 1, depth + 1, bb));
            todo.push((s, s + mid, index as u32, 0, depth + 1, ba));
        }
    }
    debug_assert!(next <= out.len());
}

/// A centroid bin of the SAH build: the bounds of its primitives' boxes and their number.
#[derive(Clone, Copy)]
struct Bin {
    lo: Vec3A,
    hi: Vec3A,
    n: u32,
}

impl Bin {
    const EMPTY: Bin = Bin {
        lo: Vec3A::INFINITY,
        hi: Vec3A::NEG_INFINITY,
        n: 0,
    };
}

/// Reorders `range` (at least 2 primitives, centroid bounds `clo..chi`) into two non-empty
/// parts: the length of the first and, for a SAH split, the bounds of both.
fn split(range: &mut [PrimBox], clo: DVec3, chi: DVec3, depth: u32) -> Split {
    let ext = chi - clo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let median = |range: &mut [PrimBox]| {
        let m = range.len() / 2;
        if ext[axis] > 0.0 {
            range.select_nth_unstable_by(m, |a, b| a.c_axis(axis).total_cmp(&b.c_axis(axis)));
        }
        (m, None)
    };
    // (`ext[axis] <= 0.0` would let a NaN extent through)
    if ext[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || depth >= MAX_SAH_DEPTH {
        return median(range);
    }
    // (the same quotient whether computed here or per primitive)
    let nb = bins_for(range.len());
    let scale: [f64; 3] = std::array::from_fn(|a| nb as f64 / ext[a]);
    // (`as i64` then clamped: the same bin as `as usize` then `min(BINS − 1)` for every
    // value, NaN included, in fewer instructions)
    let bin_of = |c: f64, a: usize| -> usize {
        let k = ((c - clo[a]) * scale[a]) as i64;
        k.clamp(0, nb as i64 - 1) as usize
    };
    // best (cost, axis, first bin of the right side)
    let mut best = (f64::INFINITY, usize::MAX, 0usize);
    // one pass over the primitives bins them along all three axes
    let mut bins = [[Bin::EMPTY; BINS]; 3];
    let live: [bool; 3] =
        std::array::from_fn(|a| ext[a].partial_cmp(&0.0) == Some(std::cmp::Ordering::Greater));
    let mut add = |a: usize, p: &PrimBox| {
        let b = &mut bins[a][bin_of(p.c_axis(a), a)];
        b.lo = b.lo.min(p.lo());
        b.hi = b.hi.max(p.hi());
        b.n += 1;
    };
    if live == [true; 3] {
        #[cfg(target_arch = "x86_64")]
        {
            // the x and y bins of a centroid in one SSE2 operation each: the same
            // subtraction and product as `bin_of`, truncated to i32, which equals its i64
            // truncation here: centroids are means of f32 coordinates, so a positive
            // extent is at least 2⁻¹⁵⁰, the scale is finite and every product lies in
            // [0, BINS] (a little above at most: clamped)
            // (the centroid's x and y as `PrimBox::c_axis` computes them: both corners
            // widened exactly to f64, added, halved)
            use std::arch::x86_64::{
                _mm_add_pd, _mm_cvtps_pd, _mm_cvtsi128_si32, _mm_cvttpd_epi32, _mm_load_ps,
                _mm_mul_pd, _mm_set1_pd, _mm_set_pd, _mm_shuffle_epi32, _mm_sub_pd,
            };
            // SAFETY (each block): SSE2 is part of the x86-64 baseline; the corners are
            // 16-byte aligned (see `PrimBox::corner`)
            let (clo_xy, scale_xy, half) = unsafe {
                (
                    _mm_set_pd(clo.y, clo.x),
                    _mm_set_pd(scale[1], scale[0]),
                    _mm_set1_pd(0.5),
                )
            };
            let clamp = |k: i32| k.clamp(0, nb as i32 - 1) as usize;
            for p in range.iter() {
                let (kx, ky) = unsafe {
                    let lo = _mm_cvtps_pd(_mm_load_ps(p.lo.as_ptr()));
                    let hi = _mm_cvtps_pd(_mm_load_ps(p.hi.as_ptr()));
                    let c = _mm_mul_pd(_mm_add_pd(lo, hi), half);
                    let xy = _mm_mul_pd(_mm_sub_pd(c, clo_xy), scale_xy);
                    let k = _mm_cvttpd_epi32(xy);
                    (
                        _mm_cvtsi128_si32(k),
                        _mm_cvtsi128_si32(_mm_shuffle_epi32::<1>(k)),
                    )
                };
                let (kx, ky) = (clamp(kx), clamp(ky));
                let kz = clamp(((p.c_axis(2) - clo.z) * scale[2]) as i32);
                let (plo, phi) = (p.lo(), p.hi());
                for (b, k) in [(0, kx), (1, ky), (2, kz)] {
                    let b = &mut bins[b][k];
                    b.lo = b.lo.min(plo);
                    b.hi = b.hi.max(phi);
                    b.n += 1;
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        for p in range.iter() {
            add(0, p);
            add(1, p);
            add(2, p);
        }
    } else {
        for p in range.iter() {
            for (a, &on) in live.iter().enumerate() {
                if on {
                    add(a, p);
                }
            }
        }
    }
    for (a, bins) in bins.iter().enumerate() {
        if !live[a] {
            continue;
        }
        // right-to-left sweep: cost of the right side starting at bin k (NaN: empty); an
        // empty bin changes nothing, so its cost is the one after it, bit for bit
        let mut right = [0.0f64; BINS];
        let (mut rlo, mut rhi, mut rn) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY, 0u32);
        let mut cost_right = f64::NAN;
        for k in (1..nb).rev() {
            if bins[k].n > 0 {
                rlo = rlo.min(bins[k].lo);
                rhi = rhi.max(bins[k].hi);
                rn += bins[k].n;
                cost_right = half_area_f64(rlo.into(), rhi.into()) * rn as f64;
            }
            right[k] = cost_right;
        }
        let (mut llo, mut lhi, mut ln) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY, 0u32);
        for k in 1..nb {
            // after an empty bin both sides are those of the boundary before it: the same
            // cost, which cannot be strictly better (small nodes leave most bins empty)
            if bins[k - 1].n == 0 {
                continue;
            }
            llo = llo.min(bins[k - 1].lo);
            lhi = lhi.max(bins[k - 1].hi);
            ln += bins[k - 1].n;
            if ln == 0 || right[k].is_nan() {
                continue;
            }
            let cost = half_area_f64(llo.into(), lhi.into()) * ln as f64 + right[k];
            if cost < best.0 {
                best = (cost, a, k);
            }
        }
    }
    if best.1 == usize::MAX {
        return median(range);
    }
    let (_, a, k) = best;
    // partition: bins below k first; the bounds of both parts on the way (their nodes need
    // them: one pass over the primitives fewer per level)
    let mut m = 0;
    let mut parts = [RangeBounds::EMPTY; 2];
    for j in 0..range.len() {
        let p = &range[j];
        if bin_of(p.c_axis(a), a) < k {
            parts[0].add(p);
            range.swap(m, j);
            m += 1;
        } else {
            parts[1].add(p);
        }
    }
    if m == 0 || m == range.len() {
        // cannot happen (both sides counted non-empty), but never build an endless loop
        return median(range);
    }
    (m, Some(parts))
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
        let dz = d[kz];
        let [kx, ky] = K[kz][(dz < 0.0) as usize];
        TriRay {
            o: ray.o,
            k: [kx, ky, kz],
            ok: [ray.o[kx], ray.o[ky], ray.o[kz]],
            s: Vec3::new(d[kx] / dz, d[ky] / dz, 1.0 / dz),
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

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::*;
    use std::arch::x86_64::*;

    /// SSE2: two 4-wide halves of each node, 4-wide triangle packets.
    pub(super) struct Sse2;
    /// AVX2 + FMA: one 8-wide box test (the triangle test is the SSE2 one, VEX-encoded).
    pub(super) struct Avx2;

    // No closures here: a closure does not inherit the target features of the function it is
    // defined in, so the intrinsics it calls would not be inlined into the AVX2 entry points.

    impl BoxTest for Sse2 {
        #[inline(always)]
        unsafe fn test(n: &Node, r: &BoxRay, t_max: f32, tnear: &mut [f32; WIDTH]) -> u32 {
            let b = n.b.as_ptr() as *const f32;
            let zero = _mm_setzero_ps();
            let scale = _mm_set1_ps(EXIT_SCALE);
            let tmax = _mm_set1_ps(t_max);
            let (ox, oy, oz) = (
                _mm_set1_ps(r.o[0]),
                _mm_set1_ps(r.o[1]),
                _mm_set1_ps(r.o[2]),
            );
            let (ix, iy, iz) = (
                _mm_set1_ps(r.inv[0]),
                _mm_set1_ps(r.inv[1]),
                _mm_set1_ps(r.inv[2]),
            );
            let mut mask = 0;
            for h in [0, 4] {
                macro_rules! slab {
                    ($plane:expr, $o:expr, $i:expr) => {
                        _mm_mul_ps(_mm_sub_ps(_mm_load_ps(b.add($plane + h)), $o), $i)
                    };
                }
                let t0 = _mm_max_ps(
                    _mm_max_ps(
                        _mm_max_ps(slab!(r.near_at[0], ox, ix), slab!(r.near_at[1], oy, iy)),
                        slab!(r.near_at[2], oz, iz),
                    ),
                    zero,
                );
                let t1 = _mm_min_ps(
                    _mm_mul_ps(
                        _mm_min_ps(
                            _mm_min_ps(slab!(r.far_at[0], ox, ix), slab!(r.far_at[1], oy, iy)),
                            slab!(r.far_at[2], oz, iz),
                        ),
                        scale,
                    ),
                    tmax,
                );
                _mm_storeu_ps(tnear.as_mut_ptr().add(h), t0);
                mask |= (_mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32) << h;
            }
            mask
        }
    }

    impl BoxTest for Avx2 {
        #[inline(always)]
        unsafe fn test(n: &Node, r: &BoxRay, t_max: f32, tnear: &mut [f32; WIDTH]) -> u32 {
            let b = n.b.as_ptr() as *const f32;
            // t = p·(1/d) − o·(1/d) in one fused operation; the exit distances get the
            // EXIT_SCALE widening folded into the factors. The reductions are balanced trees:
            // the box test is on the critical path of every node visit.
            macro_rules! slab {
                ($plane:expr, $a:expr, $s:expr) => {
                    _mm256_fmsub_ps(
                        _mm256_load_ps(b.add($plane)),
                        _mm256_set1_ps(r.inv[$a] * $s),
                        _mm256_set1_ps(r.o[$a] * r.inv[$a] * $s),
                    )
                };
            }
            let t0 = _mm256_max_ps(
                _mm256_max_ps(slab!(r.near_at[0], 0, 1.0), slab!(r.near_at[1], 1, 1.0)),
                _mm256_max_ps(slab!(r.near_at[2], 2, 1.0), _mm256_setzero_ps()),
            );
            let t1 = _mm256_min_ps(
                _mm256_min_ps(
                    slab!(r.far_at[0], 0, EXIT_SCALE),
                    slab!(r.far_at[1], 1, EXIT_SCALE),
                ),
                _mm256_min_ps(slab!(r.far_at[2], 2, EXIT_SCALE), _mm256_set1_ps(t_max)),
            );
            _mm256_storeu_ps(tnear.as_mut_ptr(), t0);
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
        }
    }

    impl PacketTest for Sse2 {
        #[inline(always)]
        unsafe fn test(p: &TriPacket, tr: &TriRay, t_max: f32, out: &mut TriOut) -> u32 {
            let zero = _mm_setzero_ps();
            let [kx, ky, kz] = tr.k;
            let (ox, oy, oz) = (
                _mm_set1_ps(tr.ok[0]),
                _mm_set1_ps(tr.ok[1]),
                _mm_set1_ps(tr.ok[2]),
            );
            macro_rules! rel {
                ($v:expr) => {
                    (
                        _mm_sub_ps(_mm_load_ps(p.v[$v][kx].as_ptr()), ox),
                        _mm_sub_ps(_mm_load_ps(p.v[$v][ky].as_ptr()), oy),
                        _mm_sub_ps(_mm_load_ps(p.v[$v][kz].as_ptr()), oz),
                    )
                };
            }
            let (sx, sy, sz) = (
                _mm_set1_ps(tr.s.x),
                _mm_set1_ps(tr.s.y),
                _mm_set1_ps(tr.s.z),
            );
            let (a_x, a_y, a_z) = rel!(0);
            let (b_x, b_y, b_z) = rel!(1);
            let (c_x, c_y, c_z) = rel!(2);
            let ax = _mm_sub_ps(a_x, _mm_mul_ps(sx, a_z));
            let ay = _mm_sub_ps(a_y, _mm_mul_ps(sy, a_z));
            let bx = _mm_sub_ps(b_x, _mm_mul_ps(sx, b_z));
            let by = _mm_sub_ps(b_y, _mm_mul_ps(sy, b_z));
            let cx = _mm_sub_ps(c_x, _mm_mul_ps(sx, c_z));
            let cy = _mm_sub_ps(c_y, _mm_mul_ps(sy, c_z));
            let mut u = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
            let mut v = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
            let mut w = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
            let zeros = _mm_or_ps(
                _mm_or_ps(_mm_cmpeq_ps(u, zero), _mm_cmpeq_ps(v, zero)),
                _mm_cmpeq_ps(w, zero),
            );
            let zm = _mm_movemask_ps(zeros);
            if zm != 0 {
                let mut e = [[0f32; 4]; 9];
                for (k, x) in [ax, ay, bx, by, cx, cy, u, v, w].iter().enumerate() {
                    _mm_storeu_ps(e[k].as_mut_ptr(), *x);
                }
                exact_edges(zm, &mut e);
                u = _mm_loadu_ps(e[6].as_ptr());
                v = _mm_loadu_ps(e[7].as_ptr());
                w = _mm_loadu_ps(e[8].as_ptr());
            }
            // some edge function negative and some positive: the ray passes outside
            let neg = _mm_cmplt_ps(_mm_min_ps(_mm_min_ps(u, v), w), zero);
            let pos = _mm_cmpgt_ps(_mm_max_ps(_mm_max_ps(u, v), w), zero);
            let det = _mm_add_ps(_mm_add_ps(u, v), w);
            let az = _mm_mul_ps(sz, a_z);
            let bz = _mm_mul_ps(sz, b_z);
            let cz = _mm_mul_ps(sz, c_z);
            let t_scaled = _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(u, az), _mm_mul_ps(v, bz)),
                _mm_mul_ps(w, cz),
            );
            let inv_det = _mm_div_ps(_mm_set1_ps(1.0), det);
            let t = _mm_mul_ps(t_scaled, inv_det);
            let ok = _mm_and_ps(
                _mm_and_ps(_mm_cmpneq_ps(det, zero), _mm_cmpgt_ps(t, zero)),
                _mm_cmplt_ps(t, _mm_set1_ps(t_max)),
            );
            let mask = _mm_movemask_ps(_mm_andnot_ps(_mm_and_ps(neg, pos), ok)) as u32;
            _mm_store_ps(out.t.as_mut_ptr(), t);
            _mm_store_ps(out.b1.as_mut_ptr(), _mm_mul_ps(v, inv_det));
            _mm_store_ps(out.b2.as_mut_ptr(), _mm_mul_ps(w, inv_det));
            mask
        }
    }

    impl PacketTest for Avx2 {
        #[inline(always)]
        unsafe fn test(p: &TriPacket, tr: &TriRay, t_max: f32, out: &mut TriOut) -> u32 {
            <Sse2 as PacketTest>::test(p, tr, t_max, out)
        }

        /// The SSE2 test on 8 lanes: the same operations, lane by lane.
        #[inline(always)]
        unsafe fn test2(p: *const TriPacket, tr: &TriRay, t_max: f32, out: &mut TriOut) -> u32 {
            let (p0, p1) = (&*p, &*p.add(1));
            let zero = _mm256_setzero_ps();
            let [kx, ky, kz] = tr.k;
            let (ox, oy, oz) = (
                _mm256_set1_ps(tr.ok[0]),
                _mm256_set1_ps(tr.ok[1]),
                _mm256_set1_ps(tr.ok[2]),
            );
            macro_rules! ld {
                ($v:expr, $k:expr) => {
                    _mm256_set_m128(
                        _mm_load_ps(p1.v[$v][$k].as_ptr()),
                        _mm_load_ps(p0.v[$v][$k].as_ptr()),
                    )
                };
            }
            macro_rules! rel {
                ($v:expr) => {
                    (
                        _mm256_sub_ps(ld!($v, kx), ox),
                        _mm256_sub_ps(ld!($v, ky), oy),
                        _mm256_sub_ps(ld!($v, kz), oz),
                    )
                };
            }
            let (sx, sy, sz) = (
                _mm256_set1_ps(tr.s.x),
                _mm256_set1_ps(tr.s.y),
                _mm256_set1_ps(tr.s.z),
            );
            let (a_x, a_y, a_z) = rel!(0);
            let (b_x, b_y, b_z) = rel!(1);
            let (c_x, c_y, c_z) = rel!(2);
            let ax = _mm256_sub_ps(a_x, _mm256_mul_ps(sx, a_z));
            let ay = _mm256_sub_ps(a_y, _mm256_mul_ps(sy, a_z));
            let bx = _mm256_sub_ps(b_x, _mm256_mul_ps(sx, b_z));
            let by = _mm256_sub_ps(b_y, _mm256_mul_ps(sy, b_z));
            let cx = _mm256_sub_ps(c_x, _mm256_mul_ps(sx, c_z));
            let cy = _mm256_sub_ps(c_y, _mm256_mul_ps(sy, c_z));
            let mut u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
            let mut v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
            let mut w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
            let zeros = _mm256_or_ps(
                _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_EQ_OQ>(u, zero),
                    _mm256_cmp_ps::<_CMP_EQ_OQ>(v, zero),
                ),
                _mm256_cmp_ps::<_CMP_EQ_OQ>(w, zero),
            );
            let zm = _mm256_movemask_ps(zeros);
            if zm != 0 {
                let mut e = [[0f32; 8]; 9];
                for (k, x) in [ax, ay, bx, by, cx, cy, u, v, w].iter().enumerate() {
                    _mm256_storeu_ps(e[k].as_mut_ptr(), *x);
                }
                exact_edges(zm, &mut e);
                u = _mm256_loadu_ps(e[6].as_ptr());
                v = _mm256_loadu_ps(e[7].as_ptr());
                w = _mm256_loadu_ps(e[8].as_ptr());
            }
            let neg = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_min_ps(_mm256_min_ps(u, v), w), zero);
            let pos = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_max_ps(_mm256_max_ps(u, v), w), zero);
            let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
            let az = _mm256_mul_ps(sz, a_z);
            let bz = _mm256_mul_ps(sz, b_z);
            let cz = _mm256_mul_ps(sz, c_z);
            let t_scaled = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(u, az), _mm256_mul_ps(v, bz)),
                _mm256_mul_ps(w, cz),
            );
            let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
            let t = _mm256_mul_ps(t_scaled, inv_det);
            let ok = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero),
                    _mm256_cmp_ps::<_CMP_GT_OQ>(t, zero),
                ),
                _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(t_max)),
            );
            let mask = _mm256_movemask_ps(_mm256_andnot_ps(_mm256_and_ps(neg, pos), ok)) as u32;
            _mm256_storeu_ps(out.t.as_mut_ptr(), t);
            _mm256_storeu_ps(out.b1.as_mut_ptr(), _mm256_mul_ps(v, inv_det));
            _mm256_storeu_ps(out.b2.as_mut_ptr(), _mm256_mul_ps(w, inv_det));
            mask
        }
    }

    /// `e` = (ax, ay, bx, by, cx, cy, u, v, w) per lane (4 for SSE2, 8 for AVX2): recomputes
    /// u, v, w of the lanes in `lanes` in double precision.
    #[cold]
    #[inline(never)]
    #[allow(clippy::needless_range_loop)]
    fn exact_edges<const N: usize>(lanes: i32, e: &mut [[f32; N]; 9]) {
        for lane in 0..N {
            if lanes & (1 << lane) != 0 {
                let (u, v, w) = edge_functions_f64(
                    e[0][lane], e[1][lane], e[2][lane], e[3][lane], e[4][lane], e[5][lane],
                );
                (e[6][lane], e[7][lane], e[8][lane]) = (u, v, w);
            }
        }
    }

    impl Bvh {
        pub(super) fn closest_sse2(&self, ray: &Ray) -> Option<Hit> {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { self.closest::<Sse2, Sse2>(ray) }
        }
        pub(super) fn occluded_sse2(&self, ray: &Ray) -> bool {
            // SAFETY: SSE2 is part of x86-64.
            unsafe { self.any_hit::<Sse2, Sse2>(ray) }
        }
        /// # Safety
        /// The CPU must support AVX2 and FMA.
        #[target_feature(enable = "avx2,fma")]
        pub(super) unsafe fn closest_avx2(&self, ray: &Ray) -> Option<Hit> {
            self.closest::<Avx2, Avx2>(ray)
        }
        /// # Safety
        /// The CPU must support AVX2 and FMA.
        #[target_feature(enable = "avx2,fma")]
        pub(super) unsafe fn occluded_avx2(&self, ray: &Ray) -> bool {
            self.any_hit::<Avx2, Avx2>(ray)
        }

        /// Closest hits of up to 8 rays that share a direction octant (`BoxRay::near_at`
        /// equal), walked as one packet: each node's 8 boxes are tested against all rays at
        /// once (one ray per lane), the stack holds a child with the rays that entered it and
        /// where, and a leaf is tested by each of its rays with the single-ray test. The
        /// per-ray arithmetic is that of `closest_avx2`, so the hits are the same.
        ///
        /// # Safety
        /// The CPU must support AVX2 and FMA; `rays` holds 1 to 8 valid rays, `hits` as many.
        #[target_feature(enable = "avx2,fma")]
        pub(super) unsafe fn closest_packet_avx2(
            &self,
            rays: &[Ray],
            brs: &[BoxRay; 8],
            hits: &mut [Option<Hit>],
        ) {
            let n = rays.len();
            let all = (1u32 << n) - 1;
            // per-lane factors of the slab test (lanes ≥ n copy lane 0 and stay inactive)
            let mut f = [[0f32; 8]; 12];
            for lane in 0..8 {
                let r = &brs[lane.min(n - 1)];
                for a in 0..3 {
                    f[a][lane] = r.inv[a];
                    f[3 + a][lane] = r.o[a] * r.inv[a];
                    f[6 + a][lane] = r.inv[a] * EXIT_SCALE;
                    f[9 + a][lane] = r.o[a] * r.inv[a] * EXIT_SCALE;
                }
            }
            macro_rules! ld {
                ($k:expr) => {
                    _mm256_loadu_ps(f[$k].as_ptr())
                };
            }
            let (inx, iny, inz) = (ld!(0), ld!(1), ld!(2));
            let (onx, ony, onz) = (ld!(3), ld!(4), ld!(5));
            let (ifx, ify, ifz) = (ld!(6), ld!(7), ld!(8));
            let (ofx, ofy, ofz) = (ld!(9), ld!(10), ld!(11));
            let (near, far) = (brs[0].near_at, brs[0].far_at);
            let trs: [TriRay; 8] = std::array::from_fn(|i| TriRay::new(&rays[i.min(n - 1)]));
            let mut t_max = [0f32; 8];
            for (lane, t) in t_max.iter_mut().enumerate() {
                *t = rays[lane.min(n - 1)].t_max;
            }
            let mut best: [Best; 8] = [None; 8];
            let mut out = TriOut {
                t: [0.0; 2 * LANES],
                b1: [0.0; 2 * LANES],
                b2: [0.0; 2 * LANES],
            };
            let mut stack: Stack<PacketEntry, 96> = Stack::new();
            let mut kids = [PacketEntry::EMPTY; WIDTH];
            let zero = _mm256_setzero_ps();
            let (mut cur, mut active) = (0u32, all);
            'walk: loop {
                if cur & LEAF == 0 {
                    let node = self.nodes.get_unchecked(cur as usize);
                    let b = node.b.as_ptr() as *const f32;
                    let tmax = _mm256_loadu_ps(t_max.as_ptr());
                    let mut k = 0;
                    for c in 0..WIDTH {
                        macro_rules! bc {
                            ($plane:expr) => {
                                _mm256_broadcast_ss(&*b.add($plane + c))
                            };
                        }
                        let t0 = _mm256_max_ps(
                            _mm256_max_ps(
                                _mm256_fmsub_ps(bc!(near[0]), inx, onx),
                                _mm256_fmsub_ps(bc!(near[1]), iny, ony),
                            ),
                            _mm256_max_ps(_mm256_fmsub_ps(bc!(near[2]), inz, onz), zero),
                        );
                        let t1 = _mm256_min_ps(
                            _mm256_min_ps(
                                _mm256_fmsub_ps(bc!(far[0]), ifx, ofx),
                                _mm256_fmsub_ps(bc!(far[1]), ify, ofy),
                            ),
                            _mm256_min_ps(_mm256_fmsub_ps(bc!(far[2]), ifz, ofz), tmax),
                        );
                        let m =
                            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32 & active;
                        if m != 0 {
                            let e = &mut kids[k];
                            _mm256_store_ps(e.t.as_mut_ptr(), t0);
                            e.code = node.child[c];
                            e.mask = m;
                            // order by where the first of its rays enters
                            e.key = e.t[m.trailing_zeros() as usize];
                            self.prefetch(e.code);
                            k += 1;
                        }
                    }
                    if k > 0 {
                        // farthest first onto the stack, the nearest visited now
                        let mut order = [0u8; WIDTH];
                        for i in 1..k {
                            let mut j = i;
                            while j > 0 && kids[order[j - 1] as usize].key < kids[i].key {
                                order[j] = order[j - 1];
                                j -= 1;
                            }
                            order[j] = i as u8;
                        }
                        for &i in &order[..k - 1] {
                            stack.push(kids[i as usize]);
                        }
                        let nearest = &kids[order[k - 1] as usize];
                        cur = nearest.code;
                        active = nearest.mask;
                        continue 'walk;
                    }
                } else {
                    let mut m = active;
                    while m != 0 {
                        let lane = m.trailing_zeros() as usize;
                        m &= m - 1;
                        self.leaf_closest::<Avx2>(
                            cur,
                            &rays[lane],
                            &trs[lane],
                            &mut t_max[lane],
                            &mut best[lane],
                            &mut out,
                        );
                    }
                }
                // next: a stacked subtree that one of its rays may still hit before its t_max
                let tmax = _mm256_loadu_ps(t_max.as_ptr());
                loop {
                    let Some(e) = stack.pop() else {
                        break 'walk;
                    };
                    let near = _mm256_load_ps(e.t.as_ptr());
                    let m =
                        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, tmax)) as u32 & e.mask;
                    if m != 0 {
                        cur = e.code;
                        active = m;
                        continue 'walk;
                    }
                }
            }
            for (lane, hit) in hits.iter_mut().enumerate().take(n) {
                *hit = self.make_hit(best[lane], t_max[lane]);
            }
        }
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
    unsafe fn closest<B: BoxTest, P: PacketTest>(&self, ray: &Ray) -> Option<Hit> {
        let br = BoxRay::new(ray);
        let tr = TriRay::new(ray);
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
                self.leaf_closest::<P>(cur, ray, &tr, &mut t_max, &mut best, &mut out);
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
    unsafe fn leaf_closest<P: PacketTest>(
        &self,
        cur: u32,
        ray: &Ray,
        tr: &TriRay,
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
                *best = Some((
                    code as u32,
                    false,
                    out.b1[lane],
                    out.b2[lane],
                    (0, 0),
                ));
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
    unsafe fn any_hit<B: BoxTest, P: PacketTest>(&self, ray: &Ray) -> bool {
        let br = BoxRay::new(ray);
        let tr = TriRay::new(ray);
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
                let first = (cur & INDEX_MASK) as usize;
                let count = ((cur >> COUNT_SHIFT) & 7) as usize + 1;
                let end = first + count;
                let mut pi = first;
                while pi < end {
                    let packet = self.packets.as_ptr().add(pi);
                    let m = if pi + 1 < end {
                        pi += 2;
                        P::test2(packet, &tr, t_max, &mut out)
                    } else {
                        pi += 1;
                        P::test(&*packet, &tr, t_max, &mut out)
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

fn valid_ray(ray: &Ray) -> bool {
    ray.o.is_finite() && ray.d.is_finite() && ray.d != Vec3::ZERO && ray.t_max > 0.0
}

impl Intersector for Bvh {
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !valid_ray(ray) || self.nodes.is_empty() {
            return None;
        }
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `set_isa` and `Isa::detect` only select AVX2 on CPUs with AVX2 and FMA.
            Isa::Avx2 => unsafe { self.closest_avx2(ray) },
            #[cfg(target_arch = "x86_64")]
            Isa::Sse2 => self.closest_sse2(ray),
            // SAFETY: the scalar tests need nothing.
            _ => unsafe { self.closest::<Scalar, Scalar>(ray) },
        }
    }

    fn occluded(&self, ray: &Ray) -> bool {
        if !valid_ray(ray) || self.nodes.is_empty() {
            return false;
        }
        match self.isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: `set_isa` and `Isa::detect` only select AVX2 on CPUs with AVX2 and FMA.
            Isa::Avx2 => unsafe { self.occluded_avx2(ray) },
            #[cfg(target_arch = "x86_64")]
            Isa::Sse2 => self.occluded_sse2(ray),
            // SAFETY: the scalar tests need nothing.
            _ => unsafe { self.any_hit::<Scalar, Scalar>(ray) },
        }
    }

    fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        #[cfg(target_arch = "x86_64")]
        if self.isa == Isa::Avx2
            && (2..=8).contains(&rays.len())
            && hits.len() >= rays.len()
            && !self.nodes.is_empty()
            && rays.iter().all(valid_ray)
        {
            let brs: [BoxRay; 8] =
                std::array::from_fn(|i| BoxRay::new(&rays[i.min(rays.len() - 1)]));
            if brs.iter().all(|b| b.near_at == brs[0].near_at) {
                // SAFETY: AVX2 and FMA are present (`isa`); 2 to 8 valid rays, one octant.
                unsafe { self.closest_packet_avx2(rays, &brs, hits) };
                return;
            }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh_io::{load_obj, load_ply, MeshData};
    use glam::{Mat4, Vec2};

    fn asset(name: &str) -> std::path::PathBuf {
        specula_testdata::root().join("scenes/assets").join(name)
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

    /// The binary build as it was before the start-up work (bounds recomputed per node, a
    /// box and a centroid array, every bin swept), sequential, compact: the reference that
    /// the faster build must reproduce node for node (as [`canonical`] lists them).
    fn reference_build_binary(boxes: &[(Vec3, Vec3)], tris: &[bool]) -> (Vec<BNode>, Vec<u32>) {
        let cent: Vec<DVec3> = boxes
            .iter()
            .map(|(lo, hi)| (lo.as_dvec3() + hi.as_dvec3()) * 0.5)
            .collect();
        let tri = |i: u32| tris[i as usize];
        let mut range: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut tree: Vec<BNode> = vec![];
        let mut todo = vec![(0usize, range.len(), NO_CHILD, 0usize, 0u32)];
        while let Some((s, e, parent, which, depth)) = todo.pop() {
            let index = tree.len() as u32;
            if parent != NO_CHILD {
                tree[parent as usize].kids[which] = index;
            }
            let r = &mut range[s..e];
            if r.len() == 1 {
                let (lo, hi) = boxes[r[0] as usize];
                tree.push(BNode {
                    lo,
                    hi,
                    kids: [s as u32, NO_CHILD],
                    count: 1,
                    tris_only: tri(r[0]),
                });
                continue;
            }
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            let (mut clo, mut chi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
            for &i in r.iter() {
                lo = lo.min(boxes[i as usize].0);
                hi = hi.max(boxes[i as usize].1);
                clo = clo.min(cent[i as usize]);
                chi = chi.max(cent[i as usize]);
            }
            let ext = chi - clo;
            let axis = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let median = |r: &mut [u32]| {
                let m = r.len() / 2;
                if ext[axis] > 0.0 {
                    r.select_nth_unstable_by(m, |&a, &b| {
                        cent[a as usize][axis].total_cmp(&cent[b as usize][axis])
                    });
                }
                m
            };
            if r.len() <= LEAF_TRIS as usize && r.iter().all(|&i| tri(i)) {
                tree.push(BNode {
                    lo,
                    hi,
                    kids: [s as u32, NO_CHILD],
                    count: r.len() as u32,
                    tris_only: true,
                });
                continue;
            }
            let mid = if ext[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
                || depth >= MAX_SAH_DEPTH
            {
                median(r)
            } else {
                let nb = bins_for(r.len());
                let bin_of =
                    |c: f64, a: usize| (((c - clo[a]) * (nb as f64 / ext[a])) as usize).min(nb - 1);
                let mut bins = [[(Vec3::INFINITY, Vec3::NEG_INFINITY, 0u32); BINS]; 3];
                let live: [bool; 3] = std::array::from_fn(|a| ext[a] > 0.0);
                for &i in r.iter() {
                    for a in (0..3).filter(|&a| live[a]) {
                        let b = &mut bins[a][bin_of(cent[i as usize][a], a)];
                        b.0 = b.0.min(boxes[i as usize].0);
                        b.1 = b.1.max(boxes[i as usize].1);
                        b.2 += 1;
                    }
                }
                let mut best = (f64::INFINITY, usize::MAX, 0usize);
                for a in (0..3).filter(|&a| live[a]) {
                    let mut right = [0.0f64; BINS];
                    let (mut rlo, mut rhi, mut rn) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0);
                    for k in (1..nb).rev() {
                        rlo = rlo.min(bins[a][k].0);
                        rhi = rhi.max(bins[a][k].1);
                        rn += bins[a][k].2;
                        right[k] = if rn == 0 {
                            f64::NAN
                        } else {
                            half_area_f64(rlo, rhi) * rn as f64
                        };
                    }
                    let (mut llo, mut lhi, mut ln) = (Vec3::INFINITY, Vec3::NEG_INFINITY, 0);
                    for k in 1..nb {
                        llo = llo.min(bins[a][k - 1].0);
                        lhi = lhi.max(bins[a][k - 1].1);
                        ln += bins[a][k - 1].2;
                        if ln == 0 || right[k].is_nan() {
                            continue;
                        }
                        let cost = half_area_f64(llo, lhi) * ln as f64 + right[k];
                        if cost < best.0 {
                            best = (cost, a, k);
                        }
                    }
                }
                if best.1 == usize::MAX {
                    median(r)
                } else {
                    let (_, a, k) = best;
                    let mut m = 0;
                    for j in 0..r.len() {
                        if bin_of(cent[r[j] as usize][a], a) < k {
                            r.swap(m, j);
                            m += 1;
                        }
                    }
                    if m == 0 || m == r.len() {
                        median(r)
                    } else {
                        m
                    }
                }
            };
            tree.push(BNode {
                lo,
                hi,
                kids: [NO_CHILD, NO_CHILD],
                count: 0,
                tris_only: true,
            });
            todo.push((s + mid, e, index, 1, depth + 1));
            todo.push((s, s + mid, index, 0, depth + 1));
        }
        for i in (0..tree.len()).rev() {
            if !tree[i].is_leaf() {
                let [a, b] = tree[i].kids.map(|k| k as usize);
                tree[i].count = tree[a].count + tree[b].count;
                tree[i].tris_only = tree[a].tris_only && tree[b].tris_only;
            }
        }
        (tree, range)
    }

    /// A binary build tree's nodes depth-first, first child first, whatever slots they
    /// occupy: box bits, count, triangles only, and for a leaf its primitives.
    #[allow(clippy::type_complexity)]
    fn canonical(
        (tree, order): &(Vec<BNode>, Vec<u32>),
    ) -> Vec<([u32; 3], [u32; 3], u32, bool, Vec<u32>)> {
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut out = vec![];
        let mut todo = vec![0usize];
        while let Some(i) = todo.pop() {
            let n = &tree[i];
            let prims = if n.is_leaf() {
                let first = n.kids[0] as usize;
                order[first..first + n.count as usize].to_vec()
            } else {
                todo.push(n.kids[1] as usize);
                todo.push(n.kids[0] as usize);
                vec![]
            };
            out.push((bits(n.lo), bits(n.hi), n.count, n.tris_only, prims));
        }
        out
    }

    /// The build gives the reference build's tree, node for node and bit for bit: random
    /// triangles (more than one parallel split's worth), clusters of coincident centroids
    /// (median splits), flat geometry (a dead axis), spheres among them, tiny inputs.
    #[test]
    fn build_matches_the_reference_build() {
        let mut rng = Rng(3);
        #[derive(Clone, Copy)]
        enum TestPrim {
            Tri([Vec3; 3]),
            Sphere { center: Vec3, radius: f32 },
        }
        let mut cases: Vec<Vec<TestPrim>> = vec![];
        let tri = |rng: &mut Rng, c: Vec3, s: f32| {
            TestPrim::Tri([0; 3].map(|_| c + rng.in_box(Vec3::splat(-s), Vec3::splat(s))))
        };
        // uniform soup, large
        cases.push(
            (0..40_000)
                .map(|_| {
                    let c = rng.in_box(Vec3::splat(-10.0), Vec3::splat(10.0));
                    tri(&mut rng, c, 0.3)
                })
                .collect(),
        );
        // clusters: many primitives on few centres, and flat in z
        cases.push(
            (0..3000)
                .map(|i| {
                    let c = Vec3::new((i % 7) as f32, (i % 3) as f32 * 0.5, 0.0);
                    if i % 50 == 0 {
                        TestPrim::Sphere {
                            center: c,
                            radius: 0.25,
                        }
                    } else {
                        let v = [c, c + Vec3::X * 0.1, c + Vec3::Y * 0.1];
                        TestPrim::Tri(v)
                    }
                })
                .collect(),
        );
        // geometric spacing (deep SAH), and tiny inputs
        cases.push(
            (0..400)
                .map(|i| {
                    let x = 1.05f32.powi(i);
                    TestPrim::Tri([
                        Vec3::new(x, 0.0, 0.0),
                        Vec3::new(x, 1.0, 0.0),
                        Vec3::new(x, 0.0, 1.0),
                    ])
                })
                .collect(),
        );
        for n in [1, 2, 3, 8, 9, 17] {
            cases.push((0..n).map(|_| tri(&mut rng, Vec3::ZERO, 2.0)).collect());
        }
        for shapes in cases {
            let boxes: Vec<(Vec3, Vec3)> = shapes
                .iter()
                .map(|s| match *s {
                    TestPrim::Tri(v) => {
                        let (lo, hi) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
                        let pad = Vec3::splat(lo.abs().max(hi.abs()).max_element() * 4e-7 + 1e-30);
                        (lo - pad, hi + pad)
                    }
                    TestPrim::Sphere { center, radius } => {
                        (center - Vec3::splat(radius), center + Vec3::splat(radius))
                    }
                })
                .collect();
            let tris: Vec<bool> = shapes
                .iter()
                .map(|s| matches!(s, TestPrim::Tri(_)))
                .collect();
            let want = canonical(&reference_build_binary(&boxes, &tris));
            let got = canonical(&build_binary(&boxes, &tris));
            assert_eq!(got.len(), want.len(), "{} primitives", shapes.len());
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    g,
                    w,
                    "node {i} of {} ({} primitives)",
                    want.len(),
                    shapes.len()
                );
            }
        }
    }

    /// The scene of ../shared/scenes/meshes.xml plus analytic shapes.
    fn scene() -> Vec<Geometry> {
        let knot = load_obj(&asset("torusknot.obj")).unwrap();
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let bumpy = load_obj(&asset("bumpy.obj")).unwrap();
        let mut shapes = vec![
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
            Geometry::cylinder(
                Vec3::new(-2.5, -1.5, -1.0),
                Vec3::new(-2.2, -1.5, 1.0),
                0.4,
                Mat4::IDENTITY,
                false,
            )
            .unwrap(),
        ];
        // two slots of one instance of a group (a mesh and a sphere), after the shapes above
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let group = std::sync::Arc::new(crate::geometry::ShapeGroup::new(
            vec![
                Geometry::mesh(ico, Mat4::IDENTITY, false, false).unwrap(),
                Geometry::sphere(Vec3::new(1.2, 0.0, 0.0), 0.5, Mat4::IDENTITY, false),
            ],
            vec![0, 0],
        ));
        let to_world = Mat4::from_translation(Vec3::new(1.0, -2.0, 1.0))
            * Mat4::from_rotation_z(0.5)
            * Mat4::from_scale(Vec3::new(0.5, 0.7, 0.5));
        shapes.extend(Geometry::instance(&group, to_world).unwrap());
        shapes
    }

    /// Every primitive of `geoms`, tested one by one with the same primitive routines.
    fn brute_force(geoms: &[Geometry], ray: &Ray) -> Option<Hit> {
        brute_force_bvh(&Bvh::build(geoms), ray)
    }

    /// Every primitive of `bvh`, tested one by one with the scalar routines (no traversal).
    fn brute_force_bvh(bvh: &Bvh, ray: &Ray) -> Option<Hit> {
        if !valid_ray(ray) {
            return None;
        }
        let tri = TriRay::new(ray);
        let mut best: Option<Hit> = None;
        let mut n = 0;
        for (p, ids) in bvh.packets.iter().zip(&bvh.packet_ids) {
            for (lane, &(shape, prim)) in ids.iter().enumerate() {
                if shape == u32::MAX {
                    continue;
                }
                n += 1;
                let v =
                    [0, 1, 2].map(|k| Vec3::new(p.v[k][0][lane], p.v[k][1][lane], p.v[k][2][lane]));
                let t_max = best.map_or(ray.t_max, |h| h.t);
                if let Some((t, u, w)) = tri.intersect(&v, t_max) {
                    best = Some(Hit {
                        t,
                        shape,
                        prim,
                        u,
                        v: w,
                        vertices: Some(v),
                    });
                }
            }
        }
        for (i, &(shape, prim)) in bvh.analytic_ids.iter().enumerate() {
            n += 1;
            let t_max = best.map_or(ray.t_max, |h| h.t);
            if let Some((t, u, v, sub)) =
                bvh.intersect_analytic(LEAF | ANALYTIC | i as u32, ray, t_max)
            {
                let instance = matches!(bvh.analytic[i], PrimShape::Instance { .. });
                best = Some(Hit {
                    t,
                    shape: shape + sub.0,
                    prim: if instance { sub.1 } else { prim },
                    u,
                    v,
                    vertices: None,
                });
            }
        }
        assert_eq!(n, bvh.primitive_count());
        best
    }

    #[test]
    fn bvh_matches_brute_force() {
        let geoms = scene();
        let bvh = Bvh::build(&geoms);
        let total: usize = geoms.iter().map(|g| g.primitive_count()).sum();
        assert_eq!(bvh.primitive_count(), total);
        let isas = Isa::available();
        assert!(isas.contains(&Isa::Scalar) && isas.contains(&Isa::detect()));
        #[cfg(target_arch = "x86_64")]
        assert!(isas.contains(&Isa::Sse2));
        let bvhs: Vec<(Isa, Bvh)> = isas
            .iter()
            .map(|&isa| {
                let mut b = bvh.clone();
                b.set_isa(isa);
                (isa, b)
            })
            .collect();
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
            let mut first: Option<Option<Hit>> = None;
            for (isa, bvh) in &bvhs {
                let got = bvh.intersect(&ray);
                match (got, want) {
                    (None, None) => {}
                    (Some(g), Some(w)) => {
                        hits += 1;
                        assert_eq!(g.t, w.t, "{isa:?} ray {i}: {ray:?}");
                        if (g.shape, g.prim) != (w.shape, w.prim) {
                            // Only a tie (a ray through a shared edge) may differ.
                            assert_eq!(g.t, w.t);
                        }
                    }
                    _ => panic!("{isa:?} ray {i}: bvh {got:?}, brute force {want:?} ({ray:?})"),
                }
                // every implementation gives the same answer, bit for bit (no exact ties here)
                assert_eq!(*first.get_or_insert(got), got, "{isa:?} ray {i}");
                assert_eq!(bvh.occluded(&ray), want.is_some(), "{isa:?} ray {i}");
            }
        }
        assert!(hits > 1000 * bvhs.len(), "only {hits} hits");
    }

    /// A soup large enough for the parallel build (several ranges of at least
    /// `PARALLEL_BUILD` primitives): the BVH built with 1 and with 3 threads answers every ray
    /// as brute force does, bit for bit the same.
    #[test]
    fn parallel_build_matches_brute_force_and_one_thread() {
        let mut rng = Rng(11);
        let n = 3 * PARALLEL_BUILD + 123;
        let mut positions = Vec::with_capacity(3 * n);
        for _ in 0..n {
            let c = rng.in_box(Vec3::splat(-3.0), Vec3::splat(3.0));
            for _ in 0..3 {
                positions.push(c + rng.in_box(Vec3::splat(-0.05), Vec3::splat(0.05)));
            }
        }
        let data = MeshData {
            indices: (0..n as u32)
                .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                .collect(),
            positions,
            normals: None,
            uvs: None,
            attributes: vec![],
        };
        let geoms = vec![Geometry::mesh(data, Mat4::IDENTITY, false, false).unwrap()];
        let build = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| Bvh::build(&geoms))
        };
        let (one, three) = (build(1), build(3));
        assert_eq!(one.primitive_count(), n);
        for i in 0..400 {
            let o = rng.in_box(Vec3::splat(-5.0), Vec3::splat(5.0));
            let d = if i % 2 == 0 {
                -o.normalize()
            } else {
                rng.dir()
            };
            let ray = Ray {
                o,
                d,
                t_max: f32::INFINITY,
            };
            let want = brute_force_bvh(&one, &ray).map(|h| h.t);
            assert_eq!(one.intersect(&ray).map(|h| h.t), want, "ray {i}");
            assert_eq!(three.intersect(&ray), one.intersect(&ray), "ray {i}");
        }
    }

    /// Packets (a pixel's camera rays, wider bundles, rays of one octant going anywhere,
    /// mixed octants, 1 to 8 rays) give every ray the hit the single-ray query gives it.
    #[test]
    fn packets_match_single_rays() {
        let geoms = scene();
        let bvh = Bvh::build(&geoms);
        let mut rng = Rng(3);
        let (lo, hi) = (Vec3::new(-4.0, -1.0, -4.0), Vec3::new(4.0, 4.0, 4.0));
        let (mut hits, mut packets) = (0, 0);
        for i in 0..4000 {
            let n = 1 + i % 8;
            let o = rng.in_box(lo, hi);
            let aim =
                (rng.in_box(Vec3::new(-2.0, 0.0, -1.0), Vec3::new(2.5, 2.0, 1.0)) - o).normalize();
            let spread = [0.002, 0.05, 0.5, 2.0][i % 4];
            let rays: Vec<Ray> = (0..n)
                .map(|k| {
                    let d = if i % 7 == 0 {
                        // one octant, any direction in it
                        rng.dir().abs() * aim.signum()
                    } else {
                        (aim + spread * (rng.dir() * rng.f())).normalize()
                    };
                    // a pixel's rays share the origin; some bundles do not
                    let o = if i % 3 == 0 {
                        o + 0.01 * k as f32 * rng.dir()
                    } else {
                        o
                    };
                    let t_max = if i % 5 == 0 {
                        3.0 * rng.f()
                    } else {
                        f32::INFINITY
                    };
                    Ray { o, d, t_max }
                })
                .collect();
            let mut got = [None; 8];
            bvh.intersect_packet(&rays, &mut got);
            let brs: Vec<BoxRay> = rays.iter().map(BoxRay::new).collect();
            packets += (n > 1 && brs.iter().all(|b| b.near_at == brs[0].near_at)) as usize;
            for (k, ray) in rays.iter().enumerate() {
                let want = bvh.intersect(ray);
                let key = |h: Option<Hit>| h.map(|h| (h.t, h.shape, h.prim, h.u, h.v));
                assert_eq!(key(got[k]), key(want), "packet {i}, ray {k}: {ray:?}");
                hits += want.is_some() as usize;
            }
        }
        // most bundles of several rays are traced as packets (the widest often span octants),
        // and most of their rays hit something
        assert!(packets > 2000, "{packets} packets");
        assert!(hits > 8000, "{hits} hits");
    }

    #[test]
    fn watertight_closed_mesh_and_shared_vertices() {
        let ico = load_ply(&asset("icosphere.ply")).unwrap();
        let g = Geometry::mesh(ico.clone(), Mat4::IDENTITY, false, false).unwrap();
        let geoms = [g];
        let Geometry::Mesh(m) = &geoms[0] else {
            unreachable!()
        };
        // Rays from outside through every vertex and every edge midpoint.
        let mut targets: Vec<Vec3> = m.positions.clone();
        for tri in m.indices.iter().take(3000) {
            for k in 0..3 {
                let a = m.positions[tri[k] as usize];
                let b = m.positions[tri[(k + 1) % 3] as usize];
                targets.push((a + b) * 0.5);
            }
        }
        // every implementation of the triangle test (their exact edge fallbacks included)
        for isa in Isa::available() {
            let mut bvh = Bvh::build(&geoms);
            bvh.set_isa(isa);
            // From the centre of the closed mesh every ray must hit it.
            let mut rng = Rng(99);
            for _ in 0..20000 {
                let ray = Ray::new(Vec3::new(0.01, -0.02, 0.015), rng.dir());
                assert!(bvh.intersect(&ray).is_some(), "{isa:?} escaped: {ray:?}");
            }
            for (i, t) in targets.iter().enumerate() {
                let o = *t * 3.0 + Vec3::new(0.3, 0.7, -0.2) * ((i % 7) as f32 * 0.1);
                let ray = Ray::new(o, (*t - o).normalize());
                let h = bvh
                    .intersect(&ray)
                    .unwrap_or_else(|| panic!("{isa:?} missed target {i}"));
                assert!(h.t <= (*t - o).length() * (1.0 + 1e-5));
            }
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

    /// Reproducers of `../shared/robustness` (`bvh_degenerate_hang`, `bvh_scale0_hang`,
    /// `big_polygon_bvh_hang`, `bvh_huge_translate_panic`): degenerate and huge-coordinate
    /// geometry builds in O(n log n) and is still intersected correctly.
    #[test]
    fn degenerate_and_huge_geometry_build_fast() {
        let mesh = |positions: Vec<Vec3>, indices: Vec<[u32; 3]>, m: Mat4| {
            let data = MeshData {
                positions,
                normals: None,
                uvs: None,
                indices,
                attributes: vec![],
            };
            Geometry::mesh(data, m, false, false).unwrap()
        };
        let tri = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let fan = |n: u32| (0..n).map(|_| [0, 1, 2]).collect::<Vec<_>>();
        // 100 000 identical triangles: was quadratic (20 000 took 113 s)
        let t = std::time::Instant::now();
        let bvh = Bvh::build(&[mesh(tri.clone(), fan(100_000), Mat4::IDENTITY)]);
        assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
        let h = bvh
            .intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z))
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        // a mesh scaled to a point, and one polygon fanned into 90 000 slivers
        let n = 90_000u32;
        let ring: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = i as f32 / n as f32 * std::f32::consts::TAU;
                Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect();
        let slivers: Vec<[u32; 3]> = (1..n - 1).map(|k| [0, k, k + 1]).collect();
        let t = std::time::Instant::now();
        let bvh = Bvh::build(&[
            mesh(ring.clone(), slivers.clone(), Mat4::from_scale(Vec3::ZERO)),
            mesh(ring, slivers, Mat4::IDENTITY),
        ]);
        assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
        let h = bvh
            .intersect(&Ray::new(Vec3::new(0.1, -0.3, 1.0), -Vec3::Z))
            .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6 && h.shape == 1);
        // boxes near ±f32::MAX (a cube translated to z = 3e38 panicked in the old builder)
        for z in [1e30f32, 3e38, -3e38] {
            let geoms = [
                Geometry::cube(Mat4::from_translation(Vec3::new(0.0, 0.0, z)), false),
                Geometry::sphere(Vec3::new(0.0, 0.0, z), 1e37, Mat4::IDENTITY, false),
                mesh(tri.clone(), fan(3), Mat4::IDENTITY),
            ];
            let bvh = Bvh::build(&geoms);
            let h = bvh
                .intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z))
                .unwrap();
            assert!((h.t - 1.0).abs() < 1e-6 && h.shape == 2, "{z}");
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

    /// Every implementation of the box and triangle tests renders the same image, bit for bit
    /// (they could differ only where two triangles are hit at exactly the same t).
    #[test]
    fn renders_identical_with_every_isa() {
        let path = specula_testdata::root().join("scenes/meshes.xml");
        let overrides = [("resx", "48"), ("resy", "32"), ("spp", "4")]
            .map(|(k, v)| (k.to_string(), v.to_string()));
        let mut scene = crate::scene::Scene::load(&path, &overrides).unwrap();
        let opts = crate::render::RenderOptions {
            spp: 4,
            seed: 1,
            threads: 1,
        };
        let stop = std::sync::atomic::AtomicBool::new(false);
        let mut first: Option<Vec<f32>> = None;
        for isa in Isa::available() {
            scene.accel.set_isa(isa);
            let out = crate::render::render(&scene, &opts, &stop, &|_, _| {});
            let want = first.get_or_insert_with(|| out.rgb.clone());
            assert!(out.rgb.iter().any(|&c| c > 0.0));
            assert!(
                out.rgb
                    .iter()
                    .zip(want.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "{isa:?} renders a different image"
            );
        }
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
        let n: usize = std::env::var("SPECULA_RAYS")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or(2_000_000);
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
