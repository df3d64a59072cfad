//! The episodic reinforcement-learning environment over any plant and a weather.
//!
//! One episode runs `steps` transitions from the model's initial state `x(0)` and start
//! input `u(−1)`, exactly as the season loop ([`run_season`](crate::sim::season::run_season))
//! does:
//!
//! * **observation** `s(k) = [y(x(k)), u(k−1), k, d(k)]` (raw, model units): the outputs of the
//!   current state computed as the season loop computes them (`g(x(k), u(k−1), d(k), p̂)`, with
//!   the parameters in force at step `k`), the input applied at the previous step, the step
//!   index as `f64`, and the disturbance of the current step. Length `ny + nu + 1 + nd`.
//!   The observation after the last step reads the weather row `min(k, len − 1)`, so a weather
//!   exactly as long as the episode suffices. With [`Env::observing`] an observation of
//!   version 2 also holds forecast rows `d(k+1), …, d(k+F)`, a row past the weather's end
//!   repeating its last.
//! * **action** `a ∈ [−1, 1]^nu` (entries outside are clipped first) maps to the input
//!   `u(k) = clip(u(k−1) + a ⊙ δu, u_min, u_max)`, where `δu` is each input's rate limit, or
//!   its full range `upper − lower` when it has none ([`Env::action_scale`]). Bounds and rate
//!   limits therefore hold by construction. The observation and the action map are
//!   [`agent::observation`](crate::agent::observation)'s, re-exported here.
//! * **reward** `r(k) = Σ stage terms − Σ soft-band penalties on y(x(k+1))`: the economic reward of
//!   the transition minus the penalties on the outputs after it, the same number as the
//!   season loop's [`StepLog::reward`](crate::sim::season::StepLog::reward).
//! * **uncertainty** (optional): a fresh parameter draw `p̂` per episode from the environment's
//!   own ChaCha8 RNG (seeded with the draw's seed, as the season loop seeds its RNG), and a new
//!   draw every step when the model's rule says `redraw = step`. The first episode after
//!   construction (or [`Env::reseed`]) therefore consumes the RNG exactly as `run_season` with
//!   the same [`UncertaintyDraw`] does.
//!
//! A step allocates nothing: every buffer (state, input, parameters, observation and the
//! plant's tape workspace) is kept in the environment.

pub use crate::agent::observation::{action_scale, input_from_action, ObservationLayout};
#[cfg(doc)]
use crate::agent::AgentError;
use crate::lang::model::Redraw;
use crate::model::finite::{first_non_finite, Quantity};
use crate::model::{Plant, StepOutcome, StepWorkspace};
use crate::rl::RlError;
use crate::sim::season::{draw_params_into, UncertaintyDraw};
use crate::sim::weather::Weather;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;

/// What one [`Env::step`] returns; the slices borrow the environment's buffers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition<'a> {
    /// The observation `s(k+1)` after the step.
    pub observation: &'a [f64],
    /// `r(k)`: economic reward minus soft-band penalties.
    pub reward: f64,
    /// The economic part of the reward alone (sum of the stage terms).
    pub economic: f64,
    /// True once the episode has taken all its steps.
    pub done: bool,
    /// The input `u(k)` the action mapped to and the plant received.
    pub input: &'a [f64],
}

/// Where the environment is in its episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Built or reseeded; `reset` has not been called yet.
    Fresh,
    Running,
    Over,
}

/// An episodic environment: a plant, a weather, an episode length and optional parametric
/// uncertainty. See the [module documentation](self) for the observation, action and reward.
///
/// ```
/// use ghm::rl::Env;
/// use ghm::sim::weather::builtin_season;
/// use std::sync::Arc;
///
/// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
/// let plant = Arc::new(ghm::model::Plant::new(ghm::lang::load(&file).map_err(|e| e.render()).unwrap()));
/// let columns = plant.model.weather_columns();
/// let weather = builtin_season(48, plant.model.sample_period, 7).select(&columns, 0, 48).unwrap();
/// let mut env = Env::new(plant, weather, 48, None).unwrap();
/// let first = env.reset().to_vec(); // outputs, previous input, step, weather: 12 values
/// assert_eq!(first.len(), 12);
/// let mut total = 0.0;
/// loop {
///     let t = env.step(&[0.0, 0.0, 0.0]).unwrap(); // hold the inputs
///     total += t.reward;
///     if t.done { break; }
/// }
/// assert!(total.is_finite());
/// ```
#[derive(Debug, Clone)]
pub struct Env {
    plant: Arc<Plant>,
    weather: Weather,
    steps: usize,
    uncertainty: Option<UncertaintyDraw>,
    rng: ChaCha8Rng,
    phase: Phase,
    /// Step index `k` of the current state.
    k: usize,
    initial_state: Vec<f64>,
    start_input: Vec<f64>,
    nominal: Vec<f64>,
    /// `δu`: the action scale of each input.
    scale: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    state: Vec<f64>,
    previous_input: Vec<f64>,
    input: Vec<f64>,
    params: Vec<f64>,
    layout: ObservationLayout,
    observation: Vec<f64>,
    ws: StepWorkspace,
    out: StepOutcome,
}

