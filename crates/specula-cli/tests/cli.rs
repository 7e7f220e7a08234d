//! End-to-end tests of the `specula` binary.

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

fn shared_scene(name: &str) -> Option<std::path::PathBuf> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/scenes")
        .join(name);
    if p.exists() {
        Some(p)
    } else {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI needs {}",
            p.display()
        );
        None
    }
}

#[test]
fn render_writes_png_and_exr_with_overrides() {
    let Some(scene) = shared_scene("cbox.xml") else {
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
