//! Reading and writing images: PNG and JPEG (8/16-bit, grey/RGB/RGBA), OpenEXR (half/float,
//! RGB\[A\] or Y) and Radiance HDR in; float32 RGB OpenEXR (like Mitsuba's `hdrfilm`) and 8-bit
//! sRGB PNG out.
//!
//! Limits: an image read has at most [`MAX_IMAGE_PIXELS`] pixels (16384 × 8192, the largest
//! common environment maps); the size is checked from the header, before any pixel storage
//! is allocated, and a larger image is refused with an error naming its size and the limit.

use crate::core::{Result, SceneError};
use std::path::Path;

/// A decoded image: `channels` interleaved `f32` values per pixel, row-major, top row first.
///
/// Integer formats are scaled to [0, 1] and left in their stored encoding (sRGB-encoded for
/// PNG/JPEG; see [`read_image`]); floating-point formats hold linear values.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: usize,
    pub height: usize,
    /// 1 (grey), 3 (RGB) or 4 (RGBA).
    pub channels: usize,
    pub data: Vec<f32>,
}

impl Image {
    /// Value of channel `c` of pixel (x, y).
    #[inline]
    pub fn get(&self, x: usize, y: usize, c: usize) -> f32 {
        self.data[(y * self.width + x) * self.channels + c]
    }

    /// Pixel (x, y) as RGB: grey is replicated, alpha is dropped.
    #[inline]
    pub fn rgb(&self, x: usize, y: usize) -> [f32; 3] {
        let i = (y * self.width + x) * self.channels;
        if self.channels < 3 {
            let v = self.data[i];
            [v, v, v]
        } else {
            [self.data[i], self.data[i + 1], self.data[i + 2]]
        }
    }
}

/// Decoded pixel values as stored: 8-bit images keep their bytes (4× less memory and no
/// conversion pass; [`SRGB8_TO_LINEAR`]/[`UNORM8`] give their values), others are `f32`.
#[derive(Clone, Debug, PartialEq)]
pub enum Pixels {
    U8(Vec<u8>),
    F32(Vec<f32>),
}

/// A decoded image before conversion: `channels` (1 … 4) interleaved values per pixel,
/// row-major, top row first; `srgb` as [`read_image`] returns it. Grey+alpha keeps its alpha
/// here (2 channels).
#[derive(Clone, Debug, PartialEq)]
pub struct RawImage {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub pixels: Pixels,
    pub srgb: bool,
}

impl RawImage {
    /// As an [`Image`] of `f32` values (grey+alpha loses its alpha): what [`read_image`]
    /// returns.
    pub fn into_image(self) -> Image {
        let (width, height) = (self.width, self.height);
        let (channels, data) = match self.pixels {
            Pixels::U8(v) => {
                let t = unorm8();
                if self.channels == 2 {
                    (1, v.iter().step_by(2).map(|&b| t[b as usize]).collect())
                } else {
                    (self.channels, v.iter().map(|&b| t[b as usize]).collect())
                }
            }
            Pixels::F32(v) if self.channels == 2 => (1, v.iter().step_by(2).copied().collect()),
            Pixels::F32(v) => (self.channels, v),
        };
        Image {
            width,
            height,
            channels,
            data,
        }
    }
}

/// `k / 255` for every byte `k`: the value of an 8-bit texel.
pub fn unorm8() -> &'static [f32; 256] {
    static T: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    T.get_or_init(|| std::array::from_fn(|k| k as f32 / 255.0))
}

/// The linear value of every 8-bit sRGB-encoded byte `k`: [`srgb_to_linear`]`(k / 255)`.
pub fn srgb8_to_linear() -> &'static [f32; 256] {
    static T: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    T.get_or_init(|| std::array::from_fn(|k| srgb_formula(k as f32 / 255.0)))
}

