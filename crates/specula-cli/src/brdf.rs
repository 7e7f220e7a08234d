//! `specula brdf …`: commands on one material given as a one-line spec.

use std::io::Write;

use clap::{Args, Subcommand, ValueEnum};
use glam::Vec3;
use specula_bsdf::build::PLUGINS;
use specula_bsdf::data::{NAMED_CONDUCTORS, NAMED_IORS};
use specula_bsdf::{BsdfContext, BsdfModel, ShadingPoint, TransportMode};

use crate::output::{num, rgb, CliError};

#[derive(Debug, Subcommand)]
pub enum BrdfCommand {
    /// Evaluate a material for one pair of directions: f (without cosine), f·cosθo and the
    /// density with which the material samples wo.
    Eval(EvalArgs),
    /// List the material plugins, their parameters and the named optical constants.
    List,
    /// Check a material: non-negativity and finiteness, reciprocity, energy conservation
    /// (white-furnace albedo ≤ 1), sampling (χ² of sample() against pdf(), or the
    /// lobe-selection test for Dirac materials) and sample-weight consistency, at several
    /// incidence angles; prints a verdict table and exits with status 1 if a check fails.
    Check(crate::check::CheckArgs),
    /// Draw the scattering lobe in the plane of incidence (PNG or SVG): a polar plot of f·cosθo
    /// (or f) for several incidence angles, one curve each, the incident directions as arrows;
    /// materials that transmit get the lower half plane, Dirac lobes are dashed rays. Default
    /// size 900x500, or 900x700 with transmission.
    ///
    /// Example: `specula brdf plot "roughconductor material=Cu alpha=0.2" -o lobe.png`
    Plot(crate::plot::lobe::LobeArgs),
    /// Draw BRDF Explorer's image slice (PNG or SVG): f over θh (x) and θd (y) at a fixed φd,
    /// on a logarithmic colour scale; a MERL table is shown bin by bin.
    ///
    /// Example: `specula brdf slice copper.binary --phi-d 90 -o slice.png`
    Slice(crate::plot::slice::SliceArgs),
    /// Directional albedo ρ(θi) = ∫ f·|cosθo| dωo against θi per channel (the white-furnace
    /// view: where a model loses energy), split into reflection and transmission; prints the
    /// table and draws it (PNG or SVG) with a reference line at 1.
    ///
    /// Example: `specula brdf albedo "roughconductor alpha=0.8" -o albedo.png`
    Albedo(crate::plot::albedo::AlbedoArgs),
    /// Tabulate a material's reflection into a MERL table (a virtual gonioreflectometer).
    ///
    /// f is evaluated at the centre of each of the 90 θh × 90 θd × 180 φd half/difference
    /// bins and stored in MERL's layout and scale; configurations below the horizon are stored
    /// as −1 (not measured). Only the reflection hemisphere is tabulated (a material's
    /// transmission is left out), and materials with Dirac lobes (conductor, dielectric,
    /// plastic, …) cannot be.
    ///
    /// Example: `specula brdf measure "roughconductor material=Au alpha=0.3" -o gold.binary`
    Measure(crate::fit::MeasureArgs),
    /// Fit an analytic material to a MERL table and print it as Mitsuba 3 XML.
    ///
    /// Families: a rough conductor (per-channel F0 and edge tint, i.e. eta/k, plus a
    /// Lambertian kd) and Specula's roughplastic (diffuse reflectance, int_ior), each with
    /// one roughness alpha; the one with the lower error is kept unless --family names one.
    /// The error compares f·cosθi·cosθo after a cube root or ln(1 + x), weighted by the solid
    /// angle of each bin. Prints the parameters (alpha=…), the material as Mitsuba 3 XML and
    /// as a Specula spec, and the error of that XML over the whole table.
    ///
    /// Example: `specula brdf fit copper.binary --model ggx`
    Fit(crate::fit::FitArgs),
    /// Energy compensation before and after: for a roughconductor, roughdielectric,
    /// roughplastic or principled spec, the directional albedo (R + T) per incidence angle with
    /// multiscatter=false (single scattering, Mitsuba's model) and multiscatter=true (Kulla &
    /// Conty), and for conductors and dielectrics the exact random walk on the microsurface
    /// (Heitz et al. 2016) with each model's lobe distance to it.
    ///
    /// Example: `specula brdf multiscatter "roughconductor distribution=ggx alpha=1"`
    Multiscatter(crate::multiscatter::MultiscatterArgs),
}

