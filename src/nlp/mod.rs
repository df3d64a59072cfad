//! Nonlinear programs: the [`Nlp`] trait every solver back-end consumes, and the
//! optimal-control transcription [`Ocp`] of a plant over a horizon.
//!
//! The conventions are IPOPT's, so that every back-end reads the same problem:
//!
//! ```text
//! minimise f(x)   subject to   x_l ≤ x ≤ x_u,   g_l ≤ g(x) ≤ g_u,
//! ```
//!
//! with the Lagrangian `L = σ f(x) + λᵀ g(x)` (bound multipliers apart). Equalities have
//! `g_l = g_u`; infinite bounds are `±f64::INFINITY`. Sparse matrices are given as a fixed
//! pattern of `(row, col)` pairs ([`Pattern`]) and a value vector in the same order; the
//! Hessian pattern holds the lower triangle only (`row ≥ col`).

mod ocp;
mod stages;
mod terminal;

pub use ocp::{Bands, Ocp, OcpError, OcpLayout};
pub use stages::Stages;
pub use terminal::{LinearTerminalCost, TerminalBox, TerminalCost};

use std::ops::Range;

/// The fixed sparsity pattern of a sparse matrix, as coordinate pairs.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Pattern {
    /// Row index of each entry, 0-based.
    pub rows: Vec<usize>,
    /// Column index of each entry, 0-based, in the same order as `rows`.
    pub cols: Vec<usize>,
}

impl Pattern {
    /// Appends the entry `(row, col)`; its value comes next in the value vector.
    pub fn push(&mut self, row: usize, col: usize) {
        self.rows.push(row);
        self.cols.push(col);
    }

    /// The number of entries (of values a matching value vector holds).
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether it has no entries.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }
}

/// The range `hi − lo` of each variable bounded on both sides (with a positive range),
/// else 1: the default [`Nlp::var_scales`].
pub fn ranges_into(lower: &[f64], upper: &[f64], scale: &mut [f64]) {
    for ((s, lo), hi) in scale.iter_mut().zip(lower).zip(upper) {
        let range = hi - lo;
        *s = if range.is_finite() && range > 0.0 {
            range
        } else {
            1.0
        };
    }
}

