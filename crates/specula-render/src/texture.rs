//! Mitsuba 3's `checkerboard`, `bitmap` and `mesh_attribute` textures.
//!
//! Conventions checked against Mitsuba 3.9.1 (`scalar_rgb` and `llvm_ad_rgb`; the reference
//! values in the tests come from it):
//! - `to_uv` is a 2-D affine map applied to the surface uv first; a 4×4 XML transform keeps
//!   rows/columns 0, 1 and 3 (x/y scale, rotation, shear and translation; z is dropped).
//! - bitmap: uv (0, 0) is the top-left corner of the image's first (top) row, v grows
//!   downwards (no flip); pixel (x, y) is centred at ((x + ½)/W, (y + ½)/H). Bilinear lookups
//!   interpolate between pixel centres (`uv·res − ½`), nearest lookups take `⌊uv·res⌋`, and the
//!   wrap mode is applied to the integer texel indices.
//! - 8-bit sRGB data is converted to linear *per texel, before* interpolation (unless `raw`);
//!   the values are those of f32 data (no half-float rounding is visible in 3.9.1's lookups).
//!   8-bit images keep their bytes and each lookup converts its texels through a 256-entry
//!   table (the same values as converting up front, at a quarter of the memory and no
//!   conversion pass at load); other images are stored as f32.
//! - `eval_1` of an RGB bitmap is the luminance (Rec. 709 weights) of the interpolated colour.
//! - `eval_1_grad` of a bitmap (what `bumpmap` uses) is the exact (u, v) derivative of the
//!   bilinear interpolant of the texels' scalar values, zero with nearest filtering; textures
//!   other than bitmaps have none (Mitsuba: "not implemented").
//! - `mesh_attribute` (`name` = `vertex_…`/`face_…`, `scale` default 1) reads the hit mesh's
//!   attribute through the shading point (see [`MeshAttributeTexture`]).

use crate::core::{to_f32, Result, SceneError};
use crate::image_io::{read_image_raw_prefetched, srgb_to_linear, Image, Pixels, RawImage};
use crate::xml::{Node, PropValue};
use glam::{Mat3, Mat4, Vec2, Vec3};
use specula_bsdf::math::floor;
use specula_bsdf::{Rgb, ShadingPoint, Texture};
use std::path::Path;

/// The 2-D affine uv transform of a 4×4 `to_uv` matrix, as Mitsuba extracts it: the upper-left
/// 2×2 block and the x/y translation.
pub fn uv_transform(m: &Mat4) -> Mat3 {
    Mat3::from_cols(
        Vec3::new(m.x_axis.x, m.x_axis.y, 0.0),
        Vec3::new(m.y_axis.x, m.y_axis.y, 0.0),
        Vec3::new(m.w_axis.x, m.w_axis.y, 1.0),
    )
}

#[inline]
fn apply_uv(m: &Mat3, uv: Vec2) -> Vec2 {
    m.transform_point2(uv)
}

/// Mitsuba's `checkerboard`: `color0` where the fractional parts of u and v are both ≤ ½ or
/// both > ½, `color1` elsewhere. A colour given as a `<spectrum>` keeps the spectrum beside
/// its RGB value (`spectra`), which spectral mode evaluates at the path's wavelengths (as
/// Mitsuba's spectral variants do); the other colour is upsampled as any RGB value.
#[derive(Clone, Debug)]
pub struct Checkerboard {
    pub color0: Rgb,
    pub color1: Rgb,
    pub to_uv: Mat3,
    /// `color0`'s and `color1`'s `<spectrum>`, if given as one.
    pub spectra: [Option<std::sync::Arc<dyn specula_bsdf::bsdf::SpectralCurve>>; 2],
}

impl Default for Checkerboard {
    /// Mitsuba's defaults: color0 = 0.4, color1 = 0.2, identity `to_uv`.
    fn default() -> Self {
        Checkerboard {
            color0: Rgb::splat(0.4),
            color1: Rgb::splat(0.2),
            to_uv: Mat3::IDENTITY,
            spectra: [None, None],
        }
    }
}

impl Checkerboard {
    /// `to_uv` is the XML 4×4 transform (see [`uv_transform`]).
    pub fn new(color0: Rgb, color1: Rgb, to_uv: Mat4) -> Self {
        Checkerboard {
            color0,
            color1,
            to_uv: uv_transform(&to_uv),
            spectra: [None, None],
        }
    }

    /// True where the pattern shows `color0`.
    #[inline]
    fn is_color0(&self, uv: Vec2) -> bool {
        let uv = apply_uv(&self.to_uv, uv);
        let mx = uv.x - floor(uv.x) > 0.5;
        let my = uv.y - floor(uv.y) > 0.5;
        mx == my
    }
}

impl Texture for Checkerboard {
    fn eval(&self, sp: &ShadingPoint) -> Rgb {
        if self.is_color0(sp.uv) {
            self.color0
        } else {
            self.color1
        }
    }

    /// Mitsuba 3.9.1's `Checkerboard::eval_1` tests the opposite condition from `eval`
    /// (`neq` instead of `eq`), so scalar lookups (e.g. a checkerboard roughness map) see the
    /// two colours swapped; each colour's scalar value is the mean of its channels (what its
    /// `srgb` constant texture's `eval_1` returns). Replicated here so renders match.
    fn eval_1(&self, sp: &ShadingPoint) -> f32 {
        if self.is_color0(sp.uv) {
            self.color1.mean()
        } else {
            self.color0.mean()
        }
    }

