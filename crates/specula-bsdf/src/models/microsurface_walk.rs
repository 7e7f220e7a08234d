//! The exact multiple-scattering reference: Heitz, Hanika, d'Eon & Dachsbacher 2016,
//! "Multiple-scattering microfacet BSDFs with the Smith model" — a random walk on the Smith
//! microsurface (uncorrelated heights, uniform height distribution), for a conductor or a
//! dielectric interface, Beckmann or GGX, isotropic or anisotropic.
//!
//! Not a renderable material (it has no closed-form `eval` or `pdf`): it *samples* outgoing
//! directions with their energy, exactly, and is used to judge the energy compensation of
//! [`crate::multiscatter`] (tests, `specula brdf multiscatter`). Too slow for rendering (a
//! walk costs several visible-normal samples and `pow`s per bounce).
//!
//! The walk: the ray enters from `wi` above the surface; its next intersection height is drawn
//! from the Smith masking function (the probability of escaping from height h in direction ω
//! is C1(h)^Λ(ω)); at each intersection a microfacet normal is drawn from the distribution of
//! normals visible from the ray, and the ray reflects (conductor: weighted by the complex
//! Fresnel reflectance; dielectric: reflects with probability F, otherwise refracts and
//! continues on the other side of the microsurface, which seen from below is the same surface
//! flipped). The walk ends when the ray escapes; walks longer than `max_bounces` are dropped
//! (lost energy: < 1e-4 of it at α = 1 with the default 64). Arithmetic is in f64.
//!
//! Its single-scattering part uses the *height-correlated* masking-shadowing
//! G2 = 1/(1 + Λ(ωi) + Λ(ωo)), whereas `roughconductor`/`roughdielectric` use the separable
//! G1·G1 (as Mitsuba): the two agree on the total energy only once all orders are summed.

use crate::fresnel::{fresnel_conductor, fresnel_dielectric};
use crate::math::erf64;
use crate::microfacet::MicrofacetType;
use crate::rng::Pcg32;
use crate::spectrum::Spectrum;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// What the microsurface is made of.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WalkMaterial {
    /// Complex index η + ik per channel, times a reflectance.
    Conductor {
        eta: Spectrum,
        k: Spectrum,
        reflectance: Spectrum,
    },
    /// Relative index η_int/η_ext (white).
    Dielectric { eta: f32 },
}

/// A random walk on a Smith microsurface.
#[derive(Clone, Copy, Debug)]
pub struct MicrosurfaceWalk {
    pub kind: MicrofacetType,
    pub alpha_u: f64,
    pub alpha_v: f64,
    pub material: WalkMaterial,
    pub max_bounces: u32,
}

/// One walk's outcome.
#[derive(Clone, Copy, Debug)]
pub struct WalkSample {
    /// Outgoing direction (local frame; below the surface for transmission).
    pub wo: Vec3,
    /// Energy carried (1 for a white material; Fresnel products for a conductor).
    pub weight: Spectrum,
    /// Scattering events on the microsurface (1 = single scattering).
    pub bounces: u32,
}

impl MicrosurfaceWalk {
    pub fn new(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, material: WalkMaterial) -> Self {
        MicrosurfaceWalk {
            kind,
            alpha_u: alpha_u.max(1e-4) as f64,
            alpha_v: alpha_v.max(1e-4) as f64,
            material,
            max_bounces: 64,
        }
    }

    /// Smith's Λ of direction `w` (signed: Λ(−w) = −1 − Λ(w)).
    pub fn lambda(&self, w: DVec3) -> f64 {
        if w.z > 0.999_999 {
            return 0.0;
        }
        if w.z < -0.999_999 {
            return -1.0;
        }
        let r = ((self.alpha_u * w.x).powi(2) + (self.alpha_v * w.y).powi(2)).sqrt();
        // a = 1/(α tanθ), negative below the horizon
        let a = w.z / r;
        match self.kind {
            MicrofacetType::Ggx => 0.5 * (-1.0 + a.signum() * (1.0 + 1.0 / (a * a)).sqrt()),
            MicrofacetType::Beckmann => {
                0.5 * (erf64(a) - 1.0) + (-a * a).exp() / (2.0 * a * PI.sqrt())
            }
        }
    }

