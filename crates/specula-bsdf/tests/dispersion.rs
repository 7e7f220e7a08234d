//! Dispersion: a prism's minimum deviation per wavelength against Snell + Sellmeier, the
//! property suite in spectral mode on dispersive materials, the relMSE of hero-wavelength MIS
//! against terminating the secondary wavelengths, and the XML extension's errors.

use glam::{Vec2, Vec3};
use specula_bsdf::bsdf::{BsdfContext, BsdfModel, LobeFlags, ShadingPoint};
use specula_bsdf::check::{run_suite, SuiteConfig, Verdict};
use specula_bsdf::frame::Frame;
use specula_bsdf::parse_spec;
use specula_bsdf::rng::Pcg32;
use specula_bsdf::spectral::dispersion::{
    collapse_dead_channels, glass, LAMBDA_C, LAMBDA_D, LAMBDA_F,
};
use specula_bsdf::Wavelengths;

fn at(w: [f32; 3]) -> ShadingPoint<'static> {
    ShadingPoint {
        wavelengths: Some(Wavelengths(w)),
        ..Default::default()
    }
}

/// Refract the world-space direction `d` (travelling towards the surface) through a face
/// with outward normal `n`, with the `dielectric` model's own sampler in spectral mode at
/// wavelengths `w`, keeping the refraction of channel `j` (found by scanning the lobe
/// random number: the sampler refracts one channel at a time).
fn refract_through(
    b: &specula_bsdf::Bsdf,
    w: [f32; 3],
    j: usize,
    n: Vec3,
    d: Vec3,
) -> Option<Vec3> {
    let frame = Frame::from_normal(n);
    let wi = frame.to_local(-d);
    let sp = at(w);
    for k in 0..10_000 {
        let u1 = (k as f32 + 0.5) / 10_000.0;
        let s = b.sample(&BsdfContext::RADIANCE, &sp, wi, u1, Vec2::splat(0.5))?;
        if s.lobe == LobeFlags::DELTA_TRANSMISSION && s.weight[j] > 0.0 {
            // exactly this channel's refraction
            assert!((0..3).all(|c| c == j || s.weight[c] == 0.0 || w[c] == w[j]));
            return Some(frame.to_world(s.wo).normalize());
        }
    }
    None
}

/// Deviation (radians) of a ray entering a prism of apex angle `apex` at incidence `theta1`
/// on its first face, traced through both faces with the model.
fn deviation(b: &specula_bsdf::Bsdf, w: [f32; 3], j: usize, apex: f64, theta1: f64) -> f64 {
    // the prism's apex points along +y; the outward normals of its left and right faces are
    // (∓cos(A/2), sin(A/2), 0)
    let h = apex / 2.0;
    let n1 = Vec3::new(-(h.cos()) as f32, h.sin() as f32, 0.0);
    let n2 = Vec3::new(h.cos() as f32, h.sin() as f32, 0.0);
    // incoming direction: at angle theta1 from the inward normal −n1, turned towards the apex
    // (so that near minimum deviation the ray crosses the prism parallel to its base)
    let (s, c) = theta1.sin_cos();
    let t = Vec3::new(h.sin() as f32, h.cos() as f32, 0.0); // along face 1, towards the apex
    let d0 = (-n1 * c as f32 + t * s as f32).normalize();
    let d1 = refract_through(b, w, j, n1, d0).expect("enters");
    let d2 = refract_through(b, w, j, n2, d1).expect("leaves");
    (d0.as_dvec3().dot(d2.as_dvec3())).clamp(-1.0, 1.0).acos()
}

