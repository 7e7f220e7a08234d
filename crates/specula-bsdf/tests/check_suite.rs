//! The check suite (`check::run_suite`, what `specula brdf check` runs) must pass correct
//! materials and flag deliberately broken ones, each by the check that concerns its defect
//! and by no other.
//!
//! Each suite run is one family of statistical tests at family-wise significance 0.01
//! (Šidák-corrected inside the suite), with fixed seeds, so the outcomes are reproducible.

mod common;
use common::Slope;
use glam::{Vec2, Vec3};
use specula_bsdf::check::suite::{self, SuiteConfig, SuiteReport, Verdict};
use specula_bsdf::warp::square_to_cosine_hemisphere;
use specula_bsdf::{
    parse_spec, BsdfContext, BsdfModel, BsdfSample, LobeFlags, ShadingPoint, Spectrum,
};
use std::f32::consts::PI;

/// A one-sided Lambertian-like test model with switchable defects.
#[derive(Clone, Copy, Debug, Default)]
struct Toy {
    /// Reflectance at normal incidence.
    rho: f32,
    /// f depends on cosθi only (not on cosθo): f(wi, wo) ≠ f(wo, wi).
    asymmetric: bool,
    /// pdf() and the sample's pdf claim uniform hemisphere sampling, while directions are drawn
    /// cosine-weighted (weights stay consistent with the claimed pdf).
    wrong_pdf: bool,
    /// The sample weight is 10 % higher than f·cos/pdf.
    heavy_weight: bool,
    /// eval returns NaN at grazing incidence.
    nan_at_grazing: bool,
}

impl Toy {
    fn f(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        if self.nan_at_grazing && wi.z < 1e-3 {
            return f32::NAN;
        }
        let r = if self.asymmetric {
            self.rho * (0.6 + 0.4 * wi.z)
        } else {
            self.rho
        };
        r / PI
    }
    fn pdf_of(&self, wo: Vec3) -> f32 {
        if wo.z <= 0.0 {
            0.0
        } else if self.wrong_pdf {
            0.5 / PI
        } else {
            wo.z / PI
        }
    }
}

impl BsdfModel for Toy {
    fn flags(&self) -> LobeFlags {
        LobeFlags::DIFFUSE_REFLECTION
    }
    fn eval(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        Spectrum::splat(self.f(wi, wo))
    }
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 {
            0.0
        } else {
            self.pdf_of(wo)
        }
    }
    fn sample(
        &self,
        _: &BsdfContext,
        _: &ShadingPoint,
        wi: Vec3,
        _: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = square_to_cosine_hemisphere(u2);
        let pdf = self.pdf_of(wo);
        if pdf <= 0.0 {
            return None;
        }
        let mut w = self.f(wi, wo) * wo.z / pdf;
        if self.heavy_weight {
            w *= 1.1;
        }
        Some(BsdfSample {
            wo,
            weight: Spectrum::splat(w),
            pdf,
            lobe: LobeFlags::DIFFUSE_REFLECTION,
            eta: 1.0,
        })
    }
}

fn config() -> SuiteConfig<'static> {
    SuiteConfig {
        samples: 100_000,
        seed: 7,
        ..Default::default()
    }
}

fn verdicts(r: &SuiteReport) -> Vec<(&'static str, Verdict)> {
    r.outcomes.iter().map(|o| (o.name, o.verdict)).collect()
}

