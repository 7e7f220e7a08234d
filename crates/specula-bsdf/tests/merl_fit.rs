//! Fitting analytic models to MERL tables (`specula_bsdf::measured::fit`).
//!
//! - the shared tables (Mitsuba 3's `roughconductor` Cu GGX α = 0.2 and `roughplastic` GGX
//!   α = 0.1, diffuse 0.6, 0.15, 0.1, int_ior 1.49, tabulated at the bin centres) give back
//!   their parameters; skipped when `../shared` is absent, except under `CI=true`;
//! - synthetic round trips need no data: Specula's `roughconductor beckmann α=0.3 Au`,
//!   tabulated with `Merl::measure_with_progress` (checked equal to `Merl::measure`), fitted
//!   with Beckmann under the cube-root metric, and a GGX `roughplastic` under the log metric;
//! - tables with nothing measured, or only zeros, are errors naming the table;
//! - the family with the lower error is the right one, and the printed Mitsuba XML builds the
//!   material whose error is reported.
//!
//! Tolerances: the tables hold the very models the families contain (the shared ones agree
//! with Specula's models to a few 1e-6 at every bin centre, see `tests/merl.rs`), so an exact
//! fit exists and the optimiser must find it; what separates the result from the truth is
//! only the optimiser's convergence and f32 rounding (expected ≪ 0.1 %). The 3 % asked by the
//! issue for α is kept as the acceptance bound, and the parameters that the data determine well
//! (diffuse colour, int_ior, F0) get 3 % too; a failure at that level means a wrong model,
//! weighting or optimiser, not noise. The error figures must be near zero (relative RMS
//! < 1e-3), which would fail for a fit stuck in a local minimum.

use specula_bsdf::measured::fit::{self, Family, FitOptions, FitParams, Metric};
use specula_bsdf::measured::merl::Merl;
use specula_bsdf::microfacet::MicrofacetType;
use specula_bsdf::parse_spec;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Under `../shared`.
const COPPER: &str = "data/merl/mitsuba_rough_copper.binary";
const PLASTIC: &str = "data/merl/mitsuba_rough_plastic.binary";

