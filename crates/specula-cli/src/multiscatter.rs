//! `specula brdf multiscatter SPEC`: energy compensation before and after, against the exact
//! reference. For a `roughconductor`, `roughdielectric`, `roughplastic` or `principled` spec,
//! prints per
//! incidence angle the directional albedo (R + T, importance transport) of the single-
//! scattering model (`multiscatter=false`, Mitsuba's) and of the compensated one
//! (`multiscatter=true`), and, where the material has one, that of its exact reference, Heitz
//! et al.'s random walk on the microsurface (`specula_bsdf::models::microsurface_walk::
//! reference_for`: conductors, dielectrics, a principled white metal or clear glass, and a
//! roughplastic with a black base, whose reference is the walk's reflection alone) with the
//! lobe distance of each model to it (total variation between the binned energy
//! distributions; the `noise` column is its value for identical lobes at this sample count).

use std::io::Write;

use clap::Args;
use specula_bsdf::check;
use specula_bsdf::models::microsurface_walk::{compare, compare_reflection, reference_for};
use specula_bsdf::{parse_spec, Bsdf, BsdfContext, ShadingPoint};

use crate::output::CliError;

#[derive(Debug, Args)]
pub struct MultiscatterArgs {
    /// A roughconductor, roughdielectric, roughplastic or principled spec, e.g.
    /// "roughconductor distribution=ggx alpha=1" (quoted, or as separate words); any
    /// `multiscatter=` in it is replaced
    #[arg(required = true, num_args = 1.., value_name = "SPEC")]
    pub material: Vec<String>,
    /// Incidence angles θi in degrees, comma separated (beyond 90° below the surface)
    #[arg(
        long,
        value_name = "DEG,…",
        value_delimiter = ',',
        default_value = "0,30,60,75,85",
        allow_negative_numbers = true
    )]
    pub angles: Vec<f32>,
    /// Samples per angle and model (the walk draws as many walks)
    #[arg(long, default_value_t = 200_000,
          value_parser = clap::value_parser!(u32).range(1000..=100_000_000))]
    pub samples: u32,
    /// Seed of the random numbers
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// The spec with `multiscatter=on`.
fn variant(spec: &str, on: bool) -> Result<Bsdf, CliError> {
    let words: Vec<&str> = spec
        .split_whitespace()
        .filter(|w| !w.starts_with("multiscatter="))
        .collect();
    if words.iter().any(|w| *w == "{" || w.starts_with('{')) {
        return Err(CliError::usage(
            "brdf multiscatter takes one roughconductor, roughdielectric, roughplastic or \
             principled spec, without nested plugins",
        ));
    }
    let s = format!("{} multiscatter={on}", words.join(" "));
    parse_spec(&s).map_err(CliError::usage)
}

fn fmt3(v: [f64; 3]) -> String {
    if (v[0] - v[1]).abs() < 5e-5 && (v[1] - v[2]).abs() < 5e-5 {
        format!("{:.4}", v[0])
    } else {
        format!("{:.4},{:.4},{:.4}", v[0], v[1], v[2])
    }
}

