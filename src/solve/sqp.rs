//! Sequential quadratic programming with the exact Hessian.
//!
//! Each iteration evaluates everything at once ([`Nlp::evaluate_all`]: one derivative
//! sweep per stage), checks the KKT conditions, and solves a quadratic sub-problem with
//! clarabel ([`super::qp`]).
//!
//! * Curvature: the exact Hessian of the Lagrangian plus a Levenberg–Marquardt term
//!   `ρ / D²` (`D` a variable's range, so inputs in W m⁻² and in mm s⁻¹ are damped alike).
//!   When that QP fails or its step ascends the merit function, the diagonal is shifted
//!   by `δ / D²`, δ = 1e-7 … 1e-1 (a hundredfold per try, starting one notch below the
//!   shift that worked at the previous iteration), and as a last resort each diagonal
//!   block is convexified by clipping its negative eigenvalues. (Clipping first was tried
//!   and is worse here: it adds curvature through the stage couplings and SQP then creeps
//!   along the flat directions of the economic cost.)
//! * Globalisation: the ℓ₁ merit `φ = f + μ Σ violation(g)`. A full step that fails the
//!   Armijo test is tried again after the NLP's own feasibility restoration (an
//!   optimal-control problem re-simulates its states from the trial inputs), then with a
//!   second-order correction (constraints re-linearised at `g(x + d) − J d`, against the
//!   Maratos effect); if all fail, a trust region — a box of `radius` times the range on
//!   every variable bounded on both sides — shrinks and the QP is solved again; a
//!   backtracking line search is the last resort. A negligible step (a stationary point
//!   whose multipliers were off, as after a warm start) is taken as it is.
//! * Multipliers: the QP's, in full steps. After a step cut short, multipliers of bounds
//!   that are not active (those of a trust-region box) are dropped.
//! * Termination: optimal at a KKT residual of `tolerance`; acceptable at
//!   `acceptable_tolerance` when no step can be made, or after `acceptable_iterations`
//!   iterations in a row below it (the economic optimum is flat in places).
//!
//! Warm starts take a primal point and, when given, the multipliers of an earlier solve
//! (shifted in time by the caller); from a shifted solution most MPC steps converge in
//! two iterations.

use super::error::SetupError;
use super::kkt::{all_finite, l1_violation, residuals_of, Bounds, PointInfo};
use super::qp::{QpData, QpOutcome, QpSolver};
use super::scaled_objective::solve_scaled;
use super::solution_builder::{Ending, SolutionBuilder};
use super::termination::Termination;
use super::{KktResiduals, Solution, SolveStatus, Solver, Start};
use crate::nlp::Nlp;
use nalgebra::DMatrix;
use std::ops::Range;

/// Tuning of [`Sqp`].
#[derive(Debug, Clone, PartialEq)]
pub struct SqpOptions {
    /// Iteration limit of a solve; reaching it ends the solve as
    /// [`SolveStatus::Acceptable`] below `acceptable_tolerance`, else as
    /// [`SolveStatus::MaxIterations`].
    pub max_iterations: usize,
    /// KKT residual (infinity norm of stationarity, feasibility, complementarity) at which
    /// the solve is optimal.
    pub tolerance: f64,
    /// KKT residual accepted when the method cannot go further, or when it has stayed
    /// below it for more than `acceptable_iterations` iterations in a row (the economic
    /// optimum is flat in places and SQP then creeps). A feasible point whose objective
    /// has not moved (relative 1e-10) for `acceptable_iterations` iterations, with a KKT
    /// residual below 1e-3, is acceptable too: its multipliers are degenerate.
    pub acceptable_tolerance: f64,
    /// The run of iterations `acceptable_tolerance` asks for.
    pub acceptable_iterations: usize,
    /// Levenberg–Marquardt term: `ρ / D²` is added to the Hessian's diagonal, `D` the
    /// variable's range (see [`super::KktResiduals::stationarity`]).
    pub levenberg_marquardt: f64,
    /// Sufficient-decrease fraction of the Armijo rule.
    pub armijo: f64,
    /// Smallest step length tried by the line search.
    pub min_step: f64,
    /// QP solves per iteration with a shrinking trust region before falling back to a
    /// line search.
    pub trust_region_tries: usize,
    /// Print one line per iteration to standard error.
    pub trace: bool,
}

