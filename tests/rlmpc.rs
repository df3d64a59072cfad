//! RL-guided MPC: the value node's derivatives and its agreement with burn, the two terminal
//! cost forms, the guess and terminal region on a hand-made case, VFO, and 2-day closed
//! loops with each guide (built-in weather and the agents shipped under models/agents/;
//! no ../shared), each pinned to its recorded reward, none beating the season optimum.

use burn::tensor::{Device, Tensor, TensorData};
use ghm::control::{
    taylor_terminal_cost, Controller, Expert, Guidance, Mpc, Observation, Policy, RlGuidance,
    RlMpcOptions, TerminalCostForm, ValueFile, ValueTerminalCost,
};
use ghm::model::Plant;
use ghm::nlp::{Nlp, Ocp, TerminalCost};
use ghm::nn::{Activation, ScaledMlp};
use ghm::rl::sac::net::Net;
use ghm::rl::PolicyFile;
use ghm::sim::optimum::season_optimum;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::{builtin_season, Weather};
use ghm::solve::Sqp;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::sync::Arc;

const MODEL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/lettuce.ghm");
const SHIPPED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/models/agents/lettuce");

fn plant() -> Arc<Plant> {
    let model = ghm::lang::load(Path::new(MODEL)).unwrap_or_else(|e| panic!("{}", e.render()));
    Arc::new(Plant::new(model))
}

fn weather(plant: &Plant, steps: usize) -> Weather {
    let columns = plant.model.weather_columns();
    builtin_season(steps, plant.model.sample_period, 2014)
        .select(&columns, 0, steps)
        .expect("built-in weather has the model's columns")
}

/// A random tanh value network over (dry weight, step).
fn random_value(seed: u64) -> (Net, ValueFile) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let net = Net::init_xavier(&[2, 16, 16, 1], Activation::Tanh, &mut rng);
    let mlp = net.to_mlp(Activation::Identity).unwrap();
    let function = ScaledMlp::new(mlp, vec![0.002, 0.0], vec![0.6, 1920.0], 2.0, 1.5).unwrap();
    let value = ValueFile {
        model: "lettuce".into(),
        guide: "expert".into(),
        state_index: 0,
        state_name: "dry_weight".into(),
        function,
        train_loss: 0.0,
        validation_loss: 0.0,
    };
    (net, value)
}

#[test]
fn value_node_matches_burn_and_its_derivatives_match_finite_differences() {
    let (net, value) = random_value(3);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let n = 1000;
    let z: Vec<f32> = (0..2 * n).map(|_| rng.random_range(-5.0..5.0)).collect();
    let device = Device::flex().autodiff();
    let burn_out = net
        .tensors(&device, false)
        .forward(Tensor::<2>::from_data(
            TensorData::new(z.clone(), [n, 2]),
            &device,
        ))
        .into_data()
        .try_to_vec::<f32>()
        .unwrap();
    let worst = z
        .chunks(2)
        .zip(&burn_out)
        .map(|(row, b)| {
            let ours = value
                .function
                .net
                .forward(&[f64::from(row[0]), f64::from(row[1])])[0];
            (ours - f64::from(*b)).abs()
        })
        .fold(0.0, f64::max);
    assert!(worst < 1e-5, "largest difference from burn {worst:e}");

    let mut cost = ValueTerminalCost::new(value.clone());
    let state = [0.2, 0.001, 15.0, 0.008];
    let (mut g, mut h) = (vec![0.0; 4], vec![0.0; 16]);
    let t = cost.evaluate(&state, 700, &mut g, &mut h);
    assert!((t + value.value(&state, 700)).abs() < 1e-15);
    let e = 1e-5;
    let at = |x0: f64| -value.value(&[x0, 0.001, 15.0, 0.008], 700);
    let fd_g = (at(0.2 + e) - at(0.2 - e)) / (2.0 * e);
    let fd_h = (at(0.2 + e) - 2.0 * at(0.2) + at(0.2 - e)) / (e * e);
    assert!(
        (g[0] - fd_g).abs() <= 1e-7 * (1.0 + fd_g.abs()),
        "{} vs {fd_g}",
        g[0]
    );
    assert!(
        (h[0] - fd_h).abs() <= 1e-3 * (1.0 + fd_h.abs()),
        "{} vs {fd_h}",
        h[0]
    );
    assert!(g[1..].iter().all(|v| *v == 0.0) && h[1..].iter().all(|v| *v == 0.0));
}

