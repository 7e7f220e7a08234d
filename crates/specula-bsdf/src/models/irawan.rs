//! `irawan`: the woven-cloth BRDF of Irawan & Marschner, "Specular reflection from woven
//! cloth", ACM Transactions on Graphics 31(1), 2012 (and P. Irawan's thesis "The Appearance
//! of Woven Cloth", Cornell 2008), with the plugin name, parameters, weave-pattern files and
//! normalisation of Mitsuba 0.6's `irawan` plugin (Mitsuba 3 has no cloth model).
//!
//! The surface is tiled by a weave pattern: a grid of `tileWidth × tileHeight` cells, each
//! naming the yarn segment seen there. A segment is a curved, possibly twisted yarn of
//! fibres lying along v (warp) or u (weft), of `width` × `length` cells. Its specular
//! reflection is that of the fibres whose tangent is perpendicular to the half vector h:
//! for untwisted filament yarns (`psi = 0`) the fibre inclination u(h) = atan(h_y/h_z) must
//! fall near the inclination of the yarn at the shading point; for twisted staple yarns
//! (`psi ≠ 0`) the azimuth v(h) round the yarn must. The reflected intensity is
//!   f_s = G · (α + vonMises(−ωi·ωo; β)) · A(n·ωi, n·ωo) / Δ,
//! with G the geometry (curvature) factor of the yarn's spine (an ellipse, parabola or
//! hyperbola set by `kappa`), A Seeliger's attenuation, Δ the highlight width (`hWidth`
//! of the segment) and α, β the fibre scattering parameters. Each yarn adds a Lambertian
//! term, so per yarn
//!   f = kd/π + ks · N · (area factor) · variation · f_s.
//!
//! **Normalisation (as Mitsuba 0.6):** N is chosen once per material so that the
//! specular term's mean over the unit square of texture coordinates and over
//! cosine-distributed ωi, ωo is 1/π: the specular albedo averaged over the surface and the
//! hemisphere is 1, and `ks` is that average albedo. It is not a per-direction bound: the
//! highlight of one yarn at one angle can reflect several times what it receives (the
//! property suite's `energy` check says where); the model is not energy-conserving, as the
//! paper's is not. It is reciprocal: every term is symmetric in ωi and ωo.
//!
//! **Parameters:**
//! - `filename` (string): a weave pattern file in Mitsuba 0.6's format (below), resolved
//!   relative to the scene; or, a Specula extension, `pattern` (string): one of the
//!   built-in weaves `denim`, `charmeuse` (silk charmeuse), `twill` (cotton twill),
//!   `gabardine` (wool gabardine), `polyester` (polyester lining cloth, the plain weave of
//!   nylon and polyester linings) and `shantung` (silk shantung), the six patterns of
//!   Mitsuba 0.6's example scenes, whose yarns take their colours from the parameters
//!   `warp_kd`, `warp_ks`, `weft_kd` and `weft_ks`. Exactly one of the two.
//! - `repeatU`, `repeatV` (float, required, as in Mitsuba): how many times the pattern
//!   repeats over the unit square of texture coordinates.
//! - any parameter the pattern refers to as `$name` (a float or an rgb colour; textures are
//!   refused: the colours are per yarn).
//!
//! **Weave files:** `weave { key = value, …, pattern { i, … }, yarn { … }, … }` with
//! `/* … */` comments. Weave keys: `name` (quoted), `tileWidth`, `tileHeight`, `alpha`,
//! `beta`, `ss` (filament smoothing, in [0, 1)), `hWidth`, `warpArea`, `weftArea`,
//! `dWarpUmaxOverDWarp`, `dWarpUmaxOverDWeft`, `dWeftUmaxOverDWarp`, `dWeftUmaxOverDWeft`
//! (degrees), `fineness`, `period`. Yarn keys: `type` (`warp` or `weft`), `psi`, `umax`
//! (degrees), `kappa`, `width`, `length`, `centerU`, `centerV`, `kd`, `ks`. Numbers may be
//! written `$name` to read the plugin parameter `name`. `pattern` lists 1-based yarn
//! indices row by row. Errors name the file, line and column.
//!
//! A yarn with width · sin(umax) ≥ length has no specular reflection (its spine would not
//! fit its segment), as in Mitsuba: the weft of the built-in `twill` is such a yarn.
//!
//! **Sampling:** Mitsuba 0.6 samples cosine-weighted directions only ("lacking a better
//! sampling method"). Specula samples a mixture: half the samples are cosine-weighted; on a
//! filament yarn the other half reflect ωi about a half vector drawn uniformly from the
//! highlight window, the lune of half vectors whose inclination atan(h_y/h_z) in the yarn's
//! frame lies where the filament term can be non-zero at the shading point (on staple
//! yarns, whose window depends on the twist, all samples are cosine-weighted). `pdf` is the
//! mixture's density; the sampled lobe is reported as glossy reflection.
//!
//! **Deviations from Mitsuba 0.6:** the normalisation constant is estimated with 2^17
//! (not 10⁴) fixed-seed samples, so it differs from Mitsuba's by Mitsuba's own Monte Carlo
//! error (about 1 %); the correlated noise that varies `umax` per yarn segment (when
//! `period` is positive) is a 1-D gradient noise of Specula's with the statistics of Perlin's 1-D slice, not
//! Mitsuba's Perlin table, so the same yarn gets a different (equally distributed) tilt;
//! tile indices use floor where Mitsuba truncates towards zero (identical for uv ≥ 0).

use crate::bsdf::*;
use crate::props::{BuildError, Props};
use crate::rng::Pcg32;
use crate::spectrum::Spectrum;
use crate::warp;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, PI};
use std::sync::Arc;

/// The built-in weave patterns (Specula's `pattern` parameter): name and file text.
pub const BUILTIN_WEAVES: &[(&str, &str)] = &[
    ("denim", include_str!("weaves/denim.wv")),
    ("charmeuse", include_str!("weaves/charmeuse.wv")),
    ("twill", include_str!("weaves/twill.wv")),
    ("gabardine", include_str!("weaves/gabardine.wv")),
    ("polyester", include_str!("weaves/polyester.wv")),
    ("shantung", include_str!("weaves/shantung.wv")),
];

/// One yarn segment of a weave pattern.
#[derive(Clone, Debug, PartialEq)]
pub struct Yarn {
    /// Warp (along v) or weft (along u).
    pub warp: bool,
    /// Fibre twist angle ψ (radians); 0 for a flat filament yarn.
    pub psi: f32,
    /// Maximum inclination angle (radians).
    pub umax: f32,
    /// Spine curvature κ (> −1).
    pub kappa: f32,
    /// Width and length of the segment, in pattern cells.
    pub width: f32,
    pub length: f32,
    /// Centre of the segment in tile space ([0, 1]², (0, 0) the lower left corner).
    pub center_u: f32,
    pub center_v: f32,
    /// Diffuse and specular colours.
    pub kd: Spectrum,
    pub ks: Spectrum,
}

