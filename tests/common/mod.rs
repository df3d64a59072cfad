//! Helpers shared by the MPC tests, and the data folder that some of them read: the Venlo
//! 2014 weather, which the repository does not ship (its sources state no licence;
//! `ghm import venlo` makes it from the file the paper's authors published, `docs/data.md`).
//! The folder is `GHM_DATA`, else `../shared/data` beside the repository; a test that needs
//! it and does not find it says on stderr that it skipped and why, unless
//! `GHM_REQUIRE_DATA` is set (`.ci/run`, which provides the data, so that CI runs every
//! test). The library's own tests follow the same rule (`src/sim/test_data.rs`, included here).
#![allow(dead_code)]

#[cfg(feature = "cli")]
pub mod bin;
pub mod greenlight;

use ghm::control::Mpc;
use ghm::model::Plant;
use ghm::nlp::Bands;
use ghm::sim::metrics::Metrics;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::{load_csv, Weather};
use ghm::solve::Solver;
use std::path::Path;
use std::sync::Arc;

/// A day of the lettuce model on the built-in weather under `controller`, on a plant
/// perturbed by `uncertainty` (seed `seed`): the run spec of the tests that need no data.
pub fn lettuce_day(
    controller: ghm::job::ControllerSpec,
    uncertainty: f64,
    seed: u64,
) -> ghm::job::RunSpec {
    ghm::job::RunSpec {
        model: Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm"),
        weather: ghm::job::WeatherSpec {
            days: Some(1.0),
            ..ghm::job::WeatherSpec::default()
        },
        plant: ghm::job::PlantSpec { uncertainty, seed },
        controller,
    }
}

/// The Venlo 2014 weather in the data folder.
pub const VENLO: &str = ghm::sim::weather::VENLO_FILE;

// The data folder's lookup and skip, the same file the library's own tests use.
#[path = "../../src/sim/test_data.rs"]
mod test_data;
#[allow(unused_imports)] // not every test binary that declares `mod common` reads data
pub use test_data::{dir as data_dir, file as data};

pub const START_ROW: usize = 1394;

pub fn plant(file: &str) -> Arc<Plant> {
    let model = ghm::lang::load(Path::new(file)).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

pub fn venlo(plant: &Plant, steps: usize) -> Weather {
    let columns = plant.model.weather_columns();
    load_csv(&data_dir().join(VENLO), &columns, 1800.0)
        .and_then(|f| f.select(&columns, START_ROW, steps))
        .expect("Venlo weather (the data folder; see `data`) must be readable")
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

/// Whether `program` runs (`program --version`). Where it does not, `test` is skipped with
/// a message that says how to install it (`install`), or fails when `GHM_REQUIRE_TOOLS` is
/// set (`.ci/run`, which installs every tool the tests use).
pub fn tool(program: &str, install: &str, test: &str) -> bool {
    let runs = std::process::Command::new(program)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if runs {
        return true;
    }
    let message = format!("{test}: needs `{program}`, which does not run here ({install})");
    test_data::skip(&message, "GHM_REQUIRE_TOOLS");
    false
}
