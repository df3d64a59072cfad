//! `ghm optimum`: the whole-season perfect-foresight optimum, the upper bound for every
//! controller on the deterministic season.

use crate::cli::mpc::{make_solver, parse_horizon, SolverChoice};
use crate::cli::simulate::{run_season_and_report, SeasonArgs};
use crate::cli::weather_args::{UncertaintyArgs, WeatherArgs};
use crate::cli::{load_model, CliError};
use crate::control::{InputTable, Mpc};
use crate::model::Plant;
use crate::sim::optimum::season_optimum;
use crate::sim::season::{run_season, SeasonConfig, StepLog};
use crate::solve::{Ipm, IpmOptions, Solver, Sqp, SqpOptions};
use clap::Args;
use serde_json::json;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

#[derive(Debug, Args)]
pub struct OptimumArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Horizon of the closed-loop MPC run that initialises the optimum.
    #[arg(long, value_name = "H", default_value = "1h")]
    pub init_horizon: String,
    /// NLP back-end for the season NLP (default: ipopt where built with it; otherwise the
    /// pure-Rust interior point, which factorises the 1920 stages by a Riccati recursion).
    #[arg(long, value_enum)]
    pub solver: Option<SolverChoice>,
    /// Iteration limit of the season NLP.
    #[arg(long, value_name = "N", default_value_t = 500)]
    pub max_iterations: usize,
    #[command(flatten)]
    pub weather: WeatherArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/optimum")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &OptimumArgs) -> Result<(), CliError> {
    crate::cli::run_folder::check(&args.out, args.overwrite)?;
    let model = load_model(&args.file)?;
    let plant = Arc::new(Plant::new(model));
    let horizon = parse_horizon(&args.init_horizon, plant.model.sample_period)?;
    let steps = args.weather.steps(&plant.model)?;
    let weather = args.weather.load(&plant.model, steps, horizon)?;

    println!(
        "initialising from a closed loop of MPC over {}",
        args.init_horizon
    );
    let mut mpc = Mpc::new(plant.clone(), horizon, Box::new(Sqp::default()))
        .map_err(|e| CliError::Argument(e.to_string()))?;
    let mut inputs = Vec::with_capacity(steps * plant.layout.nu);
    let mut collect = |log: &StepLog| inputs.extend_from_slice(&log.input);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let initial = run_season(&plant, &weather, &mut mpc, &config, &mut collect)?;
    println!(
        "  closed loop: cumulative reward {:+.4} {}",
        initial.metrics.cumulative_reward,
        plant.model.objective_unit()
    );

    println!("solving the season as one NLP ({steps} stages)");
    let choice = args.solver.unwrap_or(if cfg!(feature = "ipopt") {
        SolverChoice::Ipopt
    } else {
        SolverChoice::Ipm
    });
    let mut solver: Box<dyn Solver> = match choice {
        SolverChoice::Ipm => Box::new(Ipm::new(IpmOptions {
            max_iterations: args.max_iterations,
            trace: true,
            ..IpmOptions::default()
        })),
        SolverChoice::Sqp => Box::new(Sqp::new(SqpOptions {
            max_iterations: args.max_iterations,
            trace: true,
            ..SqpOptions::default()
        })),
        other => make_solver(other)?,
    };
    let clock = Instant::now();
    let optimum = season_optimum(plant.clone(), &weather, steps, &inputs, solver.as_mut())
        .map_err(|e| CliError::Argument(e.to_string()))?;
    let seconds = clock.elapsed().as_secs_f64();
    let s = &optimum.solution;
    println!(
        "  {} after {} iterations in {seconds:.1} s (KKT residual {:.1e})",
        s.status,
        s.stats.iterations,
        s.stats.kkt.max()
    );
    if !s.status.is_success() {
        eprintln!(
            "warning: the season NLP did not converge ({}); the figures below are those of the best point found",
            s.status
        );
    }
    let mut table = InputTable(optimum.inputs.clone());
    let season = SeasonArgs {
        file: &args.file,
        weather: &args.weather,
        uncertainty: &UncertaintyArgs::NOMINAL,
        out: &args.out,
        overwrite: args.overwrite,
        enforce_limits: true,
        forecast: 0,
    };
    run_season_and_report(
        &season,
        &plant,
        &mut table,
        json!({
            "optimum": {
                "solver": solver.name(),
                "status": s.status,
                "iterations": s.stats.iterations,
                "time_s": seconds,
                "kkt": s.stats.kkt,
                "initial_horizon_steps": horizon,
                "initial_cumulative_reward": initial.metrics.cumulative_reward,
            }
        }),
    )?;
    Ok(())
}