/// A weave pattern: the tile and its yarns.
#[derive(Clone, Debug, PartialEq)]
pub struct WeavePattern {
    pub name: String,
    pub tile_width: u32,
    pub tile_height: u32,
    /// Uniform (α) and forward (β) scattering of the fibres.
    pub alpha: f32,
    pub beta: f32,
    /// Filament smoothing, in [0, 1).
    pub ss: f32,
    /// Highlight width, a fraction of the segment.
    pub h_width: f32,
    pub warp_area: f32,
    pub weft_area: f32,
    /// Amplitudes (radians) of the noise in `umax` along warp and weft.
    pub d_warp_umax_over_d_warp: f32,
    pub d_warp_umax_over_d_weft: f32,
    pub d_weft_umax_over_d_warp: f32,
    pub d_weft_umax_over_d_weft: f32,
    /// Density of the per-fibre intensity variation (0: none).
    pub fineness: f32,
    /// Period of the correlated noise in `umax` (0: none).
    pub period: f32,
    /// 0-based yarn index per cell, row by row.
    pub pattern: Vec<u16>,
    pub yarns: Vec<Yarn>,
}

/// The `irawan` material.
#[derive(Clone, Debug)]
pub struct Irawan {
    pub weave: Arc<WeavePattern>,
    pub repeat_u: f32,
    pub repeat_v: f32,
    /// N: scales the raw specular term so that its surface- and hemisphere-averaged albedo
    /// is 1.
    pub specular_normalization: f32,
}

// ---------------------------------------------------------------------------------------
// Weave pattern files

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    Num(f32),
    Str(String),
    Param(String),
    Sym(char),
}

fn tokenize(src: &str, file: &str) -> Result<Vec<(Tok, usize, usize)>, BuildError> {
    let at = |line: usize, col: usize| Some(format!("{file}:{line}:{col}"));
    let cs: Vec<char> = src.chars().collect();
    let (mut i, mut line, mut col) = (0usize, 1usize, 1usize);
    let mut out = Vec::new();
    let advance = |i: &mut usize, line: &mut usize, col: &mut usize, c: char| {
        *i += 1;
        if c == '\n' {
            *line += 1;
            *col = 1;
        } else {
            *col += 1;
        }
    };
    while i < cs.len() {
        let c = cs[i];
        let (l0, c0) = (line, col);
        if c.is_whitespace() {
            advance(&mut i, &mut line, &mut col, c);
        } else if c == '/' && cs.get(i + 1) == Some(&'*') {
            advance(&mut i, &mut line, &mut col, '/');
            advance(&mut i, &mut line, &mut col, '*');
            loop {
                if i >= cs.len() {
                    return Err(BuildError::new(at(l0, c0), "unterminated comment"));
                }
                if cs[i] == '*' && cs.get(i + 1) == Some(&'/') {
                    advance(&mut i, &mut line, &mut col, '*');
                    advance(&mut i, &mut line, &mut col, '/');
                    break;
                }
                let ch = cs[i];
                advance(&mut i, &mut line, &mut col, ch);
            }
        } else if "{}=,".contains(c) {
            out.push((Tok::Sym(c), l0, c0));
            advance(&mut i, &mut line, &mut col, c);
        } else if c == '"' {
            advance(&mut i, &mut line, &mut col, c);
            let mut s = String::new();
            loop {
                match cs.get(i) {
                    None | Some('\n') => {
                        return Err(BuildError::new(at(l0, c0), "unterminated string"))
                    }
                    Some('"') => {
                        advance(&mut i, &mut line, &mut col, '"');
                        break;
                    }
                    Some(&ch) => {
                        s.push(ch);
                        advance(&mut i, &mut line, &mut col, ch);
                    }
                }
            }
            out.push((Tok::Str(s), l0, c0));
        } else if c == '$' || c.is_ascii_alphabetic() || c == '_' {
            let param = c == '$';
            if param {
                advance(&mut i, &mut line, &mut col, c);
            }
            let mut s = String::new();
            while let Some(&ch) = cs.get(i) {
                if ch.is_ascii_alphanumeric() || ch == '_' {
                    s.push(ch);
                    advance(&mut i, &mut line, &mut col, ch);
                } else {
                    break;
                }
            }
            if param {
                if s.is_empty() {
                    return Err(BuildError::new(
                        at(l0, c0),
                        "'$' must be followed by a parameter name",
                    ));
                }
                out.push((Tok::Param(s), l0, c0));
            } else {
                out.push((Tok::Ident(s), l0, c0));
            }
        } else if c.is_ascii_digit() || c == '-' || c == '+' || c == '.' {
            let mut s = String::new();
            while let Some(&ch) = cs.get(i) {
                let exp_sign =
                    (ch == '-' || ch == '+') && matches!(s.chars().last(), Some('e' | 'E'));
                let lead_sign = s.is_empty() && (ch == '-' || ch == '+');
                if ch.is_ascii_digit()
                    || ch == '.'
                    || ch == 'e'
                    || ch == 'E'
                    || exp_sign
                    || lead_sign
                {
                    s.push(ch);
                    advance(&mut i, &mut line, &mut col, ch);
                } else {
                    break;
                }
            }
            let v: f32 = s
                .parse()
                .map_err(|_| BuildError::new(at(l0, c0), format!("'{s}' is not a number")))?;
            if !v.is_finite() {
                return Err(BuildError::new(at(l0, c0), format!("'{s}' is not finite")));
            }
            out.push((Tok::Num(v), l0, c0));
        } else {
            return Err(BuildError::new(
                at(l0, c0),
                format!("unexpected character '{c}'"),
            ));
        }
    }
    Ok(out)
}

/// Parameter values a weave file may refer to with `$name`.
pub trait WeaveParams {
    /// The colour (or grey level) of parameter `name`, or `None` when it is not given.
    fn spectrum(&self, name: &str) -> Result<Option<Spectrum>, BuildError>;
}

impl WeaveParams for Props {
    fn spectrum(&self, name: &str) -> Result<Option<Spectrum>, BuildError> {
        if !self.has(name) {
            return Ok(None);
        }
        match Props::spectrum(self, name, 0.0)? {
            // (a `<spectrum>` value: its RGB; the model upsamples its RGB data in spectral mode)
            SpectrumParam::Const(c) | SpectrumParam::Spectral { rgb: c, .. } => Ok(Some(c)),
            SpectrumParam::Texture(_) => Err(BuildError::new(
                self.loc.clone(),
                format!(
                    "'irawan': parameter '{name}' must be a float or an rgb colour (the weave's \
                     yarn colours are constants), not a texture"
                ),
            )),
        }
    }
}

/// Parameters given as a list of (name, value), for tests and tools.
impl WeaveParams for Vec<(&str, Spectrum)> {
    fn spectrum(&self, name: &str) -> Result<Option<Spectrum>, BuildError> {
        Ok(self.iter().find(|(n, _)| *n == name).map(|(_, v)| *v))
    }
}

/// Pattern entries with their locations.
type PatternCells = Vec<(u32, Option<String>)>;

struct Parser<'a> {
    toks: Vec<(Tok, usize, usize)>,
    pos: usize,
    file: &'a str,
    params: &'a dyn WeaveParams,
}

