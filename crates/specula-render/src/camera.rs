//! Mitsuba 3's sensors: `perspective` (pinhole), `thinlens` (depth of field) and
//! `orthographic`, plus the film window (size and crop) they project onto.
//!
//! Conventions (Mitsuba 3.9.1, checked with its Python bindings: `sample_ray` at given film and
//! aperture samples; the numbers are in the tests below):
//! - Cameras look along +z of their `to_world` frame, +y up, camera +x towards the *left* of the
//!   image (Mitsuba's look-at convention). Film position (0, 0) is the top-left corner.
//! - The field of view is Mitsuba's `parse_fov`: `fov` (degrees) along `fov_axis` (`x`, `y`,
//!   `diagonal`, `smaller`, `larger`; case-insensitive; default `x`), or `focal_length`
//!   (`"<f>mm"` or `"<f>"`, default `"50mm"` when neither is given) on a 36 × 24 mm sensor:
//!   fov = 2·atan(√(36² + 24²) / 2f) along the *diagonal*. The aspect ratio is the full film's
//!   (`width`/`height`), not the crop window's. Giving both `fov` and `focal_length`, or
//!   `fov_axis` with `focal_length`, is an error (Mitsuba: "unreferenced property").
//! - `near_clip` (default 0.01) > 0 and < `far_clip` (default 10⁴); rays start on the near
//!   plane (perpendicular to the view axis) and end on the far plane.
//! - `focus_distance` (default `far_clip`) is accepted by every sensor (Mitsuba's projective
//!   camera reads it); only `thinlens` uses it.
//! - `perspective`: `principal_point_offset_x`/`_y` (default 0) shift the projection by that
//!   fraction of the *full* film's width/height (off-axis projection; with a crop window too).
//! - `perspective` and `thinlens` refuse a scaled `to_world` ("Scale factors in the
//!   camera-to-world transformation are not allowed", as Mitsuba).
//! - `thinlens`: `aperture_radius` (required; 0 becomes 10⁻⁷, a warning in Mitsuba) — rays
//!   leave a disk of that radius (Mitsuba's concentric square-to-disk warp of the aperture
//!   sample) towards the film point's image on the plane z = `focus_distance`.
//! - `orthographic`: rays leave the near plane at `to_world` · (x, y, near_clip) with
//!   x ∈ [−1, 1] across the film and y ∈ [−1/aspect, 1/aspect], along
//!   normalise(`to_world` · (0, 0, 1)); the extent therefore comes from `to_world`'s scale.
//!   The ray's length is `far_clip − near_clip` (in world units, as Mitsuba).
//! - `hdrfilm`'s `crop_offset_x`/`_y` (default 0) and `crop_width`/`_height` (default: the
//!   film size) select the window that is rendered: the image has the crop size and shows
//!   exactly those pixels of the full film (`crop_offset + crop_size` must lie within the
//!   film).
//! - `shutter_open`/`shutter_close` are accepted (Specula's scenes are static, so they have no
//!   effect).
//!
//! Deviation: Specula renders RGB only, so the sensors have no `srf` (spectral response).

use crate::core::{Ray, Result};
use crate::xml::Node;
use glam::{Mat4, Vec2, Vec3};
use specula_bsdf::warp::square_to_uniform_disk_concentric;

/// The sensor plugins Specula supports.
pub const SENSORS: [&str; 3] = ["perspective", "thinlens", "orthographic"];

/// Which image axis `fov` spans.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    /// Mitsuba's names (case-insensitive, as Mitsuba lower-cases them).
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s.to_ascii_lowercase().as_str() {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            _ => return None,
        })
    }
}

/// tan(fov_x / 2) for `fov` degrees along `axis` on an image of aspect `aspect` = width/height
/// (Mitsuba's `parse_fov`, which works in double precision).
pub fn tan_half_fov_x(fov: f64, axis: FovAxis, aspect: f64) -> f64 {
    let t = (0.5 * fov.to_radians()).tan();
    let from_y = t * aspect;
    match axis {
        FovAxis::X => t,
        FovAxis::Y => from_y,
        // diagonal = 2t; width = diagonal / √(1 + 1/aspect²)
        FovAxis::Diagonal => t / (1.0 + 1.0 / (aspect * aspect)).sqrt(),
        FovAxis::Smaller => {
            if aspect > 1.0 {
                from_y
            } else {
                t
            }
        }
        FovAxis::Larger => {
            if aspect > 1.0 {
                t
            } else {
                from_y
            }
        }
    }
}

