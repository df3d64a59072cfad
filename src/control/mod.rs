//! Controllers: what chooses the input at each step. A [`Controller`] observes the state,
//! the previous input, the step index and the weather forecast, and returns an input and a
//! record of what it did. Fixed and tabulated inputs live here; MPC and learned policies
//! implement the same trait.

pub mod expert;
pub mod mpc;
pub mod policy;
pub mod rlmpc;
mod roll_out;
pub mod rules;
pub mod stepper;
pub mod value;
pub mod warm_start;

pub use expert::Expert;
pub use mpc::{Guidance, Mpc};
pub use policy::Policy;
pub use rlmpc::{terminal_region, RlGuidance, RlMpcOptions, TerminalCostForm};
pub use rules::Rules;
pub use stepper::{LimitPolicy, StepDecision, StepError, StepRequest, SteppedController, Stepper};
pub use value::{taylor_terminal_cost, ValueFile, ValueTerminalCost};
pub use warm_start::WarmStart;

use crate::solve::SolveStatus;
use thiserror::Error;

/// What a controller sees at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    /// The season step `k`, counted from 0.
    pub step: usize,
    /// The state `x(k)`, in the model's declaration order.
    pub state: &'a [f64],
    /// The outputs at `x(k)`, evaluated with the previous input and the weather `d(k)`.
    pub outputs: &'a [f64],
    /// The input applied at step `k − 1`; at step 0, the model's start input.
    pub previous_input: &'a [f64],
    /// Perfect forecast `d(k), d(k+1), …`, row-major, as many rows as the source has left.
    pub forecast: &'a [f64],
}

/// What a controller did at one step, for the logs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepRecord {
    /// Wall time spent deciding, in seconds.
    pub solve_time_s: f64,
    /// Solver iterations, summed over every attempt at this step (0 without a solver).
    pub iterations: usize,
    /// Iterations whose Hessian the solver had to correct (inertia corrections, curvature
    /// shifts), summed over every attempt at this step.
    pub inertia_corrections: usize,
    /// How the step's last solve ended; `None` for controllers without a solver (written
    /// as an empty field).
    pub status: Option<SolveStatus>,
    /// Which fallback produced the input, if the first choice failed.
    pub fallback: Option<Fallback>,
    /// RL-guided MPC: the terminal region's state at the solution (`binding` when a
    /// bound of the region is active, `inactive` when imposed but not active); `None`
    /// without a region.
    pub terminal_region: Option<String>,
}

impl StepRecord {
    /// The status as the logs spell it: the solver's snake-case name, or `""` without a
    /// solver.
    pub fn status_name(&self) -> &'static str {
        self.status.map_or("", SolveStatus::name)
    }

    /// The fallback as the logs spell it (`cold_start`, ...), if one was taken.
    pub fn fallback_name(&self) -> Option<&'static str> {
        self.fallback.map(Fallback::name)
    }

    /// Whether the step's solve failed: a solver status that is neither optimal nor
    /// acceptable. A step without a solver did not fail.
    ///
    /// ```
    /// use ghm::control::StepRecord;
    /// use ghm::solve::SolveStatus;
    ///
    /// assert!(!StepRecord::default().solve_failed());
    /// let failed = StepRecord { status: Some(SolveStatus::Infeasible), ..StepRecord::default() };
    /// assert!(failed.solve_failed());
    /// assert_eq!(failed.status_name(), "infeasible");
    /// ```
    pub fn solve_failed(&self) -> bool {
        self.status.is_some_and(|s| !s.is_success())
    }
}

crate::choice! {
    /// Which fallback produced a step's input when the controller's first choice failed (in
    /// the order MPC tries them after its first solve).
    pub enum Fallback {
        /// The warm-started solve failed and a cold start succeeded.
        ColdStart = "cold_start",
        /// The planning model's solves failed and a cold start on the model the plant is
        /// simulated with succeeded (a model with `plan substeps` of its own).
        SimulationModel = "simulation_model",
        /// Every solve over the horizon failed and a cold start over a shorter horizon
        /// (a half, a quarter, …) succeeded: plain MPC over that horizon decided the step.
        ShorterHorizon = "shorter_horizon",
        /// No solve succeeded: the previous plan, shifted by the steps since it was made
        /// (none is kept past a step decided over a shorter horizon).
        ShiftedPlan = "shifted_plan",
        /// No solve succeeded and no plan was left: the guide's own input.
        GuideInput = "guide_input",
        /// Nothing else was left: the previous input, held.
        HoldInput = "hold_input",
    }
}

/// A controller's answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// The input to apply at this step, one entry per model input; the simulator clips it
    /// to the input limits only when it enforces them.
    pub input: Vec<f64>,
    /// What the controller did to get it.
    pub record: StepRecord,
}

/// The prediction behind a decision: what the controller expects to apply and to see over
/// its horizon, from the step it decided at.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plan {
    /// Inputs `u_0, …, u_{N−1}`; `u_0` is the decision's input (before any clipping).
    pub inputs: Vec<Vec<f64>>,
    /// Predicted states `x_1, …, x_N` (`x_0` is the measured state).
    pub states: Vec<Vec<f64>>,
}

