//! A trained policy as a controller: at each step it builds the observation the agent was
//! trained on (outputs, previous input, step index, current weather, and the forecast rows
//! of an observation of version 2), standardises it with
//! the policy's frozen statistics, and maps the action to an input with the environment's
//! own map, so rate limits and bounds hold by construction.

use crate::agent::observation::{action_scale, input_from_action};
use crate::agent::PolicyFile;
use crate::control::{ControlError, Controller, Decision, Observation, StepRecord};
use crate::model::Plant;
use std::sync::Arc;
use std::time::Instant;

/// The deterministic policy of a [`PolicyFile`] driving a plant.
///
/// # Examples
///
/// The agent shipped for the lettuce greenhouse, for six half-hour steps of the built-in
/// season: whatever the network says, the inputs keep their bounds and rate limits.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::control::Policy;
/// use ghm::model::Plant;
/// use ghm::agent::PolicyFile;
/// use ghm::sim::season::{run_season, SeasonConfig, StepLog};
/// use ghm::sim::weather::builtin_season;
/// use std::sync::Arc;
///
/// let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
/// let plant = Arc::new(Plant::new(
///     ghm::lang::load(&root.join("models/lettuce.ghm")).map_err(|e| e.render())?,
/// ));
/// let file = PolicyFile::load(&root.join("models/agents/lettuce/policy.json"))?;
/// assert_eq!(file.model, plant.model.name);
/// let mut policy = Policy::new(&plant, file)?;
///
/// let columns = plant.model.weather_columns();
/// let weather = builtin_season(6, plant.model.sample_period, 1).select(&columns, 0, 6)?;
/// // No clipping by the season loop: the policy's own action map keeps the limits.
/// let config = SeasonConfig { steps: 6, enforce_limits: false, uncertainty: None };
/// let mut previous = plant.model.start_input();
/// run_season(&plant, &weather, &mut policy, &config, &mut |log: &StepLog| {
///     for (i, decl) in plant.model.inputs.iter().enumerate() {
///         let u = log.input[i];
///         assert!(decl.lower <= u && u <= decl.upper);
///         assert!((u - previous[i]).abs() <= decl.rate.unwrap() + 1e-12);
///     }
///     previous = log.input.clone();
/// })?;
///
/// // A policy trained on another model is refused.
/// let cstr = Arc::new(Plant::new(
///     ghm::lang::load(&root.join("models/cstr.ghm")).map_err(|e| e.render())?,
/// ));
/// let file = PolicyFile::load(&root.join("models/agents/lettuce/policy.json"))?;
/// assert!(Policy::new(&cstr, file).is_err());
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct Policy {
    policy: PolicyFile,
    scale: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    observation: Vec<f64>,
    nd: usize,
}

impl Policy {
    /// Checks that the policy observes what `plant` provides.
    pub fn new(plant: &Arc<Plant>, policy: PolicyFile) -> Result<Policy, ControlError> {
        let model = &plant.model;
        let (nu, nd) = (plant.layout.nu, plant.layout.nd);
        let width = policy.observation.width(model);
        if policy.normalizer.width() != width || policy.actor.outputs() != nu {
            return Err(ControlError::Other(format!(
                "the policy observes {} values and sets {} inputs; model `{}` gives {} and has {}",
                policy.normalizer.width(),
                policy.actor.outputs(),
                model.name,
                width,
                nu
            )));
        }
        let scale = action_scale(plant)?;
        Ok(Policy {
            policy,
            scale,
            lower: model.inputs.iter().map(|u| u.lower).collect(),
            upper: model.inputs.iter().map(|u| u.upper).collect(),
            observation: vec![0.0; width],
            nd,
        })
    }

    /// The policy file it runs (actor network and observation statistics).
    pub fn file(&self) -> &PolicyFile {
        &self.policy
    }
}

impl Controller for Policy {
    fn name(&self) -> String {
        "policy".into()
    }

    fn forecast_rows(&self) -> usize {
        self.policy.observation.forecast_rows()
    }

    fn decide(&mut self, o: &Observation) -> Result<Decision, ControlError> {
        let started = Instant::now();
        let (ny, nu) = (o.outputs.len(), o.previous_input.len());
        if o.forecast.len() < self.nd {
            return Err(ControlError::Other(
                "the policy needs the current weather".into(),
            ));
        }
        let obs = &mut self.observation;
        obs[..ny].copy_from_slice(o.outputs);
        self.policy.observation.write_after_outputs(
            &mut obs[ny..],
            o.previous_input,
            o.step,
            o.forecast,
            self.nd,
        );
        let action = self.policy.action(&self.observation[..])?;
        let mut input = vec![0.0; nu];
        input_from_action(
            o.previous_input,
            &action,
            &self.scale,
            &self.lower,
            &self.upper,
            &mut input,
        );
        Ok(Decision {
            input,
            record: StepRecord {
                solve_time_s: started.elapsed().as_secs_f64(),
                ..StepRecord::default()
            },
        })
    }
}
