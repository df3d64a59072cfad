//! What a study runs: its jobs ([`Job`]), each a season, a training, a distillation or a
//! value fit ([`Work`]), run phase by phase so that a job reads only jobs of earlier phases.

use crate::job::distill::DistillSpec;
use crate::job::train::TrainSpec;
use crate::job::value::ValueSpec;
use crate::job::RunSpec;
use std::path::PathBuf;

/// What a job runs.
#[derive(Debug, Clone, PartialEq)]
pub enum Work {
    /// A season (or the season optimum).
    Season(RunSpec),
    /// A training of a SAC agent.
    Train(TrainSpec),
    /// A value network fitted to a guide's returns.
    Value(ValueSpec),
    /// A guide distilled from a teacher.
    Distill(DistillSpec),
}

/// The phases' names, in the order they run ([`Work::phase`] indexes them).
const PHASE_NAMES: [&str; 3] = ["trainings", "value fits", "seasons"];

impl Work {
    /// The job's kind in `study.json`.
    pub fn kind(&self) -> &'static str {
        match self {
            Work::Season(_) => "season",
            Work::Train(_) => "train",
            Work::Value(_) => "value",
            Work::Distill(_) => "distill",
        }
    }

    /// The phase's name, as the study's log and `timings.csv` say it.
    pub fn phase_name(&self) -> &'static str {
        PHASE_NAMES[self.phase()]
    }

    /// The phase it runs in: a job reads only jobs of earlier phases.
    pub fn phase(&self) -> usize {
        match self {
            Work::Train(_) | Work::Distill(_) => 0,
            Work::Value(_) => 1,
            Work::Season(_) => 2,
        }
    }

    /// The spec as `run.json` records it.
    pub fn spec_json(&self) -> serde_json::Value {
        let value = match self {
            Work::Season(s) => serde_json::to_value(s),
            Work::Train(s) => serde_json::to_value(s),
            Work::Value(s) => serde_json::to_value(s),
            Work::Distill(s) => serde_json::to_value(s),
        };
        value.unwrap_or_default()
    }

    /// The season's spec, for seasons.
    pub fn season(&self) -> Option<&RunSpec> {
        match self {
            Work::Season(s) => Some(s),
            _ => None,
        }
    }
}

/// One planned job.
#[derive(Debug, Clone, PartialEq)]
pub struct Job {
    /// What to run.
    pub work: Work,
    /// The folders (relative to the study's output folder) of the jobs it reads.
    pub needs: Vec<PathBuf>,
    /// Its run folder, relative to the study's output folder.
    pub folder: PathBuf,
    /// The model's file stem (a table's first column).
    pub model: String,
    /// The controller's name as the study file gives it.
    pub controller: String,
    /// The horizon as written, empty for controllers without one.
    pub horizon: String,
    /// `nominal` or `stochastic-NN` (for a training or value fit: the plant it is for).
    pub scenario: String,
}
