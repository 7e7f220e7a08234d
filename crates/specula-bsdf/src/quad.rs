//! Gauss–Legendre quadrature nodes and weights on [−1, 1] (Newton iteration on the Legendre
//! recurrence, in double precision).

/// `n` nodes (ascending) and weights of the n-point Gauss–Legendre rule on [−1, 1].
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    assert!(n >= 1);
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // Tricomi's initial guess for the i-th root from the right
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 0.0;
        for _ in 0..100 {
            let (p, d) = legendre(n, x);
            dp = d;
            let dx = p / d;
            x -= dx;
            // quadratic convergence: once a step is at rounding level the root is reached (a
            // tighter test can spin at 1 ulp for all 100 iterations)
            if dx.abs() <= 4.0 * f64::EPSILON {
                break;
            }
        }
        let (_, d) = legendre(n, x);
        dp = if d != 0.0 { d } else { dp };
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[n - 1 - i] = x;
        nodes[i] = -x;
        weights[n - 1 - i] = w;
        weights[i] = w;
    }
    (nodes, weights)
}

/// [`gauss_legendre`] computed once per `n` and kept for the life of the process (for
/// precomputed tables that use the same rule many times).
pub fn gauss_legendre_cached(n: usize) -> &'static (Vec<f64>, Vec<f64>) {
    use std::sync::{Mutex, OnceLock};
    type Rules = Vec<(usize, &'static (Vec<f64>, Vec<f64>))>;
    static RULES: OnceLock<Mutex<Rules>> = OnceLock::new();
    let mut rules = RULES
        .get_or_init(Default::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    if let Some((_, r)) = rules.iter().find(|(m, _)| *m == n) {
        return r;
    }
    let r: &'static _ = Box::leak(Box::new(gauss_legendre(n)));
    rules.push((n, r));
    r
}

/// P_n(x) and its derivative.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (x * p1 - p0) / (x * x - 1.0);
    (p1, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn integrates_polynomials_exactly() {
        for n in [1usize, 2, 5, 16, 32, 128] {
            let (x, w) = gauss_legendre(n);
            assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-12, "n={n}");
            // degree 2n−1 is integrated exactly: ∫ x^(2n−2) = 2/(2n−1)
            let deg = 2 * n - 2;
            let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32)).sum();
            assert!((s - 2.0 / (deg as f64 + 1.0)).abs() < 1e-10, "n={n} s={s}");
        }
    }
}
