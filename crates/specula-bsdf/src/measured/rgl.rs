//! `measured`: the RGL measured-material format of Dupuy & Jakob 2018 ("An Adaptive
//! Parameterization for Efficient Material Acquisition and Rendering"), evaluated and sampled
//! as Mitsuba 3's `measured` plugin does.
//!
//! The measurement is stored in a warped domain. For an incident direction ωi (elevation θi,
//! azimuth φi) and a microfacet normal ωm = normalize(ωi + ωo), the normal's spherical
//! coordinates are mapped to the unit square, u_m = (√(2θm/π), (φm − φi + π)/2π) (φm alone for
//! anisotropic data), and u_m is pulled back through the inverse of the tabulated VNDF warp
//! (a continuous marginal 2-D distribution conditioned on φi, θi) to a point s ∈ \[0,1\]².
//! The RGB data is tabulated over s. The value Mitsuba returns (f·cosθo) is
//!
//! ```text
//! f·cosθo = rgb(s) · D(u_m) / (4 σ(u_i))        (when the file's `jacobian` flag is set)
//! ```
//!
//! with D the tabulated NDF and σ the projected area. Sampling warps a uniform point through
//! the luminance distribution (over s) and then through the VNDF warp; the solid-angle pdf is
//! p_vndf(u_m) · p_lum(s) / (2π² u_m.x sinθm · 4 (ωi·ωm)).
//!
//! Files whose `phi_i` covers a reduced azimuth range (a quarter or half of the circle) are
//! handled by mirroring ωi (and ωo) into the stored range, as Mitsuba does.

pub mod marginal;
pub mod tensor;

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use marginal::Marginal2D;
use std::f32::consts::PI;
use std::path::Path;
pub use tensor::{DType, TensorError, TensorField, TensorFile};

/// A measured RGL material (`.bsdf` file, RGB variant).
#[derive(Clone, Debug)]
pub struct Rgl {
    description: String,
    ndf: Marginal2D<0>,
    sigma: Marginal2D<0>,
    vndf: Marginal2D<2>,
    luminance: Marginal2D<2>,
    /// RGB over (φi, θi, channel).
    rgb: Marginal2D<3>,
    isotropic: bool,
    jacobian: bool,
    /// 2 or 4 when the data covers half or a quarter of the azimuths; 0 otherwise.
    reduction: i32,
}

/// Numerically stable elevation angle of a unit vector (acos(z) without its loss of
/// precision near the pole).
#[inline]
fn elevation(d: Vec3) -> f32 {
    let dist = (d.x * d.x + d.y * d.y + (d.z - 1.0) * (d.z - 1.0)).sqrt();
    2.0 * (0.5 * dist).clamp(-1.0, 1.0).asin()
}
#[inline]
fn theta2u(theta: f32) -> f32 {
    (theta * (2.0 / PI)).sqrt()
}
#[inline]
fn phi2u(phi: f32) -> f32 {
    (phi + PI) * (0.5 / PI)
}
#[inline]
fn u2theta(u: f32) -> f32 {
    u * u * (PI / 2.0)
}
#[inline]
fn u2phi(u: f32) -> f32 {
    (2.0 * u - 1.0) * PI
}
/// `a` with its sign flipped unless `b` is negative (sign bit set).
#[inline]
fn mulsign_neg(a: f32, b: f32) -> f32 {
    if b.is_sign_negative() {
        a
    } else {
        -a
    }
}

/// Everything `eval` and `pdf` share for a pair of directions.
struct Query {
    params: [f32; 2],
    u_wi: Vec2,
    u_m: Vec2,
    /// Point in the warped (data) domain.
    s: Vec2,
    vndf_pdf: f32,
    /// 2π² u_m.x sinθm · 4 (ωi·ωm): d(u_m)/d(ωo).
    jacobian: f32,
}

impl Rgl {
    /// Load a `.bsdf` file.
    pub fn load(path: impl AsRef<Path>) -> Result<Rgl, TensorError> {
        Self::from_tensor(&TensorFile::open(path)?)
    }

