//! The paper's Venlo 2014 weather, from the file its authors published, into the ghm
//! weather CSV the lettuce studies read (`venlo2014_30min_model_units.csv`).
//!
//! The measurements (WUR Glas, Bleiswijk, 10 January to 29 November 2014, every 5 minutes)
//! are published in two forms, whose repositories state no licence, so ghm does not ship
//! them:
//!
//! * `outdoorWeatherWurGlas2014.mat` (`BartvLaatum/RL-SMPC`, `weather/`): a MAT-file
//!   (level 5, compressed or not) holding one numeric matrix `d` of six columns: MATLAB
//!   datenum (days), global radiation (W m⁻²), temperature (°C), relative humidity (%), wind
//!   speed (m s⁻¹) and CO₂ (ppm);
//! * `outdoorWeatherWurGlas2014.csv` (the paper's `Weather Data/`, RL-SMPC's `weather/`):
//!   the same six columns without a header, time in seconds since the first row (a time
//!   step below one is read as days).
//!
//! [`convert`] keeps the rows on the model's period (every 6th at 30 minutes: the rows whose
//! time is a multiple of it, as the paper's code picks them; nothing is averaged) and adds
//! the model's units: CO₂ and vapour density at the row's temperature
//! ([`crate::sim::weather`]'s conversions). `docs/data.md` says how to get the file.

use crate::import::ImportError;
use crate::sim::weather::{co2_ppm_to_kgm3, rh_to_vapour_kgm3, VENLO_FILE};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The header of the converted file: the model's four disturbances (radiation, CO₂
/// density, temperature, vapour density) and the raw CO₂ and humidity for reference.
pub const HEADER: [&str; 8] = [
    "row",
    "time_s",
    "rad_Wm2",
    "co2_out_kgm3",
    "temp_out_C",
    "vapdens_out_kgm3",
    "co2_out_ppm",
    "rh_out_pct",
];

/// Seconds in a day (MATLAB datenums count days).
const DAY_S: f64 = 86_400.0;

/// One measurement of the published file.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Seconds since the first row.
    pub time_s: f64,
    /// Global radiation, W m⁻².
    pub rad_wm2: f64,
    /// Temperature, °C.
    pub temp_c: f64,
    /// Relative humidity, %.
    pub rh_pct: f64,
    /// CO₂, ppm.
    pub co2_ppm: f64,
}

/// Reads the published file, a `.mat` or a headerless `.csv` (by its extension).
pub fn read(path: &Path) -> Result<Vec<Sample>, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let is_mat = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mat"));
    if is_mat {
        let matrix = mat::read_matrix(&bytes, "d").map_err(|message| format(path, message))?;
        samples_from_mat(path, &matrix)
    } else {
        samples_from_csv(path, &bytes)
    }
}

/// The rows of `samples` whose time is a multiple of `period_s`, in the model's units,
/// as the CSV text of [`HEADER`] (numbers in their shortest round-trip form).
pub fn convert(path: &Path, samples: &[Sample], period_s: f64) -> Result<String, ImportError> {
    if !(period_s.is_finite() && period_s > 0.0) {
        return Err(ImportError::Argument(format!(
            "--period must be a positive number of seconds, not {period_s}"
        )));
    }
    check_regular(path, samples, period_s)?;
    let mut text = HEADER.join(",");
    text.push('\n');
    let kept = samples.iter().filter(|s| (s.time_s % period_s) == 0.0);
    for (row, s) in kept.enumerate() {
        let values = [
            s.rad_wm2,
            co2_ppm_to_kgm3(s.co2_ppm, s.temp_c),
            s.temp_c,
            rh_to_vapour_kgm3(s.rh_pct, s.temp_c),
            s.co2_ppm,
            s.rh_pct,
        ];
        text.push_str(&format!("{row},{}", s.time_s));
        for v in values {
            text.push_str(&format!(",{v}"));
        }
        text.push('\n');
    }
    Ok(text)
}

/// Reads `source`, converts it at `period_s` and writes `DIR/`[`VENLO_FILE`]; returns the
/// path written and the number of rows.
pub fn import(source: &Path, period_s: f64, dir: &Path) -> Result<(PathBuf, usize), ImportError> {
    let samples = read(source)?;
    let text = convert(source, &samples, period_s)?;
    let rows = text.lines().count() - 1;
    let out = dir.join(VENLO_FILE);
    let write = |e| ImportError::Write {
        path: out.clone(),
        source: e,
    };
    std::fs::create_dir_all(dir).map_err(write)?;
    std::fs::write(&out, text).map_err(write)?;
    Ok((out, rows))
}

