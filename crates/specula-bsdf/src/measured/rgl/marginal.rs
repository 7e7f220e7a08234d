//! Continuous marginal/conditional warping of a bilinearly interpolated 2-D density on
//! \[0,1\]², optionally conditioned on `D` extra parameters (linear interpolation between
//! the slices where the density was tabulated). The same scheme as Mitsuba's
//! `Marginal2D<Float, D, Continuous = true>`: a continuous marginal CDF over rows, a
//! continuous conditional CDF within the chosen row, each inverted analytically on the
//! piecewise-linear segment (a quadratic), so the map is continuous and invertible.
//!
//! All tables are built once; `eval`, `sample` and `invert` do not allocate.

use glam::Vec2;

/// Data array of `slices × h × w` values (last index fastest) with the parameters it
/// depends on; see [`Marginal2D::new`].
#[derive(Clone, Debug)]
pub struct Marginal2D<const D: usize> {
    w: usize,
    h: usize,
    patch: Vec2,
    inv_patch: Vec2,
    params: [Vec<f32>; D],
    strides: [usize; D],
    data: Vec<f32>,
    marg_cdf: Vec<f32>,
    cond_cdf: Vec<f32>,
    normalized: bool,
}

/// Slice interpolation for one parameter value: up to 2^D (slice, weight) corners.
#[derive(Clone, Copy)]
struct Corners {
    slice: [usize; 8],
    weight: [f32; 8],
    n: usize,
}

impl Corners {
    #[inline]
    fn lookup(&self, table: &[f32], table_size: usize, idx: usize) -> f32 {
        let mut v = 0.0;
        for k in 0..self.n {
            v += self.weight[k] * table[self.slice[k] * table_size + idx];
        }
        v
    }
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// First index in `[start, end]` whose predicate is false (`end` if none), for a predicate
/// that is true on a prefix.
#[inline]
fn binary_search(mut start: usize, mut end: usize, pred: impl Fn(usize) -> bool) -> usize {
    while start < end {
        let mid = (start + end) / 2;
        if pred(mid) {
            start = mid + 1;
        } else {
            end = mid;
        }
    }
    start
}

impl<const D: usize> Marginal2D<D> {
    /// `data` holds `Π param_values[i].len()` slices of `h × w` values.
    /// `normalize`: scale each slice to integrate to 1 over \[0,1\]²; `sampling`: build the
    /// CDFs needed by `sample`/`invert`.
    ///
    /// Panics if sizes are inconsistent (callers validate the file first).
    pub fn new(
        data: &[f32],
        w: usize,
        h: usize,
        params: [Vec<f32>; D],
        normalize: bool,
        sampling: bool,
    ) -> Self {
        assert!(w >= 2 && h >= 2, "Marginal2D: resolution must be >= 2");
        let mut slices = 1usize;
        let mut strides = [0usize; D];
        for i in (0..D).rev() {
            assert!(!params[i].is_empty(), "Marginal2D: empty parameter");
            strides[i] = if params[i].len() > 1 { slices } else { 0 };
            slices *= params[i].len();
        }
        let n_data = w * h;
        assert_eq!(data.len(), slices * n_data, "Marginal2D: data size");
        let (sx, sy) = (0.5 / (w - 1) as f64, 0.5 / (h - 1) as f64);
        let mut out = Vec::with_capacity(data.len());
        let mut marg_cdf = Vec::new();
        let mut cond_cdf = Vec::new();
        let mut row_sum = vec![0.0f64; h];
        for s in 0..slices {
            let d = &data[s * n_data..(s + 1) * n_data];
            let mut norm = 1.0f32;
            if sampling {
                let c0 = cond_cdf.len();
                let m0 = marg_cdf.len();
                for y in 0..h {
                    let mut acc = 0.0f64;
                    for x in 0..w - 1 {
                        acc += sx * (d[y * w + x] as f64 + d[y * w + x + 1] as f64);
                        cond_cdf.push(acc as f32);
                    }
                    row_sum[y] = acc;
                }
                let mut acc = 0.0f64;
                for y in 0..h - 1 {
                    acc += sy * (row_sum[y] + row_sum[y + 1]);
                    marg_cdf.push(acc as f32);
                }
                if normalize {
                    norm = (1.0 / acc) as f32;
                }
                cond_cdf[c0..].iter_mut().for_each(|v| *v *= norm);
                marg_cdf[m0..].iter_mut().for_each(|v| *v *= norm);
            } else if normalize {
                let mut sum = 0.0f64;
                for y in 0..h - 1 {
                    for x in 0..w - 1 {
                        let i = y * w + x;
                        sum +=
                            d[i] as f64 + d[i + 1] as f64 + d[i + w] as f64 + d[i + w + 1] as f64;
                    }
                }
                norm = (1.0 / (sx * sy * sum)) as f32;
            }
            out.extend(d.iter().map(|v| v * norm));
        }
        Marginal2D {
            w,
            h,
            patch: Vec2::new(1.0 / (w - 1) as f32, 1.0 / (h - 1) as f32),
            inv_patch: Vec2::new((w - 1) as f32, (h - 1) as f32),
            params,
            strides,
            data: out,
            marg_cdf,
            cond_cdf,
            normalized: normalize,
        }
    }

