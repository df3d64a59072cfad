//! Building a model in Rust code instead of a `.ghm` file: declare states, inputs,
//! disturbances and parameters, write the dynamics, outputs and objective as expressions
//! over the same graph the language lowers into, and get the same [`Model`] a file gives.
//!
//! ```
//! use ghm::prelude::*;
//!
//! # fn main() -> Result<(), BuildError> {
//! let b = ModelBuilder::new("room");
//! let temp = b.state("temp", 15.0).unit("°C");
//! let heat = b.input("heat").unit("W").bounds(0.0, 2000.0).rate(250.0).start(0.0);
//! let outside = b.disturbance("outside").unit("°C").value(5.0);
//! let capacity = b.param("capacity", 2.0e5).unit("J °C^-1").uncertain();
//! let conductance = b.param("conductance", 40.0).unit("W °C^-1");
//! let price = 0.3 / 3.6e6; // EUR per J: a constant is a plain number
//! b.der(temp, (heat - conductance * (temp - outside)) / capacity);
//! let y = b.output("temp", temp).unit("°C");
//! y.band(19.0, 23.0).weight(0.01).plan(20.0, 22.0);
//! b.cost("energy", price * heat * 900.0).unit("EUR");
//! b.sample(900.0, 2); // 15 minutes, RK4 in 2 sub-steps
//! let plant = Plant::new(b.build()?);
//! assert!(plant.step(&[15.0], &[1000.0], &[5.0], &[2.0e5, 40.0]).next_state[0] > 15.0);
//! # Ok(())
//! # }
//! ```
//!
//! Design: an [`Expr`] is a node of the builder's graph together with a shared reference
//! to the builder (`&'b ModelBuilder`), whose graph and declarations sit in a `RefCell`.
//! That makes a handle `Copy` (an equation names a variable as often as it likes, with no
//! `.clone()` or `&`), lets the operators add nodes without a `&mut` builder in sight, and
//! ties every handle to its builder's lifetime, so none outlives it — with no global or
//! thread-local arena and no `unsafe`. The price is that [`ModelBuilder`]'s methods take
//! `&self`, and that a builder cannot be handed to another thread while handles exist (it
//! is not `Sync`). Two builders' handles do not mix: combining them, or passing one
//! builder's handle to the other, records [`BuildError::ForeignExpression`] and
//! [`build`](ModelBuilder::build) refuses the model (no panic). A clone of a builder is
//! another builder: handles of the original are foreign to it.
//!
//! What a `.ghm` statement says, a handle's method says: units, descriptions and sources
//! ([`State::unit`], [`Param::source`]), bounds, rate limits, start values and rules of
//! inputs, weather columns, constant values and the clock of disturbances, soft bands with
//! weights and planning bands ([`Output::band`]). Names are ASCII identifiers as in the
//! language; variables (states, inputs, disturbances, parameters) share one namespace,
//! outputs and terms each have their own (an output may be named like the state it shows).
//! Mistakes are collected and the first one is returned by `build`, as a [`BuildError`].

mod declare;
mod expr;

pub use declare::{Band, Disturbance, Input, Output, Param, State, Term};
pub use expr::{if_else, Expr, Operand};

use crate::graph::{Graph, Node, NodeId, Op};
use crate::lang::ast::{ParamKind, TermKind};
use crate::lang::model::*;
use crate::lang::source::SourceMap;
use std::cell::RefCell;
use thiserror::Error;

