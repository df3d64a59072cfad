//! [`Expr`], an expression handle that knows its builder, and the arithmetic on it: the
//! operators `+ − · /` and unary minus with `f64` on either side, and the language's
//! functions as methods (`exp`, `ln`, `powi`, `min`, comparisons, ...).
//!
//! Every operation adds one node to the builder's graph through the handle's shared
//! reference (the builder's graph sits in a `RefCell`); it must not touch the declarations.
//! A handle of one builder combined with another builder's records
//! [`BuildError::ForeignExpression`](super::BuildError::ForeignExpression) in the builder
//! that owns the result and stands for NaN there, so that its `build` refuses the model.

use super::ModelBuilder;
use crate::graph::{NodeId, Op};
use std::fmt;

/// An expression of a model under construction: a node of its [`ModelBuilder`]'s graph,
/// with the builder it belongs to. It is `Copy`, and borrows the builder, so it cannot
/// outlive it.
///
/// Write it as you write the equation: `(heat - conductance * (temp - outside)) / capacity`,
/// `2.0 * x + 1.0`, `(-k * t).exp()`, `x.powi(2)`, `a.min(b)`, `if_else(t.gt(20.0), 1.0, 0.0)`.
/// The declared variables ([`State`](super::State), [`Input`](super::Input), ...) are
/// expressions too.
#[derive(Clone, Copy)]
pub struct Expr<'b> {
    pub(super) builder: &'b ModelBuilder,
    pub(super) node: NodeId,
}

impl fmt::Debug for Expr<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Expr(node {} of `{}`)",
            self.node.index(),
            self.builder.name()
        )
    }
}

pub(super) mod sealed {
    pub trait Sealed {}
}

/// What may stand in an expression: an [`Expr`], a declared variable or output, or an `f64`
/// (which becomes a constant). Implemented by ghm's types only.
pub trait Operand<'b>: Copy + sealed::Sealed {
    /// The node for this operand in `builder`'s graph.
    #[doc(hidden)]
    fn node_in(self, builder: &'b ModelBuilder) -> NodeId;
}

impl sealed::Sealed for f64 {}
impl<'b> Operand<'b> for f64 {
    fn node_in(self, builder: &'b ModelBuilder) -> NodeId {
        builder.with(|p| p.graph.constant(self))
    }
}

impl sealed::Sealed for Expr<'_> {}
impl<'b> Operand<'b> for Expr<'b> {
    fn node_in(self, builder: &'b ModelBuilder) -> NodeId {
        builder.adopt(self)
    }
}

