//! `principled`: the Disney principled BSDF (Burley 2012, "Physically Based Shading at
//! Disney"; Burley 2015, "Extending the Disney BRDF to a BSDF with Integrated Subsurface
//! Scattering"), with Mitsuba 3's parameters, defaults and formulas so that renders match.
//!
//! Parameters (all but `eta`, `specular` and the sampling rates may be textures; all default
//! to 0 unless stated):
//!
//! | name | meaning |
//! |---|---|
//! | `base_color` | colour (default 0.5) |
//! | `roughness` | roughness of the main specular lobes, α = roughness² (default 0.5) |
//! | `anisotropic` | αu = r²/√(1 − 0.9 a), αv = r²·√(1 − 0.9 a), both ≥ 0.001 |
//! | `metallic` | blends in a Schlick conductor tinted by `base_color` |
//! | `spec_trans` | weight of the rough dielectric transmission lobe (tinted by √`base_color`) |
//! | `specular` | Fresnel strength: η = 2/(1 − √(0.08·specular)) − 1 (default 0.5, η = 1.5) |
//! | `eta` | the relative index directly (give either `eta` or `specular`) |
//! | `spec_tint` | tints the dielectric reflection towards `base_color` |
//! | `sheen`, `sheen_tint` | the retro-grazing sheen lobe and its tint |
//! | `clearcoat`, `clearcoat_gloss` | a GTR1 coat, α = lerp(0.1, 0.001, gloss) |
//! | `flatness` | blends the diffuse lobe with Hanrahan–Krueger-like fake subsurface |
//! | `main_specular_sampling_rate`, `clearcoat_sampling_rate`, `diffuse_reflectance_sampling_rate` | lobe sampling weights (default 1) |
//!
//! The lobes (f without the cosine; ci = cosθi, co = cosθo, h the half vector):
//! - diffuse, weight (1 − metallic)(1 − spec_trans): base/π · lerp(f_diff + f_retro, f_ss,
//!   flatness), front side only;
//! - sheen: sheen·(1 − metallic)·(1 − cos_d)⁵·lerp(1, tint, sheen_tint);
//! - main specular reflection (GGX, Smith G, visible-normal sampling): F·D·G/(4|ci||co|),
//!   with Mitsuba's blended Fresnel (exact dielectric, Schlick for the metallic and tinted
//!   parts; from below the surface only (1 − metallic)·spec_trans times the dielectric one);
//! - main specular transmission, weight (1 − metallic)·spec_trans: √base · Walter et al.'s
//!   rough-dielectric transmission term (scaled by 1/η² in radiance transport);
//! - clearcoat: 0.25·clearcoat·F_schlick(0.04)·D_GTR1·G(α = 0.25), front side only. As in
//!   Mitsuba this lobe carries no 1/(4|ci||co|) factor.
//!
//! Lobes are picked with Mitsuba's probabilities (diffuse ∝ (1 − metallic)(1 − spec_trans),
//! clearcoat ∝ clearcoat/4, main specular ∝ 1 split between reflection and transmission by
//! the dielectric Fresnel factor of the sampled normal), so `pdf` is Mitsuba's.
//!
//! Deliberate differences from Mitsuba 3.9 (`scalar_rgb`):
//! - From below the surface with no transmission weight ((1 − metallic)·spec_trans = 0 at
//!   that point) Mitsuba's `sample` produces nothing but its `pdf` is non-zero; Specula's
//!   `pdf` is 0 there, the density of its sampler (`eval` is 0 there in both).
//! - The sheen lobe is added wherever its own mask holds; Mitsuba's scalar variant adds it
//!   only where the diffuse lobe is active too, i.e. it drops the sheen at spec_trans = 1
//!   exactly (its vectorised variants add it where any lane of the wavefront is diffuse).
//! - The transmitted fraction 1 − F of the transmission lobe is computed from both cosines
//!   ([`crate::fresnel::dielectric_transmittance_pair`]), as `roughdielectric` does: the same
//!   value as Mitsuba's 1 − F, without its cancellation near total internal reflection, so
//!   that the lobe is reciprocal to single precision.
//! - Constant weights outside their ranges (negative roughness, metallic > 1, …) are errors;
//!   Mitsuba accepts them and returns negative values.
//!
//! Specula option `multiscatter` (default `false`, Mitsuba's model): energy compensation of
//! the main specular lobes (Kulla & Conty 2017, [`crate::multiscatter`]), for the parts of the
//! material that are a physical interface:
//!
//! - the **metallic** part (weight `metallic`, front side): the conductor compensation lobe
//!   of `roughconductor` with the metallic Fresnel, Schlick's with F₀ = `base_color` (which
//!   the Fresnel fit of the compensation represents exactly), with the shape measured from
//!   the random walk ([`crate::multiscatter::lobe`]) for an isotropic or textured roughness;
//! - the **specular-transmission** part (weight (1 − metallic)·spec_trans, both sides): the
//!   rough-dielectric compensation lobes of `roughdielectric` for `eta`, with their shapes
//!   measured from the random walk ([`crate::multiscatter::dielectric_lobe`]; reflection
//!   white, as the dielectric Fresnel of that part; transmission tinted by √`base_color` and
//!   scaled by 1/η² in radiance transport, as the single-scattering transmission). As in
//!   `roughdielectric multiscatter=true`, this part's single scattering is the random walk's
//!   first event, height-correlated ([`MicrofacetDistribution::g2_correlated`] in place of
//!   G1(ωi)G1(ωo): its transmission, and its share spec_trans of the non-metallic reflection
//!   — all of the reflection from below), with the height-correlated energy tables and
//!   measured lobe; the separable model transmits more than the walk at grazing incidence,
//!   which no added lobe could undo (test `principled_agrees_with_the_walk`: a clear glass
//!   and a white metal against their walks, lobe distance within noise + 0.02);
//! - the rest, (1 − metallic)(1 − spec_trans) — the dielectric reflection over the diffuse,
//!   sheen and clearcoat lobes — is **not** compensated: Burley's diffuse lobe is an empirical
//!   fit, not the light the rough interface transmits, so no energy balance says what its
//!   interreflections would add (a white non-metal reflects ~5–10 % specularly; Smith's loss
//!   is a fraction of that). The clearcoat (GTR1 with a fixed G) and the sheen are not
//!   compensated either. `spec_tint` tints the dielectric reflection of the single-scattering
//!   lobe only.
//!
//! The compensation reads the global GGX tables at √(αu αv) (a constant anisotropic
//! roughness builds its own azimuthal table for the metallic part, as `roughconductor`; the
//! other cases are approximate) and
//! the dielectric tables of η (at the constant roughness when it is constant, over α
//! otherwise). A white metal (`metallic=1 base_color=1`) and a clear glass (`spec_trans=1
//! base_color=1 metallic=0 spec_tint=0`) pass the white furnace (tests); the compensation
//! lobes are picked with probability (metallic (1 − E(μi)) + (1 − metallic) spec_trans
//! (1 − E_d(μi))), at most 0.9; the metallic one is cosine-sampled, the dielectric ones are
//! sampled from their table.
//!
//! Spectral mode: the tints (`spec_tint`, `sheen_tint`) divide `base_color` by the
//! luminance Mitsuba's spectral variants use, per wavelength (`tint_luminance`: the mean of
//! ȳ(λ)·base(λ) over the channel's wavelength and the three a quarter of the wavelength CDF
//! apart, Mitsuba's four-wavelength paths), so tinted lobes match Mitsuba's spectral renders
//! in expectation; tested against Mitsuba 3.9.1 `scalar_spectral` (also for
//! `principledthin`).

