//! `ghm simulate`: a season with fixed inputs or inputs from a CSV file.

use crate::cli::args::{FolderArgs, PlantArgs, WeatherArgs};
use crate::cli::CliError;
use crate::job::{ControllerSpec, InputsSpec, RunSpec};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// Inputs: `const:u1,u2,...` for the same input every step, or a CSV file with one row per
    /// step and one column per input (named as the model's inputs). Default: the start input.
    #[arg(long, value_name = "const:U,.. | FILE.csv", conflicts_with = "rules")]
    pub inputs: Option<String>,
    /// Let the model's own rules decide (each input's `rule`, as a model imported from
    /// GreenLight has GreenLight's climate control), held over each step.
    #[arg(long)]
    pub rules: bool,
    /// Apply the inputs as given, without clipping to bounds and rate limits.
    #[arg(long)]
    pub no_rate_limit: bool,
    #[command(flatten)]
    pub plant: PlantArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/simulate")]
    pub out: PathBuf,
    #[command(flatten)]
    pub folder: FolderArgs,
}

pub fn run(args: &SimulateArgs) -> Result<(), CliError> {
    let spec = RunSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        plant: args.plant.spec(),
        controller: if args.rules {
            ControllerSpec::Rules
        } else {
            ControllerSpec::Inputs(InputsSpec {
                inputs: args.inputs.clone(),
                enforce_limits: !args.no_rate_limit,
            })
        },
    };
    args.folder.run_season(&spec, &args.out)?;
    Ok(())
}
