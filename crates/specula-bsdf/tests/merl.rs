//! The MERL measured-BRDF reader, evaluation and sampler.
//!
//! - the two shared files (simulated measurements of Mitsuba 3's `roughconductor` Cu GGX α=0.2
//!   and `roughplastic` GGX α=0.1) agree with Specula's own analytic models at every bin
//!   centre; they are skipped when `../shared` is absent, except under `CI=true`;
//! - χ² goodness of fit of `sample` against `pdf` (10⁶ samples, `check::chi2_test` defaults,
//!   fixed seeds), family-wise significance 0.01 Šidák-corrected over every χ² test in this
//!   file ([`CHI2_TESTS`]), on the shared files and on a synthetic table that needs no data;
//! - sample weights and pdfs consistent with eval/pdf (1e-4), reciprocity of the interpolated
//!   evaluation, finiteness, no allocation in the hot paths;
//! - damaged files (empty, truncated, oversized, wrong dimensions, garbage, NaN) are errors
//!   naming the file, and write → read is exact;
//! - variance of 64-sample albedo estimates: cosine-hemisphere versus the tabulated sampler.

use glam::{Vec2, Vec3};
use specula_bsdf::check::{self, stats};
use specula_bsdf::measured::merl::{self, Merl, MerlError};
use specula_bsdf::rng::Pcg32;
use specula_bsdf::{parse_spec, Bsdf, BsdfContext, BsdfModel, ShadingPoint, Spectrum};
use std::path::PathBuf;
use std::sync::OnceLock;
use std::time::Instant;

/// Under `../shared`.
const COPPER: &str = "data/merl/mitsuba_rough_copper.binary";
const PLASTIC: &str = "data/merl/mitsuba_rough_plastic.binary";
const COPPER_SPEC: &str = "roughconductor material=Cu alpha=0.2 distribution=ggx";
const PLASTIC_SPEC: &str =
    "roughplastic distribution=ggx alpha=0.1 diffuse_reflectance=0.6,0.15,0.1";

const FAMILY_ALPHA: f64 = 0.01;
/// Incidence angles (degrees) of the χ² tests.
const ANGLES: [f32; 4] = [0.0, 30.0, 60.0, 80.0];
/// χ² tests in this file: the two shared files and the synthetic table, at each angle.
const CHI2_TESTS: usize = 3 * ANGLES.len();

/// A shared file, read once per test binary; `None` (skip) when the data is absent, except
/// under CI where that fails.
fn shared(path: &'static str) -> Option<&'static Merl> {
    static COPPER_CELL: OnceLock<Option<Merl>> = OnceLock::new();
    static PLASTIC_CELL: OnceLock<Option<Merl>> = OnceLock::new();
    let cell = if path == COPPER {
        &COPPER_CELL
    } else {
        &PLASTIC_CELL
    };
    cell.get_or_init(|| {
        let p = specula_testdata::shared(path)?;
        let t = Instant::now();
        let m = Merl::read(&p).unwrap_or_else(|e| panic!("{e}"));
        println!(
            "read + sampler construction of {}: {:.3} s",
            p.file_name().unwrap().to_string_lossy(),
            t.elapsed().as_secs_f64()
        );
        Some(m)
    })
    .as_ref()
}

/// A synthetic table that needs no shared data: a blue-ish GGX conductor plus a small
/// diffuse term, "measured" by Specula's models.
fn synthetic() -> &'static Merl {
    static CELL: OnceLock<Merl> = OnceLock::new();
    CELL.get_or_init(|| {
        let spec = parse_spec("blendbsdf weight=0.2 { diffuse reflectance=0.5 } { roughconductor distribution=ggx alpha=0.3 material=Au }").unwrap();
        Merl::measure(&spec)
    })
}

fn direction(theta_deg: f32) -> Vec3 {
    // off the xz-plane, so that the azimuthal rotation of the sampler is exercised
    let (t, p) = (theta_deg.to_radians(), 0.7f32);
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()).normalize()
}

fn interpolated(m: &Merl) -> Merl {
    let mut m = m.clone();
    m.interpolate = true;
    m
}