use crate::bsdf::*;
use crate::frame::{reflect, refract};
use crate::fresnel::{dielectric_transmittance_pair, fresnel_dielectric};
use crate::microfacet::{MicrofacetDistribution, MicrofacetType};
use crate::multiscatter::lobe::LOBE_MU;
use crate::multiscatter::{
    conductor_tables, conductor_tables_aniso, folded_phi, lobe_table, table_alpha, ConductorMs,
    ConductorTables, DielectricEnergy, FresnelFit,
};
use crate::spectrum::{Spectrum, Wavelengths};
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::Arc;

#[derive(Clone, Debug)]
pub struct Principled {
    pub base_color: SpectrumParam,
    pub roughness: FloatParam,
    pub anisotropic: FloatParam,
    pub metallic: FloatParam,
    pub spec_trans: FloatParam,
    pub spec_tint: FloatParam,
    pub sheen: FloatParam,
    pub sheen_tint: FloatParam,
    pub flatness: FloatParam,
    pub clearcoat: FloatParam,
    pub clearcoat_gloss: FloatParam,
    /// Relative index of refraction η_int/η_ext (from `eta` or `specular`).
    pub eta: f32,
    /// `spec_trans` was given (and is not the constant 0): the transmission lobe exists.
    pub has_spec_trans: bool,
    /// `clearcoat` was given (and is not the constant 0).
    pub has_clearcoat: bool,
    pub spec_srate: f32,
    pub clearcoat_srate: f32,
    pub diff_refl_srate: f32,
    /// Energy compensation (Specula's `multiscatter`): on when `Some`, with the dielectric
    /// tables of the transmission part when it exists.
    pub multiscatter: Option<PrincipledMs>,
}

/// What the energy compensation of `principled` reads.
#[derive(Clone, Debug)]
pub struct PrincipledMs {
    /// The rough-dielectric tables of η (with `spec_trans` only).
    pub dielectric: Option<Arc<DielectricEnergy>>,
    /// The conductor tables of a constant anisotropic roughness (the metallic part).
    pub aniso: Option<Arc<ConductorTables>>,
    /// The metallic part's colour when `base_color` and the roughness are constant (RGB
    /// mode; spectral mode evaluates `base_color` at the wavelengths).
    pub metal: Option<ConductorMs>,
    /// With `metal` and an isotropic roughness: the measured lobe's exact row integrals per μ
    /// bin ([`crate::multiscatter::LobeTable::rho_bins`]).
    pub metal_rho: Option<Arc<[Spectrum; LOBE_MU]>>,
}

/// The compensation at one shading point and incidence.
#[derive(Clone, Copy, Debug)]
struct MsState {
    /// Table roughness √(αu αv).
    alpha: f32,
    /// Probability of sampling a compensation lobe, and of it being the metallic one.
    p: f32,
    metal: f32,
}

/// (1 − c)⁵ clamped, Schlick's weight.
#[inline]
pub(crate) fn schlick_weight(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// ((η − 1)/(η + 1))².
#[inline]
pub(crate) fn schlick_r0(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2)
}

/// Schlick's Fresnel with normal reflectance `r0` for a cosine `c` (signed: negative from
/// inside) and relative index `eta`; the cosine on the optically thinner side is used.
#[inline]
pub(crate) fn calc_schlick(r0: Spectrum, c: f32, eta: f32) -> Spectrum {
    let eta_it = if c >= 0.0 { eta } else { 1.0 / eta };
    let eta_ti = 1.0 / eta_it;
    let w = if eta_it > 1.0 {
        schlick_weight(c.abs())
    } else {
        let ct2 = 1.0 - (1.0 - c * c) * eta_ti * eta_ti;
        schlick_weight(ct2.max(0.0).sqrt())
    };
    r0 * (1.0 - w) + Spectrum::splat(w)
}

