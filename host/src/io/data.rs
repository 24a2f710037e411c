//! The real face-data folder (`$SINEW_DATA` or `../shared/data`) of the tests and the
//! benchmarks (feature `test-support`): a data test skips where it is absent, or fails under
//! `SINEW_REQUIRE_DATA=1`.

use std::path::{Path, PathBuf};

/// The shared real-data folder: `$SINEW_DATA`, else `../shared/data` beside the repository.
pub fn data_root() -> PathBuf {
    std::env::var_os("SINEW_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"))
}

/// [`data_root`] when it exists. When it does not, a data test skips: this returns `None` after
/// saying so, unless `SINEW_REQUIRE_DATA=1` (set by `.ci/run`), where a missing data set must
/// fail the run instead, and this panics.
pub fn data_dir() -> Option<PathBuf> {
    let dir = data_root();
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("SINEW_REQUIRE_DATA").is_some_and(|v| v == "1") {
        panic!(
            "{}: data folder missing and SINEW_REQUIRE_DATA=1",
            dir.display()
        );
    }
    eprintln!(
        "skipping: real data folder {} not found (set SINEW_DATA)",
        dir.display()
    );
    None
}
