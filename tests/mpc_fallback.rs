//! The MPC's fallback order, exercised with a solver that fails on purpose, and its
//! forecast padding (built-in model, constant weather: no ../shared needed).

use ghm::control::mpc::LAST_RESORT_COLD_ITERATIONS;
use ghm::control::warm_start::PRIMAL_DUAL_TRIAL_ITERATIONS;
use ghm::control::{ControlError, Controller, Fallback, Guidance, Mpc, Observation, WarmStart};
use ghm::model::Plant;
use ghm::nlp::{Nlp, Ocp};
use ghm::solve::{Solution, SolveStatus, Solver, Sqp, Start};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::path::Path;
use std::rc::Rc;
use std::sync::{Arc, Mutex};

/// Runs SQP, then overrides the status with the next scripted one (`None`: keep it); it
/// records the iteration cap each solve ran under.
struct Scripted {
    inner: Sqp,
    script: Rc<RefCell<VecDeque<Option<SolveStatus>>>>,
    limit: Option<usize>,
    caps: Rc<RefCell<Vec<Option<usize>>>>,
}

impl Solver for Scripted {
    fn name(&self) -> &'static str {
        "scripted"
    }

    fn set_iteration_limit(&mut self, limit: Option<usize>) {
        self.limit = limit;
    }

    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        self.caps.borrow_mut().push(self.limit);
        let mut s = self.inner.solve(nlp, start);
        if let Some(Some(status)) = self.script.borrow_mut().pop_front() {
            s.status = status;
        }
        s
    }
}

fn setup(script: Vec<Option<SolveStatus>>) -> (Arc<Plant>, Mpc) {
    let (plant, mpc, _) = setup_recording(script);
    (plant, mpc)
}

/// [`setup`], with the caps the solves ran under.
fn setup_recording(script: Vec<Option<SolveStatus>>) -> (Arc<Plant>, Mpc, Caps) {
    let model = ghm::lang::load(Path::new("models/lettuce.ghm"))
        .unwrap_or_else(|e| panic!("{}", e.render()));
    setup_with(model, script)
}

type Caps = Rc<RefCell<Vec<Option<usize>>>>;

fn setup_with(
    model: ghm::lang::Model,
    script: Vec<Option<SolveStatus>>,
) -> (Arc<Plant>, Mpc, Caps) {
    let plant = Arc::new(Plant::new(model));
    let caps = Caps::default();
    let solver = Scripted {
        inner: Sqp::default(),
        script: Rc::new(RefCell::new(script.into())),
        limit: None,
        caps: caps.clone(),
    };
    let mpc = Mpc::new(plant.clone(), 4, Box::new(solver)).unwrap();
    (plant, mpc, caps)
}

/// The constant weather every scripted season runs on: 8 rows of 4 disturbances.
fn constant_weather() -> Vec<f64> {
    (0..8).flat_map(|_| [50.0, 7e-4, 8.0, 0.006]).collect()
}

/// Runs `steps` MPC steps on constant weather; returns each step's fallback and input.
fn run(plant: &Plant, mpc: &mut Mpc, steps: usize) -> Vec<(Option<String>, Vec<f64>, String)> {
    let forecast = constant_weather();
    let p = plant.model.nominal_params();
    let mut x = plant.model.initial_state();
    let mut u_prev = plant.model.start_input();
    let mut out = Vec::new();
    for k in 0..steps {
        let y = plant.outputs(&x, &u_prev, &forecast[..4], &p);
        let obs = Observation {
            step: k,
            state: &x,
            outputs: &y,
            previous_input: &u_prev,
            forecast: &forecast,
        };
        let d = mpc.decide(&obs).unwrap();
        out.push((
            d.record.fallback_name().map(String::from),
            d.input.clone(),
            d.record.status_name().to_string(),
        ));
        x = plant.step(&x, &d.input, &forecast[..4], &p).next_state;
        u_prev = d.input;
    }
    out
}