/// Mitsuba's mapping from (anisotropic, roughness) to (αu, αv).
#[inline]
pub(crate) fn dist_params(anisotropic: f32, roughness: f32) -> (f32, f32) {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

#[inline]
pub(crate) fn ggx(anisotropic: f32, roughness: f32) -> MicrofacetDistribution {
    let (ax, ay) = dist_params(anisotropic, roughness);
    MicrofacetDistribution::new(MicrofacetType::Ggx, ax, ay, true)
}

/// The luminance the tints divide the base colour by, per channel (`base` is `param`'s value
/// at `sp`).
///
/// RGB mode: the RGB luminance of `base` (the same in every channel).
///
/// Spectral mode: what Mitsuba 3.9.1's spectral variants compute, in expectation. Mitsuba
/// divides by `luminance(base, wavelengths)` (probed: `mi.luminance`), the mean over its
/// path's four wavelengths of ȳ(λ)·base(λ) (ȳ the CIE 1931 luminous-efficiency curve,
/// unnormalised: ȳ(555 nm) = 1), and its four wavelengths are one uniform number u and its
/// shifts u + ¼, u + ½, u + ¾ (mod 1) through the inverse CDF of the wavelength density
/// (`sample_shifted`). The luminance its channel at λ sees is therefore a function of λ alone:
/// the mean of ȳ·base at λ and at the three wavelengths a quarter, half and three quarters of
/// the CDF further on. Specula's paths carry three wavelengths a third apart, so each channel
/// evaluates `param` at its own three Mitsuba companions and averages the four terms: the
/// tinted lobes then agree with Mitsuba's in expectation wavelength by wavelength (taking the
/// mean over Specula's own three wavelengths instead makes saturated tinted colours a few
/// percent off).
#[inline]
pub(crate) fn tint_luminance(param: &SpectrumParam, base: Spectrum, sp: &ShadingPoint) -> Spectrum {
    use crate::spectral::cie;
    let Some(w) = sp.wavelengths else {
        return Spectrum::splat(base.luminance());
    };
    let y = |l: f32, v: f32| cie::xyz_bar(l)[1] * v;
    crate::spectrum::Rgb(std::array::from_fn(|k| {
        let u = cie::wavelength_cdf(w.0[k]);
        let others = Wavelengths([1.0f32, 2.0, 3.0].map(|j| {
            let mut uj = u + 0.25 * j;
            if uj >= 1.0 {
                uj -= 1.0;
            }
            cie::sample_wavelength(uj.min(1.0 - f32::EPSILON))
        }));
        let v = param.eval(&ShadingPoint {
            wavelengths: Some(others),
            ..*sp
        });
        (y(w.0[k], base.0[k])
            + y(others.0[0], v.0[0])
            + y(others.0[1], v.0[1])
            + y(others.0[2], v.0[2]))
            * 0.25
    }))
}

/// `base / lum` per channel, or white where the luminance is not positive.
#[inline]
pub(crate) fn tint(base: Spectrum, lum: Spectrum) -> Spectrum {
    crate::spectrum::Rgb(std::array::from_fn(|k| {
        if lum.0[k] > 0.0 {
            base.0[k] / lum.0[k]
        } else {
            1.0
        }
    }))
}

/// The diffuse, retro-reflection and fake-subsurface factor (without base/π): `ci`, `co`
/// absolute cosines, `cos_d` = h·wo.
#[inline]
pub(crate) fn diffuse_factor(ci: f32, co: f32, cos_d: f32, roughness: f32, flatness: f32) -> f32 {
    let fo = schlick_weight(co);
    let fi = schlick_weight(ci);
    let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    if flatness == 0.0 {
        return f_diff + f_retro;
    }
    let fss90 = 0.5 * rr;
    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
    let f_ss = 1.25 * (fss * (1.0 / (co + ci) - 0.5) + 0.5);
    (f_diff + f_retro) * (1.0 - flatness) + f_ss * flatness
}

/// The sheen colour lerp(1, base/lum, sheen_tint) (`lum`: [`tint_luminance`], computed
/// only when the tint is not 0).
#[inline]
pub(crate) fn sheen_color(
    base: Spectrum,
    sheen_tint: f32,
    lum: impl FnOnce() -> Spectrum,
) -> Spectrum {
    if sheen_tint == 0.0 {
        return Spectrum::ONE;
    }
    let c = tint(base, lum());
    Spectrum::splat(1.0 - sheen_tint) + c * sheen_tint
}

/// Mitsuba's macro/micro-surface compatibility: both directions on the side of `m` that
/// `wi` is on (reflection), or `wo` on the opposite side (transmission).
#[inline]
pub(crate) fn compatible(m: Vec3, wi: Vec3, wo: Vec3, cos_i: f32, reflection: bool) -> bool {
    let ms = if cos_i < 0.0 { -m } else { m };
    wi.dot(ms) > 0.0
        && if reflection {
            wo.dot(ms) > 0.0
        } else {
            wo.dot(-ms) > 0.0
        }
}

/// Burley's GTR1 distribution of the clearcoat, D(m) = (α² − 1)/(π ln(α²)(1 + (α² − 1)cos²θ)).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    #[inline]
    fn eval(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let c2 = m.z * m.z;
        let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * c2));
        if d * m.z > 1e-20 {
            d
        } else {
            0.0
        }
    }
    #[inline]
    fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.eval(m)
        }
    }
    #[inline]
    fn sample(&self, u: Vec2) -> Vec3 {
        let (s, c) = crate::math::sincos_2pi(u.x);
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let sin_t = (1.0 - cos2).max(0.0).sqrt();
        let cos_t = cos2.max(0.0).sqrt();
        Vec3::new(c * sin_t, s * sin_t, cos_t)
    }
}

/// The isotropic GGX Smith G1 of the clearcoat (Mitsuba's `smith_ggx1`).
#[inline]
fn smith_ggx1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let c2 = v.z * v.z;
    let t2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt())
}

/// The parameters looked up at one shading point.
#[derive(Clone, Copy, Debug)]
struct Local {
    base: Spectrum,
    roughness: f32,
    anisotropic: f32,
    metallic: f32,
    spec_trans: f32,
    clearcoat: f32,
}

impl Local {
    /// Weight of the diffuse (BRDF) part.
    #[inline]
    fn brdf(&self) -> f32 {
        (1.0 - self.metallic) * (1.0 - self.spec_trans)
    }
    /// Weight of the transmissive (BSDF) part.
    #[inline]
    fn bsdf(&self) -> f32 {
        (1.0 - self.metallic) * self.spec_trans
    }
}

/// Normalised lobe-selection probabilities (diffuse, clearcoat, transmission, reflection).
#[derive(Clone, Copy, Debug)]
struct Probs {
    diffuse: f32,
    clearcoat: f32,
    trans: f32,
    reflect: f32,
}