impl Parser<'_> {
    fn loc(&self) -> Option<String> {
        match self.toks.get(self.pos).or(self.toks.last()) {
            Some((_, l, c)) => Some(format!("{}:{l}:{c}", self.file)),
            None => Some(format!("{}:1:1", self.file)),
        }
    }
    fn err(&self, msg: impl Into<String>) -> BuildError {
        BuildError::new(self.loc(), msg)
    }
    fn next(&mut self) -> Option<Tok> {
        let t = self.toks.get(self.pos).map(|t| t.0.clone());
        self.pos += 1;
        t
    }
    fn expect_sym(&mut self, s: char) -> Result<(), BuildError> {
        match self.toks.get(self.pos) {
            Some((Tok::Sym(c), _, _)) if *c == s => {
                self.pos += 1;
                Ok(())
            }
            Some(_) => Err(self.err(format!("expected '{s}'"))),
            None => Err(self.err(format!("expected '{s}', found the end of the file"))),
        }
    }
    fn peek_sym(&self, s: char) -> bool {
        matches!(self.toks.get(self.pos), Some((Tok::Sym(c), _, _)) if *c == s)
    }
    fn ident(&mut self) -> Result<String, BuildError> {
        match self.toks.get(self.pos) {
            Some((Tok::Ident(s), _, _)) => {
                let s = s.clone();
                self.pos += 1;
                Ok(s)
            }
            _ => Err(self.err("expected a name")),
        }
    }
    /// A number or `$name` (a float parameter; a colour's channels must agree).
    fn spectrum(&mut self) -> Result<Spectrum, BuildError> {
        let loc = self.loc();
        match self.next() {
            Some(Tok::Num(v)) => Ok(Spectrum::splat(v)),
            Some(Tok::Param(name)) => match self.params.spectrum(&name)? {
                Some(v) => Ok(v),
                None => Err(BuildError::new(
                    loc,
                    format!(
                        "the weave refers to '${name}': give the 'irawan' plugin a parameter \
                         '{name}'"
                    ),
                )),
            },
            _ => Err(BuildError::new(loc, "expected a number or a $parameter")),
        }
    }
    fn float(&mut self) -> Result<f32, BuildError> {
        let loc = self.loc();
        let s = self.spectrum()?;
        if s.0[0] == s.0[1] && s.0[1] == s.0[2] {
            Ok(s.0[0])
        } else {
            Err(BuildError::new(
                loc,
                "expected a number, got a colour parameter",
            ))
        }
    }

    fn yarn(&mut self) -> Result<Yarn, BuildError> {
        self.expect_sym('{')?;
        let mut y = Yarn {
            warp: true,
            psi: 0.0,
            umax: 0.0,
            kappa: 0.0,
            width: 0.0,
            length: 0.0,
            center_u: 0.0,
            center_v: 0.0,
            kd: Spectrum::ZERO,
            ks: Spectrum::ZERO,
        };
        loop {
            let key = self.ident()?;
            self.expect_sym('=')?;
            match key.as_str() {
                "type" => {
                    let loc = self.loc();
                    y.warp = match self.ident()?.as_str() {
                        "warp" => true,
                        "weft" => false,
                        other => {
                            return Err(BuildError::new(
                                loc,
                                format!("yarn type must be 'warp' or 'weft', got '{other}'"),
                            ))
                        }
                    }
                }
                "psi" => y.psi = self.float()?.to_radians(),
                "umax" => y.umax = self.float()?.to_radians(),
                "kappa" => y.kappa = self.float()?,
                "width" => y.width = self.float()?,
                "length" => y.length = self.float()?,
                "centerU" => y.center_u = self.float()?,
                "centerV" => y.center_v = self.float()?,
                "kd" => y.kd = self.spectrum()?,
                "ks" => y.ks = self.spectrum()?,
                other => {
                    self.pos -= 2;
                    return Err(self.err(format!(
                        "unknown yarn parameter '{other}' (known: type, psi, umax, kappa, \
                         width, length, centerU, centerV, kd, ks)"
                    )));
                }
            }
            if self.peek_sym(',') {
                self.pos += 1;
            } else {
                break;
            }
        }
        self.expect_sym('}')?;
        Ok(y)
    }

    /// The weave and its pattern cells, each with where it was written.
    fn weave(&mut self) -> Result<(WeavePattern, PatternCells), BuildError> {
        match self.next() {
            Some(Tok::Ident(s)) if s == "weave" => {}
            _ => {
                self.pos = self.pos.saturating_sub(1);
                return Err(self.err("expected 'weave {'"));
            }
        }
        self.expect_sym('{')?;
        let mut w = WeavePattern {
            name: String::new(),
            tile_width: 0,
            tile_height: 0,
            alpha: 0.0,
            beta: 0.0,
            ss: 0.0,
            h_width: 0.0,
            warp_area: 0.0,
            weft_area: 0.0,
            d_warp_umax_over_d_warp: 0.0,
            d_warp_umax_over_d_weft: 0.0,
            d_weft_umax_over_d_warp: 0.0,
            d_weft_umax_over_d_weft: 0.0,
            fineness: 0.0,
            period: 0.0,
            pattern: Vec::new(),
            yarns: Vec::new(),
        };
        let mut cells: PatternCells = Vec::new();
        loop {
            let key_loc = self.loc();
            let key = self.ident()?;
            match key.as_str() {
                "pattern" => {
                    self.expect_sym('{')?;
                    loop {
                        let loc = self.loc();
                        match self.next() {
                            Some(Tok::Num(v)) if v >= 1.0 && v.fract() == 0.0 && v < 65536.0 => {
                                cells.push((v as u32, loc))
                            }
                            _ => {
                                return Err(BuildError::new(
                                    loc,
                                    "pattern entries are yarn numbers 1, 2, …",
                                ))
                            }
                        }
                        if self.peek_sym(',') {
                            self.pos += 1;
                        } else {
                            break;
                        }
                    }
                    self.expect_sym('}')?;
                }
                "yarn" => w.yarns.push(self.yarn()?),
                _ => {
                    self.expect_sym('=')?;
                    if key == "name" {
                        match self.next() {
                            Some(Tok::Str(s)) => w.name = s,
                            _ => {
                                self.pos -= 1;
                                return Err(self.err("expected a quoted name"));
                            }
                        }
                    } else {
                        let v = self.float()?;
                        let tile = |v: f32| {
                            if v >= 1.0 && v.fract() == 0.0 && v <= 4096.0 {
                                Ok(v as u32)
                            } else {
                                Err(BuildError::new(
                                    key_loc.clone(),
                                    format!("'{key}' must be a whole number from 1 to 4096"),
                                ))
                            }
                        };
                        match key.as_str() {
                            "tileWidth" => w.tile_width = tile(v)?,
                            "tileHeight" => w.tile_height = tile(v)?,
                            "alpha" => w.alpha = v,
                            "beta" => w.beta = v,
                            "ss" => w.ss = v,
                            "hWidth" => w.h_width = v,
                            "warpArea" => w.warp_area = v,
                            "weftArea" => w.weft_area = v,
                            "dWarpUmaxOverDWarp" => w.d_warp_umax_over_d_warp = v.to_radians(),
                            "dWarpUmaxOverDWeft" => w.d_warp_umax_over_d_weft = v.to_radians(),
                            "dWeftUmaxOverDWarp" => w.d_weft_umax_over_d_warp = v.to_radians(),
                            "dWeftUmaxOverDWeft" => w.d_weft_umax_over_d_weft = v.to_radians(),
                            "fineness" => w.fineness = v,
                            "period" => w.period = v,
                            other => {
                                return Err(BuildError::new(
                                    key_loc,
                                    format!(
                                        "unknown weave parameter '{other}' (known: name, \
                                         tileWidth, tileHeight, alpha, beta, ss, hWidth, \
                                         warpArea, weftArea, dWarpUmaxOverDWarp, \
                                         dWarpUmaxOverDWeft, dWeftUmaxOverDWarp, \
                                         dWeftUmaxOverDWeft, fineness, period, pattern, yarn)"
                                    ),
                                ))
                            }
                        }
                    }
                }
            }
            if self.peek_sym(',') {
                self.pos += 1;
            } else {
                break;
            }
        }
        self.expect_sym('}')?;
        if self.pos < self.toks.len() {
            return Err(self.err("unexpected text after the weave"));
        }
        Ok((w, cells))
    }
}