    /// The height CDF C1(h) of the uniform height distribution on [−1, 1], and its inverse.
    fn c1(h: f64) -> f64 {
        (0.5 * (h + 1.0)).clamp(0.0, 1.0)
    }
    fn inv_c1(u: f64) -> f64 {
        (2.0 * u - 1.0).clamp(-1.0, 1.0)
    }

    /// The height of the next intersection of a ray leaving height `h` in direction `w`, or
    /// `None` when it escapes.
    fn sample_height(&self, w: DVec3, h: f64, u: f64) -> Option<f64> {
        if w.z > 0.999_999 {
            return None;
        }
        if w.z < -0.999_999 {
            return Some(Self::inv_c1(u * Self::c1(h)));
        }
        if w.z.abs() < 1e-7 {
            return Some(h);
        }
        let lambda = self.lambda(w);
        let c = Self::c1(h);
        if w.z > 0.0 {
            // escapes with probability G1 = C1(h)^Λ
            let g1 = c.powf(lambda);
            if u > 1.0 - g1 {
                return None;
            }
        }
        Some(Self::inv_c1(c / (1.0 - u).powf(1.0 / lambda)))
    }

    /// A normal from the distribution of normals visible from `wi` (any direction with a
    /// visible part of the microsurface, including below the horizon).
    fn sample_vndf(&self, wi: DVec3, u1: f64, u2: f64) -> DVec3 {
        let (au, av) = (self.alpha_u, self.alpha_v);
        let v = DVec3::new(au * wi.x, av * wi.y, wi.z).normalize();
        let h = match self.kind {
            // Dupuy & Benyoub 2023: the visible normals of the unit hemisphere are v + a point
            // uniform on the spherical cap z > −v.z (valid for any v)
            MicrofacetType::Ggx => {
                let phi = 2.0 * PI * u1;
                let z = (1.0 - u2) * (1.0 + v.z) - v.z;
                let st = (1.0 - z * z).max(0.0).sqrt();
                let c = DVec3::new(st * phi.cos(), st * phi.sin(), z);
                c + v
            }
            // slope along v's azimuth from ∝ max(0, cosθ − x sinθ) e^(−x²), the other slope
            // Gaussian
            MicrofacetType::Beckmann => {
                let sin_t = (v.x * v.x + v.y * v.y).sqrt();
                let cos_t = v.z;
                let x = beckmann_visible_slope(cos_t, sin_t, u1);
                let y = erfinv64(2.0 * u2 - 1.0);
                let (cp, sp) = if sin_t > 0.0 {
                    (v.x / sin_t, v.y / sin_t)
                } else {
                    (1.0, 0.0)
                };
                DVec3::new(-(cp * x - sp * y), -(sp * x + cp * y), 1.0)
            }
        };
        DVec3::new(au * h.x, av * h.y, h.z.max(1e-12)).normalize()
    }

    /// One walk for light arriving from `wi` (pointing away from the surface, either side).
    pub fn sample(&self, wi: Vec3, rng: &mut Pcg32) -> Option<WalkSample> {
        self.sample_visit(wi, rng, |_, _| {})
    }

