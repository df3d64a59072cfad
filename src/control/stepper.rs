//! The one way a step is decided, whatever the door: the season loop, `ghm serve`, the C ABI
//! of a compiled controller and Python all call [`Stepper::decide`]. It checks the request
//! against the model (sizes, finite numbers), evaluates the outputs at the state (or takes
//! the measured ones), asks the controller, checks its answer, and applies the model's input
//! bounds and rate limits by one explicit [`LimitPolicy`]. Doors differ only in how they
//! carry the request and the answer, so they decide the same input to the last bit.

use super::{ControlError, Controller, Observation, Plan, StepRecord};
use crate::model::finite::Quantity;
use crate::model::{Plant, StepWorkspace};
use thiserror::Error;

/// What happens to the input a controller decides before the plant gets it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LimitPolicy {
    /// Clipped to `|u − u_prev| ≤ rate` and to the input bounds, as the actuators would
    /// (every door's default).
    #[default]
    Clip,
    /// Passed on as decided (a season run with `enforce_limits` off, to study a controller's
    /// raw answers).
    Pass,
}

/// One step's request, as a door received it.
#[derive(Debug, Clone, Copy)]
pub struct StepRequest<'a> {
    /// The season step `k`, counted from 0.
    pub step: usize,
    /// The state `x(k)` (measured or simulated), in declaration order.
    pub state: &'a [f64],
    /// Measured outputs at `x(k)`; `None` evaluates them from the state, the previous input
    /// and `d(k)`.
    pub measured_outputs: Option<&'a [f64]>,
    /// The input applied at step `k − 1` (the model's start input at step 0).
    pub previous_input: &'a [f64],
    /// The forecast `d(k), d(k+1), …`, row-major.
    pub forecast: &'a [f64],
}

/// One step's answer.
#[derive(Debug, Clone, PartialEq)]
pub struct StepDecision {
    /// The input the plant gets (after the [`LimitPolicy`]).
    pub input: Vec<f64>,
    /// The outputs the controller observed.
    pub outputs: Vec<f64>,
    /// How the controller found it.
    pub record: StepRecord,
    /// The plan behind the decision, where the stepper was asked to keep it
    /// ([`Stepper::with_plans`]) and the controller has one.
    pub plan: Option<Plan>,
}

/// Why a step could not be decided.
#[derive(Debug, Error)]
pub enum StepError {
    /// A vector of the request has the wrong length.
    #[error("the {what} has {given} numbers; the model has {expected}")]
    Size {
        /// Which vector.
        what: &'static str,
        /// Its length.
        given: usize,
        /// The model's.
        expected: usize,
    },
    /// The forecast is not a whole number of rows.
    #[error(
        "the forecast has {given} numbers, not a whole number of rows of {width} disturbances"
    )]
    ForecastShape {
        /// Numbers given.
        given: usize,
        /// Disturbances per row.
        width: usize,
    },
    /// The forecast has fewer rows than the controller reads.
    #[error(
        "the forecast has {rows} rows; this controller needs {needed} (its horizon), each of \
         {width} disturbances"
    )]
    ForecastShort {
        /// Rows given.
        rows: usize,
        /// Rows needed.
        needed: usize,
        /// Disturbances per row.
        width: usize,
    },
    /// A number of the request is NaN or infinite.
    #[error("the {what} is not finite: {name} = {value}")]
    RequestNotFinite {
        /// Which vector.
        what: &'static str,
        /// The entry, by the model's name for it.
        name: String,
        /// The value.
        value: f64,
    },
    /// An output the model computed, or an input the controller decided, is NaN or infinite.
    #[error("{described} is {value}")]
    NotFinite {
        /// Which number.
        quantity: Quantity,
        /// The number as the model file names it.
        described: String,
        /// The value.
        value: f64,
    },
    /// The controller decided a vector of the wrong length.
    #[error("the controller decided {given} inputs; the model has {expected}")]
    InputWidth {
        /// Inputs decided.
        given: usize,
        /// The model's.
        expected: usize,
    },
    /// The controller failed.
    #[error(transparent)]
    Controller(#[from] ControlError),
}

impl StepError {
    /// Whether the request itself was wrong (a size, the forecast's shape or rows, a number
    /// that is not finite), rather than the model or the controller failing on a good one:
    /// a door answers the caller's mistakes and the controller's failures differently.
    pub fn is_bad_request(&self) -> bool {
        match self {
            StepError::Size { .. }
            | StepError::ForecastShape { .. }
            | StepError::ForecastShort { .. }
            | StepError::RequestNotFinite { .. } => true,
            StepError::NotFinite { .. }
            | StepError::InputWidth { .. }
            | StepError::Controller(_) => false,
        }
    }
}

/// Decides steps: the request checked, the outputs, the controller, the limits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stepper {
    limits: LimitPolicy,
    forecast_rows: usize,
    plans: bool,
}

