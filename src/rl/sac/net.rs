//! The agent's networks: ReLU perceptrons whose weights live in plain `f32` vectors and
//! become burn tensors for each gradient step.
//!
//! Keeping the master copy of every weight (and of the optimiser's moments) outside burn
//! makes a checkpoint an exact copy of the agent, makes the target networks' Polyak
//! averaging a loop over floats, and lets the environment loop act with a plain forward
//! pass instead of a tensor round trip. Burn does what it is good at: the batched forward
//! pass, reverse-mode gradients, on the `flex` CPU back-end.

use crate::nn::{Activation, Dense, Mlp, NnError};
use crate::rl::RlError;
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor, TensorData};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// One affine layer: weights `inputs × outputs`, row-major by input (burn's `x · W` layout).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Layer {
    /// Inputs of the layer.
    pub inputs: usize,
    /// Outputs of the layer.
    pub outputs: usize,
    /// `inputs × outputs` weights, row-major: row `i` holds the weights out of input `i`
    /// (the transpose of [`Dense`]'s layout).
    pub weight: Vec<f32>,
    /// One bias per output.
    pub bias: Vec<f32>,
}

/// A perceptron with one hidden activation (ReLU for the agent, tanh for the value
/// network) and a linear output layer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Net {
    /// Its layers, input side first.
    pub layers: Vec<Layer>,
    /// The activation after every layer but the last (ReLU when a file omits it).
    #[serde(default = "relu_activation")]
    pub hidden: Activation,
}

fn relu_activation() -> Activation {
    Activation::Relu
}

/// A network's weights as burn tensors, for one gradient step.
pub struct NetTensors {
    weights: Vec<Tensor<2>>,
    biases: Vec<Tensor<2>>,
    hidden: Activation,
}

impl Net {
    /// A network of the given widths (`[inputs, hidden…, outputs]`), initialised as
    /// PyTorch's `nn.Linear` does: weights and biases uniform in `±1/√fan_in`.
    pub fn init<R: Rng>(widths: &[usize], rng: &mut R) -> Net {
        let layers = widths
            .windows(2)
            .map(|w| {
                let (inputs, outputs) = (w[0], w[1]);
                let bound = 1.0 / (inputs as f32).sqrt();
                let mut draw = || rng.random_range(-bound..bound);
                let weight = (0..inputs * outputs).map(|_| draw()).collect();
                let bias = (0..outputs).map(|_| draw()).collect();
                Layer {
                    inputs,
                    outputs,
                    weight,
                    bias,
                }
            })
            .collect();
        Net {
            layers,
            hidden: Activation::Relu,
        }
    }

    /// A network with `hidden` activations, Xavier-uniform weights
    /// (`±√(6/(fan_in + fan_out))`) and zero biases: the value network's initialisation.
    pub fn init_xavier<R: Rng>(widths: &[usize], hidden: Activation, rng: &mut R) -> Net {
        let layers = widths
            .windows(2)
            .map(|w| {
                let (inputs, outputs) = (w[0], w[1]);
                let bound = (6.0 / (inputs + outputs) as f32).sqrt();
                Layer {
                    inputs,
                    outputs,
                    weight: (0..inputs * outputs)
                        .map(|_| rng.random_range(-bound..bound))
                        .collect(),
                    bias: vec![0.0; outputs],
                }
            })
            .collect();
        Net { layers, hidden }
    }

    /// Inputs of the first layer.
    pub fn inputs(&self) -> usize {
        self.layers[0].inputs
    }

    /// Outputs of the last layer.
    pub fn outputs(&self) -> usize {
        self.layers[self.layers.len() - 1].outputs
    }

    /// Every weight and bias, layer by layer (weights then bias), as mutable slices.
    pub fn parameters_mut(&mut self) -> Vec<&mut [f32]> {
        let mut out = Vec::with_capacity(2 * self.layers.len());
        for layer in &mut self.layers {
            out.push(layer.weight.as_mut_slice());
            out.push(layer.bias.as_mut_slice());
        }
        out
    }

    /// Every weight and bias in the order of [`Net::parameters_mut`].
    pub fn parameters(&self) -> Vec<&[f32]> {
        let mut out = Vec::with_capacity(2 * self.layers.len());
        for layer in &self.layers {
            out.push(layer.weight.as_slice());
            out.push(layer.bias.as_slice());
        }
        out
    }

