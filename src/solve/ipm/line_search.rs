//! The filter line search of the interior point (IPOPT's, Wächter & Biegler 2006): trial
//! points along the Newton direction, halved until the filter ([`Filter`]) accepts one;
//! up to four second-order corrections of a rejected full step against the Maratos
//! effect; and the problem's own feasibility restoration ([`Nlp::restore_feasibility`])
//! when no step is found, or after a run of blocked steps ([`BlockedSteps`]).

// The iterate's parallel vectors are updated index by index; a range loop says that more
// plainly than zipping five iterators.
#![allow(clippy::needless_range_loop)]

use super::super::kkt::all_finite;
use super::filter::{Accepted, Filter};
use super::iterate::{Direction, Eval, Iterate, Trial};
use super::kkt_system::{KktSystem, SHORT_CORRECTED_STEP};
use super::newton::{Condensation, Rhs};
use super::problem::BarrierProblem;
use super::sides::pushed;
use crate::nlp::{Nlp, Pattern};

/// Accepted steps in a row, each cut below [`SHORT_CORRECTED_STEP`] by the boundary and
/// each raising the constraint violation, after which the problem's feasibility
/// restoration takes over ([`BlockedSteps`]).
const BLOCKED_STEPS_BEFORE_RESTORATION: usize = 5;

/// Watches for the line search's one blind spot: a run of short steps the filter accepts
/// on the barrier objective while the violation creeps up. Seen on the paper study's
/// longest step (RL-MPC-VFO at 6 h, a perturbed season, step 1372): the linearised
/// constraints asked a rate-limited input to move several times its range, its two rate
/// rows cut every step far short, and over a hundred such steps raised the violation on
/// negligible objective gains; the second-order correction never ran, because no trial was
/// rejected. Re-simulating the states after five of them ended that solve in a fraction of
/// its iterations. Once a solve: where the blocked run comes back after the restoration,
/// restoring again only starts the run over (a step of the same study at 5 h cycled
/// through restoration after restoration and took several times its iterations without
/// the rule); left to the filter it ends soon after. Over the study's MPC-type seasons the
/// rewards moved only in the last digits (measured: `docs/benchmarks-history.md`,
/// "Session 15: the paper study's longest step" and "Session 16: the blocked-step
/// restoration").
#[derive(Debug, Clone, Default)]
struct BlockedSteps {
    run: usize,
    restored: bool,
}

impl BlockedSteps {
    /// Records one accepted step, `blocked` if it was cut short and raised the violation;
    /// true when the run is long enough to restore, once a solve.
    fn restoration_due(&mut self, blocked: bool) -> bool {
        self.run = if blocked { self.run + 1 } else { 0 };
        let due = self.run >= BLOCKED_STEPS_BEFORE_RESTORATION && !self.restored;
        if due {
            self.run = 0;
            self.restored = true;
        }
        due
    }
}

/// Where a line search starts: the current point, its direction and the measures of the
/// filter there.
pub(super) struct SearchFrom<'a> {
    pub problem: &'a BarrierProblem,
    pub jacobian: &'a Pattern,
    pub ev: &'a Eval,
    pub it: &'a Iterate,
    pub direction: &'a Direction,
    /// The direction's right-hand side, for the second-order corrections.
    pub rhs: &'a Rhs,
    pub condensation: &'a Condensation,
    pub mu: f64,
    /// `θ`, `φ` and `∇φᵀ d` at the current point.
    pub theta: f64,
    pub phi: f64,
    pub slope: f64,
    /// The step to the boundary.
    pub alpha_max: f64,
    /// Print the first trial to standard error.
    pub trace: bool,
}

/// Buffers of the second-order corrections.
#[derive(Debug, Clone)]
struct CorrectionBuffers {
    /// The rows' values at the trial point.
    c: Vec<f64>,
    /// The corrected dynamics and inequality-row residuals.
    dynamics: Vec<f64>,
    rows: Vec<f64>,
    gradient: Vec<f64>,
    step: Vec<f64>,
    step_t: Vec<f64>,
    /// The recursion's dynamics multipliers (not used).
    multipliers: Vec<f64>,
}

