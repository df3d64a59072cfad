//! Options shared by the commands that use a guide (`ghm value`, `ghm rlmpc`): which guide,
//! which agent, and where the shipped agents live (`models/agents/<model file stem>/`
//! beside the model file).

use crate::cli::policy::load_policy;
use crate::cli::CliError;
use crate::control::{Controller, Expert, Policy};
use crate::model::Plant;
use crate::rl::PolicyFile;
use clap::ValueEnum;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Which policy guides RL-guided MPC.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GuideChoice {
    /// The trained SAC policy (`--agent`, or the one shipped for the model).
    Sac,
    /// The rule-based expert: no training needed.
    Expert,
}

impl GuideChoice {
    pub fn name(self) -> &'static str {
        match self {
            GuideChoice::Sac => "sac",
            GuideChoice::Expert => "expert",
        }
    }
}

/// `models/agents/<stem>/` beside the model file.
pub fn shipped_dir(model_file: &Path) -> PathBuf {
    let stem = model_file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    model_file
        .parent()
        .unwrap_or(Path::new("."))
        .join("agents")
        .join(stem)
}

/// The policy of `--agent`, or the shipped one.
pub fn resolve_policy(model_file: &Path, agent: Option<&Path>) -> Result<PolicyFile, CliError> {
    match agent {
        Some(a) => load_policy(a),
        None => {
            let dir = shipped_dir(model_file);
            load_policy(&dir).map_err(|_| {
                CliError::Argument(format!(
                    "no agent shipped for {} (looked in {}); train one with `ghm train` and pass --agent DIR",
                    model_file.display(),
                    dir.display()
                ))
            })
        }
    }
}

/// A factory of guide controllers (one per thread or per use).
pub type GuideFactory = Box<dyn Fn() -> Box<dyn Controller + Send> + Sync>;

/// Builds the guide factory for `choice`.
pub fn guide_factory(
    plant: &Arc<Plant>,
    choice: GuideChoice,
    model_file: &Path,
    agent: Option<&Path>,
) -> Result<GuideFactory, CliError> {
    let fail = |e: crate::control::ControlError| CliError::Argument(e.to_string());
    match choice {
        GuideChoice::Sac => {
            let file = resolve_policy(model_file, agent)?;
            let policy = Policy::new(plant, file).map_err(fail)?;
            Ok(Box::new(move || {
                Box::new(policy.clone()) as Box<dyn Controller + Send>
            }))
        }
        GuideChoice::Expert => {
            let expert = Expert::new(plant.clone()).map_err(fail)?;
            Ok(Box::new(move || {
                Box::new(expert.clone()) as Box<dyn Controller + Send>
            }))
        }
    }
}
