//! `specula fresnel`: Fresnel reflectance tables for dielectrics and named conductors, and
//! `specula fresnel plot`, which draws them (see [`crate::plot::fresnel`]).

use std::io::Write;

use clap::{Args, Subcommand};
use specula_bsdf::data::{lookup_conductor, lookup_ior, NAMED_CONDUCTORS, NAMED_IORS};
use specula_bsdf::fresnel::{
    brewster_angle, critical_angle, fresnel_conductor_rgb, fresnel_dielectric,
    fresnel_dielectric_polarized, fresnel_schlick,
};
use specula_bsdf::Spectrum;

use crate::output::CliError;

#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct FresnelArgs {
    #[command(subcommand)]
    pub command: Option<FresnelCommand>,
    /// Relative index of refraction η = n_inside / n_outside: a number or a named dielectric
    /// (water, bk7, diamond, "acrylic glass", …) [default: 1.5]
    #[arg(long, value_name = "IOR", conflicts_with = "material")]
    pub ior: Option<String>,
    /// A named conductor (Cu, Au, Ag, Al, Cr, …): reflectance per RGB channel
    #[arg(long, value_name = "NAME")]
    pub material: Option<String>,
    /// Number of incidence angles from 0° to 90° inclusive (19 = every 5°)
    #[arg(long, default_value_t = 19, value_parser = clap::value_parser!(u32).range(2..=100_000))]
    pub steps: u32,
}

#[derive(Debug, Subcommand)]
pub enum FresnelCommand {
    /// Draw the reflectance against the angle of incidence (PNG or SVG): Rs, Rp, their mean and
    /// Schlick's approximation of a dielectric with Brewster's angle marked (`--inside`: seen
    /// from inside, total internal reflection past the critical angle), or a named conductor's
    /// reflectance per RGB channel (`--material Cu`).
    ///
    /// Examples: `specula fresnel plot --ior 1.5 -o fresnel.png`,
    /// `specula fresnel plot --ior water --inside -o water.svg`,
    /// `specula fresnel plot --material Cu -o cu.png`,
    /// `specula fresnel plot --ior bk7 --spectral -o bk7.png` (one curve per wavelength).
    Plot(crate::plot::fresnel::FresnelPlotArgs),
    /// The named dispersive dielectrics (Specula's `dispersion` parameter): a table of n at
    /// the F, d and C lines, the Abbe number and each formula's source, and with `-o` a
    /// picture of n(λ) over 380–780 nm.
    ///
    /// Examples: `specula fresnel dispersion`, `specula fresnel dispersion -o n.png`,
    /// `specula fresnel dispersion --glass bk7,sf11,diamond -o n.svg`.
    Dispersion(crate::plot::dispersion::DispersionArgs),
}

pub fn run(args: &FresnelArgs, out: &mut dyn Write) -> Result<(), CliError> {
    match &args.command {
        Some(FresnelCommand::Plot(plot)) => return crate::plot::fresnel::run(plot, out),
        Some(FresnelCommand::Dispersion(d)) => return crate::plot::dispersion::run(d, out),
        None => {}
    }
    match &args.material {
        Some(name) => conductor_table(name, args.steps, out),
        None => {
            let ior = args.ior.as_deref().unwrap_or("1.5").trim();
            let eta = parse_ior(ior)?;
            let name = ior.parse::<f32>().is_err().then_some(ior);
            dielectric_table(eta, name, args.steps, out)
        }
    }
}

/// A positive number, or a name from Mitsuba's table of dielectrics (case-insensitive).
pub(crate) fn parse_ior(s: &str) -> Result<f32, CliError> {
    let s = s.trim();
    if let Ok(v) = s.parse::<f32>() {
        return if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(CliError::usage(format!(
                "index of refraction must be a positive number, got {s}"
            )))
        };
    }
    lookup_ior(s)
        .or_else(|| lookup_ior(&s.to_lowercase()))
        .ok_or_else(|| {
            let names: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
            CliError::usage(format!(
                "unknown index of refraction '{s}'; give a number or one of: {}",
                names.join(", ")
            ))
        })
}

/// Incidence angles in degrees, 0..=90 in `steps` values.
fn angles(steps: u32) -> impl Iterator<Item = f64> {
    let n = steps.max(2);
    (0..n).map(move |i| 90.0 * f64::from(i) / f64::from(n - 1))
}

