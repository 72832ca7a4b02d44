//! A model in motion: state, integrator, effects, guard.
//!
//! # How a frame goes
//! 1. the frame step `dt` is cut into sub-steps (automatic: below the explicit scheme's
//!    critical step); each sub-step evaluates loads and handles, spring forces (parallel,
//!    vectorised), per-node accelerations, and the integrator's update, then moves bone;
//! 2. with the guard on, the result is checked: a good state becomes the last good state
//!    (one copy); a bad frame is rolled back to the last good state and re-stepped with
//!    twice the sub-steps, then with implicit Euler, and frozen as a last resort; every
//!    rollback is listed in [`Simulation::quarantine`] for that frame.
//!
//! `step()` cannot fail and, with the guard on, never leaves a non-finite state.

use super::build_checks::{check_memory, check_params, check_precision, check_stability};
pub use super::build_error::SimulationBuildError;
use super::critical_step::StabilityEstimate;
use super::dynamics::{Dynamics, StageCounters, State};
use super::effects::Effects;
use super::guard::{GuardEvent, Recovery, inspect_state};
use super::implicit::ImplicitSolver;
use super::implicit_factored::ImplicitFactored;
use super::multirate::{
    FrameChanges, Multirate, MultirateStatus, RegionBuilder, Relocation, auto_build_exchanges, build_bulk,
    build_region, region_radius,
};
use super::multirate_settings::{
    DEFER_BUILD_EXCHANGES, LateBuild, MAX_BUILD_EXCHANGES, MAX_MULTIRATE_RATIO, MultirateSettings,
};
use super::params::{IntegrationParameters, IntegratorKind, Substeps};
use super::vec3s::Vec3s;
use crate::model::{Model, NodeKind};
use crate::real::Real;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

/// Totals of guard activity since the start.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GuardTotals {
    /// Frames rolled back.
    pub rollbacks: u64,
    /// Frames saved by more sub-steps.
    pub by_substeps: u64,
    /// Frames saved by implicit Euler.
    pub by_implicit: u64,
    /// Frames frozen.
    pub frozen: u64,
}

struct Rk4Scratch<T> {
    x0: Vec3s<T>,
    v0: Vec3s<T>,
    xs: Vec3s<T>,
    vs: Vec3s<T>,
    a: Vec3s<T>,
    sum_x: Vec3s<T>,
    sum_v: Vec3s<T>,
}

/// Velocity Verlet's carried acceleration.
struct VerletScratch<T> {
    /// Acceleration at the end of the last sub-step, m/s².
    a: Vec3s<T>,
    /// Predicted end-of-step velocity the end-of-step forces see, m/s.
    v_pred: Vec3s<T>,
    /// State time at which `a` holds; `None` once the state or the effects changed.
    valid_at: Option<f64>,
}

/// A model being simulated in precision `T`.
pub struct Simulation<T: Real> {
    params: IntegrationParameters,
    dynamics: Dynamics<T>,
    state: State<T>,
    snapshot: State<T>,
    rk4: Rk4Scratch<T>,
    verlet: VerletScratch<T>,
    implicit: ImplicitSolver<T>,
    /// Built when the integrator is [`IntegratorKind::ImplicitFactored`].
    factored: Option<ImplicitFactored<T>>,
    stability: StabilityEstimate,
    substeps: u32,
    /// Sub-steps the critical step asks for, before the `max_substeps` clamp.
    substeps_needed: u64,
    quarantine: Vec<GuardEvent>,
    totals: GuardTotals,
    /// The bulk's thread and the coupling, with multirate stepping.
    multirate: Option<Multirate<T>>,
    /// Springs cut so far ([`Simulation::cut_spring`]).
    cuts: u64,
    /// The builder of factors of the cut model ([`Simulation::prepare_cutting`]).
    refactor: Option<super::refactor::Refactor<T>>,
}

/// Why a simulation cannot be cut.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CutError {
    /// Only the real-time implicit integrator masks springs in its runs.
    #[error("cutting needs integrator implicit_factored, not {0}")]
    Integrator(IntegratorKind),
    /// The thread that factors the cut model did not start.
    #[error("the thread that factors the cut model did not start")]
    Thread,
}

/// The stiffest mode of `model` under `dynamics`' effects: the springs' (60 power
/// iterations), stiffened by the tool and drag handles (springs to a fixed point) and the skin's
/// volume springs.
fn stiffest_mode<T: Real>(model: &Model, dynamics: &Dynamics<T>) -> StabilityEstimate {
    let effects = &dynamics.effects;
    let mut stability = StabilityEstimate::of_model(
        model,
        effects.spring_damping,
        effects.viscous_damping.unwrap_or(0.0),
        effects.bone,
    );
    if let Some(tool) = effects.tool {
        let m = model.nodes.mass.iter().copied().fold(f64::INFINITY, f64::min);
        stability.omega_max = (stability.omega_max.powi(2) + tool.stiffness / m).sqrt();
    }
    for h in &effects.handles {
        let m = model.nodes.mass[h.node as usize];
        stability.omega_max = (stability.omega_max.powi(2) + h.stiffness / m).sqrt();
        stability.gamma_max += h.damping / m;
    }
    if let Some(k) = effects.skin_volume {
        let bound = dynamics.skin_volume.omega2_bound(model, k, effects.bone);
        stability.omega_max = (stability.omega_max.powi(2) + bound).sqrt();
    }
    stability
}

