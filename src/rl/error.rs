//! The error type of the reinforcement-learning module: wrong sizes, bad settings and
//! calls out of order.

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
    /// An input's bounds are NaN or reversed, so actions cannot be clipped to them.
    #[error("input `{input}` has bounds [{lower}, {upper}] that do not form an interval")]
    InputBounds {
        /// The input's name.
        input: String,
        /// Its lower bound.
        lower: f64,
        /// Its upper bound.
        upper: f64,
    },
    /// An input has neither a rate limit nor finite bounds, so an action of ±1 means no
    /// finite change.
    #[error(
        "input `{input}` has no finite action scale: give it a rate limit or finite bounds \
         (scale {scale})"
    )]
    UnboundedInput {
        /// The input's name.
        input: String,
        /// The scale found: its rate limit, else `upper − lower`.
        scale: f64,
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
    /// An observation of the wrong length for a normaliser, a buffer or a policy.
    #[error("the observation has {given} entries; the normaliser expects {expected}")]
    ObservationWidth {
        /// Entries given.
        given: usize,
        /// Entries expected.
        expected: usize,
    },
    /// A flat batch whose length is not a multiple of the row width (or whose width is 0).
    #[error("a batch of {len} values does not fill rows of {width}")]
    BatchShape {
        /// Values in the batch.
        len: usize,
        /// Values per row.
        width: usize,
    },
    /// A sample was asked of a replay buffer holding no transition.
    #[error("the replay buffer is empty")]
    EmptyBuffer,
    /// A policy file could not be written or read, or does not fit the model it is used
    /// on; the reason names the field.
    #[error("policy file {path}: {reason}")]
    PolicyFile {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong, naming the field.
        reason: String,
    },
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
    /// The tensor library (burn) failed; holds its message.
    #[error("the tensor back-end failed: {0}")]
    Backend(String),
    /// A normaliser setting is out of range.
    #[error("normaliser setting {name} = {value} is invalid: {why}")]
    BadSetting {
        /// The setting.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is refused.
        why: &'static str,
    },
}