fn show(r: &SuiteReport) -> String {
    r.outcomes
        .iter()
        .map(|o| {
            format!(
                "{:<15} {}  {}  {:?}",
                o.name, o.verdict, o.summary, o.details
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Runs the suite on `model` and asserts that exactly the checks in `failing` fail.
fn expect_failures(model: &Toy, failing: &[&str]) -> SuiteReport {
    let r = suite::run_suite(model, &config(), &|_, _| {});
    println!("{model:?}\n{}\n", show(&r));
    for (name, v) in verdicts(&r) {
        let want = if failing.contains(&name) {
            Verdict::Fail
        } else {
            Verdict::Pass
        };
        assert_eq!(v, want, "{name} of {model:?}:\n{}", show(&r));
    }
    assert_eq!(r.passed(), failing.is_empty());
    r
}

#[test]
fn correct_toy_passes_everything() {
    expect_failures(
        &Toy {
            rho: 0.8,
            ..Default::default()
        },
        &[],
    );
}

#[test]
fn non_reciprocal_model_fails_reciprocity() {
    let r = expect_failures(
        &Toy {
            rho: 0.8,
            asymmetric: true,
            ..Default::default()
        },
        &["reciprocity"],
    );
    // f(wi, wo)/f(wo, wi) reaches (0.6 + 0.4)/(0.6 + 0.4·cosθ) for cosθ → 0: far above 1e-4
    let o = r.outcome("reciprocity").unwrap();
    assert!(!o.details.is_empty() && o.details[0].contains("worst pair"));
}

#[test]
fn over_bright_model_fails_energy() {
    let r = expect_failures(
        &Toy {
            rho: 1.2,
            ..Default::default()
        },
        &["energy"],
    );
    assert!(r.outcome("energy").unwrap().summary.contains("1.2000"));
}

#[test]
fn mislabelled_sampler_fails_chi2() {
    // weights agree with the claimed pdf, so only the χ² test can see the lie
    expect_failures(
        &Toy {
            rho: 0.5,
            wrong_pdf: true,
            ..Default::default()
        },
        &["sampling-chi2"],
    );
}

#[test]
fn inconsistent_weights_fail_sample_weights() {
    expect_failures(
        &Toy {
            rho: 0.5,
            heavy_weight: true,
            ..Default::default()
        },
        &["sample-weights"],
    );
}

#[test]
fn nan_fails_non_negative() {
    let m = Toy {
        rho: 0.5,
        nan_at_grazing: true,
        ..Default::default()
    };
    let r = suite::run_suite(&m, &config(), &|_, _| {});
    let o = r.outcome("non-negative").unwrap();
    assert_eq!(o.verdict, Verdict::Fail, "{}", show(&r));
    assert!(o.details[0].contains("NaN"), "{:?}", o.details);
}

#[test]
fn library_models_pass() {
    for spec in [
        "diffuse reflectance=0.7",
        "roughconductor material=Cu alpha=0.2 distribution=ggx",
        "roughconductor alpha_u=0.05 alpha_v=0.3 distribution=beckmann",
        "roughdielectric distribution=ggx alpha=0.3 int_ior=1.5",
        "roughplastic distribution=ggx alpha=0.1 diffuse_reflectance=0.6,0.15,0.1",
        "twosided { roughconductor distribution=ggx alpha=0.3 }",
        "dielectric",
        "conductor material=Au",
    ] {
        let b = parse_spec(spec).unwrap();
        let r = suite::run_suite(&b, &config(), &|_, _| {});
        println!("{spec}\n{}\n", show(&r));
        assert!(r.passed(), "{spec}:\n{}", show(&r));
        let transmissive = spec.contains("dielectric") || spec.starts_with("twosided");
        assert_eq!(
            r.angles.len(),
            if transmissive { 8 } else { 4 },
            "{spec}: angles {:?}",
            r.angles
        );
    }
}

#[test]
fn dirac_materials_use_the_lobe_selection_test() {
    let b = parse_spec("dielectric int_ior=1.5").unwrap();
    let r = suite::run_suite(&b, &config(), &|_, _| {});
    assert!(r.outcome("sampling-chi2").is_none());
    let lobe = r.outcome("lobe-selection").unwrap();
    assert_eq!(lobe.verdict, Verdict::Pass, "{}", show(&r));
    assert_eq!(r.outcome("reciprocity").unwrap().verdict, Verdict::Skip);
    assert_eq!(r.outcome("sample-weights").unwrap().verdict, Verdict::Skip);
    assert!(r.chi2_bins.is_none());
}

#[test]
fn report_is_deterministic_across_thread_counts() {
    let b = parse_spec("roughplastic distribution=beckmann alpha=0.2").unwrap();
    let run = |threads| {
        let cfg = SuiteConfig {
            samples: 20_000,
            threads,
            ..config()
        };
        show(&suite::run_suite(&b, &cfg, &|_, _| {}))
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn surface_wrappers_pass() {
    // mask and null: every check applies (null: lobe selection)
    for spec in [
        "mask opacity=0.3 { diffuse reflectance=0.7 }",
        "mask opacity=0.6 { roughconductor material=Cu alpha=0.2 distribution=ggx }",
        "null",
    ] {
        let b = parse_spec(spec).unwrap();
        let r = suite::run_suite(&b, &config(), &|_, _| {});
        assert!(r.passed(), "{spec}:\n{}", show(&r));
    }
    // bump and normal maps: not reciprocal (as in Mitsuba), everything else holds on the
    // default shading point's flat frame
    let mut p = specula_bsdf::Props::new("bumpmap", None);
    p.set(
        "height",
        specula_bsdf::Value::Texture(std::sync::Arc::new(Slope)),
        None,
    )
    .unwrap();
    p.add_child(
        parse_spec("roughplastic distribution=ggx alpha=0.2").unwrap(),
        None,
    );
    let bump = specula_bsdf::build_bsdf(p).unwrap();
    let normal = parse_spec("normalmap normalmap=0.7,0.4,0.9 { roughconductor material=Au alpha=0.15 distribution=ggx }").unwrap();
    for b in [bump, normal] {
        let r = suite::run_suite(&b, &config(), &|_, _| {});
        let recip = r.outcome("reciprocity").unwrap();
        assert_eq!(recip.verdict, Verdict::Fail, "{}", show(&r));
        let cfg = SuiteConfig {
            reciprocity: suite::Reciprocity::Skip("perturbed frame".into()),
            ..config()
        };
        let r = suite::run_suite(&b, &cfg, &|_, _| {});
        assert!(r.passed(), "{}:\n{}", b.plugin_name(), show(&r));
        assert!(r.outcome("sampling-chi2").is_some());
    }
}
