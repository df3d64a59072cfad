//! The plant: a checked model turned into the discrete-time functions a controller and a
//! simulator need, each compiled to a tape with exact derivatives.
//!
//! * `step`: `(x, u, d, p) → (x⁺, stage terms, y(x⁺))`, the integrator (RK4 or Euler with
//!   the declared sub-steps) unrolled into the graph, so that derivatives of the discrete
//!   step are exact, not derivatives of an approximation;
//! * `output`: `(x, u, d, p) → y(x)`.
//!
//! Architecture invariant: `model` knows no solver and no controller. It only reads the
//! language's [`Model`] and the graph.

mod block_newton;
mod builder;
mod dense_lu;
mod eigen_split;
pub mod finite;
mod implicit;
mod penalty;
pub mod singular;
mod sparse_lu;
mod step_derivatives;
mod terminal;
pub mod verify;

pub use crate::lang::model::{Layout, SoftBand};
pub use builder::{
    if_else, Band, BuildError, Disturbance, Expr, Input, ModelBuilder, Operand, Output, Param,
    State, Term,
};
pub use penalty::{band_penalty, StagePenalty};
pub use step_derivatives::StepDerivatives;
pub(crate) use terminal::ModelTerminalCost;

use crate::graph::{Graph, NodeId, Tape, Workspace};
use crate::lang::ast::TermKind;
use crate::lang::model::{Integrator, Model};
use implicit::{ImplicitStep, ImplicitWorkspace, Purpose, Tableau};
use std::sync::{Arc, OnceLock};

/// The discrete step as graph nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct DiscreteStep {
    /// `x⁺`: expressions over `(x, u, d, p)` for an explicit integrator; for an implicit
    /// one, the variables of the last stage.
    pub next_state: Vec<NodeId>,
    /// For an implicit integrator, the stage equations `G(z, W) = 0` that define the stage
    /// values `W` (variables numbered from [`Layout::n_all`] on); empty for explicit ones.
    pub residuals: Vec<NodeId>,
}

/// The right-hand side `f` at states `x`, `elapsed` seconds into the step: the clock, if the
/// model has one, reads its time at the start of the step and is advanced to each stage's
/// own time.
pub(crate) fn rhs_at(graph: &mut Graph, model: &Model, x: &[NodeId], elapsed: f64) -> Vec<NodeId> {
    let layout = model.layout();
    let mut repl: Vec<NodeId> = (0..layout.n_all()).map(|i| graph.var(i)).collect();
    repl[..layout.nx].copy_from_slice(x);
    if let Some(c) = model.clock().map(|i| layout.d(i)) {
        let offset = graph.constant(elapsed);
        repl[c] = graph.add(repl[c], offset);
    }
    graph.substitute(&model.derivatives, &repl)
}

/// Builds the discrete step `x⁺ = F(x, u, d, p)` as graph nodes over the base variables:
/// an explicit integrator unrolled, or an implicit one's stage equations.
///
/// ```
/// use ghm::model::{discretize, ModelBuilder};
///
/// // ẋ = −x over one step of h = 0.5 s: RK4 is the Taylor series of e^{−h} to h⁴.
/// let b = ModelBuilder::new("decay");
/// let x = b.state("x", 1.0);
/// b.der(x, -x);
/// b.sample(0.5, 1);
/// let model = b.build().unwrap();
/// let mut graph = model.graph.clone();
/// let step = discretize(&mut graph, &model);
/// let h: f64 = 0.5;
/// let rk4 = 1.0 - h + h.powi(2) / 2.0 - h.powi(3) / 6.0 + h.powi(4) / 24.0;
/// assert!((graph.eval_f64(&step.next_state, &[2.0])[0] - 2.0 * rk4).abs() < 1e-15);
/// assert!(step.residuals.is_empty());
/// ```
pub fn discretize(graph: &mut Graph, model: &Model) -> DiscreteStep {
    let next_state = match model.integrator {
        Integrator::Rk4 => unrolled(graph, model, rk4_substep),
        Integrator::Euler => unrolled(graph, model, euler_substep),
        Integrator::Radau5
        | Integrator::Radau3
        | Integrator::BackwardEuler
        | Integrator::Sdirk3 => {
            let tableau =
                Tableau::of(model.integrator).expect("every implicit integrator has a tableau");
            let w_offset = model.layout().n_all();
            let nodes = implicit::build_nodes(graph, model, &tableau, w_offset);
            return DiscreteStep {
                next_state: nodes.next_state,
                residuals: nodes.residuals,
            };
        }
    };
    DiscreteStep {
        next_state,
        residuals: Vec::new(),
    }
}

