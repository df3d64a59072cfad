//! The least-squares step of a small perceptron, written out: the forward pass, the
//! backward pass and every parameter's gradient of the mean squared error over a
//! mini-batch, in `f32`, with matrixmultiply's `sgemm` for the products and a tanh the
//! compiler vectorises ([`tanh_f32`]).
//!
//! The value fit and the imitation fit are plain regressions of perceptrons such as
//! 2 → 128 → 128 → 1. On burn's CPU back-end two thirds of a value fit went to libm's
//! scalar `tanhf` (perf, 2026-12-06), and as `2σ(2x) − 1` still half to scalar `expf` and
//! the element loop around it; here the products take most of the time. The gradients are
//! those burn computes for the same loss, to `f32` rounding (test against burn below).

use crate::nn::Activation;
use crate::rl::sac::net::Net;

/// A zero gradient for every parameter of `net`, in the order of [`Net::parameters`]:
/// what [`Regression::step`] fills.
pub fn zero_gradients(net: &Net) -> Vec<Vec<f32>> {
    net.parameters()
        .iter()
        .map(|p| vec![0.0; p.len()])
        .collect()
}

/// What follows the last layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputMap {
    /// The last layer's values (the value network).
    Linear,
    /// Their tanh (an actor's actions in `[−1, 1]`).
    Tanh,
}

/// The activations and error signals of one mini-batch, kept between steps so that a fit
/// allocates once.
#[derive(Debug, Default)]
pub struct Regression {
    /// `activations[l]`: the input of layer `l` (`activations[0]` the batch), then the
    /// network's output, each `rows × width`, row-major.
    activations: Vec<Vec<f32>>,
    /// `∂L/∂z` of the layer being back-propagated, and of the one before it.
    signal: Vec<f32>,
    previous_signal: Vec<f32>,
}

impl Regression {
    /// A workspace; it grows to the first batch it is given.
    pub fn new() -> Regression {
        Regression::default()
    }

    /// The mean squared error of `net` (then `output`) on the batch `x` (`rows × inputs`)
    /// against `y` (`rows × outputs`), averaged over every entry as `mean((ŷ − y)²)`, and
    /// its gradient for every weight and bias into `gradients` (in the order of
    /// [`Net::parameters`], each as long as its parameter).
    ///
    /// # Panics
    /// Where `x`, `y` or `gradients` do not have the network's widths.
    pub fn step(
        &mut self,
        net: &Net,
        output: OutputMap,
        x: &[f32],
        y: &[f32],
        gradients: &mut [Vec<f32>],
    ) -> f32 {
        let rows = x.len() / net.inputs();
        assert_eq!(x.len(), rows * net.inputs(), "x is rows × inputs");
        assert_eq!(y.len(), rows * net.outputs(), "y is rows × outputs");
        assert_eq!(
            gradients.len(),
            2 * net.layers.len(),
            "a gradient per parameter"
        );
        self.forward(net, output, x, rows);
        let last = net.layers.len();
        let prediction = &self.activations[last];
        // ∂L/∂ŷ = 2 (ŷ − y) / (rows · outputs), through the output map.
        let scale = 2.0 / y.len() as f32;
        let mut loss = 0.0f64;
        self.signal.clear();
        for (p, t) in prediction.iter().zip(y) {
            let e = p - t;
            loss += f64::from(e * e);
            let d = scale * e;
            self.signal.push(match output {
                OutputMap::Linear => d,
                OutputMap::Tanh => d * (1.0 - p * p),
            });
        }
        for l in (0..last).rev() {
            let layer = &net.layers[l];
            let (n_in, n_out) = (layer.inputs, layer.outputs);
            let input = &self.activations[l];
            let (weight_grad, rest) = gradients[2 * l..].split_at_mut(1);
            // ∂L/∂W = Aᵀ · S (inputs × outputs), ∂L/∂b = the column sums of S.
            gemm(
                (n_in, rows, n_out),
                (input, 1, n_in),
                (&self.signal, n_out, 1),
                0.0,
                (&mut weight_grad[0], n_out, 1),
            );
            let bias_grad = &mut rest[0];
            bias_grad.fill(0.0);
            for row in self.signal.chunks_exact(n_out) {
                for (g, s) in bias_grad.iter_mut().zip(row) {
                    *g += s;
                }
            }
            if l == 0 {
                break;
            }
            // ∂L/∂A = S · Wᵀ, then through the hidden activation that made A.
            self.previous_signal.resize(rows * n_in, 0.0);
            gemm(
                (rows, n_out, n_in),
                (&self.signal, n_out, 1),
                (&layer.weight, 1, n_out),
                0.0,
                (&mut self.previous_signal, n_in, 1),
            );
            for (s, a) in self.previous_signal.iter_mut().zip(input) {
                *s *= match net.hidden {
                    Activation::Tanh => 1.0 - a * a,
                    Activation::Relu => f32::from(u8::from(*a > 0.0)),
                    Activation::Identity => 1.0,
                };
            }
            std::mem::swap(&mut self.signal, &mut self.previous_signal);
        }
        (loss / y.len() as f64) as f32
    }