/// Why [`ModelBuilder::build`] refused the model: the first mistake, in the order the calls
/// were made, then the checks of the whole model.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum BuildError {
    /// A state (named) was never given `der`.
    #[error("state `{0}` has no derivative: call `der` for it")]
    MissingDerivative(String),
    /// `sample` was never called, or with a period that is not a positive number.
    #[error("the sample period must be a positive number of seconds (call `sample`)")]
    NoSamplePeriod,
    /// Two variables (states, inputs, disturbances, parameters), two outputs or two terms
    /// share the name held, or a state has two `der`, or an output two bands.
    #[error("`{0}` is declared twice")]
    Duplicate(String),
    /// A declared name that is not an ASCII identifier.
    #[error(
        "`{0}` is not a name: use ASCII letters, digits and `_`, starting with a letter or `_`"
    )]
    BadName(String),
    /// An expression (or variable) of one builder was used in another.
    #[error("an expression of model `{other}` was used in model `{model}`: build each model from its own builder's variables")]
    ForeignExpression {
        /// The model being built.
        model: String,
        /// The model the expression belongs to.
        other: String,
    },
    /// [`ModelBuilder::apply`] was given the wrong number of arguments for its op.
    #[error("`{op}` takes {expected} argument(s), not {given}")]
    Arity {
        /// The op, as its debug form.
        op: String,
        /// The arguments it takes.
        expected: usize,
        /// The arguments it was given.
        given: usize,
    },
    /// An input's lower bound is above its upper bound, or one is NaN.
    #[error("input `{input}` has bounds [{lower}, {upper}]: write `bounds(lower, upper)` with lower <= upper")]
    InputBounds {
        /// The input.
        input: String,
        /// Its lower bound.
        lower: f64,
        /// Its upper bound.
        upper: f64,
    },
    /// An input's rate limit is negative or NaN.
    #[error("input `{input}` has the rate limit {rate}: give the largest change per step, a number >= 0")]
    InputRate {
        /// The input.
        input: String,
        /// Its rate limit.
        rate: f64,
    },
    /// An input's start value lies outside its bounds.
    #[error("the start value {start} of input `{input}` lies outside its bounds [{lower}, {upper}]: start within them")]
    InputStart {
        /// The input.
        input: String,
        /// Its start value.
        start: f64,
        /// Its lower bound.
        lower: f64,
        /// Its upper bound.
        upper: f64,
    },
    /// An input's rule reads an input.
    #[error(
        "the rule of input `{0}` reads an input: write it from states, disturbances and parameters"
    )]
    RuleReadsInput(String),
    /// A `terminal` term reads an input or a disturbance.
    #[error("`terminal {0}` reads an input or a disturbance: a terminal value is worth the state a horizon ends in; write it from states and parameters")]
    TerminalReadsControl(String),
    /// `next(x)` was used outside a reward or cost: in the place named (`der x`,
    /// `output y`, `terminal v`, `rule of u`).
    #[error("`{0}` uses `next(...)`, which only rewards and costs may: dynamics, outputs and rules use the current state")]
    NextOutsideStageTerm(String),
    /// Two disturbances are marked as the clock.
    #[error(
        "disturbances `{0}` and `{1}` are both clocks: a model has one; derive other times from it"
    )]
    SecondClock(String, String),
    /// A soft band was given no weight.
    #[error("the soft band on output `{0}` has no weight: call `weight` (or `weights`) on it")]
    BandWithoutWeight(String),
    /// A soft band's weight is negative or NaN.
    #[error("the soft band on output `{output}` has the weight {weight}: weights are prices per unit, >= 0")]
    BandWeight {
        /// The banded output.
        output: String,
        /// The weight.
        weight: f64,
    },
    /// A soft band's lower limit is above its upper limit, or one is NaN.
    #[error("the soft band on output `{output}` is [{lower}, {upper}]: give lower <= upper")]
    BandLimits {
        /// The banded output.
        output: String,
        /// Its lower limit.
        lower: f64,
        /// Its upper limit.
        upper: f64,
    },
    /// A planning band is empty inside its soft band.
    #[error("the planning band on output `{0}` is empty inside its soft band: plan with a band inside it")]
    EmptyPlan(String),
}

/// What a graph variable of the builder stands for until [`ModelBuilder::build`] fixes the
/// layout: builder variables are numbered in declaration order.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    State(usize),
    Input(usize),
    Disturbance(usize),
    Param(usize),
    Next(usize),
}

/// A soft band as declared, checked and intersected with its plan at `build`.
#[derive(Debug, Clone)]
struct BandSpec {
    output: usize,
    lower: f64,
    upper: f64,
    weights: Option<(f64, f64)>,
    plan: Option<(f64, f64)>,
    description: String,
}