impl Default for SqpOptions {
    fn default() -> Self {
        SqpOptions {
            max_iterations: 100,
            tolerance: 1e-8,
            acceptable_tolerance: 1e-6,
            acceptable_iterations: 5,
            levenberg_marquardt: 1e-6,
            armijo: 1e-4,
            min_step: 1e-8,
            trust_region_tries: 6,
            trace: false,
        }
    }
}

/// The curvature a QP is given, tried in this order until the step descends the merit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
enum Curvature {
    /// The exact Hessian of the Lagrangian (plus the Levenberg–Marquardt term).
    #[default]
    Exact,
    /// The exact Hessian plus `δ / D²` on the diagonal.
    Shifted(f64),
    /// Negative eigenvalues of every block clipped to zero.
    Clipped,
}

impl Curvature {
    /// The next try: shifts of 1e-7 … 1e-1, then clipping.
    fn stronger(self) -> Curvature {
        match self {
            Curvature::Exact => Curvature::Shifted(1e-7),
            Curvature::Shifted(d) if d < 1e-1 => Curvature::Shifted(d * 100.0),
            _ => Curvature::Clipped,
        }
    }
}

/// The pure-Rust SQP back-end.
pub struct Sqp {
    /// Its tuning; may be changed between solves.
    pub options: SqpOptions,
    /// A temporary cap on the iterations, below `options.max_iterations`.
    iteration_limit: Option<usize>,
    qp: Option<QpSolver>,
    work: Work,
}

/// Buffers reused across iterations and solves.
#[derive(Default)]
struct Work {
    g: Vec<f64>,
    gradient: Vec<f64>,
    jacobian: Vec<f64>,
    hessian: Vec<f64>,
    trial_x: Vec<f64>,
    trial_g: Vec<f64>,
    scratch: Vec<f64>,
    blocks: Vec<DMatrix<f64>>,
    block_ranges: Vec<Range<usize>>,
    tr_lower: Vec<f64>,
    tr_upper: Vec<f64>,
    step: Vec<f64>,
    dir_lambda: Vec<f64>,
    dir_nu: Vec<f64>,
    corrected_g: Vec<f64>,
    restored_x: Vec<f64>,
    restored_g: Vec<f64>,
    /// The curvature of the last direction.
    curvature: Curvature,
    /// Iterations of the current solve whose step came from a corrected curvature.
    corrected: usize,
    /// For each Hessian entry, its block and position in the block.
    entry_place: Vec<(usize, usize, usize)>,
}

impl Default for Sqp {
    fn default() -> Self {
        Sqp::new(SqpOptions::default())
    }
}

impl Sqp {
    /// An SQP solver with `options`; its QP solver and buffers are set up on the first
    /// solve.
    pub fn new(options: SqpOptions) -> Sqp {
        Sqp {
            options,
            iteration_limit: None,
            qp: None,
            work: Work::default(),
        }
    }

    /// Sizes the buffers and the QP workspace for `nlp` (reused when nothing changed).
    fn prepare(&mut self, nlp: &dyn Nlp, bounds: &Bounds) -> Result<(), SetupError> {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let w = &mut self.work;
        let jp = nlp.jacobian_pattern();
        let hp = nlp.hessian_pattern();
        w.g.resize(m, 0.0);
        w.trial_g.resize(m, 0.0);
        w.restored_g.resize(m, 0.0);
        w.gradient.resize(n, 0.0);
        w.trial_x.resize(n, 0.0);
        w.scratch.resize(n, 0.0);
        w.tr_lower.resize(n, 0.0);
        w.tr_upper.resize(n, 0.0);
        w.step.resize(n, 0.0);
        w.dir_nu.resize(n, 0.0);
        w.dir_lambda.resize(m, 0.0);
        w.corrected_g.resize(m, 0.0);
        w.jacobian.resize(jp.len(), 0.0);
        w.hessian.resize(hp.len(), 0.0);
        let blocks = nlp.hessian_blocks();
        w.blocks = blocks
            .iter()
            .map(|r| DMatrix::zeros(r.len(), r.len()))
            .collect();
        w.block_ranges = blocks.clone();
        w.entry_place.clear();
        for (&r, &c) in hp.rows.iter().zip(&hp.cols) {
            let b = find_block(&blocks, r, c)
                .ok_or(SetupError::OutsideHessianBlocks { row: r, col: c })?;
            let start = blocks[b].start;
            w.entry_place.push((b, r - start, c - start));
        }
        let b = (
            &bounds.x_lower[..],
            &bounds.x_upper[..],
            &bounds.g_lower[..],
            &bounds.g_upper[..],
        );
        let fits = self.qp.as_ref().is_some_and(|qp| qp.fits(b));
        if !fits {
            self.qp = Some(QpSolver::new(n, blocks, &jp.rows, &jp.cols, b));
        }
        Ok(())
    }

