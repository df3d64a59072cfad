//! Run folders that say what they are. A run claims its `--out` folder by writing
//! `run.json` with `"status": "running"` before anything else, and rewrites it with
//! `"status": "complete"` as the very last file; a run that fails rewrites it with
//! `"failed"` and the error. A folder whose `run.json` still says `"running"` was killed
//! (its `pid` says by whom it was held). See `docs/run-folders.md`.
//!
//! A folder that already holds the files of a run (this command's or another's) is
//! refused unless `--overwrite` is given, which removes those files first, so that no
//! stale file stays beside new ones. Files ghm does not write are never touched.

use crate::job::output::io_err;
use crate::job::JobError;
use crate::report::atomic;
use serde_json::json;
use std::path::{Path, PathBuf};

/// The files and folders ghm writes into a run folder, `run.json` first.
const RUN_FILES: &[&str] = &[
    "run.json",
    "summary.json",
    "trajectory.csv",
    "trajectory.incomplete.csv",
    "trajectory.png",
    "learning_curve.csv",
    "learning_curve.png",
    "policy.json",
    "value.json",
    "value_curve.csv",
    "value_curve.png",
    "checkpoint",
    "checkpoint.previous",
    "checkpoint.partial",
    "mpc",
    "labels",
    "student.json",
    "distill_curve.csv",
    "distill_curve.png",
];

/// A claimed run folder; see the [module documentation](self).
#[derive(Debug)]
pub struct RunFolder {
    dir: PathBuf,
    /// The job's spec, recorded in `run.json` (`null` for the commands that have none).
    spec: serde_json::Value,
}

/// The run files in `dir`, by name (temporary files of atomic writes included).
fn run_files(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| RUN_FILES.contains(&n.as_str()) || atomic::is_temporary(n))
        .collect();
    names.sort();
    names
}

/// Refuses `dir` if it holds a run's files and `overwrite` is not given; does not write.
/// For a command that computes long before it writes (`ghm optimum`).
pub fn check(dir: &Path, overwrite: bool) -> Result<(), JobError> {
    let found = run_files(dir);
    if found.is_empty() || overwrite {
        return Ok(());
    }
    let status = record(dir).and_then(|v| v["status"].as_str().map(String::from));
    let what = match status.as_deref() {
        Some("complete") => "the results of a complete run",
        Some("failed") => "the files of a failed run",
        Some(_) => "the files of an incomplete run (killed, or still running)",
        None => "the results of an earlier run",
    };
    Err(JobError::Spec(format!(
        "{} holds {what} ({}); pass --overwrite to replace them, or choose another --out",
        dir.display(),
        found.join(", ")
    )))
}

/// What `run.json` in `dir` records: the run's status (`running`, `complete`, `failed`)
/// and the spec it ran (`null` for runs without one); `None` without a readable `run.json`.
pub fn recorded(dir: &Path) -> Option<(String, serde_json::Value)> {
    let record = record(dir)?;
    let status = record["status"].as_str()?.to_string();
    Some((status, record["spec"].clone()))
}

/// The process that `run.json` in `dir` says held the run; `None` without one.
pub fn recorded_pid(dir: &Path) -> Option<u32> {
    u32::try_from(record(dir)?["pid"].as_u64()?).ok()
}

/// `run.json` in `dir`, parsed; `None` without a readable one.
fn record(dir: &Path) -> Option<serde_json::Value> {
    json_file(&dir.join("run.json"))
}

/// A season's `summary.json` in `dir`, parsed; `None` without a readable one.
pub fn summary(dir: &Path) -> Option<serde_json::Value> {
    json_file(&dir.join("summary.json"))
}

fn json_file(path: &Path) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(path).ok()?;
    serde_json::from_str(&text).ok()
}

impl RunFolder {
    /// Claims `dir` for a new run: refused if it holds a run's files, unless `overwrite`
    /// (which removes them first); creates it and writes `run.json` as running.
    /// `spec`, when given, is recorded in `run.json`: a study knows a finished job by it.
    pub fn claim(
        dir: &Path,
        overwrite: bool,
        spec: Option<serde_json::Value>,
    ) -> Result<RunFolder, JobError> {
        check(dir, overwrite)?;
        let found = run_files(dir);
        if !found.is_empty() {
            eprintln!("replacing the earlier run in {}", dir.display());
        }
        for name in found {
            let path = dir.join(&name);
            let removed = if path.is_dir() {
                std::fs::remove_dir_all(&path)
            } else {
                std::fs::remove_file(&path)
            };
            removed.map_err(io_err(&path))?;
        }
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let folder = RunFolder {
            dir: dir.to_path_buf(),
            spec: spec.unwrap_or(serde_json::Value::Null),
        };
        folder.mark("running", None)?;
        Ok(folder)
    }

    /// Claims `dir` to continue the run in it (a resumed training), keeping its files and
    /// the spec its `run.json` records.
    pub fn continue_in(dir: &Path) -> Result<RunFolder, JobError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let spec = recorded(dir).map_or(serde_json::Value::Null, |(_, spec)| spec);
        let folder = RunFolder {
            dir: dir.to_path_buf(),
            spec,
        };
        folder.mark("running", None)?;
        Ok(folder)
    }

    /// Claims `dir` to carry on the run in it with `spec` (which extends the one its
    /// `run.json` records: a distillation given more iterations), keeping its files.
    pub fn continue_as(dir: &Path, spec: serde_json::Value) -> Result<RunFolder, JobError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let folder = RunFolder {
            dir: dir.to_path_buf(),
            spec,
        };
        folder.mark("running", None)?;
        Ok(folder)
    }

    /// Marks the run complete: call it after the last result file is written.
    pub fn complete(self) -> Result<(), JobError> {
        self.mark("complete", None)
    }

    /// Ends the run with `result`: complete if it is `Ok`, otherwise failed with its
    /// error (the error is returned as it was; a failure to mark it is only printed).
    pub fn finish<T, E>(self, result: Result<T, E>) -> Result<T, E>
    where
        E: std::fmt::Display + From<JobError>,
    {
        match result {
            Ok(value) => {
                self.complete()?;
                Ok(value)
            }
            Err(e) => {
                if let Err(mark) = self.mark("failed", Some(&e.to_string())) {
                    eprintln!("warning: {mark}");
                }
                Err(e)
            }
        }
    }

    fn mark(&self, status: &str, error: Option<&str>) -> Result<(), JobError> {
        let path = self.dir.join("run.json");
        let record = json!({
            "status": status,
            "command": std::env::args().collect::<Vec<_>>(),
            "pid": std::process::id(),
            "error": error,
            "spec": self.spec,
        });
        let text = serde_json::to_string_pretty(&record).unwrap_or_default() + "\n";
        atomic::write(&path, text).map_err(io_err(&path))
    }
}
