//! The `ghm` binary end to end: outputs written, clear errors for bad files and arguments.

use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
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

/// A CSV file as its header and rows of fields (ghm writes no quoted fields).
struct Table {
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn read(path: &Path) -> Table {
        let text =
            std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = text
            .lines()
            .map(|l| l.split(',').map(String::from).collect());
        let header: Vec<String> = lines.next().unwrap_or_default();
        let rows: Vec<Vec<String>> = lines.collect();
        for row in &rows {
            assert_eq!(row.len(), header.len(), "{row:?}");
        }
        Table { header, rows }
    }

    /// The fields of column `name`, one per row.
    fn column(&self, name: &str) -> Vec<&str> {
        let i = (self.header.iter().position(|h| h == name))
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header));
        self.rows.iter().map(|r| r[i].as_str()).collect()
    }

    /// Column `name` as numbers.
    fn numbers(&self, name: &str) -> Vec<f64> {
        let parse = |v: &str| {
            v.parse()
                .unwrap_or_else(|_| panic!("{name}: {v:?} is not a number"))
        };
        self.column(name).into_iter().map(parse).collect()
    }
}

fn summary(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("JSON")
}

/// `a` and `b` agree to `rtol` of the larger (sums of the same terms in another order).
fn close(a: f64, b: f64, rtol: f64) -> bool {
    (a - b).abs() <= rtol * a.abs().max(b.abs())
}

