//! Special functions needed by the Beckmann distribution, and the sine, cosine and atan2 the
//! samplers and lat-long lookups use (inline polynomials instead of calls into libm).

/// Error function, |error| < 1.2e-7 (Numerical Recipes' erfc Chebyshev fit, evaluated in f64).
pub fn erf(x: f32) -> f32 {
    erf64(x as f64) as f32
}

/// Complementary error function 1 − erf(x), with relative accuracy ~1.2e-7 also in the tail.
pub fn erfc64(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.26551223
        + t * (1.00002368
            + t * (0.37409196
                + t * (0.09678418
                    + t * (-0.18628806
                        + t * (0.27886807
                            + t * (-1.13520398
                                + t * (1.48851587 + t * (-0.82215223 + t * 0.17087277))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// [`erfc64`] in single precision (same fit; relative error ~1e-6), for hot paths.
#[inline]
pub fn erfc32(x: f32) -> f32 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_2
        + t * (1.000_023_7
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_204
                                + t * (1.488_515_9 + t * (-0.822_152_2 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// [`erf`] in double precision (same fit, same accuracy).
pub fn erf64(x: f64) -> f64 {
    1.0 - erfc64(x)
}

/// Inverse error function on (−1, 1), refined with two Newton steps in f64 against [`erf`] so
/// that `erf(erfinv(y)) ≈ y` to float precision.
pub fn erfinv(y: f32) -> f32 {
    if y <= -1.0 {
        return f32::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f32::INFINITY;
    }
    let yd = y as f64;
    let mut x = erfinv_fast(y) as f64;
    // Newton refinement: d/dx erf(x) = 2/√π e^{−x²}
    for _ in 0..2 {
        let e = erf64(x) - yd;
        let d = std::f64::consts::FRAC_2_SQRT_PI * (-x * x).exp();
        if d > 0.0 {
            x -= e / d;
        }
    }
    x as f32
}

/// Inverse error function: Giles' single-precision polynomial approximation (2010), without
/// refinement: relative error below 5e-6 (f32 evaluation of the polynomial), ample for
/// drawing microfacet slopes.
#[inline]
pub fn erfinv_fast(y: f32) -> f32 {
    // w = −ln(1 − y²), without cancellation at either end
    let mut w = if y.abs() < 0.5 {
        -(-y * y).ln_1p()
    } else {
        -((1.0 - y) * (1.0 + y)).ln()
    };
    if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725 + p * w;
        p = -0.004_177_681_6 + p * w;
        p = 0.246_640_73 + p * w;
        p = 1.501_409_4 + p * w;
        p * y
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26;
        p = 0.000_100_950_56 + p * w;
        p = 0.001_349_343_2 + p * w;
        p = -0.003_673_428_4 + p * w;
        p = 0.005_739_507_7 + p * w;
        p = -0.007_622_461 + p * w;
        p = 0.009_438_870_5 + p * w;
        p = 1.001_674 + p * w;
        p = 2.832_976_8 + p * w;
        p * y
    }
}

/// Solve the small linear system `m x = b` by Gaussian elimination with partial pivoting.
#[allow(clippy::needless_range_loop)]
pub(crate) fn solve<const P: usize>(mut m: [[f64; P]; P], mut b: [f64; P]) -> Option<[f64; P]> {
    for col in 0..P {
        let piv = (col..P).max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs()))?;
        if m[piv][col].abs() < 1e-300 || !m[piv][col].is_finite() {
            return None;
        }
        m.swap(col, piv);
        b.swap(col, piv);
        for row in col + 1..P {
            let f = m[row][col] / m[col][col];
            for c in col..P {
                m[row][c] -= f * m[col][c];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; P];
    for row in (0..P).rev() {
        let mut s = b[row];
        for c in row + 1..P {
            s -= m[row][c] * x[c];
        }
        x[row] = s / m[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// ⌊x⌋, bit for bit `f32::floor` (signed zeros, ±∞ and NaN included), inline: x86-64's
/// baseline has no rounding instruction (SSE4.1's `roundss`), so `f32::floor` is a call into
/// libm, which also makes its caller save every live vector register. Below 2²³ in magnitude
/// the truncation to i32 is exact and is corrected by one where it rounded up; from 2²³ on
/// every f32 is an integer already (and ±∞, NaN are their own floor).
#[inline(always)]
pub fn floor(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        let t = x as i32 as f32;
        // floor keeps the sign of x (−0.0 stays −0.0, (−1, 0) gives −1, [0, 1) gives +0)
        (if t > x { t - 1.0 } else { t }).copysign(x)
    } else {
        x
    }
}

/// sin x and cos x for |x| ≤ π/4, without range reduction: the minimax polynomials of
/// Cephes' `sinf`/`cosf` (S. Moshier; degree 7 and 8, error about 1 ulp on this interval).
/// Beyond π/4 the error grows; callers reduce the argument first (see [`sincos_2pi`]).
#[inline(always)]
pub fn sincos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (s, c)
}

/// sin 2πu and cos 2πu (the azimuth of a sampled direction: u in [0, 1], or a little beyond,
/// as the environment map's u). The quadrant is split off exactly (4u and 4u − q are exact in
/// f32 for |4u| < 2²³), so the only rounding before the polynomial is that of (4u − q)·π/2: as
/// accurate as `(2π u).sin_cos()` or better, and a few times cheaper than libm's call.
#[inline(always)]
pub fn sincos_2pi(u: f32) -> (f32, f32) {
    let t = 4.0 * u;
    let q = floor(t + 0.5);
    let (s, c) = sincos_quarter((t - q) * std::f32::consts::FRAC_PI_2);
    match (q as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// atan2(y, x) in (−π, π] with the signs and special cases of libm's (±0, ±∞, NaN), from
/// Cephes' `atanf` polynomial (S. Moshier) after reducing |y|/|x| to [0, tan π/8]: about
/// 2 ulp, and without the call into libm (lat-long lookups make one per ray).
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (num, den) = if ay > ax { (ax, ay) } else { (ay, ax) };
    // num/den in [0, 1]; 0/0 (both zero) and ∞/∞ (both infinite) by their limits
    let t = if den == 0.0 {
        0.0
    } else if num == den {
        1.0
    } else {
        num / den
    };
    let (off, z) = if t > 0.414_213_57 {
        (FRAC_PI_4, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, t)
    };
    let z2 = z * z;
    let p = (((8.053_744_5e-2 * z2 - 1.387_768_6e-1) * z2 + 1.997_771_1e-1) * z2 - 3.333_295e-1)
        * z2
        * z
        + z;
    let mut r = off + p;
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x.is_sign_negative() {
        r = PI - r;
    }
    r.copysign(y)
}

/// acos x in [0, π] (NaN outside [−1, 1] and for NaN), from Cephes' `asinf` polynomial (S.
/// Moshier) on |t| ≤ ½: acos x = π/2 − asin x for |x| ≤ ½, and 2 asin √((1 − |x|)/2) (or π
/// minus it for x < 0) beyond, where the half-angle form keeps the small results near ±1
/// accurate. Within 1 ulp of the exact value on every f32 the test checks (every 97th of
/// [−1, 1], and all within 10⁵ ulp of ±½ and ±1), and without libm's call (the environment
/// map makes one per lookup and one per light sample).
#[inline]
pub fn acos(x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, PI};
    let a = x.abs();
    if a.is_nan() || a > 1.0 {
        return f32::NAN;
    }
    // asin t for |t| ≤ ½
    let asin = |t: f32| {
        let z = t * t;
        ((((4.216_32e-2 * z + 2.418_131e-2) * z + 4.547_002_6e-2) * z + 7.495_300_3e-2) * z
            + 1.666_675_2e-1)
            * z
            * t
            + t
    };
    if a <= 0.5 {
        FRAC_PI_2 - asin(x)
    } else {
        let r = 2.0 * asin((0.5 * (1.0 - a)).sqrt());
        if x < 0.0 {
            PI - r
        } else {
            r
        }
    }
}

#[cfg(test)]
mod tests {
    /// Ulps between two f32 of the same sign (both ≥ 0 here).
    fn ulps(a: f32, b: f32) -> u32 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn acos_is_within_1_ulp_of_the_exact_value() {
        let mut worst = (0, 0.0f32);
        let mut check = |x: f32| {
            let exact = (x as f64).acos() as f32;
            let got = super::acos(x);
            let e = ulps(got, exact);
            assert!(e <= 1, "acos({x:e}) = {got:e}, exact {exact:e} ({e} ulp)");
            if e > worst.0 {
                worst = (e, x);
            }
        };
        // every 97th f32 in [−1, 1], then every f32 near the switch at ±½ and near ±1
        let one = 1.0f32.to_bits();
        for b in (0..=one).step_by(97) {
            check(f32::from_bits(b));
            check(-f32::from_bits(b));
        }
        for c in [0.5f32, 1.0] {
            for k in 0..100_000 {
                check(f32::from_bits(c.to_bits() - k));
                check(-f32::from_bits(c.to_bits() - k));
                if c < 1.0 {
                    check(f32::from_bits(c.to_bits() + k));
                    check(-f32::from_bits(c.to_bits() + k));
                }
            }
        }
        for (x, want) in [
            (1.0f32, 0.0f32),
            (-1.0, std::f32::consts::PI),
            (0.0, 1.570_796_4),
        ] {
            assert_eq!(super::acos(x), want, "acos({x})");
        }
        assert_eq!(super::acos(-0.0), std::f32::consts::FRAC_PI_2);
        for x in [
            1.000_000_1f32,
            -1.000_000_1,
            2.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ] {
            assert!(super::acos(x).is_nan(), "acos({x})");
        }
        println!("worst: {} ulp at {:e}", worst.0, worst.1);
    }

    #[test]
    fn floor_is_libm_floor_bit_for_bit() {
        let mut special = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            0.999_999_94,
            -0.999_999_94,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_608.0,
            8_388_609.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            2_147_483_648.0,
            -2_147_483_904.0,
        ];
        // every f32 bit pattern's neighbourhood, sampled: random bits, and dense values
        // around small integers
        let mut h = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            special.push(f32::from_bits(h as u32));
            special.push(((h >> 40) as f32 / 16_777_216.0 - 0.5) * 64.0);
        }
        for x in special {
            let (a, b) = (super::floor(x), x.floor());
            assert!(
                a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()),
                "floor({x:e}) = {a:e}, libm {b:e}"
            );
        }
    }

    use super::*;
    #[test]
    fn erf_known_values() {
        assert!((erf(0.0)).abs() < 1e-7);
        assert!((erf(0.5) - 0.520_499_9).abs() < 2e-7);
        assert!((erf(1.0) - 0.842_700_8).abs() < 2e-7);
        assert!((erf(-2.0) + 0.995_322_3).abs() < 2e-7);
    }
    #[test]
    fn single_precision_versions_agree() {
        for i in 0..400 {
            let x = -4.0 + 8.0 * i as f32 / 400.0;
            let (a, b) = (erfc32(x) as f64, erfc64(x as f64));
            assert!((a - b).abs() <= 2e-6 * b.abs() + 1e-12, "x={x}: {a} vs {b}");
        }
        for i in 1..200 {
            let y = -0.999 + 1.998 * i as f32 / 200.0;
            let (a, b) = (erfinv_fast(y), erfinv(y));
            assert!((a - b).abs() <= 5e-6 * b.abs() + 1e-7, "y={y}: {a} vs {b}");
        }
    }
    #[test]
    fn erfinv_inverts_erf() {
        for i in 1..200 {
            let y = -0.995 + 1.99 * i as f32 / 200.0;
            let x = erfinv(y);
            assert!((erf(x) - y).abs() < 3e-7, "y={y} x={x} erf={}", erf(x));
        }
    }

    #[test]
    fn sincos_matches_f64() {
        // every 4097th float of [0, 1] and the quadrant edges: within 1.2e-7 of the f64 result,
        // and within 2.4e-7 of it relative to max(|result|, ½)
        let mut worst = 0f64;
        let mut check = |u: f32| {
            let (s, c) = sincos_2pi(u);
            let a = 2.0 * std::f64::consts::PI * u as f64;
            let (es, ec) = a.sin_cos();
            for (got, want) in [(s as f64, es), (c as f64, ec)] {
                let err = (got - want).abs() / want.abs().max(0.5);
                worst = worst.max(err);
                assert!((got - want).abs() <= 1.2e-7, "u={u}: {got} vs {want}");
            }
        };
        let mut bits = 0u32;
        while f32::from_bits(bits) <= 1.0 {
            check(f32::from_bits(bits));
            bits += 4097;
        }
        for k in 0..=8 {
            let e = k as f32 / 8.0;
            for u in [
                e,
                f32::from_bits(e.to_bits().saturating_sub(1)),
                f32::from_bits(e.to_bits() + 1),
            ] {
                if (0.0..=1.0).contains(&u) {
                    check(u);
                }
            }
        }
        // a little beyond 1, where the environment map's u ends up
        for k in 1..=16 {
            check(1.0 + k as f32 / 128.0);
        }
        assert!(worst < 2.4e-7, "{worst}");
        let x = std::f32::consts::FRAC_PI_4;
        for i in -1000..=1000 {
            let v = x * i as f32 / 1000.0;
            let (s, c) = sincos_quarter(v);
            let (es, ec) = (v as f64).sin_cos();
            assert!(
                (s as f64 - es).abs() <= 1.2e-7 * es.abs().max(1e-3),
                "{v}: {s} vs {es}"
            );
            assert!(
                (c as f64 - ec).abs() <= 1.2e-7 * ec.abs(),
                "{v}: {c} vs {ec}"
            );
        }
    }

    #[test]
    fn atan2_matches_f64() {
        // a grid of directions (both signs, every octant) and the special cases
        for i in 0..20_000 {
            let a = (i as f64 + 0.5) / 20_000.0 * 2.0 * std::f64::consts::PI;
            for r in [1.0f64, 3e-5, 7e4] {
                let (y, x) = ((a.sin() * r) as f32, (a.cos() * r) as f32);
                let want = (y as f64).atan2(x as f64);
                let got = atan2(y, x) as f64;
                assert!(
                    (got - want).abs() <= 2.5e-7 * want.abs().max(1e-38),
                    "atan2({y}, {x}) = {got}, want {want}"
                );
            }
        }
        let inf = f32::INFINITY;
        for (y, x) in [
            (0.0f32, 0.0f32),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (1.0, 0.0),
            (-1.0, 0.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (inf, inf),
            (-inf, inf),
            (inf, -inf),
            (1.0, inf),
            (1.0, -inf),
            (inf, 1.0),
            (1e-30, 1e30),
            (1e30, -1e-30),
        ] {
            let (got, want) = (atan2(y, x), y.atan2(x));
            assert!(
                got == want || (got - want).abs() <= 2.5e-7 * want.abs(),
                "atan2({y}, {x}) = {got}, libm {want}"
            );
            assert_eq!(
                got.is_sign_negative(),
                want.is_sign_negative(),
                "sign of atan2({y}, {x})"
            );
        }
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }
}
