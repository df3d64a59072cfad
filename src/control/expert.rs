//! A rule-based greenhouse climate controller, as a grower would set one up: heat when the
//! air is cold, ventilate when it is warm or humid, dose CO₂ while there is light and the
//! vents are mostly closed. It guides RL-guided MPC without any training (the paper's
//! suggestion for future work) and is a baseline in its own right.
//!
//! The rules read the model's soft bands to place their set points, so they follow a
//! model file's bands:
//!
//! * heating: proportional below `T_heat = T_lo + ¼ (T_hi − T_lo)`, full power 5 °C below;
//! * ventilation: proportional above `T_vent = T_hi − ⅕ (T_hi − T_lo)` (up to 2 °C lower in
//!   strong sun, as the vents open slower than the air warms), full 2 °C above, and at
//!   least proportional to the humidity above `RH_hi − 5`, full at `RH_hi + 5` (`RH_hi` =
//!   85 % when the model has no humidity band);
//! * CO₂: proportional below a target, full 200 ppm below it; the target is
//!   `C_lo + ¼ (C_hi − C_lo)` while the radiation is positive and the ventilation below
//!   half its range (enrichment), else `C_lo + 50` (hold the floor);
//!
//! then the plant's rate limits and bounds ([`Plant::apply_limits`]).
//!
//! It needs a greenhouse model with outputs `temp`, `rh_pct` and `co2_ppm` (soft bands on
//! `temp` and `co2_ppm`), inputs `heating`, `ventilation` and `co2_supply`, and a disturbance
//! `radiation`, as the lettuce models have; [`Expert::new`] says what is missing.

use crate::control::{ControlError, Controller, Decision, Observation, StepRecord};
use crate::model::Plant;
use std::sync::Arc;
use std::time::Instant;

/// The humidity ceiling (%) when the model has no band on `rh_pct`.
pub const DEFAULT_HUMIDITY_CEILING: f64 = 85.0;

/// The rule-based controller. See the [module documentation](self).
///
/// ```
/// use ghm::control::Expert;
/// use ghm::model::Plant;
/// use std::sync::Arc;
///
/// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/lettuce.ghm");
/// let plant = Arc::new(Plant::new(ghm::lang::load(&file).map_err(|e| e.render()).unwrap()));
/// let expert = Expert::new(plant.clone()).unwrap();
/// // A cold night (8 °C, dark): heat, keep the vents shut, only hold the CO₂ floor.
/// let outputs = [0.004, 450.0, 8.0, 70.0]; // crop, CO₂ ppm, °C, RH %
/// let weather = [0.0, 7e-4, 2.0, 4e-3]; // radiation, CO₂, temperature, humidity outside
/// let u = expert.input(&outputs, &[0.0, 0.0, 50.0], &weather);
/// assert!(u[2] > 50.0 && u[2] <= 65.0); // heating up, by at most its rate limit (15 W/m²)
/// assert_eq!(u[1], 0.0); // no ventilation
/// assert!(u[0] > 0.0); // CO₂ below the floor of 550 ppm: dose
/// ```
#[derive(Debug, Clone)]
pub struct Expert {
    plant: Arc<Plant>,
    temp: usize,
    humidity: usize,
    co2: usize,
    heating: usize,
    ventilation: usize,
    co2_supply: usize,
    radiation: usize,
    temp_band: (f64, f64),
    humidity_ceiling: f64,
    co2_band: (f64, f64),
}

