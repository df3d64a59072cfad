//! The optimal-control problem of a plant over a horizon of `N` steps, transcribed by
//! multiple shooting into an [`Nlp`].
//!
//! Variables, stage by stage (`x_0` is the measured state, not a variable):
//!
//! ```text
//! [u_0 s_0] [x_1 u_1 s_1] … [x_{N−1} u_{N−1} s_{N−1}] [x_N]
//! ```
//!
//! where `s_j` are the slacks of the soft output bands of step `j`. Constraints, stage by
//! stage: the dynamics `x_{j+1} − F(x_j, u_j, d_j, p) = 0`, one soft-band row per band side
//! (`s + w·(y − lo) ≥ 0` below, `s − w·(y − hi) ≥ 0` above, with `y = g(F(x_j, u_j))` and
//! the band's planning bounds), and for `j ≥ 1` the rate limits `|u_j − u_{j−1}| ≤ δ`. The
//! first rate limit, against the input applied at the previous step, is a bound on `u_0`.
//! The objective is `Σ_j (−Σ stage rewards_j + Σ s_j) + T(x_N)`, where the terminal cost
//! `T` is minus the model's `terminal` rewards plus an optional cost set from outside (a
//! value network); an optional terminal box bounds `x_N` and `u_{N−1}`.
//!
//! Every derivative is assembled per stage from one forward-over-reverse sweep of the
//! plant's step tape with respect to `(x_j, u_j)`: the Jacobian rows of a stage and the
//! dense Hessian block of a stage come out together, and no Hessian of the whole NLP is
//! ever formed.

use super::{Nlp, Pattern, Stages, TerminalBox, TerminalCost};
use crate::model::Plant;
use crate::model::{ModelTerminalCost, StepDerivatives, StepWorkspace};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::Arc;
use thiserror::Error;

/// Why an [`Ocp`] could not be built or given its data.
#[derive(Debug, Error, PartialEq)]
pub enum OcpError {
    /// A horizon of 0 steps was asked for.
    #[error("the horizon must be at least one step")]
    ZeroHorizon,
    /// A vector passed to the problem has the wrong length.
    #[error("{what} has {given} values; the problem needs {expected}")]
    Dimension {
        /// Which vector, in words (`the state`, `the forecast`, ...).
        what: &'static str,
        /// Its length.
        given: usize,
        /// The length needed.
        expected: usize,
    },
}

/// Where each variable and constraint of an [`Ocp`] lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OcpLayout {
    /// Steps `N` of the horizon.
    pub horizon: usize,
    /// States per stage.
    pub nx: usize,
    /// Inputs per stage.
    pub nu: usize,
    /// Slacks per stage (one per soft band side).
    pub ns: usize,
    /// Rate-limited inputs (rate rows per stage from the second stage on).
    pub nr: usize,
}

impl OcpLayout {
    fn block_start(&self, j: usize) -> usize {
        if j == 0 {
            0
        } else {
            (self.nu + self.ns) + (j - 1) * (self.nx + self.nu + self.ns)
        }
    }

    /// First index of `x_j`, `1 ≤ j ≤ N`.
    pub fn x(&self, j: usize) -> usize {
        self.block_start(j)
    }

    /// First index of `u_j`, `j < N`.
    pub fn u(&self, j: usize) -> usize {
        self.block_start(j) + if j == 0 { 0 } else { self.nx }
    }

    /// First index of the slacks of stage `j`.
    pub fn s(&self, j: usize) -> usize {
        self.u(j) + self.nu
    }

    /// Variables in all: every stage's block and `x_N`.
    pub fn n_vars(&self) -> usize {
        self.block_start(self.horizon) + self.nx
    }

    /// First dynamics row of stage `j`; the soft rows follow, then the rate rows.
    pub fn dynamics_row(&self, j: usize) -> usize {
        if j == 0 {
            0
        } else {
            (self.nx + self.ns) + (j - 1) * (self.nx + self.ns + self.nr)
        }
    }

    /// First soft-band row of stage `j`, right after its dynamics rows.
    pub fn soft_row(&self, j: usize) -> usize {
        self.dynamics_row(j) + self.nx
    }

    /// First rate row of stage `j ≥ 1`.
    pub fn rate_row(&self, j: usize) -> usize {
        self.soft_row(j) + self.ns
    }

    /// Constraint rows in all (stage 0 has no rate rows).
    pub fn n_cons(&self) -> usize {
        self.dynamics_row(self.horizon)
    }

    /// Variables of stage `j` seen by the step function: `(x_j, u_j)` for `j ≥ 1`, `u_0`
    /// for `j = 0`, as a contiguous range.
    pub fn stage_vars(&self, j: usize) -> Range<usize> {
        if j == 0 {
            0..self.nu
        } else {
            self.x(j)..self.x(j) + self.nx + self.nu
        }
    }
}

/// Which bounds of the soft bands a problem plans with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bands {
    /// The planning bounds (`plan` in the model file; the scoring bounds where none).
    Planning,
    /// The bounds the season is scored with (for the season optimum, an upper bound).
    Scoring,
}

/// One side of a soft band: row `s + sign·w·(y − bound) ≥ 0`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SoftSide {
    output: usize,
    bound: f64,
    /// `+1` for a lower bound, `−1` for an upper bound.
    sign: f64,
    weight: f64,
}

