//! `ghm value`: the value network of RL-guided MPC. The flags map onto a value-fit job
//! (`job::value`), which rolls the guide out, fits the network and writes `value.json`,
//! the learning curve and `summary.json`.

use crate::cli::args::{choice, WeatherArgs};
use crate::cli::CliError;
use crate::job::value::{run_value_job, ValueSpec};
use crate::job::{GuideChoice, JobOptions};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct ValueArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// The guide whose returns are learned.
    #[arg(long, value_parser = choice::<GuideChoice>(), default_value_t = ValueSpec::default().guide)]
    pub guide: GuideChoice,
    /// The guide's policy (a `ghm train` or `ghm distill` folder, or a policy file);
    /// default: the SAC agent shipped for the model under models/agents/.
    #[arg(long, value_name = "DIR")]
    pub agent: Option<PathBuf>,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// Roll-outs from perturbed states.
    #[arg(long, value_name = "N", default_value_t = ValueSpec::default().trajectories)]
    pub trajectories: usize,
    /// Relative spread σ of the start states around the guide's season.
    #[arg(long, value_name = "SIGMA", default_value_t = ValueSpec::default().spread)]
    pub spread: f64,
    /// The state the value function reads (default: the model's first state).
    #[arg(long, value_name = "NAME")]
    pub state: Option<String>,
    /// Training epochs of the value network.
    #[arg(long, value_name = "N", default_value_t = ValueSpec::default().epochs)]
    pub epochs: usize,
    /// Points per gradient step of the fit.
    #[arg(long, value_name = "N", default_value_t = ValueSpec::default().batch_size)]
    pub batch_size: usize,
    /// Initial Adam learning rate of the fit, decaying linearly to zero.
    #[arg(long, value_name = "LR", default_value_t = ValueSpec::default().learning_rate)]
    pub learning_rate: f64,
    /// Seed of the roll-outs and of the fit.
    #[arg(long, value_name = "S", default_value_t = ValueSpec::default().seed)]
    pub seed: u64,
    /// Also write the fitted points to value_data.csv in the run folder (the state, the
    /// step, the return), for fitting them elsewhere.
    #[arg(long)]
    pub save_data: bool,
    /// Run folder.
    #[arg(long, value_name = "DIR", default_value = "runs/value")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &ValueArgs) -> Result<(), CliError> {
    let spec = ValueSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        guide: args.guide,
        agent: args.agent.clone(),
        trajectories: args.trajectories,
        spread: args.spread,
        state: args.state.clone(),
        epochs: args.epochs,
        batch_size: args.batch_size,
        learning_rate: args.learning_rate,
        seed: args.seed,
        save_data: args.save_data,
    };
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    Ok(run_value_job(&spec, &args.out, &options)?)
}
