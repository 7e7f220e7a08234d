//! `specula render SCENE.xml`: render a Mitsuba 3 scene.

use crate::output::CliError;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use specula_render::render::{render, RenderOptions};
use specula_render::sampler::SamplerKind;
use specula_render::scene::{LoadOptions, Scene};
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

#[derive(Debug, Args)]
pub struct RenderArgs {
    /// The scene (Mitsuba 3 XML).
    pub scene: PathBuf,
    /// Output image: `.exr` (linear float32 RGB, like Mitsuba's hdrfilm) or `.png` (sRGB 8-bit).
    /// Default: the scene's name with `.exr`, in the current directory.
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// Set a scene parameter declared with `<default>`, e.g. `-D spp=16` (repeatable).
    #[arg(short = 'D', value_name = "NAME=VALUE")]
    pub defines: Vec<String>,
    /// Render at another film size, WxH (e.g. `320x240`), with the same field of view: the
    /// image you would get by editing the film's `width`/`height` in the file (its crop
    /// window reset to the whole film).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Render as Mitsuba 3.9 does where it departs from its plugins' definitions (today:
    /// `blendbsdf` with a Dirac component loses energy in Mitsuba; see README, "Mitsuba
    /// compatibility"). Off by default: Specula follows the definitions.
    #[arg(long)]
    pub mitsuba_compat: bool,
    /// `rgb` (default: linear-sRGB channels, as Mitsuba's `*_rgb` variants) or `spectral`
    /// (three wavelengths per path, RGB values upsampled, the film developed through the CIE
    /// 1931 observer, as Mitsuba's `*_spectral` variants; see README, "Spectral mode").
    #[arg(long, value_name = "MODE", default_value = "rgb")]
    pub mode: String,
    /// Samples per pixel (overrides the scene's sampler).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Sampler (overrides the scene's, keeping its sample count and seed): independent,
    /// stratified, multijitter, orthogonal, ldsampler, or sobol (Specula's Owen-scrambled
    /// Sobol: the lowest error per sample; what a scene without `<sampler>` gets). Stratified
    /// samplers round the sample count as Mitsuba does.
    #[arg(long, value_name = "NAME")]
    pub sampler: Option<String>,
    /// Spend the samples adaptively: `--spp` (or the scene's count) becomes the mean per pixel;
    /// a pilot pass takes a quarter of them everywhere, the rest go where its error estimate is
    /// highest (see README, "Adaptive sampling"). Needs a progressive sampler (sobol, the
    /// default, or independent).
    #[arg(long)]
    pub adaptive: bool,
    /// Random seed (the image is a deterministic function of the seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Print where the time went: each loading phase (parse, meshes, textures, emitters,
    /// bsdfs, bvh, other), the start-up before the first sample, the render and the write.
    #[arg(long)]
    pub timings: bool,
}

