//! Spectral pictures: `specula fresnel dispersion` (the index of refraction n(λ) of the named
//! dispersive glasses, with a table of n_F, n_d, n_C and the Abbe number) and the curves of
//! `specula fresnel plot --spectral` (reflectance against the angle of incidence, one curve
//! per wavelength, for a dispersive glass or a conductor's measured η(λ), k(λ)).
//!
//! Curves are coloured by an approximate display colour of their wavelength
//! ([`wavelength_colour`]), for legibility only.

use std::io::Write;
use std::path::PathBuf;

use clap::Args;
use plotters::coord::Shift;
use plotters::prelude::*;
use specula_bsdf::fresnel::{critical_angle, fresnel_conductor, fresnel_dielectric};
use specula_bsdf::spectral::conductors::{self, ConductorSpectrum};
use specula_bsdf::spectral::dispersion::{
    glass, glass_names, Glass, LAMBDA_C, LAMBDA_D, LAMBDA_F, NAMED_GLASSES,
};

use super::{
    angle_grid, draw_legend, legend_line, legend_spot, line_chart, px, save, stroke, titled,
    DrawResult, OutputArgs, Picture,
};
use crate::output::CliError;

/// Wavelengths of the per-wavelength curves (nm).
pub const CURVE_WAVELENGTHS: [f32; 7] = [400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0];

#[derive(Debug, Args)]
pub struct DispersionArgs {
    /// Glasses to show, comma separated [default: all named glasses]
    #[arg(long = "glass", value_name = "NAME,…", value_delimiter = ',')]
    pub glasses: Option<Vec<String>>,
    /// Draw n(λ) into this picture (.png or .svg); without it only the table is printed
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: Option<PathBuf>,
    /// Picture size in pixels, WIDTHxHEIGHT [default: 900x700]
    #[arg(long, value_name = "WxH", value_parser = super::parse_size)]
    pub size: Option<(u32, u32)>,
}

/// An approximate sRGB display colour of a monochromatic wavelength (a piecewise-linear hue
/// ramp, dimmed towards the ends of the visible range), darkened a little for white paper.
pub fn wavelength_colour(nm: f32) -> RGBColor {
    let l = nm as f64;
    let (r, g, b) = match l {
        l if l < 440.0 => (-(l - 440.0) / 60.0, 0.0, 1.0),
        l if l < 490.0 => (0.0, (l - 440.0) / 50.0, 1.0),
        l if l < 510.0 => (0.0, 1.0, -(l - 510.0) / 20.0),
        l if l < 580.0 => ((l - 510.0) / 70.0, 1.0, 0.0),
        l if l < 645.0 => (1.0, -(l - 645.0) / 65.0, 0.0),
        _ => (1.0, 0.0, 0.0),
    };
    let fade = if l < 420.0 {
        0.3 + 0.7 * (l - 380.0).max(0.0) / 40.0
    } else if l > 640.0 {
        0.35 + 0.65 * (780.0 - l).max(0.0) / 140.0
    } else {
        1.0
    };
    let c = |v: f64| (255.0 * 0.85 * (v.clamp(0.0, 1.0) * fade).powf(0.8)).round() as u8;
    RGBColor(c(r), c(g), c(b))
}

fn find_glasses(names: &Option<Vec<String>>) -> Result<Vec<&'static Glass>, CliError> {
    match names {
        None => Ok(NAMED_GLASSES.iter().collect()),
        Some(list) => list
            .iter()
            .map(|n| {
                glass(n.trim()).ok_or_else(|| {
                    CliError::usage(format!(
                        "unknown dispersive material '{n}'; known: {}",
                        glass_names().join(", ")
                    ))
                })
            })
            .collect(),
    }
}

pub fn run(args: &DispersionArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let glasses = find_glasses(&args.glasses)?;
    writeln!(
        out,
        "Named dispersive dielectrics (indices relative to air; F, d, C lines = {LAMBDA_F}, \
         {LAMBDA_D}, {LAMBDA_C} nm)"
    )?;
    writeln!(
        out,
        "{:<15} {:>8} {:>8} {:>8} {:>7}  {:<20} source",
        "name", "n_F", "n_d", "n_C", "V_d", "formula"
    )?;
    for g in &glasses {
        writeln!(
            out,
            "{:<15} {:>8.5} {:>8.5} {:>8.5} {:>7.2}  {:<20} {}",
            g.name,
            g.ior.at(LAMBDA_F),
            g.ior.at(LAMBDA_D),
            g.ior.at(LAMBDA_C),
            g.ior.abbe_number(),
            g.ior.describe(),
            g.source
        )?;
    }
    if let Some(path) = &args.output {
        let o = OutputArgs {
            output: path.clone(),
            size: args.size,
        };
        let (w, h) = save(&DispersionPlot { glasses }, &o, true)?;
        writeln!(out, "wrote {} ({w}×{h})", path.display())?;
    }
    Ok(())
}

