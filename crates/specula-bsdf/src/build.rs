//! From plugin name and parameters to a model, with Mitsuba 3's parameter names and defaults.
//!
//! **Dispersion (Specula's extension; Mitsuba 3 has none).** `dielectric`, `roughdielectric`
//! and `thindielectric` accept, instead of a constant `int_ior`, a wavelength-dependent
//! interior index (the exterior `ext_ior` stays constant), given by exactly one of:
//!
//! - `<string name="dispersion" value="bk7"/>`: a named glass of
//!   [`crate::spectral::dispersion::NAMED_GLASSES`] (`bk7`, `fused silica`, `sapphire`,
//!   `diamond`, `water`, `acrylic`, `polycarbonate`, `sf11`, `f2`); `int_ior` must not be given;
//! - `<float name="abbe_number" value="40"/>`: the Abbe number V_d, with `int_ior` read as
//!   n_d, the index at 587.56 nm (as OpenPBR and glTF `KHR_materials_dispersion` do; the
//!   formula is the Cauchy fit of [`crate::spectral::dispersion`]);
//! - `cauchy_a`, `cauchy_b` (µm²) and optionally `cauchy_c` (µm⁴): n = A + B/λ² + C/λ⁴;
//!   `int_ior` must not be given;
//! - `sellmeier_b1`, `sellmeier_c1` (µm²) and optionally `sellmeier_b2`, `sellmeier_c2`,
//!   `sellmeier_b3`, `sellmeier_c3`: n² = 1 + Σ Bᵢλ²/(λ² − Cᵢ); `int_ior` must not be given.
//!
//! `int_ior="bk7"` and the other names keep Mitsuba's constant meaning, so non-dispersive
//! scenes render as in Mitsuba. In RGB mode a dispersive material uses its index at the d line
//! (587.56 nm; e.g. 1.5168 for `dispersion="bk7"`, where Mitsuba's constant `bk7` is 1.5046); in
//! spectral mode each wavelength refracts with its own index.

use crate::bsdf::{BsdfModel, FloatParam, ShadingPoint, SpectrumParam};
use crate::fresnel::FresnelMode;
use crate::microfacet::MicrofacetType;
use crate::models::bumpmap::Bump;
use crate::models::normalmap::NormalTexture;
use crate::models::perturbed::Perturbed;
use crate::models::*;
use crate::props::{BuildError, Props};
use crate::spectral::dispersion::{Dispersion, Ior};
use crate::spectrum::Spectrum;

/// The parameters of a dispersive interior index (see the module docs).
const DISPERSION: &[&str] = &[
    "dispersion",
    "abbe_number",
    "cauchy_a",
    "cauchy_b",
    "cauchy_c",
    "sellmeier_b1",
    "sellmeier_b2",
    "sellmeier_b3",
    "sellmeier_c1",
    "sellmeier_c2",
    "sellmeier_c3",
];

/// `a` followed by `b`, in a constant.
const fn concat<const N: usize>(a: &[&'static str], b: &[&'static str]) -> [&'static str; N] {
    assert!(a.len() + b.len() == N);
    let mut out = [""; N];
    let mut i = 0;
    while i < a.len() {
        out[i] = a[i];
        i += 1;
    }
    while i < N {
        out[i] = b[i - a.len()];
        i += 1;
    }
    out
}

const DIELECTRIC: [&str; 16] = concat(
    &[
        "int_ior",
        "ext_ior",
        "specular_reflectance",
        "specular_transmittance",
        "fresnel",
    ],
    DISPERSION,
);

const ROUGHDIELECTRIC: [&str; 23] = concat(
    &[
        "int_ior",
        "ext_ior",
        "specular_reflectance",
        "specular_transmittance",
        "distribution",
        "alpha",
        "alpha_u",
        "alpha_v",
        "sample_visible",
        "smith_g1",
        "fresnel",
        "multiscatter",
    ],
    DISPERSION,
);