/// One explicit sub-step of length `h` from `x` at `t` seconds into the step.
type Substep = fn(&mut Graph, &Model, &[NodeId], f64, f64) -> Vec<NodeId>;

/// `x + a k`, element by element.
fn axpy(graph: &mut Graph, x: &[NodeId], a: f64, k: &[NodeId]) -> Vec<NodeId> {
    x.iter()
        .zip(k)
        .map(|(&xi, &ki)| {
            let s = graph.scale(a, ki);
            graph.add(xi, s)
        })
        .collect()
}

fn euler_substep(graph: &mut Graph, model: &Model, x: &[NodeId], t: f64, h: f64) -> Vec<NodeId> {
    let k1 = rhs_at(graph, model, x, t);
    axpy(graph, x, h, &k1)
}

fn rk4_substep(graph: &mut Graph, model: &Model, x: &[NodeId], t: f64, h: f64) -> Vec<NodeId> {
    let k1 = rhs_at(graph, model, x, t);
    let x2 = axpy(graph, x, h / 2.0, &k1);
    let k2 = rhs_at(graph, model, &x2, t + h / 2.0);
    let x3 = axpy(graph, x, h / 2.0, &k2);
    let k3 = rhs_at(graph, model, &x3, t + h / 2.0);
    let x4 = axpy(graph, x, h, &k3);
    let k4 = rhs_at(graph, model, &x4, t + h);
    (0..x.len())
        .map(|i| {
            let k23 = graph.add(k2[i], k3[i]);
            let k23 = graph.scale(2.0, k23);
            let s = graph.add(k1[i], k23);
            let s = graph.add(s, k4[i]);
            let inc = graph.scale(h / 6.0, s);
            graph.add(x[i], inc)
        })
        .collect()
}

/// An explicit integrator unrolled over the model's sub-steps.
fn unrolled(graph: &mut Graph, model: &Model, substep: Substep) -> Vec<NodeId> {
    let h = model.sample_period / model.substeps as f64;
    let mut x: Vec<NodeId> = (0..model.layout().nx).map(|i| graph.var(i)).collect();
    for sub in 0..model.substeps {
        x = substep(graph, model, &x, sub as f64 * h, h);
    }
    x
}

