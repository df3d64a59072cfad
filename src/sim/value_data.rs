//! Training data for RL-guided MPC's value function: returns of a guide from states
//! scattered around its own season (spec §12, reference numbers §4).
//!
//! The nominal trajectory is the guide's season on the nominal plant. Each roll-out picks a
//! step `k` uniformly from the season, draws a state `x ~ U(xⁿ(k)(1 − σ), xⁿ(k)(1 + σ))`
//! component-wise around the nominal state (the previous input is the nominal one), and
//! lets the guide run to the end of the season. Every visited step `j` gives a point
//! `(x_i(j), j) → Σ_{t ≥ j} r(t)`, the undiscounted return-to-go.
//!
//! Roll-outs run in parallel (rayon); each has its own generator seeded from the seed and
//! its number, so the data do not depend on the number of threads. A roll-out whose state
//! stops being finite is dropped and counted.

use crate::control::{Controller, Observation};
use crate::model::{Plant, StepOutcome};
use crate::sim::season::{derived_seed, run_season, SeasonConfig, SimError, StepLog};
use crate::sim::weather::Weather;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The guide's season on the nominal plant.
#[derive(Debug, Clone, PartialEq)]
pub struct NominalRun {
    /// `x(0) … x(steps)`.
    pub states: Vec<Vec<f64>>,
    /// `u(0) … u(steps − 1)`.
    pub inputs: Vec<Vec<f64>>,
    /// Cumulative reward of the season.
    pub cumulative_reward: f64,
}

/// Runs `guide` over the season on the nominal plant.
pub fn nominal_run(
    plant: &Plant,
    weather: &Weather,
    steps: usize,
    guide: &mut dyn Controller,
) -> Result<NominalRun, SimError> {
    let mut states = Vec::with_capacity(steps + 1);
    let mut inputs = Vec::with_capacity(steps);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let result = run_season(plant, weather, guide, &config, &mut |log: &StepLog| {
        states.push(log.state.clone());
        inputs.push(log.input.clone());
    })?;
    states.push(result.final_state);
    Ok(NominalRun {
        states,
        inputs,
        cumulative_reward: result.metrics.cumulative_reward,
    })
}

/// One roll-out's points: `(x_i, k)` pairs and the returns-to-go; `None` if its state or a reward stopped being finite.
type Rollout = Option<(Vec<f64>, Vec<f64>)>;

/// Settings of the value data.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ValueDataConfig {
    /// Roll-outs to sample, each from a random step of the nominal run to the season's end.
    pub trajectories: usize,
    /// Relative spread σ of the start states around the nominal ones.
    pub spread: f64,
    /// Base seed; roll-out `i` draws from its own stream derived from it, so the data do
    /// not depend on the number of threads.
    pub seed: u64,
    /// The state component the value function reads.
    pub state_index: usize,
}

/// The points: `features` holds `(x_i(j), j)` pairs, `returns` the returns-to-go.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ValueData {
    /// `(x_i(j), j)` pairs, flattened: two entries per point.
    pub features: Vec<f64>,
    /// The return-to-go from each point to the season's end, one per point.
    pub returns: Vec<f64>,
    /// Roll-outs kept.
    pub trajectories: usize,
    /// Roll-outs dropped because their state or a reward stopped being finite.
    pub dropped: usize,
}