pub fn run(args: &RenderArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let t_start = std::time::Instant::now();
    let mut defines = Vec::new();
    for d in &args.defines {
        let Some((k, v)) = d.split_once('=') else {
            return Err(CliError::usage(format!("-D expects NAME=VALUE, got '{d}'")));
        };
        defines.push((k.trim().to_string(), v.trim().to_string()));
    }
    let output = args.output.clone().unwrap_or_else(|| {
        PathBuf::from(args.scene.file_stem().unwrap_or_default()).with_extension("exr")
    });
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !matches!(ext.as_deref(), Some("exr") | Some("png")) {
        return Err(CliError::usage(format!(
            "{}: the output must end in .exr or .png",
            output.display()
        )));
    }
    let load = LoadOptions {
        size: args.size,
        mitsuba_compat: args.mitsuba_compat,
    };
    let mut scene = Scene::load_with(&args.scene, &defines, &load).map_err(CliError::usage)?;
    match args.mode.as_str() {
        "rgb" => {}
        "spectral" => scene.set_spectral(true).map_err(CliError::usage)?,
        m => {
            return Err(CliError::usage(format!(
                "--mode: unknown mode '{m}' (one of: rgb, spectral)"
            )))
        }
    }
    if let Some(name) = &args.sampler {
        scene.sampler.kind = SamplerKind::parse(name).ok_or_else(|| {
            CliError::usage(format!(
                "--sampler: unknown sampler '{name}' (one of: {})",
                SamplerKind::NAMES.join(", ")
            ))
        })?;
    }
    let opts = RenderOptions {
        spp: args.spp.unwrap_or(scene.sampler.sample_count),
        seed: args.seed,
        threads: args.threads,
    };
    if opts.spp == 0 {
        return Err(CliError::usage("--spp must be positive"));
    }
    scene
        .sampler
        .check(opts.spp)
        .map_err(|e| CliError::usage(format!("sampler '{}': {e}", scene.sampler.kind.name())))?;
    let spp = scene.sampler.sample_count(opts.spp);
    if ext.as_deref() == Some("png") && !scene.integrator.aov_channels().is_empty() {
        return Err(CliError::usage(format!(
            "{}: the scene's aov integrator writes extra channels: use .exr",
            output.display()
        )));
    }

    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // a second Ctrl-C kills the process the usual way
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    let (w, h) = (scene.film.width, scene.film.height);
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles  {msg}  ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = std::time::Instant::now();
    let startup = start - t_start;
    let samples_per_tile =
        (specula_render::render::TILE * specula_render::render::TILE) as f64 * spp as f64;
    let report = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        if !args.adaptive {
            let rate = done as f64 * samples_per_tile / start.elapsed().as_secs_f64().max(1e-9);
            bar.set_message(format!("{:.2} M samples/s", rate / 1e6));
        }
    };
    let result = if args.adaptive {
        specula_render::adaptive::render_adaptive(&scene, &opts, &stop, &report)
            .map_err(CliError::usage)?
    } else {
        render(&scene, &opts, &stop, &report)
    };
    bar.finish_and_clear();

    if result.overflowed > 0 {
        return Err(CliError::usage(format!(
            "{}: {} of {} pixels overflowed (values beyond the f32 range, 3.4e38): the scene's \
             light is too strong to store; nothing written",
            output.display(),
            result.overflowed,
            w * h
        )));
    }
    let write = match ext.as_deref() {
        Some("png") => specula_render::image_io::write_png(&output, w, h, &result.rgb),
        _ if !result.aovs.is_empty() => specula_render::image_io::write_exr_with_channels(
            &output,
            w,
            h,
            &result.rgb,
            &result.aovs,
        ),
        _ => specula_render::image_io::write_exr(&output, w, h, &result.rgb),
    };
    write.map_err(CliError::usage)?;
    let t_write = start.elapsed().saturating_sub(result.elapsed);
    let secs = result.elapsed.as_secs_f64();
    let c = result.counters;
    writeln!(
        out,
        "{}{}: {}×{} at {} spp ({}{}{}) in {:.2} s — {:.3} M samples/s, {:.3} M rays/s, {} NaN/Inf samples discarded{}",
        if result.complete { "" } else { "interrupted: " },
        output.display(),
        w,
        h,
        result.spp,
        scene.sampler.kind.name(),
        if args.adaptive { ", adaptive" } else { "" },
        if scene.spectral { ", spectral" } else { "" },
        secs,
        c.samples as f64 / secs / 1e6,
        c.rays as f64 / secs / 1e6,
        c.invalid,
        if result.complete { "" } else { " (unrendered tiles are black)" }
    )?;
    if args.timings {
        let phases = specula_render::timings::totals();
        let other = startup.as_secs_f64() - phases.iter().map(|p| p.1).sum::<f64>();
        let list: Vec<String> = phases
            .iter()
            .map(|(p, t)| format!("{} {t:.4} s", p.name()))
            .collect();
        writeln!(
            out,
            "timings: {}, other {:.4} s; start-up {:.4} s (before the first sample), render {:.4} s, write {:.4} s",
            list.join(", "),
            other.max(0.0),
            startup.as_secs_f64(),
            secs,
            t_write.as_secs_f64()
        )?;
    }
    Ok(())
}

/// Parses `--size WxH` (`x` or `×`; each side 1 … 65536).
fn parse_size(s: &str) -> Result<(usize, usize), String> {
    let bad = || format!("expected WIDTHxHEIGHT (e.g. 320x240), got '{s}'");
    let (w, h) = s.split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let w: usize = w.trim().parse().map_err(|_| bad())?;
    let h: usize = h.trim().parse().map_err(|_| bad())?;
    if !(1..=1 << 16).contains(&w) || !(1..=1 << 16).contains(&h) {
        return Err(format!(
            "each side of --size must lie in [1, 65536], got {w}x{h}"
        ));
    }
    Ok((w, h))
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn size_argument() {
        assert_eq!(parse_size("320x240"), Ok((320, 240)));
        assert_eq!(parse_size("64×48"), Ok((64, 48)));
        assert_eq!(parse_size("7X5"), Ok((7, 5)));
        for bad in ["320", "x240", "0x10", "10x0", "-3x4", "70000x2", "axb", ""] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
