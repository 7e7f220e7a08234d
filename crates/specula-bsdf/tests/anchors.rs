//! Analytic anchors: closed-form values every implementation must reproduce, and the embedded
//! optical constants checked against the published data in `../shared/data`.

use glam::{Vec2, Vec3};
use specula_bsdf::fresnel::*;
use specula_bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
use specula_bsdf::quad::gauss_legendre;
use specula_bsdf::{parse_spec, BsdfContext, BsdfModel, ShadingPoint};

fn dir(theta_deg: f64) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin() as f32, 0.0, t.cos() as f32)
}

#[test]
fn normal_incidence_reflectance_of_glass_is_four_percent() {
    let f = fresnel_dielectric(1.0, 1.5);
    assert!((f.r - 0.04).abs() < 1e-7, "{}", f.r);
    assert!((f.t - 0.96).abs() < 1e-7);
    let p = fresnel_dielectric_polarized(1.0, 1.5);
    assert!((p.rs - 0.04).abs() < 1e-7 && (p.rp - 0.04).abs() < 1e-7);
    // the same from inside (reciprocity of the interface)
    assert!((fresnel_dielectric(-1.0, 1.5).r - 0.04).abs() < 1e-7);
    // Schlick is exact at normal incidence and at grazing
    assert!((fresnel_schlick(1.0, 1.5).r - 0.04).abs() < 1e-7);
    assert!((fresnel_schlick(0.0, 1.5).r - 1.0).abs() < 1e-6);
}

#[test]
fn p_polarised_reflectance_vanishes_at_brewsters_angle() {
    for eta in [1.333f32, 1.5, 2.419] {
        let b = brewster_angle(eta);
        assert!((b - eta.atan()).abs() < 1e-7);
        let p = fresnel_dielectric_polarized(b.cos(), eta);
        assert!(p.rp < 1e-10, "η={eta}: Rp={}", p.rp);
        assert!(p.rs > 0.01);
        // from inside, Brewster's angle is atan(1/η)
        let bi = (1.0 / eta).atan();
        assert!(fresnel_dielectric_polarized(-bi.cos(), eta).rp < 1e-10);
    }
}

#[test]
fn total_internal_reflection_beyond_the_critical_angle() {
    let eta = 1.333f32;
    let crit = critical_angle(eta).unwrap().to_degrees() as f64;
    assert!((crit - 48.6066).abs() < 1e-3, "{crit}");
    // just inside the critical angle light still escapes; beyond it none does
    assert!(fresnel_dielectric(-(crit - 0.1).to_radians().cos() as f32, eta).r < 1.0);
    for theta in [crit + 0.05, 60.0, 80.0, 89.9] {
        let f = fresnel_dielectric(-theta.to_radians().cos() as f32, eta);
        assert_eq!(f.r, 1.0, "θ={theta}");
        assert_eq!(f.t, 0.0);
    }
    // the smooth dielectric then always reflects, with unit weight
    let water = parse_spec("dielectric int_ior=1.333 ext_ior=1").unwrap();
    let wi = Vec3::new(60f32.to_radians().sin(), 0.0, -(60f32.to_radians().cos()));
    for u1 in [0.0, 0.5, 0.999] {
        let s = water
            .sample(
                &BsdfContext::RADIANCE,
                &ShadingPoint::default(),
                wi,
                u1,
                Vec2::ZERO,
            )
            .unwrap();
        assert!(s.wo.z < 0.0, "reflected back inside");
        assert_eq!(s.weight.r(), 1.0);
    }
    // and Snell's law holds below it
    let wi = Vec3::new(
        -(30f32.to_radians().sin()),
        0.0,
        -(30f32.to_radians().cos()),
    );
    let s = water
        .sample(
            &BsdfContext::RADIANCE,
            &ShadingPoint::default(),
            wi,
            0.9999,
            Vec2::ZERO,
        )
        .unwrap();
    let sin_t = (1.0 - s.wo.z * s.wo.z).sqrt();
    assert!(
        (sin_t - 1.333 * 30f32.to_radians().sin()).abs() < 1e-5,
        "{sin_t}"
    );
}

