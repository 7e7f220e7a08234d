//! Volumes: 3-D fields that parameterise media (Mitsuba 3's `<volume>` plugins).
//!
//! - `constvolume`: `value` (float or rgb, default 1) everywhere;
//! - `gridvolume`: a grid read from Mitsuba's binary `.vol` file — `filename`; `filter_type`
//!   (`trilinear`, the default, or `nearest`); `wrap_mode` (`clamp`, the default, `repeat` or
//!   `mirror`); `raw` (bool, default false; in RGB rendering the values are used as they are
//!   either way; in spectral mode a `raw` 3-channel grid is refused, see
//!   [`super::spectral`]); `to_world` (default identity: the grid fills the unit cube
//!   [0, 1]³ of its local space, texel centres at (i + ½)/res, as Mitsuba 3).
//!
//! The `.vol` format: the bytes `VOL` and version 3; int32 encoding (1 = float32, the only one
//! supported, as in Mitsuba 3); int32 resolution x, y, z; int32 channel count (1 or 3); six
//! float32 bounding-box values (ignored, as Mitsuba 3 does by default); then float32 data with
//! x varying fastest, then y, then z, channels interleaved. All little-endian.
//!
//! Both cover the box `to_world([0, 1]³)`; its world-space axis-aligned bounding box
//! ([`Volume::bbox`], the eight corners transformed, as Mitsuba 3's `Volume::bbox`) is where a
//! `heterogeneous` medium has any extinction. [`Volume::max`] is the largest value over all
//! channels (and texels), Mitsuba's `Volume::max`, the majorant of delta tracking.
//!
//! In spectral mode ([`crate::spectral`]) both are evaluated at the path's wavelengths
//! ([`Volume::eval_spectral`]; how RGB values become spectra: [`super::spectral`]), after
//! [`Volume::prepare_spectral`] has upsampled their values once.
//!
//! Deviations from Mitsuba: `use_grid_bbox` is not supported; a grid holding NaN, ±∞ or
//! negative values is refused when it is read (`GridVolume::from_node`).

use super::spectral::Sigmoid;
use crate::core::{Result, SceneError};
use crate::xml::Node;
use glam::{Mat4, Vec3};
use specula_bsdf::{Rgb, Wavelengths};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Clamp,
    Repeat,
    Mirror,
}

/// A grid of RGB values over the unit cube of its local space.
#[derive(Clone, Debug, PartialEq)]
pub struct GridVolume {
    pub res: [usize; 3],
    /// RGB per texel (a one-channel grid is stored grey).
    pub data: Vec<Rgb>,
    pub trilinear: bool,
    pub wrap: Wrap,
    /// World → local (the inverse of `to_world`).
    pub to_local: Mat4,
    /// The largest value over all texels and channels.
    pub max: f32,
    /// The world-space bounding box of `to_world([0, 1]³)` (min, max).
    pub bbox: (Vec3, Vec3),
    /// Mitsuba's `raw`: no spectral upsampling (a 3-channel raw grid has no spectrum).
    pub raw: bool,
    /// Every texel grey (a one-channel grid): its spectra are constant, spectral lookups are
    /// RGB lookups.
    pub grey: bool,
    /// Spectral mode: each texel's spectrum ([`Sigmoid::texel`]), filled by
    /// [`GridVolume::prepare_spectral`] (empty before; lookups then upsample on the fly).
    pub spec: Vec<Sigmoid>,
    /// The largest value of any texel's spectrum over 360…830 nm (= `max` for a grey grid).
    pub spec_max: f32,
}

/// The world-space axis-aligned bounding box of `to_world([0, 1]³)`.
pub fn unit_cube_bbox(to_world: Mat4) -> (Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for i in 0..8 {
        let c = Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
        let w = to_world.transform_point3(c);
        lo = lo.min(w);
        hi = hi.max(w);
    }
    (lo, hi)
}

