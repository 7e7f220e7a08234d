//! Energy compensation (`multiscatter=true`, Kulla & Conty 2017): white-furnace albedo
//! 1 ± 0.5 % over a grid of roughness and incidence, the property suite (χ², reciprocity,
//! sample weights) on the compensated models, and agreement with the exact random walk on the
//! microsurface (Heitz et al. 2016). Heavier sweeps: `specula brdf multiscatter`, and the
//! ignored test at the end (`cargo test --release -p specula-bsdf --test multiscatter -- --ignored`).

use specula_bsdf::check::suite::{run_suite, SuiteConfig, Verdict};
use specula_bsdf::check::{self};
use specula_bsdf::{parse_spec, Bsdf, BsdfContext, ShadingPoint};

/// Directional albedo (importance transport) at θi (degrees, above or below), all lobes.
fn albedo(b: &Bsdf, theta: f32, samples: usize, seed: u64) -> ([f32; 3], [f32; 3]) {
    let wi = check::suite::incidence(theta);
    let a = check::albedo(
        b,
        &BsdfContext::IMPORTANCE,
        &ShadingPoint::default(),
        wi,
        samples,
        seed,
    );
    (a.mean.0, a.std_err.0)
}

const FURNACE_TOL: f32 = 0.005;

fn furnace(spec: &str, angles: &[f32], samples: usize) {
    let b = parse_spec(spec).unwrap();
    for (k, &t) in angles.iter().enumerate() {
        let (mut m, mut e) = albedo(&b, t, samples, 100 + k as u64);
        // the tolerance must dominate the noise (4σ) for the test to mean anything: where the
        // first estimate is too noisy, draw as many samples as that takes
        if 4.0 * e[0] >= 0.8 * FURNACE_TOL {
            let n = (samples as f32 * (4.0 * e[0] / (0.6 * FURNACE_TOL)).powi(2)) as usize;
            (m, e) = albedo(&b, t, n + 1, 200 + k as u64);
        }
        assert!(4.0 * e[0] < FURNACE_TOL, "{spec} θ={t}: σ = {}", e[0]);
        assert!(
            (m[0] - 1.0).abs() < FURNACE_TOL,
            "{spec} θi={t}°: albedo {} ± {}",
            m[0],
            e[0]
        );
    }
}

const ALPHAS: [f32; 6] = [0.05, 0.15, 0.3, 0.5, 0.75, 1.0];
const OUTSIDE: [f32; 6] = [0.0, 30.0, 50.0, 70.0, 80.0, 88.0];

#[test]
fn conductor_furnace() {
    for d in ["ggx", "beckmann"] {
        for a in ALPHAS {
            furnace(
                &format!("roughconductor distribution={d} alpha={a} multiscatter=true"),
                &OUTSIDE,
                30_000,
            );
        }
    }
    // anisotropic roughness uses √(αu αv): still within the target for moderate anisotropy
    furnace(
        "roughconductor distribution=ggx alpha_u=0.4 alpha_v=0.6 multiscatter=true",
        &OUTSIDE,
        30_000,
    );
}

#[test]
fn single_scattering_loses_energy_and_default_is_unchanged() {
    let ss = parse_spec("roughconductor distribution=ggx alpha=1").unwrap();
    let off = parse_spec("roughconductor distribution=ggx alpha=1 multiscatter=false").unwrap();
    let (m, _) = albedo(&ss, 60.0, 20_000, 3);
    let (m2, _) = albedo(&off, 60.0, 20_000, 3);
    assert_eq!(m, m2);
    assert!(m[0] < 0.7, "{m:?}");
}

fn suite_passes(spec: &str, samples: usize) {
    let b = parse_spec(spec).unwrap();
    let cfg = SuiteConfig {
        samples,
        seed: 5,
        ..Default::default()
    };
    let r = run_suite(&b, &cfg, &|_, _| {});
    for o in &r.outcomes {
        println!("{spec}: {:<15} {} {}", o.name, o.verdict, o.summary);
        assert_ne!(
            o.verdict,
            Verdict::Fail,
            "{spec}: {} {:?}",
            o.summary,
            o.details
        );
    }
}

#[test]
fn conductor_suite() {
    suite_passes(
        "roughconductor distribution=ggx alpha=0.8 material=Cu multiscatter=true",
        100_000,
    );
    suite_passes(
        "roughconductor distribution=beckmann alpha_u=0.2 alpha_v=0.6 material=Au multiscatter=true",
        100_000,
    );
}

#[test]
fn coloured_conductor_gains_saturated_energy() {
    // Kulla–Conty's colour term: compensation raises a gold's albedo, never above 1
    let ss = parse_spec("roughconductor distribution=ggx alpha=0.8 material=Au").unwrap();
    let ms = parse_spec("roughconductor distribution=ggx alpha=0.8 material=Au multiscatter=true")
        .unwrap();
    let (a, _) = albedo(&ss, 30.0, 20_000, 9);
    let (b, _) = albedo(&ms, 30.0, 20_000, 9);
    for c in 0..3 {
        assert!(b[c] > a[c] && b[c] < 1.0, "{a:?} {b:?}");
    }
    // the relative gain grows with the Fresnel average (gold: red ≫ blue)
    assert!(b[0] / a[0] > b[2] / a[2], "{a:?} {b:?}");
}

/// From inside, 168.5° included: near the normal the albedo of a low-index interface has a kink
/// in θ, which the tables once interpolated over √μ (0.8 % lost at η = 1.14, Beckmann α = 1).
const INSIDE: [f32; 7] = [180.0, 168.5, 150.0, 130.0, 110.0, 100.0, 92.0];

fn dielectric_grid(cases: &[(&str, f32, &str)]) {
    for (d, a, eta) in cases {
        let spec =
            format!("roughdielectric distribution={d} alpha={a} int_ior={eta} multiscatter=true");
        furnace(&spec, &OUTSIDE, 30_000);
        furnace(&spec, &INSIDE, 30_000);
    }
}

/// The whole grid (2 distributions × 4 roughnesses × 4 indices, both sides, 13 incidences):
/// about a minute; CI runs the subset below.
#[test]
#[ignore]
fn dielectric_furnace_full_grid() {
    let mut cases = Vec::new();
    for d in ["ggx", "beckmann"] {
        for a in [0.1, 0.3, 0.6, 1.0] {
            for eta in ["1.5", "1.14", "1.1", "2.4"] {
                cases.push((d, a, eta));
            }
        }
    }
    dielectric_grid(&cases);
}

