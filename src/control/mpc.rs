//! Economic model-predictive control: at every step, solve the optimal-control problem
//! over the horizon from the measured state and apply the first input.
//!
//! The solve starts from the previous solution shifted by one step, as the back-end prefers
//! ([`WarmStart::preferred_by`], [`Mpc::warm_start`]): the interior point from the shifted primal
//! point with a fresh barrier (and, under guidance, the shifted constraint multipliers;
//! [`WarmStart::Primal`]: a similar number of iterations every step, none much longer; with the
//! multipliers for plain MPC too and the bare plan where the Hessian keeps needing
//! corrections, [`WarmStart::PrimalMultipliers`]), SQP from the shifted primal point and
//! multipliers ([`WarmStart::PrimalDual`]). Its status is checked every step. A
//! primal-dual warm solve is capped at [`Mpc::warm_iteration_limit`] iterations (the
//! solver's [`Solver::warm_iteration_budget`]: 15 for SQP, 40 for IPOPT, 80 for the
//! interior-point method): from a shifted solution SQP needs only a few, and one that needs
//! many more is usually stuck on a flat stretch of the economic cost, where a cold start is
//! the better use of time (measured: `docs/benchmarks.md`, "Economic MPC over the 40-day
//! Venlo season"). When it fails, the controller falls back, in this order:
//!
//! 1. `cold_start`: solve again from the held previous input, simulated; first, under
//!    guidance, from a fresh roll-out of the guide, its terminal region re-centred on it,
//!    and without guidance, on a model with a `rule` on every input, from a roll-out of
//!    those rules, a plan of the growers' (measured in `docs/benchmarks.md`, "Economic MPC
//!    of the GreenLight tomato, priced on its fruit");
//! 2. `simulation_model` (plain MPC on a model that plans with fewer sub-steps than it
//!    simulates with, [`Plant::planning`]): solve cold once more on the model integrated
//!    as the plant is, whose problem the coarse one only approximates (on the GreenLight
//!    tomato a state where one sub-step's problem ran out of iterations solved in 121 with
//!    four). Where this fallback exists, the cold starts of fallback 1 are capped at
//!    [`LAST_RESORT_COLD_ITERATIONS`] iterations, so a step does not spend the solver's
//!    whole budget twice on the coarse problem before it;
//! 3. `shorter_horizon`: solve plain MPC's problem cold over half the horizon, then a
//!    quarter, … down to one step (each capped at [`LAST_RESORT_COLD_ITERATIONS`]), and
//!    apply the first input of the first that succeeds: on the GreenLight tomato at 1 h, a
//!    night state where the screen closes ran out of iterations over 12 steps and solved
//!    over 6 (`docs/benchmarks.md`, "The last resort over shorter horizons"). Under
//!    guidance too, without the terminal cost and region: RL-guided MPC on the tomato
//!    otherwise applied its shifted plan or the guide's input at 34 of its first 1 152
//!    steps (`docs/results.md`, "A guide distilled from MPC"). Neither that plan nor an
//!    older one is kept: the next step starts cold over the whole horizon, and should it
//!    fail, holds the input;
//! 4. `shifted_plan`: apply the input the last successful plan holds for this step (its
//!    second where it was computed at the step before);
//! 5. `guide_input` (RL-guided MPC only): the guide's own input;
//! 6. `hold_input`: hold the previous input (within the bounds and rate limits).
//!
//! The step's record names the path taken, so a season's log shows every fallback.
//!
//! A [`Guidance`] (RL-guided MPC, [`RlGuidance`](crate::control::RlGuidance)) turns this
//! controller into RL-guided MPC: before each solve it sets the terminal cost and region
//! and writes the starting point; its own input is one more fallback, before the held
//! input.

use super::roll_out::RollOut;
use super::warm_start::PRIMAL_DUAL_TRIAL_ITERATIONS;
use super::Rules;
use super::{
    ControlError, Controller, Decision, Fallback, Observation, Plan, StepRecord, WarmStart,
};
use crate::model::Plant;
use crate::nlp::{Bands, Nlp, Ocp, OcpError};
use crate::solve::{Solution, Solver, Start};
use std::sync::Arc;
use std::time::Instant;

/// What RL-guided MPC adds to MPC at each step. See the [module documentation](self).
pub trait Guidance: Send {
    /// A short name for reports (`rlmpc`, `rlmpc-vfo`, ...).
    fn name(&self) -> String;

