//! The learned value function of RL-guided MPC as a file and as terminal costs.
//!
//! `V(x_i, k)` predicts the return the guide earns from state component `x_i` (the crop
//! dry weight for the greenhouse) at season step `k` to the end of the season. The NLP
//! minimises `−V` at the end of the horizon:
//!
//! * [`ValueTerminalCost`] (`exact`): `T(x_N) = −V(x_{N,i}, k + N)`, with its exact gradient
//!   and Hessian from dual numbers through the network;
//! * [`taylor_terminal_cost`] (`taylor`, the paper's fast version): the first-order
//!   expansion of `−V` around the guess's terminal state.

use crate::control::ControlError;
use crate::nlp::{LinearTerminalCost, TerminalCost};
use crate::nn::ScaledMlp;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A fitted value function and what it was fitted on.
///
/// # Examples
///
/// The value function shipped with the lettuce agent: the return the agent still earns
/// from a crop dry weight at a season step.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::ValueFile;
///
/// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/agents/lettuce");
/// let value = ValueFile::load(&dir.join("value-sac.json"))?;
/// assert_eq!((value.model.as_str(), value.guide.as_str()), ("lettuce", "sac"));
/// assert_eq!((value.state_index, value.state_name.as_str()), (0, "dry_weight"));
///
/// // V reads only the dry weight (state 0) and the step.
/// let state = [0.05, 1e-3, 15.0, 0.008];
/// let mut other = state;
/// other[2] = 20.0;
/// assert_eq!(value.value(&state, 100), value.value(&other, 100));
/// // More season left, more return to go.
/// assert!(value.value(&state, 100) > value.value(&state, 1800));
///
/// // Round trip through a file.
/// let path = std::env::temp_dir().join(format!("ghm-doc-value-{}.json", std::process::id()));
/// value.save(&path)?;
/// assert_eq!(ValueFile::load(&path)?, value);
/// std::fs::remove_file(&path)?;
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ValueFile {
    /// The model it belongs to.
    pub model: String,
    /// The guide whose returns it predicts (`sac` or `expert`).
    pub guide: String,
    /// The state component it reads, by index and name.
    pub state_index: usize,
    /// The name of state `state_index` in the model it was fitted on, for reports.
    pub state_name: String,
    /// Inputs `(x_i, k)`, outputs the return-to-go.
    pub function: ScaledMlp,
    /// Final mean squared errors of the fit (return units squared).
    pub train_loss: f64,
    /// The same on the held-out validation set.
    pub validation_loss: f64,
}

impl ValueFile {
    /// `V(x_i, k)`.
    pub fn value(&self, state: &[f64], step: usize) -> f64 {
        self.function
            .evaluate(&[state[self.state_index], step as f64])
    }

    /// Writes it as JSON to `path`, replacing any file there.
    pub fn save(&self, path: &Path) -> Result<(), ControlError> {
        let fail = |reason: String| ControlError::ValueFile {
            path: path.to_path_buf(),
            reason,
        };
        let text = serde_json::to_string(self).map_err(|e| fail(e.to_string()))?;
        std::fs::write(path, text).map_err(|e| fail(format!("cannot write: {e}")))
    }

