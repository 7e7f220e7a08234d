//! `specula phase plot`: phase functions as polar plots, with sampled histograms.
//!
//! Light travels from left to right; the scattering angle θ is measured from its direction
//! of travel, so θ = 0° (right) is forward scattering and θ = 180° (left) back scattering.
//! In Mitsuba's convention (`wi` points back along the arriving ray) the function drawn is
//! p(θ) = phase.eval(wi = −x, wo = (cos θ, sin θ, 0)); phase functions are symmetric about
//! the axis, so the lower half mirrors the upper one.
//!
//! The left panel is the polar plot (radius p(θ) in 1/sr, linear or logarithmic); the right
//! panel is p against θ with, under each analytic curve, a histogram of `--samples`
//! directions drawn by the phase function's own `sample` (fixed seed): the density in each
//! 2° bin of θ, count / (N · 2π (cos θa − cos θb)). The two agree when sampling is right.
//! The command also prints each function's normalisation ∫p dω and mean cosine ⟨cos θ⟩
//! (analytic, by quadrature, and from the samples).

use std::io::Write;

use clap::Args;
use glam::Vec3;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use specula_bsdf::rng::Pcg32;
use specula_render::media::PhaseFunction;

use super::lobe::Scale;
use super::{
    ellipsize, fit_aspect, px, save, side_legend, stroke, text, tick_label, titled, DrawResult,
    LegendEntry, OutputArgs, Picture, GRID, PALETTE,
};
use crate::output::CliError;
use crate::phase::{load_phases, Phase};

/// Angular step of the curves (degrees).
const STEP_DEG: f64 = 0.25;
/// Histogram bins over θ ∈ [0°, 180°].
const BINS: usize = 90;
/// Seed of the sampled histograms (the picture is deterministic).
const SEED: u64 = 0x9a5e;

#[derive(Debug, Args)]
pub struct PhaseArgs {
    /// Phase functions: specs such as `hg g=0.7`, `isotropic`, `rayleigh`,
    /// "blendphase weight=0.3 { isotropic } { hg g=0.9 }", or XML snippets
    /// '<phase type="hg"><float name="g" value="0.7"/></phase>'; one curve each (at most 10)
    #[arg(value_name = "PHASE")]
    pub phases: Vec<String>,
    /// Henyey–Greenstein asymmetries, comma separated: every `hg` given without g= becomes
    /// one curve per value (and `--g` alone means hg)
    #[arg(
        long,
        value_name = "G,…",
        value_delimiter = ',',
        allow_negative_numbers = true
    )]
    pub g: Vec<f64>,
    /// Logarithmic radius and ordinate (spanning --decades decades below the largest value)
    #[arg(long)]
    pub log: bool,
    /// Decades shown by --log [default: enough for the smallest value, at most 6]
    #[arg(long, requires = "log", value_parser = clap::value_parser!(u32).range(1..=12))]
    pub decades: Option<u32>,
    /// Directions sampled per phase function for the histograms (0: no histograms)
    #[arg(long, value_name = "N", default_value_t = 200_000,
          value_parser = clap::value_parser!(u32).range(0..=100_000_000))]
    pub samples: u32,
    #[command(flatten)]
    pub out: OutputArgs,
}

/// p(θ) for the scattering angle θ (radians) from the direction of travel.
pub fn p_at(phase: &PhaseFunction, theta: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    let wi = Vec3::new(-1.0, 0.0, 0.0);
    f64::from(phase.eval(wi, Vec3::new(c as f32, s as f32, 0.0)))
}

/// (∫ p dω, ⟨cos θ⟩) by the midpoint rule in θ (fine enough for g = 0.99).
pub fn moments(phase: &PhaseFunction) -> (f64, f64) {
    let n = 40_000;
    let dt = std::f64::consts::PI / n as f64;
    let (mut norm, mut mean) = (0.0, 0.0);
    for i in 0..n {
        let t = (i as f64 + 0.5) * dt;
        let w = p_at(phase, t) * 2.0 * std::f64::consts::PI * t.sin() * dt;
        norm += w;
        mean += w * t.cos();
    }
    (norm, mean / norm)
}

