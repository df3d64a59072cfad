//! A primal-dual interior-point method that solves an optimal-control problem stage by
//! stage, with the exact Hessian taken as it is (fatrop's design, IPOPT's algorithm).
//!
//! * Inequalities: every constraint row that is not a dynamics row gets a slack `t` with
//!   the row's bounds (`c(w) − t = 0`); bounds on variables and slacks enter a
//!   logarithmic barrier `−μ Σ ln(·)`. Slacks and bound multipliers are eliminated from
//!   the primal-dual Newton system, which leaves the Hessian of the Lagrangian plus
//!   diagonal `Σ` terms and `Jᵀ Σ J` over the inequality rows, and the dynamics.
//! * Newton step: a Riccati recursion over the stages ([`super::riccati`],
//!   [`crate::nlp::Stages`]), `O(N)`; its Cholesky factorisations are the inertia test.
//!   Inertia correction stage by stage ([`Riccati::factor_corrected`]): where a stage's
//!   reduced Hessian `R̂_k` is not positive definite, `δ_k / D²` (`D` a control's range)
//!   is added to that stage's controls only, `δ_k` just above what `R̂_k`'s most negative
//!   eigenvalue needs. One `δ` for the whole horizon (IPOPT's and fatrop's correction) is
//!   sized for the worst stage and damps every other direction with it: a value network's
//!   terminal cost needed `δ ≈ 3` on the last stages while the terminal temperature's own
//!   curvature was 3e-4, and the step crept towards the terminal region's bound for
//!   hundreds of iterations. Where a stage would need more than
//!   [`super::riccati::MAX_STAGE_CORRECTION`] (negative curvature of the states piled up
//!   in the cost to go over a long horizon, as on the 1920-stage season), one `δ` on the
//!   states and controls of every stage from the failing one on takes over, with IPOPT's
//!   schedule (1e-4 the first time, a third of the last value after that, ×100 or ×8 per
//!   failure), narrowed by bisection towards the threshold. The same whole-horizon `δ`
//!   replaces a stage-wise correction whose direction the boundary cuts to a short step
//!   (`SHORT_CORRECTED_STEP`): the recursion's gains can amplify a stage's barely corrected
//!   curvature into a direction of 1e7. No convexification: where the reduced Hessian is
//!   positive definite the exact Newton step is taken, and the convergence is quadratic.
//! * Globalisation: IPOPT's filter line search on the barrier objective and the ℓ₁
//!   constraint violation, fraction to the boundary `τ = max(0.99, 1 − μ)`, up to four
//!   second-order corrections, and a feasibility restoration by the problem's own
//!   [`Nlp::restore_feasibility`] (an optimal-control problem re-simulates its states)
//!   when the step gets too short, or after a run of accepted steps that the boundary cut
//!   short and that each raised the violation (`BlockedSteps`).
//! * Barrier parameter ([`MuStrategy`]): a cold start follows IPOPT's adaptive strategy,
//!   `μ` from Mehrotra's probing every iteration (one factorisation serves the probing
//!   step, the step itself and Mehrotra's corrector where it reaches farther), with the
//!   monotone rule as its safeguard; it begins at [`IpmOptions::initial_mu`] with the
//!   point pushed [`IpmOptions::bound_push`] inside its bounds, or
//!   [`IpmOptions::shifted_push`] from an earlier solution ([`Start::shifted`], MPC's
//!   default restart, `primal`; with its constraint multipliers, as RL-guided
//!   MPC restarts, a soft band's slack by [`IpmOptions::shifted_slack_push`]). A warm
//!   start (all multipliers given) keeps IPOPT's monotone rule (`μ ← max(ε/10, min(μ/5,
//!   μ^1.5))` once the barrier problem is solved to `10 μ`) from
//!   [`IpmOptions::warm_start_mu`], the point pushed [`IpmOptions::warm_push`] inside and
//!   the bound multipliers raised to match.
//!
//! The problem must say its stages ([`Nlp::stages`]); a problem without them ends at once
//! with [`SolveStatus::NumericalError`]. A line search that finds no acceptable step, and
//! a restoration that cannot lower the violation, end the solve as
//! [`SolveStatus::Infeasible`] while the constraints are violated (above the acceptable
//! tolerance), else as acceptable or as a numerical error.

//! Its parts, each with one job (Clarabel's shape): the tuning ([`IpmOptions`]); the
//! barrier problem of a solve (`problem.rs`: bounds as the barrier sees them, `θ` and `φ`)
//! and its bounds (`sides.rs`); the iterate with what is measured at it (`iterate.rs`);
//! the KKT system (`kkt_system.rs`: the stage map of `structure.rs` and the Riccati
//! recursion, factorised with inertia correction); the Newton directions through it
//! (`newton.rs`); the barrier parameter's strategy (`barrier.rs`); the filter line search
//! with its second-order corrections and restoration (`line_search.rs`, `filter.rs`); the
//! workspace that holds them for a problem pattern (`workspace.rs`). [`Ipm::solve`]'s loop
//! drives them; the termination test and the [`Solution`] are the solve layer's, shared
//! with SQP.
//!
//! [`Riccati::factor_corrected`]: super::riccati::Riccati::factor_corrected

