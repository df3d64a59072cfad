//! One discrete lettuce step on the real model (RK4, 4 sub-steps): value, Jacobian with
//! respect to (x, u), and Hessian of λᵀ(x⁺, stage terms) with respect to (x, u).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use ghm::graph::Derivatives;
use ghm::model::Plant;

fn lettuce() -> (Plant, Vec<f64>) {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/models/lettuce.ghm");
    let model = match ghm::lang::load(std::path::Path::new(path)) {
        Ok(m) => m,
        Err(e) => panic!("{}", e.render()),
    };
    let plant = Plant::new(model);
    let mut z = plant.model.initial_state();
    z.extend([0.6, 1.0, 40.0]);
    z.extend([120.0, 8.633266287531026e-4, 5.6, 5.49814522601458e-3]);
    z.extend(plant.model.nominal_params());
    (plant, z)
}

fn step(c: &mut Criterion) {
    let (plant, z) = lettuce();
    let tape = plant.step_tape();
    let wrt: Vec<usize> = (0..7).collect();
    let mut ws = tape.workspace::<f64>();
    let mut out = vec![0.0; tape.n_outputs()];
    c.bench_function("lettuce step: value", |b| {
        b.iter(|| tape.eval(&mut ws, black_box(&z), &mut out))
    });
    let mut der = Derivatives::new(tape, &wrt);
    c.bench_function("lettuce step: Jacobian wrt (x, u)", |b| {
        b.iter(|| der.jacobian(tape, black_box(&z)).jacobian[0])
    });
    let weights: Vec<f64> = (0..tape.n_outputs())
        .map(|i| 0.5 + 0.1 * i as f64)
        .collect();
    c.bench_function(
        "lettuce step: Hessian of weighted outputs wrt (x, u)",
        |b| b.iter(|| der.hessian(tape, black_box(&z), &weights).hessian[0]),
    );
}

/// One 1920-step (40-day) season with constant inputs on the built-in weather.
fn season(c: &mut Criterion) {
    use ghm::control::ConstantInput;
    use ghm::sim::season::{run_season, SeasonConfig, StepLog};
    let (plant, _) = lettuce();
    let cols = plant.model.weather_columns();
    let weather = ghm::sim::weather::builtin_season(1920, 1800.0, 1)
        .select(&cols, 0, 1920)
        .expect("built-in weather");
    let config = SeasonConfig {
        steps: 1920,
        enforce_limits: true,
        uncertainty: None,
    };
    c.bench_function("lettuce season: 1920 steps, constant input", |b| {
        b.iter(|| {
            let mut controller = ConstantInput(vec![0.6, 1.0, 40.0]);
            run_season(
                &plant,
                &weather,
                &mut controller,
                &config,
                &mut |_: &StepLog| {},
            )
            .expect("season")
            .metrics
            .epi
        })
    });
}

criterion_group!(benches, step, season);
criterion_main!(benches);
