//! Shared plumbing for the picture commands: fonts, output backends and colour maps.
//!
//! Plotters draws text with `ab_glyph` from fonts embedded in the binary (Ubuntu Light for
//! text, Hack for monospace), so pictures come out the same on any machine, without system
//! font libraries.
//!
//! Each picture command computes its numbers with plain functions (tested on their own) and
//! draws them through [`Picture`], which [`save`] renders to PNG or SVG.

pub mod albedo;
pub mod dispersion;
pub mod fresnel;
pub mod lobe;
pub mod phase;
pub mod slice;

use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::Once;

use clap::{Args, ValueEnum};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, VPos};
use plotters::style::FontStyle;
use plotters_backend::{
    BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingErrorKind,
};
use specula_bsdf::{BsdfContext, Spectrum};

use crate::brdf::Mode;
use crate::output::CliError;

/// The font family names the commands use (registered by [`init_fonts`]).
pub const SANS: &str = "sans-serif";
pub const MONO: &str = "monospace";

/// Register the embedded fonts with plotters (idempotent).
pub fn init_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let ubuntu = epaint_default_fonts::UBUNTU_LIGHT;
        let hack = epaint_default_fonts::HACK_REGULAR;
        for style in [FontStyle::Normal, FontStyle::Bold, FontStyle::Italic] {
            // the embedded fonts are valid TrueType files: registration cannot fail
            plotters::style::register_font(SANS, style, ubuntu)
                .unwrap_or_else(|_| unreachable!("embedded font rejected"));
            plotters::style::register_font(MONO, style, hack)
                .unwrap_or_else(|_| unreachable!("embedded font rejected"));
        }
    });
}

/// The picture formats a command can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

/// The format of `path` from its extension; `svg_ok` says whether the command draws vectors.
pub fn format_of(path: &Path, svg_ok: bool) -> Result<Format, CliError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "png" => Ok(Format::Png),
        "svg" if svg_ok => Ok(Format::Svg),
        _ => Err(CliError::usage(format!(
            "{}: unsupported picture format (use {})",
            path.display(),
            if svg_ok { ".png or .svg" } else { ".png" }
        ))),
    }
}

/// Turn a plotters drawing error into a one-line CLI error naming the output file.
pub fn draw_err<E: std::fmt::Debug>(path: &Path) -> impl Fn(E) -> CliError + '_ {
    move |e| CliError::usage(format!("{}: cannot draw or write: {e:?}", path.display()))
}

/// What a picture's drawing code returns (any plotters error, whatever the backend).
pub type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// A picture that can be drawn on any plotters backend (bitmap or SVG).
pub trait Picture {
    /// The size used when `--size` is not given.
    fn default_size(&self) -> (u32, u32) {
        (900, 700)
    }
    /// Draw on `root`, which has been filled white.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult
    where
        DB::ErrorType: 'static;
}

/// The output options every picture command shares.
#[derive(Debug, Clone, Args)]
pub struct OutputArgs {
    /// Output picture: .png, or .svg where the command draws vectors
    #[arg(short = 'o', long = "output", value_name = "FILE")]
    pub output: PathBuf,
    /// Picture size in pixels, WIDTHxHEIGHT [default: 900x700, or as the command says]
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(u32, u32)>,
}

/// `900x700` (or `900×700`) → (900, 700); each side within 100..=10000 pixels.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected WIDTHxHEIGHT in pixels, e.g. 900x700, got '{s}'");
    let (w, h) = s.trim().split_once(['x', 'X', '×']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    for v in [w, h] {
        if !(100..=10_000).contains(&v) {
            return Err(format!(
                "picture sides must be 100 to 10000 pixels, got '{s}'"
            ));
        }
    }
    Ok((w, h))
}

