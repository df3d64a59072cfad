//! The handles [`ModelBuilder`]'s declarations return: a variable or output is an
//! expression ([`State`], [`Input`], [`Disturbance`], [`Param`], [`Output`]), and each
//! handle names what its declaration may say (`input.bounds(0.0, 2000.0).rate(250.0)`), as
//! the `.ghm` statement of the same name does. Objective terms ([`Term`]) and soft bands
//! ([`Band`]) are not expressions.
//!
//! A handle's setters change the declaration in its builder and return the handle, so they
//! chain; called later they still change it. They own no state of their own.

use super::expr::{expression_operators, sealed, Expr, Operand};
use super::{BandSpec, ModelBuilder, Parts};
use crate::graph::NodeId;
use crate::lang::ast::ParamKind;
use std::fmt;
use std::ops::Deref;

/// A declared variable or output: an expression ([`Deref`] to [`Expr`], so `x.exp()` and
/// `x.powi(2)` work on it) with the operators of one, and its position among its kind.
macro_rules! declared {
    ($(#[$doc:meta])* $t:ident) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug)]
        pub struct $t<'b> {
            expr: Expr<'b>,
            index: usize,
        }
        impl<'b> Deref for $t<'b> {
            type Target = Expr<'b>;
            fn deref(&self) -> &Expr<'b> {
                &self.expr
            }
        }
        impl<'b> From<$t<'b>> for Expr<'b> {
            fn from(v: $t<'b>) -> Expr<'b> {
                v.expr
            }
        }
        impl sealed::Sealed for $t<'_> {}
        impl<'b> Operand<'b> for $t<'b> {
            fn node_in(self, builder: &'b ModelBuilder) -> NodeId {
                self.expr.node_in(builder)
            }
        }
        impl<'b> $t<'b> {
            pub(super) fn new(expr: Expr<'b>, index: usize) -> $t<'b> {
                $t { expr, index }
            }
            /// Its position among the declarations of its kind (the layout order).
            pub fn index(self) -> usize {
                self.index
            }
            fn set(self, change: impl FnOnce(&mut Parts, usize)) -> Self {
                self.expr.builder.with(|p| change(p, self.index));
                self
            }
        }
        expression_operators!($t);
    };
}

declared! {
    /// A state `x` (`state` in the language): its value at the start of the step; its
    /// derivative is given with [`ModelBuilder::der`].
    State
}
declared! {
    /// An input `u` the controller sets (`input`): unbounded, without rate limit, starting at
    /// 0 clipped into its bounds until told otherwise.
    Input
}
declared! {
    /// A disturbance `d` (`disturbance`): read from the weather column of its own name
    /// until told otherwise.
    Disturbance
}
declared! {
    /// A parameter `p` (`param`): part of the parameter vector, which uncertainty may
    /// perturb; plain (perturbed only under `params = all`) unless marked
    /// [`uncertain`](Param::uncertain). A number fixed by definition (`const` in the
    /// language) is a plain `f64` in Rust.
    Param
}
declared! {
    /// An output `y` (`output`): a named expression that controllers observe and soft bands
    /// bound; an expression itself.
    Output
}

impl<'b> State<'b> {
    /// Its unit, for people (the text of `[...]` in the language).
    pub fn unit(self, unit: &str) -> Self {
        self.set(|p, i| p.states[i].info.unit = unit.to_string())
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|p, i| p.states[i].info.description = text.to_string())
    }
    /// `next(x)`: the state after the step, for rewards and costs only
    /// ([`BuildError::NextOutsideStageTerm`](super::BuildError::NextOutsideStageTerm)
    /// elsewhere).
    pub fn next(self) -> Expr<'b> {
        self.expr.builder.next_of(self.index)
    }
}

impl Input<'_> {
    /// Its unit, for people.
    pub fn unit(self, unit: &str) -> Self {
        self.set(|p, i| p.inputs[i].info.unit = unit.to_string())
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|p, i| p.inputs[i].info.description = text.to_string())
    }
    /// `in [lower, upper]`: the bounds every controller's input is held to.
    pub fn bounds(self, lower: f64, upper: f64) -> Self {
        self.set(|p, i| {
            p.inputs[i].lower = lower;
            p.inputs[i].upper = upper;
        })
    }
    /// `rate R`: the largest change per step, |u(k) − u(k−1)| ≤ R.
    pub fn rate(self, largest_change: f64) -> Self {
        self.set(|p, i| p.inputs[i].rate = Some(largest_change))
    }
    /// `start S`: the input applied before the first step (it counts for the rate limit of
    /// step 0); inside the bounds.
    pub fn start(self, value: f64) -> Self {
        self.set(|p, i| p.starts[i] = Some(value))
    }
}

impl<'b> Input<'b> {
    /// `rule EXPR`: the input a rule-based controller sets, from the states, disturbances and
    /// parameters (not from inputs:
    /// [`BuildError::RuleReadsInput`](super::BuildError::RuleReadsInput)).
    pub fn rule(self, rule: impl Operand<'b>) -> Self {
        let node = rule.node_in(self.expr.builder);
        self.set(|p, i| p.inputs[i].rule = Some(node))
    }
}