/// What the last evaluation left in the stage buffers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Cached {
    Nothing,
    Values,
    Jacobians,
}

/// The MPC problem of one step: a plant, a horizon, the current state, the previous
/// input, the forecast and the optional terminal hooks.
///
/// ```
/// use ghm::nlp::{Nlp, Ocp};
/// use ghm::solve::{kkt_residuals, Solver, Sqp, Start};
/// use std::sync::Arc;
///
/// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/cstr.ghm");
/// let plant = Arc::new(ghm::model::Plant::new(ghm::lang::load(&file).unwrap()));
/// let mut ocp = Ocp::new(plant.clone(), 10).unwrap(); // one minute ahead
/// // The reactor has no disturbances: the forecast is empty.
/// let x0 = plant.model.initial_state();
/// ocp.set_problem(0, &x0, &plant.model.start_input(), &[]).unwrap();
/// let mut start = vec![0.0; ocp.n_vars()];
/// ocp.initial_point(&mut start);
/// let solution = Sqp::default().solve(&mut ocp, Start::cold(&start));
/// assert!(solution.status.is_success());
/// let kkt = kkt_residuals(&mut ocp, &solution.x, &solution.multipliers, &solution.bound_multipliers);
/// assert!(kkt.max() < 1e-6);
/// println!("apply {:?}", ocp.input(&solution.x, 0));
/// ```
#[derive(Debug)]
pub struct Ocp {
    plant: Arc<Plant>,
    layout: OcpLayout,
    sides: Vec<SoftSide>,
    /// `(input index, rate)` of every rate-limited input.
    rated: Vec<(usize, f64)>,
    state: Vec<f64>,
    previous_input: Vec<f64>,
    /// `N × nd`, row-major.
    forecast: Vec<f64>,
    params: Vec<f64>,
    step: usize,
    /// The model's own `terminal` terms, part of every horizon's objective.
    model_terminal: Option<ModelTerminalCost>,
    /// A terminal cost set from outside (RL-guided MPC's value), added to the model's.
    terminal_cost: Option<Box<dyn TerminalCost>>,
    terminal_box: Option<TerminalBox>,
    jacobian_pattern: Pattern,
    hessian_pattern: Pattern,
    // Evaluation buffers.
    derivatives: StepDerivatives,
    workspace: StepWorkspace,
    tape_inputs: Vec<f64>,
    /// Per stage: the step tape's outputs `(x⁺, terms, y)`.
    stage_values: Vec<f64>,
    /// Per stage: the Jacobian of the outputs wrt `(x_j, u_j)`, row-major.
    stage_jacobians: Vec<f64>,
    terminal_value: f64,
    terminal_gradient: Vec<f64>,
    terminal_hessian: Vec<f64>,
    /// The outside terminal cost's derivatives, before they are added to the model's.
    hook_gradient: Vec<f64>,
    hook_hessian: Vec<f64>,
    cached_x: Vec<f64>,
    cached: Cached,
}

impl Ocp {
    /// The problem of `plant` over `horizon` steps, at the model's initial state and start
    /// input, nominal parameters and a zero forecast (set them with [`Ocp::set_problem`]).
    pub fn new(plant: Arc<Plant>, horizon: usize) -> Result<Ocp, OcpError> {
        Ocp::with_bands(plant, horizon, Bands::Planning)
    }

    /// Like [`Ocp::new`], choosing which bounds of the soft bands the slacks measure.
    pub fn with_bands(plant: Arc<Plant>, horizon: usize, bands: Bands) -> Result<Ocp, OcpError> {
        if horizon == 0 {
            return Err(OcpError::ZeroHorizon);
        }
        let l = plant.layout;
        let model = &plant.model;
        let mut sides = Vec::new();
        for band in &model.soft {
            let (lower, upper) = match bands {
                Bands::Planning => (band.plan_lower, band.plan_upper),
                Bands::Scoring => (band.lower, band.upper),
            };
            if lower.is_finite() && band.weight_below > 0.0 {
                sides.push(SoftSide {
                    output: band.output,
                    bound: lower,
                    sign: 1.0,
                    weight: band.weight_below,
                });
            }
            if upper.is_finite() && band.weight_above > 0.0 {
                sides.push(SoftSide {
                    output: band.output,
                    bound: upper,
                    sign: -1.0,
                    weight: band.weight_above,
                });
            }
        }
        let rated: Vec<(usize, f64)> = model
            .inputs
            .iter()
            .enumerate()
            .filter_map(|(i, d)| d.rate.map(|r| (i, r)))
            .collect();
        let layout = OcpLayout {
            horizon,
            nx: l.nx,
            nu: l.nu,
            ns: sides.len(),
            nr: rated.len(),
        };
        let wrt: Vec<usize> = (0..l.nx).chain((0..l.nu).map(|i| l.u(i))).collect();
        let n_out = plant.n_step_outputs();
        let nw = wrt.len();
        let mut ocp = Ocp {
            derivatives: StepDerivatives::new(&plant, &wrt),
            workspace: plant.optimisation_workspace(),
            tape_inputs: vec![0.0; l.n_base()],
            stage_values: vec![0.0; horizon * n_out],
            stage_jacobians: vec![0.0; horizon * n_out * nw],
            terminal_value: 0.0,
            terminal_gradient: vec![0.0; l.nx],
            terminal_hessian: vec![0.0; l.nx * l.nx],
            hook_gradient: vec![0.0; l.nx],
            hook_hessian: vec![0.0; l.nx * l.nx],
            cached_x: Vec::new(),
            cached: Cached::Nothing,
            state: model.initial_state(),
            previous_input: model.start_input(),
            forecast: vec![0.0; horizon * l.nd],
            params: model.nominal_params(),
            step: 0,
            model_terminal: ModelTerminalCost::of(&plant),
            terminal_cost: None,
            terminal_box: None,
            jacobian_pattern: Pattern::default(),
            hessian_pattern: Pattern::default(),
            plant,
            layout,
            sides,
            rated,
        };
        ocp.build_patterns();
        Ok(ocp)
    }