/// The line search of one problem pattern: its filter, the run of blocked steps, and its
/// buffers.
#[derive(Debug, Clone)]
pub(super) struct LineSearch {
    filter: Filter,
    /// The filter is reset at the next iteration: a new barrier problem, or a restored
    /// point.
    fresh: bool,
    blocked: BlockedSteps,
    /// The trial point; after an accepted search, the point to step to.
    pub trial: Trial,
    correction: CorrectionBuffers,
    /// The restored point's variables and slacks.
    restored_w: Vec<f64>,
    restored_t: Vec<f64>,
}

impl LineSearch {
    /// A line search for `n` variables and `m` rows.
    pub fn new(n: usize, m: usize) -> LineSearch {
        LineSearch {
            filter: Filter::default(),
            fresh: true,
            blocked: BlockedSteps::default(),
            trial: Trial::zeros(n, m),
            correction: CorrectionBuffers {
                c: vec![0.0; m],
                dynamics: vec![0.0; m],
                rows: vec![0.0; m],
                gradient: vec![0.0; n],
                step: vec![0.0; n],
                step_t: vec![0.0; m],
                multipliers: vec![0.0; m],
            },
            restored_w: vec![0.0; n],
            restored_t: vec![0.0; m],
        }
    }

    /// Starts a solve of at most `max_iterations` iterations: a fresh filter (with room
    /// for every point the solve can add), no blocked steps, the trial point zero.
    pub fn start_solve(&mut self, max_iterations: usize) {
        self.filter.reserve(2 * (max_iterations + 1));
        self.fresh = true;
        self.blocked = BlockedSteps::default();
        self.trial.clear();
    }

    /// The barrier parameter changed: the filter starts afresh at the next iteration.
    pub fn new_barrier_problem(&mut self) {
        self.fresh = true;
    }

    /// Resets the filter at violation `theta` where a new barrier problem began.
    pub fn start_iteration(&mut self, theta: f64) {
        if self.fresh {
            self.filter.reset(theta);
            self.fresh = false;
        }
    }

    /// The backtracking search from `from`: the accepted step length and how it was
    /// accepted (the point in [`LineSearch::trial`], a corrected one after a second-order
    /// correction), or `None` when no step down to the filter's smallest is acceptable.
    pub fn search(
        &mut self,
        nlp: &mut dyn Nlp,
        kkt: &mut KktSystem,
        from: &SearchFrom<'_>,
    ) -> Option<(Accepted, f64)> {
        let (problem, it, d) = (from.problem, from.it, from.direction);
        let (theta, phi, slope) = (from.theta, from.phi, from.slope);
        let tiny =
            d.w.iter()
                .zip(&it.w)
                .all(|(dw, w)| dw.abs() <= 1e-14 * (1.0 + w.abs()));
        // The filter's smallest step, and never below rounding (near feasibility the
        // filter's is zero).
        let alpha_min = self
            .filter
            .min_step(theta, slope)
            .max(1e-16 * from.alpha_max);
        let mut alpha = from.alpha_max;
        let mut first = true;
        while (alpha > 0.0 && alpha >= alpha_min) || tiny {
            let trial = &mut self.trial;
            trial.along(it, d, alpha);
            let f = nlp.objective(&trial.w);
            nlp.constraints(&trial.w, &mut trial.c);
            let trial_theta = problem.violation(&trial.c, &trial.t);
            let trial_phi = problem.barrier(f, &trial.w, &trial.t, from.mu);
            if tiny {
                return Some((Accepted::Either, alpha));
            }
            if from.trace && first {
                eprintln!(
                    "    trial α {alpha:.2e}: θ {theta:.3e} → {trial_theta:.3e}, φ {phi:.12e} → {trial_phi:.12e}, slope {slope:.2e}"
                );
            }
            if let Some(a) =
                self.filter
                    .accepts((theta, phi), slope, alpha, (trial_theta, trial_phi))
            {
                return Some((a, alpha));
            }
            if first && trial_theta >= theta {
                // Second-order corrections against the Maratos effect.
                if let Some(a) = self.second_order_correction(nlp, kkt, from, alpha) {
                    return Some((a, alpha));
                }
            }
            first = false;
            alpha *= 0.5;
        }
        None
    }

