//! RL-guided MPC (spec §12): a guide (the trained policy, or the rule-based expert)
//! extends the short horizon with what it knows about the rest of the season.
//!
//! At each step, before the solve ([`Guidance::prepare`]):
//!
//! * **guess**: at the first step (or after a step without a solution) the guide is rolled
//!   `N` steps from the measured state on the nominal model; otherwise the previous
//!   solution's inputs are shifted one step and one guide step is appended from the
//!   previous plan's terminal point (state `X*_N`, previous input `U*_{N−1}`, step
//!   `k + N − 1`). The solver starts from the states simulated under these inputs;
//! * **terminal region** (unless `vfo`): `x_N` within `(1 ± ε) x̃_N` and `u_{N−1}` within
//!   `(1 ± ε) ũ_{N−1}`, component-wise, where `x̃_N`, `ũ_{N−1}` are the guess's terminal
//!   state and last input (a zero component pins that entry to zero);
//! * **terminal cost**: `−V(x_{N,i}, k + N)` with the value network's exact derivatives, or
//!   its first-order expansion around `x̃_N` (`taylor`).
//!
//! Curvature: `−V` can make the Lagrangian Hessian indefinite in `x_{N,i}`. The SQP
//! back-end handles this as it handles any indefinite stage (diagonal shifts, then
//! eigenvalue clipping per block: see [`Sqp`](crate::solve::Sqp)); IPOPT applies
//! its own inertia correction.

use crate::control::roll_out::RollOut;
use crate::control::value::{taylor_terminal_cost, ValueTerminalCost};
use crate::control::{ControlError, Controller, Guidance, Observation, ValueFile};
use crate::model::Plant;
use crate::nlp::{Ocp, TerminalBox};
use std::sync::Arc;

/// The two forms of the terminal cost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TerminalCostForm {
    /// `−V` with exact gradient and Hessian.
    Exact,
    /// `−V`'s first-order expansion around the guess's terminal state.
    Taylor,
}

/// Settings of RL-guided MPC.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RlMpcOptions {
    /// Relative half-width of the terminal region; `None` drops the region (VFO).
    pub epsilon: Option<f64>,
    /// How `−V` enters the terminal cost: exact or its first-order expansion.
    pub terminal_cost: TerminalCostForm,
}

impl Default for RlMpcOptions {
    fn default() -> RlMpcOptions {
        RlMpcOptions {
            epsilon: Some(0.05),
            terminal_cost: TerminalCostForm::Exact,
        }
    }
}

/// The guidance of RL-guided MPC: a guide controller and an optional value function. See
/// the [module documentation](self).
pub struct RlGuidance {
    plant: Arc<Plant>,
    guide: Box<dyn Controller + Send>,
    guide_name: String,
    value: Option<ValueFile>,
    options: RlMpcOptions,
    exact_cost_set: bool,
    roll_out: RollOut,
    inputs: Vec<f64>,
    region: Option<TerminalBox>,
}

impl RlGuidance {
    /// Guidance by `guide` (named `guide_name` in reports) with the value function `value`
    /// (no terminal cost without one).
    pub fn new(
        plant: Arc<Plant>,
        guide: Box<dyn Controller + Send>,
        guide_name: &str,
        value: Option<ValueFile>,
        options: RlMpcOptions,
    ) -> Result<RlGuidance, ControlError> {
        if let Some(e) = options.epsilon {
            if !(e.is_finite() && e >= 0.0) {
                return Err(ControlError::Other(format!(
                    "the terminal region's ε must be a non-negative number, not {e}"
                )));
            }
        }
        if let Some(v) = &value {
            if v.state_index >= plant.layout.nx {
                return Err(ControlError::Other(format!(
                    "the value function reads state {} but the model has {}",
                    v.state_index, plant.layout.nx
                )));
            }
        }
        Ok(RlGuidance {
            roll_out: RollOut::new(Arc::clone(&plant)),
            inputs: Vec::new(),
            region: None,
            guide_name: guide_name.to_string(),
            guide,
            value,
            options,
            exact_cost_set: false,
            plant,
        })
    }
}

/// `[(1 − ε) v, (1 + ε) v]` ordered, component-wise.
fn relative_box(values: &[f64], epsilon: f64) -> (Vec<f64>, Vec<f64>) {
    values
        .iter()
        .map(|v| {
            let (a, b) = ((1.0 - epsilon) * v, (1.0 + epsilon) * v);
            (a.min(b), a.max(b))
        })
        .unzip()
}

