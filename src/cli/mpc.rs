//! `ghm mpc`: a season of economic MPC.

use crate::cli::simulate::{run_season_and_report, SeasonArgs};
use crate::cli::weather_args::{UncertaintyArgs, WeatherArgs};
use crate::cli::{load_model, CliError};
use crate::control::Mpc;
use crate::model::Plant;
use crate::nlp::Bands;
use crate::solve::{Ipm, Solver, Sqp};
use clap::{Args, ValueEnum};
use serde_json::json;
use std::path::PathBuf;
use std::sync::Arc;

/// The NLP back-ends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SolverChoice {
    /// Pure-Rust interior point, stage by stage (Riccati recursion), exact Hessian.
    Ipm,
    /// Pure-Rust SQP with clarabel sub-problems.
    Sqp,
    /// The system's IPOPT (needs a build with `--features ipopt`).
    Ipopt,
}

/// Which bounds of the soft bands MPC plans with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BandsChoice {
    /// The model file's `plan` bounds when the plant is uncertain (`--uncertainty` > 0),
    /// the scoring bounds when it is the model (default).
    Auto,
    /// Always the `plan` bounds (a back-off even on the nominal plant).
    Planning,
    /// Always the bounds the season is scored with.
    Scoring,
}

impl BandsChoice {
    /// The bands for a season on a plant with this uncertainty.
    pub fn resolve(self, plant: &UncertaintyArgs) -> Bands {
        match self {
            BandsChoice::Planning => Bands::Planning,
            BandsChoice::Scoring => Bands::Scoring,
            BandsChoice::Auto if plant.uncertainty > 0.0 => Bands::Planning,
            BandsChoice::Auto => Bands::Scoring,
        }
    }
}

/// MPC of `plant` over `horizon` steps with the chosen back-end and bands.
pub fn make_mpc(
    plant: &Arc<Plant>,
    horizon: usize,
    solver: SolverChoice,
    bands: Bands,
) -> Result<Mpc, CliError> {
    let fail = |e: crate::nlp::OcpError| CliError::Argument(e.to_string());
    Mpc::new(plant.clone(), horizon, make_solver(solver)?)
        .map_err(fail)?
        .with_bands(bands)
        .map_err(fail)
}

/// The bands' name in `summary.json`.
pub fn bands_name(bands: Bands) -> &'static str {
    match bands {
        Bands::Planning => "planning",
        Bands::Scoring => "scoring",
    }
}

#[derive(Debug, Args)]
pub struct MpcArgs {
    /// The model file (.ghm).
    pub file: PathBuf,
    /// Prediction horizon: `3h`, `90min`, or a number of steps (at most 100 000).
    #[arg(long, value_name = "H", default_value = "3h")]
    pub horizon: String,
    /// NLP back-end.
    #[arg(long, value_enum, default_value_t = SolverChoice::Ipm)]
    pub solver: SolverChoice,
    /// Soft-band bounds to plan with: `auto` plans with the model file's `plan` bounds on
    /// an uncertain plant and with the scoring bounds on the nominal one.
    #[arg(long, value_enum, default_value_t = BandsChoice::Auto)]
    pub bands: BandsChoice,
    #[command(flatten)]
    pub weather: WeatherArgs,
    #[command(flatten)]
    pub plant: UncertaintyArgs,
    /// Run folder for trajectory.csv, summary.json and trajectory.png.
    #[arg(long, value_name = "DIR", default_value = "runs/mpc")]
    pub out: PathBuf,
    /// Replace the files of an earlier run in the --out folder (otherwise refused).
    #[arg(long)]
    pub overwrite: bool,
}

