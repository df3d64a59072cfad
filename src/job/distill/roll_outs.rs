//! The roll-outs of a distillation: seasons on the agent's environment driven by the
//! teacher or the student, every state labelled by a teacher of the roll-out's own, run
//! `threads` at a time; and the student's evaluation.

use super::{Job, MAX_ITERATIONS};
use crate::agent::observation::action_from_input;
use crate::agent::PolicyFile;
use crate::control::{Controller, Observation};
use crate::job::{build_controller, JobError, WeatherSpec};
use crate::rl::imitation::Demonstrations;
use crate::rl::sac::agent::standard_normal;
use crate::rl::{Env, RlError};
use crate::sim::season::{derived_seed, UncertaintyDraw};
use crate::sim::weather::Weather;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::sync::Arc;

/// The roll-outs of one iteration, in roll-out order.
pub(super) struct Labelled {
    pub(super) demonstrations: Demonstrations,
    /// Roll-out of each label.
    pub(super) roll_out: Vec<usize>,
    /// Reward of the first (noise-free) roll-out.
    pub(super) first_reward: f64,
    pub(super) failed: usize,
}

/// Evaluation draws of a stochastic student (its roll-outs are numbered past every
/// labelling roll-out's).
const EVALUATION_DRAWS: u64 = 3;

impl Job<'_> {
    /// The roll-outs of `iteration` (driven by the teacher, or by `student`), labelled by
    /// the teacher, `threads` at a time; `tick` after every step.
    pub(super) fn label(
        &self,
        iteration: usize,
        student: Option<&PolicyFile>,
        tick: &(dyn Fn() + Sync),
    ) -> Result<Labelled, JobError> {
        let spec = self.spec;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(self.threads)
            .build()
            .map_err(|e| JobError::Spec(format!("cannot start the roll-outs' threads: {e}")))?;
        let runs: Vec<Result<RollOut, JobError>> = pool.install(|| {
            (0..spec.roll_outs)
                .into_par_iter()
                .map(|r| self.roll_out(iteration, r, student, tick))
                .collect()
        });
        let (width, nu) = (
            spec.observation().width(&self.plant.model),
            self.plant.layout.nu,
        );
        let mut labelled = Labelled {
            demonstrations: Demonstrations::new(width, nu),
            roll_out: Vec::new(),
            first_reward: f64::NAN,
            failed: 0,
        };
        for (r, run) in runs.into_iter().enumerate() {
            let roll_out = run?;
            if r == 0 {
                labelled.first_reward = roll_out.reward;
            }
            labelled.failed += roll_out.failed;
            let n = roll_out.demonstrations.len();
            labelled.demonstrations.extend(&roll_out.demonstrations)?;
            labelled.roll_out.extend(std::iter::repeat_n(r, n));
        }
        Ok(labelled)
    }

    /// Roll-out `r` of `iteration`: one season driven by the teacher (with `student`
    /// `None`) or the student, the noise added after the first roll-out (which also may
    /// start elsewhere in the weather file, and be warmed), every state labelled by a
    /// teacher of its own.
    fn roll_out(
        &self,
        iteration: usize,
        r: usize,
        student: Option<&PolicyFile>,
        tick: &(dyn Fn() + Sync),
    ) -> Result<RollOut, JobError> {
        let spec = self.spec;
        let index = (iteration * spec.roll_outs + r) as u64;
        let mut teacher = build_controller(&spec.teacher_run())?.controller;
        let elsewhere = match spec.start_rows.filter(|_| r > 0) {
            Some(rows) => {
                let mut draw =
                    ChaCha8Rng::seed_from_u64(derived_seed(spec.seed ^ 0x726f_7773, index));
                let start_row = draw.random_range(rows.first..=rows.last);
                let season = WeatherSpec {
                    start_row,
                    ..spec.weather.clone()
                };
                Some(season.load(&self.plant.model, self.steps, self.forecast_rows)?)
            }
            None => None,
        };
        let warmed = match spec.warming.as_ref().filter(|_| r > 0) {
            Some(warming) => {
                let mut draw =
                    ChaCha8Rng::seed_from_u64(derived_seed(spec.seed ^ 0x7761_726d, index));
                let [lo, hi] = warming.degrees;
                let degrees = lo + (hi - lo) * draw.random::<f64>();
                let recorded = elsewhere.as_ref().unwrap_or(&self.weather);
                Some(warming.apply(recorded, &self.plant.model, degrees)?)
            }
            None => None,
        };
        let noise = if r == 0 { 0.0 } else { spec.noise };
        let mut rng = ChaCha8Rng::seed_from_u64(derived_seed(spec.seed ^ 0x6461_6767, index));
        let mut driver = |observation: &[f64], label: &[f64], action: &mut [f64]| {
            match student {
                Some(policy) => {
                    let a = policy.action(observation)?;
                    action.copy_from_slice(&a);
                }
                None => action.copy_from_slice(label),
            }
            for a in action.iter_mut() {
                if noise > 0.0 {
                    *a = (*a + noise * f64::from(standard_normal(&mut rng))).clamp(-1.0, 1.0);
                }
            }
            Ok(())
        };
        let weather = warmed
            .as_ref()
            .or(elsewhere.as_ref())
            .unwrap_or(&self.weather);
        roll_out(
            self.env(weather, spec.draw(index))?,
            Some(teacher.as_mut()),
            &mut driver,
            tick,
        )
    }

    /// The student's environment over `weather` on the plant `draw` perturbs (the nominal
    /// one for `None`), observed as the student observes.
    fn env(&self, weather: &Weather, draw: Option<UncertaintyDraw>) -> Result<Env, JobError> {
        let env = Env::new(Arc::clone(&self.plant), weather.clone(), self.steps, draw)?;
        Ok(env.observing(self.spec.observation()))
    }

    /// The student's reward on a noise-free roll-out of its own: on the nominal plant, or
    /// the mean over [`EVALUATION_DRAWS`] perturbed ones.
    pub(super) fn evaluate(&self, policy: &PolicyFile) -> Result<f64, JobError> {
        let spec = self.spec;
        let draws: Vec<Option<UncertaintyDraw>> = if spec.stochastic {
            let past = (MAX_ITERATIONS * spec.roll_outs) as u64;
            (0..EVALUATION_DRAWS).map(|j| spec.draw(past + j)).collect()
        } else {
            vec![None]
        };
        let mut sum = 0.0;
        for draw in &draws {
            let mut act = |observation: &[f64], _: &[f64], action: &mut [f64]| {
                action.copy_from_slice(&policy.action(observation)?);
                Ok(())
            };
            sum += roll_out(self.env(&self.weather, *draw)?, None, &mut act, &|| {})?.reward;
        }
        Ok(sum / draws.len() as f64)
    }
}