impl Principled {
    #[inline]
    fn local(&self, sp: &ShadingPoint) -> Local {
        Local {
            base: self.base_color.eval(sp),
            roughness: self.roughness.eval(sp),
            anisotropic: self.anisotropic.eval(sp),
            metallic: self.metallic.eval(sp),
            spec_trans: if self.has_spec_trans {
                self.spec_trans.eval(sp)
            } else {
                0.0
            },
            clearcoat: if self.has_clearcoat {
                self.clearcoat.eval(sp)
            } else {
                0.0
            },
        }
    }

    #[inline]
    fn probs(&self, l: &Local, front: bool, f: f32) -> Probs {
        let bsdf = l.bsdf();
        let (mut pr, mut pt, mut pc, mut pd) = if front {
            (
                self.spec_srate * (1.0 - bsdf * (1.0 - f)),
                if self.has_spec_trans {
                    self.spec_srate * bsdf * (1.0 - f)
                } else {
                    0.0
                },
                if self.has_clearcoat {
                    0.25 * l.clearcoat * self.clearcoat_srate
                } else {
                    0.0
                },
                l.brdf() * self.diff_refl_srate,
            )
        } else {
            (f, if self.has_spec_trans { 1.0 - f } else { 0.0 }, 0.0, 0.0)
        };
        let total = pr + pt + pc + pd;
        // all sampling rates 0 where every lobe is: nothing is sampled
        let inv = if total > 0.0 { 1.0 / total } else { 0.0 };
        pr *= inv;
        pt *= inv;
        pc *= inv;
        pd *= inv;
        Probs {
            diffuse: pd,
            clearcoat: pc,
            trans: pt,
            reflect: pr,
        }
    }

    /// The compensation's sampling probabilities for `wi` (see the module).
    #[inline]
    fn ms_state(&self, ms: &PrincipledMs, l: &Local, wi: Vec3) -> MsState {
        let (au, av) = dist_params(l.anisotropic, l.roughness);
        let alpha = table_alpha(au, av);
        let front = wi.z > 0.0;
        let w_m = if front && l.metallic > 0.0 {
            let (t, x) = self.ms_conductor(ms, alpha, wi);
            l.metallic * (1.0 - t.e(x, wi.z))
        } else {
            0.0
        };
        let w_d = match &ms.dielectric {
            Some(d) if l.bsdf() > 0.0 => {
                let q = d.at(alpha);
                l.bsdf() * (1.0 - d.e(&q, front, wi.z.abs()))
            }
            _ => 0.0,
        };
        let w = w_m + w_d;
        MsState {
            alpha,
            p: w.clamp(0.0, 0.9),
            metal: if w > 0.0 { w_m / w } else { 1.0 },
        }
    }