    /// [`Self::sample`], calling `visit(bounce, cos)` at each scattering event with the
    /// cosine between the ray and the microfacet normal it meets (1-based bounce count).
    pub fn sample_visit(
        &self,
        wi: Vec3,
        rng: &mut Pcg32,
        mut visit: impl FnMut(u32, f64),
    ) -> Option<WalkSample> {
        let mut wi = wi.as_dvec3().normalize();
        // from below, walk the flipped configuration of the inverse index
        let flip = wi.z < 0.0;
        let mut eta = match self.material {
            WalkMaterial::Dielectric { eta } => eta as f64,
            WalkMaterial::Conductor { .. } => 1.0,
        };
        if flip {
            if matches!(self.material, WalkMaterial::Conductor { .. }) {
                return None;
            }
            wi.z = -wi.z;
            eta = 1.0 / eta;
        }
        let mut wr = -wi;
        let mut h = 1.0 + Self::inv_c1(0.999);
        let mut outside = true;
        let mut energy = [1.0f64; 3];
        let mut bounces = 0;
        loop {
            let u = rng.next_f64();
            let next = if outside {
                self.sample_height(wr, h, u)
            } else {
                self.sample_height(-wr, -h, u).map(|h| -h)
            };
            let Some(hn) = next else { break };
            h = hn;
            bounces += 1;
            if bounces > self.max_bounces {
                return None;
            }
            let wi_b = -wr;
            let (u1, u2) = (rng.next_f64(), rng.next_f64());
            let m = if outside {
                self.sample_vndf(wi_b, u1, u2)
            } else {
                -self.sample_vndf(-wi_b, u1, u2)
            };
            let c = wi_b.dot(m);
            if c <= 0.0 {
                // a grazing normal rounded to the back: negligible measure
                return None;
            }
            visit(bounces, c);
            match self.material {
                WalkMaterial::Conductor {
                    eta,
                    k,
                    reflectance,
                } => {
                    for (ch, e) in energy.iter_mut().enumerate() {
                        *e *= fresnel_conductor(c as f32, eta[ch], k[ch]) as f64
                            * reflectance[ch] as f64;
                    }
                    wr = 2.0 * c * m - wi_b;
                }
                WalkMaterial::Dielectric { .. } => {
                    let e = if outside { eta } else { 1.0 / eta };
                    let f = fresnel_dielectric(c as f32, e as f32);
                    if rng.next_f64() < f.r as f64 {
                        wr = 2.0 * c * m - wi_b;
                    } else {
                        let inv = 1.0 / e;
                        let ct2 = 1.0 - inv * inv * (1.0 - c * c);
                        if ct2 <= 0.0 {
                            wr = 2.0 * c * m - wi_b;
                        } else {
                            wr = -inv * wi_b + (inv * c - ct2.sqrt()) * m;
                            outside = !outside;
                        }
                    }
                }
            }
            wr = wr.normalize();
            if !wr.is_finite() {
                return None;
            }
        }
        if bounces == 0 {
            return None;
        }
        if flip {
            wr.z = -wr.z;
        }
        Some(WalkSample {
            wo: wr.as_vec3(),
            weight: Spectrum::new(energy[0] as f32, energy[1] as f32, energy[2] as f32),
            bounces,
        })
    }
}

/// Inverse error function in f64 (a Newton-refined rational start; ~1e-12 where it matters).
fn erfinv64(y: f64) -> f64 {
    let y = y.clamp(-1.0 + 1e-15, 1.0 - 1e-15);
    let mut x = crate::math::erfinv(y as f32) as f64;
    if !x.is_finite() {
        x = x.signum() * 5.0;
    }
    for _ in 0..3 {
        let err = erf64(x) - y;
        x -= err / (2.0 / PI.sqrt() * (-x * x).exp());
    }
    x
}