impl WeavePattern {
    /// Parse a weave pattern file's text; `file` names it in errors, `params` resolves
    /// `$name` references.
    pub fn parse(src: &str, file: &str, params: &dyn WeaveParams) -> Result<Self, BuildError> {
        let toks = tokenize(src, file)?;
        let mut p = Parser {
            toks,
            pos: 0,
            file,
            params,
        };
        let (mut w, cells) = p.weave()?;
        let whole = Some(format!("{file}:1:1"));
        let fail = |msg: String| Err(BuildError::new(whole.clone(), msg));
        if w.tile_width == 0 || w.tile_height == 0 {
            return fail("the weave needs 'tileWidth' and 'tileHeight'".into());
        }
        let n = (w.tile_width * w.tile_height) as usize;
        if cells.len() != n {
            return fail(format!(
                "the pattern has {} entries; a {}×{} tile needs {n}",
                cells.len(),
                w.tile_width,
                w.tile_height
            ));
        }
        if w.yarns.is_empty() {
            return fail("the weave has no yarns".into());
        }
        for (c, loc) in &cells {
            if *c as usize > w.yarns.len() {
                return Err(BuildError::new(
                    loc.clone(),
                    format!(
                        "pattern entry {c} names no yarn (the weave has {})",
                        w.yarns.len()
                    ),
                ));
            }
        }
        w.pattern = cells.iter().map(|(c, _)| (*c - 1) as u16).collect();
        if !(0.0..1.0).contains(&w.ss) {
            return fail(format!("'ss' must lie in [0, 1), got {}", w.ss));
        }
        if !(w.h_width > 0.0 && w.h_width <= 1.0) {
            return fail(format!("'hWidth' must lie in (0, 1], got {}", w.h_width));
        }
        if w.fineness < 0.0 || w.period < 0.0 || w.beta < 0.0 || w.alpha < 0.0 {
            return fail("'alpha', 'beta', 'fineness' and 'period' must not be negative".into());
        }
        let used = |warp: bool| w.pattern.iter().any(|&i| w.yarns[i as usize].warp == warp);
        if (used(true) && w.warp_area <= 0.0) || (used(false) && w.weft_area <= 0.0) {
            return fail("'warpArea' and 'weftArea' must be positive for the yarns used".into());
        }
        for (i, y) in w.yarns.iter().enumerate() {
            let bad = |m: &str| {
                Err(BuildError::new(
                    whole.clone(),
                    format!("yarn {}: {m}", i + 1),
                ))
            };
            if !(y.width > 0.0 && y.length > 0.0) {
                return bad("'width' and 'length' must be positive");
            }
            if !(y.umax > 0.0 && y.umax < FRAC_PI_2) {
                return bad("'umax' must lie in (0°, 90°)");
            }
            if y.kappa <= -1.0 {
                return bad("'kappa' must be greater than -1");
            }
            if y.psi.abs() >= FRAC_PI_2 {
                return bad("'psi' must lie in (-90°, 90°)");
            }
            if !(y.kd.min_component() >= 0.0 && y.ks.min_component() >= 0.0) {
                return bad("'kd' and 'ks' must not be negative");
            }
        }
        Ok(w)
    }
}

// ---------------------------------------------------------------------------------------
// Noise

/// Mitsuba's `sampleTEAFloat`: the Tiny Encryption Algorithm on (v0, v1), mapped to [0, 1).
#[inline]
fn tea_float(mut v0: u32, mut v1: u32, rounds: u32) -> f32 {
    let mut sum: u32 = 0;
    for _ in 0..rounds {
        sum = sum.wrapping_add(0x9e37_79b9);
        v0 = v0.wrapping_add(
            (v1 << 4).wrapping_add(0xa341_316c)
                ^ v1.wrapping_add(sum)
                ^ (v1 >> 5).wrapping_add(0xc801_3ea4),
        );
        v1 = v1.wrapping_add(
            (v0 << 4).wrapping_add(0xad90_777d)
                ^ v0.wrapping_add(sum)
                ^ (v0 >> 5).wrapping_add(0x7e95_761e),
        );
    }
    f32::from_bits((v0 >> 9) | 0x3f80_0000) - 1.0
}

/// 1-D gradient noise in [−½, ½] with Perlin's improved-noise statistics along a lattice
/// axis: the gradient at each integer is −1, 0 or 1 (the x components of the 16 cube-edge
/// gradients), chosen by a hash of the integer.
#[inline]
fn gradient_noise(x: f32) -> f32 {
    const GX: [f32; 16] = [
        1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0,
    ];
    let x0 = x.floor();
    let f = x - x0;
    let i = x0 as i64 as u32;
    let g = |k: u32| GX[(tea_float(k, 0x5eed, 4) * 16.0) as usize & 15];
    let fade = f * f * f * (f * (f * 6.0 - 15.0) + 10.0);
    let a = g(i) * f;
    let b = g(i.wrapping_add(1)) * (f - 1.0);
    a + (b - a) * fade
}

// ---------------------------------------------------------------------------------------
// The scattering functions (Irawan's thesis, chapters 5 and 6)

/// The von Mises distribution exp(b cos x) / (2π I₀(b)), I₀ by Abramowitz & Stegun 9.8.1–2.
#[inline]
fn von_mises(cos_x: f32, b: f32) -> f32 {
    let ab = b.abs();
    let i0 = if ab <= 3.75 {
        let t = (ab / 3.75) * (ab / 3.75);
        1.0 + t
            * (3.515_623
                + t * (3.089_942_4
                    + t * (1.206_749_2 + t * (0.265_973_2 + t * (0.036_076_8 + t * 0.004_581_3)))))
    } else {
        let t = 3.75 / ab;
        ab.exp() / ab.sqrt()
            * (0.398_942_3
                + t * (0.013_285_92
                    + t * (0.002_253_19
                        + t * (-0.001_575_65
                            + t * (0.009_162_81
                                + t * (-0.020_577_06
                                    + t * (0.026_355_37
                                        + t * (-0.016_476_33 + t * 0.003_923_77))))))))
    };
    (b * cos_x).exp() / (2.0 * PI * i0)
}

