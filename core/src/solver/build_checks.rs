//! What [`Simulation::new`](super::Simulation::new) refuses before it allocates a step's
//! worth of anything: solver settings above their caps, a model that does not fit the
//! chosen precision, and a stiffest mode that is not finite.
//!
//! Each cap bounds the work of one frame, so a scene cannot make a step run for hours:
//! at most [`MAX_SUBSTEPS`] sub-steps, each with at most [`MAX_CG_ITERATIONS`] conjugate
//! gradient iterations (`implicit_factored`: at most [`MAX_FACTORED_ITERATIONS`] per step),
//! and the guard's retries at most [`MAX_GUARD_RETRIES`] doublings.

use super::build_error::SimulationBuildError;
use super::critical_step::StabilityEstimate;
use super::effects::Effects;
use super::params::{IntegrationParameters, IntegratorKind, Substeps};
use crate::model::{Model, ModelSize, RUN_MEMORY_FACTOR};
use crate::real::Real;

/// Largest number of sub-steps per frame: a fixed `substeps` or `max_substeps`. 10,000.
pub const MAX_SUBSTEPS: u32 = 10_000;
/// Largest `cg_max_iterations` (per sub-step of implicit Euler). 10,000.
pub const MAX_CG_ITERATIONS: u32 = 10_000;
/// Largest `factored_iterations` (PCG iterations per step of `implicit_factored`). 64.
pub const MAX_FACTORED_ITERATIONS: u32 = 64;
/// Largest number of guard retries, each doubling the sub-steps. 8 (256 times the
/// sub-steps at most).
pub const MAX_GUARD_RETRIES: u32 = 8;
/// Largest number of force-pass threads. 256.
pub const MAX_THREADS: usize = 256;

/// Refuses settings above their caps or outside their ranges.
pub(crate) fn check_params(params: &IntegrationParameters, effects: &Effects) -> Result<(), SimulationBuildError> {
    let cap = |parameter: &'static str, value: u64, cap: u64| {
        if value > cap { Err(SimulationBuildError::AboveCap { parameter, value, cap }) } else { Ok(()) }
    };
    if let Substeps::Fixed(n) = params.substeps {
        cap("substeps", u64::from(n), u64::from(MAX_SUBSTEPS))?;
    }
    cap("max_substeps", u64::from(params.max_substeps), u64::from(MAX_SUBSTEPS))?;
    cap("cg_max_iterations", u64::from(params.cg_max_iterations), u64::from(MAX_CG_ITERATIONS))?;
    cap("factored_iterations", u64::from(params.factored_iterations), u64::from(MAX_FACTORED_ITERATIONS))?;
    cap("threads", params.threads as u64, MAX_THREADS as u64)?;
    let at_least_one = |parameter: &'static str, value: u32| {
        if value == 0 {
            Err(SimulationBuildError::BadParameter { parameter, value: 0.0, expected: "at least 1" })
        } else {
            Ok(())
        }
    };
    at_least_one("max_substeps", params.max_substeps)?;
    at_least_one("cg_max_iterations", params.cg_max_iterations)?;
    at_least_one("factored_iterations", params.factored_iterations)?;
    at_least_one("threads", params.threads as u32)?;
    if let Some(g) = effects.guard {
        cap("guard.retries", u64::from(g.retries), u64::from(MAX_GUARD_RETRIES))?;
    }
    let range = |parameter: &'static str, value: f64, ok: bool, expected: &'static str| {
        if ok { Ok(()) } else { Err(SimulationBuildError::BadParameter { parameter, value, expected }) }
    };
    let s = params.stability_safety;
    range("stability_safety", s, s > 0.0 && s <= 1.0, "in (0, 1]")?;
    let t = params.cg_tolerance;
    range("cg_tolerance", t, t > 0.0 && t < 1.0, "in (0, 1)")?;
    for (parameter, value) in [("rayleigh_alpha", params.rayleigh_alpha), ("rayleigh_beta", params.rayleigh_beta)] {
        range(parameter, value, value >= 0.0 && value.is_finite(), "finite and >= 0")?;
    }
    Ok(())
}

