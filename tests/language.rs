//! The language's additions for real models (issue 34): functions with parameters inlined
//! into the graph, constants in dependency order, the `clock` disturbance advanced within
//! a step, `mod`/`floor`, `and`/`or`/`not`, `==`/`!=`. Each is checked by its value on
//! the step or output it builds; their diagnostics are snapshots in `tests/diagnostics.rs`.

use ghm::control::Mpc;
use ghm::lang::{load, load_str, Model};
use ghm::model::Plant;
use ghm::solve::Ipm;
use std::path::Path;
use std::sync::Arc;

fn model(text: &str) -> Model {
    load_str("test.ghm", text).unwrap_or_else(|e| panic!("{}", e.render()))
}

/// The outputs of `text`'s model at its initial state, start inputs, disturbance values
/// `d` and nominal parameters.
fn outputs(text: &str, d: &[f64]) -> Vec<f64> {
    let plant = Plant::new(model(text));
    let m = &plant.model;
    plant.outputs(&m.initial_state(), &m.start_input(), d, &m.nominal_params())
}

#[test]
fn a_function_is_inlined_with_its_arguments() {
    let y = outputs(
        "sample 60 [s]
state x = 2
der x = 0
fn affine(v, slope, offset) = slope * v + offset
fn twice(v) = affine(v, 2, 0)
output a = affine(x, 3, 1)
output b = twice(affine(x, 1, 1))
output c = affine(affine(x, 1, 0), x, x)
",
        &[],
    );
    assert_eq!(y, [7.0, 6.0, 6.0]);
}

#[test]
fn a_function_body_sees_its_parameters_before_the_models_names() {
    // `x` inside `shadow` is its parameter; `k` is the model's parameter.
    let y = outputs(
        "sample 60 [s]
state x = 2
der x = 0
param k = 10
fn shadow(x) = x + k
let doubled = 2 * x
fn uses_let(v) = v + doubled
output a = shadow(1)
output b = uses_let(1)
",
        &[],
    );
    assert_eq!(y, [11.0, 5.0]);
}

#[test]
fn constants_may_name_constants_declared_below() {
    let m = model(
        "sample 60 [s]
const total = part * 2 + later
param part = base + 1
const base = 3
const later = 1
param plain = total
state x = 0
der x = part + plain
",
    );
    let nominal: Vec<(&str, f64)> = m
        .params
        .iter()
        .map(|p| (p.info.name.as_str(), p.value))
        .collect();
    // Parameters keep their declaration order in the layout.
    assert_eq!(nominal, [("part", 4.0), ("plain", 9.0)]);
}

#[test]
fn logic_comparisons_mod_and_floor_give_their_values() {
    let y = outputs(
        "sample 60 [s]
state x = 0
der x = 0
disturbance a value 0.25
output m = mod(a - 1, 24)
output f = floor(a - 1)
output both = a > 0 and a < 1
output either = a > 1 or a == 0.25
output neither = not (a > 0)
output differs = a != 0.25
output precedence = not a > 1 and a < 1 or 0
",
        &[0.25],
    );
    assert_eq!(y, [23.25, -1.0, 1.0, 1.0, 0.0, 0.0, 1.0]);
}

#[test]
fn the_clock_advances_within_the_step_as_time_does() {
    // ẋ = t: over one step of h from t0, x gains h·t0 + h²/2, exact for RK4 and for two
    // Euler sub-steps only with the time of each sub-step.
    let text = |integrator: &str| {
        format!(
            "sample 100 [s] integrator {integrator} substeps 2
disturbance time [s] clock
state x = 0
der x = time
"
        )
    };
    let rk4 = Plant::new(model(&text("rk4")));
    assert_eq!(rk4.model.weather_columns(), ["time_s"]);
    let step = rk4.step(&[0.0], &[], &[1000.0], &[]);
    assert!((step.next_state[0] - (100.0 * 1000.0 + 5000.0)).abs() < 1e-9);
    let euler = Plant::new(model(&text("euler")));
    let step = euler.step(&[0.0], &[], &[1000.0], &[]);
    assert!((step.next_state[0] - (50.0 * 1000.0 + 50.0 * 1050.0)).abs() < 1e-9);
}

#[test]
fn controllers_plan_with_the_plan_substeps_and_the_plant_simulates_with_its_own() {
    // ẋ = −x over 100 s in Euler steps: (1 − 100/n)ⁿ from x = 1, so the two integrations
    // differ, and which one a plant holds shows in its step.
    let text = |plan: &str| {
        format!(
            "sample 100 [s] integrator euler substeps 4{plan}
state x = 1
der x = -x / 100
"
        )
    };
    let plant = Arc::new(Plant::new(model(&text(" plan substeps 2"))));
    assert_eq!((plant.model.substeps, plant.model.plan_substeps), (4, 2));
    let simulated = plant.step(&[1.0], &[], &[], &[]).next_state[0];
    assert!((simulated - 0.75f64.powi(4)).abs() < 1e-15);
    let planning = plant.planning();
    assert_eq!(planning.model.substeps, 2);
    assert!((planning.step(&[1.0], &[], &[], &[]).next_state[0] - 0.25).abs() < 1e-15);
    assert!(Arc::ptr_eq(&planning, &plant.planning()), "built once");
    // Without `plan substeps`, the plant plans with itself.
    let plain = Arc::new(Plant::new(model(&text(""))));
    assert_eq!(plain.model.plan_substeps, 4);
    assert!(Arc::ptr_eq(&plain, &plain.planning()));
    // MPC predicts with the planning plant.
    let mpc = Mpc::new(plant, 2, Box::new(Ipm::default())).unwrap();
    assert_eq!(mpc.ocp().plant().model.substeps, 2);
}

#[test]
fn the_lamp_clock_example_loads_and_its_lamps_follow_the_clock() {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lamp-clock.ghm");
    let m = load(&file).unwrap_or_else(|e| panic!("{}", e.render()));
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let plant = Plant::new(m);
    let m = &plant.model;
    let lamps = plant.model.output_index("lamps_on").expect("lamps_on");
    let at = |hour: f64, day: f64, radiation: f64| {
        let time = (day - 1.0) * 86_400.0 + hour * 3600.0;
        plant.outputs(
            &m.initial_state(),
            &m.start_input(),
            &[time, 5.0, radiation],
            &m.nominal_params(),
        )[lamps]
    };
    assert!(at(6.0, 20.0, 0.0) > 0.999);
    assert!(at(19.0, 20.0, 0.0) < 1e-12, "off after 18:00");
    assert!(at(6.0, 180.0, 0.0) < 1e-12, "off in summer");
    assert!(at(12.0, 20.0, 500.0) < 0.001, "off in bright sun");
}