    /// Resolution (w, h) of one slice.
    pub fn size(&self) -> (usize, usize) {
        (self.w, self.h)
    }

    #[inline]
    fn corners(&self, param: &[f32; D]) -> Corners {
        let mut c = Corners {
            slice: [0; 8],
            weight: [0.0; 8],
            n: 1,
        };
        c.weight[0] = 1.0;
        for (dim, (vals, &p)) in self.params.iter().zip(param.iter()).enumerate() {
            if vals.len() == 1 {
                continue;
            }
            let idx = binary_search(1, vals.len() - 1, |i| vals[i] < p) - 1;
            let (p0, p1) = (vals[idx], vals[idx + 1]);
            let w1 = ((p - p0) / (p1 - p0)).clamp(0.0, 1.0);
            let w0 = 1.0 - w1;
            let stride = self.strides[dim];
            let n = c.n;
            for k in 0..n {
                let (s, w) = (c.slice[k] + stride * idx, c.weight[k]);
                c.slice[k] = s;
                c.weight[k] = w * w0;
                c.slice[k + n] = s + stride;
                c.weight[k + n] = w * w1;
            }
            c.n = 2 * n;
        }
        c
    }

    /// Interpolated (normalised, if requested) density at `pos` ∈ \[0,1\]².
    #[inline]
    pub fn eval(&self, pos: Vec2, param: &[f32; D]) -> f32 {
        let c = self.corners(param);
        let p = pos.clamp(Vec2::ZERO, Vec2::ONE) * self.inv_patch;
        let ox = (p.x as usize).min(self.w - 2);
        let oy = (p.y as usize).min(self.h - 2);
        let (fx, fy) = (p.x - ox as f32, p.y - oy as f32);
        let n = self.w * self.h;
        let i = oy * self.w + ox;
        let v00 = c.lookup(&self.data, n, i);
        let v10 = c.lookup(&self.data, n, i + 1);
        let v01 = c.lookup(&self.data, n, i + self.w);
        let v11 = c.lookup(&self.data, n, i + self.w + 1);
        lerp(lerp(v00, v10, fx), lerp(v01, v11, fx), fy)
    }

    /// Map a uniform sample on \[0,1\]² to the density; returns the point and its density.
    #[inline]
    pub fn sample(&self, u: Vec2, param: &[f32; D]) -> (Vec2, f32) {
        let c = self.corners(param);
        let (w, h) = (self.w, self.h);
        let n_cond = h * (w - 1);
        let n_marg = h - 1;
        let n_data = w * h;
        let eps = f32::EPSILON * 0.5;
        let mut sx = u.x.clamp(eps, 1.0 - eps);
        let mut sy = u.y.clamp(eps, 1.0 - eps);

        let marg = |i: usize| c.lookup(&self.marg_cdf, n_marg, i);
        if !self.normalized {
            sy *= marg(n_marg - 1);
        }
        let row = binary_search(0, n_marg - 1, |i| marg(i) < sy);
        if row > 0 {
            sy -= marg(row - 1);
        }
        let oc = row * (w - 1);
        let r0 = c.lookup(&self.cond_cdf, n_cond, oc + w - 2);
        let r1 = c.lookup(&self.cond_cdf, n_cond, oc + 2 * (w - 1) - 1);
        sy = sample_segment(sy, self.inv_patch.y, r0, r1);
        sx *= lerp(r0, r1, sy);
        let cond = |i: usize| {
            lerp(
                c.lookup(&self.cond_cdf, n_cond, oc + i),
                c.lookup(&self.cond_cdf, n_cond, oc + i + w - 1),
                sy,
            )
        };
        let col = binary_search(0, w - 1, |i| cond(i) < sx).min(w - 2);
        if col > 0 {
            sx -= cond(col - 1);
        }
        let od = row * w + col;
        let v00 = c.lookup(&self.data, n_data, od);
        let v10 = c.lookup(&self.data, n_data, od + 1);
        let v01 = c.lookup(&self.data, n_data, od + w);
        let v11 = c.lookup(&self.data, n_data, od + w + 1);
        let c0 = lerp(v00, v01, sy);
        let c1 = lerp(v10, v11, sy);
        sx = sample_segment(sx, self.inv_patch.x, c0, c1);
        (
            Vec2::new(
                (col as f32 + sx) * self.patch.x,
                (row as f32 + sy) * self.patch.y,
            ),
            lerp(c0, c1, sx),
        )
    }

