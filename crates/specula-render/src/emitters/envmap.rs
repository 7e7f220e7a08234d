//! Mitsuba's `envmap`: a lat-long environment image, importance-sampled.
//!
//! `envmap` maps a local direction d to lat-long coordinates
//! u = atan2(d.x, −d.z)/2π, v = acos(d.y)/π (+y is up, v = 0 the zenith, u = 0 towards −z,
//! u = ¼ towards +x). The image is padded with a copy of its first column and looked up
//! *bilinearly* with pixel (x, y) sitting exactly at u = (x + ½)/W, v = y/(H − 1): the first
//! and last rows lie on the poles. Radiance is that value × `scale`; `to_world` rotates the
//! map (world direction = to_world · local direction).
//!
//! Importance sampling follows the radiance's bilinear interpolation, as Mitsuba's (a
//! continuous 2D warp over the pixel grid) does, in its own way, consistent with
//! [`Emitter::pdf_direction`]. The cells between four neighbouring pixels of the bilinear
//! lookup are chosen with probability ∝ (mean luminance of their four corners) × (solid
//! angle), marginal rows first, then the column (guided CDF searches). Each texel keeps beside
//! its RGB a density share, its luminance × W / (2π Σ weights): the mean of a cell's four is
//! its probability over its solid angle, whatever the row (the band's solid angle cancels).
//! Inside the cell the solid-angle density is the bilinear interpolation of the four shares in
//! (x, s), the fractions of the cell's width (φ) and of its band's cos θ (uniform measure in
//! solid angle), drawn exactly: s from its linear marginal, then x given s. The pdf is thus
//! continuous over the sphere, and L/pdf stays nearly constant where the map changes fast
//! from pixel to pixel (a small sun), instead of varying by up to the ratio of a cell's
//! corners, as a uniform density per cell would (measured on `envmap_spheres`, 16 spp: relMSE
//! −10 % with `independent`, Mitsuba's own figure, −16 % with `sobol`). A lookup's radiance
//! and pdf come from the same two cache lines, with no per-cell table.

use super::*;
use crate::core::{to_f32, to_index};

/// Mitsuba's `envmap`: a lat-long environment image with luminance-based importance
/// sampling.
#[derive(Clone)]
pub struct Envmap {
    /// Resolution of the source image.
    pub width: usize,
    pub height: usize,
    pub scale: f32,
    /// Local → world rotation (and its inverse).
    pub(super) to_world: Mat3,
    pub(super) to_local: Mat3,
    /// Per texel (`width + 1` columns, the last repeating the first, × `height` rows): linear
    /// RGB and, in the fourth lane, its share of the sampling density: its luminance (clamped
    /// to ≥ 0, non-finite as 0) × W / (2π Σ weights), a cell's pdf being the mean of its four
    /// corners' (see the module docs; the factor is applied per texel, in f64, so that no
    /// f32 factor can overflow for a very dark map). One aligned 16-byte load gives a texel,
    /// and a cell's pdf comes from the texels its radiance reads (no table of its own to miss
    /// in the cache).
    pub(super) data: Vec<Vec4>,
    /// cos θ of each pixel row (θ = π·y/(H − 1)).
    pub(super) cos_theta: Vec<f32>,
    /// 1 / (cos θ_j − cos θ_(j+1)) for each cell row j: a cos θ's fraction of its band.
    pub(super) inv_band: Vec<f32>,
    /// Marginal CDF over the H − 1 cell rows (H entries, 0 … 1).
    pub(super) row_cdf: Vec<f32>,
    /// Per cell row, the conditional CDF over its W cells (W + 1 entries each).
    pub(super) col_cdf: Vec<f32>,
    /// Cutpoint guide tables ([`guide`]) of `row_cdf` and of each row of `col_cdf`
    /// (`guide::buckets(W) + 1` entries each).
    pub(super) row_guide: Vec<u32>,
    pub(super) col_guide: Vec<u32>,
}

