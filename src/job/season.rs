//! A season job: a [`RunSpec`] run into its run folder. The controller is built from the
//! spec, the season streams `trajectory.csv`, then `summary.json` (the figures, the spec's
//! settings) and `trajectory.png` are written and the folder is marked complete.

use crate::control::TerminalCostForm;
use crate::control::{
    Controller, Expert, Guidance, InputTable, Mpc, Policy, RlGuidance, RlMpcOptions, Rules,
};
use crate::job::build::{
    bands_name, guide_factory, input_table, load_model, make_mpc, parse_horizon, parse_inputs,
    ControllerFiles,
};
use crate::job::folder::{self, RunFolder};
use crate::job::output::{figure, model_hash, plot_trajectory, write_summary, TrajectoryWriter};
use crate::job::spec::{
    ControllerSpec, CostForm, MpcSpec, OptimumSpec, PlantSpec, RlmpcSpec, RunSpec, SolverChoice,
    SolverSpec, Variant,
};
use crate::job::JobError;
use crate::job::{optimum_checkpoint, resume};
use crate::model::Plant;
use crate::sim::metrics::Metrics;
use crate::sim::optimum::{resume_season_optimum, season_optimum};
use crate::sim::season::{resume_season, run_season, SeasonConfig, StepLog, StepsTaken};
use crate::sim::weather::Weather;
use serde_json::json;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// How a job runs, beside what it runs.
#[derive(Debug, Clone, Copy)]
pub struct JobOptions {
    /// Replace an earlier run's files in the folder (otherwise a folder holding them is
    /// refused; see [`RunFolder::claim`]).
    pub overwrite: bool,
    /// Print the season's figures to stdout and draw its per-step progress bar (the
    /// commands); a study keeps jobs quiet and shows its own progress.
    pub verbose: bool,
}

/// What a finished season job reports.
#[derive(Debug, Clone)]
pub struct SeasonOutcome {
    /// The season's figures (also in `summary.json`).
    pub metrics: Metrics,
    /// The controller's name in tables.
    pub label: String,
    /// The unit of the objective and the rewards (e.g. `€/m²`).
    pub unit: String,
}

/// The controller of a spec, ready to run, with what `summary.json` says about it.
struct Built {
    plant: Arc<Plant>,
    controller: Box<dyn Controller>,
    label: String,
    extra: serde_json::Value,
    /// Weather rows needed beyond the season (a controller's horizon).
    forecast: usize,
    enforce_limits: bool,
}

/// A season ready to run: the plant, the controller, its weather and the loop's settings.
struct Prepared {
    built: Built,
    plant_spec: PlantSpec,
    weather: Weather,
    config: SeasonConfig,
}

/// A controller from outside the job layer (`ghm replay`'s, which asks a `ghm serve`),
/// to run a season of a spec with in place of the one the spec names; the spec's
/// controller is what it stands for, recorded in `run.json`.
pub struct ExternalController {
    /// The controller.
    pub controller: Box<dyn Controller>,
    /// Weather rows it reads ahead (its horizon; 0 without one).
    pub forecast_rows: usize,
    /// Its name in tables.
    pub label: String,
    /// Fields added to `summary.json`.
    pub extra: serde_json::Value,
}

/// Loads the model and builds everything `spec` names (its controller, unless `external`
/// stands in for it); `out`, if given, is the folder the season will be written to (refused
/// first where the controller is long to build).
fn prepare(
    spec: &RunSpec,
    out: Option<&Path>,
    options: &JobOptions,
    external: Option<ExternalController>,
) -> Result<Prepared, JobError> {
    let model = load_model(&spec.model)?;
    let plant = Arc::new(Plant::new(model));
    let plant_spec = match spec.controller {
        ControllerSpec::Optimum(_) => PlantSpec::NOMINAL,
        _ => spec.plant.clone(),
    };
    let uncertainty = plant_spec.draw()?;
    let steps = spec.weather.steps(&plant.model)?;
    let built = match external {
        Some(e) => Built {
            plant: plant.clone(),
            controller: e.controller,
            label: e.label,
            extra: e.extra,
            forecast: e.forecast_rows,
            enforce_limits: true,
        },
        None => {
            let files = ControllerFiles::load(spec, &plant, options.verbose)?;
            build(spec, &plant, &plant_spec, steps, out, options, files)?
        }
    };
    let weather = spec.weather.load(&plant.model, steps, built.forecast)?;
    let config = SeasonConfig {
        steps,
        enforce_limits: built.enforce_limits,
        uncertainty,
    };
    Ok(Prepared {
        built,
        plant_spec,
        weather,
        config,
    })
}

