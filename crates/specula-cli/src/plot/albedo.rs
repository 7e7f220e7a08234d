//! `specula brdf albedo`: directional albedo ρ(θi) = ∫ f·|cosθo| dωo against the angle of
//! incidence, per channel: the white-furnace view of a material (a lossless model stays at 1;
//! a single-scattering microfacet model loses energy at grazing angles and high roughness).
//!
//! The integral is estimated with the material's own importance sampling (the mean sample
//! weight), which includes Dirac lobes; a fixed seed makes the result reproducible, and the
//! same random numbers at every angle make the curve smooth. Reflection (ωo on the side of ωi)
//! and transmission are accumulated separately.

use std::io::Write;

use clap::Args;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use specula_bsdf::check;
use specula_bsdf::rng::Pcg32;
use specula_bsdf::{Bsdf, BsdfContext, BsdfModel, ShadingPoint};

use super::{
    context, ellipsize, format_of, line_chart, px, save, side_legend, stroke, text, titled,
    DrawResult, LegendEntry, OutputArgs, Picture, CHANNEL_COLOURS, PALETTE,
};
use crate::brdf::Mode;
use crate::output::CliError;

#[derive(Debug, Args)]
pub struct AlbedoArgs {
    /// Material: a spec such as "roughconductor material=Cu alpha=0.2" (quoted, or as separate
    /// words), an XML snippet '<bsdf type=…>…</bsdf>', a MERL .binary or RGL .bsdf file, or
    /// scene.xml#id
    #[arg(required = true, num_args = 1.., value_name = "MATERIAL")]
    pub material: Vec<String>,
    /// Spacing of the incidence angles θi in degrees: 0, step, 2·step, … below 90
    #[arg(long, value_name = "DEG", default_value_t = 2.0)]
    pub step: f64,
    /// Samples per incidence angle (the standard error is printed; 200000 gives about 1e-3
    /// for an even split between reflection and transmission, far less for most materials)
    #[arg(long, default_value_t = 200_000,
          value_parser = clap::value_parser!(u32).range(100..=100_000_000))]
    pub samples: u32,
    /// Seed of the random numbers (the result is a deterministic function of it)
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Transport mode: importance (ωi is where the light comes from, so ρ is the fraction of
    /// the power that is scattered) or radiance (refraction then carries the (η_i/η_t)² factor)
    #[arg(long, value_enum, default_value_t = Mode::Importance)]
    pub mode: Mode,
    /// Texture coordinates to evaluate a spatially varying material at (textured parameters,
    /// woven cloth), on a flat surface whose ∂p/∂u, ∂p/∂v and normal are the local x, y and z
    /// axes
    #[arg(long, value_name = "U,V", value_delimiter = ',', allow_negative_numbers = true, default_values_t = [0.0, 0.0])]
    pub uv: Vec<f32>,
    #[command(flatten)]
    pub out: OutputArgs,
}

/// The albedo for one incidence angle, split into reflection and transmission, per channel,
/// with the standard errors of the estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlbedoRow {
    pub theta_i: f64,
    pub r: [f64; 3],
    pub t: [f64; 3],
    pub r_err: [f64; 3],
    pub t_err: [f64; 3],
    /// Standard error of R + T.
    pub total_err: [f64; 3],
}

impl AlbedoRow {
    pub fn total(&self) -> [f64; 3] {
        [0, 1, 2].map(|c| self.r[c] + self.t[c])
    }
}

/// Incidence angles 0, step, 2·step, … < 90 (degrees).
pub fn angles(step: f64) -> Vec<f64> {
    (0..)
        .map(|k| k as f64 * step)
        .take_while(|&t| t < 90.0 - 1e-9)
        .collect()
}

