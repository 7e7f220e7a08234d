//! Rendering a scene to an image: tiles in parallel (rayon), the scene's sampler restarted at
//! every pixel and sample (its values a function of seed, pixel, sample and dimension), blocks
//! merged in a fixed order — the image depends only on the seed, never on the number of
//! threads. The camera takes sample dimensions 0 (the film position) and 1 (a thin lens's aperture
//! sample), the integrator dimensions 2 onwards.
//! Integrators with AOVs fill extra channels, filtered like the image; when an AOV needs the
//! camera ray's differentials (`duv_dx`, `duv_dy`), they are computed as Mitsuba's sensors
//! compute them (see `ray_differentials`), and only then.

use crate::accel::Intersector;
use crate::camera::Camera;
use crate::core::{Hit, Ray};
use crate::film::{Film, ImageBlock};
use crate::integrator::{Counters, RayDifferentials};
use crate::sampler::{
    Independent, LowDiscrepancy, MultiJitter, Orthogonal, PixelSampler, SamplerKind, Sobol,
    Stratified,
};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use specula_bsdf::Rgb;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Tile edge in pixels.
pub const TILE: usize = 32;
/// Camera rays traced together.
const PACKET: usize = 8;

#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// Samples per pixel asked for; the scene's sampler may round it up (see
    /// [`crate::sampler::SamplerSettings::sample_count`]).
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
    /// Samples per pixel taken (`RenderOptions::spp` as the sampler rounded it).
    pub spp: u32,
    /// Extra channels of an AOV integrator: (name, one value per pixel, row-major).
    pub aovs: Vec<(String, Vec<f32>)>,
    /// Pixels whose sums overflowed `f32` (radiance near 3.4e38): black in `rgb`, never ±∞;
    /// a caller should report them (the CLI refuses to write such an image).
    pub overflowed: usize,
}

/// The image block of a tile and the blocks of its AOV channels (three per block).
struct TileBlocks {
    image: ImageBlock,
    aovs: Vec<ImageBlock>,
}

/// Which of a pixel's samples a pass takes: indices `first .. first + count`, each splatted
/// with weight `weight` (a uniform render: 0, spp, 1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PixelSamples {
    pub first: u32,
    pub count: u32,
    pub weight: f32,
}

/// What a pilot pass gathers per pixel for adaptive sampling ([`crate::adaptive`]): the sums
/// of the pixel's own sample values (before filtering) over the first and the second half of
/// its samples, and how many of each were finite.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct PixelStats {
    pub sum: [[f32; 3]; 2],
    pub n: [u32; 2],
}

impl PixelStats {
    #[inline]
    fn add(&mut self, half: usize, l: Rgb) {
        for c in 0..3 {
            self.sum[half][c] += l.0[c];
        }
        self.n[half] += 1;
    }
}

/// What one pass over the film returns.
pub(crate) struct Pass {
    pub film: Film,
    pub aov_films: Vec<Film>,
    pub counters: Counters,
    pub complete: bool,
    /// Each film pixel's relative error estimate ([`PixelStats::relative_error`], row-major),
    /// when the pass gathered statistics.
    pub errors: Vec<f32>,
}

/// Settings of one pass: the sample count the sampler is built for (a progressive sampler's
/// largest count when a pixel's samples come in two passes), the count the ray differentials
/// are scaled for, and where a pilot pass splits a pixel's samples into halves (`None`: no
/// [`PixelStats`]).
#[derive(Clone, Copy)]
pub(crate) struct PassSettings {
    pub sampler_spp: u32,
    pub differential_spp: u32,
    pub seed: u64,
    pub stats_half: Option<u32>,
    /// Tile edge in pixels (smaller tiles balance the threads' work when pixels take very
    /// different numbers of samples).
    pub tile: usize,
}

