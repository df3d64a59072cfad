//! The error type of the reinforcement-learning module: wrong sizes, bad settings and
//! calls out of order.

use crate::agent::AgentError;
use thiserror::Error;

/// What can go wrong building or driving an [`Env`](crate::rl::Env) or a
/// [`Normalizer`](crate::rl::Normalizer), and also in the replay buffer, SAC training,
/// checkpoints, policy files and the value fit.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RlError {
    /// An environment was asked for episodes of 0 steps.
    #[error("an episode needs at least one step")]
    EmptyEpisode,
    /// The weather has fewer rows than an episode has steps.
    #[error("the weather has {available} steps; the episode needs {needed}")]
    WeatherTooShort {
        /// Rows in the weather.
        available: usize,
        /// Steps in an episode.
        needed: usize,
    },
    /// The weather's columns do not match the model's disturbances.
    #[error("the weather provides {given} disturbances; the model has {expected}")]
    WeatherWidth {
        /// Columns in the weather.
        given: usize,
        /// Disturbances of the model.
        expected: usize,
    },
    /// The uncertainty δ given to an environment is negative, NaN or infinite, or too large
    /// for the model's spread.
    #[error(
        "the uncertainty δ = {delta} is not a finite non-negative number (or δ·spread overflows)"
    )]
    BadUncertainty {
        /// The δ given.
        delta: f64,
    },
    /// An action (or a stored transition's action) of the wrong length.
    #[error("the action has {given} entries; the model has {expected} inputs")]
    ActionWidth {
        /// Entries given.
        given: usize,
        /// Inputs of the model.
        expected: usize,
    },
    /// An action entry is NaN or infinite; the environment is unchanged.
    #[error("action entry {index} is not finite ({value})")]
    NonFiniteAction {
        /// The entry, 0-based.
        index: usize,
        /// Its value.
        value: f64,
    },
    /// [`Env::step`](crate::rl::Env::step) before the first
    /// [`Env::reset`](crate::rl::Env::reset).
    #[error("the environment must be reset before the first step")]
    NotReset,
    /// [`Env::step`](crate::rl::Env::step) after the episode's last step or after it
    /// diverged.
    #[error("the episode is over after {steps} steps; reset to start another")]
    EpisodeOver {
        /// Steps the episode took.
        steps: usize,
    },
    /// The plant's next state, a stage term, an output after the step or the reward is
    /// NaN or infinite; the episode is over.
    #[error("step {step}: {quantity} is {value}; the episode is over")]
    Diverged {
        /// The step that produced it (0-based).
        step: usize,
        /// What it is, named as the model names it (see
        /// [`Plant::describe`](crate::model::Plant::describe)).
        quantity: String,
        /// The value: NaN, `inf` or `-inf`.
        value: f64,
    },
    /// A sample was asked of a replay buffer holding no transition.
    #[error("the replay buffer is empty")]
    EmptyBuffer,
    /// A checkpoint could not be written, read or used.
    #[error("checkpoint {path}: {why}")]
    Checkpoint {
        /// The file or directory.
        path: String,
        /// What went wrong.
        why: String,
    },
    /// A training setting (SAC or value fit) is out of range.
    #[error("agent setting {name}: {why}")]
    BadConfig {
        /// The setting.
        name: &'static str,
        /// Why it is refused.
        why: String,
    },
    /// The observation statistics, the action map or a policy file (see
    /// [`AgentError`]); its message unchanged.
    #[error(transparent)]
    Agent(#[from] AgentError),
    /// The tensor library (burn) failed; holds its message.
    #[error("the tensor back-end failed: {0}")]
    Backend(String),
}
