//! KKT residuals of a primal-dual point, computed the same way for every back-end, so
//! that solutions can be compared and tested independently of the solver that made them.

use crate::nlp::{Nlp, Pattern};
use serde::Serialize;

/// Infinity norms of the first-order optimality conditions.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct KktResiduals {
    /// `‖∇f + Jᵀλ + ν‖∞`.
    pub stationarity: f64,
    /// `‖D (∇f + Jᵀλ + ν)‖∞`, `D` the range of each variable bounded on both sides (1
    /// for the others): the first-order change of the Lagrangian over a variable's range,
    /// so that inputs in different units weigh alike (reported, not used in `max`).
    pub scaled_stationarity: f64,
    /// Largest violation of a bound or constraint.
    pub primal: f64,
    /// Largest `|multiplier| × slack` of its bound, and any multiplier of the wrong sign
    /// (as its magnitude).
    pub complementarity: f64,
}

impl KktResiduals {
    /// The largest of stationarity, primal and complementarity (not the scaled
    /// stationarity): the figure compared with a solver's tolerances.
    pub fn max(&self) -> f64 {
        self.stationarity.max(self.primal).max(self.complementarity)
    }
}

/// Complementarity and sign error of one signed multiplier against its two bounds.
fn complementarity(value: f64, lower: f64, upper: f64, multiplier: f64) -> f64 {
    if multiplier > 0.0 {
        if upper.is_finite() {
            multiplier * (upper - value).max(0.0)
        } else {
            multiplier
        }
    } else if multiplier < 0.0 {
        if lower.is_finite() {
            -multiplier * (value - lower).max(0.0)
        } else {
            -multiplier
        }
    } else {
        0.0
    }
}

fn violation(value: f64, lower: f64, upper: f64) -> f64 {
    (lower - value).max(value - upper).max(0.0)
}

/// The bounds of an NLP, read once.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Bounds {
    pub x_lower: Vec<f64>,
    pub x_upper: Vec<f64>,
    pub g_lower: Vec<f64>,
    pub g_upper: Vec<f64>,
    /// Typical size of each variable ([`Nlp::var_scales`]).
    pub scale: Vec<f64>,
}

impl Bounds {
    pub fn of(nlp: &dyn Nlp) -> Bounds {
        let mut b = Bounds::default();
        b.read(nlp);
        b
    }

    /// Reads the bounds of `nlp` into these vectors (sized to the problem, without
    /// allocating when they have the size already).
    pub fn read(&mut self, nlp: &dyn Nlp) {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let reset = |v: &mut Vec<f64>, len: usize, value: f64| {
            v.clear();
            v.resize(len, value);
        };
        reset(&mut self.x_lower, n, 0.0);
        reset(&mut self.x_upper, n, 0.0);
        reset(&mut self.g_lower, m, 0.0);
        reset(&mut self.g_upper, m, 0.0);
        reset(&mut self.scale, n, 1.0);
        nlp.var_bounds(&mut self.x_lower, &mut self.x_upper);
        nlp.var_scales(&self.x_lower, &self.x_upper, &mut self.scale);
        nlp.con_bounds(&mut self.g_lower, &mut self.g_upper);
    }
}

/// A point with its first-order information, as a solver holds it.
pub(crate) struct PointInfo<'a> {
    pub x: &'a [f64],
    pub g: &'a [f64],
    pub gradient: &'a [f64],
    pub jacobian: &'a [f64],
    pub multipliers: &'a [f64],
    pub bound_multipliers: &'a [f64],
}

/// Residuals from values already computed; `scratch` has one entry per variable.
pub(crate) fn residuals_of(
    point: &PointInfo,
    pattern: &Pattern,
    bounds: &Bounds,
    scratch: &mut [f64],
) -> KktResiduals {
    scratch.copy_from_slice(point.gradient);
    for ((&r, &c), &v) in pattern.rows.iter().zip(&pattern.cols).zip(point.jacobian) {
        scratch[c] += v * point.multipliers[r];
    }
    let mut out = KktResiduals::default();
    for (i, &x) in point.x.iter().enumerate() {
        let (lo, hi, nu) = (
            bounds.x_lower[i],
            bounds.x_upper[i],
            point.bound_multipliers[i],
        );
        let r = (scratch[i] + nu).abs();
        out.stationarity = out.stationarity.max(r);
        out.scaled_stationarity = out.scaled_stationarity.max(r * bounds.scale[i]);
        out.primal = out.primal.max(violation(x, lo, hi));
        out.complementarity = out.complementarity.max(complementarity(x, lo, hi, nu));
    }
    for (j, &g) in point.g.iter().enumerate() {
        let (lo, hi, lambda) = (bounds.g_lower[j], bounds.g_upper[j], point.multipliers[j]);
        out.primal = out.primal.max(violation(g, lo, hi));
        out.complementarity = out.complementarity.max(complementarity(g, lo, hi, lambda));
    }
    if !(out.stationarity.is_finite() && out.primal.is_finite() && out.complementarity.is_finite())
    {
        out.stationarity = f64::INFINITY;
    }
    out
}

/// Whether every value is finite (no NaN, no infinity).
pub(crate) fn all_finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// Total violation `Σ` of the constraints `g_l ≤ g ≤ g_u` (the ℓ₁ infeasibility).
pub(crate) fn l1_violation(g: &[f64], bounds: &Bounds) -> f64 {
    g.iter()
        .zip(bounds.g_lower.iter().zip(&bounds.g_upper))
        .map(|(&v, (&lo, &hi))| violation(v, lo, hi))
        .sum()
}

/// Residuals of `(x, λ, ν)` for `nlp` (conventions of [`crate::solve`]).
pub fn kkt_residuals(
    nlp: &mut dyn Nlp,
    x: &[f64],
    multipliers: &[f64],
    bound_multipliers: &[f64],
) -> KktResiduals {
    let bounds = Bounds::of(nlp);
    let (n, m) = (nlp.n_vars(), nlp.n_cons());
    let mut gradient = vec![0.0; n];
    nlp.gradient(x, &mut gradient);
    let mut g = vec![0.0; m];
    nlp.constraints(x, &mut g);
    let pattern = nlp.jacobian_pattern().clone();
    let mut jacobian = vec![0.0; pattern.len()];
    nlp.jacobian_values(x, &mut jacobian);
    let point = PointInfo {
        x,
        g: &g,
        gradient: &gradient,
        jacobian: &jacobian,
        multipliers,
        bound_multipliers,
    };
    residuals_of(&point, &pattern, &bounds, &mut vec![0.0; n])
}