    /// The metallic part's tables and the coordinate of `w` in them (α, or the folded
    /// azimuth of a constant anisotropic roughness).
    #[inline]
    fn ms_conductor<'a>(
        &self,
        ms: &'a PrincipledMs,
        alpha: f32,
        w: Vec3,
    ) -> (&'a ConductorTables, f32) {
        match &ms.aniso {
            Some(t) => (t, folded_phi(w)),
            None => (conductor_tables(MicrofacetType::Ggx), alpha),
        }
    }

    /// The compensation lobes' value (without cosine) for (wi, wo); `diel`: the dielectric
    /// lobe's value ([`DielectricEnergy::lobe_eval`], importance transport) when it exists.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn ms_value(
        &self,
        ms: &PrincipledMs,
        ctx: &BsdfContext,
        spectral: bool,
        l: &Local,
        st: &MsState,
        diel: Option<f32>,
        wi: Vec3,
        wo: Vec3,
    ) -> Spectrum {
        let front = wi.z > 0.0;
        let mut v = Spectrum::ZERO;
        if front && wo.z > 0.0 && l.metallic > 0.0 {
            let (t, xi) = self.ms_conductor(ms, st.alpha, wi);
            let xo = if ms.aniso.is_some() {
                folded_phi(wo)
            } else {
                xi
            };
            let c = match ms.metal.filter(|_| !spectral) {
                Some(c) => c,
                None => t.ms(st.alpha, &FresnelFit::schlick(l.base)),
            };
            let (c_i, c_o) = (c.energy(&t.at(xi, wi.z)), c.energy(&t.at(xo, wo.z)));
            let lobe = if ms.aniso.is_some() {
                c.lobe(c_i, c_o)
            } else {
                // the measured shape (see `multiscatter::lobe`), cosine-sampled here
                let lt = lobe_table(MicrofacetType::Ggx);
                let (shape, _) = lt.eval(st.alpha, wi, wo);
                let (r_i, r_o) = match (&ms.metal_rho, ms.metal.filter(|_| !spectral)) {
                    (Some(r), Some(_)) => (r[lt.bin(wi.z)], r[lt.bin(wo.z)]),
                    _ => (lt.rho(st.alpha, wi.z, &c), lt.rho(st.alpha, wo.z, &c)),
                };
                c.lobe_measured(c_i, c_o, shape, r_i, r_o)
            };
            v += lobe * l.metallic;
        }
        if let Some(f) = diel {
            let bsdf = l.bsdf();
            if bsdf > 0.0 {
                if wi.z * wo.z > 0.0 {
                    v += Spectrum::splat(bsdf * f);
                } else {
                    let scale = match ctx.mode {
                        TransportMode::Radiance if front => 1.0 / (self.eta * self.eta),
                        TransportMode::Radiance => self.eta * self.eta,
                        TransportMode::Importance => 1.0,
                    };
                    v += l.base.map(f32::sqrt) * (bsdf * f * scale);
                }
            }
        }
        v
    }

    /// The clearcoat's GTR1 distribution at a shading point.
    #[inline]
    fn gtr1(&self, sp: &ShadingPoint) -> Gtr1 {
        let g = self.clearcoat_gloss.eval(sp);
        Gtr1 {
            alpha: 0.1 * (1.0 - g) + 0.001 * g,
        }
    }

    /// Mitsuba's blended Fresnel factor of the main specular reflection.
    #[inline]
    fn principled_fresnel(
        &self,
        sp: &ShadingPoint,
        l: &Local,
        f_diel: f32,
        cos_h: f32,
        front: bool,
    ) -> Spectrum {
        if !front {
            return Spectrum::splat(l.bsdf() * f_diel);
        }
        let m = l.metallic;
        let st = self.spec_tint.eval(sp);
        let mut fs = Spectrum::ZERO;
        if m != 0.0 {
            fs += calc_schlick(l.base, cos_h, self.eta) * m;
        }
        if st != 0.0 {
            let eta_it = if cos_h >= 0.0 {
                self.eta
            } else {
                1.0 / self.eta
            };
            let lum = tint_luminance(&self.base_color, l.base, sp);
            let r0 = tint(l.base, lum) * schlick_r0(eta_it);
            fs += calc_schlick(r0, cos_h, self.eta) * ((1.0 - m) * st);
        }
        fs + Spectrum::splat((1.0 - m) * (1.0 - st) * f_diel)
    }

    /// The main specular lobes at a half vector: (value of the reflection or transmission
    /// lobe without the cosine, pdf over wo of the visible-normal sampling before the lobe
    /// probability). Where a multiple-scattering compensation would be applied.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn spec_terms<const VALUE: bool>(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        l: &Local,
        distr: &MicrofacetDistribution,
        wi: Vec3,
        wo: Vec3,
        wh: Vec3,
        f_diel: f32,
        reflect: bool,
    ) -> (Spectrum, f32) {
        let (ci, co) = (wi.z, wo.z);
        let front = ci > 0.0;
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let wi_up = if front { wi } else { -wi };
        let d = distr.eval(wh);
        let g1_i = distr.smith_g1(wi, wh);
        let (dwi, dwo) = (wi.dot(wh), wo.dot(wh));
        // visible-normal density of wh from wi_up (G1 is even in the direction's sign)
        let pdf_m = d * g1_i * wi_up.dot(wh).abs() / wi_up.z;
        // `multiscatter` with a transmission part: that part's single scattering is the
        // walk's, height-correlated (see the module)
        let correlated = self
            .multiscatter
            .as_ref()
            .is_some_and(|ms| ms.dielectric.is_some());
        if reflect {
            let pdf = pdf_m * (1.0 / (4.0 * dwo)).abs();
            if !VALUE || f_diel <= 0.0 {
                return (Spectrum::ZERO, pdf);
            }
            let g = g1_i * distr.smith_g1(wo, wh);
            let fp = self.principled_fresnel(sp, l, f_diel, dwi, front);
            let k = d / (4.0 * ci.abs() * co.abs());
            if !correlated || l.spec_trans <= 0.0 {
                return (fp * (g * k), pdf);
            }
            let gc = distr.g2_correlated(wi, wo, wh);
            if !front {
                // only the transmissive part scatters from below
                return (fp * (gc * k), pdf);
            }
            // the transmissive part's share of the dielectric reflection, spec_trans of
            // what is not metallic, is height-correlated; the metallic part (whose
            // compensation is the conductor's) and the rest keep G1 G1
            let metal = if l.metallic > 0.0 {
                calc_schlick(l.base, dwi, self.eta) * l.metallic
            } else {
                Spectrum::ZERO
            };
            let dielectric = (fp - metal).map(|v| v.max(0.0));
            let s = l.spec_trans;
            (
                metal * (g * k) + dielectric * (((1.0 - s) * g + s * gc) * k),
                pdf,
            )
        } else {
            let denom = dwi + eta_path * dwo;
            let pdf = pdf_m * (eta_path * eta_path * dwo / (denom * denom)).abs();
            let bsdf = l.bsdf();
            if !VALUE || bsdf <= 0.0 || f_diel >= 1.0 {
                return (Spectrum::ZERO, pdf);
            }
            let g = if correlated {
                distr.g2_correlated(wi, wo, wh)
            } else {
                g1_i * distr.smith_g1(wo, wh)
            };
            let scale = match ctx.mode {
                TransportMode::Radiance => 1.0 / (eta_path * eta_path),
                TransportMode::Importance => 1.0,
            };
            let t = dielectric_transmittance_pair(dwi.abs(), dwo.abs(), eta_path);
            let v = (scale * t * d * g * eta_path * eta_path * dwi * dwo
                / (ci * co * denom * denom))
                .abs();
            (l.base.map(f32::sqrt) * (bsdf * v), pdf)
        }
    }

    /// Value and pdf, with the energy compensation when it is on.
    #[inline]
    fn eval_pdf_impl<const VALUE: bool>(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        let Some(ms) = &self.multiscatter else {
            return self.eval_pdf_ss::<VALUE>(ctx, sp, wi, wo);
        };
        let (v, p) = self.eval_pdf_ss::<VALUE>(ctx, sp, wi, wo);
        let (ci, co) = (wi.z, wo.z);
        if ci == 0.0 || co == 0.0 {
            return (v, p);
        }
        let l = self.local(sp);
        let front = ci > 0.0;
        let reflect = ci * co > 0.0;
        if (!front && l.bsdf() <= 0.0) || (!reflect && !self.has_spec_trans) {
            return (v, p);
        }
        let st = self.ms_state(ms, &l, wi);
        // the metallic lobe cosine-sampled (front, reflection), the dielectric ones from
        // their table
        let p_metal = if reflect && front {
            co.abs() * FRAC_1_PI
        } else {
            0.0
        };
        // the dielectric lobe's value and density (one table lookup for both)
        let diel = match &ms.dielectric {
            Some(d) if l.bsdf() > 0.0 => Some(d.lobe_eval(&d.at(st.alpha), wi, wo)),
            _ => None,
        };
        let p_diel = diel.map_or(0.0, |(_, p)| p);
        let pdf = (1.0 - st.p) * p + st.p * (st.metal * p_metal + (1.0 - st.metal) * p_diel);
        if !VALUE {
            return (v, pdf);
        }
        let spectral = sp.wavelengths.is_some();
        let diel = diel.map(|(f, _)| f);
        (
            v + self.ms_value(ms, ctx, spectral, &l, &st, diel, wi, wo),
            pdf,
        )
    }

    /// Value and pdf of Mitsuba's model (single scattering).
    #[inline]
    fn eval_pdf_ss<const VALUE: bool>(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        let (ci, co) = (wi.z, wo.z);
        let none = (Spectrum::ZERO, 0.0);
        if ci == 0.0 {
            return none;
        }
        let reflect = ci * co > 0.0;
        let refract = ci * co < 0.0;
        if !(reflect || refract && self.has_spec_trans) {
            return none;
        }
        let l = self.local(sp);
        let front = ci > 0.0;
        if !front && l.bsdf() <= 0.0 {
            // nothing scatters light arriving from below (see the module docs)
            return none;
        }
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let mut wh = if reflect {
            (wi + wo).normalize()
        } else {
            // in double precision, so that the pair and the swapped pair give the same half
            // vector (reciprocity of the transmission lobe), as `roughdielectric`
            (wi.as_dvec3() + wo.as_dvec3() * eta_path as f64)
                .normalize()
                .as_vec3()
        };
        if wh.z < 0.0 {
            wh = -wh;
        }
        if !wh.is_finite() {
            return none;
        }
        // for reflection wi·h = wo·h: their mean makes the value exactly symmetric in
        // (wi, wo), which matters near the critical angle where F has a square-root singularity
        let cos_h = if reflect {
            0.5 * (wi.dot(wh) + wo.dot(wh))
        } else {
            wi.dot(wh)
        };
        let f_diel = fresnel_dielectric(cos_h, self.eta).r;
        let p = self.probs(&l, front, f_diel);
        let distr = ggx(l.anisotropic, l.roughness);
        let mut value = Spectrum::ZERO;
        let mut pdf = 0.0;
        if compatible(wh, wi, wo, ci, reflect) {
            let (v, pdf_spec) =
                self.spec_terms::<VALUE>(ctx, sp, &l, &distr, wi, wo, wh, f_diel, reflect);
            value += v;
            pdf += pdf_spec * if reflect { p.reflect } else { p.trans };
            if reflect && front && self.has_clearcoat {
                let cc = self.gtr1(sp);
                pdf += p.clearcoat * cc.pdf(wh) * (1.0 / (4.0 * wo.dot(wh))).abs();
                if VALUE && l.clearcoat > 0.0 {
                    let fcc = calc_schlick(Spectrum::splat(0.04), wi.dot(wh), self.eta)[0];
                    let gcc = smith_ggx1(wi, wh, 0.25) * smith_ggx1(wo, wh, 0.25);
                    value += Spectrum::splat(0.25 * l.clearcoat * fcc * cc.eval(wh) * gcc);
                }
            }
        }
        if reflect {
            pdf += p.diffuse * warp::square_to_cosine_hemisphere_pdf(wo);
        }
        if VALUE && reflect && front {
            let brdf = l.brdf();
            let cos_d = wh.dot(wo);
            if brdf > 0.0 {
                let flatness = self.flatness.eval(sp);
                let k = diffuse_factor(ci, co, cos_d, l.roughness, flatness);
                value += l.base * (brdf * FRAC_1_PI * k);
            }
            let sheen = self.sheen.eval(sp);
            if sheen > 0.0 && 1.0 - l.metallic > 0.0 {
                let c = sheen_color(l.base, self.sheen_tint.eval(sp), || {
                    tint_luminance(&self.base_color, l.base, sp)
                });
                value += c * (sheen * (1.0 - l.metallic) * schlick_weight(cos_d.abs()));
            }
        }
        (value, pdf)
    }
}