/// A model ready to be stepped, with compiled tapes.
///
/// # Examples
///
/// A tank, integrated with one forward-Euler step per minute so that every figure can be
/// checked by hand: `x⁺ = x + 60 (u + d − k x)`.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use ghm::graph::Derivatives;
/// use ghm::model::Plant;
///
/// let text = "\
/// model tank
/// sample 60 [s] integrator euler
/// state level [m] = 1
/// input inflow [m s^-1] in [0, 0.01] rate 0.002 start 0
/// disturbance rain [m s^-1]
/// param k [s^-1] = 0.001
/// der level = inflow + rain - k * level
/// output h [m] = level
/// output h_cm [cm] = 100 * level
/// reward stored [EUR] = 2 * next(level)
/// cost pumping [EUR] = 50 * inflow
/// soft h in [0.5, 1.2] weight 10
/// ";
/// let plant = Plant::new(ghm::lang::load_str("tank.ghm", text).map_err(|e| e.render())?);
/// let (x, u, d, p) = ([1.0], [0.005], [0.0], plant.model.nominal_params());
///
/// let step = plant.step(&x, &u, &d, &p);
/// let next = 1.0 + 60.0 * (0.005 - 0.001 * 1.0);
/// assert!((step.next_state[0] - next).abs() < 1e-12);
/// // Stage terms as rewards: the reward on the level after the step, the cost negated.
/// assert!((step.terms[0] - 2.0 * next).abs() < 1e-12);
/// assert!((step.terms[1] + 50.0 * 0.005).abs() < 1e-12);
/// assert!((step.economic() - (2.0 * next - 0.25)).abs() < 1e-12);
/// // Outputs after the step, and outputs now.
/// assert!((step.next_outputs[1] - 100.0 * next).abs() < 1e-10);
/// assert_eq!(plant.outputs(&x, &u, &d, &p), [1.0, 100.0]);
///
/// // The level 1.24 m is above the band [0.5, 1.2]: 10 per metre above it.
/// let penalty = plant.penalties(&step.next_outputs)[0];
/// assert!(penalty.outside && (penalty.value - 10.0 * (next - 1.2)).abs() < 1e-10);
///
/// // The input as the season loop applies it: at most 0.002 more than the step before.
/// let mut wanted = [0.009];
/// plant.apply_limits(&[0.0], &mut wanted);
/// assert_eq!(wanted, [0.002]);
///
/// // Exact derivatives of the discrete step: ∂x⁺/∂x = 1 − 60 k, ∂x⁺/∂u = 60.
/// let tape = plant.step_tape(); // inputs (x, u, d, p); outputs (x⁺, terms, y(x⁺))
/// let l = plant.layout;
/// let mut der = Derivatives::new(tape, &[l.x(0), l.u(0)]);
/// let e = der.jacobian(tape, &[1.0, 0.005, 0.0, 0.001]);
/// assert!((e.jacobian[0] - 0.94).abs() < 1e-14 && (e.jacobian[1] - 60.0).abs() < 1e-12);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct Plant {
    /// The model it was built from.
    pub model: Model,
    /// The model's variable layout: where `x`, `u`, `d`, `p` sit in the graph's variables.
    pub layout: Layout,
    /// The graph holding every expression below (the model's graph, extended).
    pub graph: Graph,
    /// `x⁺` nodes over `(x, u, d, p)`.
    pub next_state: Vec<NodeId>,
    /// Stage reward terms (rewards positive, costs negated) over `(x, u, d, p)`, `x⁺` substituted.
    pub stage_terms: Vec<NodeId>,
    /// Outputs at `x⁺` over `(x, u, d, p)`.
    pub next_outputs: Vec<NodeId>,
    /// Indices into `model.terms` of the stage terms.
    pub stage_term_index: Vec<usize>,
    step: StepKernel,
    output: Tape,
    /// The `terminal` terms' rewards over `(x, u, d, p)` (they read `x` and `p` only);
    /// `None` when the model has none.
    terminal: Option<Tape>,
    /// The plant the controllers predict with, built on first use where the model plans
    /// with other sub-steps than it simulates with ([`Plant::planning`]).
    planning: OnceLock<Arc<Plant>>,
}

/// The scratch of a [`StepKernel`].
#[derive(Debug, Clone)]
enum KernelWorkspace {
    Unrolled(Workspace<f64>),
    Implicit(Box<ImplicitWorkspace>),
}

/// How a step is computed: one tape, or Newton on stage equations.
#[derive(Debug, Clone)]
enum StepKernel {
    /// An explicit integrator unrolled into one tape over `(x, u, d, p)`.
    Unrolled(Tape),
    /// An implicit integrator's stage equations and step outputs.
    Implicit(Box<ImplicitStep>),
}

/// One step's results (empty buffers by default, filled by [`Plant::step_into`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StepOutcome {
    /// The state after the step, `x⁺`.
    pub next_state: Vec<f64>,
    /// Each stage term's reward contribution (costs negative), in `Plant::stage_term_index` order.
    pub terms: Vec<f64>,
    /// The outputs at `x⁺` (with the step's input and disturbance).
    pub next_outputs: Vec<f64>,
}

impl StepOutcome {
    /// The economic reward of the step: the sum of the stage terms.
    pub fn economic(&self) -> f64 {
        self.terms.iter().sum()
    }
}

