//! `merl`: measured isotropic BRDFs in the MERL format (Matusik, Pfister, Brand & McMillan,
//! "A Data-Driven Reflectance Model", SIGGRAPH 2003).
//!
//! # The file format
//!
//! Three little-endian `i32` dimensions, which must be (90, 90, 180) = (θh, θd, φd) bins, then
//! all red, all green and all blue values as little-endian `f64`; the entry of bin
//! (θh, θd, φd) = (i, j, k) is at index `k + 180·(j + 90·i)` within its channel. A stored
//! value is BRDF / scale with scale = (1/1500, 1.15/1500, 1.66/1500), so BRDF = value × scale.
//! Negative entries mean "not measured" (typically a configuration below the horizon).
//!
//! The angles are Rusinkiewicz's half/difference coordinates (see [`to_half_diff`]):
//! - θh bin i spans [(i/90)², ((i+1)/90)²]·π/2 (square-root spacing, fine near the
//!   specular peak): index = ⌊√(θh/(π/2))·90⌋;
//! - θd: 1° bins over [0°, 90°); φd: 1° bins over [0°, 180°), where φd is folded by
//!   reciprocity (swapping wi and wo turns φd into φd + 180°, so φd < 0 maps to φd + 180°).
//!
//! Bin centres, as used by [`Merl::from_fn`] and [`Merl::measure`], are the centres in those
//! coordinates: θh = ((i + ½)/90)²·π/2, θd = (j + ½)°, φd = (k + ½)°.
//!
//! # Evaluation
//!
//! - nearest bin (default, `interpolate = false`), exactly as the MERL reference reader
//!   (`BRDFRead.cpp`) looks values up; a "not measured" (negative) entry evaluates to 0;
//! - multilinear interpolation (`interpolate = true`) between bin centres, in the square-root
//!   warped θh coordinate, linear θd, and φd (periodic with period 180°, since φd and
//!   φd + 180° are the same configuration); θh and θd are clamped at the table's first and
//!   last bin centres. Per channel, only the measured (non-negative) corners take part and
//!   their weights are renormalised; with no measured corner the value is 0.
//!
//! The model is one-sided: wi or wo at or below the horizon gives 0.
//!
//! # Sampling
//!
//! A mixture of cosine-weighted hemisphere sampling (probability [`COSINE_FRACTION`]) and a
//! tabulated half-vector sampler. For each of [`SAMPLER_INCIDENCE_BINS`] bins of θi (uniform
//! in θi), the constructor tabulates a piecewise-constant density over the half vector h,
//! in cells of (θh row, φ column): rows are the 90 MERL θh bins (square-root spacing), columns
//! split the azimuth of h relative to wi's azimuth over [0, π] into [`SAMPLER_PHI_BINS`]
//! equal parts (MERL BRDFs are isotropic, so the density is mirrored to [−π, 0] with equal
//! probability). A cell's probability is proportional to luminance(f)·cosθo·4(wi·h)·Ω at its
//! centre (the integrand of the albedo in half-vector measure, with f the nearest-bin value
//! at the centre of the sampler's incidence bin); within a cell h is uniform in solid angle.
//! `pdf(wi, wo)` is exactly this sampler's density: it finds h = (wi + wo)/|wi + wo|, the
//! same incidence bin (by θi of wi, no interpolation) and the same cell, and converts with
//! dωo/dωh = 4 (wo·h). Half vectors whose reflection falls below the horizon produce no
//! sample (the mass lost is the sampler's own business and shows as ∫pdf < 1).

use crate::bsdf::*;
use crate::frame::sincos_phi;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, PI};
use std::fmt;
use std::io::Read;
use std::path::Path;
use std::sync::Arc;

/// Bins in θh.
pub const RES_THETA_H: usize = 90;
/// Bins in θd.
pub const RES_THETA_D: usize = 90;
/// Bins in φd (over [0°, 180°)).
pub const RES_PHI_D: usize = 180;
/// Entries per colour channel.
pub const ENTRIES: usize = RES_THETA_H * RES_THETA_D * RES_PHI_D;
/// Size of a MERL file in bytes: the 12-byte header and 3 channels of `f64`.
pub const FILE_SIZE: usize = 12 + 3 * ENTRIES * 8;
/// BRDF = stored value × `SCALE[channel]`.
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];
/// Probability with which `sample` draws a cosine-weighted direction instead of using the
/// tabulated half-vector distribution (robustness where the table is zero or coarse).
pub const COSINE_FRACTION: f32 = 0.1;
/// Number of θi bins of the tabulated sampler (uniform in θi over [0, π/2]).
pub const SAMPLER_INCIDENCE_BINS: usize = 90;
/// Azimuth bins of the half vector (relative to wi) over [0, π] in the tabulated sampler.
pub const SAMPLER_PHI_BINS: usize = 180;
const SAMPLER_THETA_BINS: usize = RES_THETA_H;

