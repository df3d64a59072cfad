//! `ghm simulate`: a season with fixed inputs or inputs from a CSV file.

use crate::cli::output::{figure, model_hash, plot_trajectory, write_summary, TrajectoryWriter};
use crate::cli::run_folder::RunFolder;
use crate::cli::weather_args::{UncertaintyArgs, WeatherArgs};
use crate::cli::{load_model, CliError};
use crate::control::{ConstantInput, Controller, InputTable};
use crate::model::Plant;
use crate::sim::season::{run_season, SeasonConfig};
use clap::Args;
use serde_json::json;
use std::path::{Path, PathBuf};

#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// Inputs: `const:u1,u2,...` for the same input every step, or a CSV file with one row per
    /// step and one column per input (named as the model's inputs). Default: the start input.
    #[arg(long, value_name = "const:U,.. | FILE.csv")]
    pub inputs: Option<String>,
    /// Apply the inputs as given, without clipping to bounds and rate limits.
    #[arg(long)]
    pub no_rate_limit: bool,
    #[command(flatten)]
    pub plant: UncertaintyArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/simulate")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

fn parse_inputs(spec: Option<&str>, plant: &Plant) -> Result<Box<dyn Controller>, CliError> {
    let nu = plant.layout.nu;
    let Some(spec) = spec else {
        return Ok(Box::new(ConstantInput(plant.model.start_input())));
    };
    if let Some(list) = spec.strip_prefix("const:") {
        let values: Result<Vec<f64>, _> =
            list.split(',').map(|s| s.trim().parse::<f64>()).collect();
        let values = values.map_err(|_| {
            CliError::Argument(format!(
                "--inputs const:{list}: expected {nu} comma-separated numbers"
            ))
        })?;
        if values.len() != nu {
            return Err(CliError::Argument(format!(
                "--inputs const: gives {} values; the model has {nu} inputs ({})",
                values.len(),
                plant
                    .model
                    .inputs
                    .iter()
                    .map(|u| u.info.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        if let Some((u, v)) = plant
            .model
            .inputs
            .iter()
            .zip(&values)
            .find(|(_, v)| !v.is_finite())
        {
            return Err(CliError::Argument(format!(
                "--inputs const:{list}: the value of {} is {v}; every input must be a finite number",
                u.info.name
            )));
        }
        return Ok(Box::new(ConstantInput(values)));
    }
    let path = Path::new(spec);
    let names: Vec<String> = plant
        .model
        .inputs
        .iter()
        .map(|u| u.info.name.clone())
        .collect();
    let frame = crate::sim::weather::load_csv(path, &names, plant.model.sample_period)?;
    let rows = frame.rows();
    let w = frame.select(&names, 0, rows)?;
    Ok(Box::new(InputTable(
        (0..rows).map(|k| w.at(k).to_vec()).collect(),
    )))
}

pub fn run(args: &SimulateArgs) -> Result<(), CliError> {
    let model = load_model(&args.file)?;
    let plant = Plant::new(model);
    let mut controller = parse_inputs(args.inputs.as_deref(), &plant)?;
    let season = SeasonArgs {
        file: &args.file,
        weather: &args.weather,
        uncertainty: &args.plant,
        out: &args.out,
        overwrite: args.overwrite,
        enforce_limits: !args.no_rate_limit,
        forecast: 0,
    };
    run_season_and_report(&season, &plant, controller.as_mut(), json!({}))?;
    Ok(())
}

/// What every season command shares.
pub(crate) struct SeasonArgs<'a> {
    pub file: &'a Path,
    pub weather: &'a WeatherArgs,
    pub uncertainty: &'a UncertaintyArgs,
    pub out: &'a Path,
    /// Replace an earlier run's files in `out` (see [`RunFolder::claim`]).
    pub overwrite: bool,
    pub enforce_limits: bool,
    /// Steps of weather needed beyond the season (a controller's horizon).
    pub forecast: usize,
}

/// Runs a season of `controller`, streaming `trajectory.csv`, then writes `summary.json`
/// (with `extra` merged in) and `trajectory.png` and prints the figures.
pub(crate) fn run_season_and_report(
    args: &SeasonArgs,
    plant: &Plant,
    controller: &mut dyn Controller,
    extra: serde_json::Value,
) -> Result<crate::sim::metrics::Metrics, CliError> {
    let uncertainty = args.uncertainty.draw()?;
    let steps = args.weather.steps(&plant.model)?;
    let weather = args.weather.load(&plant.model, steps, args.forecast)?;
    let config = SeasonConfig {
        steps,
        enforce_limits: args.enforce_limits,
        uncertainty,
    };
    let folder = RunFolder::claim(args.out, args.overwrite)?;
    folder.finish(season_files(
        args, plant, controller, extra, &weather, &config,
    ))
}

/// The season of [`run_season_and_report`] in its claimed folder.
fn season_files(
    args: &SeasonArgs,
    plant: &Plant,
    controller: &mut dyn Controller,
    extra: serde_json::Value,
    weather: &crate::sim::weather::Weather,
    config: &SeasonConfig,
) -> Result<crate::sim::metrics::Metrics, CliError> {
    let steps = config.steps;
    let mut writer = TrajectoryWriter::create(args.out, plant, steps)?;
    let result = run_season(plant, weather, controller, config, &mut writer);
    writer.finish(result.is_ok())?;
    let result = result?;
    let m = &result.metrics;
    println!(
        "{} steps ({:.1} days) of {} on {}",
        m.steps,
        m.steps as f64 * plant.model.sample_period / 86400.0,
        controller.name(),
        args.weather.describe(&plant.model)
    );
    print_metrics(m, &plant.model.objective_unit());
    let no_solve = no_solve_succeeded(m, &writer.logs, args.out);
    let mut summary = json!({
        "command": std::env::args().collect::<Vec<_>>(),
        "model": args.file.display().to_string(),
        "model_sha256": model_hash(plant),
        "weather": args.weather.describe(&plant.model),
        "controller": controller.name(),
        "uncertainty": args.uncertainty.uncertainty,
        "seed": args.uncertainty.seed,
        "metrics": m,
        "warnings": no_solve.iter().collect::<Vec<_>>(),
    });
    if let (Some(map), serde_json::Value::Object(more)) = (summary.as_object_mut(), extra) {
        map.extend(more);
    }
    write_summary(args.out, &summary)?;
    plot_trajectory(
        args.out,
        plant,
        &writer.logs,
        &format!("{} — {}", plant.model.name, controller.name()),
    )?;
    println!(
        "wrote {}/trajectory.csv, summary.json, trajectory.png",
        args.out.display()
    );
    match no_solve {
        Some(message) => Err(CliError::NoSolveSucceeded(message)),
        None => Ok(result.metrics),
    }
}

/// A season in which every step's solve failed is not a season of the controller but of
/// its fallback: the files are written (to see why), and the run fails with this message.
fn no_solve_succeeded(
    m: &crate::sim::metrics::Metrics,
    logs: &[crate::sim::season::StepLog],
    out: &Path,
) -> Option<String> {
    if m.steps == 0 || m.solve.failed_solves < m.steps {
        return None;
    }
    let first = logs.first().map(|l| &l.record);
    Some(format!(
        "every one of the {} solves failed (the first with status `{}`); the inputs were the \
         fallback's (`{}`), not the controller's, so these figures do not measure it. The \
         status column of {}/trajectory.csv says how each solve ended",
        m.steps,
        first.map_or("", |r| r.status.as_str()),
        first.and_then(|r| r.fallback.as_deref()).unwrap_or("none"),
        out.display()
    ))
}

/// Prints the season figures.
pub fn print_metrics(m: &crate::sim::metrics::Metrics, unit: &str) {
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