    /// Fills the Hessian blocks from the Hessian values, with the Levenberg–Marquardt term,
    /// and with negative curvature clipped when `convexify` is set.
    fn fill_blocks(&mut self, curvature: Curvature, scale: &[f64]) {
        let w = &mut self.work;
        for m in &mut w.blocks {
            m.fill(0.0);
        }
        for (&(b, r, c), &v) in w.entry_place.iter().zip(&w.hessian) {
            w.blocks[b][(r, c)] = v;
            w.blocks[b][(c, r)] = v;
        }
        let rho = self.options.levenberg_marquardt
            + match curvature {
                Curvature::Shifted(delta) => delta,
                _ => 0.0,
            };
        for (m, range) in w.blocks.iter_mut().zip(&w.block_ranges) {
            if curvature == Curvature::Clipped {
                clip_negative_curvature(m);
            }
            for (i, v) in range.clone().enumerate() {
                m[(i, i)] += rho / (scale[v] * scale[v]);
            }
        }
    }

    /// Solves the QP at `x`; with `corrected_g`, the second-order correction QP whose
    /// constraints are linearised around `g(x + d) − J d`.
    fn solve_qp(
        &mut self,
        x: &[f64],
        bounds: &Bounds,
        radius: f64,
        corrected_g: Option<&[f64]>,
    ) -> QpOutcome {
        let w = &mut self.work;
        let Some(qp) = self.qp.as_mut() else {
            return QpOutcome::Failed;
        };
        // The trust region: a box on the step of every variable bounded on both sides,
        // `radius` times its range.
        for (i, &xi) in x.iter().enumerate() {
            let (lo, hi) = (bounds.x_lower[i], bounds.x_upper[i]);
            let range = hi - lo;
            if range.is_finite() && radius < 1.0 {
                w.tr_lower[i] = lo.max(xi - radius * range);
                w.tr_upper[i] = hi.min(xi + radius * range);
            } else {
                w.tr_lower[i] = lo;
                w.tr_upper[i] = hi;
            }
        }
        qp.solve(&QpData {
            blocks: &w.blocks,
            diagonal: self.options.levenberg_marquardt,
            gradient: &w.gradient,
            jacobian: &w.jacobian,
            g: corrected_g.unwrap_or(&w.g),
            x,
            x_lower: &w.tr_lower,
            x_upper: &w.tr_upper,
            g_lower: &bounds.g_lower,
            g_upper: &bounds.g_upper,
        })
    }

    /// Largest step relative to the range, over variables bounded on both sides. A fixed
    /// variable (equal bounds, such as a terminal-region component pinned at zero) cannot
    /// move, and the QP's rounding-level step on it must not count as a huge relative step.
    fn scaled_step(&self, bounds: &Bounds, d: &[f64]) -> f64 {
        d.iter()
            .zip(bounds.x_lower.iter().zip(&bounds.x_upper))
            .map(|(d, (lo, hi))| (d, hi - lo))
            .filter(|(_, range)| range.is_finite() && *range > 0.0)
            .fold(0.0, |a, (d, range)| a.max(d.abs() / range))
    }