impl BsdfModel for Principled {
    fn flags(&self) -> LobeFlags {
        let f = LobeFlags::DIFFUSE_REFLECTION | LobeFlags::GLOSSY_REFLECTION;
        if self.has_spec_trans {
            f | LobeFlags::GLOSSY_TRANSMISSION
        } else {
            f
        }
    }

    fn eval(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf_impl::<true>(ctx, sp, wi, wo).0
    }

    fn pdf(&self, ctx: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf_impl::<false>(ctx, sp, wi, wo).1
    }

    fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        wo: Vec3,
    ) -> (Spectrum, f32) {
        self.eval_pdf_impl::<true>(ctx, sp, wi, wo)
    }

    fn sample(
        &self,
        ctx: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        let ci = wi.z;
        if ci == 0.0 {
            return None;
        }
        let l = self.local(sp);
        let front = ci > 0.0;
        if !front && l.bsdf() <= 0.0 {
            return None;
        }
        let mut u1 = u1;
        if let Some(ms) = &self.multiscatter {
            let st = self.ms_state(ms, &l, wi);
            if u1 < st.p {
                // a compensation lobe: the metallic one cosine-distributed, the dielectric
                // ones from their table
                let u = u1 / st.p;
                let wo = match &ms.dielectric {
                    Some(d) if u >= st.metal => {
                        let u = ((u - st.metal) / (1.0 - st.metal)).clamp(0.0, 1.0);
                        d.sample_lobe(&d.at(st.alpha), wi, u, u2)
                    }
                    _ => warp::square_to_cosine_hemisphere(u2),
                };
                let (lobe, eta) = if wi.z * wo.z > 0.0 {
                    (LobeFlags::GLOSSY_REFLECTION, 1.0)
                } else if front {
                    (LobeFlags::GLOSSY_TRANSMISSION, self.eta)
                } else {
                    (LobeFlags::GLOSSY_TRANSMISSION, 1.0 / self.eta)
                };
                let (value, pdf) = self.eval_pdf_impl::<true>(ctx, sp, wi, wo);
                return BsdfSample::from_value(wo, value, pdf, lobe, eta);
            }
            u1 = ((u1 - st.p) / (1.0 - st.p)).clamp(0.0, 1.0 - f32::EPSILON);
        }
        let wi_up = if front { wi } else { -wi };
        let distr = ggx(l.anisotropic, l.roughness);
        let (m, _) = distr.sample(wi_up, u2);
        let f = fresnel_dielectric(wi.dot(m), self.eta);
        let p = self.probs(&l, front, f.r);
        let (wo, lobe, eta) = if u1 < p.diffuse {
            let wo = warp::square_to_cosine_hemisphere(u2);
            (wo, LobeFlags::DIFFUSE_REFLECTION, 1.0)
        } else if self.has_clearcoat && u1 < p.diffuse + p.clearcoat {
            let mc = self.gtr1(sp).sample(u2);
            let wo = reflect(wi, mc);
            if !compatible(mc, wi, wo, ci, true) {
                return None;
            }
            (wo, LobeFlags::GLOSSY_REFLECTION, 1.0)
        } else if self.has_spec_trans && u1 < p.diffuse + p.clearcoat + p.trans {
            let wo = refract(wi, m, f.cos_theta_t, f.eta_ti);
            if ci * wo.z >= 0.0 || !compatible(m, wi, wo, ci, false) {
                return None;
            }
            (wo, LobeFlags::GLOSSY_TRANSMISSION, f.eta_it)
        } else {
            let wo = reflect(wi, m);
            if !compatible(m, wi, wo, ci, true) {
                return None;
            }
            (wo, LobeFlags::GLOSSY_REFLECTION, 1.0)
        };
        if ci * wo.z <= 0.0 && lobe != LobeFlags::GLOSSY_TRANSMISSION {
            return None;
        }
        let (value, pdf) = self.eval_pdf_impl::<true>(ctx, sp, wi, wo);
        BsdfSample::from_value(wo, value, pdf, lobe, eta)
    }
}

