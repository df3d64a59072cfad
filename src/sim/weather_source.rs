//! Where a season's weather comes from — a CSV file, a KNMI station file or ghm's built-in
//! season — and the slice of it a season of a given model reads.
//!
//! The command line's weather options and the Python package both resolve to a
//! [`WeatherSource`]; [`season_weather`] is the one place that turns it into the
//! [`Weather`] a season runs on.

use crate::lang::Model;
use crate::sim::weather::{builtin_season, load_csv, load_knmi, Weather, WeatherError};
use std::path::PathBuf;

/// A source of weather rows at the model's sample period.
#[derive(Debug, Clone, PartialEq)]
pub enum WeatherSource {
    /// A CSV file with a header of named columns.
    Csv(PathBuf),
    /// A KNMI hourly station file, converted and interpolated to the model's period, with
    /// the outdoor CO₂ (which KNMI does not record) assumed constant.
    Knmi {
        /// The station file.
        path: PathBuf,
        /// Outdoor CO₂, in ppm.
        co2_ppm: f64,
    },
    /// ghm's built-in Dutch late-winter season from the generator seeded with `seed`.
    Builtin {
        /// The generator's seed.
        seed: u64,
    },
}

/// Why a season's weather could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    /// The file could not be read or lacks what the model needs.
    #[error(transparent)]
    Weather(#[from] WeatherError),
    /// The source's rows are not at the model's sample period.
    #[error(
        "the weather source has a period of {source_s} s but the model steps every {model_s} s"
    )]
    Period {
        /// The source's period, in seconds.
        source_s: f64,
        /// The model's sample period, in seconds.
        model_s: f64,
    },
}

/// `rows` weather rows for `model` from `source`, starting at row `start_row`, in the
/// model's disturbance order. A model whose disturbances all have constant values needs no
/// file: with the built-in source it gets those constants.
pub fn season_weather(
    model: &Model,
    source: &WeatherSource,
    start_row: usize,
    rows: usize,
) -> Result<Weather, SourceError> {
    let wanted = model.weather_columns();
    let frame = match source {
        WeatherSource::Csv(path) => load_csv(path, &wanted, model.sample_period)?,
        WeatherSource::Knmi { path, co2_ppm } => load_knmi(path, model.sample_period, *co2_ppm)?,
        WeatherSource::Builtin { seed } => {
            if model.disturbances.iter().all(|d| d.value.is_some()) {
                let names = model
                    .disturbances
                    .iter()
                    .map(|d| d.info.name.clone())
                    .collect();
                let values: Vec<f64> = model.disturbances.iter().filter_map(|d| d.value).collect();
                return Ok(Weather::constant(names, &values, rows, model.sample_period));
            }
            builtin_season(start_row.saturating_add(rows), model.sample_period, *seed)
        }
    };
    if (frame.period_s - model.sample_period).abs() > 1e-9 {
        return Err(SourceError::Period {
            source_s: frame.period_s,
            model_s: model.sample_period,
        });
    }
    Ok(frame.select(&wanted, start_row, rows)?)
}