    fn mean(&self) -> Rgb {
        (self.color0 + self.color1) * 0.5
    }

    fn eval_spectral(&self, sp: &ShadingPoint, w: &specula_bsdf::Wavelengths) -> Option<Rgb> {
        if self.spectra.iter().all(Option::is_none) {
            return None;
        }
        let k = if self.is_color0(sp.uv) { 0 } else { 1 };
        Some(match &self.spectra[k] {
            Some(s) => s.eval_at(w),
            None => specula_bsdf::spectral::upsample::unbounded([self.color0, self.color1][k], w),
        })
    }
}

/// Bitmap lookup filter (`filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterType {
    #[default]
    Bilinear,
    Nearest,
}

impl FilterType {
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "bilinear" => Some(FilterType::Bilinear),
            "nearest" => Some(FilterType::Nearest),
            _ => None,
        }
    }
}

/// Bitmap addressing outside [0, 1] (`wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    #[default]
    Repeat,
    Mirror,
    Clamp,
}

impl WrapMode {
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "repeat" => Some(WrapMode::Repeat),
            "mirror" => Some(WrapMode::Mirror),
            "clamp" => Some(WrapMode::Clamp),
            _ => None,
        }
    }

    /// Maps an integer texel index onto [0, n).
    #[inline]
    fn wrap(self, i: i64, n: i64) -> usize {
        (match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        }) as usize
    }
}

/// Texel storage: bytes with the table of their linear values, or linear f32 values.
#[derive(Clone, Debug)]
enum Texels {
    U8(Vec<u8>, &'static [f32; 256]),
    F32(Vec<f32>),
}

/// Keeps the first `keep` of every `stride` values and doubles a single column or row (what
/// Mitsuba's upsampling of images narrower than 2 texels yields); returns the new size.
fn compact<T: Copy>(
    data: &mut Vec<T>,
    stride: usize,
    keep: usize,
    (width, height): (usize, usize),
) -> (usize, usize) {
    if stride != keep {
        let n = data.len() / stride;
        for i in 0..n {
            for c in 0..keep {
                data[i * keep + c] = data[i * stride + c];
            }
        }
        data.truncate(n * keep);
    }
    let (mut width, mut height) = (width, height);
    if width == 1 {
        *data = data
            .chunks_exact(keep)
            .flat_map(|p| p.iter().chain(p.iter()).copied().collect::<Vec<_>>())
            .collect();
        width = 2;
    }
    if height == 1 {
        *data = data.iter().chain(data.iter()).copied().collect();
        height = 2;
    }
    (width, height)
}

/// Per-channel histograms of interleaved bytes (`channels` per pixel, 1 … 3), counted in
/// parallel over parts of the data (integer counts: the same whatever the split).
fn byte_histograms(data: &[u8], channels: usize) -> Vec<[u64; 256]> {
    use rayon::prelude::*;
    let count = |part: &[u8]| {
        let mut hist = vec![[0u64; 256]; channels];
        if channels == 3 {
            // two pixels at a time into two sets of counters: neighbouring pixels mostly
            // have the same values, and one set would make each increment wait for the last
            let mut h = [[0u32; 256]; 6];
            let mut pairs = part.chunks_exact(6);
            for px in &mut pairs {
                h[0][px[0] as usize] += 1;
                h[1][px[1] as usize] += 1;
                h[2][px[2] as usize] += 1;
                h[3][px[3] as usize] += 1;
                h[4][px[4] as usize] += 1;
                h[5][px[5] as usize] += 1;
            }
            for (c, &b) in pairs.remainder().iter().enumerate() {
                h[c][b as usize] += 1;
            }
            for (c, hc) in hist.iter_mut().enumerate() {
                for (k, v) in hc.iter_mut().enumerate() {
                    *v = h[c][k] as u64 + h[c + 3][k] as u64;
                }
            }
        } else {
            for px in part.chunks_exact(channels) {
                for (c, &b) in px.iter().enumerate() {
                    hist[c][b as usize] += 1;
                }
            }
        }
        hist
    };
    // parts of whole pixels, large enough to be worth a task (and few enough that no
    // counter can overflow 32 bits)
    let part = channels * (1 << 18);
    if data.len() <= part {
        return count(data);
    }
    data.par_chunks(part).map(count).reduce(
        || vec![[0u64; 256]; channels],
        |mut a, b| {
            for (ha, hb) in a.iter_mut().zip(&b) {
                for (x, y) in ha.iter_mut().zip(hb) {
                    *x += y;
                }
            }
            a
        },
    )
}

/// Mitsuba's `bitmap` texture: 1- or 3-channel linear data (RGBA loses its alpha, grey+alpha
/// its alpha).
#[derive(Clone, Debug)]
pub struct Bitmap {
    pub width: usize,
    pub height: usize,
    /// 1 or 3.
    pub channels: usize,
    /// The texels, row-major, top row first, `channels` values each.
    texels: Texels,
    pub filter: FilterType,
    pub wrap: WrapMode,
    pub to_uv: Mat3,
    /// [`Self::compute_mean`], once asked for.
    mean: std::sync::OnceLock<Rgb>,
}

impl Bitmap {
    /// Loads `path` with Mitsuba's string parameters (`filter_type`: bilinear | nearest,
    /// `wrap_mode`: repeat | mirror | clamp); `to_uv` is the XML 4×4 transform.
    pub fn load(path: &Path, filter: &str, wrap: &str, raw: bool, to_uv: Mat4) -> Result<Self> {
        let f = FilterType::parse(filter).ok_or_else(|| {
            SceneError::file(
                path,
                format!("invalid filter_type \"{filter}\" (bilinear, nearest)"),
            )
        })?;
        let w = WrapMode::parse(wrap).ok_or_else(|| {
            SceneError::file(
                path,
                format!("invalid wrap_mode \"{wrap}\" (repeat, mirror, clamp)"),
            )
        })?;
        let img = read_image_raw_prefetched(path)?;
        if img.width == 0 || img.height == 0 {
            return Err(SceneError::file(path, "image is empty"));
        }
        Ok(Self::from_raw(img, f, w, raw, uv_transform(&to_uv)))
    }