/// Every plugin Specula builds, with its parameters.
pub const PLUGINS: &[(&str, &[&str])] = &[
    ("diffuse", &["reflectance"]),
    (
        "conductor",
        &["material", "eta", "k", "specular_reflectance"],
    ),
    (
        "roughconductor",
        &[
            "material",
            "eta",
            "k",
            "specular_reflectance",
            "distribution",
            "alpha",
            "alpha_u",
            "alpha_v",
            "sample_visible",
            "smith_g1",
            "multiscatter",
        ],
    ),
    ("dielectric", &DIELECTRIC),
    ("thindielectric", &DIELECTRIC),
    ("roughdielectric", &ROUGHDIELECTRIC),
    (
        "plastic",
        &[
            "int_ior",
            "ext_ior",
            "diffuse_reflectance",
            "specular_reflectance",
            "nonlinear",
            "fresnel",
            "diffuse_fresnel",
        ],
    ),
    (
        "roughplastic",
        &[
            "int_ior",
            "ext_ior",
            "diffuse_reflectance",
            "specular_reflectance",
            "nonlinear",
            "distribution",
            "alpha",
            "sample_visible",
            "smith_g1",
            "fresnel",
            "multiscatter",
        ],
    ),
    ("sheen", &["reflectance", "roughness"]),
    ("principled", crate::models::principled::PARAMS),
    ("principledthin", crate::models::principledthin::PARAMS),
    ("twosided", &[]),
    ("blendbsdf", &["weight", "dirac_mixing"]),
    ("measured", &["filename"]),
    ("merl", &["filename", "interpolate", "sampling"]),
    (
        "bumpmap",
        &["scale", "flip_invalid_normals", "use_shadowing_function"],
    ),
    (
        "normalmap",
        &[
            "normalmap",
            "flip_invalid_normals",
            "use_shadowing_function",
        ],
    ),
    ("mask", &["opacity"]),
    ("null", &[]),
    (
        "irawan",
        &[
            "filename", "pattern", "repeatU", "repeatV", "warp_kd", "warp_ks", "weft_kd", "weft_ks",
        ],
    ),
    ("velvet", &["reflectance", "sigma", "amplitude"]),
];

/// Parameters a plugin accepts, or `None` for an unknown plugin.
pub fn plugin_params(name: &str) -> Option<&'static [&'static str]> {
    PLUGINS.iter().find(|(n, _)| *n == name).map(|(_, p)| *p)
}

fn fresnel_mode(p: &Props) -> Result<FresnelMode, BuildError> {
    Ok(
        match p
            .choice("fresnel", "exact", &["exact", "schlick"])?
            .as_str()
        {
            "schlick" => FresnelMode::Schlick,
            _ => FresnelMode::Exact,
        },
    )
}

/// `smith_g1`: `exact` (default) or `rational` (Mitsuba's approximation for Beckmann).
fn rational_g1(p: &Props) -> Result<bool, BuildError> {
    Ok(p.choice("smith_g1", "exact", &["exact", "rational"])? == "rational")
}

fn distribution(p: &Props) -> Result<MicrofacetType, BuildError> {
    let d = p.choice("distribution", "beckmann", &["beckmann", "ggx"])?;
    Ok(MicrofacetType::parse(&d).expect("validated"))
}

/// `alpha`, or `alpha_u` and `alpha_v` (anisotropic); default 0.1.
fn roughness(p: &Props, allow_aniso: bool) -> Result<(FloatParam, FloatParam), BuildError> {
    let has_uv = p.has("alpha_u") || p.has("alpha_v");
    if has_uv && !allow_aniso {
        return Err(BuildError::new(
            p.loc.clone(),
            format!(
                "'{}' is isotropic: give 'alpha', not 'alpha_u'/'alpha_v'",
                p.plugin
            ),
        ));
    }
    if has_uv {
        if p.has("alpha") {
            return Err(BuildError::new(
                p.loc.clone(),
                format!(
                    "'{}': give either 'alpha' or 'alpha_u'/'alpha_v', not both",
                    p.plugin
                ),
            ));
        }
        if !(p.has("alpha_u") && p.has("alpha_v")) {
            return Err(BuildError::new(
                p.loc.clone(),
                format!(
                    "'{}': 'alpha_u' and 'alpha_v' must be given together",
                    p.plugin
                ),
            ));
        }
        Ok((
            p.float_param("alpha_u", 0.1)?,
            p.float_param("alpha_v", 0.1)?,
        ))
    } else {
        let a = p.float_param("alpha", 0.1)?;
        Ok((a.clone(), a))
    }
}

