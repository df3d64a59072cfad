//! Options shared by the commands that use a guide (`ghm value`, `ghm rlmpc`): which guide,
//! which agent, and where the shipped agents live (`models/agents/<model file stem>/`
//! beside the model file).

use crate::cli::policy::policy_path;
use crate::cli::weather_args::WeatherArgs;
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

/// The agents shipped for `model_file`: `models/agents/<stem>/` beside it, trained on the
/// Venlo 2014 season; on ghm's built-in weather, its `builtin/` subfolder where one is
/// shipped. An agent trained on one season has learned that season's weather, and the
/// built-in season is not Venlo's.
pub fn shipped_dir(model_file: &Path, weather: &WeatherArgs) -> PathBuf {
    let stem = model_file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let dir = model_file
        .parent()
        .unwrap_or(Path::new("."))
        .join("agents")
        .join(stem);
    let builtin = dir.join("builtin");
    if weather.is_builtin() && builtin.join("policy.json").is_file() {
        builtin
    } else {
        dir
    }
}

/// The policy of `--agent`, or the shipped one (see [`shipped_dir`]), checked against
/// `plant`: its observation and inputs must be the model's; another model name is only
/// warned about.
pub fn resolve_policy(
    model_file: &Path,
    weather: &WeatherArgs,
    agent: Option<&Path>,
    plant: &Plant,
) -> Result<PolicyFile, CliError> {
    let path = match agent {
        Some(a) => policy_path(a)?,
        None => {
            let dir = shipped_dir(model_file, weather);
            let path = dir.join("policy.json");
            if !path.is_file() {
                return Err(CliError::Argument(format!(
                    "no agent shipped for {} (looked in {}); train one with `ghm train` and pass --agent DIR",
                    model_file.display(),
                    dir.display()
                )));
            }
            eprintln!("using the agent shipped in {}", dir.display());
            path
        }
    };
    let fail = |e: crate::rl::RlError| CliError::Argument(e.to_string());
    let policy = PolicyFile::load(&path).map_err(fail)?;
    policy.check_fits(&plant.model, &path).map_err(fail)?;
    if policy.model != plant.model.name {
        eprintln!(
            "warning: the policy was trained on model `{}`, this is `{}`",
            policy.model, plant.model.name
        );
    }
    Ok(policy)
}

/// A factory of guide controllers (one per thread or per use).
pub type GuideFactory = Box<dyn Fn() -> Box<dyn Controller + Send> + Sync>;

/// Builds the guide factory for `choice`.
pub fn guide_factory(
    plant: &Arc<Plant>,
    choice: GuideChoice,
    model_file: &Path,
    weather: &WeatherArgs,
    agent: Option<&Path>,
) -> Result<GuideFactory, CliError> {
    let fail = |e: crate::control::ControlError| CliError::Argument(e.to_string());
    match choice {
        GuideChoice::Sac => {
            let file = resolve_policy(model_file, weather, agent, plant)?;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn weather(file: Option<&str>) -> WeatherArgs {
        WeatherArgs {
            weather: file.map(PathBuf::from),
            start_row: 0,
            knmi: None,
            knmi_co2: 420.0,
            weather_seed: 2014,
            days: None,
            steps: None,
        }
    }

    #[test]
    fn the_built_in_weather_picks_the_builtin_agent_where_one_is_shipped() {
        let root = std::env::temp_dir().join(format!("ghm-shipped-{}", std::process::id()));
        let dir = root.join("agents").join("plant");
        std::fs::create_dir_all(dir.join("builtin")).unwrap();
        let model = root.join("plant.ghm");
        // No builtin/policy.json yet: the season's agent for every weather.
        assert_eq!(shipped_dir(&model, &weather(None)), dir);
        std::fs::write(dir.join("builtin").join("policy.json"), "{}").unwrap();
        assert_eq!(shipped_dir(&model, &weather(None)), dir.join("builtin"));
        assert_eq!(shipped_dir(&model, &weather(Some("venlo.csv"))), dir);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
