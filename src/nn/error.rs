//! The error type of the `nn` room: inconsistent shapes and unreadable network files.
//! Each shape error names the JSON field it is about (`layers[1].weight`), so that a
//! message about a file says where in it to look.

use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong building, evaluating or loading an [`Mlp`](crate::nn::Mlp).
#[derive(Debug, Error)]
pub enum NnError {
    /// The network was given no layers.
    #[error("\"layers\" is empty: a network needs at least one layer")]
    NoLayers,
    /// A layer declares more weights than a machine can address (`inputs × outputs`
    /// overflows).
    #[error("layers[{layer}] declares {inputs} inputs × {outputs} outputs, more weights than can be held")]
    LayerTooLarge {
        /// The layer, 0-based.
        layer: usize,
        /// Its declared inputs.
        inputs: usize,
        /// Its declared outputs.
        outputs: usize,
    },
    /// A layer's weight or bias vector does not match its declared shape.
    #[error("layers[{layer}] declares {inputs} inputs × {outputs} outputs, which need {expected} weights and {outputs} biases; its \"weight\" holds {weights} and its \"bias\" {biases}")]
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
    #[error("layers[{layer}].inputs is {inputs} but the layer before gives {previous} outputs")]
    Chain {
        /// The layer, 0-based (never 0).
        layer: usize,
        /// Its declared inputs.
        inputs: usize,
        /// The outputs of the layer before.
        previous: usize,
    },
    /// A layer holds a NaN or infinite weight or bias.
    #[error("layers[{layer}] holds a non-finite weight or bias")]
    NonFinite {
        /// The layer, 0-based.
        layer: usize,
    },
    /// A [`ScaledMlp`](crate::nn::ScaledMlp)'s input box or output map is wrong: a box of
    /// another width than the network's inputs, not finite or empty, or a non-finite
    /// output map.
    #[error("{field}: {reason}")]
    Scaling {
        /// The field, as named in the file (`input_upper`, `output_scale`, ...).
        field: &'static str,
        /// What is wrong with it.
        reason: String,
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
