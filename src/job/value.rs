//! A value-fit job: the value network of RL-guided MPC. Rolls a guide out from states
//! scattered around its own season (in parallel), fits `V(x_i, k)` to the returns with
//! burn, and writes `value.json` (what `ghm rlmpc --value` loads), the learning curve (CSV
//! and PNG) and `summary.json` (losses, timings, and the value predicted at the season
//! start beside the return the guide earned from there). `ghm value` runs one from its
//! flags; `ghm study` plans them for its RL-guided MPC.

use crate::control::ValueFile;
use crate::job::build::{guide_factory, resolve_guide_policy, GuideFactory};
use crate::job::output::{model_hash, progress_bar_if, write_atomically, write_summary};
use crate::job::{load_model, GuideChoice, JobError, JobOptions, RunFolder, WeatherSpec};
use crate::model::Plant;
use crate::report::plot::{draw_xy, Line};
use crate::report::table::{csv_text, csv_writer};
use crate::rl::value_fit::{fit_value, EpochLoss, ValueFitConfig};
use crate::sim::value_data::{nominal_run, sample_returns, ValueDataConfig};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// A value fit, as plain data (the flags of `ghm value`, a study's `[agents]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValueSpec {
    /// The model file (.ghm).
    pub model: PathBuf,
    /// The season the guide is rolled out on.
    #[serde(default)]
    pub weather: WeatherSpec,
    /// The guide whose returns are learned.
    pub guide: GuideChoice,
    /// The guide's policy (a `ghm train` or `ghm distill` folder, or a policy file);
    /// `None`: the SAC agent shipped for the model.
    #[serde(default)]
    pub agent: Option<PathBuf>,
    /// Roll-outs from perturbed states.
    pub trajectories: usize,
    /// Relative spread σ of the start states around the guide's season.
    pub spread: f64,
    /// The state the value function reads (`None`: the model's first state).
    #[serde(default)]
    pub state: Option<String>,
    /// Training epochs of the value network.
    pub epochs: usize,
    /// Points per gradient step.
    #[serde(default = "ValueSpec::default_batch_size")]
    pub batch_size: usize,
    /// Initial Adam learning rate, decaying linearly to zero.
    #[serde(default = "ValueSpec::default_learning_rate")]
    pub learning_rate: f64,
    /// Seed of the roll-outs and of the fit.
    pub seed: u64,
    /// Also write the fitted points to `value_data.csv` (the state, the step, the return),
    /// for fitting them elsewhere (`benches/value_fit_torch.py`). Not recorded when off,
    /// so that the specs of earlier runs read the same.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub save_data: bool,
}

impl Default for ValueSpec {
    /// `ghm value`'s defaults (a study's `[agents]` too): the SAC guide shipped for the
    /// model, 1 000 roll-outs spread by σ = 0.5, the fit's defaults
    /// ([`ValueFitConfig::default`]), seed 4, the model's first state; `model` is to be
    /// set.
    fn default() -> Self {
        let fit = ValueFitConfig::default();
        ValueSpec {
            model: PathBuf::new(),
            weather: WeatherSpec::default(),
            guide: GuideChoice::default(),
            agent: None,
            trajectories: 1000,
            spread: 0.5,
            state: None,
            epochs: fit.epochs,
            batch_size: fit.batch_size,
            learning_rate: fit.learning_rate,
            seed: 4,
            save_data: false,
        }
    }
}

impl ValueSpec {
    /// The fit's batch where a recorded spec has none.
    fn default_batch_size() -> usize {
        ValueFitConfig::default().batch_size
    }

    /// The fit's learning rate where a recorded spec has none.
    fn default_learning_rate() -> f64 {
        ValueFitConfig::default().learning_rate
    }
}

/// The most guide roll-outs one fit may sample.
const MAX_TRAJECTORIES: usize = 10_000_000;
/// The most training epochs of one fit.
const MAX_EPOCHS: usize = 1_000_000;

