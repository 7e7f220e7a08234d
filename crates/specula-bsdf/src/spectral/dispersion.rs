//! Wavelength-dependent indices of refraction: [`Ior`] is a constant, a Sellmeier or Cauchy
//! formula (an Abbe number becomes a Cauchy formula), and [`NAMED_GLASSES`] holds measured
//! dispersion formulas of common dielectrics, each with its source.
//!
//! Formulas (λ in micrometres inside the formulas; [`Ior::at`] takes nanometres):
//!
//! - **Sellmeier**: n(λ)² = 1 + Σᵢ Bᵢ λ² / (λ² − Cᵢ), up to four terms, Cᵢ in µm².
//! - **Cauchy**: n(λ) = A + B/λ² + C/λ⁴, B in µm², C in µm⁴.
//! - **Abbe number** (OpenPBR's `transmission_dispersion_abbe_number`, glTF
//!   `KHR_materials_dispersion`): the two-term Cauchy formula n = A + B/λ² that passes through
//!   n_d at the helium d line and has the Abbe number V_d = (n_d − 1)/(n_F − n_C):
//!   B = (n_d − 1) / (V_d (λ_F⁻² − λ_C⁻²)), A = n_d − B/λ_d², with λ_d = 587.5618 nm,
//!   λ_F = 486.1327 nm, λ_C = 656.2725 nm (the Fraunhofer d, F and C lines). This is the
//!   formula the glTF extension recommends (there written with `dispersion` = 20/V_d).
//!
//! In RGB mode a dispersive material uses its index at the d line, [`LAMBDA_D`].
//!
//! Named glasses ([`glass`]; the figures in brackets are n_d and V_d from the formula, which
//! the tests compare with the catalogues):
//!
//! | name | formula | source | n_d, V_d |
//! |---|---|---|---|
//! | `bk7` | Sellmeier (3) | Schott N-BK7 datasheet | 1.5168, 64.17 |
//! | `fused silica` | Sellmeier (3) | Malitson 1965, JOSA 55, 1205 | 1.4585, 67.82 |
//! | `sapphire` | Sellmeier (3), ordinary ray | Malitson & Dodge 1972, JOSA 62, 1405 | 1.7682, 72.3 |
//! | `diamond` | Sellmeier (2) | Peter 1923, Z. Kristallogr. 59, 375 | 2.4175, 55.3 |
//! | `water` | Sellmeier (4), 20 °C | Daimon & Masumura 2007, Appl. Opt. 46, 3811 | 1.3334, 55.8 |
//! | `acrylic` (`pmma`) | Sellmeier (1) | Sultanova et al. 2009, Acta Phys. Pol. A 116, 585 | 1.4906, 53.2 |
//! | `polycarbonate` | Sellmeier (1) | Sultanova et al. 2009 | 1.5848, 27.9 |
//! | `sf11` | Sellmeier (3) | Schott N-SF11 datasheet (dense flint) | 1.7847, 25.68 |
//! | `f2` | Sellmeier (3) | Schott F2 datasheet (flint) | 1.6200, 36.37 |
//!
//! Like the catalogues, the formulas give indices relative to air. Mitsuba's default exterior
//! (`ext_ior` = `air`, 1.000277) divides them once more, a 0.03 % error; give
//! `ext_ior="vacuum"` for the catalogue's relative index exactly.
//!
//! The formulas are valid over the visible range (each source covers at least 400–700 nm);
//! [`Ior::at`] evaluates them wherever they are finite and positive and otherwise clamps
//! (a Sellmeier pole is far outside the visible range for every named glass).

/// The helium d line (nm): where a dispersive material's index is taken in RGB mode, and the
/// reference wavelength of the Abbe number.
pub const LAMBDA_D: f32 = 587.5618;
/// The hydrogen F line (nm).
pub const LAMBDA_F: f32 = 486.1327;
/// The hydrogen C line (nm).
pub const LAMBDA_C: f32 = 656.2725;

/// An index of refraction as a function of wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ior {
    /// The same index at every wavelength.
    Constant(f32),
    /// n² = 1 + Σ Bᵢ λ²/(λ² − Cᵢ) (λ in µm, Cᵢ in µm²); unused terms have Bᵢ = 0.
    Sellmeier { b: [f32; 4], c: [f32; 4] },
    /// n = A + B/λ² + C/λ⁴ (λ in µm).
    Cauchy { a: f32, b: f32, c: f32 },
}

impl Ior {
    /// The two-term Cauchy formula with index `n_d` at the d line and Abbe number `v_d`
    /// (see the module documentation).
    pub fn from_abbe(n_d: f32, v_d: f32) -> Ior {
        let um = |nm: f32| (nm as f64 / 1000.0).powi(2);
        let (d2, f2, c2) = (um(LAMBDA_D), um(LAMBDA_F), um(LAMBDA_C));
        let b = (n_d as f64 - 1.0) / (v_d as f64 * (1.0 / f2 - 1.0 / c2));
        let a = n_d as f64 - b / d2;
        Ior::Cauchy {
            a: a as f32,
            b: b as f32,
            c: 0.0,
        }
    }