/// The sRGB transfer curve, decoding: encoded value in [0, 1] → linear.
#[inline]
pub fn srgb_to_linear(v: f32) -> f32 {
    // 8-bit images (v = k/255 as decoded) through a table of the same formula: decoding a
    // texture spent most of its time in `pow`
    struct Tables {
        encoded: [f32; 256],
        linear: [f32; 256],
    }
    static TABLES: std::sync::OnceLock<Tables> = std::sync::OnceLock::new();
    let t = TABLES.get_or_init(|| Tables {
        encoded: std::array::from_fn(|k| k as f32 / 255.0),
        linear: std::array::from_fn(|k| srgb_formula(k as f32 / 255.0)),
    });
    // (a saturating cast: negative and NaN values give 0, which the comparison rejects)
    let k = (v * 255.0 + 0.5) as usize;
    if k < 256 && t.encoded[k] == v {
        return t.linear[k];
    }
    srgb_formula(v)
}

#[inline]
fn srgb_formula(v: f32) -> f32 {
    let v = v as f64;
    let l = if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    };
    l as f32
}

/// The sRGB transfer curve, encoding: linear → encoded value (not clamped).
#[inline]
pub fn linear_to_srgb(v: f32) -> f32 {
    let v = v as f64;
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    e as f32
}

/// The most pixels an image read from a file may have (16384 × 8192).
pub const MAX_IMAGE_PIXELS: usize = 1 << 27;

fn check_image_size(width: usize, height: usize) -> std::result::Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("the image is empty ({width}×{height})"));
    }
    match width.checked_mul(height) {
        Some(n) if n <= MAX_IMAGE_PIXELS => Ok(()),
        _ => Err(format!(
            "the image is {width}×{height} pixels: at most {MAX_IMAGE_PIXELS} pixels \
             (16384×8192) are supported"
        )),
    }
}

/// Reads an image. Returns it with `true` when its values are sRGB-encoded (8- or 16-bit
/// PNG/JPEG: what Mitsuba linearises unless told `raw`), `false` when they are linear
/// (OpenEXR, Radiance HDR). Grey+alpha images keep only the grey channel.
pub fn read_image(path: &Path) -> Result<(Image, bool)> {
    let raw = read_image_raw(path)?;
    let srgb = raw.srgb;
    Ok((raw.into_image(), srgb))
}

/// [`read_image`] without the conversion to `f32`: 8-bit data stays bytes.
pub fn read_image_raw(path: &Path) -> Result<RawImage> {
    let bytes = std::fs::read(path)
        .map_err(|e| SceneError::file(path, format!("cannot open image: {e}")))?;
    decode_image_raw(&bytes).map_err(|m| SceneError::file(path, m))
}

/// [`read_image_raw`], taking the image from the current [`prefetch`] when it holds it
/// (waiting for its decoding to finish, or decoding it here if it has not started).
pub fn read_image_raw_prefetched(path: &Path) -> Result<RawImage> {
    let slot = PREFETCH.with(|c| c.borrow().as_ref().and_then(|m| m.get(path).cloned()));
    match slot {
        Some(slot) => slot.take(path),
        None => read_image_raw(path),
    }
}

/// Images decoded ahead of their use, on the thread pool, while the scene loader does other
/// work (meshes, BSDF tables, the BVH): the scene's image files are independent, so on several
/// cores they decode at the same time. Each file is decoded once; the loader takes it with
/// [`read_image_raw_prefetched`] (a file used twice is decoded again the second time). A
/// decoding that has not started when its image is needed is done by the loader itself, so
/// waiting never depends on a busy pool. The prefetch belongs to the thread that started it
/// and lasts as long as the returned guard; unfinished decodings are dropped with it.
pub fn prefetch(paths: impl IntoIterator<Item = std::path::PathBuf>) -> PrefetchGuard {
    let mut map = std::collections::HashMap::new();
    for path in paths {
        if map.contains_key(&path) || !path.is_file() {
            continue;
        }
        let slot = std::sync::Arc::new(Slot {
            state: std::sync::Mutex::new(SlotState::Pending),
            done: std::sync::Condvar::new(),
        });
        let (job, p) = (slot.clone(), path.clone());
        rayon::spawn(move || job.run(&p));
        map.insert(path, slot);
    }
    let outer = PREFETCH.with(|c| c.replace(Some(map)));
    PrefetchGuard { outer }
}

/// Ends a [`prefetch`] when dropped.
pub struct PrefetchGuard {
    outer: Option<PrefetchMap>,
}