#[test]
fn dielectric_furnace() {
    dielectric_grid(&[
        ("ggx", 1.0, "1.5"),
        ("ggx", 0.3, "2.4"),
        ("beckmann", 0.6, "1.1"),
        ("beckmann", 1.0, "1.14"),
    ]);
    // η < 1 (the exterior denser)
    furnace(
        "roughdielectric distribution=ggx alpha=0.5 int_ior=1 ext_ior=1.5 multiscatter=true",
        &[0.0, 45.0, 85.0, 180.0, 135.0, 95.0],
        30_000,
    );
}

#[test]
fn dielectric_suite() {
    suite_passes(
        "roughdielectric distribution=ggx alpha=0.7 int_ior=1.5 multiscatter=true",
        100_000,
    );
    suite_passes(
        "roughdielectric distribution=beckmann alpha=0.3 int_ior=1.33 multiscatter=true specular_transmittance=0.8,0.9,1",
        100_000,
    );
}

fn agreement(
    spec: &str,
    theta: f32,
    samples: usize,
) -> specula_bsdf::models::microsurface_walk::Agreement {
    use specula_bsdf::models::microsurface_walk::{compare, walk_for};
    let b = parse_spec(spec).unwrap();
    let w = walk_for(&b).unwrap();
    let a = compare(&b, &w, check::suite::incidence(theta), samples, 17);
    println!(
        "{spec} θi={theta}: albedo model {:.4?} walk {:.4?} (rel {:.4}), T {:.4}/{:.4}, lobe TV {:.4} (noise {:.4})",
        a.model, a.walk, a.albedo_rel, a.model_t, a.walk_t, a.lobe_tv, a.lobe_noise
    );
    a
}

/// Agreement with the exact random walk (Heitz et al. 2016), 200 000 samples each. The lobe
/// distance of two identical lobes is ≈ `lobe_noise` (≈ 0.016 here), which the thresholds
/// allow for; the albedo is compared per channel.
#[test]
fn agrees_with_the_random_walk() {
    // white GGX conductor at α = 1: the single-scattering model is 64 % short of the walk
    let a = agreement(
        "roughconductor distribution=ggx alpha=1 multiscatter=true",
        45.0,
        200_000,
    );
    assert!(a.albedo_rel < 0.02 && a.lobe_tv < 0.04, "{a:?}");
    let ss = agreement("roughconductor distribution=ggx alpha=1", 45.0, 200_000);
    assert!(
        ss.albedo_rel > 0.5 && ss.lobe_tv > 0.05,
        "the test has power: {ss:?}"
    );
    // copper, Beckmann, normal incidence
    let a = agreement(
        "roughconductor distribution=beckmann alpha=0.6 material=Cu multiscatter=true",
        0.0,
        200_000,
    );
    assert!(a.albedo_rel < 0.02 && a.lobe_tv < 0.04, "{a:?}");
    // glass: R + T and the split between them, from outside and from inside
    for (t, tv) in [(0.0, 0.04), (135.0, 0.12)] {
        let a = agreement(
            "roughdielectric distribution=ggx alpha=0.5 multiscatter=true",
            t,
            200_000,
        );
        assert!(a.albedo_rel < 0.02, "{a:?}");
        assert!((a.model_t - a.walk_t).abs() < 0.02, "{a:?}");
        assert!(a.lobe_tv < tv, "{a:?}");
    }
}

/// The shape of the compensated conductor lobe against the walk (the measured compensation
/// lobe of `multiscatter::lobe`): the total-variation distance between the binned lobes at
/// most 0.02 above its value for identical lobes (`lobe_noise`, ≈ 0.011 at 400 000 samples;
/// the distance itself fluctuates by ≈ 0.001 between seeds). Kulla–Conty's separable lobe was
/// 0.077 at GGX α = 0.1, 85° and 0.14 at α = 1, 85° (noise 0.009–0.015), beyond this bound.
#[test]
fn conductor_lobe_shape_agrees_with_the_walk() {
    for (d, alphas, angles) in [
        (
            "ggx",
            &[0.1f32, 0.3, 0.6, 1.0][..],
            &[0.0f32, 60.0, 85.0][..],
        ),
        ("beckmann", &[0.1, 0.3, 1.0][..], &[0.0, 85.0][..]),
    ] {
        for &a in alphas {
            for &t in angles {
                let spec = format!("roughconductor distribution={d} alpha={a} multiscatter=true");
                let r = agreement(&spec, t, 400_000);
                assert!(r.lobe_noise < 0.015, "{spec} θi={t}: {r:?}");
                assert!(r.lobe_tv < r.lobe_noise + 0.02, "{spec} θi={t}: {r:?}");
            }
        }
    }
}