impl Disturbance<'_> {
    /// Its unit, for people.
    pub fn unit(self, unit: &str) -> Self {
        self.set(|p, i| p.disturbances[i].info.unit = unit.to_string())
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|p, i| p.disturbances[i].info.description = text.to_string())
    }
    /// `column "name"`: the weather column it is read from.
    pub fn column(self, name: &str) -> Self {
        self.set(|p, i| p.disturbances[i].column = Some(name.to_string()))
    }
    /// `value V`: the constant used when no weather source provides it.
    pub fn value(self, value: f64) -> Self {
        self.set(|p, i| p.disturbances[i].value = Some(value))
    }
    /// `clock`: it is the model's time in seconds, advanced by the integrator within a step
    /// (at most one per model).
    pub fn clock(self) -> Self {
        self.set(|p, i| p.disturbances[i].clock = true)
    }
}

impl Param<'_> {
    /// Its unit, for people.
    pub fn unit(self, unit: &str) -> Self {
        self.set(|p, i| p.params[i].info.unit = unit.to_string())
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|p, i| p.params[i].info.description = text.to_string())
    }
    /// `source "ref"`: where its value comes from.
    pub fn source(self, reference: &str) -> Self {
        self.set(|p, i| p.params[i].info.source = reference.to_string())
    }
    /// `uncertain`: in the scope of parametric uncertainty whatever the setting.
    pub fn uncertain(self) -> Self {
        self.set(|p, i| p.params[i].kind = ParamKind::Uncertain)
    }
}

impl<'b> Output<'b> {
    /// Its unit, for people.
    pub fn unit(self, unit: &str) -> Self {
        self.set(|p, i| p.outputs[i].info.unit = unit.to_string())
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|p, i| p.outputs[i].info.description = text.to_string())
    }
    /// `soft y in [lower, upper]`: a soft band on the output after the step, scored with
    /// the [`weight`](Band::weight) it must be given.
    pub fn band(self, lower: f64, upper: f64) -> Band<'b> {
        let builder = self.expr.builder;
        let index = builder.with(|p| {
            p.bands.push(BandSpec {
                output: self.index,
                lower,
                upper,
                weights: None,
                plan: None,
                description: String::new(),
            });
            p.bands.len() - 1
        });
        Band { builder, index }
    }
    /// `soft y <= upper`: a band with no lower side.
    pub fn at_most(self, upper: f64) -> Band<'b> {
        self.band(f64::NEG_INFINITY, upper)
    }
    /// `soft y >= lower`: a band with no upper side.
    pub fn at_least(self, lower: f64) -> Band<'b> {
        self.band(lower, f64::INFINITY)
    }
}

/// An objective term (`reward`, `cost` or `terminal`); not an expression: share an
/// expression between terms by keeping it in a Rust variable.
#[derive(Clone, Copy)]
pub struct Term<'b> {
    pub(super) builder: &'b ModelBuilder,
    pub(super) index: usize,
}

impl fmt::Debug for Term<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Term({} of `{}`)", self.index, self.builder.name())
    }
}

impl Term<'_> {
    fn set(self, change: impl FnOnce(&mut Parts, usize)) -> Self {
        self.builder.with(|p| change(p, self.index));
        self
    }
    /// Its unit, for people (the first term's unit is the objective's in reports).
    pub fn unit(self, unit: &str) -> Self {
        self.set(|p, i| p.terms[i].info.unit = unit.to_string())
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|p, i| p.terms[i].info.description = text.to_string())
    }
}

/// A soft band on an output (`soft`), penalised linearly outside `[lower, upper]` after the
/// step. It needs a [`weight`](Band::weight) (or [`weights`](Band::weights));
/// [`ModelBuilder::build`] refuses a band without one.
#[derive(Clone, Copy)]
pub struct Band<'b> {
    builder: &'b ModelBuilder,
    index: usize,
}

impl fmt::Debug for Band<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Band({} of `{}`)", self.index, self.builder.name())
    }
}

impl Band<'_> {
    fn set(self, change: impl FnOnce(&mut BandSpec)) -> Self {
        self.builder.with(|p| change(&mut p.bands[self.index]));
        self
    }
    /// `weight w`: the penalty per unit outside the band, on either side.
    pub fn weight(self, per_unit: f64) -> Self {
        self.weights(per_unit, per_unit)
    }
    /// `weight below, above`: the penalties per unit below and above the band.
    pub fn weights(self, below: f64, above: f64) -> Self {
        self.set(|b| b.weights = Some((below, above)))
    }
    /// `plan in [lower, upper]`: a tighter band a controller may plan with (intersected with
    /// the band; scoring keeps the band). One-sided: `plan(f64::NEG_INFINITY, 78.0)`.
    pub fn plan(self, lower: f64, upper: f64) -> Self {
        self.set(|b| b.plan = Some((lower, upper)))
    }
    /// Its description, for people.
    pub fn describe(self, text: &str) -> Self {
        self.set(|b| b.description = text.to_string())
    }
}