impl Drop for PrefetchGuard {
    fn drop(&mut self) {
        let map = PREFETCH.with(|c| c.replace(self.outer.take()));
        for slot in map.into_iter().flat_map(|m| m.into_values()) {
            let mut s = slot.lock();
            if !matches!(*s, SlotState::Running) {
                *s = SlotState::Gone;
            }
        }
    }
}

type PrefetchMap = std::collections::HashMap<std::path::PathBuf, std::sync::Arc<Slot>>;

thread_local! {
    static PREFETCH: std::cell::RefCell<Option<PrefetchMap>> = const { std::cell::RefCell::new(None) };
}

enum SlotState {
    Pending,
    Running,
    Done(Result<RawImage>),
    /// Taken, claimed by the loader, or abandoned.
    Gone,
}

struct Slot {
    state: std::sync::Mutex<SlotState>,
    done: std::sync::Condvar,
}

impl Slot {
    fn lock(&self) -> std::sync::MutexGuard<'_, SlotState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The pool's job: decodes unless the loader claimed the image first.
    fn run(&self, path: &Path) {
        {
            let mut s = self.lock();
            if !matches!(*s, SlotState::Pending) {
                return;
            }
            *s = SlotState::Running;
        }
        let r = read_image_raw(path);
        let mut s = self.lock();
        *s = SlotState::Done(r);
        self.done.notify_all();
    }

    fn take(&self, path: &Path) -> Result<RawImage> {
        let mut s = self.lock();
        loop {
            match std::mem::replace(&mut *s, SlotState::Gone) {
                SlotState::Done(r) => return r,
                SlotState::Running => {
                    *s = SlotState::Running;
                    s = self.done.wait(s).unwrap_or_else(|e| e.into_inner());
                }
                // not started (claimed now: the job will skip it), or already taken
                SlotState::Pending | SlotState::Gone => {
                    drop(s);
                    return read_image_raw(path);
                }
            }
        }
    }
}

/// [`read_image`] on the bytes of a file; the error says what is wrong (the caller names the
/// file).
pub fn decode_image(bytes: &[u8]) -> std::result::Result<(Image, bool), String> {
    let raw = decode_image_raw(bytes)?;
    let srgb = raw.srgb;
    Ok((raw.into_image(), srgb))
}

/// [`read_image_raw`] on the bytes of a file.
pub fn decode_image_raw(bytes: &[u8]) -> std::result::Result<RawImage, String> {
    if bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        let img = read_exr(bytes)?;
        return Ok(RawImage {
            width: img.width,
            height: img.height,
            channels: img.channels,
            pixels: Pixels::F32(img.data),
            srgb: false,
        });
    }
    if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return read_jpeg(bytes);
    }
    read_with_image_crate(bytes)
}

/// A JPEG decoded by zune-jpeg directly, as the `image` crate decodes it (the same decoder
/// and options: not strict, RGB, RGBA, grey and grey+alpha kept, other colour spaces
/// converted to RGB), without the crate's copy of the file and its header pass.
fn read_jpeg(bytes: &[u8]) -> std::result::Result<RawImage, String> {
    use zune_core::bytestream::ZCursor;
    use zune_core::colorspace::ColorSpace;
    use zune_core::options::DecoderOptions;
    let err = |e: zune_jpeg::errors::DecodeErrors| format!("cannot read JPEG image: {e}");
    let options = DecoderOptions::default()
        .set_strict_mode(false)
        .set_max_width(usize::MAX)
        .set_max_height(usize::MAX);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder.decode_headers().map_err(err)?;
    let (Some((width, height)), Some(input)) = (decoder.dimensions(), decoder.input_colorspace())
    else {
        return Err("cannot read JPEG image: no frame header".into());
    };
    // the size from the header, checked before the pixels are allocated
    check_image_size(width, height)?;
    let out = match input {
        ColorSpace::RGB | ColorSpace::RGBA | ColorSpace::Luma | ColorSpace::LumaA => input,
        _ => ColorSpace::RGB,
    };
    decoder.set_options(decoder.options().jpeg_set_out_colorspace(out));
    let pixels = decoder.decode().map_err(err)?;
    let channels = out.num_components();
    if pixels.len() != width * height * channels {
        return Err(format!(
            "cannot read JPEG image: {} bytes decoded for {width}×{height}×{channels}",
            pixels.len()
        ));
    }
    Ok(RawImage {
        width,
        height,
        channels,
        pixels: Pixels::U8(pixels),
        srgb: true,
    })
}

