//! A season killed halfway continues where it stopped (`ghm mpc --resume`, a study run
//! again): its steps are read back from the temporary trajectory it was streaming and
//! replayed bit for bit, and the controller decides the rest. Built-in model and weather.
//!
//! A kill is staged rather than timed: a complete run's `trajectory.csv` is cut back to
//! the rows a killed run would have flushed (the last one cut in the middle), renamed to
//! the temporary name a run streams into, and `run.json` says `running` for a process that
//! is gone.

mod common;

use common::bin::temp_dir;
use ghm::job::{
    resume_season_job, run_season_job, ControllerSpec, JobError, JobOptions, MpcSpec, RunSpec,
};
use std::path::{Path, PathBuf};

fn spec(controller: ControllerSpec, uncertainty: f64) -> RunSpec {
    common::lettuce_day(controller, uncertainty, 3)
}

const QUIET: JobOptions = JobOptions {
    overwrite: true,
    verbose: false,
};

/// The rows of `trajectory.csv` in `dir`, without the solve time (the one column a replay
/// copies rather than recomputes, rounded as written).
fn rows(dir: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let timing = header.iter().position(|h| *h == "solve_ms").unwrap();
    text.lines()
        .map(|line| {
            let mut fields: Vec<&str> = line.split(',').collect();
            fields.remove(timing);
            fields.join(",")
        })
        .collect()
}

/// Turns the complete run in `dir` into one killed after `kept` steps: the rows cut back
/// (and the next one cut in half) in the temporary file, `run.json` saying `running`.
fn stage_kill(dir: &Path, spec: &RunSpec, kept: usize) -> PathBuf {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let cut = &lines[kept + 1][..lines[kept + 1].len() / 2];
    let partial = dir.join(".trajectory.4000000000.partial.csv");
    std::fs::write(&partial, format!("{}\n{cut}", lines[..=kept].join("\n"))).unwrap();
    for name in ["trajectory.csv", "summary.json", "trajectory.png"] {
        std::fs::remove_file(dir.join(name)).unwrap();
    }
    let record = serde_json::json!({
        "status": "running",
        "pid": 4_000_000_000u32,
        "spec": spec,
    });
    std::fs::write(dir.join("run.json"), record.to_string()).unwrap();
    partial
}

/// The column `name`'s index in the header of the CSV `text`.
fn column(text: &str, name: &str) -> usize {
    text.lines()
        .next()
        .unwrap()
        .split(',')
        .position(|h| h == name)
        .unwrap()
}

/// Sets the iterations logged at `step` in the trajectory at `path`.
fn mark_iterations(path: &Path, step: usize, value: usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let at = column(&text, "iterations");
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, line)| {
            let mut fields: Vec<String> = line.split(',').map(String::from).collect();
            if i == step + 1 {
                fields[at] = value.to_string();
            }
            fields.join(",")
        })
        .collect();
    std::fs::write(
        path,
        lines.join("\n") + if text.ends_with('\n') { "\n" } else { "" },
    )
    .unwrap();
}

/// The iterations logged at `step` in `dir`'s trajectory.
fn iterations(dir: &Path, step: usize) -> usize {
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).unwrap();
    let at = column(&text, "iterations");
    let line = text.lines().nth(step + 1).unwrap();
    line.split(',').nth(at).unwrap().parse().unwrap()
}

/// A controller without memory (the expert) on a perturbed plant (its parameters drawn
/// again in the replay): the resumed season is the uninterrupted one to the last bit.
#[test]
fn a_killed_season_resumes_to_the_same_trajectory() {
    let spec = spec(ControllerSpec::Expert, 0.2);
    let (whole, cut) = (temp_dir("resume-whole"), temp_dir("resume-cut"));
    run_season_job(&spec, &whole, &QUIET).unwrap();
    run_season_job(&spec, &cut, &QUIET).unwrap();
    let partial = stage_kill(&cut, &spec, 20);
    mark_iterations(&partial, 3, 777);
    let resumed = resume_season_job(&spec, &cut, &QUIET).unwrap();
    // The replayed steps' records come from the stopped run's file…
    assert_eq!(iterations(&cut, 3), 777);
    mark_iterations(&cut.join("trajectory.csv"), 3, 0);
    // …and everything else is the uninterrupted season's.
    assert_eq!(rows(&cut), rows(&whole));
    assert_eq!(resumed.metrics.steps, 48);
    assert!(!partial.exists(), "the stopped run's file was left behind");
    let (status, _) = ghm::job::folder::recorded(&cut).unwrap();
    assert_eq!(status, "complete");
    for dir in [whole, cut] {
        std::fs::remove_dir_all(dir).unwrap();
    }
}

