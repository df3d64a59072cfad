//! The whole-season optimum (1920 stages) in pure Rust against IPOPT's (reads the Venlo
//! weather in ../shared). The reference figures come from ghm's IPOPT back-end:
//! `ghm optimum models/<variant>.ghm --weather ../shared/data/venlo2014_30min_model_units.csv
//! --start-row 1394 --solver ipopt` (a build with `--features ipopt`, 2026-12-01).

mod common;

use common::{plant, venlo};
use ghm::control::{InputTable, Mpc};
use ghm::sim::optimum::season_optimum;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::solve::{Ipm, Sqp};

const SEASON: usize = 1920;

/// The season optimum by the interior point, initialised like `ghm optimum` (a 1 h MPC
/// closed loop), scored like any controller.
fn optimum_reward(file: &str) -> f64 {
    let plant = plant(file);
    let weather = venlo(&plant, SEASON + 2);
    let config = SeasonConfig {
        steps: SEASON,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut mpc = Mpc::new(plant.clone(), 2, Box::new(Sqp::default())).unwrap();
    let mut inputs = Vec::new();
    let mut collect = |log: &StepLog| inputs.extend_from_slice(&log.input);
    run_season(&plant, &weather, &mut mpc, &config, &mut collect).unwrap();
    let optimum = season_optimum(
        plant.clone(),
        &weather,
        SEASON,
        &inputs,
        &mut Ipm::default(),
    )
    .unwrap();
    assert!(
        optimum.solution.status.is_success(),
        "{file}: {:?} after {} iterations",
        optimum.solution.status,
        optimum.solution.stats.iterations
    );
    let mut table = InputTable(optimum.inputs.clone());
    let mut ignore = |_: &StepLog| {};
    run_season(&plant, &weather, &mut table, &config, &mut ignore)
        .unwrap()
        .metrics
        .cumulative_reward
}

/// The paper variant needs the whole-horizon fallback of the inertia correction: over
/// 1920 stages the stage-wise one meets a cost to go of 1e150 (it ended with a numerical
/// error before the fallback).
#[test]
fn venlo_paper_season_optimum_equals_ipopts() {
    let Some(_) = common::data(common::VENLO, "venlo_paper_season_optimum_equals_ipopts") else {
        return;
    };
    let reward = optimum_reward("models/lettuce.ghm");
    assert!((reward - 3.384_865_455).abs() <= 1e-4, "{reward}");
}

#[test]
fn venlo_thesis_season_optimum_equals_ipopts() {
    let Some(_) = common::data(common::VENLO, "venlo_thesis_season_optimum_equals_ipopts") else {
        return;
    };
    let reward = optimum_reward("models/lettuce-thesis.ghm");
    assert!((reward - 4.763_394_130).abs() <= 1e-4, "{reward}");
}
