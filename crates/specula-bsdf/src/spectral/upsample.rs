//! RGB → smooth spectrum (Jakob & Hanika 2019, "A Low-Dimensional Function Space for
//! Efficient Spectral Upsampling"), what spectral mode evaluates every RGB parameter with.
//!
//! # Model
//! A reflectance is ρ(λ) = σ(c₀t² + c₁t + c₂) with t = (λ − 360 nm)/470 nm and the sigmoid
//! σ(x) = ½ + x / (2√(1 + x²)): smooth, in (0, 1) everywhere, three coefficients per colour.
//!
//! # Coefficients
//! [`solve`] finds the coefficients of one linear-sRGB colour by Levenberg–Marquardt-damped
//! Gauss–Newton iterations (analytic Jacobian) on the residual between the target and the
//! colour of ρ under D65 (ρ·D65 integrated against the CIE 1931 observer at the tables' 5 nm
//! nodes, trapezoidal, normalised so that ρ = 1 is white (1, 1, 1)). The residual is measured in
//! CIELAB, as in the paper, so that dark and saturated colours are fitted evenly.
//!
//! [`table`] holds the coefficients on a grid, as the paper's (and Mitsuba's `rgb2spec`)
//! tables do: for each channel l that is largest, a [`RES`]³ grid over z = that channel's
//! value (spaced by a double smoothstep, dense near 0 and 1) and x, y = the other two divided
//! by z (uniform in [0, 1]); [`coefficients`] interpolates the grid trilinearly. The grid is
//! computed by this code the first time spectral mode needs it (continuation along z from
//! z ≈ 0.2 up and down, starting from the neighbouring solution; all cores; about 1.6 s of
//! CPU). A program may keep it between processes ([`set_cache_dir`]; the `specula` binary
//! uses `~/.cache/specula`): the file is this code's own output, read back only when its size,
//! checksum and four columns recomputed by the present solver agree bit for bit, otherwise
//! recomputed and rewritten. Greys (r = g = b) take the exact constant spectrum without a
//! lookup.
//!
//! # Three kinds (Mitsuba's `srgb` and `d65` spectra)
//! - [`reflectance`]: bounded, the colour clamped to [0, 1];
//! - [`unbounded`]: colours with a channel above 1 (an IOR given as RGB, a scaled
//!   reflectance) are upsampled as s·ρ(rgb/s), s = 2·max(rgb); within [0, 1] as
//!   [`reflectance`]. (Mitsuba 3.9 clamps such colours to the grid's last slice instead, so
//!   that e.g. k = (3, 2.5, 2) becomes k(λ) = 1: a deviation on purpose.)
//! - [`illuminant`]: emission, s·ρ(rgb/s)·D65(λ) with s = 2·max(rgb), as Mitsuba's `d65`
//!   spectrum does, so that an RGB-white emitter is D65 and develops to white.
//!
//! Round trip (tested): RGB → spectrum → RGB within 2.5·10⁻³ for colours inside the sRGB
//! cube away from its saturated edges; colours the model cannot reach exactly (e.g. pure
//! (1, 0, 0)) are approximated.

use super::cie;
use crate::spectrum::{Rgb, Spectrum, Wavelengths};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Resolution of the coefficient grid along each axis.
pub const RES: usize = 48;

/// σ(x) = ½ + x / (2√(1 + x²)).
#[inline]
fn sigmoid(x: f32) -> f32 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// The reflectance with coefficients `c` at `w` nm.
#[inline]
pub fn eval_coefficients(c: [f32; 3], w: f32) -> f32 {
    let t = (w - cie::CIE_MIN) * (1.0 / (cie::CIE_MAX - cie::CIE_MIN));
    sigmoid(c[0].mul_add(t, c[1]).mul_add(t, c[2]))
}

/// Quadrature of the colour of a reflectance under D65: points t_k and linear-sRGB weights.
struct Quadrature {
    t: Vec<f64>,
    w: Vec<[f64; 3]>,
}