/// A shared table; `None` (skip) when the data is absent, except under CI where that fails.
fn shared(path: &str) -> Option<Merl> {
    let p = specula_testdata::shared(path)?;
    Some(Merl::read(&p).unwrap_or_else(|e| panic!("{e}")))
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

fn report(name: &str, fits: &[fit::Fit]) {
    for f in fits {
        println!(
            "{name}: {:<9} {} E={:.3e} relRMS={:.3e} ({} evaluations, {:.2} s)\n    {}",
            f.family.name(),
            f.distribution.name(),
            f.quality.value,
            f.quality.rel_rms,
            f.evaluations,
            f.elapsed.as_secs_f64(),
            f.spec()
        );
    }
}

/// Fits `m` (which must succeed), prints the fits and the time taken.
fn fit_and_report(name: &str, m: &Merl, options: FitOptions) -> Vec<fit::Fit> {
    let t = Instant::now();
    let fits = fit::fit(m, &options).unwrap();
    report(name, &fits);
    println!("{name}: fitted in {:.2} s", t.elapsed().as_secs_f64());
    fits
}

#[test]
fn copper_gives_back_alpha_and_f0() {
    let Some(m) = shared(COPPER) else { return };
    let fits = fit_and_report(
        "copper",
        &m,
        FitOptions {
            distribution: MicrofacetType::Ggx,
            ..Default::default()
        },
    );
    let best = &fits[0];
    assert_eq!(best.family, Family::Conductor, "copper is a conductor");
    assert!(
        rel(best.alpha as f64, 0.2) <= 0.03,
        "alpha {} vs 0.2",
        best.alpha
    );
    // F0 of Specula's Cu constants
    let truth = parse_spec("roughconductor material=Cu alpha=0.2 distribution=ggx").unwrap();
    let specula_bsdf::Bsdf::RoughConductor(rc) = &truth else {
        panic!()
    };
    let sp = Default::default();
    let f0_true =
        specula_bsdf::fresnel::fresnel_conductor_rgb(1.0, rc.eta.eval(&sp), rc.k.eval(&sp));
    let FitParams::Conductor { f0, diffuse, .. } = &best.params else {
        panic!()
    };
    for c in 0..3 {
        assert!(
            rel(f0[c] as f64, f0_true[c] as f64) <= 0.03,
            "F0 {f0:?} vs {f0_true:?}"
        );
        assert!(diffuse[c] < 1e-3, "no diffuse term: {diffuse:?}");
    }
    assert!(best.quality.rel_rms < 1e-3, "{:?}", best.quality);
    // the plastic cannot represent a coloured highlight
    assert!(fits[1].quality.value > 10.0 * best.quality.value);
}

#[test]
fn plastic_gives_back_alpha_colour_and_ior() {
    let Some(m) = shared(PLASTIC) else { return };
    let fits = fit_and_report(
        "plastic",
        &m,
        FitOptions {
            distribution: MicrofacetType::Ggx,
            ..Default::default()
        },
    );
    let best = &fits[0];
    assert_eq!(best.family, Family::Plastic);
    assert!(rel(best.alpha as f64, 0.1) <= 0.03, "alpha {}", best.alpha);
    let FitParams::Plastic {
        int_ior,
        diffuse_reflectance,
    } = &best.params
    else {
        panic!()
    };
    for (c, want) in [0.6, 0.15, 0.1].into_iter().enumerate() {
        assert!(
            rel(diffuse_reflectance[c] as f64, want) <= 0.03,
            "diffuse {diffuse_reflectance:?}"
        );
    }
    assert!(rel(*int_ior as f64, 1.49) <= 0.03, "int_ior {int_ior}");
    assert!(best.quality.rel_rms < 1e-3, "{:?}", best.quality);
    assert!(fits[1].quality.value > 10.0 * best.quality.value);
}

#[test]
fn synthetic_beckmann_gold_round_trip() {
    let truth = parse_spec("roughconductor distribution=beckmann alpha=0.3 material=Au").unwrap();
    let t = Instant::now();
    let calls = AtomicUsize::new(0);
    let last = AtomicUsize::new(0);
    let m = Merl::measure_with_progress(&truth, |done, total| {
        assert_eq!(total, 90);
        calls.fetch_add(1, Ordering::SeqCst);
        last.fetch_max(done, Ordering::SeqCst);
    })
    .with_name("<beckmann Au>");
    println!("measure_with_progress: {:.2} s", t.elapsed().as_secs_f64());
    // one call per θh row, and the same table as the serial Merl::measure
    assert_eq!(calls.load(Ordering::SeqCst), 90);
    assert_eq!(last.load(Ordering::SeqCst), 90);
    assert!(Merl::measure(&truth).raw_table() == m.raw_table());

    let fits = fit_and_report(
        "gold",
        &m,
        FitOptions {
            distribution: MicrofacetType::Beckmann,
            family: Some(Family::Conductor),
            ..Default::default()
        },
    );
    let best = &fits[0];
    assert!(rel(best.alpha as f64, 0.3) <= 0.03, "alpha {}", best.alpha);
    assert!(best.quality.rel_rms < 1e-3, "{:?}", best.quality);
    // the error over the whole table agrees with the subsampled one
    let q = fit::table_quality(&m, &best.bsdf, Metric::Cbrt);
    println!("full table: {q:?}");
    assert!(q.rel_rms < 1e-3, "{q:?}");
}

/// The log metric, on a plastic measured by Specula (no shared data needed).
#[test]
fn synthetic_plastic_under_the_log_metric() {
    let truth = parse_spec(
        "roughplastic distribution=ggx alpha=0.3 int_ior=1.6 diffuse_reflectance=0.2,0.4,0.8",
    )
    .unwrap();
    let m = Merl::measure(&truth).with_name("<plastic>");
    let fits = fit_and_report(
        "log plastic",
        &m,
        FitOptions {
            distribution: MicrofacetType::Ggx,
            metric: Metric::Log,
            family: Some(Family::Plastic),
            ..Default::default()
        },
    );
    let best = &fits[0];
    assert_eq!(best.quality.metric, Metric::Log);
    assert!(rel(best.alpha as f64, 0.3) <= 0.03, "alpha {}", best.alpha);
    let FitParams::Plastic {
        int_ior,
        diffuse_reflectance,
    } = &best.params
    else {
        panic!()
    };
    assert!(rel(*int_ior as f64, 1.6) <= 0.03, "int_ior {int_ior}");
    for (c, want) in [0.2, 0.4, 0.8].into_iter().enumerate() {
        assert!(
            rel(diffuse_reflectance[c] as f64, want) <= 0.03,
            "diffuse {diffuse_reflectance:?}"
        );
    }
    assert!(best.quality.rel_rms < 1e-3, "{:?}", best.quality);
}

/// Tables with nothing to fit are errors naming the table, not panics.
#[test]
fn degenerate_tables_are_errors() {
    let unmeasured =
        Merl::from_fn(|_, _, _| specula_bsdf::Spectrum::splat(-1.0)).with_name("x.binary");
    let e = fit::fit(&unmeasured, &FitOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("x.binary: cannot fit:"), "{e}");
    let black = Merl::from_fn(|_, _, _| specula_bsdf::Spectrum::ZERO).with_name("y.binary");
    let e = fit::fit(&black, &FitOptions::default())
        .unwrap_err()
        .to_string();
    assert_eq!(e, "y.binary: cannot fit: every measured value is zero");
}
