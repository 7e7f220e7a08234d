//! Error of each sampler at equal sample counts: relMSE (the conformance metric) against the
//! Mitsuba references in `../shared/reference`, for `independent`, Mitsuba's stratified
//! samplers and Specula's `sobol`.
//!
//!     cargo run --release -p specula-render --example bench_samplers -- \
//!         [--spp 16,64] [--scenes cbox,mat_rough_copper,veach_mis] [--seeds 1] [--threads 0]
//!
//! The sample count asked for is rounded by each sampler as Mitsuba does (orthogonal: 64 →
//! 121), so the table prints the count each one took, and the gain is relMSE(independent) /
//! relMSE(sampler) with `independent` rendered at that same count. The reference's own noise
//! bounds what can be measured (1024–4096 spp references).

use specula_render::image_io::read_image;
use specula_render::metrics::{relmse, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::sampler::{SamplerKind, SamplerSettings};
use specula_render::scene::Scene;
use std::sync::atomic::AtomicBool;

fn arg(args: &[String], name: &str, default: &str) -> String {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
        .unwrap_or_else(|| default.to_string())
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spps: Vec<u32> = arg(&args, "--spp", "16,64")
        .split(',')
        .map(|s| s.parse().expect("--spp: numbers"))
        .collect();
    let scenes = arg(&args, "--scenes", "cbox,mat_rough_copper,veach_mis");
    let seeds: u64 = arg(&args, "--seeds", "1")
        .parse()
        .expect("--seeds: a number");
    let threads: usize = arg(&args, "--threads", "0").parse().expect("--threads");
    let Some(shared) = specula_testdata::shared("") else {
        eprintln!("../shared not found");
        std::process::exit(1);
    };
    println!(
        "{:<18} {:>5} {:<12} {:>5} {:>11} {:>8} {:>7}",
        "scene", "spp", "sampler", "taken", "relMSE", "gain", "s"
    );
    for name in scenes.split(',') {
        let reference = read_image(&shared.join(format!("reference/{name}.exr")))
            .map(|(img, _)| RgbImage::from(&img))
            .expect("reference");
        let mut scene = Scene::load(&shared.join(format!("scenes/{name}.xml")), &[])
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            (scene.film.width, scene.film.height),
            (reference.width, reference.height)
        );
        // relMSE of independent by sample count
        let mut independent = std::collections::HashMap::new();
        let error = |scene: &mut Scene, kind, spp| {
            scene.sampler = SamplerSettings::new(kind, spp);
            let mut err = 0.0;
            let start = std::time::Instant::now();
            for seed in 0..seeds {
                let out = render(
                    scene,
                    &RenderOptions { spp, seed, threads },
                    &AtomicBool::new(false),
                    &|_, _| {},
                );
                let img = RgbImage {
                    width: out.width,
                    height: out.height,
                    data: out.rgb,
                };
                err += relmse(&img, &reference) / seeds as f64;
            }
            (err, start.elapsed().as_secs_f64() / seeds as f64)
        };
        for &spp in &spps {
            for kind in SamplerKind::NAMES
                .iter()
                .map(|n| SamplerKind::parse(n).unwrap())
            {
                let taken = SamplerSettings::new(kind, spp).sample_count(spp);
                let (err, secs) = error(&mut scene, kind, spp);
                if kind == SamplerKind::Independent {
                    independent.insert(taken, err);
                }
                let ind = match independent.get(&taken) {
                    Some(&e) => e,
                    None => {
                        let e = error(&mut scene, SamplerKind::Independent, taken).0;
                        independent.insert(taken, e);
                        e
                    }
                };
                let gain = ind / err;
                println!(
                    "{name:<18} {spp:>5} {:<12} {taken:>5} {err:>11.3e} {gain:>8.2} {secs:>7.1}",
                    kind.name()
                );
            }
        }
    }
}