fn quadrature() -> &'static Quadrature {
    static Q: OnceLock<Quadrature> = OnceLock::new();
    Q.get_or_init(|| {
        let n = 95; // 5 nm steps over 360…830 nm (the tables' own nodes)
        let (lo, hi) = (cie::CIE_MIN as f64, cie::CIE_MAX as f64);
        let h = (hi - lo) / (n - 1) as f64;
        let mut t = Vec::with_capacity(n);
        let mut w = Vec::with_capacity(n);
        for i in 0..n {
            let l = lo + i as f64 * h;
            let trap = if i == 0 || i == n - 1 { 0.5 } else { 1.0 };
            let xyz = cie::xyz_bar(l as f32);
            let s = trap * h * cie::d65(l as f32) as f64 * cie::CIE_Y_NORMALIZATION;
            let rgb = cie::xyz_to_srgb(xyz).map(|v| v as f64 * s);
            t.push((l - lo) / (hi - lo));
            w.push(rgb);
        }
        // normalise so that a constant 1 is exactly white
        let mut sum = [0.0f64; 3];
        for wk in &w {
            for c in 0..3 {
                sum[c] += wk[c];
            }
        }
        for wk in &mut w {
            for c in 0..3 {
                wk[c] /= sum[c];
            }
        }
        Quadrature { t, w }
    })
}

/// Colour (linear sRGB) of the reflectance with coefficients `c` under D65, and its Jacobian
/// ∂rgb/∂c (rows: channel).
fn colour_and_jacobian(c: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let q = quadrature();
    let mut rgb = [0.0f64; 3];
    let mut jac = [[0.0f64; 3]; 3];
    for (t, w) in q.t.iter().zip(&q.w) {
        let x = (c[0] * t + c[1]) * t + c[2];
        let r = 1.0 + x * x;
        let s = 0.5 + x / (2.0 * r.sqrt());
        let ds = 0.5 / (r * r.sqrt());
        let d = [t * t * ds, t * ds, ds];
        for ch in 0..3 {
            rgb[ch] += w[ch] * s;
            for j in 0..3 {
                jac[ch][j] += w[ch] * d[j];
            }
        }
    }
    (rgb, jac)
}