    /// Whether a QP step of relative size `size` (from `scaled_step`) and merit slope
    /// `slope` is negligible: tiny against every variable's range, or, from a feasible
    /// point (ℓ₁ violation `violation`), predicting a change of the
    /// merit below `flat_slope`. The QP is solved to about 1e-8 relative accuracy, so near
    /// a stationary point its step is noise of that size in a random direction, and its
    /// predicted change sits at the rounding level of the objective: nothing a line search
    /// can confirm. Such a step is taken as it is, with the QP's multipliers.
    fn negligible(size: f64, slope: f64, violation: f64, flat_slope: f64) -> bool {
        size <= 1e-9 || (violation <= flat_slope && slope.abs() <= flat_slope)
    }

    /// A QP direction at `x` within `radius`: from the exact Hessian when clarabel solves
    /// that QP and its step descends the merit, else from the convexified Hessian. Returns the merit slope; fills `step`, `dir_*` and raises `penalty`.
    fn direction(
        &mut self,
        x: &[f64],
        bounds: &Bounds,
        radius: f64,
        violation: f64,
        flat_slope: f64,
        penalty: &mut f64,
    ) -> Result<f64, QpOutcome> {
        let mut result = Err(QpOutcome::Failed);
        // Start one notch below the shift that worked last (the curvature of one solve's
        // iterates changes slowly), then raise it a hundredfold per try.
        let mut curvature = match self.work.curvature {
            Curvature::Shifted(d) if d > 1e-7 => Curvature::Shifted(d / 100.0),
            Curvature::Clipped => Curvature::Shifted(1e-3),
            _ => Curvature::Exact,
        };
        loop {
            let last = curvature == Curvature::Clipped;
            self.fill_blocks(curvature, &bounds.scale);
            let outcome = self.solve_qp(x, bounds, radius, None);
            if outcome != QpOutcome::Solved {
                result = Err(outcome);
                if last {
                    break;
                }
                curvature = curvature.stronger();
                continue;
            }
            let Some(qp) = self.qp.as_ref() else { break };
            let w = &mut self.work;
            w.step.copy_from_slice(&qp.step);
            w.dir_lambda.copy_from_slice(&qp.multipliers);
            w.dir_nu.copy_from_slice(&qp.bound_multipliers);
            let norm = w.dir_lambda.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            if *penalty < 1.1 * norm {
                *penalty = 2.0 * norm;
            }
            let gd: f64 = w.gradient.iter().zip(&w.step).map(|(g, d)| g * d).sum();
            let slope = gd - *penalty * violation;
            // A negligible step means a stationary point: its multipliers are what counts.
            let size = self.scaled_step(bounds, &self.work.step);
            let negligible = Self::negligible(size, slope, violation, flat_slope);
            if last || slope < 0.0 || negligible {
                self.work.curvature = curvature;
                return Ok(slope);
            }
            result = Ok(slope);
            curvature = curvature.stronger();
        }
        result
    }

    /// Merit of the trial point after the NLP's feasibility restoration (if it has one);
    /// on success the restored point and its constraints replace the trial point's. The
    /// trial point's constraint values stay as they are otherwise (the second-order
    /// correction needs `g(x + d)`).
    fn restored_merit(&mut self, nlp: &mut dyn Nlp, bounds: &Bounds, penalty: f64) -> Option<f64> {
        let w = &mut self.work;
        w.restored_x.clone_from(&w.trial_x);
        if !nlp.restore_feasibility(&mut w.restored_x) {
            return None;
        }
        project_into(&mut w.restored_x, bounds);
        let merit = merit_at(nlp, &w.restored_x, &mut w.restored_g, bounds, penalty);
        if !merit.is_finite() {
            return None;
        }
        w.trial_x.clone_from(&w.restored_x);
        w.trial_g.clone_from(&w.restored_g);
        Some(merit)
    }

