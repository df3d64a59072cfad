//! The primal-dual iterate of the interior point and what is measured at it: the problem's
//! values there ([`Eval`]), a Newton direction ([`Direction`]) and a trial point along it
//! ([`Trial`]); IPOPT's optimality error, the fraction to the boundary, the barrier
//! objective's slope, and the step itself.

// The iterate's parallel vectors (values, bounds, multipliers, directions) are updated
// index by index; a range loop says that more plainly than zipping five iterators.
#![allow(clippy::needless_range_loop)]

use super::super::kkt::all_finite;
use super::super::Start;
use super::options::IpmOptions;
use super::problem::BarrierProblem;
use super::sides::{max_dual_step, max_step, pushed, Totals};
use crate::nlp::{Nlp, Pattern};

/// The primal-dual iterate.
#[derive(Debug, Clone)]
pub(super) struct Iterate {
    pub w: Vec<f64>,
    /// Slacks of the inequality rows (unused on dynamics rows).
    pub t: Vec<f64>,
    pub lambda: Vec<f64>,
    pub zl: Vec<f64>,
    pub zu: Vec<f64>,
    pub vl: Vec<f64>,
    pub vu: Vec<f64>,
}

/// A Newton direction of every part of the iterate.
#[derive(Debug, Clone)]
pub(super) struct Direction {
    pub w: Vec<f64>,
    pub t: Vec<f64>,
    pub lambda: Vec<f64>,
    pub zl: Vec<f64>,
    pub zu: Vec<f64>,
    pub vl: Vec<f64>,
    pub vu: Vec<f64>,
}

impl Direction {
    /// Zeros for `n` variables and `m` rows.
    pub fn zeros(n: usize, m: usize) -> Direction {
        Direction {
            w: vec![0.0; n],
            t: vec![0.0; m],
            lambda: vec![0.0; m],
            zl: vec![0.0; n],
            zu: vec![0.0; n],
            vl: vec![0.0; m],
            vu: vec![0.0; m],
        }
    }

    /// Every entry back to zero.
    pub fn clear(&mut self) {
        for v in [
            &mut self.w,
            &mut self.t,
            &mut self.lambda,
            &mut self.zl,
            &mut self.zu,
            &mut self.vl,
            &mut self.vu,
        ] {
            v.fill(0.0);
        }
    }
}

/// The problem's values at the current point.
#[derive(Debug, Clone)]
pub(super) struct Eval {
    pub f: f64,
    pub c: Vec<f64>,
    pub gradient: Vec<f64>,
    pub jacobian: Vec<f64>,
    pub hessian: Vec<f64>,
}

impl Eval {
    /// Zeros for `n` variables, `m` rows and the patterns' lengths.
    pub fn zeros(n: usize, m: usize, jacobian: usize, hessian: usize) -> Eval {
        Eval {
            f: 0.0,
            c: vec![0.0; m],
            gradient: vec![0.0; n],
            jacobian: vec![0.0; jacobian],
            hessian: vec![0.0; hessian],
        }
    }

    /// Every value back to zero.
    pub fn clear(&mut self) {
        self.f = 0.0;
        for v in [
            &mut self.c,
            &mut self.gradient,
            &mut self.jacobian,
            &mut self.hessian,
        ] {
            v.fill(0.0);
        }
    }

    /// Evaluates everything at `it` (the Hessian of the Lagrangian with its multipliers);
    /// returns whether every value is finite.
    pub fn evaluate(&mut self, nlp: &mut dyn Nlp, it: &Iterate) -> bool {
        self.f = nlp.evaluate_all(
            &it.w,
            1.0,
            &it.lambda,
            &mut self.c,
            &mut self.gradient,
            &mut self.jacobian,
            &mut self.hessian,
        );
        self.f.is_finite()
            && all_finite(&self.c)
            && all_finite(&self.gradient)
            && all_finite(&self.jacobian)
            && all_finite(&self.hessian)
    }
}

