//! `specula`: the command-line front end of the Specula material library.
//!
//! Every command is one variant of [`Command`] (and, for material commands, of
//! [`brdf::BrdfCommand`]), so new tools (`render`, `brdf plot`, `brdf check`, …) are added as
//! new variants with their own argument struct and module.

mod alloc;
mod brdf;
mod check;
mod fit;
mod fresnel;
mod gallery;
mod material;
mod multiscatter;
mod output;
mod phase;
mod plot;
mod render;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

use output::CliError;

#[global_allocator]
static ALLOC: alloc::HugePageAlloc = alloc::HugePageAlloc;

/// Specula: physically based materials (Mitsuba 3's BSDFs), evaluated, sampled and checked.
#[derive(Debug, Parser)]
#[command(name = "specula", version, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fresnel reflectance vs incidence angle: a dielectric (`--ior`) or a named conductor
    /// (`--material`); `specula fresnel plot …` draws it.
    Fresnel(fresnel::FresnelArgs),
    /// Render a Mitsuba 3 scene (XML) to OpenEXR or PNG, with the scene's integrator (`path`,
    /// `volpath` for participating media, `direct`, `depth`, `aov`).
    Render(render::RenderArgs),
    /// Render a labelled contact sheet (PNG) of material previews: every built-in preset and
    /// any materials given, each on a sphere on a checkerboard floor under a procedural sky
    /// (the absorbing-glass and subsurface presets fill the sphere with a medium: `volpath`).
    Gallery(gallery::GalleryArgs),
    /// Work with one material: a spec ("roughconductor material=Cu alpha=0.2"), an XML snippet,
    /// a MERL .binary or RGL .bsdf file, or scene.xml#id.
    Brdf {
        #[command(subcommand)]
        command: brdf::BrdfCommand,
    },
    /// Work with participating media's phase functions (isotropic, hg, rayleigh, blendphase),
    /// given as specs ("hg g=0.7") or XML snippets, without a scene.
    Phase {
        #[command(subcommand)]
        command: phase::PhaseCommand,
    },
}

fn run(cli: Cli, out: &mut dyn std::io::Write) -> Result<(), CliError> {
    match cli.command {
        Command::Fresnel(args) => fresnel::run(&args, out),
        Command::Brdf { command } => brdf::run(command, out),
        Command::Phase { command } => phase::run(command, out),
        Command::Render(args) => render::run(&args, out),
        Command::Gallery(args) => gallery::run(&args, out),
    }
}

/// Where the spectral upsampling table is kept between runs: `$SPECULA_CACHE_DIR` (empty: no
/// cache), else `$XDG_CACHE_HOME/specula`, else `$HOME/.cache/specula`.
fn cache_dir() -> Option<std::path::PathBuf> {
    use std::path::PathBuf;
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty());
    if let Some(v) = std::env::var_os("SPECULA_CACHE_DIR") {
        return (!v.is_empty()).then(|| PathBuf::from(v));
    }
    var("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| var("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .map(|d| d.join("specula"))
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // spectral mode's RGB → spectrum table (about 1.5 s of two cores to compute) is read from
    // there when a valid copy exists, and written there otherwise
    specula_bsdf::spectral::upsample::set_cache_dir(cache_dir());
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let result =
        run(cli, &mut out).and_then(|()| std::io::Write::flush(&mut out).map_err(Into::into));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => e.report(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cli_definition_is_consistent() {
        use clap::CommandFactory;
        Cli::command().debug_assert();
    }
}
