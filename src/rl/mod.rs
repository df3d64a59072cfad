//! Reinforcement learning on any plant: an episodic environment over the plant and a
//! weather ([`Env`]), and a running observation normaliser ([`Normalizer`]) in the style
//! of Stable-Baselines3's `VecNormalize`.
//!
//! * [`env`](mod@env): observation, action map, reward and episode bookkeeping;
//! * [`normalize`]: running mean/variance of observations and the clipped standardisation;
//! * [`error`]: the error type [`RlError`].
//!
//! Architecture invariant: `rl` knows no learning algorithm; an agent (later) consumes
//! these raw `f64` observations and rewards.

pub mod env;
pub mod error;
pub mod normalize;

pub use env::{Env, Transition};
pub use error::RlError;
pub use normalize::Normalizer;
