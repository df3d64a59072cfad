//! ghm: economic model-predictive control with learned guidance.
//!
//! A plant and its economic cost come from a `.ghm` file ([`lang::load()`]) or from Rust
//! ([`model::ModelBuilder`]); [`model::Plant`] compiles them into tapes with exact
//! derivatives; a [`control::Controller`] — [`control::Mpc`] over an [`nlp::Ocp`] solved by
//! [`solve::Ipm`] (the interior point, `ghm mpc`'s default), [`solve::Sqp`] or IPOPT
//! (feature `ipopt`), or your own type — chooses the inputs; and
//! [`sim::season::run_season`] runs it over a weather source and reports the metrics.
//!
//! ```
//! use ghm::control::Mpc;
//! use ghm::model::Plant;
//! use ghm::sim::season::{run_season, SeasonConfig, StepLog};
//! use ghm::sim::weather::builtin_season;
//! use ghm::solve::Sqp;
//! use std::sync::Arc;
//!
//! let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
//! let model = ghm::lang::load(&file).unwrap();
//! let plant = Arc::new(Plant::new(model));
//! let (steps, horizon) = (12, 4);
//! let columns = plant.model.weather_columns();
//! let weather = builtin_season(steps + horizon, plant.model.sample_period, 1)
//!     .select(&columns, 0, steps + horizon)
//!     .unwrap();
//! let mut mpc = Mpc::new(plant.clone(), horizon, Box::new(Sqp::default())).unwrap();
//! let config = SeasonConfig { steps, enforce_limits: true, uncertainty: None };
//! let result = run_season(&plant, &weather, &mut mpc, &config, &mut |_: &StepLog| {}).unwrap();
//! assert_eq!(result.metrics.steps, 12);
//! assert_eq!(result.metrics.solve.failed_solves, 0);
//! ```
pub mod agent;
pub mod cli;
pub mod control;
pub mod embed;
pub mod graph;
pub mod import;
pub mod job;
pub mod lang;
pub mod model;
pub mod nlp;
pub mod nn;
pub mod report;
pub mod rl;
pub mod serve;
pub mod sim;
pub mod solve;
pub mod study;