/// Why a controller could not decide an input.
#[derive(Debug, Error)]
pub enum ControlError {
    /// An [`InputTable`] asked for a step past its last row.
    #[error("the input table has {rows} rows; step {step} needs one more")]
    TableTooShort {
        /// Rows in the table.
        rows: usize,
        /// The step asked for (0-based).
        step: usize,
    },
    /// A value-function file that cannot be read, written or used.
    #[error("{path}: {reason}")]
    ValueFile {
        /// The file.
        path: std::path::PathBuf,
        /// What went wrong, in words.
        reason: String,
    },
    /// A policy's observation statistics, action map or network failed (see
    /// [`AgentError`](crate::agent::AgentError)); its message unchanged.
    #[error(transparent)]
    Agent(#[from] crate::agent::AgentError),
    /// The OCP rejected the step's data (see [`OcpError`](crate::nlp::OcpError)); its
    /// message unchanged.
    #[error(transparent)]
    Ocp(#[from] crate::nlp::OcpError),
    /// A remote controller's request could not be encoded, or its answer read, as JSON.
    #[error("{what}: {source}")]
    Json {
        /// What was being encoded or read, and from where.
        what: String,
        /// The JSON error.
        #[source]
        source: serde_json::Error,
    },
    /// A failure the controller found itself, described in words (there is no underlying
    /// error to keep): a forecast too short for the controller, a model the expert or a
    /// policy cannot serve, a service that cannot be reached or refuses the request.
    #[error("{0}")]
    Other(String),
}

/// Chooses inputs, one step at a time.
///
/// # Examples
///
/// A controller of your own for a tank whose level drains at `k · level`: pump in exactly
/// what drains out, so the level holds. [`run_season`](crate::sim::season::run_season) runs
/// it like any built-in controller.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::{ControlError, Controller, Decision, Observation, StepRecord};
/// use ghm::model::Plant;
/// use ghm::sim::season::{run_season, SeasonConfig, StepLog};
/// use ghm::sim::weather::Weather;
///
/// struct HoldLevel {
///     drain: f64,
/// }
///
/// impl Controller for HoldLevel {
///     fn name(&self) -> String {
///         "hold level".into()
///     }
///     fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
///         let level = o.outputs[0];
///         Ok(Decision { input: vec![self.drain * level], record: StepRecord::default() })
///     }
/// }
///
/// let text = "\
/// model tank
/// sample 60 [s] integrator euler
/// state level [m] = 1
/// input inflow [m s^-1] in [0, 0.01] rate 0.002 start 0
/// param k [s^-1] = 0.001
/// der level = inflow - k * level
/// output h [m] = level
/// reward stored [EUR] = 2 * next(level)
/// cost pumping [EUR] = 50 * inflow
/// soft h in [0.5, 1.2] weight 10
/// ";
/// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
/// let weather = Weather::constant(vec![], &[], 10, plant.model.sample_period);
/// let mut controller = HoldLevel { drain: 0.001 };
/// let config = SeasonConfig { steps: 10, enforce_limits: true, uncertainty: None };
/// let mut inputs = Vec::new();
/// let result = run_season(&plant, &weather, &mut controller, &config, &mut |log: &StepLog| {
///     inputs.push(log.input[0])
/// })?;
/// assert_eq!(inputs, [0.001; 10]);
/// assert!((result.final_state[0] - 1.0).abs() < 1e-12);
/// // Each step earns 2 · 1 m − 50 · 0.001, inside the band (no penalty).
/// assert!((result.metrics.epi - 10.0 * 1.95).abs() < 1e-9);
/// assert_eq!(result.metrics.total_penalty, 0.0);
/// # Ok(())
/// # }
/// ```
pub trait Controller {
    /// A short name for reports.
    fn name(&self) -> String;
    /// The input for the step `observation` describes, and a record of how it was found.
    fn decide(&mut self, observation: &Observation) -> Result<Decision, ControlError>;
    /// The plan behind the last decision, where it came from a solve at that step; `None`
    /// for controllers that do not predict (the default), or after a fallback.
    fn plan(&self) -> Option<Plan> {
        None
    }
    /// Rows of the forecast after the current weather that the controller reads beyond
    /// any horizon of its own: a policy whose observation has forecast rows
    /// ([`ObservationLayout`](crate::agent::observation::ObservationLayout)); 0 for the
    /// rest (the default). A caller that can supply them should: a row missing at the end
    /// of the weather repeats the last one.
    fn forecast_rows(&self) -> usize {
        0
    }
}

/// The same input at every step.
///
/// ```
/// use ghm::control::{ConstantInput, Controller, Observation};
///
/// let mut c = ConstantInput(vec![1.0, 2.0]);
/// let o = Observation { step: 3, state: &[], outputs: &[], previous_input: &[0.0, 0.0], forecast: &[] };
/// assert_eq!(c.decide(&o).unwrap().input, [1.0, 2.0]);
/// ```
#[derive(Debug, Clone)]
pub struct ConstantInput(pub Vec<f64>);

impl Controller for ConstantInput {
    fn name(&self) -> String {
        "constant".into()
    }
    fn decide(&mut self, _: &Observation) -> Result<Decision, ControlError> {
        Ok(Decision {
            input: self.0.clone(),
            record: StepRecord::default(),
        })
    }
}

/// Inputs read from a table, one row per step.
///
/// ```
/// use ghm::control::{ControlError, Controller, InputTable, Observation};
///
/// let mut table = InputTable(vec![vec![0.5], vec![0.7]]);
/// let at = |step| Observation { step, state: &[], outputs: &[], previous_input: &[0.0], forecast: &[] };
/// assert_eq!(table.decide(&at(1)).unwrap().input, [0.7]);
/// let past_the_end = table.decide(&at(2)).unwrap_err();
/// assert!(matches!(past_the_end, ControlError::TableTooShort { rows: 2, step: 2 }));
/// ```
#[derive(Debug, Clone)]
pub struct InputTable(pub Vec<Vec<f64>>);

impl Controller for InputTable {
    fn name(&self) -> String {
        "table".into()
    }
    fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
        let row = self.0.get(o.step).ok_or(ControlError::TableTooShort {
            rows: self.0.len(),
            step: o.step,
        })?;
        Ok(Decision {
            input: row.clone(),
            record: StepRecord::default(),
        })
    }
}
