//! Materials written on one line, the way a command line takes them:
//!
//! ```text
//! roughconductor material=Cu alpha=0.2 distribution=ggx
//! dielectric int_ior=water
//! plastic diffuse_reflectance=0.6,0.15,0.1 int_ior="acrylic glass"
//! blendbsdf weight=0.3 { diffuse reflectance=0.8 } { conductor material=Au }
//! twosided { roughconductor alpha_u=0.05 alpha_v=0.3 }
//! ```
//!
//! The plugin name comes first, then `key=value` pairs, then nested BSDFs in braces. A value
//! is a boolean (`true`/`false`), a number, three comma-separated numbers (an RGB colour), or
//! otherwise a string (quote it if it contains spaces). Nested braces may go
//! [`MAX_SPEC_DEPTH`] levels deep; every error names the column of the spec it is about.

use crate::build::build_bsdf;
use crate::models::Bsdf;
use crate::props::{BuildError, Props, Value};
use crate::spectrum::Spectrum;

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Word(String, bool),
    Eq,
    Open,
    Close,
}

fn tokenize(s: &str) -> Result<Vec<(Tok, usize)>, BuildError> {
    let mut out = Vec::new();
    let cs: Vec<char> = s.chars().collect();
    let mut i = 0;
    while i < cs.len() {
        let c = cs[i];
        let col = i + 1;
        match c {
            c if c.is_whitespace() => i += 1,
            '=' => {
                out.push((Tok::Eq, col));
                i += 1
            }
            '{' => {
                out.push((Tok::Open, col));
                i += 1
            }
            '}' => {
                out.push((Tok::Close, col));
                i += 1
            }
            '"' | '\'' => {
                let q = c;
                let start = i + 1;
                let mut j = start;
                while j < cs.len() && cs[j] != q {
                    j += 1;
                }
                if j == cs.len() {
                    return Err(BuildError::new(
                        Some(format!("material spec, column {col}")),
                        "unterminated quote",
                    ));
                }
                out.push((Tok::Word(cs[start..j].iter().collect(), true), col));
                i = j + 1;
            }
            _ => {
                let start = i;
                while i < cs.len()
                    && !cs[i].is_whitespace()
                    && !matches!(cs[i], '=' | '{' | '}' | '"' | '\'')
                {
                    i += 1;
                }
                out.push((Tok::Word(cs[start..i].iter().collect(), false), col));
            }
        }
    }
    Ok(out)
}

fn loc(col: usize) -> Option<String> {
    Some(format!("material spec, column {col}"))
}

fn parse_value(w: &str, quoted: bool, col: usize) -> Result<Value, BuildError> {
    if quoted {
        return Ok(Value::Str(w.to_string()));
    }
    match w {
        "true" => return Ok(Value::Bool(true)),
        "false" => return Ok(Value::Bool(false)),
        _ => {}
    }
    if w.contains(',') {
        let parts: Vec<&str> = w.split(',').collect();
        let nums: Result<Vec<f32>, _> = parts.iter().map(|p| p.trim().parse::<f32>()).collect();
        return match nums {
            Ok(v) if v.len() == 3 => Ok(Value::Rgb(Spectrum::new(v[0], v[1], v[2]))),
            _ => Err(BuildError::new(
                loc(col),
                format!("'{w}' is not an RGB colour (three comma-separated numbers)"),
            )),
        };
    }
    let looks_numeric =
        w.starts_with(|c: char| c.is_ascii_digit() || c == '-' || c == '+' || c == '.');
    if looks_numeric || w.eq_ignore_ascii_case("nan") || w.eq_ignore_ascii_case("inf") {
        return w
            .parse::<f64>()
            .map(Value::Float)
            .map_err(|_| BuildError::new(loc(col), format!("'{w}' is not a number")));
    }
    Ok(Value::Str(w.to_string()))
}

/// The deepest nesting of braces in a material spec (real materials nest two or three deep);
/// the limit keeps the recursive parser and builder far from the end of the stack.
pub const MAX_SPEC_DEPTH: usize = 64;

