//! Reinforcement learning on any plant: an episodic environment over the plant and a
//! weather ([`Env`]), a replay buffer, and with the feature `learn` soft actor-critic
//! trained with burn (`sac`) and the value-network fit. The trained agent it exports (the running observation
//! normaliser [`Normalizer`], the policy as plain weights [`PolicyFile`], the observation
//! and action map) lives one room below, in [`agent`](crate::agent), where
//! [`control`](crate::control) can run it without depending on training; it is
//! re-exported here under its former paths.
//!
//! * [`env`](mod@env): reward and episode bookkeeping over the agent's observation and
//!   action map;
//! * [`buffer`]: the replay buffer;
//! * `sac`: networks, Adam, the gradient step, the training loop and its checkpoints
//!   (feature `learn`);
//! * `value_fit`: the value network regression of RL-guided MPC (feature `learn`);
//! * `imitation`: the regression of an actor onto a teacher's actions, policy
//!   distillation's learning step (feature `learn`);
//! * `regression`: the least-squares gradient step of a small perceptron, written out
//!   (`sgemm` and a vectorised tanh), which the value and imitation fits take (feature
//!   `learn`);
//! * [`error`]: the error type [`RlError`].
//!
//! Architecture invariant: burn stays inside `sac` (and the tests that check `regression`
//! against it); everything that leaves this room
//! (a [`PolicyFile`]) is plain weights for the [`nn`](crate::nn) room.

pub mod buffer;
pub mod env;
pub mod error;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod imitation;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod regression;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod sac;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod value_fit;

pub use crate::agent::{normalize, policy, AgentError, Normalizer, PolicyFile};
pub use env::{Env, Transition};
pub use error::RlError;
