//! `ghm replay`: a season whose controller is a running `ghm serve`, the simulator playing
//! the greenhouse. The season, its files and its folder are those of `ghm mpc` (the job
//! layer runs it); only the decisions come over HTTP.

use crate::cli::args::{PlantArgs, WeatherArgs};
use crate::cli::serve::serve_error;
use crate::cli::CliError;
use crate::job::output::model_hash;
use crate::job::{load_model, run_external_season_job, ExternalController, JobOptions, RunSpec};
use crate::model::Plant;
use crate::serve::api::DEFAULT_SESSION;
use crate::serve::client::RemoteController;
use crate::serve::token::read_token;
use clap::Args;
use serde_json::json;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The model file (.ghm): the greenhouse the simulator plays; the service must serve
    /// the same model.
    pub file: PathBuf,
    /// The service, e.g. http://127.0.0.1:8750.
    #[arg(long, value_name = "URL")]
    pub server: String,
    /// The session (greenhouse) to decide for: a replay repeated on the same session and
    /// journal gets the journaled answers back.
    #[arg(long, value_name = "NAME", default_value = DEFAULT_SESSION)]
    pub session: String,
    /// A file whose first line is the service's API token; or set GHM_SERVE_TOKEN.
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
    /// How long to keep retrying a request while the service does not answer (restarting).
    #[arg(long, value_name = "SECONDS", default_value_t = 120.0)]
    pub retry_for: f64,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: PlantArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/replay")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &ReplayArgs) -> Result<(), CliError> {
    if !(args.retry_for.is_finite() && (0.0..=86_400.0).contains(&args.retry_for)) {
        return Err(CliError::Argument(
            "--retry-for must be between 0 and 86400 seconds".into(),
        ));
    }
    let token = read_token(args.token_file.as_deref()).map_err(serve_error)?;
    let remote = RemoteController::connect(
        &args.server,
        token.as_deref(),
        &args.session,
        Duration::from_secs_f64(args.retry_for),
    )
    .map_err(serve_error)?;
    let info = remote.info().clone();
    let plant = Plant::new(load_model(&args.file)?);
    let ours = model_hash(&plant);
    if ours != info.model_sha256 {
        return Err(CliError::Argument(format!(
            "{} serves model `{}` (SHA-256 {}); {} is another (SHA-256 {ours}): replay the model \
             the service serves",
            args.server,
            info.model,
            info.model_sha256,
            args.file.display()
        )));
    }
    let spec = RunSpec {
        model: args.file.clone(),
        weather: args.weather.spec(),
        plant: args.plant.spec(),
        controller: info.spec.controller.clone(),
    };
    let external = ExternalController {
        controller: Box::new(remote),
        forecast_rows: info.forecast_rows,
        label: info.controller.clone(),
        extra: json!({
            "server": args.server,
            "session": args.session,
            "served_spec": info.spec,
        }),
    };
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    run_external_season_job(&spec, external, &args.out, &options)?;
    Ok(())
}
