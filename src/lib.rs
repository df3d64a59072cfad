//! ghm: economic model-predictive control with learned guidance.
//!
//! A plant and its economic cost come from a `.ghm` file ([`lang::load()`]) or from Rust
//! ([`model::ModelBuilder`], equations written as in the file; [`prelude`] has what a plant
//! author needs); [`model::Plant`] compiles them into tapes with exact
//! derivatives; a [`control::Controller`] — [`control::Mpc`] over an [`nlp::Ocp`] solved by
//! [`solve::Ipm`] (the interior point, `ghm mpc`'s default), [`solve::Sqp`] or IPOPT
//! (feature `ipopt`), or your own type — chooses the inputs; and
//! [`sim::season::run_season`] runs it over a weather source and reports the metrics.
//!
//! The core (everything above) builds alone (`default-features = false`); features add
//! the rest: `learn` (SAC training and value fits on burn: `rl::sac`, `rl::value_fit`,
//! `job::train`, `job::value`), `serve` (`ghm serve` and its client, `serve`), `study`
//! (`ghm study` and `ghm report`, `study`; with `learn`), `cli` (the `ghm` command line;
//! all of them, and the default) and `ipopt` (the IPOPT back-end).
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
#![cfg_attr(docsrs, feature(doc_cfg))]
pub mod agent;
pub mod choice;
#[cfg(feature = "cli")]
#[cfg_attr(docsrs, doc(cfg(feature = "cli")))]
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
#[cfg(feature = "serve")]
#[cfg_attr(docsrs, doc(cfg(feature = "serve")))]
pub mod serve;
pub mod sim;
pub mod solve;
#[cfg(feature = "study")]
#[cfg_attr(docsrs, doc(cfg(feature = "study")))]
pub mod study;

/// What a plant author needs, in one `use ghm::prelude::*;`: the builder and its handles,
/// the model, the plant, and the settings a model names.
///
/// ```
/// use ghm::prelude::*;
///
/// fn decay() -> Result<Model, BuildError> {
///     let b = ModelBuilder::new("decay");
///     let x = b.state("x", 1.0).unit("mol");
///     let k = b.param("k", 0.1).unit("s^-1").uncertain();
///     b.der(x, -k * x);
///     b.output("amount", x);
///     b.sample(1.0, 1);
///     b.integrator(Integrator::Radau5);
///     b.build()
/// }
///
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let plant = Plant::new(decay()?);
/// let next = plant.step(&[1.0], &[], &[], &[0.1]).next_state[0];
/// assert!((next - (-0.1f64).exp()).abs() < 1e-6);
/// # Ok(())
/// # }
/// ```
pub mod prelude {
    pub use crate::lang::model::{Integrator, Redraw, SolverHints, Uncertainty};
    pub use crate::lang::Model;
    pub use crate::model::{
        if_else, Band, BuildError, Disturbance, Expr, Input, ModelBuilder, Operand, Output, Param,
        Plant, State, Term,
    };
}