    /// Reads a file written by [`save`](Self::save), checking that the network is valid and
    /// takes the two inputs `(x_i, k)`.
    pub fn load(path: &Path) -> Result<ValueFile, ControlError> {
        let fail = |reason: String| ControlError::ValueFile {
            path: path.to_path_buf(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| fail(format!("cannot read: {e}")))?;
        let file: ValueFile =
            serde_json::from_str(&text).map_err(|e| fail(format!("not a value file: {e}")))?;
        file.function.validate().map_err(|e| fail(e.to_string()))?;
        if file.function.net.inputs() != 2 {
            return Err(fail(format!(
                "the value network takes {} inputs; (state, step) needs 2",
                file.function.net.inputs()
            )));
        }
        Ok(file)
    }

    /// `(−V, −∂V/∂x_i, −∂²V/∂x_i²)` at `(x_i, k)`.
    fn negative_with_derivatives(&self, x_i: f64, step: usize) -> (f64, f64, f64) {
        let (v, dv, d2v) = self.function.evaluate_second(&[x_i, step as f64], 0);
        (-v, -dv, -d2v)
    }
}

type CostPoint = (f64, usize);
type CostFigures = (f64, f64, f64);

/// `T(x_N) = −V(x_{N,i}, k_N)` with exact derivatives. See the [module documentation](self).
///
/// The NLP asks for the value, gradient and Hessian at the same point several times per
/// iteration; the last point's figures are kept, so the network runs once per point.
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::{ValueFile, ValueTerminalCost};
/// use ghm::nlp::TerminalCost;
///
/// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/agents/lettuce");
/// let value = ValueFile::load(&dir.join("value-sac.json"))?;
/// let mut cost = ValueTerminalCost::new(value.clone());
///
/// let (x, k) = ([0.05, 1e-3, 15.0, 0.008], 500);
/// let (mut gradient, mut hessian) = ([0.0; 4], [0.0; 16]);
/// let t = cost.evaluate(&x, k, &mut gradient, &mut hessian);
/// // The value network's own value, to rounding (the derivative pass sums in another order).
/// assert!((t + value.value(&x, k)).abs() <= 1e-14 * t.abs());
/// // Only the dry weight (state 0) enters: one gradient entry, one Hessian entry.
/// assert!(gradient[1..].iter().all(|g| *g == 0.0));
/// assert!(hessian.iter().enumerate().all(|(i, h)| i == 0 || *h == 0.0));
/// // The exact gradient against a central difference.
/// let h = 1e-6;
/// let (mut up, mut down) = (x, x);
/// up[0] += h;
/// down[0] -= h;
/// let difference = -(value.value(&up, k) - value.value(&down, k)) / (2.0 * h);
/// assert!((gradient[0] - difference).abs() < 1e-5 * (1.0 + difference.abs()));
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct ValueTerminalCost {
    value: ValueFile,
    /// The last point `(x_i, k)` and `(T, ∂T/∂x_i, ∂²T/∂x_i²)` there.
    last: Option<(CostPoint, CostFigures)>,
}

impl ValueTerminalCost {
    /// The terminal cost `−V` of `value`, with nothing computed yet.
    pub fn new(value: ValueFile) -> ValueTerminalCost {
        ValueTerminalCost { value, last: None }
    }

    /// The value function it is the negative of.
    pub fn value(&self) -> &ValueFile {
        &self.value
    }
}

impl TerminalCost for ValueTerminalCost {
    fn evaluate(
        &mut self,
        state: &[f64],
        step: usize,
        gradient: &mut [f64],
        hessian: &mut [f64],
    ) -> f64 {
        let i = self.value.state_index;
        let nx = state.len();
        let key = (state[i], step);
        let (t, dt, d2t) = match self.last {
            Some((k, figures)) if k == key => figures,
            _ => {
                let figures = self.value.negative_with_derivatives(state[i], step);
                self.last = Some((key, figures));
                figures
            }
        };
        gradient.fill(0.0);
        hessian.fill(0.0);
        gradient[i] = dt;
        hessian[i * nx + i] = d2t;
        t
    }
}

/// The first-order expansion of `−V` around the terminal state `anchor` at step `step`.
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::{taylor_terminal_cost, ValueFile, ValueTerminalCost};
/// use ghm::nlp::TerminalCost;
///
/// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/agents/lettuce");
/// let value = ValueFile::load(&dir.join("value-sac.json"))?;
/// let (anchor, k) = ([0.05, 1e-3, 15.0, 0.008], 500);
/// let mut linear = taylor_terminal_cost(&value, &anchor, k);
/// let mut exact = ValueTerminalCost::new(value.clone());
/// let (mut g, mut h) = ([0.0; 4], [0.0; 16]);
///
/// // At the anchor both forms agree, gradient included.
/// let t_exact = exact.evaluate(&anchor, k, &mut g, &mut h);
/// let g_exact = g;
/// assert_eq!(linear.evaluate(&anchor, k, &mut g, &mut h), t_exact);
/// assert_eq!(g, g_exact);
/// assert!(h.iter().all(|v| *v == 0.0)); // a linear cost has no curvature
/// // Away from it the linear form moves along the anchor's slope.
/// let mut x = anchor;
/// x[0] += 0.01;
/// let t = linear.evaluate(&x, k, &mut g, &mut h);
/// assert!((t - (t_exact + 0.01 * g_exact[0])).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
pub fn taylor_terminal_cost(value: &ValueFile, anchor: &[f64], step: usize) -> LinearTerminalCost {
    let i = value.state_index;
    let (t, dt, _) = value.negative_with_derivatives(anchor[i], step);
    let mut gradient = vec![0.0; anchor.len()];
    gradient[i] = dt;
    LinearTerminalCost {
        value: t,
        gradient,
        anchor: anchor.to_vec(),
    }
}