    /// Where each variable and constraint lives.
    pub fn layout(&self) -> &OcpLayout {
        &self.layout
    }

    /// The plant whose step the dynamics constraints use.
    pub fn plant(&self) -> &Arc<Plant> {
        &self.plant
    }

    /// Steps `N` of the horizon.
    pub fn horizon(&self) -> usize {
        self.layout.horizon
    }

    /// The season step of the first stage.
    pub fn step(&self) -> usize {
        self.step
    }

    /// The measured state `x(k)` the problem starts from (`x_0`), as last set.
    pub fn state(&self) -> &[f64] {
        &self.state
    }

    /// The input applied at `k − 1`, which the first rate limit is taken against.
    pub fn previous_input(&self) -> &[f64] {
        &self.previous_input
    }

    /// Sets the data of one MPC step: season step `k`, measured state `x(k)`, the input
    /// applied at `k − 1`, and the forecast `d(k), …` (at least `N` rows, row-major).
    pub fn set_problem(
        &mut self,
        step: usize,
        state: &[f64],
        previous_input: &[f64],
        forecast: &[f64],
    ) -> Result<(), OcpError> {
        let l = self.plant.layout;
        check("the state", state.len(), l.nx)?;
        check("the previous input", previous_input.len(), l.nu)?;
        let needed = self.layout.horizon * l.nd;
        if forecast.len() < needed {
            return Err(OcpError::Dimension {
                what: "the forecast",
                given: forecast.len(),
                expected: needed,
            });
        }
        self.step = step;
        self.state.copy_from_slice(state);
        self.previous_input.copy_from_slice(previous_input);
        self.forecast.copy_from_slice(&forecast[..needed]);
        self.cached = Cached::Nothing;
        Ok(())
    }

    /// The parameters the controller predicts with (nominal by default).
    pub fn set_params(&mut self, params: &[f64]) -> Result<(), OcpError> {
        check("the parameter vector", params.len(), self.params.len())?;
        self.params.copy_from_slice(params);
        self.cached = Cached::Nothing;
        Ok(())
    }

    /// Sets or removes the terminal cost, added to the model's own `terminal` terms. The
    /// Hessian pattern changes with it where the model has no `terminal` terms.
    pub fn set_terminal_cost(&mut self, cost: Option<Box<dyn TerminalCost>>) {
        let had = self.has_terminal();
        self.terminal_cost = cost;
        self.cached = Cached::Nothing;
        if had != self.has_terminal() {
            self.build_patterns();
        }
    }

    /// Whether the objective has a cost on `x_N` (the model's `terminal` terms, a terminal
    /// cost set from outside, or both).
    fn has_terminal(&self) -> bool {
        self.model_terminal.is_some() || self.terminal_cost.is_some()
    }

    /// Sets or removes the terminal box on `x_N` and `u_{N−1}`; it takes effect in
    /// [`Nlp::var_bounds`] and leaves the variable scales alone.
    pub fn set_terminal_box(&mut self, terminal_box: Option<TerminalBox>) {
        self.terminal_box = terminal_box;
    }