/// The Taylor terminal cost is the exact one's first-order expansion: at the anchor they
/// agree in value and gradient (bit for bit); a step `δ` along the dry weight away from it
/// they differ by the exact cost's curvature term `½ T″ δ²` and a third-order rest; other
/// states move neither; the Taylor gradient stays the anchor's; far away they part.
#[test]
fn taylor_is_the_first_order_expansion_of_the_exact_terminal_cost() {
    let (_, value) = random_value(7);
    let anchor = [0.15, 0.0009, 17.0, 0.009];
    let mut exact = ValueTerminalCost::new(value.clone());
    let mut taylor = taylor_terminal_cost(&value, &anchor, 300);
    let (mut g1, mut h1, mut g2, mut h2) =
        (vec![0.0; 4], vec![0.0; 16], vec![0.0; 4], vec![0.0; 16]);
    let t1 = exact.evaluate(&anchor, 300, &mut g1, &mut h1);
    let t2 = taylor.evaluate(&anchor, 300, &mut g2, &mut h2);
    assert_eq!((t1, g1.clone()), (t2, g2.clone()));
    assert!(h2.iter().all(|v| *v == 0.0));
    let (slope, curvature) = (g1[0], h1[0]);
    // Other states than the dry weight change neither cost.
    let mut other = anchor;
    other[2] += 3.0;
    other[1] *= 2.0;
    assert_eq!(exact.evaluate(&other, 300, &mut g1, &mut h1), t1);
    assert_eq!(taylor.evaluate(&other, 300, &mut g2, &mut h2), t1);
    // Along the dry weight: D(δ) = exact − Taylor = ½ T″ δ² + T‴ δ³ / 6 + O(δ⁴). Its even
    // part is the curvature term to O(δ⁴) (measured: 1.4e-5 of it at δ = 5e-4, 9.3e-4 at
    // 4e-3), its odd part grows eightfold as δ doubles (8.0 measured). A slope off by any
    // ε adds ε δ to the odd part, which then only doubles.
    let mut difference = |delta: f64| {
        let mut x = anchor;
        x[0] += delta;
        let d =
            exact.evaluate(&x, 300, &mut g1, &mut h1) - taylor.evaluate(&x, 300, &mut g2, &mut h2);
        assert_eq!(g2[0], slope, "the Taylor gradient is the anchor's");
        d
    };
    let mut odd_before: Option<f64> = None;
    for delta in [5e-4, 1e-3, 2e-3, 4e-3] {
        let (up, down) = (difference(delta), difference(-delta));
        let (even, odd) = ((up + down) / 2.0, (up - down) / 2.0);
        let second = 0.5 * curvature * delta * delta;
        assert!(
            (even - second).abs() <= 1e-2 * second.abs(),
            "δ = {delta}: even part {even:e}, ½ T″ δ² {second:e}"
        );
        if let Some(before) = odd_before {
            let ratio = odd / before;
            assert!(
                (7.0..=9.0).contains(&ratio),
                "δ = {delta}: odd part grew {ratio}×"
            );
        }
        odd_before = Some(odd);
    }
    // Far from the anchor (dry weight +0.1: the exact cost moves by −0.850) the linear form
    // misses by −0.121; it must miss by a tenth of the move at least.
    let mut away = anchor;
    away[0] += 0.1;
    let e = exact.evaluate(&away, 300, &mut g1, &mut h1);
    let t = taylor.evaluate(&away, 300, &mut g2, &mut h2);
    assert!(
        (e - t).abs() >= 0.1 * (e - t1).abs(),
        "exact {e}, Taylor {t}, at the anchor {t1}"
    );
}

fn observation<'a>(
    step: usize,
    state: &'a [f64],
    outputs: &'a [f64],
    previous: &'a [f64],
    forecast: &'a [f64],
) -> Observation<'a> {
    Observation {
        step,
        state,
        outputs,
        previous_input: previous,
        forecast,
    }
}

