//! A distillation job: a policy taught by a controller with DAgger (Ross, Gordon and
//! Bagnell 2011), into a run folder. `ghm distill` runs one from its flags.
//!
//! The teacher is any feedback controller a [`ControllerSpec`] names (by default MPC at a
//! 6 h horizon); the student is the agent's deterministic actor `a = tanh(μ(ŝ))` on the
//! agent's observation, so the result, `policy.json`, is a [`PolicyFile`] like SAC's and
//! drops in wherever a guide is accepted (RL-guided MPC, VFO, `ghm policy`, `ghm value`,
//! serve, compile, Python).
//!
//! Iteration 0 rolls out the teacher; every later one rolls out the last student. Each
//! roll-out is one season on the environment of `ghm train` (the same observation, action
//! map and reward); at every state it visits the teacher decides as if it were in charge,
//! and its decision, as an action, is the label
//! ([`action_from_input`](crate::agent::observation::action_from_input)). The first
//! roll-out of an iteration is noise-free; the others add Gaussian noise to the applied action, so
//! the labels cover the states around the path. All labels so far are aggregated and the
//! student is fitted again, continuing from its weights ([`fit_actor`]); it is then
//! evaluated on a roll-out of its own. The best student evaluated is `policy.json`.
//!
//! The roll-outs of an iteration are independent (each has its own teacher) and run in
//! parallel; their labels do not depend on the number of threads. A stopped job continues
//! from its last finished iteration when run again with the same spec, and a finished one
//! goes on for more iterations when given them; either ends as a job run at once would.
//!
//! The student observes the current weather (observation version 1) or, with
//! `forecast_rows`, also that many rows of the forecast after it (version 2,
//! [`ObservationLayout`]): a controller that plans over a horizon decides from the weather
//! to come, and a student that sees it can follow.
//!
//! The run folder holds `labels/iteration-NN.csv` (every labelled observation),
//! `student.json` (the student's weights and statistics after the last finished
//! iteration: the checkpoint), `distill_curve.csv` and `.png` (each iteration's student
//! against the teacher), `policy.json`, `summary.json` and `run.json`.

mod files;
mod roll_outs;

use crate::agent::observation::ObservationLayout;
use crate::agent::{Normalizer, PolicyFile};
use crate::job::folder::{self, RunFolder};
use crate::job::output::{io_err, println_beside, progress_bar_if, write_atomically};
use crate::job::{build_controller, load_model, ControllerSpec, JobError, JobOptions, MpcSpec};
use crate::job::{PlantSpec, RunSpec, WeatherSpec};
use crate::model::Plant;
use crate::rl::imitation::{actor_weights, fit_actor, Demonstrations, ImitationConfig};
use crate::rl::sac::net::Net;
use crate::rl::RlError;
use crate::sim::season::{derived_seed, UncertaintyDraw};
pub use crate::sim::weather::Warming;
use crate::sim::weather::{parse_range, Weather};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// A distillation, as plain data (the flags of `ghm distill`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DistillSpec {
    /// The model file (.ghm).
    pub model: PathBuf,
    /// The season the roll-outs run on.
    pub weather: WeatherSpec,
    /// The teacher: a feedback controller (MPC, RL-guided MPC, the rules, a policy).
    pub teacher: ControllerSpec,
    /// Roll out on perturbed plants (parameters drawn per roll-out); the teacher predicts
    /// with the nominal model, as every controller does.
    pub stochastic: bool,
    /// Their parametric uncertainty δ.
    pub uncertainty: f64,
    /// Seed of the student's weights, the noise, the shuffles and the parameter draws.
    pub seed: u64,
    /// DAgger iterations, the teacher's own roll-outs first.
    pub iterations: usize,
    /// Roll-outs per iteration, the first noise-free.
    pub roll_outs: usize,
    /// Standard deviation of the Gaussian noise on the applied actions (in `[−1, 1]`
    /// action units) of every roll-out but an iteration's first.
    pub noise: f64,
    /// Where the noisy roll-outs start: each at a row of the weather (the file's, or the
    /// built-in generator's run on) drawn uniformly from this range (an iteration's first
    /// roll-out keeps `weather`'s season, on which the students are evaluated), so the
    /// guide learns from more of the year than one season. `None`: every roll-out on
    /// `weather`'s season.
    pub start_rows: Option<StartRows>,
    /// Warm the noisy roll-outs' weather (each by degrees drawn uniformly from the range,
    /// the humidities named kept at their relative humidity), so the guide meets warmer
    /// weather than the rows it learns from. `None`: the weather as recorded.
    pub warming: Option<Warming>,
    /// Rows of weather forecast the student observes after the current one (0: the
    /// current weather only, observation version 1; more: version 2).
    pub forecast_rows: usize,
    /// The student's network and its fit.
    pub fit: ImitationConfig,
}

