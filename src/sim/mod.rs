//! Simulation: weather sources, the season loop and its metrics, the season optimum, and
//! the roll-outs behind the value function of RL-guided MPC.
pub mod metrics;
pub mod optimum;
pub mod physical;
pub mod season;
#[cfg(test)]
pub(crate) mod test_data;
pub mod value_data;
pub mod weather;
pub mod weather_source;