/// Reusable buffers for [`Plant::step_into`].
#[derive(Debug, Clone)]
pub struct StepWorkspace {
    kernel: KernelWorkspace,
    output_ws: Workspace<f64>,
    inputs: Vec<f64>,
    outputs: Vec<f64>,
}

impl Plant {
    /// Discretises `model` with its integrator and compiles the step and output tapes.
    pub fn new(model: Model) -> Plant {
        let layout = model.layout();
        let mut graph = model.graph.clone();
        let DiscreteStep {
            next_state,
            residuals,
        } = discretize(&mut graph, &model);
        let mut repl: Vec<NodeId> = (0..layout.n_all()).map(|i| graph.var(i)).collect();
        for (i, &n) in next_state.iter().enumerate() {
            repl[layout.x_next(i)] = n;
        }
        let stage_term_index: Vec<usize> = model
            .terms
            .iter()
            .enumerate()
            .filter(|(_, t)| t.kind != TermKind::Terminal)
            .map(|(i, _)| i)
            .collect();
        let raw_terms: Vec<NodeId> = stage_term_index
            .iter()
            .map(|&i| model.terms[i].node)
            .collect();
        let stage_terms = graph.substitute(&raw_terms, &repl);
        let output_nodes: Vec<NodeId> = model.outputs.iter().map(|o| o.node).collect();
        let mut x_to_next = repl.clone();
        x_to_next[..layout.nx].copy_from_slice(&next_state);
        let next_outputs = graph.substitute(&output_nodes, &x_to_next);
        let mut all = next_state.clone();
        all.extend(&stage_terms);
        all.extend(&next_outputs);
        let step = match Tableau::of(model.integrator) {
            Some(tableau) => StepKernel::Implicit(Box::new(ImplicitStep::new(
                &graph, &model, tableau, &all, &residuals,
            ))),
            None => StepKernel::Unrolled(graph.compile(&all, layout.n_base())),
        };
        let output = graph.compile(&output_nodes, layout.n_base());
        let terminal_nodes: Vec<NodeId> = model
            .terms
            .iter()
            .filter(|t| t.kind == TermKind::Terminal)
            .map(|t| t.node)
            .collect();
        let terminal =
            (!terminal_nodes.is_empty()).then(|| graph.compile(&terminal_nodes, layout.n_base()));
        Plant {
            model,
            layout,
            graph,
            next_state,
            stage_terms,
            next_outputs,
            stage_term_index,
            step,
            output,
            terminal,
            planning: OnceLock::new(),
        }
    }

    /// The plant the controllers predict with (MPC, RL-guided MPC): the model integrated
    /// with its `plan substeps`, built once; the plant itself where those are its
    /// `substeps`. Simulations, the season optimum and the checks use the plant itself.
    pub fn planning(self: &Arc<Self>) -> Arc<Plant> {
        if !self.model.plans_with_other_substeps() {
            return Arc::clone(self);
        }
        let plant = self.planning.get_or_init(|| {
            Arc::new(Plant::new(Model {
                substeps: self.model.plan_substeps,
                ..self.model.clone()
            }))
        });
        Arc::clone(plant)
    }

    /// The tape of the model's `terminal` terms: inputs `(x, u, d, p)`, one output per
    /// term, its reward for ending a horizon in `x`. `None` when the model has none.
    pub fn terminal_tape(&self) -> Option<&Tape> {
        self.terminal.as_ref()
    }

    /// The tape behind the step. For an explicit integrator, the step itself: inputs
    /// `(x, u, d, p)`, outputs `(x⁺, stage terms, y(x⁺))`. For an implicit one, the step's
    /// outputs and stage residuals `[P; G]` over `(x, u, d, p, x⁺ slots, W)`; evaluate the
    /// step with [`eval_step`](Self::eval_step) and differentiate it with
    /// [`StepDerivatives`].
    pub fn step_tape(&self) -> &Tape {
        match &self.step {
            StepKernel::Unrolled(tape) => tape,
            StepKernel::Implicit(step) => step.combined_tape(),
        }
    }

    /// Whether each step solves stage equations (an implicit integrator).
    pub fn is_implicit(&self) -> bool {
        matches!(self.step, StepKernel::Implicit(_))
    }

