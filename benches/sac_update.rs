//! One SAC gradient step (batch 1024, the paper's 2 × 128 networks, 12 observations,
//! 3 actions) on burn's flex CPU back-end: the cost that dominates `ghm train`, with its
//! floating-point work and what one core can do beside it (issue 39, part 5).
//!
//! Criterion reports each benchmark's throughput in elements per second; every element here
//! is one floating-point operation (a fused multiply-add counts two), so "Gelem/s" reads as
//! GFLOP/s:
//!
//! * `sac_update_batch_1024`: the update's matrix products ([`update_flops`]);
//! * `flex_matmul_1024x128x128`: the update's most common product alone, on the same
//!   back-end, the best the update's kernels reach at its shapes;
//! * `fma_peak`: independent fused multiply-adds on the widest vector unit the core has,
//!   one core's measured peak.
//!
//! Run on one core, so that the figures are one core's:
//! `RAYON_NUM_THREADS=1 taskset -c 1 cargo bench --bench sac_update`.

use burn::tensor::{Device, Tensor, TensorData};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use ghm::rl::buffer::{Batch, ReplayBuffer};
use ghm::rl::sac::Sac;
use ghm::rl::Normalizer;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

const BATCH: usize = 1024;
const OBSERVATIONS: usize = 12;
const ACTIONS: usize = 3;
const HIDDEN: [usize; 2] = [128, 128];

/// Multiply-adds of one sample through the affine layers of a perceptron with `widths`
/// (`[inputs, hidden…, outputs]`): `Σ wᵢ₋₁ wᵢ`.
fn multiply_adds(widths: &[usize]) -> u64 {
    widths.windows(2).map(|w| (w[0] * w[1]) as u64).sum()
}

/// Floating-point operations of the matrix products of one SAC update
/// ([`Sac::update`]) on a batch of `batch`: the products dominate (biases, activations,
/// the squashed Gaussian and Adam add well under 1 %).
///
/// With `F` a network's forward multiply-adds per sample and `F₁` its first layer's, a
/// backward pass costs `F` for the weights' gradients and `F − F₁` for the gradients of
/// the hidden layers' inputs (`F` where the network's input is tracked too):
///
/// * the actor forward on `s` (tracked) and on `s'` (untracked): `2 F_π`;
/// * the two target critics on `(s', ã')`: `2 F_Q`;
/// * each critic's loss: forward `F_Q`, backward `F_Q + (F_Q − F_Q₁)`: `2 (3 F_Q − F_Q₁)`;
/// * the actor's loss through both critics (their weights untracked, their input tracked):
///   forward and input gradients, `2 (F_Q + F_Q)`;
/// * the actor's backward pass: `F_π + (F_π − F_π₁)`.
fn update_flops(batch: usize) -> u64 {
    let actor = [&[OBSERVATIONS][..], &HIDDEN, &[2 * ACTIONS]].concat();
    let critic = [&[OBSERVATIONS + ACTIONS][..], &HIDDEN, &[1]].concat();
    let (f_pi, f_q) = (multiply_adds(&actor), multiply_adds(&critic));
    let (f_pi1, f_q1) = (multiply_adds(&actor[..2]), multiply_adds(&critic[..2]));
    let multiply_adds_per_sample =
        2 * f_pi + 2 * f_q + 2 * (3 * f_q - f_q1) + 2 * (2 * f_q) + (2 * f_pi - f_pi1);
    2 * multiply_adds_per_sample * batch as u64
}

fn update(c: &mut Criterion) {
    let (ow, aw) = (OBSERVATIONS, ACTIONS);
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
    let mut agent = Sac::new(ow, aw, &HIDDEN, &mut rng);
    let device = ghm::rl::sac::training_device();
    let mut batch = Batch::default();
    let mut group = c.benchmark_group("sac");
    group.throughput(Throughput::Elements(update_flops(BATCH)));
    group.bench_function("sac_update_batch_1024", |b| {
        b.iter(|| {
            buffer
                .sample(BATCH, &mut rng, &normalizer, &mut batch)
                .unwrap();
            agent
                .update(&batch, 1e-3, 0.95, 0.005, -3.0, &mut rng, &device)
                .unwrap()
        })
    });
    group.finish();
}