/// A lookup's bilinear cell (the index of its upper-left texel) and the weights of its
/// second column and row (see [`Envmap::lookup`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lookup {
    cell: usize,
    w1: Vec2,
    /// The direction's fraction of its cell's band in cos θ, where the sampling density
    /// is interpolated (see [`Envmap::band_fraction`]).
    s: f32,
}

impl std::fmt::Debug for Envmap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Envmap")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("scale", &self.scale)
            .field("to_world", &self.to_world)
            .finish_non_exhaustive()
    }
}

/// Picks the bin of a CDF (`n + 1` entries, 0 … 1) holding `u`, skipping empty bins, and
/// returns it with `u` rescaled to [0, 1) within it: the binary search over the whole CDF
/// that [`guide::sample`] reproduces (kept as its reference in the tests).
#[cfg(test)]
pub(super) fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let idx = cdf[1..n].partition_point(|&c| c <= u);
    bin_offset(cdf, idx, u)
}

/// Cutpoint guide tables (Chen & Asau's method) for sampling a CDF: with m buckets, a value x
/// falls in bucket b(x) = min(⌊x·m⌋, m − 1) (the same f32 operations when the table is built
/// and when it is read, and non-decreasing in x), and entry k counts the CDF's interior entries
/// in buckets below k. The interior entries before entry b(u) are then < u and those from entry
/// b(u) + 1 on are > u, so the bin holding u is found among the few entries in u's bucket
/// instead of over the whole CDF, with no division; it returns exactly what the binary search
/// over the whole CDF returns (same bins, same images).
pub(super) mod guide {
    use super::{to_f32, to_index};

    /// Bins per bucket of the marginal (row) CDF's guide: its guide and CDF are small and
    /// stay in the cache, so short buckets make the search short.
    pub const ROW_BINS: usize = 4;
    /// Bins per bucket of the conditional (column) CDFs' guides: one entry per 16 bins keeps
    /// all rows' guides small enough to stay in the cache (33 KiB for a 512 × 256 map, where
    /// four bins per bucket took 131 KiB that missed it), so that a sample waits for one
    /// memory access to the CDF (its bucket's few lines, fetched together) instead of two in
    /// a row (the guide, then the CDF). 32 bins per bucket measured the same time with more
    /// search instructions.
    pub const COL_BINS: usize = 16;

    /// Buckets for a CDF of `n` bins with about `per` bins per bucket.
    #[inline]
    pub fn buckets(n: usize, per: usize) -> usize {
        n.div_ceil(per).max(1)
    }

    /// The bucket of `x` among `m` (`m` as f32 too).
    #[inline]
    pub(super) fn bucket(x: f32, m: usize, mf: f32) -> usize {
        // `as u32` saturates: negative x gives 0
        to_index(x * mf).min(m - 1)
    }

    /// Appends the guide (`buckets(n, per) + 1` entries) of a CDF of `n + 1` non-decreasing
    /// entries.
    pub fn build(cdf: &[f32], per: usize, out: &mut Vec<u32>) {
        let inner = &cdf[1..cdf.len() - 1];
        let m = buckets(cdf.len() - 1, per);
        let mf = to_f32(m);
        let mut c = 0;
        for k in 0..m {
            while c < inner.len() && bucket(inner[c], m, mf) < k {
                c += 1;
            }
            out.push(c as u32);
        }
        out.push(inner.len() as u32);
    }

