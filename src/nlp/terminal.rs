//! Hooks at the end of the horizon: a terminal cost on the last predicted state and a
//! terminal box on the last state and input (RL-guided MPC fills both from a policy).

use std::fmt::Debug;

/// A smooth cost `T(x_N, k_N)` on the last predicted state, where `k_N` is the season
/// step index of that state. It is minimised together with the stage costs.
pub trait TerminalCost: Debug + Send {
    /// Returns `T`, writes `∂T/∂x_N` into `gradient` (length `nx`) and `∂²T/∂x_N²` into
    /// `hessian` (`nx × nx`, row-major).
    fn evaluate(
        &mut self,
        state: &[f64],
        step: usize,
        gradient: &mut [f64],
        hessian: &mut [f64],
    ) -> f64;
}

/// `T(x) = value + gradientᵀ (x − anchor)`: the first-order form of a value function
/// around a reference terminal state.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearTerminalCost {
    /// `T` at the anchor.
    pub value: f64,
    /// `∂T/∂x` at the anchor, one entry per state.
    pub gradient: Vec<f64>,
    /// The state the expansion is taken around.
    pub anchor: Vec<f64>,
}

impl TerminalCost for LinearTerminalCost {
    fn evaluate(
        &mut self,
        state: &[f64],
        _step: usize,
        gradient: &mut [f64],
        hessian: &mut [f64],
    ) -> f64 {
        gradient.copy_from_slice(&self.gradient);
        hessian.fill(0.0);
        self.value
            + self
                .gradient
                .iter()
                .zip(state.iter().zip(&self.anchor))
                .map(|(g, (x, a))| g * (x - a))
                .sum::<f64>()
    }
}

/// Bounds on the last predicted state `x_N` and the last input `u_{N−1}`.
#[derive(Debug, Clone, PartialEq)]
pub struct TerminalBox {
    /// Lower bounds of `x_N`, one per state; they replace the state's own bounds.
    pub state_lower: Vec<f64>,
    /// Upper bounds of `x_N`, one per state; they replace the state's own bounds.
    pub state_upper: Vec<f64>,
    /// Lower bounds of `u_{N−1}`, one per input, intersected with the input's own bounds.
    pub input_lower: Vec<f64>,
    /// Upper bounds of `u_{N−1}`, one per input, intersected with the input's own bounds.
    pub input_upper: Vec<f64>,
}
