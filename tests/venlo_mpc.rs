//! Economic MPC problems of the lettuce season solved by SQP, beside the interior point
//! (reads the Venlo weather in ../shared).

mod common;

use common::{closed_loop, closed_loop_with_bands, plant, states_along_season, venlo, STEPS};
use ghm::nlp::{Bands, Nlp, Ocp};
use ghm::solve::{kkt_residuals, Ipm, Solver, Sqp, Start};

#[test]
fn venlo_sqp_solutions_satisfy_kkt_at_ten_steps_of_the_season() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_sqp_solutions_satisfy_kkt_at_ten_steps_of_the_season",
    ) else {
        return;
    };
    // Cold starts (the previous input held) from open-loop states.
    for file in ["models/lettuce-thesis.ghm", "models/lettuce.ghm"] {
        let plant = plant(file);
        let weather = venlo(&plant, 1920 + 12);
        let states = states_along_season(&plant, &weather, &STEPS);
        for hours in [1usize, 3, 6] {
            let n = 2 * hours;
            let mut ocp = Ocp::new(plant.clone(), n).unwrap();
            let mut sqp = Sqp::default();
            for (&step, state) in STEPS.iter().zip(&states) {
                ocp.set_problem(
                    step,
                    state,
                    &[0.6, 1.0, 40.0],
                    weather.horizon(step, n).unwrap(),
                )
                .unwrap();
                let mut x = vec![0.0; ocp.n_vars()];
                ocp.initial_point(&mut x);
                let sol = sqp.solve(&mut ocp, Start::cold(&x));
                let kkt = kkt_residuals(&mut ocp, &sol.x, &sol.multipliers, &sol.bound_multipliers);
                assert!(
                    sol.status.is_success(),
                    "{file} {hours} h, step {step}: {:?}",
                    sol.status
                );
                assert!(kkt.max() <= 1e-6, "{file} {hours} h, step {step}: {kkt:?}");
                // SQP reports success only below that residual, so the check above holds
                // by construction; the interior point, another algorithm from the same
                // start, must find the same optimum.
                let ipm = Ipm::default().solve(&mut ocp, Start::cold(&x));
                assert!(
                    ipm.status.is_success(),
                    "{file} {hours} h, step {step}: ipm {:?}",
                    ipm.status
                );
                let (f_sqp, f_ipm) = (sol.stats.objective, ipm.stats.objective);
                assert!(
                    (f_sqp - f_ipm).abs() <= 1e-6 * (1.0 + f_sqp.abs()),
                    "{file} {hours} h, step {step}: SQP {f_sqp} vs IPM {f_ipm}"
                );
            }
        }
    }
}

/// The 2-day closed loop of spec/peer-solvers.md: IPOPT's cumulative reward is −0.074630
/// at 1 h and −0.069817 at 6 h (thesis variant).
#[test]
fn venlo_two_day_closed_loop_matches_the_peer_reward() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_two_day_closed_loop_matches_the_peer_reward",
    ) else {
        return;
    };
    let plant = plant("models/lettuce-thesis.ghm");
    for (hours, reference) in [(1usize, -0.074630), (6, -0.069817)] {
        let m = &closed_loop(&plant, 2 * hours, Box::new(Sqp::default()), 96);
        assert!(
            (m.cumulative_reward - reference).abs() < 2e-5,
            "{hours} h: reward {} vs {reference}",
            m.cumulative_reward
        );
        assert_eq!(m.solve.failed_solves, 0, "{hours} h: {:?}", m.solve);
    }
}

/// The paper variant (`models/lettuce.ghm`) in closed loop, two days at 3 h.
///
/// Planning with the scoring bands (what `ghm mpc` does on the nominal plant), it is the
/// problem of the peer's CasADi + IPOPT (`run_reference.py mpc --hours 3 --days 2
/// --variant paper --init robust` in ../shared/peers: cumulative reward −0.0801684, no
/// failed solve, no penalty); it is held to it within the same 2e-5 as the thesis variant.
///
/// Planning with the model's `plan` bounds (humidity 78 % instead of 80 %) is a problem of
/// ghm's own, with no peer figure: its reward, −0.0838453, was recorded once from this
/// test (`cargo test --test venlo_mpc paper`) and is pinned to the same 2e-5. It is below
/// the scoring bands' reward, as the back-off costs yield.
#[test]
fn venlo_paper_variant_closed_loop_matches_the_peer_reward() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_paper_variant_closed_loop_matches_the_peer_reward",
    ) else {
        return;
    };
    let plant = plant("models/lettuce.ghm");
    for (bands, reference) in [(Bands::Scoring, -0.0801684), (Bands::Planning, -0.0838453)] {
        let m = closed_loop_with_bands(&plant, 6, Box::new(Sqp::default()), 96, bands);
        assert_eq!(m.solve.failed_solves, 0, "{bands:?}: {:?}", m.solve);
        assert!(
            (m.cumulative_reward - reference).abs() < 2e-5,
            "{bands:?}: reward {} vs {reference}: {m:?}",
            m.cumulative_reward
        );
        assert!(m.total_penalty < 1e-9, "{bands:?}: {m:?}");
    }
}
