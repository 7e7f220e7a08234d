/// Uniform numbers in [0, 1) from a 64-bit LCG seeded with `seed` (the tests' fixed
/// sequences).
fn lcg(mut seed: u64) -> impl FnMut() -> f32 {
    move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// The guided search returns exactly the whole-CDF binary search's bin and offset, on
/// CDFs with empty bins, flat runs, steps and a single bin.
#[test]
fn guided_cdf_search_is_exact() {
    let mut rnd = lcg(1);
    let mut cases: Vec<Vec<f64>> = vec![vec![1.0], vec![0.0, 1.0], vec![1.0, 0.0, 0.0, 0.0, 0.0]];
    for n in [2usize, 3, 5, 7, 16, 33, 100, 513] {
        cases.push((0..n).map(|_| rnd() as f64).collect());
        // mostly empty with a bright spot (a sun), and flat runs of equal weights
        cases.push(
            (0..n)
                .map(|i| {
                    if i == n / 3 {
                        1e6
                    } else if i % 5 == 0 {
                        0.0
                    } else {
                        1e-3
                    }
                })
                .collect(),
        );
        cases.push((0..n).map(|i| if i < n / 2 { 0.0 } else { 1.0 }).collect());
    }
    for w in &cases {
        let total: f64 = w.iter().sum();
        let mut cdf = vec![0.0f32];
        let mut acc = 0.0;
        for x in w {
            acc += x;
            cdf.push(if acc >= total {
                1.0
            } else {
                (acc / total) as f32
            });
        }
        for per in [1, super::guide::ROW_BINS, super::guide::COL_BINS, 100] {
            let mut g = vec![];
            super::guide::build(&cdf, per, &mut g);
            assert_eq!(g.len(), super::guide::buckets(w.len(), per) + 1);
            let mut us: Vec<f32> = (0..2000).map(|_| rnd()).collect();
            // the CDF's own values, the bucket edges and their neighbours
            for &c in &cdf {
                us.extend([
                    c,
                    f32::from_bits(c.to_bits().saturating_sub(1)),
                    f32::from_bits(c.to_bits() + 1),
                ]);
            }
            let m = g.len() - 1;
            for k in 0..=m {
                let t = k as f32 / m as f32;
                us.extend([
                    t,
                    f32::from_bits(t.to_bits().saturating_sub(1)),
                    f32::from_bits(t.to_bits() + 1),
                ]);
            }
            us.extend([0.0, 1.0 - f32::EPSILON / 2.0]);
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let a = super::sample_cdf(&cdf, u);
                let b = super::guide::sample::<true>(&cdf, &g, u);
                assert_eq!(b, super::guide::sample::<false>(&cdf, &g, u));
                assert_eq!(a, b, "u = {u}, {per} bins per bucket, cdf {cdf:?}");
            }
        }
    }
}

use super::*;
use specula_bsdf::rng::Pcg32;
use std::f32::consts::FRAC_1_SQRT_2;

fn asset(name: &str) -> Option<std::path::PathBuf> {
    specula_testdata::shared(&format!("scenes/assets/{name}"))
}

fn envmap(name: &str, scale: f32, to_world: Mat4) -> Option<Emitter> {
    asset(name).map(|p| Emitter::envmap_from_file(&p, scale, &to_world).unwrap())
}

fn close(a: Rgb, b: [f32; 3], tol: f32) -> bool {
    (0..3).all(|i| (a[i] - b[i]).abs() <= tol * b[i].abs().max(1e-3))
}

/// A direction from Mitsuba's lat-long coordinates.
fn uv_dir(u: f64, v: f64) -> Vec3 {
    let (th, ph) = (v * std::f64::consts::PI, u * 2.0 * std::f64::consts::PI);
    Vec3::new(
        (ph.sin() * th.sin()) as f32,
        th.cos() as f32,
        (-ph.cos() * th.sin()) as f32,
    )
}

#[test]
fn envmap_eval_matches_mitsuba() {
    let Some(e) = envmap("sky.exr", 1.0, Mat4::IDENTITY) else {
        return;
    };
    // Mitsuba 3.9.1 (scalar_rgb) envmap.eval(si) with si.wi = −d. Pixel (x, y) of the
    // 512×256 file sits at u = (x + ½)/512, v = y/255; (153, 60) is the sun, (400, 360, 300).
    let at_pixels = [
        ((0, 0), [0.250006, 0.450004, 0.899999]),
        ((10, 20), [0.260312, 0.456346, 0.898414]),
        ((153, 60), [399.998, 359.999, 299.999]),
        ((100, 128), [0.18, 0.15, 0.12]),
        ((300, 1), [0.250055, 0.450034, 0.899992]),
    ];
    for ((x, y), want) in at_pixels {
        let d = uv_dir((x as f64 + 0.5) / 512.0, y as f64 / 255.0);
        let got = e.eval_direction(d);
        assert!(
            close(got, want, 1e-4),
            "pixel ({x}, {y}): {got:?} vs {want:?}"
        );
    }
    let dirs = [
        (Vec3::new(0.0, 1.0, 0.0), [0.250006, 0.450004, 0.899999]),
        (Vec3::new(0.0, -1.0, 0.0), [0.18, 0.15, 0.12]),
        (Vec3::new(1.0, 0.0, 0.0), [0.514542, 0.484334, 0.463917]),
        (Vec3::new(0.0, 0.0, 1.0), [0.514542, 0.484334, 0.463917]),
        (Vec3::new(0.3, 0.5, -0.2), [0.315389, 0.490239, 0.88994]),
        (Vec3::new(-0.7, 0.1, 0.4), [0.672467, 0.70998, 0.835005]),
    ];
    for (d, want) in dirs {
        let got = e.eval_direction(d.normalize());
        assert!(close(got, want, 1e-4), "{d}: {got:?} vs {want:?}");
    }
    // sky_soft.exr (no sun).
    let Some(e) = envmap("sky_soft.exr", 1.0, Mat4::IDENTITY) else {
        return;
    };
    for (d, want) in [
        (Vec3::new(0.64, 0.74, 0.21), [0.341861, 0.50653, 0.885867]),
        (Vec3::new(0.0, 0.2, 1.0), [0.61274, 0.673224, 0.844194]),
        (Vec3::new(0.1, -0.9, 0.3), [0.18, 0.15, 0.12]),
    ] {
        let got = e.eval_direction(d.normalize());
        assert!(close(got, want, 1e-4), "soft {d}: {got:?} vs {want:?}");
    }
}