impl Env {
    /// An environment running episodes of `steps` transitions over `weather` (in the model's
    /// disturbance order, at least `steps` rows). Call [`Env::reset`] before the first step.
    ///
    /// Errors: [`RlError::EmptyEpisode`], [`RlError::WeatherWidth`],
    /// [`RlError::WeatherTooShort`], [`RlError::Agent`] ([`AgentError::InputBounds`],
    /// [`AgentError::UnboundedInput`]: an input with neither a rate limit nor finite bounds
    /// has no action scale),
    /// [`RlError::BadUncertainty`].
    pub fn new(
        plant: Arc<Plant>,
        weather: Weather,
        steps: usize,
        uncertainty: Option<UncertaintyDraw>,
    ) -> Result<Env, RlError> {
        let l = plant.layout;
        if steps == 0 {
            return Err(RlError::EmptyEpisode);
        }
        if weather.width() != l.nd {
            return Err(RlError::WeatherWidth {
                given: weather.width(),
                expected: l.nd,
            });
        }
        if weather.len() < steps {
            return Err(RlError::WeatherTooShort {
                available: weather.len(),
                needed: steps,
            });
        }
        let scale = action_scale(&plant)?;
        if let Some(u) = uncertainty {
            let w = u.delta * plant.model.uncertainty.spread;
            if !(u.delta.is_finite() && u.delta >= 0.0 && w.is_finite()) {
                return Err(RlError::BadUncertainty { delta: u.delta });
            }
        }
        let model = &plant.model;
        let ny = model.outputs.len();
        let nominal = model.nominal_params();
        Ok(Env {
            rng: ChaCha8Rng::seed_from_u64(uncertainty.map_or(0, |u| u.seed)),
            phase: Phase::Fresh,
            k: 0,
            initial_state: model.initial_state(),
            start_input: model.start_input(),
            params: nominal.clone(),
            nominal,
            lower: model.inputs.iter().map(|u| u.lower).collect(),
            upper: model.inputs.iter().map(|u| u.upper).collect(),
            scale,
            state: model.initial_state(),
            previous_input: model.start_input(),
            input: model.start_input(),
            layout: ObservationLayout::CURRENT_WEATHER,
            observation: vec![0.0; ObservationLayout::CURRENT_WEATHER.width(model)],
            ws: plant.workspace(),
            out: StepOutcome {
                next_state: Vec::with_capacity(l.nx),
                terms: Vec::with_capacity(plant.stage_terms.len()),
                next_outputs: Vec::with_capacity(ny),
            },
            plant,
            weather,
            steps,
            uncertainty,
        })
    }

    /// The environment with observations of `layout` (version 1, the current weather, is
    /// [`Env::new`]'s); to be reset before the next step.
    pub fn observing(mut self, layout: ObservationLayout) -> Env {
        self.observation = vec![0.0; layout.width(&self.plant.model)];
        self.layout = layout;
        self.phase = Phase::Fresh;
        self
    }

    /// Which observation the environment gives.
    pub fn observation_layout(&self) -> ObservationLayout {
        self.layout
    }

    /// Restarts the uncertainty RNG from `seed` (replacing the draw's seed); the next
    /// [`Env::reset`] then draws as a new environment with that seed would. No effect on a
    /// deterministic environment's episodes. The environment must be reset afterwards.
    pub fn reseed(&mut self, seed: u64) {
        if let Some(u) = self.uncertainty.as_mut() {
            u.seed = seed;
        }
        self.rng = ChaCha8Rng::seed_from_u64(seed);
        self.phase = Phase::Fresh;
    }

    /// Starts an episode: `x(0)` = the model's initial state, `u(−1)` = its start input,
    /// `k = 0`, and (with uncertainty) a fresh parameter draw. Returns the observation `s(0)`.
    pub fn reset(&mut self) -> &[f64] {
        self.state.copy_from_slice(&self.initial_state);
        self.previous_input.copy_from_slice(&self.start_input);
        self.input.copy_from_slice(&self.start_input);
        self.k = 0;
        let delta = self.delta();
        if delta > 0.0 {
            draw_params_into(&self.plant, delta, &mut self.rng, &mut self.params);
        } else {
            self.params.copy_from_slice(&self.nominal);
        }
        self.phase = Phase::Running;
        self.observe();
        &self.observation
    }

