//! `specula gallery -o gallery.png [MATERIAL…]`: a labelled contact sheet of material
//! previews.
//!
//! Every material is rendered by the path tracer on the same probe: a sphere on a
//! checkerboard floor under a procedural sky (a blue gradient with a warm sun disc and its
//! glow, generated in memory as a lat-long environment map, so no asset files are needed).
//! The template scene is built once from XML; only the probe's BSDF changes between tiles.
//! The tiles are laid out in a grid under a title, each labelled with its material.
//!
//! The presets with a participating medium ([`MEDIUM_PRESETS`]: absorbing glass, subsurface
//! scattering) give the probe a homogeneous `interior` medium behind its dielectric boundary;
//! their tiles are rendered by `volpath` (unbounded depth, Russian roulette) on a scene of
//! their own, the others by `path` as before.
//!
//! Layout (pixels, `s` = tile size): padding `p = max(4, s/24)`, label strip
//! `l = max(16, s/8)`, title strip `t = max(28, s/5)`; tile `i` lies at
//! x = p + (i mod c)(s + p), y = t + ⌊i/c⌋(s + l + p); the sheet is p + c(s + p) wide and
//! t + r(s + l + p) + p high for c columns and r rows.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use plotters::backend::DrawingBackend;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use specula_render::emitters::{Emitter, Envmap};
use specula_render::image_io::{linear_to_srgb8, Image};
use specula_render::render::{render, RenderOptions, TILE};
use specula_render::scene::Scene;

use crate::output::CliError;
use crate::plot::{draw_err, init_fonts, SANS};

/// The built-in presets: (label, spec).
pub const PRESETS: &[(&str, &str)] = &[
    ("diffuse", "diffuse reflectance=0.2,0.38,0.65"),
    ("conductor Au", "conductor material=Au"),
    (
        "roughconductor Cu α=0.2",
        "roughconductor material=Cu alpha=0.2 distribution=ggx",
    ),
    (
        "brushed Al α=0.05/0.3",
        "roughconductor material=Al alpha_u=0.05 alpha_v=0.3 distribution=ggx",
    ),
    ("dielectric glass", "dielectric int_ior=bk7"),
    (
        "roughdielectric α=0.15",
        "roughdielectric int_ior=bk7 alpha=0.15 distribution=ggx",
    ),
    ("thindielectric", "thindielectric int_ior=bk7"),
    ("plastic", "plastic diffuse_reflectance=0.7,0.09,0.06"),
    (
        "roughplastic α=0.15",
        "roughplastic diffuse_reflectance=0.12,0.4,0.16 alpha=0.15 distribution=ggx",
    ),
    ("sheen", "sheen reflectance=0.9,0.6,0.8 roughness=0.35"),
    (
        "blend velvet",
        "blendbsdf weight=0.5 { diffuse reflectance=0.35,0.04,0.12 } { sheen reflectance=1,0.55,0.7 roughness=0.4 }",
    ),
    (
        "nylon (irawan)",
        "irawan pattern=polyester repeatU=60 repeatV=30 warp_kd=0.03,0.08,0.3 warp_ks=0.5 weft_kd=0.03,0.08,0.3 weft_ks=0.5",
    ),
    (
        "denim (irawan)",
        "irawan pattern=denim repeatU=60 repeatV=30 warp_kd=0.03,0.07,0.25 warp_ks=0.15 weft_kd=0.6,0.6,0.55 weft_ks=0.15",
    ),
    (
        "silk charmeuse (irawan)",
        "irawan pattern=charmeuse repeatU=60 repeatV=30 warp_kd=0.25,0.02,0.05 warp_ks=0.6 weft_kd=0.25,0.02,0.05 weft_ks=0.3",
    ),
    (
        "velvet",
        "blendbsdf weight=0.6 { diffuse reflectance=0.2,0.01,0.04 } { velvet reflectance=0.9,0.25,0.4 sigma=0.3 }",
    ),
    (
        "twosided Cr α=0.08",
        "twosided { roughconductor material=Cr alpha=0.08 distribution=ggx }",
    ),
];

