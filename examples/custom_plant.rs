//! A plant of your own, built in Rust with `ModelBuilder`, run for a day with a constant
//! heater and with economic MPC.
//!
//! A small heated room: temperature T [°C] relaxes to the outdoor temperature through the
//! walls and is raised by a heater u [W]; the heater costs money and the room should stay
//! in a comfort band.
//!
//! Run: `cargo run --release --example custom_plant`

use ghm::control::{ConstantInput, Controller, Mpc};
use ghm::model::{ModelBuilder, Plant};
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::Weather;
use ghm::solve::Ipm;
use std::sync::Arc;

fn room() -> Result<ghm::lang::Model, ghm::model::BuildError> {
    let mut b = ModelBuilder::new("room");
    let temp = b.state("temp", 15.0);
    let heat = b.input("heat", 0.0, 2000.0, Some(250.0), 0.0);
    let outside = b.disturbance("outside", None, Some(5.0));
    let capacity = b.param("capacity", 2.0e5); // J/°C
    let conductance = b.param("conductance", 40.0); // W/°C
    let price = b.param("price", 0.3 / 3.6e6); // €/J
                                               // dT/dt = (heat − conductance·(T − outside)) / capacity
    let gap = b.sub(temp, outside);
    let loss = b.mul(conductance, gap);
    let net = b.sub(heat, loss);
    let rhs = b.div(net, capacity);
    b.der(temp, rhs);
    let y = b.output("temp", temp);
    let period = b.constant(900.0);
    let energy = b.mul(heat, period);
    let cost = b.mul(price, energy);
    b.cost("energy", cost);
    b.soft(y, 19.0, 23.0, 0.01, 0.01);
    b.sample(900.0, 2);
    b.build()
}

fn main() {
    let plant = match room() {
        Ok(model) => Arc::new(Plant::new(model)),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let steps = 96; // one day of 15-minute steps
    let horizon = 8; // MPC looks two hours ahead
    let weather = Weather::constant(vec!["outside".into()], &[5.0], steps + horizon, 900.0);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let mpc = match Mpc::new(plant.clone(), horizon, Box::new(Ipm::default())) {
        Ok(mpc) => mpc,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let controllers: Vec<(&str, Box<dyn Controller>)> = vec![
        ("heater at 700 W", Box::new(ConstantInput(vec![700.0]))),
        ("economic MPC, 2 h", Box::new(mpc)),
    ];
    for (name, mut controller) in controllers {
        let mut coldest = f64::INFINITY;
        let mut sink = |log: &StepLog| coldest = coldest.min(log.outputs[0]);
        match run_season(&plant, &weather, controller.as_mut(), &config, &mut sink) {
            Ok(result) => println!(
                "{name:<18} room at {:.2} °C after a day (coldest {coldest:.2} °C); energy {:.3} €, comfort penalty {:.3} €, reward {:+.3}",
                result.final_state[0],
                -result.metrics.epi,
                result.metrics.total_penalty,
                result.metrics.cumulative_reward
            ),
            Err(e) => {
                eprintln!("error: {e}");
                std::process::exit(1);
            }
        }
    }
}