    /// A Sellmeier formula with up to four terms.
    pub fn sellmeier(b: &[f32], c: &[f32]) -> Ior {
        let (mut bb, mut cc) = ([0.0; 4], [0.0; 4]);
        for (i, (x, y)) in b.iter().zip(c).take(4).enumerate() {
            bb[i] = *x;
            cc[i] = *y;
        }
        Ior::Sellmeier { b: bb, c: cc }
    }

    /// The index at `lambda_nm` nanometres.
    #[inline]
    pub fn at(&self, lambda_nm: f32) -> f32 {
        match *self {
            Ior::Constant(n) => n,
            Ior::Sellmeier { b, c } => {
                let l2 = (lambda_nm as f64 * 1e-3).powi(2);
                let mut n2 = 1.0f64;
                for i in 0..4 {
                    if b[i] != 0.0 {
                        n2 += b[i] as f64 * l2 / (l2 - c[i] as f64);
                    }
                }
                // keep a usable index next to a pole (far outside the visible range)
                n2.max(1e-4).sqrt() as f32
            }
            Ior::Cauchy { a, b, c } => {
                let il2 = 1.0 / (lambda_nm as f64 * 1e-3).powi(2);
                (a as f64 + il2 * (b as f64 + il2 * c as f64)).max(1e-2) as f32
            }
        }
    }

    /// The indices at three wavelengths.
    #[inline]
    pub fn at3(&self, lambdas: [f32; 3]) -> [f32; 3] {
        lambdas.map(|l| self.at(l))
    }

    /// True unless the index is the same at every wavelength.
    pub fn is_dispersive(&self) -> bool {
        match *self {
            Ior::Constant(_) => false,
            Ior::Sellmeier { b, .. } => b.iter().any(|&v| v != 0.0),
            Ior::Cauchy { b, c, .. } => b != 0.0 || c != 0.0,
        }
    }

    /// The index at the d line (what RGB mode uses).
    pub fn n_d(&self) -> f32 {
        self.at(LAMBDA_D)
    }

    /// The Abbe number V_d = (n_d − 1)/(n_F − n_C) (infinite for a constant index).
    pub fn abbe_number(&self) -> f32 {
        let (d, f, c) = (
            self.at(LAMBDA_D) as f64,
            self.at(LAMBDA_F) as f64,
            self.at(LAMBDA_C) as f64,
        );
        ((d - 1.0) / (f - c)) as f32
    }

    /// A description for messages and plots, e.g. `Sellmeier (3 terms)`.
    pub fn describe(&self) -> String {
        match self {
            Ior::Constant(n) => format!("constant {n}"),
            Ior::Sellmeier { b, .. } => {
                format!(
                    "Sellmeier ({} terms)",
                    b.iter().filter(|&&v| v != 0.0).count()
                )
            }
            Ior::Cauchy { a, b, c } => format!("Cauchy A={a} B={b} µm² C={c} µm⁴"),
        }
    }
}

/// The relative index η_int(λ)/η_ext of a dispersive interface (`dielectric`,
/// `roughdielectric`, `thindielectric`): a dispersive interior over a constant exterior.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dispersion {
    pub int: Ior,
    pub ext: f32,
}

impl Dispersion {
    /// The relative index at `lambda_nm`.
    #[inline]
    pub fn eta(&self, lambda_nm: f32) -> f32 {
        self.int.at(lambda_nm) / self.ext
    }

    /// The relative indices at the three wavelengths of a spectral sample.
    #[inline]
    pub fn etas(&self, w: crate::spectrum::Wavelengths) -> [f32; 3] {
        w.0.map(|l| self.eta(l))
    }

    /// The relative index at the d line (what RGB mode uses).
    pub fn eta_d(&self) -> f32 {
        self.eta(LAMBDA_D)
    }
}

/// The per-channel relative indices a dispersive model refracts with at a shading point:
/// `Some` only in spectral mode (`wavelengths` given) for a dispersive material.
#[inline]
pub fn channel_etas(
    dispersion: &Option<Dispersion>,
    wavelengths: Option<crate::spectrum::Wavelengths>,
) -> Option<[f32; 3]> {
    match (dispersion, wavelengths) {
        (Some(d), Some(w)) => Some(d.etas(w)),
        _ => None,
    }
}