/// Samples the roll-outs in parallel. `make_guide` builds one guide per roll-out;
/// `progress` is called with the number of roll-outs finished so far.
///
/// # Examples
///
/// The tank of [`Controller`], guided by a constant inflow over a ten-minute season:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::{ConstantInput, Controller};
/// use ghm::model::Plant;
/// use ghm::sim::value_data::{nominal_run, sample_returns, ValueDataConfig};
/// use ghm::sim::weather::Weather;
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
/// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
/// let steps = 10;
/// let weather = Weather::constant(vec![], &[], steps, plant.model.sample_period);
/// let nominal = nominal_run(&plant, &weather, steps, &mut ConstantInput(vec![0.001]))?;
/// assert_eq!((nominal.states.len(), nominal.inputs.len()), (steps + 1, steps));
///
/// let guide = || Box::new(ConstantInput(vec![0.001])) as Box<dyn Controller>;
/// let config = ValueDataConfig { trajectories: 8, spread: 0.1, seed: 3, state_index: 0 };
/// let data = sample_returns(&plant, &weather, steps, &nominal, &guide, &config, &|_| {})?;
/// assert_eq!((data.trajectories, data.dropped), (8, 0));
/// assert_eq!(data.features.len(), 2 * data.returns.len()); // (level, step) → return
/// for point in data.features.chunks(2) {
///     assert!((0.85..1.15).contains(&point[0])); // within ±10 % of the level, 1 m
///     assert!(point[1] < steps as f64);
/// }
/// // The same seed gives the same data, however many threads ran it.
/// let again = sample_returns(&plant, &weather, steps, &nominal, &guide, &config, &|_| {})?;
/// assert_eq!(again, data);
/// # Ok(())
/// # }
/// ```
pub fn sample_returns(
    plant: &Plant,
    weather: &Weather,
    steps: usize,
    nominal: &NominalRun,
    make_guide: &(dyn Fn() -> Box<dyn Controller> + Sync),
    config: &ValueDataConfig,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<ValueData, SimError> {
    if nominal.states.len() < steps + 1 || nominal.inputs.len() < steps {
        return Err(SimError::WeatherTooShort {
            available: nominal.inputs.len(),
            needed: steps,
        });
    }
    let finished = AtomicUsize::new(0);
    let runs: Vec<Result<Rollout, SimError>> = (0..config.trajectories)
        .into_par_iter()
        .map(|i| {
            let mut guide = make_guide();
            let run = one_rollout(plant, weather, steps, nominal, guide.as_mut(), config, i);
            progress(finished.fetch_add(1, Ordering::Relaxed) + 1);
            run
        })
        .collect();
    let mut data = ValueData::default();
    for run in runs {
        match run? {
            Some((features, returns)) => {
                data.features.extend(features);
                data.returns.extend(returns);
                data.trajectories += 1;
            }
            None => data.dropped += 1,
        }
    }
    Ok(data)
}

/// One roll-out; `None` when its state or a reward stopped being finite.
fn one_rollout(
    plant: &Plant,
    weather: &Weather,
    steps: usize,
    nominal: &NominalRun,
    guide: &mut dyn Controller,
    config: &ValueDataConfig,
    i: usize,
) -> Result<Rollout, SimError> {
    let mut rng = ChaCha8Rng::seed_from_u64(derived_seed(config.seed, i as u64 + 1));
    let k0 = rng.random_range(0..steps);
    let sigma = config.spread;
    let mut x: Vec<f64> = nominal.states[k0]
        .iter()
        .map(|v| v * rng.random_range(1.0 - sigma..=1.0 + sigma))
        .collect();
    let mut u_prev = if k0 == 0 {
        plant.model.start_input()
    } else {
        nominal.inputs[k0 - 1].clone()
    };
    let params = plant.model.nominal_params();
    let mut ws = plant.workspace();
    let mut out = StepOutcome {
        next_state: Vec::new(),
        terms: Vec::new(),
        next_outputs: Vec::new(),
    };
    let mut y = vec![0.0; plant.model.outputs.len()];
    let mut features = Vec::with_capacity(2 * (steps - k0));
    let mut rewards = Vec::with_capacity(steps - k0);
    for k in k0..steps {
        let d = weather.at(k);
        plant.outputs_into(&mut ws, &x, &u_prev, d, &params, &mut y);
        let forecast = weather.horizon(k, weather.len() - k).unwrap_or(&[]);
        let decision = guide
            .decide(&Observation {
                step: k,
                state: &x,
                outputs: &y,
                previous_input: &u_prev,
                forecast,
            })
            .map_err(|source| SimError::Controller { step: k, source })?;
        let mut u = decision.input;
        plant.apply_limits(&u_prev, &mut u);
        plant.step_into(&mut ws, &x, &u, d, &params, &mut out);
        let reward = plant.step_reward(&out);
        if out.next_state.iter().any(|v| !v.is_finite()) || !reward.is_finite() {
            return Ok(None);
        }
        features.extend([x[config.state_index], k as f64]);
        rewards.push(reward);
        x.clone_from(&out.next_state);
        u_prev = u;
    }
    let mut to_go = 0.0;
    let mut returns = vec![0.0; rewards.len()];
    for (g, r) in returns.iter_mut().zip(&rewards).rev() {
        to_go += r;
        *g = to_go;
    }
    Ok(Some((features, returns)))
}