#[test]
fn conductor_reflectance_at_normal_incidence() {
    // R(0) = ((η−1)² + k²) / ((η+1)² + k²)
    for (eta, k) in [(0.2f32, 3.9f32), (1.66, 9.22), (0.14, 3.98), (2.0, 0.0)] {
        let want = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        let got = fresnel_conductor(1.0, eta, k);
        assert!((got - want).abs() < 1e-6, "η={eta} k={k}: {got} vs {want}");
    }
    // k = 0 reduces to the dielectric formula at every angle
    for c in [1.0f32, 0.8, 0.5, 0.2, 0.05] {
        let a = fresnel_conductor(c, 1.5, 0.0);
        let b = fresnel_dielectric(c, 1.5).r;
        assert!((a - b).abs() < 2e-6, "cos={c}: {a} vs {b}");
    }
    // the ideal mirror reflects everything at every angle
    for c in [1.0f32, 0.5, 0.01] {
        assert!((fresnel_conductor(c, 0.0, 1.0) - 1.0).abs() < 1e-6);
    }
}

#[test]
fn thin_dielectric_sums_internal_reflections() {
    let slab = parse_spec("thindielectric int_ior=1.5 ext_ior=1").unwrap();
    let r = 0.04f32;
    let expect = 2.0 * r / (1.0 + r);
    let s = slab
        .sample(
            &BsdfContext::RADIANCE,
            &ShadingPoint::default(),
            Vec3::Z,
            0.0,
            Vec2::ZERO,
        )
        .unwrap();
    assert!((s.pdf - expect).abs() < 1e-6, "{} vs {expect}", s.pdf);
}

#[test]
fn lambertian_value_is_albedo_over_pi() {
    let d = parse_spec("diffuse reflectance=0.2,0.5,0.8").unwrap();
    let f = d.eval(
        &BsdfContext::RADIANCE,
        &ShadingPoint::default(),
        dir(10.0),
        dir(50.0),
    );
    for (c, rho) in [0.2f32, 0.5, 0.8].iter().enumerate() {
        assert!((f[c] - rho / std::f32::consts::PI).abs() < 1e-7);
    }
    // one-sided: nothing below the surface
    let below = d.eval(
        &BsdfContext::RADIANCE,
        &ShadingPoint::default(),
        dir(10.0),
        -dir(50.0),
    );
    assert!(below.is_black());
}

/// ∫ g(m) dω over the upper hemisphere, for integrands concentrated around the normal with
/// width ~`alpha`: composite Gauss–Legendre in x with tanθ = α x/(1−x), and in φ.
fn hemisphere_integral(alpha: f64, g: &dyn Fn(Vec3) -> f64) -> f64 {
    let (xs, ws) = gauss_legendre(8);
    let panels = 96;
    let mut total = 0.0;
    for pi in 0..panels {
        for (xn, wn) in xs.iter().zip(&ws) {
            let x = (pi as f64 + 0.5 * (xn + 1.0)) / panels as f64;
            let wx = 0.5 * wn / panels as f64;
            let t = alpha * x / (1.0 - x);
            let theta = t.atan();
            let dtheta = alpha / ((1.0 - x) * (1.0 - x) * (1.0 + t * t));
            for pj in 0..panels {
                for (yn, wy) in xs.iter().zip(&ws) {
                    let phi =
                        2.0 * std::f64::consts::PI * (pj as f64 + 0.5 * (yn + 1.0)) / panels as f64;
                    let wphi = std::f64::consts::PI * wy / panels as f64;
                    let m = Vec3::new(
                        (theta.sin() * phi.cos()) as f32,
                        (theta.sin() * phi.sin()) as f32,
                        theta.cos() as f32,
                    );
                    total += g(m) * theta.sin() * dtheta * wx * wphi;
                }
            }
        }
    }
    total
}

