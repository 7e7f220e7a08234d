//! The SSE2 and AVX2 + FMA box and triangle tests and the AVX2 entry points of the walks
//! (picked at run time, see [`super::Isa`]).

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
                    _mm_sub_ps(_mm_load_ps(p.v[$v].get_unchecked(kx).as_ptr()), ox),
                    _mm_sub_ps(_mm_load_ps(p.v[$v].get_unchecked(ky).as_ptr()), oy),
                    _mm_sub_ps(_mm_load_ps(p.v[$v].get_unchecked(kz).as_ptr()), oz),
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
                    _mm_load_ps(p1.v[$v].get_unchecked($k).as_ptr()),
                    _mm_load_ps(p0.v[$v].get_unchecked($k).as_ptr()),
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

// The walks are out of line (here and in `closest_scalar`/`any_hit_scalar`), so that the
// dispatching `Intersector` methods stay small: inlined, a walk's stack frame and register
// saves were paid on every ray whichever walk ran.
impl Bvh {
    #[inline(never)]
    pub(super) fn closest_sse2<const LAZY: bool>(&self, ray: &Ray) -> Option<Hit> {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { self.closest::<Sse2, Sse2, LAZY>(ray) }
    }
    #[inline(never)]
    pub(super) fn occluded_sse2<const LAZY: bool>(&self, ray: &Ray) -> bool {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { self.any_hit::<Sse2, Sse2, LAZY>(ray) }
    }
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn closest_avx2<const LAZY: bool>(&self, ray: &Ray) -> Option<Hit> {
        self.closest::<Avx2, Avx2, LAZY>(ray)
    }
    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn occluded_avx2<const LAZY: bool>(&self, ray: &Ray) -> bool {
        self.any_hit::<Avx2, Avx2, LAZY>(ray)
    }