/// A trial point of the line search: variables, slacks and the rows' values there.
#[derive(Debug, Clone)]
pub(super) struct Trial {
    pub w: Vec<f64>,
    pub t: Vec<f64>,
    pub c: Vec<f64>,
}

impl Trial {
    /// Zeros for `n` variables and `m` rows.
    pub fn zeros(n: usize, m: usize) -> Trial {
        Trial {
            w: vec![0.0; n],
            t: vec![0.0; m],
            c: vec![0.0; m],
        }
    }

    /// Every entry back to zero.
    pub fn clear(&mut self) {
        self.w.fill(0.0);
        self.t.fill(0.0);
        self.c.fill(0.0);
    }

    /// The primal point `alpha` along `d` from `it` (the rows' values are left alone).
    pub fn along(&mut self, it: &Iterate, d: &Direction, alpha: f64) {
        for i in 0..self.w.len() {
            self.w[i] = it.w[i] + alpha * d.w[i];
        }
        for r in 0..self.t.len() {
            self.t[r] = it.t[r] + alpha * d.t[r];
        }
    }
}

/// How a solve starts, from what its [`Start`] carries: the barrier parameter and how far
/// inside its bounds the point is pushed.
#[derive(Debug, Clone, Copy)]
pub(super) struct StartKind {
    /// All multipliers given: a warm start, IPOPT's monotone rule from a tiny `μ`.
    pub warm: bool,
    /// A shifted plan with its constraint multipliers: close enough to start the
    /// one-sided bounds near them ([`IpmOptions::shifted_slack_push`]).
    close: bool,
    /// The starting barrier parameter.
    pub mu: f64,
    /// The bound push of the start.
    pub kappa: f64,
    /// The push of a one-sided bound of a close start.
    slack_push: f64,
}

impl StartKind {
    /// The kind of `start` under `options`, for a problem whose objective is scaled by
    /// `objective_scale`: a warm start's barrier follows the scale, as the complementarity
    /// of the multipliers it carries does.
    pub fn of(start: &Start<'_>, options: &IpmOptions, objective_scale: f64) -> StartKind {
        let warm = start.multipliers.is_some() && start.bound_multipliers.is_some();
        StartKind {
            warm,
            close: start.shifted && start.multipliers.is_some() && !warm,
            mu: if warm {
                start.barrier.unwrap_or(options.warm_start_mu) * objective_scale
            } else {
                options.initial_mu
            },
            kappa: if warm {
                options.warm_push
            } else if let Some(push) = start.push {
                push
            } else if start.shifted {
                options.shifted_push
            } else {
                options.bound_push
            },
            slack_push: options.shifted_slack_push,
        }
    }
}

/// `destination` from `source` where given (as far as both reach), zero elsewhere.
fn copy_or_zero(destination: &mut [f64], source: Option<&[f64]>) {
    destination.fill(0.0);
    if let Some(source) = source {
        let k = source.len().min(destination.len());
        destination[..k].copy_from_slice(&source[..k]);
    }
}

impl Iterate {
    /// Copies `other` into this iterate's buffers (of the same sizes), allocating nothing
    /// (a derived `clone_from` would allocate anew).
    pub fn copy_from(&mut self, other: &Iterate) {
        self.w.copy_from_slice(&other.w);
        self.t.copy_from_slice(&other.t);
        self.lambda.copy_from_slice(&other.lambda);
        self.zl.copy_from_slice(&other.zl);
        self.zu.copy_from_slice(&other.zu);
        self.vl.copy_from_slice(&other.vl);
        self.vu.copy_from_slice(&other.vu);
    }

    /// Zeros for `n` variables and `m` rows.
    pub fn zeros(n: usize, m: usize) -> Iterate {
        let Direction {
            w,
            t,
            lambda,
            zl,
            zu,
            vl,
            vu,
        } = Direction::zeros(n, m);
        Iterate {
            w,
            t,
            lambda,
            zl,
            zu,
            vl,
            vu,
        }
    }

