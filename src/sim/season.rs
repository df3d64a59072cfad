//! The season loop: runs a controller on the plant over the weather, enforcing input
//! bounds and rate limits (unless told not to), drawing parametric uncertainty, and
//! reporting every step to a sink as it happens (so a run stopped halfway keeps its rows).

use crate::control::{Controller, LimitPolicy, StepError, StepRecord, StepRequest, Stepper};
use crate::lang::model::Redraw;
use crate::model::finite::{first_non_finite, Quantity};
use crate::model::{Plant, StepOutcome};
use crate::sim::metrics::{Metrics, MetricsBuilder};
use crate::sim::weather::Weather;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thiserror::Error;

/// Why a season stopped.
#[derive(Debug, Error)]
pub enum SimError {
    /// The weather has fewer rows than the season has steps; checked before the first step.
    #[error("the weather has {available} steps; the season needs {needed}")]
    WeatherTooShort {
        /// Rows in the weather.
        available: usize,
        /// Steps in the season.
        needed: usize,
    },
    /// The weather's columns do not match the model's disturbances; checked before the
    /// first step.
    #[error("the weather provides {given} disturbances; the model has {expected}")]
    WeatherWidth {
        /// Columns in the weather.
        given: usize,
        /// Disturbances of the model.
        expected: usize,
    },
    /// The controller's input has the wrong length.
    #[error("the controller returned {given} inputs; the model has {expected}")]
    InputWidth {
        /// Entries in the controller's input.
        given: usize,
        /// Inputs of the model.
        expected: usize,
    },
    /// The controller returned an error.
    #[error("controller failed at step {step}: {source}")]
    Controller {
        /// The step it failed at (0-based).
        step: usize,
        /// Its error.
        source: crate::control::ControlError,
    },
    /// A number of the step is NaN or infinite: an observed output, the controller's
    /// input, the next state, a stage term, an output after the step, a penalty, the
    /// reward or the cumulative reward (checked in that order; the first one stops the
    /// season, before the step is logged).
    #[error("step {step}: {quantity} is {value}; the season stops here")]
    NotFinite {
        /// The step (0-based).
        step: usize,
        /// What it is, named as the model names it, with its `file:line:col` when the
        /// model was read from a file (see [`Plant::describe`]).
        quantity: String,
        /// The value: NaN, `inf` or `-inf`.
        value: f64,
    },
    /// The [`StepSink`] failed; holds its message.
    #[error("writing the results failed: {0}")]
    Sink(String),
    /// A resumed season's replay reached a state other than the stopped run logged: the
    /// model, the weather or the plant's parameters are not the run's.
    #[error(
        "step {step}: replaying the stopped run gives {state} = {replayed}, where it logged \
         {logged}; the model, weather or plant differ from that run's, so it cannot be \
         resumed (start it afresh)"
    )]
    ResumeDiverged {
        /// The step whose starting state differs.
        step: usize,
        /// The state's name.
        state: String,
        /// What the replay reached.
        replayed: f64,
        /// What the stopped run logged.
        logged: f64,
    },
    /// The step's request to the controller was refused (a forecast row that is not finite).
    #[error("step {step}: {source}")]
    Step {
        /// The step.
        step: usize,
        /// Why.
        #[source]
        source: StepError,
    },
}

/// The most steps a season may have (ten million: a year at a 3-second period). The
/// weather and the step log grow with it, so a larger request is refused before anything
/// is allocated.
pub const MAX_SEASON_STEPS: usize = 10_000_000;

