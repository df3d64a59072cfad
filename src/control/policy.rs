//! A trained policy as a controller: at each step it builds the observation the agent was
//! trained on (outputs, previous input, step index, current weather), standardises it with
//! the policy's frozen statistics, and maps the action to an input with the environment's
//! own map, so rate limits and bounds hold by construction.

use crate::control::{ControlError, Controller, Decision, Observation, StepRecord};
use crate::model::Plant;
use crate::rl::env::{action_scale, input_from_action, observation_after_outputs};
use crate::rl::PolicyFile;
use std::sync::Arc;
use std::time::Instant;

/// The deterministic policy of a [`PolicyFile`] driving a plant.
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
        let width = model.outputs.len() + nu + 1 + nd;
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
        let scale = action_scale(plant).map_err(|e| ControlError::Other(e.to_string()))?;
        Ok(Policy {
            policy,
            scale,
            lower: model.inputs.iter().map(|u| u.lower).collect(),
            upper: model.inputs.iter().map(|u| u.upper).collect(),
            observation: vec![0.0; width],
            nd,
        })
    }

    pub fn file(&self) -> &PolicyFile {
        &self.policy
    }
}

impl Controller for Policy {
    fn name(&self) -> String {
        "policy".into()
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
        observation_after_outputs(
            &mut obs[ny..],
            o.previous_input,
            o.step,
            &o.forecast[..self.nd],
        );
        let action = self
            .policy
            .action(&self.observation[..])
            .map_err(|e| ControlError::Other(e.to_string()))?;
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