    /// The starting iterate from `start`: the point pushed inside its bounds, the bound
    /// multipliers centred (from `start`'s where given, read into `nu`), the slacks from
    /// the rows' values (evaluated into `c`). False where the objective or a row is not
    /// finite at the pushed point.
    pub fn start(
        &mut self,
        nlp: &mut dyn Nlp,
        problem: &BarrierProblem,
        start: &Start<'_>,
        kind: StartKind,
        nu: &mut [f64],
        c: &mut [f64],
    ) -> bool {
        copy_or_zero(&mut self.w, Some(start.x));
        copy_or_zero(&mut self.lambda, start.multipliers);
        copy_or_zero(nu, start.bound_multipliers);
        for v in [&mut self.t, &mut self.vl, &mut self.vu] {
            v.fill(0.0);
        }
        let vars = &problem.vars;
        for i in 0..problem.n {
            let (lo, hi) = (vars.lower[i], vars.upper[i]);
            let k = if kind.warm {
                kind.kappa * problem.bounds.scale[i].clamp(1e-3, 1.0)
            } else if kind.close && !(lo.is_finite() && hi.is_finite()) {
                kind.slack_push
            } else {
                kind.kappa
            };
            self.w[i] = pushed(self.w[i], lo, hi, k);
            (self.zl[i], self.zu[i]) = vars.centred(i, self.w[i], nu[i], kind.mu);
        }
        c.fill(0.0);
        let f0 = nlp.objective(&self.w);
        nlp.constraints(&self.w, c);
        if !(f0.is_finite() && all_finite(c)) {
            return false;
        }
        for r in 0..problem.m {
            if problem.is_dynamics[r] {
                continue;
            }
            let (lo, hi) = (problem.rows.lower[r], problem.rows.upper[r]);
            self.t[r] = pushed(c[r], lo, hi, kind.kappa);
            (self.vl[r], self.vu[r]) = problem.rows.centred(r, self.t[r], self.lambda[r], kind.mu);
        }
        true
    }

    /// IPOPT's optimality error `E_μ`: stationarity scaled by `s_d`, the constraint
    /// violation, complementarity against `μ` scaled by `s_c` (`scratch`: one entry per
    /// variable). The dual parts, in the units of an objective scaled by `objective_scale`,
    /// are divided by it: the error in the problem's own units.
    pub fn optimality_error(
        &self,
        problem: &BarrierProblem,
        jacobian: &Pattern,
        ev: &Eval,
        (mu, objective_scale): (f64, f64),
        scratch: &mut [f64],
    ) -> f64 {
        let (n, m) = (problem.n, problem.m);
        scratch.copy_from_slice(&ev.gradient);
        for ((&r, &c), &v) in jacobian.rows.iter().zip(&jacobian.cols).zip(&ev.jacobian) {
            scratch[c] += v * self.lambda[r];
        }
        let mut stationarity = 0.0_f64;
        let mut primal = 0.0_f64;
        let mut bounds = Totals::default();
        for (i, s) in scratch.iter().enumerate().take(n) {
            stationarity = stationarity.max((s - self.zl[i] + self.zu[i]).abs());
            problem
                .vars
                .complementarity(i, self.w[i], self.zl[i], self.zu[i], mu, &mut bounds);
        }
        let multiplier_sum: f64 = self.lambda.iter().map(|l| l.abs()).sum();
        for r in 0..m {
            if problem.is_dynamics[r] {
                primal = primal.max((ev.c[r] - problem.target[r]).abs());
                continue;
            }
            primal = primal.max((ev.c[r] - self.t[r]).abs());
            stationarity = stationarity.max((-self.lambda[r] - self.vl[r] + self.vu[r]).abs());
            problem
                .rows
                .complementarity(r, self.t[r], self.vl[r], self.vu[r], mu, &mut bounds);
        }
        const S_MAX: f64 = 100.0;
        let s_d =
            ((multiplier_sum + bounds.sum) / ((m + bounds.count).max(1) as f64)).max(S_MAX) / S_MAX;
        let s_c = (bounds.sum / (bounds.count.max(1) as f64)).max(S_MAX) / S_MAX;
        (stationarity / s_d / objective_scale)
            .max(primal)
            .max(bounds.largest / s_c / objective_scale)
    }

