//! One SAC gradient step (batch 1024, the paper's 2 × 128 networks, 12 observations,
//! 3 actions) on burn's flex CPU back-end: the cost that dominates `ghm train`.

use burn::tensor::Device;
use criterion::{criterion_group, criterion_main, Criterion};
use ghm::rl::buffer::{Batch, ReplayBuffer};
use ghm::rl::sac::Sac;
use ghm::rl::Normalizer;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn update(c: &mut Criterion) {
    let (ow, aw) = (12, 3);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut buffer = ReplayBuffer::new(ow, aw, 20_000);
    for _ in 0..20_000 {
        let s: Vec<f64> = (0..ow).map(|_| rng.random_range(-1.0..1.0)).collect();
        let a: Vec<f64> = (0..aw).map(|_| rng.random_range(-1.0..1.0)).collect();
        let s2: Vec<f64> = (0..ow).map(|_| rng.random_range(-1.0..1.0)).collect();
        buffer
            .push(&s, &a, rng.random_range(-1.0..1.0), &s2, false)
            .unwrap();
    }
    let normalizer = Normalizer::new(ow);
    let mut agent = Sac::new(ow, aw, &[128, 128], &mut rng);
    let device = Device::flex().autodiff();
    let mut batch = Batch::default();
    c.bench_function("sac_update_batch_1024", |b| {
        b.iter(|| {
            buffer
                .sample(1024, &mut rng, &normalizer, &mut batch)
                .unwrap();
            agent
                .update(&batch, 1e-3, 0.95, 0.005, -3.0, &mut rng, &device)
                .unwrap()
        })
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = update
}
criterion_main!(benches);
