//! `ghm serve`: the controller of `ghm mpc`, `ghm rlmpc`, `ghm policy` or the expert as an
//! HTTP/JSON service with a journal (`docs/serve.md`). The flags are those commands' own;
//! this file only maps them onto a spec and the service's options.

use crate::cli::args::{choice_where, PlantArgs, WeatherArgs};
use crate::cli::mpc::NlpArgs;
use crate::cli::rlmpc::GuideArgs;
use crate::cli::CliError;
use crate::job::{ControllerKind, ControllerSpec, RunSpec};
use crate::serve::token::read_token;
use crate::serve::ServeOptions;
use clap::Args;
use std::net::SocketAddr;
use std::path::PathBuf;

/// The controller a service runs or `ghm compile` packs: the model and the options of the
/// controller's own command.
#[derive(Debug, Args)]
pub struct ControllerArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// What decides, with the options of its command: `--agent` is the policy's or the
    /// guide's; the weather options pick the agents shipped for the model (the built-in
    /// weather has its own), and the season's length does not matter to a controller.
    #[arg(long, value_parser = choice_where(ControllerKind::is_feedback))]
    pub controller: ControllerKind,
    /// Prediction horizon of mpc and rlmpc (default: that of `ghm mpc` and `ghm rlmpc`).
    #[arg(long, value_name = "H")]
    pub horizon: Option<String>,
    #[command(flatten)]
    pub nlp: NlpArgs,
    #[command(flatten)]
    pub guidance: GuideArgs,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: PlantArgs,
}

impl ControllerArgs {
    /// The spec of the controller.
    pub fn spec(&self) -> Result<RunSpec, CliError> {
        Ok(RunSpec {
            model: self.file.clone(),
            weather: self.weather.spec(),
            plant: self.plant.spec(),
            controller: self.controller()?,
        })
    }

    /// The controller of `--controller` with its command's options; every setting not
    /// given keeps the kind's default.
    fn controller(&self) -> Result<ControllerSpec, CliError> {
        let kind = self.controller;
        if self.horizon.is_some() && !kind.has_horizon() {
            return Err(CliError::Argument(format!(
                "--horizon is for --controller mpc and rlmpc; {kind} looks one step ahead"
            )));
        }
        let horizon = |default: &str| self.horizon.clone().unwrap_or_else(|| default.into());
        let mut spec = ControllerSpec::default_of(kind);
        match &mut spec {
            ControllerSpec::Mpc(mpc) => *mpc = self.nlp.mpc(&horizon(&mpc.horizon)),
            ControllerSpec::Rlmpc(rlmpc) => {
                let mpc = self.nlp.mpc(&horizon(&rlmpc.mpc.horizon));
                *rlmpc = self.guidance.rlmpc(mpc);
            }
            ControllerSpec::Policy { agent } => agent.clone_from(&self.guidance.agent),
            ControllerSpec::Expert | ControllerSpec::Rules => {}
            ControllerSpec::Inputs(_) | ControllerSpec::Optimum(_) => {
                return Err(CliError::Argument(format!(
                    "--controller {kind}: only a controller that decides from the state can be \
                     served or compiled"
                )))
            }
        }
        Ok(spec)
    }
}

#[derive(Debug, Args)]
pub struct ServeArgs {
    #[command(flatten)]
    pub served: ControllerArgs,
    /// Address to listen on; port 0 picks a free port (the address is printed). Beyond
    /// loopback an API token is required.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8750")]
    pub listen: SocketAddr,
    /// The journal (SQLite): every decision and its request. An existing journal is
    /// resumed: it must have been begun with the same options and model.
    #[arg(long, value_name = "FILE", default_value = "ghm-serve.sqlite")]
    pub journal: PathBuf,
    /// A file whose first line is the API token `POST /decide` requires (at least 16
    /// characters); or set GHM_SERVE_TOKEN.
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
    /// The most sessions (greenhouses, each with its own controller) served.
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub max_sessions: usize,
    /// The largest request body, in bytes (larger: 413).
    #[arg(long, value_name = "BYTES", default_value_t = 1 << 20)]
    pub max_body: usize,
}

pub fn run(args: &ServeArgs) -> Result<(), CliError> {
    let spec = args.served.spec()?;
    let token = read_token(args.token_file.as_deref()).map_err(serve_error)?;
    crate::serve::run(ServeOptions {
        spec,
        listen: args.listen,
        journal: args.journal.clone(),
        token,
        max_sessions: args.max_sessions.max(1),
        max_body: args.max_body,
    })
    .map_err(serve_error)
}

/// A service's error as the command line's.
pub fn serve_error(e: crate::serve::ServeError) -> CliError {
    match e {
        crate::serve::ServeError::Job(j) => CliError::Job(j),
        other => CliError::Serve(other),
    }
}