impl Expert {
    /// The expert for `plant`, or a message naming what the model lacks.
    pub fn new(plant: Arc<Plant>) -> Result<Expert, ControlError> {
        let model = &plant.model;
        let missing = |what: &str| {
            ControlError::Other(format!(
                "the expert needs {what} in model `{}` (it is written for the greenhouse models)",
                model.name
            ))
        };
        let output = |name: &str| {
            model
                .output_index(name)
                .ok_or_else(|| missing(&format!("an output `{name}`")))
        };
        let input = |name: &str| {
            model
                .inputs
                .iter()
                .position(|u| u.info.name == name)
                .ok_or_else(|| missing(&format!("an input `{name}`")))
        };
        let band = |index: usize, name: &str| {
            let mut lo = f64::NEG_INFINITY;
            let mut hi = f64::INFINITY;
            for b in model.soft.iter().filter(|b| b.output == index) {
                lo = lo.max(b.lower);
                hi = hi.min(b.upper);
            }
            if hi.is_finite() {
                Ok((lo, hi))
            } else {
                Err(missing(&format!("an upper soft bound on `{name}`")))
            }
        };
        let (temp, humidity, co2) = (output("temp")?, output("rh_pct")?, output("co2_ppm")?);
        let temp_band = band(temp, "temp")?;
        if !temp_band.0.is_finite() {
            return Err(missing("a lower soft bound on `temp`"));
        }
        let co2_band = band(co2, "co2_ppm")?;
        // Without a humidity band a grower still ventilates against condensation.
        let humidity_ceiling = band(humidity, "rh_pct").map_or(DEFAULT_HUMIDITY_CEILING, |b| b.1);
        let radiation = model
            .disturbances
            .iter()
            .position(|d| d.info.name == "radiation")
            .ok_or_else(|| missing("a disturbance `radiation`"))?;
        Ok(Expert {
            temp,
            humidity,
            co2,
            heating: input("heating")?,
            ventilation: input("ventilation")?,
            co2_supply: input("co2_supply")?,
            radiation,
            temp_band,
            humidity_ceiling,
            co2_band: (co2_band.0.max(0.0), co2_band.1),
            plant,
        })
    }

    /// The rules' input for outputs `y`, previous input and current weather `d`.
    pub fn input(&self, y: &[f64], previous: &[f64], d: &[f64]) -> Vec<f64> {
        let inputs = &self.plant.model.inputs;
        let top = |i: usize| inputs[i].upper;
        let ramp = |excess: f64, full: f64| (excess / full).clamp(0.0, 1.0);
        let (t_lo, t_hi) = self.temp_band;
        let span = t_hi - t_lo;
        let t = y[self.temp];
        let heat = top(self.heating) * ramp(t_lo + 0.25 * span - t, 5.0);
        let radiation = d.get(self.radiation).copied().unwrap_or(0.0);
        // In strong sun the air heats faster than the rate-limited vents open: open earlier.
        let sun_lead = 2.0 * ramp(radiation - 200.0, 200.0);
        let vent_temp = ramp(t - (t_hi - 0.2 * span - sun_lead), 2.0);
        let vent_humid = ramp(y[self.humidity] - (self.humidity_ceiling - 5.0), 10.0);
        let vent_share = vent_temp.max(vent_humid);
        let vent = top(self.ventilation) * vent_share;
        let (c_lo, c_hi) = self.co2_band;
        let light = radiation > 0.0;
        // Enrich in the light with the vents mostly closed; otherwise only hold the floor.
        let co2_target = if light && vent_share < 0.5 {
            c_lo + 0.25 * (c_hi - c_lo)
        } else {
            c_lo + 50.0
        };
        let co2 = top(self.co2_supply) * ramp(co2_target - y[self.co2], 200.0);
        let mut u = previous.to_vec();
        u[self.heating] = heat;
        u[self.ventilation] = vent;
        u[self.co2_supply] = co2;
        self.plant.apply_limits(previous, &mut u);
        u
    }
}

impl Controller for Expert {
    fn name(&self) -> String {
        "expert".into()
    }

    fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
        let started = Instant::now();
        let nd = self.plant.layout.nd;
        if o.forecast.len() < nd {
            return Err(ControlError::Other(
                "the expert needs the current weather".into(),
            ));
        }
        let input = self.input(o.outputs, o.previous_input, &o.forecast[..nd]);
        Ok(Decision {
            input,
            record: StepRecord {
                solve_time_s: started.elapsed().as_secs_f64(),
                ..StepRecord::default()
            },
        })
    }
}