    /// Merit of a trial point `x + αd` (projected into the bounds); fills `trial_x`,
    /// `trial_g`.
    fn trial_merit(
        &mut self,
        nlp: &mut dyn Nlp,
        x: &[f64],
        d: &[f64],
        alpha: f64,
        bounds: &Bounds,
        penalty: f64,
    ) -> f64 {
        let w = &mut self.work;
        for ((t, &xi), &di) in w.trial_x.iter_mut().zip(x).zip(d) {
            *t = xi + alpha * di;
        }
        project_into(&mut w.trial_x, bounds);
        merit_at(nlp, &w.trial_x, &mut w.trial_g, bounds, penalty)
    }
}

/// The ℓ₁ merit `f + μ Σ violation(g)` at `x` (`+∞` when not finite); fills `g`.
fn merit_at(nlp: &mut dyn Nlp, x: &[f64], g: &mut [f64], bounds: &Bounds, penalty: f64) -> f64 {
    let f = nlp.objective(x);
    nlp.constraints(x, g);
    let merit = f + penalty * l1_violation(g, bounds);
    if merit.is_finite() {
        merit
    } else {
        f64::INFINITY
    }
}

/// `H ← V max(Λ, 0) Vᵀ`, skipping the eigen-decomposition when a Cholesky factorisation
/// shows `H` positive definite already.
fn clip_negative_curvature(m: &mut DMatrix<f64>) {
    if m.nrows() == 0 || m.clone().cholesky().is_some() {
        return;
    }
    let eig = m.clone().symmetric_eigen();
    let clipped = eig.eigenvalues.map(|l| l.max(0.0));
    *m = &eig.eigenvectors * DMatrix::from_diagonal(&clipped) * eig.eigenvectors.transpose();
}

fn find_block(blocks: &[Range<usize>], r: usize, c: usize) -> Option<usize> {
    blocks.iter().position(|b| b.contains(&r) && b.contains(&c))
}

fn project_into(x: &mut [f64], bounds: &Bounds) {
    for ((v, &lo), &hi) in x.iter_mut().zip(&bounds.x_lower).zip(&bounds.x_upper) {
        *v = v.max(lo).min(hi);
    }
}

impl Solver for Sqp {
    fn name(&self) -> &'static str {
        "sqp"
    }

    fn set_iteration_limit(&mut self, limit: Option<usize>) {
        self.iteration_limit = limit;
    }

    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        solve_scaled(nlp, start, |nlp, start, _| self.solve_in_scale(nlp, start))
    }
}

impl Sqp {
    /// A solve of `nlp` as given (its objective scaled already).
    fn solve_in_scale(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        let builder = SolutionBuilder::start("sqp", self.options.trace);
        self.work.corrected = 0;
        let bounds = Bounds::of(nlp);
        let mut point = Point::start(nlp, start, &bounds);
        let ending = match self.prepare(nlp, &bounds) {
            Ok(()) => self.run(nlp, &bounds, &mut point),
            Err(error) => Ending::before_start(error.status()),
        };
        let ending = Ending {
            inertia_corrections: self.work.corrected,
            ..ending
        };
        builder.build(ending, point.x, point.lambda, point.nu)
    }
}

/// The primal-dual point of a solve.
struct Point {
    x: Vec<f64>,
    /// Constraint multipliers `λ`.
    lambda: Vec<f64>,
    /// Bound multipliers `ν`.
    nu: Vec<f64>,
}

impl Point {
    /// The start projected into the bounds, multipliers zero where not given.
    fn start(nlp: &dyn Nlp, start: Start<'_>, bounds: &Bounds) -> Point {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let mut x = start.x.to_vec();
        x.resize(n, 0.0);
        project_into(&mut x, bounds);
        let mut lambda = start.multipliers.map_or(vec![0.0; m], <[f64]>::to_vec);
        let mut nu = start
            .bound_multipliers
            .map_or(vec![0.0; n], <[f64]>::to_vec);
        lambda.resize(m, 0.0);
        nu.resize(n, 0.0);
        Point { x, lambda, nu }
    }
}

/// Watches for a stalled solve: feasible, the objective no longer moving, only the
/// multipliers of a degenerate point still wandering.
struct Stall {
    /// Iterations in a row that looked stalled.
    run: usize,
    last_objective: f64,
}

impl Stall {
    fn new() -> Stall {
        Stall {
            run: 0,
            last_objective: f64::NAN,
        }
    }

