//! The `.ghm` language front end.
pub mod ast;
pub mod check;
pub mod diagnostic;
pub mod model;
pub mod parse;
pub mod source;

pub use check::{load, load_str, CheckFailure};
pub use model::Model;