/// A weight that may be textured, with its constant value checked against [lo, hi], and
/// whether it was given as anything but the constant 0 (Mitsuba's `get_flag`: lobes whose
/// weight is absent or 0 are switched off).
pub(crate) fn weight_param(
    p: &crate::props::Props,
    name: &str,
    default: f32,
    lo: f32,
    hi: f32,
) -> Result<(FloatParam, bool), crate::props::BuildError> {
    let v = p.float_param(name, default)?;
    if let FloatParam::Const(c) = v {
        if !(lo..=hi).contains(&c) {
            return Err(crate::props::BuildError::new(
                p.loc.clone(),
                format!("'{}': '{name}' must lie in [{lo}, {hi}], got {c}", p.plugin),
            ));
        }
    }
    let given = p.has(name) && !matches!(v, FloatParam::Const(c) if c == 0.0);
    Ok((v, given))
}

/// A lobe sampling rate (a non-negative constant, default 1).
pub(crate) fn sampling_rate(
    p: &crate::props::Props,
    name: &str,
) -> Result<f32, crate::props::BuildError> {
    let v = p.float(name, 1.0)?;
    if v < 0.0 {
        return Err(crate::props::BuildError::new(
            p.loc.clone(),
            format!("'{}': '{name}' must be non-negative, got {v}", p.plugin),
        ));
    }
    Ok(v)
}

impl Principled {
    /// Builds the model from its parameters (Mitsuba 3's names and defaults).
    pub fn from_props(p: &crate::props::Props) -> Result<Self, crate::props::BuildError> {
        use crate::props::BuildError;
        let (roughness, _) = weight_param(p, "roughness", 0.5, 0.0, f32::MAX)?;
        let (anisotropic, _) = weight_param(p, "anisotropic", 0.0, 0.0, 1.0)?;
        let (metallic, _) = weight_param(p, "metallic", 0.0, 0.0, 1.0)?;
        let (spec_trans, has_spec_trans) = weight_param(p, "spec_trans", 0.0, 0.0, 1.0)?;
        let (spec_tint, _) = weight_param(p, "spec_tint", 0.0, 0.0, 1.0)?;
        let (sheen, _) = weight_param(p, "sheen", 0.0, 0.0, f32::MAX)?;
        let (sheen_tint, _) = weight_param(p, "sheen_tint", 0.0, 0.0, 1.0)?;
        let (flatness, _) = weight_param(p, "flatness", 0.0, 0.0, 1.0)?;
        let (clearcoat, has_clearcoat) = weight_param(p, "clearcoat", 0.0, 0.0, f32::MAX)?;
        let (clearcoat_gloss, _) = weight_param(p, "clearcoat_gloss", 0.0, 0.0, 1.0)?;
        let eta = if p.has("eta") {
            if p.has("specular") {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'principled': give either 'eta' or 'specular', not both (they set the same index of refraction)",
                ));
            }
            let e = p.float("eta", 1.5)?;
            if e <= 0.0 {
                return Err(BuildError::new(
                    p.loc.clone(),
                    format!("'principled': 'eta' must be positive, got {e}"),
                ));
            }
            // η = 1 is implausible for transmission (as Mitsuba)
            if has_spec_trans && e == 1.0 {
                1.001
            } else {
                e
            }
        } else {
            let mut s = p.float("specular", 0.5)?;
            if !(0.0..12.5).contains(&s) {
                return Err(BuildError::new(
                    p.loc.clone(),
                    format!("'principled': 'specular' must lie in [0, 12.5), got {s}"),
                ));
            }
            if has_spec_trans && s == 0.0 {
                s = 1e-3;
            }
            2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0
        };
        let spec_srate = sampling_rate(p, "main_specular_sampling_rate")?;
        let clearcoat_srate = sampling_rate(p, "clearcoat_sampling_rate")?;
        let diff_refl_srate = sampling_rate(p, "diffuse_reflectance_sampling_rate")?;
        let multiscatter = if p.bool("multiscatter", false)? {
            crate::multiscatter::prepare_conductor(MicrofacetType::Ggx);
            let dielectric = has_spec_trans.then(|| {
                // one roughness when it is constant
                let alpha = match (&roughness, &anisotropic) {
                    (FloatParam::Const(r), FloatParam::Const(a)) => {
                        let (au, av) = dist_params(*a, *r);
                        Some(table_alpha(au, av))
                    }
                    _ => None,
                };
                DielectricEnergy::get(
                    MicrofacetType::Ggx,
                    eta,
                    crate::fresnel::FresnelMode::Exact,
                    alpha,
                    true,
                )
            });
            let aniso = match (&roughness, &anisotropic) {
                (FloatParam::Const(r), FloatParam::Const(a)) if *a > 0.0 => {
                    let (au, av) = dist_params(*a, *r);
                    Some(Arc::new(conductor_tables_aniso(
                        MicrofacetType::Ggx,
                        au.min(1.0),
                        av.min(1.0),
                    )))
                }
                _ => None,
            };
            let base = p.spectrum("base_color", 0.5)?;
            // (RGB mode only: a `<spectrum>` base colour's RGB value, as a constant's)
            let metal = match (base.rgb_constant(), &roughness, &anisotropic, &aniso) {
                (Some(b), _, _, Some(t)) => Some(t.ms(0.0, &FresnelFit::schlick(b))),
                (Some(b), FloatParam::Const(r), FloatParam::Const(a), None) => {
                    let (au, av) = dist_params(*a, *r);
                    Some(
                        conductor_tables(MicrofacetType::Ggx)
                            .ms(table_alpha(au, av), &FresnelFit::schlick(b)),
                    )
                }
                _ => None,
            };
            let metal_rho = match (&metal, &roughness, &anisotropic, &aniso) {
                (Some(m), FloatParam::Const(r), FloatParam::Const(a), None) => {
                    let (au, av) = dist_params(*a, *r);
                    Some(Arc::new(lobe_table(MicrofacetType::Ggx).rho_bins(
                        conductor_tables(MicrofacetType::Ggx),
                        table_alpha(au, av),
                        m,
                    )))
                }
                _ => None,
            };
            Some(PrincipledMs {
                dielectric,
                aniso,
                metal,
                metal_rho,
            })
        } else {
            None
        };
        Ok(Principled {
            base_color: p.spectrum("base_color", 0.5)?,
            roughness,
            anisotropic,
            metallic,
            spec_trans,
            spec_tint,
            sheen,
            sheen_tint,
            flatness,
            clearcoat,
            clearcoat_gloss,
            eta,
            has_spec_trans,
            has_clearcoat,
            spec_srate,
            clearcoat_srate,
            diff_refl_srate,
            multiscatter,
        })
    }
}

