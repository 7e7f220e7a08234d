//! The binary build tree of the BVH: top-down binned SAH over the primitives' build records
//! (see the module documentation of [`crate::accel`]), which `Bvh::collapse` turns into
//! 8-wide nodes.

use super::*;
use glam::{DVec3, Vec3, Vec3A};
use std::mem::MaybeUninit;

/// A node of the binary build tree. A leaf holds one primitive, or up to [`LEAF_TRIS`]
/// triangles: the `count` entries of the build's primitive order from `kids[0]` on.
#[derive(Clone, Copy)]
pub(super) struct BNode {
    pub(super) lo: Vec3,
    pub(super) hi: Vec3,
    /// Children (inner nodes), or `[first, NO_CHILD]` for a leaf (`first`: its first entry in
    /// the primitive order that [`build_tree`] returns).
    pub(super) kids: [u32; 2],
    /// Primitives in the subtree.
    pub(super) count: u32,
}

pub(super) const NO_CHILD: u32 = u32::MAX;

impl BNode {
    pub(super) fn half_area(&self) -> f32 {
        half_area_f32(self.lo.into(), self.hi.into())
    }
    pub(super) fn is_leaf(&self) -> bool {
        self.kids[1] == NO_CHILD
    }
}

/// Centroid bins per axis of the SAH build at most (see [`bins_for`]).
pub(super) const BINS: usize = 32;
/// Centroid bins per axis for a range of `n` primitives: [`BINS`] above 1024, 16 down to
/// 33, 8 below. Small ranges leave most of 32 bins empty, and sweeping them costs as much as
/// binning the primitives: with fewer bins the build of meshes.xml takes ~9 % fewer
/// instructions, and the trees' SAH cost ([`Bvh::sah_cost`]) hardly changes (meshes.xml
/// 8.2156 → 8.2195, bsdf_roughplastic_nopreserve 5.5015 → 5.4407).
pub(super) fn bins_for(n: usize) -> usize {
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
pub(super) const MAX_SAH_DEPTH: u32 = 48;

/// Surface area (halved) of a box, in double precision (no overflow for huge boxes).
pub(super) fn half_area_f64(lo: Vec3, hi: Vec3) -> f64 {
    let e = (hi.as_dvec3() - lo.as_dvec3()).max(DVec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// What the build reads of a primitive, in half a cache line: its (padded) box, each corner
/// followed by a 32-bit word (the primitive's index, whether it is a triangle), so that a
/// corner is one aligned 16-byte load whose fourth lane the box arithmetic ignores. The box's
/// centroid, in double precision as the bins are placed, is computed from the corners where it
/// is needed (the same bits every time: f32 → f64 is exact). The build partitions these records
/// themselves (not indices to them), so each node's primitives lie consecutively in memory;
/// 32 bytes a record instead of 64 with a stored centroid halve both the build's memory
/// traffic and its peak memory (32 MB less for a million triangles).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct PrimBox {
    lo: [f32; 3],
    index: u32,
    hi: [f32; 3],
    /// 0 for an analytic shape; for a triangle, 1 + the index of its shape (see
    /// [`split_small`])
    tri_shape: u32,
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
    /// The record of a primitive with the (padded, finite) box `lo..hi`: a triangle of
    /// shape `Some(shape)` (< u32::MAX), or an analytic shape (`None`).
    #[inline]
    pub(super) fn new(lo: Vec3, hi: Vec3, shape: Option<u32>, index: u32) -> PrimBox {
        PrimBox {
            lo: lo.to_array(),
            index,
            hi: hi.to_array(),
            tri_shape: shape.map_or(0, |s| s.saturating_add(1)),
        }
    }

    /// The 16 bytes at float offset `at` (0: `lo` and `index`, 4: `hi` and `tri`) as a SIMD
    /// vector, in one aligned load (x86-64): the word after the corner lands in the fourth
    /// lane, which `Vec3A` arithmetic never mixes into x, y, z (no floating-point operation
    /// reads it as a value).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn quad(&self, at: usize) -> std::arch::x86_64::__m128 {
        debug_assert!(at == 0 || at == 4);
        // SAFETY: SSE2 is part of the x86-64 baseline; the pointer comes from the whole
        // record (`#[repr(C)]`, 32 bytes, 32-byte aligned), so the 16 bytes at offset 0 or 16
        // are in it and 16-byte aligned
        unsafe { std::arch::x86_64::_mm_load_ps((self as *const PrimBox as *const f32).add(at)) }
    }

    #[inline(always)]
    fn lo(&self) -> Vec3A {
        #[cfg(target_arch = "x86_64")]
        return Vec3A::from(self.quad(0));
        #[cfg(not(target_arch = "x86_64"))]
        return Vec3A::from_array(self.lo);
    }

    #[inline(always)]
    fn hi(&self) -> Vec3A {
        #[cfg(target_arch = "x86_64")]
        return Vec3A::from(self.quad(4));
        #[cfg(not(target_arch = "x86_64"))]
        return Vec3A::from_array(self.hi);
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
    fn is_tri(&self) -> bool {
        self.tri_shape != 0
    }

    #[inline(always)]
    pub(super) fn index(&self) -> u32 {
        self.index
    }
}

/// [`build_tree`] over `boxes` (finite; `shapes[i]`: the shape of primitive i if it is a
/// triangle, `None` if it is analytic).
#[cfg(test)]
pub(super) fn build_binary(
    boxes: &[(Vec3, Vec3)],
    shapes: &[Option<u32>],
) -> (Vec<BNode>, Vec<u32>) {
    let mut pb: Vec<PrimBox> = boxes
        .iter()
        .zip(shapes)
        .enumerate()
        .map(|(i, (&(lo, hi), &shape))| PrimBox::new(lo, hi, shape, i as u32))
        .collect();
    build_tree(&mut pb)
}

/// The binary build tree over the primitives' build records (at least one), root first,
/// parents before children, counts filled in, and the primitives in the order its leaves
/// refer to. Leaves hold one primitive, or a range of at most [`LEAF_TRIS`] triangles (which
/// [`split_small`] did not split), listed depth-first, first
/// child first. The build writes into 2n − 1 slots (a subtree of m primitives owns 2m − 1
/// consecutive ones, so parallel parts write disjoint slices) that are never initialised
/// beforehand: the slots after a subtree's last node (most of them, since leaves hold up to
/// [`LEAF_TRIS`] triangles) are never written, so their memory is never touched (a fresh
/// allocation of that size is mapped lazily), and the nodes are then copied out in order.
/// Each node's primitive count is known when it is made (its range), so no pass over the
/// slots sums them.
///
/// Top-down binned SAH: each node bins its primitives' centroids into [`bins_for`] slots
/// along each axis of the centroid bounds and splits at the cheapest bin boundary (cost: area ×
/// count on each side). Primitives whose centroids coincide, and subtrees deeper than
/// [`MAX_SAH_DEPTH`], are split at the object median; every split is a partition of an index
/// range, so the whole build is O(n log n) with an explicit stack (no recursion).
pub(super) fn build_tree(pb: &mut [PrimBox]) -> (Vec<BNode>, Vec<u32>) {
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
pub(super) const PARALLEL_BUILD: usize = 1 << 14;

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
        self.add_at(p, p.c());
    }

    /// [`RangeBounds::add`] of `p`, whose centroid `c` the caller has computed.
    #[inline]
    fn add_at(&mut self, p: &PrimBox, c: DVec3) {
        self.lo = self.lo.min(p.lo());
        self.hi = self.hi.max(p.hi());
        self.clo = dmin(self.clo, c);
        self.chi = dmax(self.chi, c);
        self.tris &= p.is_tri();
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
/// [`LEAF_TRIS`] triangles that [`split_small`] does not split, give a leaf and no split.
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
    // A range of at most LEAF_TRIS triangles becomes one leaf as it stands, unless the SAH
    // expects a clear gain from splitting it (see `split_small`).
    if range.len() <= LEAF_TRIS as usize && tris {
        if let Some(m) = split_small(range) {
            let node = BNode {
                lo: lo.into(),
                hi: hi.into(),
                kids: [NO_CHILD, NO_CHILD],
                count: range.len() as u32,
            };
            return (node, Some((m, None)));
        }
        let leaf = BNode {
            lo: lo.into(),
            hi: hi.into(),
            kids: [first, NO_CHILD],
            count: range.len() as u32,
        };
        return (leaf, None);
    }
    let node = BNode {
        lo: lo.into(),
        hi: hi.into(),
        kids: [NO_CHILD, NO_CHILD],
        count: range.len() as u32,
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

/// The cost of visiting a leaf, beyond its packets' tests, in packet tests (the unit of
/// [`split_small`]'s costs): decoding its reference, the stack, the leaf's loop.
const LEAF_VISIT_COST: f32 = 2.0;

/// [`split_small`] splits a range where the SAH expects at most this fraction of its cost as
/// one leaf (the SAH's area ratios overrate small leaves: session 22 found leaves of 4
/// triangles slower than leaves of 8 though they test fewer triangles).
const SMALL_SPLIT_GAIN: f32 = 0.8;

/// The boxes of [`split_small`]'s range, and each triangle's centroid × 2 and index.
struct SmallRange {
    lo: [Vec3A; LEAF_TRIS as usize],
    hi: [Vec3A; LEAF_TRIS as usize],
    c2: [Vec3A; LEAF_TRIS as usize],
    index: [u32; LEAF_TRIS as usize],
}

/// Half the surface area of a box (single precision: enough to compare costs).
#[inline]
pub(super) fn half_area_f32(lo: Vec3A, hi: Vec3A) -> f32 {
    let e = (hi - lo).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// The axis of the largest of three extents (the first of equal ones).
#[inline]
fn widest_axis<T: PartialOrd>([x, y, z]: [T; 3]) -> usize {
    if x >= y && x >= z {
        0
    } else if y >= z {
        1
    } else {
        2
    }
}

/// A key ordering finite floats as their values (−0 and +0 apart, which the centroids of
/// padded boxes never are), then by the index in the low half.
#[inline]
fn order_key(x: f32, index: u32) -> u64 {
    let b = x.to_bits();
    let k = if b >> 31 != 0 { !b } else { b | 1 << 31 };
    (k as u64) << 32 | index as u64
}

/// Where to split a range of at most [`LEAF_TRIS`] triangles (reordered so that the first
/// part comes first), or `None` to keep it as one leaf (the range unchanged).
///
/// Such a range used to become one leaf whatever it held. Where it holds pieces of separate
/// shapes, e.g. a room's walls, two triangles to a `rectangle`, that leaf's box spans the
/// empty room between them: every ray through the room visits it and tests all its packets
/// (`cbox`: one leaf over the floor, back and right walls). So a range of triangles from
/// more than one shape is sorted by centroid along the axis where the centroids spread most,
/// each position is costed as two leaves (SAH: half-area × (packets + [`LEAF_VISIT_COST`])),
/// the cheapest is costed again with its parts split by the same rule ([`SMALL_LOOKAHEAD`]
/// levels down), and it is taken where that costs at most [`SMALL_SPLIT_GAIN`] × the range
/// as one leaf. The parts' nodes make the same decisions when they are built: a decision
/// depends on the set of triangles only.
///
/// Ranges within one shape are left as they are: there the binned SAH above has already
/// grouped neighbouring triangles, and the SAH cannot tell a patch of a mesh from the walls
/// (both flat pieces whose parts' areas add up to the whole's: three faces of a box have the
/// area of the box). Applied to every range, the rule split 21 % of the leaves of a
/// 10⁶-triangle sphere and of `meshes`, their traversal instructions rose by 0.8–4.5 %
/// (the sphere, the matpreview object, the bunny) and the build took 20 % longer, while rays
/// cross the box of a patch mostly where they meet it and that of the walls from every
/// surface in the room.
pub(super) fn split_small(range: &mut [PrimBox]) -> Option<usize> {
    let n = range.len();
    debug_assert!(n <= LEAF_TRIS as usize);
    if range.iter().all(|p| p.tri_shape == range[0].tri_shape) {
        return None;
    }
    let mut r = SmallRange {
        lo: [Vec3A::ZERO; LEAF_TRIS as usize],
        hi: [Vec3A::ZERO; LEAF_TRIS as usize],
        c2: [Vec3A::ZERO; LEAF_TRIS as usize],
        index: [0; LEAF_TRIS as usize],
    };
    let mut order = [0u8; LEAF_TRIS as usize];
    for (k, p) in range.iter().enumerate() {
        let (lo, hi) = (p.lo(), p.hi());
        r.lo[k] = lo;
        r.hi[k] = hi;
        r.c2[k] = lo + hi;
        r.index[k] = p.index();
        order[k] = k as u8;
    }
    let (_, m) = small_cost(&r, &mut order[..n], 0);
    if m == 0 {
        return None;
    }
    let mut sorted = [range[0]; LEAF_TRIS as usize];
    for (s, &k) in sorted.iter_mut().zip(&order[..n]) {
        *s = range[k as usize];
    }
    range.copy_from_slice(&sorted[..n]);
    Some(m)
}

/// How many levels of splits below a range [`split_small`] looks at (the parts of its parts
/// are costed as leaves): enough to see that three far-apart pairs of triangles are best as
/// three leaves, at a third of a full look-ahead's build time.
const SMALL_LOOKAHEAD: u32 = 2;

/// The cost of the triangles `order` (positions in `r`) as [`split_small`] builds them,
/// looking `SMALL_LOOKAHEAD − depth` levels down, and their split (0: one leaf), `order`
/// sorted for that split.
fn small_cost(r: &SmallRange, order: &mut [u8], depth: u32) -> (f32, usize) {
    let n = order.len();
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let (mut clo, mut chi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for &k in order.iter() {
        let k = k as usize;
        lo = lo.min(r.lo[k]);
        hi = hi.max(r.hi[k]);
        clo = clo.min(r.c2[k]);
        chi = chi.max(r.c2[k]);
    }
    let packets = |k: usize| k.div_ceil(LANES) as f32 + LEAF_VISIT_COST;
    let leaf = half_area_f32(lo, hi) * packets(n);
    let ext = chi - clo;
    let axis = widest_axis(ext.to_array());
    // (one triangle, or centroids that coincide: nothing to split along)
    if n < 2
        || ext[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
        || depth == SMALL_LOOKAHEAD
    {
        return (leaf, 0);
    }
    // insertion sort by centroid, ties by primitive index
    let mut keys = [0u64; LEAF_TRIS as usize];
    for (key, &k) in keys.iter_mut().zip(order.iter()) {
        *key = order_key(r.c2[k as usize][axis], r.index[k as usize]);
    }
    for i in 1..n {
        let (key, k) = (keys[i], order[i]);
        let mut j = i;
        while j > 0 && keys[j - 1] > key {
            keys[j] = keys[j - 1];
            order[j] = order[j - 1];
            j -= 1;
        }
        keys[j] = key;
        order[j] = k;
    }
    // the prefix boxes' half-areas, then a sweep from the right
    let mut left = [0.0f32; LEAF_TRIS as usize];
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for (k, &t) in order.iter().enumerate().take(n - 1) {
        lo = lo.min(r.lo[t as usize]);
        hi = hi.max(r.hi[t as usize]);
        left[k + 1] = half_area_f32(lo, hi);
    }
    let (mut best, mut m) = (f32::INFINITY, 0);
    let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for k in (1..n).rev() {
        lo = lo.min(r.lo[order[k] as usize]);
        hi = hi.max(r.hi[order[k] as usize]);
        let cost = left[k] * packets(k) + half_area_f32(lo, hi) * packets(n - k);
        if cost < best {
            (best, m) = (cost, k);
        }
    }
    let (a, b) = order.split_at_mut(m);
    let split = small_cost(r, a, depth + 1).0 + small_cost(r, b, depth + 1).0;
    if split <= SMALL_SPLIT_GAIN * leaf {
        (split, m)
    } else {
        (leaf, 0)
    }
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
    let axis = widest_axis(ext.to_array());
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
                _mm_add_pd, _mm_cvtps_pd, _mm_cvtsi128_si32, _mm_cvttpd_epi32, _mm_mul_pd,
                _mm_set1_pd, _mm_set_pd, _mm_shuffle_epi32, _mm_sub_pd,
            };
            // SAFETY (each block): SSE2 is part of the x86-64 baseline; the corners are
            // 16-byte aligned (see `PrimBox::quad`)
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
                    let lo = _mm_cvtps_pd(p.quad(0));
                    let hi = _mm_cvtps_pd(p.quad(4));
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
        let c = p.c();
        if bin_of(c[a], a) < k {
            parts[0].add_at(p, c);
            range.swap(m, j);
            m += 1;
        } else {
            parts[1].add_at(p, c);
        }
    }
    if m == 0 || m == range.len() {
        // cannot happen (both sides counted non-empty), but never build an endless loop
        return median(range);
    }
    (m, Some(parts))
}