/// Everything declared so far; behind the builder's `RefCell`.
#[derive(Debug, Clone)]
struct Parts {
    description: String,
    graph: Graph,
    slots: Vec<Slot>,
    /// The variables' names; outputs and terms have namespaces of their own.
    names: Vec<String>,
    output_names: Vec<String>,
    term_names: Vec<String>,
    states: Vec<StateDecl>,
    derivatives: Vec<Option<NodeId>>,
    inputs: Vec<InputDecl>,
    starts: Vec<Option<f64>>,
    disturbances: Vec<DisturbanceDecl>,
    params: Vec<ParamDecl>,
    outputs: Vec<OutputDecl>,
    terms: Vec<TermDecl>,
    bands: Vec<BandSpec>,
    sample_period: f64,
    integrator: Integrator,
    substeps: usize,
    /// `None`: `substeps`.
    plan_substeps: Option<usize>,
    uncertainty: Uncertainty,
    solver: SolverHints,
    errors: Vec<BuildError>,
}

/// Builds a [`Model`] in code. Declarations return handles that are expressions
/// ([`Expr`], [`State`], ...); variables are placeholders until [`build`](Self::build)
/// fixes the layout. Every method takes `&self` (see the module documentation).
#[derive(Debug, Clone)]
pub struct ModelBuilder {
    name: String,
    parts: RefCell<Parts>,
}

fn info(name: &str) -> Info {
    Info {
        name: name.to_string(),
        ..Info::default()
    }
}

/// A name as the language spells one: an ASCII letter or `_`, then letters, digits, `_`.
fn is_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// `lower <= upper`; false where either is NaN.
fn in_order(lower: f64, upper: f64) -> bool {
    lower.partial_cmp(&upper).is_some_and(|o| o.is_le())
}

impl ModelBuilder {
    /// An empty model named `name`, integrated with RK4 in one sub-step until told
    /// otherwise; the sample period must still be set with [`sample`](Self::sample).
    pub fn new(name: &str) -> ModelBuilder {
        ModelBuilder {
            name: name.to_string(),
            parts: RefCell::new(Parts {
                description: String::new(),
                graph: Graph::new(),
                slots: Vec::new(),
                names: Vec::new(),
                output_names: Vec::new(),
                term_names: Vec::new(),
                states: Vec::new(),
                derivatives: Vec::new(),
                inputs: Vec::new(),
                starts: Vec::new(),
                disturbances: Vec::new(),
                params: Vec::new(),
                outputs: Vec::new(),
                terms: Vec::new(),
                bands: Vec::new(),
                sample_period: f64::NAN,
                integrator: Integrator::Rk4,
                substeps: 1,
                plan_substeps: None,
                uncertainty: Uncertainty::default(),
                solver: SolverHints::default(),
                errors: Vec::new(),
            }),
        }
    }

    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Runs `change` on the parts. No caller's code runs inside, so the borrow never
    /// overlaps another.
    fn with<R>(&self, change: impl FnOnce(&mut Parts) -> R) -> R {
        change(&mut self.parts.borrow_mut())
    }