#[test]
fn envmap_to_world_and_scale_match_mitsuba() {
    // Mitsuba 3.9.1: scale 2.5, to_world = rotate(y, 90°)·rotate(x, −30°).
    let m = Mat4::from_rotation_y(90f32.to_radians()) * Mat4::from_rotation_x(-30f32.to_radians());
    let Some(e) = envmap("sky.exr", 2.5, m) else {
        return;
    };
    for (d, want) in [
        (Vec3::new(0.3, 0.5, -0.2), [1.15095, 1.44866, 2.16908]),
        (Vec3::new(-0.7, 0.1, 0.4), [1.06083, 1.3932, 2.18295]),
        (Vec3::new(0.64, 0.74, 0.21), [1.33156, 1.55981, 2.1413]),
        (Vec3::new(0.1, -0.9, 0.3), [0.45, 0.375, 0.3]),
        (Vec3::new(0.0, 0.2, 1.0), [1.58171, 1.71374, 2.10281]),
    ] {
        let got = e.eval_direction(d.normalize());
        assert!(close(got, want, 2e-4), "{d}: {got:?} vs {want:?}");
    }
    check_sampling(&e, 11);
}

/// ∫ pdf dω and ∫ L dω over the sphere. The pdf is integrated on a (u, cos θ) grid aligned
/// with the sampling cells (exact for the pdf, bilinear in (u, cos θ) per cell), the radiance on a (u, v) grid
/// aligned with the lookup's cells (8 × 8 midpoints each; smooth per piece).
fn integrals(env: &Envmap) -> (f64, [f64; 3]) {
    let (w, h) = (env.width, env.height);
    let (nu, sub) = (8 * w, 8);
    let mut pdf = 0.0f64;
    for j in 0..h - 1 {
        let (z1, z0) = (env.cos_theta[j] as f64, env.cos_theta[j + 1] as f64);
        for k in 0..sub {
            let z = z0 + (z1 - z0) * (k as f64 + 0.5) / sub as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            for a in 0..nu {
                let phi = 2.0 * std::f64::consts::PI * (a as f64 + 0.5) / nu as f64;
                let d = Vec3::new((phi.sin() * r) as f32, z as f32, (-phi.cos() * r) as f32);
                let dw = 2.0 * std::f64::consts::PI / nu as f64 * (z1 - z0) / sub as f64;
                pdf += env.pdf(env.to_world * d) as f64 * dw;
            }
        }
    }
    let nv = 8 * (h - 1);
    let mut l = [0.0f64; 3];
    for b in 0..nv {
        let v = (b as f64 + 0.5) / nv as f64;
        let jac = 2.0 * std::f64::consts::PI.powi(2) * (v * std::f64::consts::PI).sin();
        for a in 0..nu {
            let u = (a as f64 + 0.5) / nu as f64;
            let r = env.eval(env.to_world * uv_dir(u, v));
            for c in 0..3 {
                l[c] += r[c] as f64 * jac / (nu * nv) as f64;
            }
        }
    }
    (pdf, l)
}

/// Length of the overlap of [a0, a1] with [b0, b1].
fn overlap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    (a1.min(b1) - a0.max(b0)).max(0.0)
}

