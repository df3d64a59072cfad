//! `ghm train`: trains a soft actor-critic agent on a model's season, with a progress bar,
//! a learning curve (CSV and PNG) rewritten after every episode, checkpoints every few
//! episodes, and `--resume DIR` to continue an interrupted training exactly.
//!
//! The run folder holds `checkpoint/` (the full training state), `learning_curve.csv`,
//! `learning_curve.png`, `policy.json` (the best evaluated deterministic policy, what
//! `ghm policy` and RL-guided MPC load), `summary.json` (which records the season, so
//! that `--resume` continues on it) and `run.json` (complete only once every episode ran).

use crate::cli::CliError;
use crate::job::output::{model_hash, progress_bar, write_atomically, write_summary};
use crate::job::{load_model, RunFolder, WeatherSpec};
use crate::model::Plant;
use crate::report::plot::{draw_xy, Line};
use crate::report::table::csv_text;
use crate::rl::sac::{checkpoint, EpisodeRecord, SacConfig, StepProgress, Trainer};
use crate::rl::Env;
use crate::sim::season::UncertaintyDraw;
use clap::Args;
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(Debug, Args)]
pub struct TrainArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    #[command(flatten)]
    pub weather: WeatherSpec,
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
    /// Write a checkpoint every N episodes (and at the end).
    #[arg(long, value_name = "N", default_value_t = 5)]
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

/// What a training runs on, from the arguments or, resumed, from its folder.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Season {
    weather_args: WeatherSpec,
    stochastic: bool,
    uncertainty: f64,
    seed: u64,
}

impl Season {
    /// The season of the options given (their defaults where not given).
    fn given(args: &TrainArgs) -> Season {
        Season {
            weather_args: args.weather.clone(),
            stochastic: args.stochastic,
            uncertainty: match args.stochastic {
                true => args.uncertainty.unwrap_or(0.05),
                false => 0.0,
            },
            seed: args.seed.unwrap_or(4),
        }
    }
}

/// The most episodes of one training (a 40-day lettuce episode is 1 920 steps).
const MAX_EPISODES: usize = 100_000;

pub fn run(args: &TrainArgs) -> Result<(), CliError> {
    if args.checkpoint_every == 0 {
        return Err(CliError::Argument(
            "--checkpoint-every must be at least 1".into(),
        ));
    }
    let model = load_model(&args.file)?;
    let plant = Arc::new(Plant::new(model));
    let hash = model_hash(&plant);
    let season = match &args.resume {
        Some(dir) => recorded_season(dir, args, &hash)?,
        None => Season::given(args),
    };
    if season.stochastic && !(season.uncertainty > 0.0 && season.uncertainty < 1.0) {
        return Err(CliError::Argument(
            "--stochastic needs --uncertainty in (0, 1)".into(),
        ));
    }
    let weather_args = &season.weather_args;
    let steps = weather_args.steps(&plant.model)?;
    let weather = weather_args.load(&plant.model, steps, 0)?;
    let uncertainty = season.stochastic.then_some(UncertaintyDraw {
        delta: season.uncertainty,
        seed: season.seed,
    });
    let env = Env::new(plant.clone(), weather, steps, uncertainty).map_err(rl)?;
    let (folder, mut trainer) = match &args.resume {
        Some(dir) => {
            let trainer = Trainer::resume(env, dir).map_err(rl)?;
            check_same_settings(args, trainer.config())?;
            println!(
                "resuming {} after episode {} of {}",
                dir.display(),
                trainer.episodes_done(),
                trainer.config().episodes
            );
            (RunFolder::continue_in(dir)?, trainer)
        }
        None => {
            if checkpoint::exists(&args.out) && !args.overwrite {
                return Err(CliError::Argument(format!(
                    "{} already holds a training; continue it with --resume {} or choose another --out",
                    args.out.display(),
                    args.out.display()
                )));
            }
            let config = SacConfig {
                episodes: args.episodes.unwrap_or(100),
                warmup_episodes: args.warmup.unwrap_or(9),
                seed: season.seed,
                eval_episodes: if season.stochastic { 3 } else { 1 },
                ..SacConfig::default()
            };
            if config.episodes > MAX_EPISODES {
                return Err(CliError::Argument(format!(
                    "--episodes {}: a training has at most {MAX_EPISODES} episodes",
                    config.episodes
                )));
            }
            if config.warmup_episodes >= config.episodes {
                return Err(CliError::Argument(format!(
                    "--warmup {} is not fewer than --episodes {}: the training would end before it learns anything",
                    config.warmup_episodes, config.episodes
                )));
            }
            let trainer = Trainer::new(env, config).map_err(rl)?;
            (RunFolder::claim(&args.out, args.overwrite, None)?, trainer)
        }
    };
    let meta = json!({
        "command": std::env::args().collect::<Vec<_>>(),
        "model": args.file.display().to_string(),
        "model_name": plant.model.name,
        "model_sha256": hash,
        "weather": weather_args.describe(&plant.model),
        "episode_steps": steps,
        "stochastic": season.stochastic,
        "uncertainty": season.uncertainty,
        "season": season,
    });
    let dir = args.resume.as_ref().unwrap_or(&args.out);
    folder.finish(train(
        &mut trainer,
        dir,
        &plant,
        args.checkpoint_every,
        &meta,
    ))
}

