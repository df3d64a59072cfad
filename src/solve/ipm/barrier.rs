//! The barrier parameter `μ` and how it falls ([`MuStrategy`]): IPOPT's monotone rule, or
//! its adaptive strategy, whose free mode takes `μ` from Mehrotra's probing with the
//! monotone rule as its safeguard.

use super::iterate::{Direction, Iterate};
use super::options::{IpmOptions, MuStrategy};
use super::problem::BarrierProblem;

/// The barrier parameter of one solve and the state of its strategy.
#[derive(Debug, Clone)]
pub(super) struct Barrier {
    mu: f64,
    /// `ε σ / 10` (`σ` the objective's scale): below it `μ` does not fall.
    mu_min: f64,
    /// The adaptive strategy's state; `None` under the monotone rule.
    adaptive: Option<Adaptive>,
}

impl Barrier {
    /// The barrier of a solve starting at `mu` (a warm start keeps the monotone rule: see
    /// [`MuStrategy`]); `average` gives the starting point's average complementarity,
    /// which bounds the adaptive strategy's `μ`. Of an objective scaled by
    /// `objective_scale` the floor of `μ` is scaled too: the solve ends on its error in the
    /// problem's own units, and a barrier below the tolerance there gains nothing.
    pub fn new(
        options: &IpmOptions,
        (mu, objective_scale): (f64, f64),
        warm: bool,
        average: impl FnOnce() -> f64,
    ) -> Barrier {
        let mu_min = options.tolerance * objective_scale / 10.0;
        let adaptive = (options.mu_strategy == MuStrategy::Adaptive && !warm).then(|| Adaptive {
            free: true,
            references: RecentErrors::default(),
            mu_max: (1e3 * average()).min(1e5).max(mu_min),
        });
        Barrier {
            mu,
            mu_min,
            adaptive,
        }
    }

    /// The barrier parameter now.
    pub fn mu(&self) -> f64 {
        self.mu
    }

    /// In the adaptive strategy's free mode: `μ` comes from probing ([`Barrier::probe`]).
    pub fn is_free(&self) -> bool {
        self.adaptive.as_ref().is_some_and(|a| a.free)
    }

    /// The update before the factorisation, from the optimality error `error` (with
    /// `μ = 0`): the adaptive strategy leaves free mode when the error stops falling (`μ`
    /// from `average`, the average complementarity) and returns to it once the monotone
    /// rule has solved its barrier problem; under the monotone rule, `μ` falls while
    /// `error_at(μ) ≤ 10 μ`. True when `μ` changed: a new barrier problem.
    pub fn update(
        &mut self,
        error: f64,
        mut error_at: impl FnMut(f64) -> f64,
        average: impl FnOnce() -> f64,
    ) -> bool {
        let mut changed = false;
        if let Some(adaptive) = self.adaptive.as_mut() {
            if adaptive.free && !adaptive.progressed(error) {
                adaptive.free = false;
                self.mu = self.mu_min.max(0.8 * average());
                changed = true;
            } else if !adaptive.free && error_at(self.mu) <= 10.0 * self.mu {
                adaptive.enter_free_mode(error);
            }
        }
        if !self.is_free() {
            while self.mu > self.mu_min && error_at(self.mu) <= 10.0 * self.mu {
                self.mu = self.mu_min.max((0.2 * self.mu).min(self.mu.powf(1.5)));
                changed = true;
            }
        }
        changed
    }

    /// Mehrotra's probing in free mode: the affine-scaling step `probe` (`μ = 0`) to the
    /// boundary, and the complementarity `μ_aff` it would leave; then `μ = σ μ̄` with
    /// `σ = (μ_aff / μ̄)³` (at most 100), `μ̄` the average complementarity now. True when
    /// `μ` changed.
    pub fn probe(&mut self, problem: &BarrierProblem, it: &Iterate, probe: &Direction) -> bool {
        let average = average_complementarity(problem, it, None);
        let primal = it.primal_reach(problem, &probe.w, &probe.t, 1.0);
        let dual = it.dual_reach(probe, 1.0);
        let affine = average_complementarity(problem, it, Some((probe, primal, dual)));
        let sigma = if average > 0.0 {
            (affine / average).powi(3).min(100.0)
        } else {
            0.0
        };
        let mu_max = self.adaptive.as_ref().map_or(f64::INFINITY, |a| a.mu_max);
        let mu_probed = (sigma * average).clamp(self.mu_min, mu_max);
        if mu_probed != self.mu {
            self.mu = mu_probed;
            true
        } else {
            false
        }
    }
}