fn check_effects(model: &Model, effects: &Effects) -> Result<(), SimulationBuildError> {
    let n = model.nodes.len() as u32;
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    for l in &effects.loads {
        if l.node >= n {
            return Err(SimulationBuildError::NodeOutOfRange { effect: "load", node: l.node });
        }
        if !(finite(&l.force) && l.ramp_s >= 0.0 && l.ramp_s.is_finite()) {
            return Err(SimulationBuildError::BadEffectValue { effect: "load" });
        }
    }
    for h in &effects.handles {
        if h.node >= n {
            return Err(SimulationBuildError::NodeOutOfRange { effect: "handle", node: h.node });
        }
        if !(finite(&h.target)
            && h.stiffness >= 0.0
            && h.stiffness.is_finite()
            && h.damping >= 0.0
            && h.damping.is_finite())
        {
            return Err(SimulationBuildError::BadEffectValue { effect: "handle" });
        }
    }
    if effects.gravity.is_some_and(|g| !finite(&g)) {
        return Err(SimulationBuildError::BadEffectValue { effect: "gravity" });
    }
    if effects.viscous_damping.is_some_and(|a| !(a >= 0.0 && a.is_finite())) {
        return Err(SimulationBuildError::BadEffectValue { effect: "viscous_damping" });
    }
    if effects.bone_motion.is_some_and(|m| !(finite(&m.amplitude) && m.frequency_hz.is_finite())) {
        return Err(SimulationBuildError::BadEffectValue { effect: "bone_motion" });
    }
    if effects.bone_motion.is_some() && !(effects.bone && model.nodes.kind.contains(&NodeKind::Kinematic)) {
        return Err(SimulationBuildError::NothingToMove);
    }
    if effects.tool.is_some_and(|t| {
        !(t.radius > 0.0
            && t.radius.is_finite()
            && t.stiffness >= 0.0
            && t.stiffness.is_finite()
            && finite(&t.start)
            && finite(&t.velocity))
    }) {
        return Err(SimulationBuildError::BadEffectValue { effect: "tool" });
    }
    if effects.skin_volume.is_some_and(|k| !(k >= 0.0 && k.is_finite())) {
        return Err(SimulationBuildError::BadEffectValue { effect: "skin_volume" });
    }
    if effects.guard.is_some_and(|g| !(g.max_speed > 0.0 && g.max_displacement > 0.0)) {
        return Err(SimulationBuildError::BadEffectValue { effect: "guard" });
    }
    Ok(())
}

impl<T: Real> Simulation<T> {
    /// A simulation of `model` at rest. With [`IntegrationParameters::multirate`], this starts
    /// the bulk's thread (stopped when the simulation is dropped).
    pub fn new(model: &Model, params: IntegrationParameters, effects: Effects) -> Result<Self, SimulationBuildError> {
        match params.multirate {
            Some(settings) => Self::new_multirate(model, params, effects, settings),
            None => Self::new_single_rate(model, params, effects),
        }
    }

