//! The Newton direction of the primal-dual system through the condensed KKT system: the
//! slacks and bound multipliers eliminated (their barrier curvature on the diagonal, `Jᵀ Σ
//! J` over the inequality rows), the condensed right-hand side for a barrier target, and
//! the eliminated parts recovered from the step. One factorisation serves Mehrotra's
//! probing step, the corrected step and the plain one.

// The iterate's parallel vectors are updated index by index; a range loop says that more
// plainly than zipping five iterators.
#![allow(clippy::needless_range_loop)]

use super::super::kkt::all_finite;
use super::iterate::{Direction, Eval, Iterate};
use super::kkt_system::{KktSystem, SHORT_CORRECTED_STEP};
use super::problem::BarrierProblem;
use crate::nlp::Pattern;

/// The right-hand side of one Newton direction and what completes it.
#[derive(Debug, Clone)]
pub(super) struct Rhs {
    /// The condensed gradient (objective, barriers, inequality rows).
    pub condensed: Vec<f64>,
    /// `Σ_t` per inequality row.
    pub sigma_t: Vec<f64>,
    /// The rows' barrier gradients.
    row_terms: Vec<f64>,
    /// The new dynamics multipliers the recursion gives.
    new_lambda: Vec<f64>,
}

impl Rhs {
    /// Zeros for `n` variables and `m` constraint rows.
    fn zeros(n: usize, m: usize) -> Rhs {
        Rhs {
            condensed: vec![0.0; n],
            sigma_t: vec![0.0; m],
            row_terms: vec![0.0; m],
            new_lambda: vec![0.0; m],
        }
    }

    fn clear(&mut self) {
        for v in [
            &mut self.condensed,
            &mut self.sigma_t,
            &mut self.row_terms,
            &mut self.new_lambda,
        ] {
            v.fill(0.0);
        }
    }
}

/// The complementarity targets of one Newton direction: `μ` on every bound, less
/// Mehrotra's second-order term `Δs Δz` of a predictor step where one is given.
#[derive(Clone, Copy)]
struct Targets<'a> {
    mu: f64,
    predictor: Option<&'a Direction>,
}

impl Targets<'_> {
    /// `μ` on every bound.
    fn plain(mu: f64) -> Targets<'static> {
        Targets {
            mu,
            predictor: None,
        }
    }

    /// The targets `(μ_l, μ_u)` of variable `i`'s bounds (`Δs_l = Δw`, `Δs_u = −Δw`).
    fn var(&self, i: usize) -> (f64, f64) {
        match self.predictor {
            None => (self.mu, self.mu),
            Some(p) => (self.mu - p.w[i] * p.zl[i], self.mu + p.w[i] * p.zu[i]),
        }
    }

    /// The targets `(μ_l, μ_u)` of inequality row `r`'s slack bounds.
    fn row(&self, r: usize) -> (f64, f64) {
        match self.predictor {
            None => (self.mu, self.mu),
            Some(p) => (self.mu - p.t[r] * p.vl[r], self.mu + p.t[r] * p.vu[r]),
        }
    }
}

/// What the condensed system of one iteration is built from: the barrier's curvature of
/// the variables and the residuals of the rows.
#[derive(Debug, Clone)]
pub(super) struct Condensation {
    /// `Σ` per variable.
    diagonal: Vec<f64>,
    /// `c − t` on inequality rows (0 on dynamics rows).
    pub residual_i: Vec<f64>,
    /// `c − target` per row.
    dyn_residual: Vec<f64>,
    /// `Σ_t` per row, and the rows' barrier gradients, of the matrices.
    sigma_t: Vec<f64>,
    row_terms: Vec<f64>,
}

impl Condensation {
    /// Zeros for `n` variables and `m` constraint rows.
    pub fn zeros(n: usize, m: usize) -> Condensation {
        Condensation {
            diagonal: vec![0.0; n],
            residual_i: vec![0.0; m],
            dyn_residual: vec![0.0; m],
            sigma_t: vec![0.0; m],
            row_terms: vec![0.0; m],
        }
    }

