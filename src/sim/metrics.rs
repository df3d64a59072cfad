//! Season metrics as the paper reports them: EPI, cumulative reward, penalties per band,
//! hours outside each band, and the controller's solve-time statistics; and where the EPI
//! comes from: each stage term's total and each input's mean.

use crate::control::StepRecord;
use crate::model::Plant;
use serde::Serialize;

/// One soft band's totals over a season.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct BandMetrics {
    /// The name of the output the band bounds.
    pub output: String,
    /// The band's penalties summed over the season, in the model's units of money.
    pub penalty: f64,
    /// Hours in which the output after the step lay outside the band: one sample period
    /// per such step.
    pub hours_outside: f64,
}

/// One stage term's total over a season.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct TermMetrics {
    /// The term's name in the model.
    pub name: String,
    /// Its sum over the season, rewards positive and costs negative, in the model's units
    /// of money: the EPI is the sum of these.
    pub total: f64,
}

/// One input's mean over a season.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct InputMetrics {
    /// The input's name in the model.
    pub name: String,
    /// Its mean over the season's steps, in the input's unit (for an input in `[0, 1]`
    /// times the season's hours: the hours at full power).
    pub mean: f64,
}

/// Solve-time statistics of a controller over a season.
#[derive(Debug, Clone, Serialize, PartialEq, Default)]
pub struct SolveStats {
    /// Median time per step to decide, in milliseconds.
    pub median_ms: f64,
    /// 95th percentile of the time per step, in milliseconds.
    pub p95_ms: f64,
    /// Longest time per step, in milliseconds.
    pub max_ms: f64,
    /// Solver iterations per step, averaged over the season.
    pub mean_iterations: f64,
    /// Steps whose final solver status was neither `optimal` nor `acceptable` (see
    /// [`StepRecord::solve_failed`]).
    pub failed_solves: usize,
    /// Steps whose input came from a fallback rather than the first solve.
    pub fallbacks: usize,
}

/// The figures of one season.
///
/// `epi` (economic performance indicator) is the sum of the economic stage terms alone:
/// the model's rewards minus its costs. `cumulative_reward` also subtracts the soft-band
/// penalties; it is what the controllers are ranked by.
///
/// # Examples
///
/// The tank of [`Controller`](crate::control::Controller), filled at full pump power
/// without limits, so that it rises over its 1.2 m ceiling; the figures by hand:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::ConstantInput;
/// use ghm::model::Plant;
/// use ghm::sim::season::{run_season, SeasonConfig, StepLog};
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
/// let weather = Weather::constant(vec![], &[], 5, plant.model.sample_period);
/// let config = SeasonConfig { steps: 5, enforce_limits: false, uncertainty: None };
/// let result = run_season(&plant, &weather, &mut ConstantInput(vec![0.01]), &config, &mut |_: &StepLog| {})?;
/// let m = &result.metrics;
///
/// let (mut level, mut epi, mut penalty) = (1.0, 0.0, 0.0);
/// for _ in 0..5 {
///     level += 60.0 * (0.01 - 0.001 * level); // forward Euler, one minute
///     epi += 2.0 * level - 50.0 * 0.01; // reward minus cost
///     penalty += 10.0 * (level - 1.2); // 10 per metre above the band
/// }
/// assert_eq!(m.steps, 5);
/// assert!((m.epi - epi).abs() < 1e-9);
/// assert!((m.total_penalty - penalty).abs() < 1e-9);
/// assert!((m.cumulative_reward - (epi - penalty)).abs() < 1e-9);
/// assert_eq!(m.bands[0].output, "h");
/// assert!((m.bands[0].hours_outside - 5.0 / 60.0).abs() < 1e-12); // five minutes
/// assert_eq!((m.terms[0].name.as_str(), m.terms[1].name.as_str()), ("stored", "pumping"));
/// assert!((m.terms[1].total + 5.0 * 50.0 * 0.01).abs() < 1e-12); // costs are negative
/// assert!((m.terms.iter().map(|t| t.total).sum::<f64>() - m.epi).abs() < 1e-9);
/// assert_eq!((m.inputs[0].name.as_str(), m.inputs[0].mean), ("inflow", 0.01));
/// assert_eq!(m.solve.failed_solves, 0); // no solver here
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Metrics {
    /// Steps run.
    pub steps: usize,
    /// Economic performance indicator: Σ economic stage terms, in the model's units of
    /// money (€ m⁻² for the greenhouse).
    pub epi: f64,
    /// Σ soft-band penalties over the season and all bands.
    pub total_penalty: f64,
    /// EPI − Σ penalties.
    pub cumulative_reward: f64,
    /// One entry per soft band, in the model's order.
    pub bands: Vec<BandMetrics>,
    /// One entry per stage term (the terminal terms, which value a horizon's end, have
    /// none), in the model's order.
    pub terms: Vec<TermMetrics>,
    /// One entry per input, in the model's order.
    pub inputs: Vec<InputMetrics>,
    /// The controller's solve times and failures.
    pub solve: SolveStats,
}