    /// Picks the bin of `cdf` (`n + 1` entries, 0 … 1) holding `u`, skipping empty bins,
    /// through its guide `start`; returns it with `u` rescaled to [0, 1) within it.
    /// `PREFETCH`: ask for the bucket's CDF lines first (for the column CDFs, which miss the
    /// cache; the small row CDF stays in it).
    #[inline]
    pub fn sample<const PREFETCH: bool>(cdf: &[f32], start: &[u32], u: f32) -> (usize, f32) {
        let m = start.len() - 1;
        let k = bucket(u, m, to_f32(m));
        let (lo, hi) = (start[k] as usize, start[k + 1] as usize);
        // the entries the search reads (and the bin's two ends): ask for their lines at
        // once, so that the search waits for one access rather than one per line it probes
        #[cfg(target_arch = "x86_64")]
        if PREFETCH {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let first = cdf[lo..].as_ptr() as usize;
            let last = first + 4 * (hi - lo + 1);
            let mut line = first & !63;
            // (at most 8 lines: a longer search is rare, in a map with a bright spot)
            let end = (last & !63).min(line + 7 * 64);
            while line <= end {
                // SAFETY: prefetching never faults
                unsafe { _mm_prefetch::<_MM_HINT_T0>(line as *const i8) };
                line += 64;
            }
        }
        let idx = lo + cdf[1 + lo..1 + hi].partition_point(|&c| c <= u);
        super::bin_offset(cdf, idx, u)
    }
}

/// A sample of the linear density on [0, 1] with values `a` at 0 and `b` at 1 (both ≥ 0, not
/// both 0), by inverting its CDF: x = u(a + b) / (a + √((1 − u)a² + u b²)), the form without
/// cancellation (pbrt-v4's `SampleLinear`); uniform where a = b.
#[inline]
pub(super) fn sample_linear(u: f32, a: f32, b: f32) -> f32 {
    if a == b {
        return u;
    }
    // (the denominator is 0 only where a = 0 and u = 0, whose sample is 0)
    let den = a + (a * a + (b * b - a * a) * u).max(0.0).sqrt();
    let x = if den > 0.0 { u * (a + b) / den } else { 0.0 };
    x.clamp(0.0, 1.0 - f32::EPSILON / 2.0)
}

/// The bilinear interpolation of a cell's corner values (upper left, upper right, lower left,
/// lower right) at fraction `x` of its width and `s` of its height.
#[inline]
fn bilerp([d00, d10, d01, d11]: [f32; 4], x: f32, s: f32) -> f32 {
    let top = d00 + (d10 - d00) * x;
    let bottom = d01 + (d11 - d01) * x;
    top + (bottom - top) * s
}

#[inline]
fn bin_offset(cdf: &[f32], idx: usize, u: f32) -> (usize, f32) {
    let (lo, hi) = (cdf[idx], cdf[idx + 1]);
    let t = if hi > lo { (u - lo) / (hi - lo) } else { 0.5 };
    (idx, t.clamp(0.0, 1.0 - f32::EPSILON / 2.0))
}

