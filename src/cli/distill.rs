//! `ghm distill`: a policy taught by a controller with DAgger (by default MPC at 6 h).
//! The flags map onto a distillation job (`job::distill`); run again with the same flags
//! and `--out`, a stopped distillation continues from its last finished iteration.

use crate::cli::args::{self, WeatherArgs};
use crate::cli::mpc::NlpArgs;
use crate::cli::CliError;
use crate::job::distill::{
    run_distill_job, DistillSpec, StartRows, DEFAULT_STOCHASTIC_UNCERTAINTY,
};
use crate::job::{ControllerSpec, JobOptions};
use crate::rl::imitation::ImitationConfig;
use crate::sim::weather::Warming;
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct DistillArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// The teacher's prediction horizon (economic MPC): `6h`, `90min`, or a number of
    /// steps.
    #[arg(long, value_name = "H", default_value = "6h")]
    pub teacher_horizon: String,
    #[command(flatten)]
    pub nlp: NlpArgs,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// DAgger iterations, the teacher's own roll-outs first.
    #[arg(long, value_name = "N", default_value_t = DistillSpec::default().iterations)]
    pub iterations: usize,
    /// Roll-outs per iteration (the first noise-free), each labelled by the teacher.
    #[arg(long, value_name = "N", default_value_t = DistillSpec::default().roll_outs)]
    pub roll_outs: usize,
    /// Standard deviation of the noise on the applied actions (action units, [−1, 1]).
    #[arg(long, value_name = "SIGMA", default_value_t = DistillSpec::default().noise)]
    pub noise: f64,
    /// Start the noisy roll-outs at rows of the weather file drawn from FIRST..LAST (both
    /// included), each its own, to learn from more of the year than the season; the
    /// students are still evaluated on the season.
    #[arg(long, value_name = "FIRST..LAST", value_parser = str::parse::<StartRows>)]
    pub start_rows: Option<StartRows>,
    /// Warm the noisy roll-outs' weather: every temperature (°C) of each raised by degrees
    /// drawn from LO..HI, so the guide meets warmer days than the rows it learns from
    /// (e.g. summer from spring's rows).
    #[arg(long, value_name = "LO..HI", value_parser = str::parse::<Warming>)]
    pub warming: Option<Warming>,
    /// A humidity (vapour density in kg m^-3 or pressure in Pa) the warming keeps at its
    /// relative humidity, as warmer air holds more water (repeat for more).
    #[arg(long, value_name = "NAME", requires = "warming")]
    pub keep_humidity: Vec<String>,
    /// Rows of weather forecast the student observes after the current weather (0: the
    /// current weather only, observation version 1; more: version 2, e.g. 12 for the six
    /// half-hours a 6 h teacher plans over).
    #[arg(long, value_name = "N", default_value_t = DistillSpec::default().forecast_rows)]
    pub forecast_rows: usize,
    /// Roll out on perturbed plants (parameters drawn per roll-out with --uncertainty).
    #[arg(long)]
    pub stochastic: bool,
    /// Parametric uncertainty δ of the perturbed plants [default: 0.05].
    #[arg(long, value_name = "DELTA")]
    pub uncertainty: Option<f64>,
    /// Passes over the labels at each iteration's fit.
    #[arg(long, value_name = "N", default_value_t = ImitationConfig::default().epochs)]
    pub epochs: usize,
    /// Seed of the student's weights, the noise, the shuffles and the parameter draws.
    #[arg(long, value_name = "S", default_value_t = DistillSpec::default().seed)]
    pub seed: u64,
    /// Roll-outs labelled at once [default: the machine's cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Run folder.
    #[arg(long, value_name = "DIR", default_value = "runs/distill")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused; the
    /// same distillation stopped halfway continues instead).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &DistillArgs) -> Result<(), CliError> {
    let threads = args::threads(args.threads)?;
    let spec = DistillSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        teacher: ControllerSpec::Mpc(args.nlp.mpc(&args.teacher_horizon)),
        stochastic: args.stochastic,
        uncertainty: if args.stochastic {
            args.uncertainty.unwrap_or(DEFAULT_STOCHASTIC_UNCERTAINTY)
        } else {
            0.0
        },
        seed: args.seed,
        iterations: args.iterations,
        roll_outs: args.roll_outs,
        noise: args.noise,
        start_rows: args.start_rows,
        warming: args
            .warming
            .clone()
            .map(|w| w.keeping_humidity(args.keep_humidity.iter().cloned())),
        forecast_rows: args.forecast_rows,
        fit: ImitationConfig {
            epochs: args.epochs,
            ..ImitationConfig::default()
        },
    };
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    Ok(run_distill_job(
        &spec,
        &args.out,
        &options,
        !args.overwrite,
        threads,
    )?)
}
