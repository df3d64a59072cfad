//! Building a model in Rust code instead of a `.ghm` file: declare states, inputs,
//! disturbances and parameters, write the dynamics, outputs and objective as expressions
//! over the same graph the language lowers into, and get the same [`Model`] a file gives.
//!
//! ```
//! use ghm::model::{ModelBuilder, Plant};
//! let mut b = ModelBuilder::new("tank");
//! let level = b.state("level", 1.0);
//! let inflow = b.input("inflow", 0.0, 2.0, Some(0.5), 0.0);
//! let k = b.param("outflow_coefficient", 0.01);
//! let out = b.mul(k, level);
//! let rhs = b.sub(inflow, out);
//! b.der(level, rhs);
//! b.output("level", level);
//! b.sample(60.0, 4);
//! let plant = Plant::new(b.build().expect("complete model"));
//! let next = plant.step(&[1.0], &[0.0], &[], &[0.01]);
//! assert!(next.next_state[0] < 1.0);
//! ```

use crate::graph::{Graph, NodeId, Op};
use crate::lang::ast::{ParamKind, TermKind};
use crate::lang::model::*;
use crate::lang::source::SourceMap;
use thiserror::Error;

/// An expression under construction (a node of the builder's graph).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ex(NodeId);

/// Why [`ModelBuilder::build`] refused the model.
#[derive(Debug, Clone, Error, PartialEq)]
pub enum BuildError {
    /// A state (named) was never given `der`.
    #[error("state `{0}` has no derivative: call `der` for it")]
    MissingDerivative(String),
    /// `sample` was never called, or with a period that is not positive.
    #[error("the sample period must be positive (call `sample`)")]
    NoSamplePeriod,
    /// `der` or `next` was given an expression that is not a state variable; holds the
    /// expression's debug form.
    #[error("`{0}` is not a state")]
    NotAState(String),
    /// Two variables (states, inputs, disturbances, parameters) share the name held.
    #[error("`{0}` is declared twice")]
    Duplicate(String),
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Slot {
    State(usize),
    Input(usize),
    Disturbance(usize),
    Param(usize),
    Next(usize),
}

/// Builds a [`Model`] in code. Expressions are made with the methods below; variables are
/// placeholders until [`ModelBuilder::build`] fixes the layout.
#[derive(Debug, Clone)]
pub struct ModelBuilder {
    name: String,
    graph: Graph,
    slots: Vec<Slot>,
    names: Vec<String>,
    states: Vec<StateDecl>,
    inputs: Vec<InputDecl>,
    disturbances: Vec<DisturbanceDecl>,
    params: Vec<ParamDecl>,
    derivatives: Vec<Option<NodeId>>,
    outputs: Vec<OutputDecl>,
    terms: Vec<TermDecl>,
    soft: Vec<SoftBand>,
    sample_period: f64,
    integrator: Integrator,
    substeps: usize,
    errors: Vec<BuildError>,
}

fn info(name: &str) -> Info {
    Info {
        name: name.to_string(),
        ..Info::default()
    }
}

impl ModelBuilder {
    /// An empty model named `name`, integrated with RK4 in one sub-step until told
    /// otherwise; the sample period must still be set with [`sample`](Self::sample).
    pub fn new(name: &str) -> ModelBuilder {
        ModelBuilder {
            name: name.to_string(),
            graph: Graph::new(),
            slots: Vec::new(),
            names: Vec::new(),
            states: Vec::new(),
            inputs: Vec::new(),
            disturbances: Vec::new(),
            params: Vec::new(),
            derivatives: Vec::new(),
            outputs: Vec::new(),
            terms: Vec::new(),
            soft: Vec::new(),
            sample_period: f64::NAN,
            integrator: Integrator::Rk4,
            substeps: 1,
            errors: Vec::new(),
        }
    }

    fn slot(&mut self, name: &str, slot: Slot) -> Ex {
        if self.names.iter().any(|n| n == name) {
            self.errors.push(BuildError::Duplicate(name.to_string()));
        }
        self.names.push(name.to_string());
        self.slots.push(slot);
        Ex(self.graph.var(self.slots.len() - 1))
    }

