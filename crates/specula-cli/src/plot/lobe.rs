//! `specula brdf plot`: the scattering lobe in the plane of incidence, as a polar plot.
//!
//! For each incidence angle θi the curve gives, for every direction ωo in the plane of
//! incidence, the distance f(ωi, ωo)·|cosθo| (or f) from the origin. Directions are drawn
//! with the surface horizontal and its normal up, the incident direction on the left, so
//! mirror reflection lies to the right (φo = 180°) and back-scattering to the left (φo = 0°).
//! Materials that transmit get the lower half plane too.

use std::io::Write;

use clap::{Args, ValueEnum};
use glam::{Vec2, Vec3};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use specula_bsdf::{Bsdf, BsdfContext, BsdfModel, ShadingPoint};

use super::{
    context, ellipsize, fit_aspect, nice_ticks, px, save, side_legend, stroke, text, tick_label,
    titled, Channel, DrawResult, LegendEntry, OutputArgs, Picture, GRID, PALETTE,
};
use crate::brdf::Mode;
use crate::output::CliError;

/// Angular step of the curves (degrees).
const STEP_DEG: f64 = 0.25;

#[derive(Debug, Args)]
pub struct LobeArgs {
    /// Material: a spec such as "roughconductor material=Cu alpha=0.2" (quoted, or as separate
    /// words), an XML snippet '<bsdf type=…>…</bsdf>', a MERL .binary or RGL .bsdf file, or
    /// scene.xml#id
    #[arg(required = true, num_args = 1.., value_name = "MATERIAL")]
    pub material: Vec<String>,
    /// Incidence angles θi in degrees, 0 ≤ θi < 90, comma separated: one curve each (at most
    /// 10)
    #[arg(
        long,
        value_name = "DEG,…",
        value_delimiter = ',',
        default_value = "0,30,60,80"
    )]
    pub theta_i: Vec<f64>,
    /// What the radius shows: f·|cosθo| (the density of scattered light per solid angle,
    /// whose integral is the albedo) or f (the BSDF value)
    #[arg(long, value_enum, default_value_t = Quantity::FCos)]
    pub quantity: Quantity,
    /// Colour channel shown
    #[arg(long, value_enum, default_value_t = Channel::Lum)]
    pub channel: Channel,
    /// Logarithmic radius (spanning --decades decades below the largest value)
    #[arg(long)]
    pub log: bool,
    /// Decades shown by --log
    #[arg(long, default_value_t = 4, requires = "log",
          value_parser = clap::value_parser!(u32).range(1..=12))]
    pub decades: u32,
    /// Transport mode: importance (ωi is where the light comes from, so the lobe is where the
    /// light goes) or radiance (ωi towards the camera; differs only by the (η_i/η_t)² factor of
    /// refraction)
    #[arg(long, value_enum, default_value_t = Mode::Importance)]
    pub mode: Mode,
    #[command(flatten)]
    pub out: OutputArgs,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Quantity {
    /// f·|cosθo| (1/sr)
    #[value(name = "fcos")]
    FCos,
    /// f, without the cosine (1/sr)
    F,
}

impl Quantity {
    fn name(self) -> &'static str {
        match self {
            Quantity::FCos => "f·cosθo",
            Quantity::F => "f",
        }
    }
}

/// The incident direction at polar angle `theta_i` (degrees), azimuth 0.
pub fn wi_at(theta_i: f64) -> Vec3 {
    let (s, c) = theta_i.to_radians().sin_cos();
    Vec3::new(s as f32, 0.0, c as f32)
}

/// The direction in the plane of incidence drawn at angle `alpha` (degrees) clockwise from
/// the normal: positive towards the mirror side (φ = 180°), beyond ±90° below the surface.
pub fn wo_at(alpha: f64) -> Vec3 {
    let (s, c) = alpha.to_radians().sin_cos();
    Vec3::new(-s as f32, 0.0, c as f32)
}

