//! A controller rolled out on the nominal model: from a state, step by step, the controller
//! decides on the model's outputs and the forecast, its input is held within the plant's
//! bounds and rate limits, and the model steps on. RL-guided MPC rolls its guide out this
//! way for its starting point and terminal region ([`super::RlGuidance`]); plain MPC rolls
//! out the model's own rules for a cold start ([`super::Mpc`]). One way for both, so that
//! a plan and the guess it started from agree on what the controller would have done.

use crate::control::{ControlError, Controller, Observation};
use crate::model::{Plant, StepOutcome, StepWorkspace};
use std::sync::Arc;

/// The nominal model and the scratch a roll-out steps it with.
pub(crate) struct RollOut {
    plant: Arc<Plant>,
    params: Vec<f64>,
    ws: StepWorkspace,
    out: StepOutcome,
    outputs: Vec<f64>,
}

impl RollOut {
    /// Roll-outs on `plant` with its nominal parameters.
    pub fn new(plant: Arc<Plant>) -> RollOut {
        RollOut {
            params: plant.model.nominal_params(),
            ws: plant.workspace(),
            out: StepOutcome {
                next_state: Vec::with_capacity(plant.layout.nx),
                terms: Vec::new(),
                next_outputs: Vec::new(),
            },
            outputs: vec![0.0; plant.model.outputs.len()],
            plant,
        }
    }

    /// The input `controller` chooses at state `x` after input `previous`, at season step
    /// `step` with the forecast from that step on, held within the plant's limits.
    pub fn input(
        &mut self,
        controller: &mut dyn Controller,
        x: &[f64],
        previous: &[f64],
        step: usize,
        forecast: &[f64],
    ) -> Result<Vec<f64>, ControlError> {
        let nd = self.plant.layout.nd;
        let d = &forecast[..nd.min(forecast.len())];
        self.plant.outputs_into(
            &mut self.ws,
            x,
            previous,
            d,
            &self.params,
            &mut self.outputs,
        );
        let decision = controller.decide(&Observation {
            step,
            state: x,
            outputs: &self.outputs,
            previous_input: previous,
            forecast,
        })?;
        let mut u = decision.input;
        self.plant.apply_limits(previous, &mut u);
        Ok(u)
    }

    /// The nominal successor of `x` under `u` with the weather `d`.
    pub fn successor(&mut self, x: &[f64], u: &[f64], d: &[f64]) -> Vec<f64> {
        self.plant
            .step_into(&mut self.ws, x, u, d, &self.params, &mut self.out);
        self.out.next_state.clone()
    }

    /// `controller` over `steps` steps from the observation's state, previous input and
    /// step, with the forecast `forecast` from that step on (the observation's own
    /// forecast and outputs are not read): its inputs appended to `inputs`, step after
    /// step; returns the state they reach.
    pub fn horizon(
        &mut self,
        controller: &mut dyn Controller,
        observation: &Observation,
        forecast: &[f64],
        steps: usize,
        inputs: &mut Vec<f64>,
    ) -> Result<Vec<f64>, ControlError> {
        let nd = self.plant.layout.nd;
        let mut x = observation.state.to_vec();
        let mut previous = observation.previous_input.to_vec();
        for j in 0..steps {
            let weather = &forecast[j * nd..];
            let u = self.input(controller, &x, &previous, observation.step + j, weather)?;
            x = self.successor(&x, &u, &weather[..nd]);
            inputs.extend_from_slice(&u);
            previous = u;
        }
        Ok(x)
    }
}