fn read_exr(bytes: &[u8]) -> std::result::Result<Image, String> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let err = |e: exr::error::Error| format!("cannot read OpenEXR image: {e}");
    // the header first: the sizes it declares are checked before the decoder allocates
    let meta =
        exr::meta::MetaData::read_from_buffered(std::io::Cursor::new(bytes), false).map_err(err)?;
    for h in meta.headers.iter() {
        check_image_size(h.layer_size.width(), h.layer_size.height())?;
    }
    let img = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(err)?;
    let layer = &img.layer_data;
    let (width, height) = (layer.size.x(), layer.size.y());
    let find = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .map(|c| &c.sample_data)
    };
    let planes = match (find("R"), find("G"), find("B"), find("Y")) {
        (Some(r), Some(g), Some(b), _) => match find("A") {
            Some(a) => vec![r, g, b, a],
            None => vec![r, g, b],
        },
        (_, _, _, Some(y)) => vec![y],
        _ => {
            let names: Vec<String> = layer
                .channel_data
                .list
                .iter()
                .map(|c| c.name.to_string())
                .collect();
            return Err(format!(
                "OpenEXR image has neither R, G, B nor Y channels (found: {})",
                names.join(", ")
            ));
        }
    };
    let channels = planes.len();
    let n = width * height;
    if planes.iter().any(|p| p.len() != n) {
        return Err("OpenEXR channel sizes disagree".into());
    }
    // interleaved straight from the decoder's planes (no copy of each plane first)
    let mut data = vec![0.0f32; n * channels];
    for (c, plane) in planes.iter().enumerate() {
        for (d, v) in data[c..]
            .iter_mut()
            .step_by(channels)
            .zip(plane.values_as_f32())
        {
            *d = v;
        }
    }
    Ok(Image {
        width,
        height,
        channels,
        data,
    })
}

fn read_with_image_crate(bytes: &[u8]) -> std::result::Result<RawImage, String> {
    use image::DynamicImage as D;
    use image::ImageDecoder;
    let err = |e: &dyn std::fmt::Display| format!("cannot read image: {e}");
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| err(&e))?;
    let mut limits = image::Limits::default();
    // RGBA f32 at the largest size, plus the decoders' working memory
    limits.max_alloc = Some(MAX_IMAGE_PIXELS as u64 * 16 + (64 << 20));
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| err(&e))?;
    let (w, h) = decoder.dimensions();
    check_image_size(w as usize, h as usize)?;
    let dynimg = D::from_decoder(decoder).map_err(|e| err(&e))?;
    let (width, height) = (dynimg.width() as usize, dynimg.height() as usize);
    let s16 = |v: u16| v as f32 / 65535.0;
    let f16 = |v: &[u16]| Pixels::F32(v.iter().map(|&v| s16(v)).collect());
    let (channels, pixels, srgb) = match dynimg {
        D::ImageLuma8(b) => (1, Pixels::U8(b.into_raw()), true),
        D::ImageLumaA8(b) => (2, Pixels::U8(b.into_raw()), true),
        D::ImageRgb8(b) => (3, Pixels::U8(b.into_raw()), true),
        D::ImageRgba8(b) => (4, Pixels::U8(b.into_raw()), true),
        D::ImageLuma16(b) => (1, f16(b.as_raw()), true),
        D::ImageLumaA16(b) => (2, f16(b.as_raw()), true),
        D::ImageRgb16(b) => (3, f16(b.as_raw()), true),
        D::ImageRgba16(b) => (4, f16(b.as_raw()), true),
        D::ImageRgb32F(b) => (3, Pixels::F32(b.into_raw()), false),
        D::ImageRgba32F(b) => (4, Pixels::F32(b.into_raw()), false),
        // Any other (integer) layout: RGB, still sRGB-encoded.
        other => (3, Pixels::F32(other.to_rgb32f().into_raw()), true),
    };
    Ok(RawImage {
        width,
        height,
        channels,
        pixels,
        srgb,
    })
}

