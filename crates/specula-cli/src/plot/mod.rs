//! Shared plumbing for the picture commands: fonts, output backends and colour maps.
//!
//! Plotters draws text with `ab_glyph` from fonts embedded in the binary (Ubuntu Light for
//! text, Hack for monospace), so pictures come out the same on any machine, without system
//! font libraries.
#![allow(dead_code)] // used by the picture commands being added

use std::path::Path;
use std::sync::Once;

use plotters::style::FontStyle;

use crate::output::CliError;

/// The font family names the commands use (registered by [`init_fonts`]).
pub const SANS: &str = "sans-serif";
pub const MONO: &str = "monospace";

/// Register the embedded fonts with plotters (idempotent).
pub fn init_fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let ubuntu = epaint_default_fonts::UBUNTU_LIGHT;
        let hack = epaint_default_fonts::HACK_REGULAR;
        for style in [FontStyle::Normal, FontStyle::Bold, FontStyle::Italic] {
            // the embedded fonts are valid TrueType files: registration cannot fail
            plotters::style::register_font(SANS, style, ubuntu)
                .unwrap_or_else(|_| unreachable!("embedded font rejected"));
            plotters::style::register_font(MONO, style, hack)
                .unwrap_or_else(|_| unreachable!("embedded font rejected"));
        }
    });
}

/// The picture formats a command can write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Svg,
}

/// The format of `path` from its extension; `svg_ok` says whether the command draws vectors.
pub fn format_of(path: &Path, svg_ok: bool) -> Result<Format, CliError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "png" => Ok(Format::Png),
        "svg" if svg_ok => Ok(Format::Svg),
        _ => Err(CliError::usage(format!(
            "{}: unsupported picture format (use {})",
            path.display(),
            if svg_ok { ".png or .svg" } else { ".png" }
        ))),
    }
}

/// Turn a plotters drawing error into a one-line CLI error naming the output file.
pub fn draw_err<E: std::fmt::Debug>(path: &Path) -> impl Fn(E) -> CliError + '_ {
    move |e| CliError::usage(format!("{}: cannot draw or write: {e:?}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use plotters::prelude::*;

    #[test]
    fn text_renders_with_embedded_fonts() {
        init_fonts();
        let dir = std::env::temp_dir().join(format!("specula-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let png = dir.join("t.png");
        {
            let root = BitMapBackend::new(&png, (200, 60)).into_drawing_area();
            root.fill(&WHITE).unwrap();
            root.draw(&Text::new("θ φ ρ", (10, 10), (SANS, 30).into_font()))
                .unwrap();
            root.present().unwrap();
        }
        let (img, _) = specula_render::image_io::read_image(&png).unwrap();
        let dark = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| img.rgb(x, y)[0] < 0.2)
            .count();
        assert!(dark > 50, "only {dark} dark pixels: the text was not drawn");
        std::fs::remove_dir_all(&dir).ok();
    }
}
