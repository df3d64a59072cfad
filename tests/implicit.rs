//! The implicit integrators (`radau5`, `radau3`, `backward_euler`, `sdirk3`): their order on
//! a smooth problem, their stability on a stiff one where RK4 blows up, and the exact
//! derivatives of their steps (implicit function theorem) against finite differences and
//! against a very fine unrolled RK4 of the same flow. Built-in text only, no ../shared.

use ghm::model::verify::verify_step_derivatives;
use ghm::model::{Plant, StepDerivatives};

/// Prothero–Robinson, `y' = λ (y − cos t) − sin t`, `y(0) = 1`: the solution is `cos t` for
/// every λ, and λ sets the stiffness. One step of 1 s with `substeps` sub-steps.
fn prothero_robinson(integrator: &str, substeps: usize, lambda: f64) -> Plant {
    let text = format!(
        "model pr\n\
         sample 1 [s] integrator {integrator} substeps {substeps}\n\
         state y = 1\n\
         disturbance time [s] clock\n\
         param lambda = {lambda}\n\
         der y = lambda * (y - cos(time)) - sin(time)\n\
         output out = y\n"
    );
    Plant::new(ghm::lang::load_str("pr.ghm", &text).unwrap_or_else(|e| panic!("{}", e.render())))
}

fn error_after_one_second(integrator: &str, substeps: usize, lambda: f64) -> f64 {
    let plant = prothero_robinson(integrator, substeps, lambda);
    let p = plant.model.nominal_params();
    let step = plant.step(&[1.0], &[], &[0.0], &p);
    (step.next_state[0] - 1f64.cos()).abs()
}

#[test]
fn each_method_reaches_its_order() {
    for (integrator, order) in [
        ("backward_euler", 1.0),
        ("radau3", 3.0),
        ("sdirk3", 3.0),
        ("radau5", 5.0),
    ] {
        let coarse = error_after_one_second(integrator, 4, -1.0);
        let fine = error_after_one_second(integrator, 8, -1.0);
        let observed = (coarse / fine).log2();
        assert!(
            observed > order - 0.3,
            "{integrator}: errors {coarse:e} → {fine:e}, observed order {observed:.2}, expected {order}"
        );
    }
}

/// λ h = −10⁶: RK4 is unstable far beyond its limit (|λ h| < 2.8) while every L-stable
/// method follows the solution.
#[test]
fn stiff_problem_is_stable_for_implicit_methods_only() {
    for integrator in ["backward_euler", "radau3", "sdirk3", "radau5"] {
        let e = error_after_one_second(integrator, 1, -1e6);
        assert!(e < 1e-5, "{integrator}: error {e:e} on the stiff problem");
    }
    let rk4 = error_after_one_second("rk4", 1, -1e6);
    assert!(
        rk4.is_nan() || rk4 > 1.0,
        "RK4 at λh = −10⁶ should blow up, error {rk4:e}"
    );
}

/// A nonlinear plant with an input, a parameter, a clock and a stage cost on the state after
/// the step, for derivative checks.
fn nonlinear(integrator: &str, substeps: usize) -> Plant {
    let text = format!(
        "model oscillator\n\
         sample 0.5 [s] integrator {integrator} substeps {substeps}\n\
         state pos = 1.2\n\
         state vel = -0.3\n\
         input force in [-2, 2]\n\
         disturbance time [s] clock\n\
         param damping = 1.5\n\
         der pos = vel\n\
         der vel = damping * (1 - pos^2) * vel - pos + force * cos(time) + 0.1 * exp(-pos)\n\
         output energy = 0.5 * vel^2 + 0.5 * pos^2\n\
         reward late [-] = -next(pos)^2 * next(vel)\n\
         cost push [-] = 0.2 * force^2\n"
    );
    Plant::new(
        ghm::lang::load_str("oscillator.ghm", &text).unwrap_or_else(|e| panic!("{}", e.render())),
    )
}

/// Random-ish points `(x, u, d, p)`.
fn points() -> Vec<Vec<f64>> {
    (0..6)
        .map(|k| {
            let t = k as f64;
            vec![
                1.2 * (0.7 * t).cos(),
                0.8 * (1.3 * t).sin(),
                1.5 * (0.4 * t).sin(),
                100.0 * t,
                1.5,
            ]
        })
        .collect()
}