/// Render `picture` to the file named by `out` (PNG, or SVG when `svg_ok`); returns the size.
pub fn save(
    picture: &impl Picture,
    out: &OutputArgs,
    svg_ok: bool,
) -> Result<(u32, u32), CliError> {
    init_fonts();
    let path = out.output.as_path();
    let format = format_of(path, svg_ok)?;
    let size = out.size.unwrap_or_else(|| picture.default_size());
    // a clear message for an unwritable path, before any drawing
    std::fs::File::create(path)
        .map_err(|e| CliError::usage(format!("{}: cannot write: {e}", path.display())))?;
    let result = match format {
        Format::Png => render_png(path, size, picture),
        Format::Svg => render(SVGBackend::new(path, size).into_drawing_area(), picture),
    };
    result.map_err(|e| {
        CliError::usage(format!(
            "{}: cannot draw or write the picture: {e}",
            path.display()
        ))
    })?;
    Ok(size)
}

/// PNG pictures are drawn this many times larger and box-filtered down: anti-aliased lines,
/// and curves placed to a fraction of a pixel (plotters rounds coordinates to whole pixels).
pub const SUPERSAMPLE: u32 = 3;

thread_local! {
    static SCALE: Cell<f64> = const { Cell::new(1.0) };
}

/// Device pixels per picture pixel of the drawing in progress ([`SUPERSAMPLE`] for PNG).
pub fn scale() -> f64 {
    SCALE.with(Cell::get)
}

/// A length given in picture pixels, in device pixels.
pub fn px(v: f64) -> i32 {
    (v * scale()).round() as i32
}

/// A line width given in picture pixels, in device pixels (at least 1).
pub fn upx(v: f64) -> u32 {
    (v * scale()).round().max(1.0) as u32
}

/// A line style of width `width` picture pixels.
pub fn stroke(colour: RGBColor, width: f64) -> ShapeStyle {
    Color::stroke_width(&colour, upx(width))
}

/// Draw at [`SUPERSAMPLE`] times the size into memory, then average down and write the PNG.
fn render_png(path: &Path, (w, h): (u32, u32), picture: &impl Picture) -> DrawResult {
    let k = SUPERSAMPLE;
    let (bw, bh) = (w * k, h * k);
    let mut big = vec![255u8; (bw * bh * 3) as usize];
    let previous = SCALE.with(|s| s.replace(f64::from(k)));
    let drawn = render(
        Typeset(BitMapBackend::with_buffer(&mut big, (bw, bh))).into_drawing_area(),
        picture,
    );
    SCALE.with(|s| s.set(previous));
    drawn?;
    let small = downsample(&big, (w, h), k);
    let mut png = BitMapBackend::new(path, (w, h));
    png.blit_bitmap((0, 0), (w, h), &small)?;
    png.present()?;
    Ok(())
}

/// Box-filter an RGB8 image of `k`·w × `k`·h pixels down to w × h.
fn downsample(big: &[u8], (w, h): (u32, u32), k: u32) -> Vec<u8> {
    let (w, h, k) = (w as usize, h as usize, k as usize);
    let bw = w * k;
    let mut out = vec![0u8; w * h * 3];
    for y in 0..h {
        for x in 0..w {
            let mut sum = [0u32; 3];
            for dy in 0..k {
                let row = ((y * k + dy) * bw + x * k) * 3;
                for px in big[row..row + 3 * k].chunks_exact(3) {
                    for c in 0..3 {
                        sum[c] += u32::from(px[c]);
                    }
                }
            }
            let n = (k * k) as u32;
            for c in 0..3 {
                out[(y * w + x) * 3 + c] = ((sum[c] + n / 2) / n) as u8;
            }
        }
    }
    out
}

fn render<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, picture: &impl Picture) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    picture.draw(&root)?;
    root.present()?;
    Ok(())
}

/// A bitmap backend that draws text itself.
///
/// plotters 0.3.7 places each `ab_glyph` glyph with the left edge of its ink at the pen
/// position, dropping the glyph's left side bearing, so that narrow glyphs ("1", "l", "i")
/// leave a gap after them ("1 80°"). This wrapper rasterises the glyphs at their proper place
/// (same fonts, sizes, anchors, rotations and layout boxes as plotters) and passes everything
/// else through.
pub struct Typeset<B>(pub B);

/// The embedded font data for a plotters font family name.
fn font_bytes(family: &str) -> &'static [u8] {
    if family == MONO {
        epaint_default_fonts::HACK_REGULAR
    } else {
        epaint_default_fonts::UBUNTU_LIGHT
    }
}