// ---------------------------------------------------------------------------------------
// agreement with the analytic models
// ---------------------------------------------------------------------------------------

struct Agreement {
    compared: usize,
    unmeasured: usize,
    max_rel: f64,
    p999_rel: f64,
    above_1e3: usize,
    worst: String,
}

/// Compare the stored table with `model` at every bin centre (directions in f64, rounded to
/// f32 for the model). Relative error per channel, over entries above 1e-4 of the channel's
/// median (below that, float noise of the model dominates).
fn agreement(m: &Merl, model: &Bsdf) -> Agreement {
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut errs = Vec::with_capacity(merl::ENTRIES);
    let mut r = Agreement {
        compared: 0,
        unmeasured: 0,
        max_rel: 0.0,
        p999_rel: 0.0,
        above_1e3: 0,
        worst: String::new(),
    };
    for i in 0..merl::RES_THETA_H {
        for j in 0..merl::RES_THETA_D {
            for k in 0..merl::RES_PHI_D {
                let (wi, wo) = merl::bin_centre_dirs(i, j, k);
                let raw = m.raw(i, j, k);
                let below = wi[2] <= 0.0 || wo[2] <= 0.0;
                if raw.iter().any(|&v| v < 0.0) {
                    assert!(
                        below && raw.iter().all(|&v| v < 0.0),
                        "bin ({i},{j},{k}) unmeasured but above the horizon: {raw:?}"
                    );
                    r.unmeasured += 1;
                    continue;
                }
                assert!(!below, "bin ({i},{j},{k}) below the horizon but measured");
                let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
                let f = model.eval(&ctx, &sp, v(wi), v(wo));
                for c in 0..3 {
                    let t = raw[c] * merl::SCALE[c];
                    let a = f[c] as f64;
                    let e = (a - t).abs() / a.abs().max(t.abs()).max(1e-6);
                    errs.push(e);
                    if e > 1e-3 {
                        r.above_1e3 += 1;
                    }
                    if e > r.max_rel {
                        r.max_rel = e;
                        r.worst = format!(
                            "bin ({i},{j},{k}) channel {c}: table {t:.6e}, model {a:.6e}, θi={:.3}°, θo={:.3}°",
                            wi[2].acos().to_degrees(),
                            wo[2].acos().to_degrees()
                        );
                    }
                }
                r.compared += 1;
            }
        }
    }
    errs.sort_by(|a, b| a.partial_cmp(b).unwrap());
    r.p999_rel = errs[(errs.len() as f64 * 0.999) as usize];
    r
}

fn check_agreement(path: &'static str, spec: &str) {
    let Some(m) = shared(path) else { return };
    let model = parse_spec(spec).unwrap();
    let r = agreement(m, &model);
    println!(
        "{spec}: {} bins compared, {} unmeasured; relative error max {:.2e}, 99.9th percentile {:.2e}, {} channel values above 1e-3; worst: {}",
        r.compared, r.unmeasured, r.max_rel, r.p999_rel, r.above_1e3, r.worst
    );
    assert!(r.compared > 1_000_000);
    // Specula's models are not bit-identical to Mitsuba's: 1e-3 relative is the budget (the
    // shared files agree to a few 1e-6, the float noise of the f32 models)
    assert!(r.max_rel < 1e-3, "max {:.2e}: {}", r.max_rel, r.worst);
}

#[test]
fn copper_table_agrees_with_roughconductor() {
    check_agreement(COPPER, COPPER_SPEC);
}

#[test]
fn plastic_table_agrees_with_roughplastic() {
    check_agreement(PLASTIC, PLASTIC_SPEC);
}