fn check_alpha(p: &Props, a: &FloatParam) -> Result<(), BuildError> {
    if let FloatParam::Const(v) = a {
        if *v < 0.0 {
            return Err(BuildError::new(
                p.loc.clone(),
                format!("'{}': roughness must be non-negative, got {v}", p.plugin),
            ));
        }
    }
    Ok(())
}

/// Complex IOR: `material` (named conductor, default `none` = ideal mirror) or `eta`/`k`.
fn complex_ior(p: &Props) -> Result<(SpectrumParam, SpectrumParam), BuildError> {
    let material = p.string("material", "none")?;
    if p.has("eta") || p.has("k") || material == "none" {
        if material != "none" {
            return Err(BuildError::new(
                p.loc.clone(),
                format!(
                    "'{}': give either 'material' or 'eta'/'k', not both",
                    p.plugin
                ),
            ));
        }
        return Ok((p.spectrum("eta", 0.0)?, p.spectrum("k", 1.0)?));
    }
    match crate::data::lookup_conductor(&material) {
        // in spectral mode, the measured η(λ), k(λ) where the conductor has them
        Some((e, k)) => Ok(match crate::spectral::conductors::lookup(&material) {
            Some(c) => (
                SpectrumParam::Spectral {
                    rgb: Spectrum::from(e),
                    curve: std::sync::Arc::new(crate::spectral::NamedConductor { c, k: false }),
                },
                SpectrumParam::Spectral {
                    rgb: Spectrum::from(k),
                    curve: std::sync::Arc::new(crate::spectral::NamedConductor { c, k: true }),
                },
            ),
            None => (
                SpectrumParam::Const(Spectrum::from(e)),
                SpectrumParam::Const(Spectrum::from(k)),
            ),
        }),
        None => {
            let names: Vec<&str> = crate::data::NAMED_CONDUCTORS
                .iter()
                .map(|(n, _, _)| *n)
                .collect();
            Err(BuildError::new(
                p.loc.clone(),
                format!(
                    "unknown conductor '{material}'; known: none, {}",
                    names.join(", ")
                ),
            ))
        }
    }
}

fn eta(p: &Props, default_int: &str) -> Result<f32, BuildError> {
    let int = p.ior("int_ior", default_int)?;
    let ext = p.ior("ext_ior", "air")?;
    Ok(int / ext)
}

const CAUCHY: [&str; 3] = ["cauchy_a", "cauchy_b", "cauchy_c"];
const SELLMEIER: [&str; 6] = [
    "sellmeier_b1",
    "sellmeier_c1",
    "sellmeier_b2",
    "sellmeier_c2",
    "sellmeier_b3",
    "sellmeier_c3",
];