#[test]
fn microfacet_distributions_are_normalised() {
    for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
        for (au, av) in [
            (0.02, 0.02),
            (0.1, 0.1),
            (0.3, 0.3),
            (0.8, 0.8),
            (0.05, 0.3),
            (0.4, 0.1),
        ] {
            let d = MicrofacetDistribution::new(kind, au, av, true);
            let i = hemisphere_integral(au.max(av) as f64, &|m| d.eval(m) as f64 * m.z as f64);
            assert!(
                (i - 1.0).abs() < 1e-4,
                "{kind:?} α=({au},{av}): ∫D cos = {i}"
            );
        }
    }
}

#[test]
fn smith_masking_projects_microsurface_onto_macrosurface() {
    // ∫ G1(v, m) max(0, v·m) D(m) dm = cosθv for an exact Smith G1
    for kind in [MicrofacetType::Beckmann, MicrofacetType::Ggx] {
        for (au, av) in [(0.1f32, 0.1f32), (0.5, 0.5), (0.05, 0.3)] {
            let d = MicrofacetDistribution::new(kind, au, av, true);
            for theta in [0.0f64, 45.0, 75.0, 85.0] {
                let t = theta.to_radians();
                let v = Vec3::new(
                    (t.sin() * 0.6) as f32,
                    (t.sin() * 0.8) as f32,
                    t.cos() as f32,
                );
                let i = hemisphere_integral(au.max(av) as f64, &|m| {
                    (d.smith_g1(v, m) * v.dot(m).max(0.0) * d.eval(m)) as f64
                });
                let rel = (i - v.z as f64).abs() / v.z as f64;
                assert!(
                    rel < 2e-4,
                    "{kind:?} α=({au},{av}) θ={theta}: {i} vs {}",
                    v.z
                );
            }
        }
    }
    // Mitsuba's rational Beckmann G1 is within its published 0.35 % of the exact one
    let exact = MicrofacetDistribution::new(MicrofacetType::Beckmann, 0.5, 0.5, true);
    let approx = exact.with_rational_g1(true);
    for theta in [10.0f32, 45.0, 70.0, 85.0, 89.0] {
        let v = dir(theta as f64);
        let (a, b) = (exact.smith_g1(v, Vec3::Z), approx.smith_g1(v, Vec3::Z));
        assert!(
            (a - b).abs() <= 0.0035 * a,
            "θ={theta}: exact {a}, rational {b}"
        );
    }
}

/// `../shared/data/<name>` as text; `None` (skip) when absent, except under CI.
fn shared_data(name: &str) -> Option<String> {
    let p = specula_testdata::shared(&format!("data/{name}"))?;
    Some(std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())))
}

/// The numbers following `"key":` in a small JSON file (enough for the flat data files).
fn numbers_after(json: &str, key: &str) -> Vec<f64> {
    let Some(i) = json.find(&format!("\"{key}\"")) else {
        return vec![];
    };
    let rest = &json[i + key.len() + 2..];
    let rest = rest.trim_start().trim_start_matches(':').trim_start();
    if let Some(r) = rest.strip_prefix('{') {
        // an object: collect eta then k arrays
        let end = r.find('}').unwrap();
        return r[..end]
            .split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'e' || c == '+'))
            .filter_map(|t| t.parse().ok())
            .collect();
    }
    let end = rest.find([',', '\n', '}']).unwrap_or(rest.len());
    rest[..end].trim().parse().into_iter().collect()
}

#[test]
fn embedded_optical_constants_match_the_published_data() {
    if let Some(j) = shared_data("ior.json") {
        for (name, v) in specula_bsdf::data::NAMED_IORS {
            let want = numbers_after(&j, name);
            assert_eq!(want.len(), 1, "{name}");
            assert!((*v as f64 - want[0]).abs() < 1e-6, "{name}");
        }
        assert!(specula_bsdf::data::NAMED_IORS.len() >= 20);
    }
    if let Some(j) = shared_data("conductors_rgb.json") {
        for (name, eta, k) in specula_bsdf::data::NAMED_CONDUCTORS {
            let want = numbers_after(&j, name);
            assert_eq!(want.len(), 6, "{name}: {want:?}");
            for c in 0..3 {
                assert!((eta[c] as f64 - want[c]).abs() < 1e-6, "{name} eta");
                assert!((k[c] as f64 - want[3 + c]).abs() < 1e-6, "{name} k");
            }
        }
        assert!(specula_bsdf::data::lookup_conductor("Cu").is_some());
        assert!(specula_bsdf::data::lookup_conductor("Al").is_some());
        assert!(specula_bsdf::data::lookup_conductor("Au").is_some());
    }
}