/// The built-in presets with a participating medium inside the probe: (label, boundary
/// BSDF spec, `<medium name="interior">` XML). They follow [`PRESETS`] on the sheet.
pub const MEDIUM_PRESETS: &[(&str, &str, &str)] = &[
    (
        "absorbing glass (amber)",
        "dielectric int_ior=bk7",
        // Beer–Lambert: no scattering, transmittance exp(−σt·d) per channel; through the
        // probe's diameter (2) red keeps 74 %, green 20 %, blue 1.5 %
        r#"<medium type="homogeneous" name="interior">
            <rgb name="sigma_t" value="0.15, 0.8, 2.1"/>
            <rgb name="albedo" value="0, 0, 0"/>
        </medium>"#,
    ),
    (
        "subsurface jade",
        "roughdielectric int_ior=1.6 alpha=0.3 distribution=ggx",
        // dense (mean free path 0.08–0.17), forward-scattering, green-tinted; the rough
        // boundary spreads the sun's glints (light leaves a dielectric-bounded medium only by
        // chance towards the small sun, so a smooth boundary makes fireflies)
        r#"<medium type="homogeneous" name="interior">
            <rgb name="sigma_t" value="6, 12, 8"/>
            <rgb name="albedo" value="0.72, 0.96, 0.8"/>
            <phase type="hg"><float name="g" value="0.3"/></phase>
        </medium>"#,
    ),
    (
        "subsurface skin",
        "roughdielectric int_ior=1.4 alpha=0.3 distribution=ggx",
        // red light travels furthest (lowest σt, highest albedo), as in skin
        r#"<medium type="homogeneous" name="interior">
            <rgb name="sigma_t" value="8, 12, 16"/>
            <rgb name="albedo" value="0.95, 0.75, 0.6"/>
        </medium>"#,
    ),
];

#[derive(Debug, Args)]
pub struct GalleryArgs {
    /// Extra materials, one argument each (quote specs): specs such as
    /// "roughconductor material=Cu alpha=0.2", XML snippets, MERL .binary or RGL .bsdf files,
    /// or scene.xml#id; they follow the built-in presets
    #[arg(value_name = "MATERIAL")]
    pub materials: Vec<String>,
    /// Output picture (.png)
    #[arg(short = 'o', long = "output", default_value = "gallery.png")]
    pub output: PathBuf,
    /// Samples per pixel
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Tile edge in pixels
    #[arg(long, value_name = "PIXELS", default_value_t = 192)]
    pub size: usize,
    /// Tiles per row (default: 4, or fewer for fewer materials)
    #[arg(long)]
    pub columns: Option<usize>,
    /// Random seed (the picture is a deterministic function of the seed)
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Leave out the built-in presets: only the materials given
    #[arg(long)]
    pub no_presets: bool,
    /// Worker threads (default: all cores)
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// No progress bar
    #[arg(long)]
    pub quiet: bool,
}

/// Direction towards the sun (y up; the camera looks along +z and sees +x on its left): to
/// the right of the picture and a little behind the probe, so that the probe shows its lit
/// and its shaded side and casts its shadow forwards to the left.
fn sun_direction() -> Vec3 {
    Vec3::new(-0.8, 0.5, 0.25).normalize()
}
/// Angular radius of the sun disc: larger than the real sun's, which keeps the noise of
/// caustics seen through glass down (their variance falls with the disc's solid angle).
const SUN_RADIUS_DEG: f32 = 5.0;
/// Radiance of the sun disc: with its solid angle (0.024 sr) it gives the floor about as
/// much irradiance as the sky, so shadows are clear but not black.
const SUN_RADIANCE: [f32; 3] = [95.0, 86.0, 72.0];

