//! The error type of the agent module: observation statistics, the action map and policy
//! files that do not fit.

use thiserror::Error;

/// What can go wrong with a [`Normalizer`](crate::agent::Normalizer), the action map
/// ([`action_scale`](crate::agent::observation::action_scale)) or a
/// [`PolicyFile`](crate::agent::PolicyFile). Training wraps it in
/// [`RlError::Agent`](crate::rl::RlError::Agent), a running policy in
/// [`ControlError::Agent`](crate::control::ControlError::Agent); both show its message
/// unchanged.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum AgentError {
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
    /// A policy file could not be written or read, or does not fit the model it is used
    /// on; the reason names the field.
    #[error("policy file {path}: {reason}")]
    PolicyFile {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong, naming the field.
        reason: String,
    },
    /// The policy's network could not be evaluated; holds its message.
    #[error("the tensor back-end failed: {0}")]
    Network(String),
}