/// Why a MERL file could not be read or written. The message always names the file (or the
/// label given to [`Merl::from_bytes`]).
#[derive(Debug, thiserror::Error)]
pub enum MerlError {
    #[error("{file}: {source}")]
    Io {
        file: String,
        source: std::io::Error,
    },
    #[error(
        "{file}: not a MERL BRDF: expected {expected} bytes \
         (12-byte header + 3 × 90·90·180 float64), found {actual}"
    )]
    Size {
        file: String,
        expected: u64,
        actual: u64,
    },
    #[error("{file}: not a MERL BRDF: table dimensions {dims:?}, expected [90, 90, 180]")]
    Dims { file: String, dims: [i32; 3] },
    #[error(
        "{file}: {channel} channel entry {index} (θh bin {}, θd bin {}, φd bin {}) is {value}",
        index / (RES_THETA_D * RES_PHI_D), (index / RES_PHI_D) % RES_THETA_D, index % RES_PHI_D
    )]
    NonFinite {
        file: String,
        channel: &'static str,
        index: usize,
        value: f64,
    },
}

impl MerlError {
    /// The file (or label) the error is about.
    pub fn file(&self) -> &str {
        match self {
            MerlError::Io { file, .. }
            | MerlError::Size { file, .. }
            | MerlError::Dims { file, .. }
            | MerlError::NonFinite { file, .. } => file,
        }
    }
}

const CHANNEL_NAMES: [&str; 3] = ["red", "green", "blue"];

// ---------------------------------------------------------------------------------------
// Rusinkiewicz half/difference coordinates
// ---------------------------------------------------------------------------------------

/// Rusinkiewicz's half/difference angles of a pair of directions (radians).
///
/// h = (wi + wo)/|wi + wo| has polar angle θh and azimuth φh in the local frame; (θd, φd)
/// are the polar angle and azimuth of `wi` in the frame of h, that is after rotating wi by
/// −φh about the normal and then by −θh about the binormal (the MERL reference code's
/// convention). `phi_d` is not folded: it lies in (−π, π].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HalfDiff {
    pub theta_h: f32,
    pub phi_h: f32,
    pub theta_d: f32,
    pub phi_d: f32,
}

/// (wi, wo) in the local frame (z = normal) → half/difference angles. When wi = −wo the half
/// vector is undefined and the normal is used.
#[inline]
pub fn to_half_diff(wi: Vec3, wo: Vec3) -> HalfDiff {
    let (theta_h, theta_d, phi_d, h) = half_diff_core(wi, wo);
    HalfDiff {
        theta_h,
        phi_h: h.y.atan2(h.x),
        theta_d,
        phi_d,
    }
}

/// (θh, θd, φd, h) of a pair of directions; φd unfolded.
#[inline]
fn half_diff_core(wi: Vec3, wo: Vec3) -> (f32, f32, f32, Vec3) {
    let s = wi + wo;
    let len = s.length();
    let h = if len > 0.0 { s / len } else { Vec3::Z };
    let r = (h.x * h.x + h.y * h.y).sqrt();
    let theta_h = r.atan2(h.z);
    let (sin_ph, cos_ph) = if r > 0.0 {
        (h.y / r, h.x / r)
    } else {
        (0.0, 1.0)
    };
    // rotate wi by −φh about the normal ...
    let tx = cos_ph * wi.x + sin_ph * wi.y;
    let ty = -sin_ph * wi.x + cos_ph * wi.y;
    let tz = wi.z;
    // ... then by −θh about the binormal (cos θh = h.z, sin θh = r)
    let dx = tx * h.z - tz * r;
    let dz = tx * r + tz * h.z;
    let theta_d = (dx * dx + ty * ty).sqrt().atan2(dz);
    let phi_d = ty.atan2(dx);
    (theta_h, theta_d, phi_d, h)
}

/// Half/difference angles → (wi, wo) in the local frame (the inverse of [`to_half_diff`]).
#[inline]
pub fn from_half_diff(hd: HalfDiff) -> (Vec3, Vec3) {
    let (wi, wo) = dirs_from_half_diff_f64(
        hd.theta_h as f64,
        hd.phi_h as f64,
        hd.theta_d as f64,
        hd.phi_d as f64,
    );
    (to_vec3(wi), to_vec3(wo))
}

fn to_vec3(v: [f64; 3]) -> Vec3 {
    Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32)
}

/// Double-precision [`from_half_diff`]: wi is the difference vector rotated by θh about the
/// binormal and by φh about the normal; wo is its mirror image about h.
fn dirs_from_half_diff_f64(th: f64, ph: f64, td: f64, pd: f64) -> ([f64; 3], [f64; 3]) {
    let (sd, cd) = td.sin_cos();
    let (spd, cpd) = pd.sin_cos();
    let (sh, ch) = th.sin_cos();
    let (sph, cph) = ph.sin_cos();
    let rot = |x: f64, y: f64, z: f64| -> [f64; 3] {
        // by θh about y, then by φh about z
        let (x1, z1) = (x * ch + z * sh, -x * sh + z * ch);
        [x1 * cph - y * sph, x1 * sph + y * cph, z1]
    };
    let (dx, dy, dz) = (sd * cpd, sd * spd, cd);
    (rot(dx, dy, dz), rot(-dx, -dy, dz))
}

