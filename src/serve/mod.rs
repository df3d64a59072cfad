//! The controller as a service: `ghm serve` answers `POST /decide` (the measurements of a
//! step → the input to apply) over HTTP/JSON, with `GET /model`, `GET /health`,
//! `GET /metrics` (Prometheus), and a live page (`GET /`, drawn from `GET /history`).
//! Every decision is journaled in SQLite before it is answered, and a restarted service
//! rebuilds its controllers from the journal (`docs/serve.md`).
//! [`client::RemoteController`] is the other end, which `ghm replay` runs a season with.
//!
//! The room owns the JSON ([`api`]), the checks of a request ([`validate`]), the journal
//! ([`journal`]), the metrics ([`metrics`]), the controller thread ([`actor`]), the recent
//! decisions the live page shows ([`history`]), the token ([`token`]) and the HTTP side
//! ([`server`]). It builds controllers only through the job layer
//! (`job::build_controller`) and never runs a season itself.

pub mod actor;
pub mod api;
pub mod client;
pub mod history;
pub mod journal;
pub mod metrics;
pub mod server;
pub mod token;
pub mod validate;

pub use server::run;

use crate::job::{JobError, RunSpec};
use std::net::SocketAddr;
use std::path::PathBuf;
use thiserror::Error;

/// What `ghm serve` runs.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// The controller to serve (mpc, rlmpc, policy or expert).
    pub spec: RunSpec,
    /// The address to listen on; port 0 picks a free one (printed on stdout).
    pub listen: SocketAddr,
    /// The journal file (SQLite), created if missing.
    pub journal: PathBuf,
    /// The API token `POST /decide` requires (required beyond loopback).
    pub token: Option<String>,
    /// The most sessions (greenhouses) served at once.
    pub max_sessions: usize,
    /// The largest request body, in bytes.
    pub max_body: usize,
}

/// Why the service could not start, or stopped; each message says what to do.
#[derive(Debug, Error)]
pub enum ServeError {
    /// The controller could not be built from the spec.
    #[error(transparent)]
    Job(#[from] JobError),
    /// The journal could not be opened, read or written.
    #[error("journal {path}: {message}")]
    Journal {
        /// The journal file.
        path: PathBuf,
        /// What SQLite (or reading an entry back) said.
        message: String,
    },
    /// The journal was begun by a service of another spec or model.
    #[error("journal {path} does not fit this service: {message}")]
    JournalMismatch {
        /// The journal file.
        path: PathBuf,
        /// How it differs.
        message: String,
    },
    /// Deciding a journaled request again did not give the journaled decision.
    #[error("the journal of session {session:?} does not replay at step {step}: {message}")]
    Recovery {
        /// The session.
        session: String,
        /// The step.
        step: u64,
        /// How the decisions differ.
        message: String,
    },
    /// The API token is missing where it is needed, or unusable.
    #[error("{0}")]
    Token(String),
    /// The address could not be listened on.
    #[error("cannot listen on {addr}: {message}")]
    Listen {
        /// The address.
        addr: String,
        /// What the system said.
        message: String,
    },
    /// The async runtime or the controller thread failed.
    #[error("{0}")]
    Runtime(String),
    /// `ghm replay`: the service could not be reached, or its answers are not a service's.
    #[error("{0}")]
    Client(String),
}
