//! Weather sources: everything that turns outdoor weather into the disturbance
//! sequence `d(k)` a simulation reads.
//!
//! This module owns the canonical disturbance column names and units, the unit
//! conversions (ppm → kg m⁻³ CO2, relative humidity → kg m⁻³ vapour), and three
//! sources that all produce a [`WeatherFrame`] in model units:
//! * [`load_csv`] — a CSV with named columns (e.g. the Venlo 2014 data),
//! * [`load_knmi`] — KNMI hourly station data ("uurgegevens"),
//! * [`builtin_season`] — a seeded synthetic Dutch late-winter season.
//!
//! [`Warming`] makes a warmer copy of a season (for guides that learn summer from spring).
//!
//! [`WeatherFrame::select`] then picks the model's disturbances, in the model's
//! order, as a [`Weather`] with perfect-forecast horizon access.
//!
//! # Examples
//!
//! Two days of the built-in season at the lettuce model's 30-minute period, as the model's
//! disturbances:
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use ghm::sim::weather::{builtin_season, RADIATION, TEMPERATURE};
//!
//! let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
//! let model = ghm::lang::load(&file).map_err(|e| e.render())?;
//! let frame = builtin_season(96, model.sample_period, 2014);
//! assert_eq!((frame.rows(), frame.period_s), (96, 1800.0));
//! let columns = model.weather_columns(); // radiation, CO₂, temperature, humidity
//! assert_eq!((columns[0].as_str(), columns[2].as_str()), (RADIATION, TEMPERATURE));
//!
//! let weather = frame.select(&columns, 0, 96)?;
//! assert_eq!((weather.len(), weather.width()), (96, 4));
//! assert_eq!(weather.at(0)[0], 0.0); // 01:00 on 8 February: dark
//! let noon = weather.at(22); // 12:00 on 8 February
//! assert!(noon[0] > 0.0);
//! // A perfect forecast: six rows from step 20 on, row-major, as MPC reads it.
//! let forecast = weather.horizon(20, 6).unwrap();
//! assert_eq!(&forecast[2 * 4..3 * 4], noon);
//! assert!(weather.horizon(92, 6).is_none()); // runs past the end
//! # Ok(())
//! # }
//! ```

mod builtin;
mod csv_columns;
mod knmi;
mod warming;

pub use builtin::builtin_season;
pub use csv_columns::load_csv;
pub use knmi::load_knmi;
pub use warming::{parse_range, Warming};

use crate::lang::model::CLOCK_COLUMN;
use std::path::{Path, PathBuf};

/// The paper's Venlo 2014 weather in model units at 30 minutes, as `ghm import venlo`
/// writes it (`crate::import::venlo`) and the lettuce tests and studies read it from the
/// data folder (`docs/data.md`).
pub const VENLO_FILE: &str = "venlo2014_30min_model_units.csv";

// Canonical column names every source produces (model units).

/// Global radiation, W m⁻².
pub const RADIATION: &str = "rad_Wm2";
/// Outdoor CO2 density, kg m⁻³.
pub const CO2_DENSITY: &str = "co2_out_kgm3";
/// Outdoor temperature, °C.
pub const TEMPERATURE: &str = "temp_out_C";
/// Outdoor vapour density (absolute humidity), kg m⁻³.
pub const VAPOUR_DENSITY: &str = "vapdens_out_kgm3";

/// Name of the optional, evenly spaced time column of a CSV source (s).
const TIME: &str = "time_s";