/// One roll-out's labels and reward.
struct RollOut {
    demonstrations: Demonstrations,
    reward: f64,
    failed: usize,
}

/// How a roll-out sets each step's action: from the observation and the teacher's label.
type ChooseAction<'a> =
    dyn FnMut(&[f64], &[f64], &mut [f64]) -> Result<(), crate::agent::AgentError> + 'a;

/// A season on the agent's environment `env`, reset first: `act(observation, label,
/// action)` sets each step's action, the label being the `teacher`'s decision as an action
/// (zeros without a teacher). A plant that diverges ends the roll-out with what it
/// labelled.
fn roll_out(
    mut env: Env,
    mut teacher: Option<&mut dyn Controller>,
    act: &mut ChooseAction<'_>,
    tick: &(dyn Fn() + Sync),
) -> Result<RollOut, JobError> {
    let (width, nu) = (env.observation_len(), env.action_len());
    let ny = env.plant().model.outputs.len();
    let steps = env.episode_len();
    let mut result = RollOut {
        demonstrations: Demonstrations::new(width, nu),
        reward: 0.0,
        failed: 0,
    };
    let mut observation = env.reset().to_vec();
    let (mut label, mut action) = (vec![0.0; nu], vec![0.0; nu]);
    for k in 0..steps {
        if let Some(teacher) = teacher.as_deref_mut() {
            let weather = env.weather();
            let forecast = weather.horizon(k, weather.len() - k).unwrap_or(&[]);
            let decision = teacher
                .decide(&Observation {
                    step: k,
                    state: env.state(),
                    outputs: &observation[..ny],
                    previous_input: env.previous_input(),
                    forecast,
                })
                .map_err(|e| JobError::Spec(format!("the teacher at step {k}: {e}")))?;
            result.failed += usize::from(decision.record.solve_failed());
            action_from_input(
                env.previous_input(),
                &decision.input,
                env.action_scale(),
                &mut label,
            );
            result.demonstrations.push(&observation, &label)?;
        }
        act(&observation, &label, &mut action).map_err(RlError::from)?;
        let transition = match env.step(&action) {
            Ok(t) => t,
            Err(RlError::Diverged { .. }) => break,
            Err(e) => return Err(e.into()),
        };
        result.reward += transition.reward;
        observation.copy_from_slice(transition.observation);
        tick();
    }
    Ok(result)
}