    fn expr(&self, node: NodeId) -> Expr<'_> {
        Expr {
            builder: self,
            node,
        }
    }

    fn error(&self, e: BuildError) {
        self.with(|p| p.errors.push(e));
    }

    /// `e`'s node if `e` is this builder's; else a recorded error and NaN.
    fn adopt(&self, e: Expr<'_>) -> NodeId {
        if std::ptr::eq(e.builder, self) {
            return e.node;
        }
        self.error(BuildError::ForeignExpression {
            model: self.name.clone(),
            other: e.builder.name.clone(),
        });
        self.with(|p| p.graph.constant(f64::NAN))
    }

    fn node_op(&self, op: Op, args: &[NodeId]) -> Expr<'_> {
        let node = self.with(|p| p.graph.apply(op, args));
        self.expr(node)
    }

    /// A new variable named `name` (checked) in `slot`.
    fn variable(&self, name: &str, slot: Slot) -> Expr<'_> {
        self.check_name(name, |p| &p.names);
        let node = self.with(|p| {
            p.names.push(name.to_string());
            p.slots.push(slot);
            p.graph.var(p.slots.len() - 1)
        });
        self.expr(node)
    }

    fn check_name(&self, name: &str, namespace: impl Fn(&Parts) -> &Vec<String>) {
        if !is_name(name) {
            self.error(BuildError::BadName(name.to_string()));
        } else if self.with(|p| namespace(p).iter().any(|n| n == name)) {
            self.error(BuildError::Duplicate(name.to_string()));
        }
    }

    /// `state NAME = initial`: a state with its initial value x(0).
    pub fn state(&self, name: &str, initial: f64) -> State<'_> {
        let index = self.with(|p| {
            p.states.push(StateDecl {
                info: info(name),
                initial,
            });
            p.derivatives.push(None);
            p.states.len() - 1
        });
        State::new(self.variable(name, Slot::State(index)), index)
    }

    /// `input NAME`: an input the controller sets; say its [`bounds`](Input::bounds),
    /// [`rate`](Input::rate) limit and [`start`](Input::start) value on the handle.
    pub fn input(&self, name: &str) -> Input<'_> {
        let index = self.with(|p| {
            p.inputs.push(InputDecl {
                info: info(name),
                lower: f64::NEG_INFINITY,
                upper: f64::INFINITY,
                rate: None,
                start: 0.0,
                rule: None,
            });
            p.starts.push(None);
            p.inputs.len() - 1
        });
        Input::new(self.variable(name, Slot::Input(index)), index)
    }

    /// `disturbance NAME`: weather, read from the column of its own name unless the handle
    /// names another ([`column`](Disturbance::column)) or gives a constant
    /// ([`value`](Disturbance::value)).
    pub fn disturbance(&self, name: &str) -> Disturbance<'_> {
        let index = self.with(|p| {
            p.disturbances.push(DisturbanceDecl {
                info: info(name),
                column: None,
                value: None,
                clock: false,
            });
            p.disturbances.len() - 1
        });
        Disturbance::new(self.variable(name, Slot::Disturbance(index)), index)
    }

    /// `param NAME = value`: a parameter with its nominal value; plain, as in the language,
    /// unless marked [`uncertain`](Param::uncertain).
    pub fn param(&self, name: &str, value: f64) -> Param<'_> {
        let index = self.with(|p| {
            p.params.push(ParamDecl {
                info: info(name),
                value,
                kind: ParamKind::Plain,
            });
            p.params.len() - 1
        });
        Param::new(self.variable(name, Slot::Param(index)), index)
    }

    /// `next(x)`, shared by every use of the same state.
    fn next_of(&self, state: usize) -> Expr<'_> {
        let node = self.with(|p| {
            let slot = match p.slots.iter().position(|&s| s == Slot::Next(state)) {
                Some(k) => k,
                None => {
                    p.slots.push(Slot::Next(state));
                    p.slots.len() - 1
                }
            };
            p.graph.var(slot)
        });
        self.expr(node)
    }

    /// `next(x)`: the state after the step, for rewards and costs. A thin wrapper of
    /// [`State::next`].
    pub fn next<'b>(&'b self, state: State<'b>) -> Expr<'b> {
        if !std::ptr::eq(state.builder, self) {
            return self.expr(self.adopt(*state));
        }
        self.next_of(state.index())
    }

    /// `der x = rhs`: ẋ = rhs, per second.
    pub fn der<'b>(&'b self, state: State<'b>, rhs: impl Operand<'b>) {
        if !std::ptr::eq(state.builder, self) {
            self.adopt(*state);
            return;
        }
        let rhs = rhs.node_in(self);
        let twice = self.with(|p| {
            let slot = &mut p.derivatives[state.index()];
            let twice = slot.is_some();
            *slot = Some(rhs);
            twice.then(|| p.states[state.index()].info.name.clone())
        });
        if let Some(name) = twice {
            self.error(BuildError::Duplicate(format!("der {name}")));
        }
    }

    /// `output NAME = e`: a named expression controllers observe and soft bands bound (see
    /// [`Output::band`]).
    pub fn output<'b>(&'b self, name: &str, e: impl Operand<'b>) -> Output<'b> {
        let node = e.node_in(self);
        self.check_name(name, |p| &p.output_names);
        let index = self.with(|p| {
            p.output_names.push(name.to_string());
            p.outputs.push(OutputDecl {
                info: info(name),
                node,
            });
            p.outputs.len() - 1
        });
        Output::new(self.expr(node), index)
    }

    fn term<'b>(&'b self, name: &str, kind: TermKind, e: impl Operand<'b>) -> Term<'b> {
        let node = e.node_in(self);
        self.check_name(name, |p| &p.term_names);
        let index = self.with(|p| {
            // Stored as reward: a cost negated.
            let node = if kind == TermKind::Cost {
                p.graph.neg(node)
            } else {
                node
            };
            p.term_names.push(name.to_string());
            p.terms.push(TermDecl {
                info: info(name),
                kind,
                node,
            });
            p.terms.len() - 1
        });
        Term {
            builder: self,
            index,
        }
    }

    /// `reward NAME = e`: a stage reward, added each step; over `(x, u, d, p)` and
    /// [`next(x)`](State::next).
    pub fn reward<'b>(&'b self, name: &str, e: impl Operand<'b>) -> Term<'b> {
        self.term(name, TermKind::Reward, e)
    }

    /// `cost NAME = e`: a stage cost, subtracted each step.
    pub fn cost<'b>(&'b self, name: &str, e: impl Operand<'b>) -> Term<'b> {
        self.term(name, TermKind::Cost, e)
    }

    /// `terminal NAME = e`: the value of the state at the end of a horizon or season (not
    /// part of the stage reward; no `next`).
    pub fn terminal<'b>(&'b self, name: &str, e: impl Operand<'b>) -> Term<'b> {
        self.term(name, TermKind::Terminal, e)
    }

    /// A soft band on `output`, with penalty weights below and above. A thin wrapper of
    /// `output.band(lower, upper).weights(weight_below, weight_above)` ([`Output::band`]).
    pub fn soft(
        &self,
        output: Output<'_>,
        lower: f64,
        upper: f64,
        weight_below: f64,
        weight_above: f64,
    ) {
        if !std::ptr::eq(output.builder, self) {
            self.adopt(*output);
            return;
        }
        self.with(|p| {
            p.bands.push(BandSpec {
                output: output.index(),
                lower,
                upper,
                weights: Some((weight_below, weight_above)),
                plan: None,
                description: String::new(),
            })
        });
    }

    /// Tighter bounds for the optimiser to plan with on the last soft band added (`plan`
    /// in the language); the band is still scored with its own bounds. Returns `false`
    /// (and changes nothing) when there is no band yet or the planning bounds are not
    /// inside the scoring bounds. A thin wrapper kept from before [`Band::plan`], which
    /// intersects as the language does instead.
    ///
    /// ```
    /// use ghm::model::{ModelBuilder, Plant};
    ///
    /// let b = ModelBuilder::new("room");
    /// assert!(!b.plan(18.0, 22.0)); // no band yet
    /// let t = b.state("temp", 20.0);
    /// let heat = b.input("heat").bounds(0.0, 1.0);
    /// b.der(t, heat);
    /// let y = b.output("temp", t);
    /// b.soft(y, 16.0, 24.0, 1.0, 2.0); // scored: 1 per °C below 16, 2 per °C above 24
    /// assert!(!b.plan(15.0, 22.0)); // not inside the band
    /// assert!(b.plan(18.0, 22.0)); // planned with a margin
    /// b.sample(600.0, 1);
    /// let plant = Plant::new(b.build().unwrap());
    /// let band = &plant.model.soft[0];
    /// assert_eq!((band.lower, band.plan_lower, band.plan_upper, band.upper), (16.0, 18.0, 22.0, 24.0));
    /// // Penalties are scored on the band, not on the plan.
    /// assert_eq!(plant.penalties(&[23.0])[0].value, 0.0);
    /// assert_eq!(plant.penalties(&[25.0])[0].value, 2.0);
    /// ```
    pub fn plan(&self, lower: f64, upper: f64) -> bool {
        self.with(|p| {
            let Some(band) = p.bands.last_mut() else {
                return false;
            };
            if !(lower >= band.lower && upper <= band.upper && lower <= upper) {
                return false;
            }
            band.plan = Some((lower, upper));
            true
        })
    }

    /// `sample T substeps N`: the control period in seconds, integrated in `substeps`
    /// steps (at least 1).
    pub fn sample(&self, period_s: f64, substeps: usize) {
        self.with(|p| {
            p.sample_period = period_s;
            p.substeps = substeps.max(1);
        });
    }

    /// `plan substeps M` of `sample`: the integration steps per period of the controllers'
    /// predictions (at least 1; `substeps` unless told), e.g. fewer for a stiff plant whose
    /// simulation wants many.
    pub fn plan_substeps(&self, substeps: usize) {
        self.with(|p| p.plan_substeps = Some(substeps.max(1)));
    }

    /// `integrator NAME` of `sample`: how one sub-step is integrated (RK4 unless told).
    pub fn integrator(&self, integrator: Integrator) {
        self.with(|p| p.integrator = integrator);
    }

    /// Use forward Euler instead of RK4. A thin wrapper of
    /// [`integrator(Integrator::Euler)`](Self::integrator).
    pub fn euler(&self) {
        self.integrator(Integrator::Euler);
    }

    /// The model's description (`model NAME "description"`).
    pub fn describe(&self, text: &str) {
        self.with(|p| p.description = text.to_string());
    }

    /// The parametric uncertainty rule (`uncertainty ...`; the default otherwise).
    pub fn uncertainty(&self, rule: Uncertainty) {
        self.with(|p| p.uncertainty = rule);
    }

    /// How the solvers are to see the problem (`solver ...`; the defaults otherwise).
    pub fn solver_hints(&self, hints: SolverHints) {
        self.with(|p| p.solver = hints);
    }

    /// The number `v` as an expression (`b.constant(2.0).pow(x)` for `2^x`); in arithmetic
    /// a plain `f64` does.
    pub fn constant(&self, v: f64) -> Expr<'_> {
        let node = v.node_in(self);
        self.expr(node)
    }
    /// `a + b`. A thin wrapper of the operator.
    pub fn add<'b>(&'b self, a: impl Operand<'b>, b: impl Operand<'b>) -> Expr<'b> {
        self.apply_operands(Op::Add, a, b)
    }
    /// `a − b`. A thin wrapper of the operator.
    pub fn sub<'b>(&'b self, a: impl Operand<'b>, b: impl Operand<'b>) -> Expr<'b> {
        self.apply_operands(Op::Sub, a, b)
    }
    /// `a · b`. A thin wrapper of the operator.
    pub fn mul<'b>(&'b self, a: impl Operand<'b>, b: impl Operand<'b>) -> Expr<'b> {
        self.apply_operands(Op::Mul, a, b)
    }
    /// `a / b`. A thin wrapper of the operator.
    pub fn div<'b>(&'b self, a: impl Operand<'b>, b: impl Operand<'b>) -> Expr<'b> {
        self.apply_operands(Op::Div, a, b)
    }
    /// `−a`. A thin wrapper of the operator.
    pub fn neg<'b>(&'b self, a: impl Operand<'b>) -> Expr<'b> {
        let a = a.node_in(self);
        self.node_op(Op::Neg, &[a])
    }
    /// `a` to the power `b` ([`Op::Pow`]). A thin wrapper of [`Expr::pow`].
    pub fn pow<'b>(&'b self, a: impl Operand<'b>, b: impl Operand<'b>) -> Expr<'b> {
        self.apply_operands(Op::Pow, a, b)
    }

    fn apply_operands<'b>(&'b self, op: Op, a: impl Operand<'b>, b: impl Operand<'b>) -> Expr<'b> {
        let (a, b) = (a.node_in(self), b.node_in(self));
        self.node_op(op, &[a, b])
    }

    /// Any primitive of the language (`exp`, `min`, `if`, ...), by [`Op`], with as many
    /// arguments as it takes ([`BuildError::Arity`] otherwise). The methods of [`Expr`] say
    /// the same by name.
    pub fn apply<'b>(&'b self, op: Op, args: &[Expr<'b>]) -> Expr<'b> {
        if args.len() != op.arity() {
            self.error(BuildError::Arity {
                op: format!("{op:?}"),
                expected: op.arity(),
                given: args.len(),
            });
            return self.constant(f64::NAN);
        }
        let nodes: Vec<NodeId> = args.iter().map(|&e| self.adopt(e)).collect();
        self.node_op(op, &nodes)
    }

    /// Fixes the variable layout and returns the model, or the first mistake.
    pub fn build(self) -> Result<Model, BuildError> {
        let mut p = self.parts.into_inner();
        if !p.errors.is_empty() {
            return Err(p.errors.swap_remove(0));
        }
        if !(p.sample_period.is_finite() && p.sample_period > 0.0) {
            return Err(BuildError::NoSamplePeriod);
        }
        let mut derivatives = Vec::with_capacity(p.states.len());
        for (d, s) in p.derivatives.iter().zip(&p.states) {
            derivatives.push(d.ok_or_else(|| BuildError::MissingDerivative(s.info.name.clone()))?);
        }
        p.check_inputs()?;
        p.check_clock()?;
        let soft = p.check_bands()?;
        p.check_next_and_rules(&derivatives)?;

        let layout = Layout {
            nx: p.states.len(),
            nu: p.inputs.len(),
            nd: p.disturbances.len(),
            np: p.params.len(),
        };
        let replacement: Vec<NodeId> = p
            .slots
            .iter()
            .map(|s| {
                let index = match *s {
                    Slot::State(i) => layout.x(i),
                    Slot::Input(i) => layout.u(i),
                    Slot::Disturbance(i) => layout.d(i),
                    Slot::Param(i) => layout.p(i),
                    Slot::Next(i) => layout.x_next(i),
                };
                p.graph.var(index)
            })
            .collect();
        let rules: Vec<NodeId> = p.inputs.iter().filter_map(|u| u.rule).collect();
        let mut roots = derivatives;
        roots.extend(p.outputs.iter().map(|o| o.node));
        roots.extend(p.terms.iter().map(|t| t.node));
        roots.extend(rules);
        let mapped = p.graph.substitute(&roots, &replacement);
        let (ders, rest) = mapped.split_at(layout.nx);
        let (outs, rest) = rest.split_at(p.outputs.len());
        let (terms, mut rules) = rest.split_at(p.terms.len());
        for (o, &n) in p.outputs.iter_mut().zip(outs) {
            o.node = n;
        }
        for (t, &n) in p.terms.iter_mut().zip(terms) {
            t.node = n;
        }
        for u in p.inputs.iter_mut().filter(|u| u.rule.is_some()) {
            if let Some((&n, tail)) = rules.split_first() {
                u.rule = Some(n);
                rules = tail;
            }
        }
        Ok(Model {
            name: self.name,
            description: p.description,
            sources: SourceMap::default(),
            graph: p.graph,
            states: p.states,
            inputs: p.inputs,
            disturbances: p.disturbances,
            params: p.params,
            derivatives: ders.to_vec(),
            outputs: p.outputs,
            sample_period: p.sample_period,
            integrator: p.integrator,
            substeps: p.substeps,
            plan_substeps: p.plan_substeps.unwrap_or(p.substeps),
            terms: p.terms,
            soft,
            uncertainty: p.uncertainty,
            solver: p.solver,
            warnings: Vec::new(),
            origins: Default::default(),
        })
    }
}

