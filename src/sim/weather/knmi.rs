//! Weather from KNMI hourly station data ("uurgegevens"): hourly sums and means turned
//! into the model's period by interpolation, in model units.

use super::csv_columns::{check_step, parse_cell};
use super::{canonical, co2_ppm_to_kgm3, positions, rh_to_vapour_kgm3, WeatherError, WeatherFrame};
use std::path::Path;

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