/// Sample/pdf consistency, a histogram (χ²) test and an unbiasedness test.
fn check_sampling(e: &Emitter, seed: u64) {
    let Emitter::Envmap(env) = e else {
        unreachable!()
    };
    let (w, h) = (env.width, env.height);
    let (integral, reference) = integrals(env);
    assert!((integral - 1.0).abs() < 1e-4, "∫ pdf = {integral}");

    let mut rng = Pcg32::new(seed, 3);
    let n = 400_000;
    // Histogram over equal-area bins of the local (u, z = cos θ).
    let (bu, bv) = (24usize, 12usize);
    let mut hist = vec![0u32; bu * bv];
    let mut mismatched = 0;
    let mut est = [0f64; 3];
    for _ in 0..n {
        let s = e
            .sample_direction(Vec3::new(1.0, 2.0, 3.0), rng.next_vec2())
            .unwrap();
        assert!(s.pdf > 0.0 && s.dist == f32::INFINITY && !s.is_delta);
        assert!((s.wi.length() - 1.0).abs() < 1e-5);
        let p = e.pdf_direction(s.wi);
        let l = e.eval_direction(s.wi);
        let (l2, p2) = e.eval_pdf_direction(s.wi);
        assert_eq!(
            (l.0.map(f32::to_bits), p.to_bits()),
            (l2.0.map(f32::to_bits), p2.to_bits())
        );
        if (p - s.pdf).abs() > 1e-3 * s.pdf || !close(l, s.radiance.0, 1e-3) {
            mismatched += 1;
        }
        for (c, acc) in est.iter_mut().enumerate() {
            *acc += (s.radiance[c] / s.pdf) as f64;
        }
        let d = (env.to_local * s.wi).normalize();
        let u = Envmap::direction_to_uv(d).x;
        let a = ((u - u.floor()) * bu as f32) as usize;
        let b = ((1.0 - d.y.clamp(-1.0, 1.0)) * 0.5 * bv as f32) as usize;
        hist[b.min(bv - 1) * bu + a.min(bu - 1)] += 1;
    }
    // Samples on cell boundaries may round into the neighbouring cell.
    assert!(
        mismatched < n / 1000,
        "{mismatched} samples disagree with pdf/eval"
    );

    // Expected bin masses, exactly: each cell is a rectangle in (u, z) whose solid-angle
    // density is the bilinear interpolation of its corners' in (x, s), the fractions of its
    // width and of its band's z, so a bin's share of a cell is a sum of products of
    // one-dimensional integrals of 1 − t and t.
    let corner = |y: usize, x: usize| env.data[y * (w + 1) + x].w as f64;
    // ∫ (1 − t) dt and ∫ t dt over [t0, t1]
    let lin = |t0: f64, t1: f64| {
        [
            (t1 - t0) - (t1 * t1 - t0 * t0) / 2.0,
            (t1 * t1 - t0 * t0) / 2.0,
        ]
    };
    let mut expect = vec![0f64; bu * bv];
    for j in 0..h - 1 {
        let (z1, z0) = (env.cos_theta[j] as f64, env.cos_theta[j + 1] as f64);
        let omega = 2.0 * std::f64::consts::PI / w as f64 * (z1 - z0);
        for i in 0..w {
            let d = [
                [corner(j, i), corner(j, i + 1)],
                [corner(j + 1, i), corner(j + 1, i + 1)],
            ];
            if d.iter().flatten().all(|&v| v == 0.0) {
                continue;
            }
            let (u0, u1) = ((i as f64 + 0.5) / w as f64, (i as f64 + 1.5) / w as f64);
            for b in 0..bv {
                let (bz1, bz0) = (
                    1.0 - 2.0 * b as f64 / bv as f64,
                    1.0 - 2.0 * (b + 1) as f64 / bv as f64,
                );
                if overlap(z0, z1, bz0, bz1) == 0.0 {
                    continue;
                }
                // s = (z1 − z) / (z1 − z0) over the bin's part of the band
                let is = lin(
                    (z1 - bz1.min(z1)) / (z1 - z0),
                    (z1 - bz0.max(z0)) / (z1 - z0),
                );
                for a in 0..bu {
                    let (a0, a1) = (a as f64 / bu as f64, (a + 1) as f64 / bu as f64);
                    // the cell's x over the bin, the cell also seen one turn back (it may
                    // cross u = 1)
                    let mut ix = [0.0f64; 2];
                    for shift in [0.0, 1.0] {
                        let (c0, c1) = (u0 - shift, u1 - shift);
                        if overlap(c0, c1, a0, a1) > 0.0 {
                            let part =
                                lin((a0.max(c0) - c0) * w as f64, (a1.min(c1) - c0) * w as f64);
                            ix[0] += part[0];
                            ix[1] += part[1];
                        }
                    }
                    let mut mass = 0.0;
                    for (sy, row) in d.iter().enumerate() {
                        for (sx, &v) in row.iter().enumerate() {
                            mass += v * ix[sx] * is[sy];
                        }
                    }
                    expect[b * bu + a] += mass * omega;
                }
            }
        }
    }
    let mut chi2 = 0.0;
    let mut dof = 0.0f64;
    for (k, (&o, &p)) in hist.iter().zip(&expect).enumerate() {
        let ex = p * n as f64;
        assert!(
            (o as f64 - ex).abs() < 6.0 * ex.sqrt() + 3.0,
            "bin {k}: {o} vs {ex:.1}"
        );
        if ex > 5.0 {
            chi2 += (o as f64 - ex).powi(2) / ex;
            dof += 1.0;
        }
    }
    assert!(
        chi2 < dof + 5.0 * (2.0 * dof).sqrt(),
        "χ² = {chi2} ({dof} bins)"
    );

    // E[L/pdf] = ∫ L dω.
    for c in 0..3 {
        let mc = est[c] / n as f64;
        assert!(
            (mc / reference[c] - 1.0).abs() < 0.01,
            "channel {c}: {mc} vs {}",
            reference[c]
        );
    }
}