fn format(path: &Path, message: String) -> ImportError {
    ImportError::Format {
        path: path.to_path_buf(),
        message,
    }
}

/// The samples of the `.mat`'s matrix: time from the datenums, rounded to the second.
fn samples_from_mat(path: &Path, m: &mat::Matrix) -> Result<Vec<Sample>, ImportError> {
    if m.cols != 6 || m.rows < 2 {
        return Err(format(
            path,
            format!(
                "`d` is {}×{}; the Venlo file holds rows of six columns (datenum, radiation, \
                 temperature, humidity, wind, CO₂)",
                m.rows, m.cols
            ),
        ));
    }
    let rows: Vec<[f64; 6]> = (0..m.rows)
        .map(|r| std::array::from_fn(|c| m.at(r, c)))
        .collect();
    Ok(samples(&rows, DAY_S))
}

/// The samples of rows of the six published columns, time counted from the first row in
/// seconds (`seconds_per_unit` of the file's time unit), rounded to the second.
fn samples(rows: &[[f64; 6]], seconds_per_unit: f64) -> Vec<Sample> {
    let first = rows[0][0];
    rows.iter()
        .map(|r| Sample {
            time_s: ((r[0] - first) * seconds_per_unit).round(),
            rad_wm2: r[1],
            temp_c: r[2],
            rh_pct: r[3],
            co2_ppm: r[5],
        })
        .collect()
}

/// The samples of the headerless CSV: six numbers a line, time in seconds (or in days
/// where its step is below one) since the first line.
fn samples_from_csv(path: &Path, bytes: &[u8]) -> Result<Vec<Sample>, ImportError> {
    let text = std::str::from_utf8(bytes).map_err(|_| {
        format(
            path,
            "not text: expected six numbers a line, or a .mat file".into(),
        )
    })?;
    let mut rows: Vec<[f64; 6]> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let bad = |message: String| ImportError::Weather {
            path: path.to_path_buf(),
            line: i + 1,
            message,
        };
        if cells.len() != 6 {
            return Err(bad(format!(
                "{} columns; the Venlo file has six (time, radiation, temperature, humidity, \
                 wind, CO₂) and no header",
                cells.len()
            )));
        }
        let mut row = [0.0; 6];
        for (v, cell) in row.iter_mut().zip(&cells) {
            *v = cell
                .parse()
                .map_err(|_| bad(format!("`{cell}` is not a number")))?;
        }
        rows.push(row);
    }
    if rows.len() < 2 {
        return Err(format(path, "fewer than two rows".into()));
    }
    let step = rows[1][0] - rows[0][0];
    let seconds_per_unit = if step > 0.0 && step < 1.0 { DAY_S } else { 1.0 };
    Ok(samples(&rows, seconds_per_unit))
}

/// The samples must be evenly spaced, and the period a multiple of their step, so that
/// keeping every n-th row is the period.
fn check_regular(path: &Path, samples: &[Sample], period_s: f64) -> Result<(), ImportError> {
    let [a, b, ..] = samples else {
        return Err(format(path, "fewer than two rows".into()));
    };
    let step = b.time_s - a.time_s;
    if step <= 0.0 || period_s % step != 0.0 {
        return Err(format(
            path,
            format!(
                "the rows are {step} s apart; the period {period_s} s must be a positive \
                 multiple of that"
            ),
        ));
    }
    for (i, pair) in samples.windows(2).enumerate() {
        if pair[1].time_s - pair[0].time_s != step {
            return Err(ImportError::Weather {
                path: path.to_path_buf(),
                line: i + 2,
                message: format!(
                    "a gap: {} s after the row before, where the file steps {step} s",
                    pair[1].time_s - pair[0].time_s
                ),
            });
        }
    }
    Ok(())
}

/// A reader of MAT-files, level 5 (MATLAB v5 to v7.2, and what SciPy writes): just enough
/// to take one real numeric matrix by name, from plain or zlib-compressed elements, in
/// either byte order. The format is MathWorks' "MAT-File Format" (level 5, chapter 1).
pub mod mat {
    use super::Read;