/// The terminal region around the guess's terminal state and last input.
///
/// ```
/// // ±5 % around (20, −2, 0): ordered bounds, and a zero component is pinned.
/// let b = ghm::control::terminal_region(&[20.0, -2.0, 0.0], &[1.0], 0.05);
/// assert_eq!(b.state_lower, vec![19.0, -2.1, 0.0]);
/// assert_eq!(b.state_upper, vec![21.0, -1.9, 0.0]);
/// assert_eq!((b.input_lower[0], b.input_upper[0]), (0.95, 1.05));
/// ```
pub fn terminal_region(state: &[f64], input: &[f64], epsilon: f64) -> TerminalBox {
    let (state_lower, state_upper) = relative_box(state, epsilon);
    let (input_lower, input_upper) = relative_box(input, epsilon);
    TerminalBox {
        state_lower,
        state_upper,
        input_lower,
        input_upper,
    }
}

impl Guidance for RlGuidance {
    fn name(&self) -> String {
        let variant = if self.options.epsilon.is_none() {
            "rlmpc-vfo"
        } else {
            "rlmpc"
        };
        format!("{variant}[{}]", self.guide_name)
    }

    fn prepare(
        &mut self,
        ocp: &mut Ocp,
        observation: &Observation,
        forecast: &[f64],
        previous: Option<&[f64]>,
        start: &mut [f64],
    ) -> Result<(), ControlError> {
        let l = *ocp.layout();
        let (n, nu, nd) = (l.horizon, l.nu, self.plant.layout.nd);
        let k = observation.step;
        let row = |j: usize| &forecast[j * nd..];
        self.inputs.clear();
        let terminal_state = match previous {
            Some(prev) => {
                for j in 0..n - 1 {
                    self.inputs.extend_from_slice(ocp.input(prev, j + 1));
                }
                let x_end = ocp.state_at(prev, n).to_vec();
                let u_end = ocp.input(prev, n - 1).to_vec();
                let u = self.roll_out.input(
                    self.guide.as_mut(),
                    &x_end,
                    &u_end,
                    k + n - 1,
                    row(n - 1),
                )?;
                let terminal = self.roll_out.successor(&x_end, &u, &row(n - 1)[..nd]);
                self.inputs.extend_from_slice(&u);
                terminal
            }
            None => self.roll_out.horizon(
                self.guide.as_mut(),
                observation,
                forecast,
                n,
                &mut self.inputs,
            )?,
        };
        let inputs = std::mem::take(&mut self.inputs);
        ocp.rollout(&inputs, start);
        let last_input = &inputs[(n - 1) * nu..n * nu];
        self.region = self
            .options
            .epsilon
            .map(|e| terminal_region(&terminal_state, last_input, e));
        ocp.set_terminal_box(self.region.clone());
        self.inputs = inputs;
        if let Some(value) = &self.value {
            match self.options.terminal_cost {
                TerminalCostForm::Exact => {
                    if !self.exact_cost_set {
                        ocp.set_terminal_cost(Some(Box::new(ValueTerminalCost::new(
                            value.clone(),
                        ))));
                        self.exact_cost_set = true;
                    }
                }
                TerminalCostForm::Taylor => {
                    let cost = taylor_terminal_cost(value, &terminal_state, k + n);
                    ocp.set_terminal_cost(Some(Box::new(cost)));
                }
            }
        }
        Ok(())
    }

    fn forecast_rows(&self) -> usize {
        self.guide.forecast_rows()
    }

    fn guide_input(&mut self, observation: &Observation) -> Option<Vec<f64>> {
        self.roll_out
            .input(
                self.guide.as_mut(),
                observation.state,
                observation.previous_input,
                observation.step,
                observation.forecast,
            )
            .ok()
    }

    fn region_status(&self, ocp: &Ocp, x: &[f64]) -> Option<String> {
        let region = self.region.as_ref()?;
        let l = ocp.layout();
        // A pinned component (zero guess) is always at its bounds and says nothing.
        let at_bound = |v: f64, lo: f64, hi: f64| {
            let tol = 1e-7 * (1.0 + v.abs());
            hi - lo > tol && ((v - lo).abs() <= tol || (hi - v).abs() <= tol)
        };
        let x_n = ocp.state_at(x, l.horizon);
        let u_last = ocp.input(x, l.horizon - 1);
        let binding = x_n
            .iter()
            .zip(region.state_lower.iter().zip(&region.state_upper))
            .chain(
                u_last
                    .iter()
                    .zip(region.input_lower.iter().zip(&region.input_upper)),
            )
            .any(|(v, (lo, hi))| at_bound(*v, *lo, *hi));
        Some(if binding { "binding" } else { "inactive" }.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn region_is_relative_ordered_and_pins_zeros() {
        let b = terminal_region(&[10.0, -2.0, 0.0], &[0.0, 4.0], 0.05);
        assert_eq!(b.state_lower, vec![9.5, -2.1, 0.0]);
        assert_eq!(b.state_upper, vec![10.5, -1.9, 0.0]);
        assert_eq!(b.input_lower, vec![0.0, 3.8]);
        assert_eq!(b.input_upper, vec![0.0, 4.2]);
    }
}