/// Seeliger's attenuation for a purely scattering medium: c₁c₂ / (4π (c₁ + c₂)).
#[inline]
fn seeliger(c1: f32, c2: f32) -> f32 {
    if c1 <= 0.0 || c2 <= 0.0 {
        return 0.0;
    }
    c1 * c2 / (4.0 * PI * (c1 + c2))
}

#[inline]
fn smooth_step(x: f32) -> f32 {
    let v = x.clamp(0.0, 1.0);
    v * v * (3.0 - 2.0 * v)
}

/// Radius of curvature of the yarn's spine at inclination `u` (thesis §5.3): an ellipse,
/// circle, parabola or hyperbola as r̂ = 1 + κ(1 + 1/tan umax) is >0, 1, 0 or <0.
fn radius_of_curvature(u: f32, umax: f32, kappa: f32, w: f32, l: f32) -> f32 {
    let rhat = 1.0 + kappa * (1.0 + 1.0 / umax.tan());
    let a = 0.5 * w;
    let half_chord = 0.5 * l - a * umax.sin();
    if rhat == 1.0 {
        half_chord / umax.sin()
    } else if rhat > 0.0 {
        let tmax = (rhat * umax.tan()).atan();
        let bhat = half_chord / tmax.sin();
        let ahat = bhat / rhat;
        let t = (rhat * u.tan()).atan();
        let (st, ct) = t.sin_cos();
        (bhat * bhat * ct * ct + ahat * ahat * st * st).powf(1.5) / (ahat * bhat)
    } else if rhat < 0.0 {
        let tmax = -(rhat * umax.tan()).atanh();
        let bhat = half_chord / tmax.sinh();
        let ahat = bhat / rhat;
        let t = -(rhat * u.tan()).atanh();
        let (sh, ch) = (t.sinh(), t.cosh());
        -(bhat * bhat * ch * ch + ahat * ahat * sh * sh).powf(1.5) / (ahat * bhat)
    } else {
        let ahat = half_chord / (2.0 * umax.tan());
        let t = u.tan();
        2.0 * ahat * (1.0 + t * t).powf(1.5)
    }
}

impl WeavePattern {
    /// The specular integrand of a flat filament yarn (ψ = 0) at yarn coordinates (u, v).
    #[allow(clippy::too_many_arguments)]
    fn filament(&self, u: f32, v: f32, wi: Vec3, wo: Vec3, umax: f32, y: &Yarn) -> f32 {
        let (w, l, ss) = (y.width, y.length, self.ss);
        if w * umax.sin() >= l {
            return 0.0;
        }
        let sum = wi + wo;
        let h = sum.normalize();
        let u_of_v = (h.y / h.z).atan();
        if u_of_v.abs() >= umax {
            return 0.0;
        }
        // the highlight has a constant width Δy = l·hWidth along the yarn
        let delta_y = l * self.h_width;
        let y_scale = 0.5 * l / umax;
        let y_of_v = (u_of_v * y_scale).clamp(0.5 * (delta_y - l), 0.5 * (l - delta_y));
        if (y_of_v - u * y_scale).abs() >= 0.5 * delta_y {
            return 0.0;
        }
        let (su, cu) = u_of_v.sin_cos();
        let (sv, cv) = v.sin_cos();
        let n = Vec3::new(sv, su * cv, cu * cv).normalize();
        let a_att = seeliger(n.dot(wi), n.dot(wo));
        if a_att == 0.0 {
            return 0.0;
        }
        // fibre tangent t = (0, cos u, −sin u): (t × h)_x = cos u h_z + sin u h_y
        let t_cross_h_x = cu * h.z + su * h.y;
        let r = radius_of_curvature(
            u_of_v.abs().min((1.0 - ss) * umax),
            (1.0 - ss) * umax,
            y.kappa,
            w,
            l,
        );
        let a = 0.5 * w;
        let g = a * (r + a * cv) / (sum.length() * t_cross_h_x.abs());
        let fc = self.alpha + von_mises(-wi.dot(wo), self.beta);
        let a_s = if ss == 0.0 {
            a_att
        } else {
            a_att * (1.0 - smooth_step((u_of_v.abs() - (1.0 - ss) * umax) / (ss * umax)))
        };
        // domain transform, then spread over the highlight width
        g * fc * a_s * PI * l / delta_y
    }

    /// The specular integrand of a twisted staple yarn (ψ ≠ 0).
    #[allow(clippy::too_many_arguments)]
    fn staple(&self, u: f32, v: f32, wi: Vec3, wo: Vec3, umax: f32, y: &Yarn) -> f32 {
        let (w, l, psi) = (y.width, y.length, y.psi);
        if w * umax.sin() >= l {
            return 0.0;
        }
        let sum = wi + wo;
        let h = sum.normalize();
        let (su, cu) = u.sin_cos();
        let d = (h.y * cu - h.z * su)
            / ((h.x * h.x + (h.y * su + h.z * cu).powi(2)).sqrt() * psi.tan());
        if d.is_nan() || d.abs() >= 1.0 {
            return 0.0;
        }
        let v_of_u = (-h.y * su - h.z * cu).atan2(h.x) + d.acos();
        if v_of_u.abs() >= FRAC_PI_2 {
            return 0.0;
        }
        let delta_x = w * self.h_width;
        let x_of_u = (v_of_u * w / PI).clamp(0.5 * (delta_x - w), 0.5 * (w - delta_x));
        if (x_of_u - v * w / PI).abs() >= 0.5 * delta_x {
            return 0.0;
        }
        let (sv, cv) = v_of_u.sin_cos();
        let n = Vec3::new(sv, su * cv, cu * cv).normalize();
        let a_att = seeliger(n.dot(wi), n.dot(wo));
        if a_att == 0.0 {
            return 0.0;
        }
        let r = radius_of_curvature(u.abs(), umax, y.kappa, w, l);
        let a = 0.5 * w;
        let g = a * (r + a * cv) / (sum.length() * n.dot(h) * psi.sin().abs());
        let fc = self.alpha + von_mises(-wi.dot(wo), self.beta);
        g * fc * a_att * 2.0 * w * umax / delta_x
    }