/// Steps of a horizon given as `3h`, `90min`, `5400s` or a plain number of steps.
pub fn parse_horizon(text: &str, sample_period_s: f64) -> Result<usize, CliError> {
    let t = text.trim();
    let seconds = if let Some(h) = t.strip_suffix('h') {
        h.trim().parse::<f64>().ok().map(|v| v * 3600.0)
    } else if let Some(m) = t.strip_suffix("min") {
        m.trim().parse::<f64>().ok().map(|v| v * 60.0)
    } else if let Some(s) = t.strip_suffix('s') {
        s.trim().parse::<f64>().ok()
    } else {
        t.parse::<usize>().ok().map(|n| n as f64 * sample_period_s)
    };
    let bad = || {
        CliError::Argument(format!(
            "--horizon {text}: expected a duration such as 3h or 90min, or a number of steps, \
             of at least one sample period ({sample_period_s} s)"
        ))
    };
    let seconds = seconds
        .filter(|s| s.is_finite() && *s > 0.0)
        .ok_or_else(bad)?;
    let steps = (seconds / sample_period_s).round();
    if steps < 1.0 || (steps * sample_period_s - seconds).abs() > 1e-6 * seconds {
        return Err(bad());
    }
    if steps > MAX_HORIZON_STEPS as f64 {
        return Err(CliError::Argument(format!(
            "--horizon {text} is {steps:.3e} steps of {sample_period_s} s; a horizon has at most \
             {MAX_HORIZON_STEPS} steps"
        )));
    }
    Ok(steps as usize)
}

/// The longest prediction horizon, in steps: each step of it is a stage of the NLP, with
/// its own variables, constraints and derivative buffers, so a larger one is refused before
/// anything is allocated.
pub const MAX_HORIZON_STEPS: usize = 100_000;

/// The chosen back-end, or a message saying how to get it.
pub fn make_solver(choice: SolverChoice) -> Result<Box<dyn Solver>, CliError> {
    match choice {
        SolverChoice::Ipm => Ok(Box::new(Ipm::default())),
        SolverChoice::Sqp => Ok(Box::new(Sqp::default())),
        #[cfg(feature = "ipopt")]
        SolverChoice::Ipopt => Ok(Box::new(crate::solve::Ipopt::new(
            crate::solve::IpoptOptions::default(),
        ))),
        #[cfg(not(feature = "ipopt"))]
        SolverChoice::Ipopt => Err(CliError::Argument(
            "--solver ipopt needs a build with the IPOPT back-end: install IPOPT \
             (Debian: coinor-libipopt-dev) and build with `cargo build --release --features ipopt`"
                .into(),
        )),
    }
}

pub fn run(args: &MpcArgs) -> Result<(), CliError> {
    let model = load_model(&args.file)?;
    let plant = Arc::new(Plant::new(model));
    let horizon = parse_horizon(&args.horizon, plant.model.sample_period)?;
    let bands = args.bands.resolve(&args.plant);
    let mut mpc = make_mpc(&plant, horizon, args.solver, bands)?;
    let season = SeasonArgs {
        file: &args.file,
        weather: &args.weather,
        uncertainty: &args.plant,
        out: &args.out,
        overwrite: args.overwrite,
        enforce_limits: true,
        forecast: horizon,
    };
    run_season_and_report(
        &season,
        &plant,
        &mut mpc,
        json!({
            "horizon_steps": horizon,
            "horizon_h": horizon as f64 * plant.model.sample_period / 3600.0,
            "bands": bands_name(bands),
        }),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::parse_horizon;

    #[test]
    fn horizons_parse_in_hours_minutes_seconds_and_steps() {
        assert_eq!(parse_horizon("3h", 1800.0).unwrap(), 6);
        assert_eq!(parse_horizon("90min", 1800.0).unwrap(), 3);
        assert_eq!(parse_horizon("1800s", 1800.0).unwrap(), 1);
        assert_eq!(parse_horizon("4", 1800.0).unwrap(), 4);
        assert_eq!(parse_horizon("0.5h", 1800.0).unwrap(), 1);
        for bad in ["0h", "45min", "-1h", "abc", "", "1.5"] {
            assert!(parse_horizon(bad, 1800.0).is_err(), "{bad}");
        }
    }
}
