//! Solvers of nonlinear programs behind one [`Solver`] trait.
//!
//! * [`Sqp`]: sequential quadratic programming with the exact Hessian, regularised per
//!   stage block, quadratic sub-problems solved by clarabel, an ℓ₁-merit line search and
//!   warm starts. Pure Rust.
//! * [`Ipm`]: a primal-dual interior point for optimal-control problems ([`Nlp::stages`]):
//!   the Newton step by a Riccati recursion over the stages ([`riccati`]), the exact
//!   Hessian with inertia correction, IPOPT's filter line search. Pure Rust; the default
//!   of MPC, RL-guided MPC and the season optimum.
//! * `Ipopt` (cargo feature `ipopt`): the system's IPOPT through its C interface.
//!
//! A solve never panics on a bad problem: it returns a [`Solution`] whose
//! [`SolveStatus`] says what happened, with statistics and KKT residuals.
//!
//! Multiplier conventions (shared by every back-end and by [`kkt_residuals`]): the
//! stationarity condition is `∇f + Jᵀλ + ν = 0`, where `λ` are the constraint
//! multipliers and `ν` the bound multipliers, both signed: positive where an upper bound
//! is active, negative where a lower bound is.

mod error;
mod ipm;
mod kkt;
mod qp;
pub mod riccati;
mod scaled_objective;
mod solution_builder;
mod sqp;
mod termination;

#[cfg(feature = "ipopt")]
mod ipopt;

pub use ipm::{Ipm, IpmOptions, MuStrategy};
pub use kkt::{kkt_residuals, KktResiduals};
pub use sqp::{Sqp, SqpOptions};

#[cfg(feature = "ipopt")]
pub use ipopt::{Ipopt, IpoptOptions};

use crate::nlp::Nlp;
use serde::{Deserialize, Serialize};

crate::choice! {
    /// How a solve ended.
    pub enum SolveStatus {
        /// KKT conditions hold to the requested tolerance.
        Optimal = "optimal",
        /// KKT conditions hold to the looser, acceptable tolerance.
        Acceptable = "acceptable",
        /// The iteration limit (or a limit on Hessian corrections) was reached first.
        MaxIterations = "max_iterations",
        /// The (linearised) constraints could not be satisfied.
        Infeasible = "infeasible",
        /// The line search or the sub-problem solver could not make progress.
        NumericalError = "numerical_error",
        /// A function value or derivative was not finite.
        InvalidNumber = "invalid_number",
    }
}

impl SolveStatus {
    /// Optimal or acceptable: the solution may be applied.
    pub fn is_success(self) -> bool {
        matches!(self, SolveStatus::Optimal | SolveStatus::Acceptable)
    }
}

/// What a solve cost and how well it converged.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SolveStats {
    /// Iterations taken (0 when the start already satisfied the tolerance).
    pub iterations: usize,
    /// Wall time of the solve, in seconds.
    pub time_s: f64,
    /// `f(x)` at the returned point (NaN when the problem could not be evaluated).
    pub objective: f64,
    /// KKT residuals at the returned point.
    pub kkt: KktResiduals,
    /// Iterations whose Hessian had to be corrected before the step: the interior
    /// point's inertia corrections, SQP's curvature shifts (0 where a back-end does not
    /// report it: IPOPT).
    pub inertia_corrections: usize,
}

/// A primal-dual point and how it was reached.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// How the solve ended; apply `x` only on [`SolveStatus::is_success`].
    pub status: SolveStatus,
    /// The primal point reached, one entry per variable.
    pub x: Vec<f64>,
    /// Constraint multipliers `λ` (signed, see the module doc).
    pub multipliers: Vec<f64>,
    /// Bound multipliers `ν` (signed, see the module doc).
    pub bound_multipliers: Vec<f64>,
    /// Iterations, time, objective and residuals.
    pub stats: SolveStats,
}

/// Where a solve starts: a primal point and, if known, multipliers from an earlier solve.
#[derive(Debug, Clone, Copy)]
pub struct Start<'a> {
    /// The primal point, one entry per variable (projected onto the bounds by SQP).
    pub x: &'a [f64],
    /// Constraint multipliers `λ`; `None` starts them at zero.
    pub multipliers: Option<&'a [f64]>,
    /// Bound multipliers `ν`; `None` starts them at zero.
    pub bound_multipliers: Option<&'a [f64]>,
    /// `x` is an earlier solution shifted in time, close to this problem's: a cold
    /// interior-point start pushes it less far inside its bounds
    /// ([`IpmOptions::shifted_push`]) than a guess ([`IpmOptions::bound_push`]).
    pub shifted: bool,
    /// How far the interior point pushes `x` inside its bounds, relative to each bound's
    /// size, where the start has no multipliers; `None`: its own for the kind of start
    /// ([`IpmOptions::bound_push`], [`IpmOptions::shifted_push`]). A roll-out of a stiff
    /// plant's inputs wants a small push (a model's `solver rollout_push`).
    pub push: Option<f64>,
    /// The barrier parameter to go on from, with all multipliers: a solve resumed from
    /// its own [`Checkpoint`]. `None`: the back-end's own for the kind of start.
    pub barrier: Option<f64>,
}

