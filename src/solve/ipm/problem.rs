//! The barrier problem of one solve: the bounds as the barrier sees them (relaxed where
//! equal, moved where an iterate comes within rounding of them), which rows are dynamics,
//! and the two measures of the filter line search at a point, the constraint violation `θ`
//! and the barrier objective `φ`.

use super::super::kkt::Bounds;
use super::sides::Sides;
use crate::nlp::Nlp;

/// Everything of one solve that the iterations measure against; sized once per problem
/// pattern ([`BarrierProblem::new`]) and read afresh at each solve
/// ([`BarrierProblem::read`]).
#[derive(Debug, Clone)]
pub(super) struct BarrierProblem {
    /// Variables.
    pub n: usize,
    /// Constraint rows.
    pub m: usize,
    /// Variable bounds as the barrier sees them.
    pub vars: Sides,
    /// Row bounds of the inequality rows (±∞ on dynamics rows, which have none).
    pub rows: Sides,
    /// Dynamics rows' right-hand side (`g_l = g_u`).
    pub target: Vec<f64>,
    pub is_dynamics: Vec<bool>,
    /// `1 / D²` per variable: the inertia correction's diagonal.
    pub shift: Vec<f64>,
    /// The problem's own bounds.
    pub bounds: Bounds,
}

impl BarrierProblem {
    /// A problem of `n` variables and `m` rows, `is_dynamics` per row, every bound zero.
    pub fn new(n: usize, m: usize, is_dynamics: Vec<bool>) -> BarrierProblem {
        BarrierProblem {
            n,
            m,
            vars: Sides::zeros(n),
            rows: Sides::zeros(m),
            target: vec![0.0; m],
            is_dynamics,
            shift: vec![0.0; n],
            bounds: Bounds::default(),
        }
    }

    /// Reads the bounds and scales of `nlp`, of this problem's sizes.
    pub fn read(&mut self, nlp: &dyn Nlp) {
        self.bounds.read(nlp);
        let b = &self.bounds;
        self.vars.lower.copy_from_slice(&b.x_lower);
        self.vars.upper.copy_from_slice(&b.x_upper);
        self.vars.relax_equal_bounds();
        for r in 0..self.m {
            (self.rows.lower[r], self.rows.upper[r]) = if self.is_dynamics[r] {
                (f64::NEG_INFINITY, f64::INFINITY)
            } else {
                (b.g_lower[r], b.g_upper[r])
            };
        }
        self.rows.relax_equal_bounds();
        self.target.copy_from_slice(&b.g_lower);
        for (shift, d) in self.shift.iter_mut().zip(&b.scale) {
            *shift = 1.0 / (d * d);
        }
    }

    /// `θ`: ℓ₁ violation of the dynamics and of `c − t` on the other rows.
    pub fn violation(&self, c: &[f64], t: &[f64]) -> f64 {
        (0..self.m)
            .map(|r| {
                if self.is_dynamics[r] {
                    (c[r] - self.target[r]).abs()
                } else {
                    (c[r] - t[r]).abs()
                }
            })
            .sum()
    }

    /// `φ = f − μ Σ ln(slacks)`.
    pub fn barrier(&self, f: f64, w: &[f64], t: &[f64], mu: f64) -> f64 {
        let vars: f64 = (0..self.n).map(|i| self.vars.log_slacks(i, w[i])).sum();
        let rows: f64 = (0..self.m)
            .filter(|&r| !self.is_dynamics[r])
            .map(|r| self.rows.log_slacks(r, t[r]))
            .sum();
        let phi = f - mu * (vars + rows);
        if phi.is_nan() {
            f64::INFINITY
        } else {
            phi
        }
    }
}