fn check_len(path: &Path, width: usize, height: usize, rgb: &[f32]) -> Result<()> {
    if rgb.len() != width * height * 3 {
        return Err(SceneError::file(
            path,
            format!(
                "image buffer holds {} values, expected {width}×{height}×3",
                rgb.len()
            ),
        ));
    }
    Ok(())
}

/// Writes float32 RGB OpenEXR (the format of Mitsuba's `hdrfilm` output). `rgb` holds
/// `width·height` linear RGB triples, row-major, top row first.
pub fn write_exr(path: &Path, width: usize, height: usize, rgb: &[f32]) -> Result<()> {
    use exr::prelude::*;
    check_len(path, width, height, rgb)?;
    let channels = SpecificChannels::rgb(|Vec2(x, y)| {
        let i = (y * width + x) * 3;
        (rgb[i], rgb[i + 1], rgb[i + 2])
    });
    Image::from_encoded_channels((width, height), exr_encoding(), channels)
        .write()
        .to_file(path)
        .map_err(|e| SceneError::file(path, format!("cannot write OpenEXR image: {e}")))
}

/// The `exr` crate's fast lossless encoding (RLE, 64 × 64 tiles) with the tiles stored in
/// increasing order: its parallel compressor then writes them sorted, so the same image always
/// gives the same file, byte for byte (with the default unspecified order the tiles land in
/// the order their compression finished).
fn exr_encoding() -> exr::prelude::Encoding {
    exr::prelude::Encoding {
        line_order: exr::prelude::LineOrder::Increasing,
        ..exr::prelude::Encoding::FAST_LOSSLESS
    }
}

/// Writes float32 OpenEXR with R, G, B and `extra` channels (name, `width·height` values
/// each), as Mitsuba's `hdrfilm` writes an AOV integrator's output (OpenEXR stores channels
/// sorted by name).
pub fn write_exr_with_channels(
    path: &Path,
    width: usize,
    height: usize,
    rgb: &[f32],
    extra: &[(String, Vec<f32>)],
) -> Result<()> {
    use exr::prelude::*;
    check_len(path, width, height, rgb)?;
    let n = width * height;
    let mut list: Vec<AnyChannel<FlatSamples>> = ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let plane = rgb.iter().skip(c).step_by(3).copied().collect();
            AnyChannel::new(*name, FlatSamples::F32(plane))
        })
        .collect();
    for (name, values) in extra {
        if values.len() != n || ["R", "G", "B"].contains(&name.as_str()) {
            return Err(SceneError::file(
                path,
                format!(
                    "channel '{name}': bad name or {} values for {n} pixels",
                    values.len()
                ),
            ));
        }
        list.push(AnyChannel::new(
            name.as_str(),
            FlatSamples::F32(values.clone()),
        ));
    }
    let channels = AnyChannels::sort(list.into_iter().collect());
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        exr_encoding(),
        channels,
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| SceneError::file(path, format!("cannot write OpenEXR image: {e}")))
}

/// Encodes linear RGB as 8-bit sRGB: the sRGB curve, clamped to [0, 1], rounded (NaN → 0).
#[inline]
pub fn linear_to_srgb8(v: f32) -> u8 {
    let e = linear_to_srgb(v);
    if e.is_nan() {
        0
    } else {
        (e.clamp(0.0, 1.0) * 255.0).round() as u8
    }
}