#[test]
fn envmap_sampling_is_consistent_and_finds_the_sun() {
    let Some(e) = envmap("sky.exr", 1.0, Mat4::IDENTITY) else {
        return;
    };
    check_sampling(&e, 1);
    // The sun (a few very bright pixels, < 0.1 % of the sphere) carries a large part of
    // the power; sampling sends that part of the samples into its cells.
    let Emitter::Envmap(env) = &e else {
        unreachable!()
    };
    let (w, h) = (env.width, env.height);
    let bright = |j: usize, i: usize| {
        [(j, i), (j, i + 1), (j + 1, i), (j + 1, i + 1)]
            .iter()
            .any(|&(y, x)| env.texel(y * (w + 1) + x).luminance() > 10.0)
    };
    let (mut sun_mass, mut sun_area) = (0.0f64, 0.0f64);
    for j in 0..h - 1 {
        let omega = 2.0 * std::f64::consts::PI / w as f64
            * (env.cos_theta[j] - env.cos_theta[j + 1]) as f64;
        for i in 0..w {
            if bright(j, i) {
                sun_mass += env.cell_pdf(j * w + i) as f64 * omega;
                sun_area += omega / (4.0 * std::f64::consts::PI);
            }
        }
    }
    assert!(
        sun_area < 1e-3 && sun_mass > 0.2,
        "sun: area {sun_area}, mass {sun_mass}"
    );
    let mut rng = Pcg32::new(7, 0);
    let n = 20_000;
    let hits = (0..n)
        .filter(|_| {
            let s = e.sample_direction(Vec3::ZERO, rng.next_vec2()).unwrap();
            let c = env.cell(env.to_local * s.wi);
            bright(c / w, c % w)
        })
        .count();
    let frac = hits as f64 / n as f64;
    assert!(
        (frac - sun_mass).abs() < 0.02,
        "{frac} of samples hit the sun, expected {sun_mass}"
    );
    if let Some(soft) = envmap("sky_soft.exr", 1.0, Mat4::IDENTITY) {
        check_sampling(&soft, 2);
    }
}

/// The prefetch's coarse cell is the lookup's cell, or a neighbour of it, for directions
/// all over the sphere (a rotated 1024 × 512 map; poles, the seam and axes included).
#[test]
fn envmap_coarse_cell_is_the_lookup_cell_or_a_neighbour() {
    let (w, h) = (1024usize, 512usize);
    let img = Image {
        width: w,
        height: h,
        channels: 1,
        data: (0..w * h).map(|i| (i % 7) as f32 + 0.5).collect(),
    };
    let to_world = Mat4::from_rotation_y(0.7) * Mat4::from_rotation_x(0.3);
    let e = Envmap::new(&img, false, 1.0, &to_world).unwrap();
    let mut dirs = vec![Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z];
    let mut rnd = lcg(7);
    for _ in 0..200_000 {
        let (z, phi) = (2.0 * rnd() - 1.0, 2.0 * PI * rnd());
        let r = (1.0 - z * z).max(0.0).sqrt();
        dirs.push(Vec3::new(r * phi.cos(), z, r * phi.sin()));
    }
    let (mut exact, mut off) = (0, 0);
    for d in dirs {
        let want = e.bilinear_cell(Envmap::direction_to_uv(e.local(d))).0;
        let got = e.coarse_cell(d);
        let (wx, wy) = (want % (w + 1), want / (w + 1));
        let (gx, gy) = (got % (w + 1), got / (w + 1));
        let dx = wx.abs_diff(gx).min(w - wx.abs_diff(gx));
        assert!(
            dx <= 1 && wy.abs_diff(gy) <= 1,
            "{d:?}: ({wx}, {wy}) vs ({gx}, {gy})"
        );
        if got == want {
            exact += 1;
        } else {
            off += 1;
        }
    }
    // measured: 99.5 % exact
    assert!(exact > 50 * off, "{exact} exact, {off} off by one");
}

#[test]
fn envmap_from_small_image_and_black_map() {
    let img = Image {
        width: 4,
        height: 3,
        channels: 1,
        data: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 0.0, 0.0, 0.0, 0.0],
    };
    let e = Emitter::Envmap(Box::new(
        Envmap::new(&img, false, 1.0, &Mat4::IDENTITY).unwrap(),
    ));
    // Pixel (1, 1) sits at u = 1.5/4, on the horizon.
    let got = e.eval_direction(uv_dir(1.5 / 4.0, 0.5));
    assert!(close(got, [6.0; 3], 1e-5), "{got:?}");
    // Halfway between pixels (3, 1) and the wrapped (0, 1).
    let got = e.eval_direction(uv_dir(0.0, 0.5));
    assert!(close(got, [6.5; 3], 1e-5), "{got:?}");
    check_sampling(&e, 5);

    // Black bottom rows: the last cell rows are empty and must never be drawn.
    let mut data = vec![0.0; 16];
    data[..4].copy_from_slice(&[1.0, 2.0, 3.0, 4.0]);
    let img = Image {
        width: 4,
        height: 4,
        channels: 1,
        data,
    };
    let e = Emitter::Envmap(Box::new(
        Envmap::new(&img, false, 1.0, &Mat4::IDENTITY).unwrap(),
    ));
    for u in [0.0, 0.5, 1.0 - f32::EPSILON / 2.0] {
        let s = e.sample_direction(Vec3::ZERO, Vec2::new(u, u)).unwrap();
        assert!(s.pdf > 0.0 && s.wi.y > 0.49, "{s:?}");
    }
    check_sampling(&e, 6);

    let black = Image {
        width: 4,
        height: 3,
        channels: 3,
        data: vec![0.0; 36],
    };
    let e = Emitter::Envmap(Box::new(
        Envmap::new(&black, false, 1.0, &Mat4::IDENTITY).unwrap(),
    ));
    assert!(e.sample_direction(Vec3::ZERO, Vec2::splat(0.5)).is_none());
    assert_eq!(e.pdf_direction(Vec3::Y), 0.0);

    // A very dark map (subnormal values, black bottom row) samples as its bright twin: the
    // density scale W / (2π Σ weights) is about 3e39, beyond f32, and must not overflow
    // (subnormal values carry ~1e-4 and their luminance ~2e-3 relative rounding).
    let bright: Vec<f32> = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 0.0, 0.0, 0.0, 0.0];
    let [b, d] = [1.0f32, 1e-41].map(|k| {
        let img = Image {
            width: 4,
            height: 3,
            channels: 1,
            data: bright.iter().map(|v| v * k).collect(),
        };
        Emitter::Envmap(Box::new(
            Envmap::new(&img, false, 1.0, &Mat4::IDENTITY).unwrap(),
        ))
    });
    let mut rng = Pcg32::new(3, 1);
    for _ in 0..200 {
        let dir = square_to_uniform_sphere(rng.next_vec2());
        let (pb, pd) = (b.pdf_direction(dir), d.pdf_direction(dir));
        assert!(
            pd.is_finite() && (pd - pb).abs() <= 1e-2 * pb,
            "{dir}: {pd} vs {pb}"
        );
    }
    check_sampling(&d, 7);
    assert!(Envmap::new(
        &Image {
            width: 2,
            height: 2,
            channels: 1,
            data: vec![1.0; 4]
        },
        false,
        1.0,
        &Mat4::IDENTITY
    )
    .is_err());
    let missing =
        Emitter::envmap_from_file(Path::new("/nonexistent/env.exr"), 1.0, &Mat4::IDENTITY);
    assert!(missing.unwrap_err().to_string().contains("env.exr"));
}