/// A nonlinear program with exact first and second derivatives.
///
/// Evaluations take `&mut self` so that an implementation may keep its workspaces (and
/// caches of the last point) without allocating per call.
///
/// # Examples
///
/// The point of the line `x + y = 1` closest to `(1, 2)`: minimise `(x − 1)² + (y − 2)²`
/// subject to `x + y = 1`. By hand: `(0, 1)`, with multiplier `λ = 2` (from
/// `∇f + Jᵀλ = 0`, the convention of every back-end).
///
/// ```
/// use ghm::nlp::{Nlp, Pattern};
/// use ghm::solve::{Solver, SolveStatus, Sqp, Start};
///
/// struct Closest {
///     jacobian: Pattern,
///     hessian: Pattern,
/// }
///
/// impl Nlp for Closest {
///     fn n_vars(&self) -> usize { 2 }
///     fn n_cons(&self) -> usize { 1 }
///     fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
///         lower.fill(-10.0);
///         upper.fill(10.0);
///     }
///     fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
///         (lower[0], upper[0]) = (1.0, 1.0); // an equality
///     }
///     fn initial_point(&mut self, x: &mut [f64]) { x.fill(0.0) }
///     fn objective(&mut self, x: &[f64]) -> f64 {
///         (x[0] - 1.0).powi(2) + (x[1] - 2.0).powi(2)
///     }
///     fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
///         g[0] = 2.0 * (x[0] - 1.0);
///         g[1] = 2.0 * (x[1] - 2.0);
///     }
///     fn constraints(&mut self, x: &[f64], g: &mut [f64]) { g[0] = x[0] + x[1] }
///     fn jacobian_pattern(&self) -> &Pattern { &self.jacobian }
///     fn jacobian_values(&mut self, _: &[f64], values: &mut [f64]) { values.fill(1.0) }
///     fn hessian_pattern(&self) -> &Pattern { &self.hessian }
///     fn hessian_values(&mut self, _: &[f64], sigma: f64, _: &[f64], values: &mut [f64]) {
///         values.fill(2.0 * sigma); // the constraint is linear: no λ term
///     }
/// }
///
/// let mut jacobian = Pattern::default();
/// jacobian.push(0, 0);
/// jacobian.push(0, 1);
/// let mut hessian = Pattern::default(); // lower triangle: the diagonal here
/// hessian.push(0, 0);
/// hessian.push(1, 1);
/// let mut problem = Closest { jacobian, hessian };
///
/// let solution = Sqp::default().solve(&mut problem, Start::cold(&[0.0, 0.0]));
/// assert_eq!(solution.status, SolveStatus::Optimal);
/// assert!((solution.x[0] - 0.0).abs() < 1e-6 && (solution.x[1] - 1.0).abs() < 1e-6);
/// assert!((solution.multipliers[0] - 2.0).abs() < 1e-6);
/// assert!((solution.stats.objective - 2.0).abs() < 1e-6);
/// ```
pub trait Nlp {
    /// The number of variables `x`.
    fn n_vars(&self) -> usize;
    /// The number of constraints `g(x)`, equalities included.
    fn n_cons(&self) -> usize;
    /// Variable bounds `x_l, x_u`.
    fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]);
    /// Constraint bounds `g_l, g_u`.
    fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]);
    /// A starting point when the caller has none.
    fn initial_point(&mut self, x: &mut [f64]);

    /// Typical size of each variable, which a solver's regularisation is scaled by, given
    /// the bounds [`Nlp::var_bounds`] wrote: by default the range of a variable bounded on
    /// both sides, else 1. A problem whose bounds are sometimes much tighter than the
    /// variable's natural range (a terminal region) overrides this, so that the tight box
    /// does not inflate the regularisation.
    fn var_scales(&self, lower: &[f64], upper: &[f64], scale: &mut [f64]) {
        ranges_into(lower, upper, scale);
    }

    /// `f(x)`.
    fn objective(&mut self, x: &[f64]) -> f64;
    /// `∇f(x)`, one entry per variable.
    fn gradient(&mut self, x: &[f64], gradient: &mut [f64]);
    /// `g(x)`, one entry per constraint.
    fn constraints(&mut self, x: &[f64], g: &mut [f64]);

    /// Pattern of the constraint Jacobian `∂g/∂x` (`n_cons × n_vars`).
    fn jacobian_pattern(&self) -> &Pattern;
    /// Values of `∂g/∂x` at `x` on [`Nlp::jacobian_pattern`], in its order.
    fn jacobian_values(&mut self, x: &[f64], values: &mut [f64]);

    /// Pattern of the lower triangle of `∇²L` (`n_vars × n_vars`).
    fn hessian_pattern(&self) -> &Pattern;
    /// Values of `∇²(σ f + λᵀ g)` on [`Nlp::hessian_pattern`].
    fn hessian_values(
        &mut self,
        x: &[f64],
        objective_factor: f64,
        multipliers: &[f64],
        values: &mut [f64],
    );

    /// Index ranges of the variables whose Hessian entries form diagonal blocks (stages of
    /// an optimal-control problem): the unit a solver regularises on. Every Hessian entry
    /// lies inside one block. The default is one block of all variables.
    fn hessian_blocks(&self) -> Vec<Range<usize>> {
        std::iter::once(0..self.n_vars()).collect()
    }

    /// The stage structure of an optimal-control problem, for solvers that factorise
    /// stage by stage ([`Stages`]); `None` (the default) for a problem without one.
    fn stages(&self) -> Option<Stages> {
        None
    }

    /// The factor a solver multiplies the objective by (IPOPT's user scaling,
    /// `obj_scaling`); 1 (the default) leaves it as it is. Every back-end of
    /// [`crate::solve`] applies it the same way and answers in the problem's own units:
    /// the same point, multipliers and objective as unscaled.
    fn objective_scaling(&self) -> f64 {
        1.0
    }

    /// Maps `x` onto (or closer to) the feasible set cheaply, if the problem knows how: an
    /// optimal-control problem re-simulates its states from the inputs. Returns whether
    /// `x` was changed. Solvers may try the restored point when a step is rejected.
    fn restore_feasibility(&mut self, _x: &mut [f64]) -> bool {
        false
    }

    /// Everything a second-order method needs at one point, in one call: objective,
    /// constraints, gradient, Jacobian and Hessian values. Implementations that get all of
    /// them from one derivative sweep override this.
    #[allow(clippy::too_many_arguments)]
    fn evaluate_all(
        &mut self,
        x: &[f64],
        objective_factor: f64,
        multipliers: &[f64],
        g: &mut [f64],
        gradient: &mut [f64],
        jacobian: &mut [f64],
        hessian: &mut [f64],
    ) -> f64 {
        let f = self.objective(x);
        self.constraints(x, g);
        self.gradient(x, gradient);
        self.jacobian_values(x, jacobian);
        self.hessian_values(x, objective_factor, multipliers, hessian);
        f
    }
}