/// A sampled histogram: the density estimate per 2° bin and the sample mean of cos θ.
#[derive(Clone, Debug)]
pub struct Histogram {
    pub density: Vec<f64>,
    pub mean_cos: f64,
    /// Samples the phase function refused (`sample` gave `None`).
    pub failed: u32,
}

pub fn histogram(phase: &PhaseFunction, n: u32, seed: u64) -> Histogram {
    let wi = Vec3::new(-1.0, 0.0, 0.0);
    let mut rng = Pcg32::new(seed, 5);
    let mut counts = vec![0u64; BINS];
    let (mut sum_cos, mut failed) = (0.0f64, 0u32);
    for _ in 0..n {
        let u1 = rng.next_f32();
        let u2 = rng.next_vec2();
        let Some(s) = phase.sample(wi, u1, u2) else {
            failed += 1;
            continue;
        };
        let c = f64::from(s.wo.x.clamp(-1.0, 1.0));
        sum_cos += c;
        let bin = ((c.acos() / std::f64::consts::PI) * BINS as f64) as usize;
        counts[bin.min(BINS - 1)] += 1;
    }
    let dt = std::f64::consts::PI / BINS as f64;
    let density = counts
        .iter()
        .enumerate()
        .map(|(k, &c)| {
            let (a, b) = (k as f64 * dt, (k + 1) as f64 * dt);
            c as f64 / (f64::from(n) * 2.0 * std::f64::consts::PI * (a.cos() - b.cos()))
        })
        .collect();
    Histogram {
        density,
        mean_cos: sum_cos / f64::from(n.saturating_sub(failed).max(1)),
        failed,
    }
}

/// One phase function of the picture.
struct Curve {
    label: String,
    /// (θ in degrees, p) for θ ∈ [0°, 360°].
    points: Vec<(f64, f64)>,
    hist: Option<Histogram>,
}

struct PhasePicture {
    curves: Vec<Curve>,
    scale: Scale,
    log: Option<u32>,
    vmax: f64,
    samples: u32,
}

pub fn run(args: &PhaseArgs, out: &mut dyn Write) -> Result<(), CliError> {
    let phases: Vec<Phase> = load_phases(&args.phases, &args.g)?;
    if phases.len() > PALETTE.len() {
        return Err(CliError::usage(format!(
            "at most {} phase functions per picture, got {}",
            PALETTE.len(),
            phases.len()
        )));
    }
    crate::plot::format_of(&args.out.output, true)?;
    let n = (360.0 / STEP_DEG).round() as usize;
    let mut curves = Vec::new();
    writeln!(
        out,
        "{:<44} {:>9} {:>10} {:>10}",
        "phase function", "∫p dω", "⟨cosθ⟩", "sampled"
    )?;
    for (k, p) in phases.iter().enumerate() {
        let points: Vec<(f64, f64)> = (0..=n)
            .map(|i| {
                let t = 360.0 * i as f64 / n as f64;
                (t, p_at(&p.phase, t.to_radians()))
            })
            .collect();
        let (norm, mean) = moments(&p.phase);
        let mean = if mean.abs() < 5e-6 { 0.0 } else { mean };
        let hist = (args.samples > 0).then(|| histogram(&p.phase, args.samples, SEED + k as u64));
        writeln!(
            out,
            "{:<44} {:>9.5} {:>10.5} {:>10}",
            ellipsize(&p.label, 44),
            norm,
            mean,
            hist.as_ref()
                .map_or("-".to_string(), |h| format!("{:.5}", h.mean_cos))
        )?;
        if let Some(h) = hist.as_ref().filter(|h| h.failed > 0) {
            writeln!(
                out,
                "  warning: {} of {} samples were refused by {}",
                h.failed, args.samples, p.label
            )?;
        }
        curves.push(Curve {
            label: p.label.clone(),
            points,
            hist,
        });
    }
    let vmax = curves
        .iter()
        .flat_map(|c| c.points.iter().map(|p| p.1))
        .fold(0.0f64, f64::max);
    if !(vmax.is_finite() && vmax > 0.0) {
        return Err(CliError::usage(
            "the phase functions are 0 or not finite everywhere: nothing to draw",
        ));
    }
    let log = args.log.then(|| {
        args.decades.unwrap_or_else(|| {
            let vmin = curves
                .iter()
                .flat_map(|c| c.points.iter().map(|p| p.1))
                .filter(|&v| v > 0.0)
                .fold(f64::INFINITY, f64::min);
            auto_decades(vmax, vmin)
        })
    });
    let picture = PhasePicture {
        curves,
        scale: Scale::new(vmax, log),
        log,
        vmax,
        samples: args.samples,
    };
    let (w, h) = save(&picture, &args.out, true)?;
    writeln!(out, "wrote {} ({w}×{h})", args.out.output.display())?;
    Ok(())
}