impl<'b> Expr<'b> {
    pub(super) fn unary(self, op: Op) -> Expr<'b> {
        self.builder.node_op(op, &[self.node])
    }

    pub(super) fn binary(self, op: Op, rhs: impl Operand<'b>) -> Expr<'b> {
        let rhs = rhs.node_in(self.builder);
        self.builder.node_op(op, &[self.node, rhs])
    }

    /// `lhs op self` for a number `lhs` (`2.0 * x`).
    pub(super) fn reversed(self, op: Op, lhs: f64) -> Expr<'b> {
        let lhs = lhs.node_in(self.builder);
        self.builder.node_op(op, &[lhs, self.node])
    }

    /// `eˣ`.
    pub fn exp(self) -> Expr<'b> {
        self.unary(Op::Exp)
    }
    /// Natural logarithm (`log`/`ln` in the language).
    pub fn ln(self) -> Expr<'b> {
        self.unary(Op::Log)
    }
    /// `√x`.
    pub fn sqrt(self) -> Expr<'b> {
        self.unary(Op::Sqrt)
    }
    /// `|x|` (derivative 1 at 0).
    pub fn abs(self) -> Expr<'b> {
        self.unary(Op::Abs)
    }
    /// Hyperbolic tangent.
    pub fn tanh(self) -> Expr<'b> {
        self.unary(Op::Tanh)
    }
    /// Sine, in radians.
    pub fn sin(self) -> Expr<'b> {
        self.unary(Op::Sin)
    }
    /// Cosine, in radians.
    pub fn cos(self) -> Expr<'b> {
        self.unary(Op::Cos)
    }
    /// The largest whole number not above `x` (derivative 0).
    pub fn floor(self) -> Expr<'b> {
        self.unary(Op::Floor)
    }
    /// `xⁿ`, exact for a negative `x` (`x^2` in the language).
    pub fn powi(self, n: i32) -> Expr<'b> {
        self.powf(f64::from(n))
    }
    /// `xᵉ` for a constant exponent (`x^0.5` in the language): whole exponents are exact
    /// powers, `0.5` is `sqrt`.
    pub fn powf(self, exponent: f64) -> Expr<'b> {
        let node = self.builder.with(|p| p.graph.power(self.node, exponent));
        self.builder.expr(node)
    }
    /// `xʸ` for any exponent (`x^y`, `pow(x, y)` in the language): `exp(y ln x)` unless `y`
    /// is a number, which needs `x > 0`. For a constant base write
    /// `b.constant(2.0).pow(y)`.
    pub fn pow(self, exponent: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Pow, exponent)
    }
    /// The smaller of the two, with that one's derivatives.
    pub fn min(self, other: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Min, other)
    }
    /// The larger of the two, with that one's derivatives.
    pub fn max(self, other: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Max, other)
    }
    /// `mod(x, m) = x − m·floor(x / m)`: the remainder with the sign of `m`, as Python's `%`
    /// (not Rust's `%`).
    pub fn modulo(self, m: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Mod, m)
    }
    /// 1 where `x < y`, else 0 (derivative 0).
    pub fn lt(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Lt, y)
    }
    /// 1 where `x <= y`, else 0.
    pub fn le(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Le, y)
    }
    /// 1 where `x > y`, else 0.
    pub fn gt(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Gt, y)
    }
    /// 1 where `x >= y`, else 0.
    pub fn ge(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Ge, y)
    }
    /// 1 where `x == y`, else 0 (an expression, not a `bool`: `Expr` has no `PartialEq`).
    pub fn eq(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Eq, y)
    }
    /// 1 where `x != y`, else 0.
    pub fn ne(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Ne, y)
    }
    /// `x and y`: 1 where both are true (above 0.5), else 0; also `x & y`.
    pub fn and(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::And, y)
    }
    /// `x or y`: 1 where either is true (above 0.5), else 0; also `x | y`.
    pub fn or(self, y: impl Operand<'b>) -> Expr<'b> {
        self.binary(Op::Or, y)
    }
    /// `if(x, then, otherwise)`: `then` where `x > 0.5`, else `otherwise`; the branch not
    /// taken is not differentiated. [`if_else`] says the same as a function.
    pub fn select(self, then: impl Operand<'b>, otherwise: impl Operand<'b>) -> Expr<'b> {
        let then = then.node_in(self.builder);
        let otherwise = otherwise.node_in(self.builder);
        self.builder
            .node_op(Op::Select, &[self.node, then, otherwise])
    }
}

/// `if(condition, then, otherwise)` of the language: `then` where `condition > 0.5`, else
/// `otherwise` (see [`Expr::select`]).
///
/// ```
/// use ghm::prelude::*;
///
/// let b = ModelBuilder::new("thermostat");
/// let temp = b.state("temp", 15.0);
/// let heat = if_else(temp.lt(18.0), 100.0, 0.0);
/// b.der(temp, heat / 1e4);
/// b.sample(60.0, 1);
/// let plant = Plant::new(b.build()?);
/// assert!(plant.step(&[15.0], &[], &[], &[]).next_state[0] > 15.0);
/// assert_eq!(plant.step(&[19.0], &[], &[], &[]).next_state[0], 19.0);
/// # Ok::<(), ghm::model::BuildError>(())
/// ```
pub fn if_else<'b>(
    condition: impl Into<Expr<'b>>,
    then: impl Operand<'b>,
    otherwise: impl Operand<'b>,
) -> Expr<'b> {
    condition.into().select(then, otherwise)
}

