//! `ghm serve`: the controller of `ghm mpc`, `ghm rlmpc`, `ghm policy` or the expert as an
//! HTTP/JSON service with a journal (`docs/serve.md`). The flags are those commands' own;
//! this file only maps them onto a spec and the service's options.

use crate::cli::mpc::{self, NlpArgs};
use crate::cli::rlmpc::{self, GuideArgs};
use crate::cli::CliError;
use crate::job::{ControllerSpec, PlantSpec, RunSpec, WeatherSpec};
use crate::serve::token::read_token;
use crate::serve::ServeOptions;
use clap::{Args, ValueEnum};
use std::net::SocketAddr;
use std::path::PathBuf;

/// The controllers that can be served.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Served {
    /// Economic MPC (the options of `ghm mpc`).
    Mpc,
    /// RL-guided MPC (the options of `ghm rlmpc`).
    Rlmpc,
    /// A trained policy (`--agent`, or the one shipped for the model).
    Policy,
    /// The rule-based expert.
    Expert,
}

/// The controller a service runs or `ghm compile` packs: the model and the options of the
/// controller's own command.
#[derive(Debug, Args)]
pub struct ControllerArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// What decides, with the options of its command: `--agent` is the policy's or the
    /// guide's; the weather options pick the agents shipped for the model (the built-in
    /// weather has its own), and the season's length does not matter to a controller.
    #[arg(long, value_enum)]
    pub controller: Served,
    /// Prediction horizon of mpc (default 3h) and rlmpc (default 1h).
    #[arg(long, value_name = "H")]
    pub horizon: Option<String>,
    #[command(flatten)]
    pub nlp: NlpArgs,
    #[command(flatten)]
    pub guidance: GuideArgs,
    #[command(flatten)]
    pub weather: WeatherSpec,
    #[command(flatten)]
    pub plant: PlantSpec,
}

impl ControllerArgs {
    /// The spec of the controller.
    pub fn spec(&self) -> Result<RunSpec, CliError> {
        Ok(RunSpec {
            model: self.file.clone(),
            weather: self.weather.clone(),
            plant: self.plant.clone(),
            controller: self.controller()?,
        })
    }

    fn controller(&self) -> Result<ControllerSpec, CliError> {
        let horizon = |default: &str| self.horizon.clone().unwrap_or_else(|| default.into());
        Ok(match self.controller {
            Served::Mpc => ControllerSpec::Mpc(self.nlp.mpc(&horizon(mpc::DEFAULT_HORIZON))),
            Served::Rlmpc => ControllerSpec::Rlmpc(
                self.guidance
                    .rlmpc(&horizon(rlmpc::DEFAULT_HORIZON), &self.nlp),
            ),
            Served::Policy | Served::Expert if self.horizon.is_some() => {
                return Err(CliError::Argument(
                    "--horizon is for --controller mpc and rlmpc; a policy and the expert look \
                     one step ahead"
                        .into(),
                ))
            }
            Served::Policy => ControllerSpec::Policy {
                agent: self.guidance.agent.clone(),
            },
            Served::Expert => ControllerSpec::Expert,
        })
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
