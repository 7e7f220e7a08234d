//! `specula brdf slice`: BRDF Explorer's image slice, f over (θh, θd) at a fixed φd.
//!
//! Rusinkiewicz's half/difference angles (θh: half vector from the normal; θd, φd: the
//! incident direction about the half vector) separate the features of a BRDF: the specular
//! peak is a band at small θh, Fresnel brightening shows along θd, retro-reflection near
//! θd = 0. A MERL table is shown bin by bin; any other material is evaluated at the centre of
//! every cell with φh = 0.

use std::io::Write;

use clap::Args;
use plotters::coord::Shift;
use plotters::prelude::*;
use specula_bsdf::measured::merl::{
    self, from_half_diff, phi_d_index, HalfDiff, Merl, RES_THETA_D, RES_THETA_H,
};
use specula_bsdf::{Bsdf, BsdfContext, BsdfModel, ShadingPoint};

use super::{
    ellipsize, fit_aspect, px, save, stroke, text, tick_label, titled, Channel, DrawResult,
    OutputArgs, Picture,
};
use crate::output::CliError;

#[derive(Debug, Args)]
pub struct SliceArgs {
    /// Material: a spec such as "roughconductor material=Cu alpha=0.2" (quoted, or as separate
    /// words), an XML snippet '<bsdf type=…>…</bsdf>', a MERL .binary or RGL .bsdf file, or
    /// scene.xml#id
    #[arg(required = true, num_args = 1.., value_name = "MATERIAL")]
    pub material: Vec<String>,
    /// The difference azimuth φd of the slice, in degrees (90 is BRDF Explorer's default;
    /// φd and φd + 180° are the same slice for a reciprocal BRDF)
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 90.0,
        allow_negative_numbers = true
    )]
    pub phi_d: f64,
    /// Colour channel shown
    #[arg(long, value_enum, default_value_t = Channel::Lum)]
    pub channel: Channel,
    /// Decades of the logarithmic colour scale below the largest value (at most; less when
    /// the smallest value is larger)
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=12))]
    pub decades: u32,
    /// Cells per axis for materials evaluated analytically (MERL tables use their 90×90 bins)
    #[arg(long, default_value_t = 180, value_parser = clap::value_parser!(u32).range(8..=1000))]
    pub cells: u32,
    #[command(flatten)]
    pub out: OutputArgs,
}

/// The image: `values[j * nx + i]` is the cell between θh edges i, i+1 and θd edges j, j+1;
/// `None` where the configuration is not defined (below the horizon, or not measured).
#[derive(Clone, Debug)]
pub struct SliceData {
    /// Cell boundaries in θh (degrees), increasing from 0 to 90.
    pub theta_h_edges: Vec<f64>,
    /// Cell boundaries in θd (degrees), increasing from 0 to 90.
    pub theta_d_edges: Vec<f64>,
    pub values: Vec<Option<f64>>,
    /// The φd actually shown (degrees): the centre of the MERL bin, or the requested angle.
    pub phi_d: f64,
    /// True when the values are a MERL table's bins.
    pub from_bins: bool,
}

impl SliceData {
    pub fn nx(&self) -> usize {
        self.theta_h_edges.len() - 1
    }
    pub fn ny(&self) -> usize {
        self.theta_d_edges.len() - 1
    }
    pub fn get(&self, i: usize, j: usize) -> Option<f64> {
        self.values[j * self.nx() + i]
    }
    /// Largest value and smallest positive value.
    pub fn range(&self) -> Option<(f64, f64)> {
        let pos = self.values.iter().flatten().copied().filter(|v| *v > 0.0);
        let (lo, hi) = pos.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        (hi > 0.0 && hi.is_finite()).then_some((lo, hi))
    }
}