/// The operators for an expression type `$t<'b>`: `$t op R` for any operand `R`, `f64 op
/// $t`, and `−$t`; each an [`Expr`].
macro_rules! expression_operators {
    ($($t:ident),* $(,)?) => {$(
        expression_operators!(@binary $t, Add, add, Add);
        expression_operators!(@binary $t, Sub, sub, Sub);
        expression_operators!(@binary $t, Mul, mul, Mul);
        expression_operators!(@binary $t, Div, div, Div);
        expression_operators!(@binary $t, BitAnd, bitand, And);
        expression_operators!(@binary $t, BitOr, bitor, Or);
        impl<'b> std::ops::Neg for $t<'b> {
            type Output = Expr<'b>;
            fn neg(self) -> Expr<'b> {
                Expr::from(self).unary(crate::graph::Op::Neg)
            }
        }
        impl<'b> std::ops::Not for $t<'b> {
            type Output = Expr<'b>;
            fn not(self) -> Expr<'b> {
                Expr::from(self).unary(crate::graph::Op::Not)
            }
        }
    )*};
    (@binary $t:ident, $trait:ident, $method:ident, $op:ident) => {
        impl<'b, R: Operand<'b>> std::ops::$trait<R> for $t<'b> {
            type Output = Expr<'b>;
            fn $method(self, rhs: R) -> Expr<'b> {
                Expr::from(self).binary(crate::graph::Op::$op, rhs)
            }
        }
        impl<'b> std::ops::$trait<$t<'b>> for f64 {
            type Output = Expr<'b>;
            fn $method(self, rhs: $t<'b>) -> Expr<'b> {
                Expr::from(rhs).reversed(crate::graph::Op::$op, self)
            }
        }
    };
}
pub(super) use expression_operators;

expression_operators!(Expr);