    /// Prepares the problem just set for `observation` (with `forecast` padded to the
    /// horizon): the terminal cost and region, and the primal starting point `start`.
    /// `previous` is the last solution when it was computed at the previous step.
    fn prepare(
        &mut self,
        ocp: &mut Ocp,
        observation: &Observation,
        forecast: &[f64],
        previous: Option<&[f64]>,
        start: &mut [f64],
    ) -> Result<(), ControlError>;

    /// The guide's own input at this step, for the fallback.
    fn guide_input(&mut self, observation: &Observation) -> Option<Vec<f64>>;

    /// The terminal region's state at a solution, for the step record.
    fn region_status(&self, ocp: &Ocp, x: &[f64]) -> Option<String>;

    /// Rows of forecast past the horizon that [`Guidance::prepare`] reads: the guide's own
    /// ([`Controller::forecast_rows`]), for its roll-out's last steps.
    fn forecast_rows(&self) -> usize {
        0
    }
}

/// Iteration cap of plain MPC's cold solves where a last resort follows them: the cold
/// starts on the planning model where the `simulation_model` fallback follows, and every
/// solve of the `shorter_horizon` fallback. On the GreenLight tomato at 1 h a
/// cold solve that succeeds took 60 iterations at the season's first step and 25 at a
/// step's cold restart (the first two Bleiswijk days); each of the 14 failed steps of the
/// 60-day season before the fallback ran two cold solves to the interior point's limit of
/// 500 iterations, and with the fallback behind them such a step took 16 to 37 s. The cap
/// is over three times the successful solves. On a model that plans as it simulates (the
/// lettuce, the CSTR) and under guidance, the cold starts keep the solver's own limit, as
/// the seasons of `docs/results.md` were run: there they are the step's last full-horizon
/// solve, and stopping one early trades a solution for a shorter horizon's.
pub const LAST_RESORT_COLD_ITERATIONS: usize = 200;

/// The economic MPC controller.
pub struct Mpc {
    ocp: Ocp,
    solver: Box<dyn Solver>,
    /// The last successful solution over the whole horizon, in the time frame of the step
    /// it was computed at; dropped when a step is decided by a shorter horizon, whose
    /// input departs from its plan.
    last: Option<Solution>,
    /// How many steps ago `last` was computed.
    last_age: usize,
    forecast: Vec<f64>,
    start_x: Vec<f64>,
    start_lambda: Vec<f64>,
    start_nu: Vec<f64>,
    /// How each step restarts from the previous one's solution (default: the one the
    /// back-end prefers, [`WarmStart::preferred_by`]).
    pub warm_start: WarmStart,
    /// Iteration cap of a primal-dual warm solve before the cold start takes over.
    pub warm_iteration_limit: Option<usize>,
    guidance: Option<Box<dyn Guidance>>,
    /// The model's own rules, where every input has one, and the nominal model they are
    /// rolled out on: a cold start tries their roll-out first.
    rules: Option<(Rules, RollOut)>,
    /// Which bounds of the soft bands the problems measure.
    bands: Bands,
    /// The plant as simulated, where MPC plans with fewer sub-steps, and its problem,
    /// built on first use: the last resort of plain MPC before a fallback input.
    simulation_model: Option<(Arc<Plant>, Option<Ocp>)>,
    /// The problems over half the horizon, a quarter, …, built on first use: plain MPC's
    /// last resort before a fallback input.
    shorter_horizons: Vec<Ocp>,
}

impl Mpc {
    /// MPC of `plant` over `horizon` steps with `solver`, predicting with nominal
    /// parameters and the model's `plan substeps` ([`Plant::planning`]).
    pub fn new(
        plant: Arc<Plant>,
        horizon: usize,
        solver: Box<dyn Solver>,
    ) -> Result<Mpc, OcpError> {
        let simulated = plant;
        let plant = simulated.planning();
        let simulation_model = (!Arc::ptr_eq(&plant, &simulated)).then_some((simulated, None));
        let rules = Rules::new(Arc::clone(&plant))
            .ok()
            .map(|rules| (rules, RollOut::new(Arc::clone(&plant))));
        let ocp = Ocp::new(plant, horizon)?;
        let (n, m) = (ocp.n_vars(), ocp.n_cons());
        Ok(Mpc {
            ocp,
            last: None,
            last_age: 0,
            forecast: Vec::new(),
            start_x: vec![0.0; n],
            start_lambda: vec![0.0; m],
            start_nu: vec![0.0; n],
            warm_start: WarmStart::preferred_by(solver.as_ref()),
            warm_iteration_limit: Some(solver.warm_iteration_budget()),
            solver,
            guidance: None,
            rules,
            bands: Bands::Planning,
            simulation_model,
            shorter_horizons: Vec::new(),
        })
    }

