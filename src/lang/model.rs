//! The checked model: what a `.ghm` file means once names are resolved, overrides applied
//! and expressions lowered into one [`Graph`].
//!
//! Graph variables follow one fixed layout (see [`Layout`]):
//! `[x (states), u (inputs), d (disturbances), p (parameters), x⁺ (states after the step)]`.

use crate::graph::{Graph, NodeId};
use crate::lang::ast::{ParamKind, TermKind};
use crate::lang::diagnostic::Diagnostic;
use crate::lang::source::{SourceMap, Span};
use std::collections::HashMap;

/// Unit, description and source of a declaration, for people.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Info {
    /// The declared name.
    pub name: String,
    /// The text inside `[...]` after the name (`""` when none was written).
    pub unit: String,
    /// The quoted description (`""` when none was written).
    pub description: String,
    /// The reference of `source "..."` (parameters only; `""` when none was written).
    pub source: String,
    /// Where the name is declared (`None` for a model made with
    /// [`ModelBuilder`](crate::model::ModelBuilder)); [`Model::location`] gives `file:line:col`.
    pub span: Option<Span>,
}

/// A `state`: its name, unit and description, and its initial value.
#[derive(Debug, Clone, PartialEq)]
pub struct StateDecl {
    /// Name, unit and description.
    pub info: Info,
    /// x(0), with parameters at their nominal values.
    pub initial: f64,
}

/// An `input`: bounds, optional rate limit and the value before the first step.
#[derive(Debug, Clone, PartialEq)]
pub struct InputDecl {
    /// Name, unit and description.
    pub info: Info,
    /// Lower bound of `in [LO, HI]`; `-∞` when the input is unbounded.
    pub lower: f64,
    /// Upper bound of `in [LO, HI]`; `+∞` when the input is unbounded.
    pub upper: f64,
    /// Largest change per step, if rate-limited.
    pub rate: Option<f64>,
    /// The input applied before the first step (`start S`, else 0 clipped into the bounds).
    pub start: f64,
    /// `rule EXPR`: the input a rule-based controller applies, a node over `(x, d, p)` of
    /// the model's graph (it reads no input); `None`: the input has no rule.
    pub rule: Option<NodeId>,
}

/// A `disturbance`: read from a weather column or held constant.
#[derive(Debug, Clone, PartialEq)]
pub struct DisturbanceDecl {
    /// Name, unit and description.
    pub info: Info,
    /// Column name in weather files (`None`: the disturbance's own name).
    pub column: Option<String>,
    /// Constant value used when no weather source provides it.
    pub value: Option<f64>,
    /// Whether it is the model's clock (`clock`): the time in seconds, which the
    /// integrator advances within a step.
    pub clock: bool,
}

/// The weather column a `clock` disturbance reads unless it names another: seconds since
/// the clock's origin (ghm's weather files count from 1 January 00:00 of the season's
/// first year); a weather source without it counts its rows times the period.
pub const CLOCK_COLUMN: &str = "time_s";

/// A `param` or `const`: its nominal value and whether uncertainty may perturb it.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamDecl {
    /// Name, unit, description and source.
    pub info: Info,
    /// The nominal value: its expression evaluated with the parameters above it at their
    /// nominal values.
    pub value: f64,
    /// [`ParamKind::Uncertain`] or [`ParamKind::Plain`] in [`Model::params`] (constants are
    /// folded into the graph and not listed there).
    pub kind: ParamKind,
}

/// An `output`: a named expression of the variables, observed by controllers and bounded
/// by soft bands.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputDecl {
    /// Name, unit and description.
    pub info: Info,
    /// y = g(x, u, d, p).
    pub node: NodeId,
}

/// A stage or terminal term of the objective (as reward: costs are stored negated).
#[derive(Debug, Clone, PartialEq)]
pub struct TermDecl {
    /// Name, unit and description.
    pub info: Info,
    /// Whether it was declared as `reward`, `cost` or `terminal`.
    pub kind: TermKind,
    /// The term's contribution to the reward, over `(x, u, d, p, x⁺)` (terminal: over `x, p`).
    pub node: NodeId,
}

