//! Physical ranges of the weather columns ghm knows by name: a value outside them is a
//! broken file (a sign flipped, a unit mixed up, a sensor fault), never weather.
//!
//! Only these columns are checked; any other column (a model's own disturbance, the
//! inputs of `ghm simulate --inputs FILE.csv`) is only required to be finite. The table is
//! documented in `docs/weather.md`.

use crate::sim::weather::{CO2_DENSITY, RADIATION, TEMPERATURE, VAPOUR_DENSITY};

/// The range of one named column, with its unit and why the bounds are where they are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicalRange {
    /// The column name.
    pub column: &'static str,
    /// Smallest value accepted.
    pub lower: f64,
    /// Largest value accepted.
    pub upper: f64,
    /// The unit, for messages.
    pub unit: &'static str,
}

/// Outdoor relative humidity in the Venlo file, %.
pub const RELATIVE_HUMIDITY: &str = "rh_out_pct";
/// Outdoor CO2 mole fraction in the Venlo file, ppm.
pub const CO2_PPM: &str = "co2_out_ppm";

/// The ranges: global radiation up to 1 500 W m⁻² (the solar constant is 1 361, cloud
/// edges raise ground values a little above it), temperature from −90 °C to 60 °C (the
/// records are −89.2 and 56.7), vapour density up to 0.1 kg m⁻³ (saturation at 50 °C is
/// 0.083), relative humidity 0–100 %, outdoor CO2 up to 5 000 ppm (0.01 kg m⁻³).
pub const RANGES: &[PhysicalRange] = &[
    PhysicalRange {
        column: RADIATION,
        lower: 0.0,
        upper: 1500.0,
        unit: "W m^-2",
    },
    PhysicalRange {
        column: TEMPERATURE,
        lower: -90.0,
        upper: 60.0,
        unit: "°C",
    },
    PhysicalRange {
        column: VAPOUR_DENSITY,
        lower: 0.0,
        upper: 0.1,
        unit: "kg m^-3",
    },
    PhysicalRange {
        column: CO2_DENSITY,
        lower: 0.0,
        upper: 0.01,
        unit: "kg m^-3",
    },
    PhysicalRange {
        column: RELATIVE_HUMIDITY,
        lower: 0.0,
        upper: 100.0,
        unit: "%",
    },
    PhysicalRange {
        column: CO2_PPM,
        lower: 0.0,
        upper: 5000.0,
        unit: "ppm",
    },
];

/// The range of `column`, if ghm knows it.
///
/// ```
/// use ghm::sim::physical::range_of;
///
/// let rad = range_of("rad_Wm2").unwrap();
/// assert!(rad.contains(800.0) && !rad.contains(-500.0));
/// assert!(!range_of("rh_out_pct").unwrap().contains(200.0));
/// assert!(range_of("my_column").is_none());
/// ```
pub fn range_of(column: &str) -> Option<PhysicalRange> {
    RANGES.iter().find(|r| r.column == column).copied()
}

impl PhysicalRange {
    /// Whether `v` lies in `[lower, upper]` (NaN never does).
    pub fn contains(&self, v: f64) -> bool {
        v >= self.lower && v <= self.upper
    }
}
