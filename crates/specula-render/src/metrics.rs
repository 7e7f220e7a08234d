//! Image comparison metrics (the conformance criteria of the reference renders):
//!
//! - `relmse`: per pixel e = mean over channels of (img − ref)² / (ref² + 0.01); the
//!   ⌊0.001·pixels⌋ largest e are discarded; the mean of the rest.
//! - `block8`: `relmse` of both images averaged over 8×8 pixel blocks (noise falls ~64×, bias
//!   does not: the bias detector).
//! - `mean_ratio`: per channel mean(img) / mean(ref).
//!
//! A NaN or infinite pixel counts as a huge error.

/// A linear RGB image, row-major.
#[derive(Clone, Debug)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<f32>,
}

impl From<&crate::image_io::Image> for RgbImage {
    /// RGB from an image of 1 (grey), 3 or 4 channels (alpha dropped).
    fn from(img: &crate::image_io::Image) -> Self {
        let c = img.channels;
        RgbImage {
            width: img.width,
            height: img.height,
            data: (0..img.width * img.height)
                .flat_map(|i| (0..3).map(move |k| img.data[i * c + k.min(c - 1)]))
                .collect(),
        }
    }
}

const HUGE: f64 = 1e30;

/// Trimmed relative MSE.
pub fn relmse(img: &RgbImage, reference: &RgbImage) -> f64 {
    assert_eq!(
        (img.width, img.height),
        (reference.width, reference.height),
        "image sizes differ"
    );
    let n = img.width * img.height;
    let mut e: Vec<f64> = (0..n)
        .map(|i| {
            let mut s = 0.0;
            for c in 0..3 {
                let a = img.data[3 * i + c] as f64;
                let b = reference.data[3 * i + c] as f64;
                if !a.is_finite() || !b.is_finite() {
                    return HUGE;
                }
                s += (a - b) * (a - b) / (b * b + 0.01);
            }
            s / 3.0
        })
        .collect();
    let drop = n / 1000;
    e.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    let kept = &e[..n - drop];
    kept.iter().sum::<f64>() / kept.len().max(1) as f64
}

/// Average over `k`×`k` blocks (partial blocks at the border are dropped).
pub fn block_average(img: &RgbImage, k: usize) -> RgbImage {
    let (w, h) = (img.width / k, img.height / k);
    let mut data = vec![0.0f32; w * h * 3];
    for by in 0..h {
        for bx in 0..w {
            let mut s = [0.0f64; 3];
            for y in by * k..(by + 1) * k {
                for x in bx * k..(bx + 1) * k {
                    for (c, sc) in s.iter_mut().enumerate() {
                        *sc += img.data[3 * (y * img.width + x) + c] as f64;
                    }
                }
            }
            for c in 0..3 {
                data[3 * (by * w + bx) + c] = (s[c] / (k * k) as f64) as f32;
            }
        }
    }
    RgbImage {
        width: w,
        height: h,
        data,
    }
}

/// `relmse` after 8×8 block averaging.
pub fn block8(img: &RgbImage, reference: &RgbImage) -> f64 {
    relmse(&block_average(img, 8), &block_average(reference, 8))
}

/// Per-channel ratio of means.
pub fn mean_ratio(img: &RgbImage, reference: &RgbImage) -> [f64; 3] {
    let mut r = [0.0; 3];
    for (c, rc) in r.iter_mut().enumerate() {
        let a: f64 = img.data.iter().skip(c).step_by(3).map(|&v| v as f64).sum();
        let b: f64 = reference
            .data
            .iter()
            .skip(c)
            .step_by(3)
            .map(|&v| v as f64)
            .sum();
        *rc = if b != 0.0 {
            a / b
        } else if a == 0.0 {
            1.0
        } else {
            f64::INFINITY
        };
    }
    r
}

/// The conformance criteria of `../shared/README.md` for one scene: Mitsuba's own error at
/// 64 spp against the reference (as `metrics.json` gives it, averaged over seeds) and the
/// mean-ratio tolerance.
#[derive(Clone, Copy, Debug)]
pub struct Criteria {
    /// `mitsuba_64spp_relmse`.
    pub mitsuba_relmse: f64,
    /// `mitsuba_64spp_block8`.
    pub mitsuba_block8: f64,
    /// Every channel's mean ratio must lie within 1 ± this.
    pub mean_tol: f64,
}

/// How renders compare with a reference under [`Criteria`].
#[derive(Clone, Debug)]
pub struct Verdict {
    /// Per-channel mean ratio, averaged over the renders.
    pub mean: [f64; 3],
    pub block8: f64,
    pub relmse: f64,
    pub ok_mean: bool,
    pub ok_block8: bool,
    pub ok_relmse: bool,
}

