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

/// [`erf`] in double precision (same fit, same accuracy).
pub fn erf64(x: f64) -> f64 {
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
    let erfc = t * poly.exp();
    if x >= 0.0 {
        1.0 - erfc
    } else {
        erfc - 1.0
    }
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
/// refinement (relative error about 1e-6).
pub fn erfinv_fast(y: f32) -> f32 {
    if y <= -1.0 {
        return f32::NEG_INFINITY;
    }
    if y >= 1.0 {
        return f32::INFINITY;
    }
    let yd = y as f64;
    let mut w = -((1.0 - yd) * (1.0 + yd)).ln();
    let x = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
        p * yd
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
        p * yd
    };
    x as f32
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
    fn erfinv_inverts_erf() {
        for i in 1..200 {
            let y = -0.995 + 1.99 * i as f32 / 200.0;
            let x = erfinv(y);
            assert!((erf(x) - y).abs() < 3e-7, "y={y} x={x} erf={}", erf(x));
        }
    }
}