/// Radiance of the procedural sky (without the sun disc) in direction `d` (y up).
fn sky(d: Vec3) -> [f32; 3] {
    let lerp = |a: [f32; 3], b: [f32; 3], t: f32| std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t);
    if d.y >= 0.0 {
        let zenith = [0.12, 0.23, 0.55];
        let horizon = [0.62, 0.67, 0.76];
        let mut c = lerp(horizon, zenith, d.y.powf(0.55));
        // a warm glow around the sun
        let g = d.dot(sun_direction());
        let glow = 1.2 * (40.0 * (g - 1.0)).exp() + 0.2 * (4.0 * (g - 1.0)).exp();
        for (ch, w) in c.iter_mut().zip([1.0, 0.8, 0.55]) {
            *ch += glow * w;
        }
        c
    } else {
        // ground beyond the floor: a dim, warm grey that darkens downwards
        lerp([0.25, 0.24, 0.22], [0.1, 0.09, 0.08], (-d.y).powf(0.5))
    }
}

/// The sky as a lat-long image in Mitsuba's `envmap` convention: pixel (x, y) looks along
/// θ = π·y/(H − 1) from +y and φ = 2π(x + ½)/W, d = (sinθ sinφ, cosθ, −sinθ cosφ). The sun
/// disc is anti-aliased by 4×4 supersampling of each pixel's coverage.
pub fn sky_image(width: usize) -> Image {
    let height = width / 2 + 1;
    let sun = sun_direction();
    let cos_sun = SUN_RADIUS_DEG.to_radians().cos();
    let dir = |theta: f32, phi: f32| {
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        Vec3::new(st * sp, ct, -st * cp)
    };
    let (dt, dp) = (
        std::f32::consts::PI / (height - 1) as f32,
        2.0 * std::f32::consts::PI / width as f32,
    );
    let mut data = Vec::with_capacity(width * height * 3);
    for y in 0..height {
        for x in 0..width {
            let (theta, phi) = (y as f32 * dt, (x as f32 + 0.5) * dp);
            let d = dir(theta, phi);
            let mut c = sky(d);
            if d.dot(sun) > (SUN_RADIUS_DEG * 3.0).to_radians().cos() {
                let mut cover = 0.0;
                for i in 0..4 {
                    for j in 0..4 {
                        let t = theta + dt * ((i as f32 + 0.5) / 4.0 - 0.5);
                        let p = phi + dp * ((j as f32 + 0.5) / 4.0 - 0.5);
                        if dir(t, p).dot(sun) >= cos_sun {
                            cover += 1.0 / 16.0;
                        }
                    }
                }
                for (ch, s) in c.iter_mut().zip(SUN_RADIANCE) {
                    *ch += cover * s;
                }
            }
            data.extend_from_slice(&c);
        }
    }
    Image {
        width,
        height,
        channels: 3,
        data,
    }
}

/// The template scene: the probe sphere (shape 0) on a checkerboard floor, seen from slightly
/// above; the sky is added by [`preview_scene`]. `medium` (a `<medium name="interior">`
/// element, or empty) goes inside the probe, and with it the integrator becomes `volpath`.
fn template_xml(size: usize, medium: &str) -> String {
    let integrator = if medium.is_empty() {
        r#"<integrator type="path">
        <integer name="max_depth" value="16"/>
    </integrator>"#
    } else {
        r#"<integrator type="volpath">
        <integer name="max_depth" value="-1"/>
    </integrator>"#
    };
    format!(
        r#"<scene version="3.0.0">
    {integrator}
    <sensor type="perspective">
        <float name="fov" value="28"/>
        <transform name="to_world">
            <lookat origin="0, 2.1, -5.6" target="0, 0.86, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="64"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="{size}"/>
            <integer name="height" value="{size}"/>
            <rfilter type="gaussian"/>
        </film>
    </sensor>
    <shape type="sphere" id="probe">
        <point name="center" value="0, 1, 0"/>
        <float name="radius" value="1"/>
        <bsdf type="diffuse"/>
        {medium}
    </shape>
    <shape type="rectangle" id="floor">
        <transform name="to_world">
            <rotate x="1" angle="-90"/>
            <scale value="100"/>
        </transform>
        <bsdf type="diffuse">
            <texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="0.62, 0.6, 0.56"/>
                <rgb name="color1" value="0.1, 0.1, 0.11"/>
                <transform name="to_uv">
                    <scale x="200" y="200"/>
                </transform>
            </texture>
        </bsdf>
    </shape>
</scene>"#
    )
}