    /// Builds the texture from decoded data as stored ([`RawImage`]): 8-bit data keeps its
    /// bytes; sRGB-encoded values are linearised unless `raw`.
    pub fn from_raw(
        img: RawImage,
        filter: FilterType,
        wrap: WrapMode,
        raw: bool,
        to_uv: Mat3,
    ) -> Self {
        let channels = if img.channels >= 3 { 3 } else { 1 };
        let linearise = img.srgb && !raw;
        let size = (img.width, img.height);
        let (texels, (width, height)) = match img.pixels {
            Pixels::U8(mut v) => {
                let size = compact(&mut v, img.channels, channels, size);
                let table = if linearise {
                    crate::image_io::srgb8_to_linear()
                } else {
                    crate::image_io::unorm8()
                };
                (Texels::U8(v, table), size)
            }
            Pixels::F32(mut v) => {
                let size = compact(&mut v, img.channels, channels, size);
                if linearise {
                    for x in &mut v {
                        *x = srgb_to_linear(*x);
                    }
                }
                (Texels::F32(v), size)
            }
        };
        Self::with_texels(texels, width, height, channels, filter, wrap, to_uv)
    }

    /// Builds the texture from decoded data; `srgb` says the values are sRGB-encoded, which
    /// are linearised unless `raw`.
    pub fn from_image(
        img: &Image,
        srgb: bool,
        filter: FilterType,
        wrap: WrapMode,
        raw: bool,
        to_uv: Mat3,
    ) -> Self {
        let channels = if img.channels >= 3 { 3 } else { 1 };
        let linearise = srgb && !raw;
        let mut data = Vec::with_capacity(img.width * img.height * channels);
        for px in img.data.chunks_exact(img.channels) {
            for &v in &px[..channels] {
                data.push(if linearise { srgb_to_linear(v) } else { v });
            }
        }
        let (width, height) = compact(&mut data, channels, channels, (img.width, img.height));
        Self::with_texels(
            Texels::F32(data),
            width,
            height,
            channels,
            filter,
            wrap,
            to_uv,
        )
    }

    fn with_texels(
        texels: Texels,
        width: usize,
        height: usize,
        channels: usize,
        filter: FilterType,
        wrap: WrapMode,
        to_uv: Mat3,
    ) -> Self {
        Bitmap {
            width,
            height,
            channels,
            texels,
            filter,
            wrap,
            to_uv,
            mean: std::sync::OnceLock::new(),
        }
    }

    /// Per-channel average of the linear data, computed on first use (only some materials
    /// ask for it, e.g. plastic's sampling weights; a normal or bump map never does).
    fn compute_mean(&self) -> Rgb {
        let (width, height, channels) = (self.width, self.height, self.channels);
        let n = (width * height) as f64;
        let mut sum = [0f64; 3];
        match &self.texels {
            Texels::F32(data) => {
                for px in data.chunks_exact(channels) {
                    for (c, s) in sum.iter_mut().enumerate() {
                        *s += px[c.min(channels - 1)] as f64;
                    }
                }
            }
            Texels::U8(data, table) => {
                // a histogram per channel, then the sum of its values (exact in f64); the
                // counts are integers, so summing the histograms of parts in parallel gives
                // the same result
                let hist = byte_histograms(data, channels);
                for (c, s) in sum.iter_mut().enumerate() {
                    let h = &hist[c.min(channels - 1)];
                    *s = (0..256).map(|k| h[k] as f64 * table[k] as f64).sum();
                }
            }
        }
        Rgb::new(
            (sum[0] / n) as f32,
            (sum[1] / n) as f32,
            (sum[2] / n) as f32,
        )
    }

    #[inline]
    fn texel(&self, x: usize, y: usize) -> Rgb {
        let i = (y * self.width + x) * self.channels;
        match &self.texels {
            Texels::U8(d, t) => {
                if self.channels == 1 {
                    Rgb::splat(t[d[i] as usize])
                } else {
                    Rgb::new(t[d[i] as usize], t[d[i + 1] as usize], t[d[i + 2] as usize])
                }
            }
            Texels::F32(d) => {
                if self.channels == 1 {
                    Rgb::splat(d[i])
                } else {
                    Rgb::new(d[i], d[i + 1], d[i + 2])
                }
            }
        }
    }

