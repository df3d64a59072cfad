//! ghm: economic model-predictive control with learned guidance.
pub mod cli;
pub mod control;
pub mod graph;
pub mod lang;
pub mod model;
pub mod nlp;
pub mod report;
pub mod sim;
pub mod solve;
