//! The MPC's fallback order, exercised with a solver that fails on purpose (built-in
//! model, constant weather: no ../shared needed).

use ghm::control::{Controller, Mpc, Observation};
use ghm::model::Plant;
use ghm::nlp::Nlp;
use ghm::solve::{Solution, SolveStatus, Solver, Sqp, Start};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::path::Path;
use std::rc::Rc;
use std::sync::Arc;

/// Runs SQP, then overrides the status with the next scripted one (`None`: keep it).
struct Scripted {
    inner: Sqp,
    script: Rc<RefCell<VecDeque<Option<SolveStatus>>>>,
}

impl Solver for Scripted {
    fn name(&self) -> &'static str {
        "scripted"
    }

    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        let mut s = self.inner.solve(nlp, start);
        if let Some(Some(status)) = self.script.borrow_mut().pop_front() {
            s.status = status;
        }
        s
    }
}

fn setup(script: Vec<Option<SolveStatus>>) -> (Arc<Plant>, Mpc) {
    let model = ghm::lang::load(Path::new("models/lettuce.ghm"))
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = Arc::new(Plant::new(model));
    let solver = Scripted {
        inner: Sqp::default(),
        script: Rc::new(RefCell::new(script.into())),
    };
    let mpc = Mpc::new(plant.clone(), 4, Box::new(solver)).unwrap();
    (plant, mpc)
}

/// Runs `steps` MPC steps on constant weather; returns each step's fallback and input.
fn run(plant: &Plant, mpc: &mut Mpc, steps: usize) -> Vec<(Option<String>, Vec<f64>, String)> {
    let forecast: Vec<f64> = (0..8).flat_map(|_| [50.0, 7e-4, 8.0, 0.006]).collect();
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
            d.record.fallback.clone(),
            d.input.clone(),
            d.record.status.clone(),
        ));
        x = plant.step(&x, &d.input, &forecast[..4], &p).next_state;
        u_prev = d.input;
    }
    out
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
fn failed_warm_and_cold_solves_apply_the_shifted_plan() {
    let (plant, mut mpc) = setup(vec![
        None,
        Some(SolveStatus::MaxIterations),
        Some(SolveStatus::Infeasible),
    ]);
    let plan = {
        let log = run(&plant, &mut mpc, 1);
        assert_eq!(log[0].0, None);
        let s = mpc.last_solution().expect("step 0 solved");
        mpc.ocp().input(&s.x, 1).to_vec()
    };
    // Re-run from the same controller state: step 1 fails twice.
    let forecast: Vec<f64> = (0..8).flat_map(|_| [50.0, 7e-4, 8.0, 0.006]).collect();
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
    assert_eq!(d.record.fallback.as_deref(), Some("shifted_plan"));
    assert_eq!(d.record.status, "infeasible");
    for (a, b) in d.input.iter().zip(&plan) {
        assert!((a - b).abs() < 1e-12, "{:?} vs plan {:?}", d.input, plan);
    }
}

#[test]
fn failure_without_any_plan_holds_the_previous_input() {
    let (plant, mut mpc) = setup(vec![Some(SolveStatus::NumericalError)]);
    let log = run(&plant, &mut mpc, 1);
    assert_eq!(log[0].0.as_deref(), Some("hold_input"));
    assert_eq!(log[0].1, plant.model.start_input());
    assert_eq!(log[0].2, "numerical_error");
}
