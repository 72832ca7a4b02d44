//! Blocks of [`LANES`] values with the arithmetic the spring kernel needs, in two builds:
//! plain arrays ([`ScalarBlock`], any CPU) and AVX registers ([`AvxF32`], [`AvxF64`], used
//! only after [`super::SimdLevel`] detected AVX2).
//!
//! Every operation rounds exactly as its scalar counterpart (IEEE add, sub, mul, div, sqrt;
//! no fused multiply-add), and [`max`]/[`min`] follow the x86 `maxps`/`minps` rule in both
//! builds, so a block computed in registers has the same bits as the same block computed
//! lane by lane.

use crate::real::Real;
pub use crate::real::{Block, LANES, f16_from_f64, f16_to_f64, max, min};

/// A block as an array, computed lane by lane.
#[derive(Clone, Copy)]
pub struct ScalarBlock<T>([T; LANES]);

impl<T: Real> ScalarBlock<T> {
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(T, T) -> T) -> Self {
        let mut r = self.0;
        for l in 0..LANES {
            r[l] = f(self.0[l], o.0[l]);
        }
        Self(r)
    }
}

impl<T: Real> Block<T> for ScalarBlock<T> {
    #[inline(always)]
    fn load(s: &[T], i: usize) -> Self {
        Self(s[i..i + LANES].try_into().expect("a lane block"))
    }
    #[inline(always)]
    fn splat(v: T) -> Self {
        Self([v; LANES])
    }
    #[inline(always)]
    fn store(self, s: &mut [T], i: usize) {
        s[i..i + LANES].copy_from_slice(&self.0);
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        self.zip(o, |a, b| a + b)
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        self.zip(o, |a, b| a - b)
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        self.zip(o, |a, b| a * b)
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self.zip(o, |a, b| a / b)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.zip(self, |a, _| a.sqrt())
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, max)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.zip(o, min)
    }
    #[inline(always)]
    fn keep(self, keep: &[u8]) -> Self {
        let mut r = self.0;
        for l in 0..LANES {
            if keep[l] == 0 {
                r[l] = T::ZERO;
            }
        }
        Self(r)
    }
    #[inline(always)]
    fn select_positive(self, yes: Self, no: Self) -> Self {
        let mut r = no.0;
        for l in 0..LANES {
            if self.0[l] > T::ZERO {
                r[l] = yes.0[l];
            }
        }
        Self(r)
    }
    #[inline(always)]
    fn load_f16(s: &[u16], i: usize) -> Self {
        let s = &s[i..i + LANES];
        let mut r = [T::ZERO; LANES];
        for l in 0..LANES {
            r[l] = T::from_f64(f16_to_f64(s[l]));
        }
        Self(r)
    }
    #[inline(always)]
    fn load_u16(s: &[u16], i: usize) -> Self {
        let s = &s[i..i + LANES];
        let mut r = [T::ZERO; LANES];
        for l in 0..LANES {
            r[l] = T::from_f64(f64::from(s[l]));
        }
        Self(r)
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx::{AvxF32, AvxF64};

#[cfg(target_arch = "x86_64")]
mod avx {
    //! AVX blocks. Their methods are `inline(always)` and only ever inlined into functions
    //! compiled with AVX2 enabled, which the kernel calls only after detecting AVX2 (and
    //! F16C, which every AVX2 CPU has, for `load_f16`).
    use super::{Block, LANES};
    use std::arch::x86_64::*;

    /// Eight f32 in one AVX register.
    #[derive(Clone, Copy)]
    pub struct AvxF32(__m256);

    /// Eight f64 in two AVX registers.
    #[derive(Clone, Copy)]
    pub struct AvxF64(__m256d, __m256d);

    /// The `LANES` bytes of `keep`, zero-extended to 32-bit lanes, compared with 0: all ones
    /// in the lanes to drop. In registers: a mask built in memory lane by lane and loaded
    /// whole stalls on store forwarding.
    #[inline(always)]
    fn drop_lanes_32(keep: &[u8]) -> __m256i {
        let keep = &keep[..LANES];
        // SAFETY: 8 bytes read from a slice of 8; AVX2 (see the module doc).
        unsafe {
            let bytes = _mm_loadl_epi64(keep.as_ptr().cast());
            _mm256_cmpeq_epi32(_mm256_cvtepu8_epi32(bytes), _mm256_setzero_si256())
        }
    }

    // SAFETY (every unsafe block below): the intrinsics need AVX, present whenever these
    // types are used (see the module doc); loads and stores are bounds-checked first.
    impl Block<f32> for AvxF32 {
        #[inline(always)]
        fn load(s: &[f32], i: usize) -> Self {
            let s = &s[i..i + LANES];
            Self(unsafe { _mm256_loadu_ps(s.as_ptr()) })
        }
        #[inline(always)]
        fn splat(v: f32) -> Self {
            Self(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn store(self, s: &mut [f32], i: usize) {
            let s = &mut s[i..i + LANES];
            unsafe { _mm256_storeu_ps(s.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            Self(unsafe { _mm256_add_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            Self(unsafe { _mm256_sub_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            Self(unsafe { _mm256_mul_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            Self(unsafe { _mm256_div_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            Self(unsafe { _mm256_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            Self(unsafe { _mm256_max_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            Self(unsafe { _mm256_min_ps(self.0, o.0) })
        }
        #[inline(always)]
        fn keep(self, keep: &[u8]) -> Self {
            let drop = drop_lanes_32(keep);
            unsafe { Self(_mm256_andnot_ps(_mm256_castsi256_ps(drop), self.0)) }
        }
        #[inline(always)]
        fn select_positive(self, yes: Self, no: Self) -> Self {
            unsafe {
                let positive = _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, _mm256_setzero_ps());
                Self(_mm256_blendv_ps(no.0, yes.0, positive))
            }
        }
        #[inline(always)]
        fn load_f16(s: &[u16], i: usize) -> Self {
            let s = &s[i..i + LANES];
            unsafe { Self(_mm256_cvtph_ps(_mm_loadu_si128(s.as_ptr().cast()))) }
        }
        #[inline(always)]
        fn load_u16(s: &[u16], i: usize) -> Self {
            let s = &s[i..i + LANES];
            unsafe { Self(_mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(_mm_loadu_si128(s.as_ptr().cast())))) }
        }
    }

    impl Block<f64> for AvxF64 {
        #[inline(always)]
        fn load(s: &[f64], i: usize) -> Self {
            let s = &s[i..i + LANES];
            unsafe { Self(_mm256_loadu_pd(s.as_ptr()), _mm256_loadu_pd(s.as_ptr().add(4))) }
        }
        #[inline(always)]
        fn splat(v: f64) -> Self {
            unsafe { Self(_mm256_set1_pd(v), _mm256_set1_pd(v)) }
        }
        #[inline(always)]
        fn store(self, s: &mut [f64], i: usize) {
            let s = &mut s[i..i + LANES];
            unsafe {
                _mm256_storeu_pd(s.as_mut_ptr(), self.0);
                _mm256_storeu_pd(s.as_mut_ptr().add(4), self.1);
            }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            unsafe { Self(_mm256_add_pd(self.0, o.0), _mm256_add_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            unsafe { Self(_mm256_sub_pd(self.0, o.0), _mm256_sub_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn mul(self, o: Self) -> Self {
            unsafe { Self(_mm256_mul_pd(self.0, o.0), _mm256_mul_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn div(self, o: Self) -> Self {
            unsafe { Self(_mm256_div_pd(self.0, o.0), _mm256_div_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            unsafe { Self(_mm256_sqrt_pd(self.0), _mm256_sqrt_pd(self.1)) }
        }
        #[inline(always)]
        fn max(self, o: Self) -> Self {
            unsafe { Self(_mm256_max_pd(self.0, o.0), _mm256_max_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn min(self, o: Self) -> Self {
            unsafe { Self(_mm256_min_pd(self.0, o.0), _mm256_min_pd(self.1, o.1)) }
        }
        #[inline(always)]
        fn keep(self, keep: &[u8]) -> Self {
            let drop = drop_lanes_32(keep);
            unsafe {
                // Each 32-bit lane mask widened to 64 bits (sign-extended: all ones stay).
                let lo = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(drop)));
                let hi = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256::<1>(drop)));
                Self(_mm256_andnot_pd(lo, self.0), _mm256_andnot_pd(hi, self.1))
            }
        }
        #[inline(always)]
        fn select_positive(self, yes: Self, no: Self) -> Self {
            unsafe {
                let z = _mm256_setzero_pd();
                let (p0, p1) = (_mm256_cmp_pd::<_CMP_GT_OQ>(self.0, z), _mm256_cmp_pd::<_CMP_GT_OQ>(self.1, z));
                Self(_mm256_blendv_pd(no.0, yes.0, p0), _mm256_blendv_pd(no.1, yes.1, p1))
            }
        }
        #[inline(always)]
        fn load_f16(s: &[u16], i: usize) -> Self {
            let s = &s[i..i + LANES];
            unsafe {
                let w = _mm256_cvtph_ps(_mm_loadu_si128(s.as_ptr().cast()));
                Self(_mm256_cvtps_pd(_mm256_castps256_ps128(w)), _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(w)))
            }
        }
        #[inline(always)]
        fn load_u16(s: &[u16], i: usize) -> Self {
            let s = &s[i..i + LANES];
            unsafe {
                let w = _mm256_cvtepu16_epi32(_mm_loadu_si128(s.as_ptr().cast()));
                Self(
                    _mm256_cvtepi32_pd(_mm256_castsi256_si128(w)),
                    _mm256_cvtepi32_pd(_mm256_extracti128_si256::<1>(w)),
                )
            }
        }
    }
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
impl_real!(f32, "f32", AvxF32);
#[cfg(target_arch = "x86_64")]
impl_real!(f64, "f64", AvxF64);
#[cfg(not(target_arch = "x86_64"))]
impl_real!(f32, "f32", ScalarBlock<f32>);
#[cfg(not(target_arch = "x86_64"))]
impl_real!(f64, "f64", ScalarBlock<f64>);

#[cfg(test)]
mod tests {
    use super::*;

    /// Awkward lanes: NaN, ±0, tiny, huge, negative.
    fn awkward<T: Real>() -> ([T; LANES], [T; LANES]) {
        let a = [f64::NAN, -0.0, 0.0, 1e-30, 3.5, -2.0, 1e30, 7.25].map(T::from_f64);
        let b = [1.0, 0.0, -0.0, 2e-30, f64::NAN, -2.0, 0.5, 7.25].map(T::from_f64);
        (a, b)
    }

    #[inline(always)]
    fn ops<T: Real, B: Block<T>>(a: &[T], b: &[T]) -> Vec<[T; LANES]> {
        let (x, y) = (B::load(a, 0), B::load(b, 0));
        let (keep, keep_any) = ([1u8, 0, 1, 0, 1, 1, 0, 1], [0u8, 255, 2, 0, 128, 0, 1, 0]);
        let results = [
            x.keep(&keep_any),
            x.add(y),
            x.sub(y),
            x.mul(y),
            x.div(y),
            x.sqrt(),
            x.max(y),
            x.min(y),
            x.keep(&keep),
            B::splat(a[4]),
            x.select_positive(x, y),
            B::load_f16(&[0x3c00, 0x8000, 0x0001, 0x7bff, 0xfc00, 0x3555, 0x2e66, 0x03ff], 0),
            B::load_u16(&[0, 1, 65535, 32768, 7, 1000, 4096, 12345], 0),
        ];
        results
            .iter()
            .map(|r| {
                let mut out = [T::ZERO; LANES];
                r.store(&mut out, 0);
                out
            })
            .collect()
    }

    /// Bits of every lane; every NaN counts as one value (a NaN made by an operation has
    /// the CPU's default sign and payload, a constant-folded one Rust's: either is caught
    /// by the solver's guard, and no finite result depends on it).
    fn bits<T: Real>(v: &[[T; LANES]]) -> Vec<u64> {
        v.iter().flatten().map(|x| if x.to_f64().is_nan() { 1 } else { x.to_f64().to_bits() }).collect()
    }

    #[test]
    fn scalar_block_max_min_follow_the_x86_rule_works() {
        assert_eq!(max(f32::NAN, 1.0), 1.0);
        assert!(max(1.0, f32::NAN).is_nan());
        assert_eq!(max(-0.0f32, 0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(max(0.0f32, -0.0).to_bits(), (-0.0f32).to_bits());
        assert_eq!(min(f64::NAN, 1.0), 1.0);
        assert_eq!(min(-0.0f64, 0.0).to_bits(), 0.0f64.to_bits());
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx_blocks_match_scalar_blocks_bit_for_bit_works() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("no AVX2 on this CPU: nothing to compare");
            return;
        }
        #[target_feature(enable = "avx2,f16c")]
        fn with_avx<T: Real, B: Block<T>>(a: &[T], b: &[T]) -> Vec<[T; LANES]> {
            ops::<T, B>(a, b)
        }
        let (a, b) = awkward::<f32>();
        // SAFETY: AVX2 was detected above.
        let avx = unsafe { with_avx::<f32, AvxF32>(&a, &b) };
        assert_eq!(bits(&avx), bits(&ops::<f32, ScalarBlock<f32>>(&a, &b)));
        let (a, b) = awkward::<f64>();
        // SAFETY: as above.
        let avx = unsafe { with_avx::<f64, AvxF64>(&a, &b) };
        assert_eq!(bits(&avx), bits(&ops::<f64, ScalarBlock<f64>>(&a, &b)));
    }
}
