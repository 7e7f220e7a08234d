//! What the conformance tests share: render a loaded scene at 64 spp, compare it with a
//! Mitsuba reference by the criteria of `../shared/README.md` (mean ratio, block8, relMSE
//! against Mitsuba's own 64-spp figures), and collect a report that fails the test with every
//! non-conforming scene named. Each test binary compiles this module and uses part of it.
#![allow(dead_code)]

use specula_render::image_io::read_image;
use specula_render::metrics::{Criteria, RgbImage};
use specula_render::render::{render, RenderOptions};
use specula_render::scene::Scene;
use std::path::Path;
use std::sync::atomic::AtomicBool;

/// Samples per pixel of every conformance render (the references' error figures are Mitsuba's
/// at this count).
pub const SPP: u32 = 64;

/// Whether `SPECULA_SCENES=a,b` (when set) names `name`.
pub fn selected(name: &str) -> bool {
    std::env::var("SPECULA_SCENES")
        .map(|o| o.split(',').any(|s| s == name))
        .unwrap_or(true)
}

/// A `metrics.json` file.
pub fn read_metrics(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The criteria for a scene's metrics entry (`mitsuba_64spp_relmse`, `mitsuba_64spp_block8`)
/// with the given tolerance on each channel's mean ratio.
pub fn criteria(m: &serde_json::Value, mean_tol: f64) -> Criteria {
    Criteria::new(
        m["mitsuba_64spp_relmse"].as_f64().unwrap(),
        m["mitsuba_64spp_block8"].as_f64().unwrap(),
        mean_tol,
    )
}

/// `../shared/README.md`'s mean tolerance: 0.01, or 0.02 where the reference has more than
/// 1024 spp (`ref_spp`).
pub fn mean_tol_by_ref_spp(m: &serde_json::Value) -> f64 {
    if m["ref_spp"].as_f64().unwrap() > 1024.0 {
        0.02
    } else {
        0.01
    }
}

/// max(0.01, 2 × Mitsuba's own worst deviation of the mean over seeds,
/// `mitsuba_64spp_max_mean_dev`).
pub fn mean_tol_by_mitsuba_dev(m: &serde_json::Value) -> f64 {
    (2.0 * m["mitsuba_64spp_max_mean_dev"].as_f64().unwrap()).max(0.01)
}

/// One scene's verdict.
pub struct Judged {
    /// The criteria hold and no sample was NaN or infinite.
    pub ok: bool,
    /// The figures: each criterion's value and bound, the mean render time, invalid samples
    /// (or, where the sizes differ, that message).
    pub figures: String,
    /// Why it does not conform (empty when `ok`).
    pub failure: String,
    /// NaN or infinite samples, over all seeds.
    pub invalid: u64,
}

/// Renders `scene` at [`SPP`] with seeds `0..seeds` (threads: all cores) and judges the
/// renders together against the reference image at `reference` with `criteria`.
pub fn render_and_judge(
    name: &str,
    scene: &Scene,
    seeds: u64,
    reference: &Path,
    criteria: &Criteria,
) -> Judged {
    let (refimg, _) = read_image(reference)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", reference.display()));
    let reference = RgbImage::from(&refimg);
    let (mut renders, mut invalid, mut elapsed) = (vec![], 0, 0.0);
    for seed in 0..seeds {
        let opts = RenderOptions {
            spp: SPP,
            seed,
            threads: 0,
        };
        let out = render(scene, &opts, &AtomicBool::new(false), &|_, _| {});
        invalid += out.counters.invalid;
        elapsed += out.elapsed.as_secs_f64();
        renders.push(RgbImage {
            width: out.width,
            height: out.height,
            data: out.rgb,
        });
    }
    if (renders[0].width, renders[0].height) != (reference.width, reference.height) {
        let msg = format!(
            "{name}: rendered {}×{}, reference {}×{}",
            renders[0].width, renders[0].height, reference.width, reference.height
        );
        return Judged {
            ok: false,
            figures: msg.clone(),
            failure: msg,
            invalid,
        };
    }
    let v = criteria.judge(&renders, &reference);
    let ok = v.ok() && invalid == 0;
    Judged {
        ok,
        figures: format!(
            "{}  {:.2}s  invalid {invalid}",
            v.row(criteria),
            elapsed / seeds as f64
        ),
        failure: if ok {
            String::new()
        } else {
            format!(
                "{name}: {}; invalid samples {invalid}",
                v.failures(criteria)
            )
        },
        invalid,
    }
}

/// The rows and failures of a conformance test.
#[derive(Default)]
pub struct Report {
    rows: Vec<String>,
    failures: Vec<String>,
    rendered: usize,
}

impl Report {
    /// A judged scene: its row (`ok` or `FAIL`) and, if it does not conform, its failure.
    pub fn judged(&mut self, name: &str, j: Judged) {
        let verdict = if j.ok { "ok" } else { "FAIL" };
        self.row(name, &j, verdict);
        if !j.ok {
            self.failures.push(j.failure);
        }
    }

    /// A rendered scene's row with the verdict given by the caller (no failure recorded).
    pub fn row(&mut self, name: &str, j: &Judged, verdict: &str) {
        self.rendered += 1;
        let row = format!("{name:<30} {}  {verdict}", j.figures);
        // printed as it goes (long runs), and again in the table at the end
        eprintln!("{row}");
        self.rows.push(row);
    }

    /// A rendered scene that is reported but not judged (`reason`): its row, and a failure
    /// only for NaN or infinite samples.
    pub fn unjudged(&mut self, name: &str, j: Judged, reason: &str) {
        let verdict = if j.ok {
            "ok".to_string()
        } else {
            format!("differs (not judged: {reason})")
        };
        self.row(name, &j, &verdict);
        if j.invalid != 0 {
            self.failures.push(j.failure);
        }
    }

    /// A row that is not a render (an excepted scene, say).
    pub fn note(&mut self, row: String) {
        self.rows.push(row);
    }

    /// A failure (a scene that does not load, one that conforms but is listed as known not
    /// to, ...).
    pub fn fail(&mut self, failure: String) {
        self.failures.push(failure);
    }

    /// Scenes rendered so far.
    pub fn rendered(&self) -> usize {
        self.rendered
    }

    /// Prints the table under `title` and fails the test if any scene failed, or if none was
    /// rendered although `SPECULA_SCENES` restricts nothing and `require_some` is set.
    pub fn finish(self, title: &str, require_some: bool) {
        println!("{title}:\n{}", self.rows.join("\n"));
        let restricted = std::env::var("SPECULA_SCENES").is_ok();
        assert!(
            !require_some || self.rendered > 0 || restricted,
            "{title}: no scene was rendered"
        );
        assert!(
            self.failures.is_empty(),
            "{title}: non-conforming scenes:\n{}",
            self.failures.join("\n")
        );
    }
}