    /// The yarn seen at texture coordinates `uv` (Mitsuba's convention: v runs down the
    /// pattern) and where on it.
    #[inline]
    fn locate(&self, repeat: Vec2, uv: Vec2) -> Spot<'_> {
        let (tw, th) = (self.tile_width as f32, self.tile_height as f32);
        let x = uv.x * repeat.x * tw;
        let yy = (1.0 - uv.y) * repeat.y * th;
        let (fx, fy) = (x.floor(), yy.floor());
        let lx = (fx as i64).rem_euclid(self.tile_width as i64) as usize;
        let ly = (fy as i64).rem_euclid(self.tile_height as i64) as usize;
        let yarn = &self.yarns[self.pattern[lx + ly * self.tile_width as usize] as usize];
        // the segment's centre, in cells
        let center = Vec2::new(
            (x / tw).floor() * tw + yarn.center_u * tw,
            (yy / th).floor() * th + (1.0 - yarn.center_v) * th,
        );
        let mut px = x - center.x;
        let mut py = -(yy - center.y);
        let (d_warp, d_weft) = if yarn.warp {
            (self.d_warp_umax_over_d_warp, self.d_warp_umax_over_d_weft)
        } else {
            // a weft yarn is a warp yarn turned by π/2 about the normal
            (px, py) = (-py, px);
            (self.d_weft_umax_over_d_warp, self.d_weft_umax_over_d_weft)
        };
        let mut umax = yarn.umax;
        if self.period > 0.0 {
            // correlated noise in the inclination, one seed per segment
            let (pu, pv) = (center.x.max(0.0) as u32, center.y.max(0.0) as u32);
            let r1 = gradient_noise(
                (center.x * (th * repeat.y + tea_float(pu, 2 * pv, 8)) + center.y) / self.period,
            );
            let r2 = gradient_noise(
                (center.y * (tw * repeat.x + tea_float(pu, 2 * pv + 1, 8)) + center.x)
                    / self.period,
            );
            umax += r1 * d_warp + r2 * d_weft;
        }
        Spot {
            yarn,
            center,
            px,
            py,
            umax,
            u: py / (0.5 * yarn.length) * umax,
            v: px * PI / yarn.width,
        }
    }

    /// The raw specular term (before `ks` and the normalisation) at `spot`.
    #[inline]
    fn specular_at(&self, spot: &Spot, wi: Vec3, wo: Vec3) -> f32 {
        let (yarn, umax) = (spot.yarn, spot.umax);
        if !(umax > 0.0 && umax < FRAC_PI_2) {
            return 0.0;
        }
        let (wi, wo) = (spot.to_yarn(wi), spot.to_yarn(wo));
        let mut s = if yarn.psi != 0.0 {
            self.staple(spot.u, spot.v, wi, wo, umax, yarn)
        } else {
            self.filament(spot.u, spot.v, wi, wo, umax, yarn)
        };
        if s == 0.0 {
            return 0.0;
        }
        if self.fineness > 0.0 {
            // a random intensity per fineness² area of texture (exponentially distributed)
            let i1 = ((spot.center.x + spot.px) * self.fineness).max(0.0) as u32;
            let i2 = ((spot.center.y + spot.py) * self.fineness).max(0.0) as u32;
            let xi = tea_float(i1, i2, 8);
            s *= (-xi.ln()).min(10.0);
        }
        let area = self.warp_area + self.weft_area;
        s *= if yarn.warp {
            area / self.warp_area
        } else {
            area / self.weft_area
        };
        if s.is_finite() {
            s.max(0.0)
        } else {
            0.0
        }
    }

    /// The yarn seen at `uv` and the raw specular term there.
    #[inline]
    fn specular(&self, repeat: Vec2, uv: Vec2, wi: Vec3, wo: Vec3) -> (&Yarn, f32) {
        let spot = self.locate(repeat, uv);
        (spot.yarn, self.specular_at(&spot, wi, wo))
    }

    /// For a filament yarn, the interval of half-vector inclinations γ = atan(h_y/h_z) (yarn
    /// frame) where its specular term can be non-zero at `spot`: the highlight window
    /// |clamp(γ) − u| < hWidth·umax of [`WeavePattern::filament`], within (−umax, umax).
    /// `None` for staple yarns and where the yarn has no highlight.
    #[inline]
    fn highlight_window(&self, spot: &Spot) -> Option<(f32, f32)> {
        let (yarn, umax) = (spot.yarn, spot.umax);
        if yarn.psi != 0.0
            || !(umax > 0.0 && umax < FRAC_PI_2)
            || yarn.width * umax.sin() >= yarn.length
            || yarn.ks.max_component() <= 0.0
        {
            return None;
        }
        // in units of γ: the clamp limit c and the half width of the window
        let half = self.h_width * umax;
        let c = umax - half;
        let (mut lo, mut hi) = (spot.u - half, spot.u + half);
        if (c - spot.u).abs() < half {
            hi = umax;
        }
        if (-c - spot.u).abs() < half {
            lo = -umax;
        }
        let (lo, hi) = (lo.max(-umax), hi.min(umax));
        (hi > lo).then_some((lo, hi))
    }
}

/// Where on the weave a shading point lies: the yarn, its segment's centre (cells), the
/// offset from it (yarn frame), the inclination bound and the yarn coordinates (u, v).
struct Spot<'a> {
    yarn: &'a Yarn,
    center: Vec2,
    px: f32,
    py: f32,
    umax: f32,
    u: f32,
    v: f32,
}

impl Spot<'_> {
    /// From the shading frame to the yarn's (a weft yarn's is turned by π/2).
    #[inline]
    fn to_yarn(&self, w: Vec3) -> Vec3 {
        if self.yarn.warp {
            w
        } else {
            Vec3::new(-w.y, w.x, w.z)
        }
    }
    /// From the yarn's frame to the shading frame.
    #[inline]
    fn yarn_to_shading(&self, w: Vec3) -> Vec3 {
        if self.yarn.warp {
            w
        } else {
            Vec3::new(w.y, -w.x, w.z)
        }
    }
}

/// Samples of the normalisation estimate.
const NORMALIZATION_SAMPLES: usize = 1 << 17;

impl Irawan {
    /// A material of weave `weave` repeated `repeat_u` × `repeat_v` times over the unit
    /// square; estimates the specular normalisation.
    pub fn new(weave: WeavePattern, repeat_u: f32, repeat_v: f32) -> Self {
        let weave = Arc::new(weave);
        let repeat = Vec2::new(repeat_u, repeat_v);
        let mut rng = Pcg32::new(0x1a5a_3a11, 7);
        let mut sum = 0.0f64;
        for _ in 0..NORMALIZATION_SAMPLES {
            let wi = warp::square_to_cosine_hemisphere(rng.next_vec2());
            let wo = warp::square_to_cosine_hemisphere(rng.next_vec2());
            let uv = rng.next_vec2();
            if wi.z > 0.0 && wo.z > 0.0 {
                sum += weave.specular(repeat, uv, wi, wo).1 as f64;
            }
        }
        let specular_normalization = if sum > 0.0 {
            (NORMALIZATION_SAMPLES as f64 / (sum * std::f64::consts::PI)) as f32
        } else {
            0.0
        };
        Irawan {
            weave,
            repeat_u,
            repeat_v,
            specular_normalization,
        }
    }