/// Runs `spec` into the run folder `out`: the controller built, the season streamed into
/// `trajectory.csv`, then `summary.json` and `trajectory.png` written and the folder marked
/// complete.
pub fn run_season_job(
    spec: &RunSpec,
    out: &Path,
    options: &JobOptions,
) -> Result<SeasonOutcome, JobError> {
    run_prepared(spec, out, options, prepare(spec, Some(out), options, None)?)
}

/// [`run_season_job`], continuing the run of the same spec that was killed in `out` if
/// there is one (`ghm mpc --resume`, and a study run again): the steps it took are read
/// back from its temporary trajectory and replayed through the plant (each state checked
/// bit for bit), and the controller decides from the first step not taken, cold (MPC's
/// first solve has no last plan to start from). Without such a run, a fresh one. See
/// [`crate::job::resume`].
pub fn resume_season_job(
    spec: &RunSpec,
    out: &Path,
    options: &JobOptions,
) -> Result<SeasonOutcome, JobError> {
    let stopped = resume::stopped_trajectory(out, &json!(spec))?;
    let prepared = prepare(spec, Some(out), options, None)?;
    let Some(path) = stopped else {
        return run_prepared(spec, out, options, prepared);
    };
    let taken = resume::read_steps_taken(&path, &prepared.built.plant)?;
    if options.verbose {
        println!("resuming {} after {} steps", out.display(), taken.len());
    }
    let run = RunFolder::continue_in(out)?;
    season_into(spec, out, options, prepared, run, &taken)
}

/// [`run_season_job`] with `external` deciding the inputs in place of the controller the
/// spec names: the same season, files and folder.
pub fn run_external_season_job(
    spec: &RunSpec,
    external: ExternalController,
    out: &Path,
    options: &JobOptions,
) -> Result<SeasonOutcome, JobError> {
    run_prepared(
        spec,
        out,
        options,
        prepare(spec, Some(out), options, Some(external))?,
    )
}

/// A prepared season into its claimed folder.
fn run_prepared(
    spec: &RunSpec,
    out: &Path,
    options: &JobOptions,
    prepared: Prepared,
) -> Result<SeasonOutcome, JobError> {
    let run = RunFolder::claim(out, options.overwrite, Some(json!(spec)))?;
    season_into(spec, out, options, prepared, run, &StepsTaken::default())
}

/// A prepared season into the folder `run` holds, after the steps `taken` of a stopped
/// run; once it is complete, the temporary trajectories stopped runs left there go.
fn season_into(
    spec: &RunSpec,
    out: &Path,
    options: &JobOptions,
    prepared: Prepared,
    run: RunFolder,
    taken: &StepsTaken,
) -> Result<SeasonOutcome, JobError> {
    let label = prepared.built.label.clone();
    let unit = prepared.built.plant.model.objective_unit();
    let season = season_files(spec, out, prepared, options, taken)
        .and_then(|m| resume::remove_stopped_trajectories(out).map(|()| m));
    let metrics = run.finish(season)?;
    Ok(SeasonOutcome {
        metrics,
        label,
        unit,
    })
}

/// A season run in memory ([`run_season_logs`]).
pub struct SeasonLogs {
    /// The plant (the model the spec names).
    pub plant: Arc<Plant>,
    /// Every step's log: the rows of `trajectory.csv`.
    pub logs: Vec<StepLog>,
    /// The season's figures.
    pub metrics: Metrics,
}

/// A season of `spec` run in memory, without a folder: the plant, every step's log and
/// the figures (the library's and the Python package's way to the same season as the
/// commands').
pub fn run_season_logs(spec: &RunSpec) -> Result<SeasonLogs, JobError> {
    let quiet = JobOptions {
        overwrite: false,
        verbose: false,
    };
    let mut prepared = prepare(spec, None, &quiet, None)?;
    let plant = prepared.built.plant.clone();
    let mut logs = Vec::with_capacity(prepared.config.steps);
    let mut collect = |log: &StepLog| logs.push(log.clone());
    let result = run_season(
        &plant,
        &prepared.weather,
        prepared.built.controller.as_mut(),
        &prepared.config,
        &mut collect,
    )?;
    Ok(SeasonLogs {
        plant,
        logs,
        metrics: result.metrics,
    })
}