/// Largest coordinate magnitude, m, whose squared distances stay finite in `T`:
/// `sqrt(T::MAX) / 16` (1.2e18 m in `f32`, 8.4e152 m in `f64`).
pub fn max_coordinate<T: Real>() -> f64 {
    let max = if T::NAME == "f32" { f64::from(f32::MAX) } else { f64::MAX };
    max.sqrt() / 16.0
}

/// Refuses a model whose positions, masses or stiffnesses do not survive rounding to `T`
/// (a coordinate beyond [`max_coordinate`], a mass that rounds to 0 or whose inverse
/// overflows, a stiffness that overflows).
pub(crate) fn check_precision<T: Real>(model: &Model) -> Result<(), SimulationBuildError> {
    let limit = max_coordinate::<T>();
    for (i, p) in model.nodes.position.iter().enumerate() {
        if p.iter().any(|c| c.is_nan() || c.abs() > limit) {
            return Err(SimulationBuildError::PositionOutOfRange {
                node: i as u32,
                position: *p,
                limit_m: limit,
                precision: T::NAME,
            });
        }
    }
    let fits = |v: f64| {
        let t = T::from_f64(v);
        t.is_finite() && (v == 0.0 || t.to_f64() != 0.0)
    };
    for (i, &m) in model.nodes.mass.iter().enumerate() {
        if !(fits(m) && fits(1.0 / m)) {
            return Err(SimulationBuildError::NotRepresentable {
                item: format!("node {i}: mass {m:e} kg"),
                precision: T::NAME,
            });
        }
    }
    for (i, law) in model.springs.law.iter().enumerate() {
        let k = law.max_stiffness();
        if !fits(k) {
            return Err(SimulationBuildError::NotRepresentable {
                item: format!("spring {i}: stiffness {k:e} N/m"),
                precision: T::NAME,
            });
        }
    }
    Ok(())
}

/// Refuses a model whose run would need more memory than is available: the solver's
/// layout, state, scratch and snapshot come to about [`RUN_MEMORY_FACTOR`] − 1 times the
/// model's own arrays.
pub(crate) fn check_memory(model: &Model) -> Result<(), SimulationBuildError> {
    let triangles = model.surfaces.iter().map(|s| s.triangles.len() as u64).sum();
    let size = ModelSize::counted(Some(model.nodes.len() as u64), Some(model.springs.len() as u64), Some(triangles));
    size.check(&format!("simulating model '{}'", model.name), RUN_MEMORY_FACTOR - 1)
        .map_err(SimulationBuildError::Memory)
}

/// Refuses a stiffest mode whose frequency or damping rate is not finite, or an explicit
/// critical step that is not a positive number: no step could follow such a model. The
/// error names the spring with the largest stiffness over its lighter node's mass.
pub(crate) fn check_stability(
    model: &Model,
    stability: &StabilityEstimate,
    integrator: IntegratorKind,
) -> Result<(), SimulationBuildError> {
    let h = stability.critical_step(integrator);
    let finite = stability.omega_max.is_finite() && stability.gamma_max.is_finite();
    if finite && h > 0.0 {
        return Ok(());
    }
    let s = &model.springs;
    let m = &model.nodes.mass;
    let stiffest = (0..s.len()).max_by(|&i, &j| {
        let ratio = |k: usize| s.law[k].max_stiffness() / m[s.a[k] as usize].min(m[s.b[k] as usize]);
        ratio(i).total_cmp(&ratio(j))
    });
    let culprit = stiffest.map(|i| {
        let (a, b) = (s.a[i] as usize, s.b[i] as usize);
        format!(
            "spring {i}: stiffness {:e} N/m between nodes {a} ({:e} kg) and {b} ({:e} kg)",
            s.law[i].max_stiffness(),
            m[a],
            m[b]
        )
    });
    Err(SimulationBuildError::NonFiniteStability {
        omega_max: stability.omega_max,
        gamma_max: stability.gamma_max,
        stiffest: culprit.unwrap_or_else(|| "no springs; a tool, handle or damping term".into()),
    })
}