/// Linear sRGB → CIELAB (D65 white), and its Jacobian.
fn lab(rgb: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    // sRGB → XYZ (inverse of Mitsuba's matrix, to double precision via the standard one)
    const M: [[f64; 3]; 3] = [
        [0.412_456_4, 0.357_576_1, 0.180_437_5],
        [0.212_672_9, 0.715_152_2, 0.072_175_0],
        [0.019_333_9, 0.119_192_0, 0.950_304_1],
    ];
    const WHITE: [f64; 3] = [0.950_47, 1.0, 1.088_83];
    let mut f = [0.0f64; 3];
    let mut df = [0.0f64; 3];
    for i in 0..3 {
        let v = (M[i][0] * rgb[0] + M[i][1] * rgb[1] + M[i][2] * rgb[2]) / WHITE[i];
        const D: f64 = 6.0 / 29.0;
        if v > D * D * D {
            f[i] = v.cbrt();
            df[i] = 1.0 / (3.0 * f[i] * f[i]) / WHITE[i];
        } else {
            f[i] = v / (3.0 * D * D) + 4.0 / 29.0;
            df[i] = 1.0 / (3.0 * D * D) / WHITE[i];
        }
    }
    let out = [
        116.0 * f[1] - 16.0,
        500.0 * (f[0] - f[1]),
        200.0 * (f[1] - f[2]),
    ];
    // d(lab)/d(f) · d(f)/d(rgb)
    let dl_df = [
        [0.0, 116.0, 0.0],
        [500.0, -500.0, 0.0],
        [0.0, 200.0, -200.0],
    ];
    let mut j = [[0.0f64; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            j[a][b] = (0..3).map(|i| dl_df[a][i] * df[i] * M[i][b]).sum();
        }
    }
    (out, j)
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut o = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            o[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    o
}

/// Solves the 3×3 system `a x = b` (Cramer's rule); `None` when singular.
fn solve3(a: &[[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if d.abs() < 1e-300 || !d.is_finite() {
        return None;
    }
    let mut x = [0.0; 3];
    for (c, xc) in x.iter_mut().enumerate() {
        let mut m = *a;
        for r in 0..3 {
            m[r][c] = b[r];
        }
        *xc = det(&m) / d;
    }
    Some(x)
}

/// Coefficients whose reflectance has the colour `target` (linear sRGB in [0, 1]) under D65,
/// starting from `start` (damped Gauss–Newton on the CIELAB residual; at most 100 steps).
pub fn solve(target: [f64; 3], start: [f64; 3]) -> [f64; 3] {
    let (lab_t, _) = lab(target);
    let cost = |c: [f64; 3]| {
        let (rgb, jac) = colour_and_jacobian(c);
        let (l, jl) = lab(rgb);
        let r = [l[0] - lab_t[0], l[1] - lab_t[1], l[2] - lab_t[2]];
        (r, mat_mul(&jl, &jac))
    };
    let mut c = start;
    let (mut r, mut j) = cost(c);
    let mut err: f64 = r.iter().map(|v| v * v).sum();
    let mut mu = 1e-3;
    for _ in 0..100 {
        if err < 1e-8 {
            break;
        }
        // (JᵀJ + μ diag(JᵀJ)) δ = −Jᵀr
        let mut a = [[0.0f64; 3]; 3];
        let mut g = [0.0f64; 3];
        for p in 0..3 {
            for q in 0..3 {
                a[p][q] = (0..3).map(|k| j[k][p] * j[k][q]).sum();
            }
            g[p] = -(0..3).map(|k| j[k][p] * r[k]).sum::<f64>();
        }
        let mut improved = false;
        for _ in 0..12 {
            let mut ad = a;
            for p in 0..3 {
                ad[p][p] += mu * a[p][p].max(1e-12);
            }
            let Some(d) = solve3(&ad, g) else {
                mu *= 10.0;
                continue;
            };
            let cn = [c[0] + d[0], c[1] + d[1], c[2] + d[2]];
            let (rn, jn) = cost(cn);
            let en: f64 = rn.iter().map(|v| v * v).sum();
            if en.is_finite() && en < err {
                c = cn;
                r = rn;
                j = jn;
                err = en;
                mu = (mu * 0.1).max(1e-9);
                improved = true;
                break;
            }
            mu *= 10.0;
        }
        if !improved {
            break;
        }
    }
    c
}

/// z value of grid slice `j` (a double smoothstep: dense near 0 and 1).
fn z_of(j: usize) -> f32 {
    let s = |x: f32| x * x * (3.0 - 2.0 * x);
    s(s(j as f32 / (RES - 1) as f32))
}

/// One column of the grid (largest channel `l`, others' ratios `y`, `x`): every z slice,
/// solved by continuation from slice RES/5 (started from zero) up and down.
fn solve_column(z: &[f32; RES], l: usize, y: usize, x: usize) -> Vec<(usize, [f32; 3])> {
    let solve_at = |j: usize, start: [f64; 3]| {
        let zz = z[j] as f64;
        let (xf, yf) = (
            x as f64 / (RES - 1) as f64 * zz,
            y as f64 / (RES - 1) as f64 * zz,
        );
        let mut rgb = [0.0; 3];
        rgb[l] = zz;
        rgb[(l + 1) % 3] = xf;
        rgb[(l + 2) % 3] = yf;
        solve(rgb, start)
    };
    let mut out = Vec::with_capacity(RES);
    let j0 = RES / 5;
    let first = solve_at(j0, [0.0; 3]);
    out.push((j0, first.map(|v| v as f32)));
    let mut prev = first;
    for j in j0 + 1..RES {
        prev = solve_at(j, prev);
        out.push((j, prev.map(|v| v as f32)));
    }
    prev = first;
    for j in (0..j0).rev() {
        prev = solve_at(j, prev);
        out.push((j, prev.map(|v| v as f32)));
    }
    out
}

/// The coefficient grid (see the module docs).
pub struct Table {
    z: [f32; RES],
    /// [l][j (z)][y][x] → coefficients.
    c: Vec<[f32; 3]>,
}

impl Table {
    #[inline]
    fn at(&self, l: usize, j: usize, y: usize, x: usize) -> [f32; 3] {
        self.c[((l * RES + j) * RES + y) * RES + x]
    }

    /// Computes the grid (all cores).
    pub fn compute() -> Table {
        let z: [f32; RES] = std::array::from_fn(z_of);
        let columns: Vec<(usize, usize, usize)> = (0..3)
            .flat_map(|l| (0..RES).flat_map(move |y| (0..RES).map(move |x| (l, y, x))))
            .collect();
        let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
        let chunk = columns.len().div_ceil(threads);
        let mut c = vec![[0.0f32; 3]; 3 * RES * RES * RES];
        let results: Vec<Vec<(usize, [f32; 3])>> = std::thread::scope(|s| {
            let handles: Vec<_> = columns
                .chunks(chunk)
                .map(|cols| {
                    s.spawn(move || {
                        let mut out = Vec::with_capacity(cols.len() * RES);
                        for &(l, y, x) in cols {
                            for (j, v) in solve_column(&z, l, y, x) {
                                out.push((((l * RES + j) * RES + y) * RES + x, v));
                            }
                        }
                        out
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for r in results {
            for (i, v) in r {
                c[i] = v;
            }
        }
        Table { z, c }
    }

    /// Coefficients of a colour in [0, 1]³ (trilinear in the grid); `None` for black.
    pub fn lookup(&self, rgb: [f32; 3]) -> Option<[f32; 3]> {
        let rgb = rgb.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) });
        let l = if rgb[0] >= rgb[1] && rgb[0] >= rgb[2] {
            0
        } else if rgb[1] >= rgb[2] {
            1
        } else {
            2
        };
        let zv = rgb[l];
        if zv <= 0.0 {
            return None;
        }
        let scale = (RES - 1) as f32 / zv;
        let xv = (rgb[(l + 1) % 3] * scale).min((RES - 1) as f32);
        let yv = (rgb[(l + 2) % 3] * scale).min((RES - 1) as f32);
        // z slice: the last j with z[j] ≤ zv
        let j = self.z.partition_point(|&zj| zj <= zv).clamp(1, RES - 1) - 1;
        let fz = ((zv - self.z[j]) / (self.z[j + 1] - self.z[j])).clamp(0.0, 1.0);
        let xi = (xv as usize).min(RES - 2);
        let yi = (yv as usize).min(RES - 2);
        let (fx, fy) = (xv - xi as f32, yv - yi as f32);
        let mut out = [0.0f32; 3];
        for (dj, wz) in [(0, 1.0 - fz), (1, fz)] {
            for (dy, wy) in [(0, 1.0 - fy), (1, fy)] {
                for (dx, wx) in [(0, 1.0 - fx), (1, fx)] {
                    let w = wz * wy * wx;
                    let c = self.at(l, j + dj, yi + dy, xi + dx);
                    for k in 0..3 {
                        out[k] += w * c[k];
                    }
                }
            }
        }
        Some(out)
    }
}

/// Columns recomputed when a cached grid is read ([`Table::load`]): (largest channel, y, x),
/// spread over the grid. Each column is solved independently (continuation along z from
/// [`Table::compute`]'s start), so recomputing one gives its cached values bit for bit unless
/// the solver has changed.
const CHECK_COLUMNS: [(usize, usize, usize); 4] = [(0, 5, 40), (1, 47, 0), (2, 23, 31), (0, 0, 47)];

/// Bytes before the coefficients in a cache file: magic, format version, [`RES`].
const MAGIC: &[u8; 8] = b"SPRGB2SP";
const FORMAT: u32 = 1;

/// FNV-1a over bytes (the cache file's checksum; detects a damaged file, not tampering).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

impl Table {
    /// The grid as bytes: magic, format, [`RES`], the coefficients (f32, little endian), and
    /// an FNV-1a checksum of all that precedes it.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(16 + self.c.len() * 12 + 8);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT.to_le_bytes());
        out.extend_from_slice(&(RES as u32).to_le_bytes());
        for c in &self.c {
            for v in c {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        let h = fnv1a(&out);
        out.extend_from_slice(&h.to_le_bytes());
        out
    }

    /// The grid from [`Table::to_bytes`]'s format, checked: size, magic, format, resolution,
    /// checksum, finite values, and `CHECK_COLUMNS` recomputed by this build's solver and
    /// compared bit for bit (a cache written by another version of the solver is refused).
    pub fn from_bytes(bytes: &[u8]) -> Result<Table, String> {
        let n = 3 * RES * RES * RES;
        let want = 16 + n * 12 + 8;
        if bytes.len() != want {
            return Err(format!("{} bytes, expected {want}", bytes.len()));
        }
        if &bytes[..8] != MAGIC {
            return Err("not an RGB-to-spectrum table".into());
        }
        let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap());
        if word(8) != FORMAT || word(12) != RES as u32 {
            return Err(format!(
                "format {} at resolution {}, expected {FORMAT} at {RES}",
                word(8),
                word(12)
            ));
        }
        let body = &bytes[..want - 8];
        let stored = u64::from_le_bytes(bytes[want - 8..].try_into().unwrap());
        if fnv1a(body) != stored {
            return Err("checksum mismatch (damaged file)".into());
        }
        let mut c = Vec::with_capacity(n);
        for k in 0..n {
            let v: [f32; 3] = std::array::from_fn(|i| {
                let at = 16 + (3 * k + i) * 4;
                f32::from_le_bytes(bytes[at..at + 4].try_into().unwrap())
            });
            if !v.iter().all(|x| x.is_finite()) {
                return Err(format!("coefficient {k} is not finite"));
            }
            c.push(v);
        }
        let table = Table {
            z: std::array::from_fn(z_of),
            c,
        };
        for (l, y, x) in CHECK_COLUMNS {
            let col = solve_column(&table.z, l, y, x);
            for (j, v) in col {
                if table.at(l, j, y, x) != v {
                    return Err("written by another version of the solver".into());
                }
            }
        }
        Ok(table)
    }

    /// The grid cached in `dir` (file `rgb2spec-<RES>.bin`) when it is there and valid;
    /// otherwise computed ([`Table::compute`]) and written there (atomically; a directory
    /// that cannot be written is only reported). The `String` says what happened.
    pub fn cached_in(dir: &Path) -> (Table, String) {
        let path = dir.join(format!("rgb2spec-{RES}.bin"));
        let why = match std::fs::read(&path) {
            Ok(bytes) => match Table::from_bytes(&bytes) {
                Ok(t) => return (t, format!("read {}", path.display())),
                Err(e) => format!("{}: {e}; recomputed", path.display()),
            },
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => "computed".to_string(),
            Err(e) => format!("{}: {e}; recomputed", path.display()),
        };
        let t = Table::compute();
        let tmp = dir.join(format!("rgb2spec-{RES}.bin.{}.tmp", std::process::id()));
        let written = std::fs::create_dir_all(dir)
            .and_then(|_| std::fs::write(&tmp, t.to_bytes()))
            .and_then(|_| std::fs::rename(&tmp, &path));
        let note = match written {
            Ok(()) => format!("{why}, cached in {}", path.display()),
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                format!("{why}, not cached ({}: {e})", path.display())
            }
        };
        (t, note)
    }
}

static CACHE_DIR: OnceLock<Option<PathBuf>> = OnceLock::new();
static TABLE: OnceLock<Table> = OnceLock::new();

/// Where [`table`] keeps the grid between processes (`None`: nowhere, computed in every
/// process, the default). Only the first call counts, and only before [`table`] is first
/// used; returns whether it was taken.
pub fn set_cache_dir(dir: Option<PathBuf>) -> bool {
    CACHE_DIR.set(dir).is_ok() && TABLE.get().is_none()
}

/// The coefficient grid, computed at the first call (all cores; see the module docs), or
/// read from the cache directory when one was set ([`set_cache_dir`], [`Table::cached_in`]).
pub fn table() -> &'static Table {
    TABLE.get_or_init(|| match CACHE_DIR.get_or_init(|| None) {
        Some(dir) => Table::cached_in(dir).0,
        None => Table::compute(),
    })
}

/// Coefficients of a reflectance colour (clamped to [0, 1]); `None` for black.
#[inline]
pub fn coefficients(rgb: Rgb) -> Option<[f32; 3]> {
    table().lookup(rgb.0)
}

/// A reflectance colour (clamped to [0, 1]) at the wavelengths `w`.
#[inline]
pub fn reflectance(rgb: Rgb, w: &Wavelengths) -> Spectrum {
    let [r, g, b] = rgb.0;
    if r == g && g == b {
        return Spectrum::splat(r.clamp(0.0, 1.0));
    }
    match coefficients(rgb) {
        Some(c) => Rgb(w.0.map(|l| eval_coefficients(c, l))),
        None => Spectrum::ZERO,
    }
}

/// Any non-emission colour at the wavelengths `w`: [`reflectance`] within [0, 1], s·ρ(rgb/s)
/// with s = 2·max(rgb) above; negative channels count as 0.
#[inline]
pub fn unbounded(rgb: Rgb, w: &Wavelengths) -> Spectrum {
    let rgb = rgb.map(|v| v.max(0.0));
    let m = rgb.max_component();
    if m <= 1.0 {
        return reflectance(rgb, w);
    }
    let s = 2.0 * m;
    reflectance(rgb / s, w) * s
}

/// What a model holding RGB data (a measured BSDF's tabulated values) returns at a shading
/// point: `rgb` in RGB mode, [`unbounded`] at the point's wavelengths in spectral mode.
#[inline]
pub fn at_point(rgb: Rgb, w: Option<&Wavelengths>) -> Spectrum {
    match w {
        None => rgb,
        Some(w) => unbounded(rgb, w),
    }
}

/// An emitted colour at the wavelengths `w`: s·ρ(rgb/s)·D65(λ), s = 2·max(rgb) (Mitsuba's
/// `d65` spectrum); negative channels count as 0.
#[inline]
pub fn illuminant(rgb: Rgb, w: &Wavelengths) -> Spectrum {
    let rgb = rgb.map(|v| v.max(0.0));
    let [r, g, b] = rgb.0;
    let d = Rgb(w.0.map(cie::d65));
    if r == g && g == b {
        return d * r;
    }
    let s = 2.0 * rgb.max_component();
    reflectance(rgb / s, w) * d * s
}

/// An emitted colour prepared once for [`illuminant`]: the upsampling coefficients of its
/// chromaticity, so that the spectrum of any non-negative multiple of it (a light sample's
/// weight: the emitter's colour times geometry over a pdf) costs three sigmoid evaluations and
/// three D65 values instead of a table lookup. Equal to [`illuminant`] of that multiple up to
/// float rounding (the scale is read off the colour's largest channel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Illuminant {
    /// Coefficients of rgb / (2·max); `None` for a grey (or black) colour.
    coeffs: Option<[f32; 3]>,
    /// The colour's largest channel.
    k: usize,
    /// The colour's value in channel `k`.
    max: f32,
    grey: bool,
}

impl Illuminant {
    /// Prepares `rgb` (negative channels count as 0).
    pub fn new(rgb: Rgb) -> Self {
        let rgb = rgb.map(|v| v.max(0.0));
        let [r, g, b] = rgb.0;
        let k = if r >= g && r >= b {
            0
        } else if g >= b {
            1
        } else {
            2
        };
        let max = rgb.0[k];
        let grey = r == g && g == b;
        let coeffs = if grey || max <= 0.0 {
            None
        } else {
            coefficients(rgb / (2.0 * max))
        };
        Illuminant {
            coeffs,
            k,
            max,
            grey,
        }
    }

    /// [`illuminant`]`(weight, w)` for `weight` a non-negative multiple of the prepared colour.
    #[inline]
    pub fn scaled(&self, weight: Rgb, w: &Wavelengths) -> Spectrum {
        if self.max <= 0.0 {
            return Spectrum::ZERO;
        }
        let d = Rgb(w.0.map(cie::d65));
        let m = weight.0[self.k].max(0.0);
        if self.grey {
            return d * m;
        }
        match self.coeffs {
            Some(c) => Rgb(w.0.map(|l| eval_coefficients(c, l))) * d * (2.0 * m),
            None => Spectrum::ZERO,
        }
    }
}

/// The linear-sRGB colour, under D65, of the reflectance `f(λ)` (1 nm steps): what
/// [`reflectance`] is the inverse of.
pub fn reflectance_to_rgb(f: impl Fn(f32) -> f32) -> Rgb {
    let mut acc = [0.0f64; 3];
    let mut white = [0.0f64; 3];
    for i in 0..=470 {
        let l = 360.0 + i as f32;
        let trap = if i == 0 || i == 470 { 0.5 } else { 1.0 };
        let c = cie::xyz_to_srgb(cie::xyz_bar(l));
        let d = cie::d65(l) as f64 * trap;
        let v = f(l) as f64;
        for k in 0..3 {
            acc[k] += c[k] as f64 * d * v;
            white[k] += c[k] as f64 * d;
        }
    }
    Rgb(std::array::from_fn(|k| (acc[k] / white[k]) as f32))
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    #[test]
    fn solver_fits_colours_exactly() {
        for target in [
            [0.8, 0.3, 0.1],
            [0.105421, 0.37798, 0.076425],
            [0.2, 0.4, 0.7],
        ] {
            let c = solve(target, [0.0; 3]).map(|v| v as f32);
            let back = reflectance_to_rgb(|l| eval_coefficients(c, l));
            for k in 0..3 {
                assert!(
                    (back.0[k] as f64 - target[k]).abs() < 1e-3,
                    "{target:?} → {back:?}"
                );
            }
        }
    }

    /// The grid's cache file: written and read back bit for bit; a truncated file, a damaged
    /// byte, another resolution, and values changed consistently with the checksum (a file
    /// from another solver) are each refused with a reason; `cached_in` reads a valid file.
    #[test]
    fn cache_file_round_trip_and_refusals() {
        let t = table();
        let bytes = t.to_bytes();
        let back = Table::from_bytes(&bytes).unwrap();
        assert!(back.c == t.c && back.z == t.z);
        let err = |b: &[u8]| Table::from_bytes(b).err().unwrap();
        assert!(err(&bytes[..bytes.len() - 1]).contains("bytes"));
        assert!(err(&[]).contains("bytes"));
        let mut damaged = bytes.clone();
        damaged[100_000] ^= 0x10;
        assert!(err(&damaged).contains("checksum"));
        let mut res = bytes.clone();
        res[12] = 47;
        assert!(err(&res).contains("resolution"));
        let mut magic = bytes.clone();
        magic[0] = b'X';
        assert!(err(&magic).contains("not an RGB-to-spectrum table"));
        // one coefficient of a checked column changed, checksum made consistent
        let (l, y, x) = CHECK_COLUMNS[2];
        let k = ((l * RES + 30) * RES + y) * RES + x;
        let mut other = bytes.clone();
        let at = 16 + 3 * k * 4;
        let v = f32::from_le_bytes(other[at..at + 4].try_into().unwrap());
        other[at..at + 4].copy_from_slice(&(v * 1.001 + 1e-3).to_le_bytes());
        let n = other.len();
        let h = fnv1a(&other[..n - 8]);
        other[n - 8..].copy_from_slice(&h.to_le_bytes());
        assert!(err(&other).contains("another version"));
        // a valid file in a directory is read, not recomputed
        let dir = std::env::temp_dir().join(format!("specula-rgb2spec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(format!("rgb2spec-{RES}.bin")), &bytes).unwrap();
        let (read, note) = Table::cached_in(&dir);
        assert!(note.starts_with("read "), "{note}");
        assert!(read.c == t.c);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A prepared [`Illuminant`] gives [`illuminant`] of every non-negative multiple of its
    /// colour (random colours, grey, black, one zero channel; scales 0 to 10⁴), to float
    /// rounding.
    #[test]
    fn prepared_illuminant_equals_illuminant_of_multiples() {
        let mut rng = Pcg32::new(5, 1);
        let mut colours = vec![
            Rgb([0.5, 0.5, 0.5]),
            Rgb([0.0, 0.0, 0.0]),
            Rgb([3.0, 0.0, 1.0]),
            Rgb([17.0, 12.0, 4.0]),
        ];
        for _ in 0..200 {
            let c = Rgb([rng.next_f32(), rng.next_f32(), rng.next_f32()]) * (20.0 * rng.next_f32());
            colours.push(c);
        }
        for c in colours {
            let il = Illuminant::new(c);
            for a in [0.0, 1e-3, 0.7, 1.0, 33.0, 1e4] {
                let w = Wavelengths([
                    360.0 + 470.0 * rng.next_f32(),
                    360.0 + 470.0 * rng.next_f32(),
                    360.0 + 470.0 * rng.next_f32(),
                ]);
                let (got, want) = (il.scaled(c * a, &w), illuminant(c * a, &w));
                for k in 0..3 {
                    assert!(
                        (got.0[k] - want.0[k]).abs() <= 1e-4 * want.0[k].abs() + 1e-30,
                        "{c:?} × {a} at {w:?}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

    /// Upsampled reflectances stay in [0, 1] and round-trip RGB → spectrum → RGB.
    #[test]
    fn reflectance_round_trip_and_bounds() {
        let mut rng = Pcg32::new(11, 0);
        let mut worst = 0.0f32;
        for i in 0..400 {
            // colours inside the cube, away from its most saturated edges
            let rgb = Rgb::new(
                0.02 + 0.96 * rng.next_f32(),
                0.02 + 0.96 * rng.next_f32(),
                0.02 + 0.96 * rng.next_f32(),
            );
            let c = coefficients(rgb).unwrap();
            for l in (360..=830).step_by(10) {
                let v = eval_coefficients(c, l as f32);
                assert!((0.0..=1.0).contains(&v), "{rgb:?} at {l} nm: {v}");
            }
            let back = reflectance_to_rgb(|l| eval_coefficients(c, l));
            let e = (0..3)
                .map(|k| (back.0[k] - rgb.0[k]).abs())
                .fold(0.0, f32::max);
            worst = worst.max(e);
            assert!(e < 2.5e-3, "#{i} {rgb:?} → {back:?}");
        }
        eprintln!("worst round-trip error {worst}");
        // greys are exact and flat
        let w = Wavelengths([400.0, 550.0, 700.0]);
        assert_eq!(reflectance(Rgb::splat(0.3), &w), Spectrum::splat(0.3));
        // black is black
        assert_eq!(reflectance(Rgb::ZERO, &w), Spectrum::ZERO);
    }

    #[test]
    fn illuminant_white_is_d65_and_scales_linearly() {
        let w = Wavelengths([450.0, 550.0, 650.0]);
        let white = illuminant(Rgb::ONE, &w);
        for i in 0..3 {
            assert!((white.0[i] - cie::d65(w.0[i])).abs() < 1e-6);
        }
        let a = illuminant(Rgb::new(12.0, 11.0, 10.0), &w);
        let b = illuminant(Rgb::new(1.2, 1.1, 1.0), &w) * 10.0;
        for i in 0..3 {
            assert!((a.0[i] - b.0[i]).abs() < 1e-4 * a.0[i]);
        }
        // the illuminant's colour (integrated without D65 weighting, i.e. as emission)
        let c = [3.0f32, 0.6, 0.9];
        let s = 2.0 * 3.0;
        let co = coefficients(Rgb(c.map(|v| v / s))).unwrap();
        let back = reflectance_to_rgb(|l| eval_coefficients(co, l)) * s;
        for k in 0..3 {
            assert!((back.0[k] - c[k]).abs() < 0.01 * s, "{back:?}");
        }
        // unbounded values above 1 keep their colour
        let u = [0.2f32, 1.5, 3.0];
        let su = 6.0;
        let cu = coefficients(Rgb(u.map(|v| v / su))).unwrap();
        let back = reflectance_to_rgb(|l| eval_coefficients(cu, l)) * su;
        for k in 0..3 {
            assert!((back.0[k] - u[k]).abs() < 0.02, "{back:?}");
        }
        let v = unbounded(Rgb(u), &w);
        assert!(v.0.iter().all(|&x| x > 0.0 && x < 6.0));
    }
}
