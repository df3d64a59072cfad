//! The `.ghm` language front end.
pub mod ast;
pub mod chars;
mod check;
mod collect;
pub mod diagnostic;
mod limits;
pub mod load;
pub mod model;
pub mod parse;
pub mod source;
pub mod text;

pub use diagnostic::CheckFailure;
pub use load::{load, load_files, load_str};
pub use model::Model;
