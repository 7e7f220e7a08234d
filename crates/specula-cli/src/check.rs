//! `specula brdf check MATERIAL`: run the property checks of `specula_bsdf::check::suite` on
//! one material and print a verdict table; the exit status is 1 when a check fails.

use std::io::Write;
use std::time::Instant;

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use specula_bsdf::check::suite::{self, Reciprocity, SuiteConfig, Verdict};
use specula_bsdf::models::{Blend, TwoSided};
use specula_bsdf::{Bsdf, BsdfModel};

use crate::output::CliError;

#[derive(Debug, Args)]
pub struct CheckArgs {
    /// Material: a spec such as "roughconductor material=Cu alpha=0.2" (quoted, or as separate
    /// words), an XML snippet '<bsdf type=…>…</bsdf>', a MERL .binary or RGL .bsdf file, or
    /// scene.xml#id
    #[arg(required = true, num_args = 1.., value_name = "MATERIAL")]
    pub material: Vec<String>,
    /// Samples per statistical test (χ² or lobe selection, and albedo, at each incidence
    /// angle); the weight-consistency and reciprocity checks use a tenth of it
    #[arg(long, value_name = "N", default_value_t = 200_000)]
    pub samples: usize,
    /// Random seed (the report is a deterministic function of material, seed and samples)
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Incidence angles θi in degrees, comma separated (beyond 90° below the surface).
    /// Default: 0,30,60,85, plus 180,150,120,95 for materials that scatter light from below
    #[arg(
        long,
        value_name = "DEG,…",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub angles: Option<Vec<f32>>,
    /// Family-wise significance of the statistical tests (Šidák-corrected per test)
    #[arg(long, value_name = "P", default_value_t = 0.01)]
    pub alpha: f64,
    /// Worker threads (default: all cores)
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Texture coordinates to evaluate a textured material at (bump and normal maps,
    /// textured parameters), on a flat surface whose ∂p/∂u, ∂p/∂v and normal are the local
    /// x, y and z axes
    #[arg(long, value_name = "U,V", value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.0, 0.0])]
    pub uv: Vec<f32>,
    /// Check in spectral mode at these wavelengths (nm, 360–830): three values are the three
    /// channels of one spectral sample (a dispersive material samples the mixture over them,
    /// and energy and reciprocity are judged per wavelength); one value puts that wavelength
    /// in every channel. Default: RGB mode
    #[arg(
        long,
        value_name = "NM,…",
        value_delimiter = ',',
        conflicts_with = "spectral"
    )]
    pub wavelengths: Option<Vec<f32>>,
    /// Spectral mode at 450, 550 and 650 nm (`--wavelengths 450,550,650`)
    #[arg(long)]
    pub spectral: bool,
    /// No progress bar
    #[arg(long)]
    pub quiet: bool,
}

/// A copy of `b` in which every MERL table, nested ones included, uses interpolated lookup;
/// `None` when `b` has no table with nearest-bin lookup. Swapping wi and wo leaves a MERL
/// table's coordinates unchanged (φd is folded by reciprocity), so the table is reciprocal by
/// construction, but nearest-bin lookup puts the two orders in neighbouring bins where float
/// rounding crosses a bin edge: the continuous, interpolated lookup tests the data instead.
fn interpolated_merl(b: &Bsdf) -> Option<Bsdf> {
    match b {
        Bsdf::Merl(m) if !m.interpolate => {
            let mut m = m.clone();
            m.interpolate = true;
            Some(Bsdf::Merl(m))
        }
        Bsdf::TwoSided(t) => {
            let (front, back) = (interpolated_merl(&t.front), interpolated_merl(&t.back));
            (front.is_some() || back.is_some()).then(|| {
                Bsdf::TwoSided(Box::new(TwoSided {
                    front: front.unwrap_or_else(|| t.front.clone()),
                    back: back.unwrap_or_else(|| t.back.clone()),
                }))
            })
        }
        Bsdf::Blend(bl) => {
            let parts = [
                interpolated_merl(&bl.bsdfs[0]),
                interpolated_merl(&bl.bsdfs[1]),
            ];
            parts.iter().any(Option::is_some).then(|| {
                let [a, b] = parts;
                Bsdf::Blend(Box::new(Blend {
                    weight: bl.weight.clone(),
                    bsdfs: [
                        a.unwrap_or_else(|| bl.bsdfs[0].clone()),
                        b.unwrap_or_else(|| bl.bsdfs[1].clone()),
                    ],
                    mitsuba_dirac_mixing: bl.mitsuba_dirac_mixing,
                }))
            })
        }
        _ => None,
    }
}