#[test]
fn a_model_planned_with_fewer_sub_steps_is_solved_as_simulated_before_any_fallback_input() {
    let text = std::fs::read_to_string("models/lettuce.ghm").unwrap();
    let sample = "sample step_s [s] integrator rk4 substeps 4";
    assert!(text.contains(sample));
    let text = text.replace(sample, &format!("{sample} plan substeps 2"));
    let model =
        ghm::lang::load_str("lettuce.ghm", &text).unwrap_or_else(|e| panic!("{}", e.render()));
    // Step 0: cold solve ok. Step 1: the warm and the cold solve of the planning problem
    // fail; the cold solve on the model as simulated succeeds.
    let failed = Some(SolveStatus::NumericalError);
    let (plant, mut mpc, caps) = setup_with(model, vec![None, failed, failed, None, None]);
    assert_eq!(mpc.ocp().plant().model.substeps, 2);
    let log = run(&plant, &mut mpc, 3);
    // Step 1's cold solve on the planning model is capped; the one as simulated is not.
    let cold_cap = Some(LAST_RESORT_COLD_ITERATIONS);
    assert_eq!(caps.borrow()[2..4], [cold_cap, None]);
    assert_eq!(log[0].0, None);
    assert_eq!(log[1].0.as_deref(), Some("simulation_model"));
    assert_ne!(
        log[1].2, "numerical_error",
        "the simulation model's status is reported"
    );
    // Step 2 restarts warm, on the planning problem, from that solution.
    assert_eq!(log[2].0, None);
    // Without `plan substeps` the same failures, and those of the shorter horizons, end in
    // the shifted plan, the cold solve uncapped.
    let (plant, mut mpc, caps) = setup_recording(vec![None, failed, failed, failed, failed]);
    assert_eq!(
        run(&plant, &mut mpc, 2)[1].0.as_deref(),
        Some("shifted_plan")
    );
    assert_eq!(caps.borrow()[2], None);
}

/// Where every solve over the horizon (4 steps) fails, plain MPC solves cold over 2 steps,
/// then over 1, each capped like a cold start, and applies the first success's input; the
/// next step starts cold over the whole horizon (its plan over 1 step is not shifted).
#[test]
fn failed_solves_over_the_horizon_give_way_to_a_shorter_horizon() {
    let failed = Some(SolveStatus::MaxIterations);
    let (plant, mut mpc, caps) = setup_recording(vec![None, failed, failed, failed, None, None]);
    let log = run(&plant, &mut mpc, 3);
    assert_eq!(log[0].0, None);
    assert_eq!(log[1].0.as_deref(), Some("shorter_horizon"));
    assert_eq!(
        log[1].2, "optimal",
        "the shorter horizon's status is reported"
    );
    let cap = Some(LAST_RESORT_COLD_ITERATIONS);
    // Step 1: warm (SQP's primal-dual cap), cold (uncapped), over 2 and over 1 steps
    // (capped); step 2: cold, uncapped, not warm from the one-step plan.
    let warm_cap = Some(Sqp::default().warm_iteration_budget());
    assert_eq!(caps.borrow()[1..], [warm_cap, None, cap, cap, None]);
    assert_eq!(log[2].0, None);
    // The input is that of plain MPC over one step from the same state.
    let model = ghm::lang::load(Path::new("models/lettuce.ghm")).unwrap();
    let mut one_step = Mpc::new(Arc::new(Plant::new(model)), 1, Box::new(Sqp::default())).unwrap();
    let forecast = constant_weather();
    let p = plant.model.nominal_params();
    let x0 = plant.model.initial_state();
    let x1 = plant.step(&x0, &log[0].1, &forecast[..4], &p).next_state;
    let y = plant.outputs(&x1, &log[0].1, &forecast[..4], &p);
    let alone = one_step
        .decide(&Observation {
            step: 1,
            state: &x1,
            outputs: &y,
            previous_input: &log[0].1,
            forecast: &forecast,
        })
        .unwrap();
    for (a, b) in log[1].1.iter().zip(&alone.input) {
        assert!((a - b).abs() <= 1e-9, "{:?} vs {:?}", log[1].1, alone.input);
    }
}