macro_rules! assign_operators {
    ($($trait:ident, $method:ident, $op:ident);*) => {$(
        impl<'b, R: Operand<'b>> std::ops::$trait<R> for Expr<'b> {
            fn $method(&mut self, rhs: R) {
                *self = self.binary(Op::$op, rhs);
            }
        }
    )*};
}
assign_operators!(AddAssign, add_assign, Add; SubAssign, sub_assign, Sub;
    MulAssign, mul_assign, Mul; DivAssign, div_assign, Div);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ModelBuilder;

    /// The value of `e` with the builder's variables (in declaration order) at `vars`.
    fn value(e: Expr<'_>, vars: &[f64]) -> f64 {
        e.builder.with(|p| p.graph.eval_f64(&[e.node], vars))[0]
    }

    /// Each operator is the explicit call it replaces: the same node, hence the same value.
    #[test]
    fn operators_are_the_explicit_calls() {
        let b = ModelBuilder::new("ops");
        let x = b.state("x", 0.0);
        let y = b.input("y");
        let (x, y) = (Expr::from(x), Expr::from(y));
        let same = |a: Expr<'_>, e: Expr<'_>| assert_eq!(a.node, e.node, "{a:?} vs {e:?}");
        same(x + y, b.add(x, y));
        same(x - y, b.sub(x, y));
        same(x * y, b.mul(x, y));
        same(x / y, b.div(x, y));
        same(-x, b.neg(x));
        same(x.pow(y), b.pow(x, y));
        for (op, e) in [
            (Op::Exp, x.exp()),
            (Op::Log, x.ln()),
            (Op::Sqrt, x.sqrt()),
            (Op::Abs, x.abs()),
            (Op::Tanh, x.tanh()),
            (Op::Sin, x.sin()),
            (Op::Cos, x.cos()),
            (Op::Floor, x.floor()),
            (Op::Not, !x),
        ] {
            same(e, b.apply(op, &[x]));
        }
        for (op, e) in [
            (Op::Min, x.min(y)),
            (Op::Max, x.max(y)),
            (Op::Mod, x.modulo(y)),
            (Op::Lt, x.lt(y)),
            (Op::Le, x.le(y)),
            (Op::Gt, x.gt(y)),
            (Op::Ge, x.ge(y)),
            (Op::Eq, x.eq(y)),
            (Op::Ne, x.ne(y)),
            (Op::And, x.and(y)),
            (Op::Or, x.or(y)),
            (Op::And, x & y),
            (Op::Or, x | y),
        ] {
            same(e, b.apply(op, &[x, y]));
        }
        same(
            x.select(y, 2.0),
            b.apply(Op::Select, &[x, y, b.constant(2.0)]),
        );
        same(
            if_else(x, y, 2.0),
            b.apply(Op::Select, &[x, y, b.constant(2.0)]),
        );
        // Constant exponents are the language's `x^n`: an exact power, `sqrt` for 0.5.
        same(x.powi(2), b.pow(x, 2.0));
        same(x.powf(0.5), x.sqrt());
        same(x.powf(1.7), b.pow(x, 1.7));
        let mut acc = x;
        acc += y;
        acc *= 3.0;
        acc -= 1.0;
        acc /= y;
        same(acc, ((x + y) * 3.0 - 1.0) / y);
    }

    /// A number on either side is a constant node, as `b.constant` makes it.
    #[test]
    fn numbers_mix_on_either_side() {
        let b = ModelBuilder::new("literals");
        let x = b.state("x", 0.0);
        let p = b.param("p", 2.0);
        let c = |v: f64| b.constant(v);
        let same = |a: Expr<'_>, e: Expr<'_>| assert_eq!(a.node, e.node, "{a:?} vs {e:?}");
        same(x + 1.0, b.add(x, c(1.0)));
        same(1.0 + x, b.add(c(1.0), x));
        same(x - 1.0, b.sub(x, c(1.0)));
        same(1.0 - x, b.sub(c(1.0), x));
        same(2.0 * x, b.mul(c(2.0), x));
        same(x * 2.0, b.mul(x, c(2.0)));
        same(x / 2.0, b.div(x, c(2.0)));
        same(2.0 / x, b.div(c(2.0), x));
        same(2.0 * p, b.mul(c(2.0), p));
        same(1.0 & x, b.apply(Op::And, &[c(1.0), x.into()]));
        same(x.min(1.0), b.apply(Op::Min, &[x.into(), c(1.0)]));
        // The values, against the same arithmetic on floats (variables: x, p).
        let (xv, pv) = (0.7, 2.0);
        let vars = [xv, pv];
        for (e, want) in [
            ((x + 1.0) * (2.0 - p) / 4.0, (xv + 1.0) * (2.0 - pv) / 4.0),
            (-(x * p) + 3.0, -(xv * pv) + 3.0),
            ((2.0 * x).exp().ln(), 2.0 * xv),
            (x.powi(3) - x * x * x, 0.0),
            (b.constant(2.0).pow(x), 2f64.powf(xv)),
            (x.max(p) + x.min(p), xv + pv),
            (if_else(x.lt(p), 10.0, 20.0), 10.0),
            (x.modulo(0.5), 0.2),
            (!x.gt(1.0) & p.ge(2.0), 1.0),
        ] {
            assert!(
                (value(e, &vars) - want).abs() < 1e-15,
                "{e:?}: {}",
                value(e, &vars)
            );
        }
    }

    /// Two builders' expressions do not mix: the result stands for NaN in the builder of the
    /// left operand, and that builder's `build` says why.
    #[test]
    fn expressions_of_two_builders_do_not_mix() {
        let a = ModelBuilder::new("a");
        let b = ModelBuilder::new("b");
        let x = a.state("x", 1.0);
        let y = b.state("y", 1.0);
        let mixed = x + y;
        assert!(value(mixed, &[1.0, 1.0]).is_nan());
        a.der(x, mixed);
        b.der(y, 0.0);
        a.sample(1.0, 1);
        b.sample(1.0, 1);
        assert!(b.build().is_ok(), "the other builder is untouched");
        assert_eq!(
            a.build().unwrap_err(),
            crate::model::BuildError::ForeignExpression {
                model: "a".into(),
                other: "b".into()
            }
        );
    }
}
