//! The image depends only on the scene and the seed (not on the thread count); the stop flag
//! interrupts a render; tracing a path never touches the heap (allocations are counted on
//! the tracing thread only, since the other tests run concurrently).

use specula_render::accel::Intersector;
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

struct Counting;
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
thread_local! {
    // const-initialised: reading it never allocates
    static COUNTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
}
#[global_allocator]
static GLOBAL: Counting = Counting;

fn scene(name: &str, overrides: &[(&str, &str)]) -> Option<Scene> {
    let p = specula_testdata::shared(&format!("scenes/{name}"))?;
    let o: Vec<(String, String)> = overrides
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    Some(Scene::load(&p, &o).unwrap())
}

#[test]
fn same_seed_same_image_whatever_the_thread_count() {
    let Some(s) = scene("veach_mis.xml", &[("resx", "96"), ("resy", "64")]) else {
        return;
    };
    let stop = AtomicBool::new(false);
    let run = |threads, seed| {
        render(
            &s,
            &RenderOptions {
                spp: 4,
                seed,
                threads,
            },
            &stop,
            &|_, _| {},
        )
        .rgb
    };
    let one = run(1, 3);
    let two = run(2, 3);
    assert!(
        one.iter()
            .zip(&two)
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "thread count changed the image"
    );
    let other = run(2, 4);
    assert!(one != other, "the seed has no effect");
}

#[test]
fn stop_flag_interrupts_the_render() {
    let Some(s) = scene("cbox.xml", &[("resx", "64"), ("resy", "64")]) else {
        return;
    };
    let out = render(
        &s,
        &RenderOptions {
            spp: 1,
            seed: 0,
            threads: 1,
        },
        &AtomicBool::new(true),
        &|_, _| {},
    );
    assert!(!out.complete);
    assert_eq!(out.counters.samples, 0);
}

#[test]
fn tracing_paths_does_not_allocate() {
    for name in [
        "cbox.xml",
        "meshes.xml",
        "envmap_spheres.xml",
        "mat_rough_glass.xml",
    ] {
        let Some(s) = scene(name, &[]) else { return };
        let mut rng = specula_bsdf::rng::Pcg32::new(1, 1);
        let mut c = specula_render::integrator::Counters::default();
        let mut acc = 0.0f32;
        COUNTING.with(|c| c.set(true));
        let before = ALLOCATIONS.load(Ordering::SeqCst);
        for i in 0..2000 {
            let u = glam::Vec2::new((i % 50) as f32 / 50.0 + 0.01, (i / 50) as f32 / 40.0 + 0.01);
            acc += s.li(s.camera.ray(u), &mut rng, &mut c).r();
        }
        // as the renderer traces them: a pixel's camera rays as one packet
        let mut hits = [None; 8];
        for i in 0..250 {
            let base = glam::Vec2::new((i % 25) as f32 / 25.0, (i / 25) as f32 / 10.0);
            let rays: [specula_render::core::Ray; 8] =
                std::array::from_fn(|_| s.camera.ray(base + rng.next_vec2() * 0.01));
            s.accel.intersect_packet(&rays, &mut hits);
            for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
                acc += s.li_from(*ray, hit.take(), &mut rng, &mut c).r();
            }
        }
        let after = ALLOCATIONS.load(Ordering::SeqCst);
        COUNTING.with(|c| c.set(false));
        assert!(acc.is_finite());
        assert_eq!(
            after - before,
            0,
            "{name}: {} allocations in 4000 paths",
            after - before
        );
    }
}

#[test]
fn every_sampler_gives_the_same_image_whatever_the_thread_count() {
    use specula_render::sampler::{SamplerKind, SamplerSettings};
    let Some(mut s) = scene("cbox.xml", &[("resx", "48"), ("resy", "40")]) else {
        return;
    };
    let stop = AtomicBool::new(false);
    for name in SamplerKind::NAMES {
        s.sampler = SamplerSettings::new(SamplerKind::parse(name).unwrap(), 4);
        let run = |threads| {
            render(
                &s,
                &RenderOptions {
                    spp: 4,
                    seed: 1,
                    threads,
                },
                &stop,
                &|_, _| {},
            )
        };
        let (one, two) = (run(1), run(2));
        assert_eq!(one.spp, s.sampler.sample_count(4));
        assert!(
            one.rgb
                .iter()
                .zip(&two.rgb)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{name}: thread count changed the image"
        );
    }
}