    /// Up to four second-order corrections of a rejected full step: the dynamics and row
    /// residuals re-linearised at the trial point. On acceptance the trial point is the
    /// corrected one.
    fn second_order_correction(
        &mut self,
        nlp: &mut dyn Nlp,
        kkt: &mut KktSystem,
        from: &SearchFrom<'_>,
        alpha: f64,
    ) -> Option<Accepted> {
        let (problem, it, ev, rhs) = (from.problem, from.it, from.ev, from.rhs);
        let (jacobian, residual_i) = (from.jacobian, &from.condensation.residual_i);
        let (n, m) = (problem.n, problem.m);
        let (trial, soc) = (&mut self.trial, &mut self.correction);
        soc.c.fill(0.0);
        nlp.constraints(&trial.w, &mut soc.c);
        for r in 0..m {
            soc.dynamics[r] =
                alpha * (ev.c[r] - problem.target[r]) + (soc.c[r] - problem.target[r]);
            soc.rows[r] = if problem.is_dynamics[r] {
                0.0
            } else {
                alpha * residual_i[r] + (soc.c[r] - trial.t[r])
            };
        }
        let mut theta_old = problem.violation(&soc.c, &trial.t);
        soc.step.fill(0.0);
        soc.multipliers.copy_from_slice(&it.lambda);
        soc.step_t.fill(0.0);
        for _ in 0..4 {
            // The condensed gradient with the corrected row residuals.
            soc.gradient.copy_from_slice(&rhs.condensed);
            for ((&r, &col), &v) in jacobian.rows.iter().zip(&jacobian.cols).zip(&ev.jacobian) {
                if !problem.is_dynamics[r] {
                    soc.gradient[col] += v * rhs.sigma_t[r] * (soc.rows[r] - residual_i[r]);
                }
            }
            if !kkt.solve(&soc.gradient, &soc.dynamics) {
                return None;
            }
            kkt.read_solution(&mut soc.step, &mut soc.multipliers);
            soc.step_t.fill(0.0);
            for ((&r, &col), &v) in jacobian.rows.iter().zip(&jacobian.cols).zip(&ev.jacobian) {
                if !problem.is_dynamics[r] {
                    soc.step_t[r] += v * soc.step[col];
                }
            }
            for r in 0..m {
                if !problem.is_dynamics[r] {
                    soc.step_t[r] += soc.rows[r];
                }
            }
            let tau = (1.0 - from.mu).max(0.99);
            let alpha_soc = it.primal_reach(problem, &soc.step, &soc.step_t, tau);
            for i in 0..n {
                trial.w[i] = it.w[i] + alpha_soc * soc.step[i];
            }
            for r in 0..m {
                trial.t[r] = it.t[r] + alpha_soc * soc.step_t[r];
            }
            let f = nlp.objective(&trial.w);
            nlp.constraints(&trial.w, &mut soc.c);
            let trial_theta = problem.violation(&soc.c, &trial.t);
            let trial_phi = problem.barrier(f, &trial.w, &trial.t, from.mu);
            let current = (from.theta, from.phi);
            if let Some(a) =
                self.filter
                    .accepts(current, from.slope, alpha, (trial_theta, trial_phi))
            {
                return Some(a);
            }
            if trial_theta > 0.99 * theta_old {
                break;
            }
            theta_old = trial_theta;
            for r in 0..m {
                soc.dynamics[r] = alpha_soc * soc.dynamics[r] + (soc.c[r] - problem.target[r]);
                if !problem.is_dynamics[r] {
                    soc.rows[r] = alpha_soc * soc.rows[r] + (soc.c[r] - trial.t[r]);
                }
            }
        }
        None
    }

