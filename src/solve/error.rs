//! Why a pure-Rust back-end cannot set itself up for a problem: the one error of the
//! solvers' layer. A solve never returns it; it ends with the [`SolveStatus`] the error
//! names, before its first iteration.

use super::SolveStatus;
use thiserror::Error;

/// A problem whose structure a back-end cannot work with.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub(crate) enum SetupError {
    /// The interior point factorises stage by stage, and the problem declares no stages
    /// ([`crate::nlp::Nlp::stages`]).
    #[error("the problem declares no stages")]
    NoStages,
    /// The problem's Jacobian or Hessian couples variables its stages keep apart.
    #[error("the problem does not fit its stages: {0}")]
    NotStaged(String),
    /// A Hessian entry outside every block of [`crate::nlp::Nlp::hessian_blocks`].
    #[error("Hessian entry ({row}, {col}) lies in no Hessian block")]
    OutsideHessianBlocks { row: usize, col: usize },
}

impl SetupError {
    /// The status a solve refused for this reason ends with.
    pub fn status(&self) -> SolveStatus {
        match self {
            SetupError::NoStages | SetupError::NotStaged(_) => SolveStatus::NumericalError,
            SetupError::OutsideHessianBlocks { .. } => SolveStatus::InvalidNumber,
        }
    }
}