/// Parses one plugin starting at `toks[*pos]`. `open` is the column of the `{` this plugin
/// is nested in (`None` at the top level); `depth` counts the braces around it.
fn parse_plugin(
    toks: &[(Tok, usize)],
    pos: &mut usize,
    open: Option<usize>,
    depth: usize,
) -> Result<Bsdf, BuildError> {
    let (name, col) = match (toks.get(*pos), open) {
        (Some((Tok::Word(w, false), c)), _) => (w.clone(), *c),
        (Some((_, c)), _) => return Err(BuildError::new(loc(*c), "expected a plugin name")),
        (None, Some(c)) => {
            return Err(BuildError::new(
                loc(c),
                "expected a plugin name after '{', found the end of the spec",
            ))
        }
        (None, None) => return Err(BuildError::new(loc(1), "empty material spec")),
    };
    if depth > MAX_SPEC_DEPTH {
        return Err(BuildError::new(
            loc(col),
            format!("plugins nested more than {MAX_SPEC_DEPTH} deep (the limit)"),
        ));
    }
    *pos += 1;
    let mut props = Props::new(name, loc(col));
    while let Some((t, c)) = toks.get(*pos) {
        match t {
            Tok::Word(key, _) => {
                let Some((Tok::Eq, _)) = toks.get(*pos + 1) else {
                    return Err(BuildError::new(loc(*c), format!("expected '{key}=value'")));
                };
                let Some((Tok::Word(v, quoted), vc)) = toks.get(*pos + 2) else {
                    return Err(BuildError::new(
                        loc(*c),
                        format!("missing value after '{key}='"),
                    ));
                };
                let value = parse_value(v, *quoted, *vc)?;
                props.set(key, value, loc(*c))?;
                *pos += 3;
            }
            Tok::Open => {
                *pos += 1;
                let child = parse_plugin(toks, pos, Some(*c), depth + 1)?;
                match toks.get(*pos) {
                    Some((Tok::Close, _)) => *pos += 1,
                    _ => return Err(BuildError::new(loc(*c), "unclosed '{'")),
                }
                props.add_child(child, loc(*c));
            }
            Tok::Close => break,
            Tok::Eq => return Err(BuildError::new(loc(*c), "unexpected '='")),
        }
    }
    build_bsdf(props)
}

/// Parse and build a material from a one-line spec.
pub fn parse_spec(s: &str) -> Result<Bsdf, BuildError> {
    let toks = tokenize(s)?;
    let mut pos = 0;
    let b = parse_plugin(&toks, &mut pos, None, 0)?;
    if let Some((_, c)) = toks.get(pos) {
        return Err(BuildError::new(
            loc(*c),
            "unexpected text after the material",
        ));
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(s: &str) -> String {
        parse_spec(s).expect_err(s).to_string()
    }

    #[test]
    fn errors_name_a_column() {
        // an unclosed brace at the end names the brace (said "empty material spec")
        let e = err("diffuse {");
        assert!(
            e.contains("material spec, column 9")
                && e.contains("expected a plugin name after '{', found the end of the spec"),
            "{e}"
        );
        assert!(err("").contains("column 1") && err("").contains("empty material spec"));
        assert!(err("twosided { diffuse").contains("column 10"));
        assert!(parse_spec("twosided { diffuse reflectance=0.5 }").is_ok());
    }

    /// 3000 nested braces overflowed the stack of the recursive parser.
    #[test]
    fn nesting_depth_is_limited() {
        let nested = |n: usize| format!("{}diffuse{}", "twosided { ".repeat(n), " }".repeat(n));
        let e = err(&nested(3000));
        assert!(
            e.ends_with("plugins nested more than 64 deep (the limit)"),
            "{e}"
        );
        // 65 levels: the column of the first plugin too deep
        let e = err(&nested(65));
        assert!(e.contains(&format!("column {}", 65 * 11 + 1)), "{e}");
        let e = err(&nested(64));
        assert!(!e.contains("nested more than"), "{e}");
    }
}
