//! `ghm train`: trains a soft actor-critic agent on a model's season, with a progress bar,
//! a learning curve (CSV and PNG) rewritten after every episode, checkpoints every few
//! episodes, and `--resume DIR` to continue an interrupted training exactly. The flags map
//! onto a training job (`job::train`); this file adds the resume's checks.
//!
//! The run folder holds `checkpoint/` (the full training state), `learning_curve.csv`,
//! `learning_curve.png`, `policy.json` (the best evaluated deterministic policy, what
//! `ghm policy` and RL-guided MPC load), `summary.json` (which records the season, so
//! that `--resume` continues on it) and `run.json` (complete only once every episode ran).

use crate::cli::args::WeatherArgs;
use crate::cli::CliError;
use crate::job::output::model_hash;
use crate::job::train::{
    prepare, rl, run_train_job, train, Season, TrainSpec, DEFAULT_STOCHASTIC_UNCERTAINTY,
};
use crate::job::{load_model, JobOptions, RunFolder};
use crate::model::Plant;
use crate::rl::sac::{SacConfig, Trainer};
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct TrainArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// Episodes in all (each one season), the random warm-up included [default: 100].
    #[arg(long, value_name = "N")]
    pub episodes: Option<usize>,
    /// Episodes of random actions before learning starts; fewer than --episodes
    /// [default: 9].
    #[arg(long, value_name = "N")]
    pub warmup: Option<usize>,
    /// Train on the stochastic plant (parameters drawn per episode with --uncertainty).
    #[arg(long)]
    pub stochastic: bool,
    /// Parametric uncertainty δ of the stochastic plant [default: 0.05].
    #[arg(long, value_name = "DELTA")]
    pub uncertainty: Option<f64>,
    /// Seed of the training (weights, exploration, batches, parameter draws) [default: 4].
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,
    /// Discount factor γ per control step, in (0, 1] [default: 0.95, the paper's for its
    /// 30-minute step; 0.9915 keeps its look-ahead on a 5-minute step].
    #[arg(long, value_name = "G")]
    pub gamma: Option<f64>,
    /// Transitions per gradient step [default: 1024].
    #[arg(long, value_name = "N")]
    pub batch_size: Option<usize>,
    /// Initial learning rate of the actor, the critics and the entropy coefficient,
    /// decaying linearly to zero [default: 5e-3, the paper's].
    #[arg(long, value_name = "LR")]
    pub learning_rate: Option<f64>,
    /// Write a checkpoint every N episodes (and at the end).
    #[arg(long, value_name = "N", default_value_t = TrainSpec::default().checkpoint_every)]
    pub checkpoint_every: usize,
    /// Run folder.
    #[arg(long, value_name = "DIR", default_value = "runs/train")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
    /// Continue the training whose checkpoint is in DIR with the model file it started
    /// with. Its weather, season length, episodes, warm-up, seed and plant are taken from
    /// the folder; an option that says otherwise is refused.
    #[arg(long, value_name = "DIR", conflicts_with = "out")]
    pub resume: Option<PathBuf>,
}

impl TrainArgs {
    /// The training of the options given (their defaults where not given), on `season`.
    fn spec(&self, season: &Season) -> TrainSpec {
        TrainSpec {
            model: self.file.clone(),
            weather: season.weather_args.clone(),
            stochastic: season.stochastic,
            uncertainty: season.uncertainty,
            seed: season.seed,
            episodes: self.episodes.unwrap_or(TrainSpec::default().episodes),
            warmup: self.warmup.unwrap_or(TrainSpec::default().warmup),
            checkpoint_every: self.checkpoint_every,
            gamma: self.gamma.unwrap_or(TrainSpec::default().gamma),
            batch_size: self.batch_size.unwrap_or(TrainSpec::default().batch_size),
            learning_rate: self
                .learning_rate
                .unwrap_or(TrainSpec::default().learning_rate),
        }
    }

    /// The season of the options given (their defaults where not given).
    fn season(&self) -> Season {
        Season {
            weather_args: self.weather.spec(),
            stochastic: self.stochastic,
            uncertainty: match self.stochastic {
                true => self.uncertainty.unwrap_or(DEFAULT_STOCHASTIC_UNCERTAINTY),
                false => 0.0,
            },
            seed: self.seed.unwrap_or(TrainSpec::default().seed),
        }
    }
}

