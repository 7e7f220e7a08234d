//! End-to-end tests of the `specula` binary.

use specula_testdata::shared;
use std::process::{Command, Output};

fn specula(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_specula"))
        .args(args)
        .output()
        .expect("run the specula binary")
}

fn stdout(o: &Output) -> String {
    String::from_utf8(o.stdout.clone()).expect("utf-8 stdout")
}

fn stderr(o: &Output) -> String {
    String::from_utf8(o.stderr.clone()).expect("utf-8 stderr")
}

/// The numeric columns of a table row, if the line is one.
fn row(line: &str) -> Option<Vec<f64>> {
    let v: Result<Vec<f64>, _> = line
        .split_whitespace()
        .filter(|w| *w != "TIR")
        .map(str::parse)
        .collect();
    v.ok().filter(|v| !v.is_empty())
}

/// Rows of the table that follows the heading starting with `heading`.
fn table(text: &str, heading: &str) -> Vec<(Vec<f64>, bool)> {
    text.lines()
        .skip_while(|l| !l.starts_with(heading))
        .skip(2) // heading and column names
        .take_while(|l| !l.trim().is_empty())
        .map(|l| (row(l).expect("numeric row"), l.contains("TIR")))
        .collect()
}

#[test]
fn fresnel_dielectric_table() {
    for args in [&["fresnel"][..], &["fresnel", "--ior", "1.5"][..]] {
        let o = specula(args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        let text = stdout(&o);

        let outside = table(&text, "From outside");
        assert_eq!(outside.len(), 19, "{text}");
        let (first, tir) = &outside[0];
        assert_eq!(first[0], 0.0);
        // columns: θ, Rs, Rp, R, Schlick; ((1.5 − 1)/(1.5 + 1))² = 0.04
        for r in &first[1..] {
            assert!((r - 0.04).abs() < 5e-4, "R(0°) = {r}\n{text}");
        }
        assert!(!tir);
        assert!(outside.iter().all(|(_, tir)| !tir), "no TIR from outside");

        // from inside, total internal reflection beyond the critical angle 41.8°
        let inside = table(&text, "From inside");
        assert_eq!(inside.len(), 19);
        for (cols, tir) in &inside {
            assert_eq!(*tir, cols[0] > 41.81, "{cols:?}");
            if *tir {
                assert!((cols[3] - 1.0).abs() < 1e-6);
            }
        }
        assert!(text.contains("Brewster's angle: 56.31°"), "{text}");
        assert!(text.contains("Critical angle:   41.81°"), "{text}");
    }
}

#[test]
fn fresnel_conductor_table() {
    let o = specula(&["fresnel", "--material", "Cu", "--steps", "7"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let rows: Vec<Vec<f64>> = text.lines().filter_map(row).collect();
    assert_eq!(rows.len(), 7, "{text}");
    // copper: red reflects far more than blue at normal incidence
    assert!(rows[0][1] > 0.9 && rows[0][3] < 0.6, "{text}");
}

#[test]
fn brdf_eval_diffuse_normal_incidence() {
    let o = specula(&[
        "brdf",
        "eval",
        "diffuse reflectance=0.5",
        "--theta-i",
        "0",
        "--theta-o",
        "0",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let value = |label: &str| -> Vec<f64> {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(label))
            .unwrap_or_else(|| panic!("no '{label}' line in\n{text}"));
        row(line.trim_start_matches(label)).expect("numbers")
    };
    let expected = 0.5 / std::f64::consts::PI; // 0.159155
    for f in value("f") {
        assert!((f - expected).abs() < 1e-6, "{text}");
    }
    for f in value("f·cosθo") {
        assert!((f - expected).abs() < 1e-6, "{text}");
    }
    let pdf = value("pdf");
    assert!((pdf[0] - 1.0 / std::f64::consts::PI).abs() < 1e-6, "{text}");
}

#[test]
fn brdf_eval_rejects_malformed_spec() {
    for spec in [
        "diffuse reflectance=0.5 colour=red",
        "diffuse reflectance=",
        "roughconductor alpha=0.1 distribution=phong",
        "blendbsdf weight=0.3 { diffuse",
        "nosuchplugin",
    ] {
        let o = specula(&["brdf", "eval", spec, "--theta-i", "0", "--theta-o", "0"]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{spec}: accepted");
        assert_eq!(o.status.code(), Some(2), "{spec}: {err}");
        assert!(err.starts_with("error: "), "{spec}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{spec}: {err}");
        assert!(!err.contains("panicked"), "{spec}: {err}");
        assert!(stdout(&o).is_empty());
    }
    let o = specula(&[
        "brdf",
        "eval",
        "diffuse reflectance=0.5 colour=red",
        "--theta-i",
        "0",
        "--theta-o",
        "0",
    ]);
    let err = stderr(&o);
    assert!(
        err.contains("colour"),
        "names the offending parameter: {err}"
    );
}

#[test]
fn brdf_list_names_every_plugin() {
    let o = specula(&["brdf", "list"]);
    assert!(o.status.success());
    let text = stdout(&o);
    for (name, params) in specula_bsdf::build::PLUGINS {
        assert!(text.contains(name), "{name} missing");
        for p in *params {
            assert!(text.contains(p), "{name}.{p} missing");
        }
    }
}

#[test]
fn render_writes_png_and_exr_with_overrides() {
    let Some(scene) = shared("scenes/cbox.xml") else {
        return;
    };
    let dir = std::env::temp_dir().join(format!("specula-cli-render-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for ext in ["png", "exr"] {
        let out = dir.join(format!("cbox.{ext}"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_specula"))
            .args([
                "render",
                scene.to_str().unwrap(),
                "-D",
                "spp=2",
                "-D",
                "resx=40",
                "-D",
                "resy=30",
                "--quiet",
                "-o",
            ])
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(stdout.contains("40×30 at 2 spp"), "{stdout}");
        assert!(stdout.contains("0 NaN/Inf samples discarded"), "{stdout}");
        let bytes = std::fs::read(&out).unwrap();
        if ext == "png" {
            assert_eq!(&bytes[1..4], b"PNG");
        } else {
            assert_eq!(&bytes[..4], &[0x76, 0x2f, 0x31, 0x01]);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_size_resizes_the_film() {
    let scene = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../specula-render/tests/data/sensors_emitters/perspective_ppo_crop.xml");
    let dir = std::env::temp_dir().join(format!("specula-cli-size-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("small.exr");
    let o = specula(&[
        "render",
        scene.to_str().unwrap(),
        "--size",
        "20x15",
        "--spp",
        "1",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    // the file's 64×48 crop window of an 80×60 film becomes the whole 20×15 film
    assert!(stdout(&o).contains("20×15 at 1 spp"), "{}", stdout(&o));
    let (img, _) = specula_render::image_io::read_image(&out).unwrap();
    assert_eq!((img.width, img.height), (20, 15));
    for bad in ["20", "0x15", "20x15x3", "axb"] {
        let o = specula(&["render", scene.to_str().unwrap(), "--size", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--size"), "{bad}: {}", stderr(&o));
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_reports_bad_scenes_with_their_location() {
    let dir = std::env::temp_dir().join(format!("specula-cli-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let cases = [
        ("unknown.xml", "<scene version=\"3.0.0\">\n  <shape type=\"teapot\"/>\n</scene>\n", "unknown.xml:2:3"),
        (
            "param.xml",
            "<scene version=\"3.0.0\">\n <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/></sensor>\n <shape type=\"sphere\">\n  <float name=\"radiu\" value=\"1\"/>\n </shape>\n</scene>\n",
            "unknown parameter 'radiu'",
        ),
        ("malformed.xml", "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>\n", "malformed.xml:"),
        (
            "missing.xml",
            "<scene version=\"3.0.0\">\n <sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/></sensor>\n <shape type=\"obj\"><string name=\"filename\" value=\"nope.obj\"/></shape>\n</scene>\n",
            "nope.obj",
        ),
        (
            "number.xml",
            "<scene version=\"3.0.0\">\n <sensor type=\"perspective\"><float name=\"fov\" value=\"4o\"/></sensor>\n</scene>\n",
            "number.xml:2:",
        ),
    ];
    for (name, text, needle) in cases {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_specula"))
            .args(["render", path.to_str().unwrap(), "--quiet", "-o"])
            .arg(dir.join("x.exr"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name} was accepted");
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{name}: expected '{needle}' in: {stderr}"
        );
        assert_eq!(stderr.trim().lines().count(), 1, "{name}: {stderr}");
    }
    // a missing scene file
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_specula"))
        .args(["render", "/nonexistent/scene.xml"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("/nonexistent/scene.xml"));
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------------------------------
// brdf measure / brdf fit
// ---------------------------------------------------------------------------------------

fn fit_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("specula-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The value of the `alpha=` line the fit prints.
fn fitted_alpha(text: &str) -> f64 {
    text.lines()
        .find_map(|l| l.trim().strip_prefix("alpha="))
        .unwrap_or_else(|| panic!("no alpha= line in\n{text}"))
        .parse()
        .expect("a number after alpha=")
}

/// The `<bsdf>` element printed after "Mitsuba 3 XML:".
fn fitted_xml(text: &str) -> String {
    let lines: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("Mitsuba 3 XML:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .collect();
    assert!(
        lines.first().is_some_and(|l| l.starts_with("<bsdf")),
        "{text}"
    );
    lines.join("\n")
}

/// f at θi = θo = 30° on the mirror side, from `specula brdf eval`.
fn eval_f(material: &str) -> Vec<f64> {
    let o = specula(&[
        "brdf",
        "eval",
        material,
        "--theta-i",
        "30",
        "--theta-o",
        "30",
    ]);
    assert!(o.status.success(), "{material}: {}", stderr(&o));
    let text = stdout(&o);
    let line = text.lines().find(|l| l.starts_with("f ")).unwrap();
    row(line.trim_start_matches('f')).expect("numbers")
}

#[test]
fn brdf_measure_writes_a_table_that_fits_back() {
    let dir = fit_dir("measure");
    let file = dir.join("gold.binary");
    let truth = "roughconductor distribution=beckmann alpha=0.3 material=Au";
    let o = specula(&[
        "brdf",
        "measure",
        truth,
        "-o",
        file.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("1,096,216 measured"), "{}", stdout(&o));
    // 12-byte header and three channels of 90·90·180 doubles
    assert_eq!(
        std::fs::metadata(&file).unwrap().len(),
        12 + 3 * 8 * 90 * 90 * 180
    );
    // it reads back: at a bin centre-ish configuration the table is close to the model
    // (nearest-bin lookup, so a few per cent)
    let (table, model) = (eval_f(file.to_str().unwrap()), eval_f(truth));
    for c in 0..3 {
        assert!(
            (table[c] - model[c]).abs() < 0.05 * model[c],
            "{table:?} vs {model:?}"
        );
    }

    let o = specula(&[
        "brdf",
        "fit",
        file.to_str().unwrap(),
        "--model",
        "beckmann",
        "--family",
        "conductor",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let alpha = fitted_alpha(&text);
    // an exact fit exists (the table holds this very model): 3 % is the acceptance bound
    assert!((alpha - 0.3).abs() <= 0.03 * 0.3, "alpha={alpha}\n{text}");
    assert!(
        text.contains("fitted conductor (forced with --family)"),
        "{text}"
    );
    // the printed XML is a material that evaluates like the truth
    let xml = fitted_xml(&text);
    assert!(xml.starts_with("<bsdf type=\"roughconductor\">"), "{xml}");
    let fitted = eval_f(&xml);
    for c in 0..3 {
        assert!(
            (fitted[c] - model[c]).abs() < 0.01 * model[c],
            "{fitted:?} vs {model:?}\n{text}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn brdf_measure_rejects_dirac_materials_and_bad_outputs() {
    let dir = fit_dir("measure-bad");
    let out = dir.join("x.binary");
    for (args, needle) in [
        (vec!["conductor material=Cu"], "Dirac"),
        (vec!["dielectric"], "Dirac"),
        (
            vec!["blendbsdf weight=0.5 { diffuse } { conductor }"],
            "Dirac",
        ),
        (vec!["nosuchplugin"], "nosuchplugin"),
    ] {
        let mut a = vec!["brdf", "measure"];
        a.extend(args.iter().copied());
        a.extend(["-o", out.to_str().unwrap(), "--quiet"]);
        let o = specula(&a);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.starts_with("error: ") && err.contains(needle), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(!out.exists(), "{args:?} wrote a table");
    }
    let o = specula(&["brdf", "measure", "diffuse", "-o", "x.png", "--quiet"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("x.png"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn brdf_fit_recovers_the_shared_copper() {
    let Some(file) = shared("data/merl/mitsuba_rough_copper.binary") else {
        return;
    };
    let o = specula(&["brdf", "fit", file.to_str().unwrap(), "--model", "ggx"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    // Mitsuba's roughconductor Cu, GGX, α = 0.2: the conductor family wins and gives α back
    let alpha = fitted_alpha(&text);
    assert!((alpha - 0.2).abs() <= 0.03 * 0.2, "alpha={alpha}\n{text}");
    assert!(
        text.contains("fitted conductor (lowest cbrt error of 2)"),
        "{text}"
    );
    assert!(fitted_xml(&text).contains("<rgb name=\"eta\""), "{text}");
    assert!(text.contains("fit error (the XML above"), "{text}");
}

#[test]
fn brdf_fit_rejects_bad_files() {
    let dir = fit_dir("fit-bad");
    let garbage = dir.join("garbage.binary");
    std::fs::write(&garbage, b"this is not a MERL table at all").unwrap();
    // a valid header followed by too little data
    let truncated = dir.join("truncated.binary");
    let mut bytes = Vec::new();
    for d in [90i32, 90, 180] {
        bytes.extend_from_slice(&d.to_le_bytes());
    }
    bytes.extend_from_slice(&[0u8; 8 * 1000]);
    std::fs::write(&truncated, &bytes).unwrap();
    let missing = dir.join("missing.binary");
    for file in [&garbage, &truncated, &missing] {
        let path = file.to_str().unwrap();
        let o = specula(&["brdf", "fit", path, "--model", "ggx"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{path}: {err}");
        assert!(err.starts_with("error: ") && err.contains(path), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(stdout(&o).is_empty());
    }
    // a table with nothing measured
    let empty = dir.join("unmeasured.binary");
    let mut bytes = Vec::new();
    for d in [90i32, 90, 180] {
        bytes.extend_from_slice(&d.to_le_bytes());
    }
    for _ in 0..3 * 90 * 90 * 180 {
        bytes.extend_from_slice(&(-1.0f64).to_le_bytes());
    }
    std::fs::write(&empty, &bytes).unwrap();
    let o = specula(&["brdf", "fit", empty.to_str().unwrap(), "--model", "ggx"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("unmeasured.binary: cannot fit: no bin is measured"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

// ---- BRDF lab: pictures (brdf plot, brdf slice, brdf albedo, fresnel plot) ----

fn plot_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("specula-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs `specula ARGS -o FILE`, checks success and the "wrote" line, and that the picture is a
/// PNG of `size` that is not one flat colour, or an SVG document.
fn plot_writes(args: &[&str], file: &std::path::Path, size: Option<(usize, usize)>) -> String {
    let mut all: Vec<&str> = args.to_vec();
    all.extend(["-o", file.to_str().unwrap()]);
    let o = specula(&all);
    assert!(o.status.success(), "{all:?}: {}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains(&format!("wrote {}", file.display())),
        "{text}"
    );
    if file.extension().is_some_and(|e| e == "png") {
        let (img, _) = specula_render::image_io::read_image(file).unwrap();
        if let Some(size) = size {
            assert_eq!((img.width, img.height), size, "{all:?}");
        }
        let first = img.rgb(0, 0);
        let differing = (0..img.height)
            .flat_map(|y| (0..img.width).map(move |x| (x, y)))
            .filter(|&(x, y)| img.rgb(x, y) != first)
            .count();
        assert!(
            differing > img.width * img.height / 100,
            "{all:?}: only {differing} pixels differ from the background"
        );
    } else {
        let svg = std::fs::read_to_string(file).unwrap();
        assert!(svg.contains("<svg") && svg.len() > 1000, "{all:?}");
    }
    text
}

#[test]
fn fresnel_plot_draws_dielectrics_and_conductors() {
    let dir = plot_dir("fresnel-plot");
    plot_writes(
        &["fresnel", "plot", "--ior", "1.5"],
        &dir.join("f.png"),
        Some((900, 700)),
    );
    plot_writes(
        &[
            "fresnel", "plot", "--ior", "water", "--inside", "--size", "640x480",
        ],
        &dir.join("w.png"),
        Some((640, 480)),
    );
    plot_writes(
        &["fresnel", "plot", "--material", "Cu"],
        &dir.join("cu.svg"),
        None,
    );
    let svg = std::fs::read_to_string(dir.join("cu.svg")).unwrap();
    assert!(svg.contains("conductor Cu") && svg.contains("R, blue channel"));
    // the table form is unchanged and cannot be mixed with the subcommand
    let o = specula(&["fresnel", "--ior", "1.5", "--steps", "3"]);
    assert!(o.status.success() && stdout(&o).contains("Brewster's angle: 56.31°"));
    let o = specula(&["fresnel", "--ior", "1.5", "plot", "-o", "x.png"]);
    assert!(!o.status.success());
    // bad input: one line naming the problem
    for (args, needle) in [
        (
            &["fresnel", "plot", "--ior", "glass?", "-o", "x.png"][..],
            "glass?",
        ),
        (
            &["fresnel", "plot", "--material", "Xx", "-o", "x.png"][..],
            "unknown conductor",
        ),
        (&["fresnel", "plot", "-o", "x.gif"][..], "x.gif"),
        (
            &[
                "fresnel",
                "plot",
                "--material",
                "Cu",
                "--inside",
                "-o",
                "x.png",
            ][..],
            "--inside",
        ),
    ] {
        let o = specula(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(needle) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn brdf_plot_draws_lobes() {
    let dir = plot_dir("brdf-plot");
    plot_writes(
        &["brdf", "plot", "roughconductor material=Cu alpha=0.2"],
        &dir.join("lobe.png"),
        Some((900, 500)),
    );
    // transmission: the whole circle; log radius; SVG
    plot_writes(
        &[
            "brdf",
            "plot",
            "roughdielectric alpha=0.2",
            "--log",
            "--theta-i",
            "0,45",
        ],
        &dir.join("glass.svg"),
        None,
    );
    let svg = std::fs::read_to_string(dir.join("glass.svg")).unwrap();
    assert!(svg.contains("θi = 45°") && svg.contains("transmission"));
    plot_writes(
        &[
            "brdf",
            "plot",
            "plastic",
            "--quantity",
            "f",
            "--channel",
            "r",
        ],
        &dir.join("plastic.png"),
        None,
    );
    // only Dirac lobes: refused with the reason, no picture
    let out = dir.join("mirror.png");
    let o = specula(&["brdf", "plot", "conductor", "-o", out.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("Dirac") && err.trim_end().lines().count() == 1,
        "{err}"
    );
    assert!(!out.exists());
    let o = specula(&["brdf", "plot", "diffuse", "--theta-i", "90", "-o", "x.png"]);
    assert!(stderr(&o).contains("[0, 90)"), "{}", stderr(&o));
    // an output that cannot be written: one line naming it
    let bad = dir.join("no-such-dir").join("x.png");
    let o = specula(&["brdf", "plot", "diffuse", "-o", bad.to_str().unwrap()]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(bad.to_str().unwrap()) && err.trim_end().lines().count() == 1,
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn brdf_slice_draws_analytic_and_merl_materials() {
    let dir = plot_dir("brdf-slice");
    plot_writes(
        &[
            "brdf",
            "slice",
            "roughconductor material=Au alpha=0.1",
            "--cells",
            "60",
        ],
        &dir.join("au.png"),
        Some((900, 700)),
    );
    // a MERL table: tabulated from a model and written by the library
    let model = specula_bsdf::parse_spec("roughplastic alpha=0.2").unwrap();
    let table = dir.join("plastic.binary");
    specula_bsdf::measured::merl::Merl::measure(&model)
        .write(&table)
        .unwrap();
    plot_writes(
        &["brdf", "slice", table.to_str().unwrap(), "--phi-d", "45"],
        &dir.join("merl.png"),
        None,
    );
    plot_writes(
        &["brdf", "slice", "diffuse", "--phi-d", "0", "--channel", "g"],
        &dir.join("diffuse.svg"),
        None,
    );
    let o = specula(&["brdf", "slice", "dielectric", "-o", "x.png"]);
    assert!(stderr(&o).contains("Dirac"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn brdf_albedo_prints_and_draws() {
    let dir = plot_dir("brdf-albedo");
    let text = plot_writes(
        &[
            "brdf",
            "albedo",
            "diffuse reflectance=0.5",
            "--step",
            "30",
            "--samples",
            "1000",
        ],
        &dir.join("d.png"),
        Some((900, 700)),
    );
    let rows: Vec<Vec<f64>> = text.lines().filter_map(row).collect();
    assert_eq!(rows.len(), 3, "{text}");
    for r in &rows {
        // θi, R per channel, max standard error
        assert_eq!(r.len(), 5, "{text}");
        assert!(r[1..4].iter().all(|v| (v - 0.5).abs() < 1e-5), "{text}");
    }
    // smooth glass: reflection and transmission add up to 1
    let text = plot_writes(
        &[
            "brdf",
            "albedo",
            "dielectric",
            "--step",
            "20",
            "--samples",
            "5000",
        ],
        &dir.join("glass.svg"),
        None,
    );
    let rows: Vec<Vec<f64>> = text.lines().filter_map(row).collect();
    assert_eq!(rows.len(), 5, "{text}");
    for r in &rows {
        assert_eq!(r.len(), 11, "{text}");
        assert!(r[7..10].iter().all(|v| (v - 1.0).abs() < 1e-5), "{text}");
        assert!(r[1] > 0.03 && r[4] < 0.97, "{text}");
    }
    let o = specula(&["brdf", "albedo", "diffuse", "--step", "0", "-o", "x.png"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--step"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------------------------------
// brdf check and gallery

/// A scratch directory for one test, removed when dropped.
struct CheckScratch(std::path::PathBuf);

impl CheckScratch {
    fn new(name: &str) -> Self {
        let d = std::env::temp_dir().join(format!("specula-cli-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        CheckScratch(d)
    }
}

impl Drop for CheckScratch {
    fn drop(&mut self) {
        std::fs::remove_dir_all(&self.0).ok();
    }
}

/// The verdict column of the line for `check` in a `brdf check` report.
fn check_verdict<'a>(report: &'a str, check: &str) -> Option<&'a str> {
    report.lines().find_map(|l| {
        let mut w = l.split_whitespace();
        (w.next() == Some(check)).then(|| w.next()).flatten()
    })
}

/// A MERL file's bytes with every measured (non-negative) value multiplied by `k`.
fn scaled_merl(bytes: &[u8], k: f64) -> Vec<u8> {
    let mut out = bytes[..12].to_vec();
    for b in bytes[12..].chunks_exact(8) {
        let v = f64::from_le_bytes(b.try_into().unwrap());
        let v = if v >= 0.0 { v * k } else { v };
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[test]
fn brdf_check_passes_well_behaved_materials() {
    // each run is one family of statistical tests at family-wise significance 0.01 (the
    // report states the Šidák-corrected per-test level), with the default fixed seed
    for spec in [
        "diffuse reflectance=0.8",
        "roughconductor material=Cu alpha=0.2 distribution=ggx",
        "roughdielectric distribution=ggx alpha=0.3 int_ior=1.5",
        "roughplastic distribution=ggx alpha=0.1 diffuse_reflectance=0.6,0.15,0.1",
        "dielectric",
    ] {
        let o = specula(&["brdf", "check", spec, "--quiet"]);
        let text = stdout(&o);
        assert_eq!(o.status.code(), Some(0), "{spec}:\n{text}{}", stderr(&o));
        assert!(text.contains("result: PASS"), "{text}");
        assert!(text.contains("Šidák-corrected: α = "), "{text}");
        for check in ["non-negative", "reciprocity", "energy", "sample-weights"] {
            let v = check_verdict(&text, check).unwrap_or_else(|| panic!("{check}: {text}"));
            assert!(v == "PASS" || v == "SKIP", "{spec} {check}: {v}\n{text}");
        }
        let sampling = if spec == "dielectric" {
            "lobe-selection"
        } else {
            "sampling-chi2"
        };
        assert_eq!(check_verdict(&text, sampling), Some("PASS"), "{text}");
    }
}

#[test]
fn brdf_check_surface_wrappers() {
    // a normal map is judged on everything but reciprocity (it is not reciprocal, as in
    // Mitsuba), at the texture coordinates given; mask and null on everything that applies
    for (spec, recip) in [
        (
            "normalmap normalmap=0.7,0.4,0.9 { roughplastic alpha=0.2 }",
            "SKIP",
        ),
        ("mask opacity=0.4 { diffuse }", "PASS"),
        ("null", "SKIP"),
    ] {
        let o = specula(&[
            "brdf",
            "check",
            spec,
            "--quiet",
            "--samples",
            "20000",
            "--uv",
            "0.3,0.6",
        ]);
        let text = stdout(&o);
        assert_eq!(o.status.code(), Some(0), "{spec}:\n{text}{}", stderr(&o));
        assert!(text.contains("uv = (0.3, 0.6)"), "{text}");
        assert_eq!(check_verdict(&text, "reciprocity"), Some(recip), "{text}");
        assert_eq!(check_verdict(&text, "energy"), Some("PASS"), "{text}");
    }
    let o = specula(&["brdf", "check", "null", "--uv", "0.3"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

#[test]
fn brdf_check_flags_a_merl_table_scaled_by_two() {
    use specula_bsdf::measured::merl::Merl;
    let dir = CheckScratch::new("check-merl");
    // a table that needs no shared data: a white-ish rough plastic "measured" by the model
    let model =
        specula_bsdf::parse_spec("roughplastic distribution=ggx alpha=0.2 diffuse_reflectance=0.8")
            .unwrap();
    let mut tables = vec![("synthetic", Merl::measure(&model).to_bytes())];
    if let Some(copper) = shared("data/merl/mitsuba_rough_copper.binary") {
        tables.push(("copper", std::fs::read(&copper).unwrap()));
    }
    for (name, bytes) in tables {
        for (k, expect_fail) in [(1.0, false), (2.0, true)] {
            let path = dir.0.join(format!("{name}_x{k}.binary"));
            std::fs::write(&path, scaled_merl(&bytes, k)).unwrap();
            // one angle and few samples keep the test short (the χ² cubature of a tabulated
            // density is slow); an albedo of 1.6 ± 0.003 still fails by far
            let o = specula(&[
                "brdf",
                "check",
                path.to_str().unwrap(),
                "--angles",
                "30",
                "--samples",
                "20000",
                "--quiet",
            ]);
            println!("{name} ×{k}:\n{text}", text = stdout(&o));
            let text = stdout(&o);
            let energy = check_verdict(&text, "energy");
            if expect_fail {
                assert_eq!(
                    o.status.code(),
                    Some(1),
                    "{name} ×{k}:\n{text}{}",
                    stderr(&o)
                );
                assert_eq!(energy, Some("FAIL"), "{name} ×{k}:\n{text}");
                assert!(text.contains("result: FAIL"), "{text}");
                assert!(stderr(&o).is_empty(), "nothing extra: {}", stderr(&o));
            } else {
                assert_eq!(energy, Some("PASS"), "{name} ×{k}:\n{text}{}", stderr(&o));
                assert_eq!(o.status.code(), Some(0), "{name} ×{k}:\n{text}");
            }
        }
    }
}

#[test]
fn brdf_check_rejects_damaged_files_in_one_line() {
    let dir = CheckScratch::new("check-damaged");
    let header =
        |dims: [i32; 3]| -> Vec<u8> { dims.iter().flat_map(|d| d.to_le_bytes()).collect() };
    let full = 12 + 3 * 90 * 90 * 180 * 8;
    let mut truncated = header([90, 90, 180]);
    truncated.resize(full / 2, 0);
    let mut wrong_dims = header([90, 90, 360]);
    wrong_dims.resize(full, 0);
    let garbage: Vec<u8> = (0..5000u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8)
        .collect();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("truncated.binary", truncated),
        ("wrong_dims.binary", wrong_dims),
        ("empty.binary", vec![]),
        ("garbage.binary", garbage.clone()),
        ("garbage.bsdf", garbage),
        ("text.bsdf", b"not a tensor file\n".to_vec()),
    ];
    for (name, bytes) in cases {
        let path = dir.0.join(name);
        std::fs::write(&path, bytes).unwrap();
        let o = specula(&["brdf", "check", path.to_str().unwrap(), "--quiet"]);
        let err = stderr(&o);
        assert!(!o.status.success(), "{name} was accepted");
        assert_eq!(o.status.code(), Some(2), "{name}: {err}");
        assert!(!err.contains("panicked"), "{name}: {err}");
        assert!(err.starts_with("error: "), "{name}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{name}: {err}");
        assert!(
            err.contains(path.to_str().unwrap()),
            "{name}: names the file: {err}"
        );
        assert!(stdout(&o).is_empty(), "{name}");
    }
}

#[test]
fn brdf_check_usage_errors_exit_2() {
    for args in [
        &["brdf", "check", "diffuse reflectance=oops"][..],
        &["brdf", "check", "diffuse", "--samples", "10"][..],
        &["brdf", "check", "diffuse", "--angles", "0,200"][..],
        &["brdf", "check", "diffuse", "--alpha", "1.5"][..],
    ] {
        let o = specula(args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
    }
}

#[test]
fn gallery_writes_a_labelled_contact_sheet() {
    let dir = CheckScratch::new("gallery");
    let out = dir.0.join("g.png");
    let size = 48usize;
    let o = specula(&[
        "gallery",
        "--no-presets",
        "--size",
        "48",
        "--spp",
        "4",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
        "diffuse reflectance=0.8,0.1,0.1",
        "conductor material=Au",
    ]);
    let text = stdout(&o);
    assert!(o.status.success(), "{}", stderr(&o));
    // the layout of gallery.rs: padding 4, label strip 16, title strip 28 for tiles this small
    let (pad, label, title) = (4, 16, 28);
    let (w, h) = (pad + 2 * (size + pad), title + size + label + pad + pad);
    assert!(text.contains(&format!("{w}×{h} px")), "{text}");
    assert!(
        text.contains("2 materials, 2×1 tiles of 48 px at 4 spp"),
        "{text}"
    );
    let (img, srgb) = specula_render::image_io::read_image(&out).unwrap();
    assert!(srgb);
    assert_eq!((img.width, img.height), (w, h));
    let tile = |i: usize| -> Vec<[f32; 3]> {
        let x0 = pad + i * (size + pad);
        (title..title + size)
            .flat_map(|y| (x0..x0 + size).map(move |x| (x, y)))
            .map(|(x, y)| img.rgb(x, y))
            .collect()
    };
    let (a, b) = (tile(0), tile(1));
    let mean = |t: &[[f32; 3]]| -> [f64; 3] {
        std::array::from_fn(|c| t.iter().map(|p| p[c] as f64).sum::<f64>() / t.len() as f64)
    };
    // not constant: the tiles show a scene, not a flat colour
    for t in [&a, &b] {
        let m = mean(t);
        let var = t.iter().map(|p| (p[1] as f64 - m[1]).powi(2)).sum::<f64>() / t.len() as f64;
        assert!(
            var.sqrt() > 0.05,
            "tile is nearly constant: sd {}",
            var.sqrt()
        );
    }
    // different materials, different tiles: the red diffuse probe is redder than the gold one
    let diff = a
        .iter()
        .zip(&b)
        .filter(|(p, q)| (p[0] - q[0]).abs() > 0.1)
        .count();
    assert!(diff > size * size / 20, "only {diff} pixels differ");
    // the centre of the probe: red diffuse is far less green than gold
    let centre = |t: &[[f32; 3]]| -> [f64; 3] {
        let c: Vec<[f32; 3]> = (size / 2 - 4..size / 2 + 4)
            .flat_map(|y| (size / 2 - 4..size / 2 + 4).map(move |x| t[y * size + x]))
            .collect();
        mean(&c)
    };
    let (ca, cb) = (centre(&a), centre(&b));
    println!("probe centres (sRGB): red diffuse {ca:.3?}, gold {cb:.3?}");
    assert!(ca[1] / ca[0] < 0.5 && cb[1] / cb[0] > 0.6, "{ca:?} {cb:?}");
    // the label strip holds text: bright pixels on the dark background
    let label_row = title + size + label / 2;
    let bright = (pad..pad + size)
        .filter(|&x| (label_row - 4..label_row + 4).any(|y| img.rgb(x, y)[0] > 0.6))
        .count();
    assert!(bright > 5, "no label drawn");
}

#[test]
fn gallery_rejects_bad_arguments() {
    let dir = CheckScratch::new("gallery-bad");
    let out = dir.0.join("g.png");
    let garbage = dir.0.join("bad.binary");
    std::fs::write(&garbage, b"garbage").unwrap();
    for args in [
        vec!["gallery", "-o", "g.jpg"],
        vec!["gallery", "--no-presets", "-o", out.to_str().unwrap()],
        vec!["gallery", "--size", "2", "-o", out.to_str().unwrap()],
        vec![
            "gallery",
            "-o",
            out.to_str().unwrap(),
            garbage.to_str().unwrap(),
        ],
        vec![
            "gallery",
            "-o",
            out.to_str().unwrap(),
            "diffuse reflectance=x",
        ],
    ] {
        let o = specula(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(!out.exists(), "{args:?} wrote a picture");
    }
}

#[test]
fn render_with_another_sampler_and_aov_channels() {
    let dir = std::env::temp_dir().join(format!("specula-cli-aov-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("aov.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
    <integrator type="aov">
        <string name="aovs" value="nn:sh_normal, depth.y:depth"/>
        <integrator type="path" name="image"/>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="stratified"><integer name="sample_count" value="5"/></sampler>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="12"/></film>
    </sensor>
    <shape type="sphere"/>
    <emitter type="constant"/>
</scene>"#,
    )
    .unwrap();
    let out = dir.join("aov.exr");
    let run = |extra: &[&str], out: &std::path::Path| {
        std::process::Command::new(env!("CARGO_BIN_EXE_specula"))
            .args(["render", scene.to_str().unwrap(), "--quiet", "-o"])
            .arg(out)
            .args(extra)
            .output()
            .unwrap()
    };
    // the scene's stratified sampler rounds 5 samples up to 9
    let o = run(&[], &out);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("16×12 at 9 spp (stratified)"),
        "{}",
        stdout(&o)
    );
    let bytes = std::fs::read(&out).unwrap();
    for name in ["image.A", "nn.X", "nn.Z", "depth.y.T"] {
        let needle = format!("{name}\0");
        assert!(
            bytes.windows(needle.len()).any(|w| w == needle.as_bytes()),
            "channel {name} missing"
        );
    }
    let o = run(&["--sampler", "sobol", "--spp", "5"], &out);
    assert!(stdout(&o).contains("at 5 spp (sobol)"), "{}", stdout(&o));
    // adaptive sampling with the AOV channels; the scene's stratified sampler is refused
    let o = run(&["--sampler", "sobol", "--spp", "16", "--adaptive"], &out);
    assert!(
        stdout(&o).contains("at 16 spp (sobol, adaptive)"),
        "{}",
        stdout(&o)
    );
    let o = run(&["--spp", "16", "--adaptive"], &out);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("progressive sampler"), "{}", stderr(&o));
    let o = run(&["--sampler", "halton"], &out);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("unknown sampler 'halton'"),
        "{}",
        stderr(&o)
    );
    let o = run(&[], &dir.join("aov.png"));
    assert!(stderr(&o).contains("use .exr"), "{}", stderr(&o));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn phase_plot_draws_and_refuses_bad_phase_functions() {
    let dir = CheckScratch::new("phase-plot");
    let png = dir.0.join("hg.png");
    let text = plot_writes(
        &[
            "phase",
            "plot",
            "hg",
            "--g",
            "0.3,0.7,-0.5",
            "--samples",
            "20000",
        ],
        &png,
        Some((1200, 560)),
    );
    // one table row per curve: normalisation 1 and the mean cosine g, analytic and sampled
    for g in ["0.3", "0.7", "-0.5"] {
        let line = text
            .lines()
            .find(|l| l.starts_with(&format!("hg g={g} ")))
            .unwrap_or_else(|| panic!("no row for g = {g}: {text}"));
        let v: Vec<f64> = line
            .split_whitespace()
            .skip(2)
            .map(|w| w.parse().unwrap())
            .collect();
        let g: f64 = g.parse().unwrap();
        assert!(
            (v[0] - 1.0).abs() < 1e-3 && (v[1] - g).abs() < 1e-3,
            "{line}"
        );
        assert!((v[2] - g).abs() < 0.02, "{line}");
    }
    plot_writes(
        &[
            "phase",
            "plot",
            "rayleigh",
            "isotropic",
            "blendphase weight=0.3 { hg g=-0.4 } { hg g=0.9 }",
            r#"<phase type="hg"><float name="g" value="0.5"/></phase>"#,
            "--log",
            "--size",
            "800x400",
        ],
        &dir.0.join("mix.svg"),
        None,
    );
    let bad = dir.0.join("bad.png");
    for (args, expect) in [
        (vec!["hg", "g=1"], "g must lie in (−1, 1)"),
        (vec!["hg", "--g", "-1.5"], "g must lie in (−1, 1)"),
        (vec!["mie"], "phase function 'mie' is not supported"),
        (vec!["hg", "x=2"], "unknown parameter 'x'"),
        (vec!["blendphase", "{", "isotropic", "}"], "exactly two"),
        (
            vec![r#"<phase type="hg"><float name="g" value="3"/></phase>"#],
            "<phase argument>:1:",
        ),
        (vec![], "no phase function"),
    ] {
        let mut all = vec!["phase", "plot"];
        all.extend(&args);
        all.extend(["-o", bad.to_str().unwrap()]);
        let o = specula(&all);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{all:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{all:?}: {err}");
        assert!(err.contains(expect), "{all:?}: {err}");
        assert!(!bad.exists(), "{all:?} wrote a picture");
    }
}

/// `--timings` prints every loading phase (of an envmap scene: images, emitter tables), the
/// start-up, the render and the write; the phases add up to no more than the start-up.
#[test]
fn render_timings_lists_the_phases() {
    let Some(scene) = shared("scenes/envmap_spheres.xml") else {
        eprintln!("skipped: ../shared is absent");
        return;
    };
    let out = std::env::temp_dir().join(format!("specula-cli-timings-{}.exr", std::process::id()));
    let o = specula(&[
        "render",
        scene.to_str().unwrap(),
        "--size",
        "16x12",
        "--spp",
        "1",
        "--quiet",
        "--timings",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let line = text
        .lines()
        .find(|l| l.starts_with("timings: "))
        .unwrap_or_else(|| panic!("no timings line: {text}"));
    let secs = |name: &str| -> f64 {
        let at = line
            .find(&format!("{name} "))
            .unwrap_or_else(|| panic!("{name}: {line}"));
        line[at + name.len() + 1..]
            .split_whitespace()
            .next()
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{name}: {line}"))
    };
    let phases = ["parse", "meshes", "textures", "emitters", "bsdfs", "bvh"];
    let sum: f64 = phases.iter().map(|p| secs(p)).sum();
    assert!(phases.iter().all(|p| secs(p) >= 0.0), "{line}");
    assert!(sum <= secs("start-up") + 1e-3, "{line}");
    assert!(secs("render") > 0.0, "{line}");
    std::fs::remove_file(&out).ok();
}
