//! The `ghm` binary end to end: outputs written, clear errors for bad files and arguments.

use std::path::PathBuf;
use std::process::Command;

fn ghm(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_ghm"))
        .args(args)
        .output()
        .expect("run ghm");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ghm-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

#[test]
fn check_prints_summary_and_verifies_derivatives() {
    let (ok, out, err) = ghm(&[
        "check",
        "models/lettuce.ghm",
        "--verify-derivatives",
        "--points",
        "3",
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("states       (4)"), "{out}");
    assert!(out.contains("after sharing"));
    assert!(out.contains("derivatives OK"));
}

#[test]
fn simulate_writes_trajectory_summary_and_plot() {
    let dir = temp_dir("sim");
    let d = dir.to_str().expect("utf-8 temp path");
    let (ok, out, err) = ghm(&[
        "simulate",
        "models/lettuce.ghm",
        "--days",
        "2",
        "--inputs",
        "const:0.6,1,40",
        "--out",
        d,
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("EPI"), "{out}");
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).expect("trajectory.csv");
    assert_eq!(csv.lines().count(), 1 + 96);
    assert!(csv.starts_with("k,time_h,x_dry_weight"));
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("summary.json")).expect("summary.json"),
    )
    .expect("JSON");
    assert_eq!(summary["metrics"]["steps"], 96);
    assert_eq!(summary["model_sha256"].as_str().map(str::len), Some(64));
    let png = std::fs::read(dir.join("trajectory.png")).expect("trajectory.png");
    assert_eq!(&png[..4], b"\x89PNG");
}

#[test]
fn bad_model_reports_location_and_fails() {
    let dir = temp_dir("bad");
    std::fs::create_dir_all(&dir).expect("temp dir");
    let f = dir.join("bad.ghm");
    std::fs::write(&f, "state x = 1\nder x = -y\nsample 1\n").expect("write");
    let (ok, _, err) = ghm(&["check", f.to_str().expect("utf-8")]);
    assert!(!ok);
    assert!(err.contains("bad.ghm:2:10"), "{err}");
    assert!(err.contains("unknown name `y`"), "{err}");
    assert!(!err.contains("panicked"));
}

#[test]
fn bad_arguments_and_files_give_messages_not_panics() {
    let cases: &[&[&str]] = &[
        &["check", "no/such/file.ghm"],
        &["simulate", "models/lettuce.ghm", "--inputs", "const:1,2"],
        &["simulate", "models/lettuce.ghm", "--inputs", "const:a,b,c"],
        &["simulate", "models/lettuce.ghm", "--weather", "no/such.csv"],
        &["simulate", "models/lettuce.ghm", "--knmi", "no/such.txt"],
        &["simulate", "models/lettuce.ghm", "--steps", "0"],
        &["simulate", "models/lettuce.ghm", "--uncertainty", "2"],
        &[
            "simulate",
            "models/lettuce.ghm",
            "--inputs",
            "no/such-inputs.csv",
        ],
    ];
    for args in cases {
        let (ok, _, err) = ghm(args);
        assert!(!ok, "{args:?} should fail");
        assert!(
            err.starts_with("error") || err.contains("error"),
            "{args:?}: {err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn mpc_runs_on_builtin_weather_and_reports_solver_statistics() {
    let dir = temp_dir("mpc");
    let d = dir.to_str().expect("utf-8 temp path");
    let (ok, out, err) = ghm(&[
        "mpc",
        "models/lettuce.ghm",
        "--days",
        "1",
        "--horizon",
        "1h",
        "--out",
        d,
    ]);
    assert!(ok, "{err}");
    assert!(
        out.contains("cumulative reward") && out.contains("failed solves"),
        "{out}"
    );
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).expect("trajectory.csv");
    let header = csv.lines().next().unwrap_or_default();
    for column in ["solve_ms", "iterations", "status", "fallback"] {
        assert!(header.contains(column), "{header}");
    }
    assert!(csv
        .lines()
        .skip(1)
        .all(|l| l.contains(",optimal,") || l.contains(",acceptable,") || l.contains("fallback")));
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("summary.json")).expect("summary.json"),
    )
    .expect("JSON");
    assert_eq!(summary["horizon_steps"], 2);
    let solve = &summary["metrics"]["solve"];
    assert!(
        solve["median_ms"].as_f64().is_some_and(|v| v > 0.0),
        "{solve}"
    );
    assert!(solve["max_ms"].as_f64() >= solve["p95_ms"].as_f64());
    assert_eq!(solve["failed_solves"], 0, "{solve}");
}

