//! Which vector instructions the force kernels use, chosen at run time.
//!
//! The kernels are plain loops compiled three times: for the x86-64 baseline (SSE2), with
//! AVX2+FMA enabled and with AVX-512 enabled; [`SimdLevel::detect`] picks the widest the CPU
//! has. No fused multiply-add is ever formed (Rust does not contract), so all three give
//! bit-identical results and can be compared side by side in one run.

use std::fmt;

/// An instruction-set level for the kernels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SimdLevel {
    /// The target's baseline (SSE2 on x86-64; whatever the target has elsewhere).
    Baseline,
    /// AVX2, FMA and F16C (256-bit vectors).
    Avx2,
    /// AVX-512F/VL and F16C (512-bit vectors).
    Avx512,
}

impl SimdLevel {
    /// The widest level this CPU supports.
    pub fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f")
                && std::arch::is_x86_feature_detected!("avx512vl")
                && std::arch::is_x86_feature_detected!("f16c")
            {
                return SimdLevel::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
                && std::arch::is_x86_feature_detected!("f16c")
            {
                return SimdLevel::Avx2;
            }
        }
        SimdLevel::Baseline
    }

    /// Every level this CPU supports, narrowest first.
    pub fn available() -> Vec<Self> {
        let best = Self::detect();
        [SimdLevel::Baseline, SimdLevel::Avx2, SimdLevel::Avx512].into_iter().filter(|l| *l <= best).collect()
    }

    /// `level` if this CPU supports it, else the widest it does.
    pub fn clamp_to_cpu(self) -> Self {
        self.min(Self::detect())
    }

    /// Parses `baseline`, `avx2`, `avx512` (or `auto`: [`SimdLevel::detect`]).
    pub fn parse(name: &str) -> Option<Self> {
        match name {
            "baseline" | "scalar" | "sse2" => Some(SimdLevel::Baseline),
            "avx2" => Some(SimdLevel::Avx2),
            "avx512" => Some(SimdLevel::Avx512),
            "auto" => Some(Self::detect()),
            _ => None,
        }
    }
}

impl fmt::Display for SimdLevel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SimdLevel::Baseline => "baseline",
            SimdLevel::Avx2 => "avx2",
            SimdLevel::Avx512 => "avx512",
        })
    }
}