/// A controller built from a spec, to be driven step by step ([`build_controller`]).
pub struct StandaloneController {
    /// The plant (the model the spec names).
    pub plant: Arc<Plant>,
    /// The controller.
    pub controller: Box<dyn Controller>,
    /// Rows of weather forecast it reads ahead (its horizon; 0 without one).
    pub forecast_rows: usize,
}

/// The controller `spec` names, to be driven step by step. The optimum is a season, not a
/// controller, and is refused.
pub fn build_controller(spec: &RunSpec) -> Result<StandaloneController, JobError> {
    let model = load_model(&spec.model)?;
    let plant = Arc::new(Plant::new(model));
    let files = ControllerFiles::load(spec, &plant, false)?;
    build_controller_with(spec, plant, files)
}

/// [`build_controller`] for a plant and controller files already loaded (a compiled
/// controller's, which carries them inside): `spec.model` and the files it names are not
/// read.
pub fn build_controller_with(
    spec: &RunSpec,
    plant: Arc<Plant>,
    files: ControllerFiles,
) -> Result<StandaloneController, JobError> {
    if !spec.controller.kind().is_feedback() {
        return Err(JobError::Spec(format!(
            "a controller of kind `{}` decides a whole season before it starts; run it as a \
             season",
            spec.controller.kind()
        )));
    }
    let quiet = JobOptions {
        overwrite: false,
        verbose: false,
    };
    let built = build(spec, &plant, &spec.plant, 0, None, &quiet, files)?;
    Ok(StandaloneController {
        plant,
        controller: built.controller,
        forecast_rows: built.forecast,
    })
}

/// The controller `spec` names, for a season of `steps` steps.
fn build(
    spec: &RunSpec,
    plant: &Arc<Plant>,
    plant_spec: &PlantSpec,
    steps: usize,
    out: Option<&Path>,
    options: &JobOptions,
    files: ControllerFiles,
) -> Result<Built, JobError> {
    let fail = |e: crate::control::ControlError| JobError::Spec(e.to_string());
    let mut built = Built {
        plant: plant.clone(),
        controller: Box::new(crate::control::ConstantInput(Vec::new())),
        label: String::new(),
        extra: json!({}),
        forecast: 0,
        enforce_limits: true,
    };
    match &spec.controller {
        ControllerSpec::Inputs(inputs) => {
            built.controller = parse_inputs(inputs.inputs.as_deref(), plant)?;
            built.enforce_limits = inputs.enforce_limits;
        }
        ControllerSpec::Expert => {
            built.controller = Box::new(Expert::new(plant.clone()).map_err(fail)?);
            built.extra = json!({ "agent": "expert" });
        }
        ControllerSpec::Rules => {
            built.controller = Box::new(Rules::new(plant.clone()).map_err(fail)?);
        }
        ControllerSpec::Policy { agent } => {
            let file = files
                .policy
                .ok_or_else(|| JobError::Spec("a policy controller needs its policy".into()))?;
            built.extra = json!({
                "agent": agent.as_ref().map_or("shipped".into(), |a| a.display().to_string()),
                "agent_episode": file.episode,
            });
            let policy = Policy::new(plant, file).map_err(fail)?;
            // Counted as a horizon counts the rows it reads, the current one included; a
            // policy that sees the current weather only needs none past a season's end.
            built.forecast = match policy.forecast_rows() {
                0 => 0,
                rows => rows + 1,
            };
            built.controller = Box::new(policy);
        }
        ControllerSpec::Mpc(mpc) => {
            let (controller, horizon, extra) = build_mpc(mpc, plant, plant_spec)?;
            built.controller = Box::new(controller);
            built.forecast = horizon;
            built.extra = extra;
        }
        ControllerSpec::Rlmpc(rlmpc) => {
            let (controller, forecast, extra) = build_rlmpc(rlmpc, plant, plant_spec, files)?;
            built.controller = Box::new(controller);
            built.label = rlmpc.label();
            built.forecast = forecast;
            built.extra = extra;
        }
        ControllerSpec::Optimum(optimum) => {
            // Long to compute: a folder that would be refused is refused first.
            if let Some(out) = out {
                folder::check(out, options.overwrite)?;
            }
            let (table, extra) = solve_optimum(spec, optimum, plant, (steps, out), options)?;
            built.controller = Box::new(table);
            built.extra = extra;
        }
    }
    if built.label.is_empty() {
        built.label = built.controller.name();
    }
    Ok(built)
}