/// The preview scene at `size`×`size` pixels with the procedural sky; returns it with the
/// index of the probe's BSDF in `scene.bsdfs`.
pub fn preview_scene(size: usize) -> Result<(Scene, usize), CliError> {
    preview_scene_with_medium(size, "")
}

/// [`preview_scene`] with `medium` (a `<medium name="interior">` element, or empty) inside
/// the probe, rendered by `volpath` when there is one.
pub fn preview_scene_with_medium(size: usize, medium: &str) -> Result<(Scene, usize), CliError> {
    let mut scene = Scene::from_xml_str(
        &template_xml(size, medium),
        "<gallery scene>",
        Path::new("."),
        &[],
    )
    .map_err(|e| CliError::usage(format!("gallery scene: {e}")))?;
    let env = Envmap::new(&sky_image(1024), false, 1.0, &glam::Mat4::IDENTITY)
        .map_err(|e| CliError::usage(format!("gallery sky: {e}")))?;
    scene.add_light(Emitter::Envmap(Box::new(env)));
    let probe = scene.shape_bsdf[0] as usize;
    Ok((scene, probe))
}

/// Sheet geometry (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub size: usize,
    pub columns: usize,
    pub rows: usize,
    pub pad: usize,
    pub label: usize,
    pub title: usize,
}

impl Layout {
    pub fn new(size: usize, columns: usize, tiles: usize) -> Layout {
        let columns = columns.clamp(1, tiles.max(1));
        Layout {
            size,
            columns,
            rows: tiles.div_ceil(columns),
            pad: (size / 24).max(4),
            label: (size / 8).max(16),
            title: (size / 5).max(28),
        }
    }
    pub fn width(&self) -> usize {
        self.pad + self.columns * (self.size + self.pad)
    }
    pub fn height(&self) -> usize {
        self.title + self.rows * (self.size + self.label + self.pad) + self.pad
    }
    /// Top-left corner of tile `i`.
    pub fn tile(&self, i: usize) -> (usize, usize) {
        let (c, r) = (i % self.columns, i / self.columns);
        (
            self.pad + c * (self.size + self.pad),
            self.title + r * (self.size + self.label + self.pad),
        )
    }
}

/// Background of the sheet (sRGB).
const BACKGROUND: [u8; 3] = [30, 31, 34];

/// Text drawn glyph by glyph with even spacing.
///
/// plotters 0.3.7's ab_glyph text renderer puts each glyph's ink at the pen position, dropping
/// the glyph's left side bearing, so letters crowd or gap unevenly ("roug hconductor"). Here
/// each glyph is drawn on its own, its ink (measured once by rasterising it alone) centred in
/// its advance width, which plotters computes correctly.
struct Typesetter {
    font: FontDesc<'static>,
    /// char → (offset of the ink from the drawing position, ink width), `None` for blanks
    ink: std::collections::HashMap<char, Option<(i32, i32)>>,
}

impl Typesetter {
    fn new(font: FontDesc<'static>) -> Self {
        Typesetter {
            font,
            ink: std::collections::HashMap::new(),
        }
    }

    /// Advance width of `text` in pixels.
    fn width(&self, text: &str) -> i32 {
        self.font.box_size(text).map_or(0, |(w, _)| w as i32)
    }