/// The drawing angle of a direction in the plane of incidence (inverse of [`wo_at`]).
pub fn alpha_of(w: Vec3) -> f64 {
    f64::from(-w.x).atan2(f64::from(w.z)).to_degrees()
}

/// One curve of the plot.
#[derive(Clone, Debug)]
pub struct Lobe {
    pub theta_i: f64,
    /// (α, value): the value for ωo = [`wo_at`]`(α)`, α from −90° to 90° (reflection) or from
    /// −180° to 180° (with transmission).
    pub points: Vec<(f64, f64)>,
    /// Drawing angles of the Dirac lobes (mirror reflection, refraction), which f leaves out.
    pub diracs: Vec<f64>,
}

/// The lobe for incidence `theta_i`: `quantity` of `channel` at every `STEP_DEG` of the plane
/// of incidence (the upper half, or the whole circle when `transmission`).
pub fn lobe(
    bsdf: &Bsdf,
    ctx: &BsdfContext,
    theta_i: f64,
    quantity: Quantity,
    channel: Channel,
    transmission: bool,
) -> Lobe {
    let sp = ShadingPoint::default();
    let wi = wi_at(theta_i);
    let half = if transmission { 180.0 } else { 90.0 };
    let n = (2.0 * half / STEP_DEG).round() as usize;
    let points = (0..=n)
        .map(|k| {
            let alpha = -half + 2.0 * half * k as f64 / n as f64;
            let wo = wo_at(alpha);
            let f = match quantity {
                Quantity::FCos => bsdf.eval_cos(ctx, &sp, wi, wo),
                Quantity::F => bsdf.eval(ctx, &sp, wi, wo),
            };
            (alpha, channel.of(f).max(0.0))
        })
        .collect();
    Lobe {
        theta_i,
        points,
        diracs: dirac_directions(bsdf, ctx, wi),
    }
}

/// Drawing angles of the Dirac lobes a material samples for incidence `wi` (found by sampling
/// with every lobe-selection number on a fine grid).
pub fn dirac_directions(bsdf: &Bsdf, ctx: &BsdfContext, wi: Vec3) -> Vec<f64> {
    if !bsdf.flags().is_delta() {
        return Vec::new();
    }
    let sp = ShadingPoint::default();
    let mut found: Vec<f64> = Vec::new();
    const N: usize = 256;
    for k in 0..N {
        let u1 = (k as f32 + 0.5) / N as f32;
        let Some(s) = bsdf.sample(ctx, &sp, wi, u1, Vec2::splat(0.5)) else {
            continue;
        };
        if s.lobe.is_delta() && s.wo.y.abs() < 1e-3 && !s.weight.is_black() {
            let a = alpha_of(s.wo);
            if found.iter().all(|b| (a - b).abs() > 1e-3) {
                found.push(a);
            }
        }
    }
    found
}

/// How values map to the radius (1 = the outer ring).
#[derive(Clone, Debug)]
pub(crate) enum Scale {
    /// r = v / max; rings at `rings`.
    Linear { max: f64, rings: Vec<f64> },
    /// r = (log10 v − (top − decades)) / decades, clamped to [0, 1]; rings every decade.
    Log { top: i32, decades: u32 },
}

impl Scale {
    pub(crate) fn new(vmax: f64, log: Option<u32>) -> Scale {
        match log {
            Some(decades) => Scale::Log {
                top: vmax.log10().ceil() as i32,
                decades,
            },
            None => {
                let step = nice_ticks(vmax, 4).first().copied().unwrap_or(vmax);
                let n = (vmax / step - 1e-9).ceil().max(1.0) as usize;
                Scale::Linear {
                    max: n as f64 * step,
                    rings: (1..=n).map(|k| k as f64 * step).collect(),
                }
            }
        }
    }

    pub(crate) fn radius(&self, v: f64) -> f64 {
        match *self {
            Scale::Linear { max, .. } => v / max,
            Scale::Log { top, decades } => {
                if v <= 0.0 {
                    0.0
                } else {
                    ((v.log10() - f64::from(top - decades as i32)) / f64::from(decades))
                        .clamp(0.0, 1.0)
                }
            }
        }
    }