#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Material: a spec such as "roughconductor material=Cu alpha=0.2" (quoted, or as separate
    /// words), an XML snippet '<bsdf type=…>…</bsdf>', a MERL .binary or RGL .bsdf file, or
    /// scene.xml#id
    #[arg(required = true, num_args = 1.., value_name = "MATERIAL")]
    pub material: Vec<String>,
    /// Polar angle of wi (towards the viewer) from the normal, in degrees; beyond 90° it lies
    /// below the surface
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub theta_i: f64,
    /// Polar angle of wo (towards the light) from the normal, in degrees; beyond 90° it lies
    /// below the surface
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    pub theta_o: f64,
    /// Azimuth of wo in degrees, wi lying at φ = 0; 180 is the mirror side of the plane of
    /// incidence
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 180.0,
        allow_negative_numbers = true
    )]
    pub phi_o: f64,
    /// Quantity transported (matters for refraction: radiance is scaled by (η_i/η_t)²)
    #[arg(long, value_enum, default_value_t = Mode::Radiance)]
    pub mode: Mode,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    Radiance,
    Importance,
}

pub fn run(cmd: BrdfCommand, out: &mut dyn Write) -> Result<(), CliError> {
    match cmd {
        BrdfCommand::Eval(args) => eval(&args, out),
        BrdfCommand::List => list(out),
        BrdfCommand::Check(args) => crate::check::run(&args, out),
        BrdfCommand::Plot(args) => crate::plot::lobe::run(&args, out),
        BrdfCommand::Slice(args) => crate::plot::slice::run(&args, out),
        BrdfCommand::Albedo(args) => crate::plot::albedo::run(&args, out),
        BrdfCommand::Measure(args) => crate::fit::measure(&args, out),
        BrdfCommand::Fit(args) => crate::fit::fit(&args, out),
        BrdfCommand::Multiscatter(args) => crate::multiscatter::run(&args, out),
    }
}

/// Unit vector at polar angle θ and azimuth φ (degrees) in the local frame (z = normal).
fn direction(theta_deg: f64, phi_deg: f64) -> Vec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    let (sp, cp) = phi_deg.to_radians().sin_cos();
    // snap the rounding noise of cos 90° and friends, so that directions print cleanly
    let clean = |x: f64| if x.abs() < 1e-9 { 0.0 } else { x as f32 };
    Vec3::new(clean(st * cp), clean(st * sp), clean(ct)).normalize()
}

fn check_theta(name: &str, v: f64) -> Result<(), CliError> {
    if v.is_finite() && (0.0..=180.0).contains(&v) {
        Ok(())
    } else {
        Err(CliError::usage(format!(
            "--{name} must lie in [0, 180] degrees, got {v}"
        )))
    }
}

fn eval(args: &EvalArgs, out: &mut dyn Write) -> Result<(), CliError> {
    check_theta("theta-i", args.theta_i)?;
    check_theta("theta-o", args.theta_o)?;
    if !args.phi_o.is_finite() {
        return Err(CliError::usage("--phi-o must be a finite number"));
    }
    let material = crate::material::load_material(&args.material)?;
    let spec = material.label.as_str();
    let bsdf = &material.bsdf;
    let ctx = BsdfContext {
        mode: match args.mode {
            Mode::Radiance => TransportMode::Radiance,
            Mode::Importance => TransportMode::Importance,
        },
    };
    let sp = ShadingPoint::default();
    let wi = direction(args.theta_i, 0.0);
    let wo = direction(args.theta_o, args.phi_o);
    let f = bsdf.eval(&ctx, &sp, wi, wo);
    let f_cos = bsdf.eval_cos(&ctx, &sp, wi, wo);
    let pdf = bsdf.pdf(&ctx, &sp, wi, wo);
    let flags = bsdf.flags();

    let vec = |w: Vec3| format!("({}, {}, {})", num(w.x), num(w.y), num(w.z));
    writeln!(out, "{:<9} {spec}", "material")?;
    writeln!(out, "{:<9} {} ({flags})", "plugin", bsdf.plugin_name())?;
    writeln!(
        out,
        "{:<9} θ = {:.2}°, φ = 0°  {}",
        "wi",
        args.theta_i,
        vec(wi)
    )?;
    writeln!(
        out,
        "{:<9} θ = {:.2}°, φ = {}°  {}",
        "wo",
        args.theta_o,
        args.phi_o,
        vec(wo)
    )?;
    writeln!(out, "{:<9} {}", "f", rgb(f.0))?;
    writeln!(out, "{:<9} {}", "f·cosθo", rgb(f_cos.0))?;
    writeln!(out, "{:<9} {}", "pdf", num(pdf))?;
    if flags.is_delta() {
        writeln!(
            out,
            "note: this material has Dirac lobes, which f and pdf leave out (they are only \
             reached by sampling)"
        )?;
    }
    Ok(())
}

