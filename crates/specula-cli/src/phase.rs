//! `specula phase …`: commands on participating media's phase functions (Mitsuba 3's
//! `<phase>` plugins: `isotropic`, `hg`, `rayleigh`, `blendphase`), built without a scene.
//!
//! A phase function is given as
//!
//! - a spec in the style of the material specs: the plugin name, then `name=value`
//!   parameters, then nested phase functions in braces, e.g. `hg g=0.7`, `rayleigh`,
//!   `blendphase weight=0.3 { isotropic } { hg g=0.9 }`. Parameters take Mitsuba's names and
//!   defaults (`hg`'s `g` is 0.8 when left out, `blendphase`'s `weight` 0.5);
//! - an XML snippet, `'<phase type="hg"><float name="g" value="0.7"/></phase>'`.
//!
//! Both are built by the scene loader's own `<phase>` code, so the checks and messages are
//! those a scene gets (g outside (−1, 1), an unknown plugin or parameter, a blendphase
//! without two nested phase functions).
//!
//! Several phase functions can be given at once (the command-line words are split where a
//! new plugin name starts, so `hg g=0.3 rayleigh` is two), and `--g 0.2,0.5,0.9` turns every
//! `hg` written without `g=` into one curve per value.

use std::io::Write;
use std::path::Path;

use clap::Subcommand;
use specula_render::media::{phase_from_node, PhaseFunction};

use crate::output::CliError;

#[derive(Debug, Subcommand)]
pub enum PhaseCommand {
    /// Draw phase functions (PNG or SVG): a polar plot of p(θ) against the scattering angle θ
    /// (light arriving from the left, forward scattering to the right) and, beside it, p(θ)
    /// against θ with a histogram of sampled directions over each analytic curve; prints each
    /// function's normalisation and mean cosine (analytic and sampled). Default size 1200x560.
    ///
    /// Examples: `specula phase plot hg --g 0.3,0.7,0.9 --log -o hg.png`,
    /// `specula phase plot rayleigh "blendphase weight=0.3 { hg g=-0.4 } { hg g=0.9 }" -o p.png`
    Plot(crate::plot::phase::PhaseArgs),
}

pub fn run(cmd: PhaseCommand, out: &mut dyn Write) -> Result<(), CliError> {
    match cmd {
        PhaseCommand::Plot(args) => crate::plot::phase::run(&args, out),
    }
}

/// A phase function ready for evaluation, and how to name it.
#[derive(Clone, Debug)]
pub struct Phase {
    pub phase: PhaseFunction,
    /// The spec (normalised: single spaces) or the XML snippet, for legends.
    pub label: String,
}

/// A token of a phase spec: a word or a brace, with its column (1-based) in the spec.
#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Word(String),
    Open,
    Close,
}

fn tokenize(s: &str) -> Vec<(Tok, usize)> {
    let mut toks = Vec::new();
    let mut word = String::new();
    let mut start = 0;
    for (i, c) in s.chars().enumerate() {
        if c.is_whitespace() || c == '{' || c == '}' {
            if !word.is_empty() {
                toks.push((Tok::Word(std::mem::take(&mut word)), start + 1));
            }
            match c {
                '{' => toks.push((Tok::Open, i + 1)),
                '}' => toks.push((Tok::Close, i + 1)),
                _ => {}
            }
        } else {
            if word.is_empty() {
                start = i;
            }
            word.push(c);
        }
    }
    if !word.is_empty() {
        toks.push((Tok::Word(word), start + 1));
    }
    toks
}