    /// MPC whose problem measures the soft bands at `bands`: [`Bands::Planning`] (the
    /// default of [`Mpc::new`]: the model file's `plan` bounds, a back-off for a plant
    /// that differs from the model) or [`Bands::Scoring`] (the bounds the season is scored
    /// with, right when the plant is the model).
    pub fn with_bands(mut self, bands: Bands) -> Result<Mpc, OcpError> {
        let plant = Arc::clone(self.ocp.plant());
        self.ocp = Ocp::with_bands(plant, self.ocp.horizon(), bands)?;
        self.bands = bands;
        if let Some((_, ocp)) = &mut self.simulation_model {
            *ocp = None;
        }
        self.shorter_horizons.clear();
        Ok(self)
    }

    /// MPC with a [`Guidance`]: RL-guided MPC.
    pub fn with_guidance(mut self, guidance: Box<dyn Guidance>) -> Mpc {
        self.guidance = Some(guidance);
        self
    }

    /// The optimal-control problem solved at every step; it holds the problem of the last
    /// step decided.
    pub fn ocp(&self) -> &Ocp {
        &self.ocp
    }

    /// The optimal-control problem, to change its settings between steps (the parameters
    /// it predicts with, for one); the next [`decide`](Controller::decide) sets the step,
    /// state, previous input and forecast again, and a [`Guidance`] its terminal cost and
    /// region.
    pub fn ocp_mut(&mut self) -> &mut Ocp {
        &mut self.ocp
    }

    /// The last successful solution over the whole horizon (its plan starts at the step it
    /// was computed for); `None` after a step decided by the `shorter_horizon` fallback.
    pub fn last_solution(&self) -> Option<&Solution> {
        self.last.as_ref()
    }

    /// The forecast padded to the horizon, and the rows past it the guidance reads, by
    /// repeating its last row.
    fn pad_forecast(&mut self, forecast: &[f64]) -> Result<(), ControlError> {
        let nd = self.ocp.plant().layout.nd;
        let beyond = self.guidance.as_ref().map_or(0, |g| g.forecast_rows());
        let needed = (self.ocp.horizon() + beyond) * nd;
        self.forecast.clear();
        self.forecast
            .extend_from_slice(&forecast[..forecast.len().min(needed)]);
        if self.forecast.len() < needed {
            if nd > 0 && forecast.len() < nd {
                return Err(ControlError::Other("the forecast is empty".into()));
            }
            let last = forecast[forecast.len() - nd..].to_vec();
            while self.forecast.len() < needed {
                self.forecast.extend_from_slice(&last);
            }
        }
        Ok(())
    }

    /// The warm solve from the previous step's solution, shifted (its primal point too,
    /// unless `primal_ready`: a guidance wrote `start_x` already); `None` without one.
    fn solve_warm(&mut self, primal_ready: bool) -> Option<Solution> {
        let last = self.last.as_ref()?;
        if self.last_age != 1 {
            return None;
        }
        if !primal_ready {
            self.ocp.shift_primal(&last.x, &mut self.start_x);
        }
        if self.warm_start == WarmStart::Primal && !primal_ready {
            return Some(
                self.solver
                    .solve(&mut self.ocp, Start::shifted(&self.start_x)),
            );
        }
        self.ocp
            .shift_multipliers(&last.multipliers, &mut self.start_lambda);
        if !matches!(
            self.warm_start,
            WarmStart::PrimalDual | WarmStart::PrimalDualCapped
        ) {
            // A guided restart (RL-guided MPC) also carries the constraint multipliers:
            // see `IpmOptions::shifted_slack_push` for what that buys and why plain MPC
            // does so only when asked to (`WarmStart::PrimalMultipliers`).
            if primal_ready {
                let start = Start::shifted(&self.start_x).with_multipliers(&self.start_lambda);
                return Some(self.solver.solve(&mut self.ocp, start));
            }
            return Some(self.solve_shifted_with_multipliers());
        }
        self.ocp
            .shift_bound_multipliers(&last.bound_multipliers, &mut self.start_nu);
        if self.warm_start == WarmStart::PrimalDualCapped {
            return Some(self.solve_primal_dual_then_shifted(primal_ready));
        }
        // From a good warm start SQP needs two or three iterations; a warm solve that
        // needs many more is usually stuck, and a cold start is the better use of time.
        Some(solve_capped(
            self.solver.as_mut(),
            self.warm_iteration_limit,
            &mut self.ocp,
            Start::warm(&self.start_x, &self.start_lambda, &self.start_nu),
        ))
    }

