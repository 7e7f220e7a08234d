//! Special functions needed by the Beckmann distribution.

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

#[cfg(test)]
mod tests {
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
}