/// A range of the weather file's rows, both ends included.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartRows {
    /// The first row a roll-out may start at.
    pub first: usize,
    /// The last.
    pub last: usize,
}

impl std::str::FromStr for StartRows {
    type Err = String;

    /// `FIRST..LAST`, two row numbers (`0..5000`).
    fn from_str(text: &str) -> Result<Self, String> {
        let (first, last) = parse_range(text, "FIRST..LAST (e.g. 0..5000)", "a row number")?;
        Ok(StartRows { first, last })
    }
}

impl Default for DistillSpec {
    /// `ghm distill`'s defaults: MPC at 6 h teaches over 12 iterations of 4 roll-outs,
    /// noise 0.1, seed 4, on the nominal plant of the built-in season; `model` is to be
    /// set.
    fn default() -> Self {
        DistillSpec {
            model: PathBuf::new(),
            weather: WeatherSpec::default(),
            teacher: ControllerSpec::Mpc(MpcSpec {
                horizon: "6h".into(),
                ..MpcSpec::default()
            }),
            stochastic: false,
            uncertainty: 0.0,
            seed: 4,
            iterations: 12,
            roll_outs: 4,
            noise: 0.1,
            start_rows: None,
            warming: None,
            forecast_rows: 0,
            fit: ImitationConfig::default(),
        }
    }
}

/// The parametric uncertainty δ a stochastic distillation draws from where none is given
/// (a stochastic training's).
pub const DEFAULT_STOCHASTIC_UNCERTAINTY: f64 = crate::job::train::DEFAULT_STOCHASTIC_UNCERTAINTY;

/// The most DAgger iterations of one distillation.
pub const MAX_ITERATIONS: usize = 1000;

/// The most forecast rows a student observes.
pub const MAX_FORECAST_ROWS: usize = ObservationLayout::MAX_FORECAST_ROWS;

impl DistillSpec {
    /// Refuses settings that cannot distil: the error names the field.
    pub fn check(&self) -> Result<(), JobError> {
        if !self.teacher.kind().is_feedback() {
            return Err(JobError::field(
                "teacher",
                self.teacher.kind(),
                "must decide from the state it is given (mpc, rlmpc, rules, expert, policy)",
            ));
        }
        if self.iterations == 0 || self.iterations > MAX_ITERATIONS {
            return Err(JobError::field(
                "iterations",
                self.iterations,
                format!("must be between 1 and {MAX_ITERATIONS}"),
            ));
        }
        if self.roll_outs == 0 {
            return Err(JobError::field("roll_outs", 0, "must be at least 1"));
        }
        if self.forecast_rows > MAX_FORECAST_ROWS {
            return Err(JobError::field(
                "forecast_rows",
                self.forecast_rows,
                format!("must be at most {MAX_FORECAST_ROWS}"),
            ));
        }
        if !(self.noise >= 0.0 && self.noise.is_finite()) {
            return Err(JobError::field("noise", self.noise, "must be a number ≥ 0"));
        }
        if self.stochastic && !(self.uncertainty > 0.0 && self.uncertainty < 1.0) {
            return Err(JobError::field(
                "uncertainty",
                self.uncertainty,
                "a stochastic distillation needs a δ in (0, 1)",
            ));
        }
        if let Some(rows) = self.start_rows {
            if rows.first > rows.last {
                return Err(JobError::field(
                    "start_rows",
                    format!("{}..{}", rows.first, rows.last),
                    "the first row must not come after the last",
                ));
            }
        }
        self.fit.check().map_err(JobError::Rl)
    }