/// Centre of θh bin `i` (radians): ((i + ½)/90)²·π/2.
#[inline]
pub fn theta_h_centre(i: usize) -> f64 {
    let u = (i as f64 + 0.5) / RES_THETA_H as f64;
    u * u * std::f64::consts::FRAC_PI_2
}
/// Centre of θd bin `j` (radians): (j + ½)°.
#[inline]
pub fn theta_d_centre(j: usize) -> f64 {
    (j as f64 + 0.5) / RES_THETA_D as f64 * std::f64::consts::FRAC_PI_2
}
/// Centre of φd bin `k` (radians): (k + ½)°.
#[inline]
pub fn phi_d_centre(k: usize) -> f64 {
    (k as f64 + 0.5) / RES_PHI_D as f64 * std::f64::consts::PI
}

/// The pair of directions at the centre of bin (i, j, k) with φh = 0, in double precision
/// (wi, wo); either may lie below the horizon.
pub fn bin_centre_dirs(i: usize, j: usize, k: usize) -> ([f64; 3], [f64; 3]) {
    dirs_from_half_diff_f64(theta_h_centre(i), 0.0, theta_d_centre(j), phi_d_centre(k))
}

/// Index of an entry within a channel.
#[inline]
pub const fn table_index(theta_h: usize, theta_d: usize, phi_d: usize) -> usize {
    phi_d + RES_PHI_D * (theta_d + RES_THETA_D * theta_h)
}

/// θh bin of an angle, as the MERL reference reader computes it (square-root mapping, floor,
/// clamped).
#[inline]
pub fn theta_h_index(theta_h: f32) -> usize {
    if theta_h.is_nan() || theta_h <= 0.0 {
        return 0;
    }
    (((theta_h / FRAC_PI_2).sqrt() * RES_THETA_H as f32) as usize).min(RES_THETA_H - 1)
}
/// θd bin of an angle (floor, clamped).
#[inline]
pub fn theta_d_index(theta_d: f32) -> usize {
    ((theta_d / FRAC_PI_2 * RES_THETA_D as f32) as usize).min(RES_THETA_D - 1)
}
/// φd bin of an angle: folded into [0, π) by reciprocity, floor, clamped.
#[inline]
pub fn phi_d_index(phi_d: f32) -> usize {
    ((fold_phi_d(phi_d) / PI * RES_PHI_D as f32) as usize).min(RES_PHI_D - 1)
}
/// φd modulo π (φd and φd + π are the same configuration with wi and wo swapped).
#[inline]
fn fold_phi_d(phi_d: f32) -> f32 {
    if (0.0..PI).contains(&phi_d) {
        phi_d
    } else if (-PI..0.0).contains(&phi_d) {
        phi_d + PI
    } else {
        phi_d.rem_euclid(PI)
    }
}

// ---------------------------------------------------------------------------------------
// The table
// ---------------------------------------------------------------------------------------

/// A MERL measured BRDF. Cloning is cheap (the tables are shared).
#[derive(Clone)]
pub struct Merl {
    /// Multilinear interpolation between bin centres instead of the reference reader's
    /// nearest-bin lookup (default `false`). Sampling does not depend on it.
    pub interpolate: bool,
    /// How `sample` draws directions (default: the tabulated half-vector distribution).
    pub sampling: MerlSampling,
    data: Arc<MerlData>,
}

/// Sampling strategy of a [`Merl`] material (the `sampling` parameter of the `merl` plugin).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MerlSampling {
    /// Importance sampling of the data: a mixture of the per-θi tabulated half-vector
    /// distributions and [`COSINE_FRACTION`] cosine-weighted sampling.
    #[default]
    Tabulated,
    /// Cosine-weighted hemisphere sampling only: the baseline against which the tabulated
    /// strategy's variance reduction is measured.
    Cosine,
}

struct MerlData {
    name: String,
    /// Raw stored values (BRDF / scale), RGB interleaved, as read (negative: not measured).
    table: Vec<[f64; 3]>,
    sampler: Sampler,
}

impl fmt::Debug for Merl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Merl")
            .field("name", &self.data.name)
            .field("interpolate", &self.interpolate)
            .finish_non_exhaustive()
    }
}

impl Merl {
    /// Read a MERL `.binary` file: the header must say (90, 90, 180), the size must be exactly
    /// [`FILE_SIZE`], and every entry must be finite.
    pub fn read(path: &Path) -> Result<Merl, MerlError> {
        let file = path.display().to_string();
        let io = |source| MerlError::Io {
            file: file.clone(),
            source,
        };
        let mut f = std::fs::File::open(path).map_err(io)?;
        let len = f.metadata().map_err(io)?.len();
        if len != FILE_SIZE as u64 {
            // the header, when there is one, tells a wrong table from a damaged file
            let mut head = Vec::with_capacity(12);
            (&mut f).take(12).read_to_end(&mut head).map_err(io)?;
            if head.len() == 12 {
                check_dims(&file, &head)?;
            }
            return Err(MerlError::Size {
                file,
                expected: FILE_SIZE as u64,
                actual: len,
            });
        }
        let mut bytes = Vec::with_capacity(FILE_SIZE + 1);
        // read one byte more than expected, so a file that grew meanwhile is still caught
        (&mut f)
            .take(FILE_SIZE as u64 + 1)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        Self::from_bytes(&file, &bytes)
    }