/// Parameters of `principled`.
pub const PARAMS: &[&str] = &[
    "base_color",
    "roughness",
    "anisotropic",
    "metallic",
    "spec_trans",
    "eta",
    "specular",
    "spec_tint",
    "sheen",
    "sheen_tint",
    "flatness",
    "clearcoat",
    "clearcoat_gloss",
    "main_specular_sampling_rate",
    "clearcoat_sampling_rate",
    "diffuse_reflectance_sampling_rate",
    "multiscatter",
];

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parse_spec;

    fn principled(spec: &str) -> Principled {
        match parse_spec(spec).unwrap() {
            crate::Bsdf::Principled(p) => *p,
            _ => unreachable!(),
        }
    }

    #[test]
    fn specular_maps_to_eta() {
        // Mitsuba: η = 2/(1 − √(0.08 specular)) − 1; the default 0.5 is η = 1.5
        assert!((principled("principled").eta - 1.5).abs() < 1e-6);
        let e = principled("principled specular=0.2").eta;
        assert!((e - (2.0 / (1.0 - (0.016f32).sqrt()) - 1.0)).abs() < 1e-6);
        assert_eq!(principled("principled eta=1.33").eta, 1.33);
        // η = 1 and specular = 0 are implausible for transmission and nudged, as in Mitsuba
        assert_eq!(principled("principled eta=1 spec_trans=0.5").eta, 1.001);
        assert!(principled("principled specular=0 spec_trans=0.5").eta > 1.0);
        assert_eq!(principled("principled specular=0").eta, 1.0);
    }

    #[test]
    fn bad_parameters_are_errors() {
        for (bad, what) in [
            (
                "principled eta=1.5 specular=0.5",
                "either 'eta' or 'specular'",
            ),
            ("principled metallic=1.5", "'metallic' must lie in [0, 1]"),
            ("principled roughness=-0.1", "'roughness'"),
            ("principled eta=-1", "'eta' must be positive"),
            ("principled specular=20", "'specular' must lie in"),
            ("principled clearcoat_sampling_rate=-1", "non-negative"),
            (
                "principled diff_trans=0.5",
                "unknown parameter 'diff_trans'",
            ),
        ] {
            let e = parse_spec(bad).expect_err(bad).to_string();
            assert!(e.contains(what), "{bad}: {e}");
        }
    }

    #[test]
    fn transmission_lobe_exists_only_when_given() {
        assert!(!principled("principled").flags().has_transmission());
        assert!(!principled("principled spec_trans=0")
            .flags()
            .has_transmission());
        assert!(principled("principled spec_trans=0.3")
            .flags()
            .has_transmission());
    }

    /// From below a surface that transmits nothing, nothing is sampled, and the pdf is 0
    /// (Mitsuba's is not: a deliberate difference, see the module docs).
    #[test]
    fn nothing_scatters_from_below_without_transmission() {
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        let wi = Vec3::new(0.3, 0.1, -0.9).normalize();
        for spec in ["principled", "principled spec_trans=0.7 metallic=1"] {
            let b = principled(spec);
            for wo in [Vec3::new(-0.3, 0.0, -0.95), Vec3::new(0.2, 0.3, 0.9)] {
                let (f, p) = b.eval_pdf(&ctx, &sp, wi, wo.normalize());
                assert_eq!((f, p), (Spectrum::ZERO, 0.0), "{spec}");
            }
            assert!(b.sample(&ctx, &sp, wi, 0.5, Vec2::new(0.3, 0.6)).is_none());
        }
        // with transmission weight, light from below reflects and refracts
        let b = principled("principled spec_trans=0.7 roughness=0.3");
        let wo = Vec3::new(-0.3, -0.1, -0.9).normalize();
        assert!(b.eval_pdf(&ctx, &sp, wi, wo).1 > 0.0);
    }

    #[test]
    fn sampled_refraction_reports_its_relative_index() {
        let b = principled("principled spec_trans=1 roughness=0.2 eta=1.33");
        let ctx = BsdfContext::RADIANCE;
        let sp = ShadingPoint::default();
        let wi = Vec3::new(0.2, 0.0, 0.98).normalize();
        let mut seen = 0;
        for i in 0..64 {
            let u1 = (i as f32 + 0.5) / 64.0;
            if let Some(s) = b.sample(&ctx, &sp, wi, u1, Vec2::new(0.37, 0.61)) {
                if s.wo.z < 0.0 {
                    assert_eq!(s.lobe, LobeFlags::GLOSSY_TRANSMISSION);
                    assert!((s.eta - 1.33).abs() < 1e-6);
                    seen += 1;
                }
            }
        }
        assert!(seen > 0);
    }
}