/// Decades from the top ring (10^⌈log10 vmax⌉) down to below `vmin`: 1 to 6.
pub fn auto_decades(vmax: f64, vmin: f64) -> u32 {
    let top = vmax.log10().ceil();
    let span = (top - vmin.log10()).ceil();
    if span.is_finite() {
        span.clamp(1.0, 6.0) as u32
    } else {
        6
    }
}

/// Splits a polyline into the runs whose points are `keep`.
fn runs(points: &[(f64, f64)], keep: impl Fn(&(f64, f64)) -> bool) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = vec![];
    let mut cur = vec![];
    for p in points {
        if keep(p) {
            cur.push(*p);
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// A colour blended towards white by `t`.
fn lighter(c: RGBColor, t: f64) -> RGBColor {
    let m = |v: u8| (f64::from(v) + (255.0 - f64::from(v)) * t).round() as u8;
    RGBColor(m(c.0), m(c.1), m(c.2))
}

impl PhasePicture {
    /// The ordinate of a value in the right panel: p, or log10 p clamped to the bottom.
    fn y_of(&self, v: f64) -> f64 {
        match self.log {
            None => v,
            Some(_) => v.max(1e-300).log10().max(self.y_range().start),
        }
    }

    fn y_range(&self) -> std::ops::Range<f64> {
        match self.scale {
            Scale::Log { top, decades } => f64::from(top - decades as i32)..f64::from(top),
            Scale::Linear { .. } => 0.0..self.vmax * 1.08,
        }
    }

    fn draw_polar<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let area = fit_aspect(&area.margin(px(5.0), px(5.0), px(5.0), px(5.0)), 1.0);
        let mut chart =
            ChartBuilder::on(&area).build_cartesian_2d(-1.22f64..1.22f64, -1.22f64..1.22f64)?;
        let at = |deg: f64, r: f64| {
            let (s, c) = deg.to_radians().sin_cos();
            (r * c, r * s)
        };
        let rings = self.scale.rings();
        for (r, _) in &rings {
            let circle: Vec<(f64, f64)> = (0..=720).map(|k| at(f64::from(k) / 2.0, *r)).collect();
            chart.draw_series(LineSeries::new(circle, stroke(GRID, 1.0)))?;
        }
        for k in 0..12 {
            let a = f64::from(k * 30);
            chart.draw_series(LineSeries::new(
                vec![(0.0, 0.0), at(a, 1.0)],
                stroke(RGBColor(228, 228, 228), 1.0),
            ))?;
            let shown = if a > 180.0 { 360.0 - a } else { a };
            chart.draw_series(std::iter::once(Text::new(
                format!("{shown}°"),
                at(a, 1.11),
                text(14.0)
                    .color(&RGBColor(90, 90, 90))
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            )))?;
        }
        // ring values along the lower right spoke
        for (r, label) in &rings {
            let (x, y) = at(-75.0, *r);
            chart.draw_series(std::iter::once(Text::new(
                label.clone(),
                (x + 0.02, y),
                text(12.0)
                    .color(&RGBColor(90, 90, 90))
                    .pos(Pos::new(HPos::Left, VPos::Center)),
            )))?;
        }
        // the arriving light: a grey arrow along the axis from the left
        let grey = RGBColor(110, 110, 110);
        chart.draw_series(LineSeries::new(
            vec![(-1.0, 0.0), (0.0, 0.0)],
            stroke(grey, 1.2),
        ))?;
        let (tip, base) = (-0.5, -0.6);
        chart.draw_series(std::iter::once(Polygon::new(
            vec![(tip, 0.0), (base, 0.03), (base, -0.03)],
            grey.filled(),
        )))?;
        for (i, c) in self.curves.iter().enumerate() {
            let pts: Vec<(f64, f64)> = c
                .points
                .iter()
                .map(|&(t, v)| at(t, self.scale.radius(v)))
                .collect();
            chart.draw_series(LineSeries::new(pts, stroke(PALETTE[i], 2.0)))?;
        }
        Ok(())
    }

    fn draw_cartesian<DB: DrawingBackend>(&self, area: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let yr = self.y_range();
        let log = self.log.is_some();
        let mut chart = ChartBuilder::on(area)
            .margin(px(15.0))
            .margin_right(px(20.0))
            .x_label_area_size(px(50.0))
            .y_label_area_size(px(60.0))
            .build_cartesian_2d(0f64..180f64, yr.clone())?;
        let decades = (yr.end - yr.start).round() as usize;
        chart
            .configure_mesh()
            .x_desc("scattering angle θ (degrees)")
            .y_desc(if log {
                "p(θ) (1/sr), log scale"
            } else {
                "p(θ) (1/sr)"
            })
            .x_labels(7)
            .y_labels(if log { decades + 1 } else { 8 })
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| {
                if log {
                    tick_label(10f64.powf(*v))
                } else {
                    tick_label(*v)
                }
            })
            .axis_desc_style(text(16.0))
            .label_style(text(14.0))
            .light_line_style(TRANSPARENT)
            .bold_line_style(stroke(RGBColor(225, 225, 225), 1.0))
            .axis_style(stroke(RGBColor(60, 60, 60), 1.0))
            .set_all_tick_mark_size(px(5.0))
            .draw()?;
        let bin = 180.0 / BINS as f64;
        for (i, c) in self.curves.iter().enumerate() {
            if let Some(h) = &c.hist {
                let mut steps = Vec::with_capacity(2 * BINS);
                for (k, &d) in h.density.iter().enumerate() {
                    steps.push((k as f64 * bin, d));
                    steps.push(((k + 1) as f64 * bin, d));
                }
                // on a log scale, bins without samples (and below the range) break the steps
                for run in runs(&steps, |p| !log || self.y_of(p.1) > yr.start) {
                    let run = run.into_iter().map(|(x, d)| (x, self.y_of(d)));
                    chart
                        .draw_series(LineSeries::new(run, stroke(lighter(PALETTE[i], 0.5), 1.5)))?;
                }
            }
        }
        for (i, c) in self.curves.iter().enumerate() {
            let pts: Vec<(f64, f64)> = c
                .points
                .iter()
                .take_while(|p| p.0 <= 180.0 + 1e-9)
                .map(|&(t, v)| (t, self.y_of(v)))
                .collect();
            // values below a log scale's range are left out, not drawn along its floor
            for run in runs(&pts, |p| !log || p.1 > yr.start) {
                chart.draw_series(LineSeries::new(run, stroke(PALETTE[i], 2.0)))?;
            }
        }
        Ok(())
    }
}