    /// (radius, label) of the rings.
    pub(crate) fn rings(&self) -> Vec<(f64, String)> {
        match self {
            Scale::Linear { max, rings } => {
                rings.iter().map(|&v| (v / max, tick_label(v))).collect()
            }
            Scale::Log { top, decades } => (1..=*decades)
                .map(|k| {
                    let e = top - *decades as i32 + k as i32;
                    (
                        f64::from(k) / f64::from(*decades),
                        tick_label(10f64.powi(e)),
                    )
                })
                .collect(),
        }
    }
}

struct LobePicture {
    label: String,
    lobes: Vec<Lobe>,
    quantity: Quantity,
    channel: Channel,
    scale: Scale,
    transmission: bool,
    mode: Mode,
}

pub fn run(args: &LobeArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if args.theta_i.is_empty() || args.theta_i.len() > PALETTE.len() {
        return Err(CliError::usage(format!(
            "--theta-i takes 1 to {} angles, got {}",
            PALETTE.len(),
            args.theta_i.len()
        )));
    }
    for &t in &args.theta_i {
        if !(t.is_finite() && (0.0..90.0).contains(&t)) {
            return Err(CliError::usage(format!(
                "--theta-i angles must lie in [0, 90) degrees, got {t}"
            )));
        }
    }
    let material = crate::material::load_material(&args.material)?;
    let bsdf = &material.bsdf;
    let flags = bsdf.flags();
    if flags.is_all_delta() {
        return Err(CliError::usage(format!(
            "{}: every lobe of this material is a Dirac delta (ideal mirror or refraction), so f \
             is 0 in every direction and there is no lobe to draw; `specula brdf albedo` shows \
             how much it reflects and transmits",
            material.short_label()
        )));
    }
    let transmission = flags.has_transmission();
    let ctx = context(args.mode);
    let lobes: Vec<Lobe> = args
        .theta_i
        .iter()
        .map(|&t| lobe(bsdf, &ctx, t, args.quantity, args.channel, transmission))
        .collect();
    let vmax = lobes
        .iter()
        .flat_map(|l| l.points.iter().map(|p| p.1))
        .fold(0.0f64, f64::max);
    if !(vmax.is_finite() && vmax > 0.0) {
        return Err(CliError::usage(format!(
            "{}: {} ({}) is {} for every direction of the plane of incidence at θi = {}°: \
             nothing to draw",
            material.short_label(),
            args.quantity.name(),
            args.channel.name(),
            if vmax.is_finite() { "0" } else { "not finite" },
            args.theta_i
                .iter()
                .map(|t| t.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    let picture = LobePicture {
        label: material.short_label(),
        lobes,
        quantity: args.quantity,
        channel: args.channel,
        scale: Scale::new(vmax, args.log.then_some(args.decades)),
        transmission,
        mode: args.mode,
    };
    let (w, h) = save(&picture, &args.out, true)?;
    writeln!(out, "wrote {} ({w}×{h})", args.out.output.display())?;
    Ok(())
}

/// Point of the drawing at angle α (degrees) and radius r.
fn at(alpha: f64, r: f64) -> (f64, f64) {
    let (s, c) = alpha.to_radians().sin_cos();
    (r * s, r * c)
}

impl Picture for LobePicture {
    fn default_size(&self) -> (u32, u32) {
        if self.transmission {
            (900, 700)
        } else {
            (900, 500)
        }
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let q = self.quantity.name();
        let title = format!(
            "Scattering lobe of {} in the plane of incidence",
            ellipsize(&self.label, 48)
        );
        let sub = format!(
            "radius: {q} (1/sr) of the {}, {} scale; {}",
            self.channel.name(),
            if matches!(self.scale, Scale::Log { .. }) {
                "logarithmic"
            } else {
                "linear"
            },
            match self.mode {
                Mode::Importance => "light arriving along the arrows",
                Mode::Radiance => "radiance transport, ωi towards the camera (arrows)",
            }
        );
        let area = titled(root, &title, &sub)?;
        let (w, _) = area.dim_in_pixel();
        let side_w = (px(210.0) as u32).min(w / 3);
        let (plot_area, side) = area.split_horizontally(w - side_w);

        let (y0, y1) = if self.transmission {
            (-1.2, 1.2)
        } else {
            (-0.14, 1.2)
        };
        let plot_area = fit_aspect(
            &plot_area.margin(px(5.0), px(5.0), px(5.0), px(5.0)),
            2.4 / (y1 - y0),
        );
        let mut chart = ChartBuilder::on(&plot_area).build_cartesian_2d(-1.2f64..1.2f64, y0..y1)?;

        // polar grid: rings, spokes every 15°, angle labels every 30°
        let half = if self.transmission { 180 } else { 90 };
        let circle = |r: f64| -> Vec<(f64, f64)> {
            (-half * 2..=half * 2)
                .map(|k| at(f64::from(k) / 2.0, r))
                .collect()
        };
        let rings = self.scale.rings();
        for (r, _) in &rings {
            chart.draw_series(LineSeries::new(circle(*r), stroke(GRID, 1.0)))?;
        }
        for k in (-half / 15)..=(half / 15) {
            let a = f64::from(k * 15);
            chart.draw_series(LineSeries::new(
                vec![(0.0, 0.0), at(a, 1.0)],
                stroke(RGBColor(228, 228, 228), 1.0),
            ))?;
            if k % 2 == 0 && a.abs() < 180.0 + 1e-9 && (a != 180.0 || !self.transmission) {
                let (x, mut y) = at(a, 1.09);
                if a.abs() == 90.0 {
                    y += 0.05; // above the surface line
                }
                chart.draw_series(std::iter::once(Text::new(
                    format!("{}°", a.abs()),
                    (x, y),
                    text(14.0)
                        .color(&RGBColor(90, 90, 90))
                        .pos(Pos::new(HPos::Center, VPos::Center)),
                )))?;
            }
        }
        // the surface: a thick line, hatched below when nothing is transmitted
        chart.draw_series(LineSeries::new(
            vec![(-1.12, 0.0), (1.12, 0.0)],
            stroke(RGBColor(70, 70, 70), 3.0),
        ))?;
        if !self.transmission {
            for k in 0..=44 {
                let x = -1.1 + 0.05 * f64::from(k);
                chart.draw_series(LineSeries::new(
                    vec![(x, 0.0), (x - 0.035, -0.045)],
                    stroke(RGBColor(120, 120, 120), 1.0),
                ))?;
            }
        }
        // ring values, just below the surface on the right
        for (r, label) in &rings {
            chart.draw_series(std::iter::once(Text::new(
                label.clone(),
                (*r, -0.06),
                text(13.0)
                    .color(&RGBColor(90, 90, 90))
                    .pos(Pos::new(HPos::Center, VPos::Top)),
            )))?;
        }

        for (i, l) in self.lobes.iter().enumerate() {
            let colour = PALETTE[i];
            // the incident direction: an arrow from the outer ring towards the surface
            let (ux, uy) = at(-l.theta_i, 1.0);
            chart.draw_series(LineSeries::new(
                vec![(ux, uy), (0.0, 0.0)],
                stroke(colour, 1.2),
            ))?;
            let tip = 0.45;
            let (tx, ty) = (ux * tip, uy * tip);
            let (nx, ny) = (-uy, ux); // perpendicular
            let (bx, by) = (ux * (tip + 0.07), uy * (tip + 0.07));
            chart.draw_series(std::iter::once(Polygon::new(
                vec![
                    (tx, ty),
                    (bx + 0.025 * nx, by + 0.025 * ny),
                    (bx - 0.025 * nx, by - 0.025 * ny),
                ],
                colour.filled(),
            )))?;
            // Dirac lobes: dashed rays
            for &a in &l.diracs {
                chart.draw_series(DashedLineSeries::new(
                    vec![(0.0, 0.0), at(a, 1.0)],
                    px(9.0),
                    px(6.0),
                    stroke(colour, 2.0),
                ))?;
            }
            let pts: Vec<(f64, f64)> = l
                .points
                .iter()
                .map(|&(a, v)| at(a, self.scale.radius(v)))
                .collect();
            chart.draw_series(LineSeries::new(pts, stroke(colour, 2.0)))?;
        }

        // side panel: legend and reading notes
        let entries: Vec<LegendEntry> = self
            .lobes
            .iter()
            .enumerate()
            .map(|(i, l)| LegendEntry {
                label: format!("θi = {}°", l.theta_i),
                style: stroke(PALETTE[i], 3.0),
                dash: None,
            })
            .collect();
        let mut y = side_legend(&side, "incidence θi", &entries, 20.0)? + 14.0;
        let note = text(13.0).color(&RGBColor(70, 70, 70));
        let mut lines = vec![
            format!("radius: {q} (1/sr)"),
            "angles: θo from the normal".to_string(),
            "right: mirror side (φo = 180°)".to_string(),
            "left: back-scattering (φo = 0°)".to_string(),
        ];
        if let Scale::Log { top, decades } = self.scale {
            let centre = tick_label(10f64.powi(top - decades as i32));
            lines.push(format!("centre: {centre} and below"));
        }
        if self.transmission {
            lines.push("below the surface: transmission".to_string());
        }
        if self.lobes.iter().any(|l| !l.diracs.is_empty()) {
            lines.push(String::new());
            lines.push("dashed rays: Dirac lobes".to_string());
            lines.push("(ideal mirror / refraction;".to_string());
            lines.push("not part of f, length arbitrary)".to_string());
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
    use specula_bsdf::parse_spec;

    #[test]
    fn directions_in_the_plane() {
        for a in [-170.0, -90.0, -30.0, 0.0, 45.0, 135.0] {
            let w = wo_at(a);
            assert!((w.length() - 1.0).abs() < 1e-6 && w.y == 0.0);
            assert!((alpha_of(w) - a).abs() < 1e-4, "{a}");
        }
        // the mirror direction of wi is drawn at α = +θi, wi itself at −θi
        let wi = wi_at(30.0);
        let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
        assert!((alpha_of(mirror) - 30.0).abs() < 1e-4);
        assert!((alpha_of(wi) + 30.0).abs() < 1e-4);
    }

    #[test]
    fn diffuse_lobe_is_a_circle() {
        // f·cosθo = ρ/π cosθo: in polar form r = c cos α, a circle of diameter c through the
        // origin, centred on the normal
        let b = parse_spec("diffuse reflectance=0.5").unwrap();
        let ctx = BsdfContext::IMPORTANCE;
        for theta_i in [0.0, 45.0, 80.0] {
            let l = lobe(&b, &ctx, theta_i, Quantity::FCos, Channel::Lum, false);
            assert_eq!(l.points.len(), 721);
            assert!(l.diracs.is_empty());
            let c = 0.5 / std::f64::consts::PI;
            for &(a, v) in &l.points {
                let (x, y) = at(a, v);
                let d = (x * x + (y - c / 2.0).powi(2)).sqrt();
                assert!((d - c / 2.0).abs() < 1e-6, "α = {a}: distance {d}");
            }
            // f alone is constant: a semicircle of radius ρ/π
            let l = lobe(&b, &ctx, theta_i, Quantity::F, Channel::R, false);
            for &(a, v) in &l.points[1..l.points.len() - 1] {
                assert!((v - c).abs() < 1e-6, "α = {a}: {v}");
            }
        }
    }

    #[test]
    fn glossy_lobe_peaks_near_the_mirror_direction() {
        let b = parse_spec("roughconductor material=Cu alpha=0.1 distribution=ggx").unwrap();
        let l = lobe(
            &b,
            &BsdfContext::IMPORTANCE,
            30.0,
            Quantity::F,
            Channel::Lum,
            false,
        );
        let peak = l.points.iter().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        assert!((peak.0 - 30.0).abs() < 0.3, "peak at {}", peak.0);
    }

    #[test]
    fn transmission_and_dirac_lobes() {
        let ctx = BsdfContext::IMPORTANCE;
        // rough glass: the lobe has a part below the surface, around the refracted direction
        let b = parse_spec("roughdielectric alpha=0.1 int_ior=1.5 ext_ior=1").unwrap();
        let l = lobe(&b, &ctx, 45.0, Quantity::FCos, Channel::Lum, true);
        assert_eq!(l.points.len(), 1441);
        let below = l.points.iter().filter(|p| p.0.abs() > 90.0);
        let peak = below.max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
        // Snell: sin θt = sin 45° / 1.5 → θt = 28.13°, drawn at α = 180° − θt
        let theta_t = (45f64.to_radians().sin() / 1.5).asin().to_degrees();
        assert!((peak.0 - (180.0 - theta_t)).abs() < 1.0, "{peak:?}");
        // smooth glass: Dirac reflection at +θi and refraction at 180° − θt
        let g = parse_spec("dielectric int_ior=1.5 ext_ior=1").unwrap();
        let mut d = dirac_directions(&g, &ctx, wi_at(45.0));
        d.sort_by(f64::total_cmp);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(
            (d[0] - 45.0).abs() < 1e-3 && (d[1] - (180.0 - theta_t)).abs() < 1e-3,
            "{d:?}"
        );
        // plastic: a Dirac coat over a diffuse base
        let p = parse_spec("plastic").unwrap();
        let l = lobe(&p, &ctx, 60.0, Quantity::FCos, Channel::Lum, false);
        assert_eq!(l.diracs.len(), 1);
        assert!((l.diracs[0] - 60.0).abs() < 1e-3);
    }

    #[test]
    fn log_scale_rings() {
        let s = Scale::new(3.2, Some(3));
        assert!((s.radius(10.0) - 1.0).abs() < 1e-12);
        assert!((s.radius(0.1) - 1.0 / 3.0).abs() < 1e-12);
        assert_eq!(s.radius(1e-5), 0.0);
        assert_eq!(s.rings().last().unwrap().1, "10");
        assert_eq!(s.rings()[0].1, "0.1");
        let s = Scale::new(0.159, None);
        let rings = s.rings();
        assert!((rings.last().unwrap().0 - 1.0).abs() < 1e-12);
        assert!(s.radius(0.159) <= 1.0);
    }

    fn args(material: &str, out: std::path::PathBuf) -> LobeArgs {
        LobeArgs {
            material: vec![material.to_string()],
            theta_i: vec![0.0, 30.0, 60.0, 80.0],
            quantity: Quantity::FCos,
            channel: Channel::Lum,
            log: false,
            decades: 4,
            mode: Mode::Importance,
            out: OutputArgs {
                output: out,
                size: None,
            },
        }
    }

    #[test]
    fn pictures_are_written() {
        let dir = scratch("lobe-plot");
        let mut sink = Vec::new();
        let png = dir.join("lobe.png");
        run(
            &args("roughconductor material=Cu alpha=0.2", png.clone()),
            &mut sink,
        )
        .unwrap();
        assert_png_has_content(&png, (900, 500));
        let mut a = args("roughdielectric alpha=0.2", dir.join("glass.svg"));
        a.log = true;
        run(&a, &mut sink).unwrap();
        let svg = std::fs::read_to_string(dir.join("glass.svg")).unwrap();
        assert!(svg.contains("<svg") && svg.contains("θi = 80°"));
        // a material with only Dirac lobes is refused with a reason
        let e = format!(
            "{:?}",
            run(&args("conductor material=Au", dir.join("x.png")), &mut sink).unwrap_err()
        );
        assert!(e.contains("Dirac"), "{e}");
        assert!(!dir.join("x.png").exists());
        let mut a = args("diffuse", dir.join("x.png"));
        a.theta_i = vec![95.0];
        let e = format!("{:?}", run(&a, &mut sink).unwrap_err());
        assert!(e.contains("[0, 90)"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