#[test]
fn delta_lights_match_mitsuba() {
    // Mitsuba 3.9.1: point at (1, 2, 3), intensity (10, 20, 30), seen from the origin:
    // d = (0.267261, 0.534522, 0.801784), dist 3.74166, weight (0.714286, 1.42857, 2.14286).
    let p = Emitter::point(Vec3::new(1.0, 2.0, 3.0), Rgb::new(10.0, 20.0, 30.0));
    let s = p.sample_direction(Vec3::ZERO, Vec2::splat(0.5)).unwrap();
    assert!((s.wi - Vec3::new(0.267261, 0.534522, 0.801784)).length() < 1e-5);
    assert!((s.dist - 3.741_657).abs() < 1e-5);
    assert!(close(s.radiance, [0.714286, 1.42857, 2.14286], 1e-5));
    assert!(s.is_delta && s.pdf == 1.0 && p.is_delta() && !p.is_infinite());
    assert_eq!(p.eval_direction(s.wi), Rgb::ZERO);
    assert_eq!(p.pdf_direction(s.wi), 0.0);
    assert!(p
        .sample_direction(Vec3::new(1.0, 2.0, 3.0), Vec2::ZERO)
        .is_none());
    let q =
        Emitter::point_from_to_world(&Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)), Rgb::ONE);
    assert!(matches!(q, Emitter::Point(l) if l.position == Vec3::new(1.0, 2.0, 3.0)));

    // directional, direction (0, −1, −1), irradiance (1, 2, 3): d = (0, 0.707107, 0.707107).
    let d = Emitter::directional(Vec3::new(0.0, -1.0, -1.0), Rgb::new(1.0, 2.0, 3.0));
    let s = d
        .sample_direction(Vec3::new(5.0, 5.0, 5.0), Vec2::ZERO)
        .unwrap();
    assert!((s.wi - Vec3::new(0.0, FRAC_1_SQRT_2, FRAC_1_SQRT_2)).length() < 1e-5);
    assert_eq!(
        (s.radiance, s.pdf, s.dist),
        (Rgb::new(1.0, 2.0, 3.0), 1.0, f32::INFINITY)
    );
    assert!(s.is_delta && d.is_delta() && !d.is_infinite());
    // to_world maps local +z onto the travel direction.
    let m = Mat4::from_rotation_x(90f32.to_radians());
    let d2 = Emitter::directional_from_to_world(&m, Rgb::ONE);
    let s = d2.sample_direction(Vec3::ZERO, Vec2::ZERO).unwrap();
    assert!((s.wi - Vec3::Y).length() < 1e-6, "{}", s.wi);
}

fn node(body: &str) -> Result<Emitter> {
    let text = format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n");
    let root = crate::xml::parse_scene_str(&text, "test.xml", Path::new("."), &[])?;
    Emitter::from_node(&root.children[0], &specula_testdata::root().join("scenes"))
}

