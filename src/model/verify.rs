//! Derivative verification: the exact (dual-number) Jacobian of the discrete step and the
//! Hessian of `λᵀ(x⁺, stage terms)` against central finite differences, with steps scaled
//! per variable.

use crate::model::Plant;
use crate::model::StepDerivatives;

/// Where a number of the check is NaN or infinite: rows are the step tape's outputs
/// `(x⁺, stage terms, y(x⁺))` (see [`Plant::step_quantity`](crate::model::Plant::step_quantity)), columns the variables
/// `(x, u)` differentiated against (see [`Plant::describe_variable`](crate::model::Plant::describe_variable)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Entry {
    /// The value of output `row`.
    Value {
        /// The step tape output.
        row: usize,
    },
    /// `∂ row / ∂ col` of the exact Jacobian.
    Jacobian {
        /// The step tape output.
        row: usize,
        /// The variable.
        col: usize,
    },
    /// `∂² (Σ wᵢ outᵢ) / ∂ row ∂ col` of the exact Hessian of a weighted sum of the outputs.
    Hessian {
        /// The first variable.
        row: usize,
        /// The second variable.
        col: usize,
    },
}

/// The first non-finite value or exact derivative the check met.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NonFiniteEntry {
    /// The base point, an index into the points checked.
    pub point: usize,
    /// Which number.
    pub entry: Entry,
    /// Its value: NaN, `inf` or `-inf`.
    pub value: f64,
}

/// The largest relative errors found, and the first number that was not finite.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct VerifyReport {
    /// Base points checked.
    pub points: usize,
    /// Largest relative error of a step-Jacobian entry (w.r.t. `x` and `u`) against central
    /// differences, over all points.
    pub jacobian_max_rel_error: f64,
    /// Largest relative error of a Hessian entry of the weighted step outputs against
    /// central differences of the exact gradient, over all points.
    pub hessian_max_rel_error: f64,
    /// The first value, Jacobian or Hessian entry that is NaN or infinite: the derivatives
    /// cannot be right there, whatever the errors say.
    pub non_finite: Option<NonFiniteEntry>,
}

impl VerifyReport {
    /// The larger of the two errors; NaN when a comparison was NaN, infinite when a value
    /// or derivative was not finite (so that `max() <= tolerance` is a complete test).
    pub fn max(&self) -> f64 {
        if self.non_finite.is_some() {
            return f64::INFINITY;
        }
        worse(self.jacobian_max_rel_error, self.hessian_max_rel_error)
    }
}

/// The larger of two errors, NaN if either is (`f64::max` would drop it).
fn worse(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// The first non-finite number of one base point's exact evaluation.
fn first_non_finite(values: &[f64], jac: &[f64], hess: &[f64], n: usize) -> Option<(Entry, f64)> {
    let bad = |v: &f64| !v.is_finite();
    if let Some(row) = values.iter().position(bad) {
        return Some((Entry::Value { row }, values[row]));
    }
    if let Some(k) = jac.iter().position(bad) {
        let (row, col) = (k / n, k % n);
        return Some((Entry::Jacobian { row, col }, jac[k]));
    }
    hess.iter().position(bad).map(|k| {
        let (row, col) = (k / n, k % n);
        (Entry::Hessian { row, col }, hess[k])
    })
}

/// Error of `a` against `b`, relative to the larger of `|b|` and a floor tied to the scale
/// of the whole matrix (so that entries at round-off level do not dominate).
fn rel_err(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-7 * scale).max(1e-300)
}

/// Checks the step's derivatives with respect to `(x, u)` at each base point `(x, u, d, p)`.
/// Stops at the first point whose value or exact derivatives are not all finite, and says
/// which number it was in [`VerifyReport::non_finite`]; a finite difference that is not
/// finite (a point near the edge of the model's domain) makes the error NaN.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::model::{verify::verify_step_derivatives, Plant};
///
/// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/cstr.ghm");
/// let plant = Plant::new(ghm::lang::load(&file).map_err(|e| e.render())?);
/// // Two points (x, u, d, p): the initial state with the coolant at 295 K and at 305 K.
/// let points: Vec<Vec<f64>> = [295.0, 305.0]
///     .iter()
///     .map(|&tc| {
///         let mut z = plant.model.initial_state();
///         z.push(tc); // the CSTR has no disturbances
///         z.extend(plant.model.nominal_params());
///         z
///     })
///     .collect();
/// let report = verify_step_derivatives(&plant, &points);
/// assert_eq!(report.points, 2);
/// assert!(report.max() < 1e-5, "{report:?}");
/// # Ok(())
/// # }
/// ```
pub fn verify_step_derivatives(plant: &Plant, points: &[Vec<f64>]) -> VerifyReport {
    let l = plant.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let n = wrt.len();
    let m = plant.n_step_outputs();
    // Values and gradients for the differences come from the derivative evaluator too: an
    // implicit step is solved there to the tolerance derivatives need.
    let mut der = StepDerivatives::new(plant, &wrt);
    let weights: Vec<f64> = (0..m)
        .map(|i| 0.3 + 0.7 * ((i * 7 + 3) % 11) as f64 / 11.0)
        .collect();
    let mut report = VerifyReport {
        points: points.len(),
        ..Default::default()
    };
    // Typical magnitude per variable: the initial state, or the input's range.
    let typical: Vec<f64> = plant
        .model
        .states
        .iter()
        .map(|s| s.initial.abs())
        .chain(plant.model.inputs.iter().map(|u| {
            let range = u.upper - u.lower;
            if range.is_finite() {
                range
            } else {
                u.start.abs().max(1.0)
            }
        }))
        .map(|t| if t > 0.0 { t } else { 1.0 })
        .collect();
    for (point, z) in points.iter().enumerate() {
        let exact = der.hessian(plant, z, &weights).clone();
        let (jac, hess) = (&exact.jacobian, &exact.hessian);
        if let Some((entry, value)) = first_non_finite(&exact.values, jac, hess, n) {
            report.non_finite = Some(NonFiniteEntry {
                point,
                entry,
                value,
            });
            return report;
        }
        let mut fd_jac = vec![0.0; m * n];
        let mut fd_hess = vec![0.0; n * n];
        for (col, &i) in wrt.iter().enumerate() {
            let h = 1e-5 * z[i].abs().max(typical[col]);
            let mut up = z.clone();
            let mut dn = z.clone();
            up[i] += h;
            dn[i] -= h;
            let e_up = der.hessian(plant, &up, &weights).clone();
            let e_dn = der.hessian(plant, &dn, &weights);
            let (fu, fdn) = (&e_up.values, &e_dn.values);
            for r in 0..m {
                fd_jac[r * n + col] = (fu[r] - fdn[r]) / (2.0 * h);
            }
            // Hessian column from differences of the exact gradient.
            let (gu, gd) = (&e_up.gradient, &e_dn.gradient);
            for r in 0..n {
                fd_hess[r * n + col] = (gu[r] - gd[r]) / (2.0 * h);
            }
        }
        for r in 0..m {
            let row = &jac[r * n..(r + 1) * n];
            let scale = row.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            for c in 0..n {
                let e = rel_err(row[c], fd_jac[r * n + c], scale);
                report.jacobian_max_rel_error = worse(report.jacobian_max_rel_error, e);
            }
        }
        let scale = hess.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for k in 0..n * n {
            let e = rel_err(hess[k], fd_hess[k], scale);
            report.hessian_max_rel_error = worse(report.hessian_max_rel_error, e);
        }
    }
    report
}
