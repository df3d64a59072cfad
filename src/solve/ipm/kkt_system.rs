//! The condensed KKT system of the interior point, stage by stage: the stage map
//! ([`StageMap`]) that places the problem's Hessian and Jacobian in the stages of a Riccati
//! recursion, the factorisation with its inertia correction, and the solve of one
//! right-hand side.
//!
//! Inertia correction: stage by stage first ([`Riccati::factor_corrected`]); where a stage
//! would need more than the stage-wise cap, one `δ` on every stage from the failing one on
//! ([`KktSystem::factor_whole_horizon`], IPOPT's schedule narrowed by bisection).

use super::super::error::SetupError;
use super::super::riccati::Riccati;
use super::structure::StageMap;
use crate::nlp::{Pattern, Stages};

/// The fraction-to-the-boundary step below which a direction from the stage-wise inertia
/// correction is replaced by the whole-horizon correction's. Measured on the 40-day seasons
/// (6 h horizon, every step restarted from the shifted plan): without it, a few cold solves
/// of each season crawled at steps of 1e-8 … 1e-5 with directions of 1e5 … 1e7 to the
/// iteration cap; with it, none came near the cap (`docs/benchmarks-history.md`,
/// "Restarting from the shifted plan, not from its multipliers").
pub(super) const SHORT_CORRECTED_STEP: f64 = 1e-2;

/// The Riccati recursion of one problem pattern, where its stage map puts the entries.
#[derive(Debug, Clone)]
pub(super) struct KktSystem {
    map: StageMap,
    riccati: Riccati,
    /// The last `δ` of the whole-horizon correction in this solve (IPOPT's schedule starts
    /// from a third of it).
    last_delta: f64,
}

impl KktSystem {
    /// The system of a problem with `stages`, `n_vars` variables, `n_cons` rows and the
    /// two patterns; an error where the patterns couple stages the problem keeps apart.
    pub fn new(
        stages: &Stages,
        n_vars: usize,
        n_cons: usize,
        jacobian: &Pattern,
        hessian: &Pattern,
    ) -> Result<KktSystem, SetupError> {
        let map = StageMap::new(stages, n_vars, n_cons, jacobian, hessian)?;
        Ok(KktSystem {
            riccati: map.riccati(),
            map,
            last_delta: 0.0,
        })
    }

    /// Whether row `r` is a dynamics row.
    pub fn is_dynamics(&self, r: usize) -> bool {
        self.map.is_dynamics(r)
    }

    /// Forgets the last solve's whole-horizon correction.
    pub fn start_solve(&mut self) {
        self.last_delta = 0.0;
    }

    /// Fills the matrices: the Hessian values, the barrier's diagonal per variable,
    /// `Jᵀ Σ J` over the inequality rows (`row_weight` = `Σ` per row), the dynamics from
    /// the Jacobian values, and the inertia correction's diagonal `shift` per variable.
    pub fn assemble(
        &mut self,
        hessian: &[f64],
        diagonal: &[f64],
        jacobian: &[f64],
        row_weight: &[f64],
        shift: &[f64],
    ) {
        self.map.fill_matrices(
            &mut self.riccati,
            hessian,
            diagonal,
            jacobian,
            row_weight,
            shift,
        );
    }

    /// Factorises stage by stage, else with one shift from the failing stage on; returns
    /// how many corrections were made (the whole-horizon shift counts as one), `None`
    /// where no shift gives the right inertia.
    pub fn factor(&mut self) -> Option<usize> {
        match self.riccati.factor_corrected() {
            Ok(count) => Some(count),
            Err(_) => self.factor_whole_horizon().map(|d| usize::from(d > 0.0)),
        }
    }

    /// The fallback of the stage-wise correction: factorises with one `δ` on every stage
    /// from the one that failed on (states and controls), the smallest of IPOPT's schedule
    /// that gives the right inertia,
    /// then narrows it down towards the threshold by bisection (in `log δ`, between the
    /// last failure and the first success): a `δ` far above the threshold damps the step
    /// along a direction of negative curvature to a crawl, one just above it lets the
    /// step run to the bound that ends that direction, where the barrier's curvature
    /// takes over.
    pub fn factor_whole_horizon(&mut self) -> Option<f64> {
        let riccati = &mut self.riccati;
        let last_delta = &mut self.last_delta;
        let mut first = match riccati.factor(0.0) {
            Ok(()) => return Some(0.0),
            Err(e) => e.stage,
        };
        let mut delta = if *last_delta == 0.0 {
            1e-4
        } else {
            (*last_delta / 3.0).max(1e-20)
        };
        let growth = if *last_delta == 0.0 { 100.0 } else { 8.0 };
        let mut failed = delta / growth;
        loop {
            match riccati.factor_from(delta, first) {
                Ok(()) => break,
                // The missing curvature shows up earlier: shift from there on, same δ.
                Err(e) if e.stage < first => first = e.stage,
                Err(_) => {
                    failed = delta;
                    delta *= growth;
                    if delta > 1e20 {
                        return None;
                    }
                }
            }
        }
        let mut current = true;
        for _ in 0..4 {
            let middle = (failed * delta).sqrt();
            current = riccati.factor_from(middle, first).is_ok();
            if current {
                delta = middle;
            } else {
                failed = middle;
            }
        }
        // The last try failed: the factorisation held is not `δ`'s.
        if !current && riccati.factor_from(delta, first).is_err() {
            return None;
        }
        *last_delta = delta;
        Some(delta)
    }

    /// The largest correction of the last factorisation.
    pub fn largest_correction(&self) -> f64 {
        self.riccati
            .corrections()
            .iter()
            .fold(0.0_f64, |a, &d| a.max(d))
    }

    /// Solves for the condensed gradient `gradient` (per variable) and the dynamics
    /// residuals `residual` (per row) with the last factorisation; false where there is
    /// none.
    pub fn solve(&mut self, gradient: &[f64], residual: &[f64]) -> bool {
        self.map.fill_vectors(&mut self.riccati, gradient, residual);
        self.riccati.solve()
    }

    /// The step (per variable) and the new multipliers of the dynamics rows (the other
    /// rows' entries of `multipliers` left alone) of the last [`KktSystem::solve`].
    pub fn read_solution(&self, step: &mut [f64], multipliers: &mut [f64]) {
        self.map.read_solution(&self.riccati, step, multipliers);
    }
}