/// SHA-256 of a text, in hex.
fn sha256(text: &str) -> String {
    let digest = Sha256::digest(text.as_bytes());
    digest.iter().map(|b| format!("{b:02x}")).collect()
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
    let summary = summary(&dir);
    assert_eq!(summary["metrics"]["steps"], 96);
    let text = std::fs::read_to_string("models/lettuce.ghm").expect("the model file");
    assert_eq!(summary["model_sha256"], sha256(&text).as_str());
    let png = std::fs::read(dir.join("trajectory.png")).expect("trajectory.png");
    assert_eq!(&png[..4], b"\x89PNG");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `model_sha256` is the SHA-256 of the model file: the same file gives the same hash, a
/// changed price another one.
#[test]
fn model_hash_follows_the_model_file() {
    let dir = temp_dir("hash");
    std::fs::create_dir_all(&dir).expect("temp dir");
    let original = std::fs::read_to_string("models/lettuce.ghm").expect("the model file");
    let changed = original.replacen("= 20.93 ", "= 21.93 ", 1);
    assert_ne!(
        changed, original,
        "the crop price moved in models/lettuce.ghm"
    );
    let mut hashes = Vec::new();
    for (name, text) in [("a", &original), ("b", &original), ("c", &changed)] {
        let model = dir.join(format!("{name}.ghm"));
        std::fs::write(&model, text).expect("write");
        let out_dir = dir.join(name);
        let (model, out) = (
            model.to_str().expect("utf-8"),
            out_dir.to_str().expect("utf-8"),
        );
        let (ok, _, err) = ghm(&["simulate", model, "--steps", "1", "--out", out]);
        assert!(ok, "{err}");
        let hash = summary(&out_dir)["model_sha256"].as_str().map(String::from);
        assert_eq!(hash.as_deref(), Some(sha256(text).as_str()), "{name}");
        hashes.push(hash);
    }
    assert_eq!(hashes[0], hashes[1]);
    assert_ne!(hashes[0], hashes[2]);
    let _ = std::fs::remove_dir_all(&dir);
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

/// Each bad argument or missing file gets its own message, naming what is wrong (a
/// generic failure that happens to print "error" would not do).
#[test]
fn bad_arguments_and_files_give_messages_not_panics() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["check", "no/such/file.ghm"],
            "cannot read model file `no/such/file.ghm`",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--inputs", "const:1,2"],
            "error: --inputs const:1,2: gives 2 values; the model has 3 inputs (co2_supply, ventilation, heating)",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--inputs", "const:a,b,c"],
            "error: --inputs const:a,b,c: expected 3 comma-separated numbers",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--weather", "no/such.csv"],
            "error: no/such.csv: cannot read",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--knmi", "no/such.txt"],
            "error: no/such.txt: cannot read",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--steps", "0"],
            "error: --steps 0: the season must have at least one step",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--rules"],
            "error: the rules controller needs a `rule` on every input of model `lettuce`; these have none: co2_supply, ventilation, heating",
        ),
        (
            &["simulate", "models/lettuce.ghm", "--uncertainty", "2"],
            "error: --uncertainty 2: must be in [0, 1)",
        ),
        (
            &[
                "simulate",
                "models/lettuce.ghm",
                "--inputs",
                "no/such-inputs.csv",
            ],
            "error: no/such-inputs.csv: cannot read",
        ),
    ];
    for (args, message) in cases {
        let (ok, _, err) = ghm(args);
        assert!(!ok, "{args:?} should fail");
        assert!(err.contains(message), "{args:?}: {err}");
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
    let table = Table::read(&dir.join("trajectory.csv"));
    assert_eq!(table.rows.len(), 48);
    // No solve failed on this day, so every step's status is a success; a fallback is
    // only ever a cold start after a failed warm solve, which then succeeded.
    let status = table.column("status");
    let fallback = table.column("fallback");
    for (k, (status, fallback)) in status.iter().zip(&fallback).enumerate() {
        assert!(
            matches!(*status, "optimal" | "acceptable"),
            "step {k}: {status}"
        );
        assert!(
            matches!(*fallback, "" | "cold_start"),
            "step {k}: {fallback}"
        );
    }
    let summary = summary(&dir);
    assert_eq!(summary["horizon_steps"], 2);
    // The interior point's restart: the shifted plan, multipliers and barrier afresh.
    assert_eq!(summary["warm_start"], "primal");
    let solve = &summary["metrics"]["solve"];
    assert!(
        solve["median_ms"].as_f64().is_some_and(|v| v > 0.0),
        "{solve}"
    );
    assert!(solve["max_ms"].as_f64() >= solve["p95_ms"].as_f64());
    assert_eq!(solve["failed_solves"], 0, "{solve}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--warm-start primal-dual` restarts each step from the shifted plan and its
/// multipliers instead, `primal-multipliers` from the shifted plan and its constraint
/// multipliers, `primal-dual-capped` the primal-dual way for a few iterations and then
/// from the shifted plan: each run says so in its summary, solves every step, and lands on the same
/// season as the default restart.
#[test]
fn mpc_takes_the_other_restarts_on_request() {
    let reward_with = |restart: Option<&str>| {
        let dir = temp_dir(&format!("restart-{}", restart.unwrap_or("default")));
        let d = dir.to_str().expect("utf-8 temp path");
        let mut args = vec![
            "mpc",
            "models/lettuce.ghm",
            "--days",
            "1",
            "--horizon",
            "2h",
        ];
        args.extend(restart.map(|r| ["--warm-start", r]).into_iter().flatten());
        args.extend(["--out", d]);
        let (ok, _, err) = ghm(&args);
        assert!(ok, "{err}");
        let summary = summary(&dir);
        assert_eq!(
            summary["warm_start"],
            restart.unwrap_or("primal"),
            "{summary}"
        );
        assert_eq!(summary["metrics"]["solve"]["failed_solves"], 0, "{summary}");
        let reward = summary["metrics"]["cumulative_reward"].as_f64();
        let _ = std::fs::remove_dir_all(&dir);
        reward.expect("cumulative reward")
    };
    let primal = reward_with(None);
    for restart in ["primal-dual", "primal-multipliers", "primal-dual-capped"] {
        let other = reward_with(Some(restart));
        assert!(
            (primal - other).abs() <= 1e-4,
            "{restart}: {primal} vs {other}"
        );
    }
}

/// The figures of `summary.json` are those of the rows of `trajectory.csv`: the season's
/// reward, EPI and penalties are the sums of the step columns (written to full precision),
/// the last cumulative reward is the season's, and the solver figures count the rows. The
/// plant's parameters are drawn 10 % off the controller's, so that every band is left and
/// its penalty column counts.
#[test]
fn mpc_summary_agrees_with_its_trajectory() {
    let dir = temp_dir("agree");
    let d = dir.to_str().expect("utf-8 temp path");
    let (ok, _, err) = ghm(&[
        "mpc",
        "models/lettuce.ghm",
        "--days",
        "2",
        "--horizon",
        "1h",
        "--uncertainty",
        "0.1",
        "--out",
        d,
    ]);
    assert!(ok, "{err}");
    let table = Table::read(&dir.join("trajectory.csv"));
    let m = &summary(&dir)["metrics"];
    let number = |key: &str| m[key].as_f64().unwrap_or_else(|| panic!("{key}: {m}"));
    assert_eq!(m["steps"], table.rows.len());
    let sum = |name: &str| table.numbers(name).iter().sum::<f64>();
    let reward = sum("reward");
    assert!(
        close(reward, number("cumulative_reward"), 1e-12),
        "{reward} vs {m}"
    );
    let last = *table.numbers("cumulative_reward").last().expect("rows");
    assert!(
        close(last, number("cumulative_reward"), 1e-12),
        "{last} vs {m}"
    );
    assert!(close(sum("economic"), number("epi"), 1e-12), "{m}");
    let bands = m["bands"].as_array().expect("bands");
    let mut penalty = 0.0;
    for band in bands {
        let name = band["output"].as_str().expect("band output");
        let column = sum(&format!("penalty_{name}"));
        let recorded = band["penalty"].as_f64().expect("band penalty");
        assert!(recorded > 0.0, "{name}: {band}");
        assert!(close(column, recorded, 1e-12), "{name}: {column} vs {band}");
        penalty += column;
    }
    assert!(close(penalty, number("total_penalty"), 1e-12), "{m}");
    assert!(close(reward, sum("economic") - penalty, 1e-9), "{m}");
    let solve = &m["solve"];
    let iterations = table.numbers("iterations");
    let mean = iterations.iter().sum::<f64>() / iterations.len() as f64;
    let recorded = solve["mean_iterations"].as_f64().expect("mean_iterations");
    assert!(close(mean, recorded, 1e-12), "{mean} vs {solve}");
    let failed = (table.column("status").iter())
        .filter(|s| !matches!(**s, "optimal" | "acceptable"))
        .count();
    let fallbacks = table
        .column("fallback")
        .iter()
        .filter(|f| !f.is_empty())
        .count();
    assert_eq!(solve["failed_solves"], failed, "{solve}");
    assert_eq!(solve["fallbacks"], fallbacks, "{solve}");
    let times = table.numbers("solve_ms");
    let max = times.iter().copied().fold(0.0, f64::max);
    let recorded = solve["max_ms"].as_f64().expect("max_ms");
    assert!((max - recorded).abs() <= 1e-4, "{max} vs {solve}"); // the CSV rounds to 0.1 µs
    let _ = std::fs::remove_dir_all(&dir);
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
    args.extend(["--gamma", "0.99", "--batch-size", "64"]);
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
    // The checkpoint keeps the discount, the batch and the learning rate it was trained
    // with.
    for (option, value) in [
        ("--gamma", "0.9"),
        ("--batch-size", "128"),
        ("--learning-rate", "0.001"),
    ] {
        let mut other = resume.clone();
        other.extend([option, value]);
        let (ok, _, err) = ghm(&other);
        assert!(
            !ok && err.contains(&format!("{option} {value} conflicts")),
            "{err}"
        );
    }
    let (ok, _, err) = ghm(&["train", "models/lettuce.ghm", "--gamma", "1.5"]);
    assert!(
        !ok && err.contains("gamma") && err.contains("(0, 1]"),
        "{err}"
    );
    let (ok, _, err) = ghm(&["train", "models/lettuce.ghm", "--learning-rate", "0"]);
    assert!(
        !ok && err.contains("--learning-rate 0") && err.contains("positive"),
        "{err}"
    );
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

/// `ghm value MODEL --guide GUIDE` (a small fit: `trajectories` roll-outs of a day, two
/// epochs) into `value`, then `ghm rlmpc` guided by it and its value network over `days`
/// at a 1 h horizon into `run`, with `extra` options; both must succeed. Returns rlmpc's
/// standard output.
fn value_then_rlmpc(
    model: &str,
    guide: &str,
    trajectories: &str,
    (value, run): (&Path, &Path),
    days: &str,
    extra: &[&str],
) -> String {
    let v = value.to_str().expect("utf-8 temp path");
    let (ok, out, err) = ghm(&[
        "value",
        model,
        "--guide",
        guide,
        "--trajectories",
        trajectories,
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
    let r = run.to_str().expect("utf-8 temp path");
    let mut args = vec![
        "rlmpc",
        model,
        "--guide",
        guide,
        "--value",
        v,
        "--days",
        days,
        "--horizon",
        "1h",
        "--out",
        r,
    ];
    args.extend_from_slice(extra);
    let (ok, out, err) = ghm(&args);
    assert!(ok, "{err}");
    out
}

#[test]
fn value_saves_the_points_it_fitted_when_asked() {
    let value = temp_dir("value-data");
    let v = value.to_str().expect("utf-8 temp path");
    let (ok, _, err) = ghm(&[
        "value",
        "models/lettuce.ghm",
        "--guide",
        "expert",
        "--trajectories",
        "5",
        "--epochs",
        "1",
        "--days",
        "1",
        "--save-data",
        "--out",
        v,
    ]);
    assert!(ok, "{err}");
    let data = std::fs::read_to_string(value.join("value_data.csv")).expect("value_data.csv");
    let summary = summary(&value);
    let mut lines = data.lines();
    let state = summary["state"].as_str().expect("the state's name");
    assert_eq!(lines.next(), Some(format!("{state},step,return").as_str()));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().expect("a number")).collect())
        .collect();
    assert_eq!(Some(rows.len() as u64), summary["points"].as_u64());
    assert!(rows
        .iter()
        .all(|r| r.len() == 3 && r.iter().all(|v| v.is_finite())));
    // Steps of a day's season at 30 minutes: 0 to 47.
    assert!(rows
        .iter()
        .all(|r| r[1] >= 0.0 && r[1] < 48.0 && r[1].fract() == 0.0));
}

#[test]
fn value_and_rlmpc_run_end_to_end_with_the_expert_guide() {
    let (value, run) = (temp_dir("value"), temp_dir("rlmpc"));
    let out = value_then_rlmpc(
        "models/lettuce.ghm",
        "expert",
        "20",
        (&value, &run),
        "0.5",
        &["--compare"],
    );
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
    assert!(err.contains("ghm value --guide expert"), "{err}");
    let _ = std::fs::remove_dir_all(&value);
    let _ = std::fs::remove_dir_all(&run);
}

/// The model's own rules as RL-guided MPC's guide (`--guide rules`): the lamp clock's
/// thermostat rolled out for the value fit and for the terminal region, as the expert is
/// for lettuce; a model without rules is refused with the inputs that have none.
#[test]
fn value_and_rlmpc_follow_the_models_rules_as_their_guide() {
    let (value, run) = (temp_dir("value-rules"), temp_dir("rlmpc-rules"));
    let out = value_then_rlmpc(
        "models/lamp-clock.ghm",
        "rules",
        "16",
        (&value, &run),
        "0.25",
        &[],
    );
    assert!(out.contains("rlmpc[rules]"), "{out}");
    let v = value.to_str().expect("utf-8 temp path");
    let (ok, _, err) = ghm(&[
        "value",
        "models/lettuce.ghm",
        "--guide",
        "rules",
        "--out",
        v,
        "--overwrite",
    ]);
    assert!(!ok && err.contains("have none"), "{err}");
    let _ = std::fs::remove_dir_all(&value);
    let _ = std::fs::remove_dir_all(&run);
}

/// `ghm simulate --rules`: the model's own rules decide. The lamp clock's thermostat heats
/// fully below 18.5 °C and not at all above, so a cold season's heating column follows
/// the air temperature, within the input's rate limit.
#[test]
fn simulate_with_the_models_rules_follows_them() {
    let dir = temp_dir("rules");
    let out = dir.to_str().expect("utf-8");
    let (ok, _, err) = ghm(&[
        "simulate",
        "models/lamp-clock.ghm",
        "--rules",
        "--days",
        "1",
        "--out",
        out,
    ]);
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(dir.join("trajectory.csv")).expect("trajectory");
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().expect("header").split(',').collect();
    let at = |name: &str| header.iter().position(|c| *c == name).expect(name);
    let (temp, heating) = (at("x_temp_air"), at("u_heating"));
    let mut previous = 50.0; // the input's `start`
    for row in rows {
        let v: Vec<f64> = row
            .split(',')
            .map(|f| f.parse().unwrap_or(f64::NAN))
            .collect();
        let rule = 150.0 * (0.5 + 0.5 * (2.0 * (18.5 - v[temp])).tanh());
        let expected = rule
            .clamp(previous - 30.0, previous + 30.0)
            .clamp(0.0, 150.0);
        assert!((v[heating] - expected).abs() < 1e-9, "{row}");
        previous = v[heating];
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn completions_cover_every_command_and_refuse_an_unknown_shell() {
    // The commands `ghm --help` lists, each completed by the bash script with its flags.
    let (ok, help, _) = ghm(&["--help"]);
    assert!(ok);
    let commands: Vec<&str> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(
        commands.contains(&"mpc") && commands.contains(&"completions"),
        "{commands:?}"
    );
    let (ok, bash, err) = ghm(&["completions", "bash"]);
    assert!(ok, "{err}");
    for command in &commands {
        assert!(
            bash.contains(&format!("ghm__subcmd__{command}")),
            "bash lacks {command}"
        );
    }
    assert!(bash.contains("--warm-start"), "bash lacks mpc's flags");
    let (ok, zsh, _) = ghm(&["completions", "zsh"]);
    assert!(ok && zsh.starts_with("#compdef ghm"), "{zsh:.40}");
    let (ok, _, err) = ghm(&["completions", "tcsh"]);
    assert!(!ok);
    assert!(
        err.contains("invalid value 'tcsh'") && err.contains("bash"),
        "{err}"
    );
}

#[test]
fn version_names_the_package_version() {
    let (ok, out, _) = ghm(&["--version"]);
    assert!(ok);
    assert_eq!(out.trim(), format!("ghm {}", env!("CARGO_PKG_VERSION")));
}

/// `ghm import venlo` on an excerpt that ghm writes itself (a day of 5-minute rows as a
/// compressed MAT-file, as the paper's authors publish the Venlo weather): the data folder
/// it writes is one a season runs on, and a file that is not a MAT-file is refused by name.
#[test]
fn import_venlo_makes_a_data_folder_a_season_runs_on() {
    let dir = temp_dir("venlo");
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    let rows = 288;
    let datenum = |r: usize| 735_609.0 + r as f64 * 300.0 / 86_400.0;
    let columns: [&dyn Fn(usize) -> f64; 6] = [
        &datenum,
        &|r| (400.0 * ((r as f64 - 72.0) / 144.0 * std::f64::consts::PI).sin()).max(0.0),
        &|r| 4.0 + 0.01 * r as f64,
        &|_| 85.0,
        &|_| 2.0,
        &|_| 420.0,
    ];
    let data: Vec<f64> = columns.iter().flat_map(|f| (0..rows).map(f)).collect();
    let mat = dir.join("outdoorWeatherWurGlas2014.mat");
    std::fs::write(
        &mat,
        ghm::import::venlo::mat::write(&[("d", rows, &data)], true),
    )
    .expect("write the excerpt");
    let data_dir = dir.join("data");
    let (ok, out, err) = ghm(&[
        "import",
        "venlo",
        mat.to_str().unwrap(),
        "--out",
        data_dir.to_str().unwrap(),
    ]);
    assert!(ok, "{out}{err}");
    assert!(out.contains("48 rows of 1800 s"), "{out}");
    let weather = data_dir.join(ghm::sim::weather::VENLO_FILE);
    let run = dir.join("season");
    let (ok, out, err) = ghm(&[
        "simulate",
        "models/lettuce.ghm",
        "--weather",
        weather.to_str().unwrap(),
        "--steps",
        "47",
        "--out",
        run.to_str().unwrap(),
    ]);
    assert!(ok, "{out}{err}");
    assert_eq!(summary(&run)["metrics"]["steps"], 47, "{out}");

    let not_mat = dir.join("weather.mat");
    std::fs::write(&not_mat, "time,rad\n").expect("write");
    let (ok, _, err) = ghm(&["import", "venlo", not_mat.to_str().unwrap(), "--out", "x"]);
    assert!(!ok);
    assert!(
        err.contains("weather.mat") && err.contains("not a MAT-file"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn distill_refuses_bad_start_rows_and_threads_with_a_message() {
    let (ok, _, err) = ghm(&["distill", "models/lettuce.ghm", "--start-rows", "5"]);
    assert!(!ok);
    assert!(err.contains("is not FIRST..LAST"), "{err}");
    let (ok, _, err) = ghm(&["distill", "models/lettuce.ghm", "--start-rows", "9..x"]);
    assert!(!ok);
    assert!(err.contains("`x` in `9..x` is not a row number"), "{err}");
    let dir = temp_dir("distill-threads");
    let out = dir.to_string_lossy().to_string();
    let (ok, _, err) = ghm(&[
        "distill",
        "models/lettuce.ghm",
        "--threads",
        "0",
        "--out",
        &out,
    ]);
    assert!(!ok);
    assert!(err.contains("--threads must be at least 1"), "{err}");
    let (ok, _, err) = ghm(&[
        "distill",
        "models/lettuce.ghm",
        "--start-rows",
        "9..3",
        "--out",
        &out,
    ]);
    assert!(!ok);
    assert!(err.contains("--start-rows"), "{err}");
    assert!(
        !dir.join("run.json").exists(),
        "nothing is written for a refused spec"
    );
}

#[test]
fn value_refuses_a_bad_learning_rate_or_batch_with_a_message() {
    let dir = temp_dir("value-fit-options");
    let out = dir.to_string_lossy().to_string();
    for (flag, expected) in [
        ("--learning-rate=0", "--learning-rate"),
        ("--learning-rate=-1e-3", "must be a number > 0"),
        ("--batch-size=0", "--batch-size"),
    ] {
        let (ok, _, err) = ghm(&[
            "value",
            "models/lettuce.ghm",
            "--guide",
            "expert",
            flag,
            "--out",
            &out,
        ]);
        assert!(!ok, "{flag}");
        assert!(err.contains(expected), "{flag}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}
