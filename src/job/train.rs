//! A training job: a soft actor-critic agent trained on a model's season into a run folder,
//! with its learning curve (CSV and PNG) rewritten after every episode, a checkpoint every
//! few episodes, and `policy.json` (the best evaluated deterministic policy). `ghm train`
//! runs one from its flags; `ghm study` plans them for the agents its controllers follow.
//! A job killed halfway resumes from its last checkpoint when run again with the same spec.
//!
//! The run folder holds `checkpoint/` (the full training state), `learning_curve.csv`,
//! `learning_curve.png`, `policy.json`, `summary.json` (which records the season, so that
//! `ghm train --resume` continues on it) and `run.json` (complete only once every episode
//! ran).

use crate::job::folder::{self, RunFolder};
use crate::job::output::{
    model_hash, println_beside, progress_bar_if, write_atomically, write_summary,
};
use crate::job::{load_model, JobError, JobOptions, WeatherSpec};
use crate::model::Plant;
use crate::report::plot::{draw_xy, Line};
use crate::report::table::csv_text;
use crate::rl::sac::{checkpoint, EpisodeRecord, SacConfig, StepProgress, Trainer};
use crate::rl::Env;
use crate::sim::season::UncertaintyDraw;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// A training, as plain data (the flags of `ghm train`, a study's `[agents]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainSpec {
    /// The model file (.ghm).
    pub model: PathBuf,
    /// The season trained on.
    #[serde(default)]
    pub weather: WeatherSpec,
    /// Train on the perturbed plant (parameters drawn per episode).
    #[serde(default)]
    pub stochastic: bool,
    /// Its parametric uncertainty δ (0 on the nominal plant).
    #[serde(default)]
    pub uncertainty: f64,
    /// Seed of the training (weights, exploration, batches, parameter draws).
    pub seed: u64,
    /// Episodes in all, the random warm-up included.
    pub episodes: usize,
    /// Episodes of random actions before learning starts.
    pub warmup: usize,
    /// A checkpoint every this many episodes (and at the end).
    pub checkpoint_every: usize,
    /// Discount factor γ per control step, in `(0, 1]`: the paper's 0.95 per 30-minute
    /// step looks about ten hours ahead; a plant with a shorter step keeps that look-ahead
    /// with `0.95^(step / 30 min)` (0.9915 at 5 minutes).
    #[serde(default = "default_gamma")]
    pub gamma: f64,
    /// Transitions per gradient step.
    #[serde(default = "default_batch_size")]
    pub batch_size: usize,
    /// Initial learning rate of the actor, the critics and the entropy coefficient,
    /// decaying linearly to zero. Left out of the spec where it is the default, so that
    /// folders written before it was an option stay complete for a study.
    #[serde(
        default = "default_learning_rate",
        skip_serializing_if = "is_default_learning_rate"
    )]
    pub learning_rate: f64,
}

fn default_gamma() -> f64 {
    SacConfig::default().gamma
}

fn default_batch_size() -> usize {
    SacConfig::default().batch_size
}

fn default_learning_rate() -> f64 {
    SacConfig::default().learning_rate
}

fn is_default_learning_rate(rate: &f64) -> bool {
    *rate == default_learning_rate()
}

/// The most episodes of one training (a 40-day lettuce episode is 1 920 steps).
pub const MAX_EPISODES: usize = 100_000;

/// The parametric uncertainty δ a stochastic training draws from where none is given.
pub const DEFAULT_STOCHASTIC_UNCERTAINTY: f64 = 0.05;

impl Default for TrainSpec {
    /// `ghm train`'s defaults (a study's `[agents]` too): 100 episodes, the first 9 of
    /// random actions, seed 4, a checkpoint every 5 episodes, on the nominal plant of the
    /// built-in season; `model` is to be set.
    fn default() -> Self {
        TrainSpec {
            model: PathBuf::new(),
            weather: WeatherSpec::default(),
            stochastic: false,
            uncertainty: 0.0,
            seed: 4,
            episodes: 100,
            warmup: 9,
            checkpoint_every: 5,
            gamma: default_gamma(),
            batch_size: default_batch_size(),
            learning_rate: default_learning_rate(),
        }
    }
}

impl TrainSpec {
    /// The season the training runs on, as `summary.json` records it.
    pub fn season(&self) -> Season {
        Season {
            weather_args: self.weather.clone(),
            stochastic: self.stochastic,
            uncertainty: if self.stochastic {
                self.uncertainty
            } else {
                0.0
            },
            seed: self.seed,
        }
    }

