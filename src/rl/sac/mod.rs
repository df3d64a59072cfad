//! Soft actor-critic with burn: the networks ([`net`]), Adam ([`adam`]), the gradient step
//! ([`agent`]), the training loop ([`trainer`]), its data types ([`types`]), its
//! checkpoints ([`checkpoint`]) and the training process's heap policy ([`heap`]).
//!
//! Burn runs on its pure-Rust CPU back-end (`Device::flex()`, with `autodiff()` for the
//! gradients; [`training_device`]), single-threaded, so that training is reproducible from
//! a seed.

pub mod adam;
pub mod agent;
pub mod checkpoint;
pub mod heap;
pub mod net;
pub mod trainer;
pub mod types;

pub use agent::{Sac, UpdateStats};
pub use trainer::Trainer;
pub use types::{BestPolicy, EpisodeRecord, SacConfig, StepProgress};

/// The device SAC trains on: burn's flex CPU back-end with reverse-mode gradients, in a
/// process that keeps freed memory for the next gradient step ([`heap::keep_freed_memory`]).
pub fn training_device() -> burn::tensor::Device {
    heap::keep_freed_memory();
    burn::tensor::Device::flex().autodiff()
}