    /// Parse the contents of a MERL file; `label` names it in errors.
    pub fn from_bytes(label: &str, bytes: &[u8]) -> Result<Merl, MerlError> {
        let size_err = || MerlError::Size {
            file: label.to_string(),
            expected: FILE_SIZE as u64,
            actual: bytes.len() as u64,
        };
        if bytes.len() < 12 {
            return Err(size_err());
        }
        check_dims(label, &bytes[..12])?;
        if bytes.len() != FILE_SIZE {
            return Err(size_err());
        }
        let mut table = vec![[0.0f64; 3]; ENTRIES];
        for c in 0..3 {
            let chan = &bytes[12 + c * ENTRIES * 8..12 + (c + 1) * ENTRIES * 8];
            for (i, (b, t)) in chan.chunks_exact(8).zip(table.iter_mut()).enumerate() {
                let v = f64::from_le_bytes(b.try_into().unwrap());
                if !v.is_finite() {
                    return Err(MerlError::NonFinite {
                        file: label.to_string(),
                        channel: CHANNEL_NAMES[c],
                        index: i,
                        value: v,
                    });
                }
                t[c] = v;
            }
        }
        Ok(Self::from_table(label.to_string(), table))
    }

    /// Tabulate `f(θh, θd, φd)` (radians; the BRDF value, no cosine) at every bin centre (see
    /// the module documentation). Per channel, a negative or non-finite value marks the bin
    /// "not measured" and is stored as −1, as MERL's own files do.
    pub fn from_fn(f: impl Fn(f64, f64, f64) -> Spectrum) -> Merl {
        let mut table = vec![[0.0f64; 3]; ENTRIES];
        for i in 0..RES_THETA_H {
            let th = theta_h_centre(i);
            for j in 0..RES_THETA_D {
                let td = theta_d_centre(j);
                for k in 0..RES_PHI_D {
                    table[table_index(i, j, k)] = stored(f(th, td, phi_d_centre(k)));
                }
            }
        }
        Self::from_table("<tabulated>".into(), table)
    }

    /// "Measure" a model: evaluate it at the centre of every bin (φh = 0, wi the difference
    /// vector rotated into place, as [`from_half_diff`]); configurations with wi or wo at or
    /// below the horizon are stored as not measured (−1), as in MERL's own files.
    pub fn measure<B: BsdfModel + ?Sized>(bsdf: &B) -> Merl {
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        Self::from_fn(|th, td, pd| {
            let (wi, wo) = dirs_from_half_diff_f64(th, 0.0, td, pd);
            if wi[2] <= 0.0 || wo[2] <= 0.0 {
                return Spectrum::splat(-1.0);
            }
            bsdf.eval(&ctx, &sp, to_vec3(wi), to_vec3(wo))
        })
        .with_name("<measured>")
    }

    /// [`Merl::measure`] (the same table, bit for bit) with the θh rows shared among the
    /// available cores, calling `progress(rows done, rows in all)` from the worker threads as
    /// each of the 90 rows is finished.
    pub fn measure_with_progress<B: BsdfModel + Sync + ?Sized>(
        bsdf: &B,
        progress: impl Fn(usize, usize) + Sync,
    ) -> Merl {
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        let mut table = vec![[0.0f64; 3]; ENTRIES];
        let rows = std::sync::Mutex::new(table.chunks_mut(RES_THETA_D * RES_PHI_D).enumerate());
        let done = std::sync::atomic::AtomicUsize::new(0);
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::thread::scope(|s| {
            for _ in 0..threads.min(RES_THETA_H) {
                s.spawn(|| loop {
                    let next = rows.lock().unwrap_or_else(|e| e.into_inner()).next();
                    let Some((i, row)) = next else { break };
                    for j in 0..RES_THETA_D {
                        for k in 0..RES_PHI_D {
                            let (wi, wo) = bin_centre_dirs(i, j, k);
                            row[k + RES_PHI_D * j] = if wi[2] <= 0.0 || wo[2] <= 0.0 {
                                [-1.0; 3]
                            } else {
                                stored(bsdf.eval(&ctx, &sp, to_vec3(wi), to_vec3(wo)))
                            };
                        }
                    }
                    let n = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                    progress(n, RES_THETA_H);
                });
            }
        });
        Self::from_table("<measured>".into(), table)
    }

    fn from_table(name: String, table: Vec<[f64; 3]>) -> Merl {
        let sampler = Sampler::build(&table);
        Merl {
            interpolate: false,
            sampling: MerlSampling::Tabulated,
            data: Arc::new(MerlData {
                name,
                table,
                sampler,
            }),
        }
    }

    /// The same table under another name (shown by `Debug` and [`Merl::name`]).
    pub fn with_name(mut self, name: &str) -> Merl {
        match Arc::get_mut(&mut self.data) {
            Some(d) => d.name = name.to_string(),
            None => {
                let d = &self.data;
                self.data = Arc::new(MerlData {
                    name: name.to_string(),
                    table: d.table.clone(),
                    sampler: d.sampler.clone(),
                })
            }
        }
        self
    }

    /// The file (or label) the table came from.
    pub fn name(&self) -> &str {
        &self.data.name
    }