/// A `<spectrum>` value is kept for spectral mode beside its RGB value (RGB mode reads
/// only the latter); `<rgb>` values and `envmap` have none; a negative emission spectrum
/// is an error at the property.
#[test]
fn spectrum_values_are_kept_for_spectral_mode() {
    let w = specula_bsdf::Wavelengths([450.0, 500.0, 700.0]);
    for (xml, want) in [
        (
            r#"<emitter type="point"><spectrum name="intensity" value="400:0.2, 500:1.5, 600:0.3"/></emitter>"#,
            [0.85, 1.5, 0.0],
        ),
        (
            r#"<emitter type="directional"><spectrum name="irradiance" value="0.5"/></emitter>"#,
            [0.5; 3],
        ),
        (
            r#"<emitter type="constant"><spectrum name="radiance" type="uniform"><float name="value" value="2"/></spectrum></emitter>"#,
            [2.0; 3],
        ),
        (
            r#"<emitter type="spot"><spectrum name="intensity" value="400:1, 800:1"/></emitter>"#,
            [1.0; 3],
        ),
        (
            r#"<emitter type="projector"><spectrum name="irradiance" value="400:3, 800:3"/></emitter>"#,
            [3.0; 3],
        ),
    ] {
        let e = node(xml).unwrap();
        let (curve, rgb) = e.spectrum().unwrap_or_else(|| panic!("{xml}"));
        let v = curve.eval_at(&w);
        for (x, y) in v.0.iter().zip(want) {
            assert!((x - y).abs() < 1e-6, "{xml}: {v:?}");
        }
        // the RGB value RGB mode uses is the converted spectrum's
        assert!(rgb.max_component() > 0.0, "{xml}");
    }
    let e = node(r#"<emitter type="point"><rgb name="intensity" value="1, 2, 3"/></emitter>"#);
    assert!(e.unwrap().spectrum().is_none());
    let e = node(
        r#"<emitter type="point">
                <spectrum name="intensity" value="400:1, 500:-0.5, 600:1"/></emitter>"#,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("test.xml:3:17") && e.contains("non-negative"),
        "{e}"
    );
}

#[test]
fn builds_from_xml_nodes() {
    let e = node(r#"<emitter type="point"><point name="position" value="1, 2, 3"/><rgb name="intensity" value="10, 20, 30"/></emitter>"#).unwrap();
    assert!(
        matches!(e, Emitter::Point(l) if l.position == Vec3::new(1.0, 2.0, 3.0) && l.intensity == Rgb::new(10.0, 20.0, 30.0))
    );
    let e = node(r#"<emitter type="point"><transform name="to_world"><translate x="4"/></transform></emitter>"#).unwrap();
    assert!(
        matches!(e, Emitter::Point(l) if l.position == Vec3::new(4.0, 0.0, 0.0) && l.intensity == Rgb::ONE)
    );
    // a constant emission spectrum is 3 · XYZ→sRGB(1, 1, 1) in Mitsuba 3.9's RGB variants
    let e = node(r#"<emitter type="directional"><vector name="direction" value="0, 0, -2"/><spectrum name="irradiance" value="3"/></emitter>"#).unwrap();
    let want = Rgb::new(3.6143818, 2.844873, 2.7267482);
    assert!(
        matches!(&e, Emitter::Directional(l) if l.direction == -Vec3::Z && (0..3).all(|k| (l.irradiance.0[k] / want.0[k] - 1.0).abs() < 1e-6)),
        "{e:?}"
    );
    let e = node(
        r#"<emitter type="constant"><rgb name="radiance" value="0.25, 0.27, 0.3"/></emitter>"#,
    )
    .unwrap();
    assert!(matches!(e, Emitter::Constant(l) if l.radiance == Rgb::new(0.25, 0.27, 0.3)));
    let err =
        node(r#"<emitter type="constant"><rgb name="radiant" value="1"/></emitter>"#).unwrap_err();
    assert!(
        err.to_string().contains("radiant") && err.loc.is_some(),
        "{err}"
    );
    let err = node(r#"<emitter type="sunsky"/>"#).unwrap_err();
    assert!(err.to_string().contains("not supported"), "{err}");
    let err = node(
        r#"<emitter type="envmap"><string name="filename" value="assets/none.exr"/></emitter>"#,
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("none.exr") && err.loc.is_some(),
        "{err}"
    );
    if asset("sky.exr").is_some() {
        let e = node(r#"<emitter type="envmap"><string name="filename" value="assets/sky.exr"/><float name="scale" value="2"/></emitter>"#).unwrap();
        let got = e.eval_direction(Vec3::Y);
        assert!(close(got, [0.500012, 0.900008, 1.799998], 1e-4), "{got:?}");
        assert!(e.is_infinite() && !e.is_delta());
    }
}

#[test]
fn constant_samples_the_sphere_uniformly() {
    // Mitsuba 3.9.1: pdf 0.0795775 = 1/4π, weight = radiance/pdf.
    let c = Emitter::constant(Rgb::new(0.25, 0.27, 0.3));
    let mut rng = Pcg32::new(9, 9);
    let mut mean = Vec3::ZERO;
    for _ in 0..10_000 {
        let s = c.sample_direction(Vec3::ZERO, rng.next_vec2()).unwrap();
        assert!((s.pdf - 0.079_577_47).abs() < 1e-7);
        assert_eq!(s.pdf, c.pdf_direction(s.wi));
        assert_eq!(s.radiance, c.eval_direction(s.wi));
        assert!((s.wi.length() - 1.0).abs() < 1e-5 && s.dist == f32::INFINITY);
        mean += s.wi;
    }
    assert!((mean / 10_000.0).length() < 0.03);
    assert!(!c.is_delta() && c.is_infinite());
}

/// A 2×2 nearest-neighbour texture: red, green / blue, white (top row first), or a
/// constant w×h one.
fn tex(w: usize, h: usize) -> Arc<dyn Texture> {
    use crate::texture::{Bitmap, FilterType, WrapMode};
    let data = if (w, h) == (2, 2) {
        vec![1., 0., 0., 0., 1., 0., 0., 0., 1., 1., 1., 1.]
    } else {
        vec![1.0; w * h * 3]
    };
    let img = Image {
        width: w,
        height: h,
        channels: 3,
        data,
    };
    Arc::new(Bitmap::from_image(
        &img,
        false,
        FilterType::parse("nearest").unwrap(),
        WrapMode::parse("repeat").unwrap(),
        false,
        Mat3::IDENTITY,
    ))
}

fn at(e: &Emitter, p: [f32; 3]) -> Rgb {
    e.sample_direction(Vec3::from(p), Vec2::splat(0.5))
        .map_or(Rgb::ZERO, |s| {
            assert!(s.is_delta && s.pdf == 1.0);
            assert!((s.wi * s.dist + Vec3::from(p) - e_position(e)).length() < 1e-5);
            s.radiance
        })
}

fn e_position(e: &Emitter) -> Vec3 {
    match e {
        Emitter::Spot(l) => l.position,
        Emitter::Projector(l) => l.position,
        _ => unreachable!(),
    }
}

#[test]
fn spot_matches_mitsuba() {
    // Mitsuba 3.9.1 scalar_rgb: spot at the origin along +z, intensity (1, 2, 3), cutoff
    // 30° (beam 22.5°), seen from distance 2 at angle θ: sample_direction's weight.
    let e = node(r#"<emitter type="spot"><rgb name="intensity" value="1, 2, 3"/><float name="cutoff_angle" value="30"/></emitter>"#).unwrap();
    assert!(e.is_delta() && !e.is_infinite());
    for (deg, want) in [
        (0.0f32, [0.25, 0.5, 0.75]),
        (20.0, [0.25, 0.5, 0.75]),
        (22.5, [0.25, 0.5, 0.75]),
        (25.0, [0.166667, 0.333334, 0.500001]),
        (29.0, [0.0333335, 0.066667, 0.1]),
        (29.9, [0.00333336, 0.00666672, 0.0100001]),
        (30.0, [0.0; 3]),
        (31.0, [0.0; 3]),
    ] {
        let t = deg.to_radians();
        let got = at(&e, [2.0 * t.sin(), 0.0, 2.0 * t.cos()]);
        assert!(close(got, want, 2e-4), "{deg}: {got:?}");
    }
    // the 1/dist² is in world units: translate (1, 0, 0) · scale 2, seen from (1, 0, 2)
    let e = node(r#"<emitter type="spot"><transform name="to_world"><scale value="2"/><translate x="1"/></transform></emitter>"#).unwrap();
    assert!(close(at(&e, [1.0, 0.0, 2.0]), [0.25; 3], 1e-5));
    // a negative beam_width (which Mitsuba takes as a falloff starting before 0°) is refused
    let e = node(r#"<emitter type="spot"><float name="beam_width" value="-5"/></emitter>"#);
    assert!(e.unwrap_err().to_string().contains("beam_width"));
    // textured: uv = ½ + ½ (x, y) / (z tan cutoff), no flip
    let spot = SpotLight::new(&Mat4::IDENTITY, Rgb::ONE, 30.0, 22.5, Some(tex(2, 2))).unwrap();
    let e = Emitter::Spot(Box::new(spot));
    for (p, want) in [
        ([0.3, 0.3, 1.0], [0.792119; 3]),
        ([-0.3, 0.3, 1.0], [0.0, 0.0, 0.792119]),
        ([0.3, -0.3, 1.0], [0.0, 0.792119, 0.0]),
        ([-0.3, -0.3, 1.0], [0.792119, 0.0, 0.0]),
        ([0.5, 0.0, 1.0], [0.366396; 3]),
    ] {
        assert!(close(at(&e, p), want, 2e-5), "{p:?}: {:?}", at(&e, p));
    }
}

#[test]
fn projector_matches_mitsuba() {
    // Mitsuba 3.9.1 scalar_rgb: projector at the origin along +z; weights of
    // sample_direction from the given points.
    let proj = |texture, irradiance: Rgb, scale: f32, fov: f32, aspect: f32, m: Mat4| {
        let t = crate::camera::tan_half_fov_x(fov as f64, crate::camera::FovAxis::X, aspect as f64)
            as f32;
        Emitter::Projector(Box::new(
            ProjectorLight::new(&m, irradiance, texture, scale, t, aspect).unwrap(),
        ))
    };
    let e = proj(Some(tex(2, 2)), Rgb::ONE, 1.0, 40.0, 1.0, Mat4::IDENTITY);
    assert!(e.is_delta() && !e.is_infinite());
    for (p, want) in [
        ([0.3, 0.2, 1.0], [3.33956, 0.0, 0.0]),
        ([-0.3, 0.2, 1.0], [0.0, 3.33956, 0.0]),
        ([0.3, -0.2, 1.0], [0.0, 0.0, 3.33956]),
        ([-0.3, -0.2, 1.0], [3.33956; 3]),
        ([0.0, 0.0, 1.0], [PI; 3]),
        ([0.0, 0.0, 2.0], [std::f32::consts::FRAC_PI_4; 3]),
        ([0.5, 0.0, 1.0], [0.0; 3]),
        ([0.0, 0.0, -1.0], [0.0; 3]),
        ([0.36, 0.0, 1.0], [0.0, 0.0, 3.33897]),
        ([0.37, 0.0, 1.0], [0.0; 3]),
    ] {
        assert!(close(at(&e, p), want, 2e-5), "{p:?}: {:?}", at(&e, p));
    }
    let e = proj(
        None,
        Rgb::new(1.0, 2.0, 3.0),
        2.0,
        40.0,
        1.0,
        Mat4::IDENTITY,
    );
    assert!(close(
        at(&e, [0.2, 0.1, 1.0]),
        [6.43835, 12.8767, 19.315],
        2e-5
    ));
    // a 30×10 image: the aspect ratio narrows the vertical field of view
    let e = proj(Some(tex(30, 10)), Rgb::ONE, 1.0, 40.0, 3.0, Mat4::IDENTITY);
    assert!(close(at(&e, [0.2, 0.1, 1.0]), [3.21917; 3], 2e-5));
    assert_eq!(at(&e, [0.0, 0.2, 1.0]), Rgb::ZERO);
    // a scaled to_world: Mitsuba's unnormalised normal and local depth
    let m = Mat4::from_scale(Vec3::splat(2.0));
    let e = proj(None, Rgb::ONE, 1.0, 40.0, 1.0, m);
    assert!(close(at(&e, [0.2, 0.1, 1.0]), [6.43835; 3], 2e-5));
    // from XML: focal length 35 mm on a 30×10 image, translated and rotated
    let root = crate::xml::parse_scene_str(
            r#"<scene version="3.0.0"><emitter type="projector"><string name="focal_length" value="35mm"/><transform name="to_world"><rotate y="1" angle="30"/><translate x="1" y="2" z="3"/></transform></emitter></scene>"#,
            "test.xml",
            Path::new("."),
            &[],
        )
        .unwrap();
    let textures = [NamedTexture {
        name: "irradiance".into(),
        texture: tex(30, 10),
        loc: Loc::default(),
    }];
    let e = Emitter::from_node_textured(&root.children[0], Path::new("."), &textures).unwrap();
    assert!(close(at(&e, [1.5, 2.1, 4.0]), [2.53696; 3], 2e-5));
    // a texture under another name is an error at that texture
    let bad = [NamedTexture {
        name: "radiance".into(),
        texture: tex(2, 2),
        loc: Loc {
            file: "x.xml".into(),
            line: 3,
            col: 4,
        },
    }];
    let err = Emitter::from_node_textured(&root.children[0], Path::new("."), &bad).unwrap_err();
    assert!(
        err.to_string().contains("x.xml:3:4") && err.to_string().contains("irradiance"),
        "{err}"
    );
}

#[test]
fn spot_and_projector_parameters_are_checked() {
    for (body, want) in [
        (
            r#"<emitter type="spot"><float name="cutoff_angle" value="0"/></emitter>"#,
            "cutoff_angle",
        ),
        (
            r#"<emitter type="spot"><float name="cutoff_angle" value="180"/></emitter>"#,
            "cutoff_angle",
        ),
        (
            r#"<emitter type="spot"><float name="cutoff"  value="10"/></emitter>"#,
            "cutoff",
        ),
        (
            r#"<emitter type="spot"><transform name="to_world"><scale value="0"/></transform></emitter>"#,
            "singular",
        ),
        (
            r#"<emitter type="projector"><float name="fov" value="30"/><string name="focal_length" value="50mm"/></emitter>"#,
            "not both",
        ),
        (
            r#"<emitter type="projector"><float name="fov" value="190"/></emitter>"#,
            "(0, 180)",
        ),
        (
            r#"<emitter type="projector"><float name="intensity" value="1"/></emitter>"#,
            "intensity",
        ),
    ] {
        let err = node(body).unwrap_err().to_string();
        assert!(
            err.contains(want) && err.contains("test.xml:2:"),
            "{body}: {err}"
        );
    }
    // a beam wider than the cutoff is a hard edge at the cutoff (as in Mitsuba)
    let e = node(r#"<emitter type="spot"><float name="cutoff_angle" value="20"/><float name="beam_width" value="25"/></emitter>"#).unwrap();
    let t = 19f32.to_radians();
    assert!(close(at(&e, [t.sin(), 0.0, t.cos()]), [1.0; 3], 1e-5));
}

/// `sample_linear` inverts the CDF of the linear density with values a at 0 and b at 1,
/// F(x) = (2a·x + (b − a)·x²) / (a + b), to f32 rounding, including where a or b is 0 and
/// where they are equal (uniform), and keeps its result in [0, 1).
#[test]
fn sample_linear_inverts_the_linear_cdf() {
    use super::envmap::sample_linear;
    let mut rnd = lcg(3);
    let mut pairs = vec![
        (1.0f32, 1.0f32),
        (0.0, 1.0),
        (1.0, 0.0),
        (2.0, 2.0),
        (1e-30, 1.0),
    ];
    pairs.extend((0..200).map(|_| (rnd() * 10.0, rnd() * 10.0)));
    pairs.extend((0..100).map(|_| (rnd() * 1e-3, rnd() * 1e3)));
    for (a, b) in pairs {
        let mut prev = -1.0f32;
        for k in 0..=64 {
            let u = (k as f32 / 64.0).min(1.0 - f32::EPSILON / 2.0);
            let x = sample_linear(u, a, b);
            assert!((0.0..1.0).contains(&x), "a {a} b {b} u {u}: {x}");
            assert!(x >= prev, "a {a} b {b}: not monotonic at u {u}");
            prev = x;
            let (a, b, x) = (a as f64, b as f64, x as f64);
            let cdf = (2.0 * a * x + (b - a) * x * x) / (a + b);
            assert!(
                (cdf - u as f64).abs() < 2e-6,
                "a {a} b {b} u {u}: F({x}) = {cdf}"
            );
        }
    }
}