    /// Builds the plugin from its parameters (`filename` or `pattern`, `repeatU`, `repeatV`
    /// and the `$` parameters of the weave).
    pub fn build(p: &Props) -> Result<Self, BuildError> {
        let (src, file) = match (p.has("filename"), p.has("pattern")) {
            (true, true) | (false, false) => {
                return Err(BuildError::new(
                    p.loc.clone(),
                    "'irawan' needs exactly one of 'filename' (a weave pattern file) and \
                     'pattern' (a built-in weave)",
                ))
            }
            (true, false) => {
                let file = p.string("filename", "")?;
                let src = std::fs::read_to_string(&file).map_err(|e| {
                    BuildError::new(
                        p.loc.clone(),
                        format!("'irawan': cannot read weave pattern file '{file}': {e}"),
                    )
                })?;
                (src, file)
            }
            (false, true) => {
                let names: Vec<&str> = BUILTIN_WEAVES.iter().map(|(n, _)| *n).collect();
                let name = p.choice("pattern", "denim", &names)?;
                let src = BUILTIN_WEAVES.iter().find(|(n, _)| *n == name).unwrap().1;
                (src.to_string(), format!("built-in weave '{name}'"))
            }
        };
        let repeat_u = p.float_required("repeatU")?;
        let repeat_v = p.float_required("repeatV")?;
        if !(repeat_u > 0.0 && repeat_v > 0.0) {
            return Err(BuildError::new(
                p.loc.clone(),
                format!("'irawan': 'repeatU' and 'repeatV' must be positive, got {repeat_u} and {repeat_v}"),
            ));
        }
        let weave = WeavePattern::parse(&src, &file, p)?;
        Ok(Irawan::new(weave, repeat_u, repeat_v))
    }

    #[inline]
    fn repeat(&self) -> Vec2 {
        Vec2::new(self.repeat_u, self.repeat_v)
    }
}

/// The probability of sampling the highlight window of a filament yarn (the rest, and
/// everything on staple yarns, is cosine-weighted).
const WINDOW_FRACTION: f32 = 0.5;

impl Irawan {
    /// The density of `sample` for `wo` at `spot` with highlight window `window`.
    #[inline]
    fn mixture_pdf(&self, spot: &Spot, window: Option<(f32, f32)>, wi: Vec3, wo: Vec3) -> f32 {
        let cosine = warp::square_to_cosine_hemisphere_pdf(wo);
        let Some((lo, hi)) = window else {
            return cosine;
        };
        if wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        let hy = spot.to_yarn(h);
        let g = (hy.y / hy.z).atan();
        let wih = wi.dot(h);
        let band = if g >= lo && g <= hi && wih > 0.0 {
            // uniform over the lune of half vectors, area 2 (hi − lo)
            1.0 / (2.0 * (hi - lo) * 4.0 * wih)
        } else {
            0.0
        };
        (1.0 - WINDOW_FRACTION) * cosine + WINDOW_FRACTION * band
    }
}

impl BsdfModel for Irawan {
    fn flags(&self) -> LobeFlags {
        LobeFlags::GLOSSY_REFLECTION | LobeFlags::DIFFUSE_REFLECTION
    }

    #[inline]
    fn eval(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        let (yarn, s) = self.weave.specular(self.repeat(), sp.uv, wi, wo);
        yarn.kd * FRAC_1_PI + yarn.ks * (s * self.specular_normalization)
    }