/// MPC with its horizon in steps and its summary fields.
fn build_mpc(
    spec: &MpcSpec,
    plant: &Arc<Plant>,
    plant_spec: &PlantSpec,
) -> Result<(Mpc, usize, serde_json::Value), JobError> {
    let horizon = parse_horizon("horizon", &spec.horizon, plant.model.sample_period)?;
    let bands = spec.bands.resolve(plant_spec, &plant.model);
    let mpc = make_mpc(plant, horizon, spec, bands)?;
    let extra = json!({
        "horizon_steps": horizon,
        "horizon_h": horizon as f64 * plant.model.sample_period / 3600.0,
        "bands": bands_name(bands),
        "warm_start": mpc.warm_start,
    });
    Ok((mpc, horizon, extra))
}

/// RL-guided MPC with the forecast rows it reads (its horizon in steps and the guide's own
/// past it) and its summary fields.
fn build_rlmpc(
    rlmpc: &RlmpcSpec,
    plant: &Arc<Plant>,
    plant_spec: &PlantSpec,
    files: ControllerFiles,
) -> Result<(Mpc, usize, serde_json::Value), JobError> {
    let make_guide = guide_factory(plant, rlmpc.guide, files.policy)?;
    let value = match rlmpc.terminal_cost {
        CostForm::None => None,
        CostForm::Exact | CostForm::Taylor => Some(files.value.ok_or_else(|| {
            JobError::Spec("RL-guided MPC with a terminal cost needs a value network".into())
        })?),
    };
    if let Some(v) = &value {
        if v.guide != rlmpc.guide.name() {
            eprintln!(
                "warning: the value network learned the {} guide's returns; the guide is {}",
                v.guide,
                rlmpc.guide.name()
            );
        }
    }
    let options = RlMpcOptions {
        epsilon: (rlmpc.variant == Variant::Rlmpc).then_some(rlmpc.epsilon),
        terminal_cost: match rlmpc.terminal_cost {
            CostForm::Taylor => TerminalCostForm::Taylor,
            CostForm::Exact | CostForm::None => TerminalCostForm::Exact,
        },
    };
    let guidance = RlGuidance::new(
        plant.clone(),
        make_guide(),
        rlmpc.guide.name(),
        value,
        options,
    )
    .map_err(|e| JobError::Spec(e.to_string()))?;
    let (mpc, horizon, mut extra) = build_mpc(&rlmpc.mpc, plant, plant_spec)?;
    // The guide's roll-out over the horizon reads its own forecast rows past it.
    let forecast_rows = horizon + guidance.forecast_rows();
    if let Some(map) = extra.as_object_mut() {
        map.extend([
            ("guide".into(), json!(rlmpc.guide.name())),
            ("variant".into(), json!(rlmpc.variant)),
            ("epsilon".into(), json!(rlmpc.epsilon)),
            ("terminal_cost".into(), json!(rlmpc.terminal_cost)),
        ]);
    }
    Ok((mpc.with_guidance(Box::new(guidance)), forecast_rows, extra))
}