    /// The region's simulation (on the region's own model, its ring held) with the bulk's
    /// simulation (the whole model, `ratio` times the step) on a thread of its own.
    fn new_multirate(
        model: &Model,
        params: IntegrationParameters,
        effects: Effects,
        settings: MultirateSettings,
    ) -> Result<Self, SimulationBuildError> {
        let refuse = |why: String| Err(SimulationBuildError::Multirate(why));
        model.validate()?;
        if params.integrator != IntegratorKind::ImplicitFactored {
            return refuse(format!("needs integrator implicit_factored, not {}", params.integrator));
        }
        if !effects.bone {
            return refuse("holds the region's ring as bone: needs bone = true".into());
        }
        if !(settings.centre.iter().all(|c| c.is_finite()) && settings.radius > 0.0 && settings.radius.is_finite()) {
            return refuse(format!(
                "centre {:?} m and radius {:e} m must be finite, the radius positive",
                settings.centre, settings.radius
            ));
        }
        if !(2..=MAX_MULTIRATE_RATIO).contains(&settings.ratio) {
            return refuse(format!("ratio {} must be from 2 to {MAX_MULTIRATE_RATIO}", settings.ratio));
        }
        if let Some(k) = settings.build_exchanges.filter(|k| !(2..=MAX_BUILD_EXCHANGES).contains(k)) {
            return refuse(format!("build_exchanges {k} must be from 2 to {MAX_BUILD_EXCHANGES}"));
        }
        if effects.bone_motion.is_some() {
            // Measured on the default limb (2 mm at 1 Hz, ratio 8): the skin spanning both
            // halves lags, 0.76 mm from the single-rate solver's.
            return refuse(
                "moving bone drives the whole limb, which the bulk steps ratio times slower (the skin at the region's edge lags): remove bone_motion or multirate".into(),
            );
        }
        let region_params = IntegrationParameters { threads: 1, multirate: None, ..params.clone() };
        let bulk_params = IntegrationParameters {
            dt: params.dt * f64::from(settings.ratio),
            threads: params.threads.saturating_sub(1).max(1),
            multirate: None,
            ..params.clone()
        };
        let capacity = (effects.loads.capacity(), effects.handles.capacity());
        // A region that follows the tool starts wide enough for it.
        let first = match (settings.follow_tool, &effects.tool) {
            (true, Some(tool)) => MultirateSettings { radius: region_radius(settings.radius, tool.radius), ..settings },
            _ => settings,
        };
        let Relocation { layout, region: mut sim } =
            build_region::<T>(model, &region_params, &effects, &first, capacity, None, &[])?;
        let bulk_start = Instant::now();
        let bulk = build_bulk(model, &layout.partition, &bulk_params, &effects, capacity, None, &[])?;
        let build_exchanges = settings.build_exchanges.unwrap_or_else(|| match settings.late_build {
            // Taken as soon as it is built.
            LateBuild::Defer => DEFER_BUILD_EXCHANGES,
            LateBuild::Wait => auto_build_exchanges(bulk_start.elapsed(), params.dt, settings.ratio),
        });
        let settings = MultirateSettings { build_exchanges: Some(build_exchanges), ..settings };
        // Only a region that follows the tool needs the builder's copy of the model.
        let builder = settings
            .follow_tool
            .then(|| RegionBuilder::new(model, region_params, bulk_params, effects.clone(), settings, (&sim, &bulk)));
        // Pinned workers go from the first CPU up and the loop to the last: the bulk takes the first.
        let cpu =
            if params.pin_workers { core_affinity::get_core_ids().and_then(|c| c.first().copied()) } else { None };
        let mut coupling = Multirate::start(model, bulk, layout, builder, &settings, effects, cpu)
            .map_err(|e| SimulationBuildError::Multirate(format!("starting the bulk's thread: {e}")))?;
        // The bulk and the region start from the model at rest, as the whole state does.
        coupling.full.time = sim.state.time;
        sim.multirate = Some(coupling);
        sim.params = params;
        Ok(sim)
    }

    pub(super) fn new_single_rate(
        model: &Model,
        params: IntegrationParameters,
        effects: Effects,
    ) -> Result<Self, SimulationBuildError> {
        Self::new_single_rate_with(model, params, effects, None)
    }

    /// [`new_single_rate`](Self::new_single_rate), taking the stiffest mode's estimate as
    /// `known` when given (a region built about the tool reuses the first region's: the same
    /// tissue, and `implicit_factored` has no critical step) instead of 60 power iterations.
    pub(super) fn new_single_rate_with(
        model: &Model,
        params: IntegrationParameters,
        effects: Effects,
        known: Option<StabilityEstimate>,
    ) -> Result<Self, SimulationBuildError> {
        model.validate()?;
        check_effects(model, &effects)?;
        if !(params.dt.is_finite() && params.dt > 0.0) || params.substeps == Substeps::Fixed(0) {
            return Err(SimulationBuildError::BadStep);
        }
        check_params(&params, &effects)?;
        check_precision::<T>(model)?;
        check_memory(model)?;
        let dynamics = Dynamics::new(model, &params, effects);
        let stability = known.unwrap_or_else(|| stiffest_mode(model, &dynamics));
        check_stability(model, &stability, params.integrator)?;
        let n = model.nodes.len();
        let state = State { x: Vec3s::from_f64(&model.nodes.position), v: Vec3s::zeros(n), time: 0.0 };
        let z = || Vec3s::zeros(n);
        let rk4 = Rk4Scratch { x0: z(), v0: z(), xs: z(), vs: z(), a: z(), sum_x: z(), sum_v: z() };
        let implicit = ImplicitSolver::new(&dynamics);
        let verlet = VerletScratch { a: z(), v_pred: z(), valid_at: None };
        let mut sim = Self {
            snapshot: state.clone(),
            state,
            dynamics,
            rk4,
            verlet,
            implicit,
            factored: None,
            stability,
            substeps: 1,
            substeps_needed: 1,
            quarantine: Vec::with_capacity(8),
            totals: GuardTotals::default(),
            params,
            multirate: None,
            cuts: 0,
            refactor: None,
        };
        sim.substeps_needed = sim.substeps_needed(sim.params.integrator);
        sim.substeps = sim.substeps_needed.clamp(1, u64::from(sim.params.max_substeps.max(1))) as u32;
        if let Substeps::Fixed(n) = sim.params.substeps {
            sim.substeps = n;
        }
        if sim.params.integrator == IntegratorKind::ImplicitEuler && sim.params.factored_preconditioner {
            let h = sim.params.dt / sim.substeps as f64;
            let alpha = sim.params.rayleigh_alpha + sim.dynamics.effects.viscous_damping.unwrap_or(0.0);
            let (cm, cc, ck) = (1.0 + h * alpha, h, h * sim.params.rayleigh_beta + h * h);
            let pre = super::factored_preconditioner::FactoredPreconditioner::new(
                model,
                &sim.dynamics,
                cm,
                cc,
                ck,
                sim.params.simd,
                sim.params.factor_storage,
            )
            .map_err(SimulationBuildError::Factor)?;
            sim.implicit.factored = Some(pre);
            sim.dynamics.record_contacts = true;
            sim.dynamics.contacts.reserve_exact(super::dynamics::MAX_CONTACT_SAMPLES);
        }
        if sim.params.integrator == IntegratorKind::ImplicitFactored {
            let h = sim.params.dt / sim.substeps as f64;
            let p = &sim.params;
            let solver =
                ImplicitFactored::new(model, &sim.dynamics, h, p.factored_iterations, p.simd, p.factor_storage)
                    .map_err(SimulationBuildError::Factor)?;
            sim.factored = Some(solver);
            sim.dynamics.record_contacts = true;
            sim.dynamics.contacts.reserve_exact(super::dynamics::MAX_CONTACT_SAMPLES);
        }
        Ok(sim)
    }