    /// An accepted step of kind `kind` from `(θ, φ)`: the current point joins the filter
    /// unless the Armijo rule accepted it.
    pub fn accepted(&mut self, kind: Accepted, theta: f64, phi: f64) {
        if kind == Accepted::Either {
            self.filter.add(theta, phi);
        }
    }

    /// Records the accepted step of length `alpha` from violation `theta` as blocked if it
    /// was short and raised the violation (measured again: the trial may be a corrected
    /// one); true when a run of them calls for the restoration, once a solve.
    pub fn restoration_due(
        &mut self,
        nlp: &mut dyn Nlp,
        problem: &BarrierProblem,
        alpha: f64,
        theta: f64,
    ) -> bool {
        let trial = &mut self.trial;
        let raised = alpha < SHORT_CORRECTED_STEP && {
            nlp.constraints(&trial.w, &mut trial.c);
            problem.violation(&trial.c, &trial.t) > theta
        };
        self.blocked.restoration_due(raised)
    }

    /// The problem's own feasibility restoration from `it`: re-simulated states, the point
    /// pushed inside its bounds (by `kappa`, at most 1e-6) and the slacks set from the
    /// rows. Where it lowers the violation to 0.9 of what it was, `it` moves there and the
    /// filter starts afresh (the point `(θ, φ)` left added); returns whether it did.
    pub fn restore(
        &mut self,
        nlp: &mut dyn Nlp,
        problem: &BarrierProblem,
        it: &mut Iterate,
        kappa: f64,
        (theta, phi): (f64, f64),
    ) -> bool {
        let c = &mut self.trial.c;
        nlp.constraints(&it.w, c);
        let before = problem.violation(c, &it.t);
        let w = &mut self.restored_w;
        w.copy_from_slice(&it.w);
        if !nlp.restore_feasibility(w) {
            return false;
        }
        for (i, v) in w.iter_mut().enumerate() {
            *v = pushed(
                *v,
                problem.vars.lower[i],
                problem.vars.upper[i],
                kappa.min(1e-6),
            );
        }
        let f = nlp.objective(w);
        nlp.constraints(w, c);
        if !(f.is_finite() && all_finite(c)) {
            return false;
        }
        let t = &mut self.restored_t;
        t.copy_from_slice(&it.t);
        for r in 0..problem.m {
            if !problem.is_dynamics[r] {
                t[r] = pushed(
                    c[r],
                    problem.rows.lower[r],
                    problem.rows.upper[r],
                    kappa.min(1e-6),
                );
            }
        }
        let after = problem.violation(c, t);
        if after >= 0.9 * before {
            return false;
        }
        std::mem::swap(&mut it.w, w);
        std::mem::swap(&mut it.t, t);
        self.filter.add(theta, phi);
        self.fresh = true;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_of_blocked_steps_calls_for_one_restoration_a_solve() {
        let mut blocked = BlockedSteps::default();
        for _ in 1..BLOCKED_STEPS_BEFORE_RESTORATION {
            assert!(!blocked.restoration_due(true));
        }
        assert!(blocked.restoration_due(true));
        // One restoration a solve: a run that comes back after it is left to the filter.
        for _ in 0..3 * BLOCKED_STEPS_BEFORE_RESTORATION {
            assert!(!blocked.restoration_due(true));
        }
    }

    #[test]
    fn a_step_that_is_not_blocked_ends_the_run() {
        let mut blocked = BlockedSteps::default();
        for _ in 1..BLOCKED_STEPS_BEFORE_RESTORATION {
            assert!(!blocked.restoration_due(true));
        }
        assert!(!blocked.restoration_due(false));
        for _ in 1..BLOCKED_STEPS_BEFORE_RESTORATION {
            assert!(!blocked.restoration_due(true));
        }
        assert!(blocked.restoration_due(true));
    }
}