/// The season optimum's inputs, from a closed loop of MPC (or the spec's inputs) refined as
/// one NLP over `steps` steps. With a run folder `out`, the solve writes its checkpoints
/// there and goes on from one a stopped run of the same spec left ([`optimum_checkpoint`]).
fn solve_optimum(
    spec: &RunSpec,
    optimum: &OptimumSpec,
    plant: &Arc<Plant>,
    (steps, out): (usize, Option<&Path>),
    options: &JobOptions,
) -> Result<(InputTable, serde_json::Value), JobError> {
    let say = |line: String| {
        if options.verbose {
            println!("{line}");
        }
    };
    let horizon = parse_horizon(
        "init_horizon",
        &optimum.init_horizon,
        plant.model.sample_period,
    )?;
    let weather = spec.weather.load(&plant.model, steps, horizon)?;
    let identity = (json!(spec), model_hash(plant));
    let resumed = match out {
        Some(out) if options.overwrite => optimum_checkpoint::remove(out).map(|()| None)?,
        Some(out) => optimum_checkpoint::read(out, &identity.0, &identity.1)?,
        None => None,
    };
    let earlier = resumed.as_ref().map_or(0, |c| c.iteration);
    let mut solver = optimum.solver_spec(options.verbose).build()?;
    if let Some(out) = out {
        let sink = optimum_checkpoint::sink(out, identity, earlier);
        solver.set_checkpoints(Some(sink));
    }
    let clock = Instant::now();
    if let Some(checkpoint) = &resumed {
        say(format!(
            "going on with the season NLP ({steps} stages) from its checkpoint after {} iterations",
            checkpoint.iteration
        ));
    }
    let (result, initial_reward) = match &resumed {
        Some(checkpoint) => (
            resume_season_optimum(plant.clone(), &weather, steps, checkpoint, solver.as_mut()),
            None,
        ),
        None => {
            let (inputs, initial_reward) =
                optimum_start(optimum, plant, &weather, (horizon, steps), &say)?;
            say(format!("solving the season as one NLP ({steps} stages)"));
            (
                season_optimum(plant.clone(), &weather, steps, &inputs, solver.as_mut()),
                initial_reward,
            )
        }
    };
    let result = result.map_err(|e| JobError::Spec(e.to_string()))?;
    let seconds = clock.elapsed().as_secs_f64();
    let s = &result.solution;
    say(format!(
        "  {} after {} iterations in {seconds:.1} s (KKT residual {:.1e})",
        s.status,
        earlier + s.stats.iterations,
        s.stats.kkt.max()
    ));
    if !s.status.is_success() {
        eprintln!(
            "warning: the season NLP did not converge ({}); the figures below are those of the best point found",
            s.status
        );
    }
    if let Some(out) = out {
        optimum_checkpoint::remove(out)?;
    }
    let extra = json!({
        "optimum": {
            "solver": solver.name(),
            "status": s.status,
            "iterations": earlier + s.stats.iterations,
            "resumed_after_iterations": resumed.as_ref().map(|c| c.iteration),
            "time_s": seconds,
            "kkt": s.stats.kkt,
            "initial_horizon_steps": horizon,
            "initial_cumulative_reward": initial_reward,
            "initial_inputs": optimum.init_inputs,
        }
    });
    Ok((InputTable(result.inputs.clone()), extra))
}

/// The inputs the season optimum starts from, and the cumulative reward of the closed loop
/// that made them (none for the spec's own inputs).
fn optimum_start(
    optimum: &OptimumSpec,
    plant: &Arc<Plant>,
    weather: &Weather,
    (horizon, steps): (usize, usize),
    say: &impl Fn(String),
) -> Result<(Vec<f64>, Option<f64>), JobError> {
    Ok(match &optimum.init_inputs {
        Some(path) => {
            say(format!(
                "initialising from the inputs in {}",
                path.display()
            ));
            (given_inputs(path, plant, steps)?, None)
        }
        None => {
            say(format!(
                "initialising from a closed loop of MPC over {}",
                optimum.init_horizon
            ));
            let (inputs, reward) = closed_loop_inputs(plant, weather, horizon, steps)?;
            say(format!(
                "  closed loop: cumulative reward {reward:+.4} {}",
                plant.model.objective_unit()
            ));
            (inputs, Some(reward))
        }
    })
}

/// The inputs of a closed loop of MPC at `horizon` steps (SQP) over the season, and its
/// cumulative reward: the season optimum's default start.
fn closed_loop_inputs(
    plant: &Arc<Plant>,
    weather: &Weather,
    horizon: usize,
    steps: usize,
) -> Result<(Vec<f64>, f64), JobError> {
    let initialiser = SolverSpec::new(SolverChoice::Sqp).build()?;
    let mut mpc =
        Mpc::new(plant.clone(), horizon, initialiser).map_err(|e| JobError::Spec(e.to_string()))?;
    let mut inputs = Vec::with_capacity(steps * plant.layout.nu);
    let mut collect = |log: &StepLog| inputs.extend_from_slice(&log.input);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let initial = run_season(plant, weather, &mut mpc, &config, &mut collect)?;
    Ok((inputs, initial.metrics.cumulative_reward))
}