/// Runs the value fit `spec` names into `out` (an earlier run's files replaced only with
/// `options.overwrite`); `options.verbose` draws progress bars and prints the figures.
pub fn run_value_job(spec: &ValueSpec, out: &Path, options: &JobOptions) -> Result<(), JobError> {
    let args = spec;
    if !(args.spread >= 0.0 && args.spread < 1.0) {
        return Err(JobError::field("spread", args.spread, "must be in [0, 1)"));
    }
    if !(args.learning_rate.is_finite() && args.learning_rate > 0.0) {
        return Err(JobError::field(
            "learning_rate",
            args.learning_rate,
            "must be a number > 0",
        ));
    }
    // Refused before anything is allocated for them (the samples, the learning curve).
    for (field, value, most) in [
        ("trajectories", args.trajectories, MAX_TRAJECTORIES),
        ("epochs", args.epochs, MAX_EPOCHS),
        ("batch_size", args.batch_size, MAX_TRAJECTORIES),
    ] {
        if value == 0 || value > most {
            return Err(JobError::field(
                field,
                value,
                format!("must be from 1 to {most}"),
            ));
        }
    }
    let model = load_model(&args.model)?;
    let plant = Arc::new(Plant::new(model));
    let state_index = match &args.state {
        None => 0,
        Some(name) => plant
            .model
            .states
            .iter()
            .position(|s| &s.info.name == name)
            .ok_or_else(|| JobError::field("state", name, "no such state in the model"))?,
    };
    let steps = args.weather.steps(&plant.model)?;
    let policy = resolve_guide_policy(
        args.guide,
        &args.model,
        &args.weather,
        args.agent.as_deref(),
        &plant,
        true,
    )?;
    let make_guide = guide_factory(&plant, args.guide, policy)?;
    // A guide that reads the forecast reads it past the season's end too.
    let weather = args
        .weather
        .load(&plant.model, steps, make_guide().forecast_rows())?;
    let folder = RunFolder::claim(out, options.overwrite, Some(json!(spec)))?;
    let job = FitJob {
        spec,
        out,
        verbose: options.verbose,
    };
    folder.finish(fit_and_write(
        &job,
        &plant,
        state_index,
        steps,
        &weather,
        &make_guide,
    ))
}

/// Where a fit's spec is written to, and whether it prints.
struct FitJob<'a> {
    spec: &'a ValueSpec,
    out: &'a Path,
    verbose: bool,
}

/// `println!` where the job is verbose.
macro_rules! say {
    ($verbose:expr, $($arg:tt)*) => {
        if $verbose {
            println!($($arg)*);
        }
    };
}

/// Rolls the guide out, fits the value network and writes the run's files.
fn fit_and_write(
    job: &FitJob,
    plant: &Arc<Plant>,
    state_index: usize,
    steps: usize,
    weather: &crate::sim::weather::Weather,
    make_guide: &GuideFactory,
) -> Result<(), JobError> {
    let (args, out, verbose) = (job.spec, job.out, job.verbose);
    let started = Instant::now();
    let mut guide = make_guide();
    let nominal = nominal_run(plant, weather, steps, guide.as_mut())?;
    let bar = |len, template: &str| progress_bar_if(verbose, len, template);
    let tenth = (args.trajectories / 10).max(1);
    let progress = bar(
        args.trajectories as u64,
        "roll-outs {bar:30} {pos}/{len} [{elapsed_precise}, eta {eta}]",
    );
    let data = sample_returns(
        plant,
        weather,
        steps,
        &nominal,
        &|| make_guide() as Box<dyn crate::control::Controller>,
        &ValueDataConfig {
            trajectories: args.trajectories,
            spread: args.spread,
            seed: args.seed,
            state_index,
        },
        &|done| {
            progress.set_position(done as u64);
            // Without a terminal, a line at each tenth of the roll-outs, as the fit's epochs.
            if verbose && progress.is_hidden() && (done % tenth == 0 || done == args.trajectories) {
                say!(
                    verbose,
                    "roll-outs {done}/{} ({:.0} s)",
                    args.trajectories,
                    started.elapsed().as_secs_f64()
                );
            }
        },
    )?;
    progress.finish_and_clear();
    let rollout_s = started.elapsed().as_secs_f64();
    say!(
        verbose,
        "{} roll-outs ({} dropped: state diverged), {} points in {rollout_s:.1} s on {} threads",
        data.trajectories,
        data.dropped,
        data.returns.len(),
        rayon::current_num_threads()
    );

    // The input box of (x_i, k): the paper's (0.002, 0) … (0.6, 1920) for the lettuce
    // dry weight; in general the data's range with a margin.
    let xs = data.features.iter().step_by(2);
    let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(*v), b.max(*v))
    });
    if !(lo.is_finite() && hi.is_finite()) {
        return Err(JobError::Spec(
            "no roll-out survived; nothing to fit".into(),
        ));
    }
    if args.save_data {
        write_data(
            out,
            &value_state_name(plant, state_index),
            &data.features,
            &data.returns,
        )?;
    }
    let margin = 0.1 * (hi - lo).max(1e-9);
    let lower = [lo - margin, 0.0];
    let upper = [hi + margin, steps as f64];
    let config = ValueFitConfig {
        epochs: args.epochs,
        seed: args.seed,
        batch_size: args.batch_size,
        learning_rate: args.learning_rate,
        ..ValueFitConfig::default()
    };
    let fit_bar = bar(
        args.epochs as u64,
        "fit {bar:30} epoch {pos}/{len} {msg} [{elapsed_precise}, eta {eta}]",
    );
    let fit_started = Instant::now();
    let (function, curve) = fit_value(
        &data.features,
        2,
        &data.returns,
        &lower,
        &upper,
        &config,
        &mut |e: &EpochLoss| {
            if verbose && fit_bar.is_hidden() && e.epoch.is_multiple_of(10) {
                say!(
                    verbose,
                    "epoch {:>4}: train {:.3e}, validation {:.3e} ({:.0} s)",
                    e.epoch,
                    e.train,
                    e.validation,
                    fit_started.elapsed().as_secs_f64()
                );
            }
            fit_bar.set_position(e.epoch as u64);
            fit_bar.set_message(format!(
                "train {:.3e}, validation {:.3e}",
                e.train, e.validation
            ));
        },
    )
    .map_err(JobError::Rl)?;
    fit_bar.finish_and_clear();
    let fit_s = fit_started.elapsed().as_secs_f64();
    let last = curve.last().copied().unwrap_or(EpochLoss {
        epoch: 0,
        train: f64::NAN,
        validation: f64::NAN,
    });
    let value = ValueFile {
        model: plant.model.name.clone(),
        guide: args.guide.name().to_string(),
        state_index,
        state_name: value_state_name(plant, state_index),
        function,
        train_loss: last.train,
        validation_loss: last.validation,
    };
    write_atomically(&out.join("value.json"), |path| value.save(path))?;
    write_curve(out, &curve)?;
    let predicted = value.value(&nominal.states[0], 0);
    say!(
        verbose,
        "fit: {} epochs in {fit_s:.1} s; final MSE train {:.3e}, validation {:.3e}",
        curve.len(),
        last.train,
        last.validation
    );
    say!(
        verbose,
        "value at the season start {predicted:+.4}; the guide earned {:+.4} from there",
        nominal.cumulative_reward
    );
    let summary = json!({
        "command": std::env::args().collect::<Vec<_>>(),
        "model": args.model.display().to_string(),
        "model_sha256": model_hash(plant),
        "weather": args.weather.describe(&plant.model),
        "guide": args.guide.name(),
        "agent": args.agent.as_ref().map(|a| a.display().to_string()),
        "trajectories": data.trajectories,
        "dropped": data.dropped,
        "points": data.returns.len(),
        "spread": args.spread,
        "seed": args.seed,
        "state": value.state_name,
        "input_box": { "lower": lower, "upper": upper },
        "fit": config,
        "train_loss": last.train,
        "validation_loss": last.validation,
        "start_value": predicted,
        "start_return": nominal.cumulative_reward,
        "rollout_s": rollout_s,
        "fit_s": fit_s,
        "threads": rayon::current_num_threads(),
    });
    write_summary(out, &summary)?;
    say!(
        verbose,
        "wrote {0}/value.json, value_curve.csv, value_curve.png, summary.json",
        out.display()
    );
    Ok(())
}