    /// A state with its initial value.
    pub fn state(&mut self, name: &str, initial: f64) -> Ex {
        self.states.push(StateDecl {
            info: info(name),
            initial,
        });
        self.derivatives.push(None);
        self.slot(name, Slot::State(self.states.len() - 1))
    }

    /// An input with bounds, an optional rate limit per step and the value before step 0.
    pub fn input(
        &mut self,
        name: &str,
        lower: f64,
        upper: f64,
        rate: Option<f64>,
        start: f64,
    ) -> Ex {
        self.inputs.push(InputDecl {
            info: info(name),
            lower,
            upper,
            rate,
            start,
            rule: None,
        });
        self.slot(name, Slot::Input(self.inputs.len() - 1))
    }

    /// A disturbance read from the weather column `column`, or constant `value`.
    pub fn disturbance(&mut self, name: &str, column: Option<&str>, value: Option<f64>) -> Ex {
        self.disturbances.push(DisturbanceDecl {
            info: info(name),
            column: column.map(str::to_string),
            value,
            clock: false,
        });
        self.slot(name, Slot::Disturbance(self.disturbances.len() - 1))
    }

    /// A parameter (marked uncertain) with its nominal value.
    pub fn param(&mut self, name: &str, value: f64) -> Ex {
        self.params.push(ParamDecl {
            info: info(name),
            value,
            kind: ParamKind::Uncertain,
        });
        self.slot(name, Slot::Param(self.params.len() - 1))
    }

    /// `next(x)`: the state after the step, for stage rewards and costs.
    pub fn next(&mut self, state: Ex) -> Ex {
        match self.state_index(state) {
            Some(i) => {
                let name = format!("next({})", self.states[i].info.name);
                self.slot(&name, Slot::Next(i))
            }
            None => self.constant(f64::NAN),
        }
    }

    fn state_index(&mut self, e: Ex) -> Option<usize> {
        let found = (0..self.slots.len()).find(|&k| self.graph.var(k) == e.0);
        match found.map(|k| self.slots[k]) {
            Some(Slot::State(i)) => Some(i),
            _ => {
                self.errors.push(BuildError::NotAState(format!("{e:?}")));
                None
            }
        }
    }

    /// `ẋ = rhs` for a state.
    pub fn der(&mut self, state: Ex, rhs: Ex) {
        if let Some(i) = self.state_index(state) {
            self.derivatives[i] = Some(rhs.0);
        }
    }

    /// An output; returns its index (for soft bands).
    pub fn output(&mut self, name: &str, e: Ex) -> usize {
        self.outputs.push(OutputDecl {
            info: info(name),
            node: e.0,
        });
        self.outputs.len() - 1
    }

    /// A stage reward (added each step).
    pub fn reward(&mut self, name: &str, e: Ex) {
        self.terms.push(TermDecl {
            info: info(name),
            kind: TermKind::Reward,
            node: e.0,
        });
    }

    /// A stage cost (subtracted each step).
    pub fn cost(&mut self, name: &str, e: Ex) {
        let node = self.graph.neg(e.0);
        self.terms.push(TermDecl {
            info: info(name),
            kind: TermKind::Cost,
            node,
        });
    }

    /// A soft band on output `output`, with penalty weights below and above.
    pub fn soft(
        &mut self,
        output: usize,
        lower: f64,
        upper: f64,
        weight_below: f64,
        weight_above: f64,
    ) {
        self.soft.push(SoftBand {
            output,
            lower,
            upper,
            weight_below,
            weight_above,
            plan_lower: lower,
            plan_upper: upper,
            description: String::new(),
        });
    }

    /// Tighter bounds for the optimiser to plan with on the last soft band added (`plan`
    /// in the language); the band is still scored with its own bounds. Returns `false`
    /// (and changes nothing) when there is no band yet or the planning bounds are not
    /// inside the scoring bounds.
    ///
    /// ```
    /// use ghm::model::{ModelBuilder, Plant};
    ///
    /// let mut b = ModelBuilder::new("room");
    /// assert!(!b.plan(18.0, 22.0)); // no band yet
    /// let t = b.state("temp", 20.0);
    /// let heat = b.input("heat", 0.0, 1.0, None, 0.0);
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
    pub fn plan(&mut self, lower: f64, upper: f64) -> bool {
        let Some(band) = self.soft.last_mut() else {
            return false;
        };
        if !(lower >= band.lower && upper <= band.upper && lower <= upper) {
            return false;
        }
        band.plan_lower = lower;
        band.plan_upper = upper;
        true
    }