/// A medium parameter that varies in space: a `constvolume` or a `gridvolume` (a float or
/// colour given directly is a `constvolume` with identity `to_world`, as in Mitsuba 3).
#[derive(Clone, Debug, PartialEq)]
pub enum Volume {
    /// `spec`: `value` as a spectrum ([`Sigmoid::unbounded`]), filled by
    /// [`Volume::prepare_spectral`].
    Const {
        value: Rgb,
        bbox: (Vec3, Vec3),
        spec: Option<Sigmoid>,
    },
    Grid(std::sync::Arc<GridVolume>),
}

impl Volume {
    /// A constant volume over the unit cube.
    pub fn constant(value: Rgb) -> Volume {
        Volume::Const {
            value,
            bbox: (Vec3::ZERO, Vec3::ONE),
            spec: None,
        }
    }
    /// Spectral mode: upsamples the values once (the coefficient table must be computable;
    /// [`crate::scene::Scene::set_spectral`] calls this). Fails for a `raw` RGB grid.
    pub fn prepare_spectral(&mut self) -> std::result::Result<(), String> {
        match self {
            Volume::Const { value, spec, .. } => {
                *spec = Some(Sigmoid::unbounded(*value));
                Ok(())
            }
            Volume::Grid(g) => GridVolume::prepare_shared(g),
        }
    }
    /// The value at world point `p` at the wavelengths `w` (see [`super::spectral`]).
    #[inline]
    pub fn eval_spectral(&self, p: Vec3, w: &Wavelengths) -> Rgb {
        match self {
            Volume::Const { spec: Some(s), .. } => s.eval(w),
            Volume::Const { value, .. } => Sigmoid::unbounded(*value).eval(w),
            Volume::Grid(g) => g.eval_spectral(p, w),
        }
    }
    /// The value at `p` in RGB mode (`wl` = `None`) or at the wavelengths `wl`.
    #[inline]
    pub fn eval_at(&self, p: Vec3, wl: Option<&Wavelengths>) -> Rgb {
        match wl {
            None => self.eval(p),
            Some(w) => self.eval_spectral(p, w),
        }
    }
    /// The largest value at any wavelength in 360…830 nm, anywhere (spectral mode's majorant;
    /// exact for constants and grey grids, over the texels' spectra for a grid).
    pub fn spectral_max(&self) -> f32 {
        match self {
            Volume::Const { spec: Some(s), .. } => s.max(),
            Volume::Const { value, .. } => Sigmoid::unbounded(*value).max(),
            Volume::Grid(g) if g.grey => g.max,
            Volume::Grid(g) if !g.spec.is_empty() => g.spec_max,
            Volume::Grid(g) => g
                .data
                .iter()
                .fold(0f32, |m, v| m.max(Sigmoid::texel(*v).max())),
        }
    }
    /// The value at world point `p` (anywhere: a grid applies its wrap mode outside its box).
    #[inline]
    pub fn eval(&self, p: Vec3) -> Rgb {
        match self {
            Volume::Const { value, .. } => *value,
            Volume::Grid(g) => g.eval(p),
        }
    }
    /// The largest value over all channels (and texels).
    pub fn max(&self) -> f32 {
        match self {
            Volume::Const { value, .. } => value.max_component(),
            Volume::Grid(g) => g.max,
        }
    }
    /// The smallest value over all channels (and texels).
    pub fn min(&self) -> f32 {
        match self {
            Volume::Const { value, .. } => value.min_component(),
            Volume::Grid(g) => g
                .data
                .iter()
                .fold(f32::INFINITY, |m, v| m.min(v.min_component())),
        }
    }
    /// The world-space bounding box of the volume's `to_world([0, 1]³)`.
    pub fn bbox(&self) -> (Vec3, Vec3) {
        match self {
            Volume::Const { bbox, .. } => *bbox,
            Volume::Grid(g) => g.bbox,
        }
    }
}

fn bad(path: &Path, msg: impl std::fmt::Display) -> String {
    format!("{}: {msg}", path.display())
}

