//! Every door decides through one `Stepper`: the season loop, the stepper `ghm serve` and
//! Python call with a controller the job layer built, and a compiled controller (the C
//! ABI's). They give the same inputs to the last bit on a perturbed plant, and cut an
//! answer the input limits refuse the same way. Built-in model and weather, no ../shared.

mod common;

use ghm::control::{LimitPolicy, StepRequest, Stepper};
use ghm::embed::Bundle;
use ghm::job::{
    build_controller, run_season_logs, BandsChoice, ControllerSpec, MpcSpec, RunSpec, SolverChoice,
};

fn spec(controller: ControllerSpec, uncertainty: f64) -> RunSpec {
    common::lettuce_day(controller, uncertainty, 7)
}

fn mpc() -> ControllerSpec {
    ControllerSpec::Mpc(MpcSpec {
        horizon: "2h".into(),
        solver: SolverChoice::default(),
        warm_start: None,
        bands: BandsChoice::default(),
    })
}

fn bits(u: &[f64]) -> Vec<u64> {
    u.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn every_door_decides_the_seasons_inputs_on_a_perturbed_plant() {
    for controller in [ControllerSpec::Expert, mpc()] {
        let spec = spec(controller, 0.2);
        let season = run_season_logs(&spec).unwrap();
        let logs = &season.logs;
        let mut compiled = Bundle::from_spec(&spec).unwrap().controller().unwrap();
        let mut built = build_controller(&spec).unwrap();
        let stepper = Stepper::new(LimitPolicy::Clip).with_forecast_rows(built.forecast_rows);
        let params = built.plant.model.nominal_params();
        let mut workspace = built.plant.workspace();
        let nd = built.plant.layout.nd;
        let weather: Vec<f64> = logs.iter().flat_map(|l| l.disturbance.clone()).collect();
        let rows = compiled.sizes().forecast_rows;
        let start = built.plant.model.start_input();
        let mut compared = 0;
        for (k, log) in logs
            .iter()
            .enumerate()
            .take_while(|(k, _)| k + rows <= logs.len())
        {
            let previous = if k == 0 { &start } else { &logs[k - 1].input };
            let forecast = &weather[k * nd..];
            let from_c = compiled
                .decide(k as u64, &log.state, previous, forecast)
                .unwrap();
            let request = StepRequest {
                step: k,
                state: &log.state,
                measured_outputs: None,
                previous_input: previous,
                forecast,
            };
            let served = stepper
                .decide(
                    &built.plant,
                    &params,
                    &mut workspace,
                    built.controller.as_mut(),
                    &request,
                )
                .unwrap();
            assert_eq!(bits(&from_c), bits(&log.input), "{spec:?}: step {k}");
            assert_eq!(bits(&served.input), bits(&log.input), "{spec:?}: step {k}");
            assert_eq!(bits(&served.outputs), bits(&log.outputs), "step {k}");
            compared += 1;
        }
        assert!(compared >= 40, "{compared} steps compared");
    }
}

/// A heating input of 200 W m⁻² measured as applied last, above its bound of 150 and more
/// than a rate limit (15 per step) away from it: the compiled controller and the stepper a
/// service calls give the same bits, inside the bounds.
#[test]
fn a_previous_input_outside_its_bounds_gets_the_same_answer_through_every_door() {
    for controller in [ControllerSpec::Expert, mpc()] {
        let spec = spec(controller, 0.0);
        let mut compiled = Bundle::from_spec(&spec).unwrap().controller().unwrap();
        let mut built = build_controller(&spec).unwrap();
        let plant = built.plant.clone();
        let season = run_season_logs(&spec).unwrap();
        let weather: Vec<f64> = season
            .logs
            .iter()
            .flat_map(|l| l.disturbance.clone())
            .collect();
        let state = plant.model.initial_state();
        let previous = [0.0, 0.0, 200.0];
        let from_c = compiled.decide(0, &state, &previous, &weather).unwrap();
        let request = StepRequest {
            step: 0,
            state: &state,
            measured_outputs: None,
            previous_input: &previous,
            forecast: &weather,
        };
        let params = plant.model.nominal_params();
        let mut workspace = plant.workspace();
        let served = Stepper::new(LimitPolicy::Clip)
            .decide(
                &plant,
                &params,
                &mut workspace,
                built.controller.as_mut(),
                &request,
            )
            .unwrap();
        assert_eq!(bits(&from_c), bits(&served.input), "{spec:?}");
        for (u, decl) in from_c.iter().zip(&plant.model.inputs) {
            assert!((decl.lower..=decl.upper).contains(u), "{from_c:?}");
        }
        assert_eq!(from_c[2], 150.0, "{from_c:?}");
    }
}