/// Calls `draw(x, y, coverage)` for every inked pixel of `text` set in `font_data` at `size`
/// pixels, the pen starting at x = 0 with the baseline at y = size/2 + ascent offset exactly as
/// plotters sets it (so that layout boxes agree); returns false when the font does not load.
pub fn set_text(
    font_data: &'static [u8],
    size: f64,
    text: &str,
    mut draw: impl FnMut(i32, i32, f32),
) -> bool {
    use ab_glyph::{Font, FontRef, ScaleFont};
    let Ok(font) = FontRef::try_from_slice(font_data) else {
        return false;
    };
    let font = font.as_scaled(size as f32);
    let mut pen = 0.0f32;
    let mut prev = None;
    for c in text.chars() {
        let id = font.glyph_id(c);
        if let Some(p) = prev {
            pen += font.kern(p, id);
        }
        prev = Some(id);
        // plotters' vertical placement: the glyph's top at size/2 + its bounds' top
        let mut glyph = font.scaled_glyph(c);
        glyph.position = ab_glyph::point(pen, 0.0);
        if let Some(outline) = font.outline_glyph(glyph) {
            let b = outline.px_bounds();
            let (x0, y0) = (b.min.x as i32, (size as f32 / 2.0 + b.min.y) as i32);
            outline.draw(|x, y, cov| draw(x0 + x as i32, y0 + y as i32, cov));
        }
        pen += font.h_advance(id);
    }
    true
}

impl<B: DrawingBackend> DrawingBackend for Typeset<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.0.get_size()
    }
    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.ensure_prepared()
    }
    fn present(&mut self) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.present()
    }
    fn draw_pixel(
        &mut self,
        point: BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_pixel(point, color)
    }
    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_line(from, to, style)
    }
    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_rect(upper_left, bottom_right, style, fill)
    }
    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_path(path, style)
    }
    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.draw_circle(center, radius, style, fill)
    }
    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.fill_polygon(vert, style)
    }
    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
        self.0.estimate_text_size(text, style)
    }
    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.0.blit_bitmap(pos, size, src)
    }

    // as plotters' default `draw_text`, with the glyphs set by `set_text`
    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        let color = style.color();
        if color.alpha == 0.0 {
            return Ok(());
        }
        let ((min_x, min_y), (max_x, max_y)) = style
            .layout_box(text)
            .map_err(|e| DrawingErrorKind::FontError(Box::new(e)))?;
        let (width, height) = (max_x - min_x, max_y - min_y);
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let trans = style.transform();
        let (w, h) = self.get_size();
        let mut result = Ok(());
        let family = style.family();
        set_text(
            font_bytes(family.as_str()),
            style.size(),
            text,
            |x, y, cov| {
                let (x, y) = trans.transform(x + dx - min_x, y + dy - min_y);
                let (x, y) = (pos.0 + x, pos.1 + y);
                if result.is_ok() && x >= 0 && x < w as i32 && y >= 0 && y < h as i32 {
                    let c = BackendColor {
                        alpha: color.alpha * f64::from(cov.clamp(0.0, 1.0)),
                        rgb: color.rgb,
                    };
                    result = self.0.draw_pixel((x, y), c);
                }
            },
        );
        result
    }
}

/// Which value of an RGB colour a picture shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Channel {
    /// Red channel (linear sRGB)
    R,
    /// Green channel
    G,
    /// Blue channel
    B,
    /// Luminance (Rec. 709 weights of linear sRGB)
    Lum,
}

impl Channel {
    pub fn of(self, c: Spectrum) -> f64 {
        f64::from(match self {
            Channel::R => c[0],
            Channel::G => c[1],
            Channel::B => c[2],
            Channel::Lum => c.luminance(),
        })
    }
    pub fn name(self) -> &'static str {
        match self {
            Channel::R => "red channel",
            Channel::G => "green channel",
            Channel::B => "blue channel",
            Channel::Lum => "luminance",
        }
    }
}