/// A soft band on an output, penalised linearly outside `[lower, upper]`, evaluated on the
/// output after the step. The optimiser may plan with the tighter `plan_*` bounds.
#[derive(Debug, Clone, PartialEq)]
pub struct SoftBand {
    /// Index of the banded output in [`Model::outputs`].
    pub output: usize,
    /// Lower limit of the band; `-∞` for `<= hi`.
    pub lower: f64,
    /// Upper limit of the band; `+∞` for `>= lo`.
    pub upper: f64,
    /// Penalty per unit of the output below `lower` (the first weight).
    pub weight_below: f64,
    /// Penalty per unit of the output above `upper` (the second weight, else the first).
    pub weight_above: f64,
    /// Lower limit to plan with: the `plan` band intersected with the band (`lower` when
    /// there is no `plan`).
    pub plan_lower: f64,
    /// Upper limit to plan with: the `plan` band intersected with the band (`upper` when
    /// there is no `plan`).
    pub plan_upper: f64,
    /// The quoted description (`""` when none was written).
    pub description: String,
}

/// How the integrator discretises `ẋ = f` over one sample period (or sub-step).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrator {
    /// Classical fourth-order Runge–Kutta (`integrator rk4`, the default).
    Rk4,
    /// Explicit Euler (`integrator euler`).
    Euler,
    /// Radau IIA with three stages, order 5, L-stable (`integrator radau5`): for stiff models.
    Radau5,
    /// Radau IIA with two stages, order 3, L-stable (`integrator radau3`).
    Radau3,
    /// Backward (implicit) Euler, order 1, L-stable (`integrator backward_euler`).
    BackwardEuler,
    /// Alexander's three-stage singly diagonally implicit Runge–Kutta method, order 3,
    /// L-stable and stiffly accurate (`integrator sdirk3`).
    Sdirk3,
}

impl Integrator {
    /// Every integrator, in the order the documentation lists them.
    pub const ALL: [Integrator; 6] = [
        Integrator::Rk4,
        Integrator::Euler,
        Integrator::Radau5,
        Integrator::Radau3,
        Integrator::BackwardEuler,
        Integrator::Sdirk3,
    ];

    /// The name a model writes after `integrator`.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::Rk4 => "rk4",
            Integrator::Euler => "euler",
            Integrator::Radau5 => "radau5",
            Integrator::Radau3 => "radau3",
            Integrator::BackwardEuler => "backward_euler",
            Integrator::Sdirk3 => "sdirk3",
        }
    }

    /// The integrator a model names, if there is one by that name.
    ///
    /// ```
    /// use ghm::lang::model::Integrator;
    /// assert_eq!(Integrator::from_name("radau5"), Some(Integrator::Radau5));
    /// assert!(Integrator::ALL.iter().all(|i| Integrator::from_name(i.name()) == Some(*i)));
    /// assert_eq!(Integrator::from_name("ode45"), None);
    /// ```
    pub fn from_name(name: &str) -> Option<Integrator> {
        Integrator::ALL.into_iter().find(|i| i.name() == name)
    }

    /// Whether each step solves equations in the stage values (Newton) rather than
    /// evaluating them in turn.
    pub fn is_implicit(self) -> bool {
        !matches!(self, Integrator::Rk4 | Integrator::Euler)
    }
}

/// How every solver is to see the problem (`solver SETTING = VALUE, ...`): hints from the
/// model's author, like IPOPT's user scaling, that change no optimum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolverHints {
    /// The factor the solvers multiply the objective by (`objective_scale`, default 1):
    /// for an objective whose stage terms are far below one in size, such as the GreenLight
    /// tomato's (about 1e-4 € m⁻² per 300 s step), which otherwise weighs next to nothing
    /// against the constraints in the interior point's steps and line search. The
    /// solutions, multipliers and objective the solvers return are in the model's own units.
    pub objective_scale: f64,
    /// How far the interior point pushes a roll-out of inputs (the season optimum's start
    /// from a controller's inputs) inside its bounds, relative to each bound's size
    /// (`rollout_push`; `None`: a shifted plan's push). A stiff plant wants it small: the
    /// pushed inputs move the rolled-out states off its dynamics, and far off.
    pub rollout_push: Option<f64>,
}