    /// Plain MPC's [`WarmStart::PrimalMultipliers`] restart: from the shifted plan and
    /// multipliers while the Hessian needs fewer than [`CLOSER_START_CORRECTIONS`]
    /// corrections, else again from the shifted plan alone. The returned solution counts
    /// the iterations and corrections of both attempts.
    fn solve_shifted_with_multipliers(&mut self) -> Solution {
        self.solver
            .set_correction_limit(Some(CLOSER_START_CORRECTIONS));
        let start = Start::shifted(&self.start_x).with_multipliers(&self.start_lambda);
        let closer = self.solver.solve(&mut self.ocp, start);
        self.solver.set_correction_limit(None);
        if closer.status.is_success() {
            return closer;
        }
        let bare = self
            .solver
            .solve(&mut self.ocp, Start::shifted(&self.start_x));
        after(&closer, bare)
    }

    /// The [`WarmStart::PrimalDualCapped`] restart: from the shifted point and all its
    /// multipliers for at most [`PRIMAL_DUAL_TRIAL_ITERATIONS`] iterations, else from the
    /// shifted point with a fresh barrier as [`WarmStart::Primal`] restarts (with the
    /// constraint multipliers where `guided`). The returned solution counts the iterations
    /// and corrections of both attempts.
    fn solve_primal_dual_then_shifted(&mut self, guided: bool) -> Solution {
        let trial = solve_capped(
            self.solver.as_mut(),
            Some(PRIMAL_DUAL_TRIAL_ITERATIONS),
            &mut self.ocp,
            Start::warm(&self.start_x, &self.start_lambda, &self.start_nu),
        );
        if trial.status.is_success() {
            return trial;
        }
        let start = Start::shifted(&self.start_x);
        let start = if guided {
            start.with_multipliers(&self.start_lambda)
        } else {
            start
        };
        let shifted = self.solver.solve(&mut self.ocp, start);
        after(&trial, shifted)
    }

    /// The guided solve: from the guidance's starting point, with the shifted multipliers
    /// when the previous step's solution exists (capped like the warm start), else cold
    /// from a fresh roll-out of the guide. Returns the solution and whether it was warm.
    fn solve_guided(
        &mut self,
        observation: &Observation,
    ) -> Result<(Solution, bool), ControlError> {
        let previous = match (&self.last, self.last_age) {
            (Some(last), 1) => Some(last),
            _ => None,
        };
        let Some(guidance) = self.guidance.as_mut() else {
            return Err(ControlError::Other("no guidance".into()));
        };
        guidance.prepare(
            &mut self.ocp,
            observation,
            &self.forecast,
            previous.map(|s| s.x.as_slice()),
            &mut self.start_x,
        )?;
        Ok(match self.solve_warm(true) {
            Some(s) => (s, true),
            None => (
                self.solver.solve(&mut self.ocp, Start::cold(&self.start_x)),
                false,
            ),
        })
    }

