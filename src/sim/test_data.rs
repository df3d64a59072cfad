//! The data folder of the library's own tests: the Venlo 2014 weather, which the
//! repository does not ship (its sources state no licence; `docs/data.md` says how to
//! make it with `ghm import venlo`). The folder is `GHM_DATA`, else `../shared/data` beside
//! the repository; a test that needs a file and does not find it says on stderr that it
//! skipped and why, unless `GHM_REQUIRE_DATA` is set (`.ci/run`, which provides the data).
//! The integration tests include this file (`tests/common`). It lives in `sim`, which owns
//! the weather, so that `sim` and the importer above it can both use it.

use std::path::{Path, PathBuf};

/// The data folder: `GHM_DATA`, else `../shared/data` beside the repository.
pub fn dir() -> PathBuf {
    match std::env::var_os("GHM_DATA") {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data"),
    }
}

/// `name` in the data folder, where it is there. Where it is not, `test` is skipped with a
/// message that says how to provide it, or fails when `GHM_REQUIRE_DATA` is set.
pub fn file(name: &str, test: &str) -> Option<PathBuf> {
    let path = dir().join(name);
    if path.is_file() {
        return Some(path);
    }
    let message = format!(
        "{test}: needs {} (the data folder: set GHM_DATA to the folder that \
         `ghm import venlo` wrote; docs/data.md)",
        path.display()
    );
    skip(&message, "GHM_REQUIRE_DATA");
    None
}

/// Says on stderr that a test skipped (`message`: which and why), or fails it when the
/// environment variable `require` is set (as `.ci/run` sets it, having provided what the
/// test needs).
pub fn skip(message: &str, require: &str) {
    assert!(
        std::env::var_os(require).is_none(),
        "{message}; {require} is set"
    );
    // Past the test harness' capture, so that a passing run still says what it skipped.
    let _ = std::io::Write::write_fmt(&mut std::io::stderr(), format_args!("skipped: {message}\n"));
}