impl Default for SolverHints {
    fn default() -> Self {
        SolverHints {
            objective_scale: 1.0,
            rollout_push: None,
        }
    }
}

/// When parametric uncertainty redraws parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Redraw {
    /// Once per season (`redraw = season`, the default).
    Season,
    /// Anew at every step (`redraw = step`).
    Step,
}

/// Parametric uncertainty rule: p̂ ~ U(p(1 − s·δ), p(1 + s·δ)) for the parameters in scope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertainty {
    /// When perturbed parameters are drawn.
    pub redraw: Redraw,
    /// s: the half-width as a multiple of δ (1 for the paper, 0.5 for the thesis code).
    pub spread: f64,
    /// Perturb every `param` (true) or only those marked `uncertain` (false).
    pub all_params: bool,
}

impl Default for Uncertainty {
    fn default() -> Self {
        Uncertainty {
            redraw: Redraw::Season,
            spread: 1.0,
            all_params: false,
        }
    }
}

/// Offsets of each variable group in the graph's variable numbering.
///
/// ```
/// use ghm::lang::model::Layout;
///
/// // Four states, three inputs, four disturbances, two parameters.
/// let l = Layout { nx: 4, nu: 3, nd: 4, np: 2 };
/// assert_eq!((l.x(1), l.u(0), l.d(0), l.p(1), l.x_next(0)), (1, 4, 7, 12, 13));
/// assert_eq!((l.n_base(), l.n_all()), (13, 17));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Number of states.
    pub nx: usize,
    /// Number of inputs.
    pub nu: usize,
    /// Number of disturbances.
    pub nd: usize,
    /// Number of parameters (`param` only; constants are folded into the graph).
    pub np: usize,
}

impl Layout {
    /// Variable number of state `i`.
    pub fn x(&self, i: usize) -> usize {
        i
    }
    /// Variable number of input `i`.
    pub fn u(&self, i: usize) -> usize {
        self.nx + i
    }
    /// Variable number of disturbance `i`.
    pub fn d(&self, i: usize) -> usize {
        self.nx + self.nu + i
    }
    /// Variable number of parameter `i`.
    pub fn p(&self, i: usize) -> usize {
        self.nx + self.nu + self.nd + i
    }
    /// Variable number of `next(x_i)`, the state after the step (after `(x, u, d, p)`).
    pub fn x_next(&self, i: usize) -> usize {
        self.nx + self.nu + self.nd + self.np + i
    }
    /// Variables of `(x, u, d, p)`.
    pub fn n_base(&self) -> usize {
        self.nx + self.nu + self.nd + self.np
    }
    /// All variables, including `x⁺`.
    pub fn n_all(&self) -> usize {
        self.n_base() + self.nx
    }
}