    /// Longest prefix of `text` (with "…") that fits in `width` pixels.
    fn fit(&self, text: &str, width: i32) -> String {
        if self.width(text) <= width {
            return text.to_string();
        }
        let chars: Vec<char> = text.chars().collect();
        (1..chars.len())
            .rev()
            .map(|n| chars[..n].iter().collect::<String>() + "…")
            .find(|s| self.width(s) <= width)
            .unwrap_or_else(|| "…".into())
    }

    fn ink(&mut self, c: char) -> Option<(i32, i32)> {
        let font = &self.font;
        *self.ink.entry(c).or_insert_with(|| {
            let size = font.get_size().ceil() as usize + 2;
            let (w, h) = (4 * size, 3 * size);
            let mut buf = vec![255u8; w * h * 3];
            {
                let area =
                    BitMapBackend::with_buffer(&mut buf, (w as u32, h as u32)).into_drawing_area();
                let style = TextStyle::from(font.clone())
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Left, VPos::Center));
                area.draw(&Text::new(
                    c.to_string(),
                    (size as i32, h as i32 / 2),
                    style,
                ))
                .ok()?;
                area.present().ok()?;
            }
            let inked = |x: usize| (0..h).any(|y| buf[3 * (y * w + x)] < 160);
            let first = (0..w).find(|&x| inked(x))?;
            let last = (0..w).rev().find(|&x| inked(x))?;
            Some((first as i32 - size as i32, (last - first + 1) as i32))
        })
    }

    /// Draw `text` starting at `left`, vertically centred on `y`.
    fn draw<DB: DrawingBackend>(
        &mut self,
        area: &DrawingArea<DB, plotters::coord::Shift>,
        text: &str,
        (left, y): (i32, i32),
        color: RGBColor,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        let style = TextStyle::from(self.font.clone())
            .color(&color)
            .pos(Pos::new(HPos::Left, VPos::Center));
        let chars: Vec<char> = text.chars().collect();
        for (i, &c) in chars.iter().enumerate() {
            let pen = self.width(&chars[..i].iter().collect::<String>());
            let next = self.width(&chars[..=i].iter().collect::<String>());
            if let Some((offset, ink)) = self.ink(c) {
                let x = left + pen + (next - pen - ink) / 2 - offset;
                area.draw(&Text::new(c.to_string(), (x, y), style.clone()))?;
            }
        }
        Ok(())
    }
}

/// A material to render and its tile label.
struct Entry {
    label: String,
    bsdf: specula_bsdf::Bsdf,
    /// The probe's interior medium (XML), for the presets that have one.
    medium: Option<&'static str>,
}

/// The entries of [`PRESETS`] and [`MEDIUM_PRESETS`].
fn preset_entries() -> Result<Vec<Entry>, CliError> {
    let mut entries = Vec::new();
    for (label, spec) in PRESETS {
        let bsdf = specula_bsdf::parse_spec(spec)
            .map_err(|e| CliError::usage(format!("preset '{label}': {e}")))?;
        entries.push(Entry {
            label: label.to_string(),
            bsdf,
            medium: None,
        });
    }
    for (label, spec, medium) in MEDIUM_PRESETS {
        let bsdf = specula_bsdf::parse_spec(spec)
            .map_err(|e| CliError::usage(format!("preset '{label}': {e}")))?;
        entries.push(Entry {
            label: label.to_string(),
            bsdf,
            medium: Some(medium),
        });
    }
    Ok(entries)
}

