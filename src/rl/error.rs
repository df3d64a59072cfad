//! The error type of the reinforcement-learning module: wrong sizes, bad settings and
//! calls out of order.

use thiserror::Error;

/// What can go wrong building or driving an [`Env`](crate::rl::Env) or a
/// [`Normalizer`](crate::rl::Normalizer).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RlError {
    #[error("an episode needs at least one step")]
    EmptyEpisode,
    #[error("the weather has {available} steps; the episode needs {needed}")]
    WeatherTooShort { available: usize, needed: usize },
    #[error("the weather provides {given} disturbances; the model has {expected}")]
    WeatherWidth { given: usize, expected: usize },
    #[error("input `{input}` has bounds [{lower}, {upper}] that do not form an interval")]
    InputBounds {
        input: String,
        lower: f64,
        upper: f64,
    },
    #[error(
        "input `{input}` has no finite action scale: give it a rate limit or finite bounds \
         (scale {scale})"
    )]
    UnboundedInput { input: String, scale: f64 },
    #[error(
        "the uncertainty δ = {delta} is not a finite non-negative number (or δ·spread overflows)"
    )]
    BadUncertainty { delta: f64 },
    #[error("the action has {given} entries; the model has {expected} inputs")]
    ActionWidth { given: usize, expected: usize },
    #[error("action entry {index} is not finite ({value})")]
    NonFiniteAction { index: usize, value: f64 },
    #[error("the environment must be reset before the first step")]
    NotReset,
    #[error("the episode is over after {steps} steps; reset to start another")]
    EpisodeOver { steps: usize },
    #[error("the state is not finite after step {step}: {state:?}")]
    Diverged { step: usize, state: Vec<f64> },
    #[error("the observation has {given} entries; the normaliser expects {expected}")]
    ObservationWidth { given: usize, expected: usize },
    #[error("a batch of {len} values does not fill rows of {width}")]
    BatchShape { len: usize, width: usize },
    #[error("the replay buffer is empty")]
    EmptyBuffer,
    #[error("checkpoint {path}: {why}")]
    Checkpoint { path: String, why: String },
    #[error("agent setting {name}: {why}")]
    BadConfig { name: &'static str, why: String },
    #[error("the tensor back-end failed: {0}")]
    Backend(String),
    #[error("normaliser setting {name} = {value} is invalid: {why}")]
    BadSetting {
        name: &'static str,
        value: f64,
        why: &'static str,
    },
}
