//! The season optimum bounds every closed loop from above (built-in weather; no ../shared).

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