/// Renders every entry's tile (linear RGB, `size`² pixels); `progress(k, done)` is told of
/// tile `k`'s finished render tiles.
fn render_tiles(
    entries: &[Entry],
    size: usize,
    opts: &RenderOptions,
    stop: &AtomicBool,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<Vec<Vec<f32>>, CliError> {
    let (mut scene, probe) = preview_scene(size)?;
    let mut tiles = Vec::with_capacity(entries.len());
    for (k, e) in entries.iter().enumerate() {
        let r = match e.medium {
            None => {
                scene.set_bsdf(probe, e.bsdf.clone());
                render(&scene, opts, stop, &|done, _| progress(k, done))
            }
            Some(medium) => {
                let (mut s, p) = preview_scene_with_medium(size, medium)
                    .map_err(|e2| CliError::usage(format!("preset '{}': {e2:?}", e.label)))?;
                s.set_bsdf(p, e.bsdf.clone());
                render(&s, opts, stop, &|done, _| progress(k, done))
            }
        };
        tiles.push(r.rgb);
    }
    Ok(tiles)
}

pub fn run(args: &GalleryArgs, out: &mut dyn Write) -> Result<(), CliError> {
    crate::plot::format_of(&args.output, false)?;
    if args.spp == 0 {
        return Err(CliError::usage("--spp must be positive"));
    }
    if !(16..=4096).contains(&args.size) {
        return Err(CliError::usage(format!(
            "--size must lie in [16, 4096] pixels, got {}",
            args.size
        )));
    }
    if args.columns == Some(0) {
        return Err(CliError::usage("--columns must be positive"));
    }
    let mut entries = if args.no_presets {
        Vec::new()
    } else {
        preset_entries()?
    };
    for m in &args.materials {
        let material = crate::material::load_material(std::slice::from_ref(m))?;
        entries.push(Entry {
            label: material.short_label(),
            bsdf: material.bsdf,
            medium: None,
        });
    }
    if entries.is_empty() {
        return Err(CliError::usage(
            "no materials: give some, or leave out --no-presets",
        ));
    }

    let start = Instant::now();
    let opts = RenderOptions {
        spp: args.spp,
        seed: args.seed,
        threads: args.threads,
    };
    let per_render = args.size.div_ceil(TILE).pow(2);
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        ProgressBar::new((per_render * entries.len()) as u64)
    };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {msg}  ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let stop = AtomicBool::new(false);
    let tiles = render_tiles(&entries, args.size, &opts, &stop, &|k, done| {
        if done == 0 {
            bar.set_message(format!("{}/{} {}", k + 1, entries.len(), entries[k].label));
        }
        bar.set_position((k * per_render + done) as u64);
    })?;
    bar.finish_and_clear();

    let columns = args.columns.unwrap_or(4);
    let layout = Layout::new(args.size, columns, entries.len());
    let labels: Vec<&str> = entries.iter().map(|e| e.label.as_str()).collect();
    let subtitle = format!(
        "path traced{} at {} spp under a procedural sky · specula gallery",
        if entries.iter().any(|e| e.medium.is_some()) {
            " (media: volpath)"
        } else {
            ""
        },
        args.spp
    );
    compose(&args.output, &layout, &tiles, &labels, &subtitle)?;
    writeln!(
        out,
        "{}: {} materials, {}×{} tiles of {} px at {} spp, {}×{} px in {:.1} s",
        args.output.display(),
        entries.len(),
        layout.columns,
        layout.rows,
        args.size,
        args.spp,
        layout.width(),
        layout.height(),
        start.elapsed().as_secs_f64()
    )?;
    Ok(())
}

