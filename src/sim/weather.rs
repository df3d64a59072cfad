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

use crate::sim::physical::range_of;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{PI, TAU};
use std::path::{Path, PathBuf};

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
fn co2_ppm_to_kgm3(ppm: f64, t_c: f64) -> f64 {
    101325.0 * 1e-6 * ppm * 0.04401 / (8.3144598 * (t_c + 273.15))
}

/// Vapour density in kg m⁻³ from relative humidity `rh_pct` (%) at temperature `t_c` (°C).
fn rh_to_vapour_kgm3(rh_pct: f64, t_c: f64) -> f64 {
    let p_sat = 610.78 * (17.2694 * t_c / (t_c + 238.3)).exp();
    (rh_pct / 100.0) * p_sat * 18.01528e-3 / (8.3144598 * (t_c + 273.15))
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
        let idx = positions(Path::new(&self.source), &self.columns, wanted)?;
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
        let data = self.data[start_row * w..needed * w]
            .chunks_exact(w)
            .flat_map(|r| idx.iter().map(move |&c| r[c]))
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
        if width == 0 && !data.is_empty() || width > 0 && data.len() % width != 0 {
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

/// Parses one numeric cell; errors name file, 1-based line and column.
fn parse_cell(path: &Path, row: u64, column: &str, text: &str) -> Result<f64, WeatherError> {
    let (path, column) = (path.to_path_buf(), column.to_string());
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => match range_of(&column) {
            Some(r) if !r.contains(v) => Err(WeatherError::OutOfRange {
                path,
                row,
                column,
                value: v,
                lower: r.lower,
                upper: r.upper,
                unit: r.unit,
            }),
            _ => Ok(v),
        },
        Ok(_) => Err(WeatherError::NotFinite { path, row, column }),
        Err(_) => Err(WeatherError::NotNumeric {
            path,
            row,
            column,
            text: text.into(),
        }),
    }
}

/// Checks the time step ending at `row` against the first step (rel. tolerance 1e-6).
fn check_step(path: &Path, row: u64, expected: f64, found: f64) -> Result<(), WeatherError> {
    if expected > 0.0 && (found - expected).abs() <= 1e-6 * expected {
        return Ok(());
    }
    Err(WeatherError::Gap {
        path: path.to_path_buf(),
        row,
        expected_step_s: expected,
        found_step_s: found,
    })
}

/// CSV with a header row of named columns (e.g. the Venlo file).
///
/// If a `time_s` column exists it must be evenly spaced and increasing (else
/// [`WeatherError::Gap`]) and gives `period_s`; otherwise (or with a single row)
/// `period_s = default_period_s`. Only `needed_columns` (all columns if empty)
/// and `time_s` are parsed, in every row: they must be numeric and finite, and
/// errors name the file, the 1-based line and the column. Other columns may
/// hold anything. The frame holds `needed_columns` in that order, plus `time_s`.
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::sim::weather::{load_csv, WeatherError};
///
/// let dir = std::env::temp_dir().join(format!("ghm-doc-load-csv-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let path = dir.join("weather.csv");
/// std::fs::write(&path, "time_s,temp_out_C,note\n0,4.5,frost\n900,4.75,\n1800,5.0,\n")?;
///
/// let frame = load_csv(&path, &["temp_out_C".to_string()], 3600.0)?;
/// assert_eq!(frame.period_s, 900.0); // from `time_s`, not the default
/// assert_eq!(frame.columns, ["temp_out_C", "time_s"]);
/// assert_eq!(frame.column("temp_out_C").unwrap(), [4.5, 4.75, 5.0]);
///
/// // A bad cell: the message names the file, the line and the column.
/// std::fs::write(&path, "time_s,temp_out_C\n0,4.5\n900,warm\n")?;
/// let error = load_csv(&path, &["temp_out_C".to_string()], 3600.0).unwrap_err();
/// assert!(matches!(error, WeatherError::NotNumeric { row: 3, .. }));
/// assert!(error.to_string().ends_with("line 3, column `temp_out_C`: `warm` is not a number; fix or remove that row"));
/// std::fs::remove_dir_all(&dir)?;
/// # Ok(())
/// # }
/// ```
pub fn load_csv(
    path: &Path,
    needed_columns: &[String],
    default_period_s: f64,
) -> Result<WeatherFrame, WeatherError> {
    if !(default_period_s.is_finite() && default_period_s > 0.0) {
        return Err(WeatherError::BadArgument(format!(
            "default period {default_period_s} s must be positive"
        )));
    }
    let io = |source| WeatherError::Io {
        path: path.to_path_buf(),
        source,
    };
    let csv_err = |source| WeatherError::Csv {
        path: path.to_path_buf(),
        source,
    };
    let bytes = std::fs::read(path).map_err(io)?;
    // Line numbers from byte offsets: with CRLF line endings the reader's own count is one
    // short, and a record's offset can be the `\n` of the line before it.
    let newlines: Vec<usize> = bytes
        .iter()
        .enumerate()
        .filter_map(|(i, &b)| (b == b'\n').then_some(i))
        .collect();
    let line_at = |byte: u64| {
        let start = (byte as usize).min(bytes.len());
        let text = bytes[start..]
            .iter()
            .position(|&b| b != b'\r' && b != b'\n')
            .map_or(bytes.len(), |i| start + i);
        newlines.partition_point(|&n| n < text) as u64 + 1
    };
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(&bytes[..]);
    let header: Vec<String> = rdr
        .headers()
        .map_err(csv_err)?
        .iter()
        .map(str::to_string)
        .collect();
    let mut seen = std::collections::HashMap::with_capacity(header.len());
    for (second, h) in header.iter().enumerate() {
        if let Some(first) = seen.insert(h.as_str(), second) {
            return Err(WeatherError::DuplicateColumn {
                path: path.to_path_buf(),
                column: h.clone(),
                first: first + 1,
                second: second + 1,
            });
        }
    }
    let mut columns: Vec<String> = Vec::new();
    let requested = if needed_columns.is_empty() {
        &header[..]
    } else {
        needed_columns
    };
    for c in requested.iter().chain(header.iter().filter(|h| *h == TIME)) {
        if !columns.contains(c) {
            columns.push(c.clone());
        }
    }
    let idx = positions(path, &header, &columns)?;
    let time_col = columns.iter().position(|c| c == TIME);
    let (mut data, mut times) = (Vec::new(), Vec::new());
    for rec in rdr.records() {
        let rec = rec.map_err(csv_err)?;
        let line = rec.position().map_or(0, |p| line_at(p.byte()));
        for (c, &i) in columns.iter().zip(&idx) {
            data.push(parse_cell(path, line, c, rec.get(i).unwrap_or(""))?);
        }
        if let Some(tc) = time_col {
            let t = data[data.len() - columns.len() + tc];
            if times.len() >= 2 {
                check_step(path, line, times[1] - times[0], t - times[times.len() - 1])?;
            } else if times.len() == 1 && t <= times[0] {
                return Err(WeatherError::Gap {
                    path: path.to_path_buf(),
                    row: line,
                    expected_step_s: default_period_s,
                    found_step_s: t - times[0],
                });
            }
            times.push(t);
        }
    }
    let period_s = if times.len() >= 2 {
        times[1] - times[0]
    } else {
        default_period_s
    };
    Ok(WeatherFrame {
        source: path.display().to_string(),
        period_s,
        columns,
        data,
    })
}

/// Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant's algorithm).
fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + d - 1;
    era * 146097 + yoe * 365 + yoe / 4 - yoe / 100 + doy - 719468
}

