//! Weather, season-length and plant-uncertainty options shared by every command that runs
//! a season.

use crate::cli::CliError;
use crate::lang::Model;
use crate::sim::season::{UncertaintyDraw, MAX_SEASON_STEPS};
use crate::sim::weather::Weather;
use crate::sim::weather_source::{season_weather, SourceError, WeatherSource};
use clap::Args;
use std::path::PathBuf;

/// Recorded in a training's `summary.json`, so that `ghm train --resume` continues on the
/// same season.
#[derive(Debug, Clone, PartialEq, Args, serde::Serialize, serde::Deserialize)]
pub struct WeatherArgs {
    /// Weather CSV with a header of named columns (e.g. ../shared/data/venlo2014_30min_model_units.csv).
    /// Without --weather or --knmi, ghm's built-in Dutch late-winter season is used.
    #[arg(long, value_name = "CSV", conflicts_with = "knmi")]
    pub weather: Option<PathBuf>,
    /// First data row of the weather file used as step 0 (Venlo: 1394 = 2014-02-08 01:00).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub start_row: usize,
    /// KNMI hourly station file (uurgegevens), converted and interpolated to the model's period.
    #[arg(long, value_name = "FILE")]
    pub knmi: Option<PathBuf>,
    /// Outdoor CO₂ assumed with KNMI data (which has none), in ppm.
    #[arg(long, value_name = "PPM", default_value_t = 420.0)]
    pub knmi_co2: f64,
    /// Seed of the built-in weather generator.
    #[arg(long, value_name = "S", default_value_t = 2014)]
    pub weather_seed: u64,
    /// Season length in days (at most 10 000 000 steps).
    #[arg(long, value_name = "D", conflicts_with = "steps")]
    pub days: Option<f64>,
    /// Season length in steps (default: 40 days; at most 10 000 000).
    #[arg(long, value_name = "N")]
    pub steps: Option<usize>,
}

impl WeatherArgs {
    /// Whether no weather or season-length option was given (every one at its default).
    pub fn is_default(&self) -> bool {
        self.weather.is_none()
            && self.start_row == 0
            && self.knmi.is_none()
            && self.knmi_co2 == 420.0
            && self.weather_seed == 2014
            && self.days.is_none()
            && self.steps.is_none()
    }

    /// Whether the season runs on ghm's built-in weather (no `--weather`, no `--knmi`).
    pub fn is_builtin(&self) -> bool {
        self.weather.is_none() && self.knmi.is_none()
    }

    /// Number of steps of the season, at least 1 and at most [`MAX_SEASON_STEPS`]; checked
    /// before anything is allocated for it.
    pub fn steps(&self, model: &Model) -> Result<usize, CliError> {
        let per_day = 86400.0 / model.sample_period;
        let (steps, given) = match (self.steps, self.days) {
            (Some(n), _) => (n as f64, format!("--steps {n} is {n} steps")),
            (None, Some(d)) => (
                (d * per_day).round(),
                format!("--days {d:e} makes {:.3e} steps", (d * per_day).round()),
            ),
            (None, None) => (
                (40.0 * per_day).round(),
                "40 days make too many steps".into(),
            ),
        };
        if !(steps >= 1.0 && steps.is_finite()) {
            return Err(CliError::Argument(
                "the season must have at least one step (check --days / --steps)".into(),
            ));
        }
        if steps > MAX_SEASON_STEPS as f64 {
            return Err(CliError::Argument(format!(
                "{given} of {} s; a season has at most {MAX_SEASON_STEPS} steps",
                model.sample_period
            )));
        }
        if self.start_row > MAX_SEASON_STEPS {
            return Err(CliError::Argument(format!(
                "--start-row {}: the first row must be at most {MAX_SEASON_STEPS}",
                self.start_row
            )));
        }
        Ok(steps as usize)
    }

    /// The weather for `steps` steps plus `extra` steps of forecast.
    pub fn load(&self, model: &Model, steps: usize, extra: usize) -> Result<Weather, CliError> {
        let rows = steps.checked_add(extra).ok_or_else(|| {
            CliError::Argument(format!("{steps} steps and {extra} more are too many rows"))
        })?;
        season_weather(model, &self.source(), self.start_row, rows).map_err(|e| match e {
            SourceError::Weather(e) => CliError::Weather(e),
            period @ SourceError::Period { .. } => CliError::Argument(period.to_string()),
        })
    }

    /// The weather source these options name.
    pub fn source(&self) -> WeatherSource {
        match (&self.weather, &self.knmi) {
            (Some(path), _) => WeatherSource::Csv(path.clone()),
            (None, Some(path)) => WeatherSource::Knmi {
                path: path.clone(),
                co2_ppm: self.knmi_co2,
            },
            (None, None) => WeatherSource::Builtin {
                seed: self.weather_seed,
            },
        }
    }

    /// A one-line description of the weather source for summaries.
    pub fn describe(&self, model: &Model) -> String {
        if model.disturbances.iter().all(|d| d.value.is_some())
            && self.weather.is_none()
            && self.knmi.is_none()
        {
            return "no weather (the model's disturbances are constant)".into();
        }
        match (&self.weather, &self.knmi) {
            (Some(p), _) => format!("csv {} from row {}", p.display(), self.start_row),
            (None, Some(p)) => format!("knmi {} from row {}", p.display(), self.start_row),
            (None, None) => format!("built-in season, seed {}", self.weather_seed),
        }
    }
}

/// The plant's parametric uncertainty. Controllers keep predicting with the nominal model.
#[derive(Debug, Clone, Args)]
pub struct UncertaintyArgs {
    /// Parametric uncertainty δ of the plant (relative half-width; the model file says which
    /// parameters and how often they are redrawn). 0 = the nominal, deterministic plant;
    /// controllers predict with the nominal model either way.
    #[arg(long, value_name = "DELTA", default_value_t = 0.0)]
    pub uncertainty: f64,
    /// Seed of the parameter draws.
    #[arg(long, value_name = "S", default_value_t = 4)]
    pub seed: u64,
}

impl UncertaintyArgs {
    /// The nominal, deterministic plant.
    pub const NOMINAL: UncertaintyArgs = UncertaintyArgs {
        uncertainty: 0.0,
        seed: 0,
    };

    /// The parameter draws, `None` for the nominal plant.
    pub fn draw(&self) -> Result<Option<UncertaintyDraw>, CliError> {
        if !(self.uncertainty >= 0.0 && self.uncertainty < 1.0) {
            return Err(CliError::Argument("--uncertainty must be in [0, 1)".into()));
        }
        Ok((self.uncertainty > 0.0).then_some(UncertaintyDraw {
            delta: self.uncertainty,
            seed: self.seed,
        }))
    }
}