#[test]
fn bad_parameters_are_reported_not_defaulted() {
    for (spec, needle) in [
        ("diffuse reflectance=nan", "not a finite number"),
        ("diffuse albedo=0.5", "unknown parameter 'albedo'"),
        ("roughconductor material=Unobtainium", "unknown conductor"),
        ("dielectric int_ior=glassy", "unknown index of refraction"),
        (
            "roughconductor alpha=0.1 alpha_u=0.2 alpha_v=0.1",
            "either 'alpha' or",
        ),
        (
            "roughconductor distribution=phong",
            "valid values: beckmann, ggx",
        ),
        ("blendbsdf weight=0.5 { diffuse }", "exactly two nested"),
        ("twosided { dielectric }", "cannot nest"),
        ("plastic int_ior=1 ext_ior=1", "must differ"),
        ("unknownplugin", "unknown BSDF plugin"),
        ("diffuse reflectance=0.1,0.2", "not an RGB colour"),
        ("diffuse { diffuse }", "takes no nested"),
        ("roughconductor alpha=-0.1", "non-negative"),
    ] {
        match parse_spec(spec) {
            Ok(_) => panic!("'{spec}' was accepted"),
            Err(e) => assert!(e.to_string().contains(needle), "'{spec}': {e}"),
        }
    }
}

/// A texture that is red for u < 0.5 and blue otherwise, with roughness 0.05 / 0.5.
#[derive(Debug)]
struct Halves;
impl specula_bsdf::Texture for Halves {
    fn eval(&self, sp: &ShadingPoint) -> specula_bsdf::Rgb {
        if sp.uv.x < 0.5 {
            specula_bsdf::Rgb::new(0.8, 0.1, 0.1)
        } else {
            specula_bsdf::Rgb::new(0.1, 0.1, 0.8)
        }
    }
    fn eval_1(&self, sp: &ShadingPoint) -> f32 {
        if sp.uv.x < 0.5 {
            0.05
        } else {
            0.5
        }
    }
    fn mean(&self) -> specula_bsdf::Rgb {
        specula_bsdf::Rgb::new(0.45, 0.1, 0.45)
    }
}

#[test]
fn textured_parameters_are_looked_up_per_shading_point() {
    use specula_bsdf::{build_bsdf, Props, Value};
    use std::sync::Arc;
    let tex: Arc<dyn specula_bsdf::Texture> = Arc::new(Halves);
    let mut p = Props::new("diffuse", None);
    p.set("reflectance", Value::Texture(tex.clone()), None)
        .unwrap();
    let d = build_bsdf(p).unwrap();
    let ctx = BsdfContext::RADIANCE;
    let (left, right) = (
        ShadingPoint::at_uv(0.25, 0.5),
        ShadingPoint::at_uv(0.75, 0.5),
    );
    let fl = d.eval(&ctx, &left, dir(20.0), dir(40.0));
    let fr = d.eval(&ctx, &right, dir(20.0), dir(40.0));
    assert!(
        (fl.r() - 0.8 / std::f32::consts::PI).abs() < 1e-6
            && (fr.b() - 0.8 / std::f32::consts::PI).abs() < 1e-6
    );
    // a roughness map: the rough half spreads the lobe, so off-specular values rise
    let mut p = Props::new("roughconductor", None);
    p.set("alpha", Value::Texture(tex), None).unwrap();
    p.set("distribution", Value::Str("ggx".into()), None)
        .unwrap();
    let c = build_bsdf(p).unwrap();
    // back-scattering: the half vector is 50° off the normal, deep in the smooth lobe's tail
    let (wi, off) = (dir(30.0), dir(70.0));
    let smooth = c.eval(&ctx, &left, wi, off).r();
    let rough = c.eval(&ctx, &right, wi, off).r();
    assert!(rough > 20.0 * smooth, "smooth {smooth}, rough {rough}");
}
