//! The `ghm` command line: argument parsing, run folders, progress and messages.
//! Every failure becomes a [`CliError`] with a message that says what to do; nothing here
//! panics on user input.

mod args;
mod check;
mod compile;
mod completions;
mod distill;
mod import;
mod mpc;
mod optimum;
mod policy;
mod replay;
mod report;
mod rlmpc;
mod serve;
mod simulate;
mod study;
mod train;
mod value;

use crate::job::JobError;
use clap::{Parser, Subcommand};
use thiserror::Error;

/// Errors of the command line, each printed as one clear message.
#[derive(Debug, Error)]
pub enum CliError {
    /// A job (a season, its model, weather, controller or run folder) could not run or
    /// failed; see [`JobError`]. An error about a spec field is an [`CliError::Argument`]
    /// that names its flag.
    #[error(transparent)]
    Job(JobError),
    /// A study could not be planned or run, or some of its jobs failed.
    #[error(transparent)]
    Study(#[from] crate::study::StudyError),
    /// A season stopped: the weather does not cover it or fit the model, the controller
    /// failed, the state diverged, or the step log could not be written.
    #[error("{0}")]
    Simulation(#[from] crate::sim::season::SimError),
    /// A command-line value that is out of range or does not fit the model, or an error of
    /// the trainer or a value fit; the message says which.
    #[error("{0}")]
    Argument(String),
    /// A service could not start or stopped (`ghm serve`, `ghm replay`'s client).
    #[error(transparent)]
    Serve(#[from] crate::serve::ServeError),
    /// A model could not be imported (`ghm import`); the message names the file and the
    /// variable.
    #[error(transparent)]
    Import(#[from] crate::import::ImportError),
    /// A controller could not be compiled (`ghm compile`).
    #[error(transparent)]
    Embed(#[from] crate::embed::EmbedError),
    /// A file could not be read or written; `what` says which and how.
    #[error("{what}: {source}")]
    Io {
        /// `cannot read FILE`, `cannot write FILE`.
        what: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A JSON file ghm wrote could not be read back; `what` names it (and the field).
    #[error("{what}: {source}")]
    Json {
        /// The file, and the field where one is meant.
        what: String,
        /// The decoding error.
        #[source]
        source: serde_json::Error,
    },
    /// `ghm check --verify-derivatives`: the exact derivatives of the step differ from the
    /// numerical ones; holds the largest relative error (Jacobian or Hessian), above 1e-6.
    #[error("derivative check failed: largest relative error {0:.3e} exceeds 1e-6")]
    DerivativeCheck(f64),
    /// `ghm check --verify-derivatives`: a value or exact derivative of the step is NaN
    /// or infinite at a point checked; the message names it.
    #[error("derivative check failed: {0}")]
    DerivativeNotFinite(String),
}

impl From<JobError> for CliError {
    /// A spec field's error said as its flag (`--horizon 3x: expected ...`).
    fn from(e: JobError) -> Self {
        match e {
            JobError::Field {
                field,
                value,
                message,
            } => CliError::Argument(match value {
                Some(value) => format!("{} {value}: {message}", args::flag(field)),
                None => format!("{}: {message}", args::flag(field)),
            }),
            other => CliError::Job(other),
        }
    }
}

#[derive(Debug, Parser)]
#[command(
    name = "ghm",
    version,
    about = "Economic model-predictive control with learned guidance, from .ghm model files",
    long_about = "ghm compiles a plant and its economic cost written in the .ghm language into exact-derivative \
functions, and runs seasons of control on it: fixed inputs, economic MPC, learned policies and RL-guided MPC.\n\n\
Start with `ghm check models/lettuce.ghm`, then `ghm simulate models/lettuce.ghm`."
)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Parse and check a model, print a summary (and optionally verify its derivatives).
    Check(check::CheckArgs),
    /// Run a season with fixed inputs or inputs from a CSV file.
    Simulate(simulate::SimulateArgs),
    /// Run a season of economic MPC.
    Mpc(mpc::MpcArgs),
    /// Solve the whole season as one NLP with perfect foresight: the upper bound.
    Optimum(optimum::OptimumArgs),
    /// Train a soft actor-critic agent on the model's season (resumable).
    Train(train::TrainArgs),
    /// Run a season with a trained policy.
    Policy(policy::PolicyArgs),
    /// Fit the value network of RL-guided MPC to a guide's returns.
    Value(value::ValueArgs),
    /// Distil a controller (MPC at a long horizon) into a policy with DAgger: a guide for
    /// RL-guided MPC (resumable).
    Distill(distill::DistillArgs),
    /// Run a season of RL-guided MPC (learned terminal cost, terminal region, guide warm start).
    Rlmpc(rlmpc::RlmpcArgs),
    /// Run every season of a study file (controllers × horizons × scenarios), in parallel
    /// and resumable.
    Study(study::StudyArgs),
    /// Tables and figures of study folders (runs or shards), merged.
    Report(report::ReportArgs),
    /// Serve a controller over HTTP/JSON, every decision journaled (docs/serve.md).
    Serve(serve::ServeArgs),
    /// Run a season against a running `ghm serve`, the simulator playing the greenhouse.
    Replay(replay::ReplayArgs),
    /// Compile a controller into a static library with a C ABI (model, networks and options
    /// built in).
    Compile(compile::CompileArgs),
    /// Import a model from another tool: `ghm import greenlight MODEL.json --out DIR`
    /// writes a .ghm model (and the weather as a ghm CSV).
    Import(import::ImportArgs),
    /// Print the completion script of a shell (bash, zsh, fish, elvish, powershell), e.g.
    /// `ghm completions bash > ~/.local/share/bash-completion/completions/ghm`.
    Completions(completions::CompletionsArgs),
}

/// Runs the command line; returns the process exit code.
pub fn main() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check(a) => check::run(&a),
        Command::Simulate(a) => simulate::run(&a),
        Command::Mpc(a) => mpc::run(&a),
        Command::Optimum(a) => optimum::run(&a),
        Command::Train(a) => train::run(&a),
        Command::Policy(a) => policy::run(&a),
        Command::Value(a) => value::run(&a),
        Command::Distill(a) => distill::run(&a),
        Command::Rlmpc(a) => rlmpc::run(&a),
        Command::Study(a) => study::run(&a),
        Command::Report(a) => report::run(&a),
        Command::Serve(a) => serve::run(&a),
        Command::Replay(a) => replay::run(&a),
        Command::Compile(a) => compile::run(&a),
        Command::Import(a) => import::run(&a),
        Command::Completions(a) => completions::run(&a),
    };
    match result {
        Ok(()) => 0,
        Err(CliError::Job(JobError::Model(text))) => {
            eprint!("{text}");
            1
        }
        Err(e) => {
            eprintln!("error: {e}");
            1
        }
    }
}