/// Everything that can go wrong while reading or slicing weather.
///
/// Common fields: `path` is the file (or a frame's source), `row` the 1-based line
/// number in that file, `column` the column name.
#[derive(Debug, thiserror::Error)]
pub enum WeatherError {
    /// The file could not be opened or read.
    #[error("{}: cannot read the weather file: {source}; check the path and permissions", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The CSV structure itself is broken (ragged rows, bad UTF-8, ...); `source` names the line.
    #[error("{}: malformed CSV: {source}; every row must have as many cells as the header", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The CSV reader's error.
        source: csv::Error,
    },
    /// A needed column is not in the file (or frame); `available` lists those that are.
    #[error("{}: no column `{column}` (available: {}); fix the column name or use a file that has it", path.display(), available.join(", "))]
    MissingColumn {
        /// The file or frame source.
        path: PathBuf,
        /// The column asked for.
        column: String,
        /// The columns there are, in file order.
        available: Vec<String>,
    },
    /// A cell that must hold a number holds `text` instead.
    #[error("{}: line {row}, column `{column}`: {} is not a number; fix or remove that row", path.display(), if text.is_empty() { "an empty cell".into() } else { format!("`{text}`") })]
    NotNumeric {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        row: u64,
        /// The column.
        column: String,
        /// The cell's text (empty for an empty cell).
        text: String,
    },
    /// A cell holds NaN or an infinity.
    #[error("{}: line {row}, column `{column}`: value is NaN or infinite; replace it with a measured value", path.display())]
    NotFinite {
        /// The file or frame source.
        path: PathBuf,
        /// 1-based line number.
        row: u64,
        /// The column.
        column: String,
    },
    /// A value outside the physical range of its column (see [`crate::sim::physical`]).
    #[error("{}: line {row}, column `{column}`: {value} {unit} is outside the physical range [{lower}, {upper}] {unit}; check the sign and the unit of that column", path.display())]
    OutOfRange {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        row: u64,
        /// The column.
        column: String,
        /// The value found.
        value: f64,
        /// The range's lower end.
        lower: f64,
        /// The range's upper end.
        upper: f64,
        /// The column's unit.
        unit: &'static str,
    },
    /// The header names a column twice: which one is meant cannot be known.
    #[error("{}: line 1: the header has column `{column}` twice (columns {first} and {second}); remove or rename one", path.display())]
    DuplicateColumn {
        /// The file.
        path: PathBuf,
        /// The column name.
        column: String,
        /// 1-based position of its first occurrence.
        first: usize,
        /// 1-based position of its second occurrence.
        second: usize,
    },
    /// The time axis is not evenly spaced: the step ending at line `row` differs from the first step.
    #[error("{}: line {row}: time step is {found_step_s} s but {expected_step_s} s was expected; the time axis must be evenly spaced and increasing, so resample the file or remove the gap", path.display())]
    Gap {
        /// The file.
        path: PathBuf,
        /// 1-based line number of the row ending the uneven step.
        row: u64,
        /// The first time step, in seconds.
        expected_step_s: f64,
        /// The uneven time step, in seconds.
        found_step_s: f64,
    },
    /// `needed` rows are needed but the source (file or generator) has only `available`.
    /// (`r#source` keeps thiserror from taking this name for an underlying error.)
    #[error("{source}: {needed} rows needed but only {available} available; use a longer record, an earlier start or fewer steps")]
    TooShort {
        /// The source, in words (the file, or the frame's description of where it came
        /// from).
        r#source: String,
        /// Rows it has in all.
        available: usize,
        /// Rows needed: the first row asked for plus the steps.
        needed: usize,
    },
    /// No KNMI header line (`# STN,YYYYMMDD,   HH, ...`) was found.
    #[error("{}: no KNMI header line `STN,YYYYMMDD,HH,...` found; download the hourly data (uurgegevens) as text from KNMI", path.display())]
    KnmiNoHeader {
        /// The file.
        path: PathBuf,
    },
    /// A KNMI line does not have the expected layout; `message` says how.
    #[error("{}: line {row}: {message}; the file must be KNMI hourly data (uurgegevens) for one station", path.display())]
    KnmiFormat {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        row: u64,
        /// What is wrong with the line.
        message: String,
    },
    /// A needed KNMI observation is empty (missing); values are never filled silently.
    #[error("{}: line {row}, column `{column}` is empty (missing observation); pick a period without missing data or fill it yourself", path.display())]
    KnmiMissing {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        row: u64,
        /// The KNMI column that is empty.
        column: String,
    },
    /// An argument given by the caller is invalid.
    #[error("invalid weather argument: {0}")]
    BadArgument(String),
}

/// The four canonical columns, in the order every source produces them.
fn canonical() -> Vec<String> {
    [RADIATION, CO2_DENSITY, TEMPERATURE, VAPOUR_DENSITY]
        .map(String::from)
        .to_vec()
}

