//! The error type of the `nn` room: inconsistent shapes and unreadable network files.

use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong building, evaluating or loading an [`Mlp`](crate::nn::Mlp).
#[derive(Debug, Error)]
pub enum NnError {
    #[error("a network needs at least one layer")]
    NoLayers,
    #[error("layer {layer} has {weights} weights and {biases} biases; {inputs} inputs × {outputs} outputs need {expected} and {outputs}")]
    LayerShape {
        layer: usize,
        inputs: usize,
        outputs: usize,
        weights: usize,
        biases: usize,
        expected: usize,
    },
    #[error("layer {layer} takes {inputs} inputs but the layer before gives {previous}")]
    Chain {
        layer: usize,
        inputs: usize,
        previous: usize,
    },
    #[error("layer {layer} holds a non-finite weight or bias")]
    NonFinite { layer: usize },
    #[error("the network takes {expected} inputs; {given} were given")]
    InputWidth { given: usize, expected: usize },
    #[error("cannot read network file {path}: {source}")]
    Read {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot write network file {path}: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path} is not a network file: {source}")]
    Format {
        path: PathBuf,
        source: serde_json::Error,
    },
}