/// Parametric uncertainty of a season: relative half-width δ and a seed.
///
/// # Examples
///
/// The tank of [`Controller`] with its drain coefficient `k` marked `uncertain`: each
/// seed draws another plant, the same seed the same one.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::ConstantInput;
/// use ghm::model::Plant;
/// use ghm::sim::season::{run_season, SeasonConfig, StepLog, UncertaintyDraw};
/// use ghm::sim::weather::Weather;
///
/// # let text = "\
/// # model tank
/// # sample 60 [s] integrator euler
/// # state level [m] = 1
/// # input inflow [m s^-1] in [0, 0.01] rate 0.002 start 0
/// # param k [s^-1] = 0.001 uncertain
/// # der level = inflow - k * level
/// # output h [m] = level
/// # reward stored [EUR] = 2 * next(level)
/// # cost pumping [EUR] = 50 * inflow
/// # soft h in [0.5, 1.2] weight 10
/// # ";
/// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
/// let weather = Weather::constant(vec![], &[], 5, plant.model.sample_period);
/// let mut final_level = |uncertainty| -> Result<f64, Box<dyn std::error::Error>> {
///     let config = SeasonConfig { steps: 5, enforce_limits: true, uncertainty };
///     let mut hold = ConstantInput(vec![0.001]);
///     Ok(run_season(&plant, &weather, &mut hold, &config, &mut |_: &StepLog| {})?.final_state[0])
/// };
/// let nominal = final_level(None)?;
/// assert!((nominal - 1.0).abs() < 1e-12); // inflow = k · level: the level holds
/// let draw = |seed| Some(UncertaintyDraw { delta: 0.2, seed });
/// let (a, b) = (final_level(draw(1))?, final_level(draw(2))?);
/// assert!(a != nominal && a != b);
/// assert_eq!(final_level(draw(1))?, a);
/// // k within ±20 %: after five minutes the level is within 0.06 m of 1 m.
/// assert!((a - 1.0).abs() < 0.06 && (b - 1.0).abs() < 0.06);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UncertaintyDraw {
    /// Relative half-width δ: an uncertain parameter `p` is drawn uniformly from
    /// `p · (1 ± spread · δ)`, with the model's `spread`; 0 draws nothing.
    pub delta: f64,
    /// Seed of the season's random stream; the same seed draws the same parameters.
    pub seed: u64,
}

/// How a season is run.
#[derive(Debug, Clone, PartialEq)]
pub struct SeasonConfig {
    /// Steps to run; the weather must have at least as many rows.
    pub steps: usize,
    /// Clip the controller's input to the bounds and rate limits.
    pub enforce_limits: bool,
    /// Parametric uncertainty of the plant; `None` runs it with nominal parameters.
    /// Parameters are drawn once per season, or at every step when the model says
    /// `redraw = step`.
    pub uncertainty: Option<UncertaintyDraw>,
}

/// Everything about one step, as logged.
#[derive(Debug, Clone, PartialEq)]
pub struct StepLog {
    /// The step `k`, from 0.
    pub step: usize,
    /// The state `x(k)` before the step.
    pub state: Vec<f64>,
    /// The outputs the controller observed: at `x(k)` with the previous input.
    pub outputs: Vec<f64>,
    /// The input applied, after clipping when the limits are enforced.
    pub input: Vec<f64>,
    /// The weather row `d(k)`.
    pub disturbance: Vec<f64>,
    /// Stage terms of the step (rewards positive, costs negative).
    pub terms: Vec<f64>,
    /// The sum of `terms`.
    pub economic: f64,
    /// One penalty per soft band.
    pub penalties: Vec<f64>,
    /// `economic` minus the sum of `penalties`.
    pub reward: f64,
    /// `reward` summed over the season so far, this step included.
    pub cumulative_reward: f64,
    /// What the controller reported for this step.
    pub record: StepRecord,
}

/// Receives each step as it is taken.
///
/// Any `FnMut(&StepLog)` closure is a sink that never fails; implement the trait to
/// report a failure (a full disk, say), which stops the season with [`SimError::Sink`].
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::ConstantInput;
/// use ghm::model::Plant;
/// use ghm::sim::season::{run_season, SeasonConfig, SimError, StepLog, StepSink};
/// use ghm::sim::weather::Weather;
///
/// /// Keeps at most `room` rows.
/// struct Rows {
///     rows: Vec<String>,
///     room: usize,
/// }
///
/// impl StepSink for Rows {
///     fn step(&mut self, log: &StepLog) -> Result<(), String> {
///         if self.rows.len() == self.room {
///             return Err(format!("no room for step {}", log.step));
///         }
///         self.rows.push(format!("{},{:.3},{:.4}", log.step, log.state[0], log.reward));
///         Ok(())
///     }
/// }
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
/// let weather = Weather::constant(vec![], &[], 5, plant.model.sample_period);
/// let config = SeasonConfig { steps: 5, enforce_limits: true, uncertainty: None };
/// let mut sink = Rows { rows: Vec::new(), room: 3 };
/// let result = run_season(&plant, &weather, &mut ConstantInput(vec![0.001]), &config, &mut sink);
/// assert!(matches!(result, Err(SimError::Sink(ref m)) if m == "no room for step 3"));
/// assert_eq!(sink.rows, ["0,1.000,1.9500", "1,1.000,1.9500", "2,1.000,1.9500"]);
/// # Ok(())
/// # }
/// ```
pub trait StepSink {
    /// Takes one step's log; an `Err` stops the season with [`SimError::Sink`].
    fn step(&mut self, log: &StepLog) -> Result<(), String>;
}

