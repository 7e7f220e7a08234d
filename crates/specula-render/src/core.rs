//! Types shared by every part of the renderer.

use glam::{Vec2, Vec3};
use specula_bsdf::frame::Frame;
use specula_bsdf::{ShadingPoint, SurfaceData};
use std::fmt;

/// A ray o + t·d for t in (0, t_max). `d` need not be normalised for intersection, but every
/// ray the integrator traces has a unit direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_max: f32,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray {
            o,
            d,
            t_max: f32::INFINITY,
        }
    }
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// What the acceleration structure reports: which primitive of which shape was hit, where
/// along the ray, and the primitive's own parametric coordinates (barycentrics b1, b2 for a
/// triangle; anything the shape needs to reconstruct the point otherwise).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index of the shape (geometry) in the scene's list.
    pub shape: u32,
    /// Index of the primitive within the shape (triangle index; 0 for analytic shapes).
    pub prim: u32,
    pub u: f32,
    pub v: f32,
    /// For a triangle, its vertices as the acceleration structure stores them (bit-identical
    /// to the mesh's), so that the surface can be computed without looking them up again;
    /// `None` for analytic shapes (or when unknown: the mesh's are used then).
    pub vertices: Option<[Vec3; 3]>,
}

/// Local differential geometry at a surface point, following Mitsuba 3's conventions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceGeometry {
    pub p: Vec3,
    /// Geometric normal (unit), on the side Mitsuba considers the front (e.g. the outside of a
    /// sphere, +z of a rectangle/disk in object space, the winding order of a triangle).
    pub n_geo: Vec3,
    /// Shading frame: `n` is the (interpolated) shading normal; `s` follows ∂p/∂u projected
    /// onto the tangent plane (Mitsuba's `compute_shading_frame`), which orients anisotropic
    /// materials; `t = n × s`.
    pub sh_frame: Frame,
    pub uv: Vec2,
    /// ∂p/∂u and ∂p/∂v in world space (Mitsuba's `si.dp_du`, `si.dp_dv`: from the uv
    /// parameterisation of a mesh, the barycentric one without uvs, the analytic one of a
    /// sphere or disk), what `bumpmap` perturbs the frame with.
    pub dp_du: Vec3,
    pub dp_dv: Vec3,
}

impl SurfaceGeometry {
    /// The shading point a BSDF is evaluated at: uv, position, the derivatives and the
    /// geometric normal in the local shading frame, and the hit primitive with its
    /// barycentrics and the shape's per-primitive data (`surface`) for `mesh_attribute`.
    /// `local_geometry`: whether the BSDF reads the derivatives and geometric normal
    /// ([`specula_bsdf::models::Bsdf::reads_local_geometry`]); when false they keep
    /// [`ShadingPoint`]'s defaults (x, y, z) and are not transformed.
    #[inline]
    pub fn shading_point<'a>(
        &self,
        hit: &Hit,
        surface: Option<&'a dyn SurfaceData>,
        local_geometry: bool,
    ) -> ShadingPoint<'a> {
        let f = &self.sh_frame;
        let (dp_du, dp_dv, n_geo) = if local_geometry {
            (
                f.to_local(self.dp_du),
                f.to_local(self.dp_dv),
                f.to_local(self.n_geo),
            )
        } else {
            (Vec3::X, Vec3::Y, Vec3::Z)
        };
        ShadingPoint {
            uv: self.uv,
            p: self.p,
            dp_du,
            dp_dv,
            n_geo,
            prim: hit.prim,
            bary: Vec2::new(hit.u, hit.v),
            surface,
            wavelengths: None,
        }
    }
}

/// A point sampled on a surface (for area lights).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PositionSample {
    pub p: Vec3,
    /// Geometric normal at p (front side).
    pub n: Vec3,
    pub uv: Vec2,
    /// Density with respect to surface area.
    pub pdf: f32,
}

/// Where something in a scene file came from: `file:line:col`.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Loc {
    pub file: String,
    pub line: u32,
    pub col: u32,
}

impl fmt::Display for Loc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.col)
    }
}

/// A renderer error: a message, and where in which file when known.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct SceneError {
    pub loc: Option<Loc>,
    pub msg: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(l) => write!(f, "{l}: {}", self.msg),
            None => f.write_str(&self.msg),
        }
    }
}

impl SceneError {
    pub fn new(loc: Option<Loc>, msg: impl Into<String>) -> Self {
        SceneError {
            loc,
            msg: msg.into(),
        }
    }
    /// An error about a file as a whole (missing, unreadable, malformed).
    pub fn file(path: &std::path::Path, msg: impl fmt::Display) -> Self {
        SceneError {
            loc: None,
            msg: format!("{}: {msg}", path.display()),
        }
    }
}

pub type Result<T, E = SceneError> = std::result::Result<T, E>;

/// The largest of three values by comparisons (`maxss` on x86-64), for the path loop's
/// per-bounce maxima: `f32::max` ignores a NaN argument at the cost of five instructions per
/// comparison. The same value as `a.max(b).max(c)` without NaNs; with one, NaN or another
/// argument (callers whose result is unusable with a NaN anyway).
#[inline(always)]
pub(crate) fn max3(a: f32, b: f32, c: f32) -> f32 {
    let m = if a > b { a } else { b };
    if m > c {
        m
    } else {
        c
    }
}

/// `n as f32` through u32: one instruction on x86-64, where `usize as f32` is a sequence of
/// eight; the same value for every count and index below 2³² (sizes, light counts).
#[inline(always)]
pub(crate) fn to_f32(n: usize) -> f32 {
    n as u32 as f32
}

/// `x as usize` (saturating: negative and NaN give 0) through u32, which x86-64 converts in
/// fewer instructions; the same value wherever the result is then clamped below 2³².
#[inline(always)]
pub(crate) fn to_index(x: f32) -> usize {
    x as u32 as usize
}

#[cfg(test)]
mod tests {
    #[test]
    fn max3_is_f32_max_without_nans() {
        let v = [
            -2.5f32,
            -0.0,
            0.0,
            1e-30,
            0.5,
            0.5,
            3.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for &a in &v {
            for &b in &v {
                for &c in &v {
                    let want = a.max(b).max(c);
                    assert_eq!(super::max3(a, b, c), want, "{a} {b} {c}");
                }
            }
        }
    }
}
