//! Distribution functions for the statistical checks.

/// ln Γ(x) for x > 0 (Lanczos approximation, g = 7, n = 9; ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // reflection formula
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x < a + 1.0 {
        1.0 - gamma_p_series(a, x)
    } else {
        gamma_q_continued_fraction(a, x)
    }
}

fn gamma_p_series(a: f64, x: f64) -> f64 {
    let mut sum = 1.0 / a;
    let mut term = sum;
    let mut n = a;
    for _ in 0..100_000 {
        n += 1.0;
        term *= x / n;
        sum += term;
        if term.abs() < sum.abs() * 1e-16 {
            break;
        }
    }
    (sum.ln() - x + a * x.ln() - ln_gamma(a)).exp()
}

fn gamma_q_continued_fraction(a: f64, x: f64) -> f64 {
    // modified Lentz evaluation of the continued fraction for Γ(a, x)
    let tiny = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / tiny;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..100_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < tiny {
            d = tiny;
        }
        c = b + an / c;
        if c.abs() < tiny {
            c = tiny;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < 1e-16 {
            break;
        }
    }
    (-x + a * x.ln() - ln_gamma(a)).exp() * h
}

/// P(X ≥ x) for a χ² variable with `dof` degrees of freedom.
pub fn chi2_sf(x: f64, dof: f64) -> f64 {
    gamma_q(0.5 * dof, 0.5 * x)
}

/// Per-test significance level that keeps the family-wise level at `alpha` over `n` tests
/// (Šidák correction).
pub fn sidak(alpha: f64, n: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / n.max(1) as f64)
}

/// Two-sided p-value of `k` successes in `n` Bernoulli(p) trials (normal approximation with
/// continuity correction; adequate for the n ≥ 10⁵ used here).
pub fn binomial_two_sided_p(k: u64, n: u64, p: f64) -> f64 {
    let mean = n as f64 * p;
    let sd = (n as f64 * p * (1.0 - p)).sqrt();
    if sd == 0.0 {
        return if (k as f64 - mean).abs() < 0.5 {
            1.0
        } else {
            0.0
        };
    }
    let z = (((k as f64 - mean).abs() - 0.5).max(0.0)) / sd;
    erfc64(z / std::f64::consts::SQRT_2)
}

fn erfc64(x: f64) -> f64 {
    1.0 - crate::math::erf64(x)
}

/// P(Z ≥ z) for a standard normal variable (accurate in the far tail too).
pub fn normal_sf(z: f64) -> f64 {
    0.5 * crate::math::erfc64(z / std::f64::consts::SQRT_2)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn ln_gamma_matches_factorials() {
        let mut f = 1.0f64;
        for n in 1..20 {
            f *= n as f64;
            assert!((ln_gamma(n as f64 + 1.0) - f.ln()).abs() < 1e-10);
        }
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-12);
    }
    #[test]
    fn chi2_quantiles() {
        // tabulated upper quantiles
        assert!((chi2_sf(3.841_458_8, 1.0) - 0.05).abs() < 1e-6);
        assert!((chi2_sf(18.307_038, 10.0) - 0.05).abs() < 1e-6);
        assert!((chi2_sf(135.806_7, 100.0) - 0.01).abs() < 1e-4);
        // large dof: mean k, sd sqrt(2k)
        let p = chi2_sf(5000.0, 5000.0);
        assert!(p > 0.49 && p < 0.51, "{p}");
    }
    #[test]
    fn normal_tail() {
        // erfc64 is accurate to ~1.2e-7 relative, in the tail too
        let check = |z: f64, want: f64| {
            let got = normal_sf(z);
            assert!(
                ((got - want) / want).abs() < 2e-7,
                "P(Z ≥ {z}) = {got}, not {want}"
            );
        };
        check(0.0, 0.5);
        check(1.959_963_985, 0.025);
        check(-2.326_347_874, 0.99);
        // far tail: 1 − Φ(8), which 1 − erf would lose entirely
        check(8.0, 6.220_960_574_271_8e-16);
    }
    #[test]
    fn sidak_is_exact() {
        let a = sidak(0.01, 100);
        assert!(((1.0 - a).powi(100) - 0.99).abs() < 1e-12);
    }
}
