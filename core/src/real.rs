//! The floating-point type the solver runs in (`f32` in the real-time loop, `f64` for
//! reference runs) and the lane block of it the kernels compute on. One small trait instead
//! of a numerics crate, so the hot kernels stay plain loops that LLVM vectorises. The blocks
//! themselves (plain arrays and AVX registers) and the `Real` impls for `f32` and `f64` are in
//! `solver/lane_block.rs`.

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
    type AvxBlock: Block<Self>;
}

/// Springs per lane block. The block, not the register, fixes the order in which forces
/// are summed, so every instruction-set level gives the same bits. Default 8 (one AVX
/// register of f32).
pub const LANES: usize = 8;

/// `a > b ? a : b`, the x86 `maxps` rule: `b` when either is NaN or both are zero.
#[inline(always)]
pub fn max<T: Real>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// `a < b ? a : b`, the x86 `minps` rule: `b` when either is NaN or both are zero.
#[inline(always)]
pub fn min<T: Real>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// [`LANES`] values of `T` and the kernel's arithmetic on them.
pub trait Block<T: Real>: Copy {
    /// `s[i..i + LANES]`; panics if out of bounds.
    fn load(s: &[T], i: usize) -> Self;
    /// Every lane `v`.
    fn splat(v: T) -> Self;
    /// Writes the lanes to `s[i..i + LANES]`; panics if out of bounds.
    fn store(self, s: &mut [T], i: usize);
    /// Lane-wise sum.
    fn add(self, o: Self) -> Self;
    /// Lane-wise difference.
    fn sub(self, o: Self) -> Self;
    /// Lane-wise product.
    fn mul(self, o: Self) -> Self;
    /// Lane-wise quotient.
    fn div(self, o: Self) -> Self;
    /// Lane-wise square root.
    fn sqrt(self) -> Self;
    /// Lane-wise [`max`].
    fn max(self, o: Self) -> Self;
    /// Lane-wise [`min`].
    fn min(self, o: Self) -> Self;
    /// `+0` in the lanes where `keep` is 0.
    fn keep(self, keep: &[u8]) -> Self;
    /// `yes` in the lanes where `self > 0` (ordered: false for NaN), `no` elsewhere.
    fn select_positive(self, yes: Self, no: Self) -> Self;
}