/// The relative index of a dielectric interface, and its dispersion when the interior index
/// depends on the wavelength (Specula's parameters, see the module documentation); the
/// constant index is then the one at the d line.
fn dielectric_eta(p: &Props, default_int: &str) -> Result<(f32, Option<Dispersion>), BuildError> {
    let ext = p.ior("ext_ior", "air")?;
    let given: Vec<&str> = ["dispersion", "abbe_number"]
        .into_iter()
        .chain(CAUCHY)
        .chain(SELLMEIER)
        .filter(|n| p.has(n))
        .collect();
    if given.is_empty() {
        return Ok((p.ior("int_ior", default_int)? / ext, None));
    }
    let err = |msg: String| {
        Err(BuildError::new(
            p.loc.clone(),
            format!("'{}': {msg}", p.plugin),
        ))
    };
    fn family(n: &str) -> &str {
        if n.starts_with("cauchy_") {
            "cauchy_*"
        } else if n.starts_with("sellmeier_") {
            "sellmeier_*"
        } else {
            n
        }
    }
    if let Some(other) = given.iter().find(|n| family(n) != family(given[0])) {
        return err(format!(
            "give one dispersion model, not both '{}' and '{other}'",
            given[0]
        ));
    }
    let uses_int_ior = given[0] == "abbe_number";
    if !uses_int_ior && p.has("int_ior") {
        return err(format!(
            "'int_ior' and '{}' both give the interior index; drop 'int_ior' (with a dispersion \
             model the index at 587.56 nm is used in RGB mode)",
            given[0]
        ));
    }
    let int = match family(given[0]) {
        "dispersion" => {
            let name = p.string("dispersion", "")?;
            match crate::spectral::dispersion::glass(&name) {
                Some(g) => g.ior,
                None => {
                    return err(format!(
                        "unknown dispersive material '{name}'; known: {}",
                        crate::spectral::dispersion::glass_names().join(", ")
                    ))
                }
            }
        }
        "abbe_number" => {
            let n_d = p.ior("int_ior", default_int)?;
            let v = p.float("abbe_number", 0.0)?;
            if v <= 0.0 {
                return err(format!("'abbe_number' must be positive, got {v}"));
            }
            if n_d <= 1.0 {
                return err(format!(
                    "'abbe_number' needs an interior index above 1 ('int_ior' = {n_d})"
                ));
            }
            Ior::from_abbe(n_d, v)
        }
        "cauchy_*" => {
            let a = p.float_required("cauchy_a")?;
            let b = p.float_required("cauchy_b")?;
            let c = p.float("cauchy_c", 0.0)?;
            Ior::Cauchy { a, b, c }
        }
        _ => {
            let mut v = [0.0f32; 6];
            for (i, n) in SELLMEIER.iter().enumerate() {
                v[i] = if i < 2 {
                    p.float_required(n)?
                } else {
                    p.float(n, 0.0)?
                };
            }
            Ior::sellmeier(&[v[0], v[2], v[4]], &[v[1], v[3], v[5]])
        }
    };
    // the formula must give a usable index over the visible range (and a bit beyond)
    for l in (360..=830).step_by(5) {
        let n = int.at(l as f32);
        let bad = match int {
            Ior::Sellmeier { b, c } => {
                let l2 = (l as f64 * 1e-3).powi(2);
                let n2: f64 = 1.0
                    + (0..4)
                        .map(|i| b[i] as f64 * l2 / (l2 - c[i] as f64))
                        .sum::<f64>();
                !(n2.is_finite() && n2 > 0.0)
            }
            _ => false,
        };
        if bad || !n.is_finite() || n <= 0.0 {
            return err(format!(
                "the dispersion formula ({}) gives no valid index at {l} nm",
                int.describe()
            ));
        }
    }
    let d = Dispersion { int, ext };
    Ok((d.eta_d(), Some(d)))
}

/// The single nested BSDF of a wrapper (`bumpmap`, `normalmap`, `mask`).
fn one_nested(p: &Props) -> Result<Bsdf, BuildError> {
    match p.children.as_slice() {
        [(b, _)] => Ok(b.clone()),
        kids => Err(BuildError::new(
            p.loc.clone(),
            format!(
                "'{}' needs exactly one nested BSDF, got {}",
                p.plugin,
                kids.len()
            ),
        )),
    }
}

/// `flip_invalid_normals` and `use_shadowing_function` of `bumpmap` and `normalmap`.
fn perturbed<P>(p: &Props, perturbation: P) -> Result<Perturbed<P>, BuildError> {
    Ok(Perturbed {
        perturbation,
        nested: one_nested(p)?,
        flip_invalid_normals: p.bool("flip_invalid_normals", true)?,
        use_shadowing_function: p.bool("use_shadowing_function", true)?,
    })
}

/// Build a model from its plugin name, parameters and nested BSDFs.
/// The most models (leaves, `twosided`s and `blendbsdf`s) one BSDF may be made of. A
/// `twosided` with one nested BSDF holds it twice, so nested `twosided`s double the size at
/// every level; real materials have a handful.
pub const MAX_BSDF_NODES: usize = 1024;

/// How many models `b` is made of.
fn node_count(b: &Bsdf) -> usize {
    match b {
        Bsdf::TwoSided(t) => 1 + node_count(&t.front) + node_count(&t.back),
        Bsdf::Blend(bl) => 1 + node_count(&bl.bsdfs[0]) + node_count(&bl.bsdfs[1]),
        _ => 1,
    }
}

