//! `ghm mpc`: a season of economic MPC.

use crate::cli::args::{choice, FolderArgs, PlantArgs, WeatherArgs};
use crate::cli::CliError;
use crate::job::{BandsChoice, ControllerSpec, MpcSpec, RunSpec, SolverChoice, WarmStart};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct MpcArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Prediction horizon: `3h`, `90min`, or a number of steps (at most 100 000).
    #[arg(long, value_name = "H", default_value_t = MpcSpec::default().horizon)]
    pub horizon: String,
    #[command(flatten)]
    pub nlp: NlpArgs,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: PlantArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/mpc")]
    pub out: PathBuf,
    #[command(flatten)]
    pub folder: FolderArgs,
}

/// The NLP back-end and the bands MPC plans with (`ghm mpc`, `ghm rlmpc`, `ghm serve`).
#[derive(Debug, Clone, Args)]
pub struct NlpArgs {
    /// NLP back-end.
    #[arg(long, value_parser = choice::<SolverChoice>(), default_value_t = MpcSpec::default().solver)]
    pub solver: SolverChoice,
    /// How each step restarts from the last one's solution (default: `primal` with `ipm`,
    /// `primal-dual` with `sqp` and `ipopt`).
    #[arg(long, value_parser = choice::<WarmStart>())]
    pub warm_start: Option<WarmStart>,
    /// Soft-band bounds to plan with.
    #[arg(long, value_parser = choice::<BandsChoice>(), default_value_t = MpcSpec::default().bands)]
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
        weather: args.weather.spec(),
        plant: args.plant.spec(),
        controller: ControllerSpec::Mpc(args.nlp.mpc(&args.horizon)),
    };
    args.folder.run_season(&spec, &args.out)?;
    Ok(())
}