    /// Sub-steps per frame that keep `integrator` below its critical step (saturating;
    /// 1 when the critical step is infinite), or the fixed count.
    fn substeps_needed(&self, integrator: IntegratorKind) -> u64 {
        match self.params.substeps {
            Substeps::Fixed(n) => u64::from(n.max(1)),
            Substeps::Auto => {
                let h = self.stability.critical_step(integrator) * self.params.stability_safety;
                if !h.is_finite() { 1 } else { ((self.params.dt / h).ceil() as u64).max(1) }
            }
        }
    }

    /// With automatic sub-steps, the number the critical step asks for when `max_substeps`
    /// cut it down (the frame then steps above the critical step and relies on the guard);
    /// `None` when nothing was clamped. `lamina run` prints it.
    pub fn substeps_clamped(&self) -> Option<u64> {
        (self.params.substeps == Substeps::Auto && self.substeps_needed > u64::from(self.substeps))
            .then_some(self.substeps_needed)
    }

    /// Current state.
    pub fn state(&self) -> &State<T> {
        match &self.multirate {
            Some(m) => &m.full,
            None => &self.state,
        }
    }

    /// Current state, to set initial conditions or (tests) to corrupt it. With multirate
    /// stepping, the region's nodes set here are taken into the next tick; the bulk's are
    /// overwritten by the bulk's state.
    pub fn state_mut(&mut self) -> &mut State<T> {
        self.verlet.valid_at = None;
        match &mut self.multirate {
            Some(m) => {
                m.frame_epoch = m.frame_epoch.wrapping_add(1);
                &mut m.full
            }
            None => &mut self.state,
        }
    }

    /// The equations of motion's right-hand side: accelerations at positions `x`, velocities
    /// `v` and time `t` under the effects in the loop, m/s², into `a` (0 on held nodes).
    /// For integrators outside the solver (the accuracy study's reference); the state is
    /// not touched.
    pub(crate) fn accelerations_into(&mut self, x: &Vec3s<T>, v: &Vec3s<T>, t: f64, a: &mut Vec3s<T>) {
        self.dynamics.accelerations_into(x, v, t, a);
    }

    /// Solver settings.
    pub fn params(&self) -> &IntegrationParameters {
        &self.params
    }

    /// The effects in the loop. Loads and handle targets may be changed between steps;
    /// the guard catches non-finite values put here. With multirate stepping, changes reach
    /// the region at the next tick and the bulk (tool, loads, handles) with its next step.
    pub fn effects_mut(&mut self) -> &mut Effects {
        self.verlet.valid_at = None;
        match &mut self.multirate {
            Some(m) => &mut m.effects,
            None => &mut self.dynamics.effects,
        }
    }

    /// The effects in the loop.
    pub fn effects(&self) -> &Effects {
        match &self.multirate {
            Some(m) => &m.effects,
            None => &self.dynamics.effects,
        }
    }

    /// Sub-steps per frame.
    pub fn substeps(&self) -> u32 {
        self.substeps
    }

    /// The stiffest mode's estimate.
    pub fn stability(&self) -> StabilityEstimate {
        self.stability
    }

    /// Critical step of the configured integrator, s.
    pub fn critical_step(&self) -> f64 {
        self.stability.critical_step(self.params.integrator)
    }

    /// Rollbacks of the last frame.
    pub fn quarantine(&self) -> &[GuardEvent] {
        &self.quarantine
    }

    /// Whether node `i` moves (false for fixed bone nodes and out-of-range indices).
    pub fn node_is_free(&self, i: usize) -> bool {
        match &self.multirate {
            Some(m) => m.node_is_free(i),
            None => self.dynamics.free.get(i).is_some_and(|f| *f != T::ZERO),
        }
    }

    /// What the tool felt at the last force evaluation (zero when no tool is on).
    pub fn tool_feedback(&self) -> crate::solver::ToolFeedback {
        self.dynamics.tool_feedback
    }

    /// Guard totals since the start.
    pub fn guard_totals(&self) -> GuardTotals {
        self.totals
    }

    /// Per-stage time since the last [`Simulation::reset_counters`].
    pub fn counters(&self) -> &StageCounters {
        &self.dynamics.counters
    }

    /// Zeroes the per-stage timers.
    pub fn reset_counters(&mut self) {
        self.dynamics.counters = StageCounters::default();
    }