    /// Whether a distillation recorded as `recorded` is this one stopped early, or with
    /// fewer iterations: every field but `iterations` the same.
    fn continues(&self, recorded: &serde_json::Value) -> bool {
        serde_json::from_value::<DistillSpec>(recorded.clone()).is_ok_and(|r| {
            DistillSpec {
                iterations: self.iterations,
                ..r
            } == *self
        })
    }

    /// The teacher as a season spec: on the perturbed plant of a stochastic distillation,
    /// so that it plans as it would there (MPC's `bands = "auto"` backs off to the model's
    /// `plan` bands on an uncertain plant); it predicts with the nominal model either way.
    fn teacher_run(&self) -> RunSpec {
        RunSpec {
            model: self.model.clone(),
            weather: self.weather.clone(),
            plant: if self.stochastic {
                PlantSpec {
                    uncertainty: self.uncertainty,
                    seed: self.seed,
                }
            } else {
                PlantSpec::NOMINAL
            },
            controller: self.teacher.clone(),
        }
    }

    /// The observation the student sees.
    fn observation(&self) -> ObservationLayout {
        ObservationLayout::with_forecast(self.forecast_rows)
    }

    /// The parameter draw of roll-out `index` (counted over all iterations), `None` on the
    /// nominal plant.
    fn draw(&self, index: u64) -> Option<UncertaintyDraw> {
        self.stochastic.then(|| UncertaintyDraw {
            delta: self.uncertainty,
            seed: derived_seed(self.seed, index),
        })
    }
}

/// One iteration's figures: a row of `distill_curve.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// The iteration, from 0 (the teacher's roll-outs).
    pub iteration: usize,
    /// Labelled observations aggregated after it.
    pub labels: usize,
    /// The reward of its noise-free roll-out (the teacher's own at iteration 0, the last
    /// student's after).
    pub roll_out_reward: f64,
    /// The student's evaluation reward after the fit (the mean over the evaluation
    /// draws on a perturbed plant).
    pub student_reward: f64,
    /// The fit's last mean squared action error.
    pub fit_loss: f64,
    /// The teacher's solves that failed while it labelled.
    pub failed_labels: usize,
    /// Wall time of the roll-outs and their labels, in seconds.
    pub label_s: f64,
    /// Wall time of the fit and the evaluation, in seconds.
    pub fit_s: f64,
}

/// The student after an iteration: the checkpoint `student.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Checkpoint {
    /// Its weights (the master copy the next fit continues from).
    net: Net,
    /// The frozen observation statistics (of the teacher's roll-outs).
    normalizer: Normalizer,
    /// Every finished iteration's figures.
    curve: Vec<IterationRecord>,
}

