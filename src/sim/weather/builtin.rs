//! The built-in season: a seeded synthetic Dutch late-winter season (sun from the
//! site's geometry, clouds, a daily temperature cycle), for runs without a weather file.

use super::{canonical, co2_ppm_to_kgm3, rh_to_vapour_kgm3, WeatherFrame};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::{PI, TAU};

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
