//! The one table of primitive operations.
//!
//! Each [`Op`] defines its value once, generically over any dual number type; every
//! derivative (forward Jacobians, reverse adjoints, Hessians) comes from evaluating that
//! same definition on dual numbers. A few partials are spelled out for speed in the reverse
//! sweep (reusing the op's value where possible), and a test checks them against the duals.

use num_dual::{Dual, DualNum};

/// The scalar type the tape evaluates over: `f64` or any `num_dual` number over `f64`.
pub trait Real: DualNum<Primitive = f64> + Copy {}
impl<T: DualNum<Primitive = f64> + Copy> Real for T {}

/// A primitive operation of the expression graph.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Op {
    /// `-a`.
    Neg,
    /// `e^a` (`exp`).
    Exp,
    /// Natural logarithm `ln a` (`log`, `ln`); not a number for `a < 0`.
    Log,
    /// `√a` (`sqrt`).
    Sqrt,
    /// `|a|` (`abs`); its derivative at 0 is taken as 1.
    Abs,
    /// Hyperbolic tangent of `a` (`tanh`).
    Tanh,
    /// Sine of `a`, in radians (`sin`).
    Sin,
    /// Cosine of `a`, in radians (`cos`).
    Cos,
    /// `a + b`.
    Add,
    /// `a − b`.
    Sub,
    /// `a · b`.
    Mul,
    /// `a / b`.
    Div,
    /// `a^b` for a general exponent `b`, as `exp(b ln a)`.
    Pow,
    /// `a^n` for a constant integer `n`.
    Powi(i32),
    /// `a^e` for a constant real `e` (stored as its bit pattern so ops stay hashable).
    Powf(u64),
    /// The smaller of `a` and `b` (`a` on a tie), with the derivatives of that argument.
    Min,
    /// The larger of `a` and `b` (`a` on a tie), with the derivatives of that argument.
    Max,
    /// 1 where `a < b`, else 0; derivative 0.
    Lt,
    /// 1 where `a <= b`, else 0; derivative 0.
    Le,
    /// 1 where `a > b`, else 0; derivative 0.
    Gt,
    /// 1 where `a >= b`, else 0; derivative 0.
    Ge,
    /// `if(c, a, b)`: `a` where `c > 0.5`, else `b`.
    Select,
    /// 1 where `a == b`, else 0; derivative 0.
    Eq,
    /// 1 where `a != b`, else 0; derivative 0.
    Ne,
    /// `a and b`: 1 where both are true (above 0.5, as `if` reads a condition), else 0.
    And,
    /// `a or b`: 1 where either is true (above 0.5), else 0.
    Or,
    /// `not a`: 1 where `a` is false (at most 0.5), else 0.
    Not,
    /// The largest integer not above `a` (`floor`); derivative 0.
    Floor,
    /// `mod(a, b) = a − b·floor(a / b)`: the remainder with the sign of `b`, as Python's `%`
    /// and numexpr's `mod` (`mod(time_of_day + 6, 24)`); its partials are 1 and
    /// `−floor(a / b)`.
    Mod,
}

impl Op {
    /// How many arguments it takes (1 to 3).
    pub fn arity(self) -> usize {
        use Op::*;
        match self {
            Neg | Exp | Log | Sqrt | Abs | Tanh | Sin | Cos | Powi(_) | Powf(_) | Not | Floor => 1,
            Select => 3,
            _ => 2,
        }
    }

    /// The op a function name of the language calls (`exp`, `log` or `ln`, `if`, ...);
    /// `None` for any other name.
    pub fn from_function(name: &str) -> Option<Op> {
        Some(match name {
            "exp" => Op::Exp,
            "log" | "ln" => Op::Log,
            "sqrt" => Op::Sqrt,
            "abs" => Op::Abs,
            "tanh" => Op::Tanh,
            "sin" => Op::Sin,
            "cos" => Op::Cos,
            "min" => Op::Min,
            "max" => Op::Max,
            "pow" => Op::Pow,
            "if" => Op::Select,
            "floor" => Op::Floor,
            "mod" => Op::Mod,
            _ => return None,
        })
    }