/// Draw the sheet: background, tiles (linear RGB, sRGB-encoded here), labels and title.
fn compose(
    path: &Path,
    layout: &Layout,
    tiles: &[Vec<f32>],
    labels: &[&str],
    subtitle: &str,
) -> Result<(), CliError> {
    init_fonts();
    let (w, h) = (layout.width(), layout.height());
    let mut sheet: Vec<u8> = BACKGROUND.repeat(w * h);
    let s = layout.size;
    for (i, rgb) in tiles.iter().enumerate() {
        let (x0, y0) = layout.tile(i);
        for y in 0..s {
            for x in 0..s {
                let src = 3 * (y * s + x);
                let dst = 3 * ((y0 + y) * w + x0 + x);
                for c in 0..3 {
                    sheet[dst + c] = linear_to_srgb8(rgb[src + c]);
                }
            }
        }
    }
    let mut backend = BitMapBackend::new(path, (w as u32, h as u32));
    backend
        .blit_bitmap((0, 0), (w as u32, h as u32), &sheet)
        .map_err(draw_err(path))?;
    let root = backend.into_drawing_area();

    let label_px = (layout.label as f64 * 0.72).round();
    let label_font = FontDesc::new(FontFamily::Name(SANS), label_px, FontStyle::Normal);
    let mut labeller = Typesetter::new(label_font);
    for (i, label) in labels.iter().enumerate() {
        let (x0, y0) = layout.tile(i);
        let text = labeller.fit(label, (s - 4) as i32);
        let width = labeller.width(&text);
        let left = (x0 + s / 2) as i32 - width / 2;
        let y = (y0 + s + layout.label / 2 + 1) as i32;
        labeller
            .draw(&root, &text, (left, y), RGBColor(225, 226, 230))
            .map_err(draw_err(path))?;
    }

    let title_px = (layout.title as f64 * 0.5).round();
    let mut title = Typesetter::new(FontDesc::new(
        FontFamily::Name(SANS),
        title_px,
        FontStyle::Normal,
    ));
    let sub_px = (layout.title as f64 * 0.3).round().max(9.0);
    let mut sub = Typesetter::new(FontDesc::new(
        FontFamily::Name(SANS),
        sub_px,
        FontStyle::Normal,
    ));
    let text = title.fit("Specula material gallery", (w - 2 * layout.pad) as i32);
    let y = (layout.title as f64 * 0.55) as i32;
    title
        .draw(
            &root,
            &text,
            (layout.pad as i32, y),
            RGBColor(245, 245, 248),
        )
        .map_err(draw_err(path))?;
    // the subtitle after the title when there is room, else nothing
    let sub_x = layout.pad as i32 + title.width(&text) + 2 * layout.pad as i32;
    if sub_x + 40 < w as i32 {
        let text = sub.fit(subtitle, w as i32 - sub_x - layout.pad as i32);
        sub.draw(&root, &text, (sub_x, y), RGBColor(150, 152, 160))
            .map_err(draw_err(path))?;
    }
    root.present().map_err(draw_err(path))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_parse() {
        for (label, spec) in PRESETS {
            specula_bsdf::parse_spec(spec).unwrap_or_else(|e| panic!("{label}: {e}"));
        }
        // the medium presets build volpath scenes with the medium inside the probe
        for (label, _, medium) in MEDIUM_PRESETS {
            let (scene, _) =
                preview_scene_with_medium(16, medium).unwrap_or_else(|e| panic!("{label}: {e:?}"));
            assert!(scene.volpath, "{label}");
            assert_eq!(scene.media.len(), 1, "{label}");
            assert_eq!(scene.shape_media[0].interior, Some(0), "{label}");
        }
        let (scene, _) = preview_scene(16).unwrap();
        assert!(!scene.volpath && scene.media.is_empty());
    }

    /// Mean linear RGB of the central `r`×`r` pixels of a `size`² tile (the probe).
    fn centre(tile: &[f32], size: usize, r: usize) -> [f64; 3] {
        let mut m = [0.0f64; 3];
        let (a, b) = (size / 2 - r / 2, size / 2 + r / 2);
        for y in a..b {
            for x in a..b {
                for (c, v) in m.iter_mut().enumerate() {
                    *v += f64::from(tile[3 * (y * size + x) + c]);
                }
            }
        }
        m.map(|v| v / ((b - a) * (b - a)) as f64)
    }

    /// The medium presets render (small, few samples, fixed seed): finite, not black, and the
    /// amber glass is the clear glass filtered by Beer–Lambert absorption (much less blue and
    /// green against red than the same glass without its medium).
    #[test]
    fn medium_presets_render_and_absorbing_glass_is_coloured() {
        let size = 40;
        let mut entries = vec![Entry {
            label: "clear glass".into(),
            bsdf: specula_bsdf::parse_spec(MEDIUM_PRESETS[0].1).unwrap(),
            medium: None,
        }];
        entries.extend(
            preset_entries()
                .unwrap()
                .into_iter()
                .filter(|e| e.medium.is_some()),
        );
        assert_eq!(entries.len(), 1 + MEDIUM_PRESETS.len());
        let opts = RenderOptions {
            spp: 32,
            seed: 3,
            threads: 0,
        };
        let tiles =
            render_tiles(&entries, size, &opts, &AtomicBool::new(false), &|_, _| {}).unwrap();
        for (e, t) in entries.iter().zip(&tiles) {
            assert_eq!(t.len(), 3 * size * size);
            assert!(t.iter().all(|v| v.is_finite() && *v >= 0.0), "{}", e.label);
            let m = centre(t, size, 12);
            println!("{}: probe centre {m:.4?}", e.label);
            assert!(
                m.iter().sum::<f64>() > 0.05,
                "{}: black probe {m:?}",
                e.label
            );
        }
        let clear = centre(&tiles[0], size, 12);
        let amber = centre(&tiles[1], size, 12);
        // through the centre the refracted path is ~2 long: blue/red falls by e^(−3.9) ≈ 0.02
        // and green/red by e^(−1.3) ≈ 0.27, diluted by the (uncoloured) surface reflection
        let ratio = |m: [f64; 3], c: usize| m[c] / m[0];
        let (rb, rg) = (
            ratio(amber, 2) / ratio(clear, 2),
            ratio(amber, 1) / ratio(clear, 1),
        );
        assert!(rb < 0.25, "blue/red of amber over clear glass: {rb}");
        assert!(
            rg < 0.6 && rg > rb,
            "green/red of amber over clear glass: {rg}"
        );
        assert!(
            amber[0] > 0.5 * clear[0],
            "red is hardly absorbed: {amber:?} {clear:?}"
        );
        // the subsurface presets take their albedo's tint: jade green, skin red
        let jade = centre(&tiles[2], size, 12);
        let skin = centre(&tiles[3], size, 12);
        assert!(jade[1] > 1.3 * jade[0].max(jade[2]), "{jade:?}");
        assert!(skin[0] > 2.0 * skin[1].max(skin[2]), "{skin:?}");
    }

    #[test]
    fn layout_tiles_do_not_overlap_and_fit() {
        let l = Layout::new(64, 3, 7);
        assert_eq!((l.columns, l.rows), (3, 3));
        let boxes: Vec<(usize, usize)> = (0..7).map(|i| l.tile(i)).collect();
        for (i, a) in boxes.iter().enumerate() {
            assert!(a.0 + l.size <= l.width() && a.1 + l.size + l.label <= l.height());
            for b in &boxes[i + 1..] {
                let apart = a.0 + l.size <= b.0
                    || b.0 + l.size <= a.0
                    || a.1 + l.size + l.label <= b.1
                    || b.1 + l.size + l.label <= a.1;
                assert!(apart, "{a:?} {b:?}");
            }
        }
        // fewer tiles than columns: the sheet shrinks to them
        assert_eq!(Layout::new(64, 4, 2).columns, 2);
    }

    #[test]
    fn sky_is_brightest_at_the_sun_and_seen_from_the_sun_direction() {
        let img = sky_image(256);
        let env = Envmap::new(&img, false, 1.0, &glam::Mat4::IDENTITY).unwrap();
        let sun = env.eval(sun_direction());
        let zenith = env.eval(Vec3::Y);
        let horizon = env.eval(Vec3::new(1.0, 0.02, 0.0).normalize());
        assert!(
            sun.luminance() > 100.0 * zenith.luminance(),
            "{sun:?} {zenith:?}"
        );
        // the sky is bluer at the zenith than at the horizon
        assert!(zenith.b() / zenith.r() > horizon.b() / horizon.r());
    }
}
