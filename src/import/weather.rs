//! GreenLight's weather CSV into a ghm weather CSV.
//!
//! GreenLight's files (e.g. `Bleiswijk_from_20091020.csv`) are comma separated, often
//! Windows-1252 encoded (`°` is the byte 0xB0), with header rows before the data: the
//! column names, then (GreenLight's reading, checked on the Bleiswijk file) a row of
//! descriptions and a row of units; the first row whose every cell is a number starts the
//! data. The time column is named exactly `Time`, in seconds since the start of the data.
//!
//! The ghm file has one header row: `time_s` (GreenLight's `Time`, unchanged: seconds
//! since the start of the data, not since 1 January) and the other columns under their
//! GreenLight names, which the imported model's `disturbance … column "…"` statements
//! name. Numbers are copied as written.

use crate::import::ImportError;
use std::path::Path;

/// The name of GreenLight's time column.
pub const GREENLIGHT_TIME: &str = "Time";

/// Characters of Windows-1252 for the bytes 0x80–0x9F (the rest of the upper half is
/// Latin-1); `None` where the code page defines nothing.
const CP1252_HIGH: [Option<char>; 32] = [
    Some('€'),
    None,
    Some('‚'),
    Some('ƒ'),
    Some('„'),
    Some('…'),
    Some('†'),
    Some('‡'),
    Some('ˆ'),
    Some('‰'),
    Some('Š'),
    Some('‹'),
    Some('Œ'),
    None,
    Some('Ž'),
    None,
    None,
    Some('‘'),
    Some('’'),
    Some('“'),
    Some('”'),
    Some('•'),
    Some('–'),
    Some('—'),
    Some('˜'),
    Some('™'),
    Some('š'),
    Some('›'),
    Some('œ'),
    None,
    Some('ž'),
    Some('Ÿ'),
];

/// Decodes Windows-1252 bytes (a byte the code page leaves undefined becomes U+FFFD).
///
/// ```
/// use ghm::import::weather::decode_cp1252;
/// assert_eq!(decode_cp1252(b"\xb0C, m\xb2, \xb5mol, \x80"), "°C, m², µmol, €");
/// ```
pub fn decode_cp1252(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|&b| match b {
            0x00..=0x7F => char::from(b),
            0x80..=0x9F => CP1252_HIGH[usize::from(b - 0x80)].unwrap_or('\u{FFFD}'),
            _ => char::from(b), // 0xA0–0xFF: the same code points as Latin-1
        })
        .collect()
}

/// The text of a file as GreenLight reads it: UTF-8 if it is valid UTF-8, else
/// Windows-1252.
pub fn decode_text(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(s) => s.strip_prefix('\u{feff}').unwrap_or(s).to_string(),
        Err(_) => decode_cp1252(bytes),
    }
}

/// One column of a GreenLight weather file.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    /// Its name (first header row).
    pub name: String,
    /// Its description (second header row, when there are three or more).
    pub description: String,
    /// Its unit (third header row, when there are three or more).
    pub unit: String,
}

/// A GreenLight weather file, read.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The columns, `Time` included, in file order.
    pub columns: Vec<Column>,
    /// The data rows, each cell as written (trimmed), all numbers.
    pub rows: Vec<Vec<String>>,
    /// The position of `Time` in `columns`.
    pub time: usize,
    /// The file's line (1-based) of the first data row.
    pub first_line: usize,
}