#[test]
fn eval_returns_the_table_at_bin_centres() {
    // nearest: exactly the stored value; interpolated: the same up to float noise in the
    // interpolation weights (the centres are where the weights are 0/1)
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut tables: Vec<&Merl> = vec![synthetic()];
    tables.extend(shared(COPPER));
    tables.extend(shared(PLASTIC));
    for m in tables {
        let mi = interpolated(m);
        let mut rng = Pcg32::new(17, 1);
        let mut checked = 0;
        for _ in 0..200_000 {
            let (i, j, k) = (
                rng.next_u32() as usize % merl::RES_THETA_H,
                rng.next_u32() as usize % merl::RES_THETA_D,
                rng.next_u32() as usize % merl::RES_PHI_D,
            );
            let (wi, wo) = merl::bin_centre_dirs(i, j, k);
            let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
            let (wi, wo) = (v(wi), v(wo));
            if wi.z <= 0.0 || wo.z <= 0.0 {
                assert_eq!(m.eval(&ctx, &sp, wi, wo), Spectrum::ZERO);
                continue;
            }
            let want = m.bin_value(i, j, k);
            assert_eq!(m.eval(&ctx, &sp, wi, wo), want, "bin ({i},{j},{k})");
            assert_eq!(m.eval(&ctx, &sp, wo, wi), want, "bin ({i},{j},{k}) swapped");
            let got = mi.eval(&ctx, &sp, wi, wo);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 2e-3 * want[c].abs() + 1e-7,
                    "{}: interpolated bin ({i},{j},{k}): {got:?} vs {want:?}",
                    m.name()
                );
            }
            checked += 1;
        }
        assert!(checked > 100_000);
    }
}

#[test]
fn interpolation_handles_unmeasured_corners() {
    // a table measured only for θd < 45°: interpolation renormalises over measured corners,
    // nearest gives 0 for unmeasured bins
    let m = Merl::from_fn(|th, td, _| {
        if td < std::f64::consts::FRAC_PI_4 {
            Spectrum::splat((1.0 + th) as f32)
        } else {
            Spectrum::splat(-1.0)
        }
    });
    let mut mi = m.clone();
    mi.interpolate = true;
    let th = merl::theta_h_centre(10) as f32;
    let (a, b) = (44.5f32.to_radians(), 45.5f32.to_radians());
    let mid = 45.0f32.to_radians();
    let want = m.lookup_nearest(th, a, 0.3);
    assert!(want.r() > 0.0);
    assert_eq!(m.lookup_nearest(th, b, 0.3), Spectrum::ZERO);
    // halfway between a measured and an unmeasured bin centre: the measured value
    let got = mi.lookup_interpolated(th, mid, 0.3);
    assert!(
        (got.r() - want.r()).abs() < 1e-6 * want.r(),
        "{got:?} {want:?}"
    );
    // deep in the unmeasured region: 0
    assert_eq!(mi.lookup_interpolated(th, 1.2, 0.3), Spectrum::ZERO);
    // φd is periodic: across 0°/180° the interpolation wraps
    let m2 = Merl::from_fn(|_, _, pd| Spectrum::splat(pd as f32));
    let mut m2i = m2.clone();
    m2i.interpolate = true;
    let lo = m2i.lookup_interpolated(0.5, 0.5, 0.0);
    let hi = m2i.lookup_interpolated(0.5, 0.5, -1e-6);
    let expect = 0.5 * (0.5f32.to_radians() + 179.5f32.to_radians());
    assert!((lo.r() - expect).abs() < 1e-3, "{lo:?} vs {expect}");
    assert!((hi.r() - expect).abs() < 1e-3, "{hi:?} vs {expect}");
    // between centres, linear
    let q = m2i.lookup_interpolated(0.5, 0.5, 10.0f32.to_radians());
    assert!((q.r() - 10.0f32.to_radians()).abs() < 1e-5, "{q:?}");
}

// ---------------------------------------------------------------------------------------
// sampling
// ---------------------------------------------------------------------------------------

fn significance() -> f64 {
    stats::sidak(FAMILY_ALPHA, CHI2_TESTS)
}