/// The evaluation context of a transport mode.
pub fn context(mode: Mode) -> BsdfContext {
    match mode {
        Mode::Radiance => BsdfContext::RADIANCE,
        Mode::Importance => BsdfContext::IMPORTANCE,
    }
}

/// Distinct colours for several curves (matplotlib's "tab10").
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Curve colours of the red, green and blue channels.
pub const CHANNEL_COLOURS: [RGBColor; 3] = [
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(31, 119, 180),
];

/// Grey for grids and reference lines.
pub const GRID: RGBColor = RGBColor(200, 200, 200);

/// Text style of the given size (picture pixels) in the sans-serif family.
pub fn text(size: f64) -> TextStyle<'static> {
    TextStyle::from((SANS, size * scale()).into_font()).color(&BLACK)
}

/// A chart with f64 axes.
pub type Chart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// A line chart on `area`: x over `x` (labelled every `x_step`, whole numbers), y over `y`,
/// light grid, axis descriptions.
pub fn line_chart<'a, DB: DrawingBackend + 'a>(
    area: &'a DrawingArea<DB, Shift>,
    x: std::ops::Range<f64>,
    y: std::ops::Range<f64>,
    x_desc: &str,
    y_desc: &str,
) -> Result<Chart<'a, DB>, Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let mut chart = ChartBuilder::on(area)
        .margin(px(15.0))
        .margin_right(px(30.0))
        .x_label_area_size(px(55.0))
        .y_label_area_size(px(65.0))
        .build_cartesian_2d(x.clone(), y.clone())?;
    let y_labels = ((y.end - y.start) / 0.1).round() as usize + 1;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(((x.end - x.start) / 10.0).round() as usize + 1)
        .y_labels(y_labels.min(13))
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.1}"))
        .axis_desc_style(text(18.0))
        .label_style(text(15.0))
        .light_line_style(TRANSPARENT)
        .bold_line_style(stroke(RGBColor(225, 225, 225), 1.0))
        .axis_style(stroke(RGBColor(60, 60, 60), 1.0))
        .set_all_tick_mark_size(px(5.0))
        .draw()?;
    Ok(chart)
}

/// The chart's legend (series labels) in a framed box at `pos`.
pub fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    pos: SeriesLabelPosition,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(pos)
        .margin(px(12.0))
        .legend_area_size(px(36.0))
        .label_font(text(16.0))
        .background_style(WHITE.mix(0.9))
        .border_style(stroke(RGBColor(170, 170, 170), 1.0))
        .draw()?;
    Ok(())
}

/// Where a legend of `entries` lines, the longest `longest` characters, covers none of
/// `curves` (data coordinates of `chart`): the first free one of the lower left, upper left,
/// lower right, upper right, middle left and middle right corners, else the least crowded.
pub fn legend_spot<DB: DrawingBackend>(
    chart: &Chart<'_, DB>,
    curves: &[Vec<(f64, f64)>],
    entries: usize,
    longest: usize,
) -> SeriesLabelPosition {
    let (pw, ph) = chart.plotting_area().dim_in_pixel();
    let (xr, yr) = (chart.x_range(), chart.y_range());
    // the box drawn by `draw_legend`: 12 px margin, 36 px sample, ~7.5 px per character of
    // 16 px text, ~22 px per line
    let fw = (px(12.0 + 36.0 + 12.0) as f64 + longest as f64 * px(7.5) as f64) / f64::from(pw);
    let fh = (px(12.0 + 12.0) as f64 + entries as f64 * px(22.0) as f64) / f64::from(ph);
    let (fw, fh) = (fw.min(1.0), fh.min(1.0));
    let spots = [
        (SeriesLabelPosition::LowerLeft, 0.0, 0.0),
        (SeriesLabelPosition::UpperLeft, 0.0, 1.0 - fh),
        (SeriesLabelPosition::LowerRight, 1.0 - fw, 0.0),
        (SeriesLabelPosition::UpperRight, 1.0 - fw, 1.0 - fh),
        (SeriesLabelPosition::MiddleLeft, 0.0, 0.5 - fh / 2.0),
        (SeriesLabelPosition::MiddleRight, 1.0 - fw, 0.5 - fh / 2.0),
    ];
    // points along every curve, as fractions of the plotting area
    let mut pts = Vec::new();
    for c in curves {
        for w in c.windows(2) {
            for k in 0..8 {
                let t = f64::from(k) / 8.0;
                let x = w[0].0 + t * (w[1].0 - w[0].0);
                let y = w[0].1 + t * (w[1].1 - w[0].1);
                pts.push((
                    (x - xr.start) / (xr.end - xr.start),
                    (y - yr.start) / (yr.end - yr.start),
                ));
            }
        }
    }
    let crowding = |x0: f64, y0: f64| {
        pts.iter()
            .filter(|(x, y)| (x0..=x0 + fw).contains(x) && (y0..=y0 + fh).contains(y))
            .count()
    };
    let mut best = (usize::MAX, SeriesLabelPosition::LowerLeft);
    for (pos, x0, y0) in spots {
        let n = crowding(x0, y0);
        if n == 0 {
            return pos;
        }
        if n < best.0 {
            best = (n, pos);
        }
    }
    best.1
}