    /// Input `u_j` of a primal point.
    pub fn input<'a>(&self, x: &'a [f64], j: usize) -> &'a [f64] {
        &x[self.layout.u(j)..self.layout.u(j) + self.layout.nu]
    }

    /// State `x_j` of a primal point (`x_0` is the measured state).
    pub fn state_at<'a>(&'a self, x: &'a [f64], j: usize) -> &'a [f64] {
        if j == 0 {
            &self.state
        } else {
            &x[self.layout.x(j)..self.layout.x(j) + self.layout.nx]
        }
    }

    /// A consistent primal point from an input sequence (`N × nu`, row-major): states by
    /// simulation from `x(k)`, slacks at the penalties they imply.
    pub fn rollout(&mut self, inputs: &[f64], x: &mut [f64]) {
        let l = self.layout;
        for j in 0..l.horizon {
            let u = &inputs[j * l.nu..(j + 1) * l.nu];
            x[l.u(j)..l.u(j) + l.nu].copy_from_slice(u);
            self.evaluate_stage_values(x, j);
            let out = self.stage_outputs(j).to_vec();
            x[l.x(j + 1)..l.x(j + 1) + l.nx].copy_from_slice(&out[..l.nx]);
        }
        self.set_slacks(x);
    }

    /// Shifts a solution one step forward in time for the problem now set: stage `j`
    /// takes stage `j + 1`'s states and inputs, the last input is repeated and the last
    /// state simulated from it on the new forecast; slacks are recomputed.
    pub fn shift_primal(&mut self, previous: &[f64], x: &mut [f64]) {
        let l = self.layout;
        let n = l.horizon;
        for j in 0..n {
            let from = (j + 1).min(n - 1);
            x[l.u(j)..l.u(j) + l.nu].copy_from_slice(&previous[l.u(from)..l.u(from) + l.nu]);
            if j >= 1 {
                x[l.x(j)..l.x(j) + l.nx].copy_from_slice(&previous[l.x(j + 1)..l.x(j + 1) + l.nx]);
            }
        }
        // The last stage starts from the previous terminal state.
        self.evaluate_stage_values(x, n - 1);
        let next = self.stage_outputs(n - 1)[..l.nx].to_vec();
        x[l.x(n)..l.x(n) + l.nx].copy_from_slice(&next);
        self.set_slacks(x);
    }

    /// Shifts constraint multipliers like [`Ocp::shift_primal`] shifts the primal point.
    pub fn shift_multipliers(&self, previous: &[f64], multipliers: &mut [f64]) {
        let l = self.layout;
        let n = l.horizon;
        for j in 0..n {
            let from = (j + 1).min(n - 1);
            let len = l.nx + l.ns;
            multipliers[l.dynamics_row(j)..l.dynamics_row(j) + len]
                .copy_from_slice(&previous[l.dynamics_row(from)..l.dynamics_row(from) + len]);
            if j >= 1 {
                multipliers[l.rate_row(j)..l.rate_row(j) + l.nr]
                    .copy_from_slice(&previous[l.rate_row(from)..l.rate_row(from) + l.nr]);
            }
        }
    }

    /// Shifts bound multipliers like [`Ocp::shift_primal`] shifts the primal point.
    pub fn shift_bound_multipliers(&self, previous: &[f64], bound_multipliers: &mut [f64]) {
        let l = self.layout;
        let n = l.horizon;
        for j in 0..n {
            let from = (j + 1).min(n - 1);
            let len = l.nu + l.ns;
            bound_multipliers[l.u(j)..l.u(j) + len]
                .copy_from_slice(&previous[l.u(from)..l.u(from) + len]);
            if j >= 1 {
                bound_multipliers[l.x(j)..l.x(j) + l.nx]
                    .copy_from_slice(&previous[l.x(j + 1)..l.x(j + 1) + l.nx]);
            }
        }
        bound_multipliers[l.x(n)..l.x(n) + l.nx].fill(0.0);
    }

    /// Sets every slack to the smallest value its rows allow at the current states.
    fn set_slacks(&mut self, x: &mut [f64]) {
        let l = self.layout;
        let ny0 = self.outputs_offset();
        for j in 0..l.horizon {
            self.evaluate_stage_values(x, j);
            for (k, side) in self.sides.iter().enumerate() {
                let y = self.stage_values[self.stage_offset(j) + ny0 + side.output];
                x[l.s(j) + k] = (-side.sign * side.weight * (y - side.bound)).max(0.0);
            }
        }
        self.cached = Cached::Nothing;
    }

    fn n_out(&self) -> usize {
        self.plant.n_step_outputs()
    }

    fn nw(&self) -> usize {
        self.layout.nx + self.layout.nu
    }

    fn stage_offset(&self, j: usize) -> usize {
        j * self.n_out()
    }

    fn n_terms(&self) -> usize {
        self.plant.stage_terms.len()
    }

    /// Offset of the outputs `y` in the step tape's outputs.
    fn outputs_offset(&self) -> usize {
        self.layout.nx + self.n_terms()
    }

    fn stage_outputs(&self, j: usize) -> &[f64] {
        let o = self.stage_offset(j);
        &self.stage_values[o..o + self.n_out()]
    }

    /// Fills the tape inputs `(x_j, u_j, d_j, p)` of stage `j`.
    fn pack(&mut self, x: &[f64], j: usize) {
        let l = self.layout;
        let pl = self.plant.layout;
        let xj = if j == 0 {
            &self.state[..]
        } else {
            &x[l.x(j)..l.x(j) + l.nx]
        };
        self.tape_inputs[..l.nx].copy_from_slice(xj);
        self.tape_inputs[pl.u(0)..pl.u(0) + l.nu].copy_from_slice(&x[l.u(j)..l.u(j) + l.nu]);
        self.tape_inputs[pl.d(0)..pl.d(0) + pl.nd]
            .copy_from_slice(&self.forecast[j * pl.nd..(j + 1) * pl.nd]);
        self.tape_inputs[pl.p(0)..pl.p(0) + pl.np].copy_from_slice(&self.params);
    }

    fn evaluate_stage_values(&mut self, x: &[f64], j: usize) {
        self.pack(x, j);
        let o = self.stage_offset(j);
        let n_out = self.n_out();
        let plant = Arc::clone(&self.plant);
        plant.eval_step(
            &mut self.workspace,
            &self.tape_inputs,
            &mut self.stage_values[o..o + n_out],
        );
    }

    fn is_cached(&self, x: &[f64], level: Cached) -> bool {
        self.cached >= level && self.cached_x == x
    }

    fn remember(&mut self, x: &[f64], level: Cached) {
        self.cached_x.clear();
        self.cached_x.extend_from_slice(x);
        self.cached = level;
    }

    /// The cost on `x_N`: the model's `terminal` terms plus the outside terminal cost.
    fn evaluate_terminal(&mut self, x: &[f64]) {
        let l = self.layout;
        let x_n = &x[l.x(l.horizon)..l.x(l.horizon) + l.nx];
        self.terminal_value = 0.0;
        self.terminal_gradient.fill(0.0);
        self.terminal_hessian.fill(0.0);
        if let Some(model) = self.model_terminal.as_mut() {
            self.terminal_value = model.evaluate(
                &self.plant,
                x_n,
                &self.params,
                &mut self.terminal_gradient,
                &mut self.terminal_hessian,
            );
        }
        if let Some(cost) = self.terminal_cost.as_mut() {
            self.terminal_value += cost.evaluate(
                x_n,
                self.step + l.horizon,
                &mut self.hook_gradient,
                &mut self.hook_hessian,
            );
            for (t, h) in self.terminal_gradient.iter_mut().zip(&self.hook_gradient) {
                *t += h;
            }
            for (t, h) in self.terminal_hessian.iter_mut().zip(&self.hook_hessian) {
                *t += h;
            }
        }
    }

    fn ensure_values(&mut self, x: &[f64]) {
        if self.is_cached(x, Cached::Values) {
            return;
        }
        for j in 0..self.layout.horizon {
            self.evaluate_stage_values(x, j);
        }
        self.evaluate_terminal(x);
        self.remember(x, Cached::Values);
    }

    fn ensure_jacobians(&mut self, x: &[f64]) {
        if self.is_cached(x, Cached::Jacobians) {
            return;
        }
        let (n_out, nw) = (self.n_out(), self.nw());
        let plant = Arc::clone(&self.plant);
        for j in 0..self.layout.horizon {
            self.pack(x, j);
            let e = self.derivatives.jacobian(&plant, &self.tape_inputs);
            self.stage_values[j * n_out..(j + 1) * n_out].copy_from_slice(&e.values);
            self.stage_jacobians[j * n_out * nw..(j + 1) * n_out * nw].copy_from_slice(&e.jacobian);
        }
        self.evaluate_terminal(x);
        self.remember(x, Cached::Jacobians);
    }

    /// Columns of the stage derivatives that are variables: all of `(x_j, u_j)` for
    /// `j ≥ 1`, only `u_0` for `j = 0`.
    fn stage_columns(&self, j: usize) -> Range<usize> {
        if j == 0 {
            self.layout.nx..self.nw()
        } else {
            0..self.nw()
        }
    }

    /// Variable index of stage column `c`.
    fn column_var(&self, j: usize, c: usize) -> usize {
        let l = self.layout;
        if c < l.nx {
            l.x(j) + c
        } else {
            l.u(j) + c - l.nx
        }
    }

    fn build_patterns(&mut self) {
        let l = self.layout;
        let mut jac = Pattern::default();
        let mut hess = Pattern::default();
        for j in 0..l.horizon {
            let cols = self.stage_columns(j);
            for i in 0..l.nx {
                let row = l.dynamics_row(j) + i;
                jac.push(row, l.x(j + 1) + i);
                for c in cols.clone() {
                    jac.push(row, self.column_var(j, c));
                }
            }
            for k in 0..l.ns {
                let row = l.soft_row(j) + k;
                jac.push(row, l.s(j) + k);
                for c in cols.clone() {
                    jac.push(row, self.column_var(j, c));
                }
            }
            if j >= 1 {
                for (r, &(i, _)) in self.rated.iter().enumerate() {
                    let row = l.rate_row(j) + r;
                    jac.push(row, l.u(j) + i);
                    jac.push(row, l.u(j - 1) + i);
                }
            }
            for a in cols.clone() {
                for b in cols.start..=a {
                    hess.push(self.column_var(j, a), self.column_var(j, b));
                }
            }
        }
        if self.has_terminal() {
            let x_n = l.x(l.horizon);
            for a in 0..l.nx {
                for b in 0..=a {
                    hess.push(x_n + a, x_n + b);
                }
            }
        }
        self.jacobian_pattern = jac;
        self.hessian_pattern = hess;
    }

    fn objective_from_cache(&self, x: &[f64]) -> f64 {
        let l = self.layout;
        let nt = self.n_terms();
        let mut f = 0.0;
        for j in 0..l.horizon {
            let o = self.stage_offset(j);
            f -= self.stage_values[o + l.nx..o + l.nx + nt]
                .iter()
                .sum::<f64>();
            f += x[l.s(j)..l.s(j) + l.ns].iter().sum::<f64>();
        }
        if self.has_terminal() {
            f += self.terminal_value;
        }
        f
    }

    fn constraints_from_cache(&self, x: &[f64], g: &mut [f64]) {
        let l = self.layout;
        let ny0 = self.outputs_offset();
        for j in 0..l.horizon {
            let out = self.stage_outputs(j);
            for i in 0..l.nx {
                g[l.dynamics_row(j) + i] = x[l.x(j + 1) + i] - out[i];
            }
            for (k, side) in self.sides.iter().enumerate() {
                let y = out[ny0 + side.output];
                g[l.soft_row(j) + k] = x[l.s(j) + k] + side.sign * side.weight * (y - side.bound);
            }
            if j >= 1 {
                for (r, &(i, _)) in self.rated.iter().enumerate() {
                    g[l.rate_row(j) + r] = x[l.u(j) + i] - x[l.u(j - 1) + i];
                }
            }
        }
    }

    fn gradient_from_cache(&self, gradient: &mut [f64]) {
        let l = self.layout;
        let (n_out, nw, nt) = (self.n_out(), self.nw(), self.n_terms());
        gradient.fill(0.0);
        for j in 0..l.horizon {
            let jac = &self.stage_jacobians[j * n_out * nw..(j + 1) * n_out * nw];
            for c in self.stage_columns(j) {
                let d: f64 = (0..nt).map(|t| jac[(l.nx + t) * nw + c]).sum();
                gradient[self.column_var(j, c)] -= d;
            }
            gradient[l.s(j)..l.s(j) + l.ns].fill(1.0);
        }
        if self.has_terminal() {
            let x_n = l.x(l.horizon);
            gradient[x_n..x_n + l.nx].copy_from_slice(&self.terminal_gradient);
        }
    }

    fn jacobian_from_cache(&self, values: &mut [f64]) {
        let l = self.layout;
        let (n_out, nw) = (self.n_out(), self.nw());
        let ny0 = self.outputs_offset();
        let mut k = 0;
        for j in 0..l.horizon {
            let jac = &self.stage_jacobians[j * n_out * nw..(j + 1) * n_out * nw];
            let cols = self.stage_columns(j);
            for i in 0..l.nx {
                values[k] = 1.0;
                k += 1;
                for c in cols.clone() {
                    values[k] = -jac[i * nw + c];
                    k += 1;
                }
            }
            for side in &self.sides {
                values[k] = 1.0;
                k += 1;
                let row = ny0 + side.output;
                for c in cols.clone() {
                    values[k] = side.sign * side.weight * jac[row * nw + c];
                    k += 1;
                }
            }
            if j >= 1 {
                for _ in &self.rated {
                    values[k] = 1.0;
                    values[k + 1] = -1.0;
                    k += 2;
                }
            }
        }
    }

    /// Stage Hessians (and, with them, values and Jacobians) at `x`; writes the Hessian
    /// values in pattern order. Long horizons (the season optimum) are swept in parallel,
    /// one contiguous block of stages per thread.
    fn hessian_sweep(
        &mut self,
        x: &[f64],
        objective_factor: f64,
        multipliers: &[f64],
        values: &mut [f64],
    ) {
        let l = self.layout;
        let (n_out, nw) = (self.n_out(), self.nw());
        let first_len = l.nu * (l.nu + 1) / 2;
        let stage_len = nw * (nw + 1) / 2;
        let sweep = StageSweep {
            plant: &self.plant,
            layout: l,
            sides: &self.sides,
            state: &self.state,
            forecast: &self.forecast,
            params: &self.params,
            x,
            objective_factor,
            multipliers,
            n_terms: self.plant.stage_terms.len(),
        };
        let threads = rayon::current_num_threads().min(l.horizon / PARALLEL_STAGES);
        let (hessian_stages, terminal) =
            values.split_at_mut(first_len + (l.horizon - 1) * stage_len);
        if threads <= 1 {
            sweep.run(
                0,
                &mut self.derivatives,
                &mut self.stage_values,
                &mut self.stage_jacobians,
                hessian_stages,
            );
        } else {
            // Block b holds stages [b·per, (b+1)·per) (the last block the rest).
            let per = l.horizon.div_ceil(threads);
            let mut blocks = Vec::with_capacity(threads);
            let (mut sv, mut sj, mut hv) = (
                &mut self.stage_values[..],
                &mut self.stage_jacobians[..],
                hessian_stages,
            );
            let mut start = 0;
            while start < l.horizon {
                let count = per.min(l.horizon - start);
                let hessian_count = if start == 0 {
                    first_len + (count - 1) * stage_len
                } else {
                    count * stage_len
                };
                let (a, rest_v) = sv.split_at_mut(count * n_out);
                let (b, rest_j) = sj.split_at_mut(count * n_out * nw);
                let (c, rest_h) = hv.split_at_mut(hessian_count);
                blocks.push((start, a, b, c));
                (sv, sj, hv) = (rest_v, rest_j, rest_h);
                start += count;
            }
            let derivatives = &self.derivatives;
            blocks.into_par_iter().for_each(|(start, a, b, c)| {
                sweep.run(start, &mut derivatives.clone(), a, b, c);
            });
        }
        self.evaluate_terminal(x);
        if self.has_terminal() {
            let mut k = 0;
            for a in 0..l.nx {
                for b in 0..=a {
                    terminal[k] = objective_factor * self.terminal_hessian[a * l.nx + b];
                    k += 1;
                }
            }
        }
        self.remember(x, Cached::Jacobians);
    }
}

