//! RL-guided MPC on the first week of the Venlo season with the agents and value networks
//! shipped under models/agents/ (reads the Venlo weather in ../shared): no solve fails, at
//! most one step of each variant needs the cold-start fallback, and each variant's reward is
//! the one recorded.
//!
//! Two solver defects surfaced here, both in the terminal region: a component pinned at zero
//! made the QP's rounding-level step on it count as an enormous relative step (warm solves
//! ran to the iteration cap and fell back to cold starts), and near a stationary point the
//! QP's noise-level step failed the line search forever (a failed solve at step 334 of the
//! paper variant). Before the fixes the thesis variant fell back to cold starts on 10 steps
//! of this week. One warm solve of the paper variant (step 224) still creeps along a flat
//! valley under a shrinking trust region until the iteration cap, and its cold start then
//! converges in two iterations.

mod common;

use common::{plant, venlo};
use ghm::control::{Mpc, Policy, RlGuidance, RlMpcOptions, ValueFile};
use ghm::rl::PolicyFile;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::solve::Sqp;
use std::path::Path;

/// The week's cumulative rewards (€ m⁻²), recorded with SQP and printed by `cargo test
/// --test venlo_rlmpc -- --nocapture`. There is no outside figure for RL-guided MPC with
/// ghm's own agents; the tolerance is the one that separates two correct solvers on a 2-day
/// closed loop (`venlo_mpc`), far below what a change of the guidance moves.
const RECORDED: [(&str, f64); 2] = [
    ("lettuce-thesis", -0.1160975427),
    ("lettuce", -0.2566078826),
];

#[test]
fn venlo_first_week_of_rl_guided_mpc_solves_every_step_to_its_recorded_reward() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_first_week_of_rl_guided_mpc_solves_every_step_to_its_recorded_reward",
    ) else {
        return;
    };
    const STEPS: usize = 336;
    let horizon = 2;
    for (variant, recorded) in RECORDED {
        let plant = plant(&format!("models/{variant}.ghm"));
        let weather = venlo(&plant, STEPS + horizon);
        let shipped = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("models/agents")
            .join(variant);
        let policy = PolicyFile::load(&shipped.join("policy.json")).expect("shipped agent");
        let value = ValueFile::load(&shipped.join("value-sac.json")).expect("shipped value");
        let guidance = RlGuidance::new(
            plant.clone(),
            Box::new(Policy::new(&plant, policy).unwrap()),
            "sac",
            Some(value),
            RlMpcOptions::default(),
        )
        .unwrap();
        let mut rlmpc = Mpc::new(plant.clone(), horizon, Box::new(Sqp::default()))
            .unwrap()
            .with_guidance(Box::new(guidance));
        let config = SeasonConfig {
            steps: STEPS,
            enforce_limits: true,
            uncertainty: None,
        };
        let result =
            run_season(&plant, &weather, &mut rlmpc, &config, &mut |_: &StepLog| {}).unwrap();
        let solve = &result.metrics.solve;
        let reward = result.metrics.cumulative_reward;
        eprintln!("{variant}: {reward:.10} {solve:?}");
        assert_eq!(solve.failed_solves, 0, "{variant}: {solve:?}");
        assert!(solve.fallbacks <= 1, "{variant}: {solve:?}");
        assert!(
            (reward - recorded).abs() <= 2e-5,
            "{variant}: {reward:.10}, recorded {recorded}"
        );
    }
}
