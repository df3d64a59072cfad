//! `ghm policy`: a season driven by a trained deterministic policy (`policy.json` from
//! `ghm train`, or the agent shipped for the model) or by the rule-based expert, with the
//! outputs of `ghm simulate`.

use crate::cli::args::{PlantArgs, WeatherArgs};
use crate::cli::CliError;
use crate::job::{run_season_job, ControllerSpec, JobOptions, RunSpec};
use clap::Args;
use std::path::PathBuf;

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
    pub plant: PlantArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/policy")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &PolicyArgs) -> Result<(), CliError> {
    let controller = if args.expert {
        ControllerSpec::Expert
    } else {
        ControllerSpec::Policy {
            agent: args.agent.clone(),
        }
    };
    let spec = RunSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        plant: args.plant.spec(),
        controller,
    };
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    run_season_job(&spec, &args.out, &options)?;
    Ok(())
}
