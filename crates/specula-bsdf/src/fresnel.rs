//! Fresnel equations: exact dielectric (with the s- and p-polarised parts), conductors with a
//! complex index of refraction, Schlick's approximation, and the hemispherical average used by
//! the plastic models.
//!
//! Conventions follow Mitsuba 3: `eta` is the relative index η_interior / η_exterior and the
//! sign of `cos_theta_i` says from which side the light arrives (positive = outside).

use crate::spectrum::Spectrum;

/// The result of [`fresnel_dielectric`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricFresnel {
    /// Unpolarised reflectance R = (Rs + Rp) / 2; 1 under total internal reflection.
    pub r: f32,
    /// Unpolarised transmittance T = 1 − R, computed directly (no cancellation near TIR).
    pub t: f32,
    /// Signed cosine of the refracted direction (opposite sign to `cos_theta_i`; 0 under TIR).
    pub cos_theta_t: f32,
    /// Relative index η_transmitted / η_incident for this side.
    pub eta_it: f32,
    /// Its reciprocal η_incident / η_transmitted (the factor in Snell's law).
    pub eta_ti: f32,
}

/// Power reflectances of the two linear polarisations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polarized {
    /// s-polarised (TE) reflectance |r_s|².
    pub rs: f32,
    /// p-polarised (TM) reflectance |r_p|².
    pub rp: f32,
}

impl Polarized {
    /// Unpolarised reflectance.
    pub fn mean(&self) -> f32 {
        0.5 * (self.rs + self.rp)
    }
}

/// Exact Fresnel reflectance of a smooth dielectric interface, with the refraction geometry.
///
/// At η = 1 the interface is index-matched: R = 0 and light passes straight through.
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> DielectricFresnel {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    // Snell: sin²θt = (η_i/η_t)² sin²θi
    let cos_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let ci = cos_theta_i.abs();
    let ct = cos_t_sqr.max(0.0).sqrt();
    let (r, t) = if eta == 1.0 {
        (0.0, 1.0)
    } else if ci == 0.0 || cos_t_sqr <= 0.0 {
        (1.0, 0.0)
    } else {
        let (ds, dp) = (ci + eta_it * ct, ct + eta_it * ci);
        let a_s = (ci - eta_it * ct) / ds;
        let a_p = (ct - eta_it * ci) / dp;
        // T = 1 − R with 1 − a² = (1 − a)(1 + a) = 4η cosθi cosθt / d², free of the
        // cancellation that 1 − R suffers near total internal reflection
        let k = 2.0 * eta_it * ci * ct;
        (0.5 * (a_s * a_s + a_p * a_p), k / (ds * ds) + k / (dp * dp))
    };
    DielectricFresnel {
        r,
        t,
        cos_theta_t: if outside { -ct } else { ct },
        eta_it,
        eta_ti,
    }
}

/// s- and p-polarised reflectances of a dielectric interface (both 1 under TIR).
pub fn fresnel_dielectric_polarized(cos_theta_i: f32, eta: f32) -> Polarized {
    let eta_it = if cos_theta_i >= 0.0 { eta } else { 1.0 / eta };
    let ci = cos_theta_i.abs();
    let cos_t_sqr = 1.0 - (1.0 - ci * ci) / (eta_it * eta_it);
    if cos_t_sqr <= 0.0 {
        return Polarized { rs: 1.0, rp: 1.0 };
    }
    let ct = cos_t_sqr.sqrt();
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    Polarized {
        rs: a_s * a_s,
        rp: a_p * a_p,
    }
}

/// Brewster's angle (radians) for light arriving from the side of index 1 onto index `eta`.
pub fn brewster_angle(eta: f32) -> f32 {
    eta.atan()
}

/// Critical angle (radians) for light inside a medium of relative index `eta` > 1.
pub fn critical_angle(eta: f32) -> Option<f32> {
    (eta > 1.0).then(|| (1.0 / eta).asin())
}

