//! The hard cases: stiffness ratios of 10⁴, 10⁵ and 10⁶ between layers reached in the loaded
//! state, steps ten times the explicit limit (sub-stepped automatically, and taken as one fixed
//! step with and without the guard), pulls to three times rest length, zero-length and
//! inverted springs, coincident nodes, sudden large loads. Each must stay finite and bounded, and never hold
//! more energy than was put in. Every case runs with every integrator and with multirate
//! stepping ([`run_case_multirate`]).

use super::energy::EnergyLedger;
use crate::law::{Bilinear, SpringLaw};
use crate::model::Model;
use crate::scene::{BlockSpec, LayerMaterial, layered_block};
use crate::solver::{
    DragHandle, Effects, GuardSettings, IntegrationParameters, IntegratorKind, LateBuild, MultirateSettings, PointLoad,
    Simulation, SphereTool, Substeps,
};
use serde::Serialize;
use std::time::Instant;

/// A hard case: how to build it for an integrator, and how long to run it.
pub struct StabilityCase {
    /// Short name (also the test's name).
    pub name: &'static str,
    /// What makes it hard.
    pub description: &'static str,
    build: fn(IntegratorKind) -> (Model, IntegrationParameters, Effects),
    /// Frames to run.
    pub frames: usize,
}

impl StabilityCase {
    /// The case's model, step and effects for `integrator`, to run it outside the study.
    pub fn setup(&self, integrator: IntegratorKind) -> (Model, IntegrationParameters, Effects) {
        (self.build)(integrator)
    }
}

/// Outcome of one case with one integrator.
#[derive(Clone, Debug, Serialize)]
pub struct StabilityRow {
    /// Case name.
    pub case: &'static str,
    /// Integrator name.
    pub integrator: &'static str,
    /// Frames run.
    pub frames: usize,
    /// Sub-steps per frame chosen.
    pub substeps: u32,
    /// Sub-step over the integrator's own critical step (0 for implicit Euler).
    pub substep_over_critical: f64,
    /// Every state finite.
    pub finite: bool,
    /// Largest node displacement from rest, m.
    pub max_displacement_m: f64,
    /// Largest spring length over rest length.
    pub max_stretch_ratio: f64,
    /// In the final (loaded) state: the stiffest spring's tangent stiffness over the softest's
    /// (springs with a positive tangent), so a bilinear spring counts with `k2` only when it
    /// really is in its stiff phase.
    pub loaded_stiffness_ratio: f64,
    /// Bilinear springs beyond their turning length in the final state.
    pub stiff_phase_springs: usize,
    /// Largest energy excess `E(t) − W(t) − E(0)` relative to the energy scale.
    pub energy_excess: f64,
    /// Guard rollbacks.
    pub rollbacks: u64,
    /// Frames saved by more sub-steps.
    pub by_substeps: u64,
    /// Frames saved by implicit Euler.
    pub by_implicit: u64,
    /// Frames frozen.
    pub frozen: u64,
    /// Wall time of the run, s.
    pub wall_s: f64,
}

fn small_block(skin: LayerMaterial) -> Model {
    layered_block(&BlockSpec { nx: 10, nz: 6, skin, ..BlockSpec::default() })
}

fn top_centre(model: &Model) -> u32 {
    // The block's top row is the last nx·nz nodes; take the middle one.
    let top = model.nodes.len() - 60;
    (top + 3 * 10 + 5) as u32
}

fn base_effects() -> Effects {
    Effects {
        gravity: Some([0.0, -9.81, 0.0]),
        viscous_damping: Some(2.0),
        spring_damping: true,
        bone: true,
        guard: Some(GuardSettings::default()),
        ..Effects::default()
    }
}

fn params(integrator: IntegratorKind) -> IntegrationParameters {
    IntegrationParameters { integrator, ..IntegrationParameters::default() }
}

fn stiff_skin(ratio: f64) -> LayerMaterial {
    // Fat springs are 30 N/m (the default block); skin's stiff phase is `ratio` times that and
    // its first phase a tenth of it, turning at a strain of 1e-6 so that the handle's pull
    // puts the skin under it into the stiff phase: the ratio is reached in the loaded state.
    LayerMaterial::Bilinear { k1: 3.0 * ratio, k2: 30.0 * ratio, turn_strain: 1e-6, kc: None, damping: 0.02 }
}

fn with_pull(model: &Model, mut e: Effects, lift: f64, stiffness: f64) -> Effects {
    let node = top_centre(model);
    let p = model.nodes.position[node as usize];
    e.handles.push(DragHandle { node, target: [p[0], p[1] + lift, p[2]], stiffness, damping: 0.0 });
    e
}

fn ratio_case(ratio: f64) -> impl Fn(IntegratorKind) -> (Model, IntegrationParameters, Effects) {
    move |k| {
        let m = small_block(stiff_skin(ratio));
        let e = with_pull(&m, base_effects(), 0.01, 50.0);
        (m, params(k), e)
    }
}

