//! Run folders that say what they are, with the `ghm` binary: a resumed training keeps
//! the season and settings it started with, and a training that would never learn is
//! refused.

mod common;

use common::bin::{ghm, temp_dir};
use std::path::Path;
use std::process::Command;

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("JSON")
}

#[test]
fn a_warm_up_as_long_as_the_training_is_refused() {
    let dir = temp_dir("runs-warmup");
    let d = dir.to_str().expect("utf-8");
    let (ok, err) = ghm(&[
        "train",
        "models/lettuce.ghm",
        "--steps",
        "2",
        "--warmup",
        "5",
        "--episodes",
        "2",
        "--out",
        d,
    ]);
    assert!(!ok, "a training of random warm-up only was run");
    assert!(
        err.contains("--warmup 5: not fewer than the 2 episodes"),
        "{err}"
    );
    assert!(!dir.join("summary.json").exists());
}

#[test]
fn a_resumed_training_keeps_its_season_and_refuses_other_settings() {
    let dir = temp_dir("runs-resume");
    let d = dir.to_str().expect("utf-8");
    let start = [
        "train",
        "models/lettuce.ghm",
        "--steps",
        "4",
        "--episodes",
        "2",
        "--warmup",
        "1",
        "--seed",
        "7",
        "--checkpoint-every",
        "1",
        "--out",
        d,
    ];
    let (ok, err) = ghm(&start);
    assert!(ok, "{err}");
    let before = summary(&dir);
    assert_eq!(before["episode_steps"], 4);
    // Without the season options: the recorded season, not the default 40 days.
    let (ok, err) = ghm(&["train", "models/lettuce.ghm", "--resume", d]);
    assert!(ok, "{err}");
    let after = summary(&dir);
    assert_eq!(after["episode_steps"], 4, "{after}");
    assert_eq!(after["weather"], before["weather"]);
    // Options that say otherwise are refused, naming the option.
    for (option, value) in [
        ("--episodes", "5"),
        ("--warmup", "0"),
        ("--seed", "8"),
        ("--days", "3"),
        ("--steps", "8"),
    ] {
        let (ok, err) = ghm(&["train", "models/lettuce.ghm", "--resume", d, option, value]);
        assert!(!ok, "{option} {value} was accepted");
        assert!(
            err.contains(option) || err.contains("season-length option"),
            "{option}: {err}"
        );
    }
    // The same values as recorded are not a conflict.
    let (ok, err) = ghm(&[
        "train",
        "models/lettuce.ghm",
        "--resume",
        d,
        "--steps",
        "4",
        "--episodes",
        "2",
    ]);
    assert!(ok, "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn run_status(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("run.json")).expect("run.json");
    serde_json::from_str(&text).expect("JSON")
}

/// The result files of a season in `dir`, by name, hidden ones included.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("run folder")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// A season that fails in a folder of an earlier run leaves none of the earlier files
/// beside its own, and its rows under a name that says they are incomplete; a folder of
/// another run is refused without --overwrite.
#[test]
fn a_failed_run_does_not_leave_its_rows_beside_an_older_summary() {
    let dir = temp_dir("runs-failed");
    let d = dir.to_str().expect("utf-8");
    let season = ["simulate", "models/lettuce.ghm", "--steps", "4", "--out", d];
    let (ok, err) = ghm(&season);
    assert!(ok, "{err}");
    assert_eq!(run_status(&dir)["status"], "complete");
    assert_eq!(
        names(&dir),
        [
            "run.json",
            "summary.json",
            "trajectory.csv",
            "trajectory.png"
        ]
    );
    // A second run into the same folder is refused, saying what is there.
    let (ok, err) = ghm(&season);
    assert!(!ok, "a second run wrote over the first");
    assert!(
        err.contains("complete run") && err.contains("--overwrite"),
        "{err}"
    );
    // Inputs for 2 of 4 steps: the season fails at step 2.
    let inputs = std::env::temp_dir().join(format!("ghm-runs-inputs-{}.csv", std::process::id()));
    std::fs::write(
        &inputs,
        "time_s,co2_supply,ventilation,heating\n0,0,1,40\n900,0,1,40\n",
    )
    .expect("write inputs");
    let (ok, err) = ghm(&[
        "simulate",
        "models/lettuce.ghm",
        "--steps",
        "4",
        "--inputs",
        inputs.to_str().expect("utf-8"),
        "--overwrite",
        "--out",
        d,
    ]);
    assert!(!ok, "the season should fail at step 2");
    assert!(err.contains("replacing"), "{err}");
    assert_eq!(names(&dir), ["run.json", "trajectory.incomplete.csv"]);
    let status = run_status(&dir);
    assert_eq!(status["status"], "failed");
    assert!(status["error"].as_str().is_some_and(|e| !e.is_empty()));
    let rows = std::fs::read_to_string(dir.join("trajectory.incomplete.csv")).expect("rows");
    assert_eq!(rows.lines().count(), 1 + 2);
    let (ok, err) = ghm(&season);
    assert!(!ok && err.contains("failed run"), "{err}");
    let _ = std::fs::remove_file(&inputs);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A run killed halfway leaves a folder that says so: `run.json` still "running", no
/// summary, and no `trajectory.csv` that would look like a shorter valid run.
#[test]
fn a_killed_run_leaves_a_folder_that_says_so() {
    let dir = temp_dir("runs-killed");
    let d = dir.to_str().expect("utf-8");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(["mpc", "models/lettuce.ghm", "--days", "40", "--out", d])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("start ghm");
    let started = std::time::Instant::now();
    while !dir.join("run.json").exists() && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    child.kill().expect("kill ghm");
    let _ = child.wait();
    assert_eq!(run_status(&dir)["status"], "running");
    let left = names(&dir);
    assert!(
        !left
            .iter()
            .any(|n| n == "summary.json" || n == "trajectory.csv"),
        "{left:?}"
    );
    let (ok, err) = ghm(&["simulate", "models/lettuce.ghm", "--steps", "2", "--out", d]);
    assert!(!ok && err.contains("incomplete run"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
