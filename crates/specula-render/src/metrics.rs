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
}
