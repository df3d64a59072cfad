//! The one place where a pure-Rust back-end turns the end of a solve into the
//! [`Solution`] it returns: the point, the status and the statistics, timed from the
//! solve's start, with the end line of a trace.

use super::{KktResiduals, Solution, SolveStats, SolveStatus};
use std::time::Instant;

/// How a solve ended, besides its point.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Ending {
    pub status: SolveStatus,
    pub iterations: usize,
    /// `f(x)` at the returned point (NaN when it could not be evaluated).
    pub objective: f64,
    pub kkt: KktResiduals,
    pub inertia_corrections: usize,
}

impl Ending {
    /// A solve that ended before its first iteration: no objective, no residuals.
    pub fn before_start(status: SolveStatus) -> Ending {
        Ending {
            status,
            iterations: 0,
            objective: f64::NAN,
            kkt: KktResiduals::default(),
            inertia_corrections: 0,
        }
    }
}

/// Started with a solve: builds its [`Solution`] when it ends.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SolutionBuilder {
    started: Instant,
    /// The back-end's name, for the trace's end line; `None` without a trace.
    trace: Option<&'static str>,
}

impl SolutionBuilder {
    /// The builder of a solve starting now, by back-end `name`, printing its end line to
    /// standard error when `trace` is set.
    pub fn start(name: &'static str, trace: bool) -> SolutionBuilder {
        SolutionBuilder {
            started: Instant::now(),
            trace: trace.then_some(name),
        }
    }

    /// The solution of a solve that ended as `ending` at the point `x` with multipliers `λ`
    /// and bound multipliers `ν`.
    pub fn build(
        &self,
        ending: Ending,
        x: Vec<f64>,
        multipliers: Vec<f64>,
        bound_multipliers: Vec<f64>,
    ) -> Solution {
        let solution = self.untraced(ending, x, multipliers, bound_multipliers);
        if let Some(name) = self.trace {
            eprintln!(
                "{name} end: {:?} after {} iterations, KKT {:.1e}",
                ending.status,
                ending.iterations,
                ending.kkt.max()
            );
        }
        solution
    }

    /// The solution of a problem the back-end could not set itself up for: `x` as given,
    /// `m` constraint multipliers and the bound multipliers zero, nothing traced.
    pub fn refused(&self, status: SolveStatus, x: Vec<f64>, m: usize) -> Solution {
        let n = x.len();
        self.untraced(Ending::before_start(status), x, vec![0.0; m], vec![0.0; n])
    }

    fn untraced(
        &self,
        ending: Ending,
        x: Vec<f64>,
        multipliers: Vec<f64>,
        bound_multipliers: Vec<f64>,
    ) -> Solution {
        Solution {
            status: ending.status,
            x,
            multipliers,
            bound_multipliers,
            stats: SolveStats {
                iterations: ending.iterations,
                time_s: self.started.elapsed().as_secs_f64(),
                objective: ending.objective,
                kkt: ending.kkt,
                inertia_corrections: ending.inertia_corrections,
            },
        }
    }
}