mod barrier;
mod filter;
mod iterate;
mod kkt_system;
mod line_search;
mod newton;
mod options;
mod problem;
mod sides;
mod structure;
mod workspace;

pub use options::{IpmOptions, MuStrategy};

use super::scaled_objective::solve_scaled;
use super::solution_builder::{Ending, SolutionBuilder};
use super::termination::Termination;
use super::{CheckpointSink, Solution, SolveStatus, Solver, Start};
use crate::nlp::Nlp;
use barrier::{average_complementarity, Barrier};
use filter::Accepted;
use iterate::StartKind;
use line_search::SearchFrom;
use newton::Newton;
use workspace::Workspace;

/// The shortest step taken back from a point whose derivatives are not finite; below it
/// the solve ends `invalid_number`.
const MIN_STEP_BACK: f64 = 1e-12;

/// The pure-Rust structure-exploiting interior-point back-end.
pub struct Ipm {
    /// Its tuning; may be changed between solves.
    pub options: IpmOptions,
    iteration_limit: Option<usize>,
    correction_limit: Option<usize>,
    /// The buffers of the last problem pattern, kept while the patterns are the same.
    workspace: Option<Workspace>,
    /// Inertia corrections made by the last solve.
    corrections: usize,
    /// Feasibility restorations made by the last solve.
    restorations: usize,
    /// Where checkpoints go, when it wants one.
    checkpoint_sink: Option<Box<dyn CheckpointSink>>,
}

impl Default for Ipm {
    fn default() -> Self {
        Ipm::new(IpmOptions::default())
    }
}

impl Ipm {
    /// An interior-point solver with `options`.
    pub fn new(options: IpmOptions) -> Ipm {
        Ipm {
            options,
            iteration_limit: None,
            correction_limit: None,
            workspace: None,
            corrections: 0,
            restorations: 0,
            checkpoint_sink: None,
        }
    }

    /// Inertia corrections (factorisations with `δ > 0` that were used) of the last
    /// solve.
    pub fn inertia_corrections(&self) -> usize {
        self.corrections
    }

    /// Feasibility restorations ([`Nlp::restore_feasibility`]) the last solve made, after
    /// a line search that found no step or a run of blocked steps.
    pub fn restorations(&self) -> usize {
        self.restorations
    }
}

impl Solver for Ipm {
    fn name(&self) -> &'static str {
        "ipm"
    }

    fn set_iteration_limit(&mut self, limit: Option<usize>) {
        self.iteration_limit = limit;
    }

    fn set_correction_limit(&mut self, limit: Option<usize>) {
        self.correction_limit = limit;
    }

    /// 80: on the GreenLight tomato's hardest stretch (steps 1651–1760 of the Bleiswijk
    /// season, resumed from the same 1650 steps, 1 h, `primal-dual`) a cap of 40 sent 11
    /// of 109 steps to a cold start (3 178 iterations in all), 60 sent 7 (2 725), 80 sent 2
    /// (1 987), 120 sent 1 (2 649): many warm solves there converge between 40 and 80
    /// iterations, and a cold start takes 50 to 200, some over 300 (`docs/benchmarks.md`,
    /// "Economic MPC of the GreenLight tomato, priced on its fruit", "Room for a cold
    /// start"). MPC caps a `primal-dual` restart and, under guidance, the cold attempt
    /// from the guide's fresh roll-out.
    fn warm_iteration_budget(&self) -> usize {
        80
    }

    /// No: the shifted primal point with a fresh barrier (MPC's `primal` restart).
    fn restarts_from_multipliers(&self) -> bool {
        false
    }

    fn set_checkpoints(&mut self, sink: Option<Box<dyn CheckpointSink>>) -> bool {
        self.checkpoint_sink = sink;
        true
    }

    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        solve_scaled(nlp, start, |nlp, start, scale| {
            self.solve_in_scale(nlp, start, scale)
        })
    }
}

