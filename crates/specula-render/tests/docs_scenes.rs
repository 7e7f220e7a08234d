//! Mitsuba 3's own documentation scenes (`../shared/mitsuba-data/docs/scenes`), unchanged.
//!
//! - [`docs_scenes_load_or_name_an_excepted_plugin`]: every scene loads, or fails with one line
//!   that names a plugin of the excepted list below (media, curves, hair, sdfgrid, polarized
//!   rendering).
//! - [`docs_scenes_match_mitsuba_references`]: every scene with a reference in
//!   `../shared/mitsuba-data/reference` (Mitsuba 3.9 `llvm_ad_rgb`, film resized to the
//!   reference's `resolution`) is rendered at that size (as `specula render NAME.xml --size WxH`)
//!   at 64 spp with the scene's own sampler and must conform by the criteria of
//!   `../shared/README.md`, with the scene's `mean_tol` for the mean ratio: every channel within
//!   1 ± mean_tol, block8 ≤ 2 × Mitsuba's 64-spp block8 + 1e-5, relMSE ≤ 1.5 × Mitsuba's 64-spp
//!   relMSE. The table is printed (`cargo test --release --test docs_scenes -- --nocapture`);
//!   `SPECULA_SCENES=a,b` restricts the run to those scenes.
//!
//! The scenes in `KNOWN_NONCONFORMING` are reported with what is known about them (the test
//! fails when one of them starts to conform, so that the list only shrinks).
//!
//! The scenes are rendered one after the other, each over all cores; at the reduced sizes
//! (mostly 320×240) the suite takes a few minutes on two cores.

use specula_render::image_io::read_image;
use specula_render::metrics::{block8, mean_ratio, relmse, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::{LoadOptions, Scene};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Scenes that need what this renderer does not do yet, with the plugins whose names the load
/// error must contain. This list shrinks as those features land.
const EXCEPTIONS: &[(&str, &[&str], &str)] = &[
    ("shape_bsplinecurve_", &["bsplinecurve"], "curves"),
    ("shape_linearcurve_", &["linearcurve"], "curves"),
    ("bsdf_hair_", &["hair"], "hair"),
    ("shape_sdfgrid", &["sdfgrid"], "sdfgrid"),
    (
        "bsdf_pplastic",
        &["pplastic", "stokes"],
        "polarized mode (pplastic)",
    ),
    (
        "bsdf_polarizer_",
        &["polarizer"],
        "polarized mode (polarizer)",
    ),
    (
        "bsdf_measured_polarized_",
        &["measured_polarized", "stokes"],
        "polarized mode (measured_polarized)",
    ),
    ("integrator_stokes_", &["stokes"], "polarized mode (stokes)"),
];

/// Scenes with a reference that do not conform yet, each with what is known; the test reports
/// them and fails if one of them starts to conform (so that it leaves this list).
const KNOWN_NONCONFORMING: &[(&str, &str)] = &[
    (
        "bsdf_blendbsdf",
        "Mitsuba 3.9's blendbsdf weights a Dirac sample of a component by the blend weight w \
         although it picked that component with probability w (its sample weight is \
         ((1−w)f₀cos + w·F)/((1−w)p₀ + w), i.e. ≈ w·F): the smooth gold's share of the image \
         comes out w² instead of w. Specula follows the definition (1−w)f₀ + w·f₁ (checked by \
         the χ² and albedo tests of the material library)",
    ),
    (
        "integrator_depth_1",
        "a noise outlier, not a bias: with seed 0 at 64 spp relMSE is 3.07e-7 against a limit \
         of 2.73e-7 (1.5 × Mitsuba's 1.82e-7, averaged over 2 seeds); seeds 1, 2, 3 give \
         1.66e-7, 1.86e-7, 2.39e-7 and the mean at 256 spp is 0.99996 of the reference. The \
         metric is dominated by the ~100 pixels on the light's edges (binomial coverage \
         noise); comparing over several seeds, as Mitsuba's figure is, would settle it",
    ),
];

/// Docs scenes that name files absent from the upstream repository (so Mitsuba cannot load
/// them either); their load error must say so.
const MISSING_UPSTREAM: &[&str] = &["sensor_orthographic_2"];

fn exception(name: &str) -> Option<(&'static [&'static str], &'static str)> {
    EXCEPTIONS
        .iter()
        .find(|(prefix, _, _)| name.starts_with(prefix))
        .map(|(_, plugins, why)| (*plugins, *why))
}

fn docs() -> Option<PathBuf> {
    specula_testdata::shared("mitsuba-data/docs/scenes")
}

/// Loads a docs scene as `specula render` does; scenes that use `$spp` without declaring it
/// get `spp=64`, as the references were made.
fn load(path: &Path, size: Option<(usize, usize)>) -> specula_render::core::Result<Scene> {
    let opts = LoadOptions { size };
    match Scene::load_with(path, &[], &opts) {
        Err(e) if e.to_string().contains("undefined parameter '$spp'") => {
            Scene::load_with(path, &[("spp".into(), "64".into())], &opts)
        }
        r => r,
    }
}