impl Default for Stepper {
    fn default() -> Stepper {
        Stepper {
            limits: LimitPolicy::Clip,
            forecast_rows: 1,
            plans: false,
        }
    }
}

impl Stepper {
    /// A stepper with `limits` that needs one forecast row and keeps no plans.
    pub fn new(limits: LimitPolicy) -> Stepper {
        Stepper {
            limits,
            ..Stepper::default()
        }
    }

    /// Requires `rows` forecast rows (a controller's horizon), each checked to be finite;
    /// at least one.
    pub fn with_forecast_rows(self, rows: usize) -> Stepper {
        Stepper {
            forecast_rows: rows.max(1),
            ..self
        }
    }

    /// Returns the controller's plan with each decision.
    pub fn with_plans(self) -> Stepper {
        Stepper {
            plans: true,
            ..self
        }
    }

    /// The limit policy.
    pub fn limits(&self) -> LimitPolicy {
        self.limits
    }

    /// Decides the step `request` describes with `controller`, for `plant` under the
    /// parameters `params`.
    ///
    /// ```
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use ghm::control::{ConstantInput, LimitPolicy, StepRequest, Stepper};
    /// use ghm::model::Plant;
    ///
    /// let text = "sample 60 [s]\nstate level = 1\ninput inflow in [0, 1] rate 0.1\n\
    ///             der level = inflow - level\noutput h = level\n";
    /// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
    /// let mut ws = plant.workspace();
    /// let mut controller = ConstantInput(vec![0.5]);
    /// let request = StepRequest {
    ///     step: 0,
    ///     state: &[1.0],
    ///     measured_outputs: None,
    ///     previous_input: &[0.0],
    ///     forecast: &[],
    /// };
    /// // Asked for 0.5, the actuator moves at most 0.1 a step.
    /// let clipped = Stepper::new(LimitPolicy::Clip).decide(&plant, &[], &mut ws, &mut controller, &request)?;
    /// assert_eq!((clipped.input[0], clipped.outputs[0]), (0.1, 1.0));
    /// let raw = Stepper::new(LimitPolicy::Pass).decide(&plant, &[], &mut ws, &mut controller, &request)?;
    /// assert_eq!(raw.input, [0.5]);
    /// // A state of the wrong size is refused with the sizes.
    /// let wrong = StepRequest { state: &[1.0, 2.0], ..request };
    /// let e = Stepper::default().decide(&plant, &[], &mut ws, &mut controller, &wrong).unwrap_err();
    /// assert_eq!(e.to_string(), "the state has 2 numbers; the model has 1");
    /// # Ok(())
    /// # }
    /// ```
    pub fn decide(
        &self,
        plant: &Plant,
        params: &[f64],
        workspace: &mut StepWorkspace,
        controller: &mut dyn Controller,
        request: &StepRequest,
    ) -> Result<StepDecision, StepError> {
        let outputs = self.observe(plant, params, workspace, request)?;
        let observation = Observation {
            step: request.step,
            state: request.state,
            outputs: &outputs,
            previous_input: request.previous_input,
            forecast: request.forecast,
        };
        let decision = controller.decide(&observation)?;
        let mut input = decision.input;
        let nu = plant.layout.nu;
        if input.len() != nu {
            return Err(StepError::InputWidth {
                given: input.len(),
                expected: nu,
            });
        }
        model_finite(plant, &input, Quantity::Input)?;
        if self.limits == LimitPolicy::Clip {
            plant.apply_limits(request.previous_input, &mut input);
        }
        let plan = if self.plans { controller.plan() } else { None };
        Ok(StepDecision {
            input,
            outputs,
            record: decision.record,
            plan,
        })
    }

    /// A step already decided (a stopped season's, replayed when it resumes): the request
    /// checked and observed as [`decide`](Self::decide) does, and `input` and `record`
    /// returned as they were logged, without asking a controller.
    pub fn replay(
        &self,
        plant: &Plant,
        params: &[f64],
        workspace: &mut StepWorkspace,
        request: &StepRequest,
        input: &[f64],
        record: &StepRecord,
    ) -> Result<StepDecision, StepError> {
        let outputs = self.observe(plant, params, workspace, request)?;
        size("input", input, plant.layout.nu)?;
        Ok(StepDecision {
            input: input.to_vec(),
            outputs,
            record: record.clone(),
            plan: None,
        })
    }