impl<F: FnMut(&StepLog)> StepSink for F {
    fn step(&mut self, log: &StepLog) -> Result<(), String> {
        self(log);
        Ok(())
    }
}

/// The steps a stopped season took, read back from what it wrote, for
/// [`resume_season`]: each step's state `x(k)` as logged, the input applied and the
/// controller's record.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepsTaken {
    /// `x(k)` before each step.
    pub states: Vec<Vec<f64>>,
    /// The input applied at each step.
    pub inputs: Vec<Vec<f64>>,
    /// What the controller reported at each step.
    pub records: Vec<StepRecord>,
}

impl StepsTaken {
    /// The number of steps taken.
    pub fn len(&self) -> usize {
        self.inputs.len()
    }

    /// Whether no step was taken.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }
}

/// The result of a season.
#[derive(Debug, Clone)]
pub struct SeasonResult {
    /// The season's figures.
    pub metrics: Metrics,
    /// The state after the last step.
    pub final_state: Vec<f64>,
}

/// Draws p̂ under the model's uncertainty rule.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::model::Plant;
/// use ghm::sim::season::draw_params;
/// use rand::SeedableRng;
/// use rand_chacha::ChaCha8Rng;
///
/// let text = "\
/// sample 60 [s]
/// state level = 1
/// param k [s^-1] = 0.001 uncertain
/// param area [m^2] = 4
/// der level = -k * level / area
/// output h = level
/// uncertainty spread = 1, params = marked
/// ";
/// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
/// let mut rng = ChaCha8Rng::seed_from_u64(1);
/// for _ in 0..20 {
///     // δ = 10 %: k ~ U(0.0009, 0.0011); `area` is not marked `uncertain`.
///     let p = draw_params(&plant, 0.1, &mut rng);
///     assert!(p[0] >= 0.0009 - 1e-18 && p[0] <= 0.0011 + 1e-18);
///     assert_eq!(p[1], 4.0);
/// }
/// assert_eq!(draw_params(&plant, 0.0, &mut rng), [0.001, 4.0]);
/// # Ok(())
/// # }
/// ```
pub fn draw_params(plant: &Plant, delta: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut params = plant.model.nominal_params();
    draw_params_into(plant, delta, rng, &mut params);
    params
}

/// Draws p̂ under the model's uncertainty rule into `params` (one entry per model
/// parameter), without allocation; consumes the RNG exactly as [`draw_params`] does.
///
/// # Panics
/// If `params.len()` differs from the number of model parameters.
pub fn draw_params_into(plant: &Plant, delta: f64, rng: &mut ChaCha8Rng, params: &mut [f64]) {
    let rule = plant.model.uncertainty;
    assert_eq!(
        params.len(),
        plant.model.params.len(),
        "draw_params_into: one value per parameter"
    );
    for (v, p) in params.iter_mut().zip(&plant.model.params) {
        let in_scope = rule.all_params || p.kind == crate::lang::ast::ParamKind::Uncertain;
        *v = if in_scope && delta > 0.0 {
            let w = rule.spread * delta;
            p.value * (1.0 + rng.random_range(-w..=w))
        } else {
            p.value
        };
    }
}

