//! Derivative verification: the exact (dual-number) Jacobian of the discrete step and the
//! Hessian of `λᵀ(x⁺, stage terms)` against central finite differences, with steps scaled
//! per variable.

use crate::graph::Derivatives;
use crate::model::Plant;

/// The largest relative errors found.
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
}

impl VerifyReport {
    /// The larger of the two errors.
    pub fn max(&self) -> f64 {
        self.jacobian_max_rel_error.max(self.hessian_max_rel_error)
    }
}

/// Error of `a` against `b`, relative to the larger of `|b|` and a floor tied to the scale
/// of the whole matrix (so that entries at round-off level do not dominate).
fn rel_err(a: f64, b: f64, scale: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-7 * scale).max(1e-300)
}

/// Checks the step's derivatives with respect to `(x, u)` at each base point `(x, u, d, p)`.
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
    let tape = plant.step_tape();
    let l = plant.layout;
    let wrt: Vec<usize> = (0..l.nx + l.nu).collect();
    let n = wrt.len();
    let m = tape.n_outputs();
    let mut der = Derivatives::new(tape, &wrt);
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
    for z in points {
        let exact = der.hessian(tape, z, &weights).clone();
        let (jac, hess) = (&exact.jacobian, &exact.hessian);
        let mut fd_jac = vec![0.0; m * n];
        let mut fd_hess = vec![0.0; n * n];
        for (col, &i) in wrt.iter().enumerate() {
            let h = 1e-5 * z[i].abs().max(typical[col]);
            let mut up = z.clone();
            let mut dn = z.clone();
            up[i] += h;
            dn[i] -= h;
            let fu = tape.eval_f64(&up);
            let fdn = tape.eval_f64(&dn);
            for r in 0..m {
                fd_jac[r * n + col] = (fu[r] - fdn[r]) / (2.0 * h);
            }
            // Hessian column from differences of the exact gradient.
            let gu = der.hessian(tape, &up, &weights).gradient.clone();
            let gd = &der.hessian(tape, &dn, &weights).gradient;
            for r in 0..n {
                fd_hess[r * n + col] = (gu[r] - gd[r]) / (2.0 * h);
            }
        }
        for r in 0..m {
            let row = &jac[r * n..(r + 1) * n];
            let scale = row.iter().fold(0.0f64, |a, b| a.max(b.abs()));
            for c in 0..n {
                let e = rel_err(row[c], fd_jac[r * n + c], scale);
                report.jacobian_max_rel_error = report.jacobian_max_rel_error.max(e);
            }
        }
        let scale = hess.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for k in 0..n * n {
            let e = rel_err(hess[k], fd_hess[k], scale);
            report.hessian_max_rel_error = report.hessian_max_rel_error.max(e);
        }
    }
    report
}
