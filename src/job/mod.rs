//! One job layer under the commands: *what to run* → *a run folder*.
//!
//! A [`RunSpec`] names everything a season needs — the model file, the weather slice
//! ([`WeatherSpec`]), the plant's uncertainty ([`PlantSpec`]) and the controller
//! ([`ControllerSpec`]: fixed inputs, the expert, a policy, MPC, RL-guided MPC, the season
//! optimum) — and [`run_season_job`] runs it into a run folder: `trajectory.csv`,
//! `summary.json`, `trajectory.png`, and `run.json`, which says `complete` only when
//! everything else is written ([`folder`]). The season commands (`ghm simulate`, `policy`,
//! `mpc`, `rlmpc`, `optimum`) only map their flags onto a spec; `ghm study` plans many.
//!
//! A spec is plain data (serde): it is recorded in the folder's `run.json`, so a finished
//! job can be recognised and never run again.

pub mod build;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod distill;
pub mod folder;
pub mod optimum_checkpoint;
pub mod output;
pub mod resume;
mod season;
mod spec;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod train;
#[cfg(feature = "learn")]
#[cfg_attr(docsrs, doc(cfg(feature = "learn")))]
pub mod value;
mod weather;

pub use crate::choice::Choice;
pub use crate::control::WarmStart;
pub use build::{load_model, ControllerFiles};
pub use folder::RunFolder;
pub use season::{
    build_controller, build_controller_with, print_metrics, resume_season_job,
    run_external_season_job, run_season_job, run_season_logs, ExternalController, JobOptions,
    SeasonLogs, SeasonOutcome, StandaloneController,
};
pub use spec::{
    BandsChoice, ControllerKind, ControllerSpec, CostForm, GuideChoice, InputsSpec, MpcSpec,
    OptimumSpec, PlantSpec, RlmpcSpec, RunSpec, SolverChoice, SolverSpec, Variant,
};
pub use weather::WeatherSpec;

use std::path::PathBuf;
use thiserror::Error;

impl JobError {
    /// The spec's `field` holds `value`, which `message` says is wrong.
    pub fn field(
        field: &'static str,
        value: impl std::fmt::Display,
        message: impl Into<String>,
    ) -> JobError {
        JobError::Field {
            field,
            value: Some(value.to_string()),
            message: message.into(),
        }
    }

    /// The spec's `field` is missing or its default does not apply, as `message` says.
    pub fn unset(field: &'static str, message: impl Into<String>) -> JobError {
        JobError::Field {
            field,
            value: None,
            message: message.into(),
        }
    }
}

impl JobError {
    /// Whether this is a stopped season that cannot be resumed (its trajectory is
    /// another model's, or the replay does not reach the states it logged): a study then
    /// runs the season afresh.
    pub fn refuses_resume(&self) -> bool {
        matches!(
            self,
            JobError::Resume { .. }
                | JobError::Simulation(crate::sim::season::SimError::ResumeDiverged { .. })
        )
    }
}

/// Why a job could not run, or ran and failed; each message says what to do.
#[derive(Debug, Error)]
pub enum JobError {
    /// The model file has errors; the rendered diagnostics (file:line:column) are the
    /// message.
    #[error("{0}")]
    Model(String),
    /// The weather file could not be read, or does not fit the model.
    #[error("{0}")]
    Weather(#[from] crate::sim::weather::WeatherError),
    /// A season stopped: the weather does not cover it or fit the model, the controller
    /// failed, the state diverged, or the step log could not be written.
    #[error("{0}")]
    Simulation(#[from] crate::sim::season::SimError),
    /// A training or value fit failed (the trainer's, the environment's or the fit's
    /// error).
    #[error(transparent)]
    Rl(#[from] crate::rl::RlError),
    /// A value of the spec is out of range, or a file it names (agent, value network,
    /// inputs) is missing or does not fit the model; the message says which.
    #[error("{0}")]
    Spec(String),
    /// A field of the spec holds a value it cannot have, or names a file that is missing
    /// or does not fit. `field` is its name in a spec (`horizon`, `start_row`); the command
    /// line says it as its flag (`--horizon`, `--start-row`).
    #[error("`{field}`{}: {message}", value.as_ref().map(|v| format!(" = {v}")).unwrap_or_default())]
    Field {
        /// The field's name in a spec.
        field: &'static str,
        /// The value it holds, as written; `None` where it holds none.
        value: Option<String>,
        /// What is wrong with it and what to do.
        message: String,
    },
    /// A run folder or one of its files could not be created or written: the I/O error
    /// is kept as the source.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file or folder that could not be written.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A result file could not be made (encoded, drawn) or written, as a message.
    #[error("cannot write {path}: {message}")]
    Output {
        /// The file or folder that could not be written.
        path: PathBuf,
        /// Why, as the I/O or encoding error says it.
        message: String,
    },
    /// A stopped season's trajectory cannot be resumed from: the message says why.
    #[error("cannot resume from {path}: {message}")]
    Resume {
        /// The stopped run's trajectory.
        path: PathBuf,
        /// Why.
        message: String,
    },
    /// A season in which every solve failed: its files are written (with the message in
    /// `summary.json`'s `warnings`), but the run counts as failed.
    #[error("{0}")]
    NoSolveSucceeded(String),
}