/// Runs one season from the model's initial state and start input.
///
/// Every step goes to `sink` as it is taken (a closure `|log: &StepLog| ...` is a sink);
/// with `enforce_limits` the controller's input is clipped to the bounds and rate limits
/// first, as a real actuator would.
///
/// # Examples
///
/// A tank (the one of [`Controller`]: level 1 m, draining at 0.001 s⁻¹, inflow up to
/// 0.01 m s⁻¹ and by at most 0.002 m s⁻¹ more per minute) with the pump asked for full
/// power:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::ConstantInput;
/// use ghm::model::Plant;
/// use ghm::sim::season::{run_season, SeasonConfig, SimError, StepLog};
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
/// let weather = Weather::constant(vec![], &[], 8, plant.model.sample_period);
/// let mut full = ConstantInput(vec![0.01]);
/// let mut config = SeasonConfig { steps: 8, enforce_limits: true, uncertainty: None };
///
/// let mut logs: Vec<StepLog> = Vec::new();
/// let result = run_season(&plant, &weather, &mut full, &config, &mut |log: &StepLog| {
///     logs.push(log.clone())
/// })?;
/// let applied: Vec<f64> = logs.iter().map(|l| l.input[0]).collect();
/// let ramp = [0.002, 0.004, 0.006, 0.008, 0.01, 0.01, 0.01, 0.01]; // the rate limit
/// assert!(applied.iter().zip(ramp).all(|(a, r)| (a - r).abs() < 1e-15));
/// // The log's state is the state before the step; the result holds the last one.
/// assert_eq!(logs[0].state, [1.0]);
/// assert!(result.final_state[0] > 1.0);
/// assert_eq!(logs[7].cumulative_reward, result.metrics.cumulative_reward);
///
/// // Without the limits the plant gets what the controller asks for.
/// config.enforce_limits = false;
/// let mut first = None;
/// run_season(&plant, &weather, &mut full, &config, &mut |log: &StepLog| {
///     first.get_or_insert(log.input[0]);
/// })?;
/// assert_eq!(first, Some(0.01));
///
/// // The weather must cover the season.
/// config.steps = 9;
/// let short = run_season(&plant, &weather, &mut full, &config, &mut |_: &StepLog| {});
/// assert!(matches!(short, Err(SimError::WeatherTooShort { available: 8, needed: 9 })));
/// # Ok(())
/// # }
/// ```
pub fn run_season(
    plant: &Plant,
    weather: &Weather,
    controller: &mut dyn Controller,
    config: &SeasonConfig,
    sink: &mut dyn StepSink,
) -> Result<SeasonResult, SimError> {
    resume_season(
        plant,
        weather,
        controller,
        config,
        &StepsTaken::default(),
        sink,
    )
}