struct DispersionPlot {
    glasses: Vec<&'static Glass>,
}

const PALETTE_N: [RGBColor; 9] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(23, 190, 207),
];

impl Picture for DispersionPlot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let area = titled(
            root,
            "Index of refraction against wavelength",
            "Sellmeier formulas of the named dispersive dielectrics (Specula's `dispersion`), \
             relative to air; V_d = Abbe number",
        )?;
        let lambdas: Vec<f64> = (0..=80).map(|i| 380.0 + 5.0 * i as f64).collect();
        let curves: Vec<Vec<(f64, f64)>> = self
            .glasses
            .iter()
            .map(|g| {
                lambdas
                    .iter()
                    .map(|&l| (l, g.ior.at(l as f32) as f64))
                    .collect()
            })
            .collect();
        let lo = curves
            .iter()
            .flatten()
            .map(|p| p.1)
            .fold(f64::INFINITY, f64::min);
        let hi = curves
            .iter()
            .flatten()
            .map(|p| p.1)
            .fold(f64::NEG_INFINITY, f64::max);
        let pad = 0.05 * (hi - lo).max(0.01);
        let (y0, y1) = ((lo - pad) * 10.0, (hi + pad) * 10.0);
        let (y0, y1) = (y0.floor() / 10.0, y1.ceil() / 10.0);
        let mut chart = ChartBuilder::on(&area)
            .margin(px(15.0))
            .margin_right(px(30.0))
            .x_label_area_size(px(55.0))
            .y_label_area_size(px(65.0))
            .build_cartesian_2d(380.0..780.0, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc("wavelength λ (nm)")
            .y_desc("index of refraction n(λ)")
            .x_labels(9)
            .y_labels((((y1 - y0) / 0.1).round() as usize + 1).min(15))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.1}"))
            .axis_desc_style(super::text(18.0))
            .label_style(super::text(15.0))
            .light_line_style(TRANSPARENT)
            .bold_line_style(stroke(RGBColor(225, 225, 225), 1.0))
            .axis_style(stroke(RGBColor(60, 60, 60), 1.0))
            .set_all_tick_mark_size(px(5.0))
            .draw()?;
        // the Fraunhofer lines
        for (l, name) in [(LAMBDA_F, "F"), (LAMBDA_D, "d"), (LAMBDA_C, "C")] {
            let x = l as f64;
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(x, y0), (x, y1)],
                stroke(wavelength_colour(l), 1.0),
            )))?;
            chart.draw_series(std::iter::once(Text::new(
                name.to_string(),
                (x + 3.0, y0 + 0.05 * (y1 - y0)),
                super::text(15.0).color(&wavelength_colour(l)),
            )))?;
        }
        for (i, (g, pts)) in self.glasses.iter().zip(&curves).enumerate() {
            let style = stroke(PALETTE_N[i % PALETTE_N.len()], 2.5);
            chart
                .draw_series(LineSeries::new(pts.clone(), style))?
                .label(format!(
                    "{} (n_d {:.4}, V_d {:.1})",
                    g.name,
                    g.ior.n_d(),
                    g.ior.abbe_number()
                ))
                .legend(move |p| legend_line(p, style, None));
        }
        let spot = legend_spot(&chart, &curves, curves.len(), 34);
        draw_legend(&mut chart, spot)?;
        Ok(())
    }
}

/// What `fresnel plot --spectral` draws: reflectance curves per wavelength.
pub enum SpectralFresnel {
    Glass {
        glass: &'static Glass,
        /// Relative index = n(λ)/`ext`.
        ext: f32,
        inside: bool,
    },
    Conductor(ConductorSpectrum),
}

/// Points per curve.
const POINTS: usize = 181;

impl SpectralFresnel {
    /// (λ, θ grid in degrees, R) per wavelength of [`CURVE_WAVELENGTHS`].
    pub fn curves(&self) -> Vec<(f32, Vec<(f64, f64)>)> {
        CURVE_WAVELENGTHS
            .iter()
            .map(|&l| {
                let pts = match self {
                    SpectralFresnel::Glass { glass, ext, inside } => {
                        let eta = glass.ior.at(l) / ext;
                        let crit: Vec<f64> = if *inside {
                            critical_angle(eta)
                                .map(|c| f64::from(c.to_degrees()))
                                .into_iter()
                                .collect()
                        } else {
                            vec![]
                        };
                        angle_grid(90.0, POINTS, &crit)
                            .into_iter()
                            .map(|deg| {
                                let c = deg.to_radians().cos().max(0.0) as f32;
                                let cos_i = if *inside { -c } else { c };
                                (deg, f64::from(fresnel_dielectric(cos_i, eta).r))
                            })
                            .collect()
                    }
                    SpectralFresnel::Conductor(c) => {
                        let (eta, k) = c.eta_k(l);
                        angle_grid(90.0, POINTS, &[])
                            .into_iter()
                            .map(|deg| {
                                let cos = deg.to_radians().cos().max(0.0) as f32;
                                (deg, f64::from(fresnel_conductor(cos, eta, k)))
                            })
                            .collect()
                    }
                };
                (l, pts)
            })
            .collect()
    }