    /// The cold start: from the held previous input, simulated. Under guidance, a fresh
    /// roll-out of the guide from the measured state, with the terminal region re-centred
    /// on it, is tried first (capped like the warm start): the held input's trajectory
    /// usually lies outside a region built around the shifted plan, and its first QP is
    /// then infeasible. The guided attempt is skipped when `guide_tried` (the step's first
    /// solve already started from that roll-out, and would fail the same way). Without
    /// guidance, a roll-out of the model's rules is tried first where every input has one.
    /// Returns the solution and the iterations and Hessian corrections of every attempt.
    fn solve_cold(
        &mut self,
        observation: &Observation,
        guide_tried: bool,
    ) -> Result<(Solution, Effort), ControlError> {
        let mut effort = Effort::default();
        if let Some(guidance) = self.guidance.as_mut().filter(|_| !guide_tried) {
            guidance.prepare(
                &mut self.ocp,
                observation,
                &self.forecast,
                None,
                &mut self.start_x,
            )?;
            let guided = solve_capped(
                self.solver.as_mut(),
                self.warm_iteration_limit,
                &mut self.ocp,
                Start::cold(&self.start_x),
            );
            effort.add(&guided);
            if guided.status.is_success() {
                return Ok((guided, effort));
            }
        }
        // Plain MPC with the simulation model behind it caps its cold solves here.
        let limit = self
            .simulation_model_follows()
            .then_some(LAST_RESORT_COLD_ITERATIONS);
        if self.guidance.is_none() && self.rules_roll_out(observation)? {
            let ruled = solve_capped(
                self.solver.as_mut(),
                limit,
                &mut self.ocp,
                Start::cold(&self.start_x),
            );
            effort.add(&ruled);
            if ruled.status.is_success() {
                return Ok((ruled, effort));
            }
        }
        self.ocp.initial_point(&mut self.start_x);
        let plain = solve_capped(
            self.solver.as_mut(),
            limit,
            &mut self.ocp,
            Start::cold(&self.start_x),
        );
        effort.add(&plain);
        Ok((plain, effort))
    }

    /// Writes into the starting point the roll-out of the model's rules from the measured
    /// state over the forecast; false (nothing written) where some input has no rule.
    fn rules_roll_out(&mut self, observation: &Observation) -> Result<bool, ControlError> {
        let Some(inputs) = self.rules_inputs(observation)? else {
            return Ok(false);
        };
        self.ocp.rollout(&inputs, &mut self.start_x);
        Ok(true)
    }

    /// The inputs of the model's rules over the horizon from the measured state; `None`
    /// where some input has no rule.
    fn rules_inputs(
        &mut self,
        observation: &Observation,
    ) -> Result<Option<Vec<f64>>, ControlError> {
        let Some((rules, roll_out)) = self.rules.as_mut() else {
            return Ok(None);
        };
        let mut inputs = Vec::with_capacity(self.ocp.horizon() * observation.previous_input.len());
        roll_out.horizon(
            rules,
            observation,
            &self.forecast,
            self.ocp.horizon(),
            &mut inputs,
        )?;
        Ok(Some(inputs))
    }

    /// Whether a failed step is solved once more on the simulation model: plain MPC (no
    /// guidance, which prepares the planning problem only) on a model that plans with
    /// fewer sub-steps than it is simulated with.
    fn simulation_model_follows(&self) -> bool {
        self.guidance.is_none() && self.simulation_model.is_some()
    }

    /// Plain MPC's last resort where it plans with fewer sub-steps than the plant is
    /// simulated with: the step's problem on the model integrated as the plant is (the
    /// model's own terminal terms, not settings changed through [`Mpc::ocp_mut`]), solved
    /// cold from the rules' roll-out where every input has a rule, else from the held
    /// input. `None` where there is no such model, or under guidance (which prepares the
    /// planning problem only). Its solution has the planning problem's layout.
    fn solve_on_simulation_model(
        &mut self,
        observation: &Observation,
    ) -> Result<Option<Solution>, ControlError> {
        if !self.simulation_model_follows() {
            return Ok(None);
        }
        let inputs = self.rules_inputs(observation)?;
        let (horizon, bands) = (self.ocp.horizon(), self.bands);
        let Some((plant, built)) = self.simulation_model.as_mut() else {
            return Ok(None);
        };
        let ocp = match built {
            Some(ocp) => ocp,
            None => built.insert(Ocp::with_bands(Arc::clone(plant), horizon, bands)?),
        };
        cold_problem(
            ocp,
            observation,
            &self.forecast,
            inputs.as_deref(),
            &mut self.start_x,
        )?;
        Ok(Some(self.solver.solve(ocp, Start::cold(&self.start_x))))
    }

