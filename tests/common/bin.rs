//! The built `ghm` binary for the tests of run folders and agent files.

use std::path::PathBuf;
use std::process::Command;

/// Runs `ghm args`: whether it succeeded, and its stderr (which must not hold a panic).
pub fn ghm(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(args)
        .output()
        .expect("run ghm");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(!err.contains("panicked"), "{args:?}: {err}");
    (out.status.success(), err)
}

/// A fresh temporary folder path `ghm-<name>-<pid>` (removed if it was there; not created).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ghm-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}