/// A BK7 prism with a 60° apex at minimum deviation: the deviation of the rays the
/// `dielectric` model's spectral sampler traces, minimised over the incidence angle, equals
/// δ_min = 2·asin(n(λ)·sin(A/2)) − A with n(λ) from the Sellmeier formula, at the F, d and C
/// lines, to 2e-6 rad (0.4 arcsecond; single-precision tracing reaches ~3e-7).
#[test]
fn bk7_prism_minimum_deviation_at_f_d_c() {
    // catalogue indices are relative to air: the exterior is given as vacuum so that the
    // relative index is the catalogue's (Mitsuba's default `ext_ior` is air, 1.000277)
    let b = parse_spec("dielectric dispersion=bk7 ext_ior=vacuum").unwrap();
    let apex = 60f64.to_radians();
    let w = [LAMBDA_F, LAMBDA_D, LAMBDA_C];
    let ior = glass("bk7").unwrap().ior;
    let mut got = [0.0f64; 3];
    for j in 0..3 {
        // golden-section search of the deviation over the incidence angle
        let (mut lo, mut hi) = (35f64.to_radians(), 65f64.to_radians());
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..60 {
            let a = hi - g * (hi - lo);
            let c = lo + g * (hi - lo);
            if deviation(&b, w, j, apex, a) < deviation(&b, w, j, apex, c) {
                hi = c;
            } else {
                lo = a;
            }
        }
        let delta = deviation(&b, w, j, apex, 0.5 * (lo + hi));
        let n = ior.at(w[j]) as f64;
        let analytic = 2.0 * (n * (apex / 2.0).sin()).asin() - apex;
        println!(
            "λ = {:.1} nm: n = {n:.5}, δ_min traced {:.5}°, analytic {:.5}°, difference {:.2e} rad",
            w[j],
            delta.to_degrees(),
            analytic.to_degrees(),
            delta - analytic
        );
        assert!((delta - analytic).abs() < 2e-6, "{delta} vs {analytic}");
        got[j] = delta;
    }
    // blue bends most
    assert!(got[0] > got[1] && got[1] > got[2]);
}

fn suite(spec: &str, w: [f32; 3]) {
    let b = parse_spec(spec).unwrap();
    let cfg = SuiteConfig {
        samples: 100_000,
        seed: 3,
        wavelengths: Some(Wavelengths(w)),
        ..Default::default()
    };
    let r = run_suite(&b, &cfg, &|_, _| {});
    for o in &r.outcomes {
        println!("{spec} at {w:?}: {} {}: {}", o.name, o.verdict, o.summary);
        assert_ne!(
            o.verdict,
            Verdict::Fail,
            "{spec} {w:?}: {}: {:?}",
            o.name,
            o.details
        );
    }
    for name in ["non-negative", "energy"] {
        assert_eq!(r.outcome(name).unwrap().verdict, Verdict::Pass);
    }
}

/// The property suite (χ² of the mixture density, sample weight vs eval/pdf, reciprocity with
/// per-channel η, energy per wavelength) in spectral mode, on three distinct wavelengths and
/// on one wavelength alone.
#[test]
fn property_suite_per_wavelength() {
    for spec in [
        "roughdielectric dispersion=sf11 alpha=0.2",
        "roughdielectric distribution=beckmann alpha_u=0.05 alpha_v=0.3 int_ior=1.6 abbe_number=20",
        "dielectric dispersion=diamond",
        "thindielectric dispersion=bk7",
    ] {
        suite(spec, [430.0, 550.0, 670.0]);
    }
    suite("roughdielectric dispersion=diamond alpha=0.1", [450.0; 3]);
}

/// A spectrally flat, direction-peaked incident light (a soft spot seen through the glass).
fn light(wo: Vec3, centre: Vec3) -> f64 {
    let d = (wo - centre).length_squared() as f64;
    (-d / (2.0 * 0.03f64.powi(2))).exp()
}

/// Three film-like band weights g_b(λ) (Gaussians at 450, 550, 620 nm).
fn bands(l: f32) -> [f64; 3] {
    [450.0, 550.0, 620.0].map(|c: f64| (-(l as f64 - c).powi(2) / (2.0 * 35.0f64.powi(2))).exp())
}

/// One estimate of Q_b = E_λ[g_b(λ) ∫ f(λ; wi, wo)|cosθo| L(wo) dwo] with `n` paths, each
/// drawing a hero wavelength uniformly in [400, 700) nm with two secondaries rotated by
/// thirds of the range: `mis` with the model's sampler (all channels kept), otherwise
/// sampling with the hero's index and terminating the secondaries (pbrt-v4).
fn estimate(
    b: &specula_bsdf::Bsdf,
    wi: Vec3,
    centre: Vec3,
    mis: bool,
    n: usize,
    rng: &mut Pcg32,
) -> [f64; 3] {
    let ior = glass("sf11").unwrap().ior;
    let specula_bsdf::Bsdf::RoughDielectric(base) = b else {
        panic!("a roughdielectric")
    };
    let mut q = [0.0f64; 3];
    for _ in 0..n {
        let l0 = 400.0 + 300.0 * rng.next_f32();
        let w = [0, 1, 2].map(|k| 400.0 + (l0 - 400.0 + 100.0 * k as f32) % 300.0);
        let (u1, u2) = (rng.next_f32(), rng.next_vec2());
        let sample = if mis {
            b.sample(&BsdfContext::RADIANCE, &at(w), wi, u1, u2)
                .map(|s| (s.wo, [0, 1, 2].map(|c| s.weight[c] as f64 / 3.0)))
        } else {
            // the plain model at the hero's index; the hero's weight counts three times
            let mut plain = base.clone();
            plain.eta = ior.at(w[0]);
            plain.dispersion = None;
            plain
                .sample(&BsdfContext::RADIANCE, &ShadingPoint::default(), wi, u1, u2)
                .map(|s| (s.wo, [s.weight[0] as f64, 0.0, 0.0]))
        };
        let Some((wo, contrib)) = sample else {
            continue;
        };
        let l = light(wo, centre);
        for c in 0..3 {
            let g = bands(w[c]);
            for k in 0..3 {
                q[k] += contrib[c] * l * g[k];
            }
        }
    }
    q.map(|v| v / n as f64)
}