/// Horizons of at least this many stages per thread are swept in parallel.
const PARALLEL_STAGES: usize = 64;

/// What one stage's derivative sweep reads.
struct StageSweep<'a> {
    plant: &'a Arc<Plant>,
    layout: OcpLayout,
    sides: &'a [SoftSide],
    state: &'a [f64],
    forecast: &'a [f64],
    params: &'a [f64],
    x: &'a [f64],
    objective_factor: f64,
    multipliers: &'a [f64],
    n_terms: usize,
}

impl StageSweep<'_> {
    /// Sweeps the stages from `start` on, as many as `values` has room for; `values`,
    /// `jacobians` and `hessian` are those stages' slices.
    fn run(
        &self,
        start: usize,
        derivatives: &mut StepDerivatives,
        values: &mut [f64],
        jacobians: &mut [f64],
        hessian: &mut [f64],
    ) {
        let l = self.layout;
        let pl = self.plant.layout;
        let n_out = self.plant.n_step_outputs();
        let nw = l.nx + l.nu;
        let ny0 = l.nx + self.n_terms;
        let mut inputs = vec![0.0; pl.n_base()];
        let mut weights = vec![0.0; n_out];
        let mut k = 0;
        for (i, (vals, jac)) in values
            .chunks_mut(n_out)
            .zip(jacobians.chunks_mut(n_out * nw))
            .enumerate()
        {
            let j = start + i;
            // Weights of the outputs in the Lagrangian.
            weights.fill(0.0);
            let row = l.dynamics_row(j);
            for (w, m) in weights[..l.nx].iter_mut().zip(&self.multipliers[row..]) {
                *w = -m;
            }
            weights[l.nx..l.nx + self.n_terms].fill(-self.objective_factor);
            for (q, side) in self.sides.iter().enumerate() {
                weights[ny0 + side.output] +=
                    self.multipliers[l.soft_row(j) + q] * side.sign * side.weight;
            }
            // The tape's inputs (x_j, u_j, d_j, p).
            let xj = if j == 0 {
                self.state
            } else {
                &self.x[l.x(j)..l.x(j) + l.nx]
            };
            inputs[..l.nx].copy_from_slice(xj);
            inputs[pl.u(0)..pl.u(0) + l.nu].copy_from_slice(&self.x[l.u(j)..l.u(j) + l.nu]);
            inputs[pl.d(0)..pl.d(0) + pl.nd]
                .copy_from_slice(&self.forecast[j * pl.nd..(j + 1) * pl.nd]);
            inputs[pl.p(0)..pl.p(0) + pl.np].copy_from_slice(self.params);
            let e = derivatives.hessian(self.plant, &inputs, &weights);
            vals.copy_from_slice(&e.values);
            jac.copy_from_slice(&e.jacobian);
            let cols = if j == 0 { l.nx..nw } else { 0..nw };
            for a in cols.clone() {
                for b in cols.start..=a {
                    hessian[k] = e.hessian[a * nw + b];
                    k += 1;
                }
            }
        }
    }
}