    /// Build from a parsed tensor file, validating its structure.
    pub fn from_tensor(tf: &TensorFile) -> Result<Rgl, TensorError> {
        let description = String::from_utf8_lossy(tf.u8_data("description", Some(1))?)
            .trim_end_matches('\0')
            .to_string();
        let (_, theta_i) = tf.f32_data("theta_i", Some(1))?;
        let (_, phi_i) = tf.f32_data("phi_i", Some(1))?;
        let (ndf_s, ndf) = tf.f32_data("ndf", Some(2))?;
        let (sigma_s, sigma) = tf.f32_data("sigma", Some(2))?;
        let (vndf_s, vndf) = tf.f32_data("vndf", Some(4))?;
        let (lum_s, lum) = tf.f32_data("luminance", Some(4))?;
        let jac = tf.u8_data("jacobian", Some(1))?;
        if tf.has_field("wavelengths") || !tf.has_field("rgb") {
            return Err(if tf.has_field("rgb") || tf.has_field("spectra") {
                tf.invalid("spectral measurements are not supported (an RGB file is needed)")
            } else {
                TensorError::MissingField {
                    path: tf.path().to_path_buf(),
                    field: "rgb".into(),
                }
            });
        }
        let (rgb_s, rgb) = tf.f32_data("rgb", Some(5))?;
        let (np, nt) = (phi_i.len(), theta_i.len());
        let check = |ok: bool, what: &str| -> Result<(), TensorError> {
            if ok {
                Ok(())
            } else {
                Err(tf.invalid(format!("inconsistent shapes: {what}")))
            }
        };
        check(np >= 1 && nt >= 1, "phi_i and theta_i must be non-empty")?;
        check(jac.len() == 1, "jacobian must hold one value")?;
        check(
            ndf_s[0] >= 2 && ndf_s[1] >= 2 && sigma_s[0] >= 2 && sigma_s[1] >= 2,
            "ndf and sigma need at least 2×2 entries",
        )?;
        check(
            vndf_s[0] == np && vndf_s[1] == nt && vndf_s[2] >= 2 && vndf_s[3] >= 2,
            "vndf must be phi_i × theta_i × (≥2) × (≥2)",
        )?;
        check(
            lum_s[0] == np && lum_s[1] == nt && lum_s[2] == lum_s[3] && lum_s[2] >= 2,
            "luminance must be phi_i × theta_i × n × n",
        )?;
        check(
            rgb_s[0] == np
                && rgb_s[1] == nt
                && rgb_s[2] == 3
                && rgb_s[3] == lum_s[2]
                && rgb_s[4] == lum_s[3],
            "rgb must be phi_i × theta_i × 3 × n × n (n as in luminance)",
        )?;
        let increasing = |v: &[f32]| v.windows(2).all(|w| w[0] < w[1]);
        check(
            increasing(&theta_i) && increasing(&phi_i),
            "theta_i and phi_i must be increasing",
        )?;

        let isotropic = np <= 2;
        let reduction = if isotropic {
            0
        } else {
            (2.0 * PI / (phi_i[np - 1] - phi_i[0])).round() as i32
        };
        let ndf = Marginal2D::new(&ndf, ndf_s[1], ndf_s[0], [], false, false);
        let sigma = Marginal2D::new(&sigma, sigma_s[1], sigma_s[0], [], false, false);
        let vndf = Marginal2D::new(
            &vndf,
            vndf_s[3],
            vndf_s[2],
            [phi_i.clone(), theta_i.clone()],
            true,
            true,
        );
        let luminance = Marginal2D::new(
            &lum,
            lum_s[3],
            lum_s[2],
            [phi_i.clone(), theta_i.clone()],
            true,
            true,
        );
        let rgb = Marginal2D::new(
            &rgb,
            rgb_s[4],
            rgb_s[3],
            [phi_i, theta_i, vec![0.0, 1.0, 2.0]],
            false,
            false,
        );
        Ok(Rgl {
            description,
            ndf,
            sigma,
            vndf,
            luminance,
            rgb,
            isotropic,
            jacobian: jac[0] != 0,
            reduction,
        })
    }

    /// The material's description stored in the file.
    pub fn description(&self) -> &str {
        &self.description
    }
    /// Whether the data is isotropic (a single incident azimuth, or two).
    pub fn is_isotropic(&self) -> bool {
        self.isotropic
    }
    /// Azimuthal symmetry factor of anisotropic data (2 or 4), 0 when none.
    pub fn reduction(&self) -> i32 {
        self.reduction
    }

    /// Mirror ωi (and ωo) into the stored azimuth range. Returns the sign sources (sx, sy)
    /// that undo it.
    #[inline]
    fn reduce(&self, wi: &mut Vec3, wo: Option<&mut Vec3>) -> (f32, f32) {
        if self.reduction < 2 {
            return (-1.0, -1.0);
        }
        let sy = wi.y;
        let sx = if self.reduction == 4 { wi.x } else { sy };
        wi.x = mulsign_neg(wi.x, sx);
        wi.y = mulsign_neg(wi.y, sy);
        if let Some(wo) = wo {
            wo.x = mulsign_neg(wo.x, sx);
            wo.y = mulsign_neg(wo.y, sy);
        }
        (sx, sy)
    }

