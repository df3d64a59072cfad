//! Soft actor-critic (Haarnoja et al. 2018) as Stable-Baselines3 implements it: a
//! tanh-squashed Gaussian actor, twin Q critics with Polyak-averaged targets, and an
//! entropy coefficient tuned towards a target entropy.
//!
//! One gradient step ([`Sac::update`]), in SB3's order:
//!
//! 1. sample `ã ~ π(·|s)` with the reparameterisation `ã = tanh(μ + σ ε)`;
//! 2. entropy coefficient: `α = exp(log α)` is read, then `log α` takes an Adam step on
//!    `−log α · mean(log π(ã|s) + H̄)`;
//! 3. critics: `y = r + γ (1 − done) (min_i Q̄_i(s', ã') − α log π(ã'|s'))` with `ã' ~ π(·|s')`
//!    and the target critics `Q̄`; loss `½ Σ_i mean((Q_i(s, a) − y)²)`;
//! 4. actor: loss `mean(α log π(ã|s) − min_i Q_i(s, ã))` through the updated critics;
//! 5. targets: `Q̄_i ← (1 − τ) Q̄_i + τ Q_i`.
//!
//! The Gaussian noise comes from the caller's seeded generator, so a step is a pure
//! function of the agent, the batch and the generator's state.

use crate::rl::buffer::Batch;
use crate::rl::sac::adam::Adam;
use crate::rl::sac::net::{to_vec, Net};
use crate::rl::RlError;
use burn::tensor::{Device, Tensor, TensorData};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// SB3's bounds on the actor's log standard deviation.
pub const LOG_STD_MIN: f32 = -20.0;
/// The upper of SB3's bounds on the actor's log standard deviation.
pub const LOG_STD_MAX: f32 = 2.0;
/// SB3's guard inside `log(1 − tanh² + ε)`.
const SQUASH_EPSILON: f32 = 1e-6;

/// The networks and optimiser states of a soft actor-critic agent.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Sac {
    /// Entries of an observation (the actor's input).
    pub observation_width: usize,
    /// Entries of an action (one per model input).
    pub action_width: usize,
    /// Outputs `[μ, log σ]`, `2 × action_width` values.
    pub actor: Net,
    /// The twin critics `Q_1, Q_2`: input `[observation, action]`, output one value.
    pub critics: [Net; 2],
    /// The Polyak-averaged target critics `Q̄_1, Q̄_2`.
    pub targets: [Net; 2],
    /// `log α`, the logarithm of the entropy coefficient.
    pub log_alpha: f32,
    /// Adam's state for the actor.
    pub actor_adam: Adam,
    /// Adam's state for each critic, in the order of `critics`.
    pub critic_adam: [Adam; 2],
    /// Adam's state for `log_alpha`.
    pub alpha_adam: Adam,
}

/// What one gradient step measured.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct UpdateStats {
    /// The critics' loss `½ mean((Q_i − y)²)`, summed over both critics.
    pub critic_loss: f32,
    /// The actor's loss `mean(α log π − min_i Q_i)`.
    pub actor_loss: f32,
    /// The entropy coefficient α used in this step (before `log α` moved).
    pub alpha: f32,
    /// The batch estimate of the policy's entropy, `−mean(log π(ã|s))`.
    pub entropy: f32,
}

impl Sac {
    /// A fresh agent with `hidden` layer widths for every network.
    pub fn new<R: Rng>(
        observation_width: usize,
        action_width: usize,
        hidden: &[usize],
        rng: &mut R,
    ) -> Sac {
        let widths = |inputs: usize, outputs: usize| {
            let mut w = vec![inputs];
            w.extend_from_slice(hidden);
            w.push(outputs);
            w
        };
        let actor = Net::init(&widths(observation_width, 2 * action_width), rng);
        let critic_widths = widths(observation_width + action_width, 1);
        let critics = [
            Net::init(&critic_widths, rng),
            Net::init(&critic_widths, rng),
        ];
        let lengths =
            |net: &Net| -> Vec<usize> { net.parameters().iter().map(|p| p.len()).collect() };
        Sac {
            observation_width,
            action_width,
            actor_adam: Adam::new(&lengths(&actor)),
            critic_adam: [
                Adam::new(&lengths(&critics[0])),
                Adam::new(&lengths(&critics[1])),
            ],
            alpha_adam: Adam::new(&[1]),
            targets: critics.clone(),
            critics,
            actor,
            log_alpha: 0.0,
        }
    }

    /// The action for one standardised observation: `tanh(μ)` when `deterministic`, else a
    /// draw `tanh(μ + σ ε)`.
    pub fn act<R: Rng>(&self, observation: &[f32], deterministic: bool, rng: &mut R) -> Vec<f64> {
        if deterministic {
            return self.act_deterministic(observation);
        }
        let mut out = Vec::with_capacity(2 * self.action_width);
        self.actor.forward_one(observation, &mut out);
        let n = self.action_width;
        (0..n)
            .map(|i| {
                let log_std = out[n + i].clamp(LOG_STD_MIN, LOG_STD_MAX);
                let noise = standard_normal(rng);
                f64::from((out[i] + log_std.exp() * noise).tanh())
            })
            .collect()
    }

    /// The deterministic action `tanh(μ)` (what [`crate::rl::PolicyFile`] exports).
    pub fn act_deterministic(&self, observation: &[f32]) -> Vec<f64> {
        let mut out = Vec::with_capacity(2 * self.action_width);
        self.actor.forward_one(observation, &mut out);
        out[..self.action_width]
            .iter()
            .map(|m| f64::from(m.tanh()))
            .collect()
    }