pub fn run(args: &MultiscatterArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let spec = args.material.join(" ");
    let before = variant(&spec, false)?;
    let after = variant(&spec, true)?;
    if !matches!(
        before,
        Bsdf::RoughConductor(_)
            | Bsdf::RoughDielectric(_)
            | Bsdf::RoughPlastic(_)
            | Bsdf::Principled(_)
    ) {
        return Err(CliError::usage(format!(
            "'{}' has no multiscatter option (roughconductor, roughdielectric, roughplastic, \
             principled)",
            before.plugin_name()
        )));
    }
    for &t in &args.angles {
        if !(t.is_finite() && (0.0..=180.0).contains(&t) && t != 90.0) {
            return Err(CliError::usage(format!(
                "--angles: {t} is not an incidence angle in [0, 180] other than 90"
            )));
        }
    }
    let reference = reference_for(&before);
    let n = args.samples as usize;
    writeln!(out, "material  {spec}")?;
    let (walk, reflection_only) = match &reference {
        Ok((w, r)) => (Some(w), *r),
        Err(_) => (None, false),
    };
    writeln!(
        out,
        "albedo {} (importance transport), {n} samples per angle{}",
        if reflection_only { "R" } else { "R+T" },
        match &reference {
            Ok((_, false)) =>
                "; lobe: distance to the random walk (total variation of the binned energy)"
                    .to_string(),
            Ok((_, true)) => "; reference: the random walk's reflection (its transmission \
                              absorbed by the black base); lobe: distance to it"
                .to_string(),
            Err(e) => format!("; no random walk: {e}"),
        }
    )?;
    let compare = |model: &Bsdf, w, wi, seed| {
        if reflection_only {
            compare_reflection(model, w, wi, n, seed)
        } else {
            compare(model, w, wi, n, seed)
        }
    };
    if walk.is_some() {
        writeln!(
            out,
            "{:>6}  {:<22} {:<22} {:<22} {:>9} {:>9} {:>7}",
            "θi",
            "single-scattering",
            "multiscatter=true",
            "random walk",
            "lobe ss",
            "lobe ms",
            "noise"
        )?;
    } else {
        writeln!(
            out,
            "{:>6}  {:<22} {:<22}",
            "θi", "single-scattering", "multiscatter=true"
        )?;
    }
    let ctx = BsdfContext::IMPORTANCE;
    let sp = ShadingPoint::default();
    for (k, &t) in args.angles.iter().enumerate() {
        let wi = check::suite::incidence(t);
        let seed = args.seed.wrapping_mul(1000).wrapping_add(k as u64);
        match walk {
            Some(w) => {
                let a = compare(&before, w, wi, seed);
                let b = compare(&after, w, wi, seed);
                writeln!(
                    out,
                    "{:>5}°  {:<22} {:<22} {:<22} {:>9.4} {:>9.4} {:>7.4}",
                    t,
                    fmt3(a.model),
                    fmt3(b.model),
                    fmt3(b.walk),
                    a.lobe_tv,
                    b.lobe_tv,
                    b.lobe_noise
                )?;
            }
            None => {
                let a = check::albedo(&before, &ctx, &sp, wi, n, seed);
                let b = check::albedo(&after, &ctx, &sp, wi, n, seed);
                let f = |s: specula_bsdf::Spectrum| fmt3(s.0.map(f64::from));
                writeln!(out, "{:>5}°  {:<22} {:<22}", t, f(a.mean), f(b.mean))?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The command's output for one spec at one angle, 20 000 samples.
    fn run_for(spec: &str, angle: f32) -> String {
        let args = MultiscatterArgs {
            material: vec![spec.into()],
            angles: vec![angle],
            samples: 20_000,
            seed: 1,
        };
        let mut out = Vec::new();
        run(&args, &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    /// The first `n` albedo columns of the last row.
    fn last_row(s: &str, n: usize) -> Vec<f64> {
        s.lines()
            .last()
            .unwrap()
            .split_whitespace()
            .skip(1)
            .take(n)
            .map(|c| c.parse().unwrap())
            .collect()
    }

    #[test]
    fn before_and_after() {
        let s = run_for(
            "roughconductor distribution=ggx alpha=1 multiscatter=true",
            45.0,
        );
        let cols = last_row(&s, 3);
        assert!(cols[0] < 0.5 && (cols[1] - 1.0).abs() < 0.01 && (cols[2] - 1.0).abs() < 0.01);
        assert!(s.contains("random walk"), "{s}");
    }

    #[test]
    fn principled_before_and_after() {
        let s = run_for("principled base_color=1 metallic=1 roughness=1", 0.0);
        let cols = last_row(&s, 2);
        assert!(cols[0] < 0.5 && (cols[1] - 1.0).abs() < 0.01, "{s}");
        assert!(s.contains("random walk"), "{s}");
    }

    /// A roughplastic over a black base is compared with the walk's reflection; over a
    /// coloured base it has no reference.
    #[test]
    fn plastic_reference() {
        let s = run_for(
            "roughplastic distribution=ggx alpha=1 diffuse_reflectance=0",
            75.0,
        );
        assert!(s.contains("albedo R ") && s.contains("reflection"), "{s}");
        let cols = last_row(&s, 3);
        // the compensated coat reflects what the walk reflects, the single-scattering one less
        assert!(
            cols[0] < cols[2] && (cols[1] - cols[2]).abs() < 0.1 * cols[2],
            "{s}"
        );
        let s = run_for(
            "roughplastic distribution=ggx alpha=1 diffuse_reflectance=0.5",
            75.0,
        );
        assert!(s.contains("no random walk"), "{s}");
    }

    #[test]
    fn refuses_other_plugins() {
        let args = MultiscatterArgs {
            material: vec!["diffuse".into()],
            angles: vec![0.0],
            samples: 1000,
            seed: 1,
        };
        assert!(run(&args, &mut Vec::new()).is_err());
    }
}
