//! The film: Mitsuba 3's reconstruction filters, image blocks that samples are splatted into,
//! and the weighted average that develops them.
//!
//! Conventions (Mitsuba 3.9.1, checked with its Python bindings and `ImageBlock::put`):
//! - film positions are continuous pixel coordinates: pixel (i, j) spans [i, i+1) × [j, j+1);
//! - a sample at x contributes to every pixel i whose centre lies within the filter radius,
//!   with weight filter(i + ½ − x) (separably in x and y); the box filter is special-cased: the
//!   sample goes, with weight 1, to the one pixel containing it;
//! - blocks carry a border of ⌈radius − ½⌉ pixels so that splats spill into neighbouring
//!   tiles; what falls outside the film is discarded;
//! - the developed pixel is Σ w·L / Σ w (0 where Σ w = 0).
//!
//! The JIT variants (`llvm_ad_rgb`, which rendered the references) evaluate the filter
//! exactly; the scalar variants use a 31-entry table (`eval_discretized`) instead.
//!
//! Limits (Specula refuses larger or invalid values with an error; Mitsuba has none):
//! - a film has at most [`MAX_FILM_PIXELS`] pixels (8192 × 8192; 16 bytes each while
//!   rendering) and at most [`MAX_FILM_SIDE`] pixels per side ([`check_film_size`]);
//! - a Gaussian's `stddev` lies in [[`MIN_GAUSSIAN_STDDEV`], [`MAX_GAUSSIAN_STDDEV`]] (radius
//!   at most 32 pixels: a wider filter splats every sample into millions of pixels, a
//!   narrower one overflows the kernel's coefficients) ([`RFilter::gaussian_checked`]);
//! - a developed pixel whose sums overflowed `f32` (radiance near 3.4e38) is not written as
//!   ±∞: [`Film::develop`] reports how many there were (see `render::RenderOutput`).

use crate::core::to_f32;
use glam::{Vec2, Vec4};
use specula_bsdf::Rgb;

/// Remez fit to exp(−y/2) on y ∈ [0, 16] (y = x²/σ²): Mitsuba 3's Gaussian filter kernel on
/// CPUs.
const GAUSSIAN_REMEZ: [f64; 10] = [
    9.992604880e-1,
    -4.977025247e-1,
    1.222248550e-1,
    -1.932406282e-2,
    2.136713061e-3,
    -1.679873860e-4,
    9.202145248e-6,
    -3.329417433e-7,
    7.128382794e-9,
    -6.821193280e-11,
];

#[inline]
fn poly(x: f32, c: &[f32; 10]) -> f32 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci)
}

/// A reconstruction filter, as Mitsuba 3 defines it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RFilter {
    /// `box`: radius ½, weight 1 on [−½, ½).
    Box,
    /// `tent`: radius 1, weight 1 − |x|.
    Tent,
    /// `gaussian`: radius 4σ, exp(−x²/2σ²) shifted down to reach 0 at the radius (Mitsuba's
    /// polynomial approximation of it). Build with [`RFilter::gaussian`].
    Gaussian { stddev: f32, coeff: [f32; 10] },
}

impl Default for RFilter {
    /// Mitsuba's default: a Gaussian with σ = 0.5.
    fn default() -> Self {
        RFilter::default_gaussian()
    }
}

/// The most pixels a film may have (8192 × 8192).
pub const MAX_FILM_PIXELS: usize = 8192 * 8192;
/// The most pixels a film side may have.
pub const MAX_FILM_SIDE: usize = 1 << 16;
/// The smallest Gaussian `stddev` (pixels): the kernel's coefficients scale as σ⁻¹⁸ and
/// overflow `f32` below about 0.008.
pub const MIN_GAUSSIAN_STDDEV: f32 = 0.01;
/// The largest Gaussian `stddev` (pixels): radius 4σ = 32 pixels.
pub const MAX_GAUSSIAN_STDDEV: f32 = 8.0;

/// Checks a film size against [`MAX_FILM_SIDE`] and [`MAX_FILM_PIXELS`]; the error names the
/// size and the limit.
pub fn check_film_size(width: i64, height: i64) -> Result<(), String> {
    if width <= 0 || height <= 0 {
        return Err(format!("invalid film size {width}×{height}"));
    }
    if width > MAX_FILM_SIDE as i64 || height > MAX_FILM_SIDE as i64 {
        return Err(format!(
            "film size {width}×{height}: a side may have at most {MAX_FILM_SIDE} pixels"
        ));
    }
    let pixels = width as u64 * height as u64;
    if pixels > MAX_FILM_PIXELS as u64 {
        return Err(format!(
            "film size {width}×{height} ({pixels} pixels): at most {MAX_FILM_PIXELS} pixels \
             (8192×8192) are supported"
        ));
    }
    Ok(())
}

impl RFilter {
    /// [`RFilter::gaussian`] for a `stddev` from a scene: finite and within
    /// [[`MIN_GAUSSIAN_STDDEV`], [`MAX_GAUSSIAN_STDDEV`]], or an error naming the limits.
    pub fn gaussian_checked(stddev: f32) -> Result<Self, String> {
        if (MIN_GAUSSIAN_STDDEV..=MAX_GAUSSIAN_STDDEV).contains(&stddev) {
            return Ok(RFilter::gaussian(stddev));
        }
        Err(format!(
            "gaussian: 'stddev' is {stddev}; it must lie in \
             [{MIN_GAUSSIAN_STDDEV}, {MAX_GAUSSIAN_STDDEV}] pixels (radius 4·stddev at most 32)"
        ))
    }

