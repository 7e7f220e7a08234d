//! Agreement of `bumpmap`, `normalmap` and `mask` with Mitsuba 3.9.1, on the fixture written
//! by `scripts/gen_perturbed_fixture.py` (`tests/data/perturbed_fixture.txt`): every case is a
//! nested BSDF (diffuse, rough copper, smooth gold) wrapped with given parameters at a shading
//! point with given ∂p/∂u, ∂p/∂v and geometric normal (Mitsuba's shading frame is the identity
//! there, so its world coordinates are Specula's local ones).
//!
//! - `eval` lines: Specula's `eval_cos` (Mitsuba's eval includes |cosθo|) and `pdf` must agree
//!   to 2e-4 relative (the perturbed frames are built from rounded float32 vectors on both
//!   sides, in a different order of operations).
//! - `sample` lines: for the Dirac nested conductor, or the null lobe of `mask`, the sample is
//!   deterministic: direction, pdf and weight are compared. Otherwise the warps differ, and
//!   Specula's `pdf` and `eval_cos / pdf` at Mitsuba's sampled direction must give Mitsuba's
//!   sample pdf and weight (where Mitsuba's warp produced a direction its model rejects, the
//!   case is not comparable and skipped).
//!
//! Bump maps: the fixture records Mitsuba's own `eval_1_grad` of its bitmap at the lookup
//! point; here a texture returning that gradient stands in for the bitmap (the bitmap's
//! gradient itself is tested against Mitsuba in specula-render's `texture.rs`).

use glam::{Vec2, Vec3};
use specula_bsdf::{
    build_bsdf, parse_spec, Bsdf, BsdfContext, BsdfModel, Props, ShadingPoint, Spectrum, Texture,
    Value,
};
use std::sync::Arc;

const FIXTURE: &str = include_str!("data/perturbed_fixture.txt");
const REL_TOL: f32 = 2e-4;
const ABS_FLOOR: f32 = 1e-6;

/// A texture that only provides a fixed gradient.
#[derive(Debug)]
struct Gradient(Vec2);

impl Texture for Gradient {
    fn eval(&self, _: &ShadingPoint) -> Spectrum {
        Spectrum::ZERO
    }
    fn mean(&self) -> Spectrum {
        Spectrum::ZERO
    }
    fn eval_1_grad(&self, _: &ShadingPoint) -> Option<Vec2> {
        Some(self.0)
    }
}

fn nums(words: &[&str]) -> Vec<f32> {
    words.iter().map(|w| w.parse::<f32>().unwrap()).collect()
}

fn v3(x: &[f32]) -> Vec3 {
    Vec3::new(x[0], x[1], x[2])
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= REL_TOL * a.abs().max(b.abs()) + ABS_FLOOR
}

fn close_rgb(a: Spectrum, b: &[f32]) -> bool {
    (0..3).all(|i| close(a[i], b[i]))
}

struct Case {
    label: String,
    bsdf: Bsdf,
    sp: ShadingPoint<'static>,
    delta: bool,
    mask: bool,
}

fn build(kind: &[&str], nested_spec: &str) -> (Bsdf, ShadingPoint<'static>) {
    let nested = parse_spec(nested_spec).unwrap();
    let mut sp = ShadingPoint::default();
    let mut p = Props::new(kind[0], None);
    let x = nums(&kind[1..]);
    match kind[0] {
        "bump" => {
            p = Props::new("bumpmap", None);
            p.set("scale", Value::Float(x[0] as f64), None).unwrap();
            p.set("flip_invalid_normals", Value::Bool(x[1] != 0.0), None)
                .unwrap();
            p.set("use_shadowing_function", Value::Bool(x[2] != 0.0), None)
                .unwrap();
            let tex: Arc<dyn Texture> = Arc::new(Gradient(Vec2::new(x[3], x[4])));
            p.set("height", Value::Texture(tex), None).unwrap();
            sp.dp_du = v3(&x[5..8]);
            sp.dp_dv = v3(&x[8..11]);
            sp.n_geo = v3(&x[11..14]);
        }
        "normal" => {
            p = Props::new("normalmap", None);
            p.set("flip_invalid_normals", Value::Bool(x[0] != 0.0), None)
                .unwrap();
            p.set("use_shadowing_function", Value::Bool(x[1] != 0.0), None)
                .unwrap();
            p.set(
                "normalmap",
                Value::Rgb(Spectrum::new(x[2], x[3], x[4])),
                None,
            )
            .unwrap();
        }
        "mask" => {
            p.set("opacity", Value::Float(x[0] as f64), None).unwrap();
        }
        other => panic!("unknown case kind {other}"),
    }
    p.add_child(nested, None);
    (build_bsdf(p).unwrap(), sp)
}