    /// The (linear) colour at texture coordinates `uv` (before `to_uv`).
    pub fn lookup(&self, uv: Vec2) -> Rgb {
        let uv = apply_uv(&self.to_uv, uv);
        let (w, h) = (self.width as i64, self.height as i64);
        match self.filter {
            FilterType::Nearest => {
                let x = floor(uv.x * to_f32(self.width)) as i64;
                let y = floor(uv.y * to_f32(self.height)) as i64;
                self.texel(self.wrap.wrap(x, w), self.wrap.wrap(y, h))
            }
            FilterType::Bilinear => {
                let px = uv.x * to_f32(self.width) - 0.5;
                let py = uv.y * to_f32(self.height) - 0.5;
                let (fx, fy) = (floor(px), floor(py));
                let (w1x, w1y) = (px - fx, py - fy);
                let (w0x, w0y) = (1.0 - w1x, 1.0 - w1y);
                let (ix, iy) = (fx as i64, fy as i64);
                let x0 = self.wrap.wrap(ix, w);
                let x1 = self.wrap.wrap(ix + 1, w);
                let y0 = self.wrap.wrap(iy, h);
                let y1 = self.wrap.wrap(iy + 1, h);
                // Same accumulation order as Dr.Jit's texture lookup.
                self.texel(x0, y0) * (w0x * w0y)
                    + self.texel(x1, y0) * (w1x * w0y)
                    + self.texel(x0, y1) * (w0x * w1y)
                    + self.texel(x1, y1) * (w1x * w1y)
            }
        }
    }
}

impl Texture for Bitmap {
    fn eval(&self, sp: &ShadingPoint) -> Rgb {
        self.lookup(sp.uv)
    }

    fn resolution(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Luminance of the interpolated colour (the value itself for 1-channel data).
    fn eval_1(&self, sp: &ShadingPoint) -> f32 {
        let c = self.lookup(sp.uv);
        if self.channels == 1 {
            c.r()
        } else {
            c.luminance()
        }
    }

    /// Per-channel average of the linear data (its luminance is Mitsuba's `mean()`).
    fn mean(&self) -> Rgb {
        *self.mean.get_or_init(|| self.compute_mean())
    }

    fn eval_1_grad(&self, sp: &ShadingPoint) -> Option<Vec2> {
        Some(self.gradient(sp.uv))
    }

    fn channels(&self) -> usize {
        self.channels
    }
}

impl Bitmap {
    /// The scalar value (luminance, or the value of 1-channel data) of texel (x, y).
    #[inline]
    fn texel_1(&self, x: usize, y: usize) -> f32 {
        let c = self.texel(x, y);
        if self.channels == 1 {
            c.r()
        } else {
            c.luminance()
        }
    }

    /// Mitsuba's `eval_1_grad`: the exact derivative in (u, v) of the bilinear interpolant of
    /// the texels' scalar values (zero with nearest filtering). As in Mitsuba 3.9.1 the pixel
    /// gradient is mapped through the transposed linear part of `to_uv` and *then* scaled by
    /// the resolution (the same as the chain rule for square images and axis-aligned maps).
    pub fn gradient(&self, uv: Vec2) -> Vec2 {
        if self.filter == FilterType::Nearest {
            return Vec2::ZERO;
        }
        let uv = apply_uv(&self.to_uv, uv);
        let (w, h) = (self.width as i64, self.height as i64);
        let px = uv.x * to_f32(self.width) - 0.5;
        let py = uv.y * to_f32(self.height) - 0.5;
        let (fx, fy) = (floor(px), floor(py));
        let (w1x, w1y) = (px - fx, py - fy);
        let (w0x, w0y) = (1.0 - w1x, 1.0 - w1y);
        let (ix, iy) = (fx as i64, fy as i64);
        let x0 = self.wrap.wrap(ix, w);
        let x1 = self.wrap.wrap(ix + 1, w);
        let y0 = self.wrap.wrap(iy, h);
        let y1 = self.wrap.wrap(iy + 1, h);
        let (f00, f10) = (self.texel_1(x0, y0), self.texel_1(x1, y0));
        let (f01, f11) = (self.texel_1(x0, y1), self.texel_1(x1, y1));
        let dx = w0y * (f10 - f00) + w1y * (f11 - f01);
        let dy = w0x * (f01 - f00) + w1x * (f11 - f10);
        let m = &self.to_uv;
        Vec2::new(
            (m.x_axis.x * dx + m.x_axis.y * dy) * to_f32(self.width),
            (m.y_axis.x * dx + m.y_axis.y * dy) * to_f32(self.height),
        )
    }
}

/// The image files a scene reads (bitmap textures, environment maps), resolved as the loader
/// resolves them, for [`crate::image_io::prefetch`]; `base` is the scene file's folder.
pub fn scene_images(root: &Node, base: &Path) -> Vec<std::path::PathBuf> {
    fn walk(n: &Node, base: &Path, out: &mut Vec<std::path::PathBuf>) {
        let file = n.props.iter().find_map(|p| match (&p.name[..], &p.value) {
            ("filename", PropValue::Str(f)) => Some(Path::new(f)),
            _ => None,
        });
        if let Some(f) = file {
            match (n.tag.as_str(), n.plugin_type.as_str()) {
                ("texture", "bitmap") if f.is_relative() => {
                    // as the scene's resolve_from: the declaring file's folder, then `base`
                    let near = Path::new(&n.loc.file).parent().map(|d| d.join(f));
                    out.push(near.filter(|p| p.exists()).unwrap_or_else(|| base.join(f)));
                }
                ("emitter", "envmap") => out.push(base.join(f)),
                ("texture", "bitmap") => out.push(f.to_path_buf()),
                _ => {}
            }
        }
        for c in &n.children {
            walk(c, base, out);
        }
    }
    let mut out = vec![];
    walk(root, base, &mut out);
    out
}

/// Mitsuba's `mesh_attribute`: a vertex or face attribute of the mesh that was hit (`name` =
/// `vertex_…` or `face_…`, e.g. `vertex_color` from a PLY file's `r g b` properties), times
/// `scale` (default 1). Vertex attributes are interpolated with the hit's barycentrics. The
/// scene loader checks that every shape a material with this texture is attached to has the
/// attribute with 1 or 3 channels (Mitsuba fails at render time). Deviations: `eval_1` of a
/// 3-channel attribute is its luminance (Mitsuba refuses it); the `mean` (used only to balance
/// lobe sampling) is `scale`·0.5, as the texture has no data of its own.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttributeTexture {
    pub name: String,
    pub scale: f32,
}

impl Texture for MeshAttributeTexture {
    #[inline]
    fn eval(&self, sp: &ShadingPoint) -> Rgb {
        match sp.surface {
            Some(s) => s
                .attribute(&self.name, sp.prim, sp.bary)
                .map_or(Rgb::ZERO, |v| v * self.scale),
            None => Rgb::ZERO,
        }
    }