/// Linear interpolation in an evenly spaced series of at least two values at
/// fractional index `x` (clamped to the series).
fn interp(v: &[f64], x: f64) -> f64 {
    let x = x.clamp(0.0, (v.len() - 1) as f64);
    let i = (x as usize).min(v.len() - 2);
    v[i] + (x - i as f64) * (v[i + 1] - v[i])
}

/// KNMI hourly station data ("uurgegevens" text format from KNMI's website).
///
/// Comment lines start with `#`; the header is `# STN,YYYYMMDD,   HH, ...` (the
/// `#` may be absent). HH = 1..24 ends the hour; T in 0.1 °C and U in % are
/// observed at HH, Q (J cm⁻² over the hour) becomes `rad_Wm2 = Q·1e4/3600` at the
/// hour's midpoint HH − 0.5. CO2 density comes from the constant `co2_ppm`, vapour
/// density from T and U, both at HH. The series are then linearly interpolated to
/// `period_s` from the first row's HH to the last row's radiation midpoint
/// (HH − 0.5), so nothing is extrapolated. Rows must be consecutive hours of one
/// station; empty T/Q/U cells are errors (never filled).
///
/// # Examples
///
/// Three hours of a station: T = 5, 6, 7 °C and Q = 36, 72, 108 J cm⁻² (100, 200,
/// 300 W m⁻² over the hours ending at 10, 11 and 12 UT), on a 30-minute grid:
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::sim::weather::{load_knmi, WeatherError, RADIATION, TEMPERATURE};
///
/// let dir = std::env::temp_dir().join(format!("ghm-doc-knmi-{}", std::process::id()));
/// std::fs::create_dir_all(&dir)?;
/// let path = dir.join("uurgeg.txt");
/// let header = "# STN,YYYYMMDD,   HH,    T,    Q,    U\n";
/// let rows = "  380,20140208,   10,   50,   36,   80
///   380,20140208,   11,   60,   72,   75
///   380,20140208,   12,   70,  108,   70
/// ";
/// std::fs::write(&path, format!("{header}{rows}"))?;
///
/// let frame = load_knmi(&path, 1800.0, 400.0)?;
/// assert_eq!(frame.rows(), 4); // 10:00 to 11:30, the last radiation midpoint
/// let close = |a: Vec<f64>, b: [f64; 4]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9);
/// assert!(close(frame.column(RADIATION).unwrap(), [150.0, 200.0, 250.0, 300.0]));
/// assert!(close(frame.column(TEMPERATURE).unwrap(), [5.0, 5.5, 6.0, 6.5]));
///
/// // A missing observation is an error, never filled in.
/// std::fs::write(&path, format!("{header}{}", rows.replace("   60,", "     ,")))?;
/// let error = load_knmi(&path, 1800.0, 400.0).unwrap_err();
/// assert!(matches!(error, WeatherError::KnmiMissing { row: 3, .. }), "{error}");
/// std::fs::remove_dir_all(&dir)?;
/// # Ok(())
/// # }
/// ```
pub fn load_knmi(path: &Path, period_s: f64, co2_ppm: f64) -> Result<WeatherFrame, WeatherError> {
    if !(period_s.is_finite() && period_s > 0.0 && co2_ppm.is_finite() && co2_ppm > 0.0) {
        let m = format!("KNMI period {period_s} s and CO2 {co2_ppm} ppm must be positive");
        return Err(WeatherError::BadArgument(m));
    }
    let io = |source| WeatherError::Io {
        path: path.to_path_buf(),
        source,
    };
    let text = std::fs::read_to_string(path).map_err(io)?;
    let fmt = |row, message| WeatherError::KnmiFormat {
        path: path.to_path_buf(),
        row,
        message,
    };
    let wanted = ["STN", "YYYYMMDD", "HH", "T", "Q", "U"].map(String::from);
    let (mut header, mut idx) = (None::<Vec<String>>, vec![]);
    let (mut rad, mut temp, mut co2, mut vap) = (vec![], vec![], vec![], vec![]);
    let (mut first, mut prev_hour) = (None::<(f64, i64, i64)>, 0);
    for (n, raw) in text.lines().enumerate() {
        let row = n as u64 + 1;
        let body = raw.trim_start().trim_start_matches('#').trim();
        let is_header = body.starts_with("STN,") && body.contains("YYYYMMDD");
        if is_header && header.is_none() {
            let h: Vec<String> = body.split(',').map(|s| s.trim().to_string()).collect();
            idx = positions(path, &h, &wanted)?;
            header = Some(h);
        }
        if raw.trim_start().starts_with('#') || body.is_empty() || is_header {
            continue;
        }
        let Some(h) = &header else {
            return Err(fmt(row, "data line before the header line".into()));
        };
        let cells: Vec<&str> = raw.split(',').map(str::trim).collect();
        if cells.len() < h.len() {
            let m = format!("{} fields but the header has {}", cells.len(), h.len());
            return Err(fmt(row, m));
        }
        let val = |&i: &usize| match cells[i] {
            "" => Err(WeatherError::KnmiMissing {
                path: path.to_path_buf(),
                row,
                column: h[i].clone(),
            }),
            t => parse_cell(path, row, &h[i], t),
        };
        let v = idx.iter().map(val).collect::<Result<Vec<_>, _>>()?;
        let (stn, date, hh, t, q, u) = (v[0], v[1] as i64, v[2] as i64, v[3] / 10.0, v[4], v[5]);
        let (y, m, d) = (date / 10000, date / 100 % 100, date % 100);
        if !(1..=12).contains(&m) || !(1..=31).contains(&d) || !(1..=24).contains(&hh) {
            return Err(fmt(row, format!("bad date/hour {date} {hh}")));
        }
        let hour = days_from_civil(y, m, d) * 24 + hh;
        match first {
            None => first = Some((stn, date, hh)),
            Some((s0, ..)) if s0 != stn => {
                return Err(fmt(row, format!("station {stn} differs from {s0}")))
            }
            _ => check_step(path, row, 3600.0, (hour - prev_hour) as f64 * 3600.0)?,
        }
        prev_hour = hour;
        rad.push(q * 1e4 / 3600.0);
        temp.push(t);
        co2.push(co2_ppm_to_kgm3(co2_ppm, t));
        vap.push(rh_to_vapour_kgm3(u, t));
    }
    if header.is_none() {
        return Err(WeatherError::KnmiNoHeader {
            path: path.to_path_buf(),
        });
    }
    let (source, available) = (path.display().to_string(), rad.len());
    let Some((stn, date, hh)) = first.filter(|_| available >= 2) else {
        return Err(WeatherError::TooShort {
            source,
            available,
            needed: 2,
        });
    };
    // From the first observation to the last radiation midpoint, so nothing is extrapolated.
    let span_s = (available - 1) as f64 * 3600.0 - 1800.0;
    let rows = (span_s / period_s + 1e-9).floor() as usize + 1;
    let data = (0..rows)
        .flat_map(|j| {
            let x = j as f64 * period_s / 3600.0;
            [
                interp(&rad, x + 0.5),
                interp(&co2, x),
                interp(&temp, x),
                interp(&vap, x),
            ]
        })
        .collect();
    let source = format!("{source} (KNMI station {stn}, from {date} hour {hh} UT)");
    Ok(WeatherFrame {
        source,
        period_s,
        columns: canonical(),
        data,
    })
}

