//! Controllers: what chooses the input at each step. A [`Controller`] observes the state,
//! the previous input, the step index and the weather forecast, and returns an input and a
//! record of what it did. Fixed and tabulated inputs live here; MPC and learned policies
//! implement the same trait.

pub mod expert;
pub mod mpc;
pub mod policy;
pub mod rlmpc;
pub mod value;

pub use expert::Expert;
pub use mpc::{Guidance, Mpc};
pub use policy::Policy;
pub use rlmpc::{terminal_region, RlGuidance, RlMpcOptions, TerminalCostForm};
pub use value::{taylor_terminal_cost, ValueFile, ValueTerminalCost};

use thiserror::Error;

/// What a controller sees at step `k`.
#[derive(Debug, Clone, Copy)]
pub struct Observation<'a> {
    pub step: usize,
    pub state: &'a [f64],
    pub outputs: &'a [f64],
    pub previous_input: &'a [f64],
    /// Perfect forecast `d(k), d(k+1), …`, row-major, as many rows as the source has left.
    pub forecast: &'a [f64],
}

/// What a controller did at one step, for the logs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepRecord {
    /// Wall time spent deciding, in seconds.
    pub solve_time_s: f64,
    pub iterations: usize,
    /// Solver status (empty for controllers without a solver).
    pub status: String,
    /// Which fallback produced the input, if the first choice failed.
    pub fallback: Option<String>,
    /// RL-guided MPC: the terminal region's state at the solution (`binding` when a
    /// bound of the region is active, `inactive` when imposed but not active); `None`
    /// without a region.
    pub terminal_region: Option<String>,
}

/// A controller's answer.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    pub input: Vec<f64>,
    pub record: StepRecord,
}

#[derive(Debug, Error)]
pub enum ControlError {
    #[error("the input table has {rows} rows; step {step} needs one more")]
    TableTooShort { rows: usize, step: usize },
    #[error("{0}")]
    Other(String),
}

/// Chooses inputs, one step at a time.
pub trait Controller {
    /// A short name for reports.
    fn name(&self) -> String;
    fn decide(&mut self, observation: &Observation) -> Result<Decision, ControlError>;
}

/// The same input at every step.
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