/// The block pulled by a handle, one step per frame of 10 times the symplectic critical
/// step, with or without the guard.
fn fixed_step_10x(k: IntegratorKind, guard: bool) -> (Model, IntegrationParameters, Effects) {
    let m = small_block(BlockSpec::default().skin);
    let mut e = with_pull(&m, base_effects(), 0.01, 5.0);
    let probe =
        Simulation::<f64>::new(&m, params(IntegratorKind::SymplecticEuler), e.clone()).expect("the block is valid");
    let dt = 10.0 * probe.critical_step();
    if !guard {
        e.guard = None;
    }
    (m, IntegrationParameters { dt, substeps: Substeps::Fixed(1), ..params(k) }, e)
}

/// Every hard case.
pub fn stability_cases() -> Vec<StabilityCase> {
    vec![
        StabilityCase {
            name: "stiffness_ratio_1e4",
            description: "skin pulled by a handle into its stiff phase, 10^4 times stiffer than fat there",
            build: |k| ratio_case(1e4)(k),
            frames: 200,
        },
        StabilityCase {
            name: "stiffness_ratio_1e5",
            description: "skin pulled by a handle into its stiff phase, 10^5 times stiffer than fat there",
            build: |k| ratio_case(1e5)(k),
            frames: 100,
        },
        StabilityCase {
            name: "stiffness_ratio_1e6",
            description: "skin pulled by a handle into its stiff phase, 10^6 times stiffer than fat there",
            build: |k| ratio_case(1e6)(k),
            frames: 100,
        },
        StabilityCase {
            name: "step_10x_explicit_limit",
            description: "frames of 10x the symplectic critical step: explicit schemes sub-step automatically",
            build: |k| {
                let m = small_block(BlockSpec::default().skin);
                let e = with_pull(&m, base_effects(), 0.01, 5.0);
                let probe = Simulation::<f64>::new(&m, params(IntegratorKind::SymplecticEuler), e.clone())
                    .expect("the block is valid");
                let dt = 10.0 * probe.critical_step();
                (m, IntegrationParameters { dt, substeps: Substeps::Auto, ..params(k) }, e)
            },
            frames: 200,
        },
        StabilityCase {
            name: "fixed_step_10x_explicit_limit",
            description: "one step per frame at 10x the symplectic critical step (no automatic sub-steps), guard on: explicit steps fail and are caught",
            build: |k| fixed_step_10x(k, true),
            frames: 100,
        },
        StabilityCase {
            name: "fixed_step_10x_unguarded",
            description: "one step per frame at 10x the symplectic critical step, guard off: explicit schemes diverge, implicit ones do not",
            build: |k| fixed_step_10x(k, false),
            frames: 100,
        },
        StabilityCase {
            name: "pull_3x_rest_length",
            description: "a 300 N pull ramped in over 0.2 s on the top centre node: springs under it stretch past 3x rest",
            build: |k| {
                let m = small_block(BlockSpec::default().skin);
                let mut e = base_effects();
                e.loads.push(PointLoad { node: top_centre(&m), force: [0.0, 300.0, 0.0], ramp_s: 0.2 });
                (m, params(k), e)
            },
            frames: 400,
        },
        StabilityCase {
            name: "zero_length_and_inverted_springs",
            description: "zero-rest-length springs across the skin and the top row pushed below the next (inverted)",
            build: |k| {
                let mut m = small_block(BlockSpec::default().skin);
                let n = m.nodes.len();
                let top = n - 60;
                for i in 0..9 {
                    let (a, b) = ((top + i) as u32, (top + i + 1) as u32);
                    m.springs.push(a, b, 0.0, SpringLaw::Linear { stiffness: 50.0 }, 0.01, 3);
                }
                for i in top..n {
                    m.nodes.position[i][1] -= 0.015;
                }
                (m, params(k), base_effects())
            },
            frames: 300,
        },
        StabilityCase {
            name: "coincident_nodes",
            description: "pairs of connected nodes start at the same point (no spring direction)",
            build: |k| {
                let mut m = small_block(BlockSpec::default().skin);
                let top = m.nodes.len() - 60;
                for i in (0..9).step_by(2) {
                    m.nodes.position[top + i + 1] = m.nodes.position[top + i];
                }
                let law =
                    SpringLaw::Bilinear(Bilinear { k1: 400.0, k2: 4000.0, turn_length: 0.013, k_compression: 400.0 });
                m.springs.push(top as u32, (top + 20) as u32, 0.01, law, 0.02, 3);
                (m, params(k), base_effects())
            },
            frames: 300,
        },
        StabilityCase {
            name: "tool_through_skin",
            description: "a 5 mm sphere tool driven down at 0.1 m/s through the skin into the fat (3 cm travel)",
            build: |k| {
                let m = small_block(BlockSpec::default().skin);
                let p = m.nodes.position[top_centre(&m) as usize];
                let mut e = base_effects();
                e.tool = Some(SphereTool {
                    radius: 0.005,
                    stiffness: 300.0,
                    start: [p[0] + 0.002, p[1] + 0.006, p[2] + 0.002],
                    velocity: [0.0, -0.1, 0.0],
                });
                (m, params(k), e)
            },
            frames: 300,
        },
        StabilityCase {
            name: "sudden_large_load",
            description: "a 2 N step load (2000 g on a 1 g node) on the top centre node, no ramp",
            build: |k| {
                let m = small_block(BlockSpec::default().skin);
                let mut e = base_effects();
                e.loads.push(PointLoad { node: top_centre(&m), force: [0.0, -2.0, 0.0], ramp_s: 0.0 });
                (m, params(k), e)
            },
            frames: 300,
        },
    ]
}