/// Escapes text for an XML attribute value.
fn xml_attr(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// Translates one spec (from `toks[*pos]`) into a `<phase>` element.
fn spec_to_xml(
    spec: &str,
    toks: &[(Tok, usize)],
    pos: &mut usize,
    depth: usize,
) -> Result<String, String> {
    let at = |p: usize| format!("phase spec '{spec}', column {p}");
    let (name, col) = match toks.get(*pos) {
        Some((Tok::Word(w), c)) if !w.contains('=') => (w.clone(), *c),
        Some((Tok::Word(w), c)) => {
            return Err(format!(
                "{}: expected a phase function name (isotropic, hg, rayleigh, blendphase), \
                 found '{w}'",
                at(*c)
            ))
        }
        Some((_, c)) => {
            return Err(format!(
                "{}: expected a phase function name, found a brace",
                at(*c)
            ))
        }
        None => {
            return Err(if depth == 0 {
                "empty phase spec".to_string()
            } else {
                format!(
                    "{}: expected a phase function name after '{{', found the end of the spec",
                    at(spec.chars().count() + 1)
                )
            })
        }
    };
    if depth > 8 {
        return Err(format!("{}: phase functions nested too deeply", at(col)));
    }
    *pos += 1;
    let mut xml = format!("<phase type=\"{}\">", xml_attr(&name));
    // parameters
    while let Some((Tok::Word(w), c)) = toks.get(*pos) {
        let Some((key, value)) = w.split_once('=') else {
            break; // the next phase function
        };
        if key.is_empty() || value.is_empty() {
            return Err(format!("{}: expected name=value, found '{w}'", at(*c)));
        }
        let tag = if value.parse::<f64>().is_ok() {
            "float"
        } else {
            "string"
        };
        xml.push_str(&format!(
            "<{tag} name=\"{}\" value=\"{}\"/>",
            xml_attr(key),
            xml_attr(value)
        ));
        *pos += 1;
    }
    // nested phase functions
    while let Some((Tok::Open, c)) = toks.get(*pos) {
        let c = *c;
        *pos += 1;
        xml.push_str(&spec_to_xml(spec, toks, pos, depth + 1)?);
        match toks.get(*pos) {
            Some((Tok::Close, _)) => *pos += 1,
            Some((_, c2)) => {
                return Err(format!(
                    "{}: expected '}}' closing the '{{' of column {c}",
                    at(*c2)
                ))
            }
            None => return Err(format!("{}: unclosed '{{'", at(c))),
        }
    }
    xml.push_str("</phase>");
    Ok(xml)
}

/// Builds a phase function from a `<phase>` XML snippet; `label` names it in locations.
fn build_xml(xml: &str, label: &str) -> Result<PhaseFunction, specula_render::core::SceneError> {
    let wrapped = format!("<scene version=\"3.0.0\">{xml}</scene>");
    let root = specula_render::xml::parse_scene_str(&wrapped, label, Path::new("."), &[])?;
    let mut phases = root.children.iter().filter(|c| c.tag == "phase");
    let node = phases.next().ok_or_else(|| {
        specula_render::core::SceneError::new(
            Some(root.loc.clone()),
            "the text has no <phase> element",
        )
    })?;
    if let Some(extra) = root.children.iter().find(|c| !std::ptr::eq(*c, node)) {
        return Err(specula_render::core::SceneError::new(
            Some(extra.loc.clone()),
            format!(
                "give one <phase> per argument (found a <{}> besides it)",
                extra.tag
            ),
        ));
    }
    phase_from_node(node)
}

/// Builds one phase function from a spec (`hg g=0.7`) or an XML snippet (`<phase …>`).
pub fn parse_phase(arg: &str) -> Result<Phase, CliError> {
    let t = arg.trim();
    if t.starts_with('<') {
        let phase = build_xml(t, "<phase argument>").map_err(CliError::usage)?;
        return Ok(Phase {
            phase,
            label: t.split_whitespace().collect::<Vec<_>>().join(" "),
        });
    }
    let spec = t.split_whitespace().collect::<Vec<_>>().join(" ");
    let toks = tokenize(&spec);
    let mut pos = 0;
    let xml = spec_to_xml(&spec, &toks, &mut pos, 0).map_err(CliError::usage)?;
    if let Some((_, c)) = toks.get(pos) {
        return Err(CliError::usage(format!(
            "phase spec '{spec}', column {c}: unexpected text after the phase function"
        )));
    }
    // the XML is ours: report the plugin's message without its (generated) location
    let phase = build_xml(&xml, "<phase spec>")
        .map_err(|e| CliError::usage(format!("phase spec '{spec}': {}", e.msg)))?;
    Ok(Phase { phase, label: spec })
}

/// Splits command-line words into phase function arguments: an XML snippet is one argument;
/// otherwise the words are joined and cut before every plugin name at brace depth 0, so that
/// `hg g=0.3 rayleigh` and `"hg g=0.3" rayleigh` both give two.
pub fn split_args(words: &[String]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    let mut current = String::new();
    let mut depth = 0i32;
    let flush = |current: &mut String, out: &mut Vec<String>| {
        if !current.trim().is_empty() {
            out.push(current.trim().to_string());
        }
        current.clear();
    };
    for w in words {
        if w.trim_start().starts_with('<') {
            flush(&mut current, &mut out);
            out.push(w.trim().to_string());
            depth = 0;
            continue;
        }
        for (tok, _) in tokenize(w) {
            match tok {
                Tok::Open => {
                    depth += 1;
                    current.push_str(" {");
                }
                Tok::Close => {
                    depth -= 1;
                    current.push_str(" }");
                }
                Tok::Word(word) => {
                    if depth <= 0 && !word.contains('=') {
                        flush(&mut current, &mut out);
                        depth = 0;
                    }
                    current.push(' ');
                    current.push_str(&word);
                }
            }
        }
    }
    flush(&mut current, &mut out);
    out
}

/// The phase functions named by `words`, with `--g` values expanding every `hg` given
/// without `g=` (and standing for `hg` when no word is given).
pub fn load_phases(words: &[String], g_values: &[f64]) -> Result<Vec<Phase>, CliError> {
    for &g in g_values {
        if !(g.is_finite() && g > -1.0 && g < 1.0) {
            return Err(CliError::usage(format!(
                "--g: the Henyey–Greenstein asymmetry g must lie in (−1, 1), got {g}"
            )));
        }
    }
    let mut args = split_args(words);
    if args.is_empty() {
        if g_values.is_empty() {
            return Err(CliError::usage(
                "no phase function given: name one or more (isotropic, hg, rayleigh, \
                 blendphase), e.g. `hg g=0.7`, or give --g values for hg",
            ));
        }
        args.push("hg".to_string());
    }
    let mut phases = Vec::new();
    let mut expanded = false;
    for a in &args {
        if !g_values.is_empty() && (a == "hg" || a.split_whitespace().collect::<Vec<_>>() == ["hg"])
        {
            expanded = true;
            for g in g_values {
                phases.push(parse_phase(&format!("hg g={g}"))?);
            }
        } else {
            phases.push(parse_phase(a)?);
        }
    }
    if !g_values.is_empty() && !expanded {
        return Err(CliError::usage(
            "--g applies to an `hg` given without g= (e.g. `specula phase plot hg --g 0.3,0.8`), \
             and there is none",
        ));
    }
    Ok(phases)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    fn err(v: &[&str], g: &[f64]) -> String {
        match load_phases(&words(v), g) {
            Err(CliError::Usage(m)) => m,
            other => panic!("{v:?}: expected a usage error, got {other:?}"),
        }
    }

    #[test]
    fn specs_build_mitsubas_plugins() {
        let p = parse_phase("hg g=0.7").unwrap();
        assert_eq!(p.phase, PhaseFunction::HenyeyGreenstein { g: 0.7 });
        // Mitsuba's default g is 0.8
        assert_eq!(
            parse_phase("hg").unwrap().phase,
            PhaseFunction::HenyeyGreenstein { g: 0.8 }
        );
        assert_eq!(
            parse_phase("rayleigh").unwrap().phase,
            PhaseFunction::Rayleigh
        );
        let b = parse_phase("blendphase weight=0.3 { isotropic } {hg g=-0.4}").unwrap();
        assert_eq!(
            b.phase,
            PhaseFunction::Blend {
                weight: 0.3,
                first: Box::new(PhaseFunction::Isotropic),
                second: Box::new(PhaseFunction::HenyeyGreenstein { g: -0.4 }),
            }
        );
        let x = parse_phase(r#"<phase type="hg"><float name="g" value="-0.25"/></phase>"#).unwrap();
        assert_eq!(x.phase, PhaseFunction::HenyeyGreenstein { g: -0.25 });
    }

    #[test]
    fn words_split_into_phase_functions() {
        assert_eq!(
            split_args(&words(&["hg", "g=0.3", "rayleigh"])),
            ["hg g=0.3", "rayleigh"]
        );
        assert_eq!(
            split_args(&words(&[
                "blendphase weight=0.2 { hg g=0.5 }",
                "{",
                "isotropic",
                "}",
                "hg"
            ])),
            ["blendphase weight=0.2 { hg g=0.5 } { isotropic }", "hg"]
        );
        let xml = r#"<phase type="isotropic"/>"#;
        assert_eq!(split_args(&words(&["hg", xml])), ["hg", xml]);
    }

    #[test]
    fn g_values_expand_hg() {
        let p = load_phases(&words(&["hg", "rayleigh"]), &[0.2, 0.9]).unwrap();
        let names: Vec<&str> = p.iter().map(|p| p.label.as_str()).collect();
        assert_eq!(names, ["hg g=0.2", "hg g=0.9", "rayleigh"]);
        // --g alone stands for hg
        assert_eq!(load_phases(&[], &[0.5]).unwrap().len(), 1);
        // an explicit g is kept
        let p = load_phases(&words(&["hg g=0.1", "hg"]), &[0.6]).unwrap();
        assert_eq!(p[0].phase, PhaseFunction::HenyeyGreenstein { g: 0.1 });
        assert_eq!(p[1].phase, PhaseFunction::HenyeyGreenstein { g: 0.6 });
    }

    #[test]
    fn bad_input_is_named() {
        let e = err(&["hg", "g=1.5"], &[]);
        assert!(
            e.contains("'hg g=1.5'") && e.contains("g must lie in (−1, 1)"),
            "{e}"
        );
        let e = err(&["hg"], &[1.0]);
        assert!(
            e.contains("--g") && e.contains("(−1, 1)") && e.contains('1'),
            "{e}"
        );
        let e = err(&["hg"], &[f64::NAN]);
        assert!(e.contains("--g"), "{e}");
        let e = err(&["mie"], &[]);
        assert!(e.contains("'mie'") && e.contains("not supported"), "{e}");
        let e = err(&["hg", "gg=0.3"], &[]);
        assert!(e.contains("gg"), "{e}");
        let e = err(&["blendphase", "{", "hg"], &[]);
        assert!(e.contains("unclosed"), "{e}");
        let e = err(&["blendphase", "{", "hg", "}"], &[]);
        assert!(e.contains("exactly two"), "{e}");
        let e = err(&["rayleigh"], &[0.5]);
        assert!(e.contains("--g applies"), "{e}");
        let e = err(&[], &[]);
        assert!(e.contains("no phase function"), "{e}");
        let e = err(
            &[r#"<phase type="hg"><float name="g" value="2"/></phase>"#],
            &[],
        );
        assert!(
            e.contains("<phase argument>:1:") && e.contains("(−1, 1)"),
            "{e}"
        );
        let e = err(&["<phase type="], &[]);
        assert!(e.contains("<phase argument>"), "{e}");
        let e = err(&[r#"<bsdf type="diffuse"/>"#], &[]);
        assert!(e.contains("no <phase>"), "{e}");
    }
}