    /// A legend label for wavelength `l`.
    fn label(&self, l: f32) -> String {
        match self {
            SpectralFresnel::Glass { glass, ext, inside } => {
                let eta = glass.ior.at(l) / ext;
                let r0 = 100.0 * fresnel_dielectric(1.0, eta).r;
                match (inside, critical_angle(eta)) {
                    (true, Some(c)) => format!(
                        "{l} nm: η = {eta:.4}, R(0°) = {r0:.2} %, critical {:.2}°",
                        c.to_degrees()
                    ),
                    _ => format!("{l} nm: η = {eta:.4}, R(0°) = {r0:.2} %"),
                }
            }
            SpectralFresnel::Conductor(c) => {
                let (e, k) = c.eta_k(l);
                format!("{l} nm: η = {e:.3}, k = {k:.3}")
            }
        }
    }
}

impl Picture for SpectralFresnel {
    fn default_size(&self) -> (u32, u32) {
        (900, 900)
    }
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let (title, sub) = match self {
            SpectralFresnel::Glass { glass, ext, inside } => (
                format!(
                    "Fresnel reflectance of {} per wavelength, from {}",
                    glass.name,
                    if *inside { "inside" } else { "outside" }
                ),
                format!(
                    "unpolarised; η(λ) = n(λ){} with n(λ) from {} ({})",
                    if *ext == 1.0 {
                        " (relative to air)".to_string()
                    } else {
                        format!("/{ext}")
                    },
                    glass.ior.describe(),
                    glass.source
                ),
            ),
            SpectralFresnel::Conductor(c) => (
                format!(
                    "Fresnel reflectance of the conductor {} per wavelength",
                    c.name
                ),
                format!(
                    "unpolarised; measured η(λ), k(λ) ({:.0}–{:.0} nm) from Mitsuba 3's data/ior",
                    c.range().0,
                    c.range().1
                ),
            ),
        };
        let area = titled(root, &title, &sub)?;
        let h = area.dim_in_pixel().1;
        let (upper, lower) = area.split_vertically((f64::from(h) * 0.64) as u32);
        let mut chart = line_chart(
            &upper,
            0.0..90.0,
            0.0..1.0,
            "angle of incidence θi (°)",
            "reflectance",
        )?;
        let curves = self.curves();
        // lower panel: each curve minus the 550 nm one, where the curves part
        let mid = curves
            .iter()
            .position(|(l, _)| *l == 550.0)
            .expect("550 nm is a curve");
        let diffs: Vec<Vec<(f64, f64)>> = curves
            .iter()
            .map(|(_, pts)| {
                pts.iter()
                    .zip(&curves[mid].1)
                    .map(|(a, b)| (a.0, 100.0 * (a.1 - b.1)))
                    .collect()
            })
            .collect();
        let span = diffs
            .iter()
            .flatten()
            .map(|p| p.1.abs())
            .fold(0.0f64, f64::max)
            .max(1e-3);
        // a readable symmetric range: 1, 2 or 5 × 10^k percentage points
        let mag = 10f64.powf(span.log10().floor());
        let top = [1.0, 2.0, 5.0, 10.0]
            .iter()
            .map(|m| m * mag)
            .find(|v| *v >= span)
            .unwrap_or(10.0 * mag);
        let mut dchart = ChartBuilder::on(&lower)
            .margin(px(15.0))
            .margin_right(px(30.0))
            .x_label_area_size(px(55.0))
            .y_label_area_size(px(65.0))
            .build_cartesian_2d(0.0..90.0, -top..top)?;
        dchart
            .configure_mesh()
            .x_desc("angle of incidence θi (°)")
            .y_desc("R(λ) − R(550 nm) (%)")
            .x_labels(10)
            .y_labels(5)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| {
                if v.abs() < 1e-9 * top {
                    "0".into()
                } else {
                    super::tick_label(*v)
                }
            })
            .axis_desc_style(super::text(16.0))
            .label_style(super::text(14.0))
            .light_line_style(TRANSPARENT)
            .bold_line_style(stroke(RGBColor(225, 225, 225), 1.0))
            .axis_style(stroke(RGBColor(60, 60, 60), 1.0))
            .set_all_tick_mark_size(px(5.0))
            .draw()?;
        for ((l, _), pts) in curves.iter().zip(&diffs) {
            dchart.draw_series(LineSeries::new(
                pts.clone(),
                stroke(wavelength_colour(*l), 2.0),
            ))?;
        }
        let mut drawn = Vec::new();
        for (l, pts) in &curves {
            let style = stroke(wavelength_colour(*l), 2.0);
            drawn.push(pts.clone());
            chart
                .draw_series(LineSeries::new(pts.clone(), style))?
                .label(self.label(*l))
                .legend(move |p| legend_line(p, style, None));
        }
        let spot = legend_spot(&chart, &drawn, curves.len(), 34);
        draw_legend(&mut chart, spot)?;
        Ok(())
    }
}