#[test]
fn shifted_guess_and_terminal_region_on_a_hand_made_case() {
    let plant = plant();
    let horizon = 3;
    let w = weather(&plant, 40);
    let forecast = w.horizon(20, horizon).unwrap().to_vec();
    let state = vec![0.01, 0.0008, 14.0, 0.007];
    let previous_input = vec![0.0, 0.5, 40.0];
    let (_, value) = random_value(9);
    let mut ocp = Ocp::new(plant.clone(), horizon).unwrap();
    ocp.set_problem(20, &state, &previous_input, &forecast)
        .unwrap();
    // A previous plan: these inputs, simulated from the state.
    let plan = [0.1, 0.6, 45.0, 0.2, 0.0, 50.0, 0.0, 0.3, 35.0];
    let mut previous = vec![0.0; ocp.n_vars()];
    ocp.rollout(&plan, &mut previous);
    let expert = Expert::new(plant.clone()).unwrap();
    let mut guidance = RlGuidance::new(
        plant.clone(),
        Box::new(expert.clone()),
        "expert",
        Some(value),
        RlMpcOptions::default(),
    )
    .unwrap();
    let mut start = vec![0.0; ocp.n_vars()];
    let outputs = vec![0.0; plant.model.outputs.len()];
    let obs = observation(20, &state, &outputs, &previous_input, &forecast);
    guidance
        .prepare(&mut ocp, &obs, &forecast, Some(&previous), &mut start)
        .unwrap();
    // Shift: stage j takes the previous stage j + 1's input.
    assert_eq!(ocp.input(&start, 0), &plan[3..6]);
    assert_eq!(ocp.input(&start, 1), &plan[6..9]);
    // The appended input: the expert at the previous plan's terminal point.
    let x_end = ocp.state_at(&previous, horizon).to_vec();
    let nd = plant.layout.nd;
    let d = &forecast[2 * nd..3 * nd];
    let mut ws = plant.workspace();
    let p = plant.model.nominal_params();
    let mut y = vec![0.0; plant.model.outputs.len()];
    plant.outputs_into(&mut ws, &x_end, &plan[6..9], d, &p, &mut y);
    let appended = expert.input(&y, &plan[6..9], d);
    assert_eq!(ocp.input(&start, 2), appended.as_slice());
    // The region: ±5 % around the expert's step from the terminal point; the zero CO₂
    // component of the appended input (if any) is pinned.
    let terminal = plant.step(&x_end, &appended, d, &p).next_state;
    let (mut lower, mut upper) = (vec![0.0; ocp.n_vars()], vec![0.0; ocp.n_vars()]);
    ocp.var_bounds(&mut lower, &mut upper);
    let x_n = ocp.layout().x(horizon);
    for i in 0..4 {
        let (a, b) = (0.95 * terminal[i], 1.05 * terminal[i]);
        assert!((lower[x_n + i] - a.min(b)).abs() < 1e-15, "state {i}");
        assert!((upper[x_n + i] - a.max(b)).abs() < 1e-15, "state {i}");
    }
    // The last input: ±5 % around the appended one, intersected with the input's box (the
    // upper side never below the lower); both sides checked, so a region collapsed to the
    // appended input fails too.
    let u_last = ocp.layout().u(horizon - 1);
    for (i, (u, decl)) in appended.iter().zip(&plant.model.inputs).enumerate() {
        let (a, b) = (0.95 * u, 1.05 * u);
        let lo = decl.lower.max(a.min(b));
        let hi = decl.upper.min(a.max(b)).max(lo);
        assert_eq!(
            (lower[u_last + i], upper[u_last + i]),
            (lo, hi),
            "input {i}: {u}"
        );
    }
    assert!(
        appended.iter().any(|u| *u > 0.0),
        "a region with some width to check: {appended:?}"
    );

    // VFO: the same guess, no region.
    let mut vfo = RlGuidance::new(
        plant.clone(),
        Box::new(expert),
        "expert",
        None,
        RlMpcOptions {
            epsilon: None,
            terminal_cost: TerminalCostForm::Exact,
        },
    )
    .unwrap();
    vfo.prepare(&mut ocp, &obs, &forecast, Some(&previous), &mut start)
        .unwrap();
    ocp.var_bounds(&mut lower, &mut upper);
    let mut plain = Ocp::new(plant.clone(), horizon).unwrap();
    plain
        .set_problem(20, &state, &previous_input, &forecast)
        .unwrap();
    let (mut plain_lower, mut plain_upper) = (vec![0.0; ocp.n_vars()], vec![0.0; ocp.n_vars()]);
    plain.var_bounds(&mut plain_lower, &mut plain_upper);
    assert_eq!(lower, plain_lower);
    assert_eq!(upper, plain_upper);
}