fn check(what: &'static str, given: usize, expected: usize) -> Result<(), OcpError> {
    if given == expected {
        Ok(())
    } else {
        Err(OcpError::Dimension {
            what,
            given,
            expected,
        })
    }
}

impl Ocp {
    /// Input boxes, rate limits on the first input and non-negative slacks; states free.
    fn bounds_without_region(&self, lower: &mut [f64], upper: &mut [f64]) {
        let l = self.layout;
        lower.fill(f64::NEG_INFINITY);
        upper.fill(f64::INFINITY);
        let inputs = &self.plant.model.inputs;
        for j in 0..l.horizon {
            for (i, decl) in inputs.iter().enumerate() {
                lower[l.u(j) + i] = decl.lower;
                upper[l.u(j) + i] = decl.upper;
            }
            lower[l.s(j)..l.s(j) + l.ns].fill(0.0);
        }
        for &(i, rate) in &self.rated {
            let prev = self.previous_input[i];
            let (lo, hi) = (lower[i].max(prev - rate), upper[i].min(prev + rate));
            // A previous input outside the box leaves the nearest feasible value.
            let (lo, hi) = if lo <= hi {
                (lo, hi)
            } else if prev < lower[i] {
                (lower[i], lower[i])
            } else {
                (upper[i], upper[i])
            };
            lower[i] = lo;
            upper[i] = hi;
        }
    }
}