    fn mean(&self) -> Rgb {
        Rgb::splat(0.5 * self.scale)
    }

    fn mesh_attribute(&self) -> Option<&str> {
        Some(&self.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_path() -> Option<std::path::PathBuf> {
        specula_testdata::shared("scenes/assets/grid.png")
    }

    fn sp(u: f32, v: f32) -> ShadingPoint<'static> {
        ShadingPoint::at_uv(u, v)
    }

    fn close(a: Rgb, b: [f32; 3], tol: f32) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() <= tol * b[i].abs().max(1e-3))
    }

    /// A 3-column, 2-row linear bitmap from row-major values.
    fn small(vals: &[f32], channels: usize, filter: FilterType, wrap: WrapMode, m: Mat4) -> Bitmap {
        let img = Image {
            width: 3,
            height: 2,
            channels,
            data: vals.to_vec(),
        };
        Bitmap::from_image(&img, false, filter, wrap, true, uv_transform(&m))
    }

    #[test]
    fn bitmap_gradient_matches_mitsuba() {
        // Mitsuba 3.9.1 scalar_rgb: a 2×3 `bitmap` (raw) of these RGB values, eval_1_grad(si)
        let rgb = [
            0.1, 0.5, 0.9, 0.3, 0.2, 0.7, 0.8, 0.8, 0.1, 0.0, 0.4, 0.6, 0.5, 0.5, 0.5, 0.2, 0.9,
            0.3,
        ];
        type Case = (WrapMode, (f32, f32), (f32, f32));
        let cases: [Case; 9] = [
            (WrapMode::Repeat, (0.5, 0.5), (1.04994, 0.485297)),
            (WrapMode::Repeat, (0.1, 0.2), (-0.938882, 0.199755)),
            (WrapMode::Repeat, (0.95, 0.9), (-1.06989, 0.134252)),
            (WrapMode::Repeat, (0.4, 0.74), (0.490479, 0.271048)),
            (WrapMode::Repeat, (1.3, -0.2), (0.404779, -0.0567981)),
            (WrapMode::Clamp, (0.1, 0.2), (0.0, 0.0)),
            (WrapMode::Clamp, (0.4, 0.74), (0.490479, 0.271048)),
            (WrapMode::Mirror, (1.3, -0.2), (-1.47639, 0.0)),
            (WrapMode::Mirror, (0.95, 0.9), (0.0, 0.0)),
        ];
        for (wrap, (u, v), (gu, gv)) in cases {
            let t = small(&rgb, 3, FilterType::Bilinear, wrap, Mat4::IDENTITY);
            let g = t.eval_1_grad(&sp(u, v)).unwrap();
            assert!(
                (g - Vec2::new(gu, gv)).abs().max_element() < 1e-4,
                "{wrap:?} ({u}, {v}): {g}, Mitsuba ({gu}, {gv})"
            );
            // nearest filtering: piecewise constant
            let n = small(&rgb, 3, FilterType::Nearest, wrap, Mat4::IDENTITY);
            assert_eq!(n.eval_1_grad(&sp(u, v)), Some(Vec2::ZERO));
        }
        // to_uv = scale(2, 3, 1)·rotate(z, 30°): Mitsuba (−2.23804, 0.139777) at (0.3, 0.4)
        let m =
            Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0)) * Mat4::from_rotation_z(30f32.to_radians());
        let g =
            small(&rgb, 3, FilterType::Bilinear, WrapMode::Repeat, m).gradient(Vec2::new(0.3, 0.4));
        assert!(
            (g - Vec2::new(-2.23804, 0.139777)).abs().max_element() < 1e-4,
            "{g}"
        );
        // one channel: Mitsuba (0.75, 0) at (0.3, 0.4)
        let grey = [0.1, 0.5, 0.9, 0.3, 0.2, 0.7];
        let t = small(
            &grey,
            1,
            FilterType::Bilinear,
            WrapMode::Repeat,
            Mat4::IDENTITY,
        );
        assert!(
            (t.gradient(Vec2::new(0.3, 0.4)) - Vec2::new(0.75, 0.0))
                .abs()
                .max_element()
                < 1e-5
        );
        assert_eq!(t.channels(), 1);
        // the gradient is the derivative of eval_1 (central differences away from texel rows)
        let t = small(
            &rgb,
            3,
            FilterType::Bilinear,
            WrapMode::Repeat,
            Mat4::IDENTITY,
        );
        let (u, v, h) = (0.42f32, 0.61f32, 1e-3f32);
        let du = (t.eval_1(&sp(u + h, v)) - t.eval_1(&sp(u - h, v))) / (2.0 * h);
        let dv = (t.eval_1(&sp(u, v + h)) - t.eval_1(&sp(u, v - h))) / (2.0 * h);
        let g = t.gradient(Vec2::new(u, v));
        assert!(
            (g - Vec2::new(du, dv)).abs().max_element() < 2e-3,
            "{g} vs ({du}, {dv})"
        );
    }

    #[derive(Debug)]
    struct Attrs;
    impl specula_bsdf::SurfaceData for Attrs {
        fn attribute(&self, name: &str, prim: u32, bary: Vec2) -> Option<Rgb> {
            (name == "vertex_color").then(|| Rgb::new(prim as f32, bary.x, bary.y))
        }
    }

    #[test]
    fn mesh_attribute_reads_the_shading_point() {
        let t = MeshAttributeTexture {
            name: "vertex_color".into(),
            scale: 2.0,
        };
        assert_eq!(t.mesh_attribute(), Some("vertex_color"));
        let mut p = ShadingPoint::at_uv(0.1, 0.2);
        assert_eq!(t.eval(&p), Rgb::ZERO); // no surface data
        p.surface = Some(&Attrs);
        p.prim = 3;
        p.bary = Vec2::new(0.25, 0.5);
        assert_eq!(t.eval(&p), Rgb::new(6.0, 0.5, 1.0));
        let other = MeshAttributeTexture {
            name: "face_color".into(),
            scale: 1.0,
        };
        assert_eq!(other.eval(&p), Rgb::ZERO);
    }

    #[test]
    fn checkerboard_matches_mitsuba() {
        let t = Checkerboard::default();
        // Mitsuba 3.9.1, default checkerboard: eval at uv.
        let cases = [
            ((0.25, 0.25), 0.4),
            ((0.75, 0.25), 0.2),
            ((0.25, 0.75), 0.2),
            ((0.75, 0.75), 0.4),
            ((0.5, 0.5), 0.4),
            ((0.49, 0.51), 0.2),
            ((-0.25, 0.25), 0.2),
            ((1.25, 0.25), 0.4),
            ((0.0, 0.0), 0.4),
        ];
        for ((u, v), want) in cases {
            assert_eq!(t.eval(&sp(u, v)), Rgb::splat(want), "({u}, {v})");
            // Mitsuba 3.9.1's eval_1 returns the other colour.
            assert!(
                (t.eval_1(&sp(u, v)) - (0.6 - want)).abs() < 1e-6,
                "({u}, {v})"
            );
        }
        assert_eq!(t.mean(), Rgb::splat(0.3));
        // The scenes' floor: colours 0.45 / 0.15 with to_uv = scale(8, 8).
        let t = Checkerboard::new(
            Rgb::splat(0.45),
            Rgb::splat(0.15),
            Mat4::from_scale(Vec3::new(8.0, 8.0, 1.0)),
        );
        assert_eq!(t.eval(&sp(0.05, 0.05)), Rgb::splat(0.45));
        assert_eq!(t.eval(&sp(0.1, 0.05)), Rgb::splat(0.15));
        assert_eq!(t.eval(&sp(0.01, 0.07)), Rgb::splat(0.15));
        // RGB colour: eval_1 uses the channel mean (Mitsuba: 0.5 for (0.9, 0.5, 0.1)).
        let t = Checkerboard::new(Rgb::new(0.9, 0.5, 0.1), Rgb::splat(0.05), Mat4::IDENTITY);
        assert_eq!(t.eval(&sp(0.25, 0.25)), Rgb::new(0.9, 0.5, 0.1));
        assert!((t.eval_1(&sp(0.75, 0.25)) - 0.5).abs() < 1e-6);
        assert!((t.eval_1(&sp(0.25, 0.25)) - 0.05).abs() < 1e-6);
        assert!((t.mean().mean() - 0.275).abs() < 1e-6);
    }

    #[test]
    fn to_uv_keeps_xy_affine_part() {
        // Mitsuba 3.9.1: translate(0.1, 0.2, 0.7)·rotate(z, 30°) becomes
        // [[0.866, -0.5, 0.1], [0.5, 0.866, 0.2], [0, 0, 1]].
        let m = Mat4::from_translation(Vec3::new(0.1, 0.2, 0.7))
            * Mat4::from_rotation_z(30f32.to_radians());
        let t = uv_transform(&m);
        let p = t.transform_point2(Vec2::new(0.3, 0.7));
        let (c, s) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
        assert!((p - Vec2::new(c * 0.3 - s * 0.7 + 0.1, s * 0.3 + c * 0.7 + 0.2)).length() < 1e-6);
        // Mitsuba's results for this checkerboard at four points.
        let cb = Checkerboard::new(Rgb::splat(0.4), Rgb::splat(0.2), m);
        for ((u, v), want) in [
            ((0.3, 0.7), 0.2),
            ((0.9, 0.1), 0.4),
            ((0.45, 0.52), 0.2),
            ((0.2, 0.9), 0.2),
        ] {
            assert_eq!(cb.eval(&sp(u, v)), Rgb::splat(want));
        }
    }

    #[test]
    fn bitmap_matches_mitsuba_on_grid_png() {
        let Some(path) = grid_path() else { return };
        let load =
            |f: &str, w: &str, raw: bool, m: Mat4| Bitmap::load(&path, f, w, raw, m).unwrap();
        let t = load("bilinear", "repeat", false, Mat4::IDENTITY);
        assert_eq!((t.width, t.height, t.channels), (256, 256, 3));
        // Reference values: Mitsuba 3.9.1 scalar_rgb, `bitmap` of grid.png, tex.eval(si) and
        // tex.eval_1(si) at si.uv. Texel (x, y) of the file sits at ((x+½)/256, (y+½)/256):
        // (5, 7) holds bytes (4, 6, 60), (100, 37) holds (99, 36, 60).
        let cases: [((f32, f32), [f32; 3], f32); 9] = [
            (
                (0.5 / 256.0, 0.5 / 256.0),
                [0.871367, 0.871367, 0.871367],
                0.871367,
            ),
            (
                (5.5 / 256.0, 7.5 / 256.0),
                [0.00121411, 0.00182116, 0.0451862],
                0.00482167,
            ),
            (
                (100.5 / 256.0, 37.5 / 256.0),
                [0.124772, 0.017642, 0.0451862],
                0.0424132,
            ),
            (
                (200.5 / 256.0, 3.5 / 256.0),
                [0.571125, 0.000607054, 0.0451862],
                0.125157,
            ),
            ((0.3, 0.7), [0.0709337, 0.443538, 0.0451862], 0.335547),
            ((0.01, 0.99), [0.000321739, 0.97292, 0.0451862], 0.699123),
            ((0.123, 0.456), [0.0129747, 0.172198, 0.0451862], 0.129169),
            ((1.3, -0.2), [0.0709336, 0.59919, 0.0451862], 0.446863),
            ((0.0, 0.0), [0.901301, 0.901301, 0.664822], 0.884234),
        ];
        for ((u, v), rgb, lum) in cases {
            let c = t.eval(&sp(u, v));
            assert!(close(c, rgb, 2e-5), "({u}, {v}): {c:?} vs {rgb:?}");
            assert!((t.eval_1(&sp(u, v)) - lum).abs() < 2e-5 * lum.max(1e-3));
        }
        // Mitsuba's mean() (a luminance) is 0.361856; it sums in f32, the exact mean is
        // 0.3618645.
        assert!((t.mean().luminance() - 0.361_864_5).abs() < 1e-6);
        assert!((t.mean().luminance() - 0.361856).abs() < 1e-4);

        let t = load("nearest", "repeat", false, Mat4::IDENTITY);
        for ((u, v), rgb) in [
            ((0.3, 0.7), [0.0703601, 0.445201, 0.0451862]),
            ((0.01, 0.99), [0.000303527, 0.973445, 0.0451862]),
            ((0.0, 0.0), [0.871367, 0.871367, 0.871367]),
            ((-0.001, 1.001), [0.871367, 0.871367, 0.871367]),
        ] {
            assert!(close(t.eval(&sp(u, v)), rgb, 2e-5), "nearest ({u}, {v})");
        }

        type Case = ((f32, f32), [f32; 3]);
        let wrap_cases: [(&str, [Case; 4]); 3] = [
            (
                "mirror",
                [
                    ((1.3, -0.2), [0.443538, 0.0315412, 0.0451862]),
                    ((-0.001, 1.001), [0.871367, 0.871367, 0.871367]),
                    ((2.7, 3.4), [0.443538, 0.314444, 0.0451862]),
                    ((-1.3, -0.6), [0.443538, 0.314445, 0.0451862]),
                ],
            ),
            (
                "clamp",
                [
                    ((1.3, -0.2), [0.871367, 0.871367, 0.871367]),
                    ((-0.001, 1.001), [0.871367, 0.871367, 0.871367]),
                    ((2.7, 3.4), [0.991102, 0.991102, 0.0451862]),
                    ((-1.3, -0.6), [0.871367, 0.871367, 0.871367]),
                ],
            ),
            (
                "repeat",
                [
                    ((1.3, -0.2), [0.0709336, 0.59919, 0.0451862]),
                    ((-0.001, 1.001), [0.893453, 0.893453, 0.718974]),
                    ((2.7, 3.4), [0.443538, 0.129867, 0.0451862]),
                    ((-1.3, -0.6), [0.443538, 0.129867, 0.0451862]),
                ],
            ),
        ];
        for (mode, cases) in wrap_cases {
            let t = load("bilinear", mode, false, Mat4::IDENTITY);
            for ((u, v), rgb) in cases {
                let c = t.eval(&sp(u, v));
                assert!(close(c, rgb, 1e-4), "{mode} ({u}, {v}): {c:?} vs {rgb:?}");
            }
        }

        // raw = true: no linearisation (Mitsuba: mean 0.536655, f32 sum; exact 0.5366335).
        let t = load("bilinear", "repeat", true, Mat4::IDENTITY);
        assert!(close(
            t.eval(&sp(0.3, 0.7)),
            [0.295294, 0.696863, 0.235294],
            2e-5
        ));
        assert!((t.eval_1(&sp(0.123, 0.456)) - 0.365176).abs() < 1e-5);
        assert!((t.mean().luminance() - 0.536_633_5).abs() < 1e-6);

        // to_uv = scale(2, 3)·translate(0.1, 0.2): Mitsuba gives the plain lookup at
        // ((u + 0.1)·2, (v + 0.2)·3).
        let m = Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0))
            * Mat4::from_translation(Vec3::new(0.1, 0.2, 0.0));
        let t = load("bilinear", "repeat", false, m);
        assert!(close(
            t.eval(&sp(0.3, 0.7)),
            [0.59919, 0.443538, 0.0451862],
            1e-4
        ));
        assert!(close(
            t.eval(&sp(0.123, 0.456)),
            [0.164127, 0.924209, 0.0451862],
            1e-4
        ));
    }

    /// The histograms counted in parallel parts equal one sequential count (images larger
    /// than a part, and a part boundary inside the data).
    #[test]
    fn parallel_byte_histograms_are_exact() {
        let mut seed = 11u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 24) as u8
        };
        for channels in [1usize, 3] {
            let n = channels * ((1 << 19) + 12_345);
            let data: Vec<u8> = (0..n).map(|_| next()).collect();
            let mut want = vec![[0u64; 256]; channels];
            for (i, &b) in data.iter().enumerate() {
                want[i % channels][b as usize] += 1;
            }
            assert_eq!(byte_histograms(&data, channels), want, "{channels}");
        }
    }

    /// 8-bit images keep their bytes: every lookup, gradient and mean equals that of the
    /// same image converted to f32 up front (the way Bitmap::from_image stores it).
    #[test]
    fn byte_texels_equal_float_texels() {
        let mut seed = 7u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 24) as u8
        };
        // (width, height, stored channels): RGBA, grey+alpha, grey, RGB; a single row and a
        // single column are doubled
        for (w, h, c) in [(5, 3, 4), (4, 4, 2), (3, 1, 1), (1, 4, 3), (7, 5, 3)] {
            let bytes: Vec<u8> = (0..w * h * c).map(|_| next()).collect();
            for srgb in [true, false] {
                for raw in [true, false] {
                    let r = RawImage {
                        width: w,
                        height: h,
                        channels: c,
                        pixels: Pixels::U8(bytes.clone()),
                        srgb,
                    };
                    let f = r.clone().into_image();
                    let m = uv_transform(&Mat4::from_rotation_z(0.3));
                    for filter in [FilterType::Bilinear, FilterType::Nearest] {
                        let a = Bitmap::from_raw(r.clone(), filter, WrapMode::Mirror, raw, m);
                        let b = Bitmap::from_image(&f, srgb, filter, WrapMode::Mirror, raw, m);
                        assert!(matches!(a.texels, Texels::U8(..)));
                        assert_eq!(
                            (a.width, a.height, a.channels),
                            (b.width, b.height, b.channels)
                        );
                        assert_eq!(a.mean(), b.mean(), "{w}×{h}×{c}");
                        for i in 0..50 {
                            let uv = Vec2::new(i as f32 * 0.071 - 0.9, i as f32 * 0.043 - 0.4);
                            assert_eq!(a.lookup(uv), b.lookup(uv), "{w}×{h}×{c} {uv}");
                            assert_eq!(a.gradient(uv), b.gradient(uv), "{w}×{h}×{c} {uv}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn linearisation_happens_before_interpolation() {
        // Two texels, sRGB bytes 0 and 255: the midpoint is the mean of the linear values (0.5),
        // not the linearised mean of the codes (≈ 0.214).
        let img = Image {
            width: 2,
            height: 2,
            channels: 1,
            data: vec![0.0, 1.0, 0.0, 1.0],
        };
        let t = Bitmap::from_image(
            &img,
            true,
            FilterType::Bilinear,
            WrapMode::Clamp,
            false,
            Mat3::IDENTITY,
        );
        assert!((t.eval_1(&sp(0.5, 0.5)) - 0.5).abs() < 1e-6);
        assert_eq!(t.eval(&sp(0.5, 0.5)), Rgb::splat(0.5));
        assert_eq!(t.mean(), Rgb::splat(0.5));
        // A single texel is a constant texture.
        let img = Image {
            width: 1,
            height: 1,
            channels: 4,
            data: vec![0.25, 0.5, 0.75, 0.1],
        };
        let t = Bitmap::from_image(
            &img,
            false,
            FilterType::Bilinear,
            WrapMode::Repeat,
            false,
            Mat3::IDENTITY,
        );
        assert!(close(t.eval(&sp(0.37, 0.81)), [0.25, 0.5, 0.75], 1e-6));
        assert_eq!(t.channels, 3);
    }

    #[test]
    fn bad_parameters_are_reported() {
        let Some(path) = grid_path() else { return };
        let e = Bitmap::load(&path, "cubic", "repeat", false, Mat4::IDENTITY).unwrap_err();
        assert!(e.to_string().contains("filter_type"));
        let e = Bitmap::load(&path, "bilinear", "wrap", false, Mat4::IDENTITY).unwrap_err();
        assert!(e.to_string().contains("wrap_mode"));
        let e = Bitmap::load(
            Path::new("/nonexistent/tex.png"),
            "bilinear",
            "repeat",
            false,
            Mat4::IDENTITY,
        )
        .unwrap_err();
        assert!(e.to_string().contains("tex.png"));
    }
}