impl Envmap {
    /// Builds the map from decoded pixels (`srgb`: values are sRGB-encoded and get
    /// linearised). Errors are messages for the caller to attach to a file.
    pub fn new(img: &Image, srgb: bool, scale: f32, to_world: &Mat4) -> Result<Self, String> {
        let (w, h) = (img.width, img.height);
        if w < 2 || h < 3 {
            return Err(format!(
                "the environment map resolution must be at least 2×3 pixels (got {w}×{h})"
            ));
        }
        let lin = |v: f32| if srgb { srgb_to_linear(v) } else { v };
        let pw = w + 1;
        let mut data = vec![Vec4::ZERO; pw * h];
        for y in 0..h {
            for x in 0..pw {
                let rgb = img.rgb(x % w, y);
                let c = Rgb::new(lin(rgb[0]), lin(rgb[1]), lin(rgb[2]));
                let l = c.luminance();
                let l = if l.is_finite() { l.max(0.0) } else { 0.0 };
                data[y * pw + x] = Vec4::new(c.0[0], c.0[1], c.0[2], l);
            }
        }
        let lin3 = Mat3::from_mat4(*to_world);
        let to_local = lin3.inverse();
        if !to_local.is_finite() {
            return Err("the envmap's to_world transform is singular".into());
        }

        // Sampling distribution over the (H − 1) × W cells of the bilinear lookup.
        let cos_theta: Vec<f32> = (0..h)
            .map(|y| (std::f64::consts::PI * y as f64 / (h - 1) as f64).cos() as f32)
            .collect();
        // (a band too thin for f32, in a map of very many rows, puts every point at its top)
        let inv_band: Vec<f32> = cos_theta
            .windows(2)
            .map(|c| {
                if c[0] > c[1] {
                    1.0 / (c[0] - c[1])
                } else {
                    0.0
                }
            })
            .collect();
        // Two passes over the cells, row by row, reusing one row of weights (no image-sized
        // temporaries: fresh memory costs page faults, a good part of this function's time):
        // the row sums first, then each row's conditional CDF.
        let rows = h - 1;
        let band = |j: usize| {
            let th0 = std::f64::consts::PI * j as f64 / rows as f64;
            let th1 = std::f64::consts::PI * (j + 1) as f64 / rows as f64;
            th0.cos() - th1.cos()
        };
        let mut row_weights = vec![0.0f64; w];
        let fill_row = |j: usize, out: &mut [f64]| -> f64 {
            let (top, bottom) = (
                &data[j * pw..(j + 1) * pw],
                &data[(j + 1) * pw..(j + 2) * pw],
            );
            let b = band(j);
            let mut sum = 0.0f64;
            for (i, o) in out.iter_mut().enumerate() {
                let avg = 0.25
                    * (top[i].w as f64
                        + top[i + 1].w as f64
                        + bottom[i].w as f64
                        + bottom[i + 1].w as f64);
                *o = avg * b;
                sum += *o;
            }
            sum
        };
        let row_sum: Vec<f64> = (0..rows).map(|j| fill_row(j, &mut row_weights)).collect();
        let total: f64 = row_sum.iter().sum();
        let mut row_cdf = vec![0.0f32; rows + 1];
        let mut col_cdf = vec![0.0f32; rows * (w + 1)];
        if total > 0.0 && total.is_finite() {
            let mut acc = 0.0f64;
            for j in 0..rows {
                acc += row_sum[j];
                // Exactly 1 once all the mass is in (the sums run in the same order), so
                // trailing empty bins can never be drawn.
                row_cdf[j + 1] = if acc >= total {
                    1.0
                } else {
                    (acc / total) as f32
                };
                fill_row(j, &mut row_weights);
                let cdf = &mut col_cdf[j * (w + 1)..(j + 1) * (w + 1)];
                let mut a = 0.0f64;
                for i in 0..w {
                    a += row_weights[i];
                    cdf[i + 1] = if row_sum[j] > 0.0 {
                        if a >= row_sum[j] {
                            1.0
                        } else {
                            (a / row_sum[j]) as f32
                        }
                    } else {
                        (i + 1) as f32 / w as f32
                    };
                }
                cdf[w] = 1.0;
            }
            row_cdf[rows] = 1.0;
        }
        // a cell's weight is its corners' mean luminance × its band's solid angle, so its
        // solid-angle density is that mean × W / (2π Σ weights) in every row: each texel keeps
        // its luminance times that factor (all 0 for a black map, which is never sampled)
        let pdf_scale = if total > 0.0 && total.is_finite() {
            w as f64 / (2.0 * std::f64::consts::PI * total)
        } else {
            0.0
        };
        for t in data.iter_mut() {
            t.w = (t.w as f64 * pdf_scale) as f32;
        }
        let mut row_guide = vec![];
        guide::build(&row_cdf, guide::ROW_BINS, &mut row_guide);
        let mut col_guide = Vec::with_capacity(rows * (guide::buckets(w, guide::COL_BINS) + 1));
        for cdf in col_cdf.chunks_exact(w + 1) {
            guide::build(cdf, guide::COL_BINS, &mut col_guide);
        }
        Ok(Envmap {
            width: w,
            height: h,
            scale,
            to_world: lin3,
            to_local,
            data,
            cos_theta,
            inv_band,
            row_cdf,
            col_cdf,
            row_guide,
            col_guide,
        })
    }

    /// Lat-long coordinates of a local direction (Mitsuba's `direction_to_uv`).
    #[inline]
    pub(super) fn direction_to_uv(d: Vec3) -> Vec2 {
        Vec2::new(
            specula_bsdf::math::atan2(d.x, -d.z) * (0.5 / PI),
            specula_bsdf::math::acos(d.y.clamp(-1.0, 1.0)) * (1.0 / PI),
        )
    }

