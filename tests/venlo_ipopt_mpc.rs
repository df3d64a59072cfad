//! The IPOPT back-end on the lettuce MPC problems, against SQP (feature `ipopt`; reads the
//! Venlo weather in ../shared). CI installs IPOPT and runs this file.
#![cfg(feature = "ipopt")]

mod common;

use common::{closed_loop, plant, states_along_season, venlo, STEPS};
use ghm::nlp::{Nlp, Ocp};
use ghm::solve::{kkt_residuals, Ipopt, IpoptOptions, Solver, Sqp, SqpOptions, Start};

#[test]
fn venlo_sqp_and_ipopt_reach_the_same_objective_at_ten_steps() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_sqp_and_ipopt_reach_the_same_objective_at_ten_steps",
    ) else {
        return;
    };
    let plant = plant("models/lettuce-thesis.ghm");
    let weather = venlo(&plant, 1920 + 12);
    let states = states_along_season(&plant, &weather, &STEPS);
    for hours in [1usize, 3, 6] {
        let n = 2 * hours;
        let mut ocp = Ocp::new(plant.clone(), n).unwrap();
        // Tight tolerances on both sides: the economic optimum is flat along ventilation,
        // so a loose stop leaves the objective off in its sixth digit.
        let mut sqp = Sqp::new(SqpOptions {
            tolerance: 1e-10,
            ..SqpOptions::default()
        });
        let mut ipopt = Ipopt::new(IpoptOptions {
            tol: 1e-10,
            ..IpoptOptions::default()
        });
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
            let a = sqp.solve(&mut ocp, Start::cold(&x));
            let b = ipopt.solve(&mut ocp, Start::cold(&x));
            assert!(
                a.status.is_success() && b.status.is_success(),
                "{hours} h, step {step}: {:?} {:?}",
                a.status,
                b.status
            );
            let (fa, fb) = (ocp.objective(&a.x), ocp.objective(&b.x));
            let rel = (fa - fb).abs() / fa.abs().max(fb.abs());
            assert!(
                rel <= 1e-6,
                "{hours} h, step {step}: sqp {fa:.12e} ipopt {fb:.12e} ({rel:.1e})"
            );
            let kkt = kkt_residuals(&mut ocp, &b.x, &b.multipliers, &b.bound_multipliers);
            assert!(kkt.max() <= 1e-6, "ipopt {hours} h, step {step}: {kkt:?}");
        }
    }
}

#[test]
fn venlo_two_day_closed_loop_with_ipopt_matches_the_peer_reward() {
    let Some(_) = common::data(
        common::VENLO,
        "venlo_two_day_closed_loop_with_ipopt_matches_the_peer_reward",
    ) else {
        return;
    };
    let plant = plant("models/lettuce-thesis.ghm");
    for (hours, reference) in [(1usize, -0.074630), (6, -0.069817)] {
        let m = closed_loop(
            &plant,
            2 * hours,
            Box::new(Ipopt::new(IpoptOptions::default())),
            96,
        );
        assert!(
            (m.cumulative_reward - reference).abs() < 2e-5,
            "{hours} h: reward {} vs {reference}",
            m.cumulative_reward
        );
        assert_eq!(m.solve.failed_solves, 0, "{hours} h: {:?}", m.solve);
    }
}