/// The shape of the compensated dielectric lobes against the walk (the measured lobes of
/// `multiscatter::dielectric_lobe`), from outside and inside, η on (1.5) and off (1.33, 2.4)
/// the table's nodes, 400 000 samples each: the total-variation distance between the binned
/// lobes (both sides) at most 0.02 above its value for identical lobes (`lobe_noise`), the
/// albedo (R + T) within 2 % and the transmitted part within 0.02 of the walk's. Under
/// `multiscatter=true` the single-scattering part is height-correlated, the walk's own first
/// event, so the deficit f_walk − f_ss is non-negative and no lower bound above the noise
/// remains. Kulla–Conty's separable lobes were 0.065–0.19 here (`dielectric_survey`, noise
/// 0.007–0.02); with the separable single scattering the negative part of the deficit bounded
/// the distance from below (GGX α = 1, η = 1.5, 85°: 0.18, `negative_deficit`). The last two
/// cases, Beckmann at η = 1.16, were the survey's worst: α = 0.6 from inside at 85° was 0.039
/// above the noise before the lobes' histopolation and 13 roughness nodes, α = 1 from outside
/// at 85° 0.021 before the clamped lobes' block sums were restored (now 0.019;
/// `dielectric_survey`: 0 of 256 cases over, worst 0.015 at 200 000 samples).
#[test]
fn dielectric_lobe_shape_agrees_with_the_walk() {
    for (d, a, eta, t) in [
        ("ggx", 1.0f32, "1.5", 45.0f32),
        ("ggx", 1.0, "1.5", 135.0),
        ("ggx", 1.0, "1.5", 180.0),
        ("ggx", 0.6, "1.33", 135.0),
        ("ggx", 0.6, "1.5", 105.0),
        ("ggx", 0.6, "1.5", 85.0),
        ("ggx", 0.3, "1.33", 105.0),
        ("ggx", 0.1, "2.4", 85.0),
        ("ggx", 1.0, "1.5", 85.0),
        ("ggx", 1.0, "1.5", 75.0),
        ("ggx", 1.0, "2.4", 85.0),
        ("beckmann", 0.6, "1.33", 135.0),
        ("beckmann", 1.0, "1.5", 135.0),
        ("beckmann", 1.0, "1.5", 85.0),
        ("beckmann", 0.3, "1.5", 105.0),
        ("beckmann", 0.6, "1.16", 95.0),
        ("beckmann", 1.0, "1.16", 85.0),
    ] {
        let spec =
            format!("roughdielectric distribution={d} alpha={a} int_ior={eta} multiscatter=true");
        let r = agreement(&spec, t, 400_000);
        assert!(r.lobe_noise < 0.02, "{spec} θi={t}: {r:?}");
        assert!(r.lobe_tv < r.lobe_noise + 0.02, "{spec} θi={t}: {r:?}");
        assert!(r.albedo_rel < 0.02, "{spec} θi={t}: {r:?}");
        assert!((r.model_t - r.walk_t).abs() < 0.02, "{spec} θi={t}: {r:?}");
    }
}

/// The survey of the dielectric compensation lobes against the walk behind the report's
/// table (`-- --ignored --nocapture`): GGX and Beckmann, α ∈ {0.1, 0.3, 0.6, 1}, η ∈ {1.16,
/// 1.33, 1.5, 2.4} (none a node of `DIEL_ETAS`; in its coordinate cos θc, 48 %, 11 %, 59 % and
/// 41 % of the way between two nodes; 1.16 where the lobes change fastest with η), θi ∈ {0,
/// 45, 75, 85}° from outside and inside, 200 000 samples each (≈ 2.5 minutes of two cores;
/// `SPECULA_SURVEY_ETAS`, comma-separated, replaces the η values); one line
/// per case with the lobe distance (noise), the lower bound that the *separable*
/// single-scattering model would put on any non-negative compensation lobe (`negative_deficit`;
/// `multiscatter=true` is height-correlated, whose bound is 0), the albedo difference and the
/// transmitted parts.
#[test]
#[ignore]
fn dielectric_survey() {
    use specula_bsdf::models::microsurface_walk::{compare, walk_for};
    use specula_bsdf::multiscatter::dielectric_lobe::negative_deficit;
    let etas: Vec<String> = std::env::var("SPECULA_SURVEY_ETAS")
        .map(|v| v.split(',').map(|e| e.trim().to_string()).collect())
        .unwrap_or_else(|_| ["1.16", "1.33", "1.5", "2.4"].map(String::from).to_vec());
    let mut cases = Vec::new();
    for d in ["ggx", "beckmann"] {
        for a in [0.1f32, 0.3, 0.6, 1.0] {
            for eta in etas.iter().map(String::as_str) {
                for t in [0.0f32, 45.0, 75.0, 85.0] {
                    cases.push((d, a, eta, t));
                    cases.push((d, a, eta, 180.0 - t));
                }
            }
        }
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let lines = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(&(d, a, eta, t)) = cases.get(k) else {
                    break;
                };
                let spec = format!(
                    "roughdielectric distribution={d} alpha={a} int_ior={eta} multiscatter=true"
                );
                let b = parse_spec(&spec).unwrap();
                let w = walk_for(&b).unwrap();
                let wi = check::suite::incidence(t);
                let r = compare(&b, &w, wi, 200_000, 17);
                // the bound of the separable model (the deficit against the height-correlated
                // one, which `multiscatter=true` now uses, has no negative part)
                let n = negative_deficit(&w, wi, 200_000, 19, false);
                let excess = r.lobe_tv - r.lobe_noise;
                lines.lock().unwrap().push((
                    k,
                    excess,
                    format!(
                        "{d:<8} α={a:<4} η={eta:<4} θi={t:>5}: TV {:.4} ({:.4}) excess {excess:.4}{}  separable bound {n:.4}  albedo rel {:.4}  T model {:.4} walk {:.4}",
                        r.lobe_tv, r.lobe_noise, if excess > 0.02 { " FAIL" } else { "" }, r.albedo_rel, r.model_t, r.walk_t
                    ),
                ));
            });
        }
    });
    let mut lines = lines.into_inner().unwrap();
    lines.sort_by_key(|l| l.0);
    println!(
        "measured dielectric lobes: {}",
        specula_bsdf::multiscatter::dielectric_lobe::dielectric_data_present()
    );
    for (_, _, l) in &lines {
        println!("{l}");
    }
    let worst = lines.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    println!(
        "{} of {} cases more than 0.02 above the noise; worst excess {:.4}: {}",
        lines.iter().filter(|l| l.1 > 0.02).count(),
        lines.len(),
        worst.1,
        worst.2
    );
}

/// Regenerates `crates/specula-bsdf/src/multiscatter/dielectric_lobe.bin`, the measured shapes
/// of the dielectric compensation lobes (`specula_bsdf::multiscatter::dielectric_lobe`): white
/// random walks at fixed seeds, deterministic (`-- --ignored generate_dielectric_lobe_table
/// --nocapture`; 12 η × 12 α nodes, 4.4 + 11.4 minutes on two cores shared with a build; the
/// library's test `committed_data_is_the_generators_output` regenerates three nodes and
/// compares them with the file byte for byte). `SPECULA_DIEL_WALKS` overrides the walks per
/// (node, incident bin).
#[test]
#[ignore]
fn generate_dielectric_lobe_table() {
    use specula_bsdf::microfacet::MicrofacetType;
    use specula_bsdf::multiscatter::dielectric_lobe::{
        dielectric_joint_from_walk, dielectric_walks, encode_dielectric_tables,
    };
    let walks_env: Option<usize> = std::env::var("SPECULA_DIEL_WALKS")
        .ok()
        .and_then(|v| v.parse().ok());
    let mut joints = Vec::new();
    for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
        let walks = walks_env.unwrap_or(dielectric_walks(kind));
        let t = std::time::Instant::now();
        let [_, (jc, asym_c)] = dielectric_joint_from_walk(kind, walks);
        println!(
            "{kind:?}: {walks} walks per row in {:.1} s; asymmetry before symmetrising per node {:.4?}",
            t.elapsed().as_secs_f64(),
            asym_c
        );
        joints.push(jc);
    }
    let bytes = encode_dielectric_tables([&joints[0], &joints[1]]);
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/src/multiscatter/dielectric_lobe.bin"
    );
    std::fs::write(path, &bytes).unwrap();
    println!("wrote {path} ({} bytes)", bytes.len());
}

