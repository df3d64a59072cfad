//! `ghm study`: a whole comparison from one file. A study file names models, weather,
//! controllers, horizons and scenarios ([`plan()`]); every season it implies is a job of the
//! job layer ([`crate::job`]) with its own run folder under the study's output folder, run
//! in parallel over the cores ([`run_study`]).
//!
//! A finished job is never run again: a job folder whose `run.json` says `complete` and
//! records the same spec is taken as it is, so a study that was stopped (or killed)
//! completes when the same command runs again, with nothing recomputed. A job folder that
//! holds anything else — an interrupted run, a run of another spec — is run afresh. The
//! results of every complete job are gathered into `results.csv`.

pub mod breakdown;
mod jobs;
pub mod markdown;
mod own_agents;
pub mod plan;
pub mod report;
pub mod run;
mod table;

pub use markdown::splice;
pub use plan::{plan, Job};
pub use report::{gather, report_markdown, write_report, JobRow, ReportOutcome};
pub use run::{run_study, Shard, StudyOptions, StudyOutcome};

use std::path::PathBuf;
use thiserror::Error;

/// Why a study could not be planned or run.
#[derive(Debug, Error)]
pub enum StudyError {
    /// The study file could not be read, or says something that cannot be planned.
    #[error("{path}: {message}")]
    File {
        /// The study file.
        path: PathBuf,
        /// What is wrong, with line and column where the TOML parser gives them.
        message: String,
    },
    /// A `--shard` that is not `i/n` with `i < n`.
    #[error("{0}")]
    Shard(String),
    /// The output folder or one of the study's own files could not be written.
    #[error(transparent)]
    Job(#[from] crate::job::JobError),
    /// Some jobs failed; their folders say why (`run.json`'s `error`).
    #[error("{failed} of {total} jobs failed: {list}")]
    JobsFailed {
        /// How many failed.
        failed: usize,
        /// How many the study (or this shard) has.
        total: usize,
        /// The failed jobs' folders.
        list: String,
    },
}