impl Ipm {
    /// A solve of `nlp`, whose objective is the problem's times `objective_scale`.
    fn solve_in_scale(
        &mut self,
        nlp: &mut dyn Nlp,
        start: Start<'_>,
        objective_scale: f64,
    ) -> Solution {
        let builder = SolutionBuilder::start("ipm", self.options.trace);
        let refused = |status| {
            let mut x = start.x.to_vec();
            x.resize(nlp.n_vars(), 0.0);
            builder.refused(status, x, nlp.n_cons())
        };
        // The workspace, made anew when the problem's patterns changed.
        if !self.workspace.as_ref().is_some_and(|w| w.fits(nlp)) {
            match Workspace::new(nlp) {
                Ok(workspace) => self.workspace = Some(workspace),
                Err(error) => return refused(error.status()),
            }
        }
        let Some(mut workspace) = self.workspace.take() else {
            return refused(SolveStatus::NumericalError);
        };
        let (status, iterations, objective) = self.run(nlp, &mut workspace, start, objective_scale);
        let (x, lambda, nu, ending) = workspace.solution(nlp, status, iterations, objective);
        self.workspace = Some(workspace);
        let ending = Ending {
            inertia_corrections: self.corrections,
            ..ending
        };
        builder.build(ending, x, lambda, nu)
    }

    /// The iterations of one solve in `ws`, of a problem whose objective is scaled by
    /// `objective_scale`; returns how it ended, after how many iterations, with which
    /// objective.
    fn run(
        &mut self,
        nlp: &mut dyn Nlp,
        ws: &mut Workspace,
        start: Start<'_>,
        objective_scale: f64,
    ) -> (SolveStatus, usize, f64) {
        let opts = self.options.clone();
        let max_iterations = self
            .iteration_limit
            .map_or(opts.max_iterations, |l| l.min(opts.max_iterations));
        let mut termination = Termination::new(
            opts.tolerance,
            opts.acceptable_tolerance,
            opts.acceptable_iterations,
            max_iterations,
        );
        self.corrections = 0;
        self.restorations = 0;
        let kind = StartKind::of(&start, &opts, objective_scale);
        if !ws.start_solve(nlp, &start, kind, max_iterations) {
            return (SolveStatus::InvalidNumber, 0, f64::NAN);
        }
        let mut barrier = Barrier::new(&opts, (kind.mu, objective_scale), kind.warm, || {
            average_complementarity(&ws.problem, &ws.it, None)
        });
        // The longest step the next line search may take: half the last one where that
        // led to a point whose derivatives are not finite.
        let mut step_cap;
        for iteration in 0..=max_iterations {
            if ws.ev.evaluate(nlp, &ws.it) {
                step_cap = f64::INFINITY;
            } else {
                // A step accepted on its values whose derivatives are not finite (an
                // implicit step at the edge of its Newton's reach): back to the point
                // before, a step half as long; IPOPT cuts back on evaluation errors alike.
                let Some(alpha) = ws.step_back().filter(|&a| a > MIN_STEP_BACK) else {
                    return (SolveStatus::InvalidNumber, iteration, ws.ev.f);
                };
                if opts.trace {
                    eprintln!("ipm {iteration:3} derivatives not finite after α {alpha:.2e}: back");
                }
                step_cap = alpha / 2.0;
                if !ws.ev.evaluate(nlp, &ws.it) {
                    return (SolveStatus::InvalidNumber, iteration, ws.ev.f);
                }
            }
            // The barrier follows the error of the problem as solved; the solve ends on the
            // error in the problem's own units, so that a scaled objective is solved to the
            // same tolerance as unscaled.
            let e0 = optimality_error(ws, 0.0, 1.0);
            let e_own = if objective_scale == 1.0 {
                e0
            } else {
                optimality_error(ws, 0.0, objective_scale)
            };
            if let Some(status) = termination.check(e_own, iteration, false) {
                return (status, iteration, ws.ev.f);
            }
            if let Some(sink) = self.checkpoint_sink.as_mut() {
                if iteration > 0 && sink.wants(iteration) {
                    sink.keep(&ws.checkpoint(iteration, barrier.mu(), objective_scale));
                }
            }
            update_barrier(ws, &mut barrier, e0);
            let theta = ws.problem.violation(&ws.ev.c, &ws.it.t);
            ws.condensation
                .assemble(&mut ws.kkt, &ws.problem, &ws.ev, &ws.it, barrier.mu());
            let Some(corrected) = ws.kkt.factor() else {
                return (SolveStatus::NumericalError, iteration, ws.ev.f);
            };
            let delta = ws.kkt.largest_correction();
            if corrected > 0 {
                self.corrections += 1;
                if self.correction_limit.is_some_and(|l| self.corrections >= l) {
                    return (SolveStatus::MaxIterations, iteration, ws.ev.f);
                }
            }
            let Some(alpha_max) = newton_step(ws, &mut barrier, theta, corrected > 0) else {
                return (SolveStatus::NumericalError, iteration, ws.ev.f);
            };
            let alpha_max = alpha_max.min(step_cap);
            let mu = barrier.mu();
            let phi = ws.problem.barrier(ws.ev.f, &ws.it.w, &ws.it.t, mu);
            let Some((accepted, alpha)) = search(ws, nlp, (mu, theta, phi), alpha_max, opts.trace)
            else {
                // No acceptable step: the problem's own restoration, else the end.
                if ws.restore(nlp, kind.kappa, (theta, phi)) {
                    self.restorations += 1;
                    continue;
                }
                // Stuck away from feasibility: the constraints cannot be met from here.
                let infeasible = theta > opts.acceptable_tolerance;
                return (termination.stuck(e_own, infeasible), iteration, ws.ev.f);
            };
            ws.line_search.accepted(accepted, theta, phi);
            // After a run of short steps that raised the violation, restore instead.
            let due = ws
                .line_search
                .restoration_due(nlp, &ws.problem, alpha, theta);
            if due && ws.restore(nlp, kind.kappa, (theta, phi)) {
                self.restorations += 1;
                continue;
            }
            if opts.trace {
                eprintln!(
                    "ipm {iteration:3} f {:.10e} err {e0:.1e} θ {theta:.1e} μ {mu:.1e} δ {delta:.1e} α {alpha:.2e}{}",
                    ws.ev.f,
                    if barrier.is_free() { " free" } else { "" }
                );
            }
            let alpha_dual = ws.it.dual_reach(&ws.directions.step, (1.0 - mu).max(0.99));
            ws.take_step(alpha, alpha_dual, mu);
        }
        // The last iteration returns inside the loop; this is for the type checker.
        (SolveStatus::MaxIterations, max_iterations, f64::NAN)
    }
}

