//! Soft-band penalties as the season metrics score them: linear outside the band.

use crate::lang::model::SoftBand;

/// One band's penalty on one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StagePenalty {
    /// Index of the penalised output.
    pub output: usize,
    pub value: f64,
    /// Whether the output is outside the band.
    pub outside: bool,
}

/// `w⁻·max(0, lo − y) + w⁺·max(0, y − hi)` with the band's scoring bounds.
pub fn band_penalty(band: &SoftBand, y: f64) -> f64 {
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
