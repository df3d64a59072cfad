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
//!   default restart, [`WarmStart::Primal`]; with its constraint multipliers, as RL-guided
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

// The iterate's parallel vectors (values, bounds, multipliers, directions) are updated
// index by index; a range loop says that more plainly than zipping five iterators.
#![allow(clippy::needless_range_loop)]

mod filter;
mod structure;

use super::kkt::{all_finite, residuals_of, Bounds, PointInfo};
use super::riccati::Riccati;
use super::{KktResiduals, Solution, SolveStats, SolveStatus, Solver, Start, WarmStart};
use crate::nlp::{Nlp, Pattern};
use filter::Filter;
use std::time::Instant;
use structure::StageMap;

/// Tuning of [`Ipm`].
#[derive(Debug, Clone, PartialEq)]
pub struct IpmOptions {
    /// Iteration limit of a solve.
    pub max_iterations: usize,
    /// KKT residual (IPOPT's scaled optimality error, with `μ = 0`) at which the solve is
    /// optimal.
    pub tolerance: f64,
    /// KKT residual accepted when the method cannot go further or reaches its limit, or
    /// after `acceptable_iterations` iterations in a row below it. 1e-5 (IPOPT's is 1e-6):
    /// on the 40-day season at 4 h, a solve whose reduced Hessian stayed barely corrected
    /// took full steps at an error of 3.6e-6 for 150 iterations, each gaining 7e-9 of the
    /// objective.
    pub acceptable_tolerance: f64,
    /// The run of iterations `acceptable_tolerance` asks for.
    pub acceptable_iterations: usize,
    /// The barrier parameter of a cold start.
    pub initial_mu: f64,
    /// The barrier parameter of a warm start (a start with multipliers).
    pub warm_start_mu: f64,
    /// How far inside its bounds a cold start is pushed, relative to the bound's size.
    pub bound_push: f64,
    /// How far inside its bounds a cold start from an earlier solution, shifted in time
    /// ([`Start::shifted`]), is pushed, relative to the bound's size.
    pub shifted_push: f64,
    /// The same for a variable bounded on one side only, such as a soft band's slack
    /// (`s ≥ 0`, in objective units), when the shifted start also carries the earlier
    /// solution's constraint multipliers ([`Start::with_multipliers`]: RL-guided MPC's
    /// restart). Pushed by `shifted_push` = 1e-2 instead, each slack starts 1e-2 above an
    /// optimum of zero, ten stage rewards' worth of penalty, and the first step is cut to
    /// `α ≈ 0.1` by the slacks' fraction to the boundary. Measured over the paper study's
    /// 744 RL-MPC and RL-MPC-VFO seasons: with 1e-4 and the multipliers, 1.8–2.1 iterations
    /// fewer per step and the longest step within 9.8× its season's median (5.7× with the
    /// terminal region). Plain MPC keeps the bare shifted plan by default: there the same
    /// start lowered the median from 11 to 7 iterations but left the longest steps where
    /// they were (up to 94, inertia-corrected crawls), 13.4× the median in the worst
    /// season, unless a solve that needs three corrections starts again from the bare
    /// plan ([`WarmStart::PrimalMultipliers`](crate::solve::WarmStart::PrimalMultipliers)).
    pub shifted_slack_push: f64,
    /// How far inside its bounds a warm start is pushed, relative to the bound's size.
    pub warm_push: f64,
    /// How the barrier parameter falls.
    pub mu_strategy: MuStrategy,
    /// Print one line per iteration to standard error.
    pub trace: bool,
}

/// How [`Ipm`] lowers the barrier parameter `μ`.
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
    /// failed solves that the monotone rule solved, while on cold starts it halved the
    /// iterations (the season optimum: 60 → 39 and 53 → 29; the first MPC step: 20 → 12).
    Adaptive,
}