/// Runs the distillation `spec` names into `out`, from the start (an earlier run's files
/// replaced only with `options.overwrite`) or, with `continue_interrupted`, from the last
/// finished iteration of an interrupted distillation of the same spec that `out` holds.
/// `threads` roll-outs run at once.
pub fn run_distill_job(
    spec: &DistillSpec,
    out: &Path,
    options: &JobOptions,
    continue_interrupted: bool,
    threads: usize,
) -> Result<(), JobError> {
    spec.check()?;
    let plant = Arc::new(Plant::new(load_model(&spec.model)?));
    if let Some(warming) = &spec.warming {
        warming.check(&plant.model).map_err(|e| {
            let [lo, hi] = warming.degrees;
            JobError::field("warming", format!("{lo}..{hi}"), e)
        })?;
    }
    let steps = spec.weather.steps(&plant.model)?;
    let probe = build_controller(&spec.teacher_run())?;
    let forecast_rows = probe.forecast_rows.max(spec.forecast_rows);
    drop(probe);
    let weather = spec.weather.load(&plant.model, steps, forecast_rows)?;
    if let Some(rows) = spec.start_rows {
        // The latest start must leave the season and the teacher's forecast in the file.
        WeatherSpec {
            start_row: rows.last,
            ..spec.weather.clone()
        }
        .load(&plant.model, steps, forecast_rows)
        .map_err(|e| {
            JobError::field(
                "start_rows",
                format!("{}..{}", rows.first, rows.last),
                format!("a roll-out from the last row cannot run: {e}"),
            )
        })?;
    }
    let recorded = json!(spec);
    let checkpoint_path = out.join("student.json");
    let continues = continue_interrupted
        && checkpoint_path.exists()
        && folder::recorded(out).is_some_and(|(_, s)| spec.continues(&s));
    let (folder, checkpoint) = if continues {
        let text = std::fs::read_to_string(&checkpoint_path).map_err(io_err(&checkpoint_path))?;
        let checkpoint: Checkpoint = serde_json::from_str(&text).map_err(|e| JobError::Resume {
            path: checkpoint_path.clone(),
            message: format!("not a distillation checkpoint: {e}"),
        })?;
        (RunFolder::continue_as(out, recorded)?, Some(checkpoint))
    } else {
        (
            RunFolder::claim(out, options.overwrite, Some(recorded))?,
            None,
        )
    };
    let job = Job {
        spec,
        plant,
        weather,
        forecast_rows,
        steps,
        out,
        threads: threads.max(1),
        verbose: options.verbose,
    };
    folder.finish(job.run(checkpoint))
}

/// What every iteration of one distillation shares.
struct Job<'a> {
    spec: &'a DistillSpec,
    plant: Arc<Plant>,
    /// The season's weather (and the teacher's forecast past its end).
    weather: Weather,
    /// Rows of forecast the teacher and the student read past a season's end.
    forecast_rows: usize,
    steps: usize,
    out: &'a Path,
    threads: usize,
    verbose: bool,
}