    /// The network's output on the batch `x` (`rows × outputs`, row-major).
    pub fn predict(&mut self, net: &Net, output: OutputMap, x: &[f32]) -> &[f32] {
        let rows = x.len() / net.inputs();
        self.forward(net, output, x, rows);
        &self.activations[net.layers.len()]
    }

    /// Fills `activations` for a batch of `rows`.
    fn forward(&mut self, net: &Net, output: OutputMap, x: &[f32], rows: usize) {
        let last = net.layers.len();
        self.activations.resize_with(last + 1, Vec::new);
        self.activations[0].clear();
        self.activations[0].extend_from_slice(x);
        for (l, layer) in net.layers.iter().enumerate() {
            let (done, next) = self.activations.split_at_mut(l + 1);
            let out = &mut next[0];
            out.clear();
            for _ in 0..rows {
                out.extend_from_slice(&layer.bias);
            }
            gemm(
                (rows, layer.inputs, layer.outputs),
                (&done[l], layer.inputs, 1),
                (&layer.weight, layer.outputs, 1),
                1.0,
                (out, layer.outputs, 1),
            );
            let activation = if l + 1 < last {
                net.hidden
            } else {
                match output {
                    OutputMap::Linear => Activation::Identity,
                    OutputMap::Tanh => Activation::Tanh,
                }
            };
            match activation {
                Activation::Tanh => out.iter_mut().for_each(|v| *v = tanh_f32(*v)),
                Activation::Relu => out.iter_mut().for_each(|v| *v = v.max(0.0)),
                Activation::Identity => {}
            }
        }
    }
}

/// `C = A · B + beta · C` for `(m, k, n)`, each matrix given with its row and column
/// strides.
fn gemm(
    (m, k, n): (usize, usize, usize),
    (a, a_row, a_col): (&[f32], usize, usize),
    (b, b_row, b_col): (&[f32], usize, usize),
    beta: f32,
    (c, c_row, c_col): (&mut [f32], usize, usize),
) {
    let reach = |rows: usize, cols: usize, rs: usize, cs: usize| {
        if rows == 0 || cols == 0 {
            0
        } else {
            (rows - 1) * rs + (cols - 1) * cs + 1
        }
    };
    assert!(a.len() >= reach(m, k, a_row, a_col), "A is m × k");
    assert!(b.len() >= reach(k, n, b_row, b_col), "B is k × n");
    assert!(c.len() >= reach(m, n, c_row, c_col), "C is m × n");
    let stride = |s: usize| isize::try_from(s).expect("a stride fits isize");
    // SAFETY: the asserts above keep every index `sgemm` reads or writes, `i·rs + j·cs`
    // for i < rows and j < cols, inside its slice; C does not alias A or B (`&mut`).
    unsafe {
        matrixmultiply::sgemm(
            m,
            k,
            n,
            1.0,
            a.as_ptr(),
            stride(a_row),
            stride(a_col),
            b.as_ptr(),
            stride(b_row),
            stride(b_col),
            beta,
            c.as_mut_ptr(),
            stride(c_row),
            stride(c_col),
        );
    }
}

