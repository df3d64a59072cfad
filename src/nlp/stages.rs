//! The stage structure of an optimal-control problem, as a structure-exploiting solver
//! reads it: which variables are the states and the controls of each stage, and which
//! constraint rows are the dynamics that link one stage to the next.

use std::ops::Range;

/// The stages `k = 0 … N` of an optimal-control problem.
///
/// * Stage `k` owns its states `x_k` (`states[k]`, empty for a fixed initial state) and,
///   for `k < N`, its controls (`controls[k]`: inputs, slacks, anything else of the stage).
/// * The rows `dynamics[k]` (`k < N`) are equalities `x_{k+1} − F_k(x_k, v_k) = 0`: row
///   `dynamics[k].start + i` has the coefficient `1` on `states[k + 1].start + i` and no
///   other entry on a variable of a later stage.
/// * Every other constraint row and every Hessian entry touches the variables of one
///   stage, or of one stage and the controls of the stage before (a rate limit
///   `u_k − u_{k−1}`).
///
/// Every variable belongs to exactly one stage.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Stages {
    /// The state variables of stage `k`, `k = 0 … N` (`N + 1` ranges).
    pub states: Vec<Range<usize>>,
    /// The control variables of stage `k`, `k = 0 … N − 1` (`N` ranges).
    pub controls: Vec<Range<usize>>,
    /// The dynamics rows of stage `k`, `k = 0 … N − 1` (`N` ranges), one per state of
    /// stage `k + 1`.
    pub dynamics: Vec<Range<usize>>,
}

impl Stages {
    /// Steps `N` (stages with controls).
    pub fn horizon(&self) -> usize {
        self.controls.len()
    }

    /// Whether the ranges fit together: `N + 1` state ranges, `N` dynamics ranges each as
    /// long as the next stage's states, and every variable of `0..n_vars` in exactly one
    /// range.
    pub fn is_consistent(&self, n_vars: usize, n_cons: usize) -> bool {
        let n = self.horizon();
        if self.states.len() != n + 1 || self.dynamics.len() != n {
            return false;
        }
        let rows_fit = self
            .dynamics
            .iter()
            .zip(&self.states[1..])
            .all(|(rows, states)| rows.len() == states.len() && rows.end <= n_cons);
        let mut owned = vec![false; n_vars];
        for range in self.states.iter().chain(&self.controls) {
            for v in range.clone() {
                match owned.get_mut(v) {
                    Some(seen) if !*seen => *seen = true,
                    _ => return false,
                }
            }
        }
        rows_fit && owned.iter().all(|&o| o)
    }
}