    /// The file contents: header and the three channels (round trip exact with
    /// [`Merl::from_bytes`]).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(FILE_SIZE);
        for d in [RES_THETA_H, RES_THETA_D, RES_PHI_D] {
            out.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for c in 0..3 {
            for v in &self.data.table {
                out.extend_from_slice(&v[c].to_le_bytes());
            }
        }
        out
    }

    /// Write a MERL `.binary` file.
    pub fn write(&self, path: &Path) -> Result<(), MerlError> {
        std::fs::write(path, self.to_bytes()).map_err(|source| MerlError::Io {
            file: path.display().to_string(),
            source,
        })
    }

    /// The stored (unscaled) values of bin (θh, θd, φd) for red, green and blue; negative
    /// means not measured.
    #[inline]
    pub fn raw(&self, theta_h: usize, theta_d: usize, phi_d: usize) -> [f64; 3] {
        self.data.table[table_index(theta_h, theta_d, phi_d)]
    }

    /// All stored values, RGB interleaved, indexed by [`table_index`].
    pub fn raw_table(&self) -> &[[f64; 3]] {
        &self.data.table
    }

    /// The BRDF of bin (θh, θd, φd) (stored value × scale; not-measured entries give 0).
    #[inline]
    pub fn bin_value(&self, theta_h: usize, theta_d: usize, phi_d: usize) -> Spectrum {
        scaled(&self.raw(theta_h, theta_d, phi_d))
    }

    /// Nearest-bin lookup by half/difference angles (radians; φd folded here).
    #[inline]
    pub fn lookup_nearest(&self, theta_h: f32, theta_d: f32, phi_d: f32) -> Spectrum {
        self.bin_value(
            theta_h_index(theta_h),
            theta_d_index(theta_d),
            phi_d_index(phi_d),
        )
    }

    /// Multilinear interpolation between bin centres by half/difference angles (radians).
    pub fn lookup_interpolated(&self, theta_h: f32, theta_d: f32, phi_d: f32) -> Spectrum {
        let last_h = (RES_THETA_H - 1) as f32;
        let last_d = (RES_THETA_D - 1) as f32;
        let xh =
            ((theta_h.max(0.0) / FRAC_PI_2).sqrt() * RES_THETA_H as f32 - 0.5).clamp(0.0, last_h);
        let xd = (theta_d / FRAC_PI_2 * RES_THETA_D as f32 - 0.5).clamp(0.0, last_d);
        let xp = fold_phi_d(phi_d) / PI * RES_PHI_D as f32 - 0.5;
        if !(xh.is_finite() && xd.is_finite() && xp.is_finite()) {
            return Spectrum::ZERO;
        }
        let floor = crate::math::floor;
        let (h0, d0, pf) = (floor(xh), floor(xd), floor(xp));
        let (th, td, tp) = (xh - h0, xd - d0, xp - pf);
        let h0 = h0 as usize;
        let d0 = d0 as usize;
        let hs = [h0, (h0 + 1).min(RES_THETA_H - 1)];
        let ds = [d0, (d0 + 1).min(RES_THETA_D - 1)];
        let p0 = (pf as i32).rem_euclid(RES_PHI_D as i32) as usize;
        let ps = [p0, (p0 + 1) % RES_PHI_D];
        let (wh, wd, wp) = ([1.0 - th, th], [1.0 - td, td], [1.0 - tp, tp]);
        let mut sum = [0.0f64; 3];
        let mut wsum = [0.0f64; 3];
        for a in 0..2 {
            for b in 0..2 {
                for c in 0..2 {
                    let w = (wh[a] * wd[b] * wp[c]) as f64;
                    if w <= 0.0 {
                        continue;
                    }
                    let v = &self.data.table[table_index(hs[a], ds[b], ps[c])];
                    for ch in 0..3 {
                        if v[ch] >= 0.0 {
                            sum[ch] += w * v[ch];
                            wsum[ch] += w;
                        }
                    }
                }
            }
        }
        Spectrum::new(
            interp_channel(sum[0], wsum[0], 0),
            interp_channel(sum[1], wsum[1], 1),
            interp_channel(sum[2], wsum[2], 2),
        )
    }

    /// Lookup by half/difference angles in the mode chosen by [`Merl::interpolate`].
    #[inline]
    pub fn lookup(&self, theta_h: f32, theta_d: f32, phi_d: f32) -> Spectrum {
        if self.interpolate {
            self.lookup_interpolated(theta_h, theta_d, phi_d)
        } else {
            self.lookup_nearest(theta_h, theta_d, phi_d)
        }
    }

    /// Density of the tabulated half-vector sampler alone (solid angle of wo), for
    /// wi, wo in the upper hemisphere.
    #[inline]
    fn pdf_table(&self, wi: Vec3, wo: Vec3) -> f32 {
        let s = wi + wo;
        let len = s.length();
        if len <= 0.0 {
            return 0.0;
        }
        let h = s / len;
        let cos_ih = wi.dot(h);
        if cos_ih <= 0.0 {
            return 0.0;
        }
        let pdf_h = self.data.sampler.pdf_h(wi, h);
        pdf_h / (4.0 * cos_ih)
    }
}

/// A BRDF value as stored: divided by [`SCALE`]; −1 (not measured) for a negative or
/// non-finite channel.
#[inline]
fn stored(v: Spectrum) -> [f64; 3] {
    std::array::from_fn(|c| {
        let x = v[c] as f64;
        if x.is_finite() && x >= 0.0 {
            x / SCALE[c]
        } else {
            -1.0
        }
    })
}