/// The unit-roughness Beckmann slope along the view's azimuth, distributed as
/// ∝ max(0, cosθ − x sinθ) e^(−x²), for any θ (view below the horizon included), by bisection
/// on its CDF F(x) = cosθ (1 + erf x)/2 + sinθ e^(−x²)/(2√π) (x ≤ cotθ), and a Gamma(2) tail
/// where cotθ lies so far out (< −20) that F would underflow.
fn beckmann_visible_slope(cos_t: f64, sin_t: f64, u: f64) -> f64 {
    if sin_t < 1e-9 {
        return erfinv64(2.0 * u - 1.0);
    }
    let x_max = cos_t / sin_t;
    if x_max < -20.0 {
        // density ∝ (x_max − x) e^(2 x_max (x_max − x)) near the edge: t = x_max − x is
        // Gamma(2, rate), CDF 1 − (1 + rate·t) e^(−rate·t), inverted by bisection
        let rate = -2.0 * x_max;
        let (mut lo, mut hi) = (0.0f64, 50.0 / rate);
        for _ in 0..80 {
            let t = 0.5 * (lo + hi);
            if 1.0 - (1.0 + rate * t) * (-rate * t).exp() < u {
                lo = t;
            } else {
                hi = t;
            }
        }
        return x_max - 0.5 * (lo + hi);
    }
    // 1 + erf(x) = erfc(−x), accurate far into the negative tail
    let f =
        |x: f64| 0.5 * cos_t * crate::math::erfc64(-x) + sin_t * (-x * x).exp() / (2.0 * PI.sqrt());
    let target = u * f(x_max);
    let (mut lo, mut hi) = (x_max.min(0.0) - 9.0, x_max);
    for _ in 0..52 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::microfacet::MicrofacetDistribution;
    use crate::multiscatter::vndf_quadrature;

    fn white(kind: MicrofacetType, a: f32) -> MicrosurfaceWalk {
        MicrosurfaceWalk::new(
            kind,
            a,
            a,
            WalkMaterial::Conductor {
                eta: Spectrum::splat(0.0),
                k: Spectrum::splat(1.0),
                reflectance: Spectrum::splat(1.0),
            },
        )
    }

    /// The walk's visible normals follow D_wi: their mean cosine with the macro-normal
    /// matches the quadrature of the renderer's distribution.
    #[test]
    fn vndf_matches_the_distribution() {
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            let w = white(kind, 0.6);
            let d = MicrofacetDistribution::new(kind, 0.6, 0.6, true);
            for mu in [0.2f32, 0.7] {
                let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let exact = vndf_quadrature(&d, wi, 64, |m| [m.z as f64, m.x as f64]);
                let mut rng = Pcg32::new(3, 1);
                let n = 200_000;
                let (mut sz, mut sx) = (0.0, 0.0);
                for _ in 0..n {
                    let m = w.sample_vndf(wi.as_dvec3(), rng.next_f64(), rng.next_f64());
                    sz += m.z;
                    sx += m.x;
                }
                let (mz, mx) = (sz / n as f64, sx / n as f64);
                assert!(
                    (mz - exact[0]).abs() < 3e-3,
                    "{kind:?} {mu}: {mz} vs {}",
                    exact[0]
                );
                assert!(
                    (mx - exact[1]).abs() < 3e-3,
                    "{kind:?} {mu}: {mx} vs {}",
                    exact[1]
                );
            }
        }
    }

    /// Single scattering of the walk is the height-correlated microfacet BRDF: its albedo is
    /// ∫ D_wi(m) (1 + Λ(wi)) / (1 + Λ(wi) + Λ(wo)) dm.
    #[test]
    fn first_bounce_is_height_correlated_smith() {
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            for a in [0.3f32, 1.0] {
                let w = white(kind, a);
                let d = MicrofacetDistribution::new(kind, a, a, true);
                for mu in [0.3f32, 0.9] {
                    let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                    let li = w.lambda(wi.as_dvec3());
                    let exact = vndf_quadrature(&d, wi, 96, |m| {
                        let wo = crate::frame::reflect(wi, m);
                        if wo.z <= 0.0 {
                            return [0.0; 2];
                        }
                        [(1.0 + li) / (1.0 + li + w.lambda(wo.as_dvec3())), 0.0]
                    })[0];
                    let mut rng = Pcg32::new(5, 2);
                    let n = 100_000;
                    let (mut single, mut total) = (0usize, 0usize);
                    for _ in 0..n {
                        if let Some(s) = w.sample(wi, &mut rng) {
                            total += 1;
                            single += (s.bounces == 1) as usize;
                        }
                    }
                    let p = single as f64 / n as f64;
                    let se = (p * (1.0 - p) / n as f64).sqrt();
                    assert!(
                        (p - exact).abs() < 5.0 * se + 1e-3,
                        "{kind:?} α={a} μ={mu}: {p} vs {exact}"
                    );
                    // a white conductor loses nothing (except walks cut at 64 bounces)
                    assert!(total as f64 / n as f64 > 0.9995, "{total}");
                }
            }
        }
    }

    /// The first event of the dielectric walk is the height-correlated single-scattering model
    /// (`MicrofacetDistribution::g2_correlated`: 1/(1 + Λi + Λo) after a reflection,
    /// B(1 + Λi, 1 + Λo) after a refraction), which `roughdielectric multiscatter=true` uses:
    /// the fractions of walks that reflect and that refract once and leave, from both sides,
    /// against the model's R and T by quadrature, within 5σ (binomial, 100 000 walks; a false
    /// failure has probability < 1e-5 per value) + 2e-3 (the quadrature). The separable
    /// G1(ωi)G1(ωo) transmits more at grazing incidence: at GGX α = 1, μ = 0.1 from outside it
    /// is more than 20σ off the walk (the test has power).
    #[test]
    fn dielectric_first_event_is_height_correlated() {
        use crate::multiscatter::dielectric_albedo;
        for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
            for a in [0.3f32, 1.0] {
                let w = MicrosurfaceWalk::new(kind, a, a, WalkMaterial::Dielectric { eta: 1.5 });
                let d = MicrofacetDistribution::new(kind, a, a, true);
                for (mu, side) in [(0.1f32, 1.0f32), (0.7, 1.0), (0.1, -1.0), (0.7, -1.0)] {
                    let eta = if side > 0.0 { 1.5 } else { 1.0 / 1.5 };
                    let fe = crate::fresnel::FresnelMode::Exact;
                    let hc = dielectric_albedo(&d, fe, eta, mu, 96, true);
                    let sep = dielectric_albedo(&d, fe, eta, mu, 96, false);
                    let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, side * mu);
                    let mut rng = Pcg32::new(11, 5);
                    let n = 100_000;
                    let (mut r, mut t) = (0usize, 0usize);
                    for _ in 0..n {
                        if let Some(s) = w.sample(wi, &mut rng) {
                            if s.bounces == 1 {
                                if s.wo.z * wi.z > 0.0 {
                                    r += 1;
                                } else {
                                    t += 1;
                                }
                            }
                        }
                    }
                    for (k, count) in [r, t].into_iter().enumerate() {
                        let p = count as f64 / n as f64;
                        let se = (p * (1.0 - p) / n as f64).sqrt().max(1e-4);
                        assert!(
                            (p - hc[k]).abs() < 5.0 * se + 2e-3,
                            "{kind:?} α={a} μ={} {}: walk {p} vs correlated {} (separable {})",
                            side * mu,
                            ["R", "T"][k],
                            hc[k],
                            sep[k]
                        );
                        if kind == MicrofacetType::Ggx && a == 1.0 && mu == 0.1 && side > 0.0 {
                            assert!(k == 0 || sep[1] - p > 20.0 * se, "{p} vs {}", sep[1]);
                        }
                    }
                }
            }
        }
    }

    /// The white dielectric walk conserves energy from both sides, and its transmission obeys
    /// reciprocity on average: T_out,avg = η² T_in,avg (importance transport).
    #[test]
    fn dielectric_walk_conserves_energy_and_is_reciprocal() {
        let w = MicrosurfaceWalk::new(
            MicrofacetType::Ggx,
            0.7,
            0.7,
            WalkMaterial::Dielectric { eta: 1.5 },
        );
        let mut rng = Pcg32::new(9, 3);
        let n = 100_000;
        let mut t_avg = [0.0f64; 2];
        for (side, sign) in [(0, 1.0f32), (1, -1.0)] {
            let mut lost = 0;
            let mut t = 0.0;
            for _ in 0..n {
                // cosine-weighted incidence: the transmitted count estimates T_avg
                let d = crate::warp::square_to_cosine_hemisphere(rng.next_vec2());
                let wi = Vec3::new(d.x, d.y, sign * d.z);
                match w.sample(wi, &mut rng) {
                    Some(s) => t += (s.wo.z * wi.z < 0.0) as u32 as f64,
                    None => lost += 1,
                }
            }
            assert!(lost < n / 1000, "{lost}");
            t_avg[side] = t / n as f64;
        }
        let ratio = t_avg[0] / t_avg[1];
        assert!((ratio - 2.25).abs() < 0.06, "T_out/T_in = {ratio}");
    }
}