impl Table {
    /// The column names other than `Time`.
    pub fn data_columns(&self) -> Vec<String> {
        self.columns
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != self.time)
            .map(|(_, c)| c.name.clone())
            .collect()
    }

    /// The value of column `name` in data row `row`.
    pub fn value(&self, row: usize, name: &str) -> Option<f64> {
        let i = self.columns.iter().position(|c| c.name == name)?;
        self.rows.get(row)?.get(i)?.parse().ok()
    }

    /// The rows at every `step_s` seconds from the first (the model's control period, so
    /// that the weather has one row per step, held over it); `Err` with the line of the
    /// first row that breaks the pattern: a gap, or times that never land on a step.
    pub fn every(mut self, step_s: f64, path: &Path) -> Result<Table, ImportError> {
        let times: Vec<f64> = self
            .rows
            .iter()
            .map(|row| row[self.time].parse().unwrap_or(f64::NAN))
            .collect();
        let Some(&first) = times.first() else {
            return Ok(self);
        };
        let mut kept = Vec::with_capacity(self.rows.len());
        let mut next = first;
        for (i, (row, &t)) in self.rows.into_iter().zip(&times).enumerate() {
            let tolerance = 1e-6 * step_s.max(1.0);
            if (t - next).abs() <= tolerance {
                kept.push(row);
                next += step_s;
            } else if t > next + tolerance {
                return Err(ImportError::Weather {
                    path: path.to_path_buf(),
                    line: self.first_line + i,
                    message: format!(
                        "no row at {next} s: the rows must fall on every {step_s} s step \
                         (--step) from the first at {first} s"
                    ),
                });
            }
        }
        self.rows = kept;
        Ok(self)
    }

    /// The ghm weather CSV: `time_s`, then the other columns in file order.
    pub fn to_ghm_csv(&self) -> String {
        let mut out = String::with_capacity(self.rows.len() * 16 * self.columns.len());
        let order: Vec<usize> = std::iter::once(self.time)
            .chain((0..self.columns.len()).filter(|&i| i != self.time))
            .collect();
        let header: Vec<&str> = order
            .iter()
            .map(|&i| {
                if i == self.time {
                    crate::lang::model::CLOCK_COLUMN
                } else {
                    self.columns[i].name.as_str()
                }
            })
            .collect();
        out.push_str(&header.join(","));
        out.push('\n');
        for row in &self.rows {
            let cells: Vec<&str> = order.iter().map(|&i| row[i].as_str()).collect();
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        out
    }
}

fn is_number(cell: &str) -> bool {
    cell.trim().parse::<f64>().is_ok_and(f64::is_finite)
}

/// Reads a GreenLight weather CSV.
pub fn read(path: &Path) -> Result<Table, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse(path, &decode_text(&bytes))
}