    /// Applies `action` (one entry per input, clipped to `[−1, 1]`) for one sample period.
    ///
    /// Errors: [`RlError::NotReset`], [`RlError::EpisodeOver`], [`RlError::ActionWidth`],
    /// [`RlError::NonFiniteAction`] (the environment is unchanged after these), and
    /// [`RlError::Diverged`] (the episode is over; reset to continue).
    pub fn step(&mut self, action: &[f64]) -> Result<Transition<'_>, RlError> {
        match self.phase {
            Phase::Fresh => return Err(RlError::NotReset),
            Phase::Over => return Err(RlError::EpisodeOver { steps: self.k }),
            Phase::Running => {}
        }
        let nu = self.plant.layout.nu;
        if action.len() != nu {
            return Err(RlError::ActionWidth {
                given: action.len(),
                expected: nu,
            });
        }
        if let Some(index) = action.iter().position(|a| !a.is_finite()) {
            return Err(RlError::NonFiniteAction {
                index,
                value: action[index],
            });
        }
        input_from_action(
            &self.previous_input,
            action,
            &self.scale,
            &self.lower,
            &self.upper,
            &mut self.input,
        );
        let d = self.weather.at(self.k);
        self.plant.step_into(
            &mut self.ws,
            &self.state,
            &self.input,
            d,
            &self.params,
            &mut self.out,
        );
        let economic = self.out.economic();
        let reward = self.plant.step_reward(&self.out);
        let found = first_non_finite(&self.out.next_state, Quantity::State)
            .or_else(|| first_non_finite(&self.out.terms, Quantity::Term))
            .or_else(|| first_non_finite(&self.out.next_outputs, Quantity::NextOutput))
            .or_else(|| first_non_finite(&[reward], |_| Quantity::Reward));
        if let Some((q, value)) = found {
            self.phase = Phase::Over;
            return Err(RlError::Diverged {
                step: self.k,
                quantity: self.plant.describe(q),
                value,
            });
        }
        self.state.copy_from_slice(&self.out.next_state);
        self.previous_input.copy_from_slice(&self.input);
        self.k += 1;
        let done = self.k >= self.steps;
        if done {
            self.phase = Phase::Over;
        } else if self.plant.model.uncertainty.redraw == Redraw::Step {
            let delta = self.delta();
            if delta > 0.0 {
                draw_params_into(&self.plant, delta, &mut self.rng, &mut self.params);
            }
        }
        self.observe();
        Ok(Transition {
            observation: &self.observation,
            reward,
            economic,
            done,
            input: &self.input,
        })
    }

    /// Fills the observation buffer for the current `k`, state, previous input and parameters.
    fn observe(&mut self) {
        let ny = self.plant.model.outputs.len();
        let row = self.k.min(self.weather.len().saturating_sub(1));
        let rows = (1 + self.layout.forecast_rows()).min(self.weather.len() - row);
        let forecast = self.weather.horizon(row, rows).unwrap_or_default();
        let d = self.weather.at(row);
        let (y, rest) = self.observation.split_at_mut(ny);
        self.plant.outputs_into(
            &mut self.ws,
            &self.state,
            &self.previous_input,
            d,
            &self.params,
            y,
        );
        self.layout.write_after_outputs(
            rest,
            &self.previous_input,
            self.k,
            forecast,
            self.plant.layout.nd,
        );
    }

    fn delta(&self) -> f64 {
        self.uncertainty.map_or(0.0, |u| u.delta)
    }

    /// Length of an observation: outputs + inputs + 1 + disturbances (times one and the
    /// forecast rows).
    pub fn observation_len(&self) -> usize {
        self.observation.len()
    }

    /// Length of an action: the number of inputs.
    pub fn action_len(&self) -> usize {
        self.plant.layout.nu
    }

    /// Steps per episode.
    pub fn episode_len(&self) -> usize {
        self.steps
    }

    /// `δu`: how far an action of ±1 moves each input in one step (its rate limit, or its
    /// range `upper − lower` when it has none).
    pub fn action_scale(&self) -> &[f64] {
        &self.scale
    }

    /// Names of the observation entries: the outputs, `prev_<input>` per input, `step`, the
    /// disturbances, and their forecast rows ([`ObservationLayout::names`]).
    pub fn observation_names(&self) -> Vec<String> {
        self.layout.names(&self.plant.model)
    }

    /// Names of the action entries: the model's inputs, in order.
    pub fn action_names(&self) -> Vec<String> {
        let inputs = &self.plant.model.inputs;
        inputs.iter().map(|u| u.info.name.clone()).collect()
    }

    /// The current observation `s(k)`.
    pub fn observation(&self) -> &[f64] {
        &self.observation
    }

    /// The current step index `k`.
    pub fn step_index(&self) -> usize {
        self.k
    }

    /// True when the episode has ended (or has not been started).
    pub fn is_done(&self) -> bool {
        self.phase != Phase::Running
    }

    /// The true plant state `x(k)`.
    pub fn state(&self) -> &[f64] {
        &self.state
    }

    /// The input applied at the previous step, `u(k−1)`.
    pub fn previous_input(&self) -> &[f64] {
        &self.previous_input
    }

    /// The parameters in force at step `k` (nominal on a deterministic environment).
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// The plant.
    pub fn plant(&self) -> &Arc<Plant> {
        &self.plant
    }

    /// The weather.
    pub fn weather(&self) -> &Weather {
        &self.weather
    }

    /// The parametric uncertainty, if any.
    pub fn uncertainty(&self) -> Option<UncertaintyDraw> {
        self.uncertainty
    }
}