/// The field of view of a node with Mitsuba's `fov`/`fov_axis`/`focal_length` parameters, as
/// tan(fov_x / 2) for an image of aspect `aspect` (Mitsuba's `parse_fov`; also used by the
/// `projector` emitter).
pub fn parse_fov(n: &Node, aspect: f64) -> Result<f32> {
    let fov = n.float_opt("fov")?;
    let focal = n.string_opt("focal_length")?;
    let (fov, axis) =
        match (fov, focal) {
            (Some(_), Some(_)) => return Err(n.error(
                "give either a focal length ('focal_length') or a field of view ('fov'), not both",
            )),
            (Some(fov), None) => {
                let name = n.string("fov_axis", "x")?;
                let axis = FovAxis::parse(&name).ok_or_else(|| {
                    n.error(format!(
                        "fov_axis '{name}' is invalid (x, y, diagonal, smaller, larger)"
                    ))
                })?;
                (fov as f64, axis)
            }
            (None, focal) => {
                if n.has("fov_axis") {
                    return Err(n.error(
                        "'fov_axis' only applies to 'fov' (a focal length spans the diagonal)",
                    ));
                }
                let text = focal.unwrap_or_else(|| "50mm".to_string());
                let num = text.trim().strip_suffix("mm").unwrap_or(text.trim()).trim();
                let f: f64 = num.parse().map_err(|_| {
                    n.error(format!(
                        "could not parse the focal length '{text}' (must be of the form <x>mm)"
                    ))
                })?;
                let fov = 2.0 * (36f64.hypot(24.0) / (2.0 * f)).atan().to_degrees();
                (fov, FovAxis::Diagonal)
            }
        };
    let t = tan_half_fov_x(fov, axis, aspect);
    let fov_x = 2.0 * t.atan().to_degrees();
    if !(fov_x > 0.0 && fov_x < 180.0) || !t.is_finite() {
        return Err(n.error(format!(
            "the horizontal field of view must lie in (0, 180) degrees, got {fov_x}"
        )));
    }
    Ok(t as f32)
}

/// The film's geometry: its full size and the crop window that is rendered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilmWindow {
    /// Full film size (`width`, `height`): sets the aspect ratio and the field of view.
    pub size: (usize, usize),
    /// Top-left pixel of the rendered window.
    pub crop_offset: (usize, usize),
    /// Size of the rendered window (the output image).
    pub crop_size: (usize, usize),
}

impl FilmWindow {
    /// The whole film.
    pub fn full(width: usize, height: usize) -> Self {
        FilmWindow {
            size: (width, height),
            crop_offset: (0, 0),
            crop_size: (width, height),
        }
    }

    /// Reads `hdrfilm`'s `crop_offset_x`/`_y`, `crop_width`/`_height` for a film of
    /// `width` × `height` pixels.
    pub fn from_node(n: &Node, width: usize, height: usize) -> Result<Self> {
        let get = |name: &str, default: usize, limit: usize| -> Result<usize> {
            let v = n.int(name, default as i64)?;
            if v < 0 || v as u64 > limit as u64 {
                return Err(n.error(format!("{name} must lie in [0, {limit}], got {v}")));
            }
            Ok(v as usize)
        };
        let ox = get("crop_offset_x", 0, width)?;
        let oy = get("crop_offset_y", 0, height)?;
        let cw = get("crop_width", width, width)?;
        let ch = get("crop_height", height, height)?;
        if cw == 0 || ch == 0 {
            return Err(n.error(format!("the crop window is empty ({cw}×{ch})")));
        }
        if ox + cw > width || oy + ch > height {
            return Err(n.error(format!(
                "invalid crop window: crop_offset ({ox}, {oy}) + crop size ({cw}, {ch}) exceeds the film size ({width}, {height})"
            )));
        }
        Ok(FilmWindow {
            size: (width, height),
            crop_offset: (ox, oy),
            crop_size: (cw, ch),
        })
    }

    /// Full film aspect ratio (width / height).
    pub fn aspect(&self) -> f64 {
        self.size.0 as f64 / self.size.1 as f64
    }
}