    /// Checks the request and returns the outputs the controller observes.
    fn observe(
        &self,
        plant: &Plant,
        params: &[f64],
        workspace: &mut StepWorkspace,
        r: &StepRequest,
    ) -> Result<Vec<f64>, StepError> {
        let m = &plant.model;
        let l = plant.layout;
        size("state", r.state, l.nx)?;
        size("previous input", r.previous_input, l.nu)?;
        if l.nd > 0 && !r.forecast.len().is_multiple_of(l.nd) {
            return Err(StepError::ForecastShape {
                given: r.forecast.len(),
                width: l.nd,
            });
        }
        let rows = r.forecast.len().checked_div(l.nd).unwrap_or(usize::MAX);
        if rows < self.forecast_rows {
            return Err(StepError::ForecastShort {
                rows,
                needed: self.forecast_rows,
                width: l.nd,
            });
        }
        let name = |names: Vec<String>, i: usize| {
            names
                .get(i)
                .cloned()
                .unwrap_or_else(|| format!("number {i}"))
        };
        request_finite("state", r.state, |i| {
            name(m.states.iter().map(|s| s.info.name.clone()).collect(), i)
        })?;
        request_finite("previous input", r.previous_input, |i| {
            name(m.inputs.iter().map(|u| u.info.name.clone()).collect(), i)
        })?;
        // The rows the controller reads; a season's weather past them was checked when read.
        let read = (self.forecast_rows * l.nd).min(r.forecast.len());
        request_finite("forecast", &r.forecast[..read], |i| {
            format!(
                "{} of row {}",
                name(m.weather_columns(), i % l.nd),
                i / l.nd
            )
        })?;
        let outputs = match r.measured_outputs {
            Some(y) => {
                size("measured outputs", y, m.outputs.len())?;
                request_finite("measured outputs", y, |i| {
                    name(m.outputs.iter().map(|o| o.info.name.clone()).collect(), i)
                })?;
                y.to_vec()
            }
            None => {
                let mut y = vec![0.0; m.outputs.len()];
                plant.outputs_into(
                    workspace,
                    r.state,
                    r.previous_input,
                    &r.forecast[..l.nd],
                    params,
                    &mut y,
                );
                model_finite(plant, &y, Quantity::Output)?;
                y
            }
        };
        Ok(outputs)
    }
}

fn size(what: &'static str, values: &[f64], expected: usize) -> Result<(), StepError> {
    if values.len() == expected {
        Ok(())
    } else {
        Err(StepError::Size {
            what,
            given: values.len(),
            expected,
        })
    }
}

fn request_finite(
    what: &'static str,
    values: &[f64],
    name: impl Fn(usize) -> String,
) -> Result<(), StepError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(StepError::RequestNotFinite {
            what,
            name: name(i),
            value: values[i],
        }),
    }
}

fn model_finite(
    plant: &Plant,
    values: &[f64],
    quantity: fn(usize) -> Quantity,
) -> Result<(), StepError> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(StepError::NotFinite {
            quantity: quantity(i),
            described: plant.describe(quantity(i)),
            value: values[i],
        }),
    }
}

/// A controller held with what deciding from outside a season needs beside it: the plant
/// it predicts with, that plant's nominal parameters, a step workspace and the door's
/// [`Stepper`]. `ghm serve`'s sessions, the C ABI's controller and Python's each hold one,
/// so they differ only in the stepper they choose.
pub struct SteppedController {
    plant: std::sync::Arc<Plant>,
    controller: Box<dyn Controller>,
    stepper: Stepper,
    params: Vec<f64>,
    workspace: StepWorkspace,
}

impl SteppedController {
    /// `controller` of `plant`, deciding through `stepper`.
    pub fn new(
        plant: std::sync::Arc<Plant>,
        controller: Box<dyn Controller>,
        stepper: Stepper,
    ) -> SteppedController {
        SteppedController {
            params: plant.model.nominal_params(),
            workspace: plant.workspace(),
            plant,
            controller,
            stepper,
        }
    }

    /// Decides the step `request` describes ([`Stepper::decide`]).
    pub fn decide(&mut self, request: &StepRequest) -> Result<StepDecision, StepError> {
        self.stepper.decide(
            &self.plant,
            &self.params,
            &mut self.workspace,
            self.controller.as_mut(),
            request,
        )
    }

    /// The plant the controller predicts with.
    pub fn plant(&self) -> &std::sync::Arc<Plant> {
        &self.plant
    }

    /// The plant's nominal parameters.
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// The controller.
    pub fn controller(&self) -> &dyn Controller {
        self.controller.as_ref()
    }

    /// Puts `controller` in place of the one held (a reset: warm starts and plans
    /// forgotten).
    pub fn replace_controller(&mut self, controller: Box<dyn Controller>) {
        self.controller = controller;
    }

    /// One step of the nominal plant from `state` under `input` and the disturbance row
    /// `weather`, into `out` (a door that also simulates: the C ABI's `ghm_plant_step`).
    pub fn step_plant(
        &mut self,
        state: &[f64],
        input: &[f64],
        weather: &[f64],
        out: &mut crate::model::StepOutcome,
    ) {
        self.plant.step_into(
            &mut self.workspace,
            state,
            input,
            weather,
            &self.params,
            out,
        );
    }
}