    #[inline]
    pub(super) fn texel(&self, index: usize) -> Rgb {
        let t = self.data[index];
        Rgb::new(t.x, t.y, t.z)
    }

    /// The four texels of the cell whose upper-left texel is `index`: upper left, upper
    /// right, lower left, lower right.
    #[inline]
    fn cell_texels(&self, index: usize) -> [Vec4; 4] {
        let pw = self.width + 1;
        [
            self.data[index],
            self.data[index + 1],
            self.data[index + pw],
            self.data[index + pw + 1],
        ]
    }

    /// The density shares of the four corners of the cell whose upper-left texel is `index`
    /// (in [`Envmap::cell_texels`]' order).
    #[inline]
    fn corners(&self, index: usize) -> [f32; 4] {
        self.cell_texels(index).map(|t| t.w)
    }

    /// Where cos θ lies in the band of cell row `j`, as a fraction in [0, 1] from its top.
    #[inline]
    fn band_fraction(&self, j: usize, cos_theta: f32) -> f32 {
        ((self.cos_theta[j] - cos_theta) * self.inv_band[j]).clamp(0.0, 1.0)
    }

    /// The solid-angle pdf at the point of the cell whose upper-left texel is `index`, at
    /// fraction `x` of its width and `s` of its band (see the module docs).
    #[inline]
    fn pdf_in_cell(&self, index: usize, x: f32, s: f32) -> f32 {
        bilerp(self.corners(index), x.clamp(0.0, 1.0), s)
    }

    /// The mean solid-angle pdf over the sampling cell whose upper-left texel is `index`
    /// (the mean of its corners' density shares): the cell's probability over its solid angle.
    #[cfg(test)]
    pub(super) fn cell_pdf_at(&self, index: usize) -> f32 {
        let [a, b, c, d] = self.corners(index).map(|v| 0.25 * v);
        (a + b) + (c + d)
    }

    /// The sampling cell (row-major over (H − 1) × W) holding local direction `d`.
    #[cfg(test)]
    pub(super) fn cell(&self, d: Vec3) -> usize {
        let i = self.bilinear_cell(Self::direction_to_uv(d)).0;
        let pw = self.width + 1;
        (i / pw) * self.width + i % pw
    }

    /// The solid-angle pdf of sampling cell `cell` (row-major over (H − 1) × W).
    #[cfg(test)]
    pub(super) fn cell_pdf(&self, cell: usize) -> f32 {
        let (j, i) = (cell / self.width, cell % self.width);
        self.cell_pdf_at(j * (self.width + 1) + i)
    }

    /// The bilinear lookup at lat-long `uv`: the index of the upper-left texel of its cell
    /// and the weights of the right and lower texels.
    #[inline]
    pub(super) fn bilinear_cell(&self, uv: Vec2) -> (usize, Vec2) {
        let (_, cell, w1) = self.bilinear_cell_in_row(uv);
        (cell, w1)
    }

    /// [`Envmap::bilinear_cell`], with the cell's row first.
    #[inline]
    fn bilinear_cell_in_row(&self, uv: Vec2) -> (usize, usize, Vec2) {
        let (w, h) = (self.width, self.height);
        let mut uv = uv;
        uv.x -= 0.5 / to_f32(w);
        uv.x -= specula_bsdf::math::floor(uv.x);
        // Mitsuba also wraps v (`uv -= floor(uv)`), which would send the exact south pole
        // (v = 1) to the north pole; its f32 acos never yields exactly 1 there (it returns
        // the bottom row), so v is only clamped here.
        uv.y = uv.y.clamp(0.0, 1.0);
        uv *= Vec2::new(to_f32(w), to_f32(h - 1));
        let px = to_index(uv.x).min(w - 1);
        let py = to_index(uv.y).min(h - 2);
        (
            py,
            py * (w + 1) + px,
            uv - Vec2::new(to_f32(px), to_f32(py)),
        )
    }