/// Coloured conductors against the walk, per channel (target: within 2 % of the walk's
/// albedo for every α ≤ 1 and incidence; measured worst 1.1 %, at GGX α = 1, normal
/// incidence — see `multiscatter.rs`). Kulla–Conty's own F_avg term was 5–26 % low in the low
/// channels here (gold's blue, chromium and copper at α = 1), and Hoffman's two-point F82 fit
/// of the Fresnel 2.2 % (gold's blue at GGX α = 1, 45°); 200 000 samples each, the albedo's
/// standard error ≈ 0.1–0.3 %.
#[test]
fn coloured_conductors_agree_with_the_walk() {
    for (spec, angles, tol) in [
        (
            "roughconductor distribution=ggx alpha=0.6 material=Au multiscatter=true",
            &[0.0f32, 60.0, 85.0][..],
            0.02,
        ),
        (
            "roughconductor distribution=ggx alpha=1 material=Au multiscatter=true",
            &[0.0, 45.0, 85.0][..],
            0.02,
        ),
        (
            "roughconductor distribution=ggx alpha=1 material=Cr multiscatter=true",
            &[0.0, 45.0][..],
            0.02,
        ),
        (
            "roughconductor distribution=ggx alpha=0.5 material=Cr multiscatter=true",
            &[30.0, 80.0][..],
            0.02,
        ),
        (
            "roughconductor distribution=beckmann alpha=0.8 material=Cu multiscatter=true",
            &[0.0, 75.0][..],
            0.02,
        ),
    ] {
        for &t in angles {
            let a = agreement(spec, t, 200_000);
            assert!(a.albedo_rel < tol, "{spec} θi={t}: {a:?}");
        }
    }
    // Kulla–Conty's colour term would fail this: gold's blue at GGX α = 1, 85° was 26 % low
}

/// The survey behind the figures in the report (`-- --ignored --nocapture`).
#[test]
#[ignore]
fn coloured_survey() {
    for d in ["ggx", "beckmann"] {
        for m in ["Au", "Cu", "Cr", "Al"] {
            for a in [0.1, 0.3, 0.6, 1.0] {
                for t in [0.0, 45.0, 70.0, 85.0] {
                    agreement(
                        &format!(
                            "roughconductor distribution={d} alpha={a} material={m} multiscatter=true"
                        ),
                        t,
                        200_000,
                    );
                }
            }
        }
    }
}

/// The survey behind the figures in the report (`-- --ignored --nocapture`).
#[test]
#[ignore]
fn agreement_survey() {
    for spec in [
        "roughconductor distribution=ggx alpha=0.3 multiscatter=true",
        "roughconductor distribution=ggx alpha=1 multiscatter=true",
        "roughconductor distribution=ggx alpha=1",
        "roughconductor distribution=beckmann alpha=0.6 material=Cu multiscatter=true",
        "roughconductor distribution=ggx alpha=0.8 material=Au multiscatter=true",
        "roughconductor distribution=ggx alpha=0.8 material=Au",
        "roughdielectric distribution=ggx alpha=0.5 multiscatter=true",
        "roughdielectric distribution=ggx alpha=1 multiscatter=true",
        "roughdielectric distribution=beckmann alpha=0.7 multiscatter=true",
    ] {
        for t in [0.0, 45.0, 75.0] {
            agreement(spec, t, 200_000);
        }
    }
    for t in [135.0, 170.0] {
        agreement(
            "roughdielectric distribution=ggx alpha=0.5 multiscatter=true",
            t,
            200_000,
        );
    }
}

#[test]
fn plastic_furnace_and_suite() {
    for d in ["ggx", "beckmann"] {
        for a in [0.1, 0.5, 1.0] {
            furnace(
                &format!(
                    "roughplastic distribution={d} alpha={a} diffuse_reflectance=1 multiscatter=true"
                ),
                &OUTSIDE,
                30_000,
            );
        }
    }
    furnace(
        "roughplastic distribution=ggx alpha=0.6 int_ior=2.0 diffuse_reflectance=1 nonlinear=true multiscatter=true",
        &OUTSIDE,
        30_000,
    );
    suite_passes(
        "roughplastic distribution=ggx alpha=0.7 diffuse_reflectance=0.2,0.5,0.8 multiscatter=true",
        100_000,
    );
    // a black base: the compensation lobe must still be sampled
    suite_passes(
        "roughplastic distribution=beckmann alpha=0.4 diffuse_reflectance=0 multiscatter=true",
        100_000,
    );
}

/// `principled multiscatter=true`: a white metal and a clear glass pass the white furnace
/// (the metallic lobe's Schlick Fresnel with F₀ = 1 is a white conductor; spec_trans = 1 with
/// base_color = 1 and spec_tint = 0 is a rough dielectric, R + T from both sides).
#[test]
fn principled_furnace() {
    for r in [0.3, 0.6, 0.85, 1.0] {
        furnace(
            &format!("principled base_color=1 metallic=1 roughness={r} multiscatter=true"),
            &OUTSIDE,
            30_000,
        );
    }
    for (r, eta) in [(0.5, "1.5"), (1.0, "1.5"), (0.8, "1.33")] {
        let spec = format!(
            "principled base_color=1 spec_trans=1 roughness={r} eta={eta} multiscatter=true"
        );
        furnace(&spec, &OUTSIDE, 30_000);
        furnace(&spec, &INSIDE, 30_000);
    }
    // anisotropic (the tables at √(αu αv)): moderate anisotropy stays within the target
    furnace(
        "principled base_color=1 metallic=1 roughness=0.7 anisotropic=0.3 multiscatter=true",
        &[0.0, 45.0, 80.0],
        30_000,
    );
}

