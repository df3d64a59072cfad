//! The reinforcement-learning environment: one 1920-step (40-day) lettuce episode with
//! random actions on the built-in weather, deterministic and with parameters redrawn every
//! step (the thesis code's stochastic plant). Throughput is reported in env steps per second.
//!
//! Every iteration replays the same episode (the RNG is reseeded): with parameters redrawn
//! every step, random actions can heat the greenhouse past the photosynthesis singularity
//! near 42 °C within a few hundred episodes, and the plant then diverges.

use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};
use ghm::model::Plant;
use ghm::rl::Env;
use ghm::sim::season::UncertaintyDraw;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

const STEPS: usize = 1920;

fn env(file: &str, uncertainty: Option<UncertaintyDraw>) -> Env {
    let path = format!("{}/models/{file}", env!("CARGO_MANIFEST_DIR"));
    let model = match ghm::lang::load(std::path::Path::new(&path)) {
        Ok(m) => m,
        Err(e) => panic!("{}", e.render()),
    };
    let plant = Arc::new(Plant::new(model));
    let weather = ghm::sim::weather::builtin_season(STEPS, 1800.0, 1)
        .select(&plant.model.weather_columns(), 0, STEPS)
        .expect("built-in weather");
    Env::new(plant, weather, STEPS, uncertainty).expect("env")
}

fn episode(c: &mut Criterion) {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let actions: Vec<[f64; 3]> = (0..STEPS)
        .map(|_| std::array::from_fn(|_| rng.random_range(-1.0..=1.0)))
        .collect();
    let mut group = c.benchmark_group("rl env: 1920-step lettuce episode, random actions");
    group.throughput(Throughput::Elements(STEPS as u64));
    let cases = [
        ("deterministic", env("lettuce.ghm", None)),
        (
            "parameters redrawn every step",
            env(
                "lettuce-thesis.ghm",
                Some(UncertaintyDraw {
                    delta: 0.1,
                    seed: 4,
                }),
            ),
        ),
    ];
    for (name, mut env) in cases {
        group.bench_function(name, |b| {
            b.iter(|| {
                env.reseed(4);
                env.reset();
                let mut total = 0.0;
                for a in &actions {
                    total += env.step(black_box(a)).expect("step").reward;
                }
                total
            })
        });
    }
    group.finish();
}

criterion_group!(benches, episode);
criterion_main!(benches);