    /// The last resort: plain MPC's problem over half the horizon, then a quarter, … down
    /// to one step (the planning model, its own terminal terms, the same bands; under
    /// guidance too, without its terminal cost and region), each solved cold from the
    /// rules' roll-out where every input has a rule, else from the held input, capped at
    /// [`LAST_RESORT_COLD_ITERATIONS`]. Returns the first success and its first input,
    /// with the effort of every attempt added to `effort`; `None` where none succeeded.
    fn solve_on_shorter_horizons(
        &mut self,
        observation: &Observation,
        effort: &mut Effort,
    ) -> Result<Option<(Solution, Vec<f64>)>, ControlError> {
        let inputs = self.rules_inputs(observation)?;
        let mut start = Vec::new();
        let horizons = halved_horizons(self.ocp.horizon());
        for (k, &horizon) in horizons.iter().enumerate() {
            if k == self.shorter_horizons.len() {
                let plant = Arc::clone(self.ocp.plant());
                self.shorter_horizons
                    .push(Ocp::with_bands(plant, horizon, self.bands)?);
            }
            let ocp = &mut self.shorter_horizons[k];
            start.resize(ocp.n_vars(), 0.0);
            cold_problem(
                ocp,
                observation,
                &self.forecast,
                inputs.as_deref(),
                &mut start,
            )?;
            let solution = solve_capped(
                self.solver.as_mut(),
                Some(LAST_RESORT_COLD_ITERATIONS),
                ocp,
                Start::cold(&start),
            );
            effort.add(&solution);
            if solution.status.is_success() {
                let input = ocp.input(&solution.x, 0).to_vec();
                return Ok(Some((solution, input)));
            }
        }
        Ok(None)
    }

    /// The fallback inputs when no solve succeeded.
    fn fallback_input(&mut self, observation: &Observation) -> (Vec<f64>, Fallback) {
        let previous = observation.previous_input;
        let planned = self.last.as_ref().and_then(|s| {
            let j = self.last_age;
            (j < self.ocp.horizon()).then(|| self.ocp.input(&s.x, j).to_vec())
        });
        let mut guided = || {
            self.guidance
                .as_mut()
                .and_then(|g| g.guide_input(observation))
        };
        let (mut u, path) = match planned {
            Some(u) => (u, Fallback::ShiftedPlan),
            None => match guided() {
                Some(u) => (u, Fallback::GuideInput),
                None => (previous.to_vec(), Fallback::HoldInput),
            },
        };
        self.ocp.plant().apply_limits(previous, &mut u);
        (u, path)
    }
}

/// Hessian corrections after which plain MPC gives up its restart with the shifted
/// multipliers and restarts from the shifted plan alone. Over the paper study's MPC
/// seasons that restart took markedly fewer iterations a step than the bare plan, but
/// where the shifted multipliers left the Hessian indefinite (the few steps that needed
/// three corrections or more) it crawled, nearly every iteration corrected, where
/// the bare plan needed few. Steps with fewer than three corrections stayed well within
/// 10× their season's median, so the limit touches only the crawls; with it the longest
/// step of any season is shorter than the bare plan's longest and within 10× its median
/// (measured: `docs/benchmarks.md`, "Plain MPC restarted with its multipliers"; the
/// crawls: `docs/benchmarks-history.md`, the same heading).
const CLOSER_START_CORRECTIONS: usize = 3;

/// The iterations and Hessian corrections of one step's solves.
#[derive(Debug, Clone, Copy, Default)]
struct Effort {
    iterations: usize,
    corrections: usize,
}

impl Effort {
    fn add(&mut self, solution: &Solution) {
        self.iterations += solution.stats.iterations;
        self.corrections += solution.stats.inertia_corrections;
    }
}

/// Sets `ocp`'s problem at `observation` with `forecast` (padded to a horizon at least as
/// long), and its cold start into `start`: the roll-out of `inputs` (the rules' inputs over
/// a horizon at least as long; its first steps) where given, else the problem's initial
/// point.
fn cold_problem(
    ocp: &mut Ocp,
    observation: &Observation,
    forecast: &[f64],
    inputs: Option<&[f64]>,
    start: &mut [f64],
) -> Result<(), ControlError> {
    ocp.set_problem(
        observation.step,
        observation.state,
        observation.previous_input,
        forecast,
    )?;
    match inputs {
        Some(inputs) => {
            let needed = ocp.horizon() * ocp.plant().layout.nu;
            ocp.rollout(&inputs[..needed], start)
        }
        None => ocp.initial_point(start),
    }
    Ok(())
}