/// The spectral Fresnel picture for `--ior NAME` (a dispersive glass) or `--material NAME`
/// (a conductor with measured spectra).
pub fn spectral_fresnel(
    ior: Option<&str>,
    material: Option<&str>,
    inside: bool,
) -> Result<SpectralFresnel, CliError> {
    if let Some(m) = material {
        let m = m.trim();
        let found = conductors::lookup(m).or_else(|| {
            conductors::names()
                .find(|n| n.eq_ignore_ascii_case(m))
                .and_then(conductors::lookup)
        });
        return found.map(SpectralFresnel::Conductor).ok_or_else(|| {
            CliError::usage(format!(
                "--spectral: no measured spectra for conductor '{m}'; known: {}",
                conductors::names().collect::<Vec<_>>().join(", ")
            ))
        });
    }
    let given = ior.unwrap_or("bk7").trim();
    let g = glass(given).ok_or_else(|| {
        CliError::usage(format!(
            "--spectral needs a dispersive material for --ior, got '{given}'; known: {}",
            glass_names().join(", ")
        ))
    })?;
    Ok(SpectralFresnel::Glass {
        glass: g,
        ext: 1.0,
        inside,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::tests::{assert_png_has_content, scratch};

    #[test]
    fn spectral_curves_follow_the_dispersion() {
        let s = spectral_fresnel(Some("sf11"), None, true).unwrap();
        let c = s.curves();
        assert_eq!(c.len(), CURVE_WAVELENGTHS.len());
        // from inside, blue (higher index) reaches total reflection at a smaller angle
        let first_total = |pts: &Vec<(f64, f64)>| pts.iter().find(|p| p.1 >= 1.0).unwrap().0;
        assert!(first_total(&c[0].1) < first_total(&c[6].1));
        // normal incidence: ((n − 1)/(n + 1))², larger in the blue
        let n400 = glass("sf11").unwrap().ior.at(400.0) as f64;
        assert!((c[0].1[0].1 - ((n400 - 1.0) / (n400 + 1.0)).powi(2)).abs() < 1e-6);
        assert!(c[0].1[0].1 > c[6].1[0].1);
        // gold reflects red far more than blue
        let au = spectral_fresnel(None, Some("au"), false).unwrap().curves();
        assert!(au[6].1[0].1 > 0.9 && au[0].1[0].1 < 0.45);
        assert!(spectral_fresnel(Some("1.5"), None, false).is_err());
        assert!(spectral_fresnel(None, Some("Xx"), false).is_err());
    }

    #[test]
    fn wavelength_colours() {
        let RGBColor(r, g, b) = wavelength_colour(450.0);
        assert!(b > r && b > g);
        let RGBColor(r, g, b) = wavelength_colour(650.0);
        assert!(r > g && r > b);
        let RGBColor(r, g, b) = wavelength_colour(530.0);
        assert!(g > r && g > b);
    }

    #[test]
    fn pictures_and_table() {
        let dir = scratch("dispersion-plot");
        let mut text = Vec::new();
        let png = dir.join("n.png");
        run(
            &DispersionArgs {
                glasses: None,
                output: Some(png.clone()),
                size: Some((640, 480)),
            },
            &mut text,
        )
        .unwrap();
        assert_png_has_content(&png, (640, 480));
        let t = String::from_utf8(text).unwrap();
        assert!(
            t.contains("bk7") && t.contains("1.51680") && t.contains("64.17"),
            "{t}"
        );
        let svg = dir.join("f.svg");
        let o = OutputArgs {
            output: svg.clone(),
            size: Some((640, 480)),
        };
        save(
            &spectral_fresnel(Some("bk7"), None, false).unwrap(),
            &o,
            true,
        )
        .unwrap();
        assert!(std::fs::read_to_string(&svg).unwrap().contains("550 nm"));
        let bad = run(
            &DispersionArgs {
                glasses: Some(vec!["kryptonite".into()]),
                output: None,
                size: None,
            },
            &mut Vec::new(),
        );
        assert!(format!("{:?}", bad.unwrap_err()).contains("kryptonite"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