/// Words joined by ", " and wrapped to `width` columns after an indent.
fn wrapped(words: &[&str], indent: usize, width: usize) -> String {
    let mut s = String::new();
    let mut col = indent;
    for (i, w) in words.iter().enumerate() {
        let item = if i + 1 < words.len() {
            format!("{w},")
        } else {
            (*w).to_string()
        };
        if col > indent && col + 1 + item.len() > width {
            s.push('\n');
            s.push_str(&" ".repeat(indent));
            col = indent;
        } else if col > indent {
            s.push(' ');
            col += 1;
        }
        col += item.chars().count();
        s.push_str(&item);
    }
    s
}

fn list(out: &mut dyn Write) -> Result<(), CliError> {
    const W: usize = 96;
    writeln!(
        out,
        "Material plugins (Mitsuba 3 names and parameters; `sheen`, `fresnel=` and `multiscatter=` are Specula \
         extensions):"
    )?;
    for (name, params) in PLUGINS {
        let nested = match *name {
            "twosided" => "one or two nested BSDFs",
            "blendbsdf" => "two nested BSDFs",
            _ => "",
        };
        let mut line = if params.is_empty() {
            String::from("(no parameters)")
        } else {
            wrapped(params, 20, W)
        };
        if !nested.is_empty() {
            line.push_str(&format!("  + {nested} in braces"));
        }
        writeln!(out, "  {name:<16}  {line}")?;
    }
    writeln!(out)?;
    let iors: Vec<&str> = NAMED_IORS.iter().map(|(n, _)| *n).collect();
    writeln!(
        out,
        "Named dielectrics (int_ior, ext_ior; quote names with spaces):"
    )?;
    writeln!(out, "  {}", wrapped(&iors, 2, W))?;
    let mut conductors = vec!["none"];
    conductors.extend(NAMED_CONDUCTORS.iter().map(|(n, _, _)| *n));
    writeln!(out, "Named conductors (material):")?;
    writeln!(out, "  {}", wrapped(&conductors, 2, W))?;
    writeln!(out)?;
    writeln!(
        out,
        "Spec syntax: plugin key=value … {{ nested plugin … }}, e.g."
    )?;
    writeln!(out, "  specula brdf eval \"roughconductor material=Cu alpha=0.2 distribution=ggx\" --theta-i 30 --theta-o 30")?;
    writeln!(out, "  specula brdf eval \"blendbsdf weight=0.3 {{ diffuse reflectance=0.8 }} {{ conductor material=Au }}\" --theta-i 0 --theta-o 45")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions() {
        let n = direction(0.0, 123.0);
        assert!((n - Vec3::Z).length() < 1e-6);
        let w = direction(90.0, 180.0);
        assert!((w - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-6);
        assert!(direction(180.0, 0.0).z < -0.999);
    }

    #[test]
    fn wrapping() {
        assert_eq!(wrapped(&["a", "b", "c"], 2, 80), "a, b, c");
        let w = wrapped(&["aaaa", "bbbb", "cccc"], 2, 10);
        assert_eq!(w, "aaaa,\n  bbbb,\n  cccc");
    }
}