    /// Records an iteration's objective and residuals; true once `needed` iterations in a
    /// row have stalled.
    fn record(&mut self, objective: f64, kkt: &KktResiduals, needed: usize) -> bool {
        let moved = (objective - self.last_objective).abs() > 1e-10 * objective.abs().max(1e-3);
        self.run = if !moved && kkt.primal <= 1e-8 && kkt.max() <= 1e-3 {
            self.run + 1
        } else {
            0
        };
        self.last_objective = objective;
        self.run >= needed
    }
}

/// The merit at the current point and what makes a change of it negligible.
#[derive(Debug, Clone, Copy)]
struct MeritAt {
    /// `φ = f + μ Σ violation(g)`.
    merit: f64,
    /// The ℓ₁ violation of the constraints.
    violation: f64,
    /// Changes of the merit below this are rounding.
    flat_slope: f64,
}

/// What the trust-region loop of one iteration found.
struct TrustRegionSearch {
    /// A trial point was accepted (it is in `work.trial_x`).
    accepted: bool,
    /// The merit's slope along the last direction.
    slope: f64,
    /// The trust region of the last try (1: none).
    radius: f64,
    /// Whether any QP gave a direction.
    have_direction: bool,
    /// Why the last QP failed.
    failure: QpOutcome,
}

impl Sqp {
    /// The iterations of a solve from `point`, which they update; `work.corrected` counts
    /// the curvature corrections.
    fn run(&mut self, nlp: &mut dyn Nlp, bounds: &Bounds, point: &mut Point) -> Ending {
        let mut options = self.options.clone();
        if let Some(limit) = self.iteration_limit {
            options.max_iterations = options.max_iterations.min(limit);
        }
        let mut termination = Termination::new(
            options.tolerance,
            options.acceptable_tolerance,
            options.acceptable_iterations,
            options.max_iterations,
        );
        let ending = |status, iterations, objective, kkt| Ending {
            status,
            iterations,
            objective,
            kkt,
            inertia_corrections: 0,
        };
        let mut penalty = 0.0_f64;
        let mut stalled = false;
        let mut stall = Stall::new();
        self.work.curvature = Curvature::Exact;
        let mut objective = f64::NAN;
        let mut kkt = KktResiduals::default();
        for iteration in 0..=options.max_iterations {
            objective = self.evaluate(nlp, point);
            if !self.evaluation_is_finite(objective) {
                return ending(SolveStatus::InvalidNumber, iteration, objective, kkt);
            }
            kkt = self.residuals(nlp, point, bounds);
            let stalled_point = stall.record(objective, &kkt, options.acceptable_iterations);
            if let Some(status) = termination.check(kkt.max(), iteration, stalled_point) {
                return ending(status, iteration, objective, kkt);
            }
            let violation = l1_violation(&self.work.g, bounds);
            let merit = objective + penalty * violation;
            let at = MeritAt {
                merit,
                violation,
                // Changes of the merit below this are rounding: 1e-12 relative.
                flat_slope: 1e-12 * merit.abs().max(1.0),
            };
            let search =
                self.trust_region_search(nlp, &point.x, bounds, &options, at, &mut penalty);
            if !search.have_direction {
                let infeasible = search.failure == QpOutcome::Infeasible;
                return ending(
                    termination.stuck(kkt.max(), infeasible),
                    iteration,
                    objective,
                    kkt,
                );
            }
            let slope = search.slope;
            let sufficient =
                |alpha: f64, trial: f64| trial <= merit + options.armijo * alpha * slope.min(0.0);
            // Backtracking along the last direction when the trust region did not help.
            let alpha = if search.accepted {
                Some(1.0)
            } else {
                self.backtrack(nlp, &point.x, bounds, penalty, options.min_step, sufficient)
            };
            let Some(alpha) = alpha else {
                if kkt.max() <= options.acceptable_tolerance || stalled {
                    let status = termination.stuck(kkt.max(), false);
                    return ending(status, iteration, objective, kkt);
                }
                // No step, but the QP's multipliers may be all that was missing (a cold
                // start has none): take them and check again once.
                stalled = true;
                point.lambda.copy_from_slice(&self.work.dir_lambda);
                point.nu.copy_from_slice(&self.work.dir_nu);
                continue;
            };
            stalled = false;
            if self.work.curvature != Curvature::Exact {
                self.work.corrected += 1;
            }
            if options.trace {
                self.trace(iteration, objective, &kkt, alpha, search.radius);
            }
            self.take_step(point, bounds, search.radius, alpha);
        }
        // The last iteration returns inside the loop; this is for the type checker.
        let status = termination.at_limit(kkt.max());
        ending(status, options.max_iterations, objective, kkt)
    }

