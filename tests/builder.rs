//! A plant built with `ModelBuilder` equals the same plant written in `.ghm`.

use ghm::model::{ModelBuilder, Plant};

const ROOM_GHM: &str = "
model room
state temp = 15
input heat in [0, 2000] rate 250 start 0
disturbance outside value 5
param capacity = 2e5
param conductance = 40
param price = 0.3 / 3.6e6
der temp = (heat - conductance * (temp - outside)) / capacity
output temp_out = temp
cost energy = price * heat * 900
soft temp_out in [19, 23] weight 0.01
sample 900 [s] integrator rk4 substeps 2
";

fn built() -> ghm::lang::Model {
    let mut b = ModelBuilder::new("room");
    let temp = b.state("temp", 15.0);
    let heat = b.input("heat", 0.0, 2000.0, Some(250.0), 0.0);
    let outside = b.disturbance("outside", None, Some(5.0));
    let capacity = b.param("capacity", 2.0e5);
    let conductance = b.param("conductance", 40.0);
    let price = b.param("price", 0.3 / 3.6e6);
    let gap = b.sub(temp, outside);
    let loss = b.mul(conductance, gap);
    let net = b.sub(heat, loss);
    let rhs = b.div(net, capacity);
    b.der(temp, rhs);
    let y = b.output("temp_out", temp);
    let per_step = b.constant(900.0);
    let ph = b.mul(price, heat);
    let cost = b.mul(ph, per_step);
    b.cost("energy", cost);
    b.soft(y, 19.0, 23.0, 0.01, 0.01);
    b.sample(900.0, 2);
    b.build().expect("complete model")
}

#[test]
fn builder_and_language_give_the_same_trajectory() {
    let from_file = Plant::new(
        ghm::lang::load_str("room.ghm", ROOM_GHM).unwrap_or_else(|e| panic!("{}", e.render())),
    );
    let from_code = Plant::new(built());
    let p = from_file.model.nominal_params();
    assert_eq!(p, from_code.model.nominal_params());
    let (mut a, mut b) = (vec![15.0], vec![15.0]);
    for k in 0..200 {
        let u = [((k * 37) % 2000) as f64];
        let sa = from_file.step(&a, &u, &[5.0], &p);
        let sb = from_code.step(&b, &u, &[5.0], &p);
        assert!((sa.next_state[0] - sb.next_state[0]).abs() <= 1e-12 * sa.next_state[0].abs());
        assert!((sa.economic() - sb.economic()).abs() <= 1e-12 * sa.economic().abs().max(1e-300));
        a = sa.next_state;
        b = sb.next_state;
    }
}

#[test]
fn builder_reports_missing_pieces() {
    let mut b = ModelBuilder::new("x");
    b.state("x", 1.0);
    b.sample(1.0, 1);
    assert_eq!(
        b.build().unwrap_err(),
        ghm::model::BuildError::MissingDerivative("x".into())
    );
    let mut b = ModelBuilder::new("x");
    let x = b.state("x", 1.0);
    b.der(x, x);
    assert_eq!(
        b.build().unwrap_err(),
        ghm::model::BuildError::NoSamplePeriod
    );
}

