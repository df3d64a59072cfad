//! A warmer copy of a recorded season: every outdoor temperature (each disturbance in °C)
//! raised by the same number of degrees, and the humidities named kept at the relative
//! humidity they had, as air that warms by a season holds more water.
//!
//! A guide distilled on roll-outs warmed by a drawn amount meets summer-like weather while
//! learning from spring's rows only (`docs/results.md`, "Generalisation"): the days, the
//! sun and the weather's course stay those recorded.
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use ghm::sim::weather::{saturation_vapour_pressure, Warming};
//!
//! let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
//! let model = ghm::lang::load(&file).map_err(|e| e.render())?;
//! let weather = ghm::sim::weather::builtin_season(48, model.sample_period, 2014)
//!     .select(&model.weather_columns(), 0, 48)?;
//! let warming: Warming = "4..8".parse()?;
//! let warming = warming.keeping_humidity(["hum_out"]);
//! warming.check(&model)?;
//! let warmer = warming.apply(&weather, &model, 6.0)?;
//! let (t, t6) = (weather.at(10)[2], warmer.at(10)[2]); // temp_out
//! assert_eq!(t6, t + 6.0);
//! // The vapour density rose with the saturation pressure (and the air's expansion).
//! let kept = saturation_vapour_pressure(t6) / saturation_vapour_pressure(t) * (t + 273.15) / (t6 + 273.15);
//! assert!((warmer.at(10)[3] / weather.at(10)[3] - kept).abs() < 1e-12);
//! assert_eq!(warmer.at(10)[0], weather.at(10)[0]); // the sun as it was
//! # Ok(())
//! # }
//! ```

use super::{saturation_vapour_pressure, Weather, WeatherError};
use crate::lang::model::Model;
use serde::{Deserialize, Serialize};

/// How much warmer a season may be made, and which humidities go with it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Warming {
    /// The least and the most degrees added (a roll-out draws uniformly between them).
    pub degrees: [f64; 2],
    /// Disturbances (vapour densities in kg m⁻³ or vapour pressures in Pa) kept at their
    /// relative humidity at the model's first temperature disturbance.
    #[serde(default)]
    pub keep_humidity: Vec<String>,
}

impl std::str::FromStr for Warming {
    type Err = String;

    /// `LO..HI`, degrees (`0..8`), no humidities kept.
    fn from_str(text: &str) -> Result<Self, String> {
        let (lo, hi) = parse_range(text, "LO..HI in degrees (e.g. 0..8)", "a number of degrees")?;
        Ok(Warming {
            degrees: [lo, hi],
            keep_humidity: Vec::new(),
        })
    }
}

/// The two ends of `A..B` in `text`, each parsed as a `T`; the errors say the form
/// expected (`form`, e.g. `FIRST..LAST (e.g. 0..5000)`) and what an end is (`what`).
pub fn parse_range<T: std::str::FromStr>(
    text: &str,
    form: &str,
    what: &str,
) -> Result<(T, T), String>
where
    T::Err: std::fmt::Display,
{
    let (first, last) = text
        .split_once("..")
        .ok_or_else(|| format!("`{text}` is not {form}"))?;
    let end = |s: &str| {
        s.trim()
            .parse::<T>()
            .map_err(|e| format!("`{s}` in `{text}` is not {what}: {e}"))
    };
    Ok((end(first)?, end(last)?))
}

impl Warming {
    /// The unit of the disturbances a warming raises.
    pub const TEMPERATURE_UNIT: &str = "°C";
    /// The largest warming, in degrees either way.
    pub const MAX_DEGREES: f64 = 30.0;

    /// The same warming, keeping the named humidities at their relative humidity.
    pub fn keeping_humidity<S: Into<String>>(self, names: impl IntoIterator<Item = S>) -> Self {
        Warming {
            keep_humidity: names.into_iter().map(Into::into).collect(),
            ..self
        }
    }

