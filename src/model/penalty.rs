//! Soft-band penalties as the season metrics score them: linear outside the band.

use crate::lang::model::SoftBand;

/// One band's penalty on one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StagePenalty {
    /// Index of the penalised output.
    pub output: usize,
    /// The penalty, in the model's units of money; 0 inside the band.
    pub value: f64,
    /// Whether the output is outside the band.
    pub outside: bool,
}

/// `w⁻·max(0, lo − y) + w⁺·max(0, y − hi)` with the band's scoring bounds; NaN when `y`
/// is NaN (a number that is not one is never inside a band, and its penalty is unknown:
/// `f64::max` alone would call it 0).
///
/// ```
/// use ghm::lang::model::SoftBand;
/// use ghm::model::band_penalty;
///
/// // 10 °C to 20 °C; 2 per degree below, 5 per degree above (planned within 11 to 19).
/// let band = SoftBand {
///     output: 0,
///     lower: 10.0,
///     upper: 20.0,
///     weight_below: 2.0,
///     weight_above: 5.0,
///     plan_lower: 11.0,
///     plan_upper: 19.0,
///     description: String::new(),
/// };
/// assert_eq!(band_penalty(&band, 15.0), 0.0);
/// assert_eq!(band_penalty(&band, 19.5), 0.0); // outside the plan, inside the band
/// assert_eq!(band_penalty(&band, 7.0), 6.0);
/// assert_eq!(band_penalty(&band, 21.0), 5.0);
/// let ceiling = SoftBand { lower: f64::NEG_INFINITY, ..band };
/// assert_eq!(band_penalty(&ceiling, -1e9), 0.0);
/// assert!(band_penalty(&ceiling, f64::NAN).is_nan());
/// ```
pub fn band_penalty(band: &SoftBand, y: f64) -> f64 {
    if y.is_nan() {
        return f64::NAN;
    }
    let below = if band.lower.is_finite() {
        (band.lower - y).max(0.0)
    } else {
        0.0
    };
    let above = if band.upper.is_finite() {
        (y - band.upper).max(0.0)
    } else {
        0.0
    };
    band.weight_below * below + band.weight_above * above
}