/// The name of the state the value function reads.
fn value_state_name(plant: &Plant, state_index: usize) -> String {
    plant.model.states[state_index].info.name.clone()
}

/// `value_data.csv`: one row a point, the state `state` reads, the step and the return.
fn write_data(dir: &Path, state: &str, features: &[f64], returns: &[f64]) -> Result<(), JobError> {
    write_atomically(&dir.join("value_data.csv"), |path| {
        let mut out = csv_writer(std::fs::File::create(path)?);
        out.write_record([state, "step", "return"])?;
        for (point, r) in features.chunks_exact(2).zip(returns) {
            out.write_record([point[0].to_string(), point[1].to_string(), r.to_string()])?;
        }
        out.flush().map_err(csv::Error::from)
    })
}

fn write_curve(dir: &Path, curve: &[EpochLoss]) -> Result<(), JobError> {
    let records = curve.iter().map(|e| {
        [
            e.epoch.to_string(),
            e.train.to_string(),
            e.validation.to_string(),
        ]
    });
    write_atomically(&dir.join("value_curve.csv"), |path| {
        std::fs::write(
            path,
            csv_text(["epoch", "train_mse", "validation_mse"], records)?,
        )
    })?;
    let x: Vec<f64> = curve.iter().map(|e| e.epoch as f64).collect();
    let log10 = |v: f64| if v > 0.0 { v.log10() } else { f64::NAN };
    let lines = [
        Line {
            label: "train".into(),
            values: curve.iter().map(|e| log10(e.train)).collect(),
        },
        Line {
            label: "validation".into(),
            values: curve.iter().map(|e| log10(e.validation)).collect(),
        },
    ];
    write_atomically(&dir.join("value_curve.png"), |path| {
        draw_xy("value network fit", "epoch", "log10 MSE", &x, &lines, path)
    })
}