/// The parameter names of hdrfilm's crop window.
pub const CROP_PARAMS: [&str; 4] = [
    "crop_offset_x",
    "crop_offset_y",
    "crop_width",
    "crop_height",
];

/// Maps a position on the rendered (crop) image, s ∈ \[0,1\]², to the full film's
/// \[0,1\]²: offset + s·scale (offset 0, scale 1 without a crop, leaving s bit-identical).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Window {
    offset: Vec2,
    scale: Vec2,
}

impl Window {
    fn new(w: &FilmWindow) -> Self {
        let (fw, fh) = (w.size.0 as f32, w.size.1 as f32);
        Window {
            offset: Vec2::new(w.crop_offset.0 as f32 / fw, w.crop_offset.1 as f32 / fh),
            scale: Vec2::new(w.crop_size.0 as f32 / fw, w.crop_size.1 as f32 / fh),
        }
    }

    #[inline]
    fn map(&self, s: Vec2) -> Vec2 {
        self.offset + s * self.scale
    }
}

/// Mitsuba's `perspective`: a pinhole camera.
#[derive(Clone, Debug)]
pub struct PerspectiveCamera {
    pub to_world: Mat4,
    origin: Vec3,
    /// tan(fov_x / 2)
    tan_half_x: f32,
    /// Full film width / height.
    aspect: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    window: Window,
    /// Principal point offset (in units of the full film's size).
    ppo: Vec2,
}

impl PerspectiveCamera {
    /// `fov` in degrees along `axis`, for a film of `width` × `height` pixels (no crop, no
    /// principal point offset).
    pub fn new(
        to_world: Mat4,
        fov: f32,
        axis: FovAxis,
        width: usize,
        height: usize,
        near_clip: f32,
        far_clip: f32,
    ) -> Self {
        let window = FilmWindow::full(width, height);
        let t = tan_half_fov_x(fov as f64, axis, window.aspect()) as f32;
        Self::with_window(to_world, t, &window, Vec2::ZERO, near_clip, far_clip)
    }

    /// A camera with horizontal half-angle tangent `tan_half_x` over the full film of
    /// `window`, rendering its crop window, with principal point offset `ppo`.
    pub fn with_window(
        to_world: Mat4,
        tan_half_x: f32,
        window: &FilmWindow,
        ppo: Vec2,
        near_clip: f32,
        far_clip: f32,
    ) -> Self {
        let (w, h) = (window.size.0 as f32, window.size.1 as f32);
        PerspectiveCamera {
            to_world,
            origin: to_world.transform_point3(Vec3::ZERO),
            tan_half_x,
            aspect: w / h,
            near_clip,
            far_clip,
            window: Window::new(window),
            ppo,
        }
    }

    /// Camera-space direction (z = 1) through crop-film position `s`.
    #[inline]
    fn dir_cam(&self, s: Vec2) -> Vec3 {
        let q = self.window.map(s) + self.ppo;
        let x = (1.0 - 2.0 * q.x) * self.tan_half_x;
        let y = (1.0 - 2.0 * q.y) / self.aspect * self.tan_half_x;
        Vec3::new(x, y, 1.0)
    }

    /// The primary ray through normalised film position `s` ∈ \[0,1\]² ((0,0) = top-left).
    #[inline]
    pub fn ray(&self, s: Vec2) -> Ray {
        let d_cam = self.dir_cam(s);
        let inv_len = 1.0 / d_cam.length();
        let d = self.to_world.transform_vector3(d_cam * inv_len).normalize();
        // the clip planes are perpendicular to the viewing axis
        let near_t = self.near_clip * inv_len.recip();
        let far_t = self.far_clip * inv_len.recip();
        Ray {
            o: self.origin + d * near_t,
            d,
            t_max: far_t - near_t,
        }
    }
}

/// Mitsuba's `thinlens`: a perspective camera with a circular aperture (depth of field).
#[derive(Clone, Debug)]
pub struct ThinLensCamera {
    pinhole: PerspectiveCamera,
    pub aperture_radius: f32,
    pub focus_distance: f32,
}