/// Positions of `wanted` in `have`; a missing one is a [`WeatherError::MissingColumn`].
fn positions(path: &Path, have: &[String], wanted: &[String]) -> Result<Vec<usize>, WeatherError> {
    let find = |w: &String| {
        have.iter()
            .position(|h| h == w)
            .ok_or_else(|| WeatherError::MissingColumn {
                path: path.to_path_buf(),
                column: w.clone(),
                available: have.to_vec(),
            })
    };
    wanted.iter().map(find).collect()
}

/// CO2 density in kg m⁻³ from a mole fraction in ppm at temperature `t_c` (°C).
pub fn co2_ppm_to_kgm3(ppm: f64, t_c: f64) -> f64 {
    101325.0 * 1e-6 * ppm * 0.04401 / (8.3144598 * (t_c + 273.15))
}

/// Saturation vapour pressure of water in Pa at temperature `t_c` (°C), by the Magnus
/// formula.
pub fn saturation_vapour_pressure(t_c: f64) -> f64 {
    610.78 * (17.2694 * t_c / (t_c + 238.3)).exp()
}

/// Vapour density in kg m⁻³ from relative humidity `rh_pct` (%) at temperature `t_c` (°C).
pub fn rh_to_vapour_kgm3(rh_pct: f64, t_c: f64) -> f64 {
    (rh_pct / 100.0) * saturation_vapour_pressure(t_c) * 18.01528e-3 / (8.3144598 * (t_c + 273.15))
}

/// A table of named weather columns at a fixed period, row-major.
#[derive(Debug, Clone)]
pub struct WeatherFrame {
    /// Where the data came from (file path or generator), used in messages.
    pub source: String,
    /// Time between rows, s.
    pub period_s: f64,
    /// Column names.
    pub columns: Vec<String>,
    /// `rows × columns` values, row-major.
    pub data: Vec<f64>,
}

impl WeatherFrame {
    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.data.len().checked_div(self.columns.len()).unwrap_or(0)
    }

    /// A copy of one column, or `None` if there is no such column.
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        let c = self.columns.iter().position(|n| n == name)?;
        let w = self.columns.len();
        Some(self.data.chunks_exact(w).map(|r| r[c]).collect())
    }

    /// Picks `wanted` columns (in that order) from row `start_row`, `steps` rows.
    /// Errors: MissingColumn, TooShort.
    ///
    /// ```
    /// use ghm::sim::weather::{builtin_season, WeatherError, RADIATION, TEMPERATURE};
    ///
    /// let frame = builtin_season(48, 3600.0, 1);
    /// let wanted = [TEMPERATURE.to_string(), RADIATION.to_string()];
    /// let weather = frame.select(&wanted, 24, 12).unwrap(); // the second day's first half
    /// let temperature = frame.column(TEMPERATURE).unwrap();
    /// assert_eq!(weather.at(0), [temperature[24], frame.column(RADIATION).unwrap()[24]]);
    ///
    /// let missing = frame.select(&["wind_ms".to_string()], 0, 12).unwrap_err();
    /// assert!(matches!(missing, WeatherError::MissingColumn { .. }));
    /// assert!(missing.to_string().contains("no column `wind_ms`"));
    /// let too_long = frame.select(&wanted, 40, 12).unwrap_err();
    /// assert!(matches!(too_long, WeatherError::TooShort { available: 48, needed: 52, .. }));
    /// ```
    pub fn select(
        &self,
        wanted: &[String],
        start_row: usize,
        steps: usize,
    ) -> Result<Weather, WeatherError> {
        // The clock's column counts rows times the period where the source has none.
        let clock_made = |w: &String| w == CLOCK_COLUMN && !self.columns.contains(w);
        let present: Vec<String> = wanted.iter().filter(|w| !clock_made(w)).cloned().collect();
        let mut found = positions(Path::new(&self.source), &self.columns, &present)?.into_iter();
        let idx: Vec<Option<usize>> = wanted
            .iter()
            .map(|w| if clock_made(w) { None } else { found.next() })
            .collect();
        let needed = start_row.saturating_add(steps);
        if needed > self.rows() {
            let (source, available) = (self.source.clone(), self.rows());
            return Err(WeatherError::TooShort {
                source,
                available,
                needed,
            });
        }
        let w = self.columns.len();
        let period = self.period_s;
        let data = self.data[start_row * w..needed * w]
            .chunks_exact(w)
            .enumerate()
            .flat_map(|(k, r)| {
                let time = (start_row + k) as f64 * period;
                idx.iter().map(move |c| c.map_or(time, |c| r[c]))
            })
            .collect();
        Weather::new(self.source.clone(), self.period_s, wanted.to_vec(), data)
    }
}

