//! The weather a season runs on and its length: the options every season command shares
//! (flattened into their arguments), a study's `[weather]` table, and what is recorded in
//! a training's `summary.json` so that `ghm train --resume` continues on the same season.

use crate::job::JobError;
use crate::lang::Model;
use crate::sim::season::MAX_SEASON_STEPS;
use crate::sim::weather::Weather;
use crate::sim::weather_source::{season_weather, SourceError, WeatherSource};
use clap::Args;
use std::path::PathBuf;

/// The weather source and the season's slice of it (first row, length).
#[derive(Debug, Clone, PartialEq, Args, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WeatherSpec {
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

impl Default for WeatherSpec {
    /// ghm's built-in season, 40 days (the flags' defaults).
    fn default() -> Self {
        WeatherSpec {
            weather: None,
            start_row: 0,
            knmi: None,
            knmi_co2: 420.0,
            weather_seed: 2014,
            days: None,
            steps: None,
        }
    }
}

impl WeatherSpec {
    /// Whether no weather or season-length option was given (every one at its default).
    pub fn is_default(&self) -> bool {
        *self == WeatherSpec::default()
    }

    /// Whether the season runs on ghm's built-in weather (no `--weather`, no `--knmi`).
    pub fn is_builtin(&self) -> bool {
        self.weather.is_none() && self.knmi.is_none()
    }

    /// Number of steps of the season, at least 1 and at most [`MAX_SEASON_STEPS`]; checked
    /// before anything is allocated for it.
    pub fn steps(&self, model: &Model) -> Result<usize, JobError> {
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
            return Err(JobError::Spec(
                "the season must have at least one step (check --days / --steps)".into(),
            ));
        }
        if steps > MAX_SEASON_STEPS as f64 {
            return Err(JobError::Spec(format!(
                "{given} of {} s; a season has at most {MAX_SEASON_STEPS} steps",
                model.sample_period
            )));
        }
        if self.start_row > MAX_SEASON_STEPS {
            return Err(JobError::Spec(format!(
                "--start-row {}: the first row must be at most {MAX_SEASON_STEPS}",
                self.start_row
            )));
        }
        Ok(steps as usize)
    }

    /// The weather for `steps` steps plus `extra` steps of forecast.
    pub fn load(&self, model: &Model, steps: usize, extra: usize) -> Result<Weather, JobError> {
        let rows = steps.checked_add(extra).ok_or_else(|| {
            JobError::Spec(format!("{steps} steps and {extra} more are too many rows"))
        })?;
        season_weather(model, &self.source(), self.start_row, rows).map_err(|e| match e {
            SourceError::Weather(e) => JobError::Weather(e),
            period @ SourceError::Period { .. } => JobError::Spec(period.to_string()),
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
