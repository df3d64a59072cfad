//! The service's JSON: what a client sends to `POST /decide` and gets back, the model
//! description of `GET /model`, and the error body of every refusal. Plain serde types;
//! checking a request against the model is [`validate`](super::validate)'s job.

use crate::control::Fallback;
use crate::job::RunSpec;
use crate::solve::SolveStatus;
use axum::http::StatusCode;
use serde::{Deserialize, Serialize};

/// The session a request without one belongs to.
pub const DEFAULT_SESSION: &str = "default";

fn default_session() -> String {
    DEFAULT_SESSION.to_string()
}

/// One decision asked for: the measurements at step `step`, in the model's units and
/// declaration order (`GET /model` lists them). JSON has no NaN: a missing measurement is
/// `null`, and is refused like a NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecideRequest {
    /// The greenhouse (compartment) this is for: each session has its own controller, warm
    /// start and step sequence. Default `default`.
    #[serde(default = "default_session")]
    pub session: String,
    /// The step `k` the decision is for; a session's steps go forward (a step may be skipped;
    /// a step already decided gets its journaled answer again).
    pub step: u64,
    /// The measured state `x(k)`.
    pub state: Vec<Option<f64>>,
    /// The input applied over the last step, `u(k−1)` (at the first step, the model's start
    /// input).
    pub previous_input: Vec<Option<f64>>,
    /// The measured outputs at step `k`; without them, the service evaluates the model's
    /// outputs at the state, the previous input and the first forecast row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outputs: Option<Vec<Option<f64>>>,
    /// The weather forecast `d(k), d(k+1), …`, one row per step of the model's period,
    /// at least `forecast_rows` rows (`GET /model`).
    pub forecast: Vec<Vec<Option<f64>>>,
    /// The units the values are in, checked against the model's (optional).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub units: Option<Units>,
}

/// The units of a request's values, each list in declaration order; a list given must
/// name the model's unit of every entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Units {
    /// The states' units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<Vec<String>>,
    /// The inputs' units (of `previous_input`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub previous_input: Option<Vec<String>>,
    /// The outputs' units.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub outputs: Option<Vec<String>>,
    /// The disturbances' units (the forecast's columns).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forecast: Option<Vec<String>>,
}

/// The answer to a decision: the input to apply, and how the controller found it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DecideResponse {
    /// The request's session.
    pub session: String,
    /// The request's step.
    pub step: u64,
    /// The input to apply from step `k` to `k+1`, in the model's units (before the
    /// actuators' own clipping to bounds and rate limits).
    pub input: Vec<f64>,
    /// The solver's status (`""` for controllers without a solver).
    #[serde(with = "status_name")]
    pub status: Option<SolveStatus>,
    /// Solver iterations, over every attempt at this step.
    pub iterations: usize,
    /// Iterations whose Hessian the solver had to correct.
    pub inertia_corrections: usize,
    /// Time the controller took to decide, in milliseconds.
    pub solve_time_ms: f64,
    /// The fallback that produced the input when the first choice failed (`cold_start`,
    /// `simulation_model`, `shorter_horizon`, `shifted_plan`, `guide_input`, `hold_input`);
    /// `null` otherwise.
    pub fallback: Option<Fallback>,
    /// RL-guided MPC: the terminal region's state (`binding`, `inactive`); `null` otherwise.
    pub terminal_region: Option<String>,
    /// The predicted plan of the solve behind the input; `null` for controllers without one,
    /// and after a fallback.
    pub plan: Option<PlanJson>,
    /// Whether this is the journaled answer to a step decided before (a retry).
    #[serde(default)]
    pub from_journal: bool,
}

/// The plan over the horizon: inputs `u_0 … u_{N−1}`, predicted states `x_1 … x_N`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanJson {
    /// One row per step of the horizon, one value per input.
    pub inputs: Vec<Vec<f64>>,
    /// One row per step of the horizon, one value per state.
    pub states: Vec<Vec<f64>>,
}

/// A quantity of the model, as `GET /model` lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Quantity {
    /// Its name in the model file.
    pub name: String,
    /// Its unit as declared there.
    pub unit: String,
    /// Inputs: the lower bound; outputs: the soft band's lower limit (none when the band
    /// has none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lower: Option<f64>,
    /// Inputs: the upper bound; outputs: the soft band's upper limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub upper: Option<f64>,
}

/// What the service serves (`GET /model`): the model, the controller, and the shape and
/// units of a request.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelInfo {
    /// The model's name.
    pub model: String,
    /// SHA-256 of the model's source text (its files, in order).
    pub model_sha256: String,
    /// The controller's name (`mpc-ipm`, `policy`, ...).
    pub controller: String,
    /// The spec the controller was built from.
    pub spec: RunSpec,
    /// The model's sample period, in seconds: one forecast row per period.
    pub sample_period_s: f64,
    /// Forecast rows a request must carry (the horizon; 1 for controllers without one).
    pub forecast_rows: usize,
    /// The states, in order.
    pub states: Vec<Quantity>,
    /// The inputs, in order, with their bounds.
    pub inputs: Vec<Quantity>,
    /// The disturbances (forecast columns), in order.
    pub disturbances: Vec<Quantity>,
    /// The outputs, in order, with their soft bands.
    pub outputs: Vec<Quantity>,
}

/// A [`SolveStatus`] as the API spells it: its snake-case name, `""` for none.
mod status_name {
    use crate::solve::SolveStatus;
    use serde::{de, Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(status: &Option<SolveStatus>, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(status.map_or("", SolveStatus::name))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<SolveStatus>, D::Error> {
        let name = String::deserialize(d)?;
        if name.is_empty() {
            return Ok(None);
        }
        SolveStatus::deserialize(de::value::StrDeserializer::<D::Error>::new(&name)).map(Some)
    }
}

/// The body of every refusal: what is wrong, in words.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorBody {
    /// The message.
    pub error: String,
}

/// A refusal: an HTTP status and the message of its [`ErrorBody`].
#[derive(Debug, Clone, PartialEq)]
pub struct ApiError {
    /// 4xx for what the client can fix, 5xx for the service's own failures.
    pub status: StatusCode,
    /// What is wrong and what to do.
    pub message: String,
}

impl ApiError {
    /// A refusal with `status`.
    pub fn new(status: StatusCode, message: impl Into<String>) -> ApiError {
        ApiError {
            status,
            message: message.into(),
        }
    }

    /// 422: a request that parses but does not fit the model.
    pub fn unprocessable(message: impl Into<String>) -> ApiError {
        ApiError::new(StatusCode::UNPROCESSABLE_ENTITY, message)
    }
}