    /// The real-time implicit integrator, when it is the integrator.
    pub fn implicit_factored(&self) -> Option<&ImplicitFactored<T>> {
        self.factored.as_ref()
    }

    /// With multirate stepping, which nodes of [`state`](Self::state) the next ticks move:
    /// while the epoch stays, only the region's (a publisher then rewrites only those, see
    /// `lamina_bridge::NodesPublisher::publish_finite_xyz_changed`). `None` single-rate,
    /// where every step moves every free node.
    pub fn frame_changes(&self) -> Option<FrameChanges<'_>> {
        self.multirate.as_ref().map(Multirate::frame_changes)
    }

    /// With multirate stepping, the region's and the bulk's sizes and the bulk thread's counts.
    pub fn multirate_status(&self) -> Option<MultirateStatus> {
        self.multirate.as_ref().map(Multirate::status)
    }

    /// CG iterations and relative residual of the last implicit solve.
    pub fn last_cg(&self) -> (u32, f64) {
        (self.implicit.last_iterations, self.implicit.last_residual)
    }

    /// Whether springs can be cut ([`Simulation::cut_spring`]): `implicit_factored`,
    /// single-rate or multirate.
    ///
    /// # Errors
    /// [`CutError`] names what stands in the way.
    pub fn can_cut(&self) -> Result<(), CutError> {
        match self.factored {
            Some(_) => Ok(()),
            None => Err(CutError::Integrator(self.params.integrator)),
        }
    }

    /// Cuts model spring `spring` (file order): from the next step on it has no force and
    /// no stiffness, and the skin tetrahedra with both its nodes lose their volume term.
    /// Returns whether the spring was cut now (false: cut before, between two held nodes,
    /// out of range, or [`Simulation::can_cut`] refuses). The factored preconditioner keeps
    /// its matrix: it stays a valid, stiffer preconditioner of the cut system. Allocates
    /// nothing.
    pub fn cut_spring(&mut self, spring: usize) -> bool {
        if let Some(m) = &mut self.multirate {
            // A model spring: logged for the bulk (at the next exchange) and for regions
            // built later, and cut in the region now when the region holds it.
            let Some(local) = m.record_cut(spring) else { return false };
            if let Some(local) = local {
                self.cut_own_spring(local);
            }
            self.cuts += 1;
            return true;
        }
        if !self.cut_own_spring(spring) {
            return false;
        }
        if let Some(r) = &mut self.refactor {
            r.record(spring);
        }
        self.cuts += 1;
        true
    }

    /// Cuts spring `spring` of this simulation's own model (the region's, with multirate):
    /// its lanes masked, the skin tetrahedra on its edge without their volume term. Returns
    /// whether it was cut now. Allocates nothing.
    pub(super) fn cut_own_spring(&mut self, spring: usize) -> bool {
        let Some(solver) = &mut self.factored else { return false };
        let Some([a, b]) = solver.cut_spring(spring) else { return false };
        self.dynamics.skin_volume.remove_tets_with_edge(a, b);
        self.verlet.valid_at = None;
        true
    }

    /// Cuts `springs` of this simulation's own `model` (the model it was built from) and
    /// factors the cut model's matrix in place of the first factor: a simulation built off
    /// the loop for a model cut before (a multirate region or bulk). Allocates; call it off
    /// the loop.
    pub(super) fn cut_and_refactor(&mut self, model: &Model, springs: &[usize]) -> Result<(), SimulationBuildError> {
        let mut cut_model = model.clone();
        let mut any = false;
        for &s in springs {
            if self.cut_own_spring(s) {
                cut_model.springs.law[s] = crate::law::SpringLaw::Linear { stiffness: 0.0 };
                cut_model.springs.damping[s] = 0.0;
                any = true;
            }
        }
        let Some(solver) = &mut self.factored else { return Ok(()) };
        if !any {
            return Ok(());
        }
        let (cm, cc, ck) = solver.preconditioner_coefficients(self.dynamics.effects.viscous_damping.unwrap_or(0.0));
        let inputs = super::factored_preconditioner::PreconditionerInputs::of(&self.dynamics);
        let mut pre = super::factored_preconditioner::FactoredPreconditioner::from_inputs(
            &cut_model,
            &inputs,
            cm,
            cc,
            ck,
            self.params.simd,
            self.params.factor_storage,
        )
        .map_err(SimulationBuildError::Factor)?;
        solver.swap_preconditioner(&mut pre);
        Ok(())
    }

    /// Starts the thread that factors the cut model's matrix off the loop for `model` (the
    /// model this simulation was built from), taken as `swap` says. Without it a cut keeps the
    /// first factor as the preconditioner for good. Call it before the loop: it spawns a
    /// thread and copies the model.
    ///
    /// # Errors
    /// [`CutError`] when the simulation cannot be cut or the thread does not start.
    ///
    /// With multirate stepping this starts nothing: after a cut the region and the bulk are
    /// built again off the loop, factored without the cut springs, and taken like a region
    /// that follows the tool ([`MultirateSettings::follow_tool`] on; off, the first factors
    /// stay).
    pub fn prepare_cutting(&mut self, model: &Model, swap: super::refactor::FactorSwap) -> Result<(), CutError> {
        self.can_cut()?;
        if self.multirate.is_some() {
            return Ok(());
        }
        let Some(solver) = &self.factored else { return Err(CutError::Integrator(self.params.integrator)) };
        let (cm, cc, ck) = solver.preconditioner_coefficients(self.dynamics.effects.viscous_damping.unwrap_or(0.0));
        let recipe =
            super::refactor::FactorRecipe { cm, cc, ck, simd: self.params.simd, storage: self.params.factor_storage };
        let inputs = super::factored_preconditioner::PreconditionerInputs::of(&self.dynamics);
        let refactor = super::refactor::Refactor::start(model, inputs, recipe, swap).map_err(|_| CutError::Thread)?;
        self.refactor = Some(refactor);
        Ok(())
    }

    /// What the off-loop factor builds have done (`None` without [`Simulation::prepare_cutting`]).
    pub fn refactor_status(&self) -> Option<super::refactor::RefactorStatus> {
        self.refactor.as_ref().map(|r| r.status())
    }

    /// With multirate stepping, where the region follows while no sphere tool is on (m): a
    /// scalpel cutting sets its tip here. `None`, or single-rate: nothing.
    pub fn set_focus(&mut self, point: Option<[f64; 3]>) {
        if let Some(m) = &mut self.multirate {
            m.set_focus(point);
        }
    }

    /// Springs cut so far.
    pub fn cuts(&self) -> u64 {
        self.cuts
    }

    /// Rest positions, m.
    pub fn rest_positions(&self) -> &Vec3s<T> {
        match &self.multirate {
            Some(m) => &m.full_rest,
            None => &self.dynamics.rest,
        }
    }

    /// Advances one frame of `params.dt` seconds.
    ///
    /// With the guard on, a frame that ends in a bad state is re-stepped from the last good
    /// state (the end of the last good frame, so state corrupted between frames is caught
    /// too): twice the sub-steps (up to `retries` times), then implicit Euler, and as a last
    /// resort the last good state is kept with velocities zeroed.
    pub fn step(&mut self) {
        self.step_inner(None);
    }

    /// [`step`](Self::step), checking `stop` between sub-steps (one relaxed load each):
    /// once it reads `true` the frame ends after the sub-step under way, so a frame of many
    /// sub-steps stops within one sub-step's work. Returns `false` when `stop` cut the frame
    /// short: the state is then that of the last completed sub-step (with the guard on, the
    /// last good state if that one is bad). The flag is the caller's, e.g. set by a signal
    /// handler; the simulation never clears it.
    ///
    /// ```
    /// use std::sync::atomic::AtomicBool;
    /// use lamina_core::scene::Scene;
    /// use lamina_core::solver::{IntegrationParameters, IntegratorKind, Simulation};
    ///
    /// let scene = Scene::builtin_default();
    /// let model = scene.build_model()?;
    /// // Symplectic Euler takes several sub-steps per frame on this model.
    /// let params = IntegrationParameters { integrator: IntegratorKind::SymplecticEuler, ..scene.solver.clone() };
    /// let mut sim = Simulation::<f32>::new(&model, params, scene.effects.clone())?;
    /// assert!(sim.step_or_stop(&AtomicBool::new(false)));
    /// let t = sim.state().time;
    /// assert!(!sim.step_or_stop(&AtomicBool::new(true))); // stopped after one sub-step
    /// assert!(sim.state().time - t < scene.solver.dt);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    pub fn step_or_stop(&mut self, stop: &AtomicBool) -> bool {
        self.step_inner(Some(stop))
    }

    fn step_inner(&mut self, stop: Option<&AtomicBool>) -> bool {
        if let (Some(r), Some(solver)) = (&mut self.refactor, &mut self.factored) {
            r.tick(solver);
        }
        let Some(mut m) = self.multirate.take() else { return self.step_frame(stop) };
        m.take_region_nodes(&mut self.state);
        if m.exchange_due() {
            let mut retired = m.receive(&mut self.state);
            if let Some(relocation) = retired.as_mut() {
                // The region moved with the tool: this simulation takes the new region's
                // parts, `relocation` the old ones, dropped on the bulk's thread.
                self.swap_region(&mut relocation.region);
                m.adopt(relocation, &mut self.state);
                // The region was built with the cuts made when it was asked for; the ones
                // made since are cut in it now.
                for local in m.cuts_since_build() {
                    self.cut_own_spring(local);
                }
                self.snapshot.copy_from(&self.state);
            }
            m.send(&self.state, retired);
        }
        m.end_tick();
        m.region_effects(&mut self.dynamics.effects);
        self.multirate = Some(m);
        let completed = self.step_frame(stop);
        if let Some(m) = &mut self.multirate {
            m.after_tick(&self.state);
            for e in &mut self.quarantine {
                e.node = m.model_index(e.node);
            }
        }
        completed
    }

    /// Takes `other`'s state and guard snapshot (a simulation of the same nodes): a bulk built
    /// for a new region goes on from the bulk it replaces. Allocates nothing.
    pub(super) fn take_state_of(&mut self, other: &Self) {
        self.state.copy_from(&other.state);
        self.snapshot.copy_from(&other.snapshot);
        self.verlet.valid_at = None;
    }

    /// Swaps the region's simulation parts (model, state, solver) with `other`'s; the
    /// settings, guard totals, stage timers and coupling stay. Moves, allocates nothing.
    fn swap_region(&mut self, other: &mut Self) {
        std::mem::swap(&mut self.dynamics, &mut other.dynamics);
        std::mem::swap(&mut self.dynamics.counters, &mut other.dynamics.counters);
        std::mem::swap(&mut self.state, &mut other.state);
        std::mem::swap(&mut self.snapshot, &mut other.snapshot);
        std::mem::swap(&mut self.rk4, &mut other.rk4);
        std::mem::swap(&mut self.verlet, &mut other.verlet);
        std::mem::swap(&mut self.implicit, &mut other.implicit);
        std::mem::swap(&mut self.factored, &mut other.factored);
        std::mem::swap(&mut self.stability, &mut other.stability);
        std::mem::swap(&mut self.substeps, &mut other.substeps);
        std::mem::swap(&mut self.substeps_needed, &mut other.substeps_needed);
    }

    /// One frame of the simulation's own model, under the guard.
    fn step_frame(&mut self, stop: Option<&AtomicBool>) -> bool {
        self.quarantine.clear();
        let completed = self.advance(self.params.integrator, self.substeps, stop);
        self.dynamics.counters.frames += 1;
        let Some(settings) = self.dynamics.effects.guard else { return completed };
        if !completed {
            return self.stopped_in_frame(&settings);
        }
        let t = Instant::now();
        let Some((reason, node)) = inspect_state(&self.state, &self.dynamics.rest, &settings) else {
            self.snapshot.copy_from(&self.state);
            self.dynamics.counters.guard += t.elapsed();
            return true;
        };
        self.totals.rollbacks += 1;
        let time = self.snapshot.time;
        let mut recovery = Recovery::Frozen;
        if self.params.integrator.is_explicit() {
            let mut n = self.substeps;
            for _ in 0..settings.retries {
                n = n.saturating_mul(2);
                self.verlet.valid_at = None;
                self.state.copy_from(&self.snapshot);
                if !self.advance(self.params.integrator, n, stop) {
                    return self.stopped_in_frame(&settings);
                }
                if inspect_state(&self.state, &self.dynamics.rest, &settings).is_none() {
                    recovery = Recovery::Substeps(n);
                    break;
                }
            }
        }
        // The fallback's implicit Euler streams the springs as built, cut ones included: after
        // a cut the frame is frozen instead.
        if recovery == Recovery::Frozen && self.cuts == 0 {
            self.verlet.valid_at = None;
            self.state.copy_from(&self.snapshot);
            if !self.advance(IntegratorKind::ImplicitEuler, 1, stop) {
                return self.stopped_in_frame(&settings);
            }
            if inspect_state(&self.state, &self.dynamics.rest, &settings).is_none() {
                recovery = Recovery::Implicit;
            }
        }
        match recovery {
            Recovery::Substeps(_) => self.totals.by_substeps += 1,
            Recovery::Implicit => self.totals.by_implicit += 1,
            Recovery::Frozen => {
                self.verlet.valid_at = None;
                self.state.copy_from(&self.snapshot);
                self.state.v.fill_zero();
                self.state.time += self.params.dt;
                self.totals.frozen += 1;
            }
        }
        self.snapshot.copy_from(&self.state);
        if self.quarantine.len() < self.quarantine.capacity() {
            self.quarantine.push(GuardEvent { time, reason, node, recovery });
        }
        self.dynamics.counters.guard += t.elapsed();
        true
    }

    /// A frame stopped part-way: keeps the state if it is good, else the last good one.
    fn stopped_in_frame(&mut self, settings: &super::effects::GuardSettings) -> bool {
        if inspect_state(&self.state, &self.dynamics.rest, settings).is_some() {
            self.verlet.valid_at = None;
            self.state.copy_from(&self.snapshot);
        }
        false
    }

    /// Runs `substeps` sub-steps of `integrator`; `false` when `stop` ended it early.
    fn advance(&mut self, integrator: IntegratorKind, substeps: u32, stop: Option<&AtomicBool>) -> bool {
        let h = self.params.dt / substeps as f64;
        let start_time = self.state.time;
        for k in 0..substeps {
            if k > 0 && stop.is_some_and(|f| f.load(Ordering::Relaxed)) {
                return false;
            }
            match integrator {
                IntegratorKind::SymplecticEuler => self.dynamics.symplectic_substep(&mut self.state, h),
                IntegratorKind::VelocityVerlet => self.verlet_substep(h, start_time + h * (k + 1) as f64),
                IntegratorKind::Rk4 => self.rk4_substep(h),
                IntegratorKind::ImplicitEuler => {
                    self.implicit.substep(&mut self.dynamics, &self.params, &mut self.state, h)
                }
                IntegratorKind::ImplicitFactored => match &mut self.factored {
                    Some(solver) if solver.step_size() == h => {
                        self.dynamics.move_bone(&mut self.state, start_time + h * (k + 1) as f64);
                        solver.step(&mut self.dynamics, &mut self.state)
                    }
                    _ => self.implicit.substep(&mut self.dynamics, &self.params, &mut self.state, h),
                },
            }
            self.state.time = start_time + h * (k + 1) as f64;
            let now = self.state.time;
            self.dynamics.move_bone(&mut self.state, now);
            self.dynamics.counters.substeps += 1;
        }
        if integrator != IntegratorKind::VelocityVerlet {
            self.verlet.valid_at = None;
        }
        true
    }

    /// One velocity Verlet sub-step of `h` seconds ending at time `t1`.
    fn verlet_substep(&mut self, h: f64, t1: f64) {
        let s = &mut self.verlet;
        if s.valid_at != Some(self.state.time) {
            self.dynamics.accelerations_into(&self.state.x, &self.state.v, self.state.time, &mut s.a);
        }
        let (half, ht) = (T::from_f64(0.5 * h), T::from_f64(h));
        // Kick half a step, drift a whole one.
        for ((x, v), a) in self.state.x.slices_mut().into_iter().zip(self.state.v.slices_mut()).zip(s.a.slices()) {
            for i in 0..x.len() {
                v[i] += half * a[i];
                x[i] += ht * v[i];
            }
        }
        self.dynamics.move_bone(&mut self.state, t1);
        // The velocity the end-of-step forces see: v₀ + h a₀, within O(h²) of the end velocity
        // (half a kick short would leave damping first order).
        for ((p, v), a) in s.v_pred.slices_mut().into_iter().zip(self.state.v.slices()).zip(s.a.slices()) {
            for i in 0..p.len() {
                p[i] = v[i] + half * a[i];
            }
        }
        self.dynamics.accelerations_into(&self.state.x, &s.v_pred, t1, &mut s.a);
        for (v, a) in self.state.v.slices_mut().into_iter().zip(s.a.slices()) {
            for i in 0..v.len() {
                v[i] += half * a[i];
            }
        }
        s.valid_at = Some(t1);
    }

    fn rk4_substep(&mut self, h: f64) {
        let s = &mut self.rk4;
        let t0 = self.state.time;
        s.x0.copy_from(&self.state.x);
        s.v0.copy_from(&self.state.v);
        s.sum_x.fill_zero();
        s.sum_v.fill_zero();
        let stages = [(0.0, 1.0), (0.5, 2.0), (0.5, 2.0), (1.0, 1.0)];
        for (k, &(c, w)) in stages.iter().enumerate() {
            // Stage state: x0 + c h kx, v0 + c h kv (stage 0 is the start itself).
            if k == 0 {
                s.xs.copy_from(&s.x0);
                s.vs.copy_from(&s.v0);
            } else {
                let ch = T::from_f64(c * h);
                for (dst, (base, slope)) in [
                    (&mut s.xs.x, (&s.x0.x, &s.vs.x)),
                    (&mut s.xs.y, (&s.x0.y, &s.vs.y)),
                    (&mut s.xs.z, (&s.x0.z, &s.vs.z)),
                ] {
                    for i in 0..dst.len() {
                        dst[i] = base[i] + ch * slope[i];
                    }
                }
                for (dst, (base, slope)) in [
                    (&mut s.vs.x, (&s.v0.x, &s.a.x)),
                    (&mut s.vs.y, (&s.v0.y, &s.a.y)),
                    (&mut s.vs.z, (&s.v0.z, &s.a.z)),
                ] {
                    for i in 0..dst.len() {
                        dst[i] = base[i] + ch * slope[i];
                    }
                }
            }
            self.dynamics.accelerations_into(&s.xs, &s.vs, t0 + c * h, &mut s.a);
            let w = T::from_f64(w);
            for (acc, add) in [(&mut s.sum_x.x, &s.vs.x), (&mut s.sum_x.y, &s.vs.y), (&mut s.sum_x.z, &s.vs.z)] {
                for i in 0..acc.len() {
                    acc[i] += w * add[i];
                }
            }
            for (acc, add) in [(&mut s.sum_v.x, &s.a.x), (&mut s.sum_v.y, &s.a.y), (&mut s.sum_v.z, &s.a.z)] {
                for i in 0..acc.len() {
                    acc[i] += w * add[i];
                }
            }
        }
        let h6 = T::from_f64(h / 6.0);
        let free = &self.dynamics.free;
        for (dst, (base, sum)) in [
            (&mut self.state.x.x, (&s.x0.x, &s.sum_x.x)),
            (&mut self.state.x.y, (&s.x0.y, &s.sum_x.y)),
            (&mut self.state.x.z, (&s.x0.z, &s.sum_x.z)),
        ] {
            for i in 0..dst.len() {
                dst[i] = base[i] + free[i] * h6 * sum[i];
            }
        }
        for (dst, (base, sum)) in [
            (&mut self.state.v.x, (&s.v0.x, &s.sum_v.x)),
            (&mut self.state.v.y, (&s.v0.y, &s.sum_v.y)),
            (&mut self.state.v.z, (&s.v0.z, &s.sum_v.z)),
        ] {
            for i in 0..dst.len() {
                dst[i] = base[i] + h6 * sum[i];
            }
        }
    }
}
