//! A multi-layer perceptron as plain weights.
//!
//! Layer `l` computes `h_l = σ_l(W_l h_{l−1} + b_l)` with `W_l` stored row-major, one row per
//! output; `σ` is the hidden activation on every layer but the last, which has the output
//! activation. Evaluation is generic over [`Real`], so `f64`, `Dual64`, `HyperDual64` and
//! the other `num_dual` numbers all go through the same code: the gradient and Hessian of
//! a network's output are exact, not finite differences.
//!
//! ReLU's derivative at exactly zero is taken as zero (the left derivative), as the
//! expression graph's `max` does.

use super::products::three_products;
use crate::graph::{Graph, NodeId, Op, Real};
use crate::nn::NnError;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// An elementwise activation.
///
/// ```
/// use ghm::nn::Activation;
/// use num_dual::{first_derivative, DualNum};
///
/// assert_eq!(Activation::Relu.apply(-2.0), 0.0);
/// assert_eq!(Activation::Relu.apply(3.0), 3.0);
/// assert_eq!(Activation::Identity.apply(-2.0), -2.0);
/// assert_eq!(Activation::Tanh.apply(0.5), 0.5f64.tanh());
/// // Over dual numbers: tanh' = 1 − tanh², ReLU' = 0 at zero (the left derivative).
/// let (_, d) = first_derivative(|x| Activation::Tanh.apply(x), 0.5);
/// assert!((d - (1.0 - 0.5f64.tanh().powi(2))).abs() < 1e-15);
/// let (_, d) = first_derivative(|x| Activation::Relu.apply(x), 0.0);
/// assert_eq!(d, 0.0);
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Activation {
    /// `x`.
    Identity,
    /// `max(x, 0)`, with derivative 0 at 0.
    Relu,
    /// `tanh(x)`.
    Tanh,
}

impl Activation {
    /// The activation of one value.
    #[inline]
    pub fn apply<T: Real>(self, x: T) -> T {
        match self {
            Activation::Identity => x,
            Activation::Relu => {
                if x.re() > 0.0 {
                    x
                } else {
                    T::zero()
                }
            }
            Activation::Tanh => x.tanh(),
        }
    }

    /// The activation as graph nodes.
    fn to_graph(self, graph: &mut Graph, x: NodeId) -> NodeId {
        match self {
            Activation::Identity => x,
            Activation::Relu => {
                let zero = graph.constant(0.0);
                graph.apply(Op::Max, &[x, zero])
            }
            Activation::Tanh => graph.apply(Op::Tanh, &[x]),
        }
    }
}

/// One affine layer: `outputs × inputs` weights (row-major, one row per output) and
/// `outputs` biases.
///
/// ```
/// use ghm::nn::{Activation, Dense, Mlp};
///
/// // Two inputs, three outputs: row o holds the weights into output o.
/// let layer = Dense {
///     inputs: 2,
///     outputs: 3,
///     weight: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
///     bias: vec![0.0, 0.5, -1.0],
/// };
/// assert_eq!(layer.weight_at(1, 0), 3.0);
/// let net = Mlp::new(vec![layer.clone()], Activation::Relu, Activation::Identity).unwrap();
/// assert_eq!(net.forward(&[1.0, 1.0]), [3.0, 7.5, 10.0]);
/// // Shapes are checked: six weights do not make a 3 × 3 layer.
/// let wrong = Dense { inputs: 3, ..layer };
/// assert!(Mlp::new(vec![wrong], Activation::Relu, Activation::Identity).is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dense {
    /// Inputs of the layer.
    pub inputs: usize,
    /// Outputs of the layer.
    pub outputs: usize,
    /// `outputs × inputs` weights, row-major: row `o` holds the weights into output `o`.
    pub weight: Vec<f64>,
    /// One bias per output.
    pub bias: Vec<f64>,
}

impl Dense {
    /// The weight from input `i` to output `o`.
    pub fn weight_at(&self, o: usize, i: usize) -> f64 {
        self.weight[o * self.inputs + i]
    }
}