/// [`run_season`] continued after the steps `taken` of a stopped run: they are replayed
/// through the plant (their inputs applied again, the parameters drawn again, each state
/// checked bit for bit against the one logged, every step sent to `sink` as before), and
/// the controller decides from the first step not taken. The season's figures are those of
/// the whole season; a controller that carries something from step to step (MPC's warm
/// start) starts afresh where the replay ends.
pub fn resume_season(
    plant: &Plant,
    weather: &Weather,
    controller: &mut dyn Controller,
    config: &SeasonConfig,
    taken: &StepsTaken,
    sink: &mut dyn StepSink,
) -> Result<SeasonResult, SimError> {
    let l = plant.layout;
    if weather.width() != l.nd {
        return Err(SimError::WeatherWidth {
            given: weather.width(),
            expected: l.nd,
        });
    }
    if weather.len() < config.steps {
        return Err(SimError::WeatherTooShort {
            available: weather.len(),
            needed: config.steps,
        });
    }
    let nominal = plant.model.nominal_params();
    let mut rng = ChaCha8Rng::seed_from_u64(config.uncertainty.map_or(0, |u| u.seed));
    let delta = config.uncertainty.map_or(0.0, |u| u.delta);
    let mut params = if delta > 0.0 {
        draw_params(plant, delta, &mut rng)
    } else {
        nominal.clone()
    };
    let mut x = plant.model.initial_state();
    let mut u_prev = plant.model.start_input();
    let mut ws = plant.workspace();
    let mut out = StepOutcome {
        next_state: Vec::new(),
        terms: Vec::new(),
        next_outputs: Vec::new(),
    };
    let mut metrics = MetricsBuilder::new(plant);
    let mut cumulative = 0.0;
    let stepper = Stepper::new(if config.enforce_limits {
        LimitPolicy::Clip
    } else {
        LimitPolicy::Pass
    });
    for k in 0..config.steps {
        if k > 0 && delta > 0.0 && plant.model.uncertainty.redraw == Redraw::Step {
            params = draw_params(plant, delta, &mut rng);
        }
        let d = weather.at(k);
        let forecast = weather.horizon(k, weather.len() - k).unwrap_or(&[]);
        let request = StepRequest {
            step: k,
            state: &x,
            measured_outputs: None,
            previous_input: &u_prev,
            forecast,
        };
        let not_finite = |found: Option<(Quantity, f64)>| match found {
            Some((q, value)) => Err(SimError::NotFinite {
                step: k,
                quantity: plant.describe(q),
                value,
            }),
            None => Ok(()),
        };
        let decided = match (taken.inputs.get(k), taken.records.get(k)) {
            (Some(input), Some(record)) => {
                diverged(plant, k, &x, taken.states.get(k))?;
                stepper.replay(plant, &params, &mut ws, &request, input, record)
            }
            _ => stepper.decide(plant, &params, &mut ws, controller, &request),
        };
        let decision = decided.map_err(|e| match e {
            StepError::NotFinite {
                described, value, ..
            } => SimError::NotFinite {
                step: k,
                quantity: described,
                value,
            },
            StepError::InputWidth { given, expected } => SimError::InputWidth { given, expected },
            StepError::Controller(source) => SimError::Controller { step: k, source },
            other => SimError::Step {
                step: k,
                source: other,
            },
        })?;
        let (u, y) = (decision.input, decision.outputs);
        plant.step_into(&mut ws, &x, &u, d, &params, &mut out);
        not_finite(first_non_finite(&out.next_state, Quantity::State))?;
        not_finite(first_non_finite(&out.terms, Quantity::Term))?;
        not_finite(first_non_finite(&out.next_outputs, Quantity::NextOutput))?;
        let penalties: Vec<f64> = plant
            .penalties(&out.next_outputs)
            .iter()
            .map(|p| p.value)
            .collect();
        not_finite(first_non_finite(&penalties, Quantity::Penalty))?;
        let economic = out.economic();
        let reward = economic - penalties.iter().sum::<f64>();
        not_finite(first_non_finite(&[reward], |_| Quantity::Reward))?;
        cumulative += reward;
        not_finite(first_non_finite(&[cumulative], |_| {
            Quantity::CumulativeReward
        }))?;
        metrics.add(
            &out.terms,
            &penalties,
            &out.next_outputs,
            &u,
            &decision.record,
        );
        let log = StepLog {
            step: k,
            state: x.clone(),
            outputs: y,
            input: u.clone(),
            disturbance: d.to_vec(),
            terms: out.terms.clone(),
            economic,
            penalties,
            reward,
            cumulative_reward: cumulative,
            record: decision.record,
        };
        sink.step(&log).map_err(SimError::Sink)?;
        x.clone_from(&out.next_state);
        u_prev = u;
    }
    Ok(SeasonResult {
        metrics: metrics.finish(),
        final_state: x,
    })
}

/// A replayed step's state against the one the stopped run logged, bit for bit.
fn diverged(
    plant: &Plant,
    step: usize,
    x: &[f64],
    logged: Option<&Vec<f64>>,
) -> Result<(), SimError> {
    let Some(logged) = logged else {
        return Ok(());
    };
    match x
        .iter()
        .zip(logged)
        .position(|(a, b)| a.to_bits() != b.to_bits())
    {
        None if x.len() == logged.len() => Ok(()),
        found => {
            let i = found.unwrap_or(x.len().min(logged.len()));
            Err(SimError::ResumeDiverged {
                step,
                state: plant
                    .model
                    .states
                    .get(i)
                    .map_or_else(|| format!("state {i}"), |s| s.info.name.clone()),
                replayed: x.get(i).copied().unwrap_or(f64::NAN),
                logged: logged.get(i).copied().unwrap_or(f64::NAN),
            })
        }
    }
}

/// A seed for the `index`-th of many independent streams derived from `seed` (a
/// SplitMix64 finaliser over `seed ^ index · φ`): training episodes, value roll-outs.
///
/// ```
/// use ghm::sim::season::derived_seed;
///
/// assert_eq!(derived_seed(7, 3), derived_seed(7, 3)); // reproducible
/// assert_ne!(derived_seed(7, 3), derived_seed(7, 4));
/// assert_ne!(derived_seed(7, 3), derived_seed(8, 3));
/// ```
pub fn derived_seed(seed: u64, index: u64) -> u64 {
    let mut z = seed ^ index.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}
