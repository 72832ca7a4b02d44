//! Linear springs' per-spring parameters packed to the precision they need, in the order
//! the streamed kernel reads them.
//!
//! When every spring streams its own parameters (no run shares one entry), f32 parameters
//! cost 12 bytes a spring in three streams per run, and a group of nine runs reads 27 of
//! them at once, more than the hardware prefetchers follow. Packed, a spring costs 6 bytes,
//! and a group reads *one* sequential stream: for each lane block of [`LANES`] first nodes,
//! the records of the group's runs one after the other, exactly as the kernel visits them.
//!
//! A record holds, per lane, as 16-bit values:
//! * rest length: an unsigned offset in f32 units in the last place (ulp) above the run's
//!   shortest rest length, `rest = base + d·ulp(base)`. Decoded **exactly** (every rest
//!   length of f32 type at or above `base` is a whole number of `ulp(base)` above it); a run
//!   whose rest lengths span 65,536 ulps or more (about 61 µm at 1 cm) cannot be packed.
//! * stiffness and dashpot: IEEE binary16 factors of a per-run scale, `k = k_max·f`, the
//!   scale being the run's largest value or the power of two above it. Within
//!   [`PACKED_RELATIVE_BOUND`] of the f32 value (binary16 rounding, 2^-11, and the product's
//!   f32 rounding, 2^-24); exact when the run's values are equal, or in ratios binary16
//!   holds, or have at most 11 significant bits (whole N/m below 2048: the yardstick's 50,
//!   150 and 400 N/m). A factor that would lose more (below binary16's normal range, 6.1e-5
//!   of the scale) cannot be packed.
//!
//! Packing is all or nothing: when one spring of the block cannot be packed within these
//! bounds, the kernel streams the f32 parameters instead. Only f32 is packed (an f64 run
//! keeps f64 parameters).

use super::lane_block::{LANES, f16_from_f64, f16_to_f64};
use crate::real::Real;

/// Largest relative error of a packed stiffness or dashpot against its f32 value:
/// `2^-11 + 2^-23` (binary16 rounding, then the f32 product).
pub const PACKED_RELATIVE_BOUND: f64 = 1.0 / 2048.0 + 1.0 / 8_388_608.0;

/// [`LANES`] springs of one run, packed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C, align(16))]
pub struct PackedRecord {
    /// Rest length offsets in units of the run's [`PackedRun::unit`].
    pub rest: [u16; LANES],
    /// Stiffness factors (binary16) of the run's [`PackedRun::k_max`].
    pub k: [u16; LANES],
    /// Dashpot factors (binary16) of the run's [`PackedRun::c_max`].
    pub c: [u16; LANES],
}

/// What a run's records are relative to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PackedRun<T> {
    /// Shortest rest length of the run's springs, m.
    pub base: T,
    /// One f32 ulp of `base`, m.
    pub unit: T,
    /// Scale of the stiffness factors: the largest stiffness magnitude of the run's springs
    /// or the power of two above it (the one that decodes exactly; 1 when all are 0), N/m.
    pub k_max: T,
    /// Scale of the dashpot factors, as `k_max`, N·s/m.
    pub c_max: T,
}

/// A linear block's run parameters, packed.
#[derive(Clone, Debug, Default)]
pub struct PackedLinear<T> {
    /// Per run (as [`SpringBlock::runs`]).
    pub runs: Vec<PackedRun<T>>,
    /// Per run: index in `records` of its first record. A group's records are stored lane
    /// block by lane block, each block's runs in order, so a run's next record is
    /// group-size records further on.
    pub first_record: Vec<u32>,
    /// Every run's records in the kernel's reading order.
    pub records: Vec<PackedRecord>,
}

/// The decoded rest length, stiffness and dashpot of a record's lane `l`: the operations the
/// kernel performs, in `T`.
#[inline(always)]
pub fn decode<T: Real>(run: &PackedRun<T>, rec: &PackedRecord, l: usize) -> [T; 3] {
    [
        run.base + T::from_f64(f64::from(rec.rest[l])) * run.unit,
        run.k_max * T::from_f64(f16_to_f64(rec.k[l])),
        run.c_max * T::from_f64(f16_to_f64(rec.c[l])),
    ]
}

/// Why a block could not be packed.
#[derive(Clone, Debug, PartialEq)]
pub enum PackError {
    /// The precision is not f32.
    NotF32,
    /// A run's rest lengths span too many ulps of its shortest, or are not finite.
    RestSpread { run: usize },
    /// A stiffness or dashpot does not pack within [`PACKED_RELATIVE_BOUND`].
    Factor { run: usize },
}

pub(super) fn f32_ulp(v: f32) -> f32 {
    let v = v.abs();
    if !v.is_finite() {
        return f32::NAN;
    }
    let next = f32::from_bits(v.to_bits() + 1);
    next - v
}

/// The scale of a run's binary16 factors: the largest magnitude, or the power of two at or
/// above it when that decodes every value exactly and the largest does not (values with 11
/// significant bits or fewer, such as whole N/m below 2048, are exact in binary16 times a
/// power of two); 1 when every value is 0.
pub(super) fn scale_of<T: Real>(values: &[T]) -> T {
    let largest = values.iter().map(|v| v.to_f64().abs()).fold(0.0f64, f64::max);
    if largest == 0.0 || !largest.is_finite() {
        return T::ONE;
    }
    let exact = |scale: T| {
        values.iter().all(|&v| scale * T::from_f64(f16_to_f64(f16_from_f64(v.to_f64() / scale.to_f64()))) == v)
    };
    let largest = T::from_f64(largest);
    let power = T::from_f64((2.0f64).powi(largest.to_f64().log2().ceil() as i32));
    if !exact(largest) && exact(power) { power } else { largest }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reproducible stream of numbers in [0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn f16_codes_round_trip_and_round_to_nearest_works() {
        for h in 0..=u16::MAX {
            let v = f16_to_f64(h);
            if v.is_nan() {
                continue;
            }
            assert_eq!(f16_from_f64(v), h, "{h:#06x} = {v}");
        }
        assert_eq!(f16_to_f64(0x3c00), 1.0);
        assert_eq!(f16_to_f64(0x7bff), 65504.0);
        assert_eq!(f16_to_f64(0x0001), (2.0f64).powi(-24));
        assert_eq!(f16_from_f64(1e6), 0x7c00);
        let mut rng = Lcg(7);
        for _ in 0..100_000 {
            // Normal range: half a binary16 step, 2^-11 relative.
            let sign = if rng.next() < 0.5 { -1.0 } else { 1.0 };
            let v = sign * (1.0 + rng.next()) * (2.0f64).powi((rng.next() * 29.0) as i32 - 14);
            let back = f16_to_f64(f16_from_f64(v));
            assert!((back - v).abs() <= v.abs() / 2048.0, "{v} -> {back}");
        }
        // Ties go to even: 1 + 2^-11 is halfway between 1 and 1 + 2^-10.
        assert_eq!(f16_from_f64(1.0 + 1.0 / 2048.0), 0x3c00);
        assert_eq!(f16_from_f64(1.0 + 3.0 / 2048.0), 0x3c02);
    }
}
