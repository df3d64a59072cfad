//! The whole-season optimum: one NLP over every step of the season with perfect foresight
//! of the weather, the same dynamics, bounds and rate limits, and the soft bands at their
//! scoring bounds. No controller can beat it on the deterministic season, so every result
//! table can show each controller's gap to the best possible.

use crate::model::Plant;
use crate::nlp::{Bands, Nlp, Ocp, OcpError};
use crate::sim::weather::Weather;
use crate::solve::{Solution, Solver, Start};
use std::sync::Arc;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum OptimumError {
    #[error(transparent)]
    Problem(#[from] OcpError),
    #[error("the weather has {available} steps; the season needs {needed}")]
    WeatherTooShort { available: usize, needed: usize },
    #[error(
        "the initial inputs have {given} values; {steps} steps of {nu} inputs need {expected}"
    )]
    Inputs {
        given: usize,
        steps: usize,
        nu: usize,
        expected: usize,
    },
}

/// The optimum and the input sequence it applies (`steps × nu`, row-major).
#[derive(Debug, Clone)]
pub struct SeasonOptimum {
    pub solution: Solution,
    pub inputs: Vec<Vec<f64>>,
}

/// Solves the season of `steps` steps from the model's initial state and start input,
/// starting from the trajectory that `initial_inputs` (`steps × nu`, typically a closed-loop
/// run) produces.
pub fn season_optimum(
    plant: Arc<Plant>,
    weather: &Weather,
    steps: usize,
    initial_inputs: &[f64],
    solver: &mut dyn Solver,
) -> Result<SeasonOptimum, OptimumError> {
    let nu = plant.layout.nu;
    if initial_inputs.len() != steps * nu {
        return Err(OptimumError::Inputs {
            given: initial_inputs.len(),
            steps,
            nu,
            expected: steps * nu,
        });
    }
    let forecast = weather
        .horizon(0, steps)
        .ok_or(OptimumError::WeatherTooShort {
            available: weather.len(),
            needed: steps,
        })?;
    let mut ocp = Ocp::with_bands(Arc::clone(&plant), steps, Bands::Scoring)?;
    let (x0, u0) = (plant.model.initial_state(), plant.model.start_input());
    ocp.set_problem(0, &x0, &u0, forecast)?;
    let mut start = vec![0.0; ocp.n_vars()];
    ocp.rollout(initial_inputs, &mut start);
    let solution = solver.solve(&mut ocp, Start::cold(&start));
    let inputs = (0..steps)
        .map(|j| ocp.input(&solution.x, j).to_vec())
        .collect();
    Ok(SeasonOptimum { solution, inputs })
}
