//! Reports: plots of seasons and learning curves.
pub mod plot;