    /// The trainer's settings (the paper's, with these episodes, seed, γ, batch and
    /// learning rate).
    pub fn config(&self) -> SacConfig {
        SacConfig {
            episodes: self.episodes,
            warmup_episodes: self.warmup,
            seed: self.seed,
            eval_episodes: if self.stochastic { 3 } else { 1 },
            gamma: self.gamma,
            batch_size: self.batch_size,
            learning_rate: self.learning_rate,
            ..SacConfig::default()
        }
    }

    /// Refuses settings that cannot train: the error names the field.
    pub fn check(&self) -> Result<(), JobError> {
        if self.checkpoint_every == 0 {
            return Err(JobError::field("checkpoint_every", 0, "must be at least 1"));
        }
        if !(self.gamma > 0.0 && self.gamma <= 1.0) {
            return Err(JobError::field("gamma", self.gamma, "must lie in (0, 1]"));
        }
        if self.batch_size == 0 {
            return Err(JobError::field("batch_size", 0, "must be at least 1"));
        }
        if !(self.learning_rate > 0.0 && self.learning_rate.is_finite()) {
            return Err(JobError::field(
                "learning_rate",
                self.learning_rate,
                "must be positive",
            ));
        }
        if self.stochastic && !(self.uncertainty > 0.0 && self.uncertainty < 1.0) {
            return Err(JobError::field(
                "uncertainty",
                self.uncertainty,
                "a stochastic training needs a δ in (0, 1)",
            ));
        }
        if self.episodes > MAX_EPISODES {
            return Err(JobError::field(
                "episodes",
                self.episodes,
                format!("a training has at most {MAX_EPISODES} episodes"),
            ));
        }
        if self.warmup >= self.episodes {
            return Err(JobError::field(
                "warmup",
                self.warmup,
                format!(
                    "not fewer than the {} episodes: the training would end before it learns \
                     anything",
                    self.episodes
                ),
            ));
        }
        Ok(())
    }
}

/// What a training runs on; recorded in `summary.json` as `"season"`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Season {
    /// The weather options.
    pub weather_args: WeatherSpec,
    /// On the perturbed plant.
    pub stochastic: bool,
    /// Its δ (0 on the nominal plant).
    pub uncertainty: f64,
    /// The training's seed.
    pub seed: u64,
}

/// A training's environment and the fields its summary starts from.
pub struct Prepared {
    /// The plant.
    pub plant: Arc<Plant>,
    /// The episodic environment over the season.
    pub env: Env,
    /// The model's sha256, recorded in the summary.
    pub model_hash: String,
    /// The summary's fields that describe the training.
    pub meta: serde_json::Value,
}

/// Loads the model and builds the environment of `season`.
pub fn prepare(model_file: &Path, season: &Season) -> Result<Prepared, JobError> {
    let model = load_model(model_file)?;
    let plant = Arc::new(Plant::new(model));
    let hash = model_hash(&plant);
    let weather_args = &season.weather_args;
    let steps = weather_args.steps(&plant.model)?;
    let weather = weather_args.load(&plant.model, steps, 0)?;
    let uncertainty = season.stochastic.then_some(UncertaintyDraw {
        delta: season.uncertainty,
        seed: season.seed,
    });
    let env = Env::new(plant.clone(), weather, steps, uncertainty).map_err(rl)?;
    let meta = json!({
        "command": std::env::args().collect::<Vec<_>>(),
        "model": model_file.display().to_string(),
        "model_name": plant.model.name,
        "model_sha256": hash,
        "weather": weather_args.describe(&plant.model),
        "episode_steps": steps,
        "stochastic": season.stochastic,
        "uncertainty": season.uncertainty,
        "season": season,
    });
    Ok(Prepared {
        plant,
        env,
        model_hash: hash,
        meta,
    })
}