/// Without `multiscatter` the model is Mitsuba's (the agreement test covers it); with it a
/// coloured metal gains energy in every channel, never above 1, most where F₀ is high; and
/// the uncompensated diffuse mix is unchanged where metallic = spec_trans = 0.
#[test]
fn principled_compensation_is_where_documented() {
    let a = |s: &str, t: f32| albedo(&parse_spec(s).unwrap(), t, 40_000, 11).0;
    let ss = a(
        "principled base_color=0.9,0.6,0.2 metallic=1 roughness=0.9",
        30.0,
    );
    let ms = a(
        "principled base_color=0.9,0.6,0.2 metallic=1 roughness=0.9 multiscatter=true",
        30.0,
    );
    for c in 0..3 {
        assert!(ms[c] > 1.1 * ss[c] && ms[c] < 1.0, "{ss:?} {ms:?}");
    }
    assert!(ms[0] / ss[0] > ms[2] / ss[2], "{ss:?} {ms:?}");
    let off = a(
        "principled base_color=0.5 roughness=0.9 sheen=0.5 clearcoat=0.5",
        30.0,
    );
    let on = a(
        "principled base_color=0.5 roughness=0.9 sheen=0.5 clearcoat=0.5 multiscatter=true",
        30.0,
    );
    assert_eq!(off, on);
}

/// `principled multiscatter=true` against the random walk of the interface it models: a
/// clear glass (spec_trans = 1, base_color = 1, spec_tint = 0; GGX, α = roughness²) against
/// the dielectric walk, a white metal (metallic = 1, base_color = 1) against the white
/// conductor walk, 300 000 samples each: lobe distance within noise + 0.02, albedo within 2 %,
/// the transmitted part within 0.02. The glass cases include the grazing incidences where the
/// separable G1·G1 single scattering transmits more than the walk (GGX α = 1, η = 1.5, 85°:
/// no non-negative compensation lobe can come closer than 0.18 to the walk); the transmissive
/// part's single scattering is height-correlated under `multiscatter`, as `roughdielectric`'s.
#[test]
fn principled_agrees_with_the_walk() {
    use specula_bsdf::models::microsurface_walk::{compare, walk_for};
    let cases = [
        (
            "spec_trans=1 spec_tint=0",
            "roughdielectric distribution=ggx",
            1.0f32,
            "1.5",
            85.0f32,
        ),
        (
            "spec_trans=1 spec_tint=0",
            "roughdielectric distribution=ggx",
            1.0,
            "1.5",
            135.0,
        ),
        (
            "spec_trans=1 spec_tint=0",
            "roughdielectric distribution=ggx",
            0.8,
            "1.5",
            45.0,
        ),
        (
            "spec_trans=1 spec_tint=0",
            "roughdielectric distribution=ggx",
            0.8,
            "1.5",
            95.0,
        ),
        (
            "metallic=1",
            "roughconductor distribution=ggx material=none",
            1.0,
            "1.5",
            75.0,
        ),
        (
            "metallic=1",
            "roughconductor distribution=ggx material=none",
            0.7,
            "1.5",
            30.0,
        ),
    ];
    for (what, walk_spec, r, eta, t) in cases {
        let spec =
            format!("principled base_color=1 {what} roughness={r} eta={eta} multiscatter=true");
        let alpha = r * r;
        let walk_spec = if walk_spec.starts_with("roughdielectric") {
            format!("{walk_spec} alpha={alpha} int_ior={eta}")
        } else {
            format!("{walk_spec} alpha={alpha}")
        };
        let b = parse_spec(&spec).unwrap();
        let w = walk_for(&parse_spec(&walk_spec).unwrap()).unwrap();
        let a = compare(&b, &w, check::suite::incidence(t), 300_000, 23);
        println!(
            "{spec} θi={t}: albedo model {:.4?} walk {:.4?} (rel {:.4}), T {:.4}/{:.4}, lobe TV {:.4} (noise {:.4})",
            a.model, a.walk, a.albedo_rel, a.model_t, a.walk_t, a.lobe_tv, a.lobe_noise
        );
        assert!(a.lobe_noise < 0.02, "{spec} θi={t}: {a:?}");
        assert!(a.lobe_tv < a.lobe_noise + 0.02, "{spec} θi={t}: {a:?}");
        assert!(a.albedo_rel < 0.02, "{spec} θi={t}: {a:?}");
        assert!((a.model_t - a.walk_t).abs() < 0.02, "{spec} θi={t}: {a:?}");
    }
}

#[test]
fn principled_suite() {
    suite_passes(
        "principled base_color=0.8,0.5,0.3 metallic=0.5 spec_trans=0.4 roughness=0.7 multiscatter=true",
        100_000,
    );
    suite_passes(
        "principled base_color=0.9 spec_trans=1 roughness=0.4 eta=1.33 anisotropic=0.5 multiscatter=true",
        100_000,
    );
}

/// ns per `eval_pdf` and per `sample` call with and without compensation (`-- --ignored
/// --nocapture`; release build, one thread, the report's figures).
#[test]
#[ignore]
fn timing() {
    use glam::{Vec2, Vec3};
    use specula_bsdf::rng::Pcg32;
    use specula_bsdf::BsdfModel;
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    for base in [
        "roughconductor distribution=ggx alpha=0.5 material=Au",
        "roughconductor distribution=ggx alpha_u=0.2 alpha_v=0.6 material=Au",
        "roughdielectric distribution=ggx alpha=0.5",
        "roughplastic distribution=ggx alpha=0.5",
        "principled base_color=0.8,0.5,0.3 metallic=0.5 spec_trans=0.4 roughness=0.7",
    ] {
        for ms in [false, true] {
            let b = parse_spec(&format!("{base} multiscatter={ms}")).unwrap();
            let n = 400_000;
            let mut rng = Pcg32::new(1, 1);
            let dirs: Vec<(Vec3, Vec3, f32, Vec2)> = (0..1024)
                .map(|_| {
                    let a = specula_bsdf::warp::square_to_cosine_hemisphere(rng.next_vec2());
                    let c = specula_bsdf::warp::square_to_cosine_hemisphere(rng.next_vec2());
                    (a, c, rng.next_f32(), rng.next_vec2())
                })
                .collect();
            let mut acc = 0.0f32;
            let t = std::time::Instant::now();
            for i in 0..n {
                let (wi, wo, _, _) = dirs[i & 1023];
                let (v, p) = b.eval_pdf(&ctx, &sp, wi, wo);
                acc += v[0] + p;
            }
            let te = t.elapsed().as_nanos() as f64 / n as f64;
            let t = std::time::Instant::now();
            for i in 0..n {
                let (wi, _, u1, u2) = dirs[i & 1023];
                if let Some(s) = b.sample(&ctx, &sp, wi, u1, u2) {
                    acc += s.weight[0];
                }
            }
            let ts = t.elapsed().as_nanos() as f64 / n as f64;
            println!("{base} multiscatter={ms}: eval_pdf {te:.0} ns, sample {ts:.0} ns ({acc:.1})");
        }
    }
}

