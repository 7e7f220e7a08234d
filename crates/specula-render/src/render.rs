//! Rendering a scene to an image: tiles in parallel (rayon), one deterministic random stream
//! per pixel, blocks merged in a fixed order — the image depends only on the seed, never on
//! the number of threads.

use crate::accel::Intersector;
use crate::core::{Hit, Ray};
use crate::film::ImageBlock;
use crate::integrator::Counters;
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use specula_bsdf::rng::Pcg32;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Tile edge in pixels.
pub const TILE: usize = 32;
/// Camera rays traced together.
const PACKET: usize = 8;

#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub spp: u32,
    pub seed: u64,
    /// Worker threads (0 = all cores).
    pub threads: usize,
}

/// A finished (or interrupted) render.
pub struct RenderOutput {
    pub width: usize,
    pub height: usize,
    /// Linear RGB, row-major, top row first.
    pub rgb: Vec<f32>,
    pub counters: Counters,
    pub elapsed: Duration,
    /// False when the render was stopped early (tiles not rendered are black).
    pub complete: bool,
}

/// A 64-bit mix of the seed and the pixel index (SplitMix64 finaliser).
fn pixel_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed.wrapping_add(index.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn render_tile(
    scene: &Scene,
    opts: &RenderOptions,
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
) -> (ImageBlock, Counters) {
    let film = &scene.film;
    let mut block = film.new_block(x0, y0, w, h);
    let mut c = Counters::default();
    let inv = Vec2::new(1.0 / film.width as f32, 1.0 / film.height as f32);
    let mut pos = [Vec2::ZERO; PACKET];
    let mut rays = [Ray {
        o: Vec3::ZERO,
        d: Vec3::Z,
        t_max: 0.0,
    }; PACKET];
    let mut hits: [Option<Hit>; PACKET] = [None; PACKET];
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let index = (y * film.width + x) as u64;
            let mut rng = Pcg32::new(pixel_seed(opts.seed, index), index);
            // the pixel's camera rays are traced in packets of up to 8 (they are coherent),
            // then each path goes on alone
            let mut done = 0;
            while done < opts.spp {
                let n = (opts.spp - done).min(PACKET as u32) as usize;
                for i in 0..n {
                    pos[i] = Vec2::new(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                    rays[i] = scene.camera.sample_ray(pos[i] * inv, || rng.next_vec2());
                }
                scene.accel.intersect_packet(&rays[..n], &mut hits[..n]);
                for i in 0..n {
                    let l = scene.li_from(rays[i], hits[i].take(), &mut rng, &mut c);
                    c.samples += 1;
                    if l.is_finite() {
                        block.put(pos[i], l);
                    } else {
                        c.invalid += 1;
                    }
                }
                done += n as u32;
            }
        }
    }
    (block, c)
}

/// Render with progress reports (`progress(tiles_done, tiles_total)`) and a stop flag that
/// interrupts between tiles.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> RenderOutput {
    let start = Instant::now();
    let (fw, fh) = (scene.film.width, scene.film.height);
    let tiles: Vec<(usize, usize)> = (0..fh.div_ceil(TILE))
        .flat_map(|ty| (0..fw.div_ceil(TILE)).map(move |tx| (tx * TILE, ty * TILE)))
        .collect();
    let total = tiles.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let work = || {
        tiles
            .par_iter()
            .map(|&(x0, y0)| {
                if stop.load(Ordering::Relaxed) {
                    return None;
                }
                let r = render_tile(scene, opts, x0, y0, TILE.min(fw - x0), TILE.min(fh - y0));
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(n, total);
                Some(r)
            })
            .collect::<Vec<_>>()
    };
    let blocks = if opts.threads > 0 {
        match rayon::ThreadPoolBuilder::new()
            .num_threads(opts.threads)
            .build()
        {
            Ok(pool) => pool.install(work),
            Err(_) => work(),
        }
    } else {
        work()
    };
    let mut film = scene.film.clone();
    let mut counters = Counters::default();
    let mut complete = true;
    for b in blocks {
        match b {
            Some((block, c)) => {
                film.merge(&block);
                counters.add(&c);
            }
            None => complete = false,
        }
    }
    RenderOutput {
        width: fw,
        height: fh,
        rgb: film.develop(),
        counters,
        elapsed: start.elapsed(),
        complete,
    }
}