    /// One gradient step on `batch` with learning rate `lr`. See the [module
    /// documentation](self).
    #[allow(clippy::too_many_arguments)]
    pub fn update<R: Rng>(
        &mut self,
        batch: &Batch,
        lr: f32,
        gamma: f32,
        tau: f32,
        target_entropy: f32,
        rng: &mut R,
        device: &Device,
    ) -> Result<UpdateStats, RlError> {
        let (b, ow, aw) = (batch.size, self.observation_width, self.action_width);
        let matrix = |values: &[f32], cols: usize| {
            Tensor::<2>::from_data(TensorData::new(values.to_vec(), [b, cols]), device)
        };
        let noise = |rng: &mut R| {
            let v: Vec<f32> = (0..b * aw).map(|_| standard_normal(rng)).collect();
            matrix(&v, aw)
        };
        let observations = matrix(&batch.observations, ow);
        let next_observations = matrix(&batch.next_observations, ow);
        let actions = matrix(&batch.actions, aw);
        let rewards = matrix(&batch.rewards, 1);
        let not_done = matrix(&batch.dones, 1).neg().add_scalar(1.0);
        let eps_now = noise(rng);
        let eps_next = noise(rng);

        // 1. ã ~ π(·|s), tracked through the actor.
        let actor_live = self.actor.tensors(device, true);
        let (sampled, log_prob) =
            squashed_sample(actor_live.forward(observations.clone()), eps_now, aw);

        // 2. Entropy coefficient.
        let alpha = self.log_alpha.exp();
        let log_prob_values = to_vec(log_prob.clone().detach())?;
        let mean_log_prob = log_prob_values.iter().sum::<f32>() / b as f32;
        let alpha_grad = -(mean_log_prob + target_entropy);
        let mut log_alpha = [self.log_alpha];
        self.alpha_adam
            .step(lr, vec![&mut log_alpha[..]], &[vec![alpha_grad]]);
        self.log_alpha = log_alpha[0];

        // 3. Critics.
        let target = {
            let actor_fixed = self.actor.tensors(device, false);
            let (next_actions, next_log_prob) =
                squashed_sample(actor_fixed.forward(next_observations.clone()), eps_next, aw);
            let input = Tensor::cat(vec![next_observations, next_actions], 1);
            let q1 = self.targets[0]
                .tensors(device, false)
                .forward(input.clone());
            let q2 = self.targets[1].tensors(device, false).forward(input);
            let soft_value = q1.min_pair(q2) - next_log_prob.mul_scalar(alpha);
            (rewards + not_done * soft_value.mul_scalar(gamma)).detach()
        };
        let critic_input = Tensor::cat(vec![observations.clone(), actions], 1);
        let mut critic_loss_value = 0.0;
        for (critic, adam) in self.critics.iter_mut().zip(&mut self.critic_adam) {
            let live = critic.tensors(device, true);
            let error = live.forward(critic_input.clone()) - target.clone();
            let loss = error.square().mean().mul_scalar(0.5);
            critic_loss_value += to_vec(loss.clone().detach())?[0];
            let grads = live.gradients(&loss.backward())?;
            adam.step(lr, critic.parameters_mut(), &grads);
        }

        // 4. Actor, through the updated critics (their weights untracked).
        let policy_input = Tensor::cat(vec![observations, sampled], 1);
        let q1 = self.critics[0]
            .tensors(device, false)
            .forward(policy_input.clone());
        let q2 = self.critics[1].tensors(device, false).forward(policy_input);
        let actor_loss = (log_prob.mul_scalar(alpha) - q1.min_pair(q2)).mean();
        let actor_loss_value = to_vec(actor_loss.clone().detach())?[0];
        let grads = actor_live.gradients(&actor_loss.backward())?;
        self.actor_adam
            .step(lr, self.actor.parameters_mut(), &grads);

        // 5. Targets.
        for (target, critic) in self.targets.iter_mut().zip(&self.critics) {
            target.polyak(critic, tau);
        }
        if !(critic_loss_value.is_finite() && actor_loss_value.is_finite()) {
            return Err(RlError::Backend(format!(
                "the losses are not finite (critic {critic_loss_value}, actor {actor_loss_value})"
            )));
        }
        Ok(UpdateStats {
            critic_loss: critic_loss_value,
            actor_loss: actor_loss_value,
            alpha,
            entropy: -mean_log_prob,
        })
    }
}

/// `ã = tanh(μ + σ ε)` and `log π(ã)` (one column) from the actor's `[μ, log σ]` output.
fn squashed_sample(output: Tensor<2>, noise: Tensor<2>, width: usize) -> (Tensor<2>, Tensor<2>) {
    let mean = output.clone().narrow(1, 0, width);
    let log_std = output
        .narrow(1, width, width)
        .clamp(LOG_STD_MIN, LOG_STD_MAX);
    let gaussian = mean + log_std.clone().exp() * noise.clone();
    let action = gaussian.tanh();
    let half_log_two_pi = 0.5 * (2.0 * std::f32::consts::PI).ln();
    let gaussian_log_prob =
        (noise.square().mul_scalar(-0.5) - log_std).add_scalar(-half_log_two_pi);
    let squash = action
        .clone()
        .square()
        .neg()
        .add_scalar(1.0 + SQUASH_EPSILON)
        .log();
    let log_prob = (gaussian_log_prob - squash).sum_dim(1);
    (action, log_prob)
}

/// A standard normal draw (Box–Muller on two uniform draws; one is discarded so that each
/// draw consumes the generator identically).
pub fn standard_normal<R: Rng>(rng: &mut R) -> f32 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]
    let u2: f64 = rng.random::<f64>();
    ((-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()) as f32
}