    /// Evaluates everything at `point` into the work buffers; returns the objective.
    fn evaluate(&mut self, nlp: &mut dyn Nlp, point: &Point) -> f64 {
        let w = &mut self.work;
        nlp.evaluate_all(
            &point.x,
            1.0,
            &point.lambda,
            &mut w.g,
            &mut w.gradient,
            &mut w.jacobian,
            &mut w.hessian,
        )
    }

    /// Whether `objective` and the values [`Sqp::evaluate`] left are all finite.
    fn evaluation_is_finite(&self, objective: f64) -> bool {
        let w = &self.work;
        objective.is_finite()
            && all_finite(&w.g)
            && all_finite(&w.gradient)
            && all_finite(&w.jacobian)
            && all_finite(&w.hessian)
    }

    /// The KKT residuals of `point` from the values [`Sqp::evaluate`] left.
    fn residuals(&mut self, nlp: &dyn Nlp, point: &Point, bounds: &Bounds) -> KktResiduals {
        let w = &mut self.work;
        let info = PointInfo {
            x: &point.x,
            g: &w.g,
            gradient: &w.gradient,
            jacobian: &w.jacobian,
            multipliers: &point.lambda,
            bound_multipliers: &point.nu,
        };
        residuals_of(&info, nlp.jacobian_pattern(), bounds, &mut w.scratch)
    }

    /// Every iteration first tries the plain QP step; a rejected full step is tried again
    /// after the NLP's restoration and with a second-order correction, then the trust
    /// region (a box on the inputs) shrinks and the QP is solved again.
    fn trust_region_search(
        &mut self,
        nlp: &mut dyn Nlp,
        x: &[f64],
        bounds: &Bounds,
        options: &SqpOptions,
        at: MeritAt,
        penalty: &mut f64,
    ) -> TrustRegionSearch {
        let mut search = TrustRegionSearch {
            accepted: false,
            slope: 0.0,
            radius: 1.0,
            have_direction: false,
            failure: QpOutcome::Failed,
        };
        for _ in 0..options.trust_region_tries {
            match self.direction(
                x,
                bounds,
                search.radius,
                at.violation,
                at.flat_slope,
                penalty,
            ) {
                Ok(s) => search.slope = s,
                Err(outcome) => {
                    search.failure = outcome;
                    break;
                }
            }
            search.have_direction = true;
            let slope = search.slope;
            let sufficient = |alpha: f64, trial: f64| {
                trial <= at.merit + options.armijo * alpha * slope.min(0.0)
            };
            let step = self.work.step.clone();
            let full = self.trial_merit(nlp, x, &step, 1.0, bounds, *penalty);
            let size = self.scaled_step(bounds, &step);
            // A negligible step is taken as it is: the point is (nearly) stationary and
            // only the QP's multipliers are news; rounding would fail the Armijo test.
            let negligible = Self::negligible(size, slope, at.violation, at.flat_slope);
            if negligible || sufficient(1.0, full) {
                search.accepted = true;
                break;
            }
            // Restoration: the NLP may map the trial point onto its constraints (an
            // optimal-control problem re-simulates its states from the trial inputs).
            if self
                .restored_merit(nlp, bounds, *penalty)
                .is_some_and(|m| sufficient(1.0, m))
            {
                search.accepted = true;
                break;
            }
            let corrected = self.corrected_merit(nlp, x, bounds, search.radius, &step, *penalty);
            if corrected.is_some_and(|m| sufficient(1.0, m)) {
                self.take_qp_multipliers();
                search.accepted = true;
                break;
            }
            if size <= 1e-12 {
                break;
            }
            search.radius = 0.3 * size;
        }
        search
    }

