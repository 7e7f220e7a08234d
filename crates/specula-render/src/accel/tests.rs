//! Tests of the BVH: against brute force, the reference build, every instruction set.

use super::build::*;
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
fn reference_build_binary(
    boxes: &[(Vec3, Vec3)],
    shapes: &[Option<u32>],
) -> (Vec<BNode>, Vec<u32>) {
    let cent: Vec<DVec3> = boxes
        .iter()
        .map(|(lo, hi)| (lo.as_dvec3() + hi.as_dvec3()) * 0.5)
        .collect();
    let tri = |i: u32| shapes[i as usize].is_some();
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
        // small triangle ranges: one leaf unless `split_small` splits them (shared with the
        // build: what is checked here is everything around it)
        let small = if r.len() <= LEAF_TRIS as usize && r.iter().all(|&i| tri(i)) {
            let mut pb: Vec<PrimBox> = r
                .iter()
                .map(|&i| {
                    let (lo, hi) = boxes[i as usize];
                    PrimBox::new(lo, hi, shapes[i as usize], i)
                })
                .collect();
            match split_small(&mut pb) {
                Some(m) => {
                    for (slot, p) in r.iter_mut().zip(&pb) {
                        *slot = p.index();
                    }
                    Some(m)
                }
                None => {
                    tree.push(BNode {
                        lo,
                        hi,
                        kids: [s as u32, NO_CHILD],
                        count: r.len() as u32,
                    });
                    continue;
                }
            }
        } else {
            None
        };
        let mid = if let Some(m) = small {
            m
        } else if ext[axis].partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
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
        });
        todo.push((s + mid, e, index, 1, depth + 1));
        todo.push((s, s + mid, index, 0, depth + 1));
    }
    for i in (0..tree.len()).rev() {
        if !tree[i].is_leaf() {
            let [a, b] = tree[i].kids.map(|k| k as usize);
            tree[i].count = tree[a].count + tree[b].count;
        }
    }
    (tree, range)
}

/// A binary build tree's nodes depth-first, first child first, whatever slots they
/// occupy: box bits, count, triangles only, and for a leaf its primitives.
#[allow(clippy::type_complexity)]
fn canonical((tree, order): &(Vec<BNode>, Vec<u32>)) -> Vec<([u32; 3], [u32; 3], u32, Vec<u32>)> {
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
        out.push((bits(n.lo), bits(n.hi), n.count, prims));
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
        // the triangles as one shape, and spread over three (where small ranges of several
        // shapes go through `split_small`)
        for spread in [1, 3] {
            let ids: Vec<Option<u32>> = shapes
                .iter()
                .enumerate()
                .map(|(i, s)| matches!(s, TestPrim::Tri(_)).then_some(i as u32 % spread))
                .collect();
            let want = canonical(&reference_build_binary(&boxes, &ids));
            let got = canonical(&build_binary(&boxes, &ids));
            assert_eq!(got.len(), want.len(), "{} primitives", shapes.len());
            for (i, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    g,
                    w,
                    "node {i} of {} ({} primitives, {spread} shapes)",
                    want.len(),
                    shapes.len()
                );
            }
        }
    }
}

/// The leaves `split_small` makes of `pb` (splitting its parts again, as the build does),
/// each as its primitives' indices.
fn small_leaves(pb: &mut [PrimBox]) -> Vec<Vec<u32>> {
    match split_small(pb) {
        Some(m) => {
            let (a, b) = pb.split_at_mut(m);
            let mut out = small_leaves(a);
            out.extend(small_leaves(b));
            out
        }
        None => vec![pb.iter().map(PrimBox::index).collect()],
    }
}