    /// Sample period in seconds and RK4 sub-steps.
    pub fn sample(&mut self, period_s: f64, substeps: usize) {
        self.sample_period = period_s;
        self.substeps = substeps.max(1);
    }

    /// Use forward Euler instead of RK4.
    pub fn euler(&mut self) {
        self.integrator = Integrator::Euler;
    }

    /// The number `v`.
    pub fn constant(&mut self, v: f64) -> Ex {
        Ex(self.graph.constant(v))
    }
    /// `a + b`.
    pub fn add(&mut self, a: Ex, b: Ex) -> Ex {
        Ex(self.graph.add(a.0, b.0))
    }
    /// `a − b`.
    pub fn sub(&mut self, a: Ex, b: Ex) -> Ex {
        Ex(self.graph.sub(a.0, b.0))
    }
    /// `a · b`.
    pub fn mul(&mut self, a: Ex, b: Ex) -> Ex {
        Ex(self.graph.mul(a.0, b.0))
    }
    /// `a / b`.
    pub fn div(&mut self, a: Ex, b: Ex) -> Ex {
        Ex(self.graph.div(a.0, b.0))
    }
    /// `−a`.
    pub fn neg(&mut self, a: Ex) -> Ex {
        Ex(self.graph.neg(a.0))
    }
    /// `a` to the power `b` ([`Op::Pow`]).
    pub fn pow(&mut self, a: Ex, b: Ex) -> Ex {
        Ex(self.graph.apply(Op::Pow, &[a.0, b.0]))
    }
    /// Any primitive of the language (`exp`, `min`, `if`, ...), by [`Op`].
    pub fn apply(&mut self, op: Op, args: &[Ex]) -> Ex {
        let nodes: Vec<NodeId> = args.iter().map(|e| e.0).collect();
        Ex(self.graph.apply(op, &nodes))
    }

    /// Fixes the variable layout and returns the model.
    pub fn build(mut self) -> Result<Model, BuildError> {
        // The first mistake, in the order the calls were made.
        if !self.errors.is_empty() {
            return Err(self.errors.swap_remove(0));
        }
        if self.sample_period.is_nan() || self.sample_period <= 0.0 {
            return Err(BuildError::NoSamplePeriod);
        }
        if let Some(i) = self.derivatives.iter().position(Option::is_none) {
            return Err(BuildError::MissingDerivative(
                self.states[i].info.name.clone(),
            ));
        }
        let layout = Layout {
            nx: self.states.len(),
            nu: self.inputs.len(),
            nd: self.disturbances.len(),
            np: self.params.len(),
        };
        let replacement: Vec<NodeId> = self
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
                self.graph.var(index)
            })
            .collect();
        let mut roots: Vec<NodeId> = self.derivatives.iter().flatten().copied().collect();
        roots.extend(self.outputs.iter().map(|o| o.node));
        roots.extend(self.terms.iter().map(|t| t.node));
        let mapped = self.graph.substitute(&roots, &replacement);
        let (ders, rest) = mapped.split_at(layout.nx);
        let (outs, terms) = rest.split_at(self.outputs.len());
        for (o, &n) in self.outputs.iter_mut().zip(outs) {
            o.node = n;
        }
        for (t, &n) in self.terms.iter_mut().zip(terms) {
            t.node = n;
        }
        Ok(Model {
            name: self.name,
            description: String::new(),
            sources: SourceMap::default(),
            graph: self.graph,
            states: self.states,
            inputs: self.inputs,
            disturbances: self.disturbances,
            params: self.params,
            derivatives: ders.to_vec(),
            outputs: self.outputs,
            sample_period: self.sample_period,
            integrator: self.integrator,
            substeps: self.substeps,
            terms: self.terms,
            soft: self.soft,
            uncertainty: Uncertainty::default(),
            warnings: Vec::new(),
            origins: Default::default(),
        })
    }
}
