//! Start-up pieces timed in one process, for profiling the loader: each scene is loaded
//! `--loads` times (the phases of `specula render --timings`, least of the loads), then its
//! BVH is rebuilt `--builds` times on the loaded geometry (least and median). In-process
//! repeats reuse the allocator's memory, so they leave out the page faults a fresh process
//! pays; `specula render --timings` measures those.
//!
//!     cargo run --release -p specula-render --example bench_startup -- SCENE.xml... \
//!         [--loads 5] [--builds 20] [--threads 0]

use specula_render::accel::Bvh;
use specula_render::scene::Scene;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut scenes = vec![];
    let (mut loads, mut builds, mut threads) = (5usize, 20usize, 0usize);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut num = |what: &str| -> usize {
            it.next()
                .and_then(|v| v.parse().ok())
                .unwrap_or_else(|| panic!("{what} needs a number"))
        };
        match a.as_str() {
            "--loads" => loads = num("--loads"),
            "--builds" => builds = num("--builds"),
            "--threads" => threads = num("--threads"),
            s => scenes.push(s.to_string()),
        }
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global()
        .expect("thread pool");
    for s in &scenes {
        let mut best = [f64::INFINITY; 7];
        let mut scene = None;
        for _ in 0..loads.max(1) {
            specula_render::timings::reset();
            let t = Instant::now();
            let sc = Scene::load(std::path::Path::new(s), &[("spp".into(), "1".into())])
                .unwrap_or_else(|e| panic!("{s}: {e}"));
            let total = t.elapsed().as_secs_f64();
            for (i, (_, v)) in specula_render::timings::totals().iter().enumerate() {
                best[i] = best[i].min(*v);
            }
            best[6] = best[6].min(total);
            scene = Some(sc);
        }
        let scene = scene.expect("loaded");
        let phases: Vec<String> = specula_render::timings::Phase::ALL
            .iter()
            .zip(best)
            .map(|(p, v)| format!("{} {:.4}", p.name(), v))
            .collect();
        println!("{s}: load {:.4} s ({})", best[6], phases.join(", "));
        let mut times = vec![];
        for _ in 0..builds {
            let t = Instant::now();
            let bvh = Bvh::build(&scene.geometry);
            times.push(t.elapsed().as_secs_f64());
            std::hint::black_box(bvh);
        }
        times.sort_by(f64::total_cmp);
        if !times.is_empty() {
            println!(
                "  BVH over {} primitives: least {:.4} s, median {:.4} s, SAH cost {:.4}",
                scene.accel.primitive_count(),
                times[0],
                times[times.len() / 2],
                scene.accel.sah_cost()
            );
        }
    }
}