/// A step decided over a shorter horizon leaves no plan behind: where the next step fails
/// everywhere too, it holds the input rather than apply an older plan's, computed for a
/// first input that was not applied.
#[test]
fn a_failure_after_a_shorter_horizon_holds_the_input() {
    let failed = Some(SolveStatus::MaxIterations);
    // Step 1: warm, cold and over 2 steps fail, over 1 succeeds. Step 2: cold, over 2 and
    // over 1 fail.
    let script = vec![None, failed, failed, failed, None, failed, failed, failed];
    let (plant, mut mpc, caps) = setup_recording(script);
    let log = run(&plant, &mut mpc, 3);
    assert_eq!(log[1].0.as_deref(), Some("shorter_horizon"));
    assert!(mpc.last_solution().is_none());
    assert_eq!(log[2].0.as_deref(), Some("hold_input"));
    assert_eq!(log[2].1, log[1].1);
    // One solve at step 0, four at step 1, three at step 2 (no warm start).
    assert_eq!(caps.borrow().len(), 1 + 4 + 3);
}

#[test]
fn warm_start_failure_falls_back_to_a_cold_start() {
    // Step 0: cold solve ok. Step 1: the warm solve fails, the cold re-solve succeeds.
    let (plant, mut mpc) = setup(vec![None, Some(SolveStatus::NumericalError), None]);
    let log = run(&plant, &mut mpc, 3);
    assert_eq!(log[0].0, None);
    assert_eq!(log[1].0.as_deref(), Some("cold_start"));
    assert_eq!(log[1].2, "optimal");
    assert_eq!(
        log[2].0, None,
        "step 2 warm-starts again from step 1's solution"
    );
}

#[test]
fn a_capped_primal_dual_restart_that_fails_restarts_from_the_shifted_plan_not_cold() {
    // Step 0: cold solve ok. Step 1: the primal-dual attempt, capped, fails; the restart
    // from the shifted plan alone (uncapped) succeeds within the same step: no fallback.
    let failed = Some(SolveStatus::MaxIterations);
    let (plant, mut mpc, caps) = setup_recording(vec![None, failed, None, None]);
    mpc.warm_start = WarmStart::PrimalDualCapped;
    let log = run(&plant, &mut mpc, 3);
    assert_eq!(log[1].0, None, "{log:?}");
    assert_eq!(log[1].2, "optimal");
    let trial = Some(PRIMAL_DUAL_TRIAL_ITERATIONS);
    // Step 0 cold, step 1 the capped attempt then the shifted plan, step 2 capped again.
    assert_eq!(caps.borrow()[..], [None, trial, None, trial]);
}

#[test]
fn failed_warm_and_cold_solves_apply_the_shifted_plan() {
    // Step 1: the warm and the cold solve fail, then those over 2 steps and over 1.
    let (plant, mut mpc) = setup(vec![
        None,
        Some(SolveStatus::MaxIterations),
        Some(SolveStatus::Infeasible),
        Some(SolveStatus::NumericalError),
        Some(SolveStatus::NumericalError),
    ]);
    let plan = {
        let log = run(&plant, &mut mpc, 1);
        assert_eq!(log[0].0, None);
        let s = mpc.last_solution().expect("step 0 solved");
        mpc.ocp().input(&s.x, 1).to_vec()
    };
    // Re-run from the same controller state: step 1 fails twice.
    let forecast = constant_weather();
    let p = plant.model.nominal_params();
    let x0 = plant.model.initial_state();
    let u0 = mpc.ocp().input(&mpc.last_solution().unwrap().x, 0).to_vec();
    let x1 = plant.step(&x0, &u0, &forecast[..4], &p).next_state;
    let y = plant.outputs(&x1, &u0, &forecast[..4], &p);
    let d = mpc
        .decide(&Observation {
            step: 1,
            state: &x1,
            outputs: &y,
            previous_input: &u0,
            forecast: &forecast,
        })
        .unwrap();
    assert_eq!(d.record.fallback, Some(Fallback::ShiftedPlan));
    assert_eq!(d.record.status, Some(SolveStatus::Infeasible));
    assert_eq!(
        (d.record.fallback_name(), d.record.status_name()),
        (Some("shifted_plan"), "infeasible")
    );
    for (a, b) in d.input.iter().zip(&plan) {
        assert!((a - b).abs() < 1e-12, "{:?} vs plan {:?}", d.input, plan);
    }
}