impl GridVolume {
    /// Parses a `.vol` file's bytes.
    pub fn parse(bytes: &[u8], path: &Path) -> std::result::Result<(Vec<Rgb>, [usize; 3]), String> {
        if bytes.len() < 48 || &bytes[0..3] != b"VOL" {
            return Err(bad(path, "not a Mitsuba .vol file (no 'VOL' header)"));
        }
        if bytes[3] != 3 {
            return Err(bad(
                path,
                format!(".vol version {} is not supported (3)", bytes[3]),
            ));
        }
        let i32_at = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        if i32_at(4) != 1 {
            return Err(bad(
                path,
                format!(".vol encoding {} is not supported (1 = float32)", i32_at(4)),
            ));
        }
        let (x, y, z, ch) = (i32_at(8), i32_at(12), i32_at(16), i32_at(20));
        if x <= 0 || y <= 0 || z <= 0 || !(ch == 1 || ch == 3) {
            return Err(bad(
                path,
                format!("invalid .vol size {x}×{y}×{z} × {ch} channels"),
            ));
        }
        let n = (x as u64) * (y as u64) * (z as u64);
        let need = 48u64 + n * ch as u64 * 4;
        if need != bytes.len() as u64 {
            return Err(bad(
                path,
                format!(
                    "a {x}×{y}×{z}×{ch} grid needs {need} bytes, the file has {}",
                    bytes.len()
                ),
            ));
        }
        let f = |k: usize| f32::from_le_bytes(bytes[48 + 4 * k..52 + 4 * k].try_into().unwrap());
        let ch = ch as usize;
        let data = (0..n as usize)
            .map(|i| {
                if ch == 1 {
                    Rgb::splat(f(i))
                } else {
                    Rgb([f(3 * i), f(3 * i + 1), f(3 * i + 2)])
                }
            })
            .collect();
        Ok((data, [x as usize, y as usize, z as usize]))
    }

    /// A grid over `to_world([0, 1]³)`.
    pub fn new(
        res: [usize; 3],
        data: Vec<Rgb>,
        trilinear: bool,
        wrap: Wrap,
        to_world: Mat4,
    ) -> GridVolume {
        let max = data.iter().fold(0f32, |m, v| m.max(v.max_component()));
        let grey = data.iter().all(|v| v[0] == v[1] && v[1] == v[2]);
        GridVolume {
            res,
            data,
            trilinear,
            wrap,
            to_local: to_world.inverse(),
            max,
            bbox: unit_cube_bbox(to_world),
            raw: false,
            grey,
            spec: Vec::new(),
            spec_max: max,
        }
    }

    /// Upsamples every texel ([`Sigmoid::texel`]) for spectral lookups, once (nothing to do
    /// for a grey grid). Fails for a `raw` RGB grid, which has no spectrum.
    pub fn prepare_spectral(&mut self) -> std::result::Result<(), String> {
        if self.grey || !self.spec.is_empty() {
            return Ok(());
        }
        if self.raw {
            return Err(
                "a 3-channel gridvolume with raw=true has no spectrum (Mitsuba fails \
                when it is evaluated in a spectral variant): spectral mode needs raw=false or a \
                one-channel grid"
                    .into(),
            );
        }
        self.spec = self.data.iter().map(|v| Sigmoid::texel(*v)).collect();
        self.spec_max = self.spec.iter().fold(0f32, |m, s| m.max(s.max()));
        Ok(())
    }

    /// [`GridVolume::prepare_spectral`] of a shared grid (copied first if shared elsewhere).
    pub fn prepare_shared(g: &mut std::sync::Arc<GridVolume>) -> std::result::Result<(), String> {
        if g.grey || !g.spec.is_empty() {
            return Ok(());
        }
        std::sync::Arc::make_mut(g).prepare_spectral()
    }