    /// Mitsuba's `gaussian` with standard deviation `stddev` (pixels).
    pub fn gaussian(stddev: f32) -> Self {
        let radius = 4.0 * stddev;
        let mut coeff = [0f32; 10];
        let mut scale = 1f64;
        for (c, r) in coeff.iter_mut().zip(GAUSSIAN_REMEZ) {
            *c = (r * scale) as f32;
            scale /= (stddev as f64) * (stddev as f64);
        }
        // Make the kernel reach exactly zero at the radius.
        coeff[0] -= poly(radius * radius, &coeff);
        RFilter::Gaussian { stddev, coeff }
    }

    /// The Gaussian with σ = 0.5 (what an `hdrfilm` without an `rfilter` uses).
    pub fn default_gaussian() -> Self {
        RFilter::gaussian(0.5)
    }

    pub fn radius(&self) -> f32 {
        match self {
            RFilter::Box => 0.5,
            RFilter::Tent => 1.0,
            RFilter::Gaussian { stddev, .. } => 4.0 * stddev,
        }
    }

    /// Pixels a block needs around its interior: ⌈radius − ½⌉ (0 for the box filter).
    pub fn border_size(&self) -> usize {
        match self {
            RFilter::Box => 0,
            _ => (self.radius() - 0.5).ceil().max(0.0) as usize,
        }
    }

    /// The (unnormalised) filter weight at offset `x` pixels.
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        match self {
            RFilter::Box => {
                if (-0.5..0.5).contains(&x) {
                    1.0
                } else {
                    0.0
                }
            }
            RFilter::Tent => (1.0 - x.abs()).max(0.0),
            RFilter::Gaussian { coeff, .. } => poly(x * x, coeff).max(0.0),
        }
    }

    /// `eval((x.0 + i) − x.1)` for i = 0..4 in lanes 0..4 and `eval((y.0 + i) − y.1)` in lanes
    /// 4..8: [`RFilter::eval8`]'s lanes for two axes of 4 taps each.
    #[inline(always)]
    fn eval_xy4(&self, x: (f32, f32), y: (f32, f32)) -> [f32; 8] {
        let mut d = [0f32; 8];
        for i in 0..4 {
            d[i] = (x.0 + i as f32) - x.1;
            d[i + 4] = (y.0 + i as f32) - y.1;
        }
        self.eval_lanes(d)
    }

    /// `eval((first + i) − p)` for i = 0..8, computed lane by lane as [`RFilter::eval`]
    /// computes it (bit-identical weights), in a form the compiler vectorises.
    #[inline(always)]
    fn eval8(&self, first: f32, p: f32) -> [f32; 8] {
        let mut x = [0f32; 8];
        for (i, v) in x.iter_mut().enumerate() {
            // first + i is an exact integer, as (x0 + i) as f32 is
            *v = (first + i as f32) - p;
        }
        self.eval_lanes(x)
    }

    /// `eval` of each of 8 offsets, lane by lane (bit-identical to [`RFilter::eval`]), in a
    /// form the compiler vectorises.
    #[inline(always)]
    fn eval_lanes(&self, x: [f32; 8]) -> [f32; 8] {
        match self {
            RFilter::Gaussian { coeff, .. } => {
                let x2 = x.map(|x| x * x);
                // poly's Horner scheme: acc = 0 · x² + c₉, then acc · x² + cₖ
                let mut acc = [0f32; 8];
                for &c in coeff.iter().rev() {
                    for (a, &y) in acc.iter_mut().zip(&x2) {
                        *a = *a * y + c;
                    }
                }
                acc.map(|a| a.max(0.0))
            }
            _ => x.map(|x| self.eval(x)),
        }
    }
}

/// ⌊x⌋ of a finite `x` (|x| < 2⁶³) without a library call (x86-64's baseline has no
/// rounding instruction): truncation, one lower where it rounded up.
#[inline(always)]
fn floor_i64(x: f32) -> i64 {
    let i = x as i64;
    i - ((i as f32) > x) as i64
}

/// ⌈x⌉ of a finite `x` (|x| < 2⁶³), as [`floor_i64`].
#[inline(always)]
fn ceil_i64(x: f32) -> i64 {
    let i = x as i64;
    i + ((i as f32) < x) as i64
}

/// (r, g, b, 1): a sample's value and its unit weight, scaled together by the filter weight.
#[inline(always)]
fn rgb1(v: Rgb) -> Vec4 {
    Vec4::new(v.0[0], v.0[1], v.0[2], 1.0)
}

/// Most filter taps per axis kept on the stack (radius up to 31.5 pixels); wider filters
/// evaluate their x weights on the fly.
const MAX_TAPS: usize = 64;

/// A rectangle of film pixels (plus a border) that samples are splatted into. Each block is
/// filled by one thread and later merged into the [`Film`].
#[derive(Clone, Debug, PartialEq)]
pub struct ImageBlock {
    /// Film pixel of the interior's top-left corner.
    pub offset: (usize, usize),
    /// Interior size in pixels.
    pub size: (usize, usize),
    /// Extra pixels stored on every side.
    pub border: usize,
    pub filter: RFilter,
    /// (Σ w·r, Σ w·g, Σ w·b, Σ w) per stored pixel ((size + 2·border) pixels, row-major): one
    /// vector operation per pixel a sample touches.
    pub data: Vec<Vec4>,
}

impl ImageBlock {
    pub fn new(offset: (usize, usize), size: (usize, usize), filter: RFilter) -> Self {
        let border = filter.border_size();
        let n = (size.0 + 2 * border) * (size.1 + 2 * border);
        ImageBlock {
            offset,
            size,
            border,
            filter,
            data: vec![Vec4::ZERO; n],
        }
    }