#[allow(clippy::too_many_arguments)]
fn render_tile<S: PixelSampler, P: Fn(usize) -> PixelSamples>(
    scene: &Scene,
    sampler: &mut S,
    settings: PassSettings,
    plan: &P,
    aov_count: usize,
    (x0, y0, w, h): (usize, usize, usize, usize),
    stats: &mut [PixelStats],
) -> (TileBlocks, Counters) {
    let film = &scene.film;
    let mut block = film.new_block(x0, y0, w, h);
    let mut aov_blocks: Vec<ImageBlock> = (0..aov_count.div_ceil(3))
        .map(|_| film.new_block(x0, y0, w, h))
        .collect();
    let mut aov = vec![0.0f32; aov_blocks.len() * 3];
    let integrator = &scene.integrator;
    let mut c = Counters::default();
    let inv = Vec2::new(1.0 / film.width as f32, 1.0 / film.height as f32);
    let mut pos = [Vec2::ZERO; PACKET];
    let mut rays = [Ray {
        o: Vec3::ZERO,
        d: Vec3::Z,
        t_max: 0.0,
    }; PACKET];
    let mut hits: [Option<Hit>; PACKET] = [None; PACKET];
    let differentials = integrator.needs_differentials();
    let mut diffs = [RayDifferentials {
        o_x: Vec3::ZERO,
        d_x: Vec3::Z,
        o_y: Vec3::ZERO,
        d_y: Vec3::Z,
    }; PACKET];
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let index = y * film.width + x;
            let PixelSamples {
                first,
                count,
                weight,
            } = plan(index);
            if count == 0 {
                continue;
            }
            sampler.start_pixel_from(index as u64, first);
            let wl_offset = scene
                .spectral
                .then(|| crate::spectral::pixel_offset(sampler));
            let stat = settings
                .stats_half
                .map(|half| (half, (y - y0) * w + (x - x0)));
            // the pixel's camera rays are traced in packets of up to 8 (they are coherent),
            // then each path goes on alone
            let mut done = 0;
            while done < count {
                let n = (count - done).min(PACKET as u32) as usize;
                for i in 0..n {
                    sampler.start_sample(first + done + i as u32, 0);
                    pos[i] = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                    // a thin lens draws its aperture sample next; a pinhole draws none
                    let mut aperture = Vec2::splat(0.5);
                    rays[i] = scene.camera.sample_ray(pos[i] * inv, || {
                        aperture = sampler.next_2d();
                        aperture
                    });
                    if differentials {
                        diffs[i] = ray_differentials(
                            scene,
                            rays[i],
                            pos[i],
                            inv,
                            aperture,
                            settings.differential_spp,
                        );
                    }
                }
                scene.accel.intersect_packet(&rays[..n], &mut hits[..n]);
                for i in 0..n {
                    let sample = first + done + i as u32;
                    // dimension 0: film position, 1: aperture (thin lens); the integrator
                    // starts at 2 whatever the camera, so that the two never share one
                    let u_wl = wl_offset.map(|o| crate::spectral::wavelength_u(o, sample));
                    sampler.start_sample(sample, 2);
                    let l = match u_wl {
                        Some(u) => scene.sample_spectral(
                            integrator,
                            rays[i],
                            differentials.then_some(&diffs[i]),
                            hits[i].take(),
                            sampler,
                            &mut c,
                            u,
                            &mut aov,
                        ),
                        None => scene.sample_differential(
                            integrator,
                            rays[i],
                            differentials.then_some(&diffs[i]),
                            hits[i].take(),
                            sampler,
                            &mut c,
                            &mut aov,
                        ),
                    };
                    c.samples += 1;
                    if l.is_finite() {
                        block.put_weighted(pos[i], l, weight);
                        for (k, b) in aov_blocks.iter_mut().enumerate() {
                            let v = Rgb([aov[3 * k], aov[3 * k + 1], aov[3 * k + 2]]);
                            b.put_weighted(pos[i], v, weight);
                        }
                        if let Some((half, at)) = stat {
                            stats[at].add((sample >= half) as usize, l);
                        }
                    } else {
                        c.invalid += 1;
                    }
                }
                done += n as u32;
            }
        }
    }
    (
        TileBlocks {
            image: block,
            aovs: aov_blocks,
        },
        c,
    )
}

/// The differentials of the camera ray `ray` through film position `pos` (pixels; `inv` =
/// 1 / film size) with aperture sample `aperture`, as Mitsuba's sensors'
/// `sample_ray_differential` make them, scaled by 1/√spp as Mitsuba's sampling integrators
/// do (checked against Mitsuba 3.9.1's `sample_ray_differential`): the differential rays are
/// the rays through the film position one pixel over (through the same aperture point), except
/// that the pinhole camera keeps the primary ray's origin for them (Mitsuba's `perspective`
/// sets `o_x = o_y = o`; its `thinlens` and `orthographic` start each differential ray at its
/// own origin).
fn ray_differentials(
    scene: &Scene,
    ray: Ray,
    pos: Vec2,
    inv: Vec2,
    aperture: Vec2,
    spp: u32,
) -> RayDifferentials {
    let step = |d: Vec2| {
        let r = scene.camera.sample_ray((pos + d) * inv, || aperture);
        match scene.camera {
            Camera::Perspective(_) => (ray.o, r.d),
            Camera::ThinLens(_) | Camera::Orthographic(_) => (r.o, r.d),
        }
    };
    let ((o_x, d_x), (o_y, d_y)) = (step(Vec2::X), step(Vec2::Y));
    RayDifferentials { o_x, d_x, o_y, d_y }.scaled(ray.o, ray.d, 1.0 / (spp as f32).sqrt())
}

/// Render with progress reports (`progress(tiles_done, tiles_total)`) and a stop flag that
/// interrupts between tiles.
pub fn render(
    scene: &Scene,
    opts: &RenderOptions,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> RenderOutput {
    match scene.sampler.kind {
        SamplerKind::Independent => render_with::<Independent>(scene, opts, stop, progress),
        SamplerKind::Stratified => render_with::<Stratified>(scene, opts, stop, progress),
        SamplerKind::MultiJitter => render_with::<MultiJitter>(scene, opts, stop, progress),
        SamplerKind::Orthogonal => render_with::<Orthogonal>(scene, opts, stop, progress),
        SamplerKind::LowDiscrepancy => render_with::<LowDiscrepancy>(scene, opts, stop, progress),
        SamplerKind::Sobol => render_with::<Sobol>(scene, opts, stop, progress),
    }
}

/// Runs `f` on a pool of `threads` workers (0: rayon's global pool, all cores).
pub(crate) fn in_pool<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    if threads > 0 {
        if let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
            return pool.install(f);
        }
    }
    f()
}

