//! The model's own `terminal` terms at a state, as the cost every horizon ends with: minus
//! their sum, with the exact gradient and Hessian of their graph in the state.

use super::Plant;
use crate::graph::{Derivatives, Tape};

/// The derivatives of a plant's terminal tape with respect to the state.
#[derive(Debug, Clone)]
pub(crate) struct ModelTerminalCost {
    tape: Tape,
    derivatives: Derivatives,
    inputs: Vec<f64>,
    weights: Vec<f64>,
}

impl ModelTerminalCost {
    /// The terminal cost of `plant`'s model, or `None` when it declares no `terminal`.
    pub(crate) fn of(plant: &Plant) -> Option<ModelTerminalCost> {
        let tape = plant.terminal_tape()?;
        let nx = plant.layout.nx;
        Some(ModelTerminalCost {
            tape: tape.clone(),
            derivatives: Derivatives::new(tape, &(0..nx).collect::<Vec<_>>()),
            inputs: vec![0.0; plant.layout.n_base()],
            weights: vec![-1.0; tape.outputs.len()],
        })
    }

    /// `−Σ terminal rewards` of `plant` at `state` and `params`; writes the gradient and
    /// the (`nx × nx`, row-major) Hessian.
    pub(crate) fn evaluate(
        &mut self,
        plant: &Plant,
        state: &[f64],
        params: &[f64],
        gradient: &mut [f64],
        hessian: &mut [f64],
    ) -> f64 {
        let l = plant.layout;
        self.inputs[..l.nx].copy_from_slice(state);
        self.inputs[l.p(0)..l.p(0) + l.np].copy_from_slice(params);
        let e = self
            .derivatives
            .hessian(&self.tape, &self.inputs, &self.weights);
        gradient.copy_from_slice(&e.gradient);
        hessian.copy_from_slice(&e.hessian);
        -e.values.iter().sum::<f64>()
    }
}