/// Runs the training `spec` names into `out`, from the start (an earlier run's files
/// replaced only with `options.overwrite`) or, with `continue_interrupted` (a study's), from
/// the checkpoint of an interrupted training of the same spec that `out` holds.
pub fn run_train_job(
    spec: &TrainSpec,
    out: &Path,
    options: &JobOptions,
    continue_interrupted: bool,
) -> Result<(), JobError> {
    spec.check()?;
    let prepared = prepare(&spec.model, &spec.season())?;
    let recorded = json!(spec);
    let same = folder::recorded(out).is_some_and(|(_, s)| s == recorded);
    let (folder, mut trainer) = if continue_interrupted && same && checkpoint::exists(out) {
        let trainer = Trainer::resume(prepared.env, out).map_err(rl)?;
        (RunFolder::continue_in(out)?, trainer)
    } else {
        if checkpoint::exists(out) && !options.overwrite {
            return Err(JobError::Spec(format!(
                "{} already holds a training; continue it with `ghm train --resume {}` or choose another --out",
                out.display(),
                out.display()
            )));
        }
        let trainer = Trainer::new(prepared.env, spec.config()).map_err(rl)?;
        (
            RunFolder::claim(out, options.overwrite, Some(recorded))?,
            trainer,
        )
    };
    folder.finish(train(
        &mut trainer,
        out,
        &prepared.plant,
        spec.checkpoint_every,
        &prepared.meta,
        options.verbose,
    ))
}

/// A trainer's error as the job layer's.
pub fn rl(e: crate::rl::RlError) -> JobError {
    JobError::Rl(e)
}

/// Trains until the last episode, writing the curve after every episode and a checkpoint
/// every `checkpoint_every`; `verbose` draws a progress bar and prints each episode.
pub fn train(
    trainer: &mut Trainer,
    dir: &Path,
    plant: &Plant,
    checkpoint_every: usize,
    meta: &serde_json::Value,
    verbose: bool,
) -> Result<(), JobError> {
    let config = trainer.config().clone();
    let episode_steps = meta["episode_steps"].as_u64().unwrap_or(1);
    let bar = progress_bar_if(
        verbose,
        (config.episodes as u64) * episode_steps,
        "{bar:30} {percent:>3}% {msg} [{elapsed_precise}, eta {eta}]",
    );
    bar.set_position((trainer.episodes_done() as u64) * episode_steps);
    let unit = plant.model.objective_unit();
    let started = Instant::now();
    let mut session_steps = 0u64;
    let mut last = trainer.curve().last().map(|r| r.reward);
    while !trainer.is_finished() {
        let episode_start = Instant::now();
        let done_before = trainer.episodes_done() as u64;
        let record = trainer
            .run_episode(&mut |p: &StepProgress| {
                let rate = p.step as f64 / episode_start.elapsed().as_secs_f64().max(1e-9);
                bar.set_position(done_before * episode_steps + p.step as u64);
                bar.set_message(format!(
                    "episode {}/{} · last reward {} · {:.0} steps/s",
                    p.episode,
                    config.episodes,
                    last.map_or("—".into(), |r| format!("{r:+.3} {unit}")),
                    rate
                ));
            })
            .map_err(rl)?;
        session_steps += record.steps as u64;
        last = Some(record.reward);
        let line = describe(&record, &unit);
        if verbose {
            println_beside(&bar, line);
        }
        write_curve(dir, trainer.curve())?;
        if record.episode % checkpoint_every == 0 || trainer.is_finished() {
            save(trainer, dir, meta, &started, session_steps)?;
        }
    }
    bar.finish_and_clear();
    save(trainer, dir, meta, &started, session_steps)?;
    if !verbose {
        return Ok(());
    }
    match trainer.best() {
        Some(b) => println!(
            "best deterministic policy: episode {}, evaluation reward {:+.4} {unit}",
            b.episode, b.eval_reward
        ),
        None => println!("no evaluation ran; policy.json holds the final policy"),
    }
    println!(
        "wrote {0}/policy.json, learning_curve.csv, learning_curve.png, summary.json, checkpoint/",
        dir.display()
    );
    Ok(())
}

fn describe(r: &EpisodeRecord, unit: &str) -> String {
    let mut line = format!(
        "episode {:>3}: reward {:+.4} {unit}{}",
        r.episode,
        r.reward,
        if r.warmup { " (random warm-up)" } else { "" }
    );
    if let Some(e) = r.eval_reward {
        line += &format!(", deterministic {e:+.4} {unit}");
    }
    if r.diverged {
        line += &format!(", state diverged after {} steps", r.steps);
    }
    if !r.warmup {
        line += &format!(", α {:.3}, critic loss {:.3e}", r.alpha, r.critic_loss);
    }
    line + &format!(", {:.1} s", r.wall_s)
}

