//! `ghm mpc`: a season of economic MPC.

use crate::cli::CliError;
use crate::job::{
    run_season_job, BandsChoice, ControllerSpec, JobOptions, MpcSpec, PlantSpec, RunSpec,
    SolverChoice, WarmStartChoice, WeatherSpec,
};
use clap::Args;
use std::path::PathBuf;

/// `ghm mpc`'s default horizon.
pub const DEFAULT_HORIZON: &str = "3h";

#[derive(Debug, Args)]
pub struct MpcArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Prediction horizon: `3h`, `90min`, or a number of steps (at most 100 000).
    #[arg(long, value_name = "H", default_value = DEFAULT_HORIZON)]
    pub horizon: String,
    #[command(flatten)]
    pub nlp: NlpArgs,
    #[command(flatten)]
    pub weather: WeatherSpec,
    #[command(flatten)]
    pub plant: PlantSpec,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/mpc")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

/// The NLP back-end and the bands MPC plans with (`ghm mpc`, `ghm rlmpc`, `ghm serve`).
#[derive(Debug, Clone, Args)]
pub struct NlpArgs {
    /// NLP back-end.
    #[arg(long, value_enum, default_value_t = SolverChoice::Ipm)]
    pub solver: SolverChoice,
    /// How each step restarts from the last one's solution: `primal` (the shifted plan,
    /// under guidance with the constraint multipliers; bound multipliers and barrier afresh;
    /// the default of `ipm`), `primal-multipliers` (the same with the constraint
    /// multipliers for plain MPC too: a quarter fewer iterations with `ipm`) or
    /// `primal-dual` (the shifted plan and all multipliers; the default of `sqp` and
    /// `ipopt`).
    #[arg(long, value_enum)]
    pub warm_start: Option<WarmStartChoice>,
    /// Soft-band bounds to plan with: `auto` plans with the model file's `plan` bounds on
    /// an uncertain plant and with the scoring bounds on the nominal one.
    #[arg(long, value_enum, default_value_t = BandsChoice::Auto)]
    pub bands: BandsChoice,
}

impl NlpArgs {
    /// MPC over `horizon` with these settings.
    pub fn mpc(&self, horizon: &str) -> MpcSpec {
        MpcSpec {
            horizon: horizon.to_string(),
            solver: self.solver,
            warm_start: self.warm_start,
            bands: self.bands,
        }
    }
}

pub fn run(args: &MpcArgs) -> Result<(), CliError> {
    let spec = RunSpec {
        model: args.file.clone(),
        weather: args.weather.clone(),
        plant: args.plant.clone(),
        controller: ControllerSpec::Mpc(args.nlp.mpc(&args.horizon)),
    };
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    run_season_job(&spec, &args.out, &options)?;
    Ok(())
}
