//! The interior point's workspace: everything a problem pattern needs — the KKT system,
//! the barrier problem, the iterate, the values at it, the directions and the line search's
//! buffers — sized once ([`Workspace::new`]) and reused by every solve of the pattern, so
//! that the iterations allocate nothing.

use super::super::error::SetupError;
use super::super::kkt::{residuals_of, PointInfo};
use super::super::solution_builder::Ending;
use super::super::{Checkpoint, KktResiduals, SolveStatus, Start};
use super::iterate::{Eval, Iterate, StartKind};
use super::kkt_system::KktSystem;
use super::line_search::LineSearch;
use super::newton::{Condensation, Directions};
use super::problem::BarrierProblem;
use crate::nlp::{Nlp, Pattern};

/// The buffers of one problem pattern; see the [module documentation](self).
#[derive(Debug, Clone)]
pub(super) struct Workspace {
    n: usize,
    m: usize,
    /// The patterns the workspace was sized for (an `Ocp` keeps its sizes but changes its
    /// Hessian pattern when a terminal cost comes or goes).
    pub jacobian: Pattern,
    hessian: Pattern,
    pub kkt: KktSystem,
    pub problem: BarrierProblem,
    pub it: Iterate,
    /// The start's bound multipliers (signed), zero where not given.
    pub start_bound_multipliers: Vec<f64>,
    pub ev: Eval,
    pub condensation: Condensation,
    pub directions: Directions,
    /// One entry per variable, for the optimality error.
    pub scratch: Vec<f64>,
    pub line_search: LineSearch,
    /// The iterate before the last line-search step, and that step's length: where to go
    /// back to when the derivatives at the accepted point are not finite
    /// ([`Workspace::step_back`]). `None` after a start or a restoration.
    before_step: Iterate,
    last_step: Option<f64>,
}

impl Workspace {
    /// The workspace of `nlp`'s pattern; an error where the problem declares no stages or
    /// does not fit them.
    pub fn new(nlp: &dyn Nlp) -> Result<Workspace, SetupError> {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        let stages = nlp.stages().ok_or(SetupError::NoStages)?;
        let jacobian = nlp.jacobian_pattern().clone();
        let hessian = nlp.hessian_pattern().clone();
        let kkt = KktSystem::new(&stages, n, m, &jacobian, &hessian)?;
        let is_dynamics = (0..m).map(|r| kkt.is_dynamics(r)).collect();
        Ok(Workspace {
            n,
            m,
            problem: BarrierProblem::new(n, m, is_dynamics),
            it: Iterate::zeros(n, m),
            start_bound_multipliers: vec![0.0; n],
            ev: Eval::zeros(n, m, jacobian.len(), hessian.len()),
            condensation: Condensation::zeros(n, m),
            directions: Directions::zeros(n, m),
            scratch: vec![0.0; n],
            line_search: LineSearch::new(n, m),
            before_step: Iterate::zeros(n, m),
            last_step: None,
            kkt,
            jacobian,
            hessian,
        })
    }

    /// Whether `nlp` has the sizes and patterns this workspace was made for.
    pub fn fits(&self, nlp: &dyn Nlp) -> bool {
        self.n == nlp.n_vars()
            && self.m == nlp.n_cons()
            && self.jacobian == *nlp.jacobian_pattern()
            && self.hessian == *nlp.hessian_pattern()
    }

    /// Starts a solve of at most `max_iterations` iterations from `start` (of `kind`):
    /// `nlp`'s bounds read, the buffers of the last solve cleared, the starting iterate
    /// set. False where the problem is not finite at the start.
    pub fn start_solve(
        &mut self,
        nlp: &mut dyn Nlp,
        start: &Start<'_>,
        kind: StartKind,
        max_iterations: usize,
    ) -> bool {
        self.problem.read(nlp);
        self.kkt.start_solve();
        self.line_search.start_solve(max_iterations);
        self.ev.clear();
        self.directions.clear();
        self.last_step = None;
        let nu = &mut self.start_bound_multipliers;
        self.it
            .start(nlp, &self.problem, start, kind, nu, &mut self.ev.c)
    }

