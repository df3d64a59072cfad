//! The season optimum bounds every closed loop from above, and `ghm optimum` reports it
//! (built-in weather; no ../shared).

mod common;

use common::bin::ghm_with_stdout;
use ghm::control::{InputTable, Mpc};
use ghm::model::Plant;
use ghm::sim::optimum::season_optimum;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::{builtin_season, Weather};
use ghm::solve::Sqp;
use std::path::Path;
use std::sync::Arc;

const STEPS: usize = 48;

fn setup() -> (Arc<Plant>, Weather) {
    let model = ghm::lang::load(Path::new("models/lettuce.ghm"))
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = Arc::new(Plant::new(model));
    let columns = plant.model.weather_columns();
    let weather = builtin_season(STEPS + 12, plant.model.sample_period, 2014)
        .select(&columns, 0, STEPS + 12)
        .expect("built-in weather has the model's columns");
    (plant, weather)
}

fn config() -> SeasonConfig {
    SeasonConfig {
        steps: STEPS,
        enforce_limits: true,
        uncertainty: None,
    }
}

/// The `summary.json` of a run folder.
fn summary_of(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("summary.json")).expect("summary.json");
    serde_json::from_str(&text).expect("JSON")
}

/// A summary's cumulative reward.
fn reward_of(summary: &serde_json::Value) -> f64 {
    summary["metrics"]["cumulative_reward"]
        .as_f64()
        .expect("a number")
}

/// Closed-loop MPC: cumulative reward and the inputs it applied.
fn mpc(plant: &Arc<Plant>, weather: &Weather, horizon: usize) -> (f64, Vec<f64>) {
    let mut mpc = Mpc::new(plant.clone(), horizon, Box::new(Sqp::default())).unwrap();
    let mut inputs = Vec::new();
    let mut sink = |log: &StepLog| inputs.extend_from_slice(&log.input);
    let r = run_season(plant, weather, &mut mpc, &config(), &mut sink).unwrap();
    (r.metrics.cumulative_reward, inputs)
}

#[test]
fn no_closed_loop_beats_the_season_optimum() {
    let (plant, weather) = setup();
    let (reward_1h, inputs) = mpc(&plant, &weather, 2);
    let (reward_6h, _) = mpc(&plant, &weather, 12);
    let optimum =
        season_optimum(plant.clone(), &weather, STEPS, &inputs, &mut Sqp::default()).unwrap();
    assert!(
        optimum.solution.status.is_success(),
        "{:?}",
        optimum.solution.status
    );
    // Score the optimum's inputs exactly as the controllers are scored.
    let mut table = InputTable(optimum.inputs.clone());
    let mut sink = |_: &StepLog| {};
    let best = run_season(&plant, &weather, &mut table, &config(), &mut sink)
        .unwrap()
        .metrics
        .cumulative_reward;
    assert!(
        best >= reward_1h - 1e-9 && best >= reward_6h - 1e-9,
        "optimum {best} vs MPC {reward_1h} (1 h), {reward_6h} (6 h)"
    );
    // And its objective is the negated score (slacks equal the penalties at the optimum).
    assert!(
        (optimum.solution.stats.objective + best).abs() < 1e-7,
        "{} vs {best}",
        optimum.solution.stats.objective
    );
}

