//! Imitation of a teacher's actions: the regression of a deterministic actor
//! `a = tanh(μ(ŝ))` onto demonstrated actions, the learning step of policy distillation
//! (`ghm distill`, DAgger in [`job::distill`](crate::job)).
//!
//! The actor is the agent's own network ([`Net`], ReLU hidden layers, the shape SAC ships),
//! so a distilled policy is a [`PolicyFile`](crate::agent::PolicyFile) like SAC's and drops
//! in wherever a guide is accepted. Observations are standardised with frozen statistics
//! ([`Normalizer`]) as the policy will standardise them; the loss is the mean squared error
//! between `tanh(μ(ŝ))` and the teacher's action in `[−1, 1]^nu`, minimised with Adam on
//! shuffled mini-batches, its gradient steps written out
//! ([`regression`](crate::rl::regression)). A fit continues from the weights it is given, so DAgger's later
//! iterations refine the last student instead of starting over.

use crate::agent::Normalizer;
use crate::nn::{Activation, Mlp};
use crate::rl::regression::{zero_gradients, OutputMap, Regression};
use crate::rl::sac::adam::Adam;
use crate::rl::sac::net::Net;
use crate::rl::{AgentError, RlError};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// The imitation fit's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImitationConfig {
    /// Hidden layer widths of the actor (ReLU), as SAC's.
    pub hidden: Vec<usize>,
    /// Adam's learning rate.
    pub learning_rate: f64,
    /// Demonstrations per gradient step.
    pub batch_size: usize,
    /// Passes over the demonstrations of each fit.
    pub epochs: usize,
}

impl Default for ImitationConfig {
    /// SAC's actor shape (128 × 128), Adam at 10⁻³, batches of 256, 60 passes a fit (20
    /// left the paper variant's best student at 3.1803 €/m², 60 at 3.2198: `docs/results.md`).
    fn default() -> ImitationConfig {
        ImitationConfig {
            hidden: crate::rl::sac::SacConfig::default().hidden,
            learning_rate: 1e-3,
            batch_size: 256,
            epochs: 60,
        }
    }
}

impl ImitationConfig {
    /// Refuses settings that cannot fit; the error names the field.
    pub fn check(&self) -> Result<(), RlError> {
        let bad = |name: &'static str, why: &str| {
            Err(RlError::BadConfig {
                name,
                why: why.into(),
            })
        };
        if self.hidden.is_empty() || self.hidden.contains(&0) {
            return bad("hidden", "needs at least one layer, each at least one wide");
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return bad("learning_rate", "must be a positive number");
        }
        if self.batch_size == 0 || self.epochs == 0 {
            return bad("batch_size, epochs", "each must be at least 1");
        }
        Ok(())
    }

    /// A fresh actor for `observation` inputs and `actions` outputs, initialised as SAC
    /// initialises its own.
    pub fn new_actor(&self, observation: usize, actions: usize, seed: u64) -> Net {
        let mut widths = vec![observation];
        widths.extend_from_slice(&self.hidden);
        widths.push(actions);
        Net::init(&widths, &mut ChaCha8Rng::seed_from_u64(seed))
    }
}

/// A fitted actor as the plain weights of a [`PolicyFile`](crate::agent::PolicyFile)'s
/// `actor`: its layers with the tanh output that maps it into `[−1, 1]`.
pub fn actor_weights(actor: &Net) -> Result<Mlp, RlError> {
    actor
        .to_mlp(Activation::Tanh)
        .map_err(|e| RlError::Backend(e.to_string()))
}

/// Demonstrations: observations (raw, row-major) and the teacher's actions for them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Demonstrations {
    /// Entries of one observation.
    pub width: usize,
    /// Entries of one action.
    pub actions_per_row: usize,
    /// `len × width` observations.
    pub observations: Vec<f64>,
    /// `len × actions_per_row` actions in `[−1, 1]`.
    pub actions: Vec<f64>,
}

impl Demonstrations {
    /// No demonstrations yet, of the given widths.
    pub fn new(width: usize, actions_per_row: usize) -> Demonstrations {
        Demonstrations {
            width,
            actions_per_row,
            ..Demonstrations::default()
        }
    }

    /// How many observation–action pairs.
    pub fn len(&self) -> usize {
        self.observations.len() / self.width.max(1)
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.observations.is_empty()
    }

    /// Adds one pair. Errors where a width does not match.
    pub fn push(&mut self, observation: &[f64], action: &[f64]) -> Result<(), RlError> {
        if observation.len() != self.width || action.len() != self.actions_per_row {
            return Err(AgentError::BatchShape {
                len: observation.len() + action.len(),
                width: self.width + self.actions_per_row,
            }
            .into());
        }
        self.observations.extend_from_slice(observation);
        self.actions.extend_from_slice(action);
        Ok(())
    }