/// MPC resumes cold: the replayed steps are the stopped run's, the rest its own.
#[test]
fn a_killed_mpc_season_replays_its_steps_and_decides_the_rest() {
    let mpc = ControllerSpec::Mpc(MpcSpec {
        horizon: "1h".into(),
        ..MpcSpec::default()
    });
    let spec = spec(mpc, 0.0);
    let (whole, cut) = (temp_dir("resume-mpc-whole"), temp_dir("resume-mpc-cut"));
    run_season_job(&spec, &whole, &QUIET).unwrap();
    run_season_job(&spec, &cut, &QUIET).unwrap();
    stage_kill(&cut, &spec, 30);
    let resumed = resume_season_job(&spec, &cut, &QUIET).unwrap();
    assert_eq!(resumed.metrics.steps, 48);
    assert_eq!(resumed.metrics.solve.failed_solves, 0);
    let (a, b) = (rows(&whole), rows(&cut));
    assert_eq!(a.len(), b.len());
    // The header and the 30 replayed steps, to the last bit.
    assert_eq!(a[..=30], b[..=30]);
    for dir in [whole, cut] {
        std::fs::remove_dir_all(dir).unwrap();
    }
}

/// What cannot be resumed is refused with the reason: a run of another model, or a
/// logged state the replay does not reach (the model or weather changed). Without a
/// stopped run, `resume` runs the season afresh.
#[test]
fn what_cannot_be_resumed_is_refused_with_the_reason() {
    let expert = spec(ControllerSpec::Expert, 0.0);
    let dir = temp_dir("resume-refused");
    let fresh = resume_season_job(&expert, &dir, &QUIET).unwrap();
    assert_eq!(fresh.metrics.steps, 48);

    let partial = stage_kill(&dir, &expert, 10);
    let text = std::fs::read_to_string(&partial).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // Step 5's first state (the column after `k` and `time_h`), moved.
    let mut fields: Vec<String> = lines[6].split(',').map(String::from).collect();
    let moved: f64 = fields[2].parse::<f64>().unwrap() * 1.001;
    fields[2] = format!("{moved:e}");
    lines[6] = fields.join(",");
    std::fs::write(&partial, lines.join("\n")).unwrap();
    let e = resume_season_job(&expert, &dir, &QUIET).unwrap_err();
    assert!(
        e.to_string()
            .contains("step 5: replaying the stopped run gives"),
        "{e}"
    );

    // Another model's columns.
    let header_moved = text.replacen("x_", "x_other_", 1);
    std::fs::write(&partial, header_moved).unwrap();
    let record = serde_json::json!({"status": "running", "pid": 4_000_000_000u32, "spec": expert});
    std::fs::write(dir.join("run.json"), record.to_string()).unwrap();
    let e = resume_season_job(&expert, &dir, &QUIET).unwrap_err();
    assert!(matches!(e, JobError::Resume { .. }), "{e}");
    assert!(e.to_string().contains("the model changed"), "{e}");
    assert!(e.refuses_resume());

    // Killed before its header was flushed: nothing to replay, the whole season runs.
    std::fs::write(&partial, "").unwrap();
    std::fs::write(dir.join("run.json"), record.to_string()).unwrap();
    let whole = resume_season_job(&expert, &dir, &QUIET).unwrap();
    assert_eq!(whole.metrics.steps, 48);
    assert!(!partial.exists());
    std::fs::remove_dir_all(dir).unwrap();
}
