//! Neural networks as plain weights: a multi-layer perceptron ([`Mlp`]) that evaluates over
//! any dual number type, so that a trained policy or value function enters the optimal
//! control problem with exact gradients and Hessians like every other term; that expands
//! into the expression [`Graph`](crate::graph::Graph) when a model wants it as nodes; and that
//! reads and writes a small JSON file.
//!
//! * [`mlp`]: layers, activations, evaluation, graph expansion, files;
//! * [`scaled`]: a network between an input box and an affine output map (value functions);
//! * `products`: a layer's weights times three vectors at once, the second-order pass's
//!   kernel;
//! * [`error`]: the error type [`NnError`].
//!
//! Architecture invariant: `nn` knows no training framework. Networks trained with burn
//! (in [`rl`](crate::rl)) are exported into these weights; nothing here depends on burn.

pub mod error;
pub mod mlp;
mod products;
pub mod scaled;

pub use error::NnError;
pub use mlp::{Activation, Dense, Mlp};
pub use scaled::ScaledMlp;
