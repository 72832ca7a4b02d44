//! The floating-point type the solver runs in: `f32` in the real-time loop, `f64` for
//! reference runs. One small trait instead of a numerics crate, so the hot kernels stay
//! plain loops that LLVM vectorises.

use std::fmt::{Debug, Display};
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// A machine real: implemented for `f32` and `f64` only.
pub trait Real:
    Copy
    + Send
    + Sync
    + 'static
    + Default
    + Debug
    + Display
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Short name for tables: `"f32"` or `"f64"`.
    const NAME: &'static str;
    /// Rounds an `f64` to this precision.
    fn from_f64(v: f64) -> Self;
    /// Widens to `f64` (exact).
    fn to_f64(self) -> f64;
    /// IEEE square root.
    fn sqrt(self) -> Self;
    /// Larger of two values; NaN-ignoring like `f64::max`.
    fn max(self, other: Self) -> Self;
    /// Smaller of two values; NaN-ignoring like `f64::min`.
    fn min(self, other: Self) -> Self;
    /// Neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// Lane block of this type in AVX registers (x86-64; elsewhere a plain array), used by
    /// the spring kernel only after AVX2 was detected.
    type AvxBlock: crate::solver::lane_block::Block<Self>;
}

macro_rules! impl_real {
    ($t:ty, $name:literal, $avx:ty) => {
        impl Real for $t {
            type AvxBlock = $avx;
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const NAME: &'static str = $name;
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                <$t>::min(self, other)
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}

#[cfg(target_arch = "x86_64")]
impl_real!(f32, "f32", crate::solver::lane_block::AvxF32);
#[cfg(target_arch = "x86_64")]
impl_real!(f64, "f64", crate::solver::lane_block::AvxF64);
#[cfg(not(target_arch = "x86_64"))]
impl_real!(f32, "f32", crate::solver::lane_block::ScalarBlock<f32>);
#[cfg(not(target_arch = "x86_64"))]
impl_real!(f64, "f64", crate::solver::lane_block::ScalarBlock<f64>);