/// Runs `controller` for two days; returns (cumulative reward, failed solves).
fn two_days(plant: &Arc<Plant>, w: &Weather, controller: &mut dyn Controller) -> (f64, usize) {
    let config = SeasonConfig {
        steps: 96,
        enforce_limits: true,
        uncertainty: None,
    };
    let r = run_season(plant, w, controller, &config, &mut |_: &StepLog| {}).unwrap();
    (r.metrics.cumulative_reward, r.metrics.solve.failed_solves)
}

/// Recorded 2-day rewards (€ m⁻², paper variant, built-in weather, 1 h horizon, SQP), printed
/// by `cargo test --test rlmpc two_day -- --nocapture`. A closed loop of SQP solves is
/// deterministic; 2e-5 is what separates two correct solvers on such a loop (the 2-day MPC
/// against IPOPT in `venlo_mpc`), well below the gaps between the controllers. On these
/// two days neither guide beats plain MPC (the value networks were fitted on the season's
/// returns); the optimum beats all. The expert's loop forks on rounding: when the value
/// network's derivatives came from `Mlp::forward_second_along` instead of `Dual2` (the
/// same to 1e-13), its reward moved from −0.0791662143 to −0.0794525464; the others stayed
/// to ten digits.
const RECORDED: [(&str, f64); 4] = [
    ("rlmpc[sac]", -0.0630464243),
    ("rlmpc[expert]", -0.0794525464),
    ("mpc", -0.0615744084),
    ("optimum", -0.0515496153),
];
const RECORDED_TOL: f64 = 2e-5;

#[test]
fn two_day_closed_loops_with_each_guide_reproduce_their_recorded_rewards() {
    let plant = plant();
    let horizon = 2;
    let w = weather(&plant, 96 + horizon);
    let shipped = Path::new(SHIPPED);
    let policy = PolicyFile::load(&shipped.join("policy.json")).expect("shipped agent");
    let guides: Vec<(&str, Box<dyn Controller + Send>)> = vec![
        ("sac", Box::new(Policy::new(&plant, policy).unwrap())),
        ("expert", Box::new(Expert::new(plant.clone()).unwrap())),
    ];
    let mut rewards = Vec::new();
    for (name, guide) in guides {
        let value = ValueFile::load(&shipped.join(format!("value-{name}.json"))).unwrap();
        let guidance = RlGuidance::new(
            plant.clone(),
            guide,
            name,
            Some(value),
            RlMpcOptions::default(),
        )
        .unwrap();
        let mut rlmpc = Mpc::new(plant.clone(), horizon, Box::new(Sqp::default()))
            .unwrap()
            .with_guidance(Box::new(guidance));
        let (reward, failed) = two_days(&plant, &w, &mut rlmpc);
        assert_eq!(failed, 0, "rlmpc[{name}]: {failed} failed solves");
        rewards.push(reward);
    }
    let mut mpc = Mpc::new(plant.clone(), horizon, Box::new(Sqp::default())).unwrap();
    let mut inputs = Vec::new();
    let config = SeasonConfig {
        steps: 96,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut sink = |log: &StepLog| inputs.extend_from_slice(&log.input);
    let plain = run_season(&plant, &w, &mut mpc, &config, &mut sink).unwrap();
    assert_eq!(plain.metrics.solve.failed_solves, 0);
    rewards.push(plain.metrics.cumulative_reward);
    let optimum = season_optimum(plant.clone(), &w, 96, &inputs, &mut Sqp::default()).unwrap();
    assert!(optimum.solution.status.is_success());
    let mut table = ghm::control::InputTable(optimum.inputs.clone());
    let (best, _) = two_days(&plant, &w, &mut table);
    rewards.push(best);
    for ((name, _), reward) in RECORDED.iter().zip(&rewards) {
        eprintln!("{name}: {reward:.10}");
    }
    for ((name, recorded), reward) in RECORDED.iter().zip(&rewards) {
        assert!(
            (reward - recorded).abs() <= RECORDED_TOL,
            "{name}: {reward:.10}, recorded {recorded}"
        );
        assert!(
            *reward <= best + 1e-9,
            "{name}: {reward} beats the optimum {best}"
        );
    }
}
