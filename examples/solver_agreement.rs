//! Two NLP back-ends on the very same MPC problems: which one finds the better plan, step
//! by step, with no closed-loop fork in the way.
//!
//! Comparing two back-ends by their seasons' cumulative reward mixes two things: how well
//! each solves its problems, and where the closed loop goes afterwards. From the first step
//! at which they apply different inputs (a failed solve, or two local optima) the plants
//! are in different states, and the seasons' rewards differ by chance as much as by the
//! solvers (on the paper variant at 6 h, ghm's interior point, its SQP and IPOPT end
//! within 5e-4 of each other, each closed loop on its own branch).
//!
//! This example removes the fork: a *driver* back-end runs the season, and at every step a
//! *shadow* back-end solves the same problem, from the same state, forecast and previous
//! input, warm-started from its own previous solution. It prints, over the steps that both
//! solved, the shadow's objective minus the driver's (the objective is minimised: a
//! positive difference is a worse plan), and the steps where only one of them solved.
//!
//! Run (release; reads the Venlo weather beside the checkout):
//!
//! ```sh
//! cargo run --release --example solver_agreement -- models/lettuce.ghm \
//!     $GHM_DATA/venlo2014_30min_model_units.csv 1394 40 6h sqp ipm
//! ```
//!
//! Arguments: model, weather CSV, start row, days, horizon, driver, shadow (`ipm`, `sqp`,
//! or `ipopt` in a build with `--features ipopt`).

use ghm::control::{ControlError, Controller, Decision, Mpc, Observation};
use ghm::job::build::{make_mpc, parse_horizon};
use ghm::job::{MpcSpec, SolverChoice, WeatherSpec};
use ghm::model::Plant;
use ghm::nlp::Bands;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use std::path::PathBuf;
use std::sync::Arc;

/// One step's outcome for the two back-ends.
struct Compared {
    /// Both solved at this step: the shadow's objective minus the driver's.
    difference: Option<f64>,
    driver_solved: bool,
    shadow_solved: bool,
}

/// Decides with `driver`, and solves the same problem with `shadow` beside it.
struct Referee {
    driver: Mpc,
    shadow: Mpc,
    steps: Vec<Compared>,
}

/// The objective of the solve made at this step, if it succeeded without a fallback.
fn solved_objective(mpc: &Mpc, decision: &Decision) -> Option<f64> {
    let solved = decision.record.fallback.is_none()
        && decision.record.status.is_some_and(|s| s.is_success());
    solved
        .then(|| mpc.last_solution().map(|s| s.stats.objective))
        .flatten()
}

impl Controller for Referee {
    fn name(&self) -> String {
        format!("{} (shadow: {})", self.driver.name(), self.shadow.name())
    }

    fn decide(&mut self, observation: &Observation) -> Result<Decision, ControlError> {
        let shadow = self.shadow.decide(observation)?;
        let shadow_objective = solved_objective(&self.shadow, &shadow);
        let decision = self.driver.decide(observation)?;
        let driver_objective = solved_objective(&self.driver, &decision);
        self.steps.push(Compared {
            difference: shadow_objective.zip(driver_objective).map(|(s, d)| s - d),
            driver_solved: driver_objective.is_some(),
            shadow_solved: shadow_objective.is_some(),
        });
        Ok(decision)
    }
}

/// The back-end named as on `ghm mpc --solver` (`ipopt` needs a build with `--features ipopt`).
fn solver(name: &str) -> Result<SolverChoice, String> {
    SolverChoice::from_name(name)
        .ok_or_else(|| format!("unknown back-end {name:?}: expected ipm, sqp or ipopt"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [model, weather, start_row, days, horizon, driver, shadow] = args.as_slice() else {
        return Err(
            "usage: solver_agreement MODEL WEATHER.csv START_ROW DAYS HORIZON \
                    DRIVER SHADOW   (back-ends: ipm, sqp, ipopt)"
                .into(),
        );
    };
    let model = ghm::job::build::load_model(&PathBuf::from(model))?;
    let plant = Arc::new(Plant::new(model));
    let horizon = parse_horizon("horizon", horizon, plant.model.sample_period)?;
    let season = WeatherSpec {
        weather: Some(PathBuf::from(weather)),
        start_row: start_row.parse()?,
        days: Some(days.parse()?),
        ..WeatherSpec::default()
    };
    let steps = season.steps(&plant.model)?;
    let weather = season.load(&plant.model, steps, horizon)?;
    let mpc = |name: &str| -> Result<Mpc, Box<dyn std::error::Error>> {
        let spec = MpcSpec {
            solver: solver(name)?,
            ..MpcSpec::default()
        };
        Ok(make_mpc(&plant, horizon, &spec, Bands::Scoring)?)
    };
    let mut referee = Referee {
        driver: mpc(driver)?,
        shadow: mpc(shadow)?,
        steps: Vec::with_capacity(steps),
    };
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut ignore = |_: &StepLog| {};
    let result = run_season(&plant, &weather, &mut referee, &config, &mut ignore)?;

    let both: Vec<f64> = referee.steps.iter().filter_map(|c| c.difference).collect();
    let count = |pred: &dyn Fn(f64) -> bool| both.iter().filter(|d| pred(**d)).count();
    let mut sorted = both.clone();
    sorted.sort_by(f64::total_cmp);
    let worst = sorted.last().copied().unwrap_or(f64::NAN);
    let best = sorted.first().copied().unwrap_or(f64::NAN);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(f64::NAN);
    println!(
        "{} steps driven by {driver} (cumulative reward {:+.6}); {shadow} solved the same problems",
        referee.steps.len(),
        result.metrics.cumulative_reward
    );
    println!("both solved: {} steps", both.len());
    println!(
        "  {shadow} − {driver} objective: worst {worst:+.3e}, median {median:+.3e}, best {best:+.3e}, sum {:+.3e}",
        both.iter().sum::<f64>()
    );
    for tol in [1e-8, 1e-6, 1e-4] {
        println!(
            "  {shadow} worse by more than {tol:.0e}: {} steps; better by more than {tol:.0e}: {} steps",
            count(&|d| d > tol),
            count(&|d| d < -tol)
        );
    }
    let only = |a: fn(&Compared) -> bool, b: fn(&Compared) -> bool| {
        referee.steps.iter().filter(|c| a(c) && !b(c)).count()
    };
    println!(
        "only {driver} solved: {} steps; only {shadow} solved: {} steps; neither: {} steps",
        only(|c| c.driver_solved, |c| c.shadow_solved),
        only(|c| c.shadow_solved, |c| c.driver_solved),
        referee
            .steps
            .iter()
            .filter(|c| !c.driver_solved && !c.shadow_solved)
            .count()
    );
    Ok(())
}
