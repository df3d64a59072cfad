//! Hooks at the end of the horizon: a terminal cost on the last predicted state and a
//! terminal box on the last state and input (RL-guided MPC fills both from a policy), and
//! the model's own `terminal` terms, which every horizon ends with.

use std::fmt::Debug;
use std::sync::Arc;

use crate::graph::Derivatives;
use crate::model::Plant;

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

/// The model's own `terminal` terms as a cost on `x_N`: `−Σ` of their rewards, with the
/// exact gradient and Hessian of the term graph, at the parameters the controller
/// predicts with.
#[derive(Debug, Clone)]
pub(crate) struct ModelTerminal {
    plant: Arc<Plant>,
    derivatives: Derivatives,
    inputs: Vec<f64>,
    weights: Vec<f64>,
}

impl ModelTerminal {
    /// The terminal cost of `plant`'s model, or `None` when it declares no `terminal`.
    pub(crate) fn of(plant: &Arc<Plant>) -> Option<ModelTerminal> {
        let tape = plant.terminal_tape()?;
        let nx = plant.layout.nx;
        Some(ModelTerminal {
            derivatives: Derivatives::new(tape, &(0..nx).collect::<Vec<_>>()),
            inputs: vec![0.0; plant.layout.n_base()],
            weights: vec![-1.0; tape.outputs.len()],
            plant: Arc::clone(plant),
        })
    }

    /// Returns the cost at `state`; writes its gradient and (`nx × nx`, row-major) Hessian.
    pub(crate) fn evaluate(
        &mut self,
        state: &[f64],
        params: &[f64],
        gradient: &mut [f64],
        hessian: &mut [f64],
    ) -> f64 {
        let l = self.plant.layout;
        self.inputs[..l.nx].copy_from_slice(state);
        self.inputs[l.p(0)..l.p(0) + l.np].copy_from_slice(params);
        let Some(tape) = self.plant.terminal_tape() else {
            unreachable!("made only for a plant with a terminal tape");
        };
        let e = self.derivatives.hessian(tape, &self.inputs, &self.weights);
        gradient.copy_from_slice(&e.gradient);
        hessian.copy_from_slice(&e.hessian);
        -e.values.iter().sum::<f64>()
    }
}