pub fn build_bsdf(p: Props) -> Result<Bsdf, BuildError> {
    let Some(valid) = plugin_params(&p.plugin) else {
        let names: Vec<&str> = PLUGINS.iter().map(|(n, _)| *n).collect();
        return Err(BuildError::new(
            p.loc.clone(),
            format!(
                "unknown BSDF plugin '{}'; known: {}",
                p.plugin,
                names.join(", ")
            ),
        ));
    };
    let nested_ok = matches!(
        p.plugin.as_str(),
        "twosided" | "blendbsdf" | "bumpmap" | "normalmap" | "mask"
    );
    if !nested_ok && !p.children.is_empty() {
        return Err(BuildError::new(
            p.loc.clone(),
            format!("'{}' takes no nested BSDF", p.plugin),
        ));
    }
    let bsdf = match p.plugin.as_str() {
        "diffuse" => Bsdf::Diffuse(Diffuse {
            reflectance: p.spectrum("reflectance", 0.5)?,
        }),
        "conductor" => {
            let (eta, k) = complex_ior(&p)?;
            Bsdf::Conductor(Conductor {
                eta,
                k,
                specular_reflectance: p.spectrum("specular_reflectance", 1.0)?,
            })
        }
        "roughconductor" => {
            let (eta, k) = complex_ior(&p)?;
            let (au, av) = roughness(&p, true)?;
            check_alpha(&p, &au)?;
            check_alpha(&p, &av)?;
            Bsdf::RoughConductor(
                RoughConductor {
                    distribution: distribution(&p)?,
                    alpha_u: au,
                    alpha_v: av,
                    sample_visible: p.bool("sample_visible", true)?,
                    rational_g1: rational_g1(&p)?,
                    eta,
                    k,
                    specular_reflectance: p.spectrum("specular_reflectance", 1.0)?,
                    multiscatter: false,
                    ms_f_avg: None,
                    ms_aniso: None,
                }
                .with_multiscatter(p.bool("multiscatter", false)?),
            )
        }
        "dielectric" => {
            let (eta, dispersion) = dielectric_eta(&p, "bk7")?;
            Bsdf::Dielectric(Dielectric {
                eta,
                dispersion,
                specular_reflectance: p.spectrum("specular_reflectance", 1.0)?,
                specular_transmittance: p.spectrum("specular_transmittance", 1.0)?,
                fresnel: fresnel_mode(&p)?,
            })
        }
        "thindielectric" => {
            let (eta, dispersion) = dielectric_eta(&p, "bk7")?;
            Bsdf::ThinDielectric(ThinDielectric {
                eta,
                dispersion,
                specular_reflectance: p.spectrum("specular_reflectance", 1.0)?,
                specular_transmittance: p.spectrum("specular_transmittance", 1.0)?,
                fresnel: fresnel_mode(&p)?,
            })
        }
        "roughdielectric" => {
            let (au, av) = roughness(&p, true)?;
            check_alpha(&p, &au)?;
            check_alpha(&p, &av)?;
            let (eta, dispersion) = dielectric_eta(&p, "bk7")?;
            let multiscatter = p.bool("multiscatter", false)?;
            if multiscatter && dispersion.is_some() {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'roughdielectric': 'multiscatter' cannot be combined with a dispersive index \
                     (its energy tables are built for one index of refraction)",
                ));
            }
            Bsdf::RoughDielectric(
                RoughDielectric {
                    distribution: distribution(&p)?,
                    alpha_u: au,
                    alpha_v: av,
                    sample_visible: p.bool("sample_visible", true)?,
                    rational_g1: rational_g1(&p)?,
                    eta,
                    dispersion,
                    specular_reflectance: p.spectrum("specular_reflectance", 1.0)?,
                    specular_transmittance: p.spectrum("specular_transmittance", 1.0)?,
                    fresnel: fresnel_mode(&p)?,
                    multiscatter: None,
                }
                .with_multiscatter(multiscatter),
            )
        }
        "plastic" | "roughplastic" => {
            let eta = eta(&p, "polypropylene")?;
            if eta == 1.0 {
                return Err(BuildError::new(
                    p.loc.clone(),
                    format!("'{}': interior and exterior indices must differ", p.plugin),
                ));
            }
            let diffuse = p.spectrum("diffuse_reflectance", 0.5)?;
            let specular = p.spectrum("specular_reflectance", 1.0)?;
            let nonlinear = p.bool("nonlinear", false)?;
            let fresnel = fresnel_mode(&p)?;
            if p.plugin == "plastic" {
                let fit = p.choice("diffuse_fresnel", "exact", &["exact", "fit"])? == "fit";
                Bsdf::Plastic(Plastic::new(
                    diffuse, specular, eta, nonlinear, fresnel, fit,
                ))
            } else {
                let (a, _) = roughness(&p, false)?;
                let alpha = match a {
                    FloatParam::Const(v) if v >= 0.0 => v,
                    FloatParam::Const(v) => {
                        return Err(BuildError::new(p.loc.clone(), format!("'roughplastic': roughness must be non-negative, got {v}")))
                    }
                    FloatParam::Texture(_) => {
                        return Err(BuildError::new(
                            p.loc.clone(),
                            "'roughplastic': 'alpha' must be a constant (its coat transmittance is precomputed), as in Mitsuba",
                        ))
                    }
                };
                Bsdf::RoughPlastic(Box::new(
                    RoughPlastic::new(
                        distribution(&p)?,
                        alpha,
                        p.bool("sample_visible", true)?,
                        rational_g1(&p)?,
                        diffuse,
                        specular,
                        eta,
                        nonlinear,
                        fresnel,
                    )
                    .with_multiscatter(p.bool("multiscatter", false)?),
                ))
            }
        }
        "sheen" => Bsdf::Sheen(Sheen {
            reflectance: p.spectrum("reflectance", 1.0)?,
            roughness: p.float_param("roughness", 0.5)?,
        }),
        "principled" => Bsdf::Principled(Box::new(Principled::from_props(&p)?)),
        "principledthin" => Bsdf::PrincipledThin(Box::new(PrincipledThin::from_props(&p)?)),
        "twosided" => {
            // one nested BSDF serves both sides (a copy): nesting doubles the tree at every
            // level, so its size is bounded before copying
            let nodes: usize = p.children.iter().map(|(b, _)| node_count(b)).sum();
            if p.children.len() == 1 && 2 * nodes > MAX_BSDF_NODES {
                return Err(BuildError::new(
                    p.loc.clone(),
                    format!(
                        "'twosided' would make a BSDF of more than {MAX_BSDF_NODES} nested \
                         models (the limit): each level of one-sided nesting copies it"
                    ),
                ));
            }
            let mut kids: Vec<Bsdf> = p.children.iter().map(|(b, _)| b.clone()).collect();
            if kids.is_empty() || kids.len() > 2 {
                return Err(BuildError::new(
                    p.loc.clone(),
                    format!(
                        "'twosided' needs one or two nested BSDFs, got {}",
                        kids.len()
                    ),
                ));
            }
            for (b, loc) in &p.children {
                if b.flags().has_transmission() {
                    return Err(BuildError::new(
                        loc.clone().or_else(|| p.loc.clone()),
                        format!("'twosided' cannot nest '{}': only models without transmission can be made two-sided", b.plugin_name()),
                    ));
                }
            }
            let back = if kids.len() == 2 {
                kids.pop().unwrap()
            } else {
                kids[0].clone()
            };
            let front = kids.pop().unwrap();
            Bsdf::TwoSided(Box::new(TwoSided { front, back }))
        }
        "blendbsdf" => {
            if !p.has("weight") {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'blendbsdf' needs parameter 'weight'",
                ));
            }
            let weight = p.float_param("weight", 0.5)?;
            if let FloatParam::Const(w) = weight {
                if !(0.0..=1.0).contains(&w) {
                    return Err(BuildError::new(
                        p.loc.clone(),
                        format!("'blendbsdf': weight must lie in [0, 1], got {w}"),
                    ));
                }
            }
            if p.children.len() != 2 {
                return Err(BuildError::new(
                    p.loc.clone(),
                    format!(
                        "'blendbsdf' needs exactly two nested BSDFs, got {}",
                        p.children.len()
                    ),
                ));
            }
            let mitsuba_dirac_mixing =
                p.choice("dirac_mixing", "exact", &["exact", "mitsuba"])? == "mitsuba";
            let a = p.children[0].0.clone();
            let b = p.children[1].0.clone();
            Bsdf::Blend(Box::new(Blend {
                weight,
                bsdfs: [a, b],
                mitsuba_dirac_mixing,
            }))
        }
        "measured" => {
            let file = p.string("filename", "")?;
            if file.is_empty() {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'measured' needs parameter 'filename' (an RGL .bsdf tensor file)",
                ));
            }
            let rgl = crate::measured::rgl::Rgl::load(&file)
                .map_err(|e| BuildError::new(p.loc.clone(), e.to_string()))?;
            Bsdf::Measured(std::sync::Arc::new(rgl))
        }
        "merl" => {
            let file = p.string("filename", "")?;
            if file.is_empty() {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'merl' needs parameter 'filename' (a MERL .binary file)",
                ));
            }
            let mut m = crate::measured::merl::Merl::read(std::path::Path::new(&file))
                .map_err(|e| BuildError::new(p.loc.clone(), e.to_string()))?;
            m.interpolate = p.bool("interpolate", false)?;
            m.sampling = match p.string("sampling", "tabulated")?.as_str() {
                "tabulated" => crate::measured::merl::MerlSampling::Tabulated,
                "cosine" => crate::measured::merl::MerlSampling::Cosine,
                other => {
                    return Err(BuildError::new(
                        p.loc.clone(),
                        format!("'merl': sampling must be 'tabulated' or 'cosine', got '{other}'"),
                    ))
                }
            };
            Bsdf::Merl(m)
        }
        "bumpmap" => {
            let scale = p.float("scale", 1.0)?;
            let flip = p.bool("flip_invalid_normals", true)?;
            let shadowing = p.bool("use_shadowing_function", true)?;
            let known = ["scale", "flip_invalid_normals", "use_shadowing_function"];
            let textures: Vec<_> = p
                .textures()
                .into_iter()
                .filter(|(n, _, _)| !known.contains(&n.as_str()))
                .collect();
            let [(name, texture, loc)] = <[_; 1]>::try_from(textures).map_err(|t| {
                BuildError::new(
                    p.loc.clone(),
                    format!(
                        "'bumpmap' needs exactly one nested texture (the height field), got {}",
                        t.len()
                    ),
                )
            })?;
            if texture.eval_1_grad(&ShadingPoint::default()).is_none() {
                return Err(BuildError::new(
                    loc.or_else(|| p.loc.clone()),
                    format!(
                        "'bumpmap': texture '{name}' has no texture-space gradient; as in Mitsuba, \
                         the height field must be a 'bitmap' (for a tangent-space normal map use \
                         'normalmap')"
                    ),
                ));
            }
            let mut b = perturbed(&p, Bump { texture, scale })?;
            b.flip_invalid_normals = flip;
            b.use_shadowing_function = shadowing;
            Bsdf::BumpMap(Box::new(b))
        }
        "normalmap" => {
            if !p.has("normalmap") {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'normalmap' needs parameter 'normalmap' (an RGB texture of tangent-space normals)",
                ));
            }
            let normalmap = p.spectrum("normalmap", 0.5)?;
            if let SpectrumParam::Texture(t) = &normalmap {
                if t.channels() != 3 {
                    return Err(BuildError::new(
                        p.loc.clone(),
                        "'normalmap': the 'normalmap' texture is monochromatic; it must have three channels (x, y, z)",
                    ));
                }
            }
            Bsdf::NormalMap(Box::new(perturbed(&p, NormalTexture { normalmap })?))
        }
        "mask" => Bsdf::Mask(Box::new(Mask {
            opacity: p.float_param("opacity", 0.5)?,
            nested: one_nested(&p)?,
        })),
        "null" => Bsdf::Null(Null),
        "irawan" => Bsdf::Irawan(Box::new(Irawan::build(&p)?)),
        "velvet" => Bsdf::Velvet(Velvet::build(&p)?),
        _ => unreachable!("plugin table and match agree"),
    };
    p.finish(valid)?;
    Ok(bsdf)
}