#[test]
fn failure_without_any_plan_holds_the_previous_input() {
    let (plant, mut mpc) = setup(vec![Some(SolveStatus::NumericalError); 3]);
    let log = run(&plant, &mut mpc, 1);
    assert_eq!(log[0].0.as_deref(), Some("hold_input"));
    assert_eq!(log[0].1, plant.model.start_input());
    assert_eq!(log[0].2, "numerical_error");
}

/// A guidance that starts from the held input's roll-out, keeps every forecast it is given
/// and offers `input` as the guide's own.
struct Recording {
    input: Option<Vec<f64>>,
    forecasts: Arc<Mutex<Vec<Vec<f64>>>>,
}

impl Guidance for Recording {
    fn name(&self) -> String {
        "recording".into()
    }

    fn prepare(
        &mut self,
        ocp: &mut Ocp,
        _observation: &Observation,
        forecast: &[f64],
        _previous: Option<&[f64]>,
        start: &mut [f64],
    ) -> Result<(), ControlError> {
        self.forecasts.lock().unwrap().push(forecast.to_vec());
        ocp.initial_point(start);
        Ok(())
    }

    fn guide_input(&mut self, _observation: &Observation) -> Option<Vec<f64>> {
        self.input.clone()
    }

    fn region_status(&self, _ocp: &Ocp, _x: &[f64]) -> Option<String> {
        None
    }
}

/// The decision at step 0 on `forecast` (rows of 4; the outputs need a weather row even
/// when the forecast is empty).
fn first_decision(
    plant: &Plant,
    mpc: &mut Mpc,
    forecast: &[f64],
) -> Result<ghm::control::Decision, ControlError> {
    let p = plant.model.nominal_params();
    let x = plant.model.initial_state();
    let u = plant.model.start_input();
    let now = forecast.get(..4).unwrap_or(&[20.0, 7e-4, 6.0, 0.006]);
    let y = plant.outputs(&x, &u, now, &p);
    mpc.decide(&Observation {
        step: 0,
        state: &x,
        outputs: &y,
        previous_input: &u,
        forecast,
    })
}

/// With no plan to shift (step 0, every solve failing), RL-guided MPC applies the guide's
/// input, within the rate limits from the start input (0, 0, 50): (0.5, 2, 120) becomes
/// (0.12, 0.75, 65). Without a guide's input it holds the start input.
#[test]
fn failure_without_a_plan_applies_the_guides_input_within_the_limits() {
    let forecast = constant_weather();
    for (offered, applied, path) in [
        (
            Some(vec![0.5, 2.0, 120.0]),
            vec![0.12, 0.75, 65.0],
            "guide_input",
        ),
        (None, vec![0.0, 0.0, 50.0], "hold_input"),
    ] {
        // Every solve fails: over the horizon, and over 2 and 1 steps.
        let failing = vec![Some(SolveStatus::NumericalError); 8];
        let (plant, mpc) = setup(failing);
        let mut mpc = mpc.with_guidance(Box::new(Recording {
            input: offered,
            forecasts: Arc::default(),
        }));
        let d = first_decision(&plant, &mut mpc, &forecast).unwrap();
        assert_eq!(d.record.fallback_name(), Some(path));
        assert_eq!(d.record.status, Some(SolveStatus::NumericalError));
        assert_eq!(d.input, applied, "{path}");
    }
}

