//! The optimal-control transcription: sizes, patterns and exact derivatives checked against
//! finite differences of its own function values (built-in model files, no ../shared).

use ghm::model::Plant;
use ghm::nlp::{Nlp, Ocp};
use std::path::Path;
use std::sync::Arc;

fn plant(file: &str) -> Arc<Plant> {
    let model = ghm::lang::load(Path::new(file)).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

/// The lettuce model integrated by an implicit method instead of RK4.
fn implicit_lettuce(integrator: &str) -> Arc<Plant> {
    let text = std::fs::read_to_string("models/lettuce.ghm").unwrap();
    let rk4 = "integrator rk4 substeps 4";
    assert!(
        text.contains(rk4),
        "models/lettuce.ghm's sample statement changed"
    );
    let text = text.replace(rk4, &format!("integrator {integrator} substeps 1"));
    let model =
        ghm::lang::load_str("lettuce.ghm", &text).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

/// A point away from the bounds, with every soft band active somewhere.
fn problem(horizon: usize) -> (Ocp, Vec<f64>, Vec<f64>) {
    problem_with(plant("models/lettuce.ghm"), horizon)
}

/// [`problem`] with another lettuce plant.
fn problem_with(plant: Arc<Plant>, horizon: usize) -> (Ocp, Vec<f64>, Vec<f64>) {
    let mut ocp = Ocp::new(plant.clone(), horizon).unwrap();
    let nd = plant.layout.nd;
    let forecast: Vec<f64> = (0..horizon)
        .flat_map(|j| [20.0 + 10.0 * j as f64, 7e-4, 6.0 + j as f64, 0.006])
        .collect();
    assert_eq!(forecast.len(), horizon * nd);
    let x0 = plant.model.initial_state();
    ocp.set_problem(0, &x0, &[0.5, 1.0, 60.0], &forecast)
        .unwrap();
    let inputs: Vec<f64> = (0..horizon)
        .flat_map(|j| [0.4 + 0.05 * j as f64, 1.5, 55.0 + j as f64])
        .collect();
    let mut x = vec![0.0; ocp.n_vars()];
    ocp.rollout(&inputs, &mut x);
    // Off the dynamics manifold, so every row has a non-trivial value.
    for (i, v) in x.iter_mut().enumerate() {
        *v *= 1.0 + 1e-3 * ((i % 7) as f64 - 3.0);
    }
    let multipliers: Vec<f64> = (0..ocp.n_cons())
        .map(|i| 0.3 + 0.1 * (i % 5) as f64)
        .collect();
    (ocp, x, multipliers)
}

fn dense(pattern: &ghm::nlp::Pattern, values: &[f64], rows: usize, cols: usize) -> Vec<f64> {
    let mut m = vec![0.0; rows * cols];
    for ((&r, &c), &v) in pattern.rows.iter().zip(&pattern.cols).zip(values) {
        m[r * cols + c] += v;
    }
    m
}

fn step_size(v: f64) -> f64 {
    1e-6 * v.abs().max(1e-3)
}

/// Asserts that a central difference `fd` agrees with the exact derivative `exact` to
/// `rtol` of the exact value, or of `floor` where that is smaller: `|fd − exact| ≤ rtol ·
/// max(|exact|, floor)`. The floor is where the differences' rounding noise takes over;
/// structurally zero entries come out exactly zero on both sides.
fn assert_agrees(fd: f64, exact: f64, (rtol, floor): (f64, f64), what: impl Fn() -> String) {
    assert!(
        (fd - exact).abs() <= rtol * exact.abs().max(floor),
        "{}: difference {fd:e} vs exact {exact:e}",
        what()
    );
}

// Tolerances from the worst entries at the test point (models/lettuce.ghm, 3 steps): the
// gradient's central differences agree to 8e-8 of the largest entries and to 6e-12 on
// entries near 1e-7; the Jacobian's to 8e-6 (∂g29/∂x21 ≈ −7.7e-4, truncation) and 1e-11
// near 1e-8; the Hessian's (differences of the Lagrangian's gradient) to 2.5e-5 of the
// entries above 1e-3 and 2e-8 absolute below. Each tolerance leaves a margin of 4 or more
// over those, and a 1e-5 relative error in a price-sized gradient entry (the heating
// price, 6.4e-5 € per W m⁻²) fails; the old absolute 1e-6 let 1.5 % through.
/// `(rtol, floor)` of the objective gradient.
const GRADIENT_TOL: (f64, f64) = (1e-6, 1e-4);
/// `(rtol, floor)` of the constraint Jacobian.
const JACOBIAN_TOL: (f64, f64) = (3e-5, 1e-5);
/// `(rtol, floor)` of the Hessian of the Lagrangian.
const HESSIAN_TOL: (f64, f64) = (1e-4, 1e-3);

#[test]
fn gradient_and_jacobian_match_central_differences() {
    first_derivatives_match_central_differences(problem(3));
}

/// The implicit function theorem's derivatives of a Radau IIA step, through the whole
/// transcription.
#[test]
fn implicit_steps_give_derivatives_that_match_central_differences() {
    for integrator in ["radau5", "sdirk3"] {
        first_derivatives_match_central_differences(problem_with(implicit_lettuce(integrator), 3));
        hessian_matches(problem_with(implicit_lettuce(integrator), 3));
    }
}

fn first_derivatives_match_central_differences((mut ocp, x, _): (Ocp, Vec<f64>, Vec<f64>)) {
    let (n, m) = (ocp.n_vars(), ocp.n_cons());
    let mut grad = vec![0.0; n];
    ocp.gradient(&x, &mut grad);
    let pattern = ocp.jacobian_pattern().clone();
    let mut jac = vec![0.0; pattern.len()];
    ocp.jacobian_values(&x, &mut jac);
    let jac = dense(&pattern, &jac, m, n);
    for i in 0..n {
        let h = step_size(x[i]);
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[i] += h;
        xm[i] -= h;
        let df = (ocp.objective(&xp) - ocp.objective(&xm)) / (2.0 * h);
        assert_agrees(df, grad[i], GRADIENT_TOL, || format!("∂f/∂x{i}"));
        let (mut gp, mut gm) = (vec![0.0; m], vec![0.0; m]);
        ocp.constraints(&xp, &mut gp);
        ocp.constraints(&xm, &mut gm);
        for r in 0..m {
            let d = (gp[r] - gm[r]) / (2.0 * h);
            let e = jac[r * n + i];
            assert_agrees(d, e, JACOBIAN_TOL, || format!("∂g{r}/∂x{i}"));
        }
    }
}

#[test]
fn hessian_matches_differences_of_the_lagrangian_gradient() {
    hessian_matches(problem(3));
}

fn hessian_matches((mut ocp, x, lambda): (Ocp, Vec<f64>, Vec<f64>)) {
    let n = ocp.n_vars();
    let sigma = 0.7;
    let pattern = ocp.hessian_pattern().clone();
    let mut hv = vec![0.0; pattern.len()];
    ocp.hessian_values(&x, sigma, &lambda, &mut hv);
    let lower = dense(&pattern, &hv, n, n);
    let jp = ocp.jacobian_pattern().clone();
    let grad_l = |ocp: &mut Ocp, x: &[f64]| {
        let mut g = vec![0.0; n];
        ocp.gradient(x, &mut g);
        g.iter_mut().for_each(|v| *v *= sigma);
        let mut j = vec![0.0; jp.len()];
        ocp.jacobian_values(x, &mut j);
        for ((&r, &c), &v) in jp.rows.iter().zip(&jp.cols).zip(&j) {
            g[c] += lambda[r] * v;
        }
        g
    };

    for i in 0..n {
        let h = step_size(x[i]);
        let (mut xp, mut xm) = (x.clone(), x.clone());
        xp[i] += h;
        xm[i] -= h;
        let (gp, gm) = (grad_l(&mut ocp, &xp), grad_l(&mut ocp, &xm));
        for r in i..n {
            let d = (gp[r] - gm[r]) / (2.0 * h);
            let e = lower[r * n + i];
            assert_agrees(d, e, HESSIAN_TOL, || format!("H[{r},{i}]"));
        }
    }
}

/// The terminal hooks RL-guided MPC needs: a linear terminal cost changes the plan the
/// way its gradient says, and a terminal box holds at the solution, which satisfies KKT.
#[test]
fn terminal_cost_and_terminal_box_shape_the_solution() {
    use ghm::nlp::{LinearTerminalCost, TerminalBox};
    use ghm::solve::{kkt_residuals, Ipm, Solver, Sqp, Start};
    let plant = plant("models/lettuce.ghm");
    let n = 4;
    let forecast: Vec<f64> = (0..n).flat_map(|_| [120.0, 7e-4, 6.0, 6e-3]).collect();
    let x0 = plant.model.initial_state();
    let solve = |ocp: &mut Ocp| {
        ocp.set_problem(0, &x0, &plant.model.start_input(), &forecast)
            .unwrap();
        let mut start = vec![0.0; ocp.n_vars()];
        ocp.initial_point(&mut start);
        let s = Sqp::default().solve(ocp, Start::cold(&start));
        assert!(s.status.is_success(), "{:?}", s.status);
        let kkt = kkt_residuals(ocp, &s.x, &s.multipliers, &s.bound_multipliers);
        assert!(kkt.max() <= 1e-6, "{kkt:?}");
        // That holds by SQP's own stopping rule; the interior point, another algorithm,
        // must find the same optimum.
        let ipm = Ipm::default().solve(ocp, Start::cold(&start));
        assert!(ipm.status.is_success(), "{:?}", ipm.status);
        let (f, g) = (s.stats.objective, ipm.stats.objective);
        assert!(
            (f - g).abs() <= 1e-6 * (1.0 + f.abs()),
            "SQP {f} vs IPM {g}"
        );
        s
    };
    let mut plain = Ocp::new(plant.clone(), n).unwrap();
    let free = solve(&mut plain);
    let temp_at_end = |ocp: &Ocp, x: &[f64]| ocp.state_at(x, n)[2];
    let t_free = temp_at_end(&plain, &free.x);

    // A reward for a warm greenhouse at the end (cost −0.01 € per °C) warms the plan.
    let mut rewarded = Ocp::new(plant.clone(), n).unwrap();
    rewarded.set_terminal_cost(Some(Box::new(LinearTerminalCost {
        value: 0.0,
        gradient: vec![0.0, 0.0, -0.01, 0.0],
        anchor: x0.clone(),
    })));
    let warm = solve(&mut rewarded);
    assert!(
        temp_at_end(&rewarded, &warm.x) > t_free + 0.1,
        "{} vs {t_free}",
        temp_at_end(&rewarded, &warm.x)
    );

    // A terminal box 0.5 °C under the free plan's end temperature holds at the solution.
    let mut boxed = Ocp::new(plant.clone(), n).unwrap();
    let cap = t_free - 0.5;
    boxed.set_terminal_box(Some(TerminalBox {
        state_lower: vec![f64::NEG_INFINITY; 4],
        state_upper: vec![f64::INFINITY, f64::INFINITY, cap, f64::INFINITY],
        input_lower: vec![f64::NEG_INFINITY; 3],
        input_upper: vec![f64::INFINITY; 3],
    }));
    let capped = solve(&mut boxed);
    assert!(temp_at_end(&boxed, &capped.x) <= cap + 1e-9);
}

/// Lettuce with `terminal` terms appended to its model file.
fn lettuce_with_terminal(terms: &str) -> Arc<Plant> {
    let text = std::fs::read_to_string("models/lettuce.ghm").unwrap() + terms;
    let model =
        ghm::lang::load_str("lettuce.ghm", &text).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

/// The model's own `terminal` terms join every horizon's objective with exact first and
/// second derivatives, added to a terminal cost set from outside.
#[test]
fn model_terminal_terms_have_exact_derivatives_beside_an_outside_terminal_cost() {
    use ghm::nlp::LinearTerminalCost;
    let terms = "\nterminal crop_left [EUR m^-2] = 4 * dry_weight - 0.002 * (temp_air - 18)^2 + 30 * co2_air * hum_air\nterminal air_left [EUR m^-2] = 1e-3 * log(1 + temp_air^2)\n";
    let with_terms = || problem_with(lettuce_with_terminal(terms), 3);
    first_derivatives_match_central_differences(with_terms());
    hessian_matches(with_terms());
    let (mut ocp, x, lambda) = with_terms();
    ocp.set_terminal_cost(Some(Box::new(LinearTerminalCost {
        value: 0.5,
        gradient: vec![0.0, 2.0, -0.01, 0.0],
        anchor: vec![0.0; 4],
    })));
    first_derivatives_match_central_differences((ocp, x.clone(), lambda.clone()));

    // The objective is the plain problem's plus minus the terms at x_N.
    let (mut plain, _, _) = problem(3);
    let (mut ocp, _, _) = with_terms();
    let x_n = ocp.state_at(&x, 3).to_vec();
    let (w, c, t, h) = (x_n[0], x_n[1], x_n[2], x_n[3]);
    let reward = 4.0 * w - 0.002 * (t - 18.0).powi(2) + 30.0 * c * h + 1e-3 * (1.0 + t * t).ln();
    let gap = ocp.objective(&x) - plain.objective(&x);
    assert!(
        (gap + reward).abs() <= 1e-12 * reward.abs().max(1.0),
        "{gap} vs {reward}"
    );
}

/// A linear `terminal` term in the model file plans as the same cost set from outside.
#[test]
fn a_linear_model_terminal_plans_as_the_same_outside_terminal_cost() {
    use ghm::nlp::LinearTerminalCost;
    use ghm::solve::{Ipm, Solver, Start};
    let n = 4;
    let forecast: Vec<f64> = (0..n).flat_map(|_| [120.0, 7e-4, 6.0, 6e-3]).collect();
    let solve = |mut ocp: Ocp| {
        let plant = ocp.plant().clone();
        ocp.set_problem(
            0,
            &plant.model.initial_state(),
            &plant.model.start_input(),
            &forecast,
        )
        .unwrap();
        let mut start = vec![0.0; ocp.n_vars()];
        ocp.initial_point(&mut start);
        let s = Ipm::default().solve(&mut ocp, Start::cold(&start));
        assert!(s.status.is_success(), "{:?}", s.status);
        s.x
    };
    let in_model = lettuce_with_terminal("\nterminal warm_end [EUR m^-2] = 0.01 * temp_air\n");
    let from_model = solve(Ocp::new(in_model, n).unwrap());
    let mut outside = Ocp::new(plant("models/lettuce.ghm"), n).unwrap();
    outside.set_terminal_cost(Some(Box::new(LinearTerminalCost {
        value: 0.0,
        gradient: vec![0.0, 0.0, -0.01, 0.0],
        anchor: vec![0.0; 4],
    })));
    let from_outside = solve(outside);
    let gap = from_model
        .iter()
        .zip(&from_outside)
        .map(|(a, b)| (a - b).abs() / a.abs().max(1.0))
        .fold(0.0, f64::max);
    assert!(gap <= 1e-9, "plans differ by {gap:e}");
}

/// `Solver::set_iteration_limit` caps the next solves and is lifted by `None`.
#[test]
fn iteration_limit_caps_sqp_until_lifted() {
    use ghm::solve::{SolveStatus, Solver, Sqp, Start};
    let (mut ocp, _, _) = problem(3);
    let mut start = vec![0.0; ocp.n_vars()];
    ocp.initial_point(&mut start);
    let mut sqp = Sqp::default();
    sqp.set_iteration_limit(Some(1));
    let capped = sqp.solve(&mut ocp, Start::cold(&start));
    assert!(capped.stats.iterations <= 1);
    assert_ne!(capped.status, SolveStatus::Optimal);
    sqp.set_iteration_limit(None);
    let full = sqp.solve(&mut ocp, Start::cold(&start));
    assert!(full.status.is_success(), "{:?}", full.status);
    assert!(full.stats.iterations > 1);
}

/// A terminal region narrows the bounds of `x_N` and `u_{N−1}` but not their scales: the
/// SQP's Levenberg–Marquardt term is divided by the squared scale, and a region's width
/// there would make it large enough to slow Newton's method to a linear rate.
#[test]
fn terminal_region_leaves_variable_scales_alone() {
    use ghm::nlp::TerminalBox;
    let (mut ocp, x, _) = problem(3);
    let n = ocp.n_vars();
    let scales = |ocp: &Ocp| {
        let (mut lower, mut upper, mut s) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        ocp.var_bounds(&mut lower, &mut upper);
        ocp.var_scales(&lower, &upper, &mut s);
        s
    };
    let free = scales(&ocp);
    let x_n = ocp.state_at(&x, 3).to_vec();
    let u_last = ocp.input(&x, 2).to_vec();
    let region = ghm::control::terminal_region(&x_n, &u_last, 0.05);
    let region: TerminalBox = region;
    ocp.set_terminal_box(Some(region));
    let (mut lower, mut upper) = (vec![0.0; n], vec![0.0; n]);
    ocp.var_bounds(&mut lower, &mut upper);
    let x_n_at = ocp.layout().x(3);
    for (i, v) in x_n.iter().enumerate() {
        let width = upper[x_n_at + i] - lower[x_n_at + i];
        assert!(
            (width - 0.1 * v.abs()).abs() <= 1e-12 * v.abs(),
            "x_N[{i}]: {width}"
        );
    }
    assert_eq!(scales(&ocp), free);
}

/// The slacks a stage's outputs `y` imply, one per band side in the transcription's order
/// (each band's lower side, then its upper side): the planning bounds' penalties.
fn slacks_at(plant: &Plant, y: &[f64]) -> Vec<f64> {
    let mut s = Vec::new();
    for band in &plant.model.soft {
        if band.plan_lower.is_finite() && band.weight_below > 0.0 {
            s.push((band.weight_below * (band.plan_lower - y[band.output])).max(0.0));
        }
        if band.plan_upper.is_finite() && band.weight_above > 0.0 {
            s.push((band.weight_above * (y[band.output] - band.plan_upper)).max(0.0));
        }
    }
    s
}

/// The CSTR over 3 steps: 2 states, 1 input, 1 slack (the reactor-temperature ceiling),
/// 1 rate row per stage from the second on, no disturbances. Variables
/// `[u0 s0 | x1 u1 s1 | x2 u2 s2 | x3]` (12), rows `[dyn0 soft0 | dyn1 soft1 rate1 |
/// dyn2 soft2 rate2]` (11).
fn cstr_problem() -> (Arc<Plant>, Ocp) {
    let plant = plant("models/cstr.ghm");
    let ocp = Ocp::new(plant.clone(), 3).unwrap();
    let l = *ocp.layout();
    assert_eq!((l.nx, l.nu, l.ns, l.nr), (2, 1, 1, 1));
    assert_eq!((ocp.n_vars(), ocp.n_cons()), (12, 11));
    (plant, ocp)
}

/// `shift_primal` moves every stage one step forward and repeats the last input; the new
/// last state is the plant's step from the old last state, and the slacks are those the
/// new states imply. Checked element by element against the vector built by hand.
#[test]
fn shift_primal_moves_the_plan_one_step_forward() {
    let (plant, mut ocp) = cstr_problem();
    let p = plant.model.nominal_params();
    // A previous plan near the temperature ceiling (352 K planned), so slacks are active.
    let previous = [
        301.0, 0.0, // u0 s0
        0.60, 345.0, 302.0, 0.0, // x1 u1 s1
        0.55, 351.0, 299.5, 0.0, // x2 u2 s2
        0.50, 353.0, // x3
    ];
    let measured = [0.62, 344.0];
    ocp.set_problem(1, &measured, &[301.0], &[]).unwrap();
    let mut x = vec![f64::NAN; 12];
    ocp.shift_primal(&previous, &mut x);
    let step = |state: &[f64], u: f64| plant.step(state, &[u], &[], &p);
    let last = step(&[0.50, 353.0], 299.5);
    let s0 = slacks_at(&plant, &step(&measured, 302.0).next_outputs)[0];
    let s1 = slacks_at(&plant, &step(&[0.55, 351.0], 299.5).next_outputs)[0];
    let s2 = slacks_at(&plant, &last.next_outputs)[0];
    assert!(s1 > 0.0 && s2 > 0.0, "the ceiling binds: {s1} {s2}");
    let expected = [
        302.0,
        s0, // u0 = old u1
        0.55,
        351.0,
        299.5,
        s1, // x1 = old x2, u1 = old u2
        0.50,
        353.0,
        299.5,
        s2, // x2 = old x3, u2 = old u2 repeated
        last.next_state[0],
        last.next_state[1], // x3 = F(old x3, old u2)
    ];
    for (i, (a, b)) in x.iter().zip(&expected).enumerate() {
        assert!(
            (a - b).abs() <= 1e-12 * b.abs().max(1.0),
            "x[{i}]: {a} vs {b}"
        );
    }
}

/// `shift_multipliers` and `shift_bound_multipliers` move the multipliers like the primal
/// point: each stage's rows (variables) take the next stage's, the last stage repeats, and
/// the bound multipliers of the new `x_N` start at zero.
#[test]
fn shift_multipliers_move_rows_and_bounds_one_stage_forward() {
    let (_, ocp) = cstr_problem();
    let previous: Vec<f64> = (0..11).map(|i| 100.0 + i as f64).collect();
    let mut shifted = vec![f64::NAN; 11];
    ocp.shift_multipliers(&previous, &mut shifted);
    // Rows: dyn0 = 0,1, soft0 = 2 | dyn1 = 3,4, soft1 = 5, rate1 = 6 | dyn2 = 7,8, soft2 = 9,
    // rate2 = 10. Stage 0 takes stage 1's dynamics and soft rows (it has no rate row);
    // stages 1 and 2 take stage 2's.
    let rows = [3, 4, 5, 7, 8, 9, 10, 7, 8, 9, 10];
    let expected: Vec<f64> = rows.iter().map(|&r| previous[r]).collect();
    assert_eq!(shifted, expected);

    let previous: Vec<f64> = (0..12).map(|i| 200.0 + i as f64).collect();
    let mut shifted = vec![f64::NAN; 12];
    ocp.shift_bound_multipliers(&previous, &mut shifted);
    // Variables: u0 = 0, s0 = 1 | x1 = 2,3, u1 = 4, s1 = 5 | x2 = 6,7, u2 = 8, s2 = 9 | x3 =
    // 10,11.
    let from = [4, 5, 6, 7, 8, 9, 10, 11, 8, 9];
    let mut expected: Vec<f64> = from.iter().map(|&v| previous[v]).collect();
    expected.extend([0.0, 0.0]);
    assert_eq!(shifted, expected);
}

/// `restore_feasibility` keeps the inputs, re-simulates the states with the plant's step
/// on each stage's forecast row, and sets the slacks to the penalties they imply: the
/// dynamics rows then hold exactly and the soft rows are satisfied.
#[test]
fn restore_feasibility_resimulates_the_states_with_the_plant_step() {
    let (mut ocp, mut x, _) = problem(3);
    let plant = ocp.plant().clone();
    let p = plant.model.nominal_params();
    let l = *ocp.layout();
    let forecast: Vec<Vec<f64>> = (0..3)
        .map(|j| vec![20.0 + 10.0 * j as f64, 7e-4, 6.0 + j as f64, 0.006])
        .collect();
    // Off the dynamics: states and slacks far from what the inputs give.
    for j in 1..=3 {
        x[l.x(j)..l.x(j) + l.nx].iter_mut().for_each(|v| *v *= 1.1);
    }
    x.iter_mut().skip(l.s(0)).take(l.ns).for_each(|v| *v = 5.0);
    let inputs: Vec<Vec<f64>> = (0..3).map(|j| ocp.input(&x, j).to_vec()).collect();
    assert!(Nlp::restore_feasibility(&mut ocp, &mut x));
    let mut state = ocp.state().to_vec();
    for j in 0..3 {
        assert_eq!(ocp.input(&x, j), &inputs[j][..], "u_{j} kept");
        let out = plant.step(&state, &inputs[j], &forecast[j], &p);
        let restored = ocp.state_at(&x, j + 1);
        for (i, (a, b)) in restored.iter().zip(&out.next_state).enumerate() {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs(),
                "x_{}[{i}]: {a} vs {b}",
                j + 1
            );
        }
        let slacks = &x[l.s(j)..l.s(j) + l.ns];
        for (k, (a, b)) in slacks
            .iter()
            .zip(slacks_at(&plant, &out.next_outputs))
            .enumerate()
        {
            assert!(
                (a - b).abs() <= 1e-12 * b.abs().max(1e-9),
                "s_{j}[{k}]: {a} vs {b}"
            );
        }
        state = out.next_state;
    }
    let mut g = vec![0.0; ocp.n_cons()];
    ocp.constraints(&x, &mut g);
    for j in 0..3 {
        let dynamics = &g[l.dynamics_row(j)..l.dynamics_row(j) + l.nx];
        assert!(
            dynamics.iter().all(|v| v.abs() <= 1e-12),
            "stage {j}: {dynamics:?}"
        );
        let soft = &g[l.soft_row(j)..l.soft_row(j) + l.ns];
        assert!(soft.iter().all(|v| *v >= -1e-12), "stage {j}: {soft:?}");
    }
}

#[test]
fn a_long_horizon_swept_in_parallel_gives_the_stage_blocks_of_a_short_one() {
    // 130 stages are swept by two threads (stages 0–64 and 65–129); a 70-stage problem
    // started at x_65 with the same later stages is swept by one. The Hessian blocks,
    // Jacobians and constraints of the common stages must agree bit for bit.
    let plant = plant("models/cstr.ghm");
    let (long_n, offset, short_n) = (130, 65, 70);
    let mut long = Ocp::new(plant.clone(), long_n).unwrap();
    let mut x = vec![0.0; long.n_vars()];
    long.initial_point(&mut x);
    let l = *long.layout();
    // A point away from the roll-out, and multipliers of both signs.
    for (i, v) in x.iter_mut().enumerate() {
        *v += 1e-3 * ((i * 7919 % 13) as f64 - 6.0);
    }
    let lambda: Vec<f64> = (0..long.n_cons())
        .map(|r| ((r * 104729 % 17) as f64 - 8.0) * 0.1)
        .collect();
    let (mut g, mut grad) = (vec![0.0; long.n_cons()], vec![0.0; long.n_vars()]);
    let mut jac = vec![0.0; long.jacobian_pattern().len()];
    let mut hess = vec![0.0; long.hessian_pattern().len()];
    long.evaluate_all(&x, 1.0, &lambda, &mut g, &mut grad, &mut jac, &mut hess);

    let mut short = Ocp::new(plant.clone(), short_n).unwrap();
    let s = *short.layout();
    let x0 = x[l.x(offset)..l.x(offset) + l.nx].to_vec();
    let u_before = x[l.u(offset - 1)..l.u(offset - 1) + l.nu].to_vec();
    short.set_problem(0, &x0, &u_before, &[]).unwrap();
    let mut y = vec![0.0; short.n_vars()];
    let mut mu = vec![0.0; short.n_cons()];
    let stage_len = s.nx + s.nu + s.ns;
    for i in 0..short_n.min(long_n - offset) {
        let j = offset + i;
        y[s.u(i)..s.u(i) + s.nu + s.ns].copy_from_slice(&x[l.u(j)..l.u(j) + l.nu + l.ns]);
        y[s.x(i + 1)..s.x(i + 1) + s.nx].copy_from_slice(&x[l.x(j + 1)..l.x(j + 1) + l.nx]);
        let rows = s.nx + s.ns;
        mu[s.dynamics_row(i)..s.dynamics_row(i) + rows]
            .copy_from_slice(&lambda[l.dynamics_row(j)..l.dynamics_row(j) + rows]);
    }
    let (mut g2, mut grad2) = (vec![0.0; short.n_cons()], vec![0.0; short.n_vars()]);
    let mut jac2 = vec![0.0; short.jacobian_pattern().len()];
    let mut hess2 = vec![0.0; short.hessian_pattern().len()];
    short.evaluate_all(&y, 1.0, &mu, &mut g2, &mut grad2, &mut jac2, &mut hess2);

    let nw = s.nx + s.nu;
    let (first, per_stage) = (s.nu * (s.nu + 1) / 2, nw * (nw + 1) / 2);
    let block =
        |values: &[f64], j: usize| values[first + (j - 1) * per_stage..][..per_stage].to_vec();
    for i in 1..long_n - offset {
        assert_eq!(
            block(&hess, offset + i),
            block(&hess2, i),
            "Hessian of stage {i}"
        );
        let (a, b) = (l.dynamics_row(offset + i), s.dynamics_row(i));
        assert_eq!(
            g[a..a + s.nx + s.ns],
            g2[b..b + s.nx + s.ns],
            "rows of stage {i}"
        );
    }
    assert_eq!(stage_len, l.nx + l.nu + l.ns);
}

/// A store whose NLP derivatives are known by hand: `x⁺ = x + u` (rk4 of `ẋ = 0.1 u` over
/// 10 s is exact for a constant input), a reward `2 (x⁺ − x) = 2u`, a cost `1.5 u²`, and a
/// band `1 ≤ y ≤ 25` on `y = x⁺²` with weight 4 on each side.
const STORE_GHM: &str = r#"
model store "a store whose NLP derivatives are known by hand"
sample 10 [s] integrator rk4 substeps 1
state x [kg] = 1 "stock"
input u [kg s^-1] in [0, 10] start 0 "inflow"
der x = 0.1 * u
output y [kg^2] = x * x "stock squared"
reward gain [EUR] = 2 * (next(x) - x) "value of the stock gained"
cost effort [EUR] = 1.5 * u * u "effort"
soft y in [1, 25] weight 4 "band"
"#;

/// The stage costs and the soft bands' penalties differentiated by hand, on the store
/// above: objective `Σ −2u_j + 1.5 u_j² + s_j`, gradient `−2 + 3u_j` and 1 per slack; the
/// band rows `s + 4 (y − 1)` and `s − 4 (y − 25)` with `∂y/∂x_j = ∂y/∂u_j = 2 (x_j + u_j)`;
/// the Hessian of the Lagrangian `3σ` on each `u_j` plus `8 (λ_lo − λ_hi)` on the stage's
/// `(x_j, u_j)` block. Every entry exact to rounding (1e-12 relative), where the central
/// differences above allow 1e-6 of the gradient and 1e-4 of the Hessian.
#[test]
fn stage_cost_and_penalty_derivatives_equal_the_hand_figures() {
    let model =
        ghm::lang::load_str("store.ghm", STORE_GHM).unwrap_or_else(|e| panic!("{}", e.render()));
    let plant = Arc::new(Plant::new(model));
    let n = 3;
    let mut ocp = Ocp::new(plant, n).unwrap();
    let l = *ocp.layout();
    assert_eq!((l.nx, l.nu, l.ns, l.nr), (1, 1, 2, 0));
    let x0 = 1.5;
    ocp.set_problem(0, &[x0], &[0.0], &[]).unwrap();
    let (nv, m) = (ocp.n_vars(), ocp.n_cons());
    // A point off the dynamics: states, inputs and slacks chosen freely.
    let (xs, us) = ([x0, 2.2, 3.1, 4.0], [0.5, 1.25, 2.0]);
    let slacks = [[0.3, 0.7], [0.1, 0.2], [0.9, 0.4]];
    let mut v = vec![0.0; nv];
    for j in 0..n {
        if j > 0 {
            v[l.x(j)] = xs[j];
        }
        v[l.u(j)] = us[j];
        v[l.s(j)..l.s(j) + 2].copy_from_slice(&slacks[j]);
    }
    v[l.x(n)] = xs[n];
    let near = |a: f64, e: f64| (a - e).abs() <= 1e-12 * e.abs().max(1.0);

    let f: f64 = (0..n)
        .map(|j| -2.0 * us[j] + 1.5 * us[j] * us[j] + slacks[j][0] + slacks[j][1])
        .sum();
    assert!(near(ocp.objective(&v), f), "{} vs {f}", ocp.objective(&v));
    let mut expected = vec![0.0; nv];
    for j in 0..n {
        expected[l.u(j)] = -2.0 + 3.0 * us[j];
        expected[l.s(j)] = 1.0;
        expected[l.s(j) + 1] = 1.0;
    }
    let mut grad = vec![0.0; nv];
    ocp.gradient(&v, &mut grad);
    for (i, (a, e)) in grad.iter().zip(&expected).enumerate() {
        assert!(near(*a, *e), "∂f/∂v{i}: {a} vs {e}");
    }

    let mut expected = vec![0.0; m * nv];
    let mut set = |r: usize, c: usize, value: f64| expected[r * nv + c] = value;
    for j in 0..n {
        let (d, lo, hi) = (l.dynamics_row(j), l.soft_row(j), l.soft_row(j) + 1);
        let dy = 2.0 * (xs[j] + us[j]);
        set(d, l.x(j + 1), 1.0);
        set(d, l.u(j), -1.0);
        set(lo, l.u(j), 4.0 * dy);
        set(lo, l.s(j), 1.0);
        set(hi, l.u(j), -4.0 * dy);
        set(hi, l.s(j) + 1, 1.0);
        if j > 0 {
            set(d, l.x(j), -1.0);
            set(lo, l.x(j), 4.0 * dy);
            set(hi, l.x(j), -4.0 * dy);
        }
    }
    let pattern = ocp.jacobian_pattern().clone();
    let mut values = vec![0.0; pattern.len()];
    ocp.jacobian_values(&v, &mut values);
    let jac = dense(&pattern, &values, m, nv);
    for (i, (a, e)) in jac.iter().zip(&expected).enumerate() {
        assert!(near(*a, *e), "∂g{}/∂v{}: {a} vs {e}", i / nv, i % nv);
    }

    let sigma = 0.7;
    let lambda: Vec<f64> = (0..m).map(|r| 0.3 + 0.25 * r as f64).collect();
    let mut expected = vec![0.0; nv * nv];
    for j in 0..n {
        let bands = 8.0 * (lambda[l.soft_row(j)] - lambda[l.soft_row(j) + 1]);
        expected[l.u(j) * nv + l.u(j)] = 3.0 * sigma + bands;
        if j > 0 {
            expected[l.x(j) * nv + l.x(j)] = bands;
            expected[l.u(j) * nv + l.x(j)] = bands;
        }
    }
    let pattern = ocp.hessian_pattern().clone();
    let mut values = vec![0.0; pattern.len()];
    ocp.hessian_values(&v, sigma, &lambda, &mut values);
    let hess = dense(&pattern, &values, nv, nv);
    for r in 0..nv {
        for c in 0..=r {
            let (a, e) = (hess[r * nv + c], expected[r * nv + c]);
            assert!(near(a, e), "H[{r},{c}]: {a} vs {e}");
        }
    }
}
