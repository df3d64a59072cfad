//! `ghm policy`: a season driven by a trained deterministic policy (`policy.json` from
//! `ghm train`, or the agent shipped for the model) or by the rule-based expert, with the
//! outputs of `ghm simulate`.

use crate::cli::guide::resolve_policy;
use crate::cli::simulate::{run_season_and_report, SeasonArgs};
use crate::cli::weather_args::{UncertaintyArgs, WeatherArgs};
use crate::cli::{load_model, CliError};
use crate::control::{Controller, Expert, Policy};
use crate::model::Plant;
use clap::Args;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;

#[derive(Debug, Args)]
pub struct PolicyArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// The agent: a training folder of `ghm train` (its policy.json is used) or a policy
    /// file. Default: the agent shipped for the model under models/agents/.
    #[arg(long, value_name = "DIR")]
    pub agent: Option<PathBuf>,
    /// Run the rule-based expert instead of a trained agent.
    #[arg(long, conflicts_with = "agent")]
    pub expert: bool,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: UncertaintyArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/policy")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

/// The policy file of an agent folder or file, which must exist.
pub(crate) fn policy_path(agent: &Path) -> Result<PathBuf, CliError> {
    let path = if agent.is_dir() {
        agent.join("policy.json")
    } else {
        agent.to_path_buf()
    };
    if !path.is_file() {
        return Err(CliError::Argument(format!(
            "no policy at {}: pass a folder written by `ghm train` or its policy.json",
            path.display()
        )));
    }
    Ok(path)
}

pub fn run(args: &PolicyArgs) -> Result<(), CliError> {
    let model = load_model(&args.file)?;
    let plant = Arc::new(Plant::new(model));
    let (mut controller, extra): (Box<dyn Controller>, _) = if args.expert {
        let expert = Expert::new(plant.clone()).map_err(|e| CliError::Argument(e.to_string()))?;
        (Box::new(expert), json!({ "agent": "expert" }))
    } else {
        let file = resolve_policy(&args.file, &args.weather, args.agent.as_deref(), &plant)?;
        let extra = json!({
            "agent": args.agent.as_ref().map_or("shipped".into(), |a| a.display().to_string()),
            "agent_episode": file.episode,
        });
        let policy = Policy::new(&plant, file).map_err(|e| CliError::Argument(e.to_string()))?;
        (Box::new(policy), extra)
    };
    let season = SeasonArgs {
        file: &args.file,
        weather: &args.weather,
        uncertainty: &args.plant,
        out: &args.out,
        overwrite: args.overwrite,
        enforce_limits: true,
        forecast: 0,
    };
    run_season_and_report(&season, &plant, controller.as_mut(), extra)?;
    Ok(())
}
