//! `specula fresnel plot`: Fresnel reflectance against the angle of incidence, drawn.
//!
//! A dielectric shows Rs, Rp, their mean R and Schlick's approximation, with Brewster's angle
//! (Rp = 0) marked, and from inside the denser medium the critical angle beyond which the
//! reflection is total. A named conductor shows its reflectance per RGB channel.
//!
//! `--spectral` draws one reflectance curve per wavelength instead: of a dispersive glass
//! (`--ior bk7`, a name of Specula's `dispersion` table) or of a conductor's measured η(λ),
//! k(λ) (`--material Au`); see [`crate::plot::dispersion`].

use std::io::Write;

use clap::Args;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use specula_bsdf::fresnel::{
    brewster_angle, critical_angle, fresnel_conductor_rgb, fresnel_dielectric,
    fresnel_dielectric_polarized, fresnel_schlick,
};
use specula_bsdf::Spectrum;

use super::{
    angle_grid, draw_legend, legend_line, legend_spot, line_chart, px, save, stroke, text, titled,
    Chart, DrawResult, OutputArgs, Picture, CHANNEL_COLOURS, PALETTE,
};
use crate::fresnel::{find_conductor, parse_ior};
use crate::output::CliError;

/// Points per curve over 0°..90° (every 0.5°), before the special angles are merged in.
const POINTS: usize = 181;

#[derive(Debug, Args)]
pub struct FresnelPlotArgs {
    /// Relative index of refraction η = n_inside / n_outside of a smooth dielectric: a number or
    /// a named dielectric (water, bk7, diamond, "acrylic glass", …) [default: 1.5]
    #[arg(long, value_name = "IOR", conflicts_with = "material")]
    pub ior: Option<String>,
    /// A named conductor (Cu, Au, Ag, Al, Cr, …): its reflectance per RGB channel
    #[arg(long, value_name = "NAME")]
    pub material: Option<String>,
    /// Look from inside the dielectric (light arriving from the medium of index η): the
    /// reflection becomes total beyond the critical angle
    #[arg(long, conflicts_with = "material")]
    pub inside: bool,
    /// One curve per wavelength (400–700 nm): a dispersive glass's n(λ) for `--ior` (bk7,
    /// diamond, water, sf11, …) or a conductor's measured η(λ), k(λ) for `--material`
    #[arg(long)]
    pub spectral: bool,
    #[command(flatten)]
    pub out: OutputArgs,
}

/// The curves of one side of a dielectric interface, angles in degrees.
#[derive(Clone, Debug)]
pub struct DielectricCurves {
    /// η_t/η_i for light arriving from the chosen side.
    pub eta_it: f64,
    pub inside: bool,
    pub theta: Vec<f64>,
    pub rs: Vec<f64>,
    pub rp: Vec<f64>,
    /// Unpolarised reflectance (Rs + Rp)/2.
    pub r: Vec<f64>,
    pub schlick: Vec<f64>,
    /// Brewster's angle for this side (degrees), where Rp = 0.
    pub brewster: f64,
    /// The critical angle (degrees) when this side is the denser one.
    pub critical: Option<f64>,
}

/// Rs, Rp, R and Schlick's R for light arriving from outside (or inside) an interface of
/// relative index `eta` = n_inside/n_outside, on a 0..90° grid that contains Brewster's and
/// the critical angle exactly.
pub fn dielectric_curves(eta: f32, inside: bool, points: usize) -> DielectricCurves {
    let eta_it = if inside { 1.0 / eta } else { eta };
    let brewster = f64::from(brewster_angle(eta_it).to_degrees());
    let critical = critical_angle(1.0 / eta_it).map(|c| f64::from(c.to_degrees()));
    let mut special = vec![brewster];
    special.extend(critical);
    let theta = angle_grid(90.0, points, &special);
    let mut c = DielectricCurves {
        eta_it: f64::from(eta_it),
        inside,
        theta: theta.clone(),
        rs: Vec::with_capacity(theta.len()),
        rp: Vec::with_capacity(theta.len()),
        r: Vec::with_capacity(theta.len()),
        schlick: Vec::with_capacity(theta.len()),
        brewster,
        critical,
    };
    for &deg in &theta {
        // cos 90° rounds to a tiny positive number, so the side stays unambiguous
        let cos = deg.to_radians().cos().max(0.0) as f32;
        let cos_i = if inside { -cos } else { cos };
        let pol = fresnel_dielectric_polarized(cos_i, eta);
        c.rs.push(f64::from(pol.rs));
        c.rp.push(f64::from(pol.rp));
        c.r.push(f64::from(fresnel_dielectric(cos_i, eta).r));
        c.schlick.push(f64::from(fresnel_schlick(cos_i, eta).r));
    }
    c
}

