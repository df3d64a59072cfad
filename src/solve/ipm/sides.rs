//! The bounds the barrier keeps the iterate away from (of the variables, and of the
//! inequality rows' slacks), and everything measured against them: IPOPT's bound push of a
//! start, the barrier's curvature and gradient, complementarity, the bound multipliers'
//! Newton step and safeguard, the fraction to the boundary.

// Parallel vectors are updated index by index; a range loop says that more plainly than
// zipping them.
#![allow(clippy::needless_range_loop)]

/// The bounds the barrier keeps away from: of the variables, or of the inequality slacks.
#[derive(Debug, Clone)]
pub(super) struct Sides {
    pub lower: Vec<f64>,
    pub upper: Vec<f64>,
}

impl Sides {
    /// `len` entries, every bound zero.
    pub fn zeros(len: usize) -> Sides {
        Sides {
            lower: vec![0.0; len],
            upper: vec![0.0; len],
        }
    }

    /// Relaxes bounds that are equal (a fixed variable keeps a sliver of interior).
    pub fn relax_equal_bounds(&mut self) {
        for (l, h) in self.lower.iter_mut().zip(self.upper.iter_mut()) {
            if *h - *l <= 1e-12 * l.abs().max(1.0) {
                *l -= 1e-8 * l.abs().max(1.0);
                *h += 1e-8 * h.abs().max(1.0);
            }
        }
    }

    /// IPOPT's slack move: a bound closer to its value than the rounding level (`1e-12`
    /// relative) is moved out to that distance, so that no slack rounds to zero.
    pub fn move_bounds(&mut self, v: &[f64], active: impl Fn(usize) -> bool) {
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
    pub fn barrier(
        &self,
        i: usize,
        v: f64,
        zl: f64,
        zu: f64,
        (mu_l, mu_u): (f64, f64),
    ) -> (f64, f64) {
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
    pub fn complementarity(
        &self,
        i: usize,
        v: f64,
        zl: f64,
        zu: f64,
        mu: f64,
        totals: &mut Totals,
    ) {
        if self.lower[i].is_finite() {
            totals.add(zl, self.slack_lower(i, v), mu);
        }
        if self.upper[i].is_finite() {
            totals.add(zu, self.slack_upper(i, v), mu);
        }
    }

    /// `Σ ln(slack)` of entry `i` over its finite bounds.
    pub fn log_slacks(&self, i: usize, v: f64) -> f64 {
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
    pub fn centred(&self, i: usize, v: f64, nu: f64, mu: f64) -> (f64, f64) {
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
    pub fn multiplier_step(
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
    pub fn safeguard(&self, i: usize, v: f64, zl: &mut f64, zu: &mut f64, mu: f64) {
        const KAPPA: f64 = 1e10;
        let clamp = |z: &mut f64, s: f64| *z = z.max(mu / (KAPPA * s)).min(KAPPA * mu / s);
        if self.lower[i].is_finite() {
            clamp(zl, self.slack_lower(i, v));
        }
        if self.upper[i].is_finite() {
            clamp(zu, self.slack_upper(i, v));
        }
    }

    pub fn slack_lower(&self, i: usize, v: f64) -> f64 {
        v - self.lower[i]
    }
    pub fn slack_upper(&self, i: usize, v: f64) -> f64 {
        self.upper[i] - v
    }
}

/// Complementarity totals of the optimality error.
#[derive(Debug, Default)]
pub(super) struct Totals {
    /// Largest `|z·s − μ|`.
    pub largest: f64,
    /// Sum and count of the bound multipliers.
    pub sum: f64,
    pub count: usize,
}

impl Totals {
    fn add(&mut self, z: f64, slack: f64, mu: f64) {
        self.largest = self.largest.max((z * slack - mu).abs());
        self.sum += z;
        self.count += 1;
    }
}

/// `v` moved inside `[lo, hi]` by IPOPT's bound push with fraction `kappa`.
///
/// A `v` that is not a number (a start whose states could not be simulated) lands at the
/// lower bound's push, or at the upper's where only that is finite: a finite start far
/// from the dynamics, which the solve may still recover from (RL-guided MPC's warm
/// starts on the GreenLight tomato, `docs/results.md`).
pub(super) fn pushed(v: f64, lo: f64, hi: f64, kappa: f64) -> f64 {
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
pub(super) fn max_step(
    v: &[f64],
    d: &[f64],
    sides: &Sides,
    tau: f64,
    active: impl Fn(usize) -> bool,
) -> f64 {
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
pub(super) fn max_dual_step(z: &[f64], dz: &[f64], tau: f64) -> f64 {
    z.iter().zip(dz).fold(1.0_f64, |a, (&z, &d)| {
        if d < 0.0 && z > 0.0 {
            a.min(-tau * z / d)
        } else {
            a
        }
    })
}

#[cfg(test)]
mod tests {
    use super::pushed;

    #[test]
    fn a_value_that_is_not_a_number_lands_at_a_bounds_push() {
        assert_eq!(pushed(f64::NAN, 0.0, 10.0, 1e-2), 1e-2);
        assert_eq!(pushed(f64::NAN, f64::NEG_INFINITY, 10.0, 1e-2), 9.9);
        assert!(pushed(f64::NAN, f64::NEG_INFINITY, f64::INFINITY, 1e-2).is_nan());
        // Finite values inside stay; outside they are pushed in.
        assert_eq!(pushed(5.0, 0.0, 10.0, 1e-2), 5.0);
        assert_eq!(pushed(-3.0, 0.0, 10.0, 1e-2), 1e-2);
    }
}