    /// Inverse of [`Self::sample`]: the uniform sample that maps to `pos`, and the density
    /// at `pos`.
    #[inline]
    pub fn invert(&self, pos: Vec2, param: &[f32; D]) -> (Vec2, f32) {
        let c = self.corners(param);
        let (w, h) = (self.w, self.h);
        let n_cond = h * (w - 1);
        let n_marg = h - 1;
        let n_data = w * h;
        let p = pos.clamp(Vec2::ZERO, Vec2::ONE) * self.inv_patch;
        let px = (p.x as usize).min(w - 2);
        let py = (p.y as usize).min(h - 2);
        let (mut sx, mut sy) = (p.x - px as f32, p.y - py as f32);
        let od = py * w + px;
        let v00 = c.lookup(&self.data, n_data, od);
        let v10 = c.lookup(&self.data, n_data, od + 1);
        let v01 = c.lookup(&self.data, n_data, od + w);
        let v11 = c.lookup(&self.data, n_data, od + w + 1);
        let c0 = lerp(v00, v01, sy);
        let c1 = lerp(v10, v11, sy);
        let pdf = lerp(c0, c1, sx);
        sx = invert_segment(sx, self.patch.x, c0, c1);
        let oc = py * (w - 1);
        if px > 0 {
            sx += lerp(
                c.lookup(&self.cond_cdf, n_cond, oc + px - 1),
                c.lookup(&self.cond_cdf, n_cond, oc + px - 1 + w - 1),
                sy,
            );
        }
        let r0 = c.lookup(&self.cond_cdf, n_cond, oc + w - 2);
        let r1 = c.lookup(&self.cond_cdf, n_cond, oc + 2 * (w - 1) - 1);
        let row_total = lerp(r0, r1, sy);
        sx = if row_total != 0.0 {
            sx / row_total
        } else {
            0.0
        };
        sy = invert_segment(sy, self.patch.y, r0, r1);
        if py > 0 {
            sy += c.lookup(&self.marg_cdf, n_marg, py - 1);
        }
        if !self.normalized {
            let total = c.lookup(&self.marg_cdf, n_marg, n_marg - 1);
            sy = if total != 0.0 { sy / total } else { 0.0 };
        }
        (Vec2::new(sx, sy), pdf)
    }
}

/// Invert the CDF of a linear density (v0 → v1) over one segment of width 1/inv_width:
/// the fraction of the segment where the accumulated mass reaches `sample`.
#[inline]
fn sample_segment(sample: f32, inv_width: f32, v0: f32, v1: f32) -> f32 {
    let non_const = (v0 - v1).abs() > 1e-4 * (v0 + v1);
    let divisor = if non_const { v0 - v1 } else { v0 + v1 };
    let mut s = sample * 2.0 * inv_width;
    if non_const {
        s = v0 - (v0 * v0 + s * (v1 - v0)).max(0.0).sqrt();
    }
    if divisor != 0.0 {
        s /= divisor;
    }
    s
}

/// Mass of a linear density (v0 → v1) over the first fraction `t` of a segment of `width`.
#[inline]
fn invert_segment(t: f32, width: f32, v0: f32, v1: f32) -> f32 {
    t * lerp(v0, v1, 0.5 * t) * width
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roundtrip_and_density() {
        let (w, h) = (5, 4);
        let data: Vec<f32> = (0..2 * w * h)
            .map(|i| 0.1 + ((i * 7919) % 13) as f32)
            .collect();
        let m = Marginal2D::<1>::new(&data, w, h, [vec![0.0, 1.0]], true, true);
        for k in 0..200 {
            let u = Vec2::new(
                ((k * 37) % 101) as f32 / 101.0 + 0.003,
                ((k * 61) % 97) as f32 / 97.0 + 0.002,
            );
            let p = [(k % 11) as f32 / 10.0];
            let (x, pdf) = m.sample(u, &p);
            let (u2, pdf2) = m.invert(x, &p);
            assert!((u2 - u).abs().max_element() < 1e-4, "{u} {u2}");
            assert!((pdf - pdf2).abs() < 1e-4 * pdf);
            assert!((m.eval(x, &p) - pdf).abs() < 1e-4 * pdf);
        }
    }
}
