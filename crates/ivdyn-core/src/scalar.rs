//! The scalar the recursive estimators and the terminal-link recursion are written for:
//! `f64` (the default everywhere), `f32` on a small controller, or an instrumented type
//! that counts the arithmetic it executes (`tests/op_count.rs`: the operation count of
//! the terminal-link update is measured through the very code that runs in `f64`).
//!
//! Only what that code needs: the four operations, comparisons, `sqrt`, `abs`, a
//! finiteness test, `sin_cos` and `tanh` (the smooth Coulomb shape). Constants of the
//! model enter through [`RealScalar::from_f64`] (not an operation); the configuration of
//! the estimators (weights, forgetting, bounds) stays `f64`.

use core::fmt::Debug;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A real scalar for the generic estimators (see the module docs).
pub trait RealScalar:
    nalgebra::Scalar
    + Copy
    + Debug
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    /// A constant (model data, configuration): a conversion, not an operation.
    fn from_f64(x: f64) -> Self;
    /// The value as `f64` (for error reports).
    fn to_f64(self) -> f64;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// `(sin x, cos x)`.
    fn sin_cos(self) -> (Self, Self);
    /// Hyperbolic tangent.
    fn tanh(self) -> Self;
    /// `0`.
    #[inline(always)]
    fn zero() -> Self {
        Self::from_f64(0.0)
    }
    /// `1`.
    #[inline(always)]
    fn one() -> Self {
        Self::from_f64(1.0)
    }
}

impl RealScalar for f64 {
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        libm::sqrt(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    /// The crate's joint-angle sine and cosine ([`crate::trig::sin_cos`]), as the
    /// dynamics kernels use.
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        crate::trig::sin_cos(self)
    }
    #[inline(always)]
    fn tanh(self) -> Self {
        libm::tanh(self)
    }
}

impl RealScalar for f32 {
    #[inline(always)]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        libm::sqrtf(self)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f32::abs(self)
    }
    #[inline(always)]
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        libm::sincosf(self)
    }
    #[inline(always)]
    fn tanh(self) -> Self {
        libm::tanhf(self)
    }
}

/// A running sum that starts from its first term (no `0 + x`: an operation count should not
/// include additions of a zero that is known in advance); empty, it is `0`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sum<T>(Option<T>);

impl<T: RealScalar> Sum<T> {
    /// No terms yet.
    #[inline(always)]
    pub(crate) fn new() -> Self {
        Sum(None)
    }
    /// Adds a term.
    #[inline(always)]
    pub(crate) fn add(&mut self, x: T) {
        self.0 = Some(match self.0 {
            Some(s) => s + x,
            None => x,
        });
    }
    /// The sum (`0` when empty).
    #[inline(always)]
    pub(crate) fn get(self) -> T {
        self.0.unwrap_or_else(T::zero)
    }
}