    #[inline]
    fn pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 {
            return 0.0;
        }
        let spot = self.weave.locate(self.repeat(), sp.uv);
        let window = self.weave.highlight_window(&spot);
        self.mixture_pdf(&spot, window, wi, wo)
    }

    #[inline]
    fn eval_pdf(&self, _: &BsdfContext, sp: &ShadingPoint, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        if wi.z <= 0.0 {
            return (Spectrum::ZERO, 0.0);
        }
        let spot = self.weave.locate(self.repeat(), sp.uv);
        let window = self.weave.highlight_window(&spot);
        let pdf = self.mixture_pdf(&spot, window, wi, wo);
        if wo.z <= 0.0 {
            return (Spectrum::ZERO, pdf);
        }
        let s = self.weave.specular_at(&spot, wi, wo);
        let f = spot.yarn.kd * FRAC_1_PI + spot.yarn.ks * (s * self.specular_normalization);
        (f, pdf)
    }

    #[inline]
    fn sample(
        &self,
        _: &BsdfContext,
        sp: &ShadingPoint,
        wi: Vec3,
        u1: f32,
        u2: Vec2,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let spot = self.weave.locate(self.repeat(), sp.uv);
        let window = self.weave.highlight_window(&spot);
        let wo = match window {
            Some((lo, hi)) if u1 < WINDOW_FRACTION => {
                // a half vector uniform over the lune lo ≤ atan(h_y/h_z) ≤ hi (yarn frame)
                let g = lo + (hi - lo) * u2.x;
                let sb = (2.0 * u2.y - 1.0).clamp(-1.0, 1.0);
                let cb = (1.0 - sb * sb).max(0.0).sqrt();
                let (sg, cg) = g.sin_cos();
                let h = spot.yarn_to_shading(Vec3::new(sb, cb * sg, cb * cg));
                if wi.dot(h) <= 0.0 {
                    return None;
                }
                crate::frame::reflect(wi, h)
            }
            _ => warp::square_to_cosine_hemisphere(u2),
        };
        if wo.z <= 0.0 {
            return None;
        }
        let pdf = self.mixture_pdf(&spot, window, wi, wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        let s = self.weave.specular_at(&spot, wi, wo);
        let f = spot.yarn.kd * FRAC_1_PI + spot.yarn.ks * (s * self.specular_normalization);
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
    use crate::check::{run_suite, SuiteConfig, Verdict};
    use crate::parse_spec;

    const COLOURS: &str = "warp_kd=0.05,0.1,0.3 warp_ks=0.3 weft_kd=0.3 weft_ks=0.2";

    fn build(spec: &str) -> Irawan {
        match parse_spec(spec).unwrap_or_else(|e| panic!("{spec}: {e}")) {
            Bsdf::Irawan(b) => *b,
            other => panic!("{spec} built {}", other.plugin_name()),
        }
    }
    use crate::models::Bsdf;

    fn err(spec: &str) -> String {
        parse_spec(spec).expect_err(spec).to_string()
    }

    #[test]
    fn builtin_weaves_parse_and_normalise() {
        for (name, _) in BUILTIN_WEAVES {
            let b = build(&format!(
                "irawan pattern={name} repeatU=40 repeatV=30 {COLOURS}"
            ));
            let w = &b.weave;
            assert_eq!(w.pattern.len(), (w.tile_width * w.tile_height) as usize);
            assert!(w.pattern.iter().all(|&i| (i as usize) < w.yarns.len()));
            assert!(w.yarns.iter().any(|y| y.warp) && w.yarns.iter().any(|y| !y.warp));
            assert!(
                b.specular_normalization.is_finite() && b.specular_normalization > 0.0,
                "{name}: N = {}",
                b.specular_normalization
            );
        }
    }

    /// With kd = 0 and ks = 1 the specular albedo averaged over the unit square of uv and
    /// over cosine-distributed ωi is 1 (Mitsuba's normalisation), checked with samples
    /// independent of the ones the constant was estimated with.
    #[test]
    fn specular_albedo_averages_to_ks() {
        for name in ["denim", "charmeuse", "polyester", "shantung"] {
            let b = build(&format!(
                "irawan pattern={name} repeatU=7 repeatV=5 warp_kd=0 warp_ks=1 weft_kd=0 weft_ks=1"
            ));
            let mut rng = Pcg32::new(99, 3);
            let n = 1 << 17;
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let wi = warp::square_to_cosine_hemisphere(rng.next_vec2());
                let wo = warp::square_to_cosine_hemisphere(rng.next_vec2());
                let sp = ShadingPoint::at_uv(rng.next_f32(), rng.next_f32());
                // π f is the albedo estimator for cosine-distributed ωo
                let x = (PI * b.eval(&BsdfContext::RADIANCE, &sp, wi, wo).r()) as f64;
                s += x;
                s2 += x * x;
            }
            let mean = s / n as f64;
            let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
            assert!(
                (mean - 1.0).abs() < 5.0 * se + 0.01,
                "{name}: averaged specular albedo {mean} ± {se}"
            );
        }
    }

    #[test]
    fn reciprocal_and_periodic() {
        // gabardine has neither noise nor per-fibre variation: one tile repeats exactly
        let b = build(&format!(
            "irawan pattern=gabardine repeatU=4 repeatV=8 {COLOURS}"
        ));
        let ctx = BsdfContext::RADIANCE;
        let mut rng = Pcg32::new(5, 1);
        let mut nonzero = 0;
        for _ in 0..20000 {
            let wi = warp::square_to_cosine_hemisphere(rng.next_vec2());
            let wo = warp::square_to_cosine_hemisphere(rng.next_vec2());
            let (u, v) = (rng.next_f32() * 0.7, rng.next_f32() * 0.8);
            let sp = ShadingPoint::at_uv(u, v);
            let f = b.eval(&ctx, &sp, wi, wo);
            assert_eq!(f, b.eval(&ctx, &sp, wo, wi));
            let shifted = ShadingPoint::at_uv(u + 0.25, v + 0.125);
            let g = b.eval(&ctx, &shifted, wi, wo);
            assert!(
                (f.r() - g.r()).abs() <= 1e-3 * f.r().max(1e-3),
                "not periodic at ({u}, {v}): {f:?} vs {g:?}"
            );
            if f.r() > 0.3 / PI + 1e-4 || f.b() > 0.3 / PI + 1e-4 {
                nonzero += 1;
            }
        }
        assert!(nonzero > 500, "the specular term is rarely seen: {nonzero}");
    }

    #[test]
    fn property_suite_passes_but_energy() {
        let b = build(&format!(
            "irawan pattern=polyester repeatU=10 repeatV=10 {COLOURS}"
        ));
        for uv in [Vec2::new(0.013, 0.021), Vec2::new(0.37, 0.52)] {
            let cfg = SuiteConfig {
                samples: 60_000,
                threads: 1,
                uv,
                ..Default::default()
            };
            let r = run_suite(&b, &cfg, &|_, _| {});
            for o in &r.outcomes {
                if o.name != "energy" {
                    assert_eq!(o.verdict, Verdict::Pass, "{}: {}", o.name, o.summary);
                }
            }
        }
    }

    #[test]
    fn weave_errors_name_file_line_and_column() {
        let params = &vec![("c", Spectrum::splat(0.5))];
        let parse = |src: &str| {
            WeavePattern::parse(src, "w.wv", params)
                .unwrap_err()
                .to_string()
        };
        let yarn = "yarn { type = warp, umax = 20, width = 1, length = 1, kd = $c, ks = $c }";
        let ok = format!(
            "weave {{ tileWidth = 1, tileHeight = 1, hWidth = 0.5, warpArea = 1, pattern {{ 1 }}, {yarn} }}"
        );
        assert!(WeavePattern::parse(&ok, "w.wv", params).is_ok());
        assert_eq!(
            parse("weave {\n  tileWidth = 1,\n  colour = 3 }"),
            "w.wv:3:3: unknown weave parameter 'colour' (known: name, tileWidth, tileHeight, \
             alpha, beta, ss, hWidth, warpArea, weftArea, dWarpUmaxOverDWarp, \
             dWarpUmaxOverDWeft, dWeftUmaxOverDWarp, dWeftUmaxOverDWeft, fineness, period, \
             pattern, yarn)"
        );
        let e = parse(&ok.replace("kd = $c", "kd = $missing"));
        assert!(e.contains("w.wv:1:") && e.contains("'$missing'"), "{e}");
        let e = parse(&ok.replace("pattern { 1 }", "pattern { 2 }"));
        assert!(e.contains("pattern entry 2 names no yarn"), "{e}");
        let e = parse(&ok.replace("pattern { 1 }", "pattern { 1, 1 }"));
        assert!(e.contains("the pattern has 2 entries"), "{e}");
        let e = parse(&ok.replace("type = warp", "type = wool"));
        assert!(e.contains("'warp' or 'weft'"), "{e}");
        let e = parse(&ok.replace("umax = 20", "umax = 95"));
        assert!(e.contains("yarn 1: 'umax'"), "{e}");
        assert!(parse("weave { /* open").contains("w.wv:1:9: unterminated comment"));
        assert!(parse("").contains("expected 'weave {'"));
    }

    #[test]
    fn plugin_errors() {
        assert!(err("irawan repeatU=1 repeatV=1").contains("exactly one of 'filename'"));
        assert!(err(&format!("irawan pattern=denim repeatV=1 {COLOURS}"))
            .contains("needs parameter 'repeatU'"));
        assert!(err(&format!(
            "irawan pattern=velour repeatU=1 repeatV=1 {COLOURS}"
        ))
        .contains("valid values: denim, charmeuse"));
        assert!(
            err("irawan pattern=denim repeatU=1 repeatV=1 warp_kd=0.1 warp_ks=0.1")
                .contains("'$weft_kd'")
        );
        assert!(err(&format!(
            "irawan pattern=denim repeatU=-1 repeatV=1 {COLOURS}"
        ))
        .contains("must be positive"));
        assert!(err(&format!(
            "irawan pattern=denim repeatU=1 repeatV=1 {COLOURS} kd=1"
        ))
        .contains("unknown parameter 'kd'"));
        let e = err("irawan filename=/nonexistent/x.wv repeatU=1 repeatV=1");
        assert!(e.contains("cannot read weave pattern file"), "{e}");
    }

    #[test]
    fn weave_file_with_own_parameters() {
        let dir = std::env::temp_dir().join(format!("specula-irawan-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("satin.wv");
        std::fs::write(
            &file,
            "weave { name = \"one\", tileWidth = 2, tileHeight = 1, hWidth = 0.4, alpha = 0.02,\n\
             beta = 2, warpArea = 1, weftArea = 1, pattern { 1, 2 },\n\
             yarn { type = warp, umax = $tilt, width = 1, length = 1, centerU = 0.25, centerV = 0.5, kd = $base, ks = 0.5 },\n\
             yarn { type = weft, psi = 20, umax = 30, width = 1, length = 1, centerU = 0.75, centerV = 0.5, kd = $base, ks = 0.5 } }",
        )
        .unwrap();
        let b = build(&format!(
            "irawan filename={} repeatU=3 repeatV=3 tilt=25 base=0.1,0.2,0.3",
            file.display()
        ));
        assert_eq!(b.weave.name, "one");
        assert!((b.weave.yarns[0].umax - 25f32.to_radians()).abs() < 1e-6);
        assert_eq!(b.weave.yarns[1].kd, Spectrum::new(0.1, 0.2, 0.3));
        std::fs::remove_dir_all(&dir).ok();
    }
}