impl ThinLensCamera {
    /// The ray through crop-film position `s` leaving the lens at aperture sample `u`
    /// ∈ \[0,1\]².
    #[inline]
    pub fn ray(&self, s: Vec2, u: Vec2) -> Ray {
        let c = &self.pinhole;
        let focus_p = c.dir_cam(s) * self.focus_distance;
        let a = square_to_uniform_disk_concentric(u) * self.aperture_radius;
        let ap = Vec3::new(a.x, a.y, 0.0);
        let d_cam = (focus_p - ap).normalize();
        let d = c.to_world.transform_vector3(d_cam).normalize();
        let o = c.to_world.transform_point3(ap);
        let inv_z = 1.0 / d_cam.z;
        let near_t = c.near_clip * inv_z;
        let far_t = c.far_clip * inv_z;
        Ray {
            o: o + d * near_t,
            d,
            t_max: far_t - near_t,
        }
    }
}

/// Mitsuba's `orthographic`: parallel rays; the visible extent is `to_world`'s scale.
#[derive(Clone, Debug)]
pub struct OrthographicCamera {
    pub to_world: Mat4,
    d: Vec3,
    aspect: f32,
    pub near_clip: f32,
    pub far_clip: f32,
    window: Window,
}

impl OrthographicCamera {
    #[inline]
    pub fn ray(&self, s: Vec2) -> Ray {
        let q = self.window.map(s);
        let p = Vec3::new(
            1.0 - 2.0 * q.x,
            (1.0 - 2.0 * q.y) / self.aspect,
            self.near_clip,
        );
        Ray {
            o: self.to_world.transform_point3(p),
            d: self.d,
            t_max: self.far_clip - self.near_clip,
        }
    }
}

/// A sensor the renderer traces primary rays from.
#[derive(Clone, Debug)]
pub enum Camera {
    Perspective(PerspectiveCamera),
    ThinLens(ThinLensCamera),
    Orthographic(OrthographicCamera),
}

impl From<PerspectiveCamera> for Camera {
    fn from(c: PerspectiveCamera) -> Self {
        Camera::Perspective(c)
    }
}

impl Camera {
    /// Whether rays need an aperture sample (two random numbers) besides the film position.
    #[inline]
    pub fn needs_aperture_sample(&self) -> bool {
        matches!(self, Camera::ThinLens(_))
    }

    /// The primary ray through normalised (crop) film position `s` ∈ \[0,1\]² ((0,0) =
    /// top-left); `aperture` is called for an aperture sample ∈ \[0,1\)² only by cameras that
    /// need one, so a pinhole camera consumes no random numbers.
    #[inline]
    pub fn sample_ray(&self, s: Vec2, aperture: impl FnOnce() -> Vec2) -> Ray {
        match self {
            Camera::Perspective(c) => c.ray(s),
            Camera::ThinLens(c) => c.ray(s, aperture()),
            Camera::Orthographic(c) => c.ray(s),
        }
    }

    /// The ray through `s` with the aperture sample at the lens centre.
    #[inline]
    pub fn ray(&self, s: Vec2) -> Ray {
        self.sample_ray(s, || Vec2::splat(0.5))
    }