/// The slice of a MERL table at the φd bin containing `phi_d` (degrees): its bins as they
/// are stored (θh bins have square-root spacing, so their edges are (i/90)²·90°).
pub fn merl_slice(m: &Merl, phi_d: f64, channel: Channel) -> SliceData {
    let k = phi_d_index(phi_d.to_radians() as f32);
    let theta_h_edges = (0..=RES_THETA_H)
        .map(|i| (i as f64 / RES_THETA_H as f64).powi(2) * 90.0)
        .collect();
    let theta_d_edges = (0..=RES_THETA_D)
        .map(|j| j as f64 * 90.0 / RES_THETA_D as f64)
        .collect();
    let mut values = Vec::with_capacity(RES_THETA_H * RES_THETA_D);
    for j in 0..RES_THETA_D {
        for i in 0..RES_THETA_H {
            let raw = m.raw(i, j, k);
            let measured = match channel {
                Channel::R => raw[0] >= 0.0,
                Channel::G => raw[1] >= 0.0,
                Channel::B => raw[2] >= 0.0,
                Channel::Lum => raw.iter().all(|v| *v >= 0.0),
            };
            values.push(measured.then(|| channel.of(m.bin_value(i, j, k))));
        }
    }
    SliceData {
        theta_h_edges,
        theta_d_edges,
        values,
        phi_d: merl::phi_d_centre(k).to_degrees(),
        from_bins: true,
    }
}

/// The slice of any material at `phi_d` (degrees), evaluated at the centres of `cells` ×
/// `cells` equal cells with φh = 0; configurations with ωi or ωo at or below the horizon are
/// `None`.
pub fn eval_slice(bsdf: &Bsdf, phi_d: f64, channel: Channel, cells: usize) -> SliceData {
    let ctx = BsdfContext::RADIANCE;
    let sp = ShadingPoint::default();
    let edges: Vec<f64> = (0..=cells)
        .map(|i| i as f64 * 90.0 / cells as f64)
        .collect();
    let mut values = Vec::with_capacity(cells * cells);
    for j in 0..cells {
        let theta_d = (edges[j] + edges[j + 1]) / 2.0;
        for i in 0..cells {
            let theta_h = (edges[i] + edges[i + 1]) / 2.0;
            let (wi, wo) = from_half_diff(HalfDiff {
                theta_h: theta_h.to_radians() as f32,
                phi_h: 0.0,
                theta_d: theta_d.to_radians() as f32,
                phi_d: phi_d.to_radians() as f32,
            });
            values
                .push((wi.z > 0.0 && wo.z > 0.0).then(|| channel.of(bsdf.eval(&ctx, &sp, wi, wo))));
        }
    }
    SliceData {
        theta_h_edges: edges.clone(),
        theta_d_edges: edges,
        values,
        phi_d,
        from_bins: false,
    }
}

/// The slice of a material: its bins for a MERL table, evaluated otherwise.
pub fn slice(bsdf: &Bsdf, phi_d: f64, channel: Channel, cells: usize) -> SliceData {
    match bsdf {
        Bsdf::Merl(m) => merl_slice(m, phi_d, channel),
        _ => eval_slice(bsdf, phi_d, channel, cells),
    }
}

struct SlicePicture {
    label: String,
    data: SliceData,
    channel: Channel,
    /// log10 of the colour scale's ends.
    log_lo: f64,
    log_hi: f64,
    dirac_note: bool,
}

pub fn run(args: &SliceArgs, out: &mut dyn Write) -> Result<(), CliError> {
    if !args.phi_d.is_finite() {
        return Err(CliError::usage(
            "--phi-d must be a finite number of degrees",
        ));
    }
    let material = crate::material::load_material(&args.material)?;
    let bsdf = &material.bsdf;
    let flags = bsdf.flags();
    if flags.is_all_delta() {
        return Err(CliError::usage(format!(
            "{}: every lobe of this material is a Dirac delta, so f is 0 for every pair of \
             directions and the slice would be empty; `specula brdf albedo` shows how much it \
             reflects",
            material.short_label()
        )));
    }
    let data = slice(bsdf, args.phi_d, args.channel, args.cells as usize);
    let Some((lo, hi)) = data.range() else {
        return Err(CliError::usage(format!(
            "{}: f ({}) is 0 or undefined everywhere on the slice φd = {}°: nothing to draw",
            material.short_label(),
            args.channel.name(),
            args.phi_d
        )));
    };
    let log_hi = hi.log10();
    let log_lo = lo.log10().max(log_hi - f64::from(args.decades));
    // a constant slice still needs a colour scale of some extent
    let log_lo = if log_hi - log_lo < 1e-3 {
        log_hi - 0.5
    } else {
        log_lo
    };
    let picture = SlicePicture {
        label: material.short_label(),
        data,
        channel: args.channel,
        log_lo,
        log_hi,
        dirac_note: flags.is_delta(),
    };
    let (w, h) = save(&picture, &args.out, true)?;
    writeln!(out, "wrote {} ({w}×{h})", args.out.output.display())?;
    Ok(())
}