/// Whether `b` contains an RGL tensor (`measured`), nested ones included.
fn contains_rgl(b: &Bsdf) -> bool {
    match b {
        Bsdf::Measured(_) => true,
        Bsdf::TwoSided(t) => contains_rgl(&t.front) || contains_rgl(&t.back),
        Bsdf::Blend(bl) => bl.bsdfs.iter().any(contains_rgl),
        Bsdf::Mask(m) => contains_rgl(&m.nested),
        Bsdf::BumpMap(p) => contains_rgl(&p.nested),
        Bsdf::NormalMap(p) => contains_rgl(&p.nested),
        _ => false,
    }
}

/// Whether `b` contains a `bumpmap` or `normalmap`, nested ones included: their value is the
/// nested f in a frame perturbed according to wi, times the shadowing term of wo and the
/// ratio of perturbed to geometric cosines, which is not reciprocal (as in Mitsuba).
fn contains_perturbed(b: &Bsdf) -> bool {
    match b {
        Bsdf::BumpMap(_) | Bsdf::NormalMap(_) => true,
        Bsdf::TwoSided(t) => contains_perturbed(&t.front) || contains_perturbed(&t.back),
        Bsdf::Blend(bl) => bl.bsdfs.iter().any(contains_perturbed),
        Bsdf::Mask(m) => contains_perturbed(&m.nested),
        _ => false,
    }
}

