//! The weather a season runs on and its length: what every season command's weather flags
//! say (`cli` maps them onto it), a study's `[weather]` table, and what is recorded in
//! a training's `summary.json` so that `ghm train --resume` continues on the same season.

use crate::job::JobError;
use crate::lang::Model;
use crate::sim::season::MAX_SEASON_STEPS;
use crate::sim::weather::Weather;
use crate::sim::weather_source::{season_weather, SourceError, WeatherSource};
use std::path::PathBuf;

/// A season's length when neither `days` nor `steps` is given.
pub const DEFAULT_DAYS: f64 = 40.0;

/// The weather source and the season's slice of it (first row, length).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WeatherSpec {
    /// Weather CSV with a header of named columns (e.g.
    /// `$GHM_DATA/venlo2014_30min_model_units.csv`). Without `weather` or `knmi`,
    /// ghm's built-in Dutch late-winter season is used.
    pub weather: Option<PathBuf>,
    /// First data row of the weather file used as step 0 (Venlo: 1394 = 2014-02-08 01:00).
    pub start_row: usize,
    /// KNMI hourly station file (uurgegevens), converted and interpolated to the model's
    /// period.
    pub knmi: Option<PathBuf>,
    /// Outdoor CO₂ assumed with KNMI data (which has none), in ppm.
    pub knmi_co2: f64,
    /// Seed of the built-in weather generator.
    pub weather_seed: u64,
    /// Season length in days (at most 10 000 000 steps); neither this nor `steps`:
    /// 40 days.
    pub days: Option<f64>,
    /// Season length in steps (at most 10 000 000).
    pub steps: Option<usize>,
}

impl Default for WeatherSpec {
    /// ghm's built-in season, 40 days.
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

    /// Whether the season runs on ghm's built-in weather (no `weather`, no `knmi`).
    pub fn is_builtin(&self) -> bool {
        self.weather.is_none() && self.knmi.is_none()
    }

    /// Number of steps of the season, at least 1 and at most [`MAX_SEASON_STEPS`]; checked
    /// before anything is allocated for it.
    pub fn steps(&self, model: &Model) -> Result<usize, JobError> {
        if self.weather.is_some() && self.knmi.is_some() {
            return Err(JobError::unset(
                "knmi",
                "give either a weather CSV or a KNMI file, not both",
            ));
        }
        let per_day = 86400.0 / model.sample_period;
        let (steps, field, value) = match (self.steps, self.days) {
            (Some(_), Some(_)) => {
                return Err(JobError::unset(
                    "steps",
                    "give the season's length in days or in steps, not both",
                ))
            }
            (Some(n), None) => (n as f64, "steps", n.to_string()),
            (None, Some(d)) => ((d * per_day).round(), "days", d.to_string()),
            (None, None) => (
                (DEFAULT_DAYS * per_day).round(),
                "days",
                format!("{DEFAULT_DAYS} (the default)"),
            ),
        };
        if !(steps >= 1.0 && steps.is_finite()) {
            return Err(JobError::field(
                field,
                value,
                "the season must have at least one step",
            ));
        }
        if steps > MAX_SEASON_STEPS as f64 {
            return Err(JobError::field(
                field,
                value,
                format!(
                    "{steps:.3e} steps of {} s; a season has at most {MAX_SEASON_STEPS} steps",
                    model.sample_period
                ),
            ));
        }
        if self.start_row > MAX_SEASON_STEPS {
            return Err(JobError::field(
                "start_row",
                self.start_row,
                format!("the first row must be at most {MAX_SEASON_STEPS}"),
            ));
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