/// Hero-wavelength MIS across the wavelengths against termination of the secondary
/// wavelengths on a rough dispersive glass (SF11, GGX α = 0.1), at equal sample counts: the
/// relative MSE of three band-weighted transmitted radiances, over independent estimates.
#[test]
fn hero_mis_beats_termination() {
    let b = parse_spec("roughdielectric alpha=0.1 dispersion=sf11").unwrap();
    let wi = Vec3::new(0.5, 0.0, 0.75f32.sqrt());
    // the light sits around the refracted direction at the d line
    let eta = glass("sf11").unwrap().ior.n_d();
    let f = specula_bsdf::fresnel::fresnel_dielectric(wi.z, eta);
    let centre = specula_bsdf::frame::refract(wi, Vec3::Z, f.cos_theta_t, f.eta_ti);
    let mut rng = Pcg32::new(11, 5);
    let reference = estimate(&b, wi, centre, true, 400_000, &mut rng);
    let (trials, spp) = (300, 16);
    let mut rel_mse = [0.0f64; 2];
    for (k, mis) in [true, false].into_iter().enumerate() {
        let mut rng = Pcg32::new(12 + k as u64, 9);
        let mut e = 0.0;
        for _ in 0..trials {
            let q = estimate(&b, wi, centre, mis, spp, &mut rng);
            for c in 0..3 {
                e += ((q[c] - reference[c]) / reference[c]).powi(2) / 3.0;
            }
        }
        rel_mse[k] = e / trials as f64;
    }
    println!(
        "relMSE at {spp} samples (mean of 3 bands over {trials} estimates): hero MIS {:.4}, termination {:.4}, ratio {:.2}",
        rel_mse[0],
        rel_mse[1],
        rel_mse[1] / rel_mse[0]
    );
    assert!(reference.iter().all(|&v| v > 0.0));
    assert!(rel_mse[0] < 0.7 * rel_mse[1], "{rel_mse:?}");
}

/// One estimate of the band-weighted transmittance T₁T₂ through two smooth dispersive
/// interfaces (a slab of SF11 entered at 50° and left at the refracted angle, as through a
/// prism), with `n` paths of three hero-rotated wavelengths. `policy`: 0 = the dielectric's
/// per-vertex channel choice alone, 1 = the same with the integrator collapsing dead channels
/// ([`collapse_dead_channels`]), 2 = pbrt-v4's termination of the secondaries at the first
/// interface.
fn two_interfaces(policy: u8, n: usize, rng: &mut Pcg32) -> [f64; 3] {
    let b = parse_spec("dielectric dispersion=sf11 ext_ior=vacuum").unwrap();
    let (s, c) = 50f32.to_radians().sin_cos();
    let wi1 = Vec3::new(s, 0.0, c);
    let mut q = [0.0f64; 3];
    for _ in 0..n {
        let l0 = 400.0 + 300.0 * rng.next_f32();
        let mut w = [0, 1, 2].map(|k| 400.0 + (l0 - 400.0 + 100.0 * k as f32) % 300.0);
        let film = w;
        if policy == 2 {
            w = [w[0]; 3];
        }
        let Some(s1) = b.sample(
            &BsdfContext::RADIANCE,
            &at(w),
            wi1,
            rng.next_f32(),
            Vec2::ZERO,
        ) else {
            continue;
        };
        if s1.lobe != LobeFlags::DELTA_TRANSMISSION {
            continue;
        }
        let mut beta = s1.weight;
        if policy == 2 {
            // the hero alone carries the path, counted three times
            beta = specula_bsdf::Spectrum::new(beta[0] * 3.0, 0.0, 0.0);
        }
        let mut w2 = Wavelengths(w);
        if policy == 1 {
            collapse_dead_channels(&mut w2, beta.0);
        }
        // the second interface, from inside, at the refracted angle (the slab's other face)
        let wi2 = Vec3::new(-s1.wo.x, -s1.wo.y, s1.wo.z);
        let Some(s2) = b.sample(
            &BsdfContext::RADIANCE,
            &at(w2.0),
            wi2,
            rng.next_f32(),
            Vec2::ZERO,
        ) else {
            continue;
        };
        if s2.lobe != LobeFlags::DELTA_TRANSMISSION {
            continue;
        }
        let beta = beta * s2.weight;
        for ch in 0..3 {
            let g = bands(film[ch]);
            for k in 0..3 {
                q[k] += beta[ch] as f64 * g[k] / 3.0;
            }
        }
    }
    q.map(|v| v / n as f64)
}

