//! Start-up phase timings: where the time before the first sample goes (what
//! `specula render --timings` prints).
//!
//! Loading code wraps its phases in [`span`]s; each span adds its *exclusive* time (its own
//! time minus that of the spans nested in it on the same thread) to its phase's total, so the
//! phases add up to the time spent in them and never count a nested phase twice (a bitmap
//! decoded while a BSDF is built counts as `textures`, not `bsdfs`). Work spread over several
//! threads is summed over the threads (it can exceed the wall time it took). The totals are
//! process-wide atomics; a span costs two clock reads, so spans mark whole loading steps (a
//! file, a table), never per-sample work.

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// A loading phase.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// Reading and resolving the XML (includes, defaults, transforms).
    Parse,
    /// Reading mesh files (OBJ, PLY, serialized) and building the meshes (normals, transforms).
    Meshes,
    /// Decoding images and building bitmap textures.
    Textures,
    /// Emitters: environment-map and other sampling tables.
    Emitters,
    /// BSDFs (their precomputed tables, e.g. roughplastic's).
    Bsdfs,
    /// The acceleration structure (built on a thread of its own while the loader builds the
    /// BSDFs and waits for their images: its time overlaps theirs).
    Bvh,
}

impl Phase {
    /// All phases, in the order they are printed.
    pub const ALL: [Phase; 6] = [
        Phase::Parse,
        Phase::Meshes,
        Phase::Textures,
        Phase::Emitters,
        Phase::Bsdfs,
        Phase::Bvh,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Phase::Parse => "parse",
            Phase::Meshes => "meshes",
            Phase::Textures => "textures",
            Phase::Emitters => "emitters",
            Phase::Bsdfs => "bsdfs",
            Phase::Bvh => "bvh",
        }
    }
}

static NANOS: [AtomicU64; 6] = [
    AtomicU64::new(0),
    AtomicU64::new(0),
    AtomicU64::new(0),
    AtomicU64::new(0),
    AtomicU64::new(0),
    AtomicU64::new(0),
];

thread_local! {
    /// Time spent so far in spans nested in the innermost open span of this thread.
    static NESTED: Cell<u64> = const { Cell::new(0) };
    /// This thread's own totals (for tests: other threads load scenes at the same time).
    static LOCAL: [Cell<u64>; 6] = const { [const { Cell::new(0) }; 6] };
}

/// An open span: adds its exclusive time to its phase when dropped.
#[must_use = "a span measures until it is dropped"]
pub struct Span {
    phase: Phase,
    start: Instant,
    /// The enclosing span's nested time, restored on drop.
    outer_nested: u64,
}

/// Opens a span of `phase` (closed when the returned guard drops).
pub fn span(phase: Phase) -> Span {
    let outer_nested = NESTED.with(|n| n.replace(0));
    Span {
        phase,
        start: Instant::now(),
        outer_nested,
    }
}

impl Drop for Span {
    fn drop(&mut self) {
        let total = self.start.elapsed().as_nanos() as u64;
        let nested = NESTED.with(|n| n.replace(self.outer_nested + total));
        let own = total.saturating_sub(nested);
        NANOS[self.phase as usize].fetch_add(own, Ordering::Relaxed);
        LOCAL.with(|l| l[self.phase as usize].set(l[self.phase as usize].get() + own));
    }
}

/// Seconds spent in each phase so far (in [`Phase::ALL`]'s order).
pub fn totals() -> [(Phase, f64); 6] {
    Phase::ALL.map(|p| (p, NANOS[p as usize].load(Ordering::Relaxed) as f64 * 1e-9))
}

/// [`totals`] of the spans closed on this thread only.
pub fn thread_totals() -> [(Phase, f64); 6] {
    LOCAL.with(|l| Phase::ALL.map(|p| (p, l[p as usize].get() as f64 * 1e-9)))
}

/// Sets every total back to zero.
pub fn reset() {
    for n in &NANOS {
        n.store(0, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn spin(d: Duration) {
        let t = Instant::now();
        while t.elapsed() < d {}
    }

    #[test]
    fn nested_spans_count_once() {
        // this thread's totals: other tests load scenes at the same time
        let before = thread_totals();
        let t = Instant::now();
        {
            let _b = span(Phase::Bsdfs);
            spin(Duration::from_millis(4));
            {
                let _t = span(Phase::Textures);
                spin(Duration::from_millis(6));
            }
            spin(Duration::from_millis(2));
        }
        let wall = t.elapsed().as_secs_f64();
        let got: std::collections::HashMap<&str, f64> = thread_totals()
            .iter()
            .zip(before)
            .map(|((p, s), (_, b))| (p.name(), *s - b))
            .collect();
        assert!(got["textures"] >= 0.006, "{got:?}");
        assert!(got["bsdfs"] >= 0.006, "{got:?}");
        // exclusive: the two add up to the wall time, not more
        assert!(
            got["bsdfs"] + got["textures"] <= wall + 1e-6,
            "{got:?} {wall}"
        );
        assert_eq!(got["meshes"], 0.0);
    }
}
