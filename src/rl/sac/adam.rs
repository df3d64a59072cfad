//! Adam on plain `f32` parameter vectors, as PyTorch's `torch.optim.Adam` (β₁ = 0.9,
//! β₂ = 0.999, ε = 1e-8, no weight decay): the optimiser Stable-Baselines3 gives SAC.
//!
//! Its moments are plain vectors beside the parameters, so a checkpoint stores them exactly
//! and a resumed training takes bit-for-bit the steps an uninterrupted one would.
//!
//! A moment that falls below the smallest normal `f32` is set to zero. The moments of a
//! unit whose gradient has stopped (a ReLU that no longer fires) decay by β every step, and
//! after some 800 steps they are subnormal numbers, which x86 cores multiply tens of times
//! more slowly: at the end of the paper study's 100-episode trainings a quarter of the
//! agent's stored values were subnormal moments, and a learning episode took 19 s against
//! 15 s at the start. Zero in their place moves no parameter differently (`m̂ / (√v̂ + ε)`
//! with such an `m` is below 1e-30).

use serde::{Deserialize, Serialize};

/// Adam's state for one group of parameter vectors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Adam {
    /// Decay of the first-moment average (0.9).
    pub beta1: f32,
    /// Decay of the second-moment average (0.999).
    pub beta2: f32,
    /// Added to the root of the second moment in the denominator (1e-8).
    pub epsilon: f32,
    /// Steps taken so far.
    pub steps: u64,
    first: Vec<Vec<f32>>,
    second: Vec<Vec<f32>>,
}

impl Adam {
    /// Zero moments for parameters of the given lengths.
    pub fn new(lengths: &[usize]) -> Adam {
        Adam {
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-8,
            steps: 0,
            first: lengths.iter().map(|&n| vec![0.0; n]).collect(),
            second: lengths.iter().map(|&n| vec![0.0; n]).collect(),
        }
    }

    /// The moments, for checkpoints: first moments then second, one vector per parameter.
    pub fn moments(&self) -> impl Iterator<Item = &Vec<f32>> {
        self.first.iter().chain(&self.second)
    }

    /// Mutable moments in the order of [`Adam::moments`].
    pub fn moments_mut(&mut self) -> impl Iterator<Item = &mut Vec<f32>> {
        self.first.iter_mut().chain(self.second.iter_mut())
    }

    /// One step with learning rate `lr`: `params[i] −= lr · m̂ / (√v̂ + ε)`.
    pub fn step(&mut self, lr: f32, params: Vec<&mut [f32]>, grads: &[Vec<f32>]) {
        self.steps += 1;
        let t = self.steps as i32;
        let correction1 = 1.0 - self.beta1.powi(t);
        let correction2_sqrt = (1.0 - self.beta2.powi(t)).sqrt();
        let step_size = lr / correction1;
        for (((p, g), m), v) in params
            .into_iter()
            .zip(grads)
            .zip(&mut self.first)
            .zip(&mut self.second)
        {
            for (((p, g), m), v) in p.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
                *m = normal_or_zero(self.beta1 * *m + (1.0 - self.beta1) * g);
                *v = normal_or_zero(self.beta2 * *v + (1.0 - self.beta2) * g * g);
                let denominator = v.sqrt() / correction2_sqrt + self.epsilon;
                *p -= step_size * *m / denominator;
            }
        }
    }
}

/// `x`, or zero where it is subnormal (see the [module documentation](self)).
fn normal_or_zero(x: f32) -> f32 {
    if x.abs() < f32::MIN_POSITIVE {
        0.0
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moments_of_a_parameter_whose_gradient_stopped_end_at_zero_not_subnormal() {
        let mut x = vec![1.0f32];
        let mut adam = Adam::new(&[1]);
        adam.step(1e-3, vec![x.as_mut_slice()], &[vec![1.0]]);
        // β₁⁹⁰⁰ · 0.1 ≈ 1e-42 and β₂ decays slower: after 900 steps without a gradient the
        // first moment would be subnormal.
        for _ in 0..900 {
            adam.step(1e-3, vec![x.as_mut_slice()], &[vec![0.0]]);
        }
        let moments: Vec<f32> = adam.moments().flatten().copied().collect();
        assert_eq!(moments[0], 0.0, "{moments:?}");
        assert!(
            moments.iter().all(|m| *m == 0.0 || m.is_normal()),
            "{moments:?}"
        );
    }

    #[test]
    fn minimises_a_quadratic() {
        // f(x) = Σ (x_i − i)², gradient 2 (x − i).
        let mut x = vec![5.0f32, -3.0, 0.0];
        let mut adam = Adam::new(&[3]);
        for _ in 0..2000 {
            let g: Vec<f32> = x
                .iter()
                .enumerate()
                .map(|(i, v)| 2.0 * (v - i as f32))
                .collect();
            adam.step(0.05, vec![x.as_mut_slice()], &[g]);
        }
        for (i, v) in x.iter().enumerate() {
            assert!((v - i as f32).abs() < 1e-3, "{x:?}");
        }
    }

    #[test]
    fn first_step_moves_by_the_learning_rate() {
        // Adam's first step is lr · sign(g) (up to ε).
        let mut x = vec![1.0f32, 1.0];
        let mut adam = Adam::new(&[2]);
        adam.step(0.1, vec![x.as_mut_slice()], &[vec![3.0, -0.001]]);
        assert!(
            (x[0] - 0.9).abs() < 1e-6 && (x[1] - 1.1).abs() < 1e-4,
            "{x:?}"
        );
    }
}