/// A small range of triangles far apart (three walls of a room, two triangles each, as
/// `rectangle`s make them) is split into one leaf per wall, whose thin boxes a ray crosses
/// only where it meets the wall, instead of one leaf whose box is the room; a compact one
/// (the 8 faces of an octahedron, whose halves' boxes are as large as the whole's) stays one
/// leaf, and so do the walls when they belong to one shape. Decisions do not depend on the
/// order the triangles come in.
#[test]
fn small_ranges_split_where_the_sah_gains() {
    let walls = [
        (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, -1.0, 1.0)), // floor
        (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, -1.0)), // back
        (Vec3::new(1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0)),   // right
    ];
    for order in [[0u32, 1, 2, 3, 4, 5], [5, 2, 0, 3, 1, 4]] {
        let mut pb: Vec<PrimBox> = order
            .iter()
            .map(|&i| {
                let (lo, hi) = walls[i as usize / 2];
                PrimBox::new(lo, hi, Some(i / 2), i)
            })
            .collect();
        let mut leaves = small_leaves(&mut pb);
        for l in &mut leaves {
            l.sort();
        }
        leaves.sort();
        assert_eq!(
            leaves,
            vec![vec![0, 1], vec![2, 3], vec![4, 5]],
            "{order:?}"
        );
        // the same walls as one shape
        let mut one: Vec<PrimBox> = order
            .iter()
            .map(|&i| {
                let (lo, hi) = walls[i as usize / 2];
                PrimBox::new(lo, hi, Some(7), i)
            })
            .collect();
        assert_eq!(split_small(&mut one), None);
    }
    // the octahedron |x| + |y| + |z| = 1: face (sx, sy, sz) spans its octant
    let mut pb: Vec<PrimBox> = (0..8u32)
        .map(|i| {
            let s = Vec3::new(
                if i & 1 == 0 { 1.0 } else { -1.0 },
                if i & 2 == 0 { 1.0 } else { -1.0 },
                if i & 4 == 0 { 1.0 } else { -1.0 },
            );
            PrimBox::new(s.min(Vec3::ZERO), s.max(Vec3::ZERO), Some(i), i)
        })
        .collect();
    assert_eq!(split_small(&mut pb), None);
}