/// The film's tiles of `size` × `size` pixels (top-left corners), in the order their blocks
/// are merged.
pub(crate) fn tiles(scene: &Scene, size: usize) -> Vec<(usize, usize)> {
    let (fw, fh) = (scene.film.width, scene.film.height);
    (0..fh.div_ceil(size))
        .flat_map(|ty| (0..fw.div_ceil(size)).map(move |tx| (tx * size, ty * size)))
        .collect()
}

/// One pass over the film: every pixel takes the samples `plan` gives it; tiles in parallel
/// on the current pool, blocks merged in a fixed order (the result does not depend on the
/// thread count). `progress(n)` is told after each tile (n = tiles done in this pass).
pub(crate) fn render_pass<S: PixelSampler, P: Fn(usize) -> PixelSamples + Sync>(
    scene: &Scene,
    settings: PassSettings,
    plan: &P,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize) + Sync),
) -> Pass {
    let aov_count = scene.integrator.aov_channels().len();
    let (fw, fh) = (scene.film.width, scene.film.height);
    let size = settings.tile;
    let tiles = tiles(scene, size);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let blocks = tiles
        .par_iter()
        .map(|&(x0, y0)| {
            if stop.load(Ordering::Relaxed) {
                return None;
            }
            let mut sampler = S::new(&scene.sampler, settings.sampler_spp, settings.seed);
            let rect = (x0, y0, size.min(fw - x0), size.min(fh - y0));
            let mut stats =
                vec![PixelStats::default(); settings.stats_half.map_or(0, |_| rect.2 * rect.3)];
            let r = render_tile(
                scene,
                &mut sampler,
                settings,
                plan,
                aov_count,
                rect,
                &mut stats,
            );
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            let errors: Vec<f32> = stats.iter().map(PixelStats::relative_error).collect();
            Some((r, errors))
        })
        .collect::<Vec<_>>();
    let mut pass = Pass {
        film: scene.film.clone(),
        aov_films: vec![scene.film.clone(); aov_count.div_ceil(3)],
        counters: Counters::default(),
        complete: true,
        errors: vec![0.0; settings.stats_half.map_or(0, |_| fw * fh)],
    };
    for (b, &(x0, y0)) in blocks.into_iter().zip(&tiles) {
        match b {
            Some(((blocks, c), errors)) => {
                pass.film.merge(&blocks.image);
                for (f, b) in pass.aov_films.iter_mut().zip(&blocks.aovs) {
                    f.merge(b);
                }
                pass.counters.add(&c);
                let w = size.min(fw - x0);
                for (k, row) in errors.chunks_exact(w.max(1)).enumerate() {
                    let at = (y0 + k) * fw + x0;
                    pass.errors[at..at + w].copy_from_slice(row);
                }
            }
            None => pass.complete = false,
        }
    }
    pass
}

/// Develops the image and AOV films of a render into its output.
pub(crate) fn output(
    scene: &Scene,
    (rgb, overflowed): (Vec<f32>, usize),
    developed_aovs: Vec<Vec<f32>>,
    counters: Counters,
    start: Instant,
    complete: bool,
    spp: u32,
) -> RenderOutput {
    let aovs = scene
        .integrator
        .aov_channels()
        .into_iter()
        .enumerate()
        .map(|(k, name)| {
            let (plane, ch) = (&developed_aovs[k / 3], k % 3);
            (name, plane.iter().skip(ch).step_by(3).copied().collect())
        })
        .collect();
    RenderOutput {
        width: scene.film.width,
        height: scene.film.height,
        rgb,
        counters,
        elapsed: start.elapsed(),
        complete,
        spp,
        aovs,
        overflowed,
    }
}

pub(crate) fn render_with<S: PixelSampler>(
    scene: &Scene,
    opts: &RenderOptions,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> RenderOutput {
    let start = Instant::now();
    let spp = scene.sampler.sample_count(opts.spp);
    let total = tiles(scene, TILE).len();
    let settings = PassSettings {
        sampler_spp: spp,
        differential_spp: spp,
        seed: opts.seed,
        stats_half: None,
        tile: TILE,
    };
    let plan = |_| PixelSamples {
        first: 0,
        count: spp,
        weight: 1.0,
    };
    let pass = in_pool(opts.threads, || {
        render_pass::<S, _>(scene, settings, &plan, stop, &|n| progress(n, total))
    });
    let aovs = pass.aov_films.iter().map(|f| f.develop()).collect();
    output(
        scene,
        pass.film.develop_counting(),
        aovs,
        pass.counters,
        start,
        pass.complete,
        spp,
    )
}