/// Colour of log10 f on the scale [lo, hi] (viridis, clamped).
fn colour(log_v: f64, lo: f64, hi: f64) -> RGBColor {
    ViridisRGB::get_color_normalized(log_v.clamp(lo, hi), lo, hi)
}

const UNDEFINED: RGBColor = RGBColor(215, 215, 215);

impl Picture for SlicePicture {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static,
    {
        let d = &self.data;
        let title = format!(
            "f of {} at φd = {}°",
            ellipsize(&self.label, 56),
            tick_label((d.phi_d * 100.0).round() / 100.0)
        );
        let mut sub = format!(
            "{}, logarithmic colour scale; {}",
            self.channel.name(),
            if d.from_bins {
                "MERL bins as stored (θh bins narrow towards 0°)"
            } else {
                "evaluated at cell centres, φh = 0"
            }
        );
        if self.dirac_note {
            sub.push_str("; Dirac lobes not shown");
        }
        let area = titled(root, &title, &sub)?;
        let (w, _) = area.dim_in_pixel();
        let (left, right) = area.split_horizontally(w.saturating_sub(px(165.0) as u32));

        // the image, square: the plotting area is the chart less its margins (10 each side)
        // and label areas (60 left, 50 below)
        let (lw, lh) = left.dim_in_pixel();
        let (extra_w, extra_h) = (px(80.0) as u32, px(70.0) as u32);
        let side = (lw.saturating_sub(extra_w)).min(lh.saturating_sub(extra_h));
        let img_area = fit_aspect(&left, f64::from(side + extra_w) / f64::from(side + extra_h));
        let mut chart = ChartBuilder::on(&img_area)
            .margin(px(10.0))
            .x_label_area_size(px(50.0))
            .y_label_area_size(px(60.0))
            .build_cartesian_2d(0.0f64..90.0f64, 0.0f64..90.0f64)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("θh: half vector from the normal (°)")
            .y_desc("θd: difference angle (°)")
            .x_labels(10)
            .y_labels(10)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .axis_desc_style(text(17.0))
            .label_style(text(14.0))
            .axis_style(stroke(RGBColor(60, 60, 60), 1.0))
            .set_all_tick_mark_size(px(5.0))
            .draw()?;
        let (nx, ny) = (d.nx(), d.ny());
        let cells = (0..ny).flat_map(|j| (0..nx).map(move |i| (i, j)));
        chart.draw_series(cells.map(|(i, j)| {
            let fill = match d.get(i, j) {
                Some(v) if v > 0.0 => colour(v.log10(), self.log_lo, self.log_hi),
                Some(_) => colour(self.log_lo, self.log_lo, self.log_hi),
                None => UNDEFINED,
            };
            Rectangle::new(
                [
                    (d.theta_h_edges[i], d.theta_d_edges[j]),
                    (d.theta_h_edges[i + 1], d.theta_d_edges[j + 1]),
                ],
                fill.filled(),
            )
        }))?;

