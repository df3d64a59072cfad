//! Exact derivatives of a plant's step, whatever its integrator: the unrolled tape's
//! forward Jacobian and forward-over-reverse Hessian for an explicit integrator, the
//! implicit function theorem for an implicit one ([`super::implicit`]).

use super::implicit::ImplicitDerivatives;
use super::{Plant, StepKernel};
use crate::graph::{Derivatives, Evaluation};

/// Reusable derivative evaluator of one plant's step with respect to chosen base inputs
/// (indices into `(x, u, d, p)`), with the shapes of [`Evaluation`]: values `(x⁺, terms,
/// y(x⁺))`, their Jacobian, and the gradient and Hessian of a weighted sum of them.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::model::{Plant, StepDerivatives};
///
/// // ẋ = −k x with backward Euler over h = 1 s: x⁺ = x / (1 + k h).
/// let text = "\
/// model decay
/// sample 1 [s] integrator backward_euler
/// state x = 1
/// input u in [0, 1]
/// param k [s^-1] = 3
/// der x = -k * x + u
/// output y = x
/// ";
/// let plant = Plant::new(ghm::lang::load_str("decay.ghm", text).map_err(|e| e.render())?);
/// let mut der = StepDerivatives::new(&plant, &[0, 1]);
/// let e = der.hessian(&plant, &[2.0, 0.5, 3.0], &[1.0, 0.0]);
/// assert!((e.values[0] - 2.5 / 4.0).abs() < 1e-12);
/// // ∂x⁺/∂x = 1/4, ∂x⁺/∂u = 1/4; x⁺ is linear in (x, u): the Hessian is zero.
/// assert!((e.jacobian[0] - 0.25).abs() < 1e-12 && (e.jacobian[1] - 0.25).abs() < 1e-12);
/// assert!(e.hessian.iter().all(|h| h.abs() < 1e-12));
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct StepDerivatives {
    kind: Kind,
}

#[derive(Debug, Clone)]
enum Kind {
    Unrolled(Box<Derivatives>),
    Implicit(Box<ImplicitDerivatives>),
}

impl StepDerivatives {
    /// Derivatives of `plant`'s step with respect to its base inputs `wrt`.
    pub fn new(plant: &Plant, wrt: &[usize]) -> StepDerivatives {
        let kind = match &plant.step {
            StepKernel::Unrolled(tape) => Kind::Unrolled(Box::new(Derivatives::new(tape, wrt))),
            StepKernel::Implicit(step) => {
                Kind::Implicit(Box::new(ImplicitDerivatives::new(step, wrt)))
            }
        };
        StepDerivatives { kind }
    }

    /// Values and Jacobian at the base point `inputs` `(x, u, d, p)`. An implicit step whose
    /// Newton iteration fails gives NaN throughout.
    pub fn jacobian(&mut self, plant: &Plant, inputs: &[f64]) -> &Evaluation {
        match (&mut self.kind, &plant.step) {
            (Kind::Unrolled(der), StepKernel::Unrolled(tape)) => der.jacobian(tape, inputs),
            (Kind::Implicit(der), StepKernel::Implicit(step)) => der.jacobian(step, inputs),
            _ => panic!("StepDerivatives used with a plant other than its own"),
        }
    }

    /// Values, Jacobian, and the gradient and Hessian of `Σ weights[i] · output[i]`.
    pub fn hessian(&mut self, plant: &Plant, inputs: &[f64], weights: &[f64]) -> &Evaluation {
        match (&mut self.kind, &plant.step) {
            (Kind::Unrolled(der), StepKernel::Unrolled(tape)) => der.hessian(tape, inputs, weights),
            (Kind::Implicit(der), StepKernel::Implicit(step)) => der.hessian(step, inputs, weights),
            _ => panic!("StepDerivatives used with a plant other than its own"),
        }
    }
}
