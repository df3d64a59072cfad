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