pub fn run(args: &TrainArgs) -> Result<(), CliError> {
    let options = JobOptions {
        overwrite: args.overwrite,
        verbose: true,
    };
    let Some(dir) = &args.resume else {
        run_train_job(&args.spec(&args.season()), &args.out, &options, false)?;
        return Ok(());
    };
    let model = load_model(&args.file)?;
    let hash = model_hash(&Plant::new(model));
    let season = recorded_season(dir, args, &hash)?;
    if args.checkpoint_every == 0 {
        return Err(CliError::Argument(
            "--checkpoint-every must be at least 1".into(),
        ));
    }
    let prepared = prepare(&args.file, &season)?;
    let mut trainer = Trainer::resume(prepared.env, dir).map_err(rl)?;
    check_same_settings(args, trainer.config())?;
    println!(
        "resuming {} after episode {} of {}",
        dir.display(),
        trainer.episodes_done(),
        trainer.config().episodes
    );
    let folder = RunFolder::continue_in(dir)?;
    Ok(folder.finish(train(
        &mut trainer,
        dir,
        &prepared.plant,
        args.checkpoint_every,
        &prepared.meta,
        true,
    ))?)
}

/// The season a training in `dir` runs on, as its `summary.json` records it. Refuses a
/// training of another model, and options that say otherwise than the record. A folder
/// of a ghm that did not record the season yet continues with the options given.
fn recorded_season(dir: &Path, args: &TrainArgs, hash: &str) -> Result<Season, CliError> {
    let path = dir.join("summary.json");
    let given = args.season();
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(given);
    };
    let summary: serde_json::Value =
        serde_json::from_str(&text).map_err(|source| CliError::Json {
            what: path.display().to_string(),
            source,
        })?;
    if let Some(h) = summary["model_sha256"].as_str().filter(|h| *h != hash) {
        return Err(CliError::Argument(format!(
            "{} was trained on another model (sha256 {h}); pass the same model file",
            dir.display()
        )));
    }
    let Some(recorded) = summary.get("season") else {
        return Ok(given);
    };
    let recorded: Season =
        serde_json::from_value(recorded.clone()).map_err(|source| CliError::Json {
            what: format!("{}: \"season\"", path.display()),
            source,
        })?;
    let conflict = |option: &str| {
        CliError::Argument(format!(
            "{option} differs from the training in {} (it was started with {}); a resumed training keeps its season: drop the option",
            dir.display(),
            recorded_command(&summary)
        ))
    };
    let weather = args.weather.spec();
    if !weather.is_default() && weather != recorded.weather_args {
        return Err(conflict("a weather or season-length option"));
    }
    if (args.stochastic && !recorded.stochastic)
        || args.uncertainty.is_some_and(|u| u != recorded.uncertainty)
    {
        return Err(conflict("--stochastic/--uncertainty"));
    }
    Ok(recorded)
}

/// The command line a summary records, for messages.
fn recorded_command(summary: &serde_json::Value) -> String {
    match summary["command"].as_array() {
        Some(words) => {
            let words: Vec<&str> = words.iter().filter_map(|w| w.as_str()).collect();
            format!("`{}`", words.join(" "))
        }
        None => "other options".into(),
    }
}

/// Refuses `--episodes`, `--warmup`, `--gamma`, `--batch-size`, `--learning-rate` and
/// `--seed` that differ from a resumed training's.
fn check_same_settings(args: &TrainArgs, config: &SacConfig) -> Result<(), CliError> {
    same_as_kept("--episodes", args.episodes, config.episodes)?;
    same_as_kept("--warmup", args.warmup, config.warmup_episodes)?;
    same_as_kept("--gamma", args.gamma, config.gamma)?;
    same_as_kept("--batch-size", args.batch_size, config.batch_size)?;
    same_as_kept("--learning-rate", args.learning_rate, config.learning_rate)?;
    same_as_kept("--seed", args.seed, config.seed)
}

/// Refuses `option`'s `given` value where it differs from the checkpoint's `kept` one.
fn same_as_kept<T: PartialEq + std::fmt::Display>(
    option: &str,
    given: Option<T>,
    kept: T,
) -> Result<(), CliError> {
    match given.filter(|g| *g != kept) {
        Some(given) => Err(CliError::Argument(format!(
            "{option} {given} conflicts with the checkpoint's {kept}: a resumed training keeps its settings; drop {option}"
        ))),
        None => Ok(()),
    }
}