pub fn run(args: &CheckArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if args.samples < 1000 {
        return Err(CliError::usage(format!(
            "--samples must be at least 1000, got {}",
            args.samples
        )));
    }
    if !(args.alpha > 0.0 && args.alpha < 1.0) {
        return Err(CliError::usage(format!(
            "--alpha must lie strictly between 0 and 1, got {}",
            args.alpha
        )));
    }
    if let Some(a) = &args.angles {
        if let Some(bad) = a
            .iter()
            .find(|t| !(t.is_finite() && (0.0..=180.0).contains(*t)))
        {
            return Err(CliError::usage(format!(
                "--angles must lie in [0, 180] degrees, got {bad}"
            )));
        }
        if a.is_empty() {
            return Err(CliError::usage("--angles: give at least one angle"));
        }
    }
    if args.uv.len() != 2 || !args.uv.iter().all(|v| v.is_finite()) {
        return Err(CliError::usage(format!(
            "--uv takes two finite numbers U,V, got {:?}",
            args.uv
        )));
    }
    let wavelengths = match (&args.wavelengths, args.spectral) {
        (_, true) => Some(specula_bsdf::Wavelengths([450.0, 550.0, 650.0])),
        (None, false) => None,
        (Some(w), false) => {
            if let Some(bad) = w
                .iter()
                .find(|l| !(l.is_finite() && (360.0..=830.0).contains(*l)))
            {
                return Err(CliError::usage(format!(
                    "--wavelengths must lie in 360..830 nm, got {bad}"
                )));
            }
            match w.as_slice() {
                [l] => Some(specula_bsdf::Wavelengths([*l; 3])),
                [a, b, c] => Some(specula_bsdf::Wavelengths([*a, *b, *c])),
                _ => {
                    return Err(CliError::usage(format!(
                        "--wavelengths takes one or three wavelengths, got {}",
                        w.len()
                    )))
                }
            }
        }
    };
    let material = crate::material::load_material(&args.material)?;
    let bsdf = &material.bsdf;

    // Measured data: reciprocity as the data allow (see the README's "Checking a material").
    let interpolated = interpolated_merl(bsdf);
    let reciprocity = if contains_perturbed(bsdf) {
        Reciprocity::Skip(
            "bump and normal mapping evaluate the nested BSDF in a frame chosen by wi, with a \
             shadowing term of wo (Mitsuba's), which is not reciprocal"
                .into(),
        )
    } else if contains_rgl(bsdf) {
        Reciprocity::Skip(
            "RGL tensors tabulate f per incidence direction (Dupuy & Jakob 2018), \
             which is not reciprocal by construction"
                .into(),
        )
    } else if let Some(m) = &interpolated {
        Reciprocity::Substitute {
            model: m,
            note: "MERL: on the interpolated lookup (nearest-bin jumps at bin edges)".into(),
        }
    } else {
        Reciprocity::Test
    };
    let cfg = SuiteConfig {
        samples: args.samples,
        seed: args.seed,
        family_alpha: args.alpha,
        angles: args.angles.clone(),
        threads: args.threads,
        reciprocity,
        uv: glam::Vec2::new(args.uv[0], args.uv[1]),
        wavelengths,
    };

    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} tests")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    let report = suite::run_suite(bsdf, &cfg, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();

    let angles = report
        .angles
        .iter()
        .map(|t| format!("{t}°"))
        .collect::<Vec<_>>()
        .join(", ");
    writeln!(out, "{:<13}{}", "material", material.label)?;
    writeln!(
        out,
        "{:<13}{} ({})",
        "plugin",
        bsdf.plugin_name(),
        bsdf.flags()
    )?;
    writeln!(
        out,
        "{:<13}θi = {angles} (φi = {:.1}°)",
        "incidence",
        suite::PHI_I.to_degrees()
    )?;
    writeln!(
        out,
        "{:<13}uv = ({}, {}) on a flat surface (∂p/∂u, ∂p/∂v, normal = local x, y, z)",
        "at", args.uv[0], args.uv[1]
    )?;
    match wavelengths {
        Some(w) => writeln!(
            out,
            "{:<13}spectral: channels at {} nm",
            "mode",
            w.0.map(|l| l.to_string()).join(", ")
        )?,
        None => writeln!(out, "{:<13}RGB", "mode")?,
    }
    writeln!(
        out,
        "{:<13}{} per statistical test, seed {}",
        "samples", report.samples, report.seed
    )?;
    writeln!(
        out,
        "{:<13}family-wise {} over {} statistical tests ({} sampling, {} energy), \
         Šidák-corrected: α = {:.2e} per test",
        "significance",
        report.family_alpha,
        report.family_size,
        report.angles.len(),
        3 * report.angles.len(),
        report.per_test_alpha
    )?;
    writeln!(out)?;
    let w = report
        .outcomes
        .iter()
        .map(|o| o.name.len())
        .max()
        .unwrap_or(0)
        .max(5);
    writeln!(out, "{:<w$}  {:<7}  figures", "check", "verdict")?;
    for o in &report.outcomes {
        writeln!(
            out,
            "{:<w$}  {:<7}  {}",
            o.name,
            o.verdict.to_string(),
            o.summary
        )?;
        for d in &o.details {
            writeln!(out, "{:<w$}  {:<7}    {d}", "", "")?;
        }
    }
    writeln!(out)?;
    let failed: Vec<&str> = report
        .outcomes
        .iter()
        .filter(|o| o.verdict == Verdict::Fail)
        .map(|o| o.name)
        .collect();
    let skipped = report
        .outcomes
        .iter()
        .filter(|o| o.verdict == Verdict::Skip)
        .count();
    let skip_note = if skipped > 0 {
        format!(", {skipped} skipped")
    } else {
        String::new()
    };
    if failed.is_empty() {
        writeln!(
            out,
            "result: PASS ({} checks passed{skip_note}) in {secs:.1} s",
            report.outcomes.len() - skipped
        )?;
        Ok(())
    } else {
        writeln!(
            out,
            "result: FAIL ({} of {} checks failed: {}{skip_note}) in {secs:.1} s",
            failed.len(),
            report.outcomes.len(),
            failed.join(", ")
        )?;
        Err(CliError::ChecksFailed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use specula_bsdf::measured::merl::Merl;
    use specula_bsdf::{parse_spec, Spectrum};

    fn merl_interpolates(b: &Bsdf) -> Vec<bool> {
        match b {
            Bsdf::Merl(m) => vec![m.interpolate],
            Bsdf::TwoSided(t) => [merl_interpolates(&t.front), merl_interpolates(&t.back)].concat(),
            Bsdf::Blend(bl) => bl.bsdfs.iter().flat_map(merl_interpolates).collect(),
            _ => vec![],
        }
    }

    #[test]
    fn nested_merl_tables_get_interpolated_lookup() {
        let table = Bsdf::Merl(Merl::from_fn(|_, _, _| Spectrum::splat(0.1)));
        let diffuse = parse_spec("diffuse").unwrap();
        assert!(interpolated_merl(&diffuse).is_none());
        let top = interpolated_merl(&table).unwrap();
        assert_eq!(merl_interpolates(&top), [true]);
        let two = Bsdf::TwoSided(Box::new(TwoSided {
            front: table.clone(),
            back: diffuse.clone(),
        }));
        assert_eq!(merl_interpolates(&two), [false]);
        assert_eq!(merl_interpolates(&interpolated_merl(&two).unwrap()), [true]);
        let blend = Bsdf::Blend(Box::new(Blend {
            weight: 0.5.into(),
            bsdfs: [diffuse.clone(), two],
            mitsuba_dirac_mixing: false,
        }));
        let b = interpolated_merl(&blend).unwrap();
        assert_eq!(merl_interpolates(&b), [true]);
        assert!(!contains_rgl(&b) && !contains_rgl(&diffuse));
    }
}