/// Regenerates `crates/specula-bsdf/src/multiscatter/lobe.bin`, the measured shape of the
/// conductor compensation lobe (`specula_bsdf::multiscatter::lobe`): white random walks at
/// fixed seeds, deterministic (`-- --ignored generate_lobe_table --nocapture`; several
/// minutes of one core per distribution). `SPECULA_LOBE_WALKS` overrides the walks per row.
#[test]
#[ignore]
fn generate_lobe_table() {
    use specula_bsdf::microfacet::MicrofacetType;
    use specula_bsdf::multiscatter::lobe::{encode_lobe_tables, lobe_joint_from_walk, LOBE_WALKS};
    let walks = std::env::var("SPECULA_LOBE_WALKS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(LOBE_WALKS);
    let mut joints = Vec::new();
    for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
        let t = std::time::Instant::now();
        let (j, asym) = lobe_joint_from_walk(kind, walks);
        println!(
            "{kind:?}: {walks} walks per row in {:.1} s; asymmetry before symmetrising per α node {:.4?}",
            t.elapsed().as_secs_f64(),
            asym
        );
        joints.push(j);
    }
    let bytes = encode_lobe_tables([&joints[0], &joints[1]]);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/multiscatter/lobe.bin");
    std::fs::write(path, &bytes).unwrap();
    println!("wrote {path} ({} bytes)", bytes.len());
}

/// `roughplastic multiscatter=true` with a black base is its coat alone, a rough dielectric
/// interface whose transmitted light the base absorbs: its reflection must be the random
/// walk's reflection (`compare_reflection`: the walk's transmitted light counts as absorbed).
/// 400 000 samples per case; the reflected albedo within 2 % of the walk's (relative) plus
/// 3 standard errors of the two estimates, the lobe distance within noise + 0.02. The cases
/// include grazing incidence on rough coats, where the separable single scattering with the
/// averaged reflect/transmit split (the model before) reflected 28–36 % less than the walk
/// (GGX α = 1, η = 1.5 / 1.33, 85°).
#[test]
fn plastic_coat_agrees_with_the_walk() {
    for (d, a, eta, t) in [
        ("ggx", 1.0f32, "1.5", 85.0f32),
        ("ggx", 1.0, "1.33", 75.0),
        ("ggx", 0.6, "1.5", 85.0),
        ("ggx", 0.3, "2.4", 45.0),
        ("beckmann", 1.0, "1.33", 85.0),
        ("beckmann", 0.6, "2.4", 85.0),
        // between the η nodes (clamping the histopolated lobes' negative values without
        // restoring each block's row sums left these 6.5 % and 4.3 % high)
        ("ggx", 1.0, "1.2", 85.0),
        ("beckmann", 1.0, "1.25", 85.0),
    ] {
        let r = plastic_coat_case(d, a, eta, t, 400_000);
        let se = 3.0 * (r.model_err[0].powi(2) + r.walk_err[0].powi(2)).sqrt();
        assert!(
            (r.model[0] - r.walk[0]).abs() < 0.02 * r.walk[0] + se,
            "{d} α={a} η={eta} θi={t}: {r:?}"
        );
        assert!(
            r.lobe_tv < r.lobe_noise + 0.02,
            "{d} α={a} η={eta} θi={t}: {r:?}"
        );
    }
}

fn plastic_coat_case(
    d: &str,
    a: f32,
    eta: &str,
    t: f32,
    samples: usize,
) -> specula_bsdf::models::microsurface_walk::Agreement {
    use specula_bsdf::models::microsurface_walk::{compare_reflection, walk_for};
    let spec = format!(
        "roughplastic distribution={d} alpha={a} int_ior={eta} diffuse_reflectance=0 multiscatter=true"
    );
    let b = parse_spec(&spec).unwrap();
    let walk = format!("roughdielectric distribution={d} alpha={a} int_ior={eta}");
    let w = walk_for(&parse_spec(&walk).unwrap()).unwrap();
    let r = compare_reflection(&b, &w, check::suite::incidence(t), samples, 17);
    println!(
        "{d:<8} α={a:<4} η={eta:<4} θi={t:>4}: R model {:.4} ± {:.4} walk {:.4} ± {:.4} (rel {:.4}), lobe TV {:.4} (noise {:.4})",
        r.model[0], r.model_err[0], r.walk[0], r.walk_err[0], r.albedo_rel, r.lobe_tv, r.lobe_noise
    );
    r
}

/// The survey behind `plastic_coat_agrees_with_the_walk` (`-- --ignored --nocapture`): GGX and
/// Beckmann, α ∈ {0.1, 0.3, 0.6, 1}, η ∈ {1.33, 1.5, 2.4}, θi ∈ {0, 45, 75, 85}°, 200 000
/// samples each.
#[test]
#[ignore]
fn plastic_coat_survey() {
    for d in ["ggx", "beckmann"] {
        for a in [0.1f32, 0.3, 0.6, 1.0] {
            for eta in ["1.33", "1.5", "2.4"] {
                for t in [0.0f32, 45.0, 75.0, 85.0] {
                    plastic_coat_case(d, a, eta, t, 200_000);
                }
            }
        }
    }
}

