//! Economic MPC of the lettuce greenhouse, from its `.ghm` file, in a dozen lines.
//!
//! Loads `models/lettuce.ghm`, runs two days of MPC with a 3-hour horizon on the built-in
//! weather, and prints EPI, cumulative reward and the solver's statistics.
//!
//! Run: `cargo run --release --example mpc_from_ghm`

use ghm::control::Mpc;
use ghm::model::Plant;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::builtin_season;
use ghm::solve::Ipm;
use std::path::Path;
use std::sync::Arc;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
    let model = ghm::lang::load(&file)?;
    let plant = Arc::new(Plant::new(model));

    let (steps, horizon) = (96, 6); // two days of 30-minute steps, 3 h ahead
    let columns = plant.model.weather_columns();
    let weather = builtin_season(steps + horizon, plant.model.sample_period, 2014).select(
        &columns,
        0,
        steps + horizon,
    )?;

    let mut mpc = Mpc::new(plant.clone(), horizon, Box::new(Ipm::default()))?;
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut ignore = |_: &StepLog| {};
    let result = run_season(&plant, &weather, &mut mpc, &config, &mut ignore)?;

    let m = &result.metrics;
    println!("two days of economic MPC (3 h) on the built-in weather:");
    println!("  EPI               {:+.4} EUR/m2", m.epi);
    println!("  cumulative reward {:+.4} EUR/m2", m.cumulative_reward);
    println!(
        "  solve time        median {:.2} ms, max {:.2} ms; {} failed solves",
        m.solve.median_ms, m.solve.max_ms, m.solve.failed_solves
    );
    Ok(())
}