/// `tanh x` in `f32` as `1 − 2 / (e^{2x} + 1)`, with an exponential written so that a loop
/// over a slice vectorises: `e^t = 2ⁿ · e^r`, `n = round(t / ln 2)`, `|r| ≤ ln 2 / 2`,
/// `e^r` by its Taylor polynomial to degree 6 (relative error below 2e-7 there). Within
/// `f32` rounding of `tanh` (absolute error below 3e-7); ±1 beyond `|x| > 10`.
#[inline]
pub fn tanh_f32(x: f32) -> f32 {
    let t = 2.0 * x.clamp(-10.0, 10.0);
    // Round to nearest by the 1.5 · 2²³ trick (no call, vectorises).
    const SHIFTER: f32 = 12_582_912.0;
    let n = (t * std::f32::consts::LOG2_E + SHIFTER) - SHIFTER;
    let r = t - n * std::f32::consts::LN_2;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    // 2ⁿ from its exponent bits; n ∈ [−29, 29] for |t| ≤ 20.
    let scale = f32::from_bits(((n as i32 + 127) as u32) << 23);
    1.0 - 2.0 / (p * scale + 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rl::sac::net::to_vec;
    use burn::tensor::{Device, Tensor, TensorData};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn tanh_is_tanh_to_f32_rounding() {
        let mut worst = 0.0f32;
        for i in -200_000..=200_000 {
            let x = i as f32 * 1e-4;
            worst = worst.max((tanh_f32(x) - x.tanh()).abs());
        }
        assert!(worst < 3e-7, "{worst}");
        assert_eq!(tanh_f32(50.0), 1.0);
        assert_eq!(tanh_f32(-50.0), -1.0);
        assert_eq!(tanh_f32(0.0), 0.0);
    }

    /// The gradients and loss burn computes for the same network, batch and loss.
    fn burn_step(net: &Net, output: OutputMap, x: &[f32], y: &[f32]) -> (f32, Vec<Vec<f32>>) {
        let device = Device::flex().autodiff();
        let rows = x.len() / net.inputs();
        let xb = Tensor::<2>::from_data(TensorData::new(x.to_vec(), [rows, net.inputs()]), &device);
        let yb =
            Tensor::<2>::from_data(TensorData::new(y.to_vec(), [rows, net.outputs()]), &device);
        let live = net.tensors(&device, true);
        let mut prediction = live.forward(xb);
        if output == OutputMap::Tanh {
            prediction = prediction.tanh();
        }
        let loss = (prediction - yb).square().mean();
        let value = to_vec(loss.clone().detach()).unwrap()[0];
        (value, live.gradients(&loss.backward()).unwrap())
    }

    #[test]
    fn gradients_are_burns_for_both_activations_and_outputs() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for (hidden, output, widths) in [
            (Activation::Tanh, OutputMap::Linear, [2, 16, 16, 1]),
            (Activation::Relu, OutputMap::Tanh, [5, 12, 12, 3]),
        ] {
            let net = Net::init_xavier(&widths, hidden, &mut rng);
            let rows = 37;
            let x: Vec<f32> = (0..rows * widths[0])
                .map(|_| rng.random_range(-1.0..1.0))
                .collect();
            let y: Vec<f32> = (0..rows * widths[3])
                .map(|_| rng.random_range(-0.9..0.9))
                .collect();
            let mut gradients = zero_gradients(&net);
            let mut regression = Regression::new();
            let loss = regression.step(&net, output, &x, &y, &mut gradients);
            let (burn_loss, burn_gradients) = burn_step(&net, output, &x, &y);
            assert!(
                (loss - burn_loss).abs() <= 1e-5 * burn_loss,
                "{loss} {burn_loss}"
            );
            for (mine, theirs) in gradients.iter().zip(&burn_gradients) {
                let size = theirs.iter().fold(0.0f32, |m, g| m.max(g.abs()));
                for (a, b) in mine.iter().zip(theirs) {
                    assert!(
                        (a - b).abs() <= 1e-4 * size + 1e-7,
                        "{a} against {b} ({hidden:?})"
                    );
                }
            }
            // The same workspace serves a batch of another size.
            let loss_small = regression.step(
                &net,
                output,
                &x[..widths[0] * 5],
                &y[..widths[3] * 5],
                &mut gradients,
            );
            assert!(loss_small.is_finite());
        }
    }
}