    /// Builds a `<sensor>` (perspective, thinlens or orthographic) for the film `window`.
    /// Nested elements (film, sampler) are the caller's; this reads the sensor's own
    /// parameters and checks that none is left unread.
    pub fn from_node(n: &Node, window: &FilmWindow) -> Result<Camera> {
        let to_world = n.transform("to_world")?.unwrap_or(Mat4::IDENTITY);
        let near = n.float("near_clip", 1e-2)?;
        let far = n.float("far_clip", 1e4)?;
        if !(near > 0.0) || !near.is_finite() {
            return Err(n.error(format!("near_clip must be positive, got {near}")));
        }
        if !(near < far) || !far.is_finite() {
            return Err(n.error(format!(
                "near_clip ({near}) must be smaller than far_clip ({far})"
            )));
        }
        let focus = n.float("focus_distance", far)?;
        if !focus.is_finite() {
            return Err(n.error(format!("focus_distance must be finite, got {focus}")));
        }
        let open = n.float("shutter_open", 0.0)?;
        let close = n.float("shutter_close", 0.0)?;
        if !(open.is_finite() && close.is_finite() && close >= open) {
            return Err(n.error(format!(
                "shutter_close ({close}) must not come before shutter_open ({open})"
            )));
        }
        if !to_world.is_finite() {
            return Err(n.error("the sensor's to_world transform is not finite"));
        }
        const COMMON: [&str; 6] = [
            "to_world",
            "near_clip",
            "far_clip",
            "focus_distance",
            "shutter_open",
            "shutter_close",
        ];
        let cam = match n.plugin_type.as_str() {
            "perspective" | "thinlens" => {
                if has_scale(&to_world) {
                    return Err(n.error(
                        "scale factors in the camera-to-world transformation are not allowed",
                    ));
                }
                let t = parse_fov(n, window.aspect())?;
                let thin = n.plugin_type == "thinlens";
                let ppo = if thin {
                    Vec2::ZERO
                } else {
                    Vec2::new(
                        n.float("principal_point_offset_x", 0.0)?,
                        n.float("principal_point_offset_y", 0.0)?,
                    )
                };
                if !ppo.is_finite() {
                    return Err(n.error("the principal point offset must be finite"));
                }
                let pinhole = PerspectiveCamera::with_window(to_world, t, window, ppo, near, far);
                if thin {
                    let radius = n
                        .float_opt("aperture_radius")?
                        .ok_or_else(|| n.error("thinlens needs an 'aperture_radius'"))?;
                    if !radius.is_finite() {
                        return Err(
                            n.error(format!("aperture_radius must be finite, got {radius}"))
                        );
                    }
                    if !(focus > 0.0) {
                        return Err(
                            n.error(format!("focus_distance must be positive, got {focus}"))
                        );
                    }
                    // Mitsuba replaces a zero radius by its epsilon (with a warning)
                    let radius = if radius == 0.0 { 1e-7 } else { radius };
                    n.check_unused(
                        &[
                            &COMMON[..],
                            &["fov", "fov_axis", "focal_length", "aperture_radius"],
                        ]
                        .concat(),
                    )?;
                    Camera::ThinLens(ThinLensCamera {
                        pinhole,
                        aperture_radius: radius,
                        focus_distance: focus,
                    })
                } else {
                    n.check_unused(
                        &[
                            &COMMON[..],
                            &[
                                "fov",
                                "fov_axis",
                                "focal_length",
                                "principal_point_offset_x",
                                "principal_point_offset_y",
                            ],
                        ]
                        .concat(),
                    )?;
                    Camera::Perspective(pinhole)
                }
            }
            "orthographic" => {
                let d = to_world.transform_vector3(Vec3::Z);
                if !(d.length_squared() > 0.0) {
                    return Err(n.error("the orthographic camera's to_world is singular"));
                }
                n.check_unused(&COMMON)?;
                Camera::Orthographic(OrthographicCamera {
                    to_world,
                    d: d.normalize(),
                    aspect: window.aspect() as f32,
                    near_clip: near,
                    far_clip: far,
                    window: Window::new(window),
                })
            }
            other => {
                return Err(n.error(format!(
                    "sensor '{other}' is not supported (supported: {})",
                    SENSORS.join(", ")
                )))
            }
        };
        Ok(cam)
    }
}