/// Unpolarised reflectance per RGB channel of a conductor η + ik, angles in degrees.
#[derive(Clone, Debug)]
pub struct ConductorCurves {
    pub theta: Vec<f64>,
    pub r: [Vec<f64>; 3],
}

pub fn conductor_curves(eta: [f32; 3], k: [f32; 3], points: usize) -> ConductorCurves {
    let theta = angle_grid(90.0, points, &[]);
    let (eta, k) = (Spectrum::from(eta), Spectrum::from(k));
    let mut r: [Vec<f64>; 3] = Default::default();
    for &deg in &theta {
        let cos = deg.to_radians().cos().max(0.0) as f32;
        let v = fresnel_conductor_rgb(cos, eta, k);
        for (c, curve) in r.iter_mut().enumerate() {
            curve.push(f64::from(v[c]));
        }
    }
    ConductorCurves { theta, r }
}

enum Plot {
    Dielectric {
        curves: DielectricCurves,
        /// The index as given: a number or a name.
        label: String,
    },
    Conductor {
        name: String,
        eta: [f32; 3],
        k: [f32; 3],
        curves: ConductorCurves,
    },
}

pub fn run(args: &FresnelPlotArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if args.spectral {
        let plot = crate::plot::dispersion::spectral_fresnel(
            args.ior.as_deref(),
            args.material.as_deref(),
            args.inside,
        )?;
        let (w, h) = save(&plot, &args.out, true)?;
        writeln!(out, "wrote {} ({w}×{h})", args.out.output.display())?;
        return Ok(());
    }
    let plot = match &args.material {
        Some(name) => {
            let Some((name, eta, k)) = find_conductor(name.trim()) else {
                return Err(crate::fresnel::unknown_conductor(name));
            };
            let curves = conductor_curves(eta, k, POINTS);
            Plot::Conductor {
                name,
                eta,
                k,
                curves,
            }
        }
        None => {
            let given = args.ior.as_deref().unwrap_or("1.5").trim();
            let eta = parse_ior(given)?;
            if eta == 1.0 {
                return Err(CliError::usage(
                    "η = 1 is an index-matched interface: it reflects nothing, there is no curve \
                     to draw",
                ));
            }
            let label = if given.parse::<f32>().is_ok() {
                format!("η = {eta}")
            } else {
                format!("η = {eta} ({given})")
            };
            Plot::Dielectric {
                curves: dielectric_curves(eta, args.inside, POINTS),
                label,
            }
        }
    };
    let (w, h) = save(&plot, &args.out, true)?;
    writeln!(out, "wrote {} ({w}×{h})", args.out.output.display())?;
    Ok(())
}

impl Picture for Plot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        match self {
            Plot::Dielectric { curves, label } => draw_dielectric(root, curves, label),
            Plot::Conductor {
                name,
                eta,
                k,
                curves,
            } => {
                let sub = format!(
                    "unpolarised, per linear-sRGB channel; η = ({:.3}, {:.3}, {:.3}), k = ({:.3}, \
                     {:.3}, {:.3})",
                    eta[0], eta[1], eta[2], k[0], k[1], k[2]
                );
                let area = titled(
                    root,
                    &format!("Fresnel reflectance of the conductor {name}"),
                    &sub,
                )?;
                let mut chart = line_chart(&area, 0.0..90.0, 0.0..1.0, AXIS_X, AXIS_Y)?;
                let mut drawn = Vec::new();
                for (c, (curve, colour)) in curves.r.iter().zip(CHANNEL_COLOURS).enumerate() {
                    let pts: Vec<(f64, f64)> =
                        curves.theta.iter().copied().zip(curve.clone()).collect();
                    let style = stroke(colour, 2.5);
                    drawn.push(pts.clone());
                    chart
                        .draw_series(LineSeries::new(pts, style))?
                        .label(format!("R, {} channel", ["red", "green", "blue"][c]))
                        .legend(move |p| legend_line(p, style, None));
                }
                let spot = legend_spot(&chart, &drawn, 3, 18);
                draw_legend(&mut chart, spot)?;
                Ok(())
            }
        }
    }
}