/// The albedo at incidence `theta_i` (degrees, ωi at azimuth 0) from `samples` samples of the
/// material's `sample`. Without transmission this is [`check::albedo`]; with it, the same
/// estimator (the same random numbers) with the sample weights split by the side of ωo.
#[cfg(test)]
pub fn albedo_at(
    bsdf: &Bsdf,
    ctx: &BsdfContext,
    theta_i: f64,
    samples: usize,
    seed: u64,
) -> AlbedoRow {
    albedo_at_point(bsdf, ctx, &ShadingPoint::default(), theta_i, samples, seed)
}

/// The albedo at incidence `theta_i` (as `albedo_at`) at shading point `sp`.
pub fn albedo_at_point(
    bsdf: &Bsdf,
    ctx: &BsdfContext,
    sp: &ShadingPoint,
    theta_i: f64,
    samples: usize,
    seed: u64,
) -> AlbedoRow {
    let sp = *sp;
    let wi = super::lobe::wi_at(theta_i);
    if !bsdf.flags().has_transmission() {
        let a = check::albedo(bsdf, ctx, &sp, wi, samples, seed);
        let r = a.mean.0.map(f64::from);
        let r_err = a.std_err.0.map(f64::from);
        return AlbedoRow {
            theta_i,
            r,
            t: [0.0; 3],
            r_err,
            t_err: [0.0; 3],
            total_err: r_err,
        };
    }
    // as check::albedo draws them: u1, then u2, on stream 11
    let mut rng = Pcg32::new(seed, 11);
    let mut sum = [[0.0f64; 3]; 3]; // reflection, transmission, total
    let mut sum2 = [[0.0f64; 3]; 3];
    for _ in 0..samples {
        let u1 = rng.next_f32();
        let u2 = rng.next_vec2();
        let Some(s) = bsdf.sample(ctx, &sp, wi, u1, u2) else {
            continue;
        };
        let part = if s.wo.z * wi.z > 0.0 { 0 } else { 1 };
        for c in 0..3 {
            let v = f64::from(s.weight[c]);
            for k in [part, 2] {
                sum[k][c] += v;
                sum2[k][c] += v * v;
            }
        }
    }
    let n = samples as f64;
    let mean = |k: usize| [0, 1, 2].map(|c| sum[k][c] / n);
    let err = |k: usize| {
        [0, 1, 2].map(|c| {
            let m = sum[k][c] / n;
            ((sum2[k][c] / n - m * m).max(0.0) / n).sqrt()
        })
    };
    AlbedoRow {
        theta_i,
        r: mean(0),
        t: mean(1),
        r_err: err(0),
        t_err: err(1),
        total_err: err(2),
    }
}

/// [`albedo_at`] for every angle, the angles shared among threads (the result does not depend
/// on how many).
#[cfg(test)]
pub fn albedo_curve(
    bsdf: &Bsdf,
    ctx: &BsdfContext,
    thetas: &[f64],
    samples: usize,
    seed: u64,
) -> Vec<AlbedoRow> {
    albedo_curve_at(bsdf, ctx, &ShadingPoint::default(), thetas, samples, seed)
}