impl Job<'_> {
    fn run(&self, checkpoint: Option<Checkpoint>) -> Result<(), JobError> {
        let spec = self.spec;
        let names = spec.observation().names(&self.plant.model);
        let (width, nu) = (names.len(), self.plant.layout.nu);
        let mut data = Demonstrations::new(width, nu);
        let (mut state, first) = match checkpoint {
            Some(c) => {
                for iteration in 0..c.curve.len() {
                    data.extend(&self.read_labels(iteration, width, nu)?)?;
                }
                let first = c.curve.len();
                (Some(c), first)
            }
            None => (None, 0),
        };
        let started = Instant::now();
        let total = (spec.iterations * spec.roll_outs * self.steps) as u64;
        let bar = progress_bar_if(
            self.verbose,
            total,
            "{bar:30} {percent:>3}% {msg} [{elapsed_precise}, eta {eta}]",
        );
        bar.set_position((first * spec.roll_outs * self.steps) as u64);
        let unit = self.plant.model.objective_unit();
        for iteration in first..spec.iterations {
            bar.set_message(format!("iteration {iteration}/{}", spec.iterations - 1));
            let clock = Instant::now();
            let student = match &state {
                Some(c) => Some(self.policy(c, iteration)?),
                None => None,
            };
            let labelled = self.label(iteration, student.as_ref(), &|| bar.inc(1))?;
            self.write_labels(iteration, &names, &labelled)?;
            data.extend(&labelled.demonstrations)?;
            let label_s = clock.elapsed().as_secs_f64();
            let clock = Instant::now();
            let mut checkpoint = match state.take() {
                Some(c) => c,
                None => {
                    let mut normalizer = Normalizer::new(width);
                    normalizer
                        .update_batch(&labelled.demonstrations.observations)
                        .map_err(RlError::from)?;
                    normalizer.freeze();
                    Checkpoint {
                        net: spec.fit.new_actor(width, nu, spec.seed),
                        normalizer,
                        curve: Vec::new(),
                    }
                }
            };
            let losses = fit_actor(
                &mut checkpoint.net,
                &checkpoint.normalizer,
                &data,
                &spec.fit,
                derived_seed(spec.seed, iteration as u64),
            )?;
            let mut policy = self.policy(&checkpoint, iteration)?;
            let student_reward = self.evaluate(&policy)?;
            policy.eval_reward = Some(student_reward);
            let record = IterationRecord {
                iteration,
                labels: data.len(),
                roll_out_reward: labelled.first_reward,
                student_reward,
                fit_loss: losses.last().copied().unwrap_or(f64::NAN),
                failed_labels: labelled.failed,
                label_s,
                fit_s: clock.elapsed().as_secs_f64(),
            };
            let line =
                format!(
                "iteration {iteration}: {} {:+.4} {unit}, student {student_reward:+.4} {unit}, \
                 fit loss {:.2e}, {} labels{}, {:.0} s + {:.0} s",
                if iteration == 0 { "teacher" } else { "roll-out" },
                record.roll_out_reward,
                record.fit_loss,
                record.labels,
                if record.failed_labels > 0 {
                    format!(" ({} from failed solves)", record.failed_labels)
                } else {
                    String::new()
                },
                record.label_s,
                record.fit_s
            );
            let best = best_of(&checkpoint.curve).map_or(f64::NEG_INFINITY, |b| b.student_reward);
            checkpoint.curve.push(record);
            if student_reward > best {
                policy
                    .save(&self.out.join("policy.json"))
                    .map_err(RlError::from)?;
            }
            let path = self.out.join("student.json");
            write_atomically(&path, |p| {
                let text = serde_json::to_string(&checkpoint).map_err(std::io::Error::other)?;
                std::fs::write(p, text)
            })?;
            self.write_curve(&checkpoint.curve, &unit)?;
            self.write_summary(&checkpoint.curve, &started)?;
            if self.verbose {
                println_beside(&bar, line);
            }
            state = Some(checkpoint);
        }
        bar.finish_and_clear();
        if self.verbose {
            if let Some(best) = state.as_ref().and_then(|c| best_of(&c.curve)) {
                println!(
                    "best student: iteration {}, reward {:+.4} {unit} (teacher {:+.4} {unit})",
                    best.iteration,
                    best.student_reward,
                    state
                        .as_ref()
                        .and_then(|c| c.curve.first())
                        .map_or(f64::NAN, |r| r.roll_out_reward)
                );
            }
            println!(
                "wrote {0}/policy.json, distill_curve.csv, distill_curve.png, labels/, \
                 student.json, summary.json",
                self.out.display()
            );
        }
        Ok(())
    }

    /// The student of `checkpoint` as a policy file (kept after `iteration`).
    fn policy(&self, checkpoint: &Checkpoint, iteration: usize) -> Result<PolicyFile, JobError> {
        let actor = actor_weights(&checkpoint.net)?;
        let model = &self.plant.model;
        Ok(PolicyFile {
            model: model.name.clone(),
            observation: self.spec.observation(),
            observation_names: self.spec.observation().names(model),
            action_names: model.inputs.iter().map(|u| u.info.name.clone()).collect(),
            normalizer: checkpoint.normalizer.clone(),
            actor,
            episode: iteration,
            eval_reward: None,
        })
    }
}

/// The iteration whose student earned the most.
fn best_of(curve: &[IterationRecord]) -> Option<&IterationRecord> {
    curve
        .iter()
        .max_by(|a, b| a.student_reward.total_cmp(&b.student_reward))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stochastic_distillations_teacher_plans_for_an_uncertain_plant() {
        let nominal = DistillSpec::default();
        assert_eq!(nominal.teacher_run().plant, PlantSpec::NOMINAL);
        let stochastic = DistillSpec {
            stochastic: true,
            uncertainty: 0.05,
            ..DistillSpec::default()
        };
        assert_eq!(stochastic.teacher_run().plant.uncertainty, 0.05);
    }
}