/// Standard normal draw (Box–Muller, one of the pair).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1 = 1.0 - rng.random::<f64>();
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (TAU * u2).cos()
}

/// Site of the built-in season: latitude 52° N, longitude 6.2° E (Venlo), clocks at UTC+1.
const LAT_DEG: f64 = 52.0;
const LON_DEG: f64 = 6.2;
/// Day of year of 8 February, the season's first day.
const FIRST_DOY: f64 = 39.0;
/// Local clock hour of the daily temperature maximum.
const T_MAX_HOUR: f64 = 15.0;

/// Declination (rad) and clock-minus-solar-time offset (h) for a day of year.
fn sun(doy: f64) -> (f64, f64) {
    let decl = 23.45f64.to_radians() * (TAU * (284.0 + doy) / 365.0).sin();
    let b = TAU * (doy - 81.0) / 364.0;
    let eot_min = 9.87 * (2.0 * b).sin() - 7.53 * b.cos() - 1.5 * b.sin();
    (decl, -(4.0 * (LON_DEG - 15.0) + eot_min) / 60.0)
}

/// Local clock hour of sunrise on a day of year.
fn sunrise_hour(doy: f64) -> f64 {
    let (decl, offset) = sun(doy);
    let w0 = (-LAT_DEG.to_radians().tan() * decl.tan())
        .clamp(-1.0, 1.0)
        .acos();
    12.0 - w0.to_degrees() / 15.0 + offset
}

