//! The literature plants in models/ under closed-loop MPC (no weather: they have no
//! disturbances, so the season runs on an empty constant weather).
//!
//! * `cstr.ghm`: the exothermic CSTR of Henson & Seborg, started at its low-conversion
//!   steady state; the tracking MPC must bring it to the open-loop unstable middle steady
//!   state (Ca = 0.5 mol/L, T = 350 K) and hold it there, inside the temperature band.
//! * `bioreactor.ghm`: a fed-batch bioreactor with substrate-inhibited Monod growth; the
//!   economic MPC must earn clearly more than the best of a sweep of constant feeds.

use ghm::control::{ConstantInput, Controller, Mpc};
use ghm::model::Plant;
use ghm::sim::metrics::Metrics;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::Weather;
use ghm::solve::Sqp;
use std::path::Path;
use std::sync::Arc;

fn plant(file: &str) -> Arc<Plant> {
    let model = ghm::lang::load(Path::new(file)).unwrap_or_else(|e| panic!("{}", e.render()));
    assert!(
        model.disturbances.is_empty(),
        "{file} is meant to run without weather"
    );
    Arc::new(Plant::new(model))
}

fn state_index(plant: &Plant, name: &str) -> usize {
    plant
        .model
        .states
        .iter()
        .position(|s| s.info.name == name)
        .unwrap_or_else(|| panic!("no state `{name}`"))
}

/// Runs `steps` steps of `controller` from the model's initial state; returns the season's
/// metrics and the state at the start of every step, plus the final state.
fn season(
    plant: &Arc<Plant>,
    controller: &mut dyn Controller,
    steps: usize,
) -> (Metrics, Vec<Vec<f64>>) {
    let weather = Weather::constant(vec![], &[], steps, plant.model.sample_period);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut states = Vec::new();
    let mut sink = |log: &StepLog| states.push(log.state.clone());
    let result = run_season(plant, &weather, controller, &config, &mut sink).unwrap();
    states.push(result.final_state);
    (result.metrics, states)
}

#[test]
fn cstr_mpc_reaches_and_holds_the_unstable_steady_state() {
    let plant = plant("models/cstr.ghm");
    let (ca, temp) = (state_index(&plant, "ca"), state_index(&plant, "temp"));
    // 6-s steps: a 1-minute horizon, 6 minutes of closed loop.
    let mut mpc = Mpc::new(plant.clone(), 10, Box::new(Sqp::default())).unwrap();
    let (metrics, states) = season(&plant, &mut mpc, 60);
    assert_eq!(metrics.solve.failed_solves, 0, "{:?}", metrics.solve);
    // It starts far from the set point (the low-conversion steady state) …
    assert!((states[0][ca] - 0.877).abs() < 1e-3 && (states[0][temp] - 324.5).abs() < 0.1);
    // … and from step 30 (3 minutes) on stays on it.
    for (k, x) in states.iter().enumerate().skip(30) {
        assert!(
            (x[ca] - 0.5).abs() < 5e-3 && (x[temp] - 350.0).abs() < 0.5,
            "step {k}: Ca = {}, T = {}",
            x[ca],
            x[temp]
        );
    }
    // The temperature never leaves its band (no approach to runaway).
    assert!(
        metrics.total_penalty < 1e-6,
        "temperature band violated: {:?}",
        metrics.bands
    );
    let t_max = states.iter().map(|x| x[temp]).fold(f64::MIN, f64::max);
    assert!(t_max <= 355.0 + 1e-6, "peak temperature {t_max} K");
}

#[test]
fn bioreactor_economic_mpc_beats_constant_feeds() {
    let plant = plant("models/bioreactor.ghm");
    let steps = 48; // two days of hourly control
    let mut mpc = Mpc::new(plant.clone(), 12, Box::new(Sqp::default())).unwrap();
    let (metrics, states) = season(&plant, &mut mpc, steps);
    assert_eq!(metrics.solve.failed_solves, 0, "{:?}", metrics.solve);
    assert!(
        metrics.total_penalty < 1e-6,
        "volume limit violated: {:?}",
        metrics.bands
    );
    let vol = state_index(&plant, "vol");
    assert!(states.iter().all(|x| x[vol] <= 2.0 + 1e-9));

    // Constant feeds around the best one (0.0155 L/h, reward ≈ 3.07 € with the feed's ramp
    // limit from 0): lower feeds starve the culture, higher ones inhibit it.
    let feeds = [
        0.005, 0.01, 0.0125, 0.015, 0.0155, 0.016, 0.0175, 0.02, 0.03,
    ];
    let (best_feed, best) = feeds
        .iter()
        .map(|&f| {
            let (m, _) = season(&plant, &mut ConstantInput(vec![f]), steps);
            (f, m.cumulative_reward)
        })
        .fold((f64::NAN, f64::MIN), |a, b| if b.1 > a.1 { b } else { a });
    let reward = metrics.cumulative_reward;
    assert!(
        reward > 1.2 * best,
        "MPC {reward} € vs best constant feed {best} € (F = {best_feed} L/h)"
    );
}