    /// A real matrix, column-major as MATLAB stores it.
    #[derive(Debug, Clone, PartialEq)]
    pub struct Matrix {
        /// Rows.
        pub rows: usize,
        /// Columns.
        pub cols: usize,
        /// `rows × cols` values, column after column.
        pub data: Vec<f64>,
    }

    impl Matrix {
        /// The value at row `r`, column `c`.
        pub fn at(&self, r: usize, c: usize) -> f64 {
            self.data[c * self.rows + r]
        }
    }

    // Data types of the format (table 1-1).
    const MI_INT8: u32 = 1;
    const MI_UINT8: u32 = 2;
    const MI_INT16: u32 = 3;
    const MI_UINT16: u32 = 4;
    const MI_INT32: u32 = 5;
    const MI_UINT32: u32 = 6;
    const MI_SINGLE: u32 = 7;
    const MI_DOUBLE: u32 = 9;
    const MI_INT64: u32 = 12;
    const MI_UINT64: u32 = 13;
    const MI_MATRIX: u32 = 14;
    const MI_COMPRESSED: u32 = 15;
    /// Array classes 6 (double) to 15 (uint64) are numeric.
    const NUMERIC_CLASSES: std::ops::RangeInclusive<u32> = 6..=15;
    const COMPLEX_FLAG: u32 = 0x0800;