/// A plant without disturbances runs a season on a constant (empty) weather.
#[test]
fn plant_without_disturbances_runs_a_season() {
    let mut b = ModelBuilder::new("decay");
    let x = b.state("x", 1.0);
    let k = b.param("k", 0.1);
    let kx = b.mul(k, x);
    let rhs = b.neg(kx);
    b.der(x, rhs);
    b.sample(1.0, 1);
    let plant = Plant::new(b.build().expect("complete model"));
    let weather = ghm::sim::weather::Weather::constant(vec![], &[], 10, 1.0);
    assert_eq!(weather.len(), 10);
    let config = ghm::sim::season::SeasonConfig {
        steps: 10,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut none = ghm::control::ConstantInput(vec![]);
    let r = ghm::sim::season::run_season(
        &plant,
        &weather,
        &mut none,
        &config,
        &mut |_: &ghm::sim::season::StepLog| {},
    )
    .expect("season");
    assert!(r.final_state[0] < 1.0 && r.final_state[0] > 0.3);
}

/// The CSTR of `models/cstr.ghm`, written with the builder.
fn cstr_in_code() -> ghm::lang::Model {
    use ghm::graph::Op;
    let mut b = ModelBuilder::new("cstr");
    let ca = b.state("ca", 0.8772569);
    let temp = b.state("temp", 324.47544);
    let tc = b.input("tc", 250.0, 350.0, Some(3.0), 300.0);
    let q = b.param("q", 100.0);
    let vol = b.param("vol", 100.0);
    let caf = b.param("caf", 1.0);
    let tf = b.param("tf", 350.0);
    let rho = b.param("rho", 1000.0);
    let cp = b.param("cp", 0.239);
    let dh = b.param("dh", -5e4);
    let e_r = b.param("e_r", 8750.0);
    let k0 = b.param("k0", 7.2e10);
    let ua = b.param("ua", 5e4);
    let min_s = b.constant(60.0);
    // rate = k0 exp(−E/R / T); reaction = rate · Ca
    let ratio = b.div(e_r, temp);
    let minus = b.neg(ratio);
    let arrhenius = b.apply(Op::Exp, &[minus]);
    let rate = b.mul(k0, arrhenius);
    let reaction = b.mul(rate, ca);
    let dilution = b.div(q, vol);
    // dCa/dt
    let feed_gap = b.sub(caf, ca);
    let inflow = b.mul(dilution, feed_gap);
    let net = b.sub(inflow, reaction);
    let dca = b.div(net, min_s);
    b.der(ca, dca);
    // dT/dt
    let tf_gap = b.sub(tf, temp);
    let feed_heat = b.mul(dilution, tf_gap);
    let rho_cp = b.mul(rho, cp);
    let dh_rcp = b.div(dh, rho_cp);
    let heat_release = b.mul(dh_rcp, reaction);
    let v_rho_cp = b.mul(vol, rho_cp);
    let jacket_coefficient = b.div(ua, v_rho_cp);
    let tc_gap = b.sub(tc, temp);
    let jacket = b.mul(jacket_coefficient, tc_gap);
    let sum = b.sub(feed_heat, heat_release);
    let sum = b.add(sum, jacket);
    let dtemp = b.div(sum, min_s);
    b.der(temp, dtemp);
    b.output("conc", ca);
    let y_t = b.output("t_reactor", temp);
    // costs
    let two = b.constant(2.0);
    let ca_next = b.next(ca);
    let sp = b.constant(0.5);
    let dev = b.sub(ca_next, sp);
    let scale = b.constant(0.01);
    let dev = b.div(dev, scale);
    let tracking = b.pow(dev, two);
    b.cost("tracking", tracking);
    let tc_ss = b.constant(300.0);
    let move_ = b.sub(tc, tc_ss);
    let ten = b.constant(10.0);
    let move_ = b.div(move_, ten);
    let sq = b.pow(move_, two);
    let weight = b.constant(0.01);
    let effort = b.mul(weight, sq);
    b.cost("effort", effort);
    b.soft(y_t, f64::NEG_INFINITY, 355.0, 0.0, 100.0);
    assert!(
        !b.plan(f64::NEG_INFINITY, 360.0),
        "a planning bound outside the band"
    );
    assert!(b.plan(f64::NEG_INFINITY, 352.0));
    b.sample(6.0, 20);
    b.build().expect("complete CSTR")
}

#[test]
fn cstr_from_builder_and_file_give_the_same_trajectory_to_1e12() {
    let from_file = Plant::new(
        ghm::lang::load(std::path::Path::new("models/cstr.ghm"))
            .unwrap_or_else(|e| panic!("{}", e.render())),
    );
    let from_code = Plant::new(cstr_in_code());
    let p = from_file.model.nominal_params();
    assert_eq!(p, from_code.model.nominal_params());
    let (mut a, mut b) = (
        from_file.model.initial_state(),
        from_code.model.initial_state(),
    );
    assert_eq!(a, b);
    for k in 0..300 {
        let u = [290.0 + ((k * 7) % 30) as f64];
        let sa = from_file.step(&a, &u, &[], &p);
        let sb = from_code.step(&b, &u, &[], &p);
        for (x, y) in sa.next_state.iter().zip(&sb.next_state) {
            assert!((x - y).abs() <= 1e-12 * x.abs(), "step {k}: {x} vs {y}");
        }
        for (x, y) in sa.terms.iter().zip(&sb.terms) {
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(1e-300),
                "step {k}: {x} vs {y}"
            );
        }
        a = sa.next_state;
        b = sb.next_state;
    }
}