/// Where RL-guided MPC fails over the whole horizon, plain MPC over half of it decides the
/// step (`shorter_horizon`), before any plan or guide input: on the GreenLight tomato
/// those had decided 34 of RL-MPC's first 1 152 steps.
#[test]
fn failed_guided_solves_give_way_to_a_shorter_horizon() {
    let forecast = constant_weather();
    let guided = |script: Vec<Option<SolveStatus>>| {
        let (plant, mpc, caps) = setup_recording(script);
        let mpc = mpc.with_guidance(Box::new(Recording {
            input: Some(vec![0.5, 2.0, 120.0]),
            forecasts: Arc::default(),
        }));
        (plant, mpc, caps)
    };
    // How many solves the step takes where all fail: those over the horizon, then over 2
    // and over 1 step.
    let failed = Some(SolveStatus::MaxIterations);
    let (plant, mut mpc, caps) = guided(vec![failed; 20]);
    first_decision(&plant, &mut mpc, &forecast).unwrap();
    let over_the_horizon = caps.borrow().len() - 2;
    // Those over the horizon fail, the one over 2 steps succeeds.
    let (plant, mut mpc, caps) = guided(vec![failed; over_the_horizon]);
    let d = first_decision(&plant, &mut mpc, &forecast).unwrap();
    assert_eq!(d.record.fallback_name(), Some("shorter_horizon"));
    assert_eq!(d.record.status, Some(SolveStatus::Optimal));
    assert_eq!(caps.borrow().len(), over_the_horizon + 1);
    assert_eq!(
        caps.borrow().last(),
        Some(&Some(LAST_RESORT_COLD_ITERATIONS))
    );
    assert!(mpc.last_solution().is_none(), "no plan is kept");
}

/// After a successful step 0 on a 4-step horizon, failing steps apply the plan's inputs 1,
/// 2 and 3 in turn (`shifted_plan`); at step 4 the plan is used up and the input is held.
#[test]
fn a_used_up_plan_gives_way_to_the_held_input() {
    let mut script = vec![None];
    script.extend(vec![Some(SolveStatus::MaxIterations); 20]);
    let (plant, mut mpc) = setup(script);
    let log = run(&plant, &mut mpc, 5);
    assert_eq!(log[0].0, None);
    let s = mpc.last_solution().expect("step 0 solved");
    for (j, (fallback, input, status)) in log.iter().enumerate().skip(1) {
        assert_eq!(status, "max_iterations", "step {j}");
        if j < 4 {
            assert_eq!(fallback.as_deref(), Some("shifted_plan"), "step {j}");
            let planned = mpc.ocp().input(&s.x, j);
            for (a, b) in input.iter().zip(planned) {
                assert!(
                    (a - b).abs() <= 1e-9,
                    "step {j}: {input:?} vs plan {planned:?}"
                );
            }
        } else {
            assert_eq!(fallback.as_deref(), Some("hold_input"), "step {j}");
            assert_eq!(input, &log[3].1, "step 4 holds step 3's input");
        }
    }
}

/// A forecast shorter than the horizon is padded by repeating its last row: the guidance
/// sees rows (a, b, b, b) of a 2-row forecast (a, b), and the decision is bit for bit the
/// one taken on that padded forecast given whole. A longer forecast is cut to the horizon;
/// an empty one is refused.
#[test]
fn a_short_forecast_is_padded_with_its_last_row() {
    let a = [20.0, 7e-4, 6.0, 0.006];
    let b = [250.0, 8e-4, 12.0, 0.008];
    let short: Vec<f64> = [a, b].concat();
    let padded: Vec<f64> = [a, b, b, b].concat();
    let long: Vec<f64> = [a, b, b, b, a, a].concat();
    let forecasts = Arc::new(Mutex::new(Vec::new()));
    let (plant, mpc) = setup(vec![]);
    let mut guided = mpc.with_guidance(Box::new(Recording {
        input: None,
        forecasts: forecasts.clone(),
    }));
    first_decision(&plant, &mut guided, &short).unwrap();
    first_decision(&plant, &mut guided, &long).unwrap();
    assert_eq!(
        *forecasts.lock().unwrap(),
        vec![padded.clone(), padded.clone()]
    );

    let decide = |forecast: &[f64]| {
        let (plant, mut mpc) = setup(vec![]);
        first_decision(&plant, &mut mpc, forecast).unwrap().input
    };
    let on_padded = decide(&padded);
    assert_eq!(decide(&short), on_padded);
    assert_eq!(decide(&long), on_padded);
    let on_first_row_repeated = decide(&[a, b, a, a].concat());
    assert_ne!(
        on_first_row_repeated, on_padded,
        "the rows it pads with matter"
    );

    let (plant, mut mpc) = setup(vec![]);
    let err = first_decision(&plant, &mut mpc, &[]).unwrap_err();
    assert_eq!(err.to_string(), "the forecast is empty");
}