/// Whether the linear part of `m` is not orthonormal (Mitsuba's `Transform::has_scale`:
/// some entry of MᵀM differs from the identity's by more than 10⁻³).
fn has_scale(m: &Mat4) -> bool {
    let c = [
        m.x_axis.truncate(),
        m.y_axis.truncate(),
        m.z_axis.truncate(),
    ];
    (0..3).any(|i| {
        (i..3).any(|j| {
            let want = if i == j { 1.0 } else { 0.0 };
            (c[i].dot(c[j]) - want).abs() > 1e-3
        })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;
    use std::path::Path;

    /// Builds the camera of a one-sphere scene whose sensor is `sensor` (XML text).
    fn camera(sensor: &str) -> Result<Camera> {
        let text = format!("<scene version=\"3.0.0\">{sensor}<shape type=\"sphere\"/></scene>");
        Scene::from_xml_str(&text, "<test>", Path::new("."), &[]).map(|s| s.camera)
    }

    fn film(w: usize, h: usize, extra: &str) -> String {
        format!("<film type=\"hdrfilm\"><integer name=\"width\" value=\"{w}\"/><integer name=\"height\" value=\"{h}\"/>{extra}</film>")
    }

    fn close(a: Vec3, b: [f32; 3], tol: f32) {
        assert!(
            (a - Vec3::from(b)).abs().max_element() < tol,
            "{a} vs {b:?}"
        );
    }

    #[test]
    fn perspective_fov_rules_match_mitsuba() {
        // Mitsuba 3.9.1 scalar_rgb, 64×48 film, sample_ray at (1, 0.5), (0.5, 1), (0, 0):
        // ray.d of each.
        let cases: [(&str, [[f32; 3]; 3]); 4] = [
            (
                "", // 50 mm default
                [
                    [-0.327093, 0.0, 0.944992],
                    [0.0, -0.251271, 0.967917],
                    [0.317673, 0.238255, 0.917779],
                ],
            ),
            (
                r#"<string name="focal_length" value="35mm"/>"#,
                [
                    [-0.443247, 0.0, 0.896399],
                    [0.0, -0.347715, 0.9376],
                    [0.420615, 0.315461, 0.850628],
                ],
            ),
            (
                r#"<string name="focal_length" value="50"/>"#,
                [
                    [-0.327093, 0.0, 0.944992],
                    [0.0, -0.251271, 0.967917],
                    [0.317673, 0.238255, 0.917779],
                ],
            ),
            (
                r#"<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>"#,
                [
                    [-0.436598, 0.0, 0.899657],
                    [0.0, -0.34202, 0.939693],
                    [0.41492, 0.31119, 0.854987],
                ],
            ),
        ];
        for (params, want) in cases {
            let c = camera(&format!(
                "<sensor type=\"perspective\">{params}{}</sensor>",
                film(64, 48, "")
            ))
            .unwrap();
            for (s, w) in [(1.0, 0.5), (0.5, 1.0), (0.0, 0.0)].into_iter().zip(want) {
                let r = c.ray(Vec2::new(s.0, s.1));
                close(r.d, w, 2e-6);
            }
        }
        // near plane and length: (1, 0.5) at 50 mm
        let c = camera(&format!(
            "<sensor type=\"perspective\">{}</sensor>",
            film(64, 48, "")
        ))
        .unwrap();
        let r = c.ray(Vec2::new(1.0, 0.5));
        close(r.o, [-0.00346133, 0.0, 0.01], 1e-7);
        assert!((r.t_max - 10582.087).abs() < 0.02, "{}", r.t_max);
    }

    #[test]
    fn principal_point_and_crop_match_mitsuba() {
        let c = camera(&format!(
            r#"<sensor type="perspective"><float name="fov" value="40"/><float name="principal_point_offset_x" value="0.1"/><float name="principal_point_offset_y" value="-0.2"/>{}</sensor>"#,
            film(64, 48, "")
        ))
        .unwrap();
        close(
            c.ray(Vec2::new(1.0, 0.5)).d,
            [-0.398264, 0.099566, 0.911851],
            2e-6,
        );
        close(
            c.ray(Vec2::new(0.5, 1.0)).d,
            [-0.0716522, -0.161218, 0.984315],
            2e-6,
        );
        close(
            c.ray(Vec2::new(0.0, 0.0)).d,
            [0.262455, 0.344473, 0.901363],
            2e-6,
        );
        // crop window (10, 5) + 20×30 of a 64×48 film: corners of the crop image
        let c = camera(&format!(
            r#"<sensor type="perspective"><float name="fov" value="40"/>{}</sensor>"#,
            film(
                64,
                48,
                r#"<integer name="crop_offset_x" value="10"/><integer name="crop_offset_y" value="5"/><integer name="crop_width" value="20"/><integer name="crop_height" value="30"/>"#
            )
        ))
        .unwrap();
        close(
            c.ray(Vec2::new(0.0, 0.0)).d,
            [0.23758, 0.205183, 0.94945],
            2e-6,
        );
        close(
            c.ray(Vec2::new(1.0, 1.0)).d,
            [0.0225664, -0.124115, 0.992011],
            2e-6,
        );
        // crop window and principal point offset together: the offset is in units of the
        // full film (Mitsuba: x/z and y/z of ray.d)
        let c = camera(&format!(
            r#"<sensor type="perspective"><float name="fov" value="40"/><float name="principal_point_offset_x" value="0.1"/><float name="principal_point_offset_y" value="-0.2"/>{}</sensor>"#,
            film(
                64,
                48,
                r#"<integer name="crop_offset_x" value="10"/><integer name="crop_offset_y" value="5"/><integer name="crop_width" value="20"/><integer name="crop_height" value="30"/>"#
            )
        ))
        .unwrap();
        for (s, want) in [
            ((0.0, 0.0), [0.177_435_5, 0.325_298_4]),
            ((1.0, 1.0), [-0.050_045_85, -0.015_923_67]),
            ((0.5, 0.5), [0.063_694_82, 0.154_687_4]),
        ] {
            let d = c.ray(Vec2::new(s.0, s.1)).d;
            assert!(
                (d.x / d.z - want[0]).abs() < 2e-6 && (d.y / d.z - want[1]).abs() < 2e-6,
                "{d}"
            );
        }
    }

    #[test]
    fn thinlens_matches_mitsuba() {
        let c = camera(&format!(
            r#"<sensor type="thinlens"><float name="fov" value="40"/><float name="aperture_radius" value="0.5"/><float name="focus_distance" value="3"/>{}</sensor>"#,
            film(64, 48, "")
        ))
        .unwrap();
        assert!(c.needs_aperture_sample());
        let r = c.sample_ray(Vec2::new(1.0, 0.5), || Vec2::new(1.0, 0.5));
        close(r.o, [0.494694, 0.0, 0.01], 2e-6);
        close(r.d, [-0.468733, 0.0, 0.88334], 2e-6);
        assert!((r.t_max - 11320.658).abs() < 0.05);
        let r = c.sample_ray(Vec2::new(0.25, 0.75), || Vec2::new(0.9, 0.2));
        close(r.o, [0.333299, -0.222852, 0.01], 2e-6);
        close(r.d, [0.0708062, -0.0621352, 0.995553], 2e-6);
        // translated, default focus distance (far_clip), 50 mm
        let c = camera(&format!(
            r#"<sensor type="thinlens"><float name="aperture_radius" value="0.2"/><float name="far_clip" value="100"/><transform name="to_world"><translate x="1" y="2" z="3"/></transform>{}</sensor>"#,
            film(64, 48, "")
        ))
        .unwrap();
        let r = c.sample_ray(Vec2::new(0.25, 0.75), || Vec2::new(0.9, 0.2));
        close(r.o, [1.134752, 1.9098196, 3.01], 2e-6);
        close(r.d, [0.167909, -0.126038, 0.977712], 2e-6);
    }

    #[test]
    fn orthographic_matches_mitsuba() {
        let c = camera(&format!(
            r#"<sensor type="orthographic"><transform name="to_world"><scale x="2" y="3" z="4"/><lookat origin="0,0,-5" target="0,0,0" up="0,1,0"/></transform>{}</sensor>"#,
            film(64, 48, "")
        ))
        .unwrap();
        assert!(!c.needs_aperture_sample());
        for (s, o) in [
            ((0.0, 0.0), [2.0, 2.25, -4.96]),
            ((1.0, 1.0), [-2.0, -2.25, -4.96]),
            ((0.25, 0.75), [1.0, -1.125, -4.96]),
        ] {
            let r = c.ray(Vec2::new(s.0, s.1));
            close(r.o, o, 1e-5);
            close(r.d, [0.0, 0.0, 1.0], 1e-6);
            assert!((r.t_max - 9999.99).abs() < 1e-3);
        }
        let c = camera(&format!(
            r#"<sensor type="orthographic"><float name="near_clip" value="1"/><float name="far_clip" value="10"/><transform name="to_world"><scale x="2" y="3" z="4"/></transform>{}</sensor>"#,
            film(64, 48, "")
        ))
        .unwrap();
        let r = c.ray(Vec2::new(0.25, 0.75));
        close(r.o, [1.0, -1.125, 4.0], 1e-6);
        assert_eq!(r.t_max, 9.0);
        let c = camera(&format!(
            r#"<sensor type="orthographic">{}</sensor>"#,
            film(
                64,
                48,
                r#"<integer name="crop_offset_x" value="10"/><integer name="crop_offset_y" value="5"/><integer name="crop_width" value="20"/><integer name="crop_height" value="30"/>"#
            )
        ))
        .unwrap();
        close(c.ray(Vec2::ZERO).o, [0.6875, 0.59375, 0.01], 1e-6);
    }

    #[test]
    fn bad_sensors_are_errors_with_locations() {
        let f = film(64, 48, "");
        for (sensor, want) in [
            (
                format!(
                    r#"<sensor type="perspective"><float name="fov" value="40"/><string name="focal_length" value="20mm"/>{f}</sensor>"#
                ),
                "not both",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><string name="focal_length" value="abc"/>{f}</sensor>"#
                ),
                "focal length",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><string name="focal_length" value="-5mm"/>{f}</sensor>"#
                ),
                "(0, 180)",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><string name="focal_length" value="20mm"/><string name="fov_axis" value="x"/>{f}</sensor>"#
                ),
                "fov_axis",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><float name="fov" value="200"/>{f}</sensor>"#
                ),
                "(0, 180)",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><float name="fov" value="30"/><string name="fov_axis" value="z"/>{f}</sensor>"#
                ),
                "fov_axis",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><float name="near_clip" value="0"/>{f}</sensor>"#
                ),
                "near_clip",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><float name="near_clip" value="5"/><float name="far_clip" value="1"/>{f}</sensor>"#
                ),
                "far_clip",
            ),
            (
                format!(
                    r#"<sensor type="perspective"><transform name="to_world"><scale value="2"/></transform>{f}</sensor>"#
                ),
                "scale factors",
            ),
            (
                format!(r#"<sensor type="thinlens"><float name="fov" value="30"/>{f}</sensor>"#),
                "aperture_radius",
            ),
            (
                format!(
                    r#"<sensor type="thinlens"><float name="aperture_radius" value="0.1"/><float name="principal_point_offset_x" value="0.1"/>{f}</sensor>"#
                ),
                "principal_point_offset_x",
            ),
            (
                format!(
                    r#"<sensor type="orthographic"><float name="fov" value="30"/>{f}</sensor>"#
                ),
                "fov",
            ),
            (
                format!(r#"<sensor type="fisheye">{f}</sensor>"#),
                "not supported",
            ),
            (
                format!(
                    r#"<sensor type="perspective">{}</sensor>"#,
                    film(64, 48, r#"<integer name="crop_offset_x" value="10"/>"#)
                ),
                "crop",
            ),
            (
                format!(
                    r#"<sensor type="perspective">{}</sensor>"#,
                    film(64, 48, r#"<integer name="crop_width" value="0"/>"#)
                ),
                "crop",
            ),
            (
                format!(
                    r#"<sensor type="perspective">{}</sensor>"#,
                    film(64, 48, r#"<integer name="crop_offset_y" value="-1"/>"#)
                ),
                "crop_offset_y",
            ),
        ] {
            let e = camera(&sensor)
                .err()
                .unwrap_or_else(|| panic!("accepted: {sensor}"));
            let msg = e.to_string();
            assert!(
                msg.contains(want) && msg.contains("<test>:1:"),
                "{sensor}: {msg}"
            );
        }
        // accepted as Mitsuba accepts them
        for sensor in [
            format!(
                r#"<sensor type="perspective"><float name="focus_distance" value="-3"/><float name="fov" value="30"/><string name="fov_axis" value="X"/>{f}</sensor>"#
            ),
            format!(
                r#"<sensor type="orthographic"><float name="focus_distance" value="3"/>{f}</sensor>"#
            ),
            format!(
                r#"<sensor type="perspective"><transform name="to_world"><scale x="-1"/><lookat origin="1,2,3" target="0,0,0" up="0,0,1"/></transform>{f}</sensor>"#
            ),
        ] {
            camera(&sensor).unwrap_or_else(|e| panic!("{sensor}: {e}"));
        }
    }

    #[test]
    fn a_crop_renders_the_same_pixels_as_the_full_film() {
        let full = FilmWindow::full(64, 48);
        let crop = FilmWindow {
            size: (64, 48),
            crop_offset: (10, 5),
            crop_size: (20, 30),
        };
        let a = PerspectiveCamera::with_window(Mat4::IDENTITY, 0.4, &full, Vec2::ZERO, 0.01, 100.0);
        let b = PerspectiveCamera::with_window(Mat4::IDENTITY, 0.4, &crop, Vec2::ZERO, 0.01, 100.0);
        for (x, y) in [(0.5f32, 0.5f32), (3.25, 17.5), (19.9, 29.9)] {
            let ra = a.ray(Vec2::new((x + 10.0) / 64.0, (y + 5.0) / 48.0));
            let rb = b.ray(Vec2::new(x / 20.0, y / 30.0));
            assert!((ra.d - rb.d).length() < 1e-6);
        }
    }
}
