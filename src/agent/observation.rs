//! The observation an agent sees and the map from its actions to inputs, shared by the
//! training environment ([`rl::Env`](crate::rl::Env)) and the policy controller
//! ([`control::Policy`](crate::control::Policy)):
//!
//! * **observation**, in one of two versions ([`ObservationLayout`], recorded in each
//!   policy file):
//!   - version 1 `s(k) = [y(x(k)), u(k−1), k, d(k)]`: the outputs, the previous input, the
//!     step index as `f64` and the current weather;
//!   - version 2 adds `F` rows of the perfect forecast, `[…, d(k), d(k+1), …, d(k+F)]`,
//!     for a policy that imitates a controller planning ahead. A row past the end of the
//!     weather repeats the last one there is, as MPC pads its forecast.
//!
//!   [`ObservationLayout::write_after_outputs`] writes all but the outputs;
//!   [`ObservationLayout::names`] names the entries;
//! * **action** `a ∈ [−1, 1]^nu` maps to `u(k) = clip(u(k−1) + clip(a, −1, 1) ⊙ δu, lower,
//!   upper)` ([`input_from_action`]), `δu` being each input's rate limit or its range
//!   ([`action_scale`]), so bounds and rate limits hold by construction.

use crate::agent::AgentError;
use crate::lang::Model;
use crate::model::Plant;
use serde::{Deserialize, Serialize};

/// The observation versions this ghm reads and writes: a policy file that records another
/// is refused by name.
pub const OBSERVATION_VERSIONS: [u32; 2] = [1, 2];

/// Which observation an agent sees: version 1 (the current weather only) or version 2 (the
/// current weather and `forecast_rows` rows of forecast after it). See the [module
/// documentation](self).
///
/// In a policy file it is the field `"observation": {"version": 2, "forecast_rows": 12}`;
/// a file without the field is version 1 (every file written before version 2 existed),
/// and version 1 is written without it, so those files read and write as before.
///
/// ```
/// use ghm::agent::observation::ObservationLayout;
///
/// let text = "sample 60 [s]\nstate level = 1\ninput inflow in [0, 1] rate 0.1\n\
///             disturbance rain\nder level = inflow + rain - level\noutput h = level\n";
/// let model = ghm::lang::load_str("tank.ghm", text).unwrap();
/// let ahead = ObservationLayout::with_forecast(2);
/// assert_eq!(ahead.version(), 2);
/// assert_eq!(
///     ahead.names(&model),
///     ["h", "prev_inflow", "step", "rain", "rain[k+1]", "rain[k+2]"]
/// );
/// // One row of forecast given: the rows after it repeat it.
/// let mut rest = [0.0; 5];
/// ahead.write_after_outputs(&mut rest, &[0.5], 7, &[3.0, 4.0], 1);
/// assert_eq!(rest, [0.5, 7.0, 3.0, 4.0, 4.0]);
/// // A version this ghm does not know is refused by name.
/// let err = serde_json::from_str::<ObservationLayout>(r#"{"version": 3}"#).unwrap_err();
/// assert!(err.to_string().contains("observation version 3"));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(try_from = "LayoutData", into = "LayoutData")]
pub struct ObservationLayout {
    forecast_rows: usize,
}

/// The serialised form of an [`ObservationLayout`], checked on the way in.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LayoutData {
    version: u32,
    #[serde(default)]
    forecast_rows: usize,
}

impl TryFrom<LayoutData> for ObservationLayout {
    type Error = String;
    fn try_from(d: LayoutData) -> Result<ObservationLayout, String> {
        match (d.version, d.forecast_rows) {
            (1, 0) => Ok(ObservationLayout::CURRENT_WEATHER),
            (1, rows) => Err(format!(
                "observation version 1 has no forecast, but \"forecast_rows\" is {rows}"
            )),
            (2, 0) => Err("observation version 2 needs \"forecast_rows\" ≥ 1".into()),
            (2, rows) => Ok(ObservationLayout::with_forecast(rows)),
            (v, _) => Err(format!(
                "observation version {v} is not one this ghm reads ({}); a newer ghm wrote it",
                OBSERVATION_VERSIONS.map(|v| v.to_string()).join(", ")
            )),
        }
    }
}

impl From<ObservationLayout> for LayoutData {
    fn from(layout: ObservationLayout) -> LayoutData {
        LayoutData {
            version: layout.version(),
            forecast_rows: layout.forecast_rows,
        }
    }
}

impl ObservationLayout {
    /// Version 1: `[y, u_prev, k, d(k)]`.
    pub const CURRENT_WEATHER: ObservationLayout = ObservationLayout { forecast_rows: 0 };

    /// The most forecast rows an observation holds, where a user chooses them (a week of
    /// half-hour steps).
    pub const MAX_FORECAST_ROWS: usize = 336;

    /// Version 2 with `rows` rows of forecast after the current weather (version 1 for 0).
    pub fn with_forecast(rows: usize) -> ObservationLayout {
        ObservationLayout {
            forecast_rows: rows,
        }
    }

    /// The version: 1 without forecast rows, 2 with.
    pub fn version(&self) -> u32 {
        if self.forecast_rows == 0 {
            1
        } else {
            2
        }
    }

    /// Rows of forecast after the current weather.
    pub fn forecast_rows(&self) -> usize {
        self.forecast_rows
    }

    /// Whether this is version 1 (what a policy file states by leaving the field out).
    pub fn is_current_weather(&self) -> bool {
        self.forecast_rows == 0
    }

    /// Entries of an observation of `model`: outputs, inputs, the step, and the weather
    /// rows.
    pub fn width(&self, model: &Model) -> usize {
        let nd = model.disturbances.len();
        model.outputs.len() + model.inputs.len() + 1 + nd * (1 + self.forecast_rows)
    }

    /// Names of the entries of an observation of `model`: the outputs, `prev_<input>` per
    /// input, `step`, the disturbances, then `<disturbance>[k+j]` for each forecast row `j`.
    pub fn names(&self, model: &Model) -> Vec<String> {
        let weather = |j: usize| {
            model.disturbances.iter().map(move |d| match j {
                0 => d.info.name.clone(),
                j => format!("{}[k+{j}]", d.info.name),
            })
        };
        model
            .outputs
            .iter()
            .map(|o| o.info.name.clone())
            .chain(model.inputs.iter().map(|u| format!("prev_{}", u.info.name)))
            .chain(std::iter::once("step".to_string()))
            .chain((0..=self.forecast_rows).flat_map(weather))
            .collect()
    }

    /// Writes what follows the outputs in an observation: the previous input, the step
    /// index and the weather rows, from `forecast` (`d(k), d(k+1), …`, row-major, rows of
    /// `nd`; at least one row where `nd > 0`), a row past its end repeating its last one.
    /// `rest` has room for exactly these. The environment and
    /// [`Policy`](crate::control::Policy) share it, so a policy sees in closed loop what it
    /// saw in training.
    pub fn write_after_outputs(
        &self,
        rest: &mut [f64],
        previous_input: &[f64],
        step: usize,
        forecast: &[f64],
        nd: usize,
    ) {
        let nu = previous_input.len();
        rest[..nu].copy_from_slice(previous_input);
        rest[nu] = step as f64;
        if nd == 0 {
            return;
        }
        let available = forecast.len() / nd;
        for (j, row) in rest[nu + 1..].chunks_exact_mut(nd).enumerate() {
            let from = j.min(available - 1) * nd;
            row.copy_from_slice(&forecast[from..from + nd]);
        }
    }
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
