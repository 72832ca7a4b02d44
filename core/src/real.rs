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
    /// `s[i..i + LANES]` as IEEE binary16 values, widened (exactly); panics if out of bounds.
    fn load_f16(s: &[u16], i: usize) -> Self;
    /// `s[i..i + LANES]` as unsigned integers, widened (exactly); panics if out of bounds.
    fn load_u16(s: &[u16], i: usize) -> Self;
}

/// The value of IEEE binary16 bits `h` (every binary16 value is an `f64`, exactly).
#[inline(always)]
pub fn f16_to_f64(h: u16) -> f64 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let mant = f64::from(h & 0x3ff);
    sign * match exp {
        0 => mant * (2.0f64).powi(-24),
        31 if mant == 0.0 => f64::INFINITY,
        31 => f64::NAN,
        _ => (1024.0 + mant) * (2.0f64).powi(exp - 25),
    }
}

/// `v` rounded to the nearest IEEE binary16 (ties to even; beyond 65504 to infinity), as bits.
pub fn f16_from_f64(v: f64) -> u16 {
    let sign: u16 = if v.is_sign_negative() { 0x8000 } else { 0 };
    let a = v.abs();
    if a.is_nan() {
        return sign | 0x7e00;
    }
    if a >= 65520.0 {
        return sign | 0x7c00;
    }
    if a < (2.0f64).powi(-26) {
        return sign;
    }
    // a = q · 2^u with the binary16 step 2^u of a's binade (2^-24 below the normal range).
    let e = ((a.to_bits() >> 52) & 0x7ff) as i32 - 1023;
    let mut u = e.max(-14) - 10;
    let mut m = (a * (2.0f64).powi(-u)).round_ties_even() as u32;
    if m == 2048 {
        m = 1024;
        u += 1;
    }
    if m < 1024 {
        return sign | m as u16;
    }
    let field = u + 25;
    if field >= 31 {
        return sign | 0x7c00;
    }
    sign | ((field as u16) << 10) | (m - 1024) as u16
}