    /// Stored width and height (interior plus border).
    #[inline]
    pub fn stored_size(&self) -> (usize, usize) {
        (self.size.0 + 2 * self.border, self.size.1 + 2 * self.border)
    }

    /// Zeroes the accumulated values.
    pub fn clear(&mut self) {
        self.data.fill(Vec4::ZERO);
    }

    /// Σ w per stored pixel (row-major).
    pub fn weights(&self) -> Vec<f32> {
        self.data.iter().map(|d| d.w).collect()
    }

    #[inline]
    fn add(&mut self, index: usize, v: Vec4, w: f32) {
        self.data[index] += v * w;
    }

    /// Splats a sample taken at continuous film position `film_pos` (pixel (i, j) spans
    /// [i, i+1) × [j, j+1)). Pixels outside the stored area are skipped. Allocation-free.
    #[inline]
    pub fn put(&mut self, film_pos: Vec2, value: Rgb) {
        self.put_weighted(film_pos, value, 1.0);
    }

    /// [`ImageBlock::put`] with the sample's weight scaled by `weight` (its value and its
    /// contribution to Σ w alike): adaptive sampling weights a pixel's samples by the inverse
    /// of their number, so that every pixel's samples weigh the same in total.
    #[inline]
    pub fn put_weighted(&mut self, film_pos: Vec2, value: Rgb, weight: f32) {
        if !film_pos.is_finite() {
            return;
        }
        let v = rgb1(value) * weight;
        if let RFilter::Box = self.filter {
            // the one pixel holding the sample (here, not out of line: most scenes' filter)
            let x = floor_i64(film_pos.x) - self.offset.0 as i64;
            let y = floor_i64(film_pos.y) - self.offset.1 as i64;
            if x >= 0 && y >= 0 && (x as usize) < self.size.0 && (y as usize) < self.size.1 {
                // (weight 1: v · 1 is v)
                let ew = self.stored_size().0;
                self.data[y as usize * ew + x as usize] += v;
            }
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if let RFilter::Gaussian { .. } = self.filter {
            if std::arch::is_x86_feature_detected!("avx2")
                // SAFETY: AVX2 is present.
                && unsafe { self.put_gaussian4x4_avx2(film_pos, v) }
            {
                return;
            }
        }
        self.put_any(film_pos, v);
    }

    /// [`ImageBlock::put_weighted`] of the value-and-weight vector `v` for the filters with
    /// a footprint of several pixels (every footprint).
    #[inline(never)]
    fn put_any(&mut self, film_pos: Vec2, v: Vec4) {
        let (ew, eh) = self.stored_size();
        let r = self.filter.radius();
        // Position relative to the stored area's pixel centres.
        // (through u32: one conversion instruction where usize → f32 takes a dozen; the
        // same values, offsets being below `MAX_FILM_SIDE` and borders at most 32)
        let b = to_f32(self.border);
        let px = film_pos.x + (b - to_f32(self.offset.0) - 0.5);
        let py = film_pos.y + (b - to_f32(self.offset.1) - 0.5);
        let x0 = ceil_i64(px - r).max(0);
        let y0 = ceil_i64(py - r).max(0);
        let x1 = floor_i64(px + r).min(ew as i64 - 1);
        let y1 = floor_i64(py + r).min(eh as i64 - 1);
        if x0 > x1 || y0 > y1 {
            return;
        }
        let nx = (x1 - x0 + 1) as usize;
        let ny = (y1 - y0 + 1) as usize;
        let taps = (px, py, x0 as usize, y0 as usize, nx, ny);
        if nx <= 4 && ny <= 4 {
            // the commonest case (Mitsuba's default Gaussian, σ = 0.5, radius 2: 4 × 4 taps
            // unless a sample lies exactly on a pixel's edge): both axes' weights at once
            self.put_taps4(taps, v);
        } else if nx <= 8 && ny <= 8 {
            // Gaussians up to σ = 0.875: 8 weights per axis at once
            self.put_taps8(taps, v);
        } else if nx <= MAX_TAPS && ny <= MAX_TAPS {
            self.put_taps::<MAX_TAPS>(taps, v);
        } else {
            self.put_wide(px, py, (x0, y0, x1, y1), v);
        }
    }

    /// [`Self::put_taps`] for up to 4 × 4 pixels: the 4 x and 4 y weights are evaluated
    /// together as one 8-lane polynomial (the same operations as [`RFilter::eval`], so the same
    /// weights bit for bit), then each pixel takes one vector multiply-add. Exactly 4 × 4 (a
    /// sample away from the block's edges) goes through fixed-size rows with one bounds check
    /// for the whole square (the same operations per pixel, so the same sums).
    #[inline(always)]
    fn put_taps4(
        &mut self,
        (px, py, x0, y0, nx, ny): (f32, f32, usize, usize, usize, usize),
        v: Vec4,
    ) {
        let ew = self.stored_size().0;
        let w = self.filter.eval_xy4((x0 as f32, px), (y0 as f32, py));
        let (wx, wy) = w.split_at(4);
        if nx == 4 && ny == 4 {
            let first = y0 * ew + x0;
            let square = &mut self.data[first..first + 3 * ew + 4];
            for (k, &wy) in wy.iter().enumerate() {
                if wy == 0.0 {
                    continue;
                }
                let row: &mut [Vec4; 4] = (&mut square[k * ew..k * ew + 4]).try_into().unwrap();
                for (d, &w) in row.iter_mut().zip(wx) {
                    *d += v * (w * wy);
                }
            }
            return;
        }
        for (k, &wy) in wy[..ny].iter().enumerate() {
            if wy == 0.0 {
                continue;
            }
            let row = (y0 + k) * ew + x0;
            for (d, &w) in self.data[row..row + nx].iter_mut().zip(&wx[..nx]) {
                *d += v * (w * wy);
            }
        }
    }

    /// [`ImageBlock::put_any`]'s commonest case, a Gaussian footprint of exactly 4 × 4 stored
    /// pixels (Mitsuba's default, σ = 0.5, radius 2, away from a block's edges), with AVX2:
    /// the same operations in the same order as [`Self::put_taps4`] (no fused multiply-adds),
    /// so the same sums bit for bit, in 8-lane registers. The footprint's corners are rounded
    /// with `roundps` (⌈px − r⌉ and ⌊px + r⌋ exactly as `ceil_i64`/`floor_i64` give them); the
    /// weights of both axes are one 8-lane Horner evaluation; each row multiplies the 4 x
    /// weights by its y weight (as `w * wy`), spreads each product over a pixel's 4 channels
    /// and adds `v` times it to the row's 4 pixels (two 8-lane operations). Returns false,
    /// having changed nothing, for any other footprint (cut by the block's edges, 5 wide for a
    /// sample on a pixel edge, wider filters, positions beyond ±2²⁴).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn put_gaussian4x4_avx2(&mut self, film_pos: Vec2, v: Vec4) -> bool {
        use std::arch::x86_64::*;
        let RFilter::Gaussian { coeff, .. } = &self.filter else {
            return false;
        };
        let r = self.filter.radius();
        // (through u32: one conversion instruction where usize → f32 takes a dozen; the
        // same values, offsets being below `MAX_FILM_SIDE` and borders at most 32)
        let b = to_f32(self.border);
        let px = film_pos.x + (b - to_f32(self.offset.0) - 0.5);
        let py = film_pos.y + (b - to_f32(self.offset.1) - 0.5);
        if !(px.abs() < 16_777_216.0 && py.abs() < 16_777_216.0) {
            return false;
        }
        // (⌈px − r⌉, ⌈py − r⌉, ⌊px + r⌋, ⌊py + r⌋), integers below 2²⁵ in magnitude
        let e = _mm_setr_ps(px - r, py - r, px + r, py + r);
        let up = _mm_round_ps::<{ _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC }>(e);
        let down = _mm_round_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(e);
        let corners = _mm_blend_ps::<0b1100>(up, down);
        let mut c = [0i32; 4];
        _mm_storeu_si128(c.as_mut_ptr() as *mut __m128i, _mm_cvttps_epi32(corners));
        let [x0, y0, x1, y1] = c;
        let (ew, eh) = self.stored_size();
        if x0 < 0
            || y0 < 0
            || x1 - x0 != 3
            || y1 - y0 != 3
            || x1 as usize >= ew
            || y1 as usize >= eh
        {
            return false;
        }
        let first = y0 as usize * ew + x0 as usize;
        let square = &mut self.data[first..first + 3 * ew + 4];
        // d = (first + i) − p, lanes 0–3 for x, 4–7 for y
        let (fx, fy) = (x0 as f32, y0 as f32);
        let origin = _mm256_setr_ps(fx, fx, fx, fx, fy, fy, fy, fy);
        let p = _mm256_setr_ps(px, px, px, px, py, py, py, py);
        let i = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 0.0, 1.0, 2.0, 3.0);
        let d = _mm256_sub_ps(_mm256_add_ps(origin, i), p);
        let d2 = _mm256_mul_ps(d, d);
        let mut acc = _mm256_setzero_ps();
        for &c in coeff.iter().rev() {
            acc = _mm256_add_ps(_mm256_mul_ps(acc, d2), _mm256_set1_ps(c));
        }
        // f32::max(a, 0) for the finite values a polynomial of |d| ≤ 3 gives
        let w = _mm256_max_ps(acc, _mm256_setzero_ps());
        let wx = _mm256_permute2f128_ps::<0x00>(w, w);
        let mut wy = [0f32; 8];
        _mm256_storeu_ps(wy.as_mut_ptr(), w);
        let vv = {
            let v: __m128 = v.into();
            _mm256_set_m128(v, v)
        };
        let lo = _mm256_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1);
        let hi = _mm256_setr_epi32(2, 2, 2, 2, 3, 3, 3, 3);
        let base = square.as_mut_ptr() as *mut f32;
        for (k, &wyk) in wy[4..].iter().enumerate() {
            if wyk == 0.0 {
                continue;
            }
            let pw = _mm256_mul_ps(wx, _mm256_set1_ps(wyk));
            // SAFETY: row k's 4 pixels (16 floats) lie inside `square`
            let row = base.add(4 * k * ew);
            let a = _mm256_add_ps(
                _mm256_loadu_ps(row),
                _mm256_mul_ps(vv, _mm256_permutevar8x32_ps(pw, lo)),
            );
            let b = _mm256_add_ps(
                _mm256_loadu_ps(row.add(8)),
                _mm256_mul_ps(vv, _mm256_permutevar8x32_ps(pw, hi)),
            );
            _mm256_storeu_ps(row, a);
            _mm256_storeu_ps(row.add(8), b);
        }
        true
    }

    /// [`Self::put_taps`] for up to 8 × 8 pixels: the 8 weights of each axis are evaluated
    /// together (the same operations as [`RFilter::eval`], so the same weights bit for bit,
    /// in vector registers), then each pixel takes one vector multiply-add.
    #[inline(always)]
    fn put_taps8(
        &mut self,
        (px, py, x0, y0, nx, ny): (f32, f32, usize, usize, usize, usize),
        v: Vec4,
    ) {
        let ew = self.stored_size().0;
        let wx = self.filter.eval8(x0 as f32, px);
        let wy = self.filter.eval8(y0 as f32, py);
        for (k, &wy) in wy[..ny].iter().enumerate() {
            if wy == 0.0 {
                continue;
            }
            let row = (y0 + k) * ew + x0;
            for (d, &w) in self.data[row..row + nx].iter_mut().zip(&wx[..nx]) {
                *d += v * (w * wy);
            }
        }
    }

    /// Splats `value` at (`px`, `py`) (relative to the stored pixel centres) into the
    /// `nx` × `ny` ≤ `N` × `N` stored pixels from (`x0`, `y0`): the weights of both axes
    /// first (independent polynomial evaluations), then the rows, with one bounds check per
    /// row. A zero weight adds nothing, so it is not skipped.
    #[inline(always)]
    fn put_taps<const N: usize>(
        &mut self,
        (px, py, x0, y0, nx, ny): (f32, f32, usize, usize, usize, usize),
        v: Vec4,
    ) {
        let ew = self.stored_size().0;
        let mut wx = [0f32; N];
        let mut wy = [0f32; N];
        for (i, w) in wx[..nx].iter_mut().enumerate() {
            *w = self.filter.eval((x0 + i) as f32 - px);
        }
        for (i, w) in wy[..ny].iter_mut().enumerate() {
            *w = self.filter.eval((y0 + i) as f32 - py);
        }
        for (k, &wy) in wy[..ny].iter().enumerate() {
            if wy == 0.0 {
                continue;
            }
            let row = (y0 + k) * ew + x0;
            for (d, &w) in self.data[row..row + nx].iter_mut().zip(&wx[..nx]) {
                *d += v * (w * wy);
            }
        }
    }

    /// [`ImageBlock::put`] for filters wider than [`MAX_TAPS`] pixels: weights evaluated as
    /// they are used.
    #[cold]
    fn put_wide(&mut self, px: f32, py: f32, (x0, y0, x1, y1): (i64, i64, i64, i64), v: Vec4) {
        let ew = self.stored_size().0;
        for y in y0..=y1 {
            let wy = self.filter.eval(y as f32 - py);
            if wy == 0.0 {
                continue;
            }
            let row = y as usize * ew;
            for x in x0..=x1 {
                let w = self.filter.eval(x as f32 - px);
                if w != 0.0 {
                    self.add(row + x as usize, v, w * wy);
                }
            }
        }
    }
}