    /// The largest primal step along `dw` (variables) and `dt` (inequality slacks), by
    /// [`max_step`] with fraction to the boundary `tau`.
    pub fn primal_reach(&self, problem: &BarrierProblem, dw: &[f64], dt: &[f64], tau: f64) -> f64 {
        max_step(&self.w, dw, &problem.vars, tau, |_| true).min(max_step(
            &self.t,
            dt,
            &problem.rows,
            tau,
            |r| !problem.is_dynamics[r],
        ))
    }

    /// The largest step of every bound multiplier along `d` with fraction `tau`.
    pub fn dual_reach(&self, d: &Direction, tau: f64) -> f64 {
        max_dual_step(&self.zl, &d.zl, tau)
            .min(max_dual_step(&self.zu, &d.zu, tau))
            .min(max_dual_step(&self.vl, &d.vl, tau))
            .min(max_dual_step(&self.vu, &d.vu, tau))
    }

    /// The shorter of the primal and dual steps along `d` to the boundary (fraction 0.99).
    pub fn reach(&self, problem: &BarrierProblem, d: &Direction) -> f64 {
        self.primal_reach(problem, &d.w, &d.t, 0.99)
            .min(self.dual_reach(d, 0.99))
    }

    /// `∇φᵀ d`, the barrier objective's directional derivative.
    pub fn barrier_slope(
        &self,
        problem: &BarrierProblem,
        gradient: &[f64],
        d: &Direction,
        mu: f64,
    ) -> f64 {
        let mut slope = 0.0;
        for i in 0..problem.n {
            let (_, g) = problem.vars.barrier(i, self.w[i], 0.0, 0.0, (mu, mu));
            slope += (gradient[i] + g) * d.w[i];
        }
        for r in 0..problem.m {
            if !problem.is_dynamics[r] {
                let (_, g) = problem.rows.barrier(r, self.t[r], 0.0, 0.0, (mu, mu));
                slope += g * d.t[r];
            }
        }
        slope
    }

    /// Takes the step to the accepted `trial` point (which may be a corrected one): the
    /// constraint multipliers `min(α, 1)` along `d`, the bound multipliers `alpha_dual`;
    /// then bounds within rounding of the new point are moved out and the bound
    /// multipliers safeguarded ([`super::sides::Sides::safeguard`]).
    pub fn take_step(
        &mut self,
        problem: &mut BarrierProblem,
        trial: &Trial,
        d: &Direction,
        alpha: f64,
        alpha_dual: f64,
        mu: f64,
    ) {
        let (n, m) = (problem.n, problem.m);
        self.w.copy_from_slice(&trial.w);
        for r in 0..m {
            if !problem.is_dynamics[r] {
                self.t[r] = trial.t[r];
            }
        }
        let a = alpha.min(1.0);
        for r in 0..m {
            self.lambda[r] += a * d.lambda[r];
        }
        for i in 0..n {
            self.zl[i] += alpha_dual * d.zl[i];
            self.zu[i] += alpha_dual * d.zu[i];
        }
        for r in 0..m {
            self.vl[r] += alpha_dual * d.vl[r];
            self.vu[r] += alpha_dual * d.vu[r];
        }
        let BarrierProblem {
            vars,
            rows,
            is_dynamics,
            ..
        } = problem;
        vars.move_bounds(&self.w, |_| true);
        rows.move_bounds(&self.t, |r| !is_dynamics[r]);
        for i in 0..n {
            vars.safeguard(i, self.w[i], &mut self.zl[i], &mut self.zu[i], mu);
        }
        for r in (0..m).filter(|&r| !is_dynamics[r]) {
            rows.safeguard(r, self.t[r], &mut self.vl[r], &mut self.vu[r], mu);
        }
    }
}