/// A multi-layer perceptron with one activation for its hidden layers and one for its output.
///
/// ```
/// use ghm::nn::{Activation, Dense, Mlp};
/// use num_dual::{first_derivative, DualNum};
///
/// // y = tanh(2 x + 1), one layer.
/// let layer = Dense { inputs: 1, outputs: 1, weight: vec![2.0], bias: vec![1.0] };
/// let net = Mlp::new(vec![layer], Activation::Relu, Activation::Tanh).unwrap();
/// let (y, dy) = first_derivative(|x| net.forward(&[x])[0], 0.25);
/// assert!((y - 1.5f64.tanh()).abs() < 1e-15);
/// assert!((dy - 2.0 * (1.0 - 1.5f64.tanh().powi(2))).abs() < 1e-15);
/// ```
///
/// Reading one from JSON checks it as [`Mlp::new`] does, so a network inside any file (a
/// policy, a value function) is valid once it is read.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MlpData")]
pub struct Mlp {
    layers: Vec<Dense>,
    hidden: Activation,
    output: Activation,
}

/// The serialised form of an [`Mlp`], checked on the way in.
#[derive(Deserialize)]
struct MlpData {
    layers: Vec<Dense>,
    hidden: Activation,
    output: Activation,
}

impl TryFrom<MlpData> for Mlp {
    type Error = NnError;
    fn try_from(d: MlpData) -> Result<Mlp, NnError> {
        Mlp::new(d.layers, d.hidden, d.output)
    }
}

impl Mlp {
    /// A network from its layers, checking that their shapes chain and that every weight
    /// is finite.
    pub fn new(layers: Vec<Dense>, hidden: Activation, output: Activation) -> Result<Mlp, NnError> {
        let net = Mlp {
            layers,
            hidden,
            output,
        };
        net.validate()?;
        Ok(net)
    }

    fn validate(&self) -> Result<(), NnError> {
        if self.layers.is_empty() {
            return Err(NnError::NoLayers);
        }
        for (l, layer) in self.layers.iter().enumerate() {
            let expected =
                layer
                    .inputs
                    .checked_mul(layer.outputs)
                    .ok_or(NnError::LayerTooLarge {
                        layer: l,
                        inputs: layer.inputs,
                        outputs: layer.outputs,
                    })?;
            if layer.weight.len() != expected || layer.bias.len() != layer.outputs {
                return Err(NnError::LayerShape {
                    layer: l,
                    inputs: layer.inputs,
                    outputs: layer.outputs,
                    weights: layer.weight.len(),
                    biases: layer.bias.len(),
                    expected,
                });
            }
            if l > 0 && self.layers[l - 1].outputs != layer.inputs {
                return Err(NnError::Chain {
                    layer: l,
                    inputs: layer.inputs,
                    previous: self.layers[l - 1].outputs,
                });
            }
            if layer
                .weight
                .iter()
                .chain(&layer.bias)
                .any(|v| !v.is_finite())
            {
                return Err(NnError::NonFinite { layer: l });
            }
        }
        Ok(())
    }

    /// Its layers, input side first.
    pub fn layers(&self) -> &[Dense] {
        &self.layers
    }

    /// The activation after every layer but the last.
    pub fn hidden_activation(&self) -> Activation {
        self.hidden
    }

    /// The activation after the last layer.
    pub fn output_activation(&self) -> Activation {
        self.output
    }

    /// Number of inputs.
    pub fn inputs(&self) -> usize {
        self.layers[0].inputs
    }

    /// Number of outputs.
    pub fn outputs(&self) -> usize {
        self.layers[self.layers.len() - 1].outputs
    }

    /// Number of weights and biases.
    pub fn parameter_count(&self) -> usize {
        self.layers
            .iter()
            .map(|l| l.weight.len() + l.bias.len())
            .sum()
    }

    /// The same network with only the output rows `rows` of its last layer (a policy's
    /// mean head out of a layer that also gives the log standard deviations, say).
    pub fn with_output_rows(&self, rows: std::ops::Range<usize>) -> Result<Mlp, NnError> {
        let mut layers = self.layers.clone();
        let last = layers.len() - 1;
        let layer = &mut layers[last];
        let n = layer.inputs;
        let end = rows.end.min(layer.outputs);
        let start = rows.start.min(end);
        layer.weight = layer.weight[start * n..end * n].to_vec();
        layer.bias = layer.bias[start..end].to_vec();
        layer.outputs = end - start;
        Mlp::new(layers, self.hidden, self.output)
    }