    /// Total number of parameters.
    pub fn parameter_count(&self) -> usize {
        self.layers
            .iter()
            .map(|l| l.weight.len() + l.bias.len())
            .sum()
    }

    /// The weights as tensors on `device`, tracked for gradients when `track` is set.
    pub fn tensors(&self, device: &Device, track: bool) -> NetTensors {
        let mut weights = Vec::with_capacity(self.layers.len());
        let mut biases = Vec::with_capacity(self.layers.len());
        for layer in &self.layers {
            let w = Tensor::<2>::from_data(
                TensorData::new(layer.weight.clone(), [layer.inputs, layer.outputs]),
                device,
            );
            let b = Tensor::<2>::from_data(
                TensorData::new(layer.bias.clone(), [1, layer.outputs]),
                device,
            );
            if track {
                weights.push(w.require_grad());
                biases.push(b.require_grad());
            } else {
                weights.push(w);
                biases.push(b);
            }
        }
        NetTensors {
            weights,
            biases,
            hidden: self.hidden,
        }
    }

    /// Forward pass of one input on plain floats (acting in the environment).
    pub fn forward_one(&self, input: &[f32], out: &mut Vec<f32>) {
        let mut current: Vec<f32> = input.to_vec();
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let mut next = layer.bias.clone();
            for (i, x) in current.iter().enumerate() {
                let row = &layer.weight[i * layer.outputs..(i + 1) * layer.outputs];
                for (n, w) in next.iter_mut().zip(row) {
                    *n += x * w;
                }
            }
            if l < last {
                for n in &mut next {
                    *n = match self.hidden {
                        Activation::Relu => n.max(0.0),
                        Activation::Tanh => n.tanh(),
                        Activation::Identity => *n,
                    };
                }
            }
            current = next;
        }
        out.clear();
        out.extend_from_slice(&current);
    }

    /// Polyak averaging towards `online`: `θ ← (1 − τ) θ + τ θ_online`.
    pub fn polyak(&mut self, online: &Net, tau: f32) {
        for (target, source) in self.parameters_mut().into_iter().zip(online.parameters()) {
            for (t, s) in target.iter_mut().zip(source) {
                *t = (1.0 - tau) * *t + tau * s;
            }
        }
    }

    /// The network as plain `f64` weights for the `nn` room, with the given output
    /// activation.
    pub fn to_mlp(&self, output: Activation) -> Result<Mlp, NnError> {
        let layers = self
            .layers
            .iter()
            .map(|layer| {
                let mut weight = vec![0.0; layer.inputs * layer.outputs];
                for i in 0..layer.inputs {
                    for o in 0..layer.outputs {
                        weight[o * layer.inputs + i] =
                            f64::from(layer.weight[i * layer.outputs + o]);
                    }
                }
                Dense {
                    inputs: layer.inputs,
                    outputs: layer.outputs,
                    weight,
                    bias: layer.bias.iter().map(|b| f64::from(*b)).collect(),
                }
            })
            .collect();
        Mlp::new(layers, self.hidden, output)
    }
}

impl NetTensors {
    /// Hidden activations, linear output.
    pub fn forward(&self, input: Tensor<2>) -> Tensor<2> {
        let last = self.weights.len() - 1;
        let mut x = input;
        for (l, (w, b)) in self.weights.iter().zip(&self.biases).enumerate() {
            x = x.matmul(w.clone()) + b.clone();
            if l < last {
                x = match self.hidden {
                    Activation::Relu => relu(x),
                    Activation::Tanh => x.tanh(),
                    Activation::Identity => x,
                };
            }
        }
        x
    }

    /// The gradients of every parameter, in the order of [`Net::parameters`].
    pub fn gradients(&self, grads: &burn::tensor::Gradients) -> Result<Vec<Vec<f32>>, RlError> {
        let mut out = Vec::with_capacity(2 * self.weights.len());
        for (w, b) in self.weights.iter().zip(&self.biases) {
            for t in [w, b] {
                let g = t
                    .grad(grads)
                    .ok_or_else(|| RlError::Backend("a parameter has no gradient".into()))?;
                out.push(to_vec(g)?);
            }
        }
        Ok(out)
    }
}

/// A tensor's values as a vector.
pub fn to_vec<const D: usize>(t: Tensor<D>) -> Result<Vec<f32>, RlError> {
    t.into_data()
        .try_to_vec::<f32>()
        .map_err(|e| RlError::Backend(format!("{e:?}")))
}
