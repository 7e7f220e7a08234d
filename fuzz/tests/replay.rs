//! Replays the checked-in `regressions/` (hand-written seeds and every input the fuzzer found
//! a fault with) and the reproducers of `../shared/robustness` through the fuzz targets'
//! functions, without libFuzzer:
//! `cargo test --release --manifest-path fuzz/Cargo.toml --no-default-features`.
//! Each input must be handled without a panic (the targets check their own invariants, e.g.
//! finite pixels).

use std::path::Path;

type Target = fn(&[u8]);

const TARGETS: &[(&str, Target)] = &[
    ("xml_scene", specula_fuzz::xml_scene),
    ("overrides", specula_fuzz::overrides),
    ("obj", specula_fuzz::obj),
    ("ply", specula_fuzz::ply),
    ("serialized", specula_fuzz::serialized),
    ("merl", specula_fuzz::merl),
    ("rgl", specula_fuzz::rgl),
    ("image", specula_fuzz::image),
    ("spec", specula_fuzz::spec),
    ("pipeline", specula_fuzz::pipeline),
];

fn files(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return out;
    };
    for e in rd.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(files(&p));
        } else {
            out.push(p);
        }
    }
    out.sort();
    out
}

fn run(target: &str, f: Target, path: &Path) {
    let data = std::fs::read(path).unwrap();
    let dir = path.parent().unwrap();
    let t = std::time::Instant::now();
    let r = std::panic::catch_unwind(|| match target {
        // scenes refer to their assets by paths relative to their own folder
        "xml_scene" => specula_fuzz::xml_scene_in(&data, dir),
        "pipeline" => specula_fuzz::pipeline_in(&data, dir),
        _ => f(&data),
    });
    assert!(r.is_ok(), "{target} panicked on {}", path.display());
    let secs = t.elapsed().as_secs_f64();
    assert!(
        secs < 20.0,
        "{target} took {secs:.1} s on {}",
        path.display()
    );
}

#[test]
fn regressions_replay() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("regressions");
    let mut n = 0;
    for &(name, f) in TARGETS {
        for p in files(&root.join(name)) {
            run(name, f, &p);
            n += 1;
        }
    }
    assert!(n >= 10, "only {n} regression inputs found");
}

/// `../shared/robustness`: each file through the target(s) that read its kind.
#[test]
fn shared_reproducers_replay() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/robustness");
    if !root.exists() {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI needs {}",
            root.display()
        );
        eprintln!("skipping: {} not found", root.display());
        return;
    }
    let mut n = 0;
    for p in files(&root) {
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        let names: &[&str] = match ext {
            "xml" => &["xml_scene", "pipeline"],
            "obj" => &["obj"],
            "ply" => &["ply"],
            "exr" | "png" | "hdr" => &["image"],
            "txt" if p.parent().is_some_and(|d| d.ends_with("spec")) => &["spec"],
            _ => &[],
        };
        for &(name, f) in TARGETS.iter().filter(|(t, _)| names.contains(t)) {
            run(name, f, &p);
            n += 1;
        }
    }
    assert!(n >= 15, "only {n} reproducers replayed");
}