/// The walk on the microsurface a `roughconductor` or `roughdielectric` describes (constant
/// parameters; the dielectric's reflectance and transmittance tints are left out, the
/// material should be white for a comparison).
pub fn walk_for(b: &super::Bsdf) -> Result<MicrosurfaceWalk, String> {
    use crate::bsdf::{FloatParam, SpectrumParam};
    let konst = |p: &FloatParam| match p {
        FloatParam::Const(v) => Ok(*v),
        _ => Err("the random walk needs a constant roughness".to_string()),
    };
    let kspec = |p: &SpectrumParam| {
        p.rgb_constant()
            .ok_or_else(|| "the random walk needs constant optical constants".to_string())
    };
    match b {
        super::Bsdf::RoughConductor(c) => Ok(MicrosurfaceWalk::new(
            c.distribution,
            konst(&c.alpha_u)?,
            konst(&c.alpha_v)?,
            WalkMaterial::Conductor {
                eta: kspec(&c.eta)?,
                k: kspec(&c.k)?,
                reflectance: kspec(&c.specular_reflectance)?,
            },
        )),
        super::Bsdf::RoughDielectric(d) => Ok(MicrosurfaceWalk::new(
            d.distribution,
            konst(&d.alpha_u)?,
            konst(&d.alpha_v)?,
            WalkMaterial::Dielectric { eta: d.eta },
        )),
        other => Err(format!(
            "no microsurface random walk for '{}' (only roughconductor and roughdielectric)",
            other.plugin_name()
        )),
    }
}

