//! One model's table as `ghm report` builds it from the study's jobs: a line per controller
//! and horizon, with the nominal season's figures and the spread of the stochastic ones.
//! The report (`report.rs`) fills it; the Markdown (`markdown.rs`) and the CSV read it.

/// One line of a model's table: a controller at a horizon.
#[derive(Debug, Clone)]
pub(crate) struct TableLine {
    pub(crate) controller: String,
    pub(crate) horizon: String,
    pub(crate) horizon_h: Option<f64>,
    /// (EPI, cumulative reward) of the nominal season.
    pub(crate) nominal: Option<(f64, f64)>,
    /// (EPI, cumulative reward) of each stochastic season.
    pub(crate) stochastic: Vec<(f64, f64)>,
    pub(crate) failed_solves: u64,
    pub(crate) median_ms: f64,
    pub(crate) max_ms: f64,
}

/// Mean, minimum and maximum.
pub(crate) fn spread(values: impl Iterator<Item = f64>) -> Option<(f64, f64, f64)> {
    let v: Vec<f64> = values.collect();
    if v.is_empty() {
        return None;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    Some((mean, lo, hi))
}
