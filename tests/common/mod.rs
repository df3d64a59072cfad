//! Helpers shared by the MPC tests that read the Venlo season in ../shared.
#![allow(dead_code)]

pub mod bin;

use ghm::control::Mpc;
use ghm::model::Plant;
use ghm::nlp::Bands;
use ghm::sim::metrics::Metrics;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::{load_csv, Weather};
use ghm::solve::Solver;
use std::path::Path;
use std::sync::Arc;

pub const VENLO: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../shared/data/venlo2014_30min_model_units.csv"
);
pub const START_ROW: usize = 1394;

pub fn plant(file: &str) -> Arc<Plant> {
    let model = ghm::lang::load(Path::new(file)).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

pub fn venlo(plant: &Plant, steps: usize) -> Weather {
    let columns = plant.model.weather_columns();
    load_csv(Path::new(VENLO), &columns, 1800.0)
        .and_then(|f| f.select(&columns, START_ROW, steps))
        .expect("Venlo weather (../shared) must be readable")
}

/// States along an open-loop run with a mild constant input, so that the problems below
/// start from realistic states at different times of day and season.
pub fn states_along_season(plant: &Plant, weather: &Weather, steps: &[usize]) -> Vec<Vec<f64>> {
    let p = plant.model.nominal_params();
    let mut x = plant.model.initial_state();
    let mut out = Vec::new();
    for k in 0..=*steps.iter().max().unwrap() {
        if steps.contains(&k) {
            out.push(x.clone());
        }
        x = plant
            .step(&x, &[0.5, 2.0, 60.0], weather.at(k), &p)
            .next_state;
    }
    out
}

pub const STEPS: [usize; 10] = [0, 7, 150, 333, 500, 720, 1000, 1234, 1500, 1900];

/// Runs `steps` steps of MPC over `horizon` with `solver` from the start of the season,
/// planning with the model's planning bands (`Mpc::new`'s default).
pub fn closed_loop(
    plant: &Arc<Plant>,
    horizon: usize,
    solver: Box<dyn Solver>,
    steps: usize,
) -> Metrics {
    closed_loop_with_bands(plant, horizon, solver, steps, Bands::Planning)
}

/// Like [`closed_loop`], planning with the chosen bounds of the soft bands.
pub fn closed_loop_with_bands(
    plant: &Arc<Plant>,
    horizon: usize,
    solver: Box<dyn Solver>,
    steps: usize,
    bands: Bands,
) -> Metrics {
    let weather = venlo(plant, steps + horizon);
    let mpc = Mpc::new(plant.clone(), horizon, solver).expect("horizon > 0");
    let mut mpc = mpc.with_bands(bands).expect("the bands");
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut sink = |_: &StepLog| {};
    run_season(plant, &weather, &mut mpc, &config, &mut sink)
        .expect("the season runs")
        .metrics
}
