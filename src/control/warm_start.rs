//! How an MPC step restarts its back-end from the previous step's solution, shifted by one
//! step: MPC's policy, stated once here and read by the job layer's specs, the command
//! line, study files and Python by its names. The back-end only says which restart suits it
//! ([`Solver::restarts_from_multipliers`]).

use crate::solve::Solver;

crate::choice! {
    /// How each MPC step restarts the back-end from the last step's solution, shifted by
    /// one step.
    pub enum WarmStart {
        /// The shifted primal point (under guidance with the constraint multipliers); bound
        /// multipliers and barrier afresh (fatrop's way, and the interior point's default:
        /// a similar number of iterations every step, none much longer; measured in
        /// docs/benchmarks.md, "Restarting from the shifted plan, not from its multipliers").
        Primal = "primal",
        /// The shifted primal point and multipliers (SQP's and IPOPT's default: few SQP
        /// iterations; the interior point's fewest iterations in the median, from a tiny
        /// barrier parameter, but many more where the active set changes; the same section).
        PrimalDual = "primal-dual",
        /// The shifted primal point with its constraint multipliers for plain MPC too,
        /// again from the point alone where the Hessian needs three corrections (the
        /// interior point: fewer iterations than `primal`; measured in docs/benchmarks.md,
        /// "Plain MPC restarted with its multipliers").
        PrimalMultipliers = "primal-multipliers",
        /// The shifted primal point and all multipliers for at most 10 iterations, and
        /// where that does not converge the shifted point with a fresh barrier, as
        /// `primal` restarts (the interior point: the primal-dual median without its cold
        /// re-solves; measured in docs/benchmarks.md, "The primal-dual restart over the
        /// paper study's MPC seasons").
        PrimalDualCapped = "primal-dual-capped",
    }
}

/// The iterations [`WarmStart::PrimalDualCapped`] gives its primal-dual attempt (its help
/// says so; a test holds the two together). On the paper study's 372 MPC seasons the
/// interior point's primal-dual restart took 3.5 iterations in the median season; at 10 a
/// failed attempt costs a few median steps.
pub const PRIMAL_DUAL_TRIAL_ITERATIONS: usize = 10;

impl WarmStart {
    /// The restart that suits `solver`: the point and all its multipliers for a back-end
    /// that converges fastest from them (SQP, IPOPT), else the point alone with the
    /// back-end's own fresh barrier (the interior point).
    pub fn preferred_by(solver: &dyn Solver) -> WarmStart {
        if solver.restarts_from_multipliers() {
            WarmStart::PrimalDual
        } else {
            WarmStart::Primal
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_capped_restarts_help_states_its_cap() {
        let help = WarmStart::PrimalDualCapped.help();
        let said = format!("at most {PRIMAL_DUAL_TRIAL_ITERATIONS} iterations");
        assert!(help.contains(&said), "{help}");
    }
}
