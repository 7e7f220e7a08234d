//! Where Specula's tests and benchmarks find `../shared`: the Mitsuba scenes, their reference
//! renders and the data files that live beside the repository (not in it).
//!
//! A test that needs a shared file asks [`shared`]: when the file is absent the test is
//! skipped with a note, except under `CI=true`, where the shared data must be present and its
//! absence fails the test.

use std::path::{Path, PathBuf};

/// `../shared` beside the repository (whether or not it exists).
pub fn root() -> PathBuf {
    // this crate is <repository>/crates/specula-testdata
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared")
}

/// `../shared/<rel>` when it exists; `None` (with a note on stderr) when it does not.
///
/// # Panics
/// Under `CI=true`, when `../shared/<rel>` is absent.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let p = root().join(rel);
    if p.exists() {
        return Some(p);
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI needs {}",
        p.display()
    );
    eprintln!("skipping: {} not found", p.display());
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absent_files_are_none_outside_ci() {
        if std::env::var("CI").as_deref() == Ok("true") {
            return;
        }
        assert_eq!(shared("no/such/file.xml"), None);
    }

    #[test]
    fn root_is_beside_the_repository() {
        let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        assert!(repo.join("Cargo.toml").is_file());
        assert!(root().ends_with("shared"));
        assert_eq!(root().parent().unwrap(), repo.join(".."));
    }
}