/// The hidden layer's product of a batch of 1024, `[1024 × 128] · [128 × 128]`, on the
/// update's back-end: the most the update's matrix kernels reach at its shapes.
fn matmul(c: &mut Criterion) {
    let device = Device::flex();
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut random = |rows: usize, cols: usize| {
        let values: Vec<f32> = (0..rows * cols)
            .map(|_| rng.random_range(-1.0..1.0))
            .collect();
        Tensor::<2>::from_data(TensorData::new(values, [rows, cols]), &device)
    };
    let (x, w) = (random(BATCH, HIDDEN[0]), random(HIDDEN[0], HIDDEN[1]));
    let mut group = c.benchmark_group("sac");
    group.throughput(Throughput::Elements(
        2 * (BATCH * HIDDEN[0] * HIDDEN[1]) as u64,
    ));
    group.bench_function("flex_matmul_1024x128x128", |b| {
        b.iter(|| black_box(x.clone().matmul(w.clone())))
    });
    group.finish();
}

/// One core's peak: independent fused multiply-adds on its widest vector unit.
fn fma_peak(c: &mut Criterion) {
    let Some((unit, flops_per_round, kernel)) = peak::widest() else {
        eprintln!("fma_peak skipped: no x86-64 FMA unit on this machine");
        return;
    };
    let mut group = c.benchmark_group("sac");
    group.throughput(Throughput::Elements(flops_per_round * peak::ROUNDS));
    group.bench_function(format!("fma_peak_{unit}"), |b| {
        b.iter(|| black_box(kernel(black_box(1.0))))
    });
    group.finish();
}

#[cfg(target_arch = "x86_64")]
mod peak {
    //! Chains of fused multiply-adds, as many as keep both FMA ports busy through their
    //! four-cycle latency, on 16 (AVX-512) or 8 (AVX2) `f32` lanes.
    use std::arch::x86_64::*;

    /// Rounds of every chain per call.
    pub const ROUNDS: u64 = 100_000;
    /// Independent accumulators: two ports × four cycles of latency, and some to spare.
    const CHAINS: usize = 12;

    type Kernel = fn(f32) -> f32;

    /// The widest unit this core has, the operations of one round and its kernel.
    pub fn widest() -> Option<(&'static str, u64, Kernel)> {
        if is_x86_feature_detected!("avx512f") {
            Some(("avx512", (CHAINS * 16 * 2) as u64, avx512))
        } else if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            Some(("avx2", (CHAINS * 8 * 2) as u64, avx2))
        } else {
            None
        }
    }

    fn avx512(seed: f32) -> f32 {
        // SAFETY: `widest` hands this kernel out only where AVX-512F is detected.
        unsafe { chains_avx512(seed) }
    }

    fn avx2(seed: f32) -> f32 {
        // SAFETY: `widest` hands this kernel out only where AVX2 and FMA are detected.
        unsafe { chains_avx2(seed) }
    }

    #[target_feature(enable = "avx512f")]
    fn chains_avx512(seed: f32) -> f32 {
        let (a, b) = (_mm512_set1_ps(0.999_999), _mm512_set1_ps(1e-7));
        let mut acc = [_mm512_set1_ps(seed); CHAINS];
        for _ in 0..ROUNDS {
            for x in &mut acc {
                *x = _mm512_fmadd_ps(*x, a, b);
            }
        }
        acc.iter().map(|&x| _mm512_reduce_add_ps(x)).sum()
    }

    #[target_feature(enable = "avx2,fma")]
    fn chains_avx2(seed: f32) -> f32 {
        let (a, b) = (_mm256_set1_ps(0.999_999), _mm256_set1_ps(1e-7));
        let mut acc = [_mm256_set1_ps(seed); CHAINS];
        for _ in 0..ROUNDS {
            for x in &mut acc {
                *x = _mm256_fmadd_ps(*x, a, b);
            }
        }
        let mut lanes = [0.0f32; 8];
        acc.iter()
            .map(|&x| {
                // SAFETY: `lanes` holds the eight floats an unaligned store writes.
                unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), x) };
                lanes.iter().sum::<f32>()
            })
            .sum()
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod peak {
    pub const ROUNDS: u64 = 0;
    pub fn widest() -> Option<(&'static str, u64, fn(f32) -> f32)> {
        None
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(30);
    targets = update, matmul, fma_peak
}
criterion_main!(benches);