    /// The condensed matrices at `it` for barrier parameter `mu` into `kkt`: Hessian,
    /// barrier curvature, `Jᵀ Σ J` of the inequality rows.
    pub fn assemble(
        &mut self,
        kkt: &mut KktSystem,
        problem: &BarrierProblem,
        ev: &Eval,
        it: &Iterate,
        mu: f64,
    ) {
        for i in 0..problem.n {
            (self.diagonal[i], _) = problem
                .vars
                .barrier(i, it.w[i], it.zl[i], it.zu[i], (mu, mu));
        }
        for r in 0..problem.m {
            self.residual_i[r] = if problem.is_dynamics[r] {
                0.0
            } else {
                ev.c[r] - it.t[r]
            };
            self.dyn_residual[r] = ev.c[r] - problem.target[r];
        }
        barrier_row_terms(
            problem,
            it,
            Targets::plain(mu),
            &mut self.sigma_t,
            &mut self.row_terms,
        );
        kkt.assemble(
            &ev.hessian,
            &self.diagonal,
            &ev.jacobian,
            &self.sigma_t,
            &problem.shift,
        );
    }
}

/// Everything a Newton direction needs once the matrices are factorised.
pub(super) struct Newton<'a> {
    pub problem: &'a BarrierProblem,
    pub jacobian: &'a Pattern,
    pub ev: &'a Eval,
    pub it: &'a Iterate,
    pub condensation: &'a Condensation,
}

impl Newton<'_> {
    /// The direction for `targets` into `d` (its right-hand side left in `rhs` for the
    /// second-order corrections); false when the recursion fails or the step is not
    /// finite.
    fn solve(
        &self,
        kkt: &mut KktSystem,
        targets: Targets<'_>,
        rhs: &mut Rhs,
        d: &mut Direction,
    ) -> bool {
        let (problem, it, ev) = (self.problem, self.it, self.ev);
        for i in 0..problem.n {
            let (_, g) = problem
                .vars
                .barrier(i, it.w[i], it.zl[i], it.zu[i], targets.var(i));
            rhs.condensed[i] = ev.gradient[i] + g;
        }
        barrier_row_terms(problem, it, targets, &mut rhs.sigma_t, &mut rhs.row_terms);
        let residual_i = &self.condensation.residual_i;
        for ((&r, &c), &v) in self
            .jacobian
            .rows
            .iter()
            .zip(&self.jacobian.cols)
            .zip(&ev.jacobian)
        {
            if !problem.is_dynamics[r] {
                rhs.condensed[c] += v * (rhs.sigma_t[r] * residual_i[r] + rhs.row_terms[r]);
            }
        }
        if !kkt.solve(&rhs.condensed, &self.condensation.dyn_residual) {
            return false;
        }
        rhs.new_lambda.copy_from_slice(&it.lambda);
        kkt.read_solution(&mut d.w, &mut rhs.new_lambda);
        self.complete(targets, rhs, d);
        all_finite(&d.w)
    }

    /// The slack, row-multiplier and bound-multiplier parts of the direction from `d.w`.
    fn complete(&self, targets: Targets<'_>, rhs: &Rhs, d: &mut Direction) {
        let (problem, it, jacobian) = (self.problem, self.it, self.jacobian);
        let residual_i = &self.condensation.residual_i;
        d.t.fill(0.0);
        for ((&r, &c), &v) in jacobian
            .rows
            .iter()
            .zip(&jacobian.cols)
            .zip(&self.ev.jacobian)
        {
            if !problem.is_dynamics[r] {
                d.t[r] += v * d.w[c];
            }
        }
        for r in 0..problem.m {
            if problem.is_dynamics[r] {
                d.t[r] = 0.0;
                d.lambda[r] = rhs.new_lambda[r] - it.lambda[r];
                d.vl[r] = 0.0;
                d.vu[r] = 0.0;
                continue;
            }
            d.t[r] += residual_i[r];
            // λ⁺ = Σ_t Δt − μ/(t − t_l) + μ/(t_u − t).
            d.lambda[r] = rhs.sigma_t[r] * d.t[r] + rhs.row_terms[r] - it.lambda[r];
            (d.vl[r], d.vu[r]) = problem.rows.multiplier_step(
                r,
                it.t[r],
                d.t[r],
                (it.vl[r], it.vu[r]),
                targets.row(r),
            );
        }
        for i in 0..problem.n {
            (d.zl[i], d.zu[i]) = problem.vars.multiplier_step(
                i,
                it.w[i],
                d.w[i],
                (it.zl[i], it.zu[i]),
                targets.var(i),
            );
        }
    }
}