    /// Byte order and a cursor over a buffer.
    struct Reader<'a> {
        bytes: &'a [u8],
        at: usize,
        big_endian: bool,
    }

    impl<'a> Reader<'a> {
        fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
            let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len());
            let end = end.ok_or_else(|| {
                format!(
                    "truncated: {n} bytes wanted at byte {} of {}",
                    self.at,
                    self.bytes.len()
                )
            })?;
            let s = &self.bytes[self.at..end];
            self.at = end;
            Ok(s)
        }

        fn u32(&mut self) -> Result<u32, String> {
            let b: [u8; 4] = self.take(4)?.try_into().expect("4 bytes");
            Ok(if self.big_endian {
                u32::from_be_bytes(b)
            } else {
                u32::from_le_bytes(b)
            })
        }

        /// One data element: its type and its bytes (a small element packs both in 8).
        fn element(&mut self) -> Result<(u32, &'a [u8]), String> {
            let first = self.u32()?;
            if first >> 16 != 0 {
                let (kind, n) = (first & 0xFFFF, (first >> 16) as usize);
                let body = self.take(4)?;
                return body
                    .get(..n)
                    .map(|b| (kind, b))
                    .ok_or_else(|| "a small data element longer than 4 bytes".to_string());
            }
            let n = self.u32()? as usize;
            let body = self.take(n)?;
            if first != MI_COMPRESSED {
                let pad = (8 - n % 8) % 8;
                self.take(pad.min(self.bytes.len() - self.at))?;
            }
            Ok((first, body))
        }

        fn done(&self) -> bool {
            self.at >= self.bytes.len()
        }
    }

    /// Reads the matrix named `name` (or, where no variable has that name, the only
    /// numeric matrix) of a MAT-file's bytes.
    pub fn read_matrix(bytes: &[u8], name: &str) -> Result<Matrix, String> {
        if bytes.len() < 128 || !bytes.starts_with(b"MATLAB 5.0 MAT-file") {
            return Err(
                "not a MAT-file of level 5 (MATLAB 5 to 7.2): its header is missing; \
                        MATLAB's v7.3 files are HDF5, save with -v7"
                    .into(),
            );
        }
        let big_endian = match &bytes[126..128] {
            b"IM" => false,
            b"MI" => true,
            _ => return Err("the header's byte order mark is neither IM nor MI".into()),
        };
        let mut top = Reader {
            bytes: &bytes[128..],
            at: 0,
            big_endian,
        };
        let mut found = Vec::new();
        while !top.done() {
            let (kind, body) = top.element()?;
            let variable = if kind == MI_COMPRESSED {
                let mut inflated = Vec::new();
                flate2::read::ZlibDecoder::new(body)
                    .read_to_end(&mut inflated)
                    .map_err(|e| format!("a compressed variable does not inflate: {e}"))?;
                let mut inner = Reader {
                    bytes: &inflated,
                    at: 0,
                    big_endian,
                };
                let (kind, body) = inner.element()?;
                variable(kind, body, big_endian)?
            } else {
                variable(kind, body, big_endian)?
            };
            found.extend(variable);
        }
        if let Some(i) = found.iter().position(|(n, _)| n == name) {
            return Ok(found.swap_remove(i).1);
        }
        match found.len() {
            1 => Ok(found.remove(0).1),
            0 => Err("no real numeric matrix in the file".into()),
            _ => {
                let names: Vec<&str> = found.iter().map(|(n, _)| n.as_str()).collect();
                Err(format!(
                    "no variable `{name}`, and several matrices to choose from: {}",
                    names.join(", ")
                ))
            }
        }
    }

    /// The name and values of a data element of type `kind`, where it is a real numeric
    /// 2-D matrix.
    fn variable(
        kind: u32,
        body: &[u8],
        big_endian: bool,
    ) -> Result<Option<(String, Matrix)>, String> {
        if kind == MI_MATRIX {
            matrix(body, big_endian)
        } else {
            Ok(None)
        }
    }

    /// A variable's name and values, where it is a real numeric 2-D matrix.
    fn matrix(body: &[u8], big_endian: bool) -> Result<Option<(String, Matrix)>, String> {
        let mut r = Reader {
            bytes: body,
            at: 0,
            big_endian,
        };
        let (_, flags) = r.element()?;
        let flags = numbers(MI_UINT32, flags, big_endian)?;
        let word = *flags.first().ok_or("array flags missing")? as u32;
        let class = word & 0xFF;
        if !NUMERIC_CLASSES.contains(&class) || word & COMPLEX_FLAG != 0 {
            return Ok(None);
        }
        let (dims_kind, dims) = r.element()?;
        let dims = numbers(dims_kind, dims, big_endian)?;
        let (_, name) = r.element()?;
        let name = String::from_utf8_lossy(name).into_owned();
        let [rows, cols] = dims[..] else {
            return Ok(None);
        };
        let (kind, real) = r.element()?;
        let data = numbers(kind, real, big_endian)?;
        let (rows, cols) = (rows as usize, cols as usize);
        if data.len() != rows * cols {
            return Err(format!(
                "`{name}` is {rows}×{cols} but holds {} values",
                data.len()
            ));
        }
        Ok(Some((name, Matrix { rows, cols, data })))
    }

    /// The numbers of an element of type `kind` (MATLAB stores a double matrix in the
    /// smallest type that holds its values exactly).
    fn numbers(kind: u32, b: &[u8], big_endian: bool) -> Result<Vec<f64>, String> {
        macro_rules! each {
            ($t:ty, $n:expr) => {
                b.chunks_exact($n)
                    .map(|c| {
                        let a: [u8; $n] = c.try_into().expect("chunk");
                        (if big_endian {
                            <$t>::from_be_bytes(a)
                        } else {
                            <$t>::from_le_bytes(a)
                        }) as f64
                    })
                    .collect()
            };
        }
        Ok(match kind {
            MI_INT8 => each!(i8, 1),
            MI_UINT8 => each!(u8, 1),
            MI_INT16 => each!(i16, 2),
            MI_UINT16 => each!(u16, 2),
            MI_INT32 => each!(i32, 4),
            MI_UINT32 => each!(u32, 4),
            MI_SINGLE => each!(f32, 4),
            MI_DOUBLE => each!(f64, 8),
            MI_INT64 => each!(i64, 8),
            MI_UINT64 => each!(u64, 8),
            other => {
                return Err(format!(
                    "a numeric element of type {other}, which is not numeric"
                ))
            }
        })
    }

    /// Writes `matrices` (name, rows, column-major values) as a little-endian level-5
    /// MAT-file, each compressed where `compress` is set: the excerpts the tests convert,
    /// and a way to hand a matrix to MATLAB or SciPy.
    pub fn write(matrices: &[(&str, usize, &[f64])], compress: bool) -> Vec<u8> {
        let mut out = Vec::with_capacity(128);
        let mut header = format!(
            "MATLAB 5.0 MAT-file, written by ghm {}",
            env!("CARGO_PKG_VERSION")
        )
        .into_bytes();
        header.resize(116, b' ');
        out.extend_from_slice(&header);
        out.extend_from_slice(&[0; 8]);
        out.extend_from_slice(&0x0100u16.to_le_bytes());
        out.extend_from_slice(b"IM");
        for &(name, rows, data) in matrices {
            let cols = data.len().checked_div(rows).unwrap_or(0);
            let mut body = Vec::new();
            element(
                &mut body,
                MI_UINT32,
                &[6u32.to_le_bytes(), 0u32.to_le_bytes()].concat(),
            );
            element(
                &mut body,
                MI_INT32,
                &[(rows as i32).to_le_bytes(), (cols as i32).to_le_bytes()].concat(),
            );
            element(&mut body, MI_INT8, name.as_bytes());
            let values: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
            element(&mut body, MI_DOUBLE, &values);
            let mut variable = Vec::new();
            element(&mut variable, MI_MATRIX, &body);
            if compress {
                let mut z =
                    flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
                std::io::Write::write_all(&mut z, &variable).expect("writes to memory");
                let z = z.finish().expect("writes to memory");
                out.extend_from_slice(&MI_COMPRESSED.to_le_bytes());
                out.extend_from_slice(&(z.len() as u32).to_le_bytes());
                out.extend_from_slice(&z);
            } else {
                out.extend_from_slice(&variable);
            }
        }
        out
    }

    /// Appends a data element: tag, bytes, padding to 8.
    fn element(out: &mut Vec<u8>, kind: u32, bytes: &[u8]) {
        out.extend_from_slice(&kind.to_le_bytes());
        out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(bytes);
        out.resize(out.len() + (8 - bytes.len() % 8) % 8, 0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A day of made-up 5-minute weather: datenum, radiation, temperature, humidity, wind,
    /// CO₂, column-major, with values that no other column shares.
    fn excerpt(rows: usize) -> Vec<f64> {
        let start = 735_609.0; // 10 January 2014
        let columns: [Box<dyn Fn(usize) -> f64>; 6] = [
            Box::new(|r| start + r as f64 * 300.0 / DAY_S),
            Box::new(|r| (r as f64 * 7.5).max(0.0)),
            Box::new(|r| 5.0 + 0.01 * r as f64),
            Box::new(|r| 80.0 - 0.1 * r as f64),
            Box::new(|_| 3.0),
            Box::new(|r| 400.0 + 0.5 * r as f64),
        ];
        columns.iter().flat_map(|f| (0..rows).map(f)).collect()
    }

    fn temp_file(name: &str, bytes: &[u8]) -> PathBuf {
        let p = std::env::temp_dir().join(format!("ghm_venlo_{}_{name}", std::process::id()));
        std::fs::write(&p, bytes).expect("write temp file");
        p
    }

    fn parse(text: &str) -> Vec<Vec<f64>> {
        text.lines()
            .skip(1)
            .map(|l| l.split(',').map(|c| c.parse().expect("a number")).collect())
            .collect()
    }

    #[test]
    fn a_mat_excerpt_becomes_every_sixth_row_in_model_units() {
        let data = excerpt(24);
        for compress in [false, true] {
            let path = temp_file(
                &format!("excerpt_{compress}.mat"),
                &mat::write(&[("d", 24, &data)], compress),
            );
            let samples = read(&path).expect("reads");
            let rows = parse(&convert(&path, &samples, 1800.0).expect("converts"));
            std::fs::remove_file(&path).ok();
            assert_eq!(rows.len(), 4, "24 five-minute rows are 4 half hours");
            for (k, row) in rows.iter().enumerate() {
                let r = 6 * k;
                let (t, rh, ppm) = (data[48 + r], data[72 + r], data[120 + r]);
                assert_eq!(row[0], k as f64);
                assert_eq!(row[1], 1800.0 * k as f64);
                assert_eq!(row[2], data[24 + r]);
                assert_eq!(row[3], co2_ppm_to_kgm3(ppm, t));
                assert_eq!(row[4], t);
                assert_eq!(row[5], rh_to_vapour_kgm3(rh, t));
                assert_eq!((row[6], row[7]), (ppm, rh));
            }
        }
    }

    #[test]
    fn the_csv_form_converts_to_the_same_file() {
        let data = excerpt(24);
        let mat = temp_file("same.mat", &mat::write(&[("d", 24, &data)], true));
        let from_mat = convert(&mat, &read(&mat).expect("mat"), 1800.0).expect("mat converts");
        // The published CSV: seconds since the first row, no header.
        let text: String = (0..24)
            .map(|r| {
                let row: Vec<String> = (1..6).map(|c| data[c * 24 + r].to_string()).collect();
                format!("{},{}\n", 300 * r, row.join(","))
            })
            .collect();
        let csv = temp_file("same.csv", text.as_bytes());
        let from_csv = convert(&csv, &read(&csv).expect("csv"), 1800.0).expect("csv converts");
        std::fs::remove_file(&mat).ok();
        std::fs::remove_file(&csv).ok();
        assert_eq!(from_csv, from_mat);
    }

    #[test]
    fn bad_files_say_what_is_wrong_and_where() {
        let cases: [(&str, Vec<u8>, &str); 5] = [
            ("a.mat", b"not a mat file".to_vec(), "not a MAT-file"),
            (
                "b.mat",
                mat::write(&[("d", 2, &[1.0, 2.0, 3.0, 4.0])], false),
                "is 2×2",
            ),
            (
                "c.csv",
                b"0,1,2,3,4,5\n300,1,2,3,4\n".to_vec(),
                "line 2: 5 columns",
            ),
            (
                "d.csv",
                b"0,1,2,3,4,5\n300,1,x,3,4,5\n".to_vec(),
                "`x` is not a number",
            ),
            (
                "e.csv",
                b"0,1,2,3,4,5\n300,1,2,3,4,5\n900,1,2,3,4,5\n".to_vec(),
                "line 3: a gap: 600 s",
            ),
        ];
        for (name, bytes, wanted) in cases {
            let path = temp_file(name, &bytes);
            let err = read(&path)
                .and_then(|s| convert(&path, &s, 1800.0))
                .expect_err(name)
                .to_string();
            std::fs::remove_file(&path).ok();
            assert!(err.contains(wanted), "{name}: {err}");
            assert!(err.contains(name), "{name} names the file: {err}");
        }
    }

    #[test]
    fn the_matrix_is_found_by_name_among_others() {
        let bytes = mat::write(&[("t", 1, &[1.0]), ("d", 2, &[1.0, 2.0, 3.0, 4.0])], true);
        let m = mat::read_matrix(&bytes, "d").expect("reads");
        assert_eq!((m.rows, m.cols, m.at(1, 1)), (2, 2, 4.0));
        let err = mat::read_matrix(&bytes, "x").expect_err("two candidates");
        assert!(err.contains("t, d"), "{err}");
    }

    /// The conversion against the reference file of the shared data folder: an excerpt of
    /// its 5-minute file (the `.mat`'s values to 10 significant digits) written as a
    /// MAT-file converts to the rows of its 30-minute file, to those 10 digits.
    #[test]
    fn venlo_excerpt_converts_to_the_reference_rows() {
        let test = "venlo_excerpt_converts_to_the_reference_rows";
        let (Some(raw), Some(reference)) = (
            crate::sim::test_data::file("venlo2014_5min_raw.csv", test),
            crate::sim::test_data::file(VENLO_FILE, test),
        ) else {
            return;
        };
        let rows = 6 * 96; // two days
        let raw = std::fs::read_to_string(raw).expect("the 5-minute file reads");
        let lines: Vec<Vec<f64>> = raw
            .lines()
            .skip(1)
            .take(rows)
            .map(|l| l.split(',').map(|c| c.parse().expect("number")).collect())
            .collect();
        // time_s, datenum, rad, temp, rh, wind, co2 → the .mat's six columns.
        let data: Vec<f64> = (1..7)
            .flat_map(|c| lines.iter().map(move |l| l[c]))
            .collect();
        let path = temp_file("shared.mat", &mat::write(&[("d", rows, &data)], true));
        let converted = convert(&path, &read(&path).expect("reads"), 1800.0).expect("converts");
        std::fs::remove_file(&path).ok();
        let want = std::fs::read_to_string(reference).expect("the 30-minute file reads");
        assert_eq!(converted.lines().next(), want.lines().next(), "the header");
        let (got, want) = (parse(&converted), parse(&want));
        assert_eq!(got.len(), 96);
        for (g, w) in got.iter().zip(&want) {
            for (a, b) in g.iter().zip(w) {
                assert!((a - b).abs() <= 1e-8 * b.abs(), "row {}: {a} vs {b}", g[0]);
            }
        }
    }
}