    /// Values a step returns: `(x⁺, stage terms, y(x⁺))`.
    pub fn n_step_outputs(&self) -> usize {
        self.layout.nx + self.stage_terms.len() + self.next_outputs.len()
    }

    /// One step from the packed inputs `(x, u, d, p)` into `outputs` `(x⁺, terms, y(x⁺))`,
    /// whatever the integrator; an implicit step whose Newton iteration fails gives NaN.
    pub fn eval_step(&self, ws: &mut StepWorkspace, inputs: &[f64], outputs: &mut [f64]) {
        match (&self.step, &mut ws.kernel) {
            (StepKernel::Unrolled(tape), KernelWorkspace::Unrolled(scratch)) => {
                tape.eval(scratch, inputs, outputs)
            }
            (StepKernel::Implicit(step), KernelWorkspace::Implicit(scratch)) => {
                step.eval(scratch, inputs, outputs)
            }
            // A workspace made by another plant: made anew for this one.
            _ => {
                ws.kernel = self.kernel_workspace();
                self.eval_step(ws, inputs, outputs);
            }
        }
    }

    /// The output tape: inputs `(x, u, d, p)`, outputs `y(x)`.
    pub fn output_tape(&self) -> &Tape {
        &self.output
    }

    /// Fresh buffers for [`step_into`](Self::step_into) and
    /// [`outputs_into`](Self::outputs_into); keep one per thread and reuse it.
    pub fn workspace(&self) -> StepWorkspace {
        StepWorkspace {
            kernel: self.kernel_workspace(),
            output_ws: self.output.workspace(),
            inputs: vec![0.0; self.layout.n_base()],
            outputs: vec![0.0; self.n_step_outputs()],
        }
    }

    /// Buffers like [`workspace`](Self::workspace) for an optimiser: an implicit step is
    /// solved as [`StepDerivatives`] solves it (as tightly, and from no earlier step), so
    /// that its values are those whose derivatives the optimiser takes. A simulation's
    /// workspace stops Newton sooner, far below the integration error but not below what
    /// central differences of the values see.
    pub fn optimisation_workspace(&self) -> StepWorkspace {
        StepWorkspace {
            kernel: self.kernel_workspace_for(Purpose::Derivatives),
            ..self.workspace()
        }
    }

    fn kernel_workspace(&self) -> KernelWorkspace {
        self.kernel_workspace_for(Purpose::Simulation)
    }

    fn kernel_workspace_for(&self, purpose: Purpose) -> KernelWorkspace {
        match &self.step {
            StepKernel::Unrolled(tape) => KernelWorkspace::Unrolled(tape.workspace()),
            StepKernel::Implicit(step) => {
                KernelWorkspace::Implicit(Box::new(step.workspace_for(purpose)))
            }
        }
    }

    fn pack(&self, buf: &mut [f64], x: &[f64], u: &[f64], d: &[f64], p: &[f64]) {
        let l = &self.layout;
        buf[..l.nx].copy_from_slice(x);
        buf[l.u(0)..l.u(0) + l.nu].copy_from_slice(u);
        buf[l.d(0)..l.d(0) + l.nd].copy_from_slice(d);
        buf[l.p(0)..l.p(0) + l.np].copy_from_slice(p);
    }