/// The error of interpolating the dielectric deficit joints in η between two measured values
/// (`-- --ignored dielectric_eta_interpolation_probe --nocapture`): per distribution, roughness
/// and η interval (a, b), the joints measured directly at a, b and the midpoint m = √(ab), and
/// at m again with other seeds. Per incident row (μ bin of either side) the total-variation
/// distance between the row shapes of the midpoint's joint and of the mean of the unit-total
/// joints at a and b (what `interpolated_joint` reads at m), times the row's deficit fraction
/// (≈ its share of a survey case's distance); the same for the two seeds at m is the noise.
/// `SPECULA_PROBE_ETAS` (comma-separated, ascending) sets the interval ends.
#[test]
#[ignore]
fn dielectric_eta_interpolation_probe() {
    use specula_bsdf::microfacet::MicrofacetType;
    use specula_bsdf::multiscatter::dielectric_lobe::{bin_m, dielectric_joint_at, NR};
    use specula_bsdf::multiscatter::lobe::{LOBE_MU, LOBE_PHI};
    let etas: Vec<f32> = std::env::var("SPECULA_PROBE_ETAS")
        .ok()
        .map(|v| v.split(',').map(|x| x.trim().parse().unwrap()).collect())
        .unwrap_or_else(|| vec![1.05, 1.25, 1.5, 2.0, 3.0]);
    let alphas: Vec<f32> = std::env::var("SPECULA_PROBE_ALPHAS")
        .ok()
        .map(|v| v.split(',').map(|x| x.trim().parse().unwrap()).collect())
        .unwrap_or_else(|| vec![4.0 / 9.0, 1.0]);
    let (drow, coarse) = (NR * LOBE_PHI, 4usize);
    // row shape on cells merged 2 (θ) × 4 (Δφ), normalised
    let shape = |j: &[f64], r: usize, merge: bool| -> Vec<f64> {
        let row = &j[r * drow..][..drow];
        let mut v = if merge {
            let mut v = vec![0.0; NR / 2 * coarse];
            for (c, x) in row.iter().enumerate() {
                let (q, p) = (c / LOBE_PHI, c % LOBE_PHI);
                v[q / 2 * coarse + p * coarse / LOBE_PHI] += x.max(0.0);
            }
            v
        } else {
            row.iter().map(|x| x.max(0.0)).collect()
        };
        let s: f64 = v.iter().sum();
        if s > 0.0 {
            v.iter_mut().for_each(|x| *x /= s);
        }
        v
    };
    let tv = |a: &[f64], b: &[f64]| 0.5 * a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f64>();
    for (kind, walks) in [
        (MicrofacetType::Ggx, 300_000),
        (MicrofacetType::Beckmann, 100_000),
    ] {
        for &alpha in &alphas {
            let t = std::time::Instant::now();
            let unit = |mut j: Vec<f64>| {
                let s: f64 = j.iter().sum();
                j.iter_mut().for_each(|v| *v /= s);
                j
            };
            let ends: Vec<Vec<f64>> = etas
                .iter()
                .map(|&e| unit(dielectric_joint_at(kind, e, alpha, walks, 1 << 20)[1].clone()))
                .collect();
            for k in 0..etas.len() - 1 {
                let m = (etas[k] * etas[k + 1]).sqrt();
                let direct = dielectric_joint_at(kind, m, alpha, walks, 2 << 20)[1].clone();
                let again = dielectric_joint_at(kind, m, alpha, walks, 3 << 20)[1].clone();
                let interp: Vec<f64> = ends[k]
                    .iter()
                    .zip(&ends[k + 1])
                    .map(|(a, b)| 0.5 * (a + b))
                    .collect();
                let (mut worst, mut worst_noise, mut worst_fine, mut at) =
                    (0.0f64, 0.0f64, 0.0f64, 0);
                for r in 0..NR {
                    let sum: f64 = direct[r * drow..][..drow].iter().sum();
                    let frac =
                        sum / bin_m(r % LOBE_MU) / if r >= LOBE_MU { (m * m) as f64 } else { 1.0 };
                    let e = frac * tv(&shape(&direct, r, true), &shape(&interp, r, true));
                    let n = frac * tv(&shape(&direct, r, true), &shape(&again, r, true));
                    let f = frac * tv(&shape(&direct, r, false), &shape(&interp, r, false))
                        - frac * tv(&shape(&direct, r, false), &shape(&again, r, false));
                    if e > worst {
                        (worst, at) = (e, r);
                    }
                    worst_noise = worst_noise.max(n);
                    worst_fine = worst_fine.max(f);
                }
                println!(
                    "{kind:?} α={alpha:.3} η {:.3}–{:.3} (mid {m:.3}, θc {:.1}°–{:.1}°): interpolation error {worst:.4} (row {at}; noise {worst_noise:.4}); fine bins, less noise: {worst_fine:.4}",
                    etas[k],
                    etas[k + 1],
                    (1.0 / etas[k]).asin().to_degrees(),
                    (1.0 / etas[k + 1]).asin().to_degrees(),
                );
            }
            println!("  ({:.1} s)", t.elapsed().as_secs_f64());
        }
    }
}

