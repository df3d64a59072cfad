//! The objective as a solver sees it: multiplied by the problem's own scale
//! ([`Nlp::objective_scaling`], a model's `solver objective_scale`), and the answer put back
//! into the problem's units, the same way for every back-end.
//!
//! Multiplying `f` by `σ` changes no optimum: the point is the same and every multiplier is
//! `σ` times the unscaled one. So a start's multipliers go in times `σ`, and the solution's
//! multipliers, objective and dual residuals come out divided by `σ`; the primal point and
//! the constraints' violation are the same in both.

use super::{Solution, Start};
use crate::nlp::{Nlp, Pattern, Stages};
use std::ops::Range;

/// Solves `nlp` from `start` with `solve`, which is handed the problem with its objective
/// times `σ = nlp.objective_scaling()`, the start in that scale, and `σ` (for what else
/// of the solver's own follows the objective, such as a warm start's barrier). Where `σ` is
/// 1 `solve` gets `nlp` itself.
pub(super) fn solve_scaled(
    nlp: &mut dyn Nlp,
    start: Start<'_>,
    solve: impl FnOnce(&mut dyn Nlp, Start<'_>, f64) -> Solution,
) -> Solution {
    let scale = nlp.objective_scaling();
    if scale == 1.0 || !(scale > 0.0 && scale.is_finite()) {
        return solve(nlp, start, 1.0);
    }
    let times_scale = |values: &[f64]| values.iter().map(|v| v * scale).collect::<Vec<_>>();
    let multipliers = start.multipliers.map(times_scale);
    let bound_multipliers = start.bound_multipliers.map(times_scale);
    let scaled_start = Start {
        multipliers: multipliers.as_deref(),
        bound_multipliers: bound_multipliers.as_deref(),
        ..start
    };
    let mut scaled = ScaledObjective { inner: nlp, scale };
    let mut solution = solve(&mut scaled, scaled_start, scale);
    unscale(&mut solution, scale);
    solution
}

/// `solution` of the problem with its objective times `scale`, in the problem's own units.
fn unscale(solution: &mut Solution, scale: f64) {
    for value in solution
        .multipliers
        .iter_mut()
        .chain(solution.bound_multipliers.iter_mut())
    {
        *value /= scale;
    }
    let stats = &mut solution.stats;
    stats.objective /= scale;
    stats.kkt.stationarity /= scale;
    stats.kkt.scaled_stationarity /= scale;
    stats.kkt.complementarity /= scale;
}

/// `inner` with its objective multiplied by `scale`; everything else passed through.
struct ScaledObjective<'a> {
    inner: &'a mut dyn Nlp,
    scale: f64,
}

impl Nlp for ScaledObjective<'_> {
    fn n_vars(&self) -> usize {
        self.inner.n_vars()
    }

    fn n_cons(&self) -> usize {
        self.inner.n_cons()
    }

    fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        self.inner.var_bounds(lower, upper)
    }

    fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        self.inner.con_bounds(lower, upper)
    }

    fn initial_point(&mut self, x: &mut [f64]) {
        self.inner.initial_point(x)
    }

    fn var_scales(&self, lower: &[f64], upper: &[f64], scale: &mut [f64]) {
        self.inner.var_scales(lower, upper, scale)
    }

    fn objective(&mut self, x: &[f64]) -> f64 {
        self.scale * self.inner.objective(x)
    }

    fn gradient(&mut self, x: &[f64], gradient: &mut [f64]) {
        self.inner.gradient(x, gradient);
        gradient.iter_mut().for_each(|g| *g *= self.scale);
    }

    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        self.inner.constraints(x, g)
    }

    fn jacobian_pattern(&self) -> &Pattern {
        self.inner.jacobian_pattern()
    }

    fn jacobian_values(&mut self, x: &[f64], values: &mut [f64]) {
        self.inner.jacobian_values(x, values)
    }

    fn hessian_pattern(&self) -> &Pattern {
        self.inner.hessian_pattern()
    }

    fn hessian_values(
        &mut self,
        x: &[f64],
        objective_factor: f64,
        multipliers: &[f64],
        values: &mut [f64],
    ) {
        self.inner
            .hessian_values(x, objective_factor * self.scale, multipliers, values)
    }

    fn hessian_blocks(&self) -> Vec<Range<usize>> {
        self.inner.hessian_blocks()
    }

    fn stages(&self) -> Option<Stages> {
        self.inner.stages()
    }

    /// 1: the scale is applied here already.
    fn objective_scaling(&self) -> f64 {
        1.0
    }

    fn restore_feasibility(&mut self, x: &mut [f64]) -> bool {
        self.inner.restore_feasibility(x)
    }

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
        let f = self.inner.evaluate_all(
            x,
            objective_factor * self.scale,
            multipliers,
            g,
            gradient,
            jacobian,
            hessian,
        );
        gradient.iter_mut().for_each(|g| *g *= self.scale);
        self.scale * f
    }
}
