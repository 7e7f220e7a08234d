//! The matrices behind `<transform>`'s operations, computed in `f64` and following Mitsuba 3's
//! conventions exactly (column vectors, `p' = M · p`, angles in degrees).

use glam::{DMat4, DVec3, DVec4};

/// `<translate>`.
pub(crate) fn translate(v: DVec3) -> DMat4 {
    DMat4::from_translation(v)
}

/// `<scale>`.
pub(crate) fn scale(v: DVec3) -> DMat4 {
    DMat4::from_scale(v)
}

/// `<rotate>`: a right-handed rotation by `angle_deg` degrees about `axis` through the origin.
///
/// Like Mitsuba 3 (`Transform4f.rotate`, which uses Dr.Jit's Rodrigues formula), the axis is
/// used as given and *not* normalised: a unit axis gives a rotation, any other axis gives the
/// same (non-rigid) matrix Mitsuba produces. The caller rejects a zero axis, as Mitsuba does.
pub(crate) fn rotate(axis: DVec3, angle_deg: f64) -> DMat4 {
    let (s, c) = angle_deg.to_radians().sin_cos();
    let t = 1.0 - c;
    let DVec3 { x, y, z } = axis;
    DMat4::from_cols(
        DVec4::new(c + x * x * t, x * y * t + z * s, x * z * t - y * s, 0.0),
        DVec4::new(x * y * t - z * s, c + y * y * t, y * z * t + x * s, 0.0),
        DVec4::new(x * z * t + y * s, y * z * t - x * s, c + z * z * t, 0.0),
        DVec4::W,
    )
}

/// The first tangent of the orthonormal basis Mitsuba's `coordinate_system(n)` builds around a
/// unit vector `n` (Duff et al. 2017); Mitsuba uses it as the `up` of a `<lookat>` without one.
fn coordinate_system_s(n: DVec3) -> DVec3 {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}

/// `<lookat>`: Mitsuba's `Transform4f.look_at`, a camera-to-world matrix whose columns are
/// `left = normalize(up × dir)`, `dir × left`, `dir = normalize(target − origin)` and `origin`;
/// the camera looks along its local +z. Without `up`, Mitsuba picks one perpendicular to `dir`.
pub(crate) fn look_at(
    origin: DVec3,
    target: DVec3,
    up: Option<DVec3>,
) -> Result<DMat4, &'static str> {
    let dir = target - origin;
    let len = dir.length();
    if !len.is_finite() || len == 0.0 {
        return Err("origin and target coincide (or are not finite)");
    }
    let dir = dir / len;
    let up = up.unwrap_or_else(|| coordinate_system_s(dir));
    let left = up.cross(dir);
    let left_len = left.length();
    if !left_len.is_finite() || left_len <= 1e-9 * up.length() {
        return Err("the up vector is zero or parallel to the viewing direction");
    }
    let left = left / left_len;
    let new_up = dir.cross(left);
    Ok(DMat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// `<matrix>`: 16 numbers (4×4) or 9 numbers (3×3, embedded in the upper-left block), row-major.
pub(crate) fn matrix(values: &[f64]) -> Option<DMat4> {
    match values.len() {
        16 => {
            let mut a = [0.0; 16];
            a.copy_from_slice(values);
            // `from_cols_array` reads column-major; the XML lists rows.
            Some(DMat4::from_cols_array(&a).transpose())
        }
        9 => {
            let r = |i: usize| DVec4::new(values[3 * i], values[3 * i + 1], values[3 * i + 2], 0.0);
            Some(DMat4::from_cols(r(0), r(1), r(2), DVec4::W).transpose())
        }
        _ => None,
    }
}