/// The first `steps` rows of the inputs in `path`, row after row: the season optimum's
/// start when the spec names one.
fn given_inputs(path: &Path, plant: &Plant, steps: usize) -> Result<Vec<f64>, JobError> {
    let table = input_table(path, plant)?;
    if table.0.len() < steps {
        return Err(JobError::field(
            "init_inputs",
            path.display(),
            format!(
                "has {} rows of inputs; the season has {steps} steps",
                table.0.len()
            ),
        ));
    }
    Ok(table.0[..steps].concat())
}

/// The season of [`run_season_job`] in its claimed folder.
fn season_files(
    spec: &RunSpec,
    out: &Path,
    prepared: Prepared,
    options: &JobOptions,
    taken: &StepsTaken,
) -> Result<Metrics, JobError> {
    let Prepared {
        mut built,
        plant_spec,
        weather,
        config,
    } = prepared;
    let plant = built.plant.clone();
    let mut writer = TrajectoryWriter::create(out, &plant, config.steps, options.verbose)?;
    let result = resume_season(
        &plant,
        &weather,
        built.controller.as_mut(),
        &config,
        taken,
        &mut writer,
    );
    writer.finish(result.is_ok())?;
    let result = result?;
    let m = &result.metrics;
    let name = built.controller.name();
    if options.verbose {
        println!(
            "{} steps ({:.1} days) of {} on {}",
            m.steps,
            m.steps as f64 * plant.model.sample_period / 86400.0,
            name,
            spec.weather.describe(&plant.model)
        );
        print_metrics(m, &plant.model.objective_unit());
    }
    let no_solve = no_solve_succeeded(m, &writer.logs, out);
    let mut summary = json!({
        "command": std::env::args().collect::<Vec<_>>(),
        "model": spec.model.display().to_string(),
        "model_sha256": model_hash(&plant),
        "weather": spec.weather.describe(&plant.model),
        "controller": name,
        "label": built.label,
        "unit": plant.model.objective_unit(),
        "uncertainty": plant_spec.uncertainty,
        "seed": plant_spec.seed,
        "metrics": m,
        "warnings": no_solve.iter().collect::<Vec<_>>(),
    });
    if let (Some(map), serde_json::Value::Object(more)) =
        (summary.as_object_mut(), std::mem::take(&mut built.extra))
    {
        map.extend(more);
    }
    write_summary(out, &summary)?;
    plot_trajectory(
        out,
        &plant,
        &writer.logs,
        &format!("{} — {}", plant.model.name, name),
    )?;
    if options.verbose {
        println!(
            "wrote {}/trajectory.csv, summary.json, trajectory.png",
            out.display()
        );
    }
    match no_solve {
        Some(message) => Err(JobError::NoSolveSucceeded(message)),
        None => Ok(result.metrics),
    }
}

/// A season in which every step's solve failed is not a season of the controller but of
/// its fallback: the files are written (to see why), and the run fails with this message.
fn no_solve_succeeded(m: &Metrics, logs: &[StepLog], out: &Path) -> Option<String> {
    if m.steps == 0 || m.solve.failed_solves < m.steps {
        return None;
    }
    let first = logs.first().map(|l| &l.record);
    Some(format!(
        "every one of the {} solves failed (the first with status `{}`); the inputs were the \
         fallback's (`{}`), not the controller's, so these figures do not measure it. The \
         status column of {}/trajectory.csv says how each solve ended",
        m.steps,
        first.map_or("", |r| r.status_name()),
        first.and_then(|r| r.fallback_name()).unwrap_or("none"),
        out.display()
    ))
}

/// Prints the season figures.
pub fn print_metrics(m: &Metrics, unit: &str) {
    println!("  EPI               {} {unit}", figure(m.epi, true));
    println!(
        "  penalties         {} {unit}",
        figure(m.total_penalty, false)
    );
    for b in &m.bands {
        println!(
            "    {:<14} {} {unit}, {:.1} h outside",
            b.output,
            figure(b.penalty, false),
            b.hours_outside
        );
    }
    println!(
        "  cumulative reward {} {unit}",
        figure(m.cumulative_reward, true)
    );
    let s = &m.solve;
    if s.max_ms > 0.0 {
        println!(
            "  solve time        median {:.3} ms, p95 {:.3} ms, max {:.3} ms; {:.2} iterations per step",
            s.median_ms, s.p95_ms, s.max_ms, s.mean_iterations
        );
        println!(
            "  failed solves     {} ({} steps took a fallback)",
            s.failed_solves, s.fallbacks
        );
    }
}