impl Criteria {
    /// Reads a scene's entry of a `metrics.json` (`mitsuba_64spp_relmse`,
    /// `mitsuba_64spp_block8`), with the given mean tolerance.
    pub fn new(mitsuba_relmse: f64, mitsuba_block8: f64, mean_tol: f64) -> Self {
        Criteria {
            mitsuba_relmse,
            mitsuba_block8,
            mean_tol,
        }
    }
    /// The largest block8 that conforms: 2 × Mitsuba's + 1e-5.
    pub fn block8_limit(&self) -> f64 {
        2.0 * self.mitsuba_block8 + 1e-5
    }
    /// The largest relMSE that conforms: 1.5 × Mitsuba's.
    pub fn relmse_limit(&self) -> f64 {
        1.5 * self.mitsuba_relmse
    }
    /// Judges renders of one scene (one per seed, all at 64 spp) against its reference. Each
    /// metric is averaged over the renders, as Mitsuba's own figures are averaged over seeds.
    pub fn judge(&self, renders: &[RgbImage], reference: &RgbImage) -> Verdict {
        assert!(!renders.is_empty(), "judge needs at least one render");
        let n = renders.len() as f64;
        let mut mean = [0.0; 3];
        let (mut b, mut r) = (0.0, 0.0);
        for img in renders {
            let m = mean_ratio(img, reference);
            for c in 0..3 {
                mean[c] += m[c] / n;
            }
            b += block8(img, reference) / n;
            r += relmse(img, reference) / n;
        }
        Verdict {
            mean,
            block8: b,
            relmse: r,
            ok_mean: mean.iter().all(|v| (v - 1.0).abs() <= self.mean_tol),
            ok_block8: b <= self.block8_limit(),
            ok_relmse: r <= self.relmse_limit(),
        }
    }
}

impl Verdict {
    /// All three criteria hold.
    pub fn ok(&self) -> bool {
        self.ok_mean && self.ok_block8 && self.ok_relmse
    }
    /// `mean [r g b] (±tol)  block8 … (mitsuba …)  relmse … (mitsuba …)`, for test tables.
    pub fn row(&self, c: &Criteria) -> String {
        format!(
            "mean [{:.4} {:.4} {:.4}] (±{:.3})  block8 {:.3e} (mitsuba {:.3e})  relmse {:.3e} (mitsuba {:.3e})",
            self.mean[0],
            self.mean[1],
            self.mean[2],
            c.mean_tol,
            self.block8,
            c.mitsuba_block8,
            self.relmse,
            c.mitsuba_relmse
        )
    }
    /// Which criteria fail and by how much, for failure messages.
    pub fn failures(&self, c: &Criteria) -> String {
        let mut f = vec![];
        if !self.ok_mean {
            f.push(format!(
                "mean {:?} not within 1 ± {}",
                self.mean, c.mean_tol
            ));
        }
        if !self.ok_block8 {
            f.push(format!(
                "block8 {:.3e} > {:.3e}",
                self.block8,
                c.block8_limit()
            ));
        }
        if !self.ok_relmse {
            f.push(format!(
                "relmse {:.3e} > {:.3e}",
                self.relmse,
                c.relmse_limit()
            ));
        }
        f.join(", ")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    fn img(w: usize, h: usize, f: impl Fn(usize, usize, usize) -> f32) -> RgbImage {
        let mut data = vec![0.0; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    data[3 * (y * w + x) + c] = f(x, y, c);
                }
            }
        }
        RgbImage {
            width: w,
            height: h,
            data,
        }
    }
    #[test]
    fn identical_images_have_zero_error() {
        let a = img(16, 16, |x, y, c| (x + y + c) as f32 * 0.1);
        assert_eq!(relmse(&a, &a), 0.0);
        assert_eq!(block8(&a, &a), 0.0);
        assert_eq!(mean_ratio(&a, &a), [1.0; 3]);
    }
    #[test]
    fn relmse_by_hand_and_trimming() {
        let r = img(100, 20, |_, _, _| 1.0);
        // 2000 pixels: the 2 worst are trimmed
        let mut a = r.clone();
        for v in a.data.iter_mut() {
            *v = 1.1;
        }
        a.data[0] = f32::NAN;
        a.data[3] = 100.0;
        // 1.1 as stored in f32
        let d = 1.1f32 as f64 - 1.0;
        let expect = d * d / 1.01;
        assert!((relmse(&a, &r) - expect).abs() < 1e-12);
        // a third outlier survives the trim
        a.data[6] = 100.0;
        assert!(relmse(&a, &r) > 1.0);
    }
    #[test]
    fn block_average_removes_zero_mean_noise() {
        let r = img(16, 16, |_, _, _| 1.0);
        let a = img(16, 16, |x, y, _| if (x + y) % 2 == 0 { 1.5 } else { 0.5 });
        assert!(relmse(&a, &r) > 0.2);
        assert!(block8(&a, &r) < 1e-12);
        assert!((mean_ratio(&a, &r)[0] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn criteria_average_over_renders_and_name_what_fails() {
        let reference = img(16, 16, |x, y, c| 0.5 + (x * y + c) as f32 * 0.01);
        let bright = img(16, 16, |x, y, c| 1.05 * (0.5 + (x * y + c) as f32 * 0.01));
        let c = Criteria::new(1e-3, 1e-4, 0.01);
        let v = c.judge(std::slice::from_ref(&reference), &reference);
        assert!(v.ok(), "{}", v.row(&c));
        // a 5 % bias fails the mean and the bias detector; averaged with an exact render the
        // mean ratio is 1.025, still outside ±1 %
        let v = c.judge(&[bright.clone(), reference.clone()], &reference);
        assert!((v.mean[0] - 1.025).abs() < 1e-6, "{:?}", v.mean);
        assert!(!v.ok_mean && !v.ok_block8 && !v.ok());
        let why = v.failures(&c);
        assert!(why.contains("mean") && why.contains("block8"), "{why}");
        // relMSE is the mean of the renders' relMSEs
        let r = (relmse(&bright, &reference) + 0.0) / 2.0;
        assert!((v.relmse - r).abs() < 1e-12);
    }
}