/// The horizons of [`Mpc`]'s `shorter_horizon` fallback below `horizon`: half of it, a
/// quarter, … down to one step.
///
/// ```text
/// 12 → 6, 3, 1        2 → 1        1 → (none)
/// ```
fn halved_horizons(horizon: usize) -> Vec<usize> {
    std::iter::successors(Some(horizon / 2), |h| Some(h / 2))
        .take_while(|&h| h >= 1)
        .collect()
}

/// `second`, counting the iterations, corrections and time of the `first` attempt it
/// followed at the same step.
fn after(first: &Solution, mut second: Solution) -> Solution {
    second.stats.iterations += first.stats.iterations;
    second.stats.inertia_corrections += first.stats.inertia_corrections;
    second.stats.time_s += first.stats.time_s;
    second
}

/// A solve capped at `limit` iterations; the cap is lifted afterwards.
fn solve_capped(
    solver: &mut dyn Solver,
    limit: Option<usize>,
    ocp: &mut Ocp,
    start: Start<'_>,
) -> Solution {
    solver.set_iteration_limit(limit);
    let solution = solver.solve(ocp, start);
    solver.set_iteration_limit(None);
    solution
}

impl Controller for Mpc {
    fn name(&self) -> String {
        match &self.guidance {
            Some(g) => format!("{}-{}", g.name(), self.solver.name()),
            None => format!("mpc-{}", self.solver.name()),
        }
    }

    fn plan(&self) -> Option<Plan> {
        let last = self.last.as_ref().filter(|_| self.last_age == 0)?;
        let n = self.ocp.horizon();
        Some(Plan {
            inputs: (0..n)
                .map(|j| self.ocp.input(&last.x, j).to_vec())
                .collect(),
            states: (1..=n)
                .map(|j| self.ocp.state_at(&last.x, j).to_vec())
                .collect(),
        })
    }

    fn decide(&mut self, observation: &Observation) -> Result<Decision, ControlError> {
        let clock = Instant::now();
        self.pad_forecast(observation.forecast)?;
        self.ocp.set_problem(
            observation.step,
            observation.state,
            observation.previous_input,
            &self.forecast,
        )?;
        self.last_age += 1;
        let mut effort = Effort::default();
        let mut fallback = None;
        // Whether the first solve already started from a fresh roll-out of the guide.
        let mut guide_tried = false;
        let mut solution = if self.guidance.is_some() {
            let (s, warm) = self.solve_guided(observation)?;
            guide_tried = !warm;
            Some(s)
        } else {
            self.solve_warm(false)
        };
        let warm_failed = solution.as_ref().is_some_and(|s| !s.status.is_success());
        if let Some(s) = &solution {
            effort.add(s);
        }
        if solution.as_ref().is_none_or(|s| !s.status.is_success()) {
            let (cold, cold_effort) = self.solve_cold(observation, guide_tried)?;
            effort.iterations += cold_effort.iterations;
            effort.corrections += cold_effort.corrections;
            if warm_failed {
                fallback = Some(Fallback::ColdStart);
            }
            solution = Some(cold);
        }
        let Some(mut solution) = solution else {
            return Err(ControlError::Other("no solve was attempted".into()));
        };
        if !solution.status.is_success() {
            if let Some(simulated) = self.solve_on_simulation_model(observation)? {
                effort.add(&simulated);
                if simulated.status.is_success() {
                    solution = simulated;
                    fallback = Some(Fallback::SimulationModel);
                }
            }
        }
        let mut status = solution.status;
        let mut terminal_region = None;
        let input = if status.is_success() {
            let u = self.ocp.input(&solution.x, 0).to_vec();
            terminal_region = self
                .guidance
                .as_ref()
                .and_then(|g| g.region_status(&self.ocp, &solution.x));
            self.last = Some(solution);
            self.last_age = 0;
            u
        } else if let Some((short, u)) = self.solve_on_shorter_horizons(observation, &mut effort)? {
            // The input departs from every plan over the whole horizon: none is shifted
            // into the next step.
            self.last = None;
            status = short.status;
            fallback = Some(Fallback::ShorterHorizon);
            u
        } else {
            let (u, path) = self.fallback_input(observation);
            fallback = Some(path);
            u
        };
        Ok(Decision {
            input,
            record: StepRecord {
                solve_time_s: clock.elapsed().as_secs_f64(),
                iterations: effort.iterations,
                inertia_corrections: effort.corrections,
                status: Some(status),
                fallback,
                terminal_region,
            },
        })
    }
}