/// The state of [`MuStrategy::Adaptive`].
#[derive(Debug, Clone)]
struct Adaptive {
    /// Free mode (`μ` from probing) or the monotone rule.
    free: bool,
    /// The optimality errors of the last free-mode iterations.
    references: RecentErrors,
    /// The largest `μ` probing may give: 1000 × the starting average complementarity.
    mu_max: f64,
}

impl Adaptive {
    /// IPOPT's progress test of free mode: with four errors remembered, `error` must be
    /// below 0.9999 of one of them. Remembers `error` when it passes.
    fn progressed(&mut self, error: f64) -> bool {
        let progressed =
            !self.references.is_full() || self.references.iter().any(|&r| error <= 0.9999 * r);
        if progressed {
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

/// The last four optimality errors, oldest first (no allocation).
#[derive(Debug, Clone, Copy, Default)]
struct RecentErrors {
    errors: [f64; RecentErrors::REMEMBERED],
    len: usize,
}

impl RecentErrors {
    const REMEMBERED: usize = 4;

    fn is_full(&self) -> bool {
        self.len == Self::REMEMBERED
    }

    fn iter(&self) -> impl Iterator<Item = &f64> {
        self.errors[..self.len].iter()
    }

    fn clear(&mut self) {
        self.len = 0;
    }

    /// Remembers `error`, forgetting the oldest when four are remembered.
    fn push(&mut self, error: f64) {
        if self.is_full() {
            self.errors.copy_within(1.., 0);
            self.len -= 1;
        }
        self.errors[self.len] = error;
        self.len += 1;
    }
}

/// The average `z·s` over every finite bound of the variables and inequality slacks, now
/// or, with `step = (d, primal, dual)`, after a step of `primal` along `d`'s primal part and
/// `dual` along its multipliers.
pub(super) fn average_complementarity(
    problem: &BarrierProblem,
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
    for i in 0..problem.n {
        let (lo, hi) = (problem.vars.lower[i], problem.vars.upper[i]);
        let dw = along(|d| &d.w, i);
        if lo.is_finite() {
            add(it.zl[i], along(|d| &d.zl, i), it.w[i] - lo, dw);
        }
        if hi.is_finite() {
            add(it.zu[i], along(|d| &d.zu, i), hi - it.w[i], -dw);
        }
    }
    for r in (0..problem.m).filter(|&r| !problem.is_dynamics[r]) {
        let (lo, hi) = (problem.rows.lower[r], problem.rows.upper[r]);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_errors_are_remembered_the_oldest_forgotten_first() {
        let mut recent = RecentErrors::default();
        for e in [1.0, 2.0, 3.0, 4.0, 5.0] {
            recent.push(e);
        }
        assert!(recent.is_full());
        assert_eq!(
            recent.iter().copied().collect::<Vec<_>>(),
            [2.0, 3.0, 4.0, 5.0]
        );
        recent.clear();
        recent.push(6.0);
        assert_eq!(recent.iter().copied().collect::<Vec<_>>(), [6.0]);
    }

    #[test]
    fn free_mode_needs_progress_against_one_of_four_errors() {
        let mut adaptive = Adaptive {
            free: true,
            references: RecentErrors::default(),
            mu_max: 1.0,
        };
        // Fewer than four remembered: always progress.
        for e in [1.0, 1.0, 1.0, 1.0] {
            assert!(adaptive.progressed(e));
        }
        assert!(!adaptive.progressed(1.0));
        assert!(adaptive.progressed(0.5));
    }
}