/// The exact reference of a material with energy compensation: the walk on its microsurface
/// and whether only the walk's reflection is the reference (the light the walk transmits
/// counts as absorbed: [`compare_reflection`]).
///
/// - `roughconductor`, `roughdielectric`: [`walk_for`];
/// - `roughplastic` with a black base (`diffuse_reflectance` 0, `specular_reflectance` 1,
///   exact Fresnel): the coat alone, the dielectric walk's reflection;
/// - `principled` of constant parameters with `base_color` 1, no sheen and no clearcoat: a
///   white metal (`metallic` 1) is the white conductor walk, a clear glass (`metallic` 0,
///   `spec_trans` 1, `spec_tint` 0) the dielectric walk, both GGX at the model's (αu, αv).
pub fn reference_for(b: &super::Bsdf) -> Result<(MicrosurfaceWalk, bool), String> {
    use crate::bsdf::{FloatParam, SpectrumParam};
    let is = |p: &FloatParam, v: f32| matches!(p, FloatParam::Const(c) if *c == v);
    let spectrum_is = |p: &SpectrumParam, v: f32| {
        p.rgb_constant()
            .is_some_and(|c| c.0.iter().all(|&x| x == v))
    };
    match b {
        super::Bsdf::RoughPlastic(p) => {
            if !(spectrum_is(&p.diffuse_reflectance, 0.0)
                && spectrum_is(&p.specular_reflectance, 1.0)
                && p.fresnel == crate::fresnel::FresnelMode::Exact)
            {
                return Err(
                    "the random walk is the reference of a roughplastic with a black \
                     base only (diffuse_reflectance=0, specular_reflectance=1, exact Fresnel)"
                        .to_string(),
                );
            }
            let walk = MicrosurfaceWalk::new(
                p.distribution,
                p.alpha,
                p.alpha,
                WalkMaterial::Dielectric { eta: p.eta },
            );
            Ok((walk, true))
        }
        super::Bsdf::Principled(p) => {
            let konst = |f: &FloatParam| match f {
                FloatParam::Const(v) => Some(*v),
                _ => None,
            };
            let (Some(r), Some(a)) = (konst(&p.roughness), konst(&p.anisotropic)) else {
                return Err("the random walk needs a constant roughness".to_string());
            };
            let plain = spectrum_is(&p.base_color, 1.0) && is(&p.sheen, 0.0) && !p.has_clearcoat;
            let (au, av) = super::principled::dist_params(a, r);
            let distribution = crate::microfacet::MicrofacetType::Ggx;
            if plain && is(&p.metallic, 1.0) {
                let material = WalkMaterial::Conductor {
                    eta: Spectrum::ZERO,
                    k: Spectrum::ONE,
                    reflectance: Spectrum::ONE,
                };
                return Ok((MicrosurfaceWalk::new(distribution, au, av, material), false));
            }
            if plain
                && is(&p.metallic, 0.0)
                && p.has_spec_trans
                && is(&p.spec_trans, 1.0)
                && is(&p.spec_tint, 0.0)
            {
                let material = WalkMaterial::Dielectric { eta: p.eta };
                return Ok((MicrosurfaceWalk::new(distribution, au, av, material), false));
            }
            Err(
                "the random walk is the reference of a principled white metal (base_color=1 \
                 metallic=1) or clear glass (base_color=1 spec_trans=1 spec_tint=0), without \
                 sheen or clearcoat"
                    .to_string(),
            )
        }
        other => walk_for(other).map(|w| (w, false)),
    }
}