    /// Adds every pair of `other`.
    pub fn extend(&mut self, other: &Demonstrations) -> Result<(), RlError> {
        if other.width != self.width || other.actions_per_row != self.actions_per_row {
            return Err(AgentError::BatchShape {
                len: other.width + other.actions_per_row,
                width: self.width + self.actions_per_row,
            }
            .into());
        }
        self.observations.extend_from_slice(&other.observations);
        self.actions.extend_from_slice(&other.actions);
        Ok(())
    }
}

/// Fits `actor` (continuing from its weights) to `data`, its observations standardised by
/// `normalizer`; `seed` drives the shuffles. Returns each epoch's mean squared action
/// error (in squared action units, `[−1, 1]`).
///
/// # Examples
///
/// A teacher that heats against the cold, `a = tanh(−2 (T − 15)/5)`, learnt from 400
/// demonstrations in a fraction of a second:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::agent::Normalizer;
/// use ghm::rl::imitation::{actor_weights, fit_actor, Demonstrations, ImitationConfig};
///
/// let mut data = Demonstrations::new(1, 1);
/// for i in 0..400 {
///     let t = 5.0 + 20.0 * i as f64 / 399.0;
///     data.push(&[t], &[(-2.0 * (t - 15.0) / 5.0).tanh()])?;
/// }
/// let mut normalizer = Normalizer::from_stats(vec![15.0], vec![33.0], 1.0)?;
/// normalizer.freeze();
/// let config = ImitationConfig { hidden: vec![16], learning_rate: 1e-2, epochs: 60, ..Default::default() };
/// let mut actor = config.new_actor(1, 1, 7);
/// let losses = fit_actor(&mut actor, &normalizer, &data, &config, 7)?;
/// assert!(losses[59] < 0.1 * losses[0], "{losses:?}");
/// let mlp = actor_weights(&actor)?;
/// let mut z = [0.0];
/// normalizer.normalize(&[8.0], &mut z)?;
/// assert!(mlp.forward(&z)[0] > 0.8); // cold: heat
/// # Ok(())
/// # }
/// ```
pub fn fit_actor(
    actor: &mut Net,
    normalizer: &Normalizer,
    data: &Demonstrations,
    config: &ImitationConfig,
    seed: u64,
) -> Result<Vec<f64>, RlError> {
    config.check()?;
    let (width, nu, n) = (data.width, data.actions_per_row, data.len());
    if n == 0 || actor.inputs() != width || actor.outputs() != nu {
        return Err(RlError::BadConfig {
            name: "demonstrations",
            why: format!(
                "{n} pairs of {width} observations and {nu} actions for an actor of {} inputs \
                 and {} outputs: need at least one pair, of the actor's widths",
                actor.inputs(),
                actor.outputs()
            ),
        });
    }
    let mut z = vec![0.0f32; n * width];
    let mut scratch = vec![0.0; width];
    for (row, out) in data.observations.chunks(width).zip(z.chunks_mut(width)) {
        normalizer.normalize_f32(row, &mut scratch, out)?;
    }
    let y: Vec<f32> = data
        .actions
        .iter()
        .map(|a| a.clamp(-1.0, 1.0) as f32)
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut order: Vec<usize> = (0..n).collect();
    let mut gradients = zero_gradients(actor);
    let lengths: Vec<usize> = gradients.iter().map(Vec::len).collect();
    let mut adam = Adam::new(&lengths);
    let lr = config.learning_rate as f32;
    let mut losses = Vec::with_capacity(config.epochs);
    let mut regression = Regression::new();
    let (mut zb, mut yb) = (Vec::new(), Vec::new());
    for epoch in 1..=config.epochs {
        order.shuffle(&mut rng);
        let mut sum = 0.0;
        for rows in order.chunks(config.batch_size) {
            zb.clear();
            yb.clear();
            for &r in rows {
                zb.extend_from_slice(&z[r * width..(r + 1) * width]);
                yb.extend_from_slice(&y[r * nu..(r + 1) * nu]);
            }
            let loss = regression.step(actor, OutputMap::Tanh, &zb, &yb, &mut gradients);
            sum += f64::from(loss) * rows.len() as f64;
            adam.step(lr, actor.parameters_mut(), &gradients);
        }
        let loss = sum / n as f64;
        if !loss.is_finite() {
            return Err(RlError::Backend(format!(
                "the imitation fit diverged at epoch {epoch}"
            )));
        }
        losses.push(loss);
    }
    Ok(losses)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_mismatched_widths() {
        let mut data = Demonstrations::new(2, 1);
        assert!(data.push(&[1.0], &[0.0]).is_err());
        data.push(&[1.0, 2.0], &[0.5]).unwrap();
        let normalizer = Normalizer::new(2);
        let config = ImitationConfig::default();
        let mut actor = config.new_actor(3, 1, 0);
        assert!(fit_actor(&mut actor, &normalizer, &data, &config, 0).is_err());
    }
}
