//! The error type of the `nn` room: inconsistent shapes and unreadable network files.

use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong building, evaluating or loading an [`Mlp`](crate::nn::Mlp).
#[derive(Debug, Error)]
pub enum NnError {
    /// The network was given no layers.
    #[error("a network needs at least one layer")]
    NoLayers,
    /// A layer's weight or bias vector does not match its declared shape.
    #[error("layer {layer} has {weights} weights and {biases} biases; {inputs} inputs × {outputs} outputs need {expected} and {outputs}")]
    LayerShape {
        /// The layer, 0-based.
        layer: usize,
        /// Its declared inputs.
        inputs: usize,
        /// Its declared outputs.
        outputs: usize,
        /// The weights it holds.
        weights: usize,
        /// The biases it holds.
        biases: usize,
        /// `inputs × outputs`, the weights it should hold.
        expected: usize,
    },
    /// A layer's inputs differ from the previous layer's outputs.
    #[error("layer {layer} takes {inputs} inputs but the layer before gives {previous}")]
    Chain {
        /// The layer, 0-based (never 0).
        layer: usize,
        /// Its declared inputs.
        inputs: usize,
        /// The outputs of the layer before.
        previous: usize,
    },
    /// A layer holds a NaN or infinite weight or bias. Also reported, as layer 0, for a
    /// [`ScaledMlp`](crate::nn::ScaledMlp) whose input box is not finite or empty, or whose
    /// output map is not finite.
    #[error("layer {layer} holds a non-finite weight or bias")]
    NonFinite {
        /// The layer, 0-based.
        layer: usize,
    },
    /// An input vector (or an input box) of the wrong length.
    #[error("the network takes {expected} inputs; {given} were given")]
    InputWidth {
        /// The length given (the shorter of the two bounds for a box).
        given: usize,
        /// The network's inputs.
        expected: usize,
    },
    /// A network file could not be read.
    #[error("cannot read network file {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A network file could not be written.
    #[error("cannot write network file {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A file is not valid network JSON (also used if serialising for a save fails).
    #[error("{path} is not a network file: {source}")]
    Format {
        /// The file.
        path: PathBuf,
        /// The JSON error.
        source: serde_json::Error,
    },
}