#[inline]
fn scaled(v: &[f64; 3]) -> Spectrum {
    let c = |i: usize| {
        if v[i] > 0.0 {
            (v[i] * SCALE[i]) as f32
        } else {
            0.0
        }
    };
    Spectrum::new(c(0), c(1), c(2))
}

#[inline]
fn interp_channel(sum: f64, wsum: f64, ch: usize) -> f32 {
    if wsum > 0.0 {
        (sum / wsum * SCALE[ch]) as f32
    } else {
        0.0
    }
}

fn check_dims(file: &str, head: &[u8]) -> Result<(), MerlError> {
    let dims: [i32; 3] =
        std::array::from_fn(|i| i32::from_le_bytes(head[4 * i..4 * i + 4].try_into().unwrap()));
    if dims != [RES_THETA_H as i32, RES_THETA_D as i32, RES_PHI_D as i32] {
        return Err(MerlError::Dims {
            file: file.to_string(),
            dims,
        });
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Importance sampling
// ---------------------------------------------------------------------------------------

/// Per incidence bin, a piecewise-constant density of the half vector over
/// (θh row, |φh − φi| column) cells (see the module documentation).
#[derive(Clone)]
struct Sampler {
    /// Per incidence bin: CDF over the θh rows (`SAMPLER_THETA_BINS + 1` entries, 0 … 1).
    marginal: Vec<f32>,
    /// Per incidence bin and row: CDF over the φ columns (`SAMPLER_PHI_BINS + 1` entries).
    conditional: Vec<f32>,
    /// 1 − cos θh at the row edges.
    edge_a: Vec<f32>,
    /// 1 / (2 Ω) of a cell of each row, Ω its solid angle (the 2: a cell and its mirror
    /// image share its probability).
    inv_two_omega: Vec<f32>,
}

const MSTRIDE: usize = SAMPLER_THETA_BINS + 1;
const CSTRIDE: usize = SAMPLER_PHI_BINS + 1;

/// Incidence bin of the sampler for wi (upper hemisphere).
#[inline]
fn incidence_bin(wi: Vec3) -> usize {
    let theta = (wi.x * wi.x + wi.y * wi.y).sqrt().atan2(wi.z);
    ((theta / FRAC_PI_2 * SAMPLER_INCIDENCE_BINS as f32) as usize).min(SAMPLER_INCIDENCE_BINS - 1)
}

/// Write the normalised CDF of `w` into `cdf` (`w.len() + 1` entries); uniform when `w` sums
/// to zero. Returns the sum.
fn build_cdf(w: &[f64], cdf: &mut [f32]) -> f64 {
    let total: f64 = w.iter().sum();
    let n = w.len();
    let mut acc = 0.0;
    cdf[0] = 0.0;
    for i in 0..n {
        acc += if total > 0.0 { w[i] } else { 1.0 };
        let t = if total > 0.0 { total } else { n as f64 };
        cdf[i + 1] = (acc / t) as f32;
    }
    cdf[n] = 1.0;
    total
}

/// Index i with cdf[i] ≤ u < cdf[i + 1] (so cdf[i + 1] > cdf[i]) and the position of u
/// within that interval, in [0, 1).
#[inline]
fn sample_cdf(cdf: &[f32], u: f32) -> (usize, f32, f32) {
    let n = cdf.len() - 1;
    let i = cdf
        .partition_point(|&c| c <= u)
        .saturating_sub(1)
        .min(n - 1);
    let p = cdf[i + 1] - cdf[i];
    let r = if p > 0.0 {
        ((u - cdf[i]) / p).clamp(0.0, 1.0 - f32::EPSILON)
    } else {
        0.5
    };
    (i, r, p)
}

impl Sampler {
    fn build(table: &[[f64; 3]]) -> Sampler {
        let (nt, np) = (SAMPLER_THETA_BINS, SAMPLER_PHI_BINS);
        let dphi = std::f64::consts::PI / np as f64;
        let edge_theta = |r: usize| {
            let u = r as f64 / nt as f64;
            u * u * std::f64::consts::FRAC_PI_2
        };
        let edge_a64: Vec<f64> = (0..=nt)
            .map(|r| 2.0 * (0.5 * edge_theta(r)).sin().powi(2))
            .collect();
        let omega: Vec<f64> = (0..nt)
            .map(|r| (edge_a64[r + 1] - edge_a64[r]) * dphi)
            .collect();
        // cell centres: the θh bin centre and the middle of the φ column
        let rows: Vec<(f32, f32)> = (0..nt)
            .map(|r| {
                let t = theta_h_centre(r);
                (t.sin() as f32, t.cos() as f32)
            })
            .collect();
        let cols: Vec<(f32, f32)> = (0..np)
            .map(|c| {
                let p = (c as f64 + 0.5) * dphi;
                (p.sin() as f32, p.cos() as f32)
            })
            .collect();

        let mut marginal = vec![0.0f32; SAMPLER_INCIDENCE_BINS * MSTRIDE];
        let mut conditional = vec![0.0f32; SAMPLER_INCIDENCE_BINS * nt * CSTRIDE];
        let mut w = vec![0.0f64; np];
        let mut row_w = vec![0.0f64; nt];
        for k in 0..SAMPLER_INCIDENCE_BINS {
            let ti = (k as f64 + 0.5) / SAMPLER_INCIDENCE_BINS as f64 * std::f64::consts::FRAC_PI_2;
            let wi = Vec3::new(ti.sin() as f32, 0.0, ti.cos() as f32);
            for r in 0..nt {
                let (st, ct) = rows[r];
                for (c, &(sp, cp)) in cols.iter().enumerate() {
                    let h = Vec3::new(st * cp, st * sp, ct);
                    let cos_ih = wi.dot(h);
                    let wo = 2.0 * cos_ih * h - wi;
                    w[c] = if cos_ih > 0.0 && wo.z > 0.0 {
                        let (th, td, pd, _) = half_diff_core(wi, wo);
                        let f = scaled(
                            &table[table_index(
                                theta_h_index(th),
                                theta_d_index(td),
                                phi_d_index(pd),
                            )],
                        )
                        .luminance()
                        .max(0.0) as f64;
                        f * (wo.z * 4.0 * cos_ih) as f64 * omega[r]
                    } else {
                        0.0
                    };
                }
                let off = (k * nt + r) * CSTRIDE;
                row_w[r] = build_cdf(&w, &mut conditional[off..off + CSTRIDE]);
            }
            let total: f64 = row_w.iter().sum();
            if total <= 0.0 {
                // nothing measured for this incidence: uniform over the hemisphere of h
                for r in 0..nt {
                    row_w[r] = omega[r] * np as f64;
                }
            }
            build_cdf(&row_w, &mut marginal[k * MSTRIDE..(k + 1) * MSTRIDE]);
        }
        Sampler {
            marginal,
            conditional,
            edge_a: edge_a64.iter().map(|&a| a as f32).collect(),
            inv_two_omega: omega.iter().map(|&o| (0.5 / o) as f32).collect(),
        }
    }

    /// Solid-angle density of h (upper hemisphere, unit) given wi.
    #[inline]
    fn pdf_h(&self, wi: Vec3, h: Vec3) -> f32 {
        let k = incidence_bin(wi);
        let r = (h.x * h.x + h.y * h.y).sqrt();
        let row = theta_h_index(r.atan2(h.z)).min(SAMPLER_THETA_BINS - 1);
        let (sin_pi, cos_pi) = sincos_phi(wi);
        let hx = h.x * cos_pi + h.y * sin_pi;
        let hy = -h.x * sin_pi + h.y * cos_pi;
        let phi = hy.abs().atan2(hx);
        let col = ((phi / PI * SAMPLER_PHI_BINS as f32) as usize).min(SAMPLER_PHI_BINS - 1);
        let m = &self.marginal[k * MSTRIDE..(k + 1) * MSTRIDE];
        let off = (k * SAMPLER_THETA_BINS + row) * CSTRIDE;
        let c = &self.conditional[off..off + CSTRIDE];
        (m[row + 1] - m[row]) * (c[col + 1] - c[col]) * self.inv_two_omega[row]
    }

    /// A half vector for wi (upper hemisphere) from `u` and the mirror choice `flip`.
    #[inline]
    fn sample_h(&self, wi: Vec3, u: Vec2, flip: bool) -> Vec3 {
        let k = incidence_bin(wi);
        let m = &self.marginal[k * MSTRIDE..(k + 1) * MSTRIDE];
        let (row, rx, _) = sample_cdf(m, u.x);
        let off = (k * SAMPLER_THETA_BINS + row) * CSTRIDE;
        let (col, ry, _) = sample_cdf(&self.conditional[off..off + CSTRIDE], u.y);
        // uniform in solid angle within the cell: 1 − cos θ linear
        let a = self.edge_a[row] + (self.edge_a[row + 1] - self.edge_a[row]) * rx;
        let cos_t = 1.0 - a;
        let sin_t = (a * (2.0 - a)).max(0.0).sqrt();
        let phi = (col as f32 + ry) * (PI / SAMPLER_PHI_BINS as f32);
        let (mut sp, cp) = phi.sin_cos();
        if flip {
            sp = -sp;
        }
        let (hx, hy) = (sin_t * cp, sin_t * sp);
        let (sin_pi, cos_pi) = sincos_phi(wi);
        Vec3::new(hx * cos_pi - hy * sin_pi, hx * sin_pi + hy * cos_pi, cos_t)
    }
}

impl BsdfModel for Merl {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION | LobeFlags::DIFFUSE_REFLECTION
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let (th, td, pd, _) = half_diff_core(wi, wo);
        crate::spectral::upsample::at_point(self.lookup(th, td, pd), sp.wavelengths.as_ref())
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        if self.sampling == MerlSampling::Cosine {
            return warp::square_to_cosine_hemisphere_pdf(wo);
        }
        COSINE_FRACTION * warp::square_to_cosine_hemisphere_pdf(wo)
            + (1.0 - COSINE_FRACTION) * self.pdf_table(wi, wo)
    }

    #[inline]
    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = if self.sampling == MerlSampling::Cosine || u1 < COSINE_FRACTION {
            warp::square_to_cosine_hemisphere(u2)
        } else {
            let flip = (u1 - COSINE_FRACTION) < 0.5 * (1.0 - COSINE_FRACTION);
            let h = self.data.sampler.sample_h(wi, u2, flip);
            let cos_ih = wi.dot(h);
            if cos_ih <= 0.0 {
                return None;
            }
            (2.0 * cos_ih * h - wi).normalize()
        };
        if wo.z <= 0.0 || !wo.is_finite() {
            return None;
        }
        let (f, pdf) = self.eval_pdf(ctx, sp, wi, wo);
        if pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: f * (wo.z / pdf),
            pdf,
            lobe: LobeFlags::GLOSSY_REFLECTION,
            eta: 1.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    fn upper(rng: &mut Pcg32) -> Vec3 {
        let w = warp::square_to_uniform_hemisphere(rng.next_vec2());
        Vec3::new(w.x, w.y, w.z.max(1e-3)).normalize()
    }

    #[test]
    fn half_diff_round_trip_from_directions() {
        let mut rng = Pcg32::new(1, 2);
        for _ in 0..100_000 {
            let (wi, wo) = (upper(&mut rng), upper(&mut rng));
            let hd = to_half_diff(wi, wo);
            assert!((0.0..=FRAC_PI_2 + 1e-6).contains(&hd.theta_h), "{hd:?}");
            assert!((0.0..=FRAC_PI_2 + 1e-6).contains(&hd.theta_d), "{hd:?}");
            let (a, b) = from_half_diff(hd);
            // h loses precision as wi → −wo (grazing, opposite azimuths)
            let tol = 2e-6 * (2.0 / (wi + wo).length()).max(1.0);
            assert!(
                (a - wi).length() < tol && (b - wo).length() < tol,
                "wi={wi:?} wo={wo:?} → {hd:?} → {a:?} {b:?}"
            );
        }
    }

    #[test]
    fn half_diff_round_trip_from_angles() {
        let mut rng = Pcg32::new(3, 4);
        let wrap = |d: f32| {
            let d = d.rem_euclid(2.0 * PI);
            d.min(2.0 * PI - d)
        };
        let mut checked = 0;
        for _ in 0..100_000 {
            let hd = HalfDiff {
                theta_h: rng.next_f32() * FRAC_PI_2,
                phi_h: (rng.next_f32() * 2.0 - 1.0) * PI,
                theta_d: rng.next_f32() * FRAC_PI_2,
                phi_d: (rng.next_f32() * 2.0 - 1.0) * PI,
            };
            let (wi, wo) = from_half_diff(hd);
            if wi.z < 1e-2 || wo.z < 1e-2 || hd.theta_h < 1e-2 || hd.theta_d < 1e-2 {
                continue; // azimuths are ill-conditioned at the poles
            }
            let back = to_half_diff(wi, wo);
            assert!((back.theta_h - hd.theta_h).abs() < 1e-4, "{hd:?} {back:?}");
            assert!((back.theta_d - hd.theta_d).abs() < 1e-4, "{hd:?} {back:?}");
            assert!(wrap(back.phi_h - hd.phi_h) < 1e-3, "{hd:?} {back:?}");
            assert!(wrap(back.phi_d - hd.phi_d) < 1e-3, "{hd:?} {back:?}");
            checked += 1;
        }
        assert!(checked > 30_000);
    }

    #[test]
    fn reciprocity_shifts_phi_d_by_pi() {
        let mut rng = Pcg32::new(5, 6);
        for _ in 0..10_000 {
            let (wi, wo) = (upper(&mut rng), upper(&mut rng));
            let (a, b) = (to_half_diff(wi, wo), to_half_diff(wo, wi));
            // the half vector of nearly opposite directions carries a relative rounding error
            // of about ε/|wi + wo|, which bounds how well θd can agree
            let tol = 1e-5f32.max(8.0 * f32::EPSILON / (wi + wo).length());
            assert!((a.theta_d - b.theta_d).abs() < tol, "{wi} {wo} {a:?} {b:?}");
            assert!((fold_phi_d(a.phi_d) - fold_phi_d(b.phi_d)).abs() < 1e-4 || a.theta_d < 1e-3);
        }
    }

    #[test]
    fn indices_match_the_reference_reader() {
        for i in 0..RES_THETA_H {
            assert_eq!(theta_h_index(theta_h_centre(i) as f32), i);
            let lo = (i as f64 / 90.0).powi(2) * std::f64::consts::FRAC_PI_2;
            assert_eq!(theta_h_index((lo * (1.0 + 1e-5) + 1e-9) as f32), i);
        }
        for j in 0..RES_THETA_D {
            assert_eq!(theta_d_index(theta_d_centre(j) as f32), j);
        }
        for k in 0..RES_PHI_D {
            let p = phi_d_centre(k) as f32;
            assert_eq!(phi_d_index(p), k);
            assert_eq!(phi_d_index(p - PI), k, "folded");
        }
        assert_eq!(theta_h_index(0.0), 0);
        assert_eq!(theta_h_index(10.0), 89);
        assert_eq!(theta_d_index(FRAC_PI_2), 89);
        assert_eq!(phi_d_index(PI), 0);
    }
}