fn rl(e: crate::rl::RlError) -> CliError {
    CliError::Argument(e.to_string())
}

/// The season a training in `dir` runs on, as its `summary.json` records it. Refuses a
/// training of another model, and options that say otherwise than the record. A folder
/// of a ghm that did not record the season yet continues with the options given.
fn recorded_season(dir: &Path, args: &TrainArgs, hash: &str) -> Result<Season, CliError> {
    let path = dir.join("summary.json");
    let given = Season::given(args);
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(given);
    };
    let summary: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| CliError::Argument(format!("{}: {e}", path.display())))?;
    if let Some(h) = summary["model_sha256"].as_str().filter(|h| *h != hash) {
        return Err(CliError::Argument(format!(
            "{} was trained on another model (sha256 {h}); pass the same model file",
            dir.display()
        )));
    }
    let Some(recorded) = summary.get("season") else {
        return Ok(given);
    };
    let recorded: Season = serde_json::from_value(recorded.clone())
        .map_err(|e| CliError::Argument(format!("{}: \"season\": {e}", path.display())))?;
    let conflict = |option: &str| {
        CliError::Argument(format!(
            "{option} differs from the training in {} (it was started with {}); a resumed training keeps its season: drop the option",
            dir.display(),
            recorded_command(&summary)
        ))
    };
    if !args.weather.is_default() && args.weather != recorded.weather_args {
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

/// Refuses `--episodes`, `--warmup` and `--seed` that differ from a resumed training's.
fn check_same_settings(args: &TrainArgs, config: &SacConfig) -> Result<(), CliError> {
    let checks = [
        ("--episodes", args.episodes, config.episodes),
        ("--warmup", args.warmup, config.warmup_episodes),
    ];
    for (option, given, kept) in checks {
        if let Some(given) = given.filter(|g| *g != kept) {
            return Err(CliError::Argument(format!(
                "{option} {given} conflicts with the checkpoint's {kept}: a resumed training keeps its settings; drop {option}"
            )));
        }
    }
    if let Some(seed) = args.seed.filter(|s| *s != config.seed) {
        return Err(CliError::Argument(format!(
            "--seed {seed} conflicts with the checkpoint's {}: a resumed training keeps its settings; drop --seed",
            config.seed
        )));
    }
    Ok(())
}

fn train(
    trainer: &mut Trainer,
    dir: &Path,
    plant: &Plant,
    checkpoint_every: usize,
    meta: &serde_json::Value,
) -> Result<(), CliError> {
    let config = trainer.config().clone();
    let episode_steps = meta["episode_steps"].as_u64().unwrap_or(1);
    let bar = progress_bar(
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
        if bar.is_hidden() {
            println!("{line}");
        } else {
            bar.println(line);
        }
        write_curve(dir, trainer.curve())?;
        if record.episode % checkpoint_every == 0 || trainer.is_finished() {
            save(trainer, dir, meta, &started, session_steps)?;
        }
    }
    bar.finish_and_clear();
    save(trainer, dir, meta, &started, session_steps)?;
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
) -> Result<(), CliError> {
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
    Ok(write_summary(dir, &summary)?)
}

/// `learning_curve.csv` and `learning_curve.png`.
fn write_curve(dir: &Path, curve: &[EpisodeRecord]) -> Result<(), CliError> {
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
    Ok(write_atomically(&dir.join("learning_curve.png"), |path| {
        draw_xy(
            "SAC learning curve",
            "episode",
            "cumulative reward",
            &x,
            &[training, evaluation],
            path,
        )
    })?)
}