fn chi2_all(name: &str, m: &Merl, seed0: u64) {
    let alpha = significance();
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut failures = Vec::new();
    for (ai, &theta) in ANGLES.iter().enumerate() {
        let t = Instant::now();
        let r = check::chi2_test(
            m,
            &ctx,
            &sp,
            direction(theta),
            &check::Chi2Config {
                seed: seed0 + ai as u64,
                ..Default::default()
            },
        );
        println!(
            "χ² {name} θi={theta}°: χ²={:.1} dof={} p={:.4} ∫pdf={:.5} ({:.1} s)",
            r.statistic,
            r.dof,
            r.p_value,
            r.pdf_integral,
            t.elapsed().as_secs_f64()
        );
        if r.p_value < alpha {
            failures.push(format!(
                "{name} θi={theta}: χ²={:.1} dof={} p={:.3e} worst cells {:?}",
                r.statistic, r.dof, r.p_value, r.worst
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "per-test significance {alpha:.3e}:\n{}",
        failures.join("\n")
    );
}

#[test]
fn chi2_copper() {
    if let Some(m) = shared(COPPER) {
        chi2_all("copper", m, 100);
    }
}

#[test]
fn chi2_plastic() {
    if let Some(m) = shared(PLASTIC) {
        chi2_all("plastic", m, 200);
    }
}

#[test]
fn chi2_synthetic() {
    chi2_all("synthetic", synthetic(), 300);
}

#[test]
fn sample_weights_and_pdfs_are_consistent() {
    let sp = ShadingPoint::default();
    let mut tables: Vec<&Merl> = vec![synthetic()];
    tables.extend(shared(COPPER));
    tables.extend(shared(PLASTIC));
    let mut failures = Vec::new();
    for m in tables {
        let mut cosine = m.clone();
        cosine.sampling = specula_bsdf::measured::merl::MerlSampling::Cosine;
        for m in [m.clone(), interpolated(m), cosine] {
            for ctx in [BsdfContext::RADIANCE, BsdfContext::IMPORTANCE] {
                for theta in [0.0, 30.0, 60.0, 80.0, 89.0] {
                    let r = check::sample_consistency(&m, &ctx, &sp, direction(theta), 20_000, 5);
                    if r.max_weight_err > 1e-4 || r.max_pdf_err > 1e-4 {
                        failures.push(format!(
                            "{:?} θi={theta}: weight err {:.2e}, pdf err {:.2e}: {}",
                            m,
                            r.max_weight_err,
                            r.max_pdf_err,
                            r.worst.unwrap_or_default()
                        ));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn interpolated_evaluation_is_reciprocal() {
    // Swapping wi and wo maps φd to φd + π, which the table folds away: the interpolated
    // value is continuous, so it is reciprocal up to float rounding. Nearest-bin lookup is
    // reciprocal too except where rounding puts the two orders in different bins.
    let sp = ShadingPoint::default();
    let mut tables: Vec<&Merl> = vec![synthetic()];
    tables.extend(shared(COPPER));
    tables.extend(shared(PLASTIC));
    for m in tables {
        let r = check::reciprocity(&interpolated(m), &sp, None, 100_000, 9);
        let n = check::reciprocity(m, &sp, None, 100_000, 9);
        println!(
            "{m:?}: reciprocity, interpolated max rel err {:.2e}; nearest {:.2e}",
            r.max_rel_err, n.max_rel_err
        );
        assert!(
            r.max_rel_err < 2e-4,
            "{m:?}: {:.3e} at {:?}",
            r.max_rel_err,
            r.worst
        );
    }
}

#[test]
fn values_are_finite_and_nonnegative() {
    let sp = ShadingPoint::default();
    let mut tables: Vec<&Merl> = vec![synthetic()];
    tables.extend(shared(COPPER));
    tables.extend(shared(PLASTIC));
    for m in tables {
        for m in [m.clone(), interpolated(m)] {
            if let Err(e) = check::finite_nonnegative(&m, &sp, 20_000, 3) {
                panic!("{m:?}: {e}");
            }
        }
    }
}

#[test]
fn no_sample_below_the_horizon_and_one_sided() {
    let m = synthetic();
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let below = Vec3::new(0.3, 0.2, -0.9).normalize();
    let above = Vec3::new(-0.3, 0.1, 0.9).normalize();
    assert!(m.sample(&ctx, &sp, below, 0.5, Vec2::splat(0.5)).is_none());
    assert_eq!(m.eval(&ctx, &sp, below, above), Spectrum::ZERO);
    assert_eq!(m.eval(&ctx, &sp, above, below), Spectrum::ZERO);
    assert_eq!(m.pdf(&ctx, &sp, above, below), 0.0);
    assert_eq!(m.pdf(&ctx, &sp, below, above), 0.0);
    let mut rng = Pcg32::new(4, 4);
    for _ in 0..100_000 {
        let wi = direction(rng.next_f32() * 90.0);
        if let Some(s) = m.sample(&ctx, &sp, wi, rng.next_f32(), rng.next_vec2()) {
            assert!(s.wo.z > 0.0 && s.pdf > 0.0, "{s:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// files
// ---------------------------------------------------------------------------------------

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("specula-merl-test-{}-{name}", std::process::id()))
}

fn small_table() -> Merl {
    // values that exercise every byte of the f64s, plus unmeasured bins
    Merl::from_fn(|th, td, pd| {
        if td + th > 2.0 {
            Spectrum::splat(-1.0)
        } else {
            Spectrum::new(
                (0.1 + th.sin() * 0.3) as f32,
                (0.2 + td * pd.cos() * 0.01) as f32,
                (1e-3 + (th * 7.0 + pd).sin().abs() * 0.05) as f32,
            )
        }
    })
}

#[test]
fn write_read_round_trip_is_exact() {
    let m = small_table();
    let bytes = m.to_bytes();
    assert_eq!(bytes.len(), merl::FILE_SIZE);
    let path = temp_path("roundtrip.binary");
    m.write(&path).unwrap();
    let back = Merl::read(&path).unwrap();
    std::fs::remove_file(&path).ok();
    assert_eq!(back.name(), path.display().to_string());
    let (a, b) = (m.raw_table(), back.raw_table());
    assert_eq!(a.len(), b.len());
    assert!(
        a.iter()
            .zip(b)
            .all(|(x, y)| (0..3).all(|c| x[c].to_bits() == y[c].to_bits())),
        "values differ after write → read"
    );
    assert_eq!(back.to_bytes(), bytes);
    assert_eq!(Merl::from_bytes("mem", &bytes).unwrap().to_bytes(), bytes);
    // unmeasured entries survive
    assert!(b.iter().any(|v| v[0] < 0.0));
    // the shared files too, byte for byte
    for p in [COPPER, PLASTIC] {
        if let Some(m) = shared(p) {
            let file = specula_testdata::root().join(p);
            assert!(m.to_bytes() == std::fs::read(file).unwrap(), "{p}");
        }
    }
}

/// Every way a file can be broken, as (name, bytes, what the message must mention).
fn damaged_files() -> Vec<(&'static str, Vec<u8>, &'static str)> {
    let good = small_table().to_bytes();
    let mut nan = good.clone();
    let at = 12 + 8 * (merl::ENTRIES + 1234); // a green entry
    nan[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
    let mut inf = good.clone();
    let at = 12 + 8 * (2 * merl::ENTRIES + merl::ENTRIES - 1); // the last blue entry
    inf[at..at + 8].copy_from_slice(&f64::INFINITY.to_le_bytes());
    let mut dims = good.clone();
    dims[8..12].copy_from_slice(&360i32.to_le_bytes());
    let mut negative_dims = good.clone();
    negative_dims[0..4].copy_from_slice(&(-90i32).to_le_bytes());
    let mut oversized = good.clone();
    oversized.extend_from_slice(&[0u8; 8]);
    let mut rng = Pcg32::new(99, 1);
    let garbage: Vec<u8> = (0..100_000).map(|_| rng.next_u32() as u8).collect();
    let garbage_sized: Vec<u8> = (0..merl::FILE_SIZE).map(|_| rng.next_u32() as u8).collect();
    vec![
        ("empty", vec![], "found 0"),
        ("header-only", good[..12].to_vec(), "found 12"),
        ("short-header", good[..7].to_vec(), "found 7"),
        (
            "truncated",
            good[..good.len() - 1].to_vec(),
            "found 34992011",
        ),
        ("half", good[..good.len() / 2].to_vec(), "expected 34992012"),
        ("oversized", oversized, "found 34992020"),
        ("wrong-dims", dims, "[90, 90, 360]"),
        ("negative-dims", negative_dims, "[-90, 90, 180]"),
        ("garbage", garbage, "not a MERL BRDF"),
        ("garbage-sized", garbage_sized, "not a MERL BRDF"),
        ("nan", nan, "green channel entry 1234"),
        ("inf", inf, "blue channel entry 1457999"),
    ]
}

#[test]
fn damaged_files_are_errors_naming_the_file() {
    for (name, bytes, mention) in damaged_files() {
        let path = temp_path(&format!("{name}.binary"));
        std::fs::write(&path, &bytes).unwrap();
        let shown = path.display().to_string();
        let r = std::panic::catch_unwind(|| Merl::read(&path));
        std::fs::remove_file(&path).ok();
        let err = r
            .unwrap_or_else(|_| panic!("{name}: read panicked"))
            .expect_err(name);
        let msg = err.to_string();
        println!("{name}: {msg}");
        assert!(msg.contains(&shown), "{name}: {msg}");
        assert_eq!(err.file(), shown);
        assert!(
            msg.contains(mention),
            "{name}: {msg} (should mention {mention})"
        );
        // the same from memory
        let err = Merl::from_bytes("label.binary", &bytes).expect_err(name);
        assert!(err.to_string().starts_with("label.binary: "), "{err}");
        assert!(err.to_string().contains(mention), "{err}");
    }
    // a missing file and a directory
    let missing = temp_path("does-not-exist.binary");
    let e = Merl::read(&missing).unwrap_err();
    assert!(
        matches!(e, MerlError::Io { .. })
            && e.to_string().contains(&*missing.display().to_string())
    );
    let e = Merl::read(&std::env::temp_dir()).unwrap_err();
    assert!(
        e.to_string()
            .contains(&*std::env::temp_dir().display().to_string()),
        "{e}"
    );
    // writing into a missing directory
    let e = small_table().write(&missing.join("x.binary")).unwrap_err();
    assert!(e.to_string().contains("does-not-exist"), "{e}");
}

// ---------------------------------------------------------------------------------------
// variance reduction
// ---------------------------------------------------------------------------------------

/// Mean and variance over `runs` of 64-sample albedo estimates (luminance), by cosine
/// sampling (`cosine`) or by the model's sampler.
fn albedo_estimates(m: &Merl, wi: Vec3, cosine: bool, runs: usize, seed: u64) -> (f64, f64) {
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut rng = Pcg32::new(seed, 21);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..runs {
        let mut est = 0.0f64;
        for _ in 0..64 {
            let (u1, u2) = (rng.next_f32(), rng.next_vec2());
            est += if cosine {
                let wo = specula_bsdf::warp::square_to_cosine_hemisphere(u2);
                let pdf = specula_bsdf::warp::square_to_cosine_hemisphere_pdf(wo);
                if pdf > 0.0 {
                    (m.eval(&ctx, &sp, wi, wo).luminance() * wo.z / pdf) as f64
                } else {
                    0.0
                }
            } else {
                m.sample(&ctx, &sp, wi, u1, u2)
                    .map_or(0.0, |s| s.weight.luminance() as f64)
            };
        }
        est /= 64.0;
        s1 += est;
        s2 += est * est;
    }
    let n = runs as f64;
    let mean = s1 / n;
    (mean, (s2 / n - mean * mean).max(0.0) * n / (n - 1.0))
}

#[test]
fn importance_sampling_reduces_variance() {
    let mut tables: Vec<(&str, &Merl)> = vec![("synthetic", synthetic())];
    tables.extend(shared(COPPER).map(|m| ("copper", m)));
    tables.extend(shared(PLASTIC).map(|m| ("plastic", m)));
    let runs = 20_000;
    for (name, m) in tables {
        for theta in [30.0, 60.0] {
            let wi = direction(theta);
            let (mc, vc) = albedo_estimates(m, wi, true, runs, 1);
            let (mi, vi) = albedo_estimates(m, wi, false, runs, 2);
            let ratio = vc / vi;
            println!(
                "{name} θi={theta}°: albedo (luminance, 64 samples × {runs}) cosine {mc:.5} (var {vc:.3e}), importance {mi:.5} (var {vi:.3e}); variance ratio {ratio:.1}"
            );
            // both estimators are unbiased: the means agree within their errors
            let se = ((vc + vi) / runs as f64).sqrt();
            assert!(
                (mc - mi).abs() < 5.0 * se,
                "{name} θi={theta}: {mc} vs {mi} (se {se:.2e})"
            );
            if name == "copper" {
                assert!(ratio >= 4.0, "copper θi={theta}: variance ratio {ratio:.2}");
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// no allocation in the hot paths
// ---------------------------------------------------------------------------------------

mod counting {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    pub struct Counting;
    thread_local! {
        /// Allocations made by this thread (other tests run on other threads).
        pub static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    }
    fn count() {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
    }
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            count();
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            count();
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }
}

#[global_allocator]
static GLOBAL: counting::Counting = counting::Counting;

#[test]
fn hot_paths_do_not_allocate() {
    let m = synthetic();
    let mi = interpolated(m);
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let mut rng = Pcg32::new(8, 8);
    let dirs: Vec<(Vec3, Vec3, f32, Vec2)> = (0..4096)
        .map(|_| {
            let a = specula_bsdf::warp::square_to_uniform_sphere(rng.next_vec2());
            let b = specula_bsdf::warp::square_to_uniform_sphere(rng.next_vec2());
            (a, b, rng.next_f32(), rng.next_vec2())
        })
        .collect();
    let before = counting::ALLOCATIONS.with(|c| c.get());
    let mut acc = 0.0f32;
    for b in [m, &mi] {
        for &(wi, wo, u1, u2) in &dirs {
            let (wi, wo) = (Vec3::new(wi.x, wi.y, wi.z.abs()), wo);
            acc += b.eval(&ctx, &sp, wi, wo).r();
            acc += b.pdf(&ctx, &sp, wi, wo);
            acc += b.eval_pdf(&ctx, &sp, wi, wo).1;
            if let Some(s) = b.sample(&ctx, &sp, wi, u1, u2) {
                acc += s.pdf;
            }
        }
    }
    let after = counting::ALLOCATIONS.with(|c| c.get());
    assert!(acc.is_finite());
    assert_eq!(after - before, 0, "eval/pdf/sample allocated");
}

/// Directional albedo per channel of `b` at `wi`, by `check::albedo` with the sampler of
/// `b` (validated by the χ² tests above).
fn albedo(b: &dyn BsdfModel, wi: Vec3) -> [f64; 3] {
    let a = check::albedo(
        b,
        &BsdfContext::RADIANCE,
        &ShadingPoint::default(),
        wi,
        400_000,
        31,
    );
    [a.mean[0] as f64, a.mean[1] as f64, a.mean[2] as f64]
}

#[test]
fn tabulation_error_of_the_albedo() {
    // What a renderer sees: the directional albedo of the table (both lookup modes) against
    // the analytic model it was made from.
    for (path, spec) in [(COPPER, COPPER_SPEC), (PLASTIC, PLASTIC_SPEC)] {
        let Some(m) = shared(path) else { continue };
        let model = parse_spec(spec).unwrap();
        let mi = interpolated(m);
        for theta in [0.0, 30.0, 60.0, 80.0] {
            let wi = direction(theta);
            let (a, n, i) = (albedo(&model, wi), albedo(m, wi), albedo(&mi, wi));
            let rel = |x: [f64; 3]| {
                (0..3)
                    .map(|c| (x[c] / a[c] - 1.0).abs())
                    .fold(0.0, f64::max)
            };
            println!(
                "{spec} θi={theta}°: albedo analytic {a:.4?}, nearest {n:.4?} ({:.2}%), interpolated {i:.4?} ({:.2}%)",
                100.0 * rel(n),
                100.0 * rel(i)
            );
            assert!(rel(n) < 0.02 && rel(i) < 0.02, "{spec} θi={theta}");
        }
    }
}