    /// Refuses a warming `model` cannot take, saying why: a range that is empty, not
    /// finite or beyond [`Self::MAX_DEGREES`], a model without a temperature (°C), a humidity
    /// it does not have or whose unit is not a vapour density's (kg m^-3) or pressure's (Pa).
    pub fn check(&self, model: &Model) -> Result<(), String> {
        let [lo, hi] = self.degrees;
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(format!(
                "{lo}..{hi} must be two numbers, the first not above the second"
            ));
        }
        if lo.abs().max(hi.abs()) > Self::MAX_DEGREES {
            return Err(format!(
                "{lo}..{hi} goes beyond ±{} degrees",
                Self::MAX_DEGREES
            ));
        }
        if temperatures(model).next().is_none() {
            return Err(format!(
                "the model has no disturbance in {} to warm",
                Self::TEMPERATURE_UNIT
            ));
        }
        for name in &self.keep_humidity {
            let Some(d) = model.disturbances.iter().find(|d| d.info.name == *name) else {
                let names: Vec<&str> = model
                    .disturbances
                    .iter()
                    .map(|d| d.info.name.as_str())
                    .collect();
                return Err(format!(
                    "the model has no disturbance `{name}` (it has {})",
                    names.join(", ")
                ));
            };
            if humidity_unit(&d.info.unit).is_none() {
                return Err(format!(
                    "`{name}` is in [{}]; a humidity kept at its relative humidity is in [{}]",
                    d.info.unit,
                    HUMIDITIES.map(|(unit, _)| unit).join("] or [")
                ));
            }
        }
        Ok(())
    }

    /// `weather` (in `model`'s disturbance order) warmed by `degrees`: each temperature
    /// raised by them, each kept humidity scaled at every row as its relative humidity at
    /// the first temperature requires. The warming is assumed [checked](Self::check).
    pub fn apply(
        &self,
        weather: &Weather,
        model: &Model,
        degrees: f64,
    ) -> Result<Weather, WeatherError> {
        let warmed: Vec<usize> = temperatures(model).collect();
        let humidities: Vec<(usize, HumidityUnit)> = model
            .disturbances
            .iter()
            .enumerate()
            .filter(|(_, d)| self.keep_humidity.contains(&d.info.name))
            .filter_map(|(i, d)| humidity_unit(&d.info.unit).map(|unit| (i, unit)))
            .collect();
        let mut data = weather.data.clone();
        if let Some(&reference) = warmed.first() {
            for row in data.chunks_exact_mut(weather.width) {
                let t = row[reference];
                let pressure_ratio =
                    saturation_vapour_pressure(t + degrees) / saturation_vapour_pressure(t);
                for &(i, unit) in &humidities {
                    row[i] *= match unit {
                        HumidityUnit::VapourPressure => pressure_ratio,
                        // ρ = p M / (R T): the same pressure in warmer air is less dense.
                        HumidityUnit::VapourDensity => {
                            pressure_ratio * (t + 273.15) / (t + degrees + 273.15)
                        }
                    };
                }
                for &i in &warmed {
                    row[i] += degrees;
                }
            }
        }
        Weather::new(
            format!("{}, {degrees:+.2} °C", weather.source),
            weather.period_s,
            weather.names.clone(),
            data,
        )
    }
}

/// How a kept humidity is measured.
#[derive(Debug, Clone, Copy)]
enum HumidityUnit {
    VapourDensity,
    VapourPressure,
}

/// The units a humidity kept at its relative humidity may have, and what each measures.
const HUMIDITIES: [(&str, HumidityUnit); 2] = [
    ("kg m^-3", HumidityUnit::VapourDensity),
    ("Pa", HumidityUnit::VapourPressure),
];

fn humidity_unit(unit: &str) -> Option<HumidityUnit> {
    let unit = unit.split_whitespace().collect::<Vec<_>>().join(" ");
    HUMIDITIES
        .iter()
        .find(|(name, _)| *name == unit)
        .map(|&(_, measure)| measure)
}

/// The model's temperature disturbances (unit °C), in its order.
fn temperatures(model: &Model) -> impl Iterator<Item = usize> + '_ {
    model
        .disturbances
        .iter()
        .enumerate()
        .filter(|(_, d)| d.info.unit.trim() == Warming::TEMPERATURE_UNIT && !d.clock)
        .map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lettuce() -> Model {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
        crate::lang::load(&file).unwrap()
    }

    #[test]
    fn a_range_is_read_and_checked_against_the_model() {
        let model = lettuce();
        assert_eq!("-2..8".parse::<Warming>().unwrap().degrees, [-2.0, 8.0]);
        assert!("8".parse::<Warming>().unwrap_err().contains("LO..HI"));
        assert!("0..warm".parse::<Warming>().unwrap_err().contains("`warm`"));
        let check = |text: &str, keep: &[&str]| {
            text.parse::<Warming>()
                .unwrap()
                .keeping_humidity(keep.iter().copied())
                .check(&model)
        };
        assert!(check("0..8", &["hum_out"]).is_ok());
        assert!(check("8..0", &[]).unwrap_err().contains("not above"));
        assert!(check("0..40", &[]).unwrap_err().contains("±30"));
        assert!(check("0..8", &["rain"])
            .unwrap_err()
            .contains("no disturbance `rain`"));
        // A humidity in an unknown unit (radiation, W m⁻²) is refused, naming the units.
        let e = check("0..8", &["radiation"]).unwrap_err();
        assert!(
            e.contains("[W m^-2]") && e.contains("[kg m^-3] or [Pa]"),
            "{e}"
        );
    }

    #[test]
    fn a_vapour_pressure_keeps_its_relative_humidity() {
        let mut model = lettuce();
        model.disturbances[3].info.unit = "Pa".into();
        let weather = Weather::new(
            "by hand",
            1800.0,
            model.weather_columns(),
            vec![0.0, 7e-4, 10.0, 0.6 * saturation_vapour_pressure(10.0)],
        )
        .unwrap();
        let warming = Warming {
            degrees: [5.0, 5.0],
            keep_humidity: vec!["hum_out".into()],
        };
        let warmer = warming.apply(&weather, &model, 5.0).unwrap();
        assert_eq!(warmer.at(0)[2], 15.0);
        let rh = warmer.at(0)[3] / saturation_vapour_pressure(15.0);
        assert!((rh - 0.6).abs() < 1e-12, "{rh}");
        assert_eq!(warmer.at(0)[1], 7e-4);
    }
}