    /// The problem's own feasibility restoration from the iterate
    /// ([`LineSearch::restore`]); `(θ, φ)` of the iterate join the filter where it
    /// succeeds.
    pub fn restore(&mut self, nlp: &mut dyn Nlp, kappa: f64, theta_phi: (f64, f64)) -> bool {
        self.last_step = None;
        self.line_search
            .restore(nlp, &self.problem, &mut self.it, kappa, theta_phi)
    }

    /// Takes the line search's step of length `alpha` (primal) and `alpha_dual` (bound
    /// multipliers) at barrier `mu`, keeping the iterate before it.
    pub fn take_step(&mut self, alpha: f64, alpha_dual: f64, mu: f64) {
        self.before_step.copy_from(&self.it);
        self.last_step = Some(alpha);
        let d = &self.directions.step;
        let trial = &self.line_search.trial;
        self.it
            .take_step(&mut self.problem, trial, d, alpha, alpha_dual, mu);
    }

    /// Back to the iterate before the last step, whose length it returns; `None` where the
    /// iterate did not come from a step (a start, a restoration, a step taken back).
    pub fn step_back(&mut self) -> Option<f64> {
        let alpha = self.last_step.take()?;
        std::mem::swap(&mut self.it, &mut self.before_step);
        Some(alpha)
    }

    /// Where the solve stands after `iteration` iterations at barrier `mu`, in the units
    /// of the problem whose objective was scaled by `objective_scale`.
    pub fn checkpoint(&self, iteration: usize, mu: f64, objective_scale: f64) -> Checkpoint {
        let it = &self.it;
        Checkpoint {
            iteration,
            x: self.point(),
            multipliers: it.lambda.iter().map(|l| l / objective_scale).collect(),
            bound_multipliers: self
                .bound_multipliers()
                .iter()
                .map(|v| v / objective_scale)
                .collect(),
            barrier: mu / objective_scale,
        }
    }

    /// The iterate's point, the relaxed bounds of fixed variables back onto the true ones.
    fn point(&self) -> Vec<f64> {
        let (it, bounds) = (&self.it, &self.problem.bounds);
        (0..self.n)
            .map(|i| it.w[i].max(bounds.x_lower[i]).min(bounds.x_upper[i]))
            .collect()
    }

    /// The iterate's bound multipliers `ν = z_U − z_L`.
    fn bound_multipliers(&self) -> Vec<f64> {
        (0..self.n).map(|i| self.it.zu[i] - self.it.zl[i]).collect()
    }

    /// The solution in ghm's conventions from the iterate, with its objective and KKT
    /// residuals evaluated on the original bounds (where the status says the problem could
    /// be evaluated): the point, `λ`, `ν` and how the solve ended.
    pub fn solution(
        &mut self,
        nlp: &mut dyn Nlp,
        status: SolveStatus,
        iterations: usize,
        objective: f64,
    ) -> (Vec<f64>, Vec<f64>, Vec<f64>, Ending) {
        let x = self.point();
        let nu = self.bound_multipliers();
        let lambda = self.it.lambda.clone();
        let bounds = &self.problem.bounds;
        let mut kkt = KktResiduals::default();
        let mut objective = objective;
        if status != SolveStatus::InvalidNumber && x.iter().all(|v| v.is_finite()) {
            let ev = &mut self.ev;
            ev.clear();
            self.scratch.fill(0.0);
            objective = nlp.objective(&x);
            nlp.constraints(&x, &mut ev.c);
            nlp.gradient(&x, &mut ev.gradient);
            nlp.jacobian_values(&x, &mut ev.jacobian);
            let point = PointInfo {
                x: &x,
                g: &ev.c,
                gradient: &ev.gradient,
                jacobian: &ev.jacobian,
                multipliers: &lambda,
                bound_multipliers: &nu,
            };
            kkt = residuals_of(&point, &self.jacobian, bounds, &mut self.scratch);
        }
        let ending = Ending {
            status,
            iterations,
            objective,
            kkt,
            inertia_corrections: 0,
        };
        (x, lambda, nu, ending)
    }
}
