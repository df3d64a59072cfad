//! IPOPT's filter line search acceptance test (Wächter & Biegler 2006): a trial point is
//! taken when it improves either the constraint violation `θ` or the barrier objective
//! `φ` enough against the current point and every point remembered in the filter, and,
//! once the violation is small and the step a descent direction of `φ`, only when `φ`
//! decreases by the Armijo rule.

/// The constants of the test (IPOPT's defaults).
const GAMMA_THETA: f64 = 1e-5;
const GAMMA_PHI: f64 = 1e-8;
const DELTA: f64 = 1.0;
const S_THETA: f64 = 1.1;
const S_PHI: f64 = 2.3;
const ETA_PHI: f64 = 1e-8;
const GAMMA_ALPHA: f64 = 0.05;

/// How a trial point was accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Accepted {
    /// By the Armijo rule on `φ` (an `f`-type step: the filter is left alone).
    Objective,
    /// By sufficient decrease of `θ` or `φ` (the current point joins the filter).
    Either,
}

/// The filter: corners `(θ, φ)` of the forbidden region, and the violation bounds.
#[derive(Debug, Clone, Default)]
pub(crate) struct Filter {
    entries: Vec<(f64, f64)>,
    theta_max: f64,
    theta_min: f64,
}

impl Filter {
    /// An empty filter for a barrier problem starting at violation `theta0`.
    pub fn reset(&mut self, theta0: f64) {
        self.entries.clear();
        self.theta_max = 1e4 * theta0.max(1.0);
        self.theta_min = 1e-4 * theta0.max(1.0);
    }

    /// Makes room for `points` remembered points, so that adding them does not allocate.
    pub fn reserve(&mut self, points: usize) {
        self.entries
            .reserve(points.saturating_sub(self.entries.len()));
    }

    /// Remembers the current point `(θ, φ)` with the margins of the test.
    pub fn add(&mut self, theta: f64, phi: f64) {
        let corner = ((1.0 - GAMMA_THETA) * theta, phi - GAMMA_PHI * theta);
        self.entries
            .retain(|&(t, p)| !(t >= corner.0 && p >= corner.1));
        self.entries.push(corner);
    }

    /// Whether `(θ, φ)` lies outside every remembered forbidden region.
    fn admits(&self, theta: f64, phi: f64) -> bool {
        self.entries.iter().all(|&(t, p)| theta < t || phi < p)
    }

    /// The switching condition: the step is a descent direction of `φ` whose predicted
    /// decrease dominates the violation.
    fn switching(alpha: f64, slope: f64, theta: f64) -> bool {
        slope < 0.0 && alpha * (-slope).powf(S_PHI) > DELTA * theta.powf(S_THETA)
    }

    /// Whether the trial point `(θ⁺, φ⁺)` at step `alpha` is accepted from the current
    /// point `(θ, φ)` with directional derivative `slope` of `φ`.
    pub fn accepts(
        &self,
        (theta, phi): (f64, f64),
        slope: f64,
        alpha: f64,
        (trial_theta, trial_phi): (f64, f64),
    ) -> Option<Accepted> {
        if !(trial_theta.is_finite() && trial_phi.is_finite()) || trial_theta > self.theta_max {
            return None;
        }
        if !self.admits(trial_theta, trial_phi) {
            return None;
        }
        if theta <= self.theta_min && Self::switching(alpha, slope, theta) {
            let armijo = trial_phi <= phi + ETA_PHI * alpha * slope;
            return armijo.then_some(Accepted::Objective);
        }
        let enough =
            trial_theta <= (1.0 - GAMMA_THETA) * theta || trial_phi <= phi - GAMMA_PHI * theta;
        enough.then_some(Accepted::Either)
    }

    /// The smallest step the line search tries before it gives up on the direction.
    pub fn min_step(&self, theta: f64, slope: f64) -> f64 {
        let mut bound = GAMMA_THETA;
        if slope < 0.0 {
            bound = bound
                .min(GAMMA_PHI * theta / -slope)
                .min(DELTA * theta.powf(S_THETA) / (-slope).powf(S_PHI));
            if theta <= self.theta_min {
                // Near feasibility the Armijo rule governs: allow tiny steps.
                bound = bound.min(1e-12);
            }
        }
        GAMMA_ALPHA * bound
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_dominated_by_the_filter_is_refused() {
        let mut f = Filter::default();
        f.reset(1.0);
        f.add(1.0, 0.0);
        // Worse in both: refused; better in violation: accepted.
        assert_eq!(f.accepts((2.0, 1.0), 0.0, 1.0, (1.5, 0.5)), None);
        assert_eq!(
            f.accepts((2.0, 1.0), 0.0, 1.0, (0.5, 0.5)),
            Some(Accepted::Either)
        );
    }

    #[test]
    fn near_feasibility_a_descent_step_needs_armijo() {
        let mut f = Filter::default();
        f.reset(1.0);
        // θ = 0 ≤ θ_min, slope −1: φ must fall by 1e-8 α at least.
        assert_eq!(f.accepts((0.0, 1.0), -1.0, 1.0, (0.0, 1.0)), None);
        assert_eq!(
            f.accepts((0.0, 1.0), -1.0, 1.0, (0.0, 0.5)),
            Some(Accepted::Objective)
        );
    }
}
