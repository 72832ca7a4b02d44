//! Spring laws: the scalar force a spring exerts as a function of its length.
//!
//! Positive force is tension. Lengths in metres, stiffnesses in N/m, forces in N.

mod bilinear;
mod ppu;

pub use bilinear::Bilinear;
pub use ppu::{PpuBilinearPair, PpuDecomposeError, PpuLinearSpring};

/// How a spring's force depends on its length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpringLaw {
    /// `F = k (L − L0)` in tension and compression; `k` in N/m.
    Linear {
        /// Stiffness, N/m.
        stiffness: f64,
    },
    /// Two linear phases in tension and its own compression stiffness (see [`Bilinear`]).
    Bilinear(Bilinear),
}

impl SpringLaw {
    /// Force in N (positive = tension) at length `length` for rest length `rest_length`, both m.
    pub fn force(&self, length: f64, rest_length: f64) -> f64 {
        match self {
            SpringLaw::Linear { stiffness } => stiffness * (length - rest_length),
            SpringLaw::Bilinear(b) => b.force(length, rest_length),
        }
    }

    /// Elastic energy stored at `length`, J: the integral of [`SpringLaw::force`] from the
    /// rest length.
    pub fn energy(&self, length: f64, rest_length: f64) -> f64 {
        let s = length - rest_length;
        match self {
            SpringLaw::Linear { stiffness } => 0.5 * stiffness * s * s,
            SpringLaw::Bilinear(b) => {
                if s < 0.0 {
                    0.5 * b.k_compression * s * s
                } else {
                    let t = b.turn_length - rest_length;
                    if s <= t {
                        0.5 * b.k1 * s * s
                    } else {
                        0.5 * b.k1 * t * t + b.k1 * t * (s - t) + 0.5 * b.k2 * (s - t) * (s - t)
                    }
                }
            }
        }
    }

    /// Tangent stiffness dF/dL in N/m at `length` (the larger one at a kink).
    pub fn tangent(&self, length: f64, rest_length: f64) -> f64 {
        match self {
            SpringLaw::Linear { stiffness } => *stiffness,
            SpringLaw::Bilinear(b) => b.tangent(length, rest_length),
        }
    }

    /// The largest stiffness this law can show at any length, N/m: what bounds the
    /// critical time step of explicit integrators.
    pub fn max_stiffness(&self) -> f64 {
        match self {
            SpringLaw::Linear { stiffness } => *stiffness,
            SpringLaw::Bilinear(b) => b.k1.max(b.k2).max(b.k_compression),
        }
    }

    /// Short name used in files and tables: `linear` or `bilinear`.
    pub fn kind_name(&self) -> &'static str {
        match self {
            SpringLaw::Linear { .. } => "linear",
            SpringLaw::Bilinear(_) => "bilinear",
        }
    }

    /// Whether every parameter is finite and non-negative (and the turning length is not
    /// below the rest length `rest_length`).
    pub fn is_valid(&self, rest_length: f64) -> bool {
        match self {
            SpringLaw::Linear { stiffness } => stiffness.is_finite() && *stiffness >= 0.0,
            SpringLaw::Bilinear(b) => b.is_valid(rest_length),
        }
    }
}
