//! The dual number the derivative sweeps run on: a value and [`LANES`] directional
//! derivatives held in a plain array.
//!
//! It is a `num_dual` number like the others ([`DualNum`] is implemented by num-dual's own
//! macros, from the chain, product and quotient rules below), so every op of the tape
//! evaluates on it unchanged. It differs from num-dual's `DualSVec64<8>` in one thing:
//! that type keeps its derivative part as an `Option` of a nalgebra vector (so that a
//! constant carries none), and every operation branches on it and goes through
//! nalgebra's generic arithmetic. The tape's sweeps seed every input with lanes, so the
//! option is always set; here the lanes are eight plain floats that the compiler keeps in
//! vector registers, and a sweep of the lettuce step's 1024 instructions runs much faster
//! (measured: `docs/benchmarks-history.md`, "A lane type without `Option`").

// The product and quotient rules are a dual number's multiplication and division: their
// `+`, `−` and `*` inside `Mul` and `Div` are the point, not a slip.
#![allow(clippy::suspicious_arithmetic_impl)]

use num_dual::{
    chain_rule, first, forward_binop, impl_add_sub_rem, impl_assign_ops, impl_comparisons,
    impl_derivatives, impl_dual, impl_dual_struct, impl_first_derivatives, impl_float_const,
    impl_from_f, impl_from_primitive, impl_inv, impl_iterator, impl_neg, impl_num, impl_scalar_op,
    impl_signed, impl_zero_one, second, third, zeroth, DualNum, DualNumFloat, DualStruct,
};
use num_traits::{FloatConst, FromPrimitive, Inv, Num, One, Signed, Zero};
use std::fmt;
use std::iter::{Product, Sum};
use std::ops::{
    Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Rem, RemAssign, Sub, SubAssign,
};

/// Number of directional derivatives carried by one [`Lanes`] number.
pub const LANES: usize = 8;

/// The derivative part of a [`Lanes`] number: one value per direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LaneVector<T>(pub [T; LANES]);

impl<T: DualNum> LaneVector<T> {
    /// All lanes zero.
    #[inline]
    pub fn zero() -> Self {
        LaneVector(std::array::from_fn(|_| T::zero()))
    }

    #[inline]
    fn map(self, f: impl FnMut(T) -> T) -> Self {
        LaneVector(self.0.map(f))
    }

    #[inline]
    fn zip(self, other: &Self, f: impl Fn(&T, &T) -> T) -> Self {
        let mut out = self.0;
        for (o, b) in out.iter_mut().zip(&other.0) {
            *o = f(o, b);
        }
        LaneVector(out)
    }
}

impl<T: DualNum> Add<&LaneVector<T>> for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn add(self, other: &Self) -> Self {
        self.zip(other, |a, b| a.clone() + b)
    }
}

impl<T: DualNum> Add for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn add(self, other: Self) -> Self {
        self + &other
    }
}

impl<T: DualNum> Sub<&LaneVector<T>> for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn sub(self, other: &Self) -> Self {
        self.zip(other, |a, b| a.clone() - b)
    }
}

impl<T: DualNum> Sub for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn sub(self, other: Self) -> Self {
        self - &other
    }
}

impl<T: DualNum> Neg for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.map(|a| -a)
    }
}

impl<T: DualNum> AddAssign for LaneVector<T> {
    #[inline]
    fn add_assign(&mut self, other: Self) {
        *self = self.clone() + &other;
    }
}

impl<T: DualNum> SubAssign for LaneVector<T> {
    #[inline]
    fn sub_assign(&mut self, other: Self) {
        *self = self.clone() - &other;
    }
}

impl<T: DualNum> Mul<T> for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn mul(self, factor: T) -> Self {
        self.map(|a| a * factor.clone())
    }
}

impl<T: DualNum> Mul<&T> for LaneVector<T> {
    type Output = Self;
    #[inline]
    fn mul(self, factor: &T) -> Self {
        self * factor.clone()
    }
}

