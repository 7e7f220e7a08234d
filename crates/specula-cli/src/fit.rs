//! `specula brdf measure MATERIAL -o out.binary` (a virtual gonioreflectometer) and
//! `specula brdf fit FILE.binary --model ggx|beckmann` (a compact analytic representation of a
//! MERL table).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use specula_bsdf::measured::fit::{self, Family, FitOptions, Metric};
use specula_bsdf::measured::merl::{self, Merl};
use specula_bsdf::microfacet::MicrofacetType;
use specula_bsdf::BsdfModel;

use crate::output::CliError;

#[derive(Debug, Args)]
pub struct MeasureArgs {
    /// Material: a spec such as "roughconductor material=Cu alpha=0.2" (quoted, or as separate
    /// words), an XML snippet '<bsdf type=…>…</bsdf>', a MERL .binary or RGL .bsdf file, or
    /// scene.xml#id. It must have no Dirac lobe (conductor, dielectric, plastic, …)
    #[arg(required = true, num_args = 1.., value_name = "MATERIAL")]
    pub material: Vec<String>,
    /// Output MERL table (must end in .binary)
    #[arg(short = 'o', long = "output", value_name = "FILE.binary")]
    pub output: PathBuf,
    /// No progress bar
    #[arg(long)]
    pub quiet: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Distribution {
    Ggx,
    Beckmann,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum MetricArg {
    /// Cube root of f·cosθi·cosθo (Ngan et al. 2005)
    Cbrt,
    /// ln(1 + f·cosθi·cosθo) (Löw et al. 2012)
    Log,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum FamilyArg {
    /// Fit every family and keep the one with the lowest error
    Auto,
    /// roughconductor (per-channel F0 / edge tint → eta, k) plus a Lambertian kd per channel
    Conductor,
    /// roughplastic (diffuse_reflectance per channel, int_ior)
    Plastic,
}

#[derive(Debug, Args)]
pub struct FitArgs {
    /// The MERL table (.binary) to fit
    #[arg(value_name = "FILE.binary")]
    pub file: PathBuf,
    /// Microfacet distribution of the fitted specular lobe
    #[arg(long, value_enum)]
    pub model: Distribution,
    /// Error metric: the map applied to f·cosθi·cosθo before comparing (weights: solid angle
    /// of each bin)
    #[arg(long, value_enum, default_value_t = MetricArg::Cbrt)]
    pub metric: MetricArg,
    /// Model family
    #[arg(long, value_enum, default_value_t = FamilyArg::Auto)]
    pub family: FamilyArg,
}

fn thousands(n: usize) -> String {
    let s = n.to_string();
    let mut groups = Vec::new();
    let mut end = s.len();
    while end > 3 {
        groups.push(&s[end - 3..end]);
        end -= 3;
    }
    groups.push(&s[..end]);
    groups.reverse();
    groups.join(",")
}

fn is_binary(p: &Path) -> bool {
    p.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("binary"))
}

pub fn measure(args: &MeasureArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if !is_binary(&args.output) {
        return Err(CliError::usage(format!(
            "{}: the output must end in .binary (a MERL table)",
            args.output.display()
        )));
    }
    let material = crate::material::load_material(&args.material)?;
    let flags = material.bsdf.flags();
    if flags.is_delta() {
        return Err(CliError::usage(format!(
            "'{}' has a Dirac (perfectly specular) lobe ({flags}), which a table of BRDF \
             values cannot hold; measure a rough model instead (e.g. roughconductor, \
             roughdielectric, roughplastic)",
            material.label
        )));
    }
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(merl::RES_THETA_H as u64)
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} θh rows  ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let start = Instant::now();
    let table = Merl::measure_with_progress(&material.bsdf, |done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    let secs = start.elapsed().as_secs_f64();
    table.write(&args.output).map_err(CliError::usage)?;
    let measured = table
        .raw_table()
        .iter()
        .filter(|v| v.iter().all(|&x| x >= 0.0))
        .count();
    let mut below = 0;
    for i in 0..merl::RES_THETA_H {
        for j in 0..merl::RES_THETA_D {
            for k in 0..merl::RES_PHI_D {
                let (wi, wo) = merl::bin_centre_dirs(i, j, k);
                below += usize::from(wi[2] <= 0.0 || wo[2] <= 0.0);
            }
        }
    }
    let invalid = merl::ENTRIES - measured - below;
    writeln!(
        out,
        "{}: {} tabulated in {}×{}×{} (θh, θd, φd) bins in {secs:.2} s — {} measured, {} below \
         the horizon (stored as −1){}; {} bytes",
        args.output.display(),
        material.label,
        merl::RES_THETA_H,
        merl::RES_THETA_D,
        merl::RES_PHI_D,
        thousands(measured),
        thousands(below),
        if invalid > 0 {
            format!(
                ", {} where the material gave a negative or non-finite value (stored as −1)",
                thousands(invalid)
            )
        } else {
            String::new()
        },
        thousands(merl::FILE_SIZE),
    )?;
    if flags.has_transmission() {
        writeln!(
            out,
            "note: only the reflection hemisphere is tabulated; the material's transmission is \
             not in the table"
        )?;
    }
    Ok(())
}

pub fn fit(args: &FitArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let table = Merl::read(&args.file).map_err(CliError::usage)?;
    let metric = match args.metric {
        MetricArg::Cbrt => Metric::Cbrt,
        MetricArg::Log => Metric::Log,
    };
    let opts = FitOptions {
        distribution: match args.model {
            Distribution::Ggx => MicrofacetType::Ggx,
            Distribution::Beckmann => MicrofacetType::Beckmann,
        },
        metric,
        family: match args.family {
            FamilyArg::Auto => None,
            FamilyArg::Conductor => Some(Family::Conductor),
            FamilyArg::Plastic => Some(Family::Plastic),
        },
        ..Default::default()
    };
    let start = Instant::now();
    let data = fit::FitData::new(&table, &opts).map_err(CliError::usage)?;
    let families: Vec<Family> = opts.family.map_or(Family::ALL.to_vec(), |f| vec![f]);
    let mut fits = Vec::new();
    for f in families {
        fits.push(fit::fit_family(&data, f, opts.distribution).map_err(CliError::usage)?);
    }
    fits.sort_by(|a, b| a.quality.value.total_cmp(&b.quality.value));
    let m = metric.name();
    writeln!(out, "{:<10} {}", "file", args.file.display())?;
    writeln!(
        out,
        "{:<10} {} of {} measured bins (bin centres: all θh, θd and φd at strides {} and {}), \
         weighted by solid angle",
        "samples",
        thousands(data.len()),
        thousands(data.measured_bins),
        opts.theta_d_stride,
        opts.phi_d_stride
    )?;
    writeln!(
        out,
        "{:<10} {m}: E = √(Σ w·⅓Σ_rgb [g(f·cosθi·cosθo) − g(measured·cosθi·cosθo)]²), \
         g(x) = {}, Σ w = 1",
        "metric",
        metric.formula()
    )?;
    writeln!(out, "{:<10} {}", "model", opts.distribution.name())?;
    writeln!(out)?;
    writeln!(
        out,
        "{:<10}  {:>12}  {:>10}  {:>10}  {:>7}  {:>8}",
        "family",
        format!("E ({m})"),
        "rel. RMS",
        "alpha",
        "evals",
        "time"
    )?;
    for (i, f) in fits.iter().enumerate() {
        writeln!(
            out,
            "{:<10}  {:>12.4e}  {:>10.4e}  {:>10.6}  {:>7}  {:>6.2} s{}",
            f.family.name(),
            f.quality.value,
            f.quality.rel_rms,
            f.alpha,
            f.evaluations,
            f.elapsed.as_secs_f64(),
            if i == 0 && fits.len() > 1 {
                "  ← lowest error"
            } else {
                ""
            }
        )?;
    }
    let best = &fits[0];
    writeln!(out)?;
    writeln!(
        out,
        "fitted {} ({}):",
        best.family.name(),
        if opts.family.is_some() {
            "forced with --family".to_string()
        } else {
            format!("lowest {m} error of {}", fits.len())
        }
    )?;
    for line in best.param_lines() {
        writeln!(out, "  {line}")?;
    }
    writeln!(out)?;
    let xml = best.mitsuba_xml();
    writeln!(out, "Mitsuba 3 XML:")?;
    write!(out, "{xml}")?;
    writeln!(out)?;
    writeln!(out, "Specula spec: {}", best.spec())?;
    // the error of the material as the XML describes it, over the whole table
    let reread = specula_render::scene::bsdf_from_xml_str(&xml, "<fitted XML>", Path::new("."))
        .map_err(|e| {
            CliError::usage(format!(
                "internal error: the fitted XML does not build: {e}"
            ))
        })?;
    let q = fit::table_quality(&table, &reread, metric);
    writeln!(
        out,
        "fit error (the XML above, all {} measured bins): E ({m}) = {:.4e}, relative RMS of \
         f·cosθi·cosθo = {:.4e} ({:.3} %)",
        thousands(q.bins),
        q.value,
        q.rel_rms,
        100.0 * q.rel_rms
    )?;
    writeln!(out, "total time {:.2} s", start.elapsed().as_secs_f64())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thousands_separators() {
        assert_eq!(thousands(0), "0");
        assert_eq!(thousands(999), "999");
        assert_eq!(thousands(1000), "1,000");
        assert_eq!(thousands(1458000), "1,458,000");
    }
}
