//! The whole-season optimum: one NLP over every step of the season with perfect foresight
//! of the weather, the same dynamics, bounds and rate limits, and the soft bands at their
//! scoring bounds. No controller can beat it on the deterministic season, so every result
//! table can show each controller's gap to the best possible.

use crate::model::Plant;
use crate::nlp::{Bands, Nlp, Ocp, OcpError};
use crate::sim::weather::Weather;
use crate::solve::{Checkpoint, Solution, Solver, Start};
use std::sync::Arc;
use thiserror::Error;

/// Why the season optimum could not be set up.
#[derive(Debug, Error)]
pub enum OptimumError {
    /// The season-long OCP could not be built or given its problem.
    #[error(transparent)]
    Problem(#[from] OcpError),
    /// The weather has fewer rows than the season has steps.
    #[error("the weather has {available} steps; the season needs {needed}")]
    WeatherTooShort {
        /// Rows in the weather.
        available: usize,
        /// Steps in the season.
        needed: usize,
    },
    /// `initial_inputs` is not `steps × nu` long.
    #[error(
        "the initial inputs have {given} values; {steps} steps of {nu} inputs need {expected}"
    )]
    Inputs {
        /// Values given.
        given: usize,
        /// Steps in the season.
        steps: usize,
        /// Inputs of the model.
        nu: usize,
        /// `steps × nu`.
        expected: usize,
    },
    /// A checkpoint to resume from is not of this season's problem.
    #[error(
        "the checkpoint has {given} values; this season's problem has {variables} variables and {rows} rows"
    )]
    Checkpoint {
        /// Values in the checkpoint (point, multipliers, bound multipliers).
        given: usize,
        /// Variables of the season's NLP.
        variables: usize,
        /// Rows of the season's NLP.
        rows: usize,
    },
}

/// The optimum and the input sequence it applies (one row of `nu` inputs per step).
#[derive(Debug, Clone)]
pub struct SeasonOptimum {
    /// The solver's result for the season-long NLP; check its status before trusting it.
    pub solution: Solution,
    /// The optimal inputs, one row of `nu` values per step.
    pub inputs: Vec<Vec<f64>>,
}

/// Solves the season of `steps` steps from the model's initial state and start input,
/// starting from the trajectory that `initial_inputs` (`steps × nu`, typically a closed-loop
/// run) produces.
///
/// # Examples
///
/// Six minutes of the tank of [`Controller`](crate::control::Controller): the level earns
/// 2 per metre per step, pumping costs 50 per m s⁻¹, and above 1.2 m each metre costs 10.
/// The optimum, started from the pump off, beats any fixed input, and its objective is
/// minus the cumulative reward its inputs earn in the season loop.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::{ConstantInput, Controller, InputTable};
/// use ghm::model::Plant;
/// use ghm::sim::optimum::season_optimum;
/// use ghm::sim::season::{run_season, SeasonConfig, StepLog};
/// use ghm::sim::weather::Weather;
/// use ghm::solve::Sqp;
/// use std::sync::Arc;
///
/// # let text = "\
/// # model tank
/// # sample 60 [s] integrator euler
/// # state level [m] = 1
/// # input inflow [m s^-1] in [0, 0.01] rate 0.002 start 0
/// # param k [s^-1] = 0.001
/// # der level = inflow - k * level
/// # output h [m] = level
/// # reward stored [EUR] = 2 * next(level)
/// # cost pumping [EUR] = 50 * inflow
/// # soft h in [0.5, 1.2] weight 10
/// # ";
/// let plant = Arc::new(Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?));
/// let steps = 6;
/// let weather = Weather::constant(vec![], &[], steps, plant.model.sample_period);
/// let best = season_optimum(plant.clone(), &weather, steps, &[0.0; 6], &mut Sqp::default())?;
/// assert!(best.solution.status.is_success());
/// assert_eq!(best.inputs.len(), steps);
///
/// let config = SeasonConfig { steps, enforce_limits: true, uncertainty: None };
/// let mut score = |c: &mut dyn Controller| -> Result<f64, Box<dyn std::error::Error>> {
///     Ok(run_season(&plant, &weather, c, &config, &mut |_: &StepLog| {})?.metrics.cumulative_reward)
/// };
/// let optimum = score(&mut InputTable(best.inputs.clone()))?;
/// assert!((best.solution.stats.objective + optimum).abs() < 1e-6);
/// for u in [0.0, 0.001, 0.002, 0.01] {
///     assert!(score(&mut ConstantInput(vec![u]))? < optimum + 1e-9);
/// }
/// # Ok(())
/// # }
/// ```
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
    let mut ocp = season_problem(&plant, weather, steps)?;
    let mut start = vec![0.0; ocp.n_vars()];
    ocp.rollout(initial_inputs, &mut start);
    let push = plant.model.solver.rollout_push;
    let solution = solver.solve(&mut ocp, Start::rollout(&start, push));
    Ok(SeasonOptimum::of(&ocp, solution, steps))
}

/// Goes on with the solve of [`season_optimum`] from where it stood at `checkpoint` (one
/// its solver handed out, [`Solver::set_checkpoints`]), on the same season.
pub fn resume_season_optimum(
    plant: Arc<Plant>,
    weather: &Weather,
    steps: usize,
    checkpoint: &Checkpoint,
    solver: &mut dyn Solver,
) -> Result<SeasonOptimum, OptimumError> {
    let mut ocp = season_problem(&plant, weather, steps)?;
    let (n, m) = (ocp.n_vars(), ocp.n_cons());
    let sizes = [
        checkpoint.x.len(),
        checkpoint.multipliers.len(),
        checkpoint.bound_multipliers.len(),
    ];
    if sizes != [n, m, n] {
        return Err(OptimumError::Checkpoint {
            given: sizes.iter().sum(),
            variables: n,
            rows: m,
        });
    }
    let solution = solver.solve(&mut ocp, Start::resumed(checkpoint));
    Ok(SeasonOptimum::of(&ocp, solution, steps))
}

/// The season-long problem: every step, from the model's initial state and start input,
/// the soft bands at their scoring bounds.
fn season_problem(
    plant: &Arc<Plant>,
    weather: &Weather,
    steps: usize,
) -> Result<Ocp, OptimumError> {
    let forecast = weather
        .horizon(0, steps)
        .ok_or(OptimumError::WeatherTooShort {
            available: weather.len(),
            needed: steps,
        })?;
    let mut ocp = Ocp::with_bands(Arc::clone(plant), steps, Bands::Scoring)?;
    let (x0, u0) = (plant.model.initial_state(), plant.model.start_input());
    ocp.set_problem(0, &x0, &u0, forecast)?;
    Ok(ocp)
}

impl SeasonOptimum {
    /// `solution` of `ocp`, with the inputs of its `steps` steps.
    fn of(ocp: &Ocp, solution: Solution, steps: usize) -> SeasonOptimum {
        let inputs = (0..steps)
            .map(|j| ocp.input(&solution.x, j).to_vec())
            .collect();
        SeasonOptimum { solution, inputs }
    }
}