    #[inline]
    fn query(&self, mut wi: Vec3, mut wo: Vec3) -> Query {
        self.reduce(&mut wi, Some(&mut wo));
        let m = (wi + wo).normalize();
        let theta_i = elevation(wi);
        let phi_i = wi.y.atan2(wi.x);
        let theta_m = elevation(m);
        let phi_m = m.y.atan2(m.x);
        let u_wi = Vec2::new(theta2u(theta_i), phi2u(phi_i));
        let mut u_m = Vec2::new(
            theta2u(theta_m),
            phi2u(if self.isotropic { phi_m - phi_i } else { phi_m }),
        );
        u_m.y -= crate::math::floor(u_m.y);
        let params = [phi_i, theta_i];
        let (s, vndf_pdf) = self.vndf.invert(u_m, &params);
        let sin_m = (m.x * m.x + m.y * m.y).sqrt();
        let jacobian = (2.0 * PI * PI * u_m.x * sin_m).max(1e-6) * 4.0 * wi.dot(m);
        Query {
            params,
            u_wi,
            u_m,
            s,
            vndf_pdf,
            jacobian,
        }
    }

    /// RGB value at data point `s` times the NDF / projected-area factor: f·cosθo.
    #[inline]
    fn value(&self, s: Vec2, params: [f32; 2], u_m: Vec2, u_wi: Vec2) -> Spectrum {
        let mut v = Spectrum::new(
            self.rgb.eval(s, &[params[0], params[1], 0.0]),
            self.rgb.eval(s, &[params[0], params[1], 1.0]),
            self.rgb.eval(s, &[params[0], params[1], 2.0]),
        );
        if self.jacobian {
            v *= self.ndf.eval(u_m, &[]) / (4.0 * self.sigma.eval(u_wi, &[]));
        }
        v
    }

    /// Mitsuba's `eval`: f(ωi, ωo)·cosθo.
    #[inline]
    pub fn eval_cos(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let q = self.query(wi, wo);
        self.value(q.s, q.params, q.u_m, q.u_wi)
    }

    #[inline]
    fn pdf_of(&self, q: &Query) -> f32 {
        let lum = self.luminance.eval(q.s, &q.params);
        q.vndf_pdf * lum / q.jacobian
    }
}

impl BsdfModel for Rgl {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let f = self.eval_cos(wi, wo) * (1.0 / wo.z);
        crate::spectral::upsample::at_point(f, sp.wavelengths.as_ref())
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, _: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let p = self.pdf_of(&self.query(wi, wo));
        if p.is_finite() {
            p.max(0.0)
        } else {
            0.0
        }
    }

    #[inline]
    fn eval_pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let q = self.query(wi, wo);
        let f = self.value(q.s, q.params, q.u_m, q.u_wi) * (1.0 / wo.z);
        let f = crate::spectral::upsample::at_point(f, sp.wavelengths.as_ref());
        let p = self.pdf_of(&q);
        (f, if p.is_finite() { p.max(0.0) } else { 0.0 })
    }

    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        _: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wi0 = wi;
        let mut wi = wi;
        let (sx, sy) = self.reduce(&mut wi, None);
        let theta_i = elevation(wi);
        let phi_i = wi.y.atan2(wi.x);
        let params = [phi_i, theta_i];

        // Mitsuba swaps the two sample dimensions.
        let (s, _) = self.luminance.sample(Vec2::new(u2.y, u2.x), &params);
        let (u_m, _) = self.vndf.sample(s, &params);
        let mut phi_m = u2phi(u_m.y);
        let theta_m = u2theta(u_m.x);
        if self.isotropic {
            phi_m += phi_i;
        }
        let (sin_phi, cos_phi) = phi_m.sin_cos();
        let (sin_theta, cos_theta) = theta_m.sin_cos();
        let m = Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta);
        let mut wo = m * (2.0 * wi.dot(m)) - wi;
        wo.x = mulsign_neg(wo.x, sx);
        wo.y = mulsign_neg(wo.y, sy);
        if wo.z <= 0.0 {
            return None;
        }
        // Value and density through the same (inverse) path as `eval` and `pdf`, so that the
        // three agree to rounding; they equal the forward warp's to ~1e-6.
        let q = self.query(wi0, wo);
        let pdf = self.pdf_of(&q);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        let value = self.value(q.s, q.params, q.u_m, q.u_wi);
        let value = crate::spectral::upsample::at_point(value, sp.wavelengths.as_ref());
        Some(BsdfSample {
            wo,
            weight: value * (1.0 / pdf),
            pdf,
            lobe: LobeFlags::GLOSSY_REFLECTION,
            eta: 1.0,
        })
    }
}