/// Bins of the lobe comparison: uniform in cosθ (equal solid angle) on each hemisphere, and in
/// φ.
pub const LOBE_MU_BINS: usize = 12;
pub const LOBE_PHI_BINS: usize = 16;

/// How a material's scattering for one incidence compares with the random walk's.
#[derive(Clone, Copy, Debug)]
pub struct Agreement {
    /// Directional albedo (R + T) per channel, the model's and the walk's, with standard errors.
    pub model: [f64; 3],
    pub walk: [f64; 3],
    pub model_err: [f64; 3],
    pub walk_err: [f64; 3],
    /// Transmitted part of the albedo (channel mean), model and walk.
    pub model_t: f64,
    pub walk_t: f64,
    /// Largest relative albedo difference over the channels, |model − walk| / walk.
    pub albedo_rel: f64,
    /// Lobe shape: the total-variation distance ½ Σ|p − q| between the two energy histograms,
    /// each normalised to 1 (the fraction of the scattered energy that lands in different
    /// bins), over [`LOBE_MU_BINS`] × [`LOBE_PHI_BINS`] bins per hemisphere.
    pub lobe_tv: f64,
    /// The same distance between two independent halves of the walk's samples, divided by √2:
    /// the value `lobe_tv` takes from sampling noise alone when the lobes are identical.
    pub lobe_noise: f64,
}

pub(crate) fn lobe_bin(w: Vec3) -> usize {
    let hemi = (w.z < 0.0) as usize;
    let mu = ((w.z.abs() * LOBE_MU_BINS as f32) as usize).min(LOBE_MU_BINS - 1);
    let phi = w.y.atan2(w.x) / (2.0 * std::f32::consts::PI) + 0.5;
    let p = ((phi * LOBE_PHI_BINS as f32) as usize).min(LOBE_PHI_BINS - 1);
    (hemi * LOBE_MU_BINS + mu) * LOBE_PHI_BINS + p
}

fn total_variation(a: &[f64], b: &[f64]) -> f64 {
    let (sa, sb): (f64, f64) = (a.iter().sum(), b.iter().sum());
    if sa <= 0.0 || sb <= 0.0 {
        return 1.0;
    }
    0.5 * a
        .iter()
        .zip(b)
        .map(|(x, y)| (x / sa - y / sb).abs())
        .sum::<f64>()
}