    /// Merit of the second-order correction of the rejected step `step` (the constraints
    /// linearised around `g(x + d) − J d`), `None` when its QP fails; fills `trial_x`,
    /// `trial_g`, and leaves the correction's multipliers in the QP solver.
    fn corrected_merit(
        &mut self,
        nlp: &mut dyn Nlp,
        x: &[f64],
        bounds: &Bounds,
        radius: f64,
        step: &[f64],
        penalty: f64,
    ) -> Option<f64> {
        let w = &mut self.work;
        w.corrected_g.copy_from_slice(&w.trial_g);
        let pattern = nlp.jacobian_pattern();
        for ((&r, &c), &v) in pattern.rows.iter().zip(&pattern.cols).zip(&w.jacobian) {
            w.corrected_g[r] -= v * step[c];
        }
        let corrected = w.corrected_g.clone();
        if self.solve_qp(x, bounds, radius, Some(&corrected)) != QpOutcome::Solved {
            return None;
        }
        let soc = self.qp.as_ref()?.step.clone();
        Some(self.trial_merit(nlp, x, &soc, 1.0, bounds, penalty))
    }

    /// The QP solver's multipliers as the direction's.
    fn take_qp_multipliers(&mut self) {
        if let Some(qp) = self.qp.as_ref() {
            self.work.dir_lambda.copy_from_slice(&qp.multipliers);
            self.work.dir_nu.copy_from_slice(&qp.bound_multipliers);
        }
    }

    /// Halves the step along the last direction until `sufficient(α, merit)` holds, down to
    /// `min_step`; returns the step length taken (the trial point is in `trial_x`).
    fn backtrack(
        &mut self,
        nlp: &mut dyn Nlp,
        x: &[f64],
        bounds: &Bounds,
        penalty: f64,
        min_step: f64,
        sufficient: impl Fn(f64, f64) -> bool,
    ) -> Option<f64> {
        let step = self.work.step.clone();
        let mut alpha = 1.0;
        loop {
            alpha *= 0.5;
            if alpha < min_step {
                return None;
            }
            let trial = self.trial_merit(nlp, x, &step, alpha, bounds, penalty);
            if sufficient(alpha, trial) {
                return Some(alpha);
            }
        }
    }

    /// Moves `point` to the accepted trial point with the direction's multipliers in full
    /// (the best estimate at hand whatever the primal step length).
    fn take_step(&mut self, point: &mut Point, bounds: &Bounds, radius: f64, alpha: f64) {
        let w = &mut self.work;
        // After a step cut short (by the trust region or the line search), a bound
        // multiplier stands only where its bound is active at the new point: the
        // multipliers of a trust-region box, or of a bound the step stopped short of,
        // are dropped.
        if radius < 1.0 || alpha < 1.0 {
            for (i, v) in w.dir_nu.iter_mut().enumerate() {
                let t = w.trial_x[i];
                let tolerance = 1e-7 * bounds.scale[i];
                let active = if *v > 0.0 {
                    bounds.x_upper[i] - t <= tolerance
                } else {
                    t - bounds.x_lower[i] <= tolerance
                };
                if !active {
                    *v = 0.0;
                }
            }
        }
        point.x.copy_from_slice(&w.trial_x);
        point.lambda.copy_from_slice(&w.dir_lambda);
        point.nu.copy_from_slice(&w.dir_nu);
    }

    /// One line per iteration on standard error.
    fn trace(&self, iteration: usize, objective: f64, kkt: &KktResiduals, alpha: f64, radius: f64) {
        eprintln!(
            "sqp {iteration:3} f {objective:.12e} kkt {:.1e} {:.1e} {:.1e} alpha {alpha:.3} radius {radius:.2e}{}",
            kkt.stationarity, kkt.primal, kkt.complementarity,
            match self.work.curvature {
                Curvature::Exact => String::new(),
                c => format!(" {c:?}"),
            }
        );
    }
}
