//! A controller of your own: a rule-based greenhouse climate controller implementing the
//! `Controller` trait, run over two days and compared with economic MPC on the same plant
//! and weather.
//!
//! Run: `cargo run --release --example custom_controller`

use ghm::control::{ControlError, Controller, Decision, Mpc, Observation, StepRecord};
use ghm::model::Plant;
use ghm::sim::metrics::Metrics;
use ghm::sim::season::{run_season, SeasonConfig, StepLog};
use ghm::sim::weather::{builtin_season, Weather};
use ghm::solve::Ipm;
use std::path::Path;
use std::sync::Arc;

/// What a grower might program: dose CO₂ while the sun shines, heat below a set point,
/// ventilate above another one. Inputs: CO₂ supply, ventilation, heating; outputs of the
/// lettuce model: crop, CO₂ [ppm], temperature [°C], relative humidity [%].
struct RuleBased {
    heat_below_c: f64,
    vent_above_c: f64,
    co2_target_ppm: f64,
}

impl Controller for RuleBased {
    fn name(&self) -> String {
        "rule-based".into()
    }

    fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
        let (co2_ppm, temp) = (o.outputs[1], o.outputs[2]);
        let radiation = o.forecast.first().copied().unwrap_or(0.0);
        let co2 = if radiation > 10.0 && co2_ppm < self.co2_target_ppm {
            1.2
        } else {
            0.0
        };
        let ventilation = if temp > self.vent_above_c { 7.5 } else { 0.0 };
        let heating = if temp < self.heat_below_c { 150.0 } else { 0.0 };
        // The season loop clips to the bounds and rate limits, as for every controller.
        Ok(Decision {
            input: vec![co2, ventilation, heating],
            record: StepRecord::default(),
        })
    }
}

fn season(
    plant: &Plant,
    weather: &Weather,
    controller: &mut dyn Controller,
) -> Result<Metrics, Box<dyn std::error::Error>> {
    let config = SeasonConfig {
        steps: 96,
        enforce_limits: true,
        uncertainty: None,
    };
    let mut ignore = |_: &StepLog| {};
    Ok(run_season(plant, weather, controller, &config, &mut ignore)?.metrics)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
    let plant = Arc::new(Plant::new(ghm::lang::load(&file)?));
    let columns = plant.model.weather_columns();
    let weather =
        builtin_season(96 + 6, plant.model.sample_period, 2014).select(&columns, 0, 96 + 6)?;

    let mut rules = RuleBased {
        heat_below_c: 12.0,
        vent_above_c: 19.0,
        co2_target_ppm: 900.0,
    };
    let mut mpc = Mpc::new(plant.clone(), 6, Box::new(Ipm::default()))?;
    println!("two days on the built-in weather   EPI [EUR/m2]   cumulative reward [EUR/m2]");
    for (name, controller) in [
        ("rule-based", &mut rules as &mut dyn Controller),
        ("MPC, 3 h", &mut mpc),
    ] {
        let m = season(&plant, &weather, controller)?;
        println!(
            "  {name:<32} {:+.4}        {:+.4}",
            m.epi, m.cumulative_reward
        );
    }
    Ok(())
}