#[test]
fn mpc_rejects_bad_horizons_with_a_message() {
    for bad in ["0h", "45min", "soon"] {
        let (ok, _, err) = ghm(&["mpc", "models/lettuce.ghm", "--horizon", bad]);
        assert!(!ok);
        assert!(err.contains("--horizon"), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn train_checkpoints_resumes_and_ships_a_policy_that_policy_runs() {
    let dir = temp_dir("train");
    let d = dir.to_str().expect("utf-8 temp path");
    let short = ["--days", "0.5", "--warmup", "1", "--checkpoint-every", "1"];
    let mut args = vec!["train", "models/lettuce.ghm", "--episodes", "2", "--out", d];
    args.extend(short);
    let (ok, out, err) = ghm(&args);
    assert!(ok, "{err}");
    assert!(out.contains("episode   2: reward"), "{out}");
    let curve = std::fs::read_to_string(dir.join("learning_curve.csv")).expect("curve");
    assert_eq!(curve.lines().count(), 1 + 2);
    assert!(dir.join("learning_curve.png").is_file());
    assert!(dir.join("checkpoint/state.json").is_file());
    // A second training into the same folder is refused with advice.
    let (ok, _, err) = ghm(&args);
    assert!(!ok && err.contains("--resume"), "{err}");
    // Resuming a finished training adds nothing; the policy runs a season.
    let mut resume = vec!["train", "models/lettuce.ghm", "--resume", d];
    resume.extend(short);
    let (ok, out, err) = ghm(&resume);
    assert!(ok && out.contains("resuming"), "{out}{err}");
    let season = temp_dir("policy");
    let s = season.to_str().expect("utf-8 temp path");
    let (ok, out, err) = ghm(&[
        "policy",
        "models/lettuce.ghm",
        "--agent",
        d,
        "--days",
        "1",
        "--out",
        s,
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("cumulative reward"), "{out}");
    assert!(season.join("trajectory.csv").is_file());
    let (ok, _, err) = ghm(&["policy", "models/lettuce.ghm", "--agent", "no/such/agent"]);
    assert!(!ok && err.contains("no policy at"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
    let _ = std::fs::remove_dir_all(&season);
}

#[test]
fn value_and_rlmpc_run_end_to_end_with_the_expert_guide() {
    let value = temp_dir("value");
    let v = value.to_str().expect("utf-8 temp path");
    let (ok, out, err) = ghm(&[
        "value",
        "models/lettuce.ghm",
        "--guide",
        "expert",
        "--trajectories",
        "20",
        "--epochs",
        "2",
        "--days",
        "1",
        "--out",
        v,
    ]);
    assert!(ok, "{err}");
    assert!(out.contains("value at the season start"), "{out}");
    assert!(value.join("value.json").is_file() && value.join("value_curve.png").is_file());
    let run = temp_dir("rlmpc");
    let r = run.to_str().expect("utf-8 temp path");
    let (ok, out, err) = ghm(&[
        "rlmpc",
        "models/lettuce.ghm",
        "--guide",
        "expert",
        "--value",
        v,
        "--days",
        "0.5",
        "--horizon",
        "1h",
        "--compare",
        "--out",
        r,
    ]);
    assert!(ok, "{err}");
    assert!(
        out.contains("RL-MPC (expert)") && out.contains("MPC "),
        "{out}"
    );
    let csv = std::fs::read_to_string(run.join("trajectory.csv")).expect("trajectory.csv");
    assert!(csv
        .lines()
        .next()
        .unwrap_or("")
        .ends_with(",terminal_region"));
    assert!(csv.contains(",binding") || csv.contains(",inactive"));
    assert!(run.join("mpc/summary.json").is_file());
    let (ok, _, err) = ghm(&[
        "rlmpc",
        "models/lettuce.ghm",
        "--guide",
        "expert",
        "--value",
        "nowhere",
    ]);
    assert!(!ok && err.contains("no value network"), "{err}");
    let _ = std::fs::remove_dir_all(&value);
    let _ = std::fs::remove_dir_all(&run);
}