#[test]
fn docs_scenes_load_or_name_an_excepted_plugin() {
    let Some(dir) = docs() else { return };
    let mut scenes: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    let skipped = skipped_by_mitsuba();
    let mut failures = vec![];
    let (mut loaded, mut excepted) = (0, 0);
    for path in &scenes {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        // small films: loading is what is tested here
        match load(path, Some((8, 6))) {
            Ok(_) => loaded += 1,
            Err(e) => {
                let msg = e.to_string();
                let one_line = !msg.trim_end().contains('\n');
                match exception(&name) {
                    Some((plugins, why)) if plugins.iter().any(|p| msg.contains(p)) && one_line => {
                        excepted += 1;
                        println!("{name:<44} excepted ({why}): {msg}");
                    }
                    _ if MISSING_UPSTREAM.contains(&name.as_str())
                        && msg.contains("not found")
                        && one_line =>
                    {
                        println!("{name:<44} names a file absent upstream: {msg}");
                    }
                    _ if skipped.contains(&name) && one_line => {
                        println!("{name:<44} Mitsuba cannot render it either: {msg}");
                    }
                    _ => failures.push(format!("{name}: {msg}")),
                }
            }
        }
    }
    println!(
        "{} docs scenes: {loaded} load, {excepted} excepted, {} fail",
        scenes.len(),
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "docs scenes that neither load nor name an excepted plugin:\n{}",
        failures.join("\n")
    );
}

fn metrics() -> serde_json::Value {
    let root = specula_testdata::root();
    serde_json::from_str(
        &std::fs::read_to_string(root.join("mitsuba-data/reference/metrics.json")).unwrap(),
    )
    .unwrap()
}

fn skipped_by_mitsuba() -> Vec<String> {
    metrics()["_skipped"]
        .as_object()
        .map(|o| o.keys().cloned().collect())
        .unwrap_or_default()
}

#[test]
fn docs_scenes_match_mitsuba_references() {
    let Some(dir) = docs() else { return };
    let metrics = metrics();
    let refs = specula_testdata::root().join("mitsuba-data/reference");
    let only = std::env::var("SPECULA_SCENES").ok();
    let mut names: Vec<&String> = metrics
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| !k.starts_with('_'))
        .collect();
    names.sort();
    let (mut rows, mut failures) = (vec![], vec![]);
    let (mut conforming, mut rendered) = (0, 0);
    for name in names {
        if let Some(o) = &only {
            if !o.split(',').any(|s| s == name) {
                continue;
            }
        }
        let m = &metrics[name];
        let res = &m["resolution"];
        let size = (
            res[0].as_u64().unwrap() as usize,
            res[1].as_u64().unwrap() as usize,
        );
        let path = dir.join(format!("{name}.xml"));
        if let Some((_, why)) = exception(name) {
            rows.push(format!("{name:<44} excepted: {why}"));
            continue;
        }
        let scene = match load(&path, Some(size)) {
            Ok(s) => s,
            Err(e) => {
                failures.push(format!("{name}: does not load: {e}"));
                continue;
            }
        };
        let opts = RenderOptions {
            spp: 64,
            seed: 0,
            threads: 0,
        };
        let out = render(&scene, &opts, &AtomicBool::new(false), &|_, _| {});
        rendered += 1;
        let (refimg, _) = read_image(&refs.join(format!("{name}.exr"))).unwrap();
        let reference = RgbImage::from(&refimg);
        if (out.width, out.height) != (reference.width, reference.height) {
            failures.push(format!(
                "{name}: rendered {}×{}, reference {}×{}",
                out.width, out.height, reference.width, reference.height
            ));
            continue;
        }
        let img = RgbImage {
            width: out.width,
            height: out.height,
            data: out.rgb,
        };
        let (r, b, mr) = (
            relmse(&img, &reference),
            block8(&img, &reference),
            mean_ratio(&img, &reference),
        );
        let m_r = m["mitsuba_64spp_relmse"].as_f64().unwrap();
        let m_b = m["mitsuba_64spp_block8"].as_f64().unwrap();
        let tol = m["mean_tol"].as_f64().unwrap();
        let ok_mean = mr.iter().all(|v| (v - 1.0).abs() <= tol);
        let ok_b = b <= 2.0 * m_b + 1e-5;
        let ok_r = r <= 1.5 * m_r;
        let ok = ok_mean && ok_b && ok_r && out.counters.invalid == 0;
        if ok {
            conforming += 1;
        }
        let row = format!(
            "{name:<44} mean [{:.4} {:.4} {:.4}] (±{tol:.3})  block8 {b:.3e} (mitsuba {m_b:.3e})  relmse {r:.3e} (mitsuba {m_r:.3e})  {:.2}s  {}",
            mr[0],
            mr[1],
            mr[2],
            out.elapsed.as_secs_f64(),
            if ok {
                "ok"
            } else if KNOWN_NONCONFORMING.iter().any(|(n, _)| n == name) {
                "FAIL (known)"
            } else {
                "FAIL"
            }
        );
        // printed as it goes (long runs), and again in the table at the end
        eprintln!("{row}");
        rows.push(row);
        let known = KNOWN_NONCONFORMING.iter().find(|(n, _)| n == name);
        if let Some((_, why)) = known {
            if ok {
                failures.push(format!(
                    "{name} conforms now: remove it from KNOWN_NONCONFORMING"
                ));
            } else {
                eprintln!("{name}: known not to conform: {why}");
            }
        } else if !ok {
            failures.push(format!(
                "{name}: mean {mr:?} (±{tol}), block8 {b:.3e} ≤ {:.3e}?, relmse {r:.3e} ≤ {:.3e}?, invalid samples {}",
                2.0 * m_b + 1e-5,
                1.5 * m_r,
                out.counters.invalid
            ));
        }
    }
    println!("{}", rows.join("\n"));
    println!("{rendered} rendered, {conforming} conform");
    assert!(rendered > 0 || only.is_some(), "no scene was rendered");
    assert!(
        failures.is_empty(),
        "non-conforming docs scenes:\n{}",
        failures.join("\n")
    );
}
