//! Reinforcement learning on any plant: an episodic environment over the plant and a
//! weather ([`Env`]), a running observation normaliser in the style of
//! Stable-Baselines3's `VecNormalize` ([`Normalizer`]), a replay buffer, soft actor-critic
//! trained with burn ([`sac`]), and the trained policy exported as plain weights
//! ([`PolicyFile`]).
//!
//! * [`env`](mod@env): observation, action map, reward and episode bookkeeping;
//! * [`normalize`]: running mean/variance of observations and the clipped standardisation;
//! * [`buffer`]: the replay buffer;
//! * [`sac`]: networks, Adam, the gradient step, the training loop and its checkpoints;
//! * [`policy`]: the exported deterministic policy;
//! * [`value_fit`]: the value network regression of RL-guided MPC;
//! * [`error`]: the error type [`RlError`].
//!
//! Architecture invariant: burn stays inside [`sac`]; everything that leaves this room
//! (a [`PolicyFile`]) is plain weights for the [`nn`](crate::nn) room.

pub mod buffer;
pub mod env;
pub mod error;
pub mod normalize;
pub mod policy;
pub mod sac;
pub mod value_fit;

pub use env::{Env, Transition};
pub use error::RlError;
pub use normalize::Normalizer;
pub use policy::PolicyFile;