/// The image being rendered: accumulated Σ w·rgb and Σ w per pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: usize,
    pub height: usize,
    pub filter: RFilter,
    sum: Vec<f32>,
    weight: Vec<f32>,
}

impl Film {
    pub fn new(width: usize, height: usize, filter: RFilter) -> Self {
        Film {
            width,
            height,
            filter,
            sum: vec![0.0; 3 * width * height],
            weight: vec![0.0; width * height],
        }
    }

    /// An empty block for the pixels [x0, x0 + w) × [y0, y0 + h), with the border the filter
    /// needs.
    pub fn new_block(&self, x0: usize, y0: usize, w: usize, h: usize) -> ImageBlock {
        ImageBlock::new((x0, y0), (w, h), self.filter)
    }

    /// Adds a block's contents (border included) to the film; what lies outside the film is
    /// dropped. Merging blocks in a fixed order makes the result deterministic.
    pub fn merge(&mut self, block: &ImageBlock) {
        let (ew, eh) = block.stored_size();
        let ox = block.offset.0 as i64 - block.border as i64;
        let oy = block.offset.1 as i64 - block.border as i64;
        for by in 0..eh {
            let fy = oy + by as i64;
            if fy < 0 || fy >= self.height as i64 {
                continue;
            }
            for bx in 0..ew {
                let fx = ox + bx as i64;
                if fx < 0 || fx >= self.width as i64 {
                    continue;
                }
                let d = block.data[by * ew + bx];
                let fi = fy as usize * self.width + fx as usize;
                for (c, v) in [d.x, d.y, d.z].into_iter().enumerate() {
                    self.sum[3 * fi + c] += v;
                }
                self.weight[fi] += d.w;
            }
        }
    }