/// Unpolarised reflectance of a conductor with complex relative index η + i·k, for a cosine
/// of incidence in [0, 1]. Derived from the complex Snell law written in real arithmetic:
/// with a² + b² = √((η² − k² − sin²θ)² + 4η²k²) and a = √((a²+b² + η² − k² − sin²θ)/2),
/// Rs = (a²+b² − 2a cosθ + cos²θ) / (a²+b² + 2a cosθ + cos²θ) and
/// Rp = Rs · (a²+b² cos²θ − 2a cosθ sin²θ + sin⁴θ) / (a²+b² cos²θ + 2a cosθ sin²θ + sin⁴θ).
pub fn fresnel_conductor_polarized(cos_theta_i: f32, eta: f32, k: f32) -> Polarized {
    let (rs, rp) = conductor_rs_rp_f32(cos_theta_i, eta, k);
    Polarized { rs, rp }
}

/// [`fresnel_conductor`] in double precision (for fitting, where finite differences of the
/// reflectance must not drown in single-precision rounding): the same formula, one body.
pub fn fresnel_conductor_f64(cos_theta_i: f64, eta: f64, k: f64) -> f64 {
    let (rs, rp) = conductor_rs_rp_f64(cos_theta_i, eta, k);
    0.5 * (rs + rp)
}

/// (Rs, Rp) of a conductor, written once for both precisions.
macro_rules! conductor_rs_rp {
    ($name:ident, $t:ty) => {
        #[inline]
        fn $name(cos_theta_i: $t, eta: $t, k: $t) -> ($t, $t) {
            let c = cos_theta_i.clamp(0.0, 1.0);
            let c2 = c * c;
            let s2 = 1.0 - c2;
            let t = eta * eta - k * k - s2;
            let a2b2 = (t * t + 4.0 * eta * eta * k * k).max(0.0).sqrt();
            let a = (0.5 * (a2b2 + t)).max(0.0).sqrt();
            let t1 = a2b2 + c2;
            let t2 = 2.0 * a * c;
            let rs = (t1 - t2) / (t1 + t2);
            let t3 = a2b2 * c2 + s2 * s2;
            let t4 = t2 * s2;
            let rp = rs * (t3 - t4) / (t3 + t4);
            (rs, rp)
        }
    };
}
conductor_rs_rp!(conductor_rs_rp_f32, f32);
conductor_rs_rp!(conductor_rs_rp_f64, f64);

/// Unpolarised conductor reflectance.
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    fresnel_conductor_polarized(cos_theta_i, eta, k).mean()
}

/// Per-channel conductor reflectance.
#[inline]
pub fn fresnel_conductor_rgb(cos_theta_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    // `conductor_rs_rp_f32` and `Polarized::mean` lane by lane (the same operations, so the
    // same values bit for bit), written over 4 lanes so that the compiler evaluates the three
    // channels' square roots and divisions as one vector instruction each.
    let eta = [eta[0], eta[1], eta[2], eta[2]];
    let k = [k[0], k[1], k[2], k[2]];
    let c = cos_theta_i.clamp(0.0, 1.0);
    let c2 = c * c;
    let s2 = 1.0 - c2;
    let mut f = [0f32; 4];
    for i in 0..4 {
        let t = eta[i] * eta[i] - k[i] * k[i] - s2;
        let a2b2 = (t * t + 4.0 * eta[i] * eta[i] * k[i] * k[i])
            .max(0.0)
            .sqrt();
        let a = (0.5 * (a2b2 + t)).max(0.0).sqrt();
        let t1 = a2b2 + c2;
        let t2 = 2.0 * a * c;
        let rs = (t1 - t2) / (t1 + t2);
        let t3 = a2b2 * c2 + s2 * s2;
        let t4 = t2 * s2;
        let rp = rs * (t3 - t4) / (t3 + t4);
        f[i] = 0.5 * (rs + rp);
    }
    Spectrum::new(f[0], f[1], f[2])
}

/// Schlick's approximation of the dielectric reflectance, with the same interface as
/// [`fresnel_dielectric`]. F0 = ((η−1)/(η+1))²; the cosine used is the one on the
/// optically thinner side, so that total internal reflection is reproduced from inside.
#[inline]
pub fn fresnel_schlick(cos_theta_i: f32, eta: f32) -> DielectricFresnel {
    let exact = fresnel_dielectric(cos_theta_i, eta);
    let f0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
    let r = if eta == 1.0 {
        0.0
    } else if exact.t <= 0.0 {
        1.0
    } else {
        // the larger angle lies in the thinner medium
        let c = if exact.eta_it >= 1.0 {
            cos_theta_i.abs()
        } else {
            exact.cos_theta_t.abs()
        };
        f0 + (1.0 - f0) * (1.0 - c).powi(5)
    };
    DielectricFresnel {
        r,
        t: 1.0 - r,
        ..exact
    }
}