#[test]
fn perturbed_models_agree_with_mitsuba() {
    let ctx = BsdfContext::RADIANCE;
    let mut case: Option<Case> = None;
    let mut nested_spec = String::new();
    let mut nested_name = String::new();
    let (mut evals, mut samples, mut failures) = (0, 0, Vec::new());
    for line in FIXTURE.lines() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let w: Vec<&str> = line.split_whitespace().collect();
        match w[0] {
            "nested" => {
                nested_name = w[1].to_string();
                nested_spec = w[2..].join(" ");
            }
            "bump" | "normal" | "mask" => {
                let (bsdf, sp) = build(&w, &nested_spec);
                case = Some(Case {
                    label: format!("{line} [{nested_name}]"),
                    bsdf,
                    sp,
                    delta: nested_name == "conductor",
                    mask: w[0] == "mask",
                });
            }
            "eval" => {
                let c = case.as_ref().unwrap();
                let x = nums(&w[1..]);
                let (wi, wo) = (v3(&x[0..3]), v3(&x[3..6]));
                let v = c.bsdf.eval_cos(&ctx, &c.sp, wi, wo);
                let pdf = c.bsdf.pdf(&ctx, &c.sp, wi, wo);
                evals += 1;
                if !close_rgb(v, &x[6..9]) || !close(pdf, x[9]) {
                    failures.push(format!(
                        "{}: wi {wi} wo {wo}: eval {v:?} pdf {pdf}, Mitsuba {:?} {}",
                        c.label,
                        &x[6..9],
                        x[9]
                    ));
                }
            }
            "sample" => {
                let c = case.as_ref().unwrap();
                let x = nums(&w[1..]);
                let wi = v3(&x[0..3]);
                let (s1, s2) = (x[3], Vec2::new(x[4], x[5]));
                let (wo_m, pdf_m, w_m) = (v3(&x[6..9]), x[9], &x[10..13]);
                let s = c.bsdf.sample(&ctx, &c.sp, wi, s1, s2);
                samples += 1;
                let null_lobe = c.mask && pdf_m > 0.0 && (wo_m + wi).length() < 1e-5;
                let ok = if pdf_m == 0.0 && !c.delta {
                    // Mitsuba's warp gave a direction its model rejects; Specula's warp gives
                    // another direction: nothing to compare
                    samples -= 1;
                    true
                } else if pdf_m == 0.0 {
                    // a deterministic sample Mitsuba rejects: Specula must reject it too
                    s.is_none_or(|s| s.weight.is_black())
                } else if c.delta || null_lobe {
                    s.is_some_and(|s| {
                        (s.wo - wo_m).abs().max_element() < 1e-4
                            && close(s.pdf, pdf_m)
                            && close_rgb(s.weight, w_m)
                    })
                } else {
                    let pdf = c.bsdf.pdf(&ctx, &c.sp, wi, wo_m);
                    let f = c.bsdf.eval_cos(&ctx, &c.sp, wi, wo_m);
                    close(pdf, pdf_m) && pdf > 0.0 && close_rgb(f / pdf, w_m)
                };
                if !ok {
                    failures.push(format!(
                        "{}: sample wi {wi} s1 {s1} s2 {s2}: Specula {s:?}; Mitsuba wo {wo_m} pdf {pdf_m} weight {w_m:?}",
                        c.label
                    ));
                }
            }
            other => panic!("unknown fixture line {other}"),
        }
    }
    assert!(
        evals > 600 && samples > 250,
        "{evals} evals, {samples} samples"
    );
    assert!(
        failures.is_empty(),
        "{} of {} comparisons disagree:\n{}",
        failures.len(),
        evals + samples,
        failures.join("\n")
    );
}