/// Per inequality row: `Σ_t` into `sigma_t`, `−μ/(t − t_l) + μ/(t_u − t)` into
/// `row_terms` (both 0 on dynamics rows).
fn barrier_row_terms(
    problem: &BarrierProblem,
    it: &Iterate,
    targets: Targets<'_>,
    sigma_t: &mut [f64],
    row_terms: &mut [f64],
) {
    for r in 0..problem.m {
        (sigma_t[r], row_terms[r]) = if problem.is_dynamics[r] {
            (0.0, 0.0)
        } else {
            problem
                .rows
                .barrier(r, it.t[r], it.vl[r], it.vu[r], targets.row(r))
        };
    }
}

/// The directions of one iteration and their right-hand sides.
#[derive(Debug, Clone)]
pub(super) struct Directions {
    /// The step's direction.
    pub step: Direction,
    /// Its right-hand side (for the second-order corrections).
    pub rhs: Rhs,
    /// Mehrotra's probing (affine-scaling) direction.
    pub probe: Direction,
    /// The plain direction, the corrector's alternative.
    plain: Direction,
    plain_rhs: Rhs,
}

impl Directions {
    /// Zeros for `n` variables and `m` constraint rows.
    pub fn zeros(n: usize, m: usize) -> Directions {
        Directions {
            step: Direction::zeros(n, m),
            rhs: Rhs::zeros(n, m),
            probe: Direction::zeros(n, m),
            plain: Direction::zeros(n, m),
            plain_rhs: Rhs::zeros(n, m),
        }
    }

    /// Every entry back to zero.
    pub fn clear(&mut self) {
        for d in [&mut self.step, &mut self.probe, &mut self.plain] {
            d.clear();
        }
        self.rhs.clear();
        self.plain_rhs.clear();
    }

    /// The affine-scaling direction (`μ = 0`) into `probe`; false where it fails.
    pub fn solve_probe(&mut self, newton: &Newton<'_>, kkt: &mut KktSystem) -> bool {
        newton.solve(kkt, Targets::plain(0.0), &mut self.rhs, &mut self.probe)
    }

    /// The step's direction for `mu`: in free mode Mehrotra's corrector (the predictor's
    /// `Δs Δz` taken off the targets), kept where it descends the barrier objective and
    /// reaches farther to the boundary than the plain step (far from the central path it
    /// can point anywhere); else the plain step. False where a solve fails.
    pub fn solve_step(
        &mut self,
        newton: &Newton<'_>,
        kkt: &mut KktSystem,
        mu: f64,
        free: bool,
    ) -> bool {
        let targets = Targets {
            mu,
            predictor: free.then_some(&self.probe),
        };
        let mut ok = newton.solve(kkt, targets, &mut self.rhs, &mut self.step);
        if ok && free {
            let (problem, it) = (newton.problem, newton.it);
            let corrected = it.reach(problem, &self.step);
            ok = newton.solve(
                kkt,
                Targets::plain(mu),
                &mut self.plain_rhs,
                &mut self.plain,
            );
            let descends = it.barrier_slope(problem, &newton.ev.gradient, &self.step, mu) < 0.0;
            if ok && (!descends || it.reach(problem, &self.plain) >= corrected) {
                self.take_plain();
            }
        }
        ok
    }

    /// The primal step to the boundary (fraction `tau`) along the step's direction. A
    /// stage-wise correction (`corrected`) lifts each stage just above positive
    /// definiteness; where the gains of the recursion then amplify a nearly flat direction
    /// into a step the boundary cuts below [`SHORT_CORRECTED_STEP`], the whole-horizon `δ`
    /// (IPOPT's correction) gives this iteration's direction instead.
    pub fn primal_reach(
        &mut self,
        newton: &Newton<'_>,
        kkt: &mut KktSystem,
        corrected: bool,
        mu: f64,
        tau: f64,
    ) -> f64 {
        let (problem, it) = (newton.problem, newton.it);
        let mut alpha_max = it.primal_reach(problem, &self.step.w, &self.step.t, tau);
        if corrected && alpha_max < SHORT_CORRECTED_STEP {
            let uniform = kkt.factor_whole_horizon().is_some()
                && newton.solve(
                    kkt,
                    Targets::plain(mu),
                    &mut self.plain_rhs,
                    &mut self.plain,
                );
            if uniform {
                self.take_plain();
                alpha_max = it.primal_reach(problem, &self.step.w, &self.step.t, tau);
            }
        }
        alpha_max
    }

    /// The plain direction becomes the step's.
    fn take_plain(&mut self) {
        std::mem::swap(&mut self.step, &mut self.plain);
        std::mem::swap(&mut self.rhs, &mut self.plain_rhs);
    }
}