/// Transmittance of a dielectric interface for a known refraction pair: `cos_i` and `cos_t`
/// are the absolute cosines of the incident and refracted directions with the (micro)normal and
/// `eta_it` = η_t/η_i. Equal to 1 − R for a pair related by Snell's law, but computed from
/// both cosines, so it is exactly symmetric under exchanging the two sides (η → 1/η) and stays
/// accurate when the refracted direction grazes the surface, where recovering cosθt from
/// cosθi through Snell's law is ill-conditioned.
#[inline]
pub fn dielectric_transmittance_pair(cos_i: f32, cos_t: f32, eta_it: f32) -> f32 {
    let (ci, ct) = (cos_i as f64, cos_t as f64);
    let e = eta_it as f64;
    let (ds, dp) = (ci + e * ct, ct + e * ci);
    if ds <= 0.0 || dp <= 0.0 {
        return 0.0;
    }
    let k = 2.0 * e * ci * ct;
    (k / (ds * ds) + k / (dp * dp)) as f32
}

/// Which dielectric Fresnel formula a coated model uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FresnelMode {
    /// The exact unpolarised Fresnel equations (default, as Mitsuba).
    #[default]
    Exact,
    /// Schlick's approximation (a Specula option).
    Schlick,
}

impl FresnelMode {
    /// Transmittance of a known refraction pair (see [`dielectric_transmittance_pair`]);
    /// `eta_it` = η_t/η_i seen from the incident side.
    #[inline]
    pub fn transmittance_pair(self, cos_i: f32, cos_t: f32, eta_it: f32) -> f32 {
        match self {
            FresnelMode::Exact => dielectric_transmittance_pair(cos_i, cos_t, eta_it),
            FresnelMode::Schlick => {
                let f0 = ((eta_it - 1.0) / (eta_it + 1.0)).powi(2);
                // the cosine on the optically thinner side
                let c = if eta_it >= 1.0 { cos_i } else { cos_t };
                1.0 - (f0 + (1.0 - f0) * (1.0 - c).powi(5))
            }
        }
    }

    #[inline]
    pub fn eval(self, cos_theta_i: f32, eta: f32) -> DielectricFresnel {
        match self {
            FresnelMode::Exact => fresnel_dielectric(cos_theta_i, eta),
            FresnelMode::Schlick => fresnel_schlick(cos_theta_i, eta),
        }
    }
}

/// Hemispherical average of the dielectric Fresnel reflectance, 2∫F(μ)μ dμ, by the polynomial
/// fits Mitsuba uses: Egan & Hilgeman (1973) for η < 1, d'Eon & Irving (2011) for η ≥ 1.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * (eta * eta) + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let i1 = 1.0 / eta;
        let i2 = i1 * i1;
        let i3 = i2 * i1;
        let i4 = i3 * i1;
        let i5 = i4 * i1;
        0.919317 - 3.4793 * i1 + 6.75335 * i2 - 7.80989 * i3 + 4.98554 * i4 - 1.36881 * i5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The three-channel conductor Fresnel is the scalar one per channel, bit for bit, over
    /// a grid of angles (including 0, 1 and out-of-range cosines) and of the named metals'
    /// range of η and k (including k = 0 and η < 1).
    #[test]
    fn conductor_rgb_is_the_scalar_formula_per_channel() {
        let etas = [0.05f32, 0.2, 0.27, 1.0, 1.5, 3.0, 4.4];
        let ks = [0.0f32, 0.5, 2.6, 3.6, 7.0];
        for i in 0..=64 {
            let c = -0.1 + 1.2 * i as f32 / 64.0;
            for (j, &e) in etas.iter().enumerate() {
                for (l, &k) in ks.iter().enumerate() {
                    let eta = Spectrum::new(e, etas[(j + 1) % etas.len()], etas[(j + 3) % 7]);
                    let kk = Spectrum::new(k, ks[(l + 2) % ks.len()], ks[(l + 4) % 5]);
                    let f = fresnel_conductor_rgb(c, eta, kk);
                    for ch in 0..3 {
                        let s = fresnel_conductor(c, eta[ch], kk[ch]);
                        assert_eq!(f[ch].to_bits(), s.to_bits(), "cos {c} η {eta:?} k {kk:?}");
                    }
                }
            }
        }
    }
}