const AXIS_X: &str = "angle of incidence θi (°)";
const AXIS_Y: &str = "reflectance";

/// A vertical dashed marker at `x` with a label on the `side` of it at the height `y`.
fn marker<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    x: f64,
    (side, y): (HPos, f64),
    label: &str,
    colour: RGBColor,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    chart.draw_series(DashedLineSeries::new(
        vec![(x, 0.0), (x, 1.0)],
        px(8.0),
        px(5.0),
        stroke(colour, 2.0),
    ))?;
    let (dx, anchor) = match side {
        HPos::Left => (-0.8, HPos::Right),
        _ => (0.8, HPos::Left),
    };
    chart.draw_series(std::iter::once(Text::new(
        label.to_string(),
        (x + dx, y),
        text(16.0)
            .color(&colour)
            .pos(Pos::new(anchor, VPos::Center)),
    )))?;
    Ok(())
}

fn draw_dielectric<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    c: &DielectricCurves,
    label: &str,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let (n_i, n_t) = if c.inside { ("η", "1") } else { ("1", "η") };
    let title = format!(
        "Fresnel reflectance of a smooth dielectric, {label}, from {}",
        if c.inside { "inside" } else { "outside" }
    );
    let sub = format!(
        "light from the medium of index {n_i} onto index {n_t} (relative index {:.4}); Schlick: \
         F0 + (1 − F0)(1 − cosθ)^5 with the cosine in the thinner medium",
        c.eta_it
    );
    let area = titled(root, &title, &sub)?;
    let mut chart = line_chart(&area, 0.0..90.0, 0.0..1.0, AXIS_X, AXIS_Y)?;
    let tir_colour = RGBColor(160, 95, 0);
    if let Some(crit) = c.critical {
        chart.draw_series(std::iter::once(Rectangle::new(
            [(crit, 0.0), (90.0, 1.0)],
            RGBColor(255, 238, 210).filled(),
        )))?;
        chart.draw_series(std::iter::once(Text::new(
            "total internal reflection",
            ((crit + 90.0) / 2.0, 0.5),
            text(17.0)
                .color(&tir_colour)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        )))?;
    }
    let series: [(&str, &Vec<f64>, RGBColor, f64, bool); 4] = [
        ("Rs (s-polarised)", &c.rs, PALETTE[0], 2.0, false),
        ("Rp (p-polarised)", &c.rp, PALETTE[1], 2.0, false),
        ("R = (Rs + Rp)/2", &c.r, BLACK, 2.5, false),
        ("Schlick's approximation", &c.schlick, PALETTE[2], 2.0, true),
    ];
    for (name, ys, colour, width, dashed) in series {
        let pts: Vec<(f64, f64)> = c.theta.iter().copied().zip(ys.clone()).collect();
        let style = stroke(colour, width);
        let dash = dashed.then_some((10.0, 6.0));
        let anno = match dash {
            Some((on, off)) => {
                chart.draw_series(DashedLineSeries::new(pts, px(on), px(off), style))?
            }
            None => chart.draw_series(LineSeries::new(pts, style))?,
        };
        anno.label(name)
            .legend(move |p| legend_line(p, style, dash));
    }
    // labels where the curves and the legend leave room: right of Brewster's line from
    // outside; from inside left of it, below the legend, and the critical angle's in the
    // shaded region
    let brewster_place = if c.critical.is_some_and(|crit| crit > c.brewster) {
        (HPos::Left, 0.62)
    } else {
        (HPos::Right, 0.88)
    };
    marker(
        &mut chart,
        c.brewster,
        brewster_place,
        &format!("Brewster {:.2}° (Rp = 0)", c.brewster),
        PALETTE[1],
    )?;
    if let Some(crit) = c.critical {
        marker(
            &mut chart,
            crit,
            (HPos::Right, 0.78),
            &format!("critical angle {crit:.2}°"),
            tir_colour,
        )?;
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::tests::{assert_png_has_content, scratch};

    fn at(c: &DielectricCurves, deg: f64) -> usize {
        c.theta
            .iter()
            .position(|&t| (t - deg).abs() < 1e-9)
            .unwrap_or_else(|| panic!("{deg}° not on the grid"))
    }

    #[test]
    fn rp_vanishes_at_brewsters_angle() {
        let c = dielectric_curves(1.5, false, POINTS);
        assert!((c.brewster - 1.5f64.atan().to_degrees()).abs() < 1e-4);
        assert!((c.brewster - 56.31).abs() < 0.01);
        let i = at(&c, c.brewster);
        assert!(c.rp[i] < 1e-9, "Rp(θB) = {}", c.rp[i]);
        // and it is the minimum of the curve, with Rp > 0 elsewhere on the grid
        let min =
            c.rp.iter()
                .enumerate()
                .min_by(|a, b| a.1.total_cmp(b.1))
                .unwrap()
                .0;
        assert_eq!(min, i);
        assert!(c.rp[i - 5] > 1e-5 && c.rp[i + 5] > 1e-5);
        // normal incidence: ((η − 1)/(η + 1))² for every curve
        for v in [c.rs[0], c.rp[0], c.r[0], c.schlick[0]] {
            assert!((v - 0.04).abs() < 1e-6, "{v}");
        }
        // grazing: everything reflects
        let last = c.theta.len() - 1;
        assert!(c.r[last] > 0.999 && c.rs[last] > 0.999);
        // R is the mean of the polarisations, s reflects at least as much as p
        for i in 0..c.theta.len() {
            assert!((c.r[i] - 0.5 * (c.rs[i] + c.rp[i])).abs() < 1e-6);
            assert!(c.rs[i] >= c.rp[i] - 1e-7);
        }
        assert_eq!(c.critical, None, "no TIR from outside");
    }

    #[test]
    fn total_internal_reflection_from_inside() {
        let c = dielectric_curves(1.5, true, POINTS);
        let crit = c.critical.expect("critical angle from inside");
        assert!((crit - (1.0f64 / 1.5).asin().to_degrees()).abs() < 1e-4);
        assert!((crit - 41.81).abs() < 0.01);
        // Brewster from inside: arctan(1/1.5) = 33.69°
        assert!((c.brewster - 33.69).abs() < 0.01);
        assert!(c.rp[at(&c, c.brewster)] < 1e-9);
        for (i, &t) in c.theta.iter().enumerate() {
            if t > crit + 1e-6 {
                for v in [c.rs[i], c.rp[i], c.r[i], c.schlick[i]] {
                    assert_eq!(v, 1.0, "θ = {t}");
                }
            } else if t < crit - 0.05 {
                assert!(c.r[i] < 1.0, "θ = {t}: R = {}", c.r[i]);
            }
        }
        // from inside at normal incidence the reflectance is the same 4 %
        assert!((c.r[0] - 0.04).abs() < 1e-6);
    }

    #[test]
    fn conductor_channels() {
        let (_, eta, k) = find_conductor("Cu").unwrap();
        let c = conductor_curves(eta, k, 91);
        assert_eq!(c.theta.len(), 91);
        // copper: red reflects far more than blue at normal incidence, all → 1 at grazing
        assert!(
            c.r[0][0] > 0.9 && c.r[2][0] < 0.6,
            "{:?}",
            [c.r[0][0], c.r[2][0]]
        );
        for ch in &c.r {
            assert!((ch[90] - 1.0).abs() < 1e-3);
            assert!(ch.iter().all(|v| (0.0..=1.0 + 1e-6).contains(v)));
        }
    }

    #[test]
    fn pictures_are_written() {
        let dir = scratch("fresnel-plot");
        let mut sink = Vec::new();
        for (i, (ior, material, inside)) in [
            (Some("1.5"), None, false),
            (Some("water"), None, true),
            (None, Some("Au"), false),
        ]
        .into_iter()
        .enumerate()
        {
            for ext in ["png", "svg"] {
                let path = dir.join(format!("f{i}.{ext}"));
                let args = FresnelPlotArgs {
                    ior: ior.map(String::from),
                    material: material.map(String::from),
                    inside,
                    spectral: false,
                    out: OutputArgs {
                        output: path.clone(),
                        size: Some((640, 480)),
                    },
                };
                run(&args, &mut sink).unwrap();
                if ext == "png" {
                    assert_png_has_content(&path, (640, 480));
                } else {
                    let svg = std::fs::read_to_string(&path).unwrap();
                    assert!(svg.contains("<svg") && svg.contains("Brewster") == material.is_none());
                }
            }
        }
        let bad = FresnelPlotArgs {
            ior: Some("1.5".into()),
            material: None,
            inside: false,
            spectral: false,
            out: OutputArgs {
                output: dir.join("f.jpg"),
                size: None,
            },
        };
        let e = format!("{:?}", run(&bad, &mut sink).unwrap_err());
        assert!(e.contains("f.jpg") && e.contains(".png or .svg"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