    /// One step without allocation: fills `out` (resized on first use only).
    ///
    /// ```
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use ghm::model::{Plant, StepOutcome};
    ///
    /// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/cstr.ghm");
    /// let plant = Plant::new(ghm::lang::load(&file).map_err(|e| e.render())?);
    /// let (mut x, p) = (plant.model.initial_state(), plant.model.nominal_params());
    /// let mut ws = plant.workspace();
    /// let mut out = StepOutcome::default();
    /// // The reactor starts at its low steady state for a coolant at 300 K: it stays there.
    /// for _ in 0..10 {
    ///     plant.step_into(&mut ws, &x, &[300.0], &[], &p, &mut out);
    ///     x.clone_from(&out.next_state);
    /// }
    /// let start = plant.model.initial_state();
    /// assert!((x[0] - start[0]).abs() < 1e-5 && (x[1] - start[1]).abs() < 1e-3);
    /// // Ten steps of a warmer coolant heat the reactor.
    /// for _ in 0..10 {
    ///     plant.step_into(&mut ws, &x, &[310.0], &[], &p, &mut out);
    ///     x.clone_from(&out.next_state);
    /// }
    /// assert!(x[1] > start[1] + 1.0);
    /// # Ok(())
    /// # }
    /// ```
    pub fn step_into(
        &self,
        ws: &mut StepWorkspace,
        x: &[f64],
        u: &[f64],
        d: &[f64],
        p: &[f64],
        out: &mut StepOutcome,
    ) {
        self.pack(&mut ws.inputs, x, u, d, p);
        let inputs = std::mem::take(&mut ws.inputs);
        let mut outputs = std::mem::take(&mut ws.outputs);
        self.eval_step(ws, &inputs, &mut outputs);
        ws.inputs = inputs;
        ws.outputs = outputs;
        let nx = self.layout.nx;
        let nt = self.stage_terms.len();
        out.next_state.clear();
        out.next_state.extend_from_slice(&ws.outputs[..nx]);
        out.terms.clear();
        out.terms.extend_from_slice(&ws.outputs[nx..nx + nt]);
        out.next_outputs.clear();
        out.next_outputs.extend_from_slice(&ws.outputs[nx + nt..]);
    }

    /// One step (allocates the result).
    pub fn step(&self, x: &[f64], u: &[f64], d: &[f64], p: &[f64]) -> StepOutcome {
        let mut ws = self.workspace();
        let mut out = StepOutcome {
            next_state: Vec::new(),
            terms: Vec::new(),
            next_outputs: Vec::new(),
        };
        self.step_into(&mut ws, x, u, d, p, &mut out);
        out
    }

    /// Outputs `y = g(x, u, d, p)`.
    pub fn outputs(&self, x: &[f64], u: &[f64], d: &[f64], p: &[f64]) -> Vec<f64> {
        let mut ws = self.workspace();
        let mut y = vec![0.0; self.output.n_outputs()];
        self.outputs_into(&mut ws, x, u, d, p, &mut y);
        y
    }

    /// Outputs `y = g(x, u, d, p)` into `y`, without allocation.
    pub fn outputs_into(
        &self,
        ws: &mut StepWorkspace,
        x: &[f64],
        u: &[f64],
        d: &[f64],
        p: &[f64],
        y: &mut [f64],
    ) {
        self.pack(&mut ws.inputs, x, u, d, p);
        self.output.eval(&mut ws.output_ws, &ws.inputs, y);
    }

    /// Clips `u` to `|u − u_prev| ≤ rate` and to the input bounds, as the season loop does
    /// with every controller's input.
    pub fn apply_limits(&self, previous: &[f64], u: &mut [f64]) {
        for (i, decl) in self.model.inputs.iter().enumerate() {
            let mut v = u[i];
            if let Some(r) = decl.rate {
                v = v.clamp(previous[i] - r, previous[i] + r);
            }
            u[i] = v.clamp(decl.lower, decl.upper);
        }
    }

    /// The reward of one transition: its economic terms minus the soft-band penalties on
    /// the outputs after it (`r(k)` of the RL environment, the step of every season's
    /// cumulative reward).
    pub fn step_reward(&self, out: &StepOutcome) -> f64 {
        let penalty: f64 = self
            .model
            .soft
            .iter()
            .map(|b| band_penalty(b, out.next_outputs[b.output]))
            .sum();
        out.economic() - penalty
    }

    /// Penalties of the soft bands on the outputs `y` (scoring bounds).
    pub fn penalties(&self, y: &[f64]) -> Vec<StagePenalty> {
        self.model
            .soft
            .iter()
            .map(|b| StagePenalty {
                output: b.output,
                value: band_penalty(b, y[b.output]),
                // NaN is outside every band.
                outside: !(y[b.output] >= b.lower && y[b.output] <= b.upper),
            })
            .collect()
    }
}