    /// Closest hits of 2 to 8 rays that share a direction octant, walked as one packet:
    /// each node's 8 boxes are tested against all rays at once (one ray per lane), the stack
    /// holds a child with the rays that entered it and where, and a leaf is tested by each of
    /// its rays with the single-ray test. The per-ray arithmetic is that of `closest_avx2`
    /// (the slab factors are `BoxRay::new`'s, computed for the 8 lanes at once), so the hits
    /// are the same. Returns false, having written nothing, when a ray is not valid
    /// (`valid_ray`) or the rays do not share an octant.
    ///
    /// # Safety
    /// The CPU must support AVX2 and FMA; `rays` holds 2 to 8 rays, `hits` at least as many
    /// hits; the tree is not empty.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn closest_packet_avx2<const LAZY: bool>(
        &self,
        rays: &[Ray],
        hits: &mut [Option<Hit>],
    ) -> bool {
        let n = rays.len();
        let all = (1u32 << n) - 1;
        // lanes ≥ n copy lane n − 1 (and stay inactive)
        // (no `array::from_fn`: its closure would not inherit this function's target
        // features, and was called once per lane)
        let mut r = [&rays[0]; 8];
        for (i, ray) in r.iter_mut().enumerate() {
            *ray = &rays[i.min(n - 1)];
        }
        macro_rules! lanes {
            ($($f:ident).+) => {
                _mm256_setr_ps(
                    r[0].$($f).+, r[1].$($f).+, r[2].$($f).+, r[3].$($f).+,
                    r[4].$($f).+, r[5].$($f).+, r[6].$($f).+, r[7].$($f).+,
                )
            };
        }
        let (ox, oy, oz) = (lanes!(o.x), lanes!(o.y), lanes!(o.z));
        let (dx, dy, dz) = (lanes!(d.x), lanes!(d.y), lanes!(d.z));
        let tm = lanes!(t_max);
        // `valid_ray` for the 8 lanes: finite origin and direction (|x| < ∞ is false for ±∞
        // and NaN), a nonzero direction, t_max > 0
        let zero = _mm256_setzero_ps();
        let inf = _mm256_set1_ps(f32::INFINITY);
        let sign = _mm256_set1_ps(-0.0);
        macro_rules! finite {
            ($v:expr) => {
                _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_andnot_ps(sign, $v), inf)
            };
        }
        let ok = _mm256_and_ps(
            _mm256_and_ps(
                _mm256_and_ps(finite!(ox), finite!(oy)),
                _mm256_and_ps(finite!(oz), finite!(dx)),
            ),
            _mm256_and_ps(
                _mm256_and_ps(finite!(dy), finite!(dz)),
                _mm256_cmp_ps::<_CMP_GT_OQ>(tm, zero),
            ),
        );
        let nonzero = _mm256_or_ps(
            _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_NEQ_UQ>(dx, zero),
                _mm256_cmp_ps::<_CMP_NEQ_UQ>(dy, zero),
            ),
            _mm256_cmp_ps::<_CMP_NEQ_UQ>(dz, zero),
        );
        if _mm256_movemask_ps(_mm256_and_ps(ok, nonzero)) != 0xff {
            return false;
        }
        // `BoxRay::new` for the 8 lanes: +0 for zero components (including −0), which get
        // +MAX_INV_DIR; 1/d clamped to ±MAX_INV_DIR
        let max = _mm256_set1_ps(MAX_INV_DIR);
        let min = _mm256_set1_ps(-MAX_INV_DIR);
        let one = _mm256_set1_ps(1.0);
        macro_rules! inv {
            ($d:expr) => {{
                let d = _mm256_add_ps($d, zero);
                let q = _mm256_min_ps(_mm256_max_ps(_mm256_div_ps(one, d), min), max);
                _mm256_blendv_ps(q, max, _mm256_cmp_ps::<_CMP_EQ_OQ>(d, zero))
            }};
        }
        let (inx, iny, inz) = (inv!(dx), inv!(dy), inv!(dz));
        // one octant: each axis's sign the same in every lane
        macro_rules! neg {
            ($v:expr) => {
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>($v, zero))
            };
        }
        let (nx, ny, nz) = (neg!(inx), neg!(iny), neg!(inz));
        if ![nx, ny, nz].iter().all(|&m| m == 0 || m == 0xff) {
            return false;
        }
        let bit = |m: i32| (m & 1) as usize;
        let near = [bit(nx), 2 + bit(ny), 4 + bit(nz)].map(|p| p * WIDTH);
        let far = [1 - bit(nx), 3 - bit(ny), 5 - bit(nz)].map(|p| p * WIDTH);
        // the slab factors: o·inv, and both times EXIT_SCALE for the exit planes
        let (onx, ony, onz) = (
            _mm256_mul_ps(ox, inx),
            _mm256_mul_ps(oy, iny),
            _mm256_mul_ps(oz, inz),
        );
        let exit = _mm256_set1_ps(EXIT_SCALE);
        let (ifx, ify, ifz) = (
            _mm256_mul_ps(inx, exit),
            _mm256_mul_ps(iny, exit),
            _mm256_mul_ps(inz, exit),
        );
        let (ofx, ofy, ofz) = (
            _mm256_mul_ps(onx, exit),
            _mm256_mul_ps(ony, exit),
            _mm256_mul_ps(onz, exit),
        );
        let mut trs = [
            TriRayCell::<LAZY>::new(r[0]),
            TriRayCell::<LAZY>::new(r[1]),
            TriRayCell::<LAZY>::new(r[2]),
            TriRayCell::<LAZY>::new(r[3]),
            TriRayCell::<LAZY>::new(r[4]),
            TriRayCell::<LAZY>::new(r[5]),
            TriRayCell::<LAZY>::new(r[6]),
            TriRayCell::<LAZY>::new(r[7]),
        ];
        let mut t_max = [0f32; 8];
        _mm256_storeu_ps(t_max.as_mut_ptr(), tm);
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
                    let m = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32 & active;
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
                    self.leaf_closest::<Avx2, LAZY>(
                        cur,
                        &rays[lane],
                        &mut trs[lane],
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
                let m = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, tmax)) as u32 & e.mask;
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
        true
    }
}