/// Mitsuba's Cornell box as `rectangle`s and `cube`s (the geometry of
/// ../shared/scenes/cbox.xml): with its walls in leaves of their own, the BVH answers rays
/// from inside the room (closest hit and occlusion, every instruction set) as brute force
/// does, and its root holds no leaf whose box is the room.
#[test]
fn room_of_rectangles_matches_brute_force() {
    use glam::Quat;
    let rect = |r: Quat, t: Vec3| Geometry::rectangle(Mat4::from_rotation_translation(r, t), false);
    let (rx, ry) = (Quat::from_rotation_x, Quat::from_rotation_y);
    let h = std::f32::consts::FRAC_PI_2;
    let geoms = vec![
        Geometry::rectangle(
            Mat4::from_translation(Vec3::new(0.0, 0.99, 0.01))
                * Mat4::from_quat(rx(h))
                * Mat4::from_scale(Vec3::new(0.23, 0.19, 1.0)),
            false,
        ),
        rect(rx(-h), Vec3::new(0.0, -1.0, 0.0)),
        rect(rx(h), Vec3::new(0.0, 1.0, 0.0)),
        rect(Quat::IDENTITY, Vec3::new(0.0, 0.0, -1.0)),
        rect(ry(-h), Vec3::new(1.0, 0.0, 0.0)),
        rect(ry(h), Vec3::new(-1.0, 0.0, 0.0)),
        Geometry::cube(
            Mat4::from_translation(Vec3::new(0.335, -0.7, 0.38))
                * Mat4::from_quat(ry(-0.314))
                * Mat4::from_scale(Vec3::splat(0.3)),
            false,
        ),
        Geometry::cube(
            Mat4::from_translation(Vec3::new(-0.335, -0.4, -0.28))
                * Mat4::from_quat(ry(0.314))
                * Mat4::from_scale(Vec3::new(0.3, 0.6, 0.3)),
            false,
        ),
    ];
    let bvh = Bvh::build(&geoms);
    // triangles only: the walks make each ray's triangle constants up front
    assert!(!bvh.lazy);
    // no child of the root is a leaf whose box holds most of the room
    let root = &bvh.nodes[0];
    for s in 0..WIDTH {
        let c = root.child[s];
        if c & LEAF != 0 && c & ANALYTIC == 0 {
            let e = Vec3::new(
                root.b[1][s] - root.b[0][s],
                root.b[3][s] - root.b[2][s],
                root.b[5][s] - root.b[4][s],
            );
            assert!(e.min_element() < 1.0, "leaf {s} spans {e:?}");
        }
    }
    let mut rng = Rng(11);
    let mut hits = 0;
    for i in 0..4000 {
        let o = rng.in_box(Vec3::splat(-0.95), Vec3::splat(0.95));
        let t_max = if i % 4 == 0 { rng.f() } else { f32::INFINITY };
        let ray = Ray {
            o,
            d: rng.dir(),
            t_max,
        };
        let want = brute_force_bvh(&bvh, &ray);
        for isa in Isa::available() {
            let mut b = bvh.clone();
            b.set_isa(isa);
            let got = b.intersect(&ray);
            assert_eq!(
                got.map(|h| h.t),
                want.map(|h| h.t),
                "{isa:?} ray {i}: {ray:?}"
            );
            assert_eq!(b.occluded(&ray), want.is_some(), "{isa:?} ray {i}");
        }
        hits += want.is_some() as usize;
    }
    assert!(hits > 2500, "only {hits} hits");
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
            Mat4::from_translation(Vec3::new(-1.2, 1.1, 0.0)) * Mat4::from_scale(Vec3::splat(0.9)),
            false,
            false,
        )
        .unwrap(),
        Geometry::mesh(
            ico,
            Mat4::from_translation(Vec3::new(1.4, 0.9, 0.2)) * Mat4::from_scale(Vec3::splat(0.7)),
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
            Mat4::from_translation(Vec3::new(2.5, 0.5, -1.5)) * Mat4::from_scale(Vec3::splat(0.3)),
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
            let v = [0, 1, 2].map(|k| Vec3::new(p.v[k][0][lane], p.v[k][1][lane], p.v[k][2][lane]));
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
        if let Some((t, u, v, sub)) = bvh.intersect_analytic(LEAF | ANALYTIC | i as u32, ray, t_max)
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
    // the tree holds a sphere and a disk, so its walks make the triangle constants lazily;
    // each instruction set runs both ways (`TriRayCell`), which must agree bit for bit
    assert!(bvh.lazy);
    let bvhs: Vec<((Isa, bool), Bvh)> = isas
        .iter()
        .flat_map(|&isa| [(isa, true), (isa, false)])
        .map(|(isa, lazy)| {
            let mut b = bvh.clone();
            b.set_isa(isa);
            b.lazy = lazy;
            ((isa, lazy), b)
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

/// The AVX2 packet walk checks its rays itself (the `valid_ray` test and the octant of
/// `BoxRay::new`, computed for 8 lanes at once): it declines, writing nothing, a packet with
/// an invalid ray (non-finite origin or direction, a zero direction, t_max ≤ 0) or with rays
/// of two octants, and takes packets of one octant including axis-aligned directions (±0
/// components, which count as positive), giving each ray the single-ray hit.
#[cfg(target_arch = "x86_64")]
#[test]
fn avx2_packet_checks_validity_and_octant_as_the_single_ray_path() {
    if !Isa::Avx2.supported() {
        return;
    }
    let geoms = scene();
    let bvh = Bvh::build(&geoms);
    let o = Vec3::new(0.3, 0.4, -3.5);
    // x and y ≥ 0 (+0 and −0 both count as positive), z > 0
    let base = [
        Vec3::new(0.0, 0.2, 1.0),
        Vec3::new(-0.0, 0.1, 1.0),
        Vec3::new(0.1, -0.0, 1.0),
        Vec3::new(0.2, 0.1, 1.0),
        Vec3::new(0.0, 0.05, 0.5),
        Vec3::new(0.05, 0.25, 1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.3, 0.15, 1.0),
    ];
    let rays: Vec<Ray> = base
        .iter()
        .map(|&d| Ray {
            o,
            d: d.normalize(),
            t_max: f32::INFINITY,
        })
        .collect();
    let key = |h: Option<Hit>| h.map(|h| (h.t, h.shape, h.prim, h.u, h.v));
    // both ways of making the triangle constants (`TriRayCell`), which must agree
    let run = |rays: &[Ray]| {
        let mut hits = [None; 8];
        let mut lazy_hits = [None; 8];
        // SAFETY: AVX2 and FMA are present; 2 to 8 rays, 8 hits, a non-empty tree.
        let taken = unsafe { bvh.closest_packet_avx2::<false>(rays, &mut hits) };
        // SAFETY: as above.
        let lazy_taken = unsafe { bvh.closest_packet_avx2::<true>(rays, &mut lazy_hits) };
        assert_eq!((taken, hits.map(key)), (lazy_taken, lazy_hits.map(key)));
        (taken, hits)
    };
    for n in 2..=8 {
        let (taken, hits) = run(&rays[..n]);
        assert!(taken, "{n} rays of one octant");
        for (k, ray) in rays[..n].iter().enumerate() {
            assert_eq!(key(hits[k]), key(bvh.intersect(ray)), "{n} rays, ray {k}");
        }
    }
    assert!(rays.iter().any(|r| bvh.intersect(r).is_some()));
    type Spoil = (usize, fn(&mut Ray));
    let spoiled: [Spoil; 8] = [
        (0, |r| r.d = Vec3::ZERO),
        (7, |r| r.t_max = 0.0),
        (3, |r| r.t_max = -1.0),
        (5, |r| r.o.x = f32::INFINITY),
        (1, |r| r.o.y = f32::NAN),
        (2, |r| r.d.z = f32::NAN),
        (6, |r| r.d.x = f32::NEG_INFINITY),
        // another octant (−x): a valid ray the packet cannot take
        (4, |r| r.d.x = -0.5),
    ];
    for (i, (lane, spoil)) in spoiled.iter().enumerate() {
        let mut bad = rays.clone();
        spoil(&mut bad[*lane]);
        let (taken, hits) = run(&bad);
        assert!(!taken, "case {i}");
        assert!(hits.iter().all(|h| h.is_none()), "case {i} wrote hits");
        // the dispatching query falls back to single rays
        let mut got = [None; 8];
        bvh.intersect_packet(&bad, &mut got);
        for (k, ray) in bad.iter().enumerate() {
            assert_eq!(key(got[k]), key(bvh.intersect(ray)), "case {i}, ray {k}");
        }
    }
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
    let overrides =
        [("resx", "48"), ("resy", "32"), ("spp", "4")].map(|(k, v)| (k.to_string(), v.to_string()));
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

#[test]
fn invalid_rays_hit_nothing() {
    let geoms = scene();
    let bvh = Bvh::build(&geoms);
    // a ray through the scene that hits something
    let good = Ray {
        o: Vec3::new(0.0, 1.0, 6.0),
        d: Vec3::new(0.0, 0.0, -1.0),
        t_max: f32::INFINITY,
    };
    assert!(valid_ray(&good));
    assert!(bvh.intersect(&good).is_some() && bvh.occluded(&good));
    let mut bad = Vec::new();
    for bad_value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for axis in 0..3 {
            let mut r = good;
            r.o[axis] = bad_value;
            bad.push(r);
            let mut r = good;
            r.d[axis] = bad_value;
            bad.push(r);
        }
    }
    for d in [Vec3::ZERO, Vec3::new(-0.0, 0.0, -0.0)] {
        bad.push(Ray { d, ..good });
    }
    for t_max in [0.0, -0.0, -1.0, f32::NAN] {
        bad.push(Ray { t_max, ..good });
    }
    for r in &bad {
        assert!(!valid_ray(r), "{r:?}");
        for isa in Isa::available() {
            let mut b = bvh.clone();
            b.set_isa(isa);
            assert!(b.intersect(r).is_none() && !b.occluded(r), "{isa:?} {r:?}");
        }
    }
    // a direction with one non-zero (even subnormal) component is valid
    assert!(valid_ray(&Ray {
        d: Vec3::new(0.0, 0.0, -1e-40),
        ..good
    }));
}