/// `ghm optimum` from the command line on one day: its summary says what it solved (IPM,
/// optimal, from a 1 h closed loop whose reward is the library's MPC's on the same weather)
/// and its season reward is the optimum SQP, another algorithm, finds from the same start
/// (to the interior point's final barrier term), at or above the closed loop's; the
/// trajectory has a row per step.
#[test]
fn optimum_command_reports_the_optimum_sqp_finds() {
    let dir = std::env::temp_dir().join(format!("ghm-optimum-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let (ok, _, stderr) = ghm_with_stdout(&[
        "optimum",
        "models/lettuce.ghm",
        "--days",
        "1",
        "--init-horizon",
        "1h",
        "--solver",
        "ipm",
        "--out",
        dir.to_str().expect("utf-8 temp path"),
    ]);
    assert!(ok, "{stderr}");
    let summary = summary_of(&dir);
    let optimum = &summary["optimum"];
    assert_eq!(optimum["solver"], "ipm", "{optimum}");
    assert_eq!(optimum["status"], "optimal", "{optimum}");
    assert_eq!(optimum["initial_horizon_steps"], 2, "{optimum}");
    assert_eq!(summary["metrics"]["steps"], STEPS);
    let csv = std::fs::read_to_string(dir.join("trajectory.csv")).expect("trajectory.csv");
    assert_eq!(
        csv.lines().count(),
        STEPS + 1,
        "a header and a row per step"
    );

    let (plant, weather) = setup();
    let (closed_loop, inputs) = mpc(&plant, &weather, 2);
    let initial = optimum["initial_cumulative_reward"]
        .as_f64()
        .expect("a number");
    assert!(
        (initial - closed_loop).abs() <= 1e-12 * closed_loop.abs(),
        "{initial} vs the library's {closed_loop}"
    );
    let sqp = season_optimum(plant.clone(), &weather, STEPS, &inputs, &mut Sqp::default()).unwrap();
    assert!(
        sqp.solution.status.is_success(),
        "{:?}",
        sqp.solution.status
    );
    let mut table = InputTable(sqp.inputs.clone());
    let best = run_season(
        &plant,
        &weather,
        &mut table,
        &config(),
        &mut |_: &StepLog| {},
    )
    .unwrap()
    .metrics
    .cumulative_reward;
    let reward = reward_of(&summary);
    // The interior point stops at μ = 1e-9 with its complementarity there, so its objective
    // may sit up to μ per bound (≈ 500 bounds: 5e-7, 1.4e-5 of this reward) off the optimum;
    // measured 1.4e-7 (4e-6 relative) below SQP's.
    assert!(
        (reward - best).abs() <= 2e-5 * best.abs(),
        "ghm optimum {reward} vs SQP {best}"
    );
    assert!(
        reward >= closed_loop,
        "{reward} below the closed loop's {closed_loop}"
    );

    // Started from a season's inputs (here the optimum's own `trajectory.csv`, whose
    // columns are `u_<input>`) instead of a closed loop: the same optimum, no closed loop.
    let again = dir.join("again");
    let trajectory = dir.join("trajectory.csv");
    let (ok, stdout, stderr) = ghm_with_stdout(&[
        "optimum",
        "models/lettuce.ghm",
        "--days",
        "1",
        "--solver",
        "ipm",
        "--init-inputs",
        trajectory.to_str().expect("utf-8 temp path"),
        "--out",
        again.to_str().expect("utf-8 temp path"),
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("initialising from the inputs in"),
        "{stdout}"
    );
    let restarted = summary_of(&again);
    assert_eq!(restarted["optimum"]["status"], "optimal");
    assert!(restarted["optimum"]["initial_cumulative_reward"].is_null());
    let reward_again = reward_of(&restarted);
    assert!(
        (reward_again - best).abs() <= 2e-5 * best.abs(),
        "from the optimum's own inputs {reward_again} vs SQP {best}"
    );

    // Fewer rows than the season's steps: refused with a message.
    let short = dir.join("short.csv");
    let rows: Vec<&str> = csv.lines().take(STEPS / 2).collect();
    std::fs::write(&short, rows.join("\n")).unwrap();
    let short_out = dir.join("short");
    let (ok, _, stderr) = ghm_with_stdout(&[
        "optimum",
        "models/lettuce.ghm",
        "--days",
        "1",
        "--init-inputs",
        short.to_str().expect("utf-8 temp path"),
        "--out",
        short_out.to_str().expect("utf-8 temp path"),
    ]);
    assert!(!ok);
    assert!(
        stderr.contains("rows of inputs; the season has 48 steps") && !stderr.contains("panicked"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_season_optimum_resumed_from_a_checkpoint_reaches_the_same_optimum() {
    use ghm::sim::optimum::resume_season_optimum;
    use ghm::solve::{Checkpoint, CheckpointSink, Ipm, Solver};
    use std::sync::Mutex;
    let (plant, weather) = setup();
    let (_, inputs) = mpc(&plant, &weather, 2);
    /// Keeps a checkpoint every fifth iteration.
    struct EveryFifth(Arc<Mutex<Vec<Checkpoint>>>);
    impl CheckpointSink for EveryFifth {
        fn wants(&mut self, iteration: usize) -> bool {
            iteration.is_multiple_of(5)
        }
        fn keep(&mut self, checkpoint: &Checkpoint) {
            self.0.lock().unwrap().push(checkpoint.clone());
        }
    }
    let kept: Arc<Mutex<Vec<Checkpoint>>> = Arc::default();
    let mut ipm = Ipm::default();
    assert!(ipm.set_checkpoints(Some(Box::new(EveryFifth(Arc::clone(&kept))))));
    let whole = season_optimum(plant.clone(), &weather, STEPS, &inputs, &mut ipm).unwrap();
    assert!(whole.solution.status.is_success());
    let checkpoints = kept.lock().unwrap().clone();
    assert!(
        checkpoints.len() >= 2,
        "{} checkpoints in {} iterations",
        checkpoints.len(),
        whole.solution.stats.iterations
    );
    assert!(checkpoints.iter().all(|c| c.iteration % 5 == 0));
    // From the middle checkpoint: the same optimum, in about the iterations left.
    let middle = &checkpoints[checkpoints.len() / 2];
    let mut fresh = Ipm::default();
    let resumed =
        resume_season_optimum(plant.clone(), &weather, STEPS, middle, &mut fresh).unwrap();
    assert!(resumed.solution.status.is_success());
    let (a, b) = (
        whole.solution.stats.objective,
        resumed.solution.stats.objective,
    );
    assert!((a - b).abs() <= 1e-6 * a.abs(), "{a} vs resumed {b}");
    let left = whole.solution.stats.iterations - middle.iteration;
    assert!(
        resumed.solution.stats.iterations <= 2 * left + 10,
        "{} iterations resumed after {}, against {left} left",
        resumed.solution.stats.iterations,
        middle.iteration
    );
    // A checkpoint of another problem is refused.
    let mut short = middle.clone();
    short.x.pop();
    assert!(resume_season_optimum(plant, &weather, STEPS, &short, &mut fresh).is_err());
}

#[test]
fn a_checkpoint_of_another_optimum_is_refused_with_a_message() {
    let dir = std::env::temp_dir().join(format!("ghm-optimum-ckpt-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let checkpoint = serde_json::json!({
        "spec": {"model": "another.ghm"},
        "model_hash": "0",
        "checkpoint": {"iteration": 5, "x": [], "multipliers": [], "bound_multipliers": [], "barrier": 1e-3},
    });
    std::fs::write(
        dir.join(ghm::job::optimum_checkpoint::FILE),
        checkpoint.to_string(),
    )
    .unwrap();
    let out = dir.to_str().expect("utf-8 temp path");
    let args = [
        "optimum",
        "models/lettuce.ghm",
        "--days",
        "1",
        "--solver",
        "ipm",
        "--out",
        out,
    ];
    let (ok, _, stderr) = ghm_with_stdout(&args);
    assert!(!ok);
    assert!(
        stderr.contains("it is of another optimum") && stderr.contains("--overwrite"),
        "{stderr}"
    );
    // --overwrite starts afresh, and a finished optimum leaves no checkpoint.
    let mut overwrite = args.to_vec();
    overwrite.push("--overwrite");
    let (ok, _, stderr) = ghm_with_stdout(&overwrite);
    assert!(ok, "{stderr}");
    assert!(!dir.join(ghm::job::optimum_checkpoint::FILE).exists());
    let _ = std::fs::remove_dir_all(&dir);
}
