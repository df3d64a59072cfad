//! `ghm import`: models and weather data of other tools turned into `.ghm` files and ghm
//! weather CSVs. Two sources: GreenLight's JSON model files and weather CSV
//! ([`greenlight`], [`weather`]; `docs/import.md`), and the paper's Venlo weather as its
//! authors published it ([`venlo`]; `docs/data.md`).

pub mod greenlight;
pub mod venlo;
pub mod weather;

use std::path::PathBuf;
use thiserror::Error;

/// Why an import failed; every message names the file, and the variable where there is
/// one.
#[derive(Debug, Error)]
pub enum ImportError {
    /// A file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A file named by a `processing_order` could not be read.
    #[error("cannot read {} (named in the processing_order of {}): {source}", path.display(), from.display())]
    Missing {
        /// The file named.
        path: PathBuf,
        /// The file whose `processing_order` names it.
        from: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A model file is not JSON as GreenLight reads it (also: a duplicate key, a cycle of
    /// files).
    #[error("{}: {message}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A variable the importer cannot take as it is declared.
    #[error("{}: variable `{name}`: {message}", path.display())]
    Variable {
        /// The file that declares (or last defines) it.
        path: PathBuf,
        /// The variable.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// An expression the importer does not read or cannot translate.
    #[error("{}: variable `{name}`: {field} `{text}`: {message}", path.display())]
    Expr {
        /// The file its definition comes from.
        path: PathBuf,
        /// The variable.
        name: String,
        /// `definition` or `init`.
        field: &'static str,
        /// The expression as written.
        text: String,
        /// The construct refused, or the name or function not found.
        message: String,
    },
    /// A file that is not in the format its kind promises (e.g. not a MAT-file).
    #[error("{}: {message}", path.display())]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A weather file that cannot be converted.
    #[error("{}: line {line}: {message}", path.display())]
    Weather {
        /// The file.
        path: PathBuf,
        /// The 1-based line (record) number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A control named by `--inputs` that the model lacks or cannot make an input.
    #[error("--inputs: {0}")]
    Inputs(String),
    /// An option out of range.
    #[error("{0}")]
    Argument(String),
    /// The written model does not load: a bug of the importer, or a GreenLight model the
    /// language cannot express. Holds the rendered diagnostics.
    #[error("the imported model {file} does not load; nothing was written:\n{report}")]
    Check {
        /// The name the model would have been written under.
        file: String,
        /// The diagnostics, rendered.
        report: String,
    },
    /// A result file could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}