/// For an integrator: give the channels whose path throughput is zero the wavelength of a
/// surviving channel, for shading the rest of the path (the film keeps the original
/// wavelengths). A dead channel's values no longer matter, and after a dispersive Dirac
/// refraction (which keeps one channel, see `dielectric`) the path then continues as a single
/// wavelength: later dispersive interfaces see three equal indices and refract every channel
/// together instead of splitting again (which would discard two thirds of the paths at every
/// further interface). Returns whether anything changed.
pub fn collapse_dead_channels(w: &mut crate::spectrum::Wavelengths, throughput: [f32; 3]) -> bool {
    let Some(alive) = (0..3).find(|&c| throughput[c] != 0.0) else {
        return false;
    };
    let keep = w.0[alive];
    let mut changed = false;
    for (l, t) in w.0.iter_mut().zip(throughput) {
        if t == 0.0 && *l != keep {
            *l = keep;
            changed = true;
        }
    }
    changed
}

/// A named dispersive dielectric.
#[derive(Clone, Copy, Debug)]
pub struct Glass {
    pub name: &'static str,
    /// Other accepted names.
    pub aliases: &'static [&'static str],
    pub ior: Ior,
    /// Where the coefficients come from.
    pub source: &'static str,
}

/// The named dispersive dielectrics (see the module documentation); coefficients with the
/// sources' digits.
#[allow(clippy::excessive_precision)]
pub const NAMED_GLASSES: &[Glass] = &[
    Glass {
        name: "bk7",
        aliases: &["n-bk7"],
        ior: Ior::Sellmeier {
            b: [1.039_612_1, 0.231_792_34, 1.010_469_5, 0.0],
            c: [0.006_000_698_7, 0.020_017_914, 103.560_65, 0.0],
        },
        source: "Schott N-BK7 datasheet",
    },
    Glass {
        name: "fused silica",
        aliases: &["fused quartz", "silica"],
        ior: Ior::Sellmeier {
            b: [0.696_166_3, 0.407_942_6, 0.897_479_4, 0.0],
            // 0.0684043², 0.1162414², 9.896161²
            c: [0.004_679_148, 0.013_512_063, 97.934_0, 0.0],
        },
        source: "Malitson 1965, JOSA 55(10), 1205",
    },
    Glass {
        name: "sapphire",
        aliases: &[],
        ior: Ior::Sellmeier {
            b: [1.431_349_3, 0.650_547_13, 5.341_402, 0.0],
            // 0.0726631², 0.1193242², 18.028251² (ordinary ray)
            c: [0.005_279_926, 0.014_238_265, 325.017_8, 0.0],
        },
        source: "Malitson & Dodge 1972, JOSA 62, 1405 (ordinary ray)",
    },
    Glass {
        name: "diamond",
        aliases: &[],
        ior: Ior::Sellmeier {
            b: [0.3306, 4.3356, 0.0, 0.0],
            // 0.1750², 0.1060²
            c: [0.030_625, 0.011_236, 0.0, 0.0],
        },
        source: "Peter 1923, Z. Kristallogr. 59, 375",
    },
    Glass {
        name: "water",
        aliases: &[],
        ior: Ior::Sellmeier {
            b: [0.568_402_76, 0.172_617_74, 0.020_861_896, 0.113_074_87],
            c: [0.005_101_829_7, 0.018_211_539, 0.026_207_223, 10.697_927],
        },
        source: "Daimon & Masumura 2007, Appl. Opt. 46(18), 3811 (20 °C)",
    },
    Glass {
        name: "acrylic",
        aliases: &["pmma", "acrylic glass"],
        ior: Ior::Sellmeier {
            b: [1.1819, 0.0, 0.0, 0.0],
            c: [0.011313, 0.0, 0.0, 0.0],
        },
        source: "Sultanova et al. 2009, Acta Phys. Pol. A 116(4), 585 (PMMA)",
    },
    Glass {
        name: "polycarbonate",
        aliases: &["pc"],
        ior: Ior::Sellmeier {
            b: [1.4182, 0.0, 0.0, 0.0],
            c: [0.021304, 0.0, 0.0, 0.0],
        },
        source: "Sultanova et al. 2009, Acta Phys. Pol. A 116(4), 585",
    },
    Glass {
        name: "sf11",
        aliases: &["n-sf11"],
        ior: Ior::Sellmeier {
            b: [1.737_597, 0.313_747_35, 1.898_781, 0.0],
            c: [0.013_188_707, 0.062_306_814, 155.236_29, 0.0],
        },
        source: "Schott N-SF11 datasheet",
    },
    Glass {
        name: "f2",
        aliases: &[],
        ior: Ior::Sellmeier {
            b: [1.345_333_6, 0.209_073_18, 0.937_357_2, 0.0],
            c: [0.009_977_438_7, 0.047_045_077, 111.886_764, 0.0],
        },
        source: "Schott F2 datasheet",
    },
];

/// The named glass `name` (or one of its aliases), case-insensitive.
pub fn glass(name: &str) -> Option<&'static Glass> {
    NAMED_GLASSES.iter().find(|g| {
        g.name.eq_ignore_ascii_case(name) || g.aliases.iter().any(|a| a.eq_ignore_ascii_case(name))
    })
}

