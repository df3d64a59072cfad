//! One step of GreenLight's Katzin 2021 model (`models/greenlight/katzin_2021.ghm`, 28
//! states, `radau5` with 4 sub-steps of 75 s): the value (Newton on the stage equations),
//! and the exact Jacobian with respect to (x, u) and Hessian of λᵀ(x⁺, terms, y) by the
//! implicit function theorem. Weather: each disturbance's default value (night, 20 °C
//! outside); inputs: heating, screen and CO₂ on, lamps off.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use ghm::model::{Plant, StepDerivatives};

fn greenlight() -> (Plant, Vec<f64>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/greenlight/katzin_2021.ghm"
    );
    let model = match ghm::lang::load(std::path::Path::new(path)) {
        Ok(m) => m,
        Err(e) => panic!("{}", e.render()),
    };
    let plant = Plant::new(model);
    let m = &plant.model;
    let mut z = m.initial_state();
    z.extend(m.inputs.iter().map(|u| match u.info.name.as_str() {
        "uLamp" | "uRoof" => 0.0,
        _ => 1.0,
    }));
    z.extend(m.disturbances.iter().map(|d| d.value.unwrap_or(0.0)));
    z.extend(m.nominal_params());
    (plant, z)
}

fn step(c: &mut Criterion) {
    let (plant, z) = greenlight();
    let mut ws = plant.workspace();
    let mut out = vec![0.0; plant.n_step_outputs()];
    plant.eval_step(&mut ws, &z, &mut out);
    assert!(
        out.iter().all(|v| v.is_finite()),
        "the benchmark's step is not finite"
    );
    let l = plant.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let mut group = c.benchmark_group("greenlight step");
    group.sample_size(20);
    group.bench_function("value", |b| {
        b.iter(|| plant.eval_step(&mut ws, black_box(&z), &mut out))
    });
    let mut der = StepDerivatives::new(&plant, &wrt);
    group.bench_function("Jacobian wrt (x, u)", |b| {
        b.iter(|| der.jacobian(&plant, black_box(&z)).jacobian[0])
    });
    let weights: Vec<f64> = (0..plant.n_step_outputs())
        .map(|i| 0.5 + 0.1 * i as f64)
        .collect();
    group.bench_function("Hessian of weighted outputs wrt (x, u)", |b| {
        b.iter(|| der.hessian(&plant, black_box(&z), &weights).hessian[0])
    });
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