    /// The radiance (times `scale`) interpolated with weights `w1` in the cell from texel `i`.
    #[inline]
    pub(super) fn interpolate(&self, i: usize, w1: Vec2) -> Rgb {
        self.interpolate_texels(self.cell_texels(i), w1)
    }

    /// [`Envmap::interpolate`] of a cell's texels already read ([`Envmap::cell_texels`]).
    #[inline]
    fn interpolate_texels(&self, [t00, t10, t01, t11]: [Vec4; 4], w1: Vec2) -> Rgb {
        let w0 = Vec2::ONE - w1;
        let v0 = t00 * w0.x + t10 * w1.x;
        let v1 = t01 * w0.x + t11 * w1.x;
        let v = v0 * w0.y + v1 * w1.y;
        Rgb::new(v.x, v.y, v.z) * self.scale
    }

    /// Spectral mode: the radiance from world direction `d` at the wavelengths `wl`, as
    /// Mitsuba's spectral `envmap` computes it: each of the four texels around the lookup is
    /// upsampled as an illuminant (shape ρᵢ of rgbᵢ/sᵢ, sᵢ = 2·max(rgbᵢ)), and the bilinear
    /// interpolation of the shapes is multiplied by the interpolation of the sᵢ and by D65
    /// (not the interpolation of the products: near a small bright sun this shifts the colour
    /// by a percent or so against upsampling the interpolated RGB, which Specula reproduces
    /// so that spectral renders match Mitsuba's).
    pub fn eval_spectral(&self, d_world: Vec3, wl: &specula_bsdf::Wavelengths) -> Rgb {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return Rgb::ZERO;
        }
        let (i, w1) = self.bilinear_cell(Self::direction_to_uv(d));
        let w0 = Vec2::ONE - w1;
        let pw = self.width + 1;
        let mut shape = Rgb::ZERO;
        let mut scale = 0.0f32;
        for (idx, wt) in [
            (i, w0.x * w0.y),
            (i + 1, w1.x * w0.y),
            (i + pw, w0.x * w1.y),
            (i + pw + 1, w1.x * w1.y),
        ] {
            let rgb = self.texel(idx).map(|v| v.max(0.0));
            let s = 2.0 * rgb.max_component();
            if s > 0.0 {
                shape += specula_bsdf::spectral::upsample::reflectance(rgb / s, wl) * wt;
                scale += s * wt;
            }
        }
        let d65 = Rgb(wl.0.map(specula_bsdf::spectral::cie::d65));
        shape * d65 * (scale * self.scale)
    }

    #[inline]
    pub(super) fn local(&self, d_world: Vec3) -> Vec3 {
        (self.to_local * d_world).normalize_or_zero()
    }

    /// Asks the cache for the texels that a lookup from world direction `d_world` reads,
    /// before the caller traces a ray that may escape along it (the lookup itself would wait
    /// for them when the ray escapes); a map small enough to stay in the core's cache
    /// (under 256 KiB of texels) is skipped.
    #[inline]
    pub fn prefetch(&self, d_world: Vec3) {
        #[cfg(target_arch = "x86_64")]
        if self.worth_prefetching() {
            self.prefetch_cell(self.coarse_cell(d_world));
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = d_world;
    }

    /// [`Envmap::lookup`], asking the cache for the texels it reads (the exact cell, where
    /// [`Envmap::prefetch`] computes a cheaper one that may be a texel off): for a caller
    /// that keeps the lookup and finishes it with [`Envmap::eval_pdf_at`] if the ray escapes.
    #[inline]
    pub fn prefetch_lookup(&self, d_world: Vec3) -> Option<Lookup> {
        let l = self.lookup(d_world)?;
        #[cfg(target_arch = "x86_64")]
        self.prefetch_cell(l.cell);
        Some(l)
    }

    /// Asks the cache for the four texels of the cell whose upper-left texel is `i` (a cell
    /// of `bilinear_cell` or `coarse_cell`: py ≤ h − 2 and px ≤ w − 1).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn prefetch_cell(&self, i: usize) {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        debug_assert!(i + self.width + 2 < self.data.len());
        // SAFETY: the cell's four texels i, i + 1, i + w + 1 and i + w + 2 lie in `data`
        // (py ≤ h − 2 and px ≤ w − 1, so i + w + 2 ≤ (h − 1)(w + 1) + w = len − 1), and
        // prefetching never faults
        unsafe {
            let p = self.data.as_ptr().add(i) as *const i8;
            _mm_prefetch::<_MM_HINT_T0>(p);
            _mm_prefetch::<_MM_HINT_T0>(p.add(16));
            let q = self.data.as_ptr().add(i + self.width + 1) as *const i8;
            _mm_prefetch::<_MM_HINT_T0>(q);
            _mm_prefetch::<_MM_HINT_T0>(q.add(16));
        }
    }

    /// Whether [`Envmap::prefetch`] does anything: maps of 256 KiB of texels or more (16 Ki
    /// texels of 16 bytes); smaller ones stay in the core's cache.
    #[inline]
    pub fn worth_prefetching(&self) -> bool {
        self.data.len() >= 16 * 1024
    }

    /// The upper-left texel of the bilinear lookup's cell for world direction `d_world`
    /// (as `bilinear_cell(direction_to_uv(local(d)))` gives it) computed cheaply for
    /// [`Envmap::prefetch`]: acos from a short polynomial (error under 0.0001 rad) instead
    /// of libm's, and no normalisation, so it can be a texel off next to a cell's edge.
    #[inline]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    pub(super) fn coarse_cell(&self, d_world: Vec3) -> usize {
        let d = self.to_local * d_world;
        // φ as the lookup computes it (a short polynomial already)
        let phi = specula_bsdf::math::atan2(d.x, -d.z);
        // θ = acos(y/|d|): √(1 − y)·(1.5707288 − 0.2121144 y + 0.0742610 y² − 0.0187293 y³)
        // for y ≥ 0 (Abramowitz & Stegun 4.4.45), mirrored for y < 0
        let len = d.length();
        let y = if len > 0.0 {
            (d.y / len).clamp(-1.0, 1.0)
        } else {
            0.0
        };
        let ay = y.abs();
        let a = (1.0 - ay).sqrt()
            * (1.570_728_8 + ay * (-0.212_114_4 + ay * (0.074_261 - 0.018_729_3 * ay)));
        let theta = if y < 0.0 { PI - a } else { a };
        let (w, h) = (self.width, self.height);
        let mut u = phi * (0.5 / PI) - 0.5 / to_f32(w);
        if u < 0.0 {
            u += 1.0;
        }
        // (`as i32` of NaN is 0: a degenerate direction still gives a texel in the map)
        let px = ((u * to_f32(w)) as i32).clamp(0, w as i32 - 1) as usize;
        let py = ((theta * (1.0 / PI) * to_f32(h - 1)) as i32).clamp(0, h as i32 - 2) as usize;
        py * (w + 1) + px
    }

    /// Radiance arriving from world direction `d`.
    pub fn eval(&self, d_world: Vec3) -> Rgb {
        match self.lookup(d_world) {
            Some(l) => self.eval_at(l),
            None => Rgb::ZERO,
        }
    }

    /// [`Envmap::eval`] and [`Envmap::pdf`] together (one lat-long conversion, and the pdf
    /// from the texels the radiance reads).
    pub fn eval_pdf(&self, d_world: Vec3) -> (Rgb, f32) {
        match self.lookup(d_world) {
            Some(l) => self.eval_pdf_at(l),
            None => (Rgb::ZERO, 0.0),
        }
    }

    /// Where the lookups from world direction `d_world` read: its bilinear cell and weights
    /// (None for a zero direction). [`Envmap::eval_at`] and [`Envmap::eval_pdf_at`] finish
    /// them, so a caller that finds the cell before it knows whether the ray escapes (to
    /// prefetch its texels, see [`Envmap::prefetch_lookup`]) does not compute it twice.
    #[inline]
    pub fn lookup(&self, d_world: Vec3) -> Option<Lookup> {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return None;
        }
        let (j, cell, w1) = self.bilinear_cell_in_row(Self::direction_to_uv(d));
        Some(Lookup {
            cell,
            w1,
            s: self.band_fraction(j, d.y),
        })
    }

    /// [`Envmap::eval`] of a [`Envmap::lookup`].
    #[inline]
    pub fn eval_at(&self, l: Lookup) -> Rgb {
        self.interpolate(l.cell, l.w1)
    }

    /// [`Envmap::eval_pdf`] of a [`Envmap::lookup`].
    #[inline]
    pub fn eval_pdf_at(&self, l: Lookup) -> (Rgb, f32) {
        (
            self.interpolate(l.cell, l.w1),
            self.pdf_in_cell(l.cell, l.w1.x, l.s),
        )
    }

    /// Solid-angle pdf of [`Envmap::sample`]: the density shares of the bilinear lookup's
    /// cell, interpolated at the direction (see the module docs).
    pub fn pdf(&self, d_world: Vec3) -> f32 {
        let d = self.local(d_world);
        if d == Vec3::ZERO {
            return 0.0;
        }
        let (j, cell, w1) = self.bilinear_cell_in_row(Self::direction_to_uv(d));
        self.pdf_in_cell(cell, w1.x, self.band_fraction(j, d.y))
    }

    /// Importance-samples a direction (see the module documentation).
    pub fn sample(&self, u: Vec2) -> Option<DirectionSample> {
        let (w, h) = (self.width, self.height);
        if self.row_cdf[h - 1] != 1.0 {
            return None; // black (or non-finite) map
        }
        let (j, sv) = guide::sample::<false>(&self.row_cdf, &self.row_guide, u.y);
        let g = guide::buckets(w, guide::COL_BINS) + 1;
        let (i, su) = guide::sample::<true>(
            &self.col_cdf[j * (w + 1)..(j + 1) * (w + 1)],
            &self.col_guide[j * g..(j + 1) * g],
            u.x,
        );
        // the cell's four texels, read once: their density shares place the point inside
        // the cell, and their colours give its radiance
        let texels = self.cell_texels(j * (w + 1) + i);
        let corners = texels.map(|t| t.w);
        // inside the cell, (x, s) (fractions of its width and of its band's cos θ) from the
        // bilinear interpolation of its corners' densities: s from the marginal, linear
        // between the top and bottom edges' sums, then x from the row at s
        let [d00, d10, d01, d11] = corners;
        let sf = sample_linear(sv, d00 + d10, d01 + d11);
        let xf = sample_linear(su, d00 + (d01 - d00) * sf, d10 + (d11 - d10) * sf);
        let pdf = bilerp(corners, xf, sf);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        // u of the lat-long map (φ / 2π, a half texel on from the cell's corner) and cos θ
        let x = (to_f32(i) + xf + 0.5) / to_f32(w);
        let (c0, c1) = (self.cos_theta[j], self.cos_theta[j + 1]);
        let cos_t = c0 + (c1 - c0) * sf;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        let (sin_p, cos_p) = specula_bsdf::math::sincos_2pi(x);
        let d_local = Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p);
        let wi = (self.to_world * d_local).normalize();
        // the radiance at the sampled point: the bilinear lookup in the same cell, whose
        // weights are the point's fractions of the cell's width (xf) and of its height in θ
        // (the lookup's coordinate, v = θ/π), clamped against rounding at the cell's edges
        let theta = specula_bsdf::math::acos(cos_t.clamp(-1.0, 1.0));
        let wy = (theta * (to_f32(h - 1) / PI) - to_f32(j)).clamp(0.0, 1.0);
        Some(DirectionSample {
            wi,
            dist: f32::INFINITY,
            radiance: self.interpolate_texels(texels, Vec2::new(xf, wy)),
            pdf,
            is_delta: false,
        })
    }
}
