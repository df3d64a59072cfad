//! The observation an agent sees and the map from its actions to inputs, shared by the
//! training environment ([`rl::Env`](crate::rl::Env)) and the policy controller
//! ([`control::Policy`](crate::control::Policy)):
//!
//! * **observation** `s(k) = [y(x(k)), u(k−1), k, d(k)]`: the outputs, the previous input,
//!   the step index as `f64` and the current weather ([`observation_after_outputs`] writes
//!   all but the outputs; [`observation_names`] names the entries);
//! * **action** `a ∈ [−1, 1]^nu` maps to `u(k) = clip(u(k−1) + clip(a, −1, 1) ⊙ δu, lower,
//!   upper)` ([`input_from_action`]), `δu` being each input's rate limit or its range
//!   ([`action_scale`]), so bounds and rate limits hold by construction.

use crate::agent::AgentError;
use crate::lang::Model;
use crate::model::Plant;

/// Writes what follows the outputs in an observation `[y, u_prev, k, d]`: the previous
/// input, the step index and the current weather (`rest` has room for exactly these). The
/// environment and [`Policy`](crate::control::Policy) share it, so a policy sees in closed loop what
/// it saw in training.
pub fn observation_after_outputs(rest: &mut [f64], previous_input: &[f64], step: usize, d: &[f64]) {
    let nu = previous_input.len();
    rest[..nu].copy_from_slice(previous_input);
    rest[nu] = step as f64;
    rest[nu + 1..].copy_from_slice(d);
}

/// Each input's action scale `δu`: its rate limit, or its range `upper − lower` when it has
/// none.
///
/// Errors: [`AgentError::InputBounds`] (NaN or reversed bounds), [`AgentError::UnboundedInput`]
/// (no rate limit and an infinite range).
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::model::ModelBuilder;
/// use ghm::model::Plant;
/// use ghm::agent::observation::action_scale;
///
/// let b = ModelBuilder::new("two inputs");
/// let x = b.state("x", 0.0);
/// let fast = b.input("fast").bounds(0.0, 10.0); // no rate limit: its range
/// let slow = b.input("slow").bounds(-1.0, 1.0).rate(0.1); // its rate limit
/// b.der(x, fast + slow);
/// b.sample(60.0, 1);
/// let plant = Plant::new(b.build()?);
/// assert_eq!(action_scale(&plant)?, [10.0, 0.1]);
/// # Ok(())
/// # }
/// ```
pub fn action_scale(plant: &Plant) -> Result<Vec<f64>, AgentError> {
    let mut scale = Vec::with_capacity(plant.layout.nu);
    for decl in &plant.model.inputs {
        // NaN bounds or lower > upper would make `f64::clamp` panic.
        if decl.lower.is_nan() || decl.upper.is_nan() || decl.lower > decl.upper {
            return Err(AgentError::InputBounds {
                input: decl.info.name.clone(),
                lower: decl.lower,
                upper: decl.upper,
            });
        }
        let s = decl.rate.unwrap_or(decl.upper - decl.lower);
        if !(s.is_finite() && s >= 0.0) {
            return Err(AgentError::UnboundedInput {
                input: decl.info.name.clone(),
                scale: s,
            });
        }
        scale.push(s);
    }
    Ok(scale)
}

/// The action map `u = clip(u_prev + clip(a, −1, 1) ⊙ δu, lower, upper)`.
///
/// ```
/// use ghm::agent::observation::input_from_action;
///
/// // Heating in [0, 150] W m⁻², at most 15 more or less per step, now at 50.
/// let (scale, lower, upper) = ([15.0], [0.0], [150.0]);
/// let mut u = [0.0];
/// input_from_action(&[50.0], &[0.5], &scale, &lower, &upper, &mut u);
/// assert_eq!(u, [57.5]);
/// input_from_action(&[50.0], &[-3.0], &scale, &lower, &upper, &mut u); // a clipped to −1
/// assert_eq!(u, [35.0]);
/// input_from_action(&[145.0], &[1.0], &scale, &lower, &upper, &mut u); // u clipped to 150
/// assert_eq!(u, [150.0]);
/// ```
pub fn input_from_action(
    previous: &[f64],
    action: &[f64],
    scale: &[f64],
    lower: &[f64],
    upper: &[f64],
    input: &mut [f64],
) {
    for (i, (u, a)) in input.iter_mut().zip(action).enumerate() {
        let v = previous[i] + a.clamp(-1.0, 1.0) * scale[i];
        *u = v.clamp(lower[i], upper[i]);
    }
}

/// The action that maps to `input` from `previous` ([`input_from_action`]'s inverse where
/// the step from `previous` keeps the rate limit): `a = clip((u − u_prev)/δu, −1, 1)`, 0
/// for an input whose scale is 0. A teacher's decision as the label of an imitated action.
///
/// ```
/// use ghm::agent::observation::{action_from_input, input_from_action};
///
/// let (scale, lower, upper) = ([15.0], [0.0], [150.0]);
/// let mut a = [0.0];
/// action_from_input(&[50.0], &[57.5], &scale, &mut a);
/// assert_eq!(a, [0.5]);
/// let mut u = [0.0];
/// input_from_action(&[50.0], &a, &scale, &lower, &upper, &mut u);
/// assert_eq!(u, [57.5]);
/// action_from_input(&[50.0], &[0.0], &scale, &mut a); // beyond the rate limit: clipped
/// assert_eq!(a, [-1.0]);
/// ```
pub fn action_from_input(previous: &[f64], input: &[f64], scale: &[f64], action: &mut [f64]) {
    for (i, a) in action.iter_mut().enumerate() {
        *a = if scale[i] > 0.0 {
            ((input[i] - previous[i]) / scale[i]).clamp(-1.0, 1.0)
        } else {
            0.0
        };
    }
}

/// Names of the observation entries of an environment over `model`: the outputs,
/// `prev_<input>` per input, `step`, and the disturbances.
pub fn observation_names(model: &Model) -> Vec<String> {
    model
        .outputs
        .iter()
        .map(|o| o.info.name.clone())
        .chain(model.inputs.iter().map(|u| format!("prev_{}", u.info.name)))
        .chain(std::iter::once("step".to_string()))
        .chain(model.disturbances.iter().map(|d| d.info.name.clone()))
        .collect()
}