fn dielectric_table(
    eta: f32,
    name: Option<&str>,
    steps: u32,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    let named = name.map(|n| format!(" ({n})")).unwrap_or_default();
    writeln!(
        out,
        "Fresnel reflectance of a smooth dielectric interface, relative index η = n_inside/n_outside = {eta}{named}"
    )?;
    let b_out = brewster_angle(eta).to_degrees();
    let b_in = brewster_angle(1.0 / eta).to_degrees();
    writeln!(
        out,
        "Brewster's angle: {b_out:.2}° from outside, {b_in:.2}° from inside (Rp = 0)"
    )?;
    if let Some(c) = critical_angle(eta) {
        writeln!(
            out,
            "Critical angle:   {:.2}° from inside (total internal reflection beyond it)",
            c.to_degrees()
        )?;
    } else if let Some(c) = critical_angle(1.0 / eta) {
        writeln!(
            out,
            "Critical angle:   {:.2}° from outside (total internal reflection beyond it)",
            c.to_degrees()
        )?;
    } else {
        writeln!(out, "Critical angle:   none (index-matched interface)")?;
    }
    for inside in [false, true] {
        let (n_i, n_t) = if inside { (eta, 1.0) } else { (1.0, eta) };
        writeln!(out)?;
        writeln!(
            out,
            "From {} (n = {n_i} -> n = {n_t}):",
            if inside { "inside" } else { "outside" }
        )?;
        writeln!(
            out,
            "{:>8} {:>10} {:>10} {:>10} {:>10}",
            "θi (°)", "Rs", "Rp", "R", "Schlick"
        )?;
        for deg in angles(steps) {
            let rad = deg.to_radians();
            // cos 90° rounds to a tiny positive number, so the side stays unambiguous
            let c = rad.cos().max(0.0) as f32;
            let cos_i = if inside { -c } else { c };
            let pol = fresnel_dielectric_polarized(cos_i, eta);
            let exact = fresnel_dielectric(cos_i, eta);
            let schlick = fresnel_schlick(cos_i, eta);
            let tir = rad.sin() * f64::from(n_i) > f64::from(n_t);
            writeln!(
                out,
                "{deg:>8.2} {:>10.6} {:>10.6} {:>10.6} {:>10.6}{}",
                pol.rs,
                pol.rp,
                exact.r,
                schlick.r,
                if tir { "  TIR" } else { "" }
            )?;
        }
    }
    Ok(())
}

/// Exact name, else a unique case-insensitive match.
pub(crate) fn find_conductor(name: &str) -> Option<(String, [f32; 3], [f32; 3])> {
    if let Some((e, k)) = lookup_conductor(name) {
        return Some((name.to_string(), e, k));
    }
    let mut hits = NAMED_CONDUCTORS
        .iter()
        .filter(|(n, _, _)| n.eq_ignore_ascii_case(name));
    match (hits.next(), hits.next()) {
        (Some((n, e, k)), None) => Some((n.to_string(), *e, *k)),
        _ => None,
    }
}

/// The error for a conductor name that is not in the table.
pub(crate) fn unknown_conductor(name: &str) -> CliError {
    let names: Vec<&str> = NAMED_CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
    CliError::usage(format!(
        "unknown conductor '{name}'; known: none, {}",
        names.join(", ")
    ))
}

fn conductor_table(name: &str, steps: u32, out: &mut dyn Write) -> Result<(), CliError> {
    let Some((name, eta, k)) = find_conductor(name.trim()) else {
        return Err(unknown_conductor(name));
    };
    writeln!(
        out,
        "Fresnel reflectance of conductor '{name}' per linear-sRGB channel (unpolarised)"
    )?;
    writeln!(
        out,
        "η = ({:.4}, {:.4}, {:.4}), k = ({:.4}, {:.4}, {:.4})",
        eta[0], eta[1], eta[2], k[0], k[1], k[2]
    )?;
    writeln!(out)?;
    writeln!(
        out,
        "{:>8} {:>10} {:>10} {:>10} {:>10}",
        "θi (°)", "R (red)", "R (green)", "R (blue)", "mean"
    )?;
    let (eta, k) = (Spectrum::from(eta), Spectrum::from(k));
    for deg in angles(steps) {
        let c = deg.to_radians().cos().max(0.0) as f32;
        let r = fresnel_conductor_rgb(c, eta, k);
        writeln!(
            out,
            "{deg:>8.2} {:>10.6} {:>10.6} {:>10.6} {:>10.6}",
            r[0],
            r[1],
            r[2],
            r.mean()
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ior_parsing() {
        assert_eq!(parse_ior("1.5").unwrap(), 1.5);
        assert_eq!(parse_ior("water").unwrap(), 1.333);
        assert_eq!(parse_ior("BK7").unwrap(), 1.5046);
        assert!(parse_ior("0").is_err());
        assert!(parse_ior("-1").is_err());
        assert!(parse_ior("nan").is_err());
        assert!(parse_ior("unobtainium").is_err());
    }

    #[test]
    fn angle_grid() {
        let a: Vec<f64> = angles(19).collect();
        assert_eq!(a.len(), 19);
        assert_eq!(a[0], 0.0);
        assert_eq!(a[1], 5.0);
        assert_eq!(a[18], 90.0);
    }

    #[test]
    fn conductor_names() {
        assert_eq!(find_conductor("Cu").unwrap().0, "Cu");
        assert_eq!(find_conductor("cu").unwrap().0, "Cu");
        assert!(find_conductor("none").is_some());
        assert!(find_conductor("Xx").is_none());
    }
}
