//! Weather from a CSV file with named columns (the Venlo 2014 data, or any file with the
//! canonical column names), checked cell by cell with file, line and column in every error.

use super::{positions, WeatherError, WeatherFrame, TIME};
use crate::sim::physical::range_of;
use std::path::Path;

/// Parses one numeric cell; errors name file, 1-based line and column.
pub(super) fn parse_cell(
    path: &Path,
    row: u64,
    column: &str,
    text: &str,
) -> Result<f64, WeatherError> {
    // The path and the column are copied into an error only: a weather file has hundreds
    // of thousands of cells.
    let (path_buf, column_name) = (|| path.to_path_buf(), || column.to_string());
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => match range_of(column) {
            Some(r) if !r.contains(v) => Err(WeatherError::OutOfRange {
                path: path_buf(),
                row,
                column: column_name(),
                value: v,
                lower: r.lower,
                upper: r.upper,
                unit: r.unit,
            }),
            _ => Ok(v),
        },
        Ok(_) => Err(WeatherError::NotFinite {
            path: path_buf(),
            row,
            column: column_name(),
        }),
        Err(_) => Err(WeatherError::NotNumeric {
            path: path_buf(),
            row,
            column: column_name(),
            text: text.into(),
        }),
    }
}

/// Checks the time step ending at `row` against the first step (rel. tolerance 1e-6).
pub(super) fn check_step(
    path: &Path,
    row: u64,
    expected: f64,
    found: f64,
) -> Result<(), WeatherError> {
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