/// The albedo for every angle (as `albedo_curve`) at shading point `sp`.
pub fn albedo_curve_at(
    bsdf: &Bsdf,
    ctx: &BsdfContext,
    sp: &ShadingPoint,
    thetas: &[f64],
    samples: usize,
    seed: u64,
) -> Vec<AlbedoRow> {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, thetas.len().max(1));
    let mut rows: Vec<(usize, AlbedoRow)> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                s.spawn(move || {
                    (t..thetas.len())
                        .step_by(threads)
                        .map(|i| (i, albedo_at_point(bsdf, ctx, sp, thetas[i], samples, seed)))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    rows.sort_by_key(|r| r.0);
    rows.into_iter().map(|r| r.1).collect()
}

/// True when every channel has the same value at every angle (a grey material).
fn is_grey(rows: &[AlbedoRow]) -> bool {
    let same = |v: [f64; 3]| (v[0] - v[1]).abs() <= 1e-7 && (v[0] - v[2]).abs() <= 1e-7;
    rows.iter().all(|r| same(r.r) && same(r.t))
}

struct AlbedoPicture {
    label: String,
    rows: Vec<AlbedoRow>,
    transmission: bool,
    grey: bool,
    samples: u32,
    mode: Mode,
}

pub fn run(args: &AlbedoArgs, out: &mut dyn Write) -> Result<(), CliError> {
    format_of(&args.out.output, true)?;
    if !(args.step.is_finite() && args.step >= 0.1 && args.step <= 45.0) {
        return Err(CliError::usage(format!(
            "--step must lie in [0.1, 45] degrees, got {}",
            args.step
        )));
    }
    let material = crate::material::load_material(&args.material)?;
    let bsdf = &material.bsdf;
    let transmission = bsdf.flags().has_transmission();
    let ctx = context(args.mode);
    let thetas = angles(args.step);
    let sp = super::lobe::uv_point(&args.uv)?;
    let rows = albedo_curve_at(bsdf, &ctx, &sp, &thetas, args.samples as usize, args.seed);
    let grey = is_grey(&rows);
    write_table(&material.label, &rows, transmission, args, out)?;
    let picture = AlbedoPicture {
        label: material.short_label(),
        rows,
        transmission,
        grey,
        samples: args.samples,
        mode: args.mode,
    };
    let (w, h) = save(&picture, &args.out, true)?;
    writeln!(out, "wrote {} ({w}×{h})", args.out.output.display())?;
    Ok(())
}

fn write_table(
    label: &str,
    rows: &[AlbedoRow],
    transmission: bool,
    args: &AlbedoArgs,
    out: &mut dyn Write,
) -> Result<(), CliError> {
    writeln!(out, "Directional albedo ρ(θi) = ∫ f·|cosθo| dωo of {label}",)?;
    writeln!(
        out,
        "{} transport; {} samples per angle of the material's own sampling, seed {}",
        match args.mode {
            Mode::Importance => "importance",
            Mode::Radiance => "radiance",
        },
        args.samples,
        args.seed
    )?;
    writeln!(out)?;
    let mut head = format!("{:>7}", "θi (°)");
    let groups: &[&str] = if transmission {
        &["R", "T", "R+T"]
    } else {
        &["R"]
    };
    for g in groups {
        for ch in ["r", "g", "b"] {
            head.push_str(&format!(" {:>9}", format!("{g} ({ch})")));
        }
    }
    head.push_str(&format!(" {:>9}", "± max"));
    writeln!(out, "{head}")?;
    for row in rows {
        let mut line = format!("{:>7.2}", row.theta_i);
        let mut cols = vec![row.r];
        if transmission {
            cols.push(row.t);
            cols.push(row.total());
        }
        for v in cols.iter().flatten() {
            line.push_str(&format!(" {v:>9.5}"));
        }
        let err = row
            .r_err
            .iter()
            .chain(&row.t_err)
            .chain(&row.total_err)
            .fold(0.0f64, |a, &b| a.max(b));
        line.push_str(&format!(" {err:>9.1e}"));
        writeln!(out, "{line}")?;
    }
    Ok(())
}

impl Picture for AlbedoPicture {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let max_err = self
            .rows
            .iter()
            .flat_map(|r| r.r_err.iter().chain(&r.t_err).chain(&r.total_err))
            .fold(0.0f64, |a, &b| a.max(b));
        let title = format!("Directional albedo of {}", ellipsize(&self.label, 64));
        let sub = format!(
            "ρ(θi) = ∫ f·|cosθo| dωo by the material's own sampling, {} samples per angle \
             (std. error ≤ {max_err:.1e}); {} transport",
            self.samples,
            match self.mode {
                Mode::Importance => "importance",
                Mode::Radiance => "radiance",
            }
        );
        let area = titled(root, &title, &sub)?;
        let (w, _) = area.dim_in_pixel();
        let (area, side) = area.split_horizontally(w.saturating_sub(px(190.0) as u32));
        let vmax = self
            .rows
            .iter()
            .flat_map(|r| r.total())
            .fold(0.0f64, f64::max);
        let ymax = ((vmax * 1.08).max(1.1) * 10.0).ceil() / 10.0;
        let mut chart = line_chart(
            &area,
            0.0..90.0,
            0.0..ymax,
            "angle of incidence θi (°)",
            "albedo ρ (fraction of the light scattered)",
        )?;
        // the reference: all the light is scattered
        chart.draw_series(DashedLineSeries::new(
            vec![(0.0, 1.0), (90.0, 1.0)],
            px(10.0),
            px(6.0),
            stroke(RGBColor(110, 110, 110), 1.5),
        ))?;
        chart.draw_series(std::iter::once(Text::new(
            "ρ = 1: energy conserved, nothing absorbed",
            (89.0, 1.0 + 0.012 * ymax),
            text(15.0)
                .color(&RGBColor(90, 90, 90))
                .pos(Pos::new(HPos::Right, VPos::Bottom)),
        )))?;

        let mut legend: Vec<LegendEntry> = Vec::new();
        // (name, value of a row and channel, dash pattern or solid)
        type Getter = fn(&AlbedoRow, usize) -> f64;
        type Part = (&'static str, Getter, Option<(f64, f64)>);
        let parts: Vec<Part> = if self.transmission {
            vec![
                ("R+T", |r, c| r.r[c] + r.t[c], None),
                ("R (reflection)", |r, c| r.r[c], Some((10.0, 6.0))),
                ("T (transmission)", |r, c| r.t[c], Some((3.0, 4.0))),
            ]
        } else {
            vec![("ρ (reflection)", |r, c| r.r[c], None)]
        };
        let channels: Vec<(usize, RGBColor, &str)> = if self.grey {
            vec![(1, BLACK, "")]
        } else {
            (0..3)
                .map(|c| (c, CHANNEL_COLOURS[c], ["red", "green", "blue"][c]))
                .collect()
        };
        for (k, &(name, get, dash)) in parts.iter().enumerate() {
            // a part equal in all channels (R of a tinted glass) is drawn once, in black
            let part_grey = self.rows.iter().all(|r| {
                (get(r, 0) - get(r, 1)).abs() <= 1e-7 && (get(r, 0) - get(r, 2)).abs() <= 1e-7
            });
            let one = [(1, BLACK, "")];
            let channels = if part_grey && !self.grey {
                &one[..]
            } else {
                &channels[..]
            };
            for &(c, base, ch_name) in channels {
                // a grey material with transmission: one colour per part
                let colour = if self.grey && self.transmission {
                    [BLACK, PALETTE[0], PALETTE[1]][k]
                } else {
                    base
                };
                let style = stroke(colour, if dash.is_none() { 2.5 } else { 2.0 });
                let pts: Vec<(f64, f64)> =
                    self.rows.iter().map(|r| (r.theta_i, get(r, c))).collect();
                match dash {
                    None => chart.draw_series(LineSeries::new(pts, style))?,
                    Some((on, off)) => {
                        chart.draw_series(DashedLineSeries::new(pts, px(on), px(off), style))?
                    }
                };
                // legend: every curve when grey or reflecting only; otherwise one entry per
                // channel (solid) and one per part (black, in its dash pattern)
                if self.grey || !self.transmission {
                    let label = if ch_name.is_empty() {
                        name.to_string()
                    } else {
                        format!("{name}, {ch_name}")
                    };
                    legend.push(LegendEntry { label, style, dash });
                }
            }
        }
        if self.transmission && !self.grey {
            for (c, name) in ["red", "green", "blue"].into_iter().enumerate() {
                legend.push(LegendEntry {
                    label: format!("{name} channel"),
                    style: stroke(CHANNEL_COLOURS[c], 2.5),
                    dash: None,
                });
            }
            for &(name, _, dash) in &parts {
                legend.push(LegendEntry {
                    label: name.to_string(),
                    style: stroke(BLACK, 2.0),
                    dash,
                });
            }
        }
        side_legend(&side, "curves", &legend, 20.0)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::tests::{assert_png_has_content, scratch};
    use specula_bsdf::fresnel::fresnel_dielectric;
    use specula_bsdf::parse_spec;

    const N: usize = 100_000;

    #[test]
    fn angle_grid() {
        assert_eq!(angles(30.0), vec![0.0, 30.0, 60.0]);
        assert_eq!(angles(2.0).len(), 45);
        assert_eq!(*angles(2.0).last().unwrap(), 88.0);
    }

    #[test]
    fn diffuse_albedo_is_its_reflectance() {
        let b = parse_spec("diffuse reflectance=0.5").unwrap();
        let rows = albedo_curve(&b, &BsdfContext::IMPORTANCE, &angles(15.0), N, 1);
        assert_eq!(rows.len(), 6);
        for r in &rows {
            for c in 0..3 {
                // every sample weighs ρ exactly: no noise at all
                assert!((r.r[c] - 0.5).abs() < 1e-6, "θi = {}: {:?}", r.theta_i, r.r);
                assert!(r.r_err[c] < 1e-6);
                assert_eq!(r.t[c], 0.0);
            }
        }
        assert!(is_grey(&rows));
    }

    #[test]
    fn smooth_glass_conserves_energy_and_splits_by_fresnel() {
        let b = parse_spec("dielectric int_ior=1.5 ext_ior=1").unwrap();
        let ctx = BsdfContext::IMPORTANCE;
        for theta in [0.0, 30.0, 60.0, 85.0] {
            let r = albedo_at(&b, &ctx, theta, N, 3);
            let fresnel = f64::from(fresnel_dielectric(theta.to_radians().cos() as f32, 1.5).r);
            for c in 0..3 {
                assert!((r.total()[c] - 1.0).abs() < 1e-6, "θi = {theta}: {r:?}");
                // R is a fraction of Bernoulli trials with probability F
                let sigma = (fresnel * (1.0 - fresnel) / N as f64).sqrt();
                assert!(
                    (r.r[c] - fresnel).abs() <= 4.0 * sigma + 1e-9,
                    "θi = {theta}: R = {} vs Fresnel {fresnel}",
                    r.r[c]
                );
                assert!((r.r_err[c] - sigma).abs() < 0.05 * sigma + 1e-9);
            }
        }
        // radiance transport scales refracted radiance by (η_i/η_t)² = 1/2.25
        let imp = albedo_at(&b, &ctx, 30.0, N, 3);
        let rad = albedo_at(&b, &BsdfContext::RADIANCE, 30.0, N, 3);
        assert!((rad.r[0] - imp.r[0]).abs() < 1e-12);
        assert!((rad.t[0] - imp.t[0] / 2.25).abs() < 1e-5, "{rad:?} {imp:?}");
    }

    #[test]
    fn split_estimate_sums_to_the_shared_helper() {
        // R + T uses the same random numbers as check::albedo, so it is the same estimate
        let b = parse_spec("roughdielectric alpha=0.3 int_ior=1.5 ext_ior=1").unwrap();
        let ctx = BsdfContext::IMPORTANCE;
        let sp = ShadingPoint::default();
        for theta in [10.0, 70.0] {
            let r = albedo_at(&b, &ctx, theta, 20_000, 9);
            let a = check::albedo(&b, &ctx, &sp, super::super::lobe::wi_at(theta), 20_000, 9);
            for c in 0..3 {
                assert!((r.total()[c] - f64::from(a.mean[c])).abs() < 1e-5);
                assert!(r.r[c] > 0.0 && r.t[c] > 0.0);
            }
        }
    }

    /// ∫ f·cosθo dωo by the midpoint rule in (cosθo, φo): an estimate independent of sampling.
    fn quadrature(b: &Bsdf, theta_i: f64) -> f64 {
        let (ctx, sp) = (BsdfContext::IMPORTANCE, ShadingPoint::default());
        let wi = super::super::lobe::wi_at(theta_i);
        let (nu, nphi) = (400, 800);
        let mut sum = 0.0;
        for i in 0..nu {
            let u = (i as f64 + 0.5) / nu as f64;
            let s = (1.0 - u * u).sqrt();
            for j in 0..nphi {
                let phi = (j as f64 + 0.5) / nphi as f64 * std::f64::consts::TAU;
                let wo = glam::Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, u as f32);
                sum += f64::from(b.eval_cos(&ctx, &sp, wi, wo)[1]);
            }
        }
        sum * std::f64::consts::TAU / (nu * nphi) as f64
    }

    #[test]
    fn rough_conductor_matches_quadrature_and_loses_energy() {
        // a white (lossless Fresnel) rough conductor: single scattering misses the light that
        // would bounce between microfacets, the more the rougher
        let rough = parse_spec("roughconductor material=none alpha=0.5 distribution=ggx").unwrap();
        let thetas = [0.0, 45.0, 70.0];
        let rows = albedo_curve(&rough, &BsdfContext::IMPORTANCE, &thetas, N, 1);
        for (row, &t) in rows.iter().zip(&thetas) {
            let q = quadrature(&rough, t);
            let (mc, err) = (row.r[1], row.r_err[1]);
            assert!(
                (mc - q).abs() < 4.0 * err + 2e-3,
                "θi = {t}: {mc} ± {err} vs {q}"
            );
            assert!(mc < 0.95, "θi = {t}: {mc}");
        }
        let smooth = parse_spec("roughconductor material=none alpha=0.02").unwrap();
        for row in albedo_curve(&smooth, &BsdfContext::IMPORTANCE, &thetas, N, 1) {
            assert!((row.r[1] - 1.0).abs() < 2e-3, "{row:?}");
        }
        // the thread count does not matter: the same as one angle at a time
        let one = albedo_at(&rough, &BsdfContext::IMPORTANCE, 45.0, N, 1);
        assert_eq!(one, rows[1]);
    }

    #[test]
    fn table_and_pictures() {
        let dir = scratch("albedo-plot");
        for (mat, file, columns) in [
            ("roughconductor material=Cu alpha=0.5", "cu.png", 5),
            ("roughdielectric alpha=0.3", "glass.svg", 11),
            (
                "roughdielectric alpha=0.3 specular_transmittance=0.5,0.8,1",
                "tint.png",
                11,
            ),
        ] {
            let args = AlbedoArgs {
                material: vec![mat.to_string()],
                step: 10.0,
                samples: 2000,
                seed: 1,
                mode: Mode::Importance,
                uv: vec![0.0, 0.0],
                out: OutputArgs {
                    output: dir.join(file),
                    size: Some((640, 480)),
                },
            };
            let mut out = Vec::new();
            run(&args, &mut out).unwrap();
            let text = String::from_utf8(out).unwrap();
            let rows: Vec<Vec<f64>> = text
                .lines()
                .filter_map(|l| {
                    l.split_whitespace()
                        .map(str::parse::<f64>)
                        .collect::<Result<Vec<_>, _>>()
                        .ok()
                        .filter(|v| !v.is_empty())
                })
                .collect();
            assert_eq!(rows.len(), 9, "{text}");
            assert!(rows.iter().all(|r| r.len() == columns), "{text}");
            assert!(text.contains(&format!("wrote {}", dir.join(file).display())));
            if file.ends_with(".png") {
                assert_png_has_content(&dir.join(file), (640, 480));
            } else {
                let svg = std::fs::read_to_string(dir.join(file)).unwrap();
                assert!(svg.contains("<svg") && svg.contains("T (transmission)"));
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