/// IPOPT's optimality error at the iterate of `ws` for barrier parameter `mu`, its dual
/// parts divided by `objective_scale`.
fn optimality_error(ws: &mut Workspace, mu: f64, objective_scale: f64) -> f64 {
    ws.it.optimality_error(
        &ws.problem,
        &ws.jacobian,
        &ws.ev,
        (mu, objective_scale),
        &mut ws.scratch,
    )
}

/// The barrier parameter's update before the factorisation, from the optimality error
/// `e0` (`μ = 0`); a new barrier problem starts the filter afresh.
fn update_barrier(ws: &mut Workspace, barrier: &mut Barrier, e0: f64) {
    let Workspace {
        jacobian,
        problem,
        it,
        ev,
        scratch,
        ..
    } = ws;
    let error_at = |mu| it.optimality_error(problem, jacobian, ev, (mu, 1.0), scratch);
    let average = || average_complementarity(problem, it, None);
    if barrier.update(e0, error_at, average) {
        ws.line_search.new_barrier_problem();
    }
}

/// The step's direction from the factorised system (in free mode after Mehrotra's probing
/// has set `μ`; the filter reset at violation `theta` where the barrier problem is new);
/// returns the primal step to the boundary, `None` where a solve failed.
fn newton_step(
    ws: &mut Workspace,
    barrier: &mut Barrier,
    theta: f64,
    corrected: bool,
) -> Option<f64> {
    let Workspace {
        jacobian,
        kkt,
        problem,
        it,
        ev,
        condensation,
        directions,
        line_search,
        ..
    } = ws;
    let newton = Newton {
        problem,
        jacobian,
        ev,
        it,
        condensation,
    };
    let free = barrier.is_free();
    let probed = !free || directions.solve_probe(&newton, kkt);
    if free && probed && barrier.probe(problem, it, &directions.probe) {
        line_search.new_barrier_problem();
    }
    line_search.start_iteration(theta);
    let mu = barrier.mu();
    if !(probed && directions.solve_step(&newton, kkt, mu, free)) {
        return None;
    }
    let tau = (1.0 - mu).max(0.99);
    Some(directions.primal_reach(&newton, kkt, corrected, mu, tau))
}

/// The filter line search along the step's direction from the iterate, whose barrier
/// parameter, violation and barrier objective are `(μ, θ, φ)`; the step to the boundary
/// is `alpha_max`. Returns how the step was accepted and its length.
fn search(
    ws: &mut Workspace,
    nlp: &mut dyn Nlp,
    (mu, theta, phi): (f64, f64, f64),
    alpha_max: f64,
    trace: bool,
) -> Option<(Accepted, f64)> {
    let Workspace {
        jacobian,
        kkt,
        problem,
        it,
        ev,
        condensation,
        directions,
        line_search,
        ..
    } = ws;
    let d = &directions.step;
    let from = SearchFrom {
        problem,
        jacobian,
        ev,
        it,
        direction: d,
        rhs: &directions.rhs,
        condensation,
        mu,
        theta,
        phi,
        slope: it.barrier_slope(problem, &ev.gradient, d, mu),
        alpha_max,
        trace,
    };
    line_search.search(nlp, kkt, &from)
}