impl Nlp for Ocp {
    /// The model's `solver objective_scale`.
    fn objective_scaling(&self) -> f64 {
        self.plant.model.solver.objective_scale
    }

    fn n_vars(&self) -> usize {
        self.layout.n_vars()
    }

    fn n_cons(&self) -> usize {
        self.layout.n_cons()
    }

    fn var_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        self.bounds_without_region(lower, upper);
        let l = self.layout;
        if let Some(b) = &self.terminal_box {
            let x_n = l.x(l.horizon);
            let u_last = l.u(l.horizon - 1);
            lower[x_n..x_n + l.nx].copy_from_slice(&b.state_lower);
            upper[x_n..x_n + l.nx].copy_from_slice(&b.state_upper);
            for i in 0..l.nu {
                lower[u_last + i] = lower[u_last + i].max(b.input_lower[i]);
                upper[u_last + i] = upper[u_last + i]
                    .min(b.input_upper[i])
                    .max(lower[u_last + i]);
            }
        }
    }

    /// The scales of the bounds without the terminal region: a region a few per cent wide
    /// would otherwise multiply the solver's Levenberg–Marquardt term on `x_N` and
    /// `u_{N−1}` by the inverse square of its width (10⁴ at ε = 5 %), and that term, no
    /// longer negligible beside the curvature, slows Newton's method to a linear rate.
    fn var_scales(&self, _lower: &[f64], _upper: &[f64], scale: &mut [f64]) {
        let n = scale.len();
        let (mut lower, mut upper) = (vec![0.0; n], vec![0.0; n]);
        self.bounds_without_region(&mut lower, &mut upper);
        crate::nlp::ranges_into(&lower, &upper, scale);
    }

    fn con_bounds(&self, lower: &mut [f64], upper: &mut [f64]) {
        let l = self.layout;
        for j in 0..l.horizon {
            let d = l.dynamics_row(j);
            lower[d..d + l.nx].fill(0.0);
            upper[d..d + l.nx].fill(0.0);
            let s = l.soft_row(j);
            lower[s..s + l.ns].fill(0.0);
            upper[s..s + l.ns].fill(f64::INFINITY);
            if j >= 1 {
                for (r, &(_, rate)) in self.rated.iter().enumerate() {
                    lower[l.rate_row(j) + r] = -rate;
                    upper[l.rate_row(j) + r] = rate;
                }
            }
        }
    }

    /// The previous input held over the horizon (within the first stage's bounds),
    /// simulated.
    fn initial_point(&mut self, x: &mut [f64]) {
        let l = self.layout;
        let (mut lo, mut hi) = (vec![0.0; l.n_vars()], vec![0.0; l.n_vars()]);
        self.var_bounds(&mut lo, &mut hi);
        let mut inputs = Vec::with_capacity(l.horizon * l.nu);
        for _ in 0..l.horizon {
            for i in 0..l.nu {
                inputs.push(self.previous_input[i].clamp(lo[i], hi[i]));
            }
        }
        self.rollout(&inputs, x);
    }

    fn objective(&mut self, x: &[f64]) -> f64 {
        self.ensure_values(x);
        self.objective_from_cache(x)
    }

    fn gradient(&mut self, x: &[f64], gradient: &mut [f64]) {
        self.ensure_jacobians(x);
        self.gradient_from_cache(gradient);
    }

    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        self.ensure_values(x);
        self.constraints_from_cache(x, g);
    }

    fn jacobian_pattern(&self) -> &Pattern {
        &self.jacobian_pattern
    }

    fn jacobian_values(&mut self, x: &[f64], values: &mut [f64]) {
        self.ensure_jacobians(x);
        self.jacobian_from_cache(values);
    }

    fn hessian_pattern(&self) -> &Pattern {
        &self.hessian_pattern
    }

    fn hessian_values(
        &mut self,
        x: &[f64],
        objective_factor: f64,
        multipliers: &[f64],
        values: &mut [f64],
    ) {
        self.hessian_sweep(x, objective_factor, multipliers, values);
    }

    /// Re-simulates the states from the inputs of `x` and sets the slacks to the
    /// penalties: the dynamics and soft-band rows then hold exactly.
    fn restore_feasibility(&mut self, x: &mut [f64]) -> bool {
        let l = self.layout;
        for j in 0..l.horizon {
            self.evaluate_stage_values(x, j);
            let o = self.stage_offset(j);
            let next = l.x(j + 1);
            x[next..next + l.nx].copy_from_slice(&self.stage_values[o..o + l.nx]);
        }
        self.set_slacks(x);
        true
    }

    /// States `x_1 … x_N` (the measured `x_0` is no variable), controls `(u_j, s_j)`,
    /// dynamics rows `x_{j+1} − F(x_j, u_j) = 0`; the rate rows link `u_j` to `u_{j−1}`.
    fn stages(&self) -> Option<Stages> {
        let l = self.layout;
        let n = l.horizon;
        let states = std::iter::once(0..0)
            .chain((1..=n).map(|j| l.x(j)..l.x(j) + l.nx))
            .collect();
        let controls = (0..n).map(|j| l.u(j)..l.u(j) + l.nu + l.ns).collect();
        let dynamics = (0..n)
            .map(|j| l.dynamics_row(j)..l.dynamics_row(j) + l.nx)
            .collect();
        Some(Stages {
            states,
            controls,
            dynamics,
        })
    }

    fn hessian_blocks(&self) -> Vec<Range<usize>> {
        let l = self.layout;
        let mut blocks: Vec<Range<usize>> = (0..l.horizon).map(|j| l.stage_vars(j)).collect();
        blocks.push(l.x(l.horizon)..l.x(l.horizon) + l.nx);
        blocks
    }

    fn evaluate_all(
        &mut self,
        x: &[f64],
        objective_factor: f64,
        multipliers: &[f64],
        g: &mut [f64],
        gradient: &mut [f64],
        jacobian: &mut [f64],
        hessian: &mut [f64],
    ) -> f64 {
        self.hessian_sweep(x, objective_factor, multipliers, hessian);
        self.constraints_from_cache(x, g);
        self.gradient_from_cache(gradient);
        self.jacobian_from_cache(jacobian);
        self.objective_from_cache(x)
    }
}