        // the colour bar, logarithmic
        let (lo, hi) = (10f64.powf(self.log_lo), 10f64.powf(self.log_hi));
        let (_, img_h) = img_area.dim_in_pixel();
        let (_, rh) = right.dim_in_pixel();
        let top = (rh.saturating_sub(img_h) / 2) as i32;
        let bar_area = right.margin(top, top, px(25.0), 0);
        let mut bar = ChartBuilder::on(&bar_area)
            .margin(px(10.0))
            .margin_left(0)
            .margin_right(px(4.0))
            .x_label_area_size(px(50.0))
            .right_y_label_area_size(px(85.0))
            .build_cartesian_2d(0.0f64..1.0f64, (lo..hi).log_scale())?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc("f (1/sr)")
            .y_label_formatter(&|v| tick_label(*v))
            .axis_desc_style(text(16.0))
            .label_style(text(14.0))
            .axis_style(stroke(RGBColor(60, 60, 60), 1.0))
            .set_all_tick_mark_size(px(5.0))
            .draw()?;
        let steps = 200;
        bar.draw_series((0..steps).map(|s| {
            let a = self.log_lo + (self.log_hi - self.log_lo) * s as f64 / steps as f64;
            let b = self.log_lo + (self.log_hi - self.log_lo) * (s + 1) as f64 / steps as f64;
            Rectangle::new(
                [(0.0, 10f64.powf(a)), (1.0, 10f64.powf(b))],
                colour((a + b) / 2.0, self.log_lo, self.log_hi).filled(),
            )
        }))?;
        // the key for undefined cells, under the bar
        if d.values.iter().all(Option::is_some) {
            return Ok(());
        }
        let (_, bh) = bar_area.dim_in_pixel();
        let key_y = bh as i32 - px(35.0);
        bar_area.draw(&Rectangle::new(
            [(0, key_y), (px(18.0), key_y + px(16.0))],
            UNDEFINED.filled(),
        ))?;
        let key = if d.from_bins {
            "not measured"
        } else {
            "below horizon"
        };
        bar_area.draw_text(
            key,
            &text(13.0).color(&RGBColor(70, 70, 70)),
            (px(24.0), key_y + px(1.0)),
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::tests::{assert_png_has_content, scratch};
    use specula_bsdf::measured::merl::SCALE;
    use specula_bsdf::{parse_spec, Spectrum};

    /// A synthetic table: a distinct value in every bin, some bins "not measured".
    fn table() -> Merl {
        Merl::from_fn(|th, td, pd| {
            if td > 1.4 && pd < 0.5 {
                Spectrum::splat(-1.0)
            } else {
                Spectrum::new(
                    (1.0 + th + 2.0 * td + 0.1 * pd) as f32,
                    (0.5 + th * td) as f32,
                    (0.2 + pd) as f32,
                )
            }
        })
    }

    #[test]
    fn merl_slice_is_the_tables_bins() {
        let m = table();
        for (phi_d, k) in [(90.0, 90), (10.3, 10), (-170.0, 10), (0.0, 0)] {
            let s = merl_slice(&m, phi_d, Channel::Lum);
            assert!(s.from_bins);
            assert_eq!((s.nx(), s.ny()), (90, 90));
            assert!(
                (s.phi_d - (k as f64 + 0.5)).abs() < 1e-9,
                "{phi_d} → {}",
                s.phi_d
            );
            let mut undefined = 0;
            for i in 0..90 {
                for j in 0..90 {
                    let raw = m.raw(i, j, k);
                    match s.get(i, j) {
                        Some(v) => {
                            assert!(raw.iter().all(|r| *r >= 0.0));
                            let want = m.bin_value(i, j, k).luminance() as f64;
                            assert_eq!(v, want, "bin ({i}, {j}, {k})");
                        }
                        None => {
                            assert!(raw.iter().any(|r| *r < 0.0));
                            undefined += 1;
                        }
                    }
                }
            }
            assert_eq!(undefined > 0, phi_d.rem_euclid(180.0) < 28.6);
            // the bin centre of θh bin i lies inside its cell
            for i in 0..90 {
                let c = merl::theta_h_centre(i).to_degrees();
                assert!(s.theta_h_edges[i] < c && c < s.theta_h_edges[i + 1]);
            }
        }
        // one channel: the stored value times the channel's scale
        let s = merl_slice(&m, 45.0, Channel::B);
        let raw = m.raw(7, 8, 45);
        assert!((s.get(7, 8).unwrap() - raw[2] * SCALE[2]).abs() < 1e-5 * raw[2] * SCALE[2]);
    }

    #[test]
    fn measured_model_matches_its_evaluation_at_bin_centres() {
        let model = parse_spec("roughconductor alpha=0.3").unwrap();
        let m = Merl::measure(&model);
        let s = slice(&Bsdf::Merl(m), 90.0, Channel::R, 0);
        let (ctx, sp) = (BsdfContext::RADIANCE, ShadingPoint::default());
        for (i, j) in [(3, 4), (30, 20), (60, 10), (10, 80)] {
            let (wi, wo) = merl::bin_centre_dirs(i, j, 90);
            if wi[2] <= 0.0 || wo[2] <= 0.0 {
                assert_eq!(s.get(i, j), None);
                continue;
            }
            let v = |w: [f64; 3]| glam::Vec3::new(w[0] as f32, w[1] as f32, w[2] as f32);
            let f = f64::from(model.eval(&ctx, &sp, v(wi), v(wo))[0]);
            let got = s.get(i, j).unwrap();
            assert!((got - f).abs() <= 1e-5 * f, "({i}, {j}): {got} vs {f}");
        }
    }

    #[test]
    fn diffuse_slice_is_flat_above_the_horizon() {
        let b = parse_spec("diffuse reflectance=0.6").unwrap();
        let want = 0.6 / std::f64::consts::PI;
        // at φd = 90° both directions have cosθ = cosθh·cosθd > 0: all defined; at φd = 0°
        // they have cosθ = cos(θh ± θd): ωi sinks below the horizon where θh + θd > 90°
        for phi_d in [90.0, 0.0] {
            let s = eval_slice(&b, phi_d, Channel::G, 30);
            assert_eq!((s.nx(), s.ny()), (30, 30));
            for i in 0..30 {
                for j in 0..30 {
                    let v = s.get(i, j);
                    if let Some(v) = v {
                        assert!((v - want).abs() < 1e-6, "{v}");
                    }
                    // cell centres (i + ½)·3°: θh + θd = 3(i + j + 1)°, exactly 90° on the
                    // diagonal i + j = 29, where rounding decides
                    if phi_d == 90.0 || i + j < 29 {
                        assert!(v.is_some(), "({i}, {j}) at φd = {phi_d}");
                    } else if i + j > 29 {
                        assert!(v.is_none(), "({i}, {j}) at φd = {phi_d}");
                    }
                }
            }
        }
    }

    #[test]
    fn specular_peak_is_at_small_theta_h() {
        let b = parse_spec("roughconductor alpha=0.1").unwrap();
        let s = eval_slice(&b, 90.0, Channel::Lum, 90);
        let (mut best, mut at) = (0.0, (0, 0));
        for j in 0..90 {
            for i in 0..90 {
                if let Some(v) = s.get(i, j) {
                    if v > best {
                        best = v;
                        at = (i, j);
                    }
                }
            }
        }
        assert_eq!(at.0, 0, "peak at θh cell {at:?}");
    }

    #[test]
    fn pictures_are_written() {
        let dir = scratch("slice-plot");
        let mut sink = Vec::new();
        let merl_path = dir.join("t.binary");
        table().write(&merl_path).unwrap();
        for (mat, file) in [
            ("roughconductor material=Cu alpha=0.15", "a.png"),
            (merl_path.to_str().unwrap(), "m.png"),
            ("plastic", "p.svg"),
        ] {
            let args = SliceArgs {
                material: vec![mat.to_string()],
                phi_d: 90.0,
                channel: Channel::Lum,
                decades: 5,
                cells: 60,
                out: OutputArgs {
                    output: dir.join(file),
                    size: Some((700, 560)),
                },
            };
            run(&args, &mut sink).unwrap();
            if file.ends_with(".png") {
                assert_png_has_content(&dir.join(file), (700, 560));
            } else {
                let svg = std::fs::read_to_string(dir.join(file)).unwrap();
                assert!(svg.contains("<svg") && svg.contains("Dirac lobes not shown"));
            }
        }
        let args = SliceArgs {
            material: vec!["dielectric".into()],
            phi_d: 90.0,
            channel: Channel::Lum,
            decades: 5,
            cells: 60,
            out: OutputArgs {
                output: dir.join("d.png"),
                size: None,
            },
        };
        let e = format!("{:?}", run(&args, &mut sink).unwrap_err());
        assert!(e.contains("Dirac"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