impl Parts {
    /// Bounds, rate limits and start values (the default start: 0 clipped into the bounds).
    fn check_inputs(&mut self) -> Result<(), BuildError> {
        for (u, start) in self.inputs.iter_mut().zip(&self.starts) {
            let input = || u.info.name.clone();
            if !in_order(u.lower, u.upper) {
                return Err(BuildError::InputBounds {
                    input: input(),
                    lower: u.lower,
                    upper: u.upper,
                });
            }
            if let Some(rate) = u.rate.filter(|&r| !in_order(0.0, r)) {
                return Err(BuildError::InputRate {
                    input: input(),
                    rate,
                });
            }
            let value = start.unwrap_or(u.lower.max(0.0).min(u.upper));
            if !(in_order(u.lower, value) && in_order(value, u.upper)) {
                return Err(BuildError::InputStart {
                    input: input(),
                    start: value,
                    lower: u.lower,
                    upper: u.upper,
                });
            }
            u.start = value;
        }
        Ok(())
    }

    fn check_clock(&self) -> Result<(), BuildError> {
        let mut clocks = self.disturbances.iter().filter(|d| d.clock);
        match (clocks.next(), clocks.next()) {
            (Some(a), Some(b)) => Err(BuildError::SecondClock(
                a.info.name.clone(),
                b.info.name.clone(),
            )),
            _ => Ok(()),
        }
    }