/// A checked `.ghm` model.
///
/// # Examples
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("models/cstr.ghm");
/// let model = ghm::lang::load(&file)?;
/// let l = model.layout();
/// assert_eq!((l.nx, l.nu, l.nd), (2, 1, 0)); // no disturbances: no weather needed
/// assert_eq!(model.initial_state(), [0.8772569, 324.47544]);
/// assert_eq!(model.start_input(), [300.0]); // coolant temperature, K
/// assert!(model.weather_columns().is_empty());
/// assert_eq!(model.output_index("t_reactor"), Some(1));
/// assert_eq!(model.sample_period, 6.0);
/// # Ok(())
/// # }
/// ```
#[derive(Debug, Clone)]
pub struct Model {
    /// The name of the last `model` statement (`model` when there is none).
    pub name: String,
    /// The description of that `model` statement (`""` when none).
    pub description: String,
    /// The main file and its imports, which the spans of `warnings` point into.
    pub sources: SourceMap,
    /// Every equation lowered into one expression graph, over the variables of [`Layout`].
    pub graph: Graph,
    /// The states x, in layout order.
    pub states: Vec<StateDecl>,
    /// The inputs u, in layout order.
    pub inputs: Vec<InputDecl>,
    /// The disturbances d, in layout order.
    pub disturbances: Vec<DisturbanceDecl>,
    /// The parameters p (`param` only, not `const`), in layout order.
    pub params: Vec<ParamDecl>,
    /// ẋᵢ = f_i(x, u, d, p), one per state.
    pub derivatives: Vec<NodeId>,
    /// The outputs y, in declaration order.
    pub outputs: Vec<OutputDecl>,
    /// The control period T, in seconds (`sample` converted from `[min]` or `[h]`).
    pub sample_period: f64,
    /// How one period is integrated.
    pub integrator: Integrator,
    /// Integration steps per period, 1 to 1000 (`substeps N`, default 1).
    pub substeps: usize,
    /// Integration steps per period in the controllers' predictions, 1 to 1000 (`plan
    /// substeps M`, default `substeps`): MPC and RL-guided MPC plan on the model integrated
    /// with them ([`crate::model::Plant::planning`]); simulations, the season optimum and
    /// every check use `substeps`.
    pub plan_substeps: usize,
    /// The objective terms (`reward`, `cost`, `terminal`), in declaration order.
    pub terms: Vec<TermDecl>,
    /// The soft bands, at most one per output, in declaration order.
    pub soft: Vec<SoftBand>,
    /// The parametric uncertainty rule (the last `uncertainty` statement, else the default).
    pub uncertainty: Uncertainty,
    /// The solver hints (the `solver` statements' settings, else the defaults).
    pub solver: SolverHints,
    /// Warnings found while checking (errors stop checking instead).
    pub warnings: Vec<Diagnostic>,
    /// Where each node of `graph` was first written, for messages about an expression
    /// (empty for a model made with [`ModelBuilder`](crate::model::ModelBuilder)).
    pub origins: HashMap<NodeId, Span>,
}

impl Model {
    /// Whether the controllers predict with other sub-steps than the plant is simulated
    /// with (`plan substeps`), so that their model only approximates the plant.
    pub fn plans_with_other_substeps(&self) -> bool {
        self.plan_substeps != self.substeps
    }

    /// The sizes of its variable groups.
    pub fn layout(&self) -> Layout {
        Layout {
            nx: self.states.len(),
            nu: self.inputs.len(),
            nd: self.disturbances.len(),
            np: self.params.len(),
        }
    }

    /// Every parameter's nominal value, in declaration order.
    pub fn nominal_params(&self) -> Vec<f64> {
        self.params.iter().map(|p| p.value).collect()
    }

    /// Every state's initial value, in declaration order.
    pub fn initial_state(&self) -> Vec<f64> {
        self.states.iter().map(|s| s.initial).collect()
    }

    /// Every input's value before the first step, in declaration order.
    pub fn start_input(&self) -> Vec<f64> {
        self.inputs.iter().map(|u| u.start).collect()
    }

    /// The index of the `clock` disturbance, if the model has one.
    pub fn clock(&self) -> Option<usize> {
        self.disturbances.iter().position(|d| d.clock)
    }

    /// The weather column each disturbance is read from (its `column`, else its name).
    pub fn weather_columns(&self) -> Vec<String> {
        self.disturbances
            .iter()
            .map(|d| d.column.clone().unwrap_or_else(|| d.info.name.clone()))
            .collect()
    }

    /// The unit of the objective for reports: the unit of the first term of the objective
    /// (reward, cost or terminal), as written in the model file (`""` when it has none or
    /// says `-`).
    pub fn objective_unit(&self) -> String {
        self.terms
            .first()
            .map(|t| t.info.unit.trim().to_string())
            .filter(|u| u != "-")
            .unwrap_or_default()
    }

    /// `file:line:col` of a declaration, if it was read from a file.
    pub fn location(&self, info: &Info) -> Option<String> {
        info.span.map(|s| self.sources.location(s))
    }

    /// The position of the output named `name`, if there is one.
    pub fn output_index(&self, name: &str) -> Option<usize> {
        self.outputs.iter().position(|o| o.info.name == name)
    }
}