/// Writes an 8-bit sRGB PNG from linear RGB (`width·height` triples, top row first).
pub fn write_png(path: &Path, width: usize, height: usize, rgb_linear: &[f32]) -> Result<()> {
    check_len(path, width, height, rgb_linear)?;
    let bytes: Vec<u8> = rgb_linear.iter().map(|&v| linear_to_srgb8(v)).collect();
    image::save_buffer_with_format(
        path,
        &bytes,
        width as u32,
        height as u32,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .map_err(|e| SceneError::file(path, format!("cannot write PNG image: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scratch file in the temporary directory, removed when dropped.
    struct TmpFile(std::path::PathBuf);

    impl Drop for TmpFile {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    impl std::ops::Deref for TmpFile {
        type Target = Path;
        fn deref(&self) -> &Path {
            &self.0
        }
    }

    impl AsRef<Path> for TmpFile {
        fn as_ref(&self) -> &Path {
            &self.0
        }
    }

    fn tmp(name: &str) -> TmpFile {
        let file = format!("specula-image-io-{}-{name}", std::process::id());
        TmpFile(std::env::temp_dir().join(file))
    }

    fn ramp(w: usize, h: usize) -> Vec<f32> {
        (0..w * h * 3)
            .map(|i| (i as f32 * 0.37).sin().abs() * 3.0 + 1e-3 * i as f32)
            .collect()
    }

    /// Prefetched images are the images read directly; a broken file gives the same error;
    /// a file used twice, or not prefetched, is read directly; the guard ends the prefetch.
    #[test]
    fn prefetched_images_are_the_files() {
        let (a, b, bad) = (tmp("pa.png"), tmp("pb.exr"), tmp("pbad.png"));
        write_png(&a, 5, 3, &ramp(5, 3)).unwrap();
        write_exr(&b, 4, 2, &ramp(4, 2)).unwrap();
        std::fs::write(&*bad, b"\x89PNG not really").unwrap();
        let direct: Vec<_> = [&a, &b, &bad]
            .iter()
            .map(|p| read_image_raw(p).map_err(|e| e.to_string()))
            .collect();
        {
            let _g = prefetch([a.0.clone(), b.0.clone(), bad.0.clone(), a.0.clone()]);
            for (p, want) in [&a, &b, &bad, &a].iter().zip(direct.iter().cycle()) {
                let got = read_image_raw_prefetched(p).map_err(|e| e.to_string());
                assert_eq!(&got, want, "{}", p.display());
            }
        }
        assert!(PREFETCH.with(|c| c.borrow().is_none()));
        let got = read_image_raw_prefetched(&b).map_err(|e| e.to_string());
        assert_eq!(got, direct[1]);
    }

    #[test]
    fn srgb_curve_round_trip() {
        for i in 0..=255 {
            let e = i as f32 / 255.0;
            let l = srgb_to_linear(e);
            assert!((linear_to_srgb(l) - e).abs() < 1e-6, "{i}");
            assert_eq!(linear_to_srgb8(l), i as u8);
        }
        // The value Mitsuba 3.9.1 produces for an sRGB byte of 240.
        assert!((srgb_to_linear(240.0 / 255.0) - 0.871_367).abs() < 1e-6);
        assert_eq!(linear_to_srgb8(-1.0), 0);
        assert_eq!(linear_to_srgb8(7.0), 255);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
    }

    #[test]
    fn srgb_table_is_the_formula() {
        // 8-bit values (the table) and others (the formula) decode alike
        for i in 0..=255 {
            let e = i as f32 / 255.0;
            assert_eq!(
                srgb_to_linear(e).to_bits(),
                srgb_formula(e).to_bits(),
                "{i}"
            );
        }
        for v in [0.5, 0.001, 1.0 - 1e-7, 1.5, -0.25, 300.0 / 255.0, 1e-30] {
            assert_eq!(
                srgb_to_linear(v).to_bits(),
                srgb_formula(v).to_bits(),
                "{v}"
            );
        }
        assert!(srgb_to_linear(f32::NAN).is_nan());
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let (w, h) = (13, 7);
        let rgb = ramp(w, h);
        let p = tmp("rt.exr");
        write_exr(&p, w, h, &rgb).unwrap();
        let (img, srgb) = read_image(&p).unwrap();
        assert!(!srgb);
        assert_eq!((img.width, img.height, img.channels), (w, h, 3));
        assert_eq!(img.data, rgb);
        let i = (2 * w + 3) * 3;
        assert_eq!(img.rgb(3, 2), [rgb[i], rgb[i + 1], rgb[i + 2]]);
    }

    /// An image of many tiles (compressed in parallel) is written as the same bytes every
    /// time, its tiles in increasing order, with and without extra channels.
    #[test]
    fn exr_files_are_deterministic() {
        let (w, h) = (700, 300);
        let rgb = ramp(w, h);
        let depth: Vec<f32> = (0..w * h).map(|i| (i % 977) as f32).collect();
        let (a, b) = (tmp("det-a.exr"), tmp("det-b.exr"));
        for extra in [vec![], vec![("depth.T".to_string(), depth)]] {
            let mut first = None;
            for _ in 0..4 {
                for p in [&a, &b] {
                    write_exr_with_channels(p, w, h, &rgb, &extra).unwrap();
                }
                let (x, y) = (std::fs::read(&*a).unwrap(), std::fs::read(&*b).unwrap());
                assert_eq!(x, y);
                assert_eq!(*first.get_or_insert(x.clone()), x);
                let meta = exr::meta::MetaData::read_from_file(&*a, false).unwrap();
                assert_eq!(
                    meta.headers[0].line_order,
                    exr::prelude::LineOrder::Increasing
                );
                assert_eq!(meta.headers[0].chunk_count, 11 * 5);
            }
            write_exr(&a, w, h, &rgb).unwrap();
            write_exr(&b, w, h, &rgb).unwrap();
            assert_eq!(std::fs::read(&*a).unwrap(), std::fs::read(&*b).unwrap());
            assert_eq!(read_image(&a).unwrap().0.data, rgb);
        }
    }

    #[test]
    fn exr_with_extra_channels() {
        let (w, h) = (4, 3);
        let rgb = ramp(w, h);
        let depth: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.5).collect();
        let p = tmp("aov.exr");
        write_exr_with_channels(&p, w, h, &rgb, &[("depth.y.T".into(), depth.clone())]).unwrap();
        let img = exr::prelude::read_first_flat_layer_from_file(&p.0).unwrap();
        let names: Vec<String> = img
            .layer_data
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        assert_eq!(names, ["B", "G", "R", "depth.y.T"]);
        let d: Vec<f32> = img.layer_data.channel_data.list[3]
            .sample_data
            .values_as_f32()
            .collect();
        assert_eq!(d, depth);
        let (back, _) = read_image(&p).unwrap();
        assert_eq!(back.data, rgb);
        assert!(
            write_exr_with_channels(&p, w, h, &rgb, &[("R".into(), vec![0.0; w * h])]).is_err()
        );
    }

    #[test]
    fn png_round_trip_within_quantisation() {
        let (w, h) = (9, 5);
        let rgb: Vec<f32> = ramp(w, h).iter().map(|v| v / 3.5).collect();
        let p = tmp("rt.png");
        write_png(&p, w, h, &rgb).unwrap();
        let (img, srgb) = read_image(&p).unwrap();
        assert!(srgb);
        assert_eq!((img.width, img.height, img.channels), (w, h, 3));
        for (a, b) in img.data.iter().zip(&rgb) {
            let want = linear_to_srgb8(*b) as f32 / 255.0;
            assert_eq!(*a, want);
            assert!((srgb_to_linear(*a) - b.min(1.0)).abs() < 0.01);
        }
    }

    #[test]
    fn reads_grey_rgba_16bit_png_and_hdr() {
        let p = tmp("grey16.png");
        let buf: Vec<u16> = (0..12).map(|i| i * 5000).collect();
        image::ImageBuffer::<image::Luma<u16>, _>::from_raw(4, 3, buf.clone())
            .unwrap()
            .save(&p)
            .unwrap();
        let (img, srgb) = read_image(&p).unwrap();
        assert!(srgb);
        assert_eq!((img.width, img.height, img.channels), (4, 3, 1));
        assert!((img.get(1, 2, 0) - 45000.0 / 65535.0).abs() < 1e-7);

        let p = tmp("rgba.png");
        let buf: Vec<u8> = (0..2 * 2 * 4).map(|i| (i * 13) as u8).collect();
        image::RgbaImage::from_raw(2, 2, buf.clone())
            .unwrap()
            .save(&p)
            .unwrap();
        let (img, _) = read_image(&p).unwrap();
        assert_eq!(img.channels, 4);
        assert_eq!(img.get(1, 1, 3), buf[15] as f32 / 255.0);

        let p = tmp("x.hdr");
        let px: Vec<image::Rgb<f32>> = (0..6).map(|i| image::Rgb([i as f32, 0.5, 100.0])).collect();
        let f = std::fs::File::create(&p).unwrap();
        image::codecs::hdr::HdrEncoder::new(f)
            .encode(&px, 3, 2)
            .unwrap();
        let (img, srgb) = read_image(&p).unwrap();
        assert!(!srgb);
        assert_eq!((img.width, img.height, img.channels), (3, 2, 3));
        assert!((img.get(2, 1, 0) - 5.0).abs() < 0.05);
        assert!((img.get(2, 1, 2) - 100.0).abs() < 1.0);
    }

    /// JPEGs decoded directly are the `image` crate's decoding of them, byte for byte (the
    /// shared textures, grey and RGB, and small files written here), and a broken JPEG is an
    /// error that says so.
    #[test]
    fn jpegs_decode_as_the_image_crate_decodes_them() {
        let textures = specula_testdata::root().join("mitsuba-data/common/textures");
        let mut files: Vec<Vec<u8>> = ["floor_tiles.jpg", "gradient.jpg", "noise_01.jpg"]
            .iter()
            .map(|f| std::fs::read(textures.join(f)).unwrap())
            .collect();
        let mut grey = vec![];
        image::codecs::jpeg::JpegEncoder::new(&mut grey)
            .encode(
                &[0u8, 60, 120, 250, 30, 90],
                3,
                2,
                image::ExtendedColorType::L8,
            )
            .unwrap();
        let mut rgb = vec![];
        let px: Vec<u8> = (0..17 * 9 * 3).map(|i| (i * 37 % 256) as u8).collect();
        image::codecs::jpeg::JpegEncoder::new(&mut rgb)
            .encode(&px, 17, 9, image::ExtendedColorType::Rgb8)
            .unwrap();
        files.extend([grey, rgb]);
        for bytes in &files {
            let got = decode_image_raw(bytes).unwrap();
            let want = image::load_from_memory(bytes).unwrap();
            let channels = want.color().channel_count() as usize;
            assert_eq!(
                (got.width, got.height, got.channels, got.srgb),
                (
                    want.width() as usize,
                    want.height() as usize,
                    channels,
                    true
                )
            );
            assert_eq!(got.pixels, Pixels::U8(want.into_bytes()));
        }
        let mut broken = files[4].clone();
        broken.truncate(broken.len() / 2);
        broken[200..].fill(0xFF);
        let e = decode_image_raw(&broken[..300]).map(|_| ()).unwrap_err();
        assert!(e.contains("JPEG"), "{e}");
    }

    #[test]
    fn reads_shared_assets() {
        let Some(assets) = specula_testdata::shared("scenes/assets") else {
            return;
        };
        let (img, srgb) = read_image(&assets.join("grid.png")).unwrap();
        assert!(srgb);
        assert_eq!((img.width, img.height, img.channels), (256, 256, 3));
        assert_eq!(img.get(5, 7, 2), 60.0 / 255.0);
        let (img, srgb) = read_image(&assets.join("sky.exr")).unwrap();
        assert!(!srgb);
        assert_eq!((img.width, img.height, img.channels), (512, 256, 3));
        // The sun's brightest pixel, as Mitsuba 3.9.1 reads it.
        assert_eq!(img.rgb(153, 60), [400.0, 360.0, 300.0]);
    }

    #[test]
    fn errors_name_the_file() {
        let p = tmp("missing.png");
        let e = read_image(&p).unwrap_err();
        assert!(e.to_string().contains("missing.png"), "{e}");
        let p = tmp("garbage.exr");
        std::fs::write(&p, [0x76, 0x2f, 0x31, 0x01, 9, 9, 9]).unwrap();
        let e = read_image(&p).unwrap_err();
        assert!(e.to_string().contains("garbage.exr"), "{e}");
        let e = write_png(&p, 2, 2, &[0.0; 3]).unwrap_err();
        assert!(e.to_string().contains("garbage.exr"), "{e}");
    }
}