/// Through two smooth dispersive interfaces the per-vertex channel choice alone loses two
/// thirds of the paths at the second interface; collapsing dead channels in the integrator
/// (one line in a path loop) makes it as good as termination. All three are unbiased.
#[test]
fn collapsing_dead_channels_after_a_dispersive_refraction() {
    let mut rng = Pcg32::new(21, 3);
    let reference = two_interfaces(1, 400_000, &mut rng);
    let (trials, spp) = (300, 16);
    let mut rel_mse = [0.0f64; 3];
    let mut means = [[0.0f64; 3]; 3];
    for policy in 0..3u8 {
        let mut rng = Pcg32::new(30 + policy as u64, 1);
        for _ in 0..trials {
            let q = two_interfaces(policy, spp, &mut rng);
            for c in 0..3 {
                rel_mse[policy as usize] += ((q[c] - reference[c]) / reference[c]).powi(2) / 3.0;
                means[policy as usize][c] += q[c] / trials as f64;
            }
        }
        rel_mse[policy as usize] /= trials as f64;
    }
    println!(
        "two smooth dispersive interfaces, relMSE at {spp} samples: per-vertex choice {:.4}, with collapse {:.4}, termination {:.4}; means {means:?} vs {reference:?}",
        rel_mse[0], rel_mse[1], rel_mse[2]
    );
    for (m, e) in means.iter().zip(rel_mse) {
        for c in 0..3 {
            // unbiased: the mean of the estimates within 4 standard errors of the reference
            let tol = 4.0 * (e / trials as f64).sqrt();
            assert!(
                (m[c] / reference[c] - 1.0).abs() < tol,
                "{m:?} vs {reference:?}"
            );
        }
    }
    assert!(rel_mse[1] < 0.5 * rel_mse[0], "{rel_mse:?}");
}

#[test]
fn xml_extension_errors_name_the_problem() {
    let err = |spec: &str| parse_spec(spec).unwrap_err().to_string();
    assert!(err("dielectric dispersion=bk7 int_ior=1.5").contains("drop 'int_ior'"));
    assert!(err("dielectric dispersion=unobtainium").contains("known: bk7"));
    assert!(err("dielectric dispersion=bk7 abbe_number=30").contains("one dispersion model"));
    assert!(err("dielectric cauchy_a=1.5").contains("cauchy_b"));
    assert!(err("dielectric abbe_number=-3").contains("positive"));
    assert!(err("roughdielectric dispersion=bk7 multiscatter=true").contains("multiscatter"));
    // a pole inside the visible range
    assert!(err("dielectric sellmeier_b1=1 sellmeier_c1=0.25").contains("no valid index"));
    assert!(err("dielectric abbe_number=30 int_ior=1").contains("above 1"));
    // accepted forms
    for spec in [
        "dielectric dispersion=\"fused silica\"",
        "thindielectric dispersion=water ext_ior=1.0",
        "dielectric cauchy_a=1.5 cauchy_b=0.0042 cauchy_c=0.0001",
        "roughdielectric sellmeier_b1=1.0396 sellmeier_c1=0.0060 sellmeier_b2=0.2318 sellmeier_c2=0.0200",
        "dielectric int_ior=diamond abbe_number=55",
    ] {
        parse_spec(spec).unwrap_or_else(|e| panic!("{spec}: {e}"));
    }
}