#[test]
fn implicit_derivatives_match_finite_differences() {
    for integrator in ["radau5", "sdirk3", "backward_euler"] {
        let plant = nonlinear(integrator, 2);
        let report = verify_step_derivatives(&plant, &points());
        assert!(report.non_finite.is_none(), "{integrator}: {report:?}");
        assert!(
            report.jacobian_max_rel_error < 1e-6 && report.hessian_max_rel_error < 1e-5,
            "{integrator}: {report:?}"
        );
    }
}

/// The Radau IIA step's exact derivatives (8 sub-steps of 1/16 s) equal those of the flow itself, computed by an
/// unrolled RK4 of 1 000 sub-steps, to 1e-6 relative: the derivatives are of the step taken,
/// and the step is accurate.
#[test]
fn implicit_derivatives_match_a_very_fine_rk4() {
    let implicit = nonlinear("radau5", 8);
    let fine = nonlinear("rk4", 1000);
    let wrt = [0, 1, 2];
    let (mut a, mut b) = (
        StepDerivatives::new(&implicit, &wrt),
        StepDerivatives::new(&fine, &wrt),
    );
    let weights = [0.7, -1.3, 0.4, 0.9, 0.5];
    assert_eq!(implicit.n_step_outputs(), weights.len());
    for z in points() {
        let ea = a.hessian(&implicit, &z, &weights).clone();
        let eb = b.hessian(&fine, &z, &weights).clone();
        let close = |x: &[f64], y: &[f64], what: &str| {
            let scale = y.iter().fold(1e-3f64, |m, v| m.max(v.abs()));
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                assert!(
                    (p - q).abs() <= 1e-6 * scale,
                    "{what}[{i}] at {z:?}: radau5 {p:e} vs fine RK4 {q:e}"
                );
            }
        };
        close(&ea.values, &eb.values, "values");
        close(&ea.jacobian, &eb.jacobian, "jacobian");
        close(&ea.gradient, &eb.gradient, "gradient");
        close(&ea.hessian, &eb.hessian, "hessian");
        for r in 0..3 {
            for c in 0..3 {
                assert_eq!(ea.hessian[r * 3 + c], ea.hessian[c * 3 + r], "symmetric");
            }
        }
    }
}

/// A step whose Newton iteration cannot converge gives NaN, which the season loop reports,
/// never a wrong number.
#[test]
fn a_step_that_cannot_be_solved_is_not_finite() {
    // ẏ = y² from y = 10 over 1 s blows up at t = 0.1 s: no real stage values exist.
    let text =
        "model blowup\nsample 1 [s] integrator radau5\nstate y = 10\nder y = y^2\noutput out = y\n";
    let plant = Plant::new(ghm::lang::load_str("b.ghm", text).unwrap());
    let step = plant.step(&[10.0], &[], &[], &[]);
    assert!(step.next_state[0].is_nan(), "{:?}", step.next_state);
}

/// In a simulation, a sub-step whose Newton iteration fails is solved in pieces, and so is
/// the rest of the step: `ẏ = y²` from `y = 1` is `1 / (1 − t)`, 10 at `t = 0.9`. Newton
/// does not solve RADAU5's stage equations over all three sub-steps of 0.3 s: an
/// optimiser's step, which cannot split, has no value there, while the simulated step
/// reaches the solution.
#[test]
fn a_sub_step_newton_cannot_solve_whole_is_solved_in_pieces() {
    let text = "model blowup\nsample 0.9 [s] integrator radau5 substeps 3\nstate y = 1\n\
                der y = y^2\noutput out = y\n";
    let plant = Plant::new(ghm::lang::load_str("b.ghm", text).unwrap());
    let mut derivatives = StepDerivatives::new(&plant, &[0]);
    let whole = derivatives.jacobian(&plant, &[1.0]).values[0];
    assert!(whole.is_nan(), "the step solved whole: {whole}");
    let step = plant.step(&[1.0], &[], &[], &[]);
    let y = step.next_state[0];
    // Within 0.2 % (10.0098 today): the solution is steep, blowing up at t = 1.
    assert!((y - 10.0).abs() < 0.02, "y(0.9) = {y}, exactly 10");
}
