//! Adaptive sampling (`specula_render::adaptive`): deterministic whatever the thread count,
//! the sample budget kept, the expected image that of a uniform render, and less error than a
//! uniform render with as many samples where the noise is concentrated (`veach_mis`'s glossy
//! highlights).

use specula_render::adaptive::render_adaptive;
use specula_render::metrics::{self, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::sampler::SamplerKind;
use specula_render::scene::Scene;
use std::sync::atomic::AtomicBool;

fn veach(w: u32, h: u32) -> Option<Scene> {
    let p = specula_testdata::shared("scenes/veach_mis.xml")?;
    let o = vec![
        ("resx".to_string(), w.to_string()),
        ("resy".to_string(), h.to_string()),
    ];
    let mut s = Scene::load(&p, &o).unwrap();
    s.sampler.kind = SamplerKind::Sobol;
    Some(s)
}

fn opts(spp: u32, seed: u64, threads: usize) -> RenderOptions {
    RenderOptions { spp, seed, threads }
}

/// relMSE as `../shared/README.md` defines it (`specula_render::metrics::relmse`).
fn relmse(img: &[f32], reference: &[f32], (w, h): (usize, usize)) -> f64 {
    let image = |data: &[f32]| RgbImage {
        width: w,
        height: h,
        data: data.to_vec(),
    };
    metrics::relmse(&image(img), &image(reference))
}

#[test]
fn deterministic_and_within_budget() {
    let Some(s) = veach(96, 64) else { return };
    let stop = AtomicBool::new(false);
    let run = |threads, seed| render_adaptive(&s, &opts(16, seed, threads), &stop, &|_, _| {});
    let one = run(1, 3).unwrap();
    let two = run(2, 3).unwrap();
    assert!(one.complete && two.complete);
    assert!(
        one.rgb
            .iter()
            .zip(&two.rgb)
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "thread count changed the image"
    );
    assert_ne!(one.rgb, run(2, 4).unwrap().rgb, "the seed has no effect");
    // every sample taken is counted once: the budget is kept to within one sample
    assert!(
        one.counters.samples.abs_diff(16 * 96 * 64) <= 1,
        "{}",
        one.counters.samples
    );
    assert_eq!(one.spp, 16);
    // the stop flag interrupts it
    let out = render_adaptive(&s, &opts(16, 0, 1), &AtomicBool::new(true), &|_, _| {}).unwrap();
    assert!(!out.complete);
    assert_eq!(out.counters.samples, 0);
}

#[test]
fn refuses_samplers_that_are_not_progressive() {
    let Some(mut s) = veach(16, 8) else { return };
    s.sampler.kind = SamplerKind::Stratified;
    let e = render_adaptive(&s, &opts(16, 0, 1), &AtomicBool::new(false), &|_, _| {});
    assert!(e.err().unwrap().contains("progressive"));
}

/// Against a uniform 4096-spp render: the mean of four adaptive 64-spp images (seeds 1–4)
/// agrees within 1.5 % (it is the same expected image: each pixel's samples weigh the same in
/// total; the four-seed mean's spread, measured over seeds, is ≈ 0.3 %, so the bound is ≈ 5σ),
/// and at 32 spp the adaptive image's relMSE is below 0.6× the uniform render's (measured at
/// this size: 0.28× at seed 1, and 0.29–0.43× untrimmed over seeds 1–3; fixed seeds, so the
/// comparison is deterministic).
#[test]
fn same_expected_image_less_error() {
    let Some(s) = veach(64, 40) else { return };
    let stop = AtomicBool::new(false);
    let reference = render(&s, &opts(4096, 11, 0), &stop, &|_, _| {}).rgb;
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    let m_ad = (1..=4)
        .map(|seed| {
            let img = render_adaptive(&s, &opts(64, seed, 0), &stop, &|_, _| {});
            mean(&img.unwrap().rgb)
        })
        .sum::<f64>()
        / 4.0;
    let m_ref = mean(&reference);
    assert!((m_ad / m_ref - 1.0).abs() < 0.015, "{m_ad} vs {m_ref}");
    let uniform = render(&s, &opts(32, 1, 0), &stop, &|_, _| {}).rgb;
    let adaptive = render_adaptive(&s, &opts(32, 1, 0), &stop, &|_, _| {})
        .unwrap()
        .rgb;
    let size = (64, 40);
    let (e_u, e_a) = (
        relmse(&uniform, &reference, size),
        relmse(&adaptive, &reference, size),
    );
    assert!(e_a < 0.6 * e_u, "adaptive {e_a} vs uniform {e_u}");
}
