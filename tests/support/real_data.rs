//! Locating the real data in `../shared/data/` (next to the workspace) for the tests that
//! read it. Absent data is skipped with a printed reason on a developer machine and is a
//! test failure when the environment variable `CI` is set (CI clones the repository with
//! `shared/` beside it, so missing data there is a broken checkout, not a skip).

#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// What a real-data test does about one data path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DataDecision {
    /// The data is there: run the test on it.
    Use,
    /// The data is absent on a developer machine: print why and pass without checking.
    Skip,
    /// The data is absent under CI: fail the test.
    Fail,
}

/// The decision for a data path: `ci` is whether the `CI` environment variable is set,
/// `exists` whether the path is on disk.
pub fn data_or_skip(ci: bool, exists: bool) -> DataDecision {
    match (exists, ci) {
        (true, _) => DataDecision::Use,
        (false, false) => DataDecision::Skip,
        (false, true) => DataDecision::Fail,
    }
}

/// The shared data folder, `../shared/data` from the workspace root.
pub fn shared_data_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data")
}

/// `../shared/data/<rel>` (a file or folder) if it exists. Otherwise prints a `SKIP:` line
/// naming the path and returns `None`, or panics with the path when `CI` is set.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let path = shared_data_root().join(rel);
    let ci = std::env::var_os("CI").is_some();
    match data_or_skip(ci, path.exists()) {
        DataDecision::Use => Some(path),
        DataDecision::Skip => {
            eprintln!(
                "SKIP: real data {} not found; real-data test not run",
                path.display()
            );
            None
        }
        DataDecision::Fail => panic!(
            "real data {} not found but CI is set: CI needs `shared/data/` next to the \
             repository clone",
            path.display()
        ),
    }
}

#[test]
fn real_data_decision_skips_only_off_ci() {
    assert_eq!(data_or_skip(false, true), DataDecision::Use);
    assert_eq!(data_or_skip(true, true), DataDecision::Use);
    assert_eq!(data_or_skip(false, false), DataDecision::Skip);
    assert_eq!(data_or_skip(true, false), DataDecision::Fail);
}
