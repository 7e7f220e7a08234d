//! The diffuse reflectance ("albedo") of a material, as Mitsuba 3's
//! `BSDF::eval_diffuse_reflectance` defines it: what the `aov` integrator's `albedo` output
//! records.
//!
//! - `diffuse`: its `reflectance`; `plastic`, `roughplastic`: their `diffuse_reflectance`
//!   (whichever side `wi` is on);
//! - `twosided`: the front model's for `wi` above the surface, the back model's (with `wi`
//!   mirrored) below, 0 at grazing `wi`;
//! - `blendbsdf`: the blend of its two models' by `weight` (clamped to [0, 1]);
//! - `mask`, `bumpmap`, `normalmap`: the nested model's, at the unperturbed shading point
//!   (neither the opacity nor the perturbed frame enters, as in Mitsuba);
//! - every other model: Mitsuba's default, π·f(wi, n), the BSDF evaluated towards the shading
//!   normal (0 for purely specular models and one-sided ones seen from below; for glossy
//!   models an approximation that can exceed 1, e.g. 2.78 for a `roughconductor` with α = 0.3
//!   at normal incidence, exactly what Mitsuba reports).

use crate::bsdf::*;
use crate::spectrum::Spectrum;
use glam::Vec3;

use super::Bsdf;

impl Bsdf {
    /// Mitsuba's `eval_diffuse_reflectance` at `sp`, for the direction `wi` (local shading
    /// frame, pointing away from the surface, towards the viewer).
    pub fn diffuse_reflectance(&self, sp: &ShadingPoint, wi: Vec3) -> Spectrum {
        match self {
            Bsdf::Diffuse(b) => b.reflectance.eval(sp),
            Bsdf::Plastic(b) => b.diffuse_reflectance.eval(sp),
            Bsdf::RoughPlastic(b) => b.diffuse_reflectance.eval(sp),
            Bsdf::TwoSided(b) => {
                if wi.z > 0.0 {
                    b.front.diffuse_reflectance(sp, wi)
                } else if wi.z < 0.0 {
                    b.back.diffuse_reflectance(sp, Vec3::new(wi.x, wi.y, -wi.z))
                } else {
                    Spectrum::ZERO
                }
            }
            Bsdf::Blend(b) => {
                let w = b.weight.eval(sp).clamp(0.0, 1.0);
                b.bsdfs[0].diffuse_reflectance(sp, wi) * (1.0 - w)
                    + b.bsdfs[1].diffuse_reflectance(sp, wi) * w
            }
            Bsdf::Mask(b) => b.nested.diffuse_reflectance(sp, wi),
            Bsdf::BumpMap(b) => b.nested.diffuse_reflectance(sp, wi),
            Bsdf::NormalMap(b) => b.nested.diffuse_reflectance(sp, wi),
            _ => self.eval(&BsdfContext::RADIANCE, sp, wi, Vec3::Z) * std::f32::consts::PI,
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::bsdf::ShadingPoint;
    use crate::spec::parse_spec;
    use glam::Vec3;

    #[test]
    fn matches_mitsuba() {
        // Mitsuba 3.9.1 (scalar_rgb), `bsdf.eval_diffuse_reflectance(si)` with si.wi =
        // (0,0,1), normalize(0.3,0.2,0.9) and normalize(0.3,0.2,−0.9), the default flat shading
        // point (scripts/probe_aov.py prints these)
        let wis = [
            Vec3::Z,
            Vec3::new(0.3, 0.2, 0.9).normalize(),
            Vec3::new(0.3, 0.2, -0.9).normalize(),
        ];
        let d = "diffuse reflectance=0.2,0.4,0.6";
        let rc = "roughconductor alpha=0.3";
        let cases: Vec<(String, [[f32; 3]; 3])> = vec![
            (d.into(), [[0.2, 0.4, 0.6]; 3]),
            ("conductor".into(), [[0.0; 3]; 3]),
            ("dielectric".into(), [[0.0; 3]; 3]),
            ("thindielectric".into(), [[0.0; 3]; 3]),
            ("null".into(), [[0.0; 3]; 3]),
            (rc.into(), [[2.77778; 3], [2.12941; 3], [0.0; 3]]),
            (
                "roughdielectric alpha=0.3".into(),
                [[0.112601; 3], [0.0863657; 3], [5.67091e-08; 3]],
            ),
            (
                "plastic diffuse_reflectance=0.2,0.4,0.6".into(),
                [[0.2, 0.4, 0.6]; 3],
            ),
            (
                "roughplastic diffuse_reflectance=0.2,0.4,0.6".into(),
                [[0.2, 0.4, 0.6]; 3],
            ),
            (
                format!("twosided {{ {d} }} {{ diffuse reflectance=0.7,0.1,0.1 }}"),
                [[0.2, 0.4, 0.6], [0.2, 0.4, 0.6], [0.7, 0.1, 0.1]],
            ),
            (
                format!("twosided {{ {rc} }}"),
                [[2.77778; 3], [2.12941; 3], [2.12941; 3]],
            ),
            (
                format!(
                    "blendbsdf weight=0.25 {{ {d} }} {{ plastic diffuse_reflectance=0.7,0.1,0.1 }}"
                ),
                [[0.325, 0.325, 0.475]; 3],
            ),
            (
                format!("blendbsdf weight=0.25 {{ {d} }} {{ {rc} }}"),
                [
                    [0.844444, 0.994444, 1.14444],
                    [0.682352, 0.832352, 0.982352],
                    [0.15, 0.3, 0.45],
                ],
            ),
            (format!("mask opacity=0.3 {{ {d} }}"), [[0.2, 0.4, 0.6]; 3]),
            (
                format!("mask opacity=0.3 {{ {rc} }}"),
                [[2.77778; 3], [2.12941; 3], [0.0; 3]],
            ),
        ];
        let sp = ShadingPoint::at_uv(0.3, 0.3);
        for (spec, want) in cases {
            let b = parse_spec(&spec).unwrap();
            for (wi, w) in wis.iter().zip(want) {
                let a = b.diffuse_reflectance(&sp, *wi);
                let ok = (0..3).all(|i| (a[i] - w[i]).abs() <= 2e-5 * w[i].abs().max(1.0));
                assert!(ok, "{spec}, wi {wi}: {a:?} vs Mitsuba {w:?}");
            }
        }
    }
}