impl Default for IpmOptions {
    fn default() -> Self {
        IpmOptions {
            max_iterations: 200,
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

/// The fraction-to-the-boundary step below which a direction from the stage-wise inertia
/// correction is replaced by the whole-horizon correction's. Measured on the 40-day seasons
/// (6 h horizon, every step restarted from the shifted plan): without it, cold solves
/// crawled at steps of 1e-8 … 1e-5 with directions of 1e5 … 1e7 to the 200-iteration cap
/// (3 of 1920 steps on the thesis variant, 4 on the paper's); with it, the longest took
/// 34 and 70 iterations.
const SHORT_CORRECTED_STEP: f64 = 1e-2;

/// Accepted steps in a row, each cut below [`SHORT_CORRECTED_STEP`] by the boundary and
/// each raising the constraint violation, after which the problem's feasibility
/// restoration takes over ([`BlockedSteps`]).
const BLOCKED_STEPS_BEFORE_RESTORATION: usize = 5;

/// Watches for the line search's one blind spot: a run of short steps the filter accepts
/// on the barrier objective while the violation creeps up. Measured on the paper study's
/// longest step (RL-MPC-VFO at 6 h, a perturbed season, step 1372): the linearised
/// constraints asked a rate-limited input to move six times its range, its two rate rows
/// cut every step to `α ≈ 4e-3`, and 125 such steps raised the violation from 2.5e-3 to
/// 8.3e-3 on objective gains of 1e-9; the second-order correction never ran, because no
/// trial was rejected. Re-simulating the states after five of them ended that solve in 29
/// iterations instead of 152. Once a solve: where the blocked run comes back after the
/// restoration, restoring again only starts the run over (a step of the same study, 5 h,
/// cycled 14 times, 92 iterations against 26 without the rule); left to the filter it
/// ends in 36. Over the study's 1116 MPC-type seasons, rewards moved by at most 1e-8.
#[derive(Debug, Default)]
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

/// The pure-Rust structure-exploiting interior-point back-end.
pub struct Ipm {
    /// Its tuning; may be changed between solves.
    pub options: IpmOptions,
    iteration_limit: Option<usize>,
    correction_limit: Option<usize>,
    /// The stage map and the Riccati workspace, kept while the problem's patterns are
    /// the same (an `Ocp` keeps its sizes but changes its Hessian pattern when a terminal
    /// cost comes or goes).
    layout: Option<Layout>,
    /// Inertia corrections made by the last solve.
    corrections: usize,
    /// Feasibility restorations made by the last solve.
    restorations: usize,
    /// The last `δ` of the whole-horizon fallback correction (IPOPT's schedule starts
    /// from a third of it).
    last_delta: f64,
}

/// The stage map of one problem shape, with the patterns it was built from.
struct Layout {
    map: StageMap,
    riccati: Riccati,
    jacobian: Pattern,
    hessian: Pattern,
}

impl Default for Ipm {
    fn default() -> Self {
        Ipm::new(IpmOptions::default())
    }
}

/// The bounds the barrier keeps away from: variables and inequality slacks.
struct Sides {
    lower: Vec<f64>,
    upper: Vec<f64>,
}

impl Sides {
    /// IPOPT's slack move: a bound closer to its value than the rounding level (`1e-12`
    /// relative) is moved out to that distance, so that no slack rounds to zero.
    fn move_bounds(&mut self, v: &[f64], active: impl Fn(usize) -> bool) {
        for (i, &x) in v.iter().enumerate() {
            if !active(i) {
                continue;
            }
            let lo = self.lower[i];
            if lo.is_finite() {
                let least = 1e-12 * lo.abs().max(1.0);
                if x - lo < least {
                    self.lower[i] = x - least;
                }
            }
            let hi = self.upper[i];
            if hi.is_finite() {
                let least = 1e-12 * hi.abs().max(1.0);
                if hi - x < least {
                    self.upper[i] = x + least;
                }
            }
        }
    }

    /// The barrier of entry `i` at value `v` with bound multipliers `zl`, `zu` and
    /// complementarity targets `(μ_l, μ_u)`: its curvature `Σ = zl/(v − lo) + zu/(hi − v)`
    /// and its gradient `−μ_l/(v − lo) + μ_u/(hi − v)` (each side only where its bound is
    /// finite).
    fn barrier(&self, i: usize, v: f64, zl: f64, zu: f64, (mu_l, mu_u): (f64, f64)) -> (f64, f64) {
        let (mut sigma, mut gradient) = (0.0, 0.0);
        if self.lower[i].is_finite() {
            let s = self.slack_lower(i, v);
            sigma += zl / s;
            gradient -= mu_l / s;
        }
        if self.upper[i].is_finite() {
            let s = self.slack_upper(i, v);
            sigma += zu / s;
            gradient += mu_u / s;
        }
        (sigma, gradient)
    }

    /// Adds entry `i`'s complementarity `|z·s − μ|` (largest) and its bound multipliers
    /// (sum and count, for IPOPT's scaling) to `totals`.
    fn complementarity(&self, i: usize, v: f64, zl: f64, zu: f64, mu: f64, totals: &mut Totals) {
        if self.lower[i].is_finite() {
            totals.add(zl, self.slack_lower(i, v), mu);
        }
        if self.upper[i].is_finite() {
            totals.add(zu, self.slack_upper(i, v), mu);
        }
    }

    /// `Σ ln(slack)` of entry `i` over its finite bounds.
    fn log_slacks(&self, i: usize, v: f64) -> f64 {
        let mut sum = 0.0;
        if self.lower[i].is_finite() {
            sum += self.slack_lower(i, v).ln();
        }
        if self.upper[i].is_finite() {
            sum += self.slack_upper(i, v).ln();
        }
        sum
    }

    /// Starting bound multipliers of entry `i` from a signed multiplier `nu` (positive on
    /// the upper bound), each at least `μ / slack` (centred).
    fn centred(&self, i: usize, v: f64, nu: f64, mu: f64) -> (f64, f64) {
        let zl = if self.lower[i].is_finite() {
            (-nu).max(mu / self.slack_lower(i, v))
        } else {
            0.0
        };
        let zu = if self.upper[i].is_finite() {
            nu.max(mu / self.slack_upper(i, v))
        } else {
            0.0
        };
        (zl, zu)
    }

    /// The Newton step of entry `i`'s bound multipliers for a primal step `dv` and
    /// complementarity targets `(μ_l, μ_u)`: `μ/s − z ∓ (z/s) dv`.
    fn multiplier_step(
        &self,
        i: usize,
        v: f64,
        dv: f64,
        (zl, zu): (f64, f64),
        (mu_l, mu_u): (f64, f64),
    ) -> (f64, f64) {
        let dzl = if self.lower[i].is_finite() {
            let s = self.slack_lower(i, v);
            mu_l / s - zl - zl / s * dv
        } else {
            0.0
        };
        let dzu = if self.upper[i].is_finite() {
            let s = self.slack_upper(i, v);
            mu_u / s - zu + zu / s * dv
        } else {
            0.0
        };
        (dzl, dzu)
    }

    /// IPOPT's safeguard on entry `i`'s bound multipliers: each within
    /// `[μ/(κ s), κ μ/s]`, `κ = 1e10`.
    fn safeguard(&self, i: usize, v: f64, zl: &mut f64, zu: &mut f64, mu: f64) {
        const KAPPA: f64 = 1e10;
        let clamp = |z: &mut f64, s: f64| *z = z.max(mu / (KAPPA * s)).min(KAPPA * mu / s);
        if self.lower[i].is_finite() {
            clamp(zl, self.slack_lower(i, v));
        }
        if self.upper[i].is_finite() {
            clamp(zu, self.slack_upper(i, v));
        }
    }

    fn slack_lower(&self, i: usize, v: f64) -> f64 {
        v - self.lower[i]
    }
    fn slack_upper(&self, i: usize, v: f64) -> f64 {
        self.upper[i] - v
    }
}

/// Complementarity totals of the optimality error.
#[derive(Debug, Default)]
struct Totals {
    /// Largest `|z·s − μ|`.
    largest: f64,
    /// Sum and count of the bound multipliers.
    sum: f64,
    count: usize,
}

impl Totals {
    fn add(&mut self, z: f64, slack: f64, mu: f64) {
        self.largest = self.largest.max((z * slack - mu).abs());
        self.sum += z;
        self.count += 1;
    }
}

/// Bounds relaxed where they are equal (a fixed variable keeps a sliver of interior).
fn relaxed(lower: &[f64], upper: &[f64]) -> Sides {
    let mut lo = lower.to_vec();
    let mut hi = upper.to_vec();
    for (l, h) in lo.iter_mut().zip(hi.iter_mut()) {
        if *h - *l <= 1e-12 * l.abs().max(1.0) {
            *l -= 1e-8 * l.abs().max(1.0);
            *h += 1e-8 * h.abs().max(1.0);
        }
    }
    Sides {
        lower: lo,
        upper: hi,
    }
}

/// `v` moved inside `[lo, hi]` by IPOPT's bound push with fraction `kappa`.
fn pushed(v: f64, lo: f64, hi: f64, kappa: f64) -> f64 {
    // The push from a bound: relative to the bound's size, at most `kappa` of the range
    // (an infinite range, one-sided bounds, leaves the first).
    let push = |bound: f64| (kappa * bound.abs().max(1.0)).min(kappa * (hi - lo));
    let mut v = v;
    if lo.is_finite() {
        v = v.max(lo + push(lo));
    }
    if hi.is_finite() {
        v = v.min(hi - push(hi));
    }
    if lo.is_finite() && hi.is_finite() && !(v > lo && v < hi) {
        v = 0.5 * (lo + hi);
    }
    v
}

/// The largest step in `(0, 1]` along `d` that keeps every slack of `v` in `[lo, hi]` at
/// least the fraction `1 − tau` of its value, and above the rounding level of its bound
/// (`1e-12` relative; IPOPT moves such bounds instead): with `τ` near 1 a slack of an
/// active bound could otherwise round to zero.
fn max_step(v: &[f64], d: &[f64], sides: &Sides, tau: f64, active: impl Fn(usize) -> bool) -> f64 {
    let floor =
        |s: f64, bound: f64| ((1.0 - tau) * s).max((1e-12 * bound.abs().max(1.0)).min(0.01 * s));
    let mut alpha: f64 = 1.0;
    for i in 0..v.len() {
        if !active(i) {
            continue;
        }
        if sides.lower[i].is_finite() && d[i] < 0.0 {
            let s = sides.slack_lower(i, v[i]);
            alpha = alpha.min((s - floor(s, sides.lower[i])) / -d[i]);
        }
        if sides.upper[i].is_finite() && d[i] > 0.0 {
            let s = sides.slack_upper(i, v[i]);
            alpha = alpha.min((s - floor(s, sides.upper[i])) / d[i]);
        }
    }
    alpha.max(0.0)
}

/// The largest step that keeps multipliers `z` (with directions `dz`) at least `1 − tau`
/// of their value.
fn max_dual_step(z: &[f64], dz: &[f64], tau: f64) -> f64 {
    z.iter().zip(dz).fold(1.0_f64, |a, (&z, &d)| {
        if d < 0.0 && z > 0.0 {
            a.min(-tau * z / d)
        } else {
            a
        }
    })
}

/// The primal-dual iterate.
#[derive(Debug, Clone)]
struct Iterate {
    w: Vec<f64>,
    /// Slacks of the inequality rows (unused on dynamics rows).
    t: Vec<f64>,
    lambda: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    vl: Vec<f64>,
    vu: Vec<f64>,
}

/// Values at the current point.
struct Eval {
    f: f64,
    c: Vec<f64>,
    gradient: Vec<f64>,
    jacobian: Vec<f64>,
    hessian: Vec<f64>,
}

/// The Newton direction.
#[derive(Debug, Clone, Default)]
struct Direction {
    w: Vec<f64>,
    t: Vec<f64>,
    lambda: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    vl: Vec<f64>,
    vu: Vec<f64>,
}

impl Ipm {
    /// An interior-point solver with `options`.
    pub fn new(options: IpmOptions) -> Ipm {
        Ipm {
            options,
            iteration_limit: None,
            correction_limit: None,
            layout: None,
            corrections: 0,
            restorations: 0,
            last_delta: 0.0,
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

    /// The fallback of the stage-wise correction: factorises with one `δ` on every stage
    /// from the one that failed on (states and controls), the smallest of IPOPT's schedule
    /// that gives the right inertia,
    /// then narrows it down towards the threshold by bisection (in `log δ`, between the
    /// last failure and the first success): a `δ` far above the threshold damps the step
    /// along a direction of negative curvature to a crawl, one just above it lets the
    /// step run to the bound that ends that direction, where the barrier's curvature
    /// takes over.
    fn factor(riccati: &mut Riccati, last_delta: &mut f64) -> Option<f64> {
        let mut first = match riccati.factor(0.0) {
            Ok(()) => return Some(0.0),
            Err(e) => e.stage,
        };
        let mut delta = if *last_delta == 0.0 {
            1e-4
        } else {
            (*last_delta / 3.0).max(1e-20)
        };
        let growth = if *last_delta == 0.0 { 100.0 } else { 8.0 };
        let mut failed = delta / growth;
        loop {
            match riccati.factor_from(delta, first) {
                Ok(()) => break,
                // The missing curvature shows up earlier: shift from there on, same δ.
                Err(e) if e.stage < first => first = e.stage,
                Err(_) => {
                    failed = delta;
                    delta *= growth;
                    if delta > 1e20 {
                        return None;
                    }
                }
            }
        }
        let mut current = true;
        for _ in 0..4 {
            let middle = (failed * delta).sqrt();
            current = riccati.factor_from(middle, first).is_ok();
            if current {
                delta = middle;
            } else {
                failed = middle;
            }
        }
        // The last try failed: the factorisation held is not `δ`'s.
        if !current && riccati.factor_from(delta, first).is_err() {
            return None;
        }
        *last_delta = delta;
        Some(delta)
    }
}

/// Everything of one solve that does not change between iterations.
struct Setup {
    n: usize,
    m: usize,
    /// Variable bounds as the barrier sees them.
    vars: Sides,
    /// Row bounds of the inequality rows (±∞ on dynamics rows, which have none).
    rows: Sides,
    /// Dynamics rows' right-hand side (`g_l = g_u`).
    target: Vec<f64>,
    is_dynamics: Vec<bool>,
    /// `1 / D²` per variable.
    shift: Vec<f64>,
    bounds: Bounds,
}

impl Setup {
    /// `θ`: ℓ₁ violation of the dynamics and of `c − t` on the other rows.
    fn violation(&self, c: &[f64], t: &[f64]) -> f64 {
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
    fn barrier(&self, f: f64, w: &[f64], t: &[f64], mu: f64) -> f64 {
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

    fn warm_iteration_budget(&self) -> usize {
        40
    }

    /// The shifted primal point with a fresh barrier: see [`WarmStart`].
    fn warm_start(&self) -> WarmStart {
        WarmStart::Primal
    }

    fn solve(&mut self, nlp: &mut dyn Nlp, start: Start<'_>) -> Solution {
        let clock = Instant::now();
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let bounds = Bounds::of(nlp);
        let mut x = start.x.to_vec();
        x.resize(n, 0.0);
        let trace = self.options.trace;
        let fail = |status, x: Vec<f64>| Solution {
            status,
            x,
            multipliers: vec![0.0; m],
            bound_multipliers: vec![0.0; n],
            stats: SolveStats {
                iterations: 0,
                time_s: clock.elapsed().as_secs_f64(),
                objective: f64::NAN,
                kkt: KktResiduals::default(),
                inertia_corrections: 0,
            },
        };
        // The stage map, rebuilt when the problem's patterns changed.
        let fits = self.layout.as_ref().is_some_and(|l| {
            l.jacobian == *nlp.jacobian_pattern() && l.hessian == *nlp.hessian_pattern()
        });
        if !fits {
            let Some(stages) = nlp.stages() else {
                return fail(SolveStatus::NumericalError, x);
            };
            let (jacobian, hessian) = (nlp.jacobian_pattern(), nlp.hessian_pattern());
            match StageMap::new(&stages, n, m, jacobian, hessian) {
                Ok(map) => {
                    self.layout = Some(Layout {
                        riccati: map.riccati(),
                        map,
                        jacobian: jacobian.clone(),
                        hessian: hessian.clone(),
                    });
                }
                Err(_) => return fail(SolveStatus::NumericalError, x),
            }
        }
        let Some(mut layout) = self.layout.take() else {
            return fail(SolveStatus::NumericalError, x);
        };
        let solution = self.run(
            nlp,
            &layout.map,
            &mut layout.riccati,
            bounds,
            &x,
            start,
            clock,
        );
        self.layout = Some(layout);
        if trace {
            eprintln!(
                "ipm end: {:?} after {} iterations, KKT {:.1e}",
                solution.status,
                solution.stats.iterations,
                solution.stats.kkt.max()
            );
        }
        solution
    }
}

impl Ipm {
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        nlp: &mut dyn Nlp,
        map: &StageMap,
        riccati: &mut Riccati,
        bounds: Bounds,
        x: &[f64],
        start: Start<'_>,
        clock: Instant,
    ) -> Solution {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let opts = self.options.clone();
        let max_iterations = self
            .iteration_limit
            .map_or(opts.max_iterations, |l| l.min(opts.max_iterations));
        let is_dynamics: Vec<bool> = (0..m).map(|r| map.is_dynamics(r)).collect();
        let mut row_lower = bounds.g_lower.clone();
        let mut row_upper = bounds.g_upper.clone();
        for r in 0..m {
            if is_dynamics[r] {
                row_lower[r] = f64::NEG_INFINITY;
                row_upper[r] = f64::INFINITY;
            }
        }
        let mut setup = Setup {
            n,
            m,
            vars: relaxed(&bounds.x_lower, &bounds.x_upper),
            rows: relaxed(&row_lower, &row_upper),
            target: bounds.g_lower.clone(),
            is_dynamics,
            shift: bounds.scale.iter().map(|d| 1.0 / (d * d)).collect(),
            bounds,
        };
        self.corrections = 0;
        self.restorations = 0;
        self.last_delta = 0.0;
        let warm = start.multipliers.is_some() && start.bound_multipliers.is_some();
        // A shifted plan with its constraint multipliers: close enough to start the
        // one-sided bounds near them ([`IpmOptions::shifted_slack_push`]).
        let close = start.shifted && start.multipliers.is_some() && !warm;
        let mut mu = if warm {
            opts.warm_start_mu
        } else {
            opts.initial_mu
        };
        let kappa = if warm {
            opts.warm_push
        } else if start.shifted {
            opts.shifted_push
        } else {
            opts.bound_push
        };
        let mu_min = opts.tolerance / 10.0;

        // The starting iterate.
        let mut it = Iterate {
            w: x.to_vec(),
            t: vec![0.0; m],
            lambda: start.multipliers.map_or(vec![0.0; m], <[f64]>::to_vec),
            zl: vec![0.0; n],
            zu: vec![0.0; n],
            vl: vec![0.0; m],
            vu: vec![0.0; m],
        };
        it.lambda.resize(m, 0.0);
        let mut nu = start
            .bound_multipliers
            .map_or(vec![0.0; n], <[f64]>::to_vec);
        nu.resize(n, 0.0);
        for i in 0..n {
            let (lo, hi) = (setup.vars.lower[i], setup.vars.upper[i]);
            let k = if warm {
                kappa * setup.bounds.scale[i].clamp(1e-3, 1.0)
            } else if close && !(lo.is_finite() && hi.is_finite()) {
                opts.shifted_slack_push
            } else {
                kappa
            };
            it.w[i] = pushed(it.w[i], lo, hi, k);
            (it.zl[i], it.zu[i]) = setup.vars.centred(i, it.w[i], nu[i], mu);
        }
        let mut c = vec![0.0; m];
        let f0 = nlp.objective(&it.w);
        nlp.constraints(&it.w, &mut c);
        if !(f0.is_finite() && all_finite(&c)) {
            return self.finish(
                nlp,
                &setup,
                it,
                SolveStatus::InvalidNumber,
                0,
                f64::NAN,
                clock,
            );
        }
        for r in 0..m {
            if setup.is_dynamics[r] {
                continue;
            }
            let (lo, hi) = (setup.rows.lower[r], setup.rows.upper[r]);
            it.t[r] = pushed(c[r], lo, hi, kappa);
            (it.vl[r], it.vu[r]) = setup.rows.centred(r, it.t[r], it.lambda[r], mu);
        }

        let jp = nlp.jacobian_pattern().clone();
        let hp_len = nlp.hessian_pattern().len();
        let mut ev = Eval {
            f: 0.0,
            c: vec![0.0; m],
            gradient: vec![0.0; n],
            jacobian: vec![0.0; jp.len()],
            hessian: vec![0.0; hp_len],
        };
        let mut filter = Filter::default();
        let mut filter_fresh = true;
        let mut acceptable_run = 0;
        let mut blocked = BlockedSteps::default();
        let mut d = Direction {
            w: vec![0.0; n],
            t: vec![0.0; m],
            lambda: vec![0.0; m],
            zl: vec![0.0; n],
            zu: vec![0.0; n],
            vl: vec![0.0; m],
            vu: vec![0.0; m],
        };
        let mut probe = d.clone();
        let mut plain = d.clone();
        let mut scratch = vec![0.0; n];
        let mut diag = vec![0.0; n];
        let mut rhs = Rhs::new(n, m);
        let mut plain_rhs = Rhs::new(n, m);
        let mut trial_w = vec![0.0; n];
        let mut trial_t = vec![0.0; m];
        let mut trial_c = vec![0.0; m];
        let mut dyn_residual = vec![0.0; m];
        let mut residual_i = vec![0.0; m];
        // A warm start keeps the monotone rule: see [`MuStrategy`].
        let mut adaptive = (opts.mu_strategy == MuStrategy::Adaptive && !warm).then(|| Adaptive {
            free: true,
            references: Vec::new(),
            mu_max: (1e3 * average_complementarity(&setup, &it, None))
                .min(1e5)
                .max(mu_min),
        });

        for iteration in 0..=max_iterations {
            ev.f = nlp.evaluate_all(
                &it.w,
                1.0,
                &it.lambda,
                &mut ev.c,
                &mut ev.gradient,
                &mut ev.jacobian,
                &mut ev.hessian,
            );
            let finite = ev.f.is_finite()
                && all_finite(&ev.c)
                && all_finite(&ev.gradient)
                && all_finite(&ev.jacobian)
                && all_finite(&ev.hessian);
            if !finite {
                return self.finish(
                    nlp,
                    &setup,
                    it,
                    SolveStatus::InvalidNumber,
                    iteration,
                    ev.f,
                    clock,
                );
            }
            // Optimality errors with μ = 0 and with the current μ.
            let error = |mu_target: f64, it: &Iterate, scratch: &mut [f64]| -> f64 {
                optimality_error(&setup, &jp, &ev, it, mu_target, scratch)
            };
            let e0 = error(0.0, &it, &mut scratch);
            acceptable_run = if e0 <= opts.acceptable_tolerance {
                acceptable_run + 1
            } else {
                0
            };
            if e0 <= opts.tolerance {
                return self.finish(
                    nlp,
                    &setup,
                    it,
                    SolveStatus::Optimal,
                    iteration,
                    ev.f,
                    clock,
                );
            }
            if acceptable_run > opts.acceptable_iterations || iteration == max_iterations {
                let status = if e0 <= opts.acceptable_tolerance {
                    SolveStatus::Acceptable
                } else {
                    SolveStatus::MaxIterations
                };
                return self.finish(nlp, &setup, it, status, iteration, ev.f, clock);
            }
            // The barrier parameter: IPOPT's monotone rule, or in the adaptive strategy's
            // free mode Mehrotra's probing (after the factorisation, below), guarded by the
            // optimality error's progress.
            if let Some(adaptive) = adaptive.as_mut() {
                if adaptive.free && !adaptive.progressed(e0) {
                    adaptive.free = false;
                    mu = mu_min.max(0.8 * average_complementarity(&setup, &it, None));
                    filter_fresh = true;
                } else if !adaptive.free && error(mu, &it, &mut scratch) <= 10.0 * mu {
                    adaptive.enter_free_mode(e0);
                }
            }
            if adaptive.as_ref().is_none_or(|a| !a.free) {
                while mu > mu_min && error(mu, &it, &mut scratch) <= 10.0 * mu {
                    mu = mu_min.max((0.2 * mu).min(mu.powf(1.5)));
                    filter_fresh = true;
                }
            }
            let theta = setup.violation(&ev.c, &it.t);

            // The condensed matrices: Hessian, barrier curvature, `Jᵀ Σ J` of the rows.
            for i in 0..n {
                (diag[i], _) = setup.vars.barrier(i, it.w[i], it.zl[i], it.zu[i], (mu, mu));
            }
            for r in 0..m {
                residual_i[r] = if setup.is_dynamics[r] {
                    0.0
                } else {
                    ev.c[r] - it.t[r]
                };
                dyn_residual[r] = ev.c[r] - setup.target[r];
            }
            barrier_row_terms(
                &setup,
                &it,
                Targets::plain(mu),
                &mut rhs.sigma_t,
                &mut rhs.row_terms,
            );
            map.fill_matrices(
                riccati,
                &ev.hessian,
                &diag,
                &ev.jacobian,
                &rhs.sigma_t,
                &setup.shift,
            );
            // Stage by stage, else one shift from the failing stage on.
            let corrected = match riccati.factor_corrected() {
                Ok(count) => Some(count),
                Err(_) => Self::factor(riccati, &mut self.last_delta).map(|d| usize::from(d > 0.0)),
            };
            let Some(corrected) = corrected else {
                return self.finish(
                    nlp,
                    &setup,
                    it,
                    SolveStatus::NumericalError,
                    iteration,
                    ev.f,
                    clock,
                );
            };
            // The largest stage correction, for the trace.
            let delta = riccati.corrections().iter().fold(0.0_f64, |a, &d| a.max(d));
            if corrected > 0 {
                self.corrections += 1;
                if self
                    .correction_limit
                    .is_some_and(|limit| self.corrections >= limit)
                {
                    return self.finish(
                        nlp,
                        &setup,
                        it,
                        SolveStatus::MaxIterations,
                        iteration,
                        ev.f,
                        clock,
                    );
                }
            }
            let direction = Newton {
                setup: &setup,
                jp: &jp,
                map,
                ev: &ev,
                it: &it,
                residual_i: &residual_i,
                dyn_residual: &dyn_residual,
            };
            // Mehrotra's probing in free mode: the affine-scaling step (μ = 0) to the
            // boundary, and the complementarity it would leave, `μ_aff`; then `μ = σ μ̄`
            // with `σ = (μ_aff / μ̄)³` (at most 100), `μ̄` the average complementarity now.
            let free = adaptive.as_ref().is_some_and(|a| a.free);
            let probed =
                !free || direction.solve(riccati, Targets::plain(0.0), &mut rhs, &mut probe);
            if free && probed {
                let average = average_complementarity(&setup, &it, None);
                let primal = primal_reach(&setup, &it, &probe.w, &probe.t, 1.0);
                let dual = dual_reach(&it, &probe, 1.0);
                let affine = average_complementarity(&setup, &it, Some((&probe, primal, dual)));
                let sigma = if average > 0.0 {
                    (affine / average).powi(3).min(100.0)
                } else {
                    0.0
                };
                let mu_max = adaptive.as_ref().map_or(f64::INFINITY, |a| a.mu_max);
                let mu_probed = (sigma * average).clamp(mu_min, mu_max);
                if mu_probed != mu {
                    mu = mu_probed;
                    filter_fresh = true;
                }
            }
            if filter_fresh {
                filter.reset(theta);
                filter_fresh = false;
            }
            // In free mode Mehrotra's corrector (the predictor's `Δs Δz` taken off the
            // targets), kept where it descends the barrier objective and reaches farther
            // to the boundary than the plain step; far from the central path it can point
            // anywhere.
            let targets = Targets {
                mu,
                predictor: free.then_some(&probe),
            };
            let mut ok = probed && direction.solve(riccati, targets, &mut rhs, &mut d);
            if ok && free {
                let corrected = reach(&setup, &it, &d);
                ok = direction.solve(riccati, Targets::plain(mu), &mut plain_rhs, &mut plain);
                let descends = barrier_slope(&setup, &ev.gradient, &it, &d, mu) < 0.0;
                if ok && (!descends || reach(&setup, &it, &plain) >= corrected) {
                    std::mem::swap(&mut d, &mut plain);
                    std::mem::swap(&mut rhs, &mut plain_rhs);
                }
            }
            if !ok {
                return self.finish(
                    nlp,
                    &setup,
                    it,
                    SolveStatus::NumericalError,
                    iteration,
                    ev.f,
                    clock,
                );
            }
            let tau = (1.0 - mu).max(0.99);
            let mut alpha_max = primal_reach(&setup, &it, &d.w, &d.t, tau);
            // A stage-wise correction lifts each stage just above positive definiteness;
            // where the gains of the recursion then amplify a nearly flat direction into a
            // step the boundary cuts below `SHORT_CORRECTED_STEP`, the whole-horizon `δ`
            // (IPOPT's correction) gives this iteration's direction instead.
            if corrected > 0 && alpha_max < SHORT_CORRECTED_STEP {
                let uniform = Self::factor(riccati, &mut self.last_delta).is_some()
                    && direction.solve(riccati, Targets::plain(mu), &mut plain_rhs, &mut plain);
                if uniform {
                    std::mem::swap(&mut d, &mut plain);
                    std::mem::swap(&mut rhs, &mut plain_rhs);
                    alpha_max = primal_reach(&setup, &it, &d.w, &d.t, tau);
                }
            }
            let alpha_dual = dual_reach(&it, &d, tau);

            // Filter line search.
            let phi = setup.barrier(ev.f, &it.w, &it.t, mu);
            let slope = barrier_slope(&setup, &ev.gradient, &it, &d, mu);
            let tiny =
                d.w.iter()
                    .zip(&it.w)
                    .all(|(dw, w)| dw.abs() <= 1e-14 * (1.0 + w.abs()));
            // The filter's smallest step, and never below rounding (near feasibility
            // the filter's is zero).
            let alpha_min = filter.min_step(theta, slope).max(1e-16 * alpha_max);
            let mut alpha = alpha_max;
            let mut accepted = None;
            let mut first = true;
            while (alpha > 0.0 && alpha >= alpha_min) || tiny {
                for i in 0..n {
                    trial_w[i] = it.w[i] + alpha * d.w[i];
                }
                for r in 0..m {
                    trial_t[r] = it.t[r] + alpha * d.t[r];
                }
                let f = nlp.objective(&trial_w);
                nlp.constraints(&trial_w, &mut trial_c);
                let trial_theta = setup.violation(&trial_c, &trial_t);
                let trial_phi = setup.barrier(f, &trial_w, &trial_t, mu);
                if tiny {
                    accepted = Some(filter::Accepted::Either);
                    break;
                }
                if opts.trace && first {
                    eprintln!(
                        "    trial α {alpha:.2e}: θ {theta:.3e} → {trial_theta:.3e}, φ {phi:.12e} → {trial_phi:.12e}, slope {slope:.2e}"
                    );
                }
                if let Some(a) =
                    filter.accepts((theta, phi), slope, alpha, (trial_theta, trial_phi))
                {
                    accepted = Some(a);
                    break;
                }
                if first && trial_theta >= theta {
                    // Second-order corrections against the Maratos effect.
                    if let Some(a) = self.second_order_correction(
                        nlp,
                        map,
                        riccati,
                        &setup,
                        &jp,
                        &ev,
                        &it,
                        alpha,
                        theta,
                        phi,
                        slope,
                        &filter,
                        mu,
                        &rhs,
                        &residual_i,
                        &mut trial_w,
                        &mut trial_t,
                    ) {
                        accepted = Some(a);
                        break;
                    }
                }
                first = false;
                alpha *= 0.5;
            }
            let Some(kind) = accepted else {
                // No acceptable step: the problem's own restoration, once per barrier
                // problem, else the end.
                if restore(nlp, &setup, &mut it, kappa, &mut trial_c) {
                    self.restorations += 1;
                    filter.add(theta, phi);
                    filter_fresh = true;
                    continue;
                }
                let status = if e0 <= opts.acceptable_tolerance {
                    SolveStatus::Acceptable
                } else if theta > opts.acceptable_tolerance {
                    // Stuck away from feasibility: the constraints cannot be met from here.
                    SolveStatus::Infeasible
                } else {
                    SolveStatus::NumericalError
                };
                return self.finish(nlp, &setup, it, status, iteration, ev.f, clock);
            };
            if kind == filter::Accepted::Either {
                filter.add(theta, phi);
            }
            // A short step that raised the violation (measured again: the trial may be a
            // corrected one); after a run of them, restore from the current point instead.
            let raised = alpha < SHORT_CORRECTED_STEP && {
                nlp.constraints(&trial_w, &mut trial_c);
                setup.violation(&trial_c, &trial_t) > theta
            };
            if blocked.restoration_due(raised) && restore(nlp, &setup, &mut it, kappa, &mut trial_c)
            {
                self.restorations += 1;
                filter.add(theta, phi);
                filter_fresh = true;
                continue;
            }
            if opts.trace {
                eprintln!(
                    "ipm {iteration:3} f {:.10e} err {e0:.1e} θ {theta:.1e} μ {mu:.1e} δ {delta:.1e} α {alpha:.2e}{}",
                    ev.f,
                    if free { " free" } else { "" }
                );
            }
            // Take the step (the trial point may be a corrected one).
            it.w.copy_from_slice(&trial_w);
            for r in 0..m {
                if !setup.is_dynamics[r] {
                    it.t[r] = trial_t[r];
                }
            }
            let a = alpha.min(1.0);
            for r in 0..m {
                it.lambda[r] += a * d.lambda[r];
            }
            for i in 0..n {
                it.zl[i] += alpha_dual * d.zl[i];
                it.zu[i] += alpha_dual * d.zu[i];
            }
            for r in 0..m {
                it.vl[r] += alpha_dual * d.vl[r];
                it.vu[r] += alpha_dual * d.vu[r];
            }
            setup.vars.move_bounds(&it.w, |_| true);
            let dynamics = setup.is_dynamics.clone();
            setup.rows.move_bounds(&it.t, |r| !dynamics[r]);
            safeguard_multipliers(&setup, &mut it, mu);
        }
        // The last iteration returns inside the loop; this is for the type checker.
        self.finish(
            nlp,
            &setup,
            it,
            SolveStatus::MaxIterations,
            max_iterations,
            f64::NAN,
            clock,
        )
    }

    /// Up to four second-order corrections of a rejected full step: the dynamics and row
    /// residuals re-linearised at the trial point. On acceptance `trial_*` hold the
    /// corrected point.
    #[allow(clippy::too_many_arguments)]
    fn second_order_correction(
        &mut self,
        nlp: &mut dyn Nlp,
        map: &StageMap,
        riccati: &mut Riccati,
        setup: &Setup,
        jp: &Pattern,
        ev: &Eval,
        it: &Iterate,
        alpha: f64,
        theta: f64,
        phi: f64,
        slope: f64,
        filter: &Filter,
        mu: f64,
        rhs: &Rhs,
        residual_i: &[f64],
        trial_w: &mut [f64],
        trial_t: &mut [f64],
    ) -> Option<filter::Accepted> {
        let (n, m) = (setup.n, setup.m);
        let mut c_trial = vec![0.0; m];
        nlp.constraints(trial_w, &mut c_trial);
        let mut soc_dyn: Vec<f64> = (0..m)
            .map(|r| alpha * (ev.c[r] - setup.target[r]) + (c_trial[r] - setup.target[r]))
            .collect();
        let mut soc_rows: Vec<f64> = (0..m)
            .map(|r| {
                if setup.is_dynamics[r] {
                    0.0
                } else {
                    alpha * residual_i[r] + (c_trial[r] - trial_t[r])
                }
            })
            .collect();
        let mut theta_old = setup.violation(&c_trial, trial_t);
        let mut step = vec![0.0; n];
        let mut lambda = it.lambda.clone();
        let mut step_t = vec![0.0; m];
        for _ in 0..4 {
            // The condensed gradient with the corrected row residuals.
            let mut gradient = rhs.condensed.to_vec();
            for ((&r, &col), &v) in jp.rows.iter().zip(&jp.cols).zip(&ev.jacobian) {
                if !setup.is_dynamics[r] {
                    gradient[col] += v * rhs.sigma_t[r] * (soc_rows[r] - residual_i[r]);
                }
            }
            map.fill_vectors(riccati, &gradient, &soc_dyn);
            if !riccati.solve() {
                return None;
            }
            map.read_solution(riccati, &mut step, &mut lambda);
            step_t.fill(0.0);
            for ((&r, &col), &v) in jp.rows.iter().zip(&jp.cols).zip(&ev.jacobian) {
                if !setup.is_dynamics[r] {
                    step_t[r] += v * step[col];
                }
            }
            for r in 0..m {
                if !setup.is_dynamics[r] {
                    step_t[r] += soc_rows[r];
                }
            }
            let tau = (1.0 - mu).max(0.99);
            let alpha_soc = primal_reach(setup, it, &step, &step_t, tau);
            for i in 0..n {
                trial_w[i] = it.w[i] + alpha_soc * step[i];
            }
            for r in 0..m {
                trial_t[r] = it.t[r] + alpha_soc * step_t[r];
            }
            let f = nlp.objective(trial_w);
            nlp.constraints(trial_w, &mut c_trial);
            let trial_theta = setup.violation(&c_trial, trial_t);
            let trial_phi = setup.barrier(f, trial_w, trial_t, mu);
            if let Some(a) = filter.accepts((theta, phi), slope, alpha, (trial_theta, trial_phi)) {
                return Some(a);
            }
            if trial_theta > 0.99 * theta_old {
                break;
            }
            theta_old = trial_theta;
            for r in 0..m {
                soc_dyn[r] = alpha_soc * soc_dyn[r] + (c_trial[r] - setup.target[r]);
                if !setup.is_dynamics[r] {
                    soc_rows[r] = alpha_soc * soc_rows[r] + (c_trial[r] - trial_t[r]);
                }
            }
        }
        None
    }

    /// The solution in ghm's conventions, with its KKT residuals on the original bounds.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        nlp: &mut dyn Nlp,
        setup: &Setup,
        it: Iterate,
        status: SolveStatus,
        iterations: usize,
        objective: f64,
        clock: Instant,
    ) -> Solution {
        let (n, m) = (setup.n, setup.m);
        let mut x = it.w;
        // The relaxed bounds of fixed variables: back onto the true bounds.
        for i in 0..n {
            x[i] = x[i]
                .max(setup.bounds.x_lower[i])
                .min(setup.bounds.x_upper[i]);
        }
        let nu: Vec<f64> = (0..n).map(|i| it.zu[i] - it.zl[i]).collect();
        let lambda = it.lambda;
        let mut kkt = KktResiduals::default();
        let mut objective = objective;
        if status != SolveStatus::InvalidNumber && x.iter().all(|v| v.is_finite()) {
            let mut g = vec![0.0; m];
            let mut gradient = vec![0.0; n];
            let pattern = nlp.jacobian_pattern().clone();
            let mut jacobian = vec![0.0; pattern.len()];
            objective = nlp.objective(&x);
            nlp.constraints(&x, &mut g);
            nlp.gradient(&x, &mut gradient);
            nlp.jacobian_values(&x, &mut jacobian);
            let mut scratch = vec![0.0; n];
            kkt = residuals_of(
                &PointInfo {
                    x: &x,
                    g: &g,
                    gradient: &gradient,
                    jacobian: &jacobian,
                    multipliers: &lambda,
                    bound_multipliers: &nu,
                },
                &pattern,
                &setup.bounds,
                &mut scratch,
            );
        }
        Solution {
            status,
            x,
            multipliers: lambda,
            bound_multipliers: nu,
            stats: SolveStats {
                iterations,
                time_s: clock.elapsed().as_secs_f64(),
                objective,
                kkt,
                inertia_corrections: self.corrections,
            },
        }
    }
}

/// IPOPT's optimality error `E_μ`: stationarity scaled by `s_d`, the constraint
/// violation, complementarity against `μ` scaled by `s_c`.
fn optimality_error(
    setup: &Setup,
    jp: &Pattern,
    ev: &Eval,
    it: &Iterate,
    mu: f64,
    scratch: &mut [f64],
) -> f64 {
    let (n, m) = (setup.n, setup.m);
    scratch.copy_from_slice(&ev.gradient);
    for ((&r, &c), &v) in jp.rows.iter().zip(&jp.cols).zip(&ev.jacobian) {
        scratch[c] += v * it.lambda[r];
    }
    let mut stationarity = 0.0_f64;
    let mut primal = 0.0_f64;
    let mut bounds = Totals::default();
    for (i, s) in scratch.iter().enumerate().take(n) {
        stationarity = stationarity.max((s - it.zl[i] + it.zu[i]).abs());
        setup
            .vars
            .complementarity(i, it.w[i], it.zl[i], it.zu[i], mu, &mut bounds);
    }
    let multiplier_sum: f64 = it.lambda.iter().map(|l| l.abs()).sum();
    for r in 0..m {
        if setup.is_dynamics[r] {
            primal = primal.max((ev.c[r] - setup.target[r]).abs());
            continue;
        }
        primal = primal.max((ev.c[r] - it.t[r]).abs());
        stationarity = stationarity.max((-it.lambda[r] - it.vl[r] + it.vu[r]).abs());
        setup
            .rows
            .complementarity(r, it.t[r], it.vl[r], it.vu[r], mu, &mut bounds);
    }
    const S_MAX: f64 = 100.0;
    let s_d =
        ((multiplier_sum + bounds.sum) / ((m + bounds.count).max(1) as f64)).max(S_MAX) / S_MAX;
    let s_c = (bounds.sum / (bounds.count.max(1) as f64)).max(S_MAX) / S_MAX;
    (stationarity / s_d).max(primal).max(bounds.largest / s_c)
}

/// Per inequality row: `Σ_t` into `sigma_t`, `−μ/(t − t_l) + μ/(t_u − t)` into
/// `row_terms` (both 0 on dynamics rows).
fn barrier_row_terms(
    setup: &Setup,
    it: &Iterate,
    targets: Targets<'_>,
    sigma_t: &mut [f64],
    row_terms: &mut [f64],
) {
    for r in 0..setup.m {
        (sigma_t[r], row_terms[r]) = if setup.is_dynamics[r] {
            (0.0, 0.0)
        } else {
            setup
                .rows
                .barrier(r, it.t[r], it.vl[r], it.vu[r], targets.row(r))
        };
    }
}

/// Adds `J_Iᵀ (Σ_t r_I + row_terms)` to the condensed gradient.
fn add_row_gradient(
    jp: &Pattern,
    jacobian: &[f64],
    setup: &Setup,
    sigma_t: &[f64],
    residual_i: &[f64],
    row_terms: &[f64],
    condensed: &mut [f64],
) {
    for ((&r, &c), &v) in jp.rows.iter().zip(&jp.cols).zip(jacobian) {
        if !setup.is_dynamics[r] {
            condensed[c] += v * (sigma_t[r] * residual_i[r] + row_terms[r]);
        }
    }
}

/// The slack, row-multiplier and bound-multiplier parts of the direction from `d.w`.
#[allow(clippy::too_many_arguments)]
fn complete_direction(
    setup: &Setup,
    jp: &Pattern,
    jacobian: &[f64],
    it: &Iterate,
    targets: Targets<'_>,
    sigma_t: &[f64],
    residual_i: &[f64],
    row_terms: &[f64],
    new_lambda: &[f64],
    d: &mut Direction,
) {
    let (n, m) = (setup.n, setup.m);
    d.t.fill(0.0);
    for ((&r, &c), &v) in jp.rows.iter().zip(&jp.cols).zip(jacobian) {
        if !setup.is_dynamics[r] {
            d.t[r] += v * d.w[c];
        }
    }
    for r in 0..m {
        if setup.is_dynamics[r] {
            d.t[r] = 0.0;
            d.lambda[r] = new_lambda[r] - it.lambda[r];
            d.vl[r] = 0.0;
            d.vu[r] = 0.0;
            continue;
        }
        d.t[r] += residual_i[r];
        // λ⁺ = Σ_t Δt − μ/(t − t_l) + μ/(t_u − t).
        d.lambda[r] = sigma_t[r] * d.t[r] + row_terms[r] - it.lambda[r];
        (d.vl[r], d.vu[r]) =
            setup
                .rows
                .multiplier_step(r, it.t[r], d.t[r], (it.vl[r], it.vu[r]), targets.row(r));
    }
    for i in 0..n {
        (d.zl[i], d.zu[i]) =
            setup
                .vars
                .multiplier_step(i, it.w[i], d.w[i], (it.zl[i], it.zu[i]), targets.var(i));
    }
}

/// `∇φᵀ d`, the barrier objective's directional derivative.
fn barrier_slope(setup: &Setup, gradient: &[f64], it: &Iterate, d: &Direction, mu: f64) -> f64 {
    let mut slope = 0.0;
    for i in 0..setup.n {
        let (_, g) = setup.vars.barrier(i, it.w[i], 0.0, 0.0, (mu, mu));
        slope += (gradient[i] + g) * d.w[i];
    }
    for r in 0..setup.m {
        if !setup.is_dynamics[r] {
            let (_, g) = setup.rows.barrier(r, it.t[r], 0.0, 0.0, (mu, mu));
            slope += g * d.t[r];
        }
    }
    slope
}

/// IPOPT's safeguard on every bound multiplier ([`Sides::safeguard`]).
fn safeguard_multipliers(setup: &Setup, it: &mut Iterate, mu: f64) {
    for i in 0..setup.n {
        setup
            .vars
            .safeguard(i, it.w[i], &mut it.zl[i], &mut it.zu[i], mu);
    }
    for r in (0..setup.m).filter(|&r| !setup.is_dynamics[r]) {
        setup
            .rows
            .safeguard(r, it.t[r], &mut it.vl[r], &mut it.vu[r], mu);
    }
}

/// The problem's own feasibility restoration: re-simulated states, the point pushed
/// inside its bounds and the slacks set from the rows. Returns whether it lowered the
/// violation.
fn restore(nlp: &mut dyn Nlp, setup: &Setup, it: &mut Iterate, kappa: f64, c: &mut [f64]) -> bool {
    nlp.constraints(&it.w, c);
    let before = setup.violation(c, &it.t);
    let mut w = it.w.clone();
    if !nlp.restore_feasibility(&mut w) {
        return false;
    }
    for (i, v) in w.iter_mut().enumerate() {
        *v = pushed(
            *v,
            setup.vars.lower[i],
            setup.vars.upper[i],
            kappa.min(1e-6),
        );
    }
    let f = nlp.objective(&w);
    nlp.constraints(&w, c);
    if !(f.is_finite() && all_finite(c)) {
        return false;
    }
    let mut t = it.t.clone();
    for r in 0..setup.m {
        if !setup.is_dynamics[r] {
            t[r] = pushed(
                c[r],
                setup.rows.lower[r],
                setup.rows.upper[r],
                kappa.min(1e-6),
            );
        }
    }
    let after = setup.violation(c, &t);
    if after >= 0.9 * before {
        return false;
    }
    it.w = w;
    it.t = t;
    true
}

/// The right-hand side of one Newton direction and what completes it.
struct Rhs {
    /// The condensed gradient (objective, barriers, inequality rows).
    condensed: Vec<f64>,
    /// `Σ_t` per inequality row.
    sigma_t: Vec<f64>,
    /// The rows' barrier gradients.
    row_terms: Vec<f64>,
    /// The new dynamics multipliers the recursion gives.
    new_lambda: Vec<f64>,
}

impl Rhs {
    /// Zeros for `n` variables and `m` constraint rows.
    fn new(n: usize, m: usize) -> Rhs {
        Rhs {
            condensed: vec![0.0; n],
            sigma_t: vec![0.0; m],
            row_terms: vec![0.0; m],
            new_lambda: vec![0.0; m],
        }
    }
}

/// Everything a Newton direction needs once the matrices are factorised: one
/// factorisation serves the probing step (`μ = 0`) and the step itself.
struct Newton<'a> {
    setup: &'a Setup,
    jp: &'a Pattern,
    map: &'a StageMap,
    ev: &'a Eval,
    it: &'a Iterate,
    /// `c − t` on inequality rows (0 on dynamics rows).
    residual_i: &'a [f64],
    dyn_residual: &'a [f64],
}

impl Newton<'_> {
    /// The direction for barrier parameter `mu` into `d` (its right-hand side left in
    /// `rhs` for the second-order corrections); false when the recursion fails or the
    /// step is not finite.
    fn solve(
        &self,
        riccati: &mut Riccati,
        targets: Targets<'_>,
        rhs: &mut Rhs,
        d: &mut Direction,
    ) -> bool {
        let (setup, it, ev) = (self.setup, self.it, self.ev);
        for i in 0..setup.n {
            let (_, g) = setup
                .vars
                .barrier(i, it.w[i], it.zl[i], it.zu[i], targets.var(i));
            rhs.condensed[i] = ev.gradient[i] + g;
        }
        barrier_row_terms(setup, it, targets, &mut rhs.sigma_t, &mut rhs.row_terms);
        add_row_gradient(
            self.jp,
            &ev.jacobian,
            setup,
            &rhs.sigma_t,
            self.residual_i,
            &rhs.row_terms,
            &mut rhs.condensed,
        );
        self.map
            .fill_vectors(riccati, &rhs.condensed, self.dyn_residual);
        if !riccati.solve() {
            return false;
        }
        rhs.new_lambda.copy_from_slice(&it.lambda);
        self.map
            .read_solution(riccati, &mut d.w, &mut rhs.new_lambda);
        complete_direction(
            setup,
            self.jp,
            &ev.jacobian,
            it,
            targets,
            &rhs.sigma_t,
            self.residual_i,
            &rhs.row_terms,
            &rhs.new_lambda,
            d,
        );
        all_finite(&d.w)
    }
}

/// The state of [`MuStrategy::Adaptive`].
struct Adaptive {
    /// Free mode (`μ` from probing) or the monotone rule.
    free: bool,
    /// The optimality errors of the last free-mode iterations (at most four).
    references: Vec<f64>,
    /// The largest `μ` probing may give: 1000 × the starting average complementarity.
    mu_max: f64,
}

impl Adaptive {
    /// IPOPT's progress test of free mode: with four errors remembered, `error` must be
    /// below 0.9999 of one of them. Remembers `error` when it passes.
    fn progressed(&mut self, error: f64) -> bool {
        const REMEMBERED: usize = 4;
        let progressed = self.references.len() < REMEMBERED
            || self.references.iter().any(|&r| error <= 0.9999 * r);
        if progressed {
            if self.references.len() == REMEMBERED {
                self.references.remove(0);
            }
            self.references.push(error);
        }
        progressed
    }

    /// Back to free mode after the monotone rule solved its barrier problem.
    fn enter_free_mode(&mut self, error: f64) {
        self.free = true;
        self.references.clear();
        self.references.push(error);
    }
}

/// The average `z·s` over every finite bound of the variables and inequality slacks, now
/// or, with `step = (d, primal, dual)`, after a step of `primal` along `d`'s primal part and
/// `dual` along its multipliers.
fn average_complementarity(
    setup: &Setup,
    it: &Iterate,
    step: Option<(&Direction, f64, f64)>,
) -> f64 {
    let (primal, dual) = step.map_or((0.0, 0.0), |(_, p, q)| (p, q));
    let along = |part: fn(&Direction) -> &[f64], k: usize| step.map_or(0.0, |(d, _, _)| part(d)[k]);
    let mut totals = (0.0, 0usize);
    let mut add = |z: f64, dz: f64, s: f64, ds: f64| {
        totals.0 += (z + dual * dz) * (s + primal * ds);
        totals.1 += 1;
    };
    for i in 0..setup.n {
        let (lo, hi) = (setup.vars.lower[i], setup.vars.upper[i]);
        let dw = along(|d| &d.w, i);
        if lo.is_finite() {
            add(it.zl[i], along(|d| &d.zl, i), it.w[i] - lo, dw);
        }
        if hi.is_finite() {
            add(it.zu[i], along(|d| &d.zu, i), hi - it.w[i], -dw);
        }
    }
    for r in (0..setup.m).filter(|&r| !setup.is_dynamics[r]) {
        let (lo, hi) = (setup.rows.lower[r], setup.rows.upper[r]);
        let dt = along(|d| &d.t, r);
        if lo.is_finite() {
            add(it.vl[r], along(|d| &d.vl, r), it.t[r] - lo, dt);
        }
        if hi.is_finite() {
            add(it.vu[r], along(|d| &d.vu, r), hi - it.t[r], -dt);
        }
    }
    if totals.1 == 0 {
        0.0
    } else {
        totals.0 / totals.1 as f64
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

/// The largest primal step along `dw` (variables) and `dt` (inequality slacks), by
/// [`max_step`] with fraction to the boundary `tau`.
fn primal_reach(setup: &Setup, it: &Iterate, dw: &[f64], dt: &[f64], tau: f64) -> f64 {
    max_step(&it.w, dw, &setup.vars, tau, |_| true).min(max_step(
        &it.t,
        dt,
        &setup.rows,
        tau,
        |r| !setup.is_dynamics[r],
    ))
}

/// The largest step of every bound multiplier along `d` with fraction `tau`.
fn dual_reach(it: &Iterate, d: &Direction, tau: f64) -> f64 {
    max_dual_step(&it.zl, &d.zl, tau)
        .min(max_dual_step(&it.zu, &d.zu, tau))
        .min(max_dual_step(&it.vl, &d.vl, tau))
        .min(max_dual_step(&it.vu, &d.vu, tau))
}

/// The shorter of the primal and dual steps along `d` to the boundary (fraction 0.99).
fn reach(setup: &Setup, it: &Iterate, d: &Direction) -> f64 {
    primal_reach(setup, it, &d.w, &d.t, 0.99).min(dual_reach(it, d, 0.99))
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
