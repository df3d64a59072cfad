//! Soft actor-critic with burn: the networks ([`net`]), Adam ([`adam`]), the gradient step
//! ([`agent`]), the training loop ([`trainer`]), its data types ([`types`]) and its
//! checkpoints ([`checkpoint`]).
//!
//! Burn runs on its pure-Rust CPU back-end (`Device::flex()`, with `autodiff()` for the
//! gradients), single-threaded, so that training is reproducible from a seed.

pub mod adam;
pub mod agent;
pub mod checkpoint;
pub mod net;
pub mod trainer;
pub mod types;

pub use agent::{Sac, UpdateStats};
pub use trainer::Trainer;
pub use types::{BestPolicy, EpisodeRecord, SacConfig, StepProgress};