    /// The bands as the model holds them: weighted, ordered limits, plans intersected.
    fn check_bands(&self) -> Result<Vec<SoftBand>, BuildError> {
        let mut soft: Vec<SoftBand> = Vec::with_capacity(self.bands.len());
        for b in &self.bands {
            let output = self.outputs[b.output].info.name.clone();
            if soft.iter().any(|s| s.output == b.output) {
                return Err(BuildError::Duplicate(format!("soft {output}")));
            }
            if !in_order(b.lower, b.upper) {
                return Err(BuildError::BandLimits {
                    output,
                    lower: b.lower,
                    upper: b.upper,
                });
            }
            let Some((below, above)) = b.weights else {
                return Err(BuildError::BandWithoutWeight(output));
            };
            if let Some(weight) = [below, above].into_iter().find(|&w| !in_order(0.0, w)) {
                return Err(BuildError::BandWeight { output, weight });
            }
            let (plan_lower, plan_upper) = match b.plan {
                Some((lo, hi)) => (lo.max(b.lower), hi.min(b.upper)),
                None => (b.lower, b.upper),
            };
            if !in_order(plan_lower, plan_upper) {
                return Err(BuildError::EmptyPlan(output));
            }
            soft.push(SoftBand {
                output: b.output,
                lower: b.lower,
                upper: b.upper,
                weight_below: below,
                weight_above: above,
                plan_lower,
                plan_upper,
                description: b.description.clone(),
            });
        }
        Ok(soft)
    }

