//! Simulation: weather sources, the season loop and its metrics.
pub mod metrics;
pub mod optimum;
pub mod season;
pub mod weather;