/// The names [`glass`] knows (without aliases), for error messages.
pub fn glass_names() -> Vec<&'static str> {
    NAMED_GLASSES.iter().map(|g| g.name).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// n_d and V_d from each formula against the catalogue values (a wrong or mistyped
    /// coefficient moves them by far more than the tolerance).
    #[test]
    fn named_glasses_match_catalogue_nd_and_vd() {
        // (name, n_d, tolerance, V_d, tolerance): Schott catalogue figures for the Schott
        // glasses, the sources' own tables otherwise
        let cases = [
            ("bk7", 1.51680, 2e-5, 64.17, 0.02),
            ("sf11", 1.78472, 2e-5, 25.68, 0.02),
            ("f2", 1.62004, 2e-5, 36.37, 0.02),
            ("fused silica", 1.4585, 1e-4, 67.8, 0.1),
            ("sapphire", 1.7682, 2e-4, 72.2, 0.3),
            ("diamond", 2.4175, 5e-4, 55.3, 0.5),
            ("water", 1.3333, 3e-4, 55.8, 0.5),
            ("acrylic", 1.4906, 5e-4, 53.2, 0.5),
            ("polycarbonate", 1.5848, 5e-4, 27.9, 0.5),
        ];
        assert_eq!(cases.len(), NAMED_GLASSES.len());
        for (name, nd, nd_tol, vd, vd_tol) in cases {
            let g = glass(name).unwrap();
            let (n, v) = (g.ior.n_d(), g.ior.abbe_number());
            assert!(
                (n - nd).abs() <= nd_tol,
                "{name}: n_d = {n}, catalogue {nd}"
            );
            assert!(
                (v - vd).abs() <= vd_tol,
                "{name}: V_d = {v}, catalogue {vd}"
            );
            assert!(g.ior.is_dispersive());
            // normal dispersion over the visible range
            let mut last = f32::INFINITY;
            for l in (380..=780).step_by(10) {
                let x = g.ior.at(l as f32);
                assert!(x > 1.0 && x < last, "{name} at {l} nm: {x}");
                last = x;
            }
        }
    }

    #[test]
    fn bk7_at_the_fraunhofer_lines() {
        // Schott N-BK7 datasheet: n_F = 1.52238, n_C = 1.51432
        let g = glass("BK7").unwrap();
        assert!((g.ior.at(LAMBDA_F) - 1.52238).abs() < 2e-5);
        assert!((g.ior.at(LAMBDA_C) - 1.51432).abs() < 2e-5);
        assert!(glass("pmma").is_some() && glass("fused quartz").is_some());
        assert!(glass("unobtainium").is_none());
    }

    #[test]
    fn abbe_parameterisation_reproduces_nd_and_vd() {
        for (nd, vd) in [(1.5f32, 40.0f32), (2.4, 20.0), (1.33, 55.0), (1.7, 90.0)] {
            let ior = Ior::from_abbe(nd, vd);
            assert!((ior.n_d() - nd).abs() < 1e-5, "{ior:?}");
            assert!((ior.abbe_number() - vd).abs() < 1e-2 * vd / 40.0, "{ior:?}");
        }
    }

    #[test]
    fn dead_channels_take_a_living_wavelength() {
        use crate::spectrum::Wavelengths;
        let mut w = Wavelengths([400.0, 500.0, 600.0]);
        assert!(collapse_dead_channels(&mut w, [0.0, 2.0, 0.0]));
        assert_eq!(w.0, [500.0; 3]);
        let mut w = Wavelengths([400.0, 500.0, 600.0]);
        assert!(!collapse_dead_channels(&mut w, [1.0, 2.0, 3.0]));
        assert!(!collapse_dead_channels(&mut w, [0.0; 3]));
        assert!(collapse_dead_channels(&mut w, [1.0, 0.0, 3.0]));
        assert_eq!(w.0, [400.0, 400.0, 600.0]);
    }

    #[test]
    fn cauchy_and_constant() {
        let c = Ior::Cauchy {
            a: 1.5,
            b: 0.005,
            c: 0.0001,
        };
        let l = 0.5f32;
        let expect = 1.5 + 0.005 / (l * l) + 0.0001 / (l * l * l * l);
        assert!((c.at(500.0) - expect).abs() < 1e-6);
        assert!(c.is_dispersive());
        let k = Ior::Constant(1.33);
        assert_eq!(k.at(400.0), 1.33);
        assert!(!k.is_dispersive());
        assert_eq!(Ior::sellmeier(&[1.0], &[0.01]).at3([500.0; 3])[2], {
            let l2 = 0.25f64;
            (1.0 + l2 / (l2 - 0.01)).sqrt() as f32
        });
    }
}
