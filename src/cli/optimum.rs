//! `ghm optimum`: the whole-season perfect-foresight optimum, the upper bound for every
//! controller on the deterministic season.

use crate::cli::args::choice;
use crate::cli::args::WeatherArgs;
use crate::cli::CliError;
use crate::job::{
    run_season_job, ControllerSpec, JobOptions, OptimumSpec, PlantSpec, RunSpec, SolverChoice,
};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct OptimumArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Horizon of the closed-loop MPC run that initialises the optimum.
    #[arg(long, value_name = "H", default_value_t = OptimumSpec::default().init_horizon)]
    pub init_horizon: String,
    /// Start from the inputs in this CSV instead of a closed loop of MPC: a row per step,
    /// columns named as the model's inputs or `u_<input>` (a season's `trajectory.csv`,
    /// e.g. a study's MPC season over the same weather).
    #[arg(long, value_name = "CSV")]
    pub init_inputs: Option<PathBuf>,
    /// NLP back-end for the season NLP (default: ipopt where built with it; otherwise the
    /// pure-Rust interior point, which factorises the 1920 stages by a Riccati recursion).
    #[arg(long, value_parser = choice::<SolverChoice>())]
    pub solver: Option<SolverChoice>,
    /// Iteration limit of the season NLP.
    #[arg(long, value_name = "N", default_value_t = OptimumSpec::default().max_iterations)]
    pub max_iterations: usize,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/optimum")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &OptimumArgs) -> Result<(), CliError> {
    let spec = RunSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        plant: PlantSpec::NOMINAL,
        controller: ControllerSpec::Optimum(OptimumSpec {
            init_horizon: args.init_horizon.clone(),
            init_inputs: args.init_inputs.clone(),
            solver: args.solver,
            max_iterations: args.max_iterations,
        }),
    };
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    run_season_job(&spec, &args.out, &options)?;
    Ok(())
}
