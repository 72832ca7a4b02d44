//! Running the yardstick: the solver configured as the specification says, and the
//! displacement checksum.

use crate::model::Model;
use crate::solver::{Effects, IntegrationParameters, IntegratorKind, SimdLevel, Substeps};
use std::fmt;

/// Gravity of the yardstick, m/s².
pub const GRAVITY: [f64; 3] = [0.0, -9.81, 0.0];
/// Step of the yardstick, s.
pub const DT: f64 = 1.0e-4;

/// Which code steps the yardstick.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum YardstickImpl {
    /// The specification's plain scalar loop ([`super::ReferenceStepper`]).
    Reference,
    /// Lamina's solver with its kernels built for this instruction set.
    Lamina(SimdLevel),
    /// The same, with every spring streaming its own parameters (no shared entries), as a
    /// model whose springs all differ would: in f32 packed to 6 bytes a spring in one
    /// sequential stream per thread (`solver::spring_pack`), in f64 as f64 streams.
    LaminaStreamed(SimdLevel),
}

impl fmt::Display for YardstickImpl {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Reference => f.write_str("scalar-reference"),
            Self::Lamina(level) => write!(f, "lamina-{level}"),
            Self::LaminaStreamed(level) => write!(f, "lamina-{level}-streamed"),
        }
    }
}

/// Solver settings of `imp` (the reference gets Lamina's best level's settings).
pub fn impl_params(imp: YardstickImpl, threads: usize) -> IntegrationParameters {
    match imp {
        YardstickImpl::Reference => lattice_params(threads, SimdLevel::detect()),
        YardstickImpl::Lamina(level) => lattice_params(threads, level),
        YardstickImpl::LaminaStreamed(level) => {
            IntegrationParameters { share_run_parameters: false, ..lattice_params(threads, level) }
        }
    }
}

/// Solver settings of the yardstick: symplectic Euler, one fixed step of 1e-4 s.
pub fn lattice_params(threads: usize, simd: SimdLevel) -> IntegrationParameters {
    IntegrationParameters {
        dt: DT,
        integrator: IntegratorKind::SymplecticEuler,
        substeps: Substeps::Fixed(1),
        threads,
        pin_workers: threads > 1,
        simd,
        ..IntegrationParameters::default()
    }
}

/// Effects of the yardstick: gravity, spring dashpots, the fixed bottom row; nothing else.
pub fn lattice_effects() -> Effects {
    Effects { gravity: Some(GRAVITY), spring_damping: true, bone: true, ..Effects::default() }
}

/// Displacement statistics of `u = x − x0`, m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checksum {
    /// Σ u.x (0 by symmetry up to round-off).
    pub sum_ux: f64,
    /// Σ u.y.
    pub sum_uy: f64,
    /// Σ u.z (0 by symmetry up to round-off).
    pub sum_uz: f64,
    /// max |u|.
    pub max_u: f64,
    /// sqrt(mean |u|²).
    pub rms_u: f64,
}

/// Checksum of final positions `x` against the model's initial ones.
pub fn checksum(model: &Model, x: impl Fn(usize) -> [f64; 3]) -> Checksum {
    let mut c = Checksum { sum_ux: 0.0, sum_uy: 0.0, sum_uz: 0.0, max_u: 0.0, rms_u: 0.0 };
    let n = model.nodes.len();
    let mut sq = 0.0;
    for i in 0..n {
        let (p, p0) = (x(i), model.nodes.position[i]);
        let u = [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]];
        c.sum_ux += u[0];
        c.sum_uy += u[1];
        c.sum_uz += u[2];
        let m2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        c.max_u = c.max_u.max(m2.sqrt());
        sq += m2;
    }
    c.rms_u = (sq / n.max(1) as f64).sqrt();
    c
}

/// [`GRAVITY`], for callers that build their own stepper.
pub fn run_gravity() -> [f64; 3] {
    GRAVITY
}