impl<'a> Start<'a> {
    /// A primal point only (multipliers start at zero).
    pub fn cold(x: &'a [f64]) -> Start<'a> {
        Start {
            x,
            multipliers: None,
            bound_multipliers: None,
            shifted: false,
            push: None,
            barrier: None,
        }
    }

    /// A roll-out of inputs through the dynamics, without multipliers (the season
    /// optimum's start from a controller's inputs): pushed inside its bounds as a shifted
    /// plan is, or by `push` where given.
    pub fn rollout(x: &'a [f64], push: Option<f64>) -> Start<'a> {
        Start {
            shifted: true,
            push,
            ..Start::cold(x)
        }
    }

    /// Where an interrupted solve stood ([`Checkpoint`]): its point, multipliers and
    /// barrier parameter. The interior point goes on from there under its monotone rule,
    /// its point pushed inside its bounds as a warm start's; other back-ends start warm.
    pub fn resumed(checkpoint: &'a Checkpoint) -> Start<'a> {
        Start {
            x: &checkpoint.x,
            multipliers: Some(&checkpoint.multipliers),
            bound_multipliers: Some(&checkpoint.bound_multipliers),
            shifted: false,
            push: None,
            barrier: Some(checkpoint.barrier),
        }
    }

    /// An earlier solution's primal point, shifted in time, without its multipliers (MPC's
    /// `primal` restart).
    pub fn shifted(x: &'a [f64]) -> Start<'a> {
        Start {
            shifted: true,
            ..Start::cold(x)
        }
    }

    /// The same start with the constraint multipliers `λ` of the earlier solution,
    /// shifted like the point; the bound multipliers still start afresh (RL-guided MPC's
    /// restart). An interior point starts its barrier from its initial `μ` all the same,
    /// the Hessian of its first iteration carries the dynamics' curvature (with `λ = 0` it
    /// is the cost's alone), and it pushes the one-sided bounds less far inside
    /// ([`IpmOptions::shifted_slack_push`](crate::solve::IpmOptions::shifted_slack_push)).
    pub fn with_multipliers(self, multipliers: &'a [f64]) -> Start<'a> {
        Start {
            multipliers: Some(multipliers),
            ..self
        }
    }

    /// A full primal-dual point, typically an earlier solution shifted in time (MPC's
    /// `primal-dual` restart).
    pub fn warm(x: &'a [f64], multipliers: &'a [f64], bound_multipliers: &'a [f64]) -> Start<'a> {
        Start {
            x,
            multipliers: Some(multipliers),
            bound_multipliers: Some(bound_multipliers),
            shifted: true,
            push: None,
            barrier: None,
        }
    }
}

/// Where a solve stood after some iteration, in the problem's own units: enough to go on
/// from there ([`Start::resumed`]) when a long solve (a season's optimum) is stopped.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Iterations done.
    pub iteration: usize,
    /// The primal point.
    pub x: Vec<f64>,
    /// Constraint multipliers `λ`.
    pub multipliers: Vec<f64>,
    /// Bound multipliers `ν`.
    pub bound_multipliers: Vec<f64>,
    /// The barrier parameter.
    pub barrier: f64,
}

/// Where a back-end hands its [`Checkpoint`]s, and when: asked each iteration whether it
/// wants one, so that a back-end makes one only when it is kept.
pub trait CheckpointSink: Send {
    /// Whether a checkpoint after `iteration` iterations is wanted.
    fn wants(&mut self, iteration: usize) -> bool;
    /// Keeps the checkpoint it wanted.
    fn keep(&mut self, checkpoint: &Checkpoint);
}

/// A back-end that solves an [`Nlp`].
pub trait Solver {
    /// A short name for reports (`sqp`, `ipopt`).
    fn name(&self) -> &'static str;
    /// Solves from `start`. Never panics on a bad problem; the status tells.
    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution;
    /// Caps the iterations of the following solves (`None`: the solver's own limit).
    /// Back-ends without the notion ignore it.
    fn set_iteration_limit(&mut self, _limit: Option<usize>) {}
    /// Ends the following solves as [`SolveStatus::MaxIterations`] once their Hessian has
    /// needed this many corrections (`None`: no such limit). Back-ends that do not correct
    /// an indefinite Hessian ignore it.
    fn set_correction_limit(&mut self, _limit: Option<usize>) {}
    /// The iterations a warm-started MPC solve should be allowed before a cold start is
    /// the better use of time: SQP converges in two or three from a shifted solution, an
    /// interior-point method in five to ten.
    fn warm_iteration_budget(&self) -> usize {
        15
    }
    /// Whether this back-end restarts fastest from an earlier solution's point and all
    /// its multipliers (SQP, IPOPT), rather than from the point alone with multipliers and
    /// barrier of its own (the interior point): what MPC's
    /// [`WarmStart`](crate::control::WarmStart) defaults to.
    fn restarts_from_multipliers(&self) -> bool {
        true
    }
    /// Hands a [`Checkpoint`] to `sink` after each iteration of the following solves that
    /// it wants one (`None`: no more). True where the back-end can ([`Ipm`]); the others
    /// ignore it.
    fn set_checkpoints(&mut self, _sink: Option<Box<dyn CheckpointSink>>) -> bool {
        false
    }
}