/// The disturbance sequence a simulation reads: d(k) for k in 0..len, in the model's disturbance order.
#[derive(Debug, Clone)]
pub struct Weather {
    /// Where the data came from, used in messages.
    pub source: String,
    /// Time between rows, s.
    pub period_s: f64,
    /// Disturbance names, in the model's order.
    pub names: Vec<String>,
    data: Vec<f64>,
    width: usize,
    /// Number of rows (kept apart from `data` so that a plant without disturbances still
    /// has a season length).
    rows: usize,
}

impl Weather {
    /// Builds a weather from row-major `data`; checks that `data.len()` is a
    /// multiple of `names.len()`, that every value is finite and `period_s > 0`.
    ///
    /// ```
    /// use ghm::sim::weather::Weather;
    ///
    /// let names = vec!["temp_out".to_string(), "rain".to_string()];
    /// let weather = Weather::new("by hand", 600.0, names.clone(), vec![5.0, 0.0, 6.0, 0.1]).unwrap();
    /// assert_eq!((weather.len(), weather.width()), (2, 2));
    /// assert_eq!(weather.at(1), [6.0, 0.1]);
    /// assert!(Weather::new("by hand", 600.0, names.clone(), vec![5.0, 0.0, 6.0]).is_err());
    /// assert!(Weather::new("by hand", 600.0, names, vec![5.0, f64::NAN]).is_err());
    /// ```
    pub fn new(
        source: impl Into<String>,
        period_s: f64,
        names: Vec<String>,
        data: Vec<f64>,
    ) -> Result<Weather, WeatherError> {
        let source = source.into();
        let width = names.len();
        let bad = |m: String| Err(WeatherError::BadArgument(format!("{source}: {m}")));
        if !(period_s.is_finite() && period_s > 0.0) {
            return bad(format!("period {period_s} s must be positive"));
        }
        if width == 0 && !data.is_empty() || width > 0 && !data.len().is_multiple_of(width) {
            return bad(format!("{} values do not fill rows of {width}", data.len()));
        }
        if let Some(i) = data.iter().position(|v| !v.is_finite()) {
            return bad(format!(
                "row {}, `{}` is not finite",
                i / width,
                names[i % width]
            ));
        }
        let rows = data.len().checked_div(width).unwrap_or(0);
        Ok(Weather {
            source,
            period_s,
            names,
            data,
            width,
            rows,
        })
    }

    /// Number of steps (rows).
    pub fn len(&self) -> usize {
        self.rows
    }

    /// True if there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of disturbances per row.
    pub fn width(&self) -> usize {
        self.width
    }

    /// d(k). Panics only if k >= len (callers check len up front).
    pub fn at(&self, k: usize) -> &[f64] {
        assert!(
            k < self.len(),
            "weather step {k} out of range (len {})",
            self.len()
        );
        &self.data[k * self.width..(k + 1) * self.width]
    }

    /// d(k) .. d(k+n-1) as one contiguous row-major slice (perfect forecast); None if it would run past the end.
    pub fn horizon(&self, k: usize, n: usize) -> Option<&[f64]> {
        let end = k.checked_add(n)?;
        (end <= self.len()).then(|| &self.data[k * self.width..end * self.width])
    }