    /// The network with another output activation.
    pub fn with_output_activation(mut self, output: Activation) -> Mlp {
        self.output = output;
        self
    }

    /// Evaluates the network on `input` (length [`Mlp::inputs`]; extra entries are ignored,
    /// missing ones panic: use [`Mlp::try_forward`] on input a user controls).
    pub fn forward<T: Real>(&self, input: &[T]) -> Vec<T> {
        let mut current: Vec<T> = input[..self.inputs()].to_vec();
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let activation = if l == last { self.output } else { self.hidden };
            let next = (0..layer.outputs)
                .map(|o| {
                    let row = &layer.weight[o * layer.inputs..(o + 1) * layer.inputs];
                    let mut sum = T::from(layer.bias[o]);
                    for (w, x) in row.iter().zip(&current) {
                        sum += *x * *w;
                    }
                    activation.apply(sum)
                })
                .collect();
            current = next;
        }
        current
    }

    /// The first output and its first and second derivatives along the input direction
    /// `tangent` (`∂input/∂s`; the input's second derivative is zero), in one pass over
    /// three plain vectors per layer: value, first and second derivative. The figures of
    /// [`Mlp::forward`] over `Dual2` to rounding, at a fraction of its cost: `tanh` once
    /// per unit with its derivatives written out (`Dual2`'s is `sinh / cosh` of dual
    /// numbers), and each row of weights read once for its three products
    /// (`nn::products`).
    pub fn forward_second_along(&self, input: &[f64], tangent: &[f64]) -> (f64, f64, f64) {
        let n = self.inputs();
        let mut value = input[..n].to_vec();
        let mut first = tangent[..n].to_vec();
        let mut second = vec![0.0; n];
        let mut products = Vec::new();
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let activation = if l == last { self.output } else { self.hidden };
            products.resize(layer.outputs, [0.0; 3]);
            three_products(&layer.weight, [&value, &first, &second], &mut products);
            (value, first, second) = (
                Vec::with_capacity(layer.outputs),
                Vec::with_capacity(layer.outputs),
                Vec::with_capacity(layer.outputs),
            );
            for (&[z, z1, z2], &bias) in products.iter().zip(&layer.bias) {
                let z = bias + z;
                let (a, a1, a2) = match activation {
                    Activation::Identity => (z, z1, z2),
                    Activation::Relu if z > 0.0 => (z, z1, z2),
                    Activation::Relu => (0.0, 0.0, 0.0),
                    Activation::Tanh => {
                        let t = z.tanh();
                        let slope = 1.0 - t * t;
                        (t, slope * z1, slope * (z2 - 2.0 * t * z1 * z1))
                    }
                };
                value.push(a);
                first.push(a1);
                second.push(a2);
            }
        }
        (value[0], first[0], second[0])
    }

    /// [`Mlp::forward`] with the input width checked.
    pub fn try_forward<T: Real>(&self, input: &[T]) -> Result<Vec<T>, NnError> {
        if input.len() != self.inputs() {
            return Err(NnError::InputWidth {
                given: input.len(),
                expected: self.inputs(),
            });
        }
        Ok(self.forward(input))
    }

    /// Expands the network into `graph` over the nodes `inputs` and returns its output
    /// nodes. Zero weights add no node (the graph folds them away).
    ///
    /// ```
    /// use ghm::graph::Graph;
    /// use ghm::nn::{Activation, Dense, Mlp};
    ///
    /// let layer = Dense { inputs: 2, outputs: 1, weight: vec![0.5, -1.0], bias: vec![0.25] };
    /// let net = Mlp::new(vec![layer], Activation::Relu, Activation::Tanh).unwrap();
    /// let mut graph = Graph::new();
    /// let x = [graph.var(0), graph.var(1)];
    /// let y = net.to_graph(&mut graph, &x).unwrap();
    /// let from_graph = graph.eval_f64(&y, &[2.0, 0.5])[0];
    /// assert!((from_graph - net.forward(&[2.0, 0.5])[0]).abs() < 1e-15);
    /// ```
    pub fn to_graph(&self, graph: &mut Graph, inputs: &[NodeId]) -> Result<Vec<NodeId>, NnError> {
        if inputs.len() != self.inputs() {
            return Err(NnError::InputWidth {
                given: inputs.len(),
                expected: self.inputs(),
            });
        }
        let mut current = inputs.to_vec();
        let last = self.layers.len() - 1;
        for (l, layer) in self.layers.iter().enumerate() {
            let activation = if l == last { self.output } else { self.hidden };
            let mut next = Vec::with_capacity(layer.outputs);
            for o in 0..layer.outputs {
                let mut terms = vec![graph.constant(layer.bias[o])];
                for (i, &x) in current.iter().enumerate() {
                    let w = layer.weight_at(o, i);
                    if w != 0.0 {
                        terms.push(graph.scale(w, x));
                    }
                }
                let sum = graph.sum(&terms);
                next.push(activation.to_graph(graph, sum));
            }
            current = next;
        }
        Ok(current)
    }

    /// Writes the network as JSON, atomically (see [`atomic`](crate::report::atomic)).
    pub fn save(&self, path: &Path) -> Result<(), NnError> {
        let text = serde_json::to_string(self).map_err(|source| NnError::Format {
            path: path.to_path_buf(),
            source,
        })?;
        crate::report::atomic::write(path, text).map_err(|source| NnError::Write {
            path: path.to_path_buf(),
            source,
        })
    }

    /// Reads a network written by [`Mlp::save`], checking its shapes.
    ///
    /// ```
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use ghm::nn::{Activation, Dense, Mlp, NnError};
    ///
    /// // 2 → 3 (tanh) → 1 (identity)
    /// let hidden = Dense { inputs: 2, outputs: 3, weight: vec![0.1, -0.2, 0.3, 0.4, -0.5, 0.6], bias: vec![0.0; 3] };
    /// let last = Dense { inputs: 3, outputs: 1, weight: vec![1.0, -1.0, 0.5], bias: vec![0.25] };
    /// let net = Mlp::new(vec![hidden, last], Activation::Tanh, Activation::Identity)?;
    /// assert_eq!((net.inputs(), net.outputs(), net.parameter_count()), (2, 1, 13));
    ///
    /// let dir = std::env::temp_dir().join(format!("ghm-doc-mlp-{}", std::process::id()));
    /// std::fs::create_dir_all(&dir)?;
    /// let path = dir.join("net.json");
    /// net.save(&path)?;
    /// let back = Mlp::load(&path)?;
    /// assert_eq!(back, net);
    /// assert_eq!(back.forward(&[0.3, -0.7]), net.forward(&[0.3, -0.7]));
    ///
    /// std::fs::write(&path, "{}")?;
    /// assert!(matches!(Mlp::load(&path), Err(NnError::Format { .. })));
    /// std::fs::remove_dir_all(&dir)?;
    /// # Ok(())
    /// # }
    /// ```
    pub fn load(path: &Path) -> Result<Mlp, NnError> {
        let text = std::fs::read_to_string(path).map_err(|source| NnError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        serde_json::from_str(&text).map_err(|source| NnError::Format {
            path: path.to_path_buf(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::SVector;
    use num_dual::{hessian, Dual2Vec64};

    fn small() -> Mlp {
        let l0 = Dense {
            inputs: 2,
            outputs: 3,
            weight: vec![0.5, -1.0, 0.25, 0.75, -0.3, 0.2],
            bias: vec![0.1, 0.2, -0.1],
        };
        let l1 = Dense {
            inputs: 3,
            outputs: 1,
            weight: vec![1.0, -2.0, 0.5],
            bias: vec![0.3],
        };
        Mlp::new(vec![l0, l1], Activation::Tanh, Activation::Identity).unwrap()
    }

    #[test]
    fn rejects_inconsistent_shapes() {
        let bad = Dense {
            inputs: 2,
            outputs: 2,
            weight: vec![1.0; 3],
            bias: vec![0.0; 2],
        };
        assert!(matches!(
            Mlp::new(vec![bad], Activation::Relu, Activation::Identity),
            Err(NnError::LayerShape { .. })
        ));
        let a = Dense {
            inputs: 1,
            outputs: 2,
            weight: vec![1.0; 2],
            bias: vec![0.0; 2],
        };
        let b = Dense {
            inputs: 3,
            outputs: 1,
            weight: vec![1.0; 3],
            bias: vec![0.0],
        };
        assert!(matches!(
            Mlp::new(vec![a, b], Activation::Relu, Activation::Identity),
            Err(NnError::Chain { .. })
        ));
        assert!(matches!(
            small().try_forward(&[1.0]),
            Err(NnError::InputWidth { .. })
        ));
    }

    #[test]
    fn the_second_order_pass_matches_dual_numbers() {
        use num_dual::second_derivative;
        let mut net = small();
        for hidden in [Activation::Tanh, Activation::Relu, Activation::Identity] {
            net.hidden = hidden;
            for (x, direction) in [([0.4, -0.2], [1.0, 0.0]), ([-1.3, 2.1], [0.3, -2.0])] {
                let (v, d, d2) = net.forward_second_along(&x, &direction);
                let (rv, rd, rd2) = second_derivative(
                    |s| {
                        let input = [s * direction[0] + x[0], s * direction[1] + x[1]];
                        net.forward(&input)[0]
                    },
                    0.0,
                );
                for (a, b) in [(v, rv), (d, rd), (d2, rd2)] {
                    assert!(
                        (a - b).abs() <= 1e-13 * (1.0 + b.abs()),
                        "{hidden:?} at {x:?}: {a} vs {b}"
                    );
                }
                // Not all zero: the test compares something.
                assert!(d != 0.0 || hidden == Activation::Relu);
            }
        }
    }

    #[test]
    fn graph_expansion_evaluates_like_the_network() {
        let net = small();
        let mut graph = Graph::new();
        let inputs = [graph.var(0), graph.var(1)];
        let out = net.to_graph(&mut graph, &inputs).unwrap();
        for x in [[0.3, -0.7], [1.5, 2.0], [-4.0, 0.0]] {
            let from_graph = graph.eval_f64(&out, &x)[0];
            let direct = net.forward(&x)[0];
            assert!(
                (from_graph - direct).abs() < 1e-14,
                "{from_graph} vs {direct}"
            );
        }
    }

    #[test]
    fn hessian_from_duals_matches_central_differences() {
        let net = small();
        let x = [0.4, -0.2];
        let (_, g, h) = hessian(
            |v: SVector<Dual2Vec64<nalgebra::Const<2>>, 2>| net.forward(&[v[0], v[1]])[0],
            &SVector::from(x),
        );
        let f = |a: f64, b: f64| net.forward(&[a, b])[0];
        let e = 1e-4;
        let fd_g0 = (f(x[0] + e, x[1]) - f(x[0] - e, x[1])) / (2.0 * e);
        let fd_h01 = (f(x[0] + e, x[1] + e) - f(x[0] + e, x[1] - e) - f(x[0] - e, x[1] + e)
            + f(x[0] - e, x[1] - e))
            / (4.0 * e * e);
        assert!((g[0] - fd_g0).abs() < 1e-7, "{} vs {fd_g0}", g[0]);
        assert!(
            (h[(0, 1)] - fd_h01).abs() < 1e-5,
            "{} vs {fd_h01}",
            h[(0, 1)]
        );
        assert!((h[(0, 1)] - h[(1, 0)]).abs() < 1e-15);
    }

    #[test]
    fn output_rows_and_file_round_trip() {
        let net = small();
        let two_heads = Dense {
            inputs: 3,
            outputs: 2,
            weight: vec![1.0, -2.0, 0.5, 9.0, 9.0, 9.0],
            bias: vec![0.3, 7.0],
        };
        let wide = Mlp::new(
            vec![net.layers[0].clone(), two_heads],
            Activation::Tanh,
            Activation::Identity,
        )
        .unwrap();
        let head = wide.with_output_rows(0..1).unwrap();
        assert_eq!(head, net);
        let dir = std::env::temp_dir().join(format!("ghm-nn-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("net.json");
        net.save(&path).unwrap();
        assert_eq!(Mlp::load(&path).unwrap(), net);
        std::fs::write(&path, "{\"layers\": []}").unwrap();
        assert!(matches!(Mlp::load(&path), Err(NnError::Format { .. })));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