impl<T: DualNum> MulAssign<T> for LaneVector<T> {
    #[inline]
    fn mul_assign(&mut self, factor: T) {
        *self = self.clone() * factor;
    }
}

impl<T: DualNum> DivAssign<T> for LaneVector<T> {
    #[inline]
    fn div_assign(&mut self, divisor: T) {
        *self = self.clone().map(|a| a / divisor.clone());
    }
}

/// A value and [`LANES`] directional derivatives, as one `num_dual` number.
///
/// ```
/// use ghm::graph::Lanes;
/// use num_dual::DualNum;
///
/// // x²·y at (5, 3), seeded in lanes 0 (x) and 1 (y): (75, [2xy, x², 0, …]).
/// let x = Lanes::from_re(5.0).derivative(0);
/// let y = Lanes::from_re(3.0).derivative(1);
/// let z = x * x * y;
/// assert_eq!(z.re, 75.0);
/// assert_eq!(&z.eps.0[..3], &[30.0, 25.0, 0.0]);
/// assert_eq!(z.exp().eps.0[1], 75f64.exp() * 25.0);
/// ```
// The lanes first, at the start of the number: copies of it then move them in the
// vector-register pieces its arithmetic reads, and a read never straddles two earlier
// writes (whose forwarding stalls made the sweeps of `super::wide` slower than plain ones).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Lanes<T> {
    /// The directional derivatives.
    pub eps: LaneVector<T>,
    /// The value.
    pub re: T,
}

impl<T: DualNum> Lanes<T> {
    /// A number from its value and derivatives.
    #[inline]
    pub fn new(re: T, eps: LaneVector<T>) -> Self {
        Lanes { re, eps }
    }

    /// A constant: its derivatives are zero.
    #[inline]
    pub fn from_re(re: T) -> Self {
        Lanes::new(re, LaneVector::zero())
    }

    /// The same value with derivative 1 in lane `lane` and 0 in the others.
    #[inline]
    pub fn derivative(mut self, lane: usize) -> Self {
        self.eps = LaneVector::zero();
        self.eps.0[lane] = T::one();
        self
    }

    /// The chain rule: `f(self)` from `f0 = f(re)` and `f1 = f'(re)`.
    #[inline]
    fn chain_rule(&self, f0: T, f1: T) -> Self {
        Lanes::new(f0, self.eps.clone() * f1)
    }
}

/* product rule */
impl<T: DualNum> Mul<&Lanes<T>> for &Lanes<T> {
    type Output = Lanes<T>;
    #[inline]
    fn mul(self, other: &Lanes<T>) -> Lanes<T> {
        Lanes::new(
            self.re.clone() * other.re.clone(),
            self.eps.clone().zip(&other.eps, |a, b| {
                a.clone() * other.re.clone() + b.clone() * self.re.clone()
            }),
        )
    }
}

/* quotient rule */
impl<T: DualNum> Div<&Lanes<T>> for &Lanes<T> {
    type Output = Lanes<T>;
    #[inline]
    fn div(self, other: &Lanes<T>) -> Lanes<T> {
        // num-dual's own rounding, `(a′·b − b′·a) / b²`, so that results stay those of
        // its `DualSVec64` to the last bit.
        let inv = other.re.recip();
        let eps = self.eps.clone().zip(&other.eps, |a, b| {
            (a.clone() * other.re.clone() - b.clone() * self.re.clone()) * inv.clone() * inv.clone()
        });
        Lanes::new(self.re.clone() * inv, eps)
    }
}

impl<T: DualNum> fmt::Display for Lanes<T> {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}", self.re)?;
        for (l, e) in self.eps.0.iter().enumerate() {
            write!(f, " + {e}ε{l}")?;
        }
        Ok(())
    }
}

impl_first_derivatives!(Lanes, [eps]);
impl_dual!(Lanes, [eps]);