    /// Whether `root` reads a builder variable whose slot passes `which`.
    fn reads(&self, root: NodeId, which: impl Fn(Slot) -> bool) -> bool {
        self.graph
            .reachable(&[root])
            .into_iter()
            .any(|n| match self.graph.node(n) {
                Node::Var(k) => self.slots.get(k as usize).is_some_and(|&s| which(s)),
                _ => false,
            })
    }

    /// `next` only in rewards and costs; rules read no input.
    fn check_next_and_rules(&self, derivatives: &[NodeId]) -> Result<(), BuildError> {
        let next = |s| matches!(s, Slot::Next(_));
        let mut places: Vec<(String, NodeId)> = Vec::new();
        for (s, &d) in self.states.iter().zip(derivatives) {
            places.push((format!("der {}", s.info.name), d));
        }
        for o in &self.outputs {
            places.push((format!("output {}", o.info.name), o.node));
        }
        for t in self.terms.iter().filter(|t| t.kind == TermKind::Terminal) {
            if self.reads(t.node, |s| {
                matches!(s, Slot::Input(_) | Slot::Disturbance(_))
            }) {
                return Err(BuildError::TerminalReadsControl(t.info.name.clone()));
            }
            places.push((format!("terminal {}", t.info.name), t.node));
        }
        for u in &self.inputs {
            if let Some(rule) = u.rule {
                if self.reads(rule, |s| matches!(s, Slot::Input(_))) {
                    return Err(BuildError::RuleReadsInput(u.info.name.clone()));
                }
                places.push((format!("rule of {}", u.info.name), rule));
            }
        }
        match places.into_iter().find(|&(_, n)| self.reads(n, next)) {
            Some((place, _)) => Err(BuildError::NextOutsideStageTerm(place)),
            None => Ok(()),
        }
    }
}