/// One line of a legend drawn by [`side_legend`].
pub struct LegendEntry {
    pub label: String,
    pub style: ShapeStyle,
    /// (on, off) dash lengths in picture pixels, or a solid line.
    pub dash: Option<(f64, f64)>,
}

/// A legend in a side panel: `heading`, then one sample line and label per entry, starting
/// `top` picture pixels below the top of `area`; returns where the next line would go.
pub fn side_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    heading: &str,
    entries: &[LegendEntry],
    top: f64,
) -> Result<f64, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut y = top;
    area.draw_text(heading, &text(16.0), (px(10.0), px(y)))?;
    y += 28.0;
    for e in entries {
        let mid = px(y + 9.0);
        let (a, b) = ((px(12.0), mid), (px(12.0) + px(28.0), mid));
        match e.dash {
            None => area.draw(&PathElement::new(vec![a, b], e.style))?,
            Some((on, off)) => area.draw(&plotters::element::DashedPathElement::new(
                vec![a, b],
                px(on),
                px(off),
                e.style,
            ))?,
        }
        area.draw_text(&e.label, &text(16.0), (px(50.0), px(y)))?;
        y += 25.0;
    }
    Ok(y)
}

/// A legend sample: a line `length` picture pixels long starting at `(x, y)`, dashed when
/// `dash` gives (on, off) lengths.
pub fn legend_line<DB: DrawingBackend>(
    (x, y): BackendCoord,
    style: ShapeStyle,
    dash: Option<(f64, f64)>,
) -> DynElement<'static, DB, BackendCoord> {
    let end = (x + px(28.0), y);
    match dash {
        None => PathElement::new(vec![(x, y), end], style).into_dyn(),
        Some((on, off)) => {
            plotters::element::DashedPathElement::new(vec![(x, y), end], px(on), px(off), style)
                .into_dyn()
        }
    }
}

/// A title and, when not empty, a smaller subtitle at the top of `root`; returns the area below.
pub fn titled<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: &str,
) -> Result<DrawingArea<DB, Shift>, DrawingAreaErrorKind<DB::ErrorType>> {
    let area = heading(root, title, text(22.0), px(10.0))?;
    if subtitle.is_empty() {
        Ok(area.margin(px(4.0), 0, 0, 0))
    } else {
        let area = heading(
            &area,
            subtitle,
            text(15.0).color(&RGBColor(80, 80, 80)),
            px(2.0),
        )?;
        Ok(area.margin(px(6.0), 0, 0, 0))
    }
}

/// One centred line of text `pad` device pixels below the top of `area`; returns the area
/// below it.
fn heading<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    line: &str,
    style: TextStyle,
    pad: i32,
) -> Result<DrawingArea<DB, Shift>, DrawingAreaErrorKind<DB::ErrorType>> {
    let (_, h) = area.estimate_text_size(line, &style)?;
    let (w, _) = area.dim_in_pixel();
    let style = style.pos(plotters::style::text_anchor::Pos::new(
        HPos::Center,
        VPos::Top,
    ));
    area.draw_text(line, &style, (w as i32 / 2, pad))?;
    Ok(area.margin(pad + h as i32, 0, 0, 0))
}