    /// A constant weather (for plants without real weather): `len` rows equal to `values`.
    ///
    /// # Panics
    /// If `values.len() != names.len()` or `period_s` is not positive (programming errors).
    ///
    /// # Examples
    ///
    /// ```
    /// use ghm::sim::weather::Weather;
    ///
    /// let weather = Weather::constant(vec!["temp_out".into()], &[4.5], 48, 1800.0);
    /// assert_eq!(weather.len(), 48);
    /// assert_eq!(weather.horizon(40, 8).unwrap(), [4.5; 8]);
    /// // A plant without disturbances still gets a season length.
    /// let none = Weather::constant(vec![], &[], 10, 60.0);
    /// assert_eq!((none.len(), none.width()), (10, 0));
    /// ```
    pub fn constant(names: Vec<String>, values: &[f64], len: usize, period_s: f64) -> Weather {
        assert_eq!(
            values.len(),
            names.len(),
            "Weather::constant: one value per name"
        );
        assert!(
            period_s.is_finite() && period_s > 0.0,
            "Weather::constant: period must be > 0"
        );
        let data = values.repeat(len);
        Weather {
            source: "constant weather".into(),
            period_s,
            width: names.len(),
            names,
            data,
            rows: len,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use WeatherError as E;

    /// The Venlo weather of the data folder, where it is there (`crate::sim::test_data`).
    fn venlo_file(test: &str) -> Option<std::path::PathBuf> {
        crate::sim::test_data::file(VENLO_FILE, test)
    }

    /// Runs `f` on `text` written to a uniquely named temp file, then removes the file.
    fn with_file<T>(name: &str, text: &str, f: impl FnOnce(&Path) -> T) -> T {
        let p = std::env::temp_dir().join(format!("ghm_weather_{}_{name}", std::process::id()));
        std::fs::write(&p, text).expect("write temp file");
        let r = f(&p);
        std::fs::remove_file(&p).ok();
        r
    }

    fn names(n: &[&str]) -> Vec<String> {
        n.iter().map(|s| s.to_string()).collect()
    }

    fn csv_err(name: &str, text: &str, needed: &[&str]) -> WeatherError {
        with_file(name, text, |p| load_csv(p, &names(needed), 1800.0)).expect_err(name)
    }

    fn knmi(name: &str, text: &str) -> Result<WeatherFrame, WeatherError> {
        with_file(name, text, |p| load_knmi(p, 1800.0, 400.0))
    }

    fn venlo(test: &str) -> Option<Weather> {
        let f = load_csv(&venlo_file(test)?, &canonical(), 300.0).expect("load Venlo");
        Some(f.select(&canonical(), 1394, 1920 + 12).expect("select"))
    }

    /// Mean daily radiation sum (MJ m⁻²), mean/min/max T (°C), mean RH (%) and mean
    /// CO2 (ppm) over the first `days` whole days of a weather in canonical order.
    fn season_stats(w: &Weather, days: usize) -> [f64; 6] {
        let n = days * (86400.0 / w.period_s) as usize;
        let mut s = [0.0, 0.0, f64::MAX, f64::MIN, 0.0, 0.0];
        for d in (0..n).map(|k| w.at(k)) {
            s[0] += d[0] * w.period_s / 1e6 / days as f64;
            s[1] += d[2] / n as f64;
            (s[2], s[3]) = (s[2].min(d[2]), s[3].max(d[2]));
            s[4] += 100.0 * d[3] / rh_to_vapour_kgm3(100.0, d[2]) / n as f64;
            s[5] += 1e6 * d[1] / co2_ppm_to_kgm3(1e6, d[2]) / n as f64;
        }
        s
    }

    #[test]
    fn venlo_first_step_and_period() {
        let Some(w) = venlo("venlo_first_step_and_period") else {
            return;
        };
        assert_eq!((w.len(), w.width(), w.period_s), (1932, 4, 1800.0));
        let want = [0.0, 8.633266287531032e-04, 5.6, 5.498145226014581e-03];
        for (a, b) in w.at(0).iter().zip(want) {
            assert!((a - b).abs() <= 1e-15 * b.abs(), "{a} vs {b}");
        }
        let h = w.horizon(1920, 12).expect("horizon fits");
        assert_eq!((h.len(), &h[..4]), (48, w.at(1920)));
        assert!(w.horizon(1921, 12).is_none());
    }

    #[test]
    fn venlo_vs_builtin_season() {
        let Some(venlo) = venlo("venlo_vs_builtin_season") else {
            return;
        };
        let v = season_stats(&venlo, 40);
        let stats = |seed| {
            let w = builtin_season(1920, 1800.0, seed).select(&canonical(), 0, 1920);
            season_stats(&w.expect("select"), 40)
        };
        let b = stats(42);
        let mut avg = [0.0; 6];
        for seed in 0..20 {
            avg.iter_mut()
                .zip(stats(seed))
                .for_each(|(a, x)| *a += x / 20.0);
        }
        println!("| quantity | Venlo | built-in seed 42 | built-in, mean of seeds 0-19 |");
        let rows = [
            "daily rad MJ/m2",
            "mean T",
            "min T",
            "max T",
            "mean RH %",
            "mean CO2 ppm",
        ];
        for (i, q) in rows.iter().enumerate() {
            println!("| {q} | {:.2} | {:.2} | {:.2} |", v[i], b[i], avg[i]);
        }
        assert!((b[0] / v[0] - 1.0).abs() < 0.35, "radiation {b:?} vs {v:?}");
        assert!((b[1] - v[1]).abs() < 3.0, "temperature {b:?} vs {v:?}");
    }

    #[test]
    fn csv_select_and_errors() {
        let ok = "time_s,a,b,note\n0,1,2,x\n600,3,4,y\n1200,5,6,z\n";
        let f = with_file("ok.csv", ok, |p| load_csv(p, &names(&["b", "a"]), 1.0)).expect("ok");
        assert_eq!((f.period_s, f.rows()), (600.0, 3));
        assert_eq!(f.column("a"), Some(vec![1.0, 3.0, 5.0]));
        let w = f.select(&names(&["a", "b"]), 1, 2).expect("select");
        assert_eq!((w.at(0), w.at(1)), (&[3.0, 4.0][..], &[5.0, 6.0][..]));
        let e = f.select(&names(&["a"]), 2, 2).expect_err("too few rows");
        assert!(
            matches!(
                e,
                E::TooShort {
                    available: 3,
                    needed: 4,
                    ..
                }
            ),
            "{e}"
        );
        assert!(std::error::Error::source(&e).is_none());
        let e = f.select(&names(&["zz"]), 0, 1).expect_err("missing");
        assert!(matches!(e, E::MissingColumn { .. }), "{e}");

        let e = csv_err("missing.csv", ok, &["a", "c"]);
        assert!(
            matches!(&e, E::MissingColumn { column, .. } if column == "c"),
            "{e}"
        );
        assert!(e.to_string().contains("time_s, a, b, note"), "{e}");
        let e = csv_err("text.csv", "time_s,a\n0,1\n600,abc\n", &["a"]);
        assert!(matches!(&e, E::NotNumeric { row: 3, .. }), "{e}");
        assert!(
            e.to_string().contains("text.csv: line 3, column `a`"),
            "{e}"
        );
        let e = csv_err("nan.csv", "time_s,a\n0,1\n600,NaN\n", &["a"]);
        assert!(matches!(e, E::NotFinite { row: 3, .. }), "{e}");
        let e = csv_err("gap.csv", "time_s,a\n0,1\n600,2\n1200,3\n2400,4\n", &["a"]);
        let (row, expected, found) = match e {
            E::Gap {
                row,
                expected_step_s,
                found_step_s,
                ..
            } => (row, expected_step_s, found_step_s),
            e => panic!("{e}"),
        };
        assert_eq!((row, expected, found), (5, 600.0, 1200.0));
        // Non-numeric cells in columns that are not needed are fine.
        let f = with_file("lazy.csv", "a,b\n1,x\n2,y\n", |p| {
            load_csv(p, &names(&["a"]), 900.0)
        });
        assert_eq!(f.map(|f| (f.period_s, f.rows())).ok(), Some((900.0, 2)));
    }

    #[test]
    fn weather_new_and_constant() {
        assert!(Weather::new("t", 1.0, names(&["a", "b"]), vec![1.0, 2.0, 3.0]).is_err());
        assert!(Weather::new("t", 1.0, names(&["a"]), vec![1.0, f64::INFINITY]).is_err());
        let w = Weather::constant(names(&["a", "b"]), &[1.0, 2.0], 3, 60.0);
        assert_eq!((w.len(), w.at(2)), (3, &[1.0, 2.0][..]));
        assert_eq!(w.horizon(1, 2), Some(&[1.0, 2.0, 1.0, 2.0][..]));
    }

    const KNMI: &str = "\
# BRON: KONINKLIJK NEDERLANDS METEOROLOGISCH INSTITUUT (KNMI)
# STN         LON(east)   LAT(north)  ALT(m)      NAME
# 391         6.197       51.498      19.50       Arcen
#
# STN,YYYYMMDD,   HH,   DD,   FH,    T,   Q,    U
#
  391,20140208,    7,  190,   50,   40,    0,   90
  391,20140208,    8,  190,   50,   50,   18,   86
  391,20140208,    9,  200,   60,   70,   72,   80
  391,20140208,   10,  200,   60,   90,  108,   70
";

    #[test]
    fn knmi_converts_and_interpolates() {
        let f = knmi("knmi.txt", KNMI).expect("knmi");
        let f2 = knmi("knmi_nohash.txt", &KNMI.replace("# STN,", "STN,")).expect("no #");
        assert_eq!(f.data, f2.data);
        // Q = 0, 18, 72, 108 J/cm² → 0, 50, 200, 300 W/m² at 06:30 .. 09:30; T, U at 7 .. 10 h.
        // Output rows: 07:00 .. 09:30 every 30 min.
        let close = |col: &str, want: [f64; 6]| {
            let got = f.column(col).expect("column");
            assert_eq!(got.len(), 6);
            got.iter()
                .zip(want)
                .for_each(|(a, b)| assert!((a - b).abs() < 1e-12, "{a} vs {b}"));
        };
        close(RADIATION, [25.0, 50.0, 125.0, 200.0, 250.0, 300.0]);
        close(TEMPERATURE, [4.0, 4.5, 5.0, 6.0, 7.0, 8.0]);
        let (v7, v8) = (rh_to_vapour_kgm3(90.0, 4.0), rh_to_vapour_kgm3(86.0, 5.0));
        assert!((v7 - 5.75e-3).abs() < 0.05e-3, "{v7}"); // ≈ 5.75 g/m³ at 4 °C, 90 %
        let vap = f.column(VAPOUR_DENSITY).expect("vap");
        assert!((vap[0] - v7).abs() < 1e-15 && (vap[1] - 0.5 * (v7 + v8)).abs() < 1e-15);
        let co2 = f.column(CO2_DENSITY).expect("co2");
        assert!((co2[0] - 101325.0 * 400e-6 * 0.04401 / (8.3144598 * 277.15)).abs() < 1e-15);
    }

    #[test]
    fn knmi_day_rollover_and_errors() {
        let row = |date: u32, hh: u32, q: &str| format!("391,{date},{hh},50,{q},90\n");
        let head = "STN,YYYYMMDD,HH,T,Q,U\n".to_string();
        let roll = head.clone() + &row(20140228, 23, "0") + &row(20140228, 24, "0");
        let r = knmi("knmi_roll.txt", &(roll + &row(20140301, 1, "0")));
        assert_eq!(r.map(|f| f.rows()).ok(), Some(4));
        let miss = head.clone() + &row(20140208, 1, "0") + &row(20140208, 2, "");
        let e = knmi("knmi_miss.txt", &miss).expect_err("missing cell");
        assert!(
            matches!(&e, E::KnmiMissing { row: 3, column, .. } if column == "Q"),
            "{e}"
        );
        assert!(
            e.to_string()
                .contains("knmi_miss.txt: line 3, column `Q` is empty"),
            "{e}"
        );
        let gap = head.clone() + &row(20140208, 1, "0") + &row(20140208, 3, "0");
        let e = knmi("knmi_gap.txt", &gap).expect_err("gap");
        assert!(
            matches!(
                e,
                E::Gap {
                    row: 3,
                    found_step_s: 7200.0,
                    ..
                }
            ),
            "{e}"
        );
        let e = knmi("knmi_one.txt", &(head + &row(20140208, 1, "0"))).expect_err("short");
        assert!(
            matches!(
                e,
                E::TooShort {
                    available: 1,
                    needed: 2,
                    ..
                }
            ),
            "{e}"
        );
        let e = knmi("knmi_nohead.txt", "# nothing here\n").expect_err("no header");
        assert!(matches!(e, E::KnmiNoHeader { .. }), "{e}");
    }

    /// Each way a KNMI file can be malformed is its own error, naming the line: a data
    /// line before the header, a short line, a date or hour out of range, a second
    /// station, a cell that is not a number, a header without a needed column, and
    /// arguments that are not positive.
    #[test]
    fn knmi_format_errors_name_the_line_and_the_fault() {
        let head = "STN,YYYYMMDD,HH,T,Q,U\n";
        let good = "391,20140208,1,50,0,90\n";
        let format = |name: &str, text: &str| match knmi(name, text) {
            Err(E::KnmiFormat { row, message, .. }) => (row, message),
            other => panic!("{name}: {other:?}"),
        };
        let early = format("knmi_early.txt", &format!("{good}{head}{good}"));
        assert_eq!(early, (1, "data line before the header line".into()));
        let short = format(
            "knmi_short.txt",
            &format!("{head}{good}391,20140208,2,50,0\n"),
        );
        assert_eq!(short, (3, "5 fields but the header has 6".into()));
        for (bad, date, hour) in [
            ("391,20141308,2,50,0,90", 20141308, 2),
            ("391,20140200,2,50,0,90", 20140200, 2),
            ("391,20140208,0,50,0,90", 20140208, 0),
            ("391,20140208,25,50,0,90", 20140208, 25),
        ] {
            let e = format("knmi_date.txt", &format!("{head}{good}{bad}\n"));
            assert_eq!(e, (3, format!("bad date/hour {date} {hour}")), "{bad}");
        }
        let other = format(
            "knmi_stn.txt",
            &format!("{head}{good}380,20140208,2,50,0,90\n"),
        );
        assert_eq!(other, (3, "station 380 differs from 391".into()));
        let e = knmi(
            "knmi_text.txt",
            &format!("{head}{good}391,20140208,2,warm,0,90\n"),
        )
        .expect_err("a word for T");
        assert!(
            matches!(&e, E::NotNumeric { row: 3, column, text, .. } if column == "T" && text == "warm"),
            "{e}"
        );
        let e = knmi(
            "knmi_no_q.txt",
            "STN,YYYYMMDD,HH,T,U\n391,20140208,1,50,90\n",
        )
        .expect_err("no Q column");
        assert!(
            matches!(&e, E::MissingColumn { column, .. } if column == "Q"),
            "{e}"
        );
        let text = format!("{head}{good}391,20140208,2,50,0,90\n");
        assert!(knmi("knmi_ok.txt", &text).is_ok());
        for (period, co2) in [(0.0, 400.0), (1800.0, -1.0), (f64::NAN, 400.0)] {
            let e = with_file("knmi_args.txt", &text, |p| load_knmi(p, period, co2));
            assert!(matches!(e, Err(E::BadArgument(_))), "{period} {co2}: {e:?}");
        }
    }

    #[test]
    fn builtin_deterministic_and_plausible() {
        let a = builtin_season(1920, 1800.0, 7);
        assert_eq!(a.data, builtin_season(1920, 1800.0, 7).data);
        assert_ne!(a.data, builtin_season(1920, 1800.0, 8).data);
        assert_eq!(builtin_season(100, 1800.0, 7).data[..], a.data[..400]);
        let rad = a.column(RADIATION).expect("rad");
        assert!(rad.iter().all(|&r| r >= 0.0));
        // Each day, rows 0..8 (01:00–04:30) and 46 (24:00) are night; 23 (12:30) is day.
        for day in rad.chunks_exact(48) {
            assert!(day[..8].iter().chain(&day[46..47]).all(|&r| r == 0.0) && day[23] > 0.0);
        }
        for seed in 0..5 {
            let w = builtin_season(1920, 1800.0, seed).select(&canonical(), 0, 1920);
            let [r, t, t_min, t_max, rh, co2] = season_stats(&w.expect("select"), 40);
            assert!(
                (4.0..11.0).contains(&r) && (5.0..10.5).contains(&t),
                "{r} {t}"
            );
            assert!(t_min > -10.0 && t_max < 25.0, "{t_min} {t_max}");
            assert!(
                (65.0..90.0).contains(&rh) && (400.0..450.0).contains(&co2),
                "{rh} {co2}"
            );
        }
    }
}
