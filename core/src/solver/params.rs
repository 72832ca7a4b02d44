//! The one parameter struct of the solver.

use super::simd::SimdLevel;
use std::fmt;

/// Time integration scheme.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IntegratorKind {
    /// Semi-implicit (symplectic) Euler: `v += h a(x, v)`, then `x += h v`. First order,
    /// one force evaluation per sub-step, bounded energy error.
    SymplecticEuler,
    /// Velocity Verlet (kick-drift-kick leapfrog): `v += h/2 a`, `x += h v`, then
    /// `v += h/2 a(x, ṽ)` with `ṽ = v₀ + h a₀` the predicted velocity its velocity-dependent
    /// forces (dashpots, viscous damping) see. Second order, symplectic without damping, one
    /// force evaluation per sub-step (the end-of-step acceleration is the next sub-step's
    /// start; a frame after the state or the effects were changed from outside costs one more),
    /// the same critical step as symplectic Euler.
    VelocityVerlet,
    /// Classical fourth-order Runge–Kutta: four force evaluations per sub-step.
    Rk4,
    /// Linearly implicit backward Euler (one Newton step per sub-step), solved by
    /// warm-started Jacobi-preconditioned conjugate gradients on the tangent stiffness.
    /// Unconditionally stable, first order, numerically damped.
    ImplicitEuler,
    /// Implicit Euler for real time: one Newton step whose linear system gets a fixed number
    /// of conjugate-gradient iterations (default 1), preconditioned by the prefactored
    /// soft-phase spring matrix. Unconditionally stable, first order, a fixed cost per step.
    ImplicitFactored,
}

impl IntegratorKind {
    /// Every scheme, in table order.
    pub const ALL: [IntegratorKind; 5] = [
        IntegratorKind::SymplecticEuler,
        IntegratorKind::VelocityVerlet,
        IntegratorKind::Rk4,
        IntegratorKind::ImplicitEuler,
        IntegratorKind::ImplicitFactored,
    ];

    /// Name used in scenes and tables.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::SymplecticEuler => "symplectic_euler",
            IntegratorKind::VelocityVerlet => "velocity_verlet",
            IntegratorKind::Rk4 => "rk4",
            IntegratorKind::ImplicitEuler => "implicit_euler",
            IntegratorKind::ImplicitFactored => "implicit_factored",
        }
    }

    /// Parses [`IntegratorKind::name`]'s output.
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Theoretical order of global accuracy.
    pub fn order(self) -> u32 {
        match self {
            IntegratorKind::SymplecticEuler | IntegratorKind::ImplicitEuler | IntegratorKind::ImplicitFactored => 1,
            IntegratorKind::VelocityVerlet => 2,
            IntegratorKind::Rk4 => 4,
        }
    }

    /// Whether the scheme has a critical time step.
    pub fn is_explicit(self) -> bool {
        !matches!(self, IntegratorKind::ImplicitEuler | IntegratorKind::ImplicitFactored)
    }
}

impl fmt::Display for IntegratorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// How a frame step is cut into sub-steps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Substeps {
    /// As few as keep an explicit scheme below its critical step (1 for implicit).
    Auto,
    /// Exactly this many (1 to [`MAX_SUBSTEPS`](super::MAX_SUBSTEPS), 10,000), even above
    /// the critical step (for stability studies).
    Fixed(u32),
}

/// Solver settings. Every field has a unit and a default.
#[derive(Clone, Debug, PartialEq)]
pub struct IntegrationParameters {
    /// Frame step, s: what one call to `step()` advances. Default 1e-3 (1 kHz).
    pub dt: f64,
    /// Integration scheme. Default symplectic Euler.
    pub integrator: IntegratorKind,
    /// Sub-stepping. Default [`Substeps::Auto`].
    pub substeps: Substeps,
    /// Fraction of the critical step that automatic sub-steps use, in (0, 1]. Default 0.9.
    pub stability_safety: f64,
    /// Upper bound on automatic sub-steps per frame. Default 1000; at most
    /// [`MAX_SUBSTEPS`](super::MAX_SUBSTEPS) (10,000). When the critical step asks for
    /// more, the frame steps above it ([`Simulation::substeps_clamped`](super::Simulation::substeps_clamped)).
    pub max_substeps: u32,
    /// Conjugate-gradient stop: residual norm relative to the right-hand side. Default 1e-5.
    pub cg_tolerance: f64,
    /// Conjugate-gradient iteration cap per sub-step. Default 200; at most
    /// [`MAX_CG_ITERATIONS`](super::MAX_CG_ITERATIONS) (10,000).
    pub cg_max_iterations: u32,
    /// Precondition implicit Euler's conjugate gradients with the prefactored soft-phase
    /// matrix (`factored_preconditioner.rs`) instead of its diagonal. Default false.
    pub factored_preconditioner: bool,
    /// Conjugate-gradient iterations per step (`implicit_factored` only). Default 1; 1 to
    /// [`MAX_FACTORED_ITERATIONS`](super::MAX_FACTORED_ITERATIONS) (64).
    pub factored_iterations: u32,
    /// How the prefactored matrix's coefficients are stored (`implicit_factored`, and
    /// `implicit_euler` with `factored_preconditioner`). Default
    /// [`FactorStorage::Full`](super::FactorStorage::Full), in the simulation's precision;
    /// [`FactorStorage::Half`](super::FactorStorage::Half) streams half the bytes of f32.
    pub factor_storage: super::FactorStorage,
    /// Rayleigh mass-proportional damping α, 1/s (implicit Euler only). Default 0.
    pub rayleigh_alpha: f64,
    /// Rayleigh stiffness-proportional damping β, s (implicit Euler only). Default 0.
    pub rayleigh_beta: f64,
    /// Worker threads for the force pass (the caller is one). Default 1; at most
    /// [`MAX_THREADS`](super::MAX_THREADS) (256).
    pub threads: usize,
    /// Pin worker threads to CPUs. Default false.
    pub pin_workers: bool,
    /// Kernel instruction set. Default: the widest the CPU has.
    pub simd: SimdLevel,
    /// Runs of springs with identical parameters read one shared entry instead of a
    /// per-spring stream (bit-identical forces, less memory traffic). Default true; false
    /// (every spring streams its own parameters, in f32 packed to 6 bytes a spring when they
    /// pack within the bounds of `solver::spring_pack`) is for side-by-side benchmarks.
    pub share_run_parameters: bool,
    /// Multirate stepping (`implicit_factored` only): the region around the tool every frame,
    /// the rest of the model once per `ratio` frames on a thread of its own
    /// (`solver/multirate.rs`). Default `None`: every node every frame.
    pub multirate: Option<super::multirate_settings::MultirateSettings>,
}

impl Default for IntegrationParameters {
    fn default() -> Self {
        Self {
            dt: 1e-3,
            integrator: IntegratorKind::SymplecticEuler,
            substeps: Substeps::Auto,
            stability_safety: 0.9,
            max_substeps: 1000,
            cg_tolerance: 1e-5,
            cg_max_iterations: 200,
            factored_preconditioner: false,
            factored_iterations: 1,
            factor_storage: super::FactorStorage::Full,
            rayleigh_alpha: 0.0,
            rayleigh_beta: 0.0,
            threads: 1,
            pin_workers: false,
            simd: SimdLevel::detect(),
            share_run_parameters: true,
            multirate: None,
        }
    }
}

impl IntegrationParameters {
    /// Frame rate, Hz (`1 / dt`).
    pub fn rate_hz(&self) -> f64 {
        1.0 / self.dt
    }
}