/// Runs `case` with `integrator` in `f32` (the real-time precision).
pub fn run_case(case: &StabilityCase, integrator: IntegratorKind) -> StabilityRow {
    let (model, params, effects) = (case.build)(integrator);
    run_built(case, integrator.name(), &model, params, effects)
}

/// Name of the multirate rows.
pub const MULTIRATE_ROW: &str = "multirate";

/// The multirate region of the hard cases: 3 cm about the block's top centre (where every
/// case pulls, loads or presses; the region follows the tool of `tool_through_skin`), the
/// bulk one step per 8 frames.
pub fn multirate_settings(model: &Model) -> MultirateSettings {
    let centre = model.nodes.position[top_centre(model) as usize];
    MultirateSettings {
        centre,
        radius: 0.03,
        ratio: 8,
        follow_tool: true,
        build_exchanges: Some(4),
        late_build: LateBuild::Wait,
    }
}

/// Runs `case` with multirate stepping in `f32`: the region about the block's top centre
/// ([`multirate_settings`]) with `implicit_factored` at the case's step, the whole block
/// with it at 8 times that step on a thread of its own. The row's integrator is
/// [`MULTIRATE_ROW`]; sub-steps and the critical step are the region's.
pub fn run_case_multirate(case: &StabilityCase) -> StabilityRow {
    let (model, mut params, effects) = (case.build)(IntegratorKind::ImplicitFactored);
    params.multirate = Some(multirate_settings(&model));
    run_built(case, MULTIRATE_ROW, &model, params, effects)
}

fn run_built(
    case: &StabilityCase,
    integrator: &'static str,
    model: &Model,
    params: IntegrationParameters,
    effects: Effects,
) -> StabilityRow {
    let mut sim = Simulation::<f32>::new(model, params, effects).expect("hard cases are valid models");
    let mut ledger = EnergyLedger::new(model, &sim);
    let mut finite = true;
    let mut max_disp: f64 = 0.0;
    let mut max_stretch: f64 = 0.0;
    let start = Instant::now();
    for _ in 0..case.frames {
        sim.step();
        let s = sim.state();
        finite &= s.x.all_finite() && s.v.all_finite();
        ledger.record(model, &sim);
        for i in 0..model.nodes.len() {
            let (p, r) = (s.x.get_f64(i), model.nodes.position[i]);
            max_disp = max_disp.max(((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt());
        }
        let sp = &model.springs;
        for j in 0..sp.len() {
            if sp.rest_length[j] > 0.0 {
                let (a, b) = (s.x.get_f64(sp.a[j] as usize), s.x.get_f64(sp.b[j] as usize));
                let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
                max_stretch = max_stretch.max(l / sp.rest_length[j]);
            }
        }
    }
    let wall_s = start.elapsed().as_secs_f64();
    let (loaded_stiffness_ratio, stiff_phase_springs) = loaded_stiffness(model, &sim);
    let g = sim.guard_totals();
    StabilityRow {
        case: case.name,
        integrator,
        frames: case.frames,
        substeps: sim.substeps(),
        substep_over_critical: sim.params().dt / sim.substeps() as f64 / sim.critical_step(),
        finite,
        max_displacement_m: max_disp,
        max_stretch_ratio: max_stretch,
        loaded_stiffness_ratio,
        stiff_phase_springs,
        energy_excess: ledger.max_excess / ledger.scale.max(1e-12),
        rollbacks: g.rollbacks,
        by_substeps: g.by_substeps,
        by_implicit: g.by_implicit,
        frozen: g.frozen,
        wall_s,
    }
}

/// The stiffest over the softest positive spring tangent at `sim`'s state, and how many
/// bilinear springs are beyond their turning length.
fn loaded_stiffness(model: &Model, sim: &Simulation<f32>) -> (f64, usize) {
    let (mut stiffest, mut softest, mut stiff_phase) = (0.0f64, f64::INFINITY, 0);
    let sp = &model.springs;
    for j in 0..sp.len() {
        let (a, b) = (sim.state().x.get_f64(sp.a[j] as usize), sim.state().x.get_f64(sp.b[j] as usize));
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        let k = sp.law[j].tangent(l, sp.rest_length[j]);
        if k > 0.0 {
            stiffest = stiffest.max(k);
            softest = softest.min(k);
        }
        if let SpringLaw::Bilinear(b) = sp.law[j] {
            stiff_phase += usize::from(l > b.turn_length);
        }
    }
    (if softest.is_finite() { stiffest / softest } else { 0.0 }, stiff_phase)
}