/// Accumulates [`Metrics`] step by step.
#[derive(Debug, Clone)]
pub struct MetricsBuilder {
    period_h: f64,
    bands: Vec<(usize, f64, f64, String)>,
    band_lo_hi: Vec<(f64, f64)>,
    terms: Vec<TermMetrics>,
    /// Each input's name and its sum over the steps so far.
    input_sums: Vec<(String, f64)>,
    epi: f64,
    steps: usize,
    times_ms: Vec<f64>,
    iterations: usize,
    failed: usize,
    fallbacks: usize,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let idx = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[idx.min(sorted.len() - 1)]
}

impl MetricsBuilder {
    /// An empty accumulator for a season of `plant`.
    pub fn new(plant: &Plant) -> MetricsBuilder {
        let m = &plant.model;
        MetricsBuilder {
            period_h: m.sample_period / 3600.0,
            bands: m
                .soft
                .iter()
                .map(|b| (b.output, 0.0, 0.0, m.outputs[b.output].info.name.clone()))
                .collect(),
            band_lo_hi: m.soft.iter().map(|b| (b.lower, b.upper)).collect(),
            terms: plant
                .stage_term_index
                .iter()
                .map(|&i| TermMetrics {
                    name: m.terms[i].info.name.clone(),
                    total: 0.0,
                })
                .collect(),
            input_sums: m
                .inputs
                .iter()
                .map(|u| (u.info.name.clone(), 0.0))
                .collect(),
            epi: 0.0,
            steps: 0,
            times_ms: Vec::new(),
            iterations: 0,
            failed: 0,
            fallbacks: 0,
        }
    }

    /// Adds one step: its stage terms (their sum is its economic reward), one penalty per
    /// soft band, the outputs after the step (to count hours outside the bands), the input
    /// applied and the controller's record.
    pub fn add(
        &mut self,
        terms: &[f64],
        penalties: &[f64],
        next_outputs: &[f64],
        input: &[f64],
        record: &StepRecord,
    ) {
        self.epi += terms.iter().sum::<f64>();
        for (total, value) in self.terms.iter_mut().zip(terms) {
            total.total += value;
        }
        for (sum, value) in self.input_sums.iter_mut().zip(input) {
            sum.1 += value;
        }
        self.steps += 1;
        for (i, b) in self.bands.iter_mut().enumerate() {
            b.1 += penalties[i];
            let y = next_outputs[b.0];
            let (lo, hi) = self.band_lo_hi[i];
            // NaN is outside every band.
            if !(y >= lo && y <= hi) {
                b.2 += self.period_h;
            }
        }
        self.times_ms.push(record.solve_time_s * 1e3);
        self.iterations += record.iterations;
        if record.solve_failed() {
            self.failed += 1;
        }
        if record.fallback.is_some() {
            self.fallbacks += 1;
        }
    }

    /// The season's metrics, from the steps added.
    pub fn finish(mut self) -> Metrics {
        let total_penalty: f64 = self.bands.iter().map(|b| b.1).sum();
        self.times_ms.sort_by(f64::total_cmp);
        let steps = self.steps.max(1) as f64;
        Metrics {
            steps: self.steps,
            epi: self.epi,
            total_penalty,
            cumulative_reward: self.epi - total_penalty,
            bands: self
                .bands
                .into_iter()
                .map(|(_, penalty, hours, output)| BandMetrics {
                    output,
                    penalty,
                    hours_outside: hours,
                })
                .collect(),
            terms: self.terms,
            inputs: self
                .input_sums
                .into_iter()
                .map(|(name, sum)| InputMetrics {
                    name,
                    mean: sum / steps,
                })
                .collect(),
            solve: SolveStats {
                median_ms: percentile(&self.times_ms, 0.5),
                p95_ms: percentile(&self.times_ms, 0.95),
                max_ms: self.times_ms.last().copied().unwrap_or(0.0),
                mean_iterations: self.iterations as f64 / self.steps.max(1) as f64,
                failed_solves: self.failed,
                fallbacks: self.fallbacks,
            },
        }
    }
}