    /// Names of the functions the language offers (for messages).
    pub const FUNCTIONS: &'static [&'static str] = &[
        "exp", "log", "sqrt", "abs", "tanh", "sin", "cos", "min", "max", "pow", "if", "floor",
        "mod",
    ];

    /// Whether its two arguments may be swapped (`+`, `·`, `min`, `max`); the graph orders
    /// them so that both orders share a node.
    pub fn is_commutative(self) -> bool {
        matches!(
            self,
            Op::Add | Op::Mul | Op::Min | Op::Max | Op::Eq | Op::Ne | Op::And | Op::Or
        )
    }

    /// True for ops whose value is an affine function of their arguments (no Hessian
    /// contribution), used by the sparsity analysis.
    pub fn is_linear(self) -> bool {
        matches!(self, Op::Neg | Op::Add | Op::Sub)
    }

    /// True for ops whose derivative is zero almost everywhere.
    pub fn is_piecewise_constant(self) -> bool {
        use Op::*;
        matches!(self, Lt | Le | Gt | Ge | Eq | Ne | And | Or | Not | Floor)
    }

    /// The value of the op. `b` and `c` are ignored by ops of lower arity.
    // Always: inlined into every interpreter's loop, those of `super::wide` compiled for
    // wider vector units included.
    #[inline(always)]
    pub fn apply<T: DualNum<Primitive = f64>>(self, a: T, b: T, c: T) -> T {
        use Op::*;
        let truth = |t: bool| if t { T::one() } else { T::zero() };
        match self {
            Neg => -a,
            Exp => a.exp(),
            Log => a.ln(),
            Sqrt => a.sqrt(),
            Abs => {
                if a.re() < 0.0 {
                    -a
                } else {
                    a
                }
            }
            Tanh => a.tanh(),
            Sin => a.sin(),
            Cos => a.cos(),
            Add => a + b,
            Sub => a - b,
            Mul => a * b,
            Div => a / b,
            Pow => (b * a.ln()).exp(),
            Powi(n) => a.powi(n),
            Powf(bits) => a.powf(f64::from_bits(bits)),
            Min => {
                if b.re() < a.re() {
                    b
                } else {
                    a
                }
            }
            Max => {
                if b.re() > a.re() {
                    b
                } else {
                    a
                }
            }
            Lt => truth(a.re() < b.re()),
            Le => truth(a.re() <= b.re()),
            Gt => truth(a.re() > b.re()),
            Ge => truth(a.re() >= b.re()),
            Select => {
                if a.re() > 0.5 {
                    b
                } else {
                    c
                }
            }
            Eq => truth(a.re() == b.re()),
            Ne => truth(a.re() != b.re()),
            And => truth(a.re() > 0.5 && b.re() > 0.5),
            Or => truth(a.re() > 0.5 || b.re() > 0.5),
            Not => truth(a.re() <= 0.5),
            Floor => T::from(a.re().floor()),
            Mod => {
                let quotient = (a.re() / b.re()).floor();
                a - b * T::from(quotient)
            }
        }
    }

    /// The argument the op passes on whole at `(a, b, c)`, for the ops that choose one
    /// (`if`, `min`, `max`): the same comparison as [`Op::apply`]. `None` for the others.
    /// The reverse sweep gives an adjoint to that argument only, so the argument not taken
    /// never meets its partials (which need not be defined there).
    ///
    /// ```
    /// use ghm::graph::Op;
    ///
    /// assert_eq!(Op::Select.passed_on(1.0, 5.0, f64::NAN), Some(1));
    /// assert_eq!(Op::Select.passed_on(0.0, 5.0, 7.0), Some(2));
    /// assert_eq!(Op::Max.passed_on(0.0, f64::NAN, 0.0), Some(0)); // max(0, NaN) = 0
    /// assert_eq!(Op::Min.passed_on(3.0, 2.0, 0.0), Some(1));
    /// assert_eq!(Op::Add.passed_on(1.0, 2.0, 0.0), None);
    /// ```
    #[inline]
    pub fn passed_on(self, a: f64, b: f64, _c: f64) -> Option<usize> {
        match self {
            Op::Select => Some(if a > 0.5 { 1 } else { 2 }),
            Op::Min => Some(if b < a { 1 } else { 0 }),
            Op::Max => Some(if b > a { 1 } else { 0 }),
            _ => None,
        }
    }

    /// The value on plain floats.
    // Always: inlined into `apply_points`' general arm, so that the tape interpreter
    // (`Tape::eval_points`) never calls out of line per point (docs/benchmarks.md).
    #[inline(always)]
    pub fn apply_f64(self, a: f64, b: f64, c: f64) -> f64 {
        self.apply(a, b, c)
    }

    /// The values at `N` points at once, point by point as [`Op::apply_f64`]: one dispatch
    /// for the `N` of them, and the four arithmetic ops (most of a model's instructions) in
    /// one loop over the points.
    #[inline]
    pub fn apply_points<const N: usize>(self, a: [f64; N], b: [f64; N], c: [f64; N]) -> [f64; N] {
        match self {
            Op::Add => std::array::from_fn(|l| a[l] + b[l]),
            Op::Sub => std::array::from_fn(|l| a[l] - b[l]),
            Op::Mul => std::array::from_fn(|l| a[l] * b[l]),
            Op::Div => std::array::from_fn(|l| a[l] / b[l]),
            // The transcendental ops most common in models, without a call and a second
            // dispatch per point (a tenth of GreenLight's `f`); the same functions as
            // `apply` on `f64`.
            Op::Exp => a.map(f64::exp),
            Op::Powi(n) => a.map(|x| x.powi(n)),
            Op::Powf(bits) => {
                let exponent = f64::from_bits(bits);
                a.map(|x| x.powf(exponent))
            }
            // A loop, not `array::from_fn`: its closure was left out of line in some builds
            // (the Python wheel), a call per point (docs/benchmarks.md).
            _ => {
                let mut out = [0.0; N];
                for (l, out) in out.iter_mut().enumerate() {
                    *out = self.apply_f64(a[l], b[l], c[l]);
                }
                out
            }
        }
    }

    /// Partial derivatives of the op with respect to each argument, at `(a, b, c)` whose
    /// value is `out`. The common smooth ops reuse `out` (e.g. `d exp(a)/da = out`); all
    /// others come from evaluating [`Op::apply`] on `Dual<T>`, so there is one definition
    /// of every function. A test checks the fast paths against the dual-number partials.
    // Always: as `apply`.
    #[inline(always)]
    pub fn partials<T: Real>(self, a: T, b: T, c: T, out: T) -> [T; 3] {
        let zero = T::zero();
        let one = T::one();
        match self {
            Op::Neg => [-one, zero, zero],
            Op::Add => [one, one, zero],
            Op::Sub => [one, -one, zero],
            Op::Mul => [b, a, zero],
            Op::Div => {
                let r = b.recip();
                [r, -(out * r), zero]
            }
            Op::Exp => [out, zero, zero],
            Op::Log => [a.recip(), zero, zero],
            Op::Tanh => [one - out * out, zero, zero],
            Op::Powi(2) => [a + a, zero, zero],
            // The rest of a stiff model's smooth ops (GreenLight's powers, roots and
            // smoothed switches): through nested duals they cost an eighth of an MPC step
            // in copies, measured (docs/benchmarks.md, "Planning with one sub-step").
            Op::Sqrt => [(out + out).recip(), zero, zero],
            Op::Abs => [if a.re() < 0.0 { -one } else { one }, zero, zero],
            Op::Sin => [a.cos(), zero, zero],
            Op::Cos => [-a.sin(), zero, zero],
            Op::Powi(0) => [zero, zero, zero],
            Op::Powi(n) => [a.powi(n - 1) * T::from(f64::from(n)), zero, zero],
            Op::Powf(bits) => {
                let exponent = f64::from_bits(bits);
                [a.powf(exponent - 1.0) * T::from(exponent), zero, zero]
            }
            Op::Pow => [b * out / a, out * a.ln(), zero],
            Op::Mod => [one, T::from(-(a.re() / b.re()).floor()), zero],
            _ => self.partials_from_duals(a, b, c),
        }
    }

    /// Partials obtained by seeding one argument at a time with a nested dual number.
    pub fn partials_from_duals<T: Real>(self, a: T, b: T, c: T) -> [T; 3] {
        let mut out = [T::zero(); 3];
        let args = [a, b, c];
        for (i, slot) in out.iter_mut().enumerate().take(self.arity()) {
            let seeded: [Dual<T>; 3] = std::array::from_fn(|j| {
                if i == j {
                    Dual::new(args[j], T::one())
                } else {
                    Dual::from_re(args[j])
                }
            });
            *slot = self.apply(seeded[0], seeded[1], seeded[2]).eps;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use num_dual::Dual64;

    const ALL: &[Op] = &[
        Op::Neg,
        Op::Exp,
        Op::Log,
        Op::Sqrt,
        Op::Abs,
        Op::Tanh,
        Op::Sin,
        Op::Cos,
        Op::Add,
        Op::Sub,
        Op::Mul,
        Op::Div,
        Op::Pow,
        Op::Powi(2),
        Op::Powi(3),
        Op::Powi(-2),
        Op::Powf(0.5f64.to_bits()),
        Op::Powi(0),
        Op::Powi(1),
        Op::Powf(0.33f64.to_bits()),
        Op::Powf(2.5f64.to_bits()),
        Op::Min,
        Op::Max,
        Op::Lt,
        Op::Le,
        Op::Gt,
        Op::Ge,
        Op::Select,
        Op::Eq,
        Op::Ne,
        Op::And,
        Op::Or,
        Op::Not,
        Op::Floor,
        Op::Mod,
    ];

    /// `apply_points` gives `apply_f64`'s value at every point, to the bit.
    #[test]
    fn values_at_points_are_the_values_one_by_one() {
        let a = [0.3, -1.7, 2.5, 0.0];
        let b = [1.1, 0.6, -2.0, 0.0];
        let c = [-0.4, 3.0, 0.9, 1.0];
        for &op in ALL {
            let points = op.apply_points(a, b, c);
            for l in 0..4 {
                let one = op.apply_f64(a[l], b[l], c[l]);
                assert!(
                    points[l].to_bits() == one.to_bits() || (points[l].is_nan() && one.is_nan()),
                    "{op:?} at point {l}: {} against {one}",
                    points[l]
                );
            }
        }
    }

    #[test]
    fn written_out_partials_match_the_dual_partials() {
        for &op in ALL {
            let (a, b, c) = (
                Dual64::new(1.3, 0.7),
                Dual64::new(0.4, -0.2),
                Dual64::new(2.0, 1.0),
            );
            let fast = op.partials(a, b, c, op.apply(a, b, c));
            let slow = op.partials_from_duals(a, b, c);
            for i in 0..3 {
                assert!((fast[i].re - slow[i].re).abs() < 1e-14, "{op:?}");
                assert!((fast[i].eps - slow[i].eps).abs() < 1e-14, "{op:?}");
            }
        }
    }

    #[test]
    fn partials_agree_with_central_differences() {
        for &op in ALL {
            let args = [0.8, 1.7, 0.3];
            let p = op.partials(
                args[0],
                args[1],
                args[2],
                op.apply_f64(args[0], args[1], args[2]),
            );
            for i in 0..op.arity() {
                let h = 1e-6;
                let mut up = args;
                let mut dn = args;
                up[i] += h;
                dn[i] -= h;
                let fd = (op.apply_f64(up[0], up[1], up[2]) - op.apply_f64(dn[0], dn[1], dn[2]))
                    / (2.0 * h);
                assert!(
                    (fd - p[i]).abs() < 1e-6 * (1.0 + fd.abs()),
                    "{op:?} arg {i}: {fd} vs {}",
                    p[i]
                );
            }
        }
    }

    #[test]
    fn mod_and_floor_follow_python() {
        assert_eq!(Op::Mod.apply_f64(7.5, 24.0, 0.0), 7.5);
        assert_eq!(Op::Mod.apply_f64(-1.0, 24.0, 0.0), 23.0);
        assert_eq!(Op::Mod.apply_f64(25.0, 24.0, 0.0), 1.0);
        assert_eq!(Op::Floor.apply_f64(-0.5, 0.0, 0.0), -1.0);
        let p = Op::Mod.partials(50.0, 24.0, 0.0, 2.0);
        assert_eq!(p[..2], [1.0, -2.0]);
    }

    #[test]
    fn logic_reads_a_condition_as_if_does() {
        let t = |op: Op, a: f64, b: f64| op.apply_f64(a, b, 0.0);
        assert_eq!(
            [
                t(Op::And, 1.0, 1.0),
                t(Op::And, 1.0, 0.0),
                t(Op::Or, 0.0, 1.0),
                t(Op::Or, 0.0, 0.2)
            ],
            [1.0, 0.0, 1.0, 0.0]
        );
        assert_eq!([t(Op::Not, 0.0, 0.0), t(Op::Not, 0.7, 0.0)], [1.0, 0.0]);
        assert_eq!([t(Op::Eq, 2.0, 2.0), t(Op::Ne, 2.0, 2.0)], [1.0, 0.0]);
    }

    #[test]
    fn square_of_zero_has_finite_derivative() {
        let d = Op::Powi(2).partials(0.0, 0.0, 0.0, 0.0);
        assert_eq!(d[0], 0.0);
    }
}