/// Writes the checkpoint, the shipped policy and the summary.
fn save(
    trainer: &Trainer,
    dir: &Path,
    meta: &serde_json::Value,
    started: &Instant,
    session_steps: u64,
) -> Result<(), JobError> {
    trainer.save_checkpoint(dir).map_err(rl)?;
    let name = meta["model_name"].as_str().unwrap_or("model");
    trainer
        .policy(name)
        .and_then(|p| Ok(p.save(&dir.join("policy.json"))?))
        .map_err(rl)?;
    let curve = trainer.curve();
    let wall: f64 = curve.iter().map(|r| r.wall_s).sum();
    let steps: u64 = curve.iter().map(|r| r.steps as u64).sum();
    let learning: Vec<&EpisodeRecord> = curve.iter().filter(|r| !r.warmup).collect();
    let learning_wall: f64 = learning.iter().map(|r| r.wall_s).sum();
    let updates: u64 = learning.iter().map(|r| r.steps as u64).sum();
    let mut summary = meta.clone();
    if let Some(map) = summary.as_object_mut() {
        map.insert("config".into(), json!(trainer.config()));
        map.insert("finished".into(), json!(trainer.is_finished()));
        map.insert("episodes_done".into(), json!(curve.len()));
        map.insert("environment_steps".into(), json!(steps));
        map.insert("gradient_steps".into(), json!(updates));
        map.insert("training_wall_s".into(), json!(wall));
        map.insert(
            "learning_steps_per_s".into(),
            json!(if learning_wall > 0.0 {
                updates as f64 / learning_wall
            } else {
                0.0
            }),
        );
        map.insert(
            "this_session".into(),
            json!({ "wall_s": started.elapsed().as_secs_f64(), "environment_steps": session_steps }),
        );
        map.insert(
            "last_episode_reward".into(),
            json!(curve.last().map(|r| r.reward)),
        );
        map.insert(
            "best".into(),
            json!(trainer
                .best()
                .map(|b| json!({ "episode": b.episode, "eval_reward": b.eval_reward }))),
        );
        map.insert(
            "diverged_episodes".into(),
            json!(curve.iter().filter(|r| r.diverged).count()),
        );
    }
    write_summary(dir, &summary)
}

/// `learning_curve.csv` and `learning_curve.png`.
fn write_curve(dir: &Path, curve: &[EpisodeRecord]) -> Result<(), JobError> {
    let header = [
        "episode",
        "total_steps",
        "steps",
        "reward",
        "eval_reward",
        "warmup",
        "diverged",
        "critic_loss",
        "actor_loss",
        "alpha",
        "entropy",
        "wall_s",
    ];
    let records = curve.iter().map(|r| {
        [
            r.episode.to_string(),
            r.total_steps.to_string(),
            r.steps.to_string(),
            r.reward.to_string(),
            r.eval_reward.map_or(String::new(), |e| e.to_string()),
            r.warmup.to_string(),
            r.diverged.to_string(),
            r.critic_loss.to_string(),
            r.actor_loss.to_string(),
            r.alpha.to_string(),
            r.entropy.to_string(),
            format!("{:.3}", r.wall_s),
        ]
    });
    write_atomically(&dir.join("learning_curve.csv"), |path| {
        std::fs::write(path, csv_text(header, records)?)
    })?;
    let x: Vec<f64> = curve.iter().map(|r| r.episode as f64).collect();
    let training = Line {
        label: "training episode".into(),
        values: curve.iter().map(|r| r.reward).collect(),
    };
    let evaluation = Line {
        label: "deterministic policy".into(),
        values: curve
            .iter()
            .map(|r| r.eval_reward.unwrap_or(f64::NAN))
            .collect(),
    };
    write_atomically(&dir.join("learning_curve.png"), |path| {
        draw_xy(
            "SAC learning curve",
            "episode",
            "cumulative reward",
            &x,
            &[training, evaluation],
            path,
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_learning_rate_is_left_out_of_the_spec_and_another_is_kept() {
        // A study compares a folder's recorded spec with its own: folders written before
        // the learning rate was an option hold no such field.
        let default = TrainSpec::default();
        let json = serde_json::to_value(&default).unwrap();
        assert!(json.get("learning_rate").is_none(), "{json}");
        let read: TrainSpec = serde_json::from_value(json).unwrap();
        assert_eq!(read, default);

        let slower = TrainSpec {
            learning_rate: 5e-4,
            ..TrainSpec::default()
        };
        let json = serde_json::to_value(&slower).unwrap();
        assert_eq!(json["learning_rate"], 5e-4);
        let read: TrainSpec = serde_json::from_value(json).unwrap();
        assert_eq!(read.config().learning_rate, 5e-4);
    }
}
