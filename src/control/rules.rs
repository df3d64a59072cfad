//! The model's own rules as a controller: each input set by the `rule` its declaration
//! gives (`input uBoil [-] in [0, 1] rule proportionalControl(tAir, heatSetPoint, …)`),
//! evaluated at the step's state, the weather of the step and the nominal parameters, then
//! held over the step. A model imported from GreenLight carries GreenLight's climate rules
//! (heating, vents, screens, lamps, CO₂) this way: the growers' baseline every economic
//! controller is compared with.
//!
//! GreenLight evaluates its rules continuously inside the integration; here they decide
//! once per sample period, as every controller of ghm does, so the closed loop differs
//! from GreenLight's by that hold (`docs/import.md`, "What each kind becomes", measures it).

use crate::control::{ControlError, Controller, Decision, Observation, StepRecord};
use crate::graph::{Tape, Workspace};
use crate::model::Plant;
use std::sync::Arc;
use std::time::Instant;

/// The controller that applies each input's `rule`. See the [module documentation](self).
///
/// ```
/// use ghm::control::{Controller, Observation, Rules};
/// use ghm::model::Plant;
/// use std::sync::Arc;
///
/// let text = "model tank\nstate level [m] = 1\ndisturbance inflow [m s^-1] value 0.1\n\
///             input valve [-] in [0, 1] rule min(1, max(0, level - 0.5))\n\
///             der level = inflow - 0.2 * valve\noutput level_m [m] = level\nsample 60 [s]\n";
/// let model = ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render()).unwrap();
/// let mut rules = Rules::new(Arc::new(Plant::new(model))).unwrap();
/// let seen = Observation { step: 0, state: &[1.2], outputs: &[1.2], previous_input: &[0.0], forecast: &[0.1] };
/// let input = rules.decide(&seen).unwrap().input;
/// assert!((input[0] - 0.7).abs() < 1e-12);
/// ```
#[derive(Debug, Clone)]
pub struct Rules {
    plant: Arc<Plant>,
    tape: Tape,
    workspace: Workspace<f64>,
    /// `(x, u, d, p)` packed as the tape reads them; `p` holds the nominal parameters.
    base: Vec<f64>,
}

impl Rules {
    /// The rules of `plant`'s model; refused, naming them, when some inputs have none.
    pub fn new(plant: Arc<Plant>) -> Result<Rules, ControlError> {
        let inputs = &plant.model.inputs;
        let without: Vec<&str> = inputs
            .iter()
            .filter(|u| u.rule.is_none())
            .map(|u| u.info.name.as_str())
            .collect();
        if inputs.is_empty() || !without.is_empty() {
            return Err(ControlError::Other(format!(
                "the rules controller needs a `rule` on every input of model `{}`; {} {}",
                plant.model.name,
                if inputs.is_empty() {
                    "it has no inputs".to_string()
                } else {
                    format!("these have none: {}", without.join(", "))
                },
                "(write `input NAME … rule EXPRESSION`, or import a GreenLight model with its controls as inputs)"
            )));
        }
        let nodes: Vec<_> = inputs.iter().filter_map(|u| u.rule).collect();
        let layout = plant.layout;
        let tape = plant.graph.compile(&nodes, layout.n_base());
        let workspace = tape.workspace();
        let mut base = vec![0.0; layout.n_base()];
        base[layout.p(0)..layout.p(0) + layout.np].copy_from_slice(&plant.model.nominal_params());
        Ok(Rules {
            plant,
            tape,
            workspace,
            base,
        })
    }
}

impl Controller for Rules {
    fn name(&self) -> String {
        "rules".into()
    }

    fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
        let clock = Instant::now();
        let l = self.plant.layout;
        let weather = o.forecast.get(..l.nd).ok_or_else(|| {
            ControlError::Other(format!(
                "the rules read this step's weather: {} values, the forecast has {}",
                l.nd,
                o.forecast.len()
            ))
        })?;
        self.base[..l.nx].copy_from_slice(o.state);
        self.base[l.u(0)..l.u(0) + l.nu].copy_from_slice(o.previous_input);
        self.base[l.d(0)..l.d(0) + l.nd].copy_from_slice(weather);
        let mut input = vec![0.0; l.nu];
        self.tape.eval(&mut self.workspace, &self.base, &mut input);
        Ok(Decision {
            input,
            record: StepRecord {
                solve_time_s: clock.elapsed().as_secs_f64(),
                ..StepRecord::default()
            },
        })
    }
}
