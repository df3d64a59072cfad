//! The training's data types, apart from the loop that makes them, so that the checkpoint
//! (which stores them) and the trainer (which runs on them) do not import each other: the
//! settings ([`SacConfig`]), a row of the learning curve ([`EpisodeRecord`]), a running
//! episode's progress ([`StepProgress`]) and the best evaluated policy ([`BestPolicy`]).

use crate::rl::sac::net::Net;
use crate::rl::{Normalizer, RlError};
use serde::{Deserialize, Serialize};

/// Training settings; the defaults are the paper's (`reference-numbers.md` §3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SacConfig {
    /// Hidden layer widths of the actor and of each critic.
    pub hidden: Vec<usize>,
    /// Discount factor γ of the critics' targets, in `(0, 1]`.
    pub gamma: f64,
    /// Initial learning rate, decaying linearly to zero.
    pub learning_rate: f64,
    /// Transitions per gradient step (one gradient step per environment step after the
    /// warm-up).
    pub batch_size: usize,
    /// Capacity of the replay buffer, in transitions.
    pub buffer_size: usize,
    /// Episodes of uniformly random actions before learning starts.
    pub warmup_episodes: usize,
    /// Episodes in all, warm-up included.
    pub episodes: usize,
    /// Polyak coefficient of the target critics.
    pub tau: f64,
    /// Target entropy; `None` means `−(number of inputs)`, SB3's `'auto'`.
    pub target_entropy: Option<f64>,
    /// Seed of the networks' initialisation, the actions and batches, and (derived per
    /// episode) the environment's draws.
    pub seed: u64,
    /// Evaluate the deterministic policy every this many episodes (0: never).
    pub eval_every: usize,
    /// Episodes per evaluation (a deterministic environment needs one).
    pub eval_episodes: usize,
}

impl Default for SacConfig {
    fn default() -> SacConfig {
        SacConfig {
            hidden: vec![128, 128],
            gamma: 0.95,
            learning_rate: 5e-3,
            batch_size: 1024,
            buffer_size: 100_000,
            warmup_episodes: 9,
            episodes: 100,
            tau: 0.005,
            target_entropy: None,
            seed: 4,
            eval_every: 2,
            eval_episodes: 1,
        }
    }
}

impl SacConfig {
    pub(crate) fn validate(&self) -> Result<(), RlError> {
        let bad = |name: &'static str, why: &str| {
            Err(RlError::BadConfig {
                name,
                why: why.to_string(),
            })
        };
        if self.hidden.is_empty() || self.hidden.contains(&0) {
            return bad("hidden", "needs at least one layer, each at least one wide");
        }
        if !(self.gamma > 0.0 && self.gamma <= 1.0) {
            return bad("gamma", "must lie in (0, 1]");
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return bad("learning_rate", "must be positive");
        }
        if self.batch_size == 0 {
            return bad("batch_size", "must be positive");
        }
        if self.buffer_size == 0 {
            return bad("buffer_size", "must be positive");
        }
        if self.episodes == 0 {
            return bad("episodes", "must be at least one");
        }
        if self.warmup_episodes >= self.episodes {
            return bad(
                "warmup_episodes",
                "must be fewer than the episodes: a training that is all random warm-up never learns",
            );
        }
        if !(self.tau > 0.0 && self.tau <= 1.0) {
            return bad("tau", "must lie in (0, 1]");
        }
        if self.eval_every > 0 && self.eval_episodes == 0 {
            return bad("eval_episodes", "must be at least one when evaluating");
        }
        Ok(())
    }
}

/// One row of the learning curve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRecord {
    /// 1-based episode number.
    pub episode: usize,
    /// Environment steps taken so far in the training.
    pub total_steps: u64,
    /// Steps of this episode (short when the state diverged).
    pub steps: usize,
    /// Cumulative reward of the training episode (exploration included).
    pub reward: f64,
    /// Whether it was a warm-up episode (random actions, no learning).
    pub warmup: bool,
    /// Whether the state diverged, ending the episode early.
    pub diverged: bool,
    /// Mean cumulative reward of the deterministic policy, when evaluated after this episode.
    pub eval_reward: Option<f64>,
    /// Means over the episode's gradient steps (zero in the warm-up).
    pub critic_loss: f64,
    /// Mean actor loss (see [`UpdateStats`](crate::rl::sac::UpdateStats)).
    pub actor_loss: f64,
    /// Mean entropy coefficient α.
    pub alpha: f64,
    /// Mean batch estimate of the policy's entropy.
    pub entropy: f64,
    /// Wall time of the episode, seconds.
    pub wall_s: f64,
}

/// Where a running episode is, for progress bars.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepProgress {
    /// The episode, 1-based.
    pub episode: usize,
    /// Steps taken in this episode so far.
    pub step: usize,
    /// Environment steps taken in the training so far.
    pub total_steps: u64,
    /// Reward summed over this episode so far.
    pub reward: f64,
}

/// The best evaluated policy so far.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BestPolicy {
    /// Its mean cumulative reward over the evaluation episodes.
    pub eval_reward: f64,
    /// The episode after which it was evaluated, 1-based.
    pub episode: usize,
    /// The actor network then.
    pub actor: Net,
    /// The observation statistics then, frozen.
    pub normalizer: Normalizer,
}