impl Picture for PhasePicture {
    fn default_size(&self) -> (u32, u32) {
        (1200, 560)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let title = if self.curves.len() == 1 {
            format!("Phase function {}", ellipsize(&self.curves[0].label, 60))
        } else {
            "Phase functions".to_string()
        };
        let sub =
            format!(
            "p(θ) (1/sr) against the scattering angle θ from the direction of travel; {} scale{}",
            if self.log.is_some() {
                "logarithmic"
            } else {
                "linear"
            },
            if self.samples > 0 {
                format!("; pale steps: histogram of {} sampled directions", self.samples)
            } else {
                String::new()
            }
        );
        let area = titled(root, &title, &sub)?;
        let (w, _) = area.dim_in_pixel();
        let side_w = (px(250.0) as u32).min(w / 4);
        let (plots, side) = area.split_horizontally(w - side_w);
        let (pw, _) = plots.dim_in_pixel();
        let (polar, cart) = plots.split_horizontally(pw * 9 / 20);
        self.draw_polar(&polar)?;
        self.draw_cartesian(&cart)?;

        let entries: Vec<LegendEntry> = self
            .curves
            .iter()
            .enumerate()
            .map(|(i, c)| LegendEntry {
                label: ellipsize(&c.label, 22),
                style: stroke(PALETTE[i], 3.0),
                dash: None,
            })
            .collect();
        let mut y = side_legend(&side, "phase function", &entries, 20.0)? + 14.0;
        let note = text(13.0).color(&RGBColor(70, 70, 70));
        let mut lines = vec![
            "light travels left to right (arrow)".to_string(),
            "θ = 0°: forward scattering".to_string(),
            "θ = 180°: back scattering".to_string(),
            "radius / ordinate: p(θ) (1/sr)".to_string(),
        ];
        if let Scale::Log { top, decades } = self.scale {
            let centre = tick_label(10f64.powi(top - decades as i32));
            lines.push(format!("centre: {centre} and below"));
        }
        if self.samples > 0 {
            lines.push(String::new());
            lines.push("pale steps (right): density of".to_string());
            lines.push("sampled directions per 2° bin".to_string());
        }
        for line in lines {
            side.draw_text(&line, &note, (px(10.0), px(y)))?;
            y += 19.0;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::tests::{assert_png_has_content, scratch};

    #[test]
    fn quadrature_gives_unit_mass_and_g() {
        for (p, g) in [
            (PhaseFunction::Isotropic, 0.0),
            (PhaseFunction::HenyeyGreenstein { g: 0.7 }, 0.7),
            (PhaseFunction::HenyeyGreenstein { g: -0.95 }, -0.95),
            (PhaseFunction::Rayleigh, 0.0),
        ] {
            let (norm, mean) = moments(&p);
            assert!((norm - 1.0).abs() < 1e-3, "{p:?}: {norm}");
            assert!((mean - g).abs() < 1e-3, "{p:?}: {mean}");
        }
        // forward is θ = 0: hg(0.6) gives Mitsuba's 0.795775 there
        let hg = PhaseFunction::HenyeyGreenstein { g: 0.6 };
        assert!((p_at(&hg, 0.0) - 0.795775).abs() < 1e-5);
        assert!((p_at(&hg, std::f64::consts::PI) - 0.012434).abs() < 1e-5);
    }

    #[test]
    fn log_scales_reach_the_smallest_value() {
        // hg(0.9): 15.9 forward, 0.0022 backward → 10^2 down to 10^-3
        assert_eq!(auto_decades(15.9, 0.0022), 5);
        assert_eq!(auto_decades(0.0796, 0.0796), 1);
        assert_eq!(auto_decades(1e3, 1e-9), 6);
        let r = runs(&[(0.0, 1.0), (1.0, -1.0), (2.0, 2.0), (3.0, 3.0)], |p| {
            p.1 > 0.0
        });
        assert_eq!(r, vec![vec![(0.0, 1.0)], vec![(2.0, 2.0), (3.0, 3.0)]]);
    }

    #[test]
    fn histograms_follow_the_curves() {
        // the sampled density of every bin lies within 5σ of the bin's analytic mean
        let blend = PhaseFunction::Blend {
            weight: 0.4,
            first: Box::new(PhaseFunction::Rayleigh),
            second: Box::new(PhaseFunction::HenyeyGreenstein { g: -0.6 }),
        };
        let n = 400_000;
        for p in [PhaseFunction::HenyeyGreenstein { g: 0.8 }, blend] {
            let h = histogram(&p, n, 1);
            assert_eq!(h.failed, 0);
            let dt = std::f64::consts::PI / BINS as f64;
            for (k, &d) in h.density.iter().enumerate() {
                let (a, b) = (k as f64 * dt, (k + 1) as f64 * dt);
                // probability of the bin by the midpoint rule
                let m = 64;
                let prob: f64 = (0..m)
                    .map(|j| {
                        let t = a + (j as f64 + 0.5) * (b - a) / m as f64;
                        p_at(&p, t) * 2.0 * std::f64::consts::PI * t.sin() * (b - a) / m as f64
                    })
                    .sum();
                let sa = 2.0 * std::f64::consts::PI * (a.cos() - b.cos());
                let expect = prob / sa;
                let sigma = (prob * (1.0 - prob) / f64::from(n)).sqrt() / sa;
                assert!(
                    (d - expect).abs() <= 5.0 * sigma + 1e-9,
                    "{p:?} bin {k}: {d} vs {expect} ± {sigma}"
                );
            }
        }
        let h = histogram(&PhaseFunction::HenyeyGreenstein { g: 0.5 }, n, 2);
        assert!((h.mean_cos - 0.5).abs() < 0.01, "{}", h.mean_cos);
    }

    fn args(phases: &[&str], g: &[f64], out: std::path::PathBuf) -> PhaseArgs {
        PhaseArgs {
            phases: phases.iter().map(|s| s.to_string()).collect(),
            g: g.to_vec(),
            log: false,
            decades: None,
            samples: 20_000,
            out: OutputArgs {
                output: out,
                size: None,
            },
        }
    }

    #[test]
    fn pictures_are_written() {
        let dir = scratch("phase-plot");
        let mut sink = Vec::new();
        let png = dir.join("hg.png");
        run(&args(&["hg"], &[0.3, 0.7, -0.5], png.clone()), &mut sink).unwrap();
        assert_png_has_content(&png, (1200, 560));
        let report = String::from_utf8(sink.clone()).unwrap();
        assert!(
            report.contains("hg g=0.7") && report.contains("wrote"),
            "{report}"
        );
        let mut a = args(
            &[
                "rayleigh",
                "blendphase weight=0.3 { isotropic } { hg g=0.9 }",
            ],
            &[],
            dir.join("p.svg"),
        );
        a.log = true;
        run(&a, &mut sink).unwrap();
        let svg = std::fs::read_to_string(dir.join("p.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("rayleigh"));
        // bad input: a clear error and no picture
        let bad = dir.join("bad.png");
        let e = format!(
            "{:?}",
            run(&args(&["hg g=1"], &[], bad.clone()), &mut sink).unwrap_err()
        );
        assert!(e.contains("(−1, 1)"), "{e}");
        let e = format!(
            "{:?}",
            run(&args(&["fog"], &[], bad.clone()), &mut sink).unwrap_err()
        );
        assert!(e.contains("'fog'") && e.contains("not supported"), "{e}");
        let e = format!(
            "{:?}",
            run(&args(&["hg"], &[0.1], dir.join("x.jpg")), &mut sink).unwrap_err()
        );
        assert!(e.contains("unsupported picture format"), "{e}");
        assert!(!bad.exists());
        std::fs::remove_dir_all(&dir).ok();
    }
}
