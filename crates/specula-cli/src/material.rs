//! How every material command takes its material: one argument that is
//!
//! - a Mitsuba-style spec, `"roughconductor material=Cu alpha=0.2"` (nested plugins in braces);
//! - an XML snippet, `'<bsdf type="twosided"><bsdf type="diffuse"/></bsdf>'`;
//! - a MERL table, `path/to/file.binary`;
//! - an RGL tensor file, `path/to/file.bsdf`;
//! - a BSDF of a scene, `scene.xml#id`.
#![allow(dead_code)] // used by the commands being added (plot, slice, check, measure, fit)

use std::path::{Path, PathBuf};
use std::sync::Arc;

use specula_bsdf::measured::merl::Merl;
use specula_bsdf::measured::rgl::Rgl;
use specula_bsdf::{parse_spec, Bsdf};

use crate::output::CliError;

/// Where a material came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Source {
    Spec,
    Xml,
    Merl(PathBuf),
    Rgl(PathBuf),
    Scene { path: PathBuf, id: String },
}

/// A material ready for evaluation, and how to name it.
#[derive(Clone, Debug)]
pub struct Material {
    pub bsdf: Bsdf,
    /// The argument as given (spec text, path, `scene.xml#id`), for titles and reports.
    pub label: String,
    pub source: Source,
}

impl Material {
    /// A short name for titles: the file name for files, the spec otherwise.
    pub fn short_label(&self) -> String {
        match &self.source {
            Source::Merl(p) | Source::Rgl(p) => p
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_else(|| self.label.clone()),
            Source::Scene { path, id } => format!(
                "{}#{id}",
                path.file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or_default()
            ),
            _ => self.label.clone(),
        }
    }
}

fn has_ext(s: &str, ext: &str) -> bool {
    Path::new(s)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

/// Interprets one material argument (several words are joined by spaces first, so that specs
/// may be given unquoted).
pub fn load_material(words: &[String]) -> Result<Material, CliError> {
    let arg = words.join(" ");
    let t = arg.trim();
    if t.is_empty() {
        return Err(CliError::usage("no material given"));
    }
    if t.starts_with('<') {
        let bsdf =
            specula_render::scene::bsdf_from_xml_str(t, "<material argument>", Path::new("."))
                .map_err(CliError::usage)?;
        return Ok(Material {
            bsdf,
            label: t.to_string(),
            source: Source::Xml,
        });
    }
    if has_ext(t, "binary") {
        let path = PathBuf::from(t);
        let merl = Merl::read(&path).map_err(CliError::usage)?;
        return Ok(Material {
            bsdf: Bsdf::Merl(merl),
            label: t.to_string(),
            source: Source::Merl(path),
        });
    }
    if has_ext(t, "bsdf") {
        let path = PathBuf::from(t);
        let rgl = Rgl::load(&path).map_err(CliError::usage)?;
        return Ok(Material {
            bsdf: Bsdf::Measured(Arc::new(rgl)),
            label: t.to_string(),
            source: Source::Rgl(path),
        });
    }
    if let Some((file, id)) = t.rsplit_once('#') {
        if has_ext(file, "xml") {
            if id.is_empty() {
                return Err(CliError::usage(format!(
                    "'{t}': give the BSDF's id after '#', e.g. {file}#mybsdf"
                )));
            }
            let path = PathBuf::from(file);
            let bsdf =
                specula_render::scene::load_bsdf_by_id(&path, id, &[]).map_err(CliError::usage)?;
            return Ok(Material {
                bsdf,
                label: t.to_string(),
                source: Source::Scene {
                    path,
                    id: id.to_string(),
                },
            });
        }
    }
    if has_ext(t, "xml") {
        return Err(CliError::usage(format!(
            "'{t}' is a scene file: name one of its BSDFs as {t}#id"
        )));
    }
    let bsdf = parse_spec(t).map_err(CliError::usage)?;
    Ok(Material {
        bsdf,
        label: t.to_string(),
        source: Source::Spec,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(s: &str) -> Vec<String> {
        vec![s.to_string()]
    }

    #[test]
    fn spec_and_xml_snippets() {
        let m = load_material(&words("roughconductor material=Cu alpha=0.2")).unwrap();
        assert_eq!(m.bsdf.plugin_name(), "roughconductor");
        assert_eq!(m.source, Source::Spec);
        let m = load_material(&words(
            r#"<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.3, 0.4"/></bsdf></bsdf>"#,
        ))
        .unwrap();
        assert_eq!(m.bsdf.plugin_name(), "twosided");
        assert_eq!(m.source, Source::Xml);
    }

    #[test]
    fn bad_inputs_name_the_problem() {
        let e = format!("{:?}", load_material(&words("nosuchplugin")).unwrap_err());
        assert!(e.contains("nosuchplugin"), "{e}");
        let e = format!(
            "{:?}",
            load_material(&words("/nonexistent/file.binary")).unwrap_err()
        );
        assert!(e.contains("/nonexistent/file.binary"), "{e}");
        let e = format!(
            "{:?}",
            load_material(&words("/nonexistent/file.bsdf")).unwrap_err()
        );
        assert!(e.contains("/nonexistent/file.bsdf"), "{e}");
        let e = format!(
            "{:?}",
            load_material(&words("/nonexistent/scene.xml#x")).unwrap_err()
        );
        assert!(e.contains("/nonexistent/scene.xml"), "{e}");
        let e = format!("{:?}", load_material(&words("<bsdf type=")).unwrap_err());
        assert!(e.contains("malformed XML"), "{e}");
    }

    #[test]
    fn scene_ids() {
        let dir = std::env::temp_dir().join(format!("specula-material-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let scene = dir.join("s.xml");
        std::fs::write(
            &scene,
            r#"<scene version="3.0.0">
  <bsdf type="diffuse" id="white"/>
  <shape type="sphere">
    <bsdf type="roughconductor" id="metal"><float name="alpha" value="0.3"/></bsdf>
  </shape>
</scene>"#,
        )
        .unwrap();
        let arg = |id: &str| words(&format!("{}#{id}", scene.display()));
        assert_eq!(
            load_material(&arg("white")).unwrap().bsdf.plugin_name(),
            "diffuse"
        );
        assert_eq!(
            load_material(&arg("metal")).unwrap().bsdf.plugin_name(),
            "roughconductor"
        );
        let e = format!("{:?}", load_material(&arg("nope")).unwrap_err());
        assert!(e.contains("white, metal"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