/// The largest centred part of `area` whose width/height ratio is `aspect`.
pub fn fit_aspect<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    aspect: f64,
) -> DrawingArea<DB, Shift> {
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (f64::from(w), f64::from(h));
    if w > h * aspect {
        let pad = ((w - h * aspect) / 2.0).floor() as i32;
        area.margin(0, 0, pad, pad)
    } else {
        let pad = ((h - w / aspect) / 2.0).floor() as i32;
        area.margin(pad, pad, 0, 0)
    }
}

/// Shorten a label for a title (measured in characters).
pub fn ellipsize(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        s.to_string()
    } else {
        let head: String = s.chars().take(max.saturating_sub(3)).collect();
        format!("{}...", head.trim_end())
    }
}

/// Round tick values 0 < t ≤ `max`, about `target` of them (steps of 1, 2, 2.5 or 5 × 10^k).
pub fn nice_ticks(max: f64, target: usize) -> Vec<f64> {
    if !(max.is_finite() && max > 0.0) {
        return Vec::new();
    }
    let raw = max / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|&s| s >= raw)
        .unwrap_or(10.0 * mag);
    (1..)
        .map(|k| k as f64 * step)
        .take_while(|&t| t <= max * (1.0 + 1e-9))
        .collect()
}

/// A number for an axis or ring label: few digits, scientific outside [1e-3, 1e4).
pub fn tick_label(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e4).contains(&a) {
        let e = a.log10().floor() as i32;
        let m = v / 10f64.powi(e);
        if (m.abs() - 1.0).abs() < 1e-9 {
            format!("1e{e}")
        } else {
            format!("{}e{e}", trim_zeros(&format!("{m:.2}")))
        }
    } else {
        trim_zeros(&format!("{v:.4}"))
    }
}

fn trim_zeros(s: &str) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s.to_string()
    }
}