/// Compare `model` (importance transport, its own sampling) with `walk` for incidence `wi`,
/// `samples` samples each.
pub fn compare<B: crate::bsdf::BsdfModel + ?Sized>(
    model: &B,
    walk: &MicrosurfaceWalk,
    wi: Vec3,
    samples: usize,
    seed: u64,
) -> Agreement {
    compare_with(model, walk, wi, samples, seed, false)
}

/// [`compare`] against the walk's reflection alone: the light the walk transmits counts as
/// absorbed (the ground truth of a dielectric coat over a black base, e.g. `roughplastic`
/// with `diffuse_reflectance=0`).
pub fn compare_reflection<B: crate::bsdf::BsdfModel + ?Sized>(
    model: &B,
    walk: &MicrosurfaceWalk,
    wi: Vec3,
    samples: usize,
    seed: u64,
) -> Agreement {
    compare_with(model, walk, wi, samples, seed, true)
}

fn compare_with<B: crate::bsdf::BsdfModel + ?Sized>(
    model: &B,
    walk: &MicrosurfaceWalk,
    wi: Vec3,
    samples: usize,
    seed: u64,
    reflection_only: bool,
) -> Agreement {
    let bins = 2 * LOBE_MU_BINS * LOBE_PHI_BINS;
    let ctx = crate::bsdf::BsdfContext::IMPORTANCE;
    let sp = crate::bsdf::ShadingPoint::default();
    let mut hm = vec![0.0f64; bins];
    let mut hw = [vec![0.0f64; bins], vec![0.0f64; bins]];
    let (mut sm, mut sm2, mut sw, mut sw2) = ([0.0f64; 3], [0.0f64; 3], [0.0f64; 3], [0.0f64; 3]);
    let (mut tm, mut tw) = (0.0f64, 0.0f64);
    let mut rng = Pcg32::new(seed, 21);
    for _ in 0..samples {
        let u1 = rng.next_f32();
        let u2 = rng.next_vec2();
        if let Some(s) = model.sample(&ctx, &sp, wi, u1, u2) {
            let w = s.weight.0.map(f64::from);
            for c in 0..3 {
                sm[c] += w[c];
                sm2[c] += w[c] * w[c];
            }
            let mean = (w[0] + w[1] + w[2]) / 3.0;
            hm[lobe_bin(s.wo)] += mean;
            if s.wo.z * wi.z < 0.0 {
                tm += mean;
            }
        }
    }
    let mut rng = Pcg32::new(seed, 22);
    for i in 0..samples {
        if let Some(s) = walk
            .sample(wi, &mut rng)
            .filter(|s| !reflection_only || s.wo.z * wi.z > 0.0)
        {
            let w = s.weight.0.map(f64::from);
            for c in 0..3 {
                sw[c] += w[c];
                sw2[c] += w[c] * w[c];
            }
            let mean = (w[0] + w[1] + w[2]) / 3.0;
            hw[i & 1][lobe_bin(s.wo)] += mean;
            if s.wo.z * wi.z < 0.0 {
                tw += mean;
            }
        }
    }
    let n = samples as f64;
    let mean = |s: [f64; 3]| s.map(|v| v / n);
    let err = |s: [f64; 3], s2: [f64; 3]| {
        [0, 1, 2].map(|c| ((s2[c] / n - (s[c] / n).powi(2)).max(0.0) / n).sqrt())
    };
    let (model_a, walk_a) = (mean(sm), mean(sw));
    let albedo_rel = (0..3)
        .map(|c| (model_a[c] - walk_a[c]).abs() / walk_a[c].max(1e-12))
        .fold(0.0, f64::max);
    let hw_all: Vec<f64> = hw[0].iter().zip(&hw[1]).map(|(a, b)| a + b).collect();
    Agreement {
        model: model_a,
        walk: walk_a,
        model_err: err(sm, sm2),
        walk_err: err(sw, sw2),
        model_t: tm / n,
        walk_t: tw / n,
        albedo_rel,
        lobe_tv: total_variation(&hm, &hw_all),
        lobe_noise: total_variation(&hw[0], &hw[1]) / std::f64::consts::SQRT_2,
    }
}
