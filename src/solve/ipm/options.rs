//! The tuning of the interior point ([`IpmOptions`]) and its barrier strategies
//! ([`MuStrategy`]).

/// Tuning of [`Ipm`](super::Ipm).
#[derive(Debug, Clone, PartialEq)]
pub struct IpmOptions {
    /// Iteration limit of a solve. 500: the GreenLight tomato's MPC study met six steps in
    /// its first 33 days whose cold starts each ran to the old 200 and failed; with room,
    /// each converged in 333–362 iterations (32–44 s, within the 300 s control period;
    /// `docs/benchmarks.md`, "Room for a cold start"). No lettuce solve comes near 200.
    pub max_iterations: usize,
    /// KKT residual (IPOPT's scaled optimality error, with `μ = 0`) at which the solve is
    /// optimal, in the problem's own units where its objective is scaled
    /// ([`Nlp::objective_scaling`](crate::nlp::Nlp::objective_scaling)).
    pub tolerance: f64,
    /// KKT residual accepted when the method cannot go further or reaches its limit, or
    /// after `acceptable_iterations` iterations in a row below it. 1e-5 (IPOPT's is 1e-6):
    /// on the 40-day season at 4 h, a solve whose reduced Hessian stayed barely corrected
    /// took full steps at an error between 1e-6 and 1e-5 for over a hundred iterations, each
    /// gaining next to nothing of the objective (`docs/benchmarks-history.md`, "Restarting
    /// from the shifted plan, not from its multipliers").
    pub acceptable_tolerance: f64,
    /// The run of iterations `acceptable_tolerance` asks for.
    pub acceptable_iterations: usize,
    /// The barrier parameter of a cold start.
    pub initial_mu: f64,
    /// The barrier parameter of a warm start (a start with multipliers), times the
    /// problem's objective scale.
    pub warm_start_mu: f64,
    /// How far inside its bounds a cold start is pushed, relative to the bound's size.
    pub bound_push: f64,
    /// How far inside its bounds a cold start from an earlier solution, shifted in time
    /// ([`Start::shifted`]), is pushed, relative to the bound's size.
    ///
    /// [`Start::shifted`]: crate::solve::Start::shifted
    pub shifted_push: f64,
    /// The same for a variable bounded on one side only, such as a soft band's slack
    /// (`s ≥ 0`, in objective units), when the shifted start also carries the earlier
    /// solution's constraint multipliers ([`Start::with_multipliers`]: RL-guided MPC's
    /// restart). Pushed by `shifted_push` = 1e-2 instead, each slack starts 1e-2 above an
    /// optimum of zero, ten stage rewards' worth of penalty, and the first step is cut to
    /// `α ≈ 0.1` by the slacks' fraction to the boundary. Measured over the paper study's
    /// RL-MPC and RL-MPC-VFO seasons: with 1e-4 and the multipliers, fewer iterations per
    /// step and the longest step still within 10× its season's median. Plain MPC
    /// keeps the bare shifted plan by default: there the same start lowered the median but
    /// left the longest steps where they were (inertia-corrected crawls), past 10× the
    /// median in the worst seasons, unless a solve that needs three corrections starts
    /// again from the bare plan
    /// ([`WarmStart::PrimalMultipliers`](crate::control::WarmStart::PrimalMultipliers);
    /// measured: `docs/benchmarks-history.md`, "Session 17: RL-guided MPC's closer
    /// restart").
    ///
    /// [`Start::with_multipliers`]: crate::solve::Start::with_multipliers
    pub shifted_slack_push: f64,
    /// How far inside its bounds a warm start is pushed, relative to the bound's size.
    pub warm_push: f64,
    /// How the barrier parameter falls.
    pub mu_strategy: MuStrategy,
    /// Print one line per iteration to standard error.
    pub trace: bool,
}

/// How [`Ipm`](super::Ipm) lowers the barrier parameter `μ`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MuStrategy {
    /// IPOPT's monotone rule: `μ` stays until its barrier problem is solved to `10 μ`,
    /// then falls by `μ ← max(ε/10, min(μ/5, μ^1.5))`.
    Monotone,
    /// IPOPT's adaptive strategy, for cold starts: in its free mode every iteration takes
    /// `μ` from Mehrotra's probing (the affine-scaling step's complementarity); when the
    /// optimality error stops falling (not below 0.9999 of one of the last four), the
    /// monotone rule takes over from `0.8 ×` the average complementarity until its barrier
    /// problem is solved, and free mode resumes. A warm start keeps the monotone rule:
    /// measured on the 40-day seasons, probing from a warm start's tiny complementarity
    /// failed solves that the monotone rule solved, while on cold starts it took far fewer
    /// iterations (the season optimum and the first MPC step; `docs/benchmarks-history.md`,
    /// "An adaptive barrier for cold starts").
    Adaptive,
}

impl Default for IpmOptions {
    fn default() -> Self {
        IpmOptions {
            max_iterations: 500,
            tolerance: 1e-8,
            acceptable_tolerance: 1e-5,
            acceptable_iterations: 10,
            initial_mu: 1e-3,
            warm_start_mu: 1e-9,
            bound_push: 1e-1,
            shifted_push: 1e-2,
            shifted_slack_push: 1e-4,
            warm_push: 1e-7,
            mu_strategy: MuStrategy::Adaptive,
            trace: false,
        }
    }
}