/// What the table's bins alone cost a narrow multiple-scattering lobe (`-- --ignored
/// dielectric_bin_probe --nocapture`; `SPECULA_PROBE_CASES` = `d:alpha:eta:theta;...`): the
/// total-variation distance (the survey's bins) between the walk and the walk whose multiple
/// scattering (bounces ≥ 2, the height-correlated deficit) is replaced by its best piecewise
/// constant version in the table's cells — (out) the outgoing direction redrawn within its
/// cell (μ ∝ μ in its θ bin, Δφ uniform in its bin, either sign), (in) the incidence drawn ∝ μ
/// over its θ bin as the generator does, (both) — each against independent walks, with the
/// noise of the distance (two independent walks); for 16 uniform θ bins per side × 16 uniform
/// Δφ bins (the table's cells until they were made to narrow towards the horizon and Δφ = π,
/// which this probe motivated) and for twice as many θ bins, or twice or four times as many Δφ
/// bins.
#[test]
#[ignore]
fn dielectric_bin_probe() {
    use glam::Vec3;
    use specula_bsdf::models::microsurface_walk::{MicrosurfaceWalk, WalkMaterial};
    use specula_bsdf::multiscatter::lobe::{LOBE_MU, LOBE_PHI};
    use specula_bsdf::rng::Pcg32;
    use std::f32::consts::{FRAC_PI_2, PI};
    let cases = std::env::var("SPECULA_PROBE_CASES").unwrap_or_else(|_| {
        "beckmann:0.1:1.5:95;ggx:0.1:1.5:95;beckmann:0.1:2.4:85;beckmann:0.3:1.5:95".into()
    });
    let n = 200_000usize;
    let (mb, pb) = (12usize, 16usize);
    let bin = |w: Vec3| {
        let hemi = (w.z < 0.0) as usize;
        let mu = ((w.z.abs() * mb as f32) as usize).min(mb - 1);
        let phi = w.y.atan2(w.x) / (2.0 * PI) + 0.5;
        let p = ((phi * pb as f32) as usize).min(pb - 1);
        (hemi * mb + mu) * pb + p
    };
    let tv = |a: &[f64], b: &[f64]| {
        let (sa, sb): (f64, f64) = (a.iter().sum(), b.iter().sum());
        0.5 * a
            .iter()
            .zip(b)
            .map(|(x, y)| (x / sa - y / sb).abs())
            .sum::<f64>()
    };
    // (θ bin edges, Δφ bins): the table's (16 uniform, 16), and for comparison twice as many
    // θ bins or Δφ bins
    let uniform = |k: usize| {
        (0..=k)
            .map(|i| i as f32 * FRAC_PI_2 / k as f32)
            .collect::<Vec<_>>()
    };
    let edge_sets = [
        ("16 θ × 16 Δφ", uniform(LOBE_MU), LOBE_PHI),
        ("32 θ × 16 Δφ", uniform(2 * LOBE_MU), LOBE_PHI),
        ("16 θ × 32 Δφ", uniform(LOBE_MU), 2 * LOBE_PHI),
        ("16 θ × 64 Δφ", uniform(LOBE_MU), 4 * LOBE_PHI),
    ];
    let theta_bin = |e: &[f32], mu: f32| {
        let t = mu.clamp(0.0, 1.0).acos();
        (e.partition_point(|&x| x <= t) - 1).min(e.len() - 2)
    };
    // μ ∝ μ within the θ bin k (k = 0 at the normal)
    let draw_mu = |e: &[f32], k: usize, u: f32| {
        let (hi, lo) = (e[k].cos(), e[k + 1].cos().max(0.0));
        (lo * lo + u * (hi * hi - lo * lo)).sqrt()
    };
    for case in cases.split(';') {
        let f: Vec<&str> = case.split(':').collect();
        let kind = if f[0] == "ggx" {
            specula_bsdf::microfacet::MicrofacetType::Ggx
        } else {
            specula_bsdf::microfacet::MicrofacetType::Beckmann
        };
        let (alpha, eta, theta): (f32, f32, f32) = (
            f[1].parse().unwrap(),
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
        );
        let walk = MicrosurfaceWalk::new(kind, alpha, alpha, WalkMaterial::Dielectric { eta });
        let wi = check::suite::incidence(theta);
        let phi_i = wi.y.atan2(wi.x);
        let dir = |mu: f32, phi: f32, below: bool| {
            let s = (1.0 - mu * mu).max(0.0).sqrt();
            Vec3::new(s * phi.cos(), s * phi.sin(), if below { -mu } else { mu })
        };
        let plain = |seed: u64| {
            let mut h = vec![0.0f64; 2 * mb * pb];
            let mut ms = 0.0;
            let mut rng = Pcg32::new(seed, 5);
            for _ in 0..n {
                if let Some(s) = walk.sample(wi, &mut rng) {
                    h[bin(s.wo)] += 1.0;
                    ms += (s.bounces > 1) as u32 as f64;
                }
            }
            (h, ms / n as f64)
        };
        let (w1, msf) = plain(1);
        let (w2, _) = plain(2);
        let noise = tv(&w1, &w2) / std::f64::consts::SQRT_2;
        // (smear incidence, smear outgoing)
        let variant = |e: &[f32], nphi: usize, smear_in: bool, smear_out: bool, seed: u64| {
            let mut h = vec![0.0f64; 2 * mb * pb];
            let mut rng = Pcg32::new(seed, 7);
            // single scattering at the exact incidence
            for _ in 0..n {
                if let Some(s) = walk.sample(wi, &mut rng) {
                    if s.bounces == 1 {
                        h[bin(s.wo)] += 1.0;
                    }
                }
            }
            // multiple scattering, normalised to the exact incidence's fraction
            let mut hm = vec![0.0f64; 2 * mb * pb];
            let ki = theta_bin(e, wi.z.abs());
            for _ in 0..n {
                let w = if smear_in {
                    dir(draw_mu(e, ki, rng.next_f32()).max(1e-4), phi_i, wi.z < 0.0)
                } else {
                    wi
                };
                let Some(s) = walk.sample(w, &mut rng) else {
                    continue;
                };
                if s.bounces == 1 || s.wo.z == 0.0 {
                    continue;
                }
                let wo = if smear_out {
                    let ko = theta_bin(e, s.wo.z.abs());
                    let dphi = (s.wo.y.atan2(s.wo.x) - phi_i).rem_euclid(2.0 * PI);
                    let fold = if dphi > PI { 2.0 * PI - dphi } else { dphi };
                    let p = ((fold / PI * nphi as f32) as usize).min(nphi - 1);
                    let d = (p as f32 + rng.next_f32()) * PI / nphi as f32;
                    let sign = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
                    dir(
                        draw_mu(e, ko, rng.next_f32()),
                        phi_i + sign * d,
                        s.wo.z < 0.0,
                    )
                } else {
                    s.wo
                };
                hm[bin(wo)] += 1.0;
            }
            let sm: f64 = hm.iter().sum();
            for (a, b) in h.iter_mut().zip(&hm) {
                *a += b / sm * msf * n as f64;
            }
            h
        };
        let none = tv(&variant(&edge_sets[0].1, LOBE_PHI, false, false, 6), &w1);
        let mut line = String::new();
        for (name, e, nphi) in &edge_sets {
            let out = tv(&variant(e, *nphi, false, true, 3), &w1);
            let inc = tv(&variant(e, *nphi, true, false, 4), &w1);
            let both = tv(&variant(e, *nphi, true, true, 5), &w1);
            line += &format!(" {name}: (out) {out:.4} (in) {inc:.4} (both) {both:.4};");
        }
        println!(
            "{case}: multiple scattering {msf:.4};{line} (neither) {none:.4}; noise {noise:.4}"
        );
    }
}