/// Regularly spaced angles `0, step, 2·step, … ≤ max` (degrees) with `extra` values merged in
/// (sorted, duplicates within 1e-9 removed): the abscissae of curves whose special points
/// (Brewster's angle, the critical angle) must be sampled exactly.
pub fn angle_grid(max: f64, n: usize, extra: &[f64]) -> Vec<f64> {
    let n = n.max(2);
    let mut v: Vec<f64> = (0..n).map(|i| max * i as f64 / (n - 1) as f64).collect();
    v.extend(extra.iter().copied().filter(|x| (0.0..=max).contains(x)));
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    v
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A fresh scratch directory for one test.
    pub(crate) fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("specula-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// The PNG at `path` decodes, has the given size and is not one flat colour; returns the
    /// number of distinct colours.
    pub(crate) fn assert_png_has_content(path: &Path, size: (u32, u32)) -> usize {
        let (img, _) = specula_render::image_io::read_image(path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert_eq!((img.width as u32, img.height as u32), size);
        let mut colours: Vec<[u8; 3]> = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .map(|(x, y)| img.rgb(x, y).map(|v| (v * 255.0).round() as u8))
            .collect();
        colours.sort_unstable();
        colours.dedup();
        assert!(
            colours.len() > 10,
            "{}: {} colours",
            path.display(),
            colours.len()
        );
        colours.len()
    }

    #[test]
    fn glyphs_keep_their_left_side_bearing() {
        use ab_glyph::{Font, FontRef, ScaleFont};
        // "1" is narrow and set well inside its advance: its ink must start at the bearing,
        // not at the pen (plotters' own placement puts it at x = 0)
        let font = FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT).unwrap();
        let scaled = font.as_scaled(100.0);
        let bearing = scaled.h_side_bearing(scaled.glyph_id('1'));
        assert!(bearing > 5.0, "{bearing}");
        let mut xs = Vec::new();
        assert!(set_text(
            epaint_default_fonts::UBUNTU_LIGHT,
            100.0,
            "1",
            |x, _, c| {
                if c > 0.5 {
                    xs.push(x);
                }
            }
        ));
        let left = *xs.iter().min().unwrap();
        assert!(
            (f64::from(left) - f64::from(bearing)).abs() <= 2.0,
            "{left} vs {bearing}"
        );
        // and the second glyph of "11" starts one advance later
        let advance = scaled.h_advance(scaled.glyph_id('1'));
        let mut xs = Vec::new();
        set_text(
            epaint_default_fonts::UBUNTU_LIGHT,
            100.0,
            "11",
            |x, _, c| {
                if c > 0.5 {
                    xs.push(x);
                }
            },
        );
        let right = *xs.iter().max().unwrap();
        let single_right = {
            let mut v = Vec::new();
            set_text(epaint_default_fonts::UBUNTU_LIGHT, 100.0, "1", |x, _, c| {
                if c > 0.5 {
                    v.push(x);
                }
            });
            *v.iter().max().unwrap()
        };
        assert!((f64::from(right - single_right) - f64::from(advance)).abs() <= 1.0);
    }

    #[test]
    fn supersampled_pixels_are_averaged() {
        // 2 × 1 output from a 3× image: left block white, right block half black
        let (w, h, k) = (2usize, 1usize, 3usize);
        let mut big = vec![255u8; w * k * h * k * 3];
        for y in 0..3 {
            for x in 3..6 {
                if (x + y) % 2 == 0 {
                    let i = (y * w * k + x) * 3;
                    big[i..i + 3].copy_from_slice(&[0, 0, 0]);
                }
            }
        }
        let small = downsample(&big, (2, 1), 3);
        assert_eq!(&small[..3], &[255, 255, 255]);
        // a checkerboard of 4 black among 9 sub-pixels: 255·5/9 = 141.7
        assert_eq!(&small[3..], &[142, 142, 142]);
    }

    #[test]
    fn sizes() {
        assert_eq!(parse_size("900x700"), Ok((900, 700)));
        assert_eq!(parse_size("640×480"), Ok((640, 480)));
        assert!(parse_size("900").is_err());
        assert!(parse_size("10x700").is_err());
        assert!(parse_size("axb").is_err());
    }

    #[test]
    fn ticks_and_labels() {
        let close = |a: Vec<f64>, b: &[f64]| {
            a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12)
        };
        assert!(close(nice_ticks(1.0, 5), &[0.2, 0.4, 0.6, 0.8, 1.0]));
        assert!(close(nice_ticks(7.3, 4), &[2.0, 4.0, 6.0]));
        assert!(close(nice_ticks(0.03, 3), &[0.01, 0.02, 0.03]));
        assert!(nice_ticks(0.0, 4).is_empty());
        assert_eq!(tick_label(0.25), "0.25");
        assert_eq!(tick_label(1e-5), "1e-5");
        assert_eq!(tick_label(2.5e5), "2.5e5");
        assert_eq!(tick_label(3.0), "3");
    }

    #[test]
    fn grids_include_special_angles() {
        let g = angle_grid(90.0, 10, &[56.31, 10.0, 95.0]);
        assert_eq!(g.len(), 11);
        assert!(g.contains(&56.31));
        assert!(g.windows(2).all(|w| w[0] < w[1]));
        assert_eq!((g[0], g[10]), (0.0, 90.0));
    }

    #[test]
    fn ellipsis() {
        assert_eq!(ellipsize("diffuse", 10), "diffuse");
        assert_eq!(ellipsize("abcdefghijkl", 8), "abcde...");
    }

    #[test]
    fn text_renders_with_embedded_fonts() {
        init_fonts();
        let dir = std::env::temp_dir().join(format!("specula-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("t.png");
        {
            let root = BitMapBackend::new(&png, (200, 60)).into_drawing_area();
            root.fill(&WHITE).unwrap();
            root.draw(&Text::new("θ φ ρ", (10, 10), (SANS, 30).into_font()))
                .unwrap();
            root.present().unwrap();
        }
        let (img, _) = specula_render::image_io::read_image(&png).unwrap();
        let dark = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| img.rgb(x, y)[0] < 0.2)
            .count();
        assert!(dark > 50, "only {dark} dark pixels: the text was not drawn");
        std::fs::remove_dir_all(&dir).ok();
    }
}