/// Parses the text of a GreenLight weather CSV (`path` is for messages).
pub fn parse(path: &Path, text: &str) -> Result<Table, ImportError> {
    let bad = |line: usize, message: String| ImportError::Weather {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut header_rows: Vec<Vec<String>> = Vec::new();
    let mut rows: Vec<Vec<String>> = Vec::new();
    for (i, record) in rdr.records().enumerate() {
        let line = i + 1;
        let record = record.map_err(|e| bad(line, e.to_string()))?;
        let cells: Vec<String> = record.iter().map(str::to_string).collect();
        if cells.iter().all(|c| c.is_empty()) {
            continue;
        }
        let numeric = cells.iter().all(|c| is_number(c));
        if rows.is_empty() && !numeric {
            header_rows.push(cells);
            continue;
        }
        let width = header_rows.first().map_or(0, Vec::len);
        if cells.len() != width {
            return Err(bad(
                line,
                format!(
                    "{} cells, but the header names {width} columns",
                    cells.len()
                ),
            ));
        }
        if let Some(j) = cells.iter().position(|c| !is_number(c)) {
            let name = header_rows
                .first()
                .and_then(|h| h.get(j))
                .cloned()
                .unwrap_or_default();
            return Err(bad(
                line,
                format!("column `{name}`: `{}` is not a finite number", cells[j]),
            ));
        }
        rows.push(cells);
    }
    let Some(names) = header_rows.first() else {
        return Err(bad(1, "no header row of column names".into()));
    };
    if rows.is_empty() {
        return Err(bad(
            header_rows.len(),
            "no data rows (rows of numbers only)".into(),
        ));
    }
    let (descriptions, units) = if header_rows.len() >= 3 {
        (Some(&header_rows[1]), Some(&header_rows[2]))
    } else {
        (header_rows.get(1), None)
    };
    let cell = |row: Option<&Vec<String>>, i: usize| {
        row.and_then(|r| r.get(i)).cloned().unwrap_or_default()
    };
    let mut columns = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        if name.is_empty() {
            return Err(bad(1, format!("column {} has no name", i + 1)));
        }
        if names[..i].contains(name) {
            return Err(bad(1, format!("column `{name}` appears twice")));
        }
        if name == crate::lang::model::CLOCK_COLUMN {
            return Err(bad(
                1,
                format!(
                    "a column is named `{name}`, the name the ghm file gives GreenLight's `Time`"
                ),
            ));
        }
        columns.push(Column {
            name: name.clone(),
            description: cell(descriptions, i),
            unit: cell(units, i),
        });
    }
    let time = names
        .iter()
        .position(|n| n == GREENLIGHT_TIME)
        .ok_or_else(|| {
            bad(
                1,
                format!("no `{GREENLIGHT_TIME}` column (seconds since the start of the data)"),
            )
        })?;
    let first_data_line = header_rows.len() + 1;
    let mut last = f64::NEG_INFINITY;
    for (k, row) in rows.iter().enumerate() {
        let t: f64 = row[time].parse().unwrap_or(f64::NAN);
        if t <= last {
            return Err(bad(
                first_data_line + k,
                format!("`Time` {t} does not increase (previous row: {last})"),
            ));
        }
        last = t;
    }
    Ok(Table {
        columns,
        rows,
        time,
        first_line: first_data_line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cp1252_maps_the_upper_half() {
        assert_eq!(
            decode_cp1252(b"\xb0C \xb2 \xb3 \xb5 \xe9 \x93x\x94 \x96"),
            "°C ² ³ µ é “x” –"
        );
        assert_eq!(decode_cp1252(b"\x81"), "\u{FFFD}");
        assert_eq!(decode_cp1252(b"plain"), "plain");
        // UTF-8 is read as UTF-8, other bytes as Windows-1252.
        assert_eq!(decode_text("°C".as_bytes()), "°C");
        assert_eq!(decode_text(b"\xb0C"), "°C");
    }

    /// One row per step of the model: every second row of a 60 s file for a 120 s step;
    /// a step no row falls on is refused with its line.
    #[test]
    fn rows_are_kept_at_every_step() {
        let text = "Time,a\n0,1\n60,2\n120,3\n180,4\n240,5\n";
        let t = parse(Path::new("w.csv"), text).unwrap();
        let every = t.clone().every(120.0, Path::new("w.csv")).unwrap();
        assert_eq!(every.to_ghm_csv(), "time_s,a\n0,1\n120,3\n240,5\n");
        assert_eq!(t.clone().every(60.0, Path::new("w.csv")).unwrap(), t);
        let e = t.every(90.0, Path::new("w.csv")).unwrap_err().to_string();
        assert_eq!(
            e,
            "w.csv: line 4: no row at 90 s: the rows must fall on every 90 s step (--step) \
             from the first at 0 s"
        );
    }

    #[test]
    fn three_header_rows_and_data() {
        let bytes = b"Time,tOut,hElevation\r\nTime since start,Outdoor temperature,Elevation\r\ns,\xb0C,m\r\n0,6.8000001,-5\r\n300,6.8,-5\r\n";
        let t = parse(Path::new("w.csv"), &decode_text(bytes)).unwrap();
        assert_eq!(t.columns[1].unit, "°C");
        assert_eq!(t.columns[1].description, "Outdoor temperature");
        assert_eq!(t.data_columns(), ["tOut", "hElevation"]);
        assert_eq!(t.value(0, "tOut"), Some(6.8000001));
        assert_eq!(
            t.to_ghm_csv(),
            "time_s,tOut,hElevation\n0,6.8000001,-5\n300,6.8,-5\n"
        );
    }

    #[test]
    fn time_column_need_not_come_first() {
        let t = parse(Path::new("w.csv"), "a,Time\n1,0\n2,60\n").unwrap();
        assert_eq!(t.to_ghm_csv(), "time_s,a\n0,1\n60,2\n");
    }

    #[test]
    fn errors_name_the_file_line_and_column() {
        let e = parse(Path::new("w.csv"), "Time,a\ns,-\n0,1\n300,x\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "w.csv: line 4: column `a`: `x` is not a finite number"
        );
        let e = parse(Path::new("w.csv"), "t,a\n0,1\n").unwrap_err();
        assert!(e.to_string().contains("no `Time` column"), "{e}");
        let e = parse(Path::new("w.csv"), "Time,a\n0,1\n0,2\n").unwrap_err();
        assert!(
            e.to_string().contains("line 3: `Time` 0 does not increase"),
            "{e}"
        );
        let e = parse(Path::new("w.csv"), "Time,a\n0,1,2\n").unwrap_err();
        assert!(e.to_string().contains("3 cells"), "{e}");
        let e = parse(Path::new("w.csv"), "Time,a\n").unwrap_err();
        assert!(e.to_string().contains("no data rows"), "{e}");
    }
}
