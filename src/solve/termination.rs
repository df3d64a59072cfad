//! The one termination test of the pure-Rust back-ends: when an optimality error ends a
//! solve, and with which [`SolveStatus`].
//!
//! Each back-end measures its own error (SQP the KKT residual's largest norm, the interior
//! point IPOPT's scaled optimality error); the rules on it are the same: optimal at
//! `tolerance`; acceptable after more than `acceptable_iterations` iterations in a row at
//! or below `acceptable_tolerance` (or where the back-end says it has stalled); at the
//! iteration limit acceptable or [`SolveStatus::MaxIterations`]; and, when no step can be
//! made, acceptable, infeasible or a numerical error.

use super::SolveStatus;

/// The termination test of one solve, with the run of acceptable iterations it counts.
#[derive(Debug, Clone)]
pub(crate) struct Termination {
    tolerance: f64,
    acceptable_tolerance: f64,
    acceptable_iterations: usize,
    max_iterations: usize,
    /// Iterations in a row whose error was at or below `acceptable_tolerance`.
    acceptable_run: usize,
}

impl Termination {
    /// The test of a solve allowed `max_iterations` iterations (iterations `0 ..=
    /// max_iterations` are checked).
    pub fn new(
        tolerance: f64,
        acceptable_tolerance: f64,
        acceptable_iterations: usize,
        max_iterations: usize,
    ) -> Termination {
        Termination {
            tolerance,
            acceptable_tolerance,
            acceptable_iterations,
            max_iterations,
            acceptable_run: 0,
        }
    }

    /// Records the optimality `error` of iteration `iteration` and says whether the solve
    /// ends there: optimal at `tolerance`; acceptable after the run of acceptable
    /// iterations, or when `stalled`; at the iteration limit acceptable below
    /// `acceptable_tolerance`, else [`SolveStatus::MaxIterations`].
    pub fn check(&mut self, error: f64, iteration: usize, stalled: bool) -> Option<SolveStatus> {
        self.acceptable_run = if error <= self.acceptable_tolerance {
            self.acceptable_run + 1
        } else {
            0
        };
        if error <= self.tolerance {
            Some(SolveStatus::Optimal)
        } else if self.acceptable_run > self.acceptable_iterations || stalled {
            Some(SolveStatus::Acceptable)
        } else if iteration >= self.max_iterations {
            Some(self.at_limit(error))
        } else {
            None
        }
    }

    /// The status of a solve that ends at the iteration limit with optimality `error`.
    pub fn at_limit(&self, error: f64) -> SolveStatus {
        if error <= self.acceptable_tolerance {
            SolveStatus::Acceptable
        } else {
            SolveStatus::MaxIterations
        }
    }

    /// The status of a solve that can make no step from a point of optimality `error`:
    /// acceptable below `acceptable_tolerance`, else infeasible where the back-end found
    /// the constraints unreachable (`infeasible`), else a numerical error.
    pub fn stuck(&self, error: f64, infeasible: bool) -> SolveStatus {
        if error <= self.acceptable_tolerance {
            SolveStatus::Acceptable
        } else if infeasible {
            SolveStatus::Infeasible
        } else {
            SolveStatus::NumericalError
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test() -> Termination {
        Termination::new(1e-8, 1e-6, 2, 10)
    }

    #[test]
    fn the_tolerance_ends_a_solve_as_optimal() {
        assert_eq!(test().check(1e-9, 0, false), Some(SolveStatus::Optimal));
        assert_eq!(test().check(1e-7, 0, false), None);
    }

    #[test]
    fn a_run_of_acceptable_iterations_ends_a_solve_as_acceptable() {
        let mut t = test();
        assert_eq!(t.check(1e-7, 0, false), None);
        assert_eq!(t.check(1e-7, 1, false), None);
        assert_eq!(t.check(1e-7, 2, false), Some(SolveStatus::Acceptable));
        // A worse iteration starts the run over.
        let mut t = test();
        assert_eq!(t.check(1e-7, 0, false), None);
        assert_eq!(t.check(1e-3, 1, false), None);
        assert_eq!(t.check(1e-7, 2, false), None);
        assert_eq!(t.check(1e-3, 3, true), Some(SolveStatus::Acceptable));
    }

    #[test]
    fn the_iteration_limit_ends_a_solve_by_its_error() {
        assert_eq!(
            test().check(1e-3, 10, false),
            Some(SolveStatus::MaxIterations)
        );
        assert_eq!(test().check(1e-7, 10, false), Some(SolveStatus::Acceptable));
    }

    #[test]
    fn a_solve_without_a_step_ends_by_its_error_and_feasibility() {
        let t = test();
        assert_eq!(t.stuck(1e-7, true), SolveStatus::Acceptable);
        assert_eq!(t.stuck(1e-3, true), SolveStatus::Infeasible);
        assert_eq!(t.stuck(1e-3, false), SolveStatus::NumericalError);
    }
}