    #[inline]
    fn wrap_index(&self, i: i64, n: usize) -> usize {
        let n = n as i64;
        (match self.wrap {
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m < n {
                    m
                } else {
                    2 * n - 1 - m
                }
            }
        }) as usize
    }

    /// The index of texel (x, y, z) after wrapping.
    #[inline]
    fn index(&self, x: i64, y: i64, z: i64) -> usize {
        let [rx, ry, rz] = self.res;
        let (x, y, z) = (
            self.wrap_index(x, rx),
            self.wrap_index(y, ry),
            self.wrap_index(z, rz),
        );
        (z * ry + y) * rx + x
    }

    /// Filters the texel values `texel(index)` at world point `p` (nearest or trilinear).
    #[inline(always)]
    fn filter(&self, p: Vec3, texel: impl Fn(usize) -> Rgb) -> Rgb {
        let q = self.to_local.transform_point3(p);
        let [rx, ry, rz] = self.res;
        let s = Vec3::new(q.x * rx as f32, q.y * ry as f32, q.z * rz as f32);
        if !self.trilinear {
            return texel(self.index(s.x.floor() as i64, s.y.floor() as i64, s.z.floor() as i64));
        }
        let s = s - Vec3::splat(0.5);
        let b = s.floor();
        let f = s - b;
        let (x, y, z) = (b.x as i64, b.y as i64, b.z as i64);
        let t = |x, y, z| texel(self.index(x, y, z));
        let lerp = |a: Rgb, b: Rgb, t: f32| a * (1.0 - t) + b * t;
        let c00 = lerp(t(x, y, z), t(x + 1, y, z), f.x);
        let c10 = lerp(t(x, y + 1, z), t(x + 1, y + 1, z), f.x);
        let c01 = lerp(t(x, y, z + 1), t(x + 1, y, z + 1), f.x);
        let c11 = lerp(t(x, y + 1, z + 1), t(x + 1, y + 1, z + 1), f.x);
        lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z)
    }

    /// The value at world point `p`.
    pub fn eval(&self, p: Vec3) -> Rgb {
        self.filter(p, |i| self.data[i])
    }

    /// The value at world point `p` at the wavelengths `w`: the texels' spectra at `w`,
    /// filtered as [`GridVolume::eval`] filters RGB values (Mitsuba's spectral `gridvolume`).
    pub fn eval_spectral(&self, p: Vec3, w: &Wavelengths) -> Rgb {
        if self.grey {
            return self.eval(p);
        }
        if self.spec.is_empty() {
            return self.filter(p, |i| Sigmoid::texel(self.data[i]).eval(w));
        }
        self.filter(p, |i| self.spec[i].eval(w))
    }

    /// Builds a `<volume type="gridvolume">`; `resolve` finds its file.
    pub fn from_node(n: &Node, resolve: &dyn Fn(&str) -> std::path::PathBuf) -> Result<GridVolume> {
        let err = |m: String| SceneError::new(Some(n.loc.clone()), m);
        let file = n
            .string_opt("filename")?
            .ok_or_else(|| err("gridvolume needs 'filename'".into()))?;
        let trilinear = match n.string("filter_type", "trilinear")?.as_str() {
            "trilinear" => true,
            "nearest" => false,
            o => {
                return Err(err(format!(
                    "filter_type '{o}' is invalid (trilinear, nearest)"
                )))
            }
        };
        let wrap = match n.string("wrap_mode", "clamp")?.as_str() {
            "clamp" => Wrap::Clamp,
            "repeat" => Wrap::Repeat,
            "mirror" => Wrap::Mirror,
            o => {
                return Err(err(format!(
                    "wrap_mode '{o}' is invalid (clamp, repeat, mirror)"
                )))
            }
        };
        let raw = n.bool("raw", false)?;
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        n.check_unused(&["filename", "filter_type", "wrap_mode", "raw", "to_world"])?;
        let path = resolve(&file);
        let bytes = std::fs::read(&path).map_err(|e| err(format!("{}: {e}", path.display())))?;
        let (data, res) = GridVolume::parse(&bytes, &path).map_err(err)?;
        if !(to_world.determinant().is_normal() && to_world.is_finite()) {
            return Err(err("to_world of a gridvolume must be invertible".into()));
        }
        if let Some(i) = data
            .iter()
            .position(|v| !(v.is_finite() && v.min_component() >= 0.0))
        {
            return Err(err(format!(
                "{}: texel {i} holds {:?}; grid values must be finite and non-negative",
                path.display(),
                data[i].0
            )));
        }
        let mut g = GridVolume::new(res, data, trilinear, wrap, to_world);
        g.raw = raw;
        Ok(g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vol(res: [usize; 3], ch: usize, data: &[f32]) -> Vec<u8> {
        let mut b = b"VOL\x03".to_vec();
        for v in [1i32, res[0] as i32, res[1] as i32, res[2] as i32, ch as i32] {
            b.extend(v.to_le_bytes());
        }
        for v in [0f32, 0., 0., 1., 1., 1.].iter().chain(data) {
            b.extend(v.to_le_bytes());
        }
        b
    }

    #[test]
    fn reads_and_interpolates_like_mitsuba() {
        // 2×1×1 grid, 1 channel: texel centres at x = 0.25 and 0.75
        let (data, res) =
            GridVolume::parse(&vol([2, 1, 1], 1, &[1.0, 3.0]), Path::new("t")).unwrap();
        let mut g = GridVolume::new(res, data, true, Wrap::Clamp, Mat4::IDENTITY);
        assert_eq!(g.max, 3.0);
        assert_eq!(g.bbox, (Vec3::ZERO, Vec3::ONE));
        assert_eq!(g.eval(Vec3::new(0.5, 0.5, 0.5)), Rgb::splat(2.0));
        assert_eq!(g.eval(Vec3::new(0.1, 0.5, 0.5)), Rgb::splat(1.0));
        assert_eq!(g.eval(Vec3::new(0.625, 0.2, 0.9)), Rgb::splat(2.5));
        g.wrap = Wrap::Repeat;
        // halfway between the last texel (x = 0.75) and the first one repeated (x = 1.25)
        assert_eq!(g.eval(Vec3::new(1.0, 0.5, 0.5)), Rgb::splat(2.0));
        g.trilinear = false;
        assert_eq!(g.eval(Vec3::new(0.9, 0.5, 0.5)), Rgb::splat(3.0));
        for (bytes, want) in [
            (b"VOX\x03".to_vec(), "VOL"),
            (vol([2, 1, 1], 1, &[1.0]), "needs"),
            (vol([2, 1, 1], 2, &[1.0; 4]), "channels"),
        ] {
            let mut b = bytes;
            b.resize(b.len().max(48), 0);
            let e = GridVolume::parse(&b, Path::new("t")).unwrap_err();
            assert!(e.contains(want), "{e}");
        }
    }

    /// Mitsuba 3.9.1's `gridvolume` on the docs' `textures/albedo.vol` (16³, RGB), default
    /// clamp and trilinear, at three points (values printed by Mitsuba).
    #[test]
    fn docs_albedo_grid_matches_mitsuba() {
        let Some(p) = specula_testdata::shared("mitsuba-data/docs/scenes/textures/albedo.vol")
        else {
            return;
        };
        let (data, res) = GridVolume::parse(&std::fs::read(&p).unwrap(), &p).unwrap();
        assert_eq!(res, [16, 16, 16]);
        let g = GridVolume::new(res, data, true, Wrap::Clamp, Mat4::IDENTITY);
        for (p, want) in [
            ([0.5, 0.5, 0.5], [0.328199, 0.05, 0.671801]),
            ([0.1, 0.2, 0.3], [0.890391, 0.05, 0.109609]),
            ([0.0, 0.0, 0.0], [0.5, 0.05, 0.5]),
        ] {
            let v = g.eval(Vec3::from(p));
            for c in 0..3 {
                assert!((v[c] - want[c]).abs() < 1e-5, "{p:?}: {v:?} vs {want:?}");
            }
        }
    }
}
