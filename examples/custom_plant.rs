//! A plant of your own, built in Rust with `ModelBuilder`, run for a day with a constant
//! heater and with economic MPC.
//!
//! A small heated room: temperature T [°C] relaxes to the outdoor temperature through the
//! walls and is raised by a heater u [W]; the heater costs money and the room should stay
//! in a comfort band. `tests/builder.rs` checks that `room()` is the same model as its
//! `.ghm` twin.
//!
//! Run: `cargo run --release --example custom_plant`

use ghm::control::{ConstantInput, Controller, Mpc};
use ghm::prelude::*;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::Weather;
use ghm::solve::Ipm;
use std::sync::Arc;

/// The room, as `model room` in the `.ghm` language would say it.
pub fn room() -> Result<Model, BuildError> {
    let b = ModelBuilder::new("room");
    b.describe("a heated room, 15-minute control");
    let temp = b.state("temp", 15.0).unit("°C").describe("room air");
    let heat = b
        .input("heat")
        .unit("W")
        .bounds(0.0, 2000.0)
        .rate(250.0)
        .start(0.0)
        .describe("heater power");
    let outside = b.disturbance("outside").unit("°C").value(5.0);
    let capacity = b.param("capacity", 2.0e5).unit("J °C^-1").uncertain();
    let conductance = b.param("conductance", 40.0).unit("W °C^-1").uncertain();
    let price = b.param("price", 0.3 / 3.6e6).unit("EUR J^-1");
    let period = 900.0; // s

    b.der(temp, (heat - conductance * (temp - outside)) / capacity);
    let room_temp = b.output("room_temp", temp).unit("°C");
    room_temp
        .band(19.0, 23.0)
        .weight(0.01)
        .describe("comfort band");
    b.cost("energy", price * heat * period).unit("EUR");
    b.sample(period, 2);
    b.build()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let plant = Arc::new(Plant::new(room()?));
    let steps = 96; // one day of 15-minute steps
    let horizon = 8; // MPC looks two hours ahead
    let weather = Weather::constant(vec!["outside".into()], &[5.0], steps + horizon, 900.0);
    let config = SeasonConfig {
        steps,
        enforce_limits: true,
        uncertainty: None,
    };
    let mpc = Mpc::new(plant.clone(), horizon, Box::new(Ipm::default()))?;
    let controllers: Vec<(&str, Box<dyn Controller>)> = vec![
        ("heater at 700 W", Box::new(ConstantInput(vec![700.0]))),
        ("economic MPC, 2 h", Box::new(mpc)),
    ];
    for (name, mut controller) in controllers {
        let mut coldest = f64::INFINITY;
        let mut sink = |log: &StepLog| coldest = coldest.min(log.outputs[0]);
        let result = run_season(&plant, &weather, controller.as_mut(), &config, &mut sink)?;
        println!(
            "{name:<18} room at {:.2} °C after a day (coldest {coldest:.2} °C); energy {:.3} €, comfort penalty {:.3} €, reward {:+.3}",
            result.final_state[0],
            -result.metrics.epi,
            result.metrics.total_penalty,
            result.metrics.cumulative_reward
        );
    }
    Ok(())
}