/// Built-in default season: a deterministic, seeded generator of a Dutch late-winter /
/// early-spring season starting 8 February at 01:00 local time (the paper's season:
/// 2014-02-08 01:00 in the Venlo data) at latitude 52° N, `steps` rows at `period_s`.
///
/// Radiation: Haurwitz clear-sky global radiation from the solar elevation
/// (declination, equation of time, hour angle) times a daily clear-sky index
/// from an AR(1) cloudiness process, with AR(1) sub-daily cloud flicker.
/// Temperature: an annual cycle of the daily mean (≈ 6.4 → 9.3 °C over the first
/// 40 days) plus AR(1) daily anomalies, and a diurnal cycle (minimum at sunrise, maximum 15:00) whose amplitude grows
/// with sunshine. Relative humidity: high at night, lower by day. CO2 ≈ 400–450 ppm,
/// higher at night. Same seed → bit-identical output; a shorter run is a prefix of a
/// longer one. Columns: the four canonical ones.
///
/// # Panics
/// If `period_s` is not positive and finite.
///
/// # Examples
///
/// ```
/// use ghm::sim::weather::{builtin_season, CO2_DENSITY, RADIATION, TEMPERATURE, VAPOUR_DENSITY};
///
/// let day = builtin_season(24, 3600.0, 7);
/// assert_eq!(day.columns, [RADIATION, CO2_DENSITY, TEMPERATURE, VAPOUR_DENSITY]);
/// assert_eq!((day.rows(), day.period_s), (24, 3600.0));
/// // Same seed, same weather; a shorter run is a prefix of a longer one.
/// let two_days = builtin_season(48, 3600.0, 7);
/// assert_eq!(day.data[..], two_days.data[..day.data.len()]);
/// assert_ne!(builtin_season(24, 3600.0, 8).data, day.data);
/// // Dark at night (the first row is 01:00), sunny around noon, late-winter temperatures.
/// let radiation = day.column(RADIATION).unwrap();
/// assert_eq!(radiation[0], 0.0);
/// assert!(radiation[11] > 0.0);
/// assert!(day.column(TEMPERATURE).unwrap().iter().all(|t| (-15.0..25.0).contains(t)));
/// ```
pub fn builtin_season(steps: usize, period_s: f64, seed: u64) -> WeatherFrame {
    assert!(
        period_s.is_finite() && period_s > 0.0,
        "builtin_season: period must be > 0"
    );
    let mut day_rng = ChaCha8Rng::seed_from_u64(seed);
    let mut step_rng = ChaCha8Rng::seed_from_u64(seed);
    step_rng.set_stream(1);
    // Days -1 ..= last+1, so that noon-to-noon interpolation is always defined.
    let n_days = (3600.0 + steps as f64 * period_s) / 86400.0;
    let (mut z, mut ta, mut ra, mut ca) = (0.0, 0.0, 0.0, 0.0);
    // Per day: clear-sky index (cloudiness, 0.1–0.97) and anomalies of daily-mean
    // temperature (°C), relative humidity (%) and CO2 (ppm); AR(1) from day to day.
    let days: Vec<[f64; 4]> = (0..n_days.ceil() as usize + 3)
        .map(|_| {
            z = 0.6 * z + 0.8 * normal(&mut day_rng);
            ta = 0.7 * ta + 1.5 * 0.714 * normal(&mut day_rng);
            ra = 0.6 * ra + 5.0 * 0.8 * normal(&mut day_rng);
            ca = 0.5 * ca + 8.0 * 0.866 * normal(&mut day_rng);
            [0.1 + 0.87 / (1.0 + (-1.7 * (z + 0.4)).exp()), ta, ra, ca]
        })
        .collect();
    let phi = (-period_s / 5400.0).exp();
    let mut flicker = 0.0;
    let mut data = Vec::with_capacity(steps * 4);
    for j in 0..steps {
        let t_h = 1.0 + j as f64 * period_s / 3600.0; // hours since 8 Feb 00:00 local
        let day = (t_h / 24.0).floor();
        let clock = t_h - 24.0 * day;
        let doy = FIRST_DOY + day;
        let k_day = days[day as usize + 1][0];
        // Radiation.
        let (decl, offset) = sun(doy);
        let omega = (15.0 * (clock - offset - 12.0)).to_radians();
        let lat = LAT_DEG.to_radians();
        let sin_el = lat.sin() * decl.sin() + lat.cos() * decl.cos() * omega.cos();
        flicker = phi * flicker + (1.0 - phi * phi).sqrt() * normal(&mut step_rng);
        let s = 0.45 * (1.0 - k_day);
        let index = (k_day * (s * flicker - 0.5 * s * s).exp()).min(1.05);
        let rad = if sin_el > 0.0 {
            1098.0 * sin_el * (-0.057 / sin_el).exp() * index
        } else {
            0.0
        };
        // Daily values at noon, linearly interpolated in between.
        let x = (t_h - 12.0) / 24.0 + 1.0;
        let (i, f) = (x.floor() as usize, x - x.floor());
        let lerp = |c: usize| days[i][c] + f * (days[i + 1][c] - days[i][c]);
        let k = lerp(0);
        // Diurnal shape: −1 at sunrise, +1 at 15:00, half-cosines in between.
        let rise = sunrise_hour(doy);
        let shape = if clock < rise {
            (PI * (clock + 24.0 - T_MAX_HOUR) / (rise + 24.0 - T_MAX_HOUR)).cos()
        } else if clock < T_MAX_HOUR {
            -(PI * (clock - rise) / (T_MAX_HOUR - rise)).cos()
        } else {
            let next = sunrise_hour(doy + 1.0) + 24.0;
            (PI * (clock - T_MAX_HOUR) / (next - T_MAX_HOUR)).cos()
        };
        // Seasonal mean: an annual cycle, coldest on 20 January, ≈ 6.4 °C on 8 February
        // and ≈ 9.3 °C on 20 March (mild, like Venlo 2014).
        let season = 13.0 - 7.0 * (TAU * (FIRST_DOY + t_h / 24.0 - 20.0) / 365.0).cos();
        let temp = season + lerp(1) + (0.8 + 2.4 * k) * shape;
        let rh = (78.0 - 6.0 * (k - 0.55) + lerp(2) - (2.0 + 12.0 * k) * shape).clamp(30.0, 100.0);
        let ppm = 425.0 + lerp(3) - 10.0 * shape;
        data.extend([
            rad,
            co2_ppm_to_kgm3(ppm, temp),
            temp,
            rh_to_vapour_kgm3(rh, temp),
        ]);
    }
    WeatherFrame {
        source: format!("built-in season (seed {seed})"),
        period_s,
        columns: canonical(),
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use WeatherError as E;

    /// The project's shared data folder, relative to the crate root.
    const SHARED_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared");

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

    fn venlo() -> Weather {
        let p = Path::new(SHARED_DIR).join("data/venlo2014_30min_model_units.csv");
        let f = load_csv(&p, &canonical(), 300.0).expect("load Venlo");
        f.select(&canonical(), 1394, 1920 + 12).expect("select")
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
    fn shared_venlo_first_step_and_period() {
        let w = venlo();
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
    fn shared_venlo_vs_builtin_season() {
        let v = season_stats(&venlo(), 40);
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
