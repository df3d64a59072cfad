//! The built `ghm` binary for the tests of run folders, agent files and studies.

use std::path::PathBuf;
use std::process::Command;

/// Runs `ghm args`: whether it succeeded, and its stderr (which must not hold a panic).
pub fn ghm(args: &[&str]) -> (bool, String) {
    let (ok, _, err) = ghm_with_stdout(args);
    (ok, err)
}

/// Runs `ghm args`: whether it succeeded, its stdout and its stderr (which must not hold
/// a panic).
pub fn ghm_with_stdout(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(args)
        .output()
        .expect("run ghm");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        err,
    )
}

/// A fresh temporary folder path `ghm-<name>-<pid>` (removed if it was there; not created).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ghm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}