    /// Zeroes the accumulated values.
    pub fn clear(&mut self) {
        self.sum.fill(0.0);
        self.weight.fill(0.0);
    }

    /// Σ w per pixel (row-major).
    pub fn weights(&self) -> &[f32] {
        &self.weight
    }

    /// The image: linear RGB per pixel, row-major, top row first; Σ w·rgb / Σ w, or 0 where
    /// no sample landed (and where the sums overflowed: see [`Film::develop_counting`]).
    pub fn develop(&self) -> Vec<f32> {
        self.develop_counting().0
    }

    /// [`Film::develop`], and how many pixels overflowed. Samples are finite, but their sums
    /// can still overflow `f32` (values near 3.4e38): such a pixel is black in the image and
    /// counted here, so that the caller reports it instead of writing ±∞ or NaN.
    pub fn develop_counting(&self) -> (Vec<f32>, usize) {
        let mut out = vec![0.0f32; 3 * self.width * self.height];
        let mut overflowed = 0;
        for (i, &w) in self.weight.iter().enumerate() {
            if w != 0.0 {
                let inv = 1.0 / w;
                let px = &mut out[3 * i..3 * i + 3];
                for (v, s) in px.iter_mut().zip(&self.sum[3 * i..3 * i + 3]) {
                    *v = s * inv;
                }
                if !(w.is_finite() && px.iter().all(|v| v.is_finite())) {
                    px.fill(0.0);
                    overflowed += 1;
                }
            }
        }
        (out, overflowed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use specula_bsdf::rng::Pcg32;
    use std::f32::consts::FRAC_PI_2;

    #[test]
    fn filters_match_mitsuba() {
        // Mitsuba 3.9.1 rfilter.radius(), border_size() and rfilter.eval(x).
        assert_eq!(RFilter::Box.radius(), 0.5);
        assert_eq!(RFilter::Tent.radius(), 1.0);
        assert_eq!(RFilter::default_gaussian().radius(), 2.0);
        assert_eq!(RFilter::Box.border_size(), 0);
        assert_eq!(RFilter::Tent.border_size(), 1);
        assert_eq!(RFilter::default_gaussian().border_size(), 2);
        let b = RFilter::Box;
        assert_eq!(
            [
                b.eval(-0.5),
                b.eval(0.0),
                b.eval(0.4999),
                b.eval(0.5),
                b.eval(0.75)
            ],
            [1.0, 1.0, 1.0, 0.0, 0.0]
        );
        let t = RFilter::Tent;
        for (x, want) in [
            (0.0, 1.0),
            (0.1, 0.9),
            (0.25, 0.75),
            (0.75, 0.25),
            (1.0, 0.0),
            (1.5, 0.0),
        ] {
            assert!((t.eval(x) - want).abs() < 1e-6);
        }
        let g = RFilter::default_gaussian();
        let cases = [
            (0.0, 0.999_247_1),
            (0.1, 0.979_533_3),
            (0.25, 0.882_166_7),
            (0.5, 0.606_423),
            (0.75, 0.324_242_56),
            (1.0, 0.134_960_49),
            (1.5, 0.010_758_21),
            (1.99, 2.973_749_5e-5),
        ];
        for (x, want) in cases {
            assert!(
                (g.eval(x) - want).abs() < 2e-6,
                "{x}: {} vs {want}",
                g.eval(x)
            );
            assert_eq!(g.eval(x), g.eval(-x));
        }
        assert!(g.eval(2.0).abs() < 1e-5 && g.eval(2.01) == 0.0 && g.eval(5.0) == 0.0);
    }

    #[test]
    fn floor_and_ceil_without_libm() {
        let mut rng = Pcg32::new(1, 4);
        let mut xs = vec![
            0.0,
            -0.0,
            1.0,
            -1.0,
            2.5,
            -2.5,
            1e-30,
            -1e-30,
            0.999_999_9,
            -0.999_999_9,
        ];
        xs.extend((0..10_000).map(|_| (rng.next_f32() - 0.5) * 3e5));
        xs.extend((0..10_000).map(|_| (rng.next_f32() - 0.5) * 8.0));
        for x in xs {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
            assert_eq!(ceil_i64(x), x.ceil() as i64, "{x}");
        }
    }

    #[test]
    fn eight_weights_at_once_equal_eval() {
        let mut rng = Pcg32::new(5, 9);
        for f in [
            RFilter::default_gaussian(),
            RFilter::gaussian(0.3),
            RFilter::gaussian(0.875),
            RFilter::Tent,
        ] {
            for _ in 0..1000 {
                let first = (rng.next_f32() * 300.0).floor();
                let p = first + rng.next_f32() * 4.0;
                let w = f.eval8(first, p);
                for (i, &w) in w.iter().enumerate() {
                    assert_eq!(w.to_bits(), f.eval((first + i as f32) - p).to_bits());
                }
                let (fy, py) = (first + 7.0, first + 7.0 + rng.next_f32() * 4.0);
                let w = f.eval_xy4((first, p), (fy, py));
                for i in 0..4 {
                    assert_eq!(w[i].to_bits(), f.eval((first + i as f32) - p).to_bits());
                    assert_eq!(w[i + 4].to_bits(), f.eval((fy + i as f32) - py).to_bits());
                }
            }
        }
    }

    /// Every splat path (4 × 4, 8 × 8 and the general one) leaves each stored pixel exactly
    /// `value · (wx · wy)` with [`RFilter::eval`]'s weights, inside the block and where the
    /// footprint is cut by its edges.
    #[test]
    fn splats_are_the_product_of_eval_weights_bit_for_bit() {
        let mut rng = Pcg32::new(17, 4);
        for f in [
            RFilter::default_gaussian(),
            RFilter::gaussian(0.8),
            RFilter::gaussian(2.0),
        ] {
            let film = Film::new(24, 20, f);
            let mut b = film.new_block(4, 3, 12, 10);
            let (ew, _) = b.stored_size();
            let bo = b.border as f32;
            for _ in 0..300 {
                let p = Vec2::new(rng.next_f32() * 24.0, rng.next_f32() * 20.0);
                let v = Rgb::new(rng.next_f32(), 3.0, 0.25);
                b.clear();
                b.put(p, v);
                for (k, d) in b.data.iter().enumerate() {
                    // film coordinates of stored pixel k's centre (the block starts at film
                    // pixel (4, 3), its border before it)
                    let sx = (k % ew) as f32 + 0.5 - bo + 4.0;
                    let sy = (k / ew) as f32 + 0.5 - bo + 3.0;
                    let (px, py) = (p.x + (bo - 4.0 - 0.5), p.y + (bo - 3.0 - 0.5));
                    let wx = f.eval((k % ew) as f32 - px);
                    let wy = f.eval((k / ew) as f32 - py);
                    let want = if (sx - p.x).abs() <= f.radius() && (sy - p.y).abs() <= f.radius() {
                        rgb1(v) * (wx * wy)
                    } else {
                        Vec4::ZERO
                    };
                    assert_eq!(*d, want, "filter {f:?}, sample {p}, stored pixel {k}");
                }
            }
        }
    }

    /// The AVX2 4 × 4 Gaussian splat leaves every stored pixel with the same bits as the
    /// general path, for accumulated samples of any weight, and takes the footprints it should
    /// (exactly 4 × 4 inside the block) and no others.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_gaussian_splat_equals_the_general_path_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 here: nothing to compare");
            return;
        }
        let mut rng = Pcg32::new(5, 11);
        for sigma in [0.5, 0.45, 0.3, 0.8] {
            let f = RFilter::gaussian(sigma);
            let film = Film::new(40, 30, f);
            let mut fast = film.new_block(8, 6, 16, 12);
            let mut general = fast.clone();
            let (ew, eh) = fast.stored_size();
            let mut taken = 0;
            for k in 0..4000 {
                // positions over the whole film (most outside or across the block's edges
                // for the wider filters), some exactly on pixel edges
                let mut p = Vec2::new(rng.next_f32() * 40.0, rng.next_f32() * 30.0);
                if k % 7 == 0 {
                    p.x = p.x.floor();
                }
                let v = rgb1(Rgb::new(rng.next_f32() * 4.0, rng.next_f32(), 0.5))
                    * (0.25 + rng.next_f32());
                // SAFETY: AVX2 is present.
                if unsafe { fast.put_gaussian4x4_avx2(p, v) } {
                    taken += 1;
                    let r = f.radius();
                    let b = fast.border as f32;
                    let px = p.x + (b - 8.0 - 0.5);
                    let py = p.y + (b - 6.0 - 0.5);
                    let (x0, x1) = ((px - r).ceil(), (px + r).floor());
                    let (y0, y1) = ((py - r).ceil(), (py + r).floor());
                    assert!(x1 - x0 == 3.0 && y1 - y0 == 3.0 && x0 >= 0.0 && y0 >= 0.0);
                    assert!((x1 as usize) < ew && (y1 as usize) < eh);
                } else {
                    fast.put_any(p, v);
                }
                general.put_any(p, v);
            }
            for (a, b) in fast.data.iter().zip(&general.data) {
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits)
                );
            }
            if sigma == 0.5 {
                assert!(
                    taken > 500,
                    "σ = 0.5: only {taken} samples took the 4 × 4 path"
                );
            }
            if sigma == 0.8 {
                assert_eq!(taken, 0, "σ = 0.8 has no 4 × 4 footprints");
            }
        }
    }

    #[test]
    fn box_filter_gives_each_sample_to_its_pixel() {
        let mut film = Film::new(7, 5, RFilter::Box);
        let mut rng = Pcg32::new(3, 1);
        let mut want = [0.0f32; 7 * 5 * 3];
        let mut count = [0u32; 7 * 5];
        for _ in 0..2000 {
            let p = Vec2::new(rng.next_f32() * 7.0, rng.next_f32() * 5.0);
            let v = Rgb::new(rng.next_f32(), 2.0, p.x);
            let mut block = film.new_block(0, 0, 7, 5);
            assert_eq!(block.border, 0);
            block.put(p, v);
            let i = p.y as usize * 7 + p.x as usize;
            // Exactly one pixel receives the sample, with weight 1.
            assert_eq!(block.weights().iter().filter(|&&w| w != 0.0).count(), 1);
            assert_eq!(block.weights()[i], 1.0);
            film.merge(&block);
            for c in 0..3 {
                want[3 * i + c] += v[c];
            }
            count[i] += 1;
        }
        let img = film.develop();
        for i in 0..35 {
            for c in 0..3 {
                let w = want[3 * i + c] / count[i] as f32;
                assert!((img[3 * i + c] - w).abs() <= 1e-5 * w.abs().max(1.0));
            }
        }
        // Pixel boundaries: x = 3.0 belongs to pixel 3, x just below to pixel 2.
        let mut b = film.new_block(0, 0, 7, 5);
        b.put(Vec2::new(3.0, 0.5), Rgb::ONE);
        b.put(Vec2::new(2.9999998, 0.5), Rgb::ONE);
        assert_eq!((b.weights()[3], b.weights()[2]), (1.0, 1.0));
        // Outside the block: dropped.
        b.put(Vec2::new(7.0, 0.5), Rgb::ONE);
        b.put(Vec2::new(-0.1, 0.5), Rgb::ONE);
        b.put(Vec2::new(f32::NAN, 0.5), Rgb::ONE);
        assert_eq!(b.weights().iter().sum::<f32>(), 2.0);
    }

    #[test]
    fn splat_weights_follow_pixel_centres() {
        let f = RFilter::default_gaussian();
        let film = Film::new(16, 16, f);
        let mut b = film.new_block(4, 4, 8, 8);
        assert_eq!(b.border, 2);
        let p = Vec2::new(7.3, 9.8);
        b.put(p, Rgb::ONE);
        let (ew, _) = b.stored_size();
        for (k, &w) in b.weights().iter().enumerate() {
            let (sx, sy) = (k % ew, k / ew);
            // Film pixel of stored pixel (sx, sy).
            let (fx, fy) = (sx as f32 + 4.0 - 2.0, sy as f32 + 4.0 - 2.0);
            let want = f.eval(fx + 0.5 - p.x) * f.eval(fy + 0.5 - p.y);
            assert!((w - want).abs() < 1e-6, "pixel ({fx}, {fy}): {w} vs {want}");
        }
        // A filter wider than the on-stack weight cache (73 taps) gives the same weights.
        let f = RFilter::gaussian(9.0);
        let film = Film::new(8, 8, f);
        let mut b = film.new_block(0, 0, 8, 8);
        assert!(2 * b.border + 1 > MAX_TAPS);
        let p = Vec2::new(3.7, 4.2);
        b.put(p, Rgb::ONE);
        let (ew, _) = b.stored_size();
        let bo = b.border as f32;
        for (k, &w) in b.weights().iter().enumerate() {
            let (fx, fy) = ((k % ew) as f32 - bo, (k / ew) as f32 - bo);
            let want = f.eval(fx + 0.5 - p.x) * f.eval(fy + 0.5 - p.y);
            assert!((w - want).abs() < 1e-6);
        }
        // Tent: a sample at a pixel centre touches only that pixel; halfway between two
        // centres it splits evenly.
        let film = Film::new(4, 1, RFilter::Tent);
        let mut b = film.new_block(0, 0, 4, 1);
        b.put(Vec2::new(1.5, 0.5), Rgb::ONE);
        let ew = b.stored_size().0;
        assert_eq!(b.weights()[ew..2 * ew], [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]);
        b.clear();
        b.put(Vec2::new(2.0, 0.5), Rgb::ONE);
        assert_eq!(b.weights()[ew..2 * ew], [0.0, 0.0, 0.5, 0.5, 0.0, 0.0]);
    }

    #[test]
    fn gaussian_weights_normalise() {
        // A constant signal develops to the same constant wherever samples landed, and the
        // total weight a sample leaves on an unbounded lattice is nearly position independent.
        let f = RFilter::default_gaussian();
        let mut film = Film::new(12, 9, f);
        let mut rng = Pcg32::new(11, 2);
        let c = Rgb::new(0.25, 1.5, 7.0);
        let mut block = film.new_block(0, 0, 12, 9);
        for _ in 0..500 {
            block.put(Vec2::new(rng.next_f32() * 12.0, rng.next_f32() * 9.0), c);
        }
        film.merge(&block);
        let img = film.develop();
        for px in img.chunks(3) {
            for k in 0..3 {
                assert!((px[k] - c[k]).abs() < 1e-5 * c[k]);
            }
        }
        let mut totals = vec![];
        for _ in 0..200 {
            let film = Film::new(32, 32, f);
            let mut b = film.new_block(8, 8, 16, 16);
            b.put(
                Vec2::new(14.0 + rng.next_f32(), 14.0 + rng.next_f32()),
                Rgb::ONE,
            );
            totals.push(b.weights().iter().sum::<f32>());
        }
        let (lo, hi) = totals
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &t| (a.min(t), b.max(t)));
        // (∫ filter)² ≈ 2πσ² = π/2 for σ = 0.5; the lattice sum wobbles by about
        // ±2·exp(−2π²σ²) ≈ ±1.4 % per axis.
        assert!(
            (lo - FRAC_PI_2).abs() < 0.05 && (hi - FRAC_PI_2).abs() < 0.05,
            "{lo} {hi}"
        );
    }

    #[test]
    fn merged_tiles_equal_one_big_block() {
        for filter in [
            RFilter::Box,
            RFilter::Tent,
            RFilter::default_gaussian(),
            RFilter::gaussian(0.9),
        ] {
            let (w, h, tile) = (23, 17, 8);
            let mut rng = Pcg32::new(5, 7);
            let samples: Vec<(Vec2, Rgb)> = (0..3000)
                .map(|_| {
                    let p = Vec2::new(rng.next_f32() * w as f32, rng.next_f32() * h as f32);
                    (p, Rgb::new(rng.next_f32(), rng.next_f32() * 4.0, 1.0))
                })
                .collect();
            let mut whole = Film::new(w, h, filter);
            let mut big = whole.new_block(0, 0, w, h);
            for &(p, v) in &samples {
                big.put(p, v);
            }
            whole.merge(&big);
            let mut tiled = Film::new(w, h, filter);
            for ty in (0..h).step_by(tile) {
                for tx in (0..w).step_by(tile) {
                    let (bw, bh) = (tile.min(w - tx), tile.min(h - ty));
                    let mut b = tiled.new_block(tx, ty, bw, bh);
                    for &(p, v) in &samples {
                        // Each sample goes to the tile whose interior contains it.
                        if p.x as usize / tile == tx / tile && p.y as usize / tile == ty / tile {
                            b.put(p, v);
                        }
                    }
                    tiled.merge(&b);
                }
            }
            let (a, b) = (whole.develop(), tiled.develop());
            for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (x - y).abs() <= 1e-5 * x.abs().max(1.0),
                    "{filter:?} value {i}: {x} vs {y}"
                );
            }
            for (x, y) in whole.weights().iter().zip(tiled.weights()) {
                assert!((x - y).abs() <= 1e-5 * x.max(1.0));
            }
        }
    }

    #[test]
    fn empty_pixels_develop_to_zero() {
        let mut film = Film::new(3, 2, RFilter::Box);
        let mut b = film.new_block(0, 0, 3, 2);
        b.put(Vec2::new(0.5, 0.5), Rgb::splat(2.0));
        film.merge(&b);
        let img = film.develop();
        assert_eq!(&img[..6], &[2.0, 2.0, 2.0, 0.0, 0.0, 0.0]);
        assert!(img[6..].iter().all(|&v| v == 0.0));
    }
}
