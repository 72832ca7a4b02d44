//! The real-time implicit solver (`implicit_factored`) against closed forms and against the
//! converged explicit solver.

mod common;

use lamina_core::law::{Bilinear, SpringLaw};
use lamina_core::model::{Layer, Model, NodeKind, Tissue};
use lamina_core::real::Real;
use lamina_core::scene::Scene;
use lamina_core::solver::{Effects, FactorStorage, IntegrationParameters, IntegratorKind, Simulation};

fn hanging_chain(n: usize, law: SpringLaw, m: f64, l0: f64) -> Model {
    let mut model = Model::default();
    model.layers.push(Layer { name: "chain".into(), tissue: Tissue::Other });
    model.nodes.push([0.0, 0.0, 0.0], m, NodeKind::Fixed, 0);
    for i in 1..=n {
        model.nodes.push([0.0, -(i as f64) * l0, 0.0], m, NodeKind::Free, 0);
        model.springs.push((i - 1) as u32, i as u32, l0, law, 0.0, 0);
    }
    model
}

fn settle(model: &Model, frames: usize) -> Simulation<f64> {
    let params = IntegrationParameters { integrator: IntegratorKind::ImplicitFactored, ..Default::default() };
    let effects =
        Effects { gravity: Some([0.0, -9.81, 0.0]), viscous_damping: Some(20.0), bone: true, ..Default::default() };
    let mut sim = Simulation::<f64>::new(model, params, effects).unwrap();
    assert_eq!(sim.substeps(), 1, "one step per 1 ms frame");
    for _ in 0..frames {
        sim.step();
    }
    sim
}

#[test]
fn implicit_factored_linear_chain_reaches_the_static_sag_works() {
    // Spring i (from the top) carries the weight of the n − i + 1 masses below it.
    let (n, k, m, l0, g) = (8usize, 50.0, 0.01, 0.01, 9.81);
    let sim = settle(&hanging_chain(n, SpringLaw::Linear { stiffness: k }, m, l0), 5000);
    let mut expected = 0.0;
    for i in 1..=n {
        expected -= l0 + (n - i + 1) as f64 * m * g / k;
        let y = sim.state().x.get_f64(i)[1];
        assert!((y - expected).abs() < 1e-9, "node {i}: y {y}, closed form {expected}");
    }
}

#[test]
fn implicit_factored_bilinear_chain_reaches_the_static_sag_in_both_phases_works() {
    // Springs stiffen 40x past a stretch of 2 mm: the upper springs (more weight) end in
    // their second phase, the lower ones in their first. The preconditioner holds only the
    // first phase, so this is the case where it is furthest from the tangent.
    let (n, m, l0, g) = (8usize, 0.01, 0.01, 9.81);
    let law = Bilinear { k1: 50.0, k2: 2000.0, turn_length: l0 + 0.002, k_compression: 80.0 };
    let sim = settle(&hanging_chain(n, SpringLaw::Bilinear(law), m, l0), 20000);
    let mut expected = 0.0;
    let mut stiff = 0;
    for i in 1..=n {
        let f = (n - i + 1) as f64 * m * g;
        let stretch = if f <= law.k1 * 0.002 {
            f / law.k1
        } else {
            stiff += 1;
            0.002 + (f - law.k1 * 0.002) / law.k2
        };
        expected -= l0 + stretch;
        let y = sim.state().x.get_f64(i)[1];
        assert!((y - expected).abs() < 1e-7, "node {i}: y {y}, closed form {expected}");
    }
    assert!(stiff >= 2 && stiff < n, "both phases are reached ({stiff} stiff springs)");
}

/// The built-in default scene with its tool held at the device origin, stepped by
/// `integrator` on `threads` threads; returns the simulation and the origin, m.
fn default_scene_with_tool<T: Real>(integrator: IntegratorKind, threads: usize) -> (Simulation<T>, [f64; 3]) {
    common::limb_with_tool(Scene::builtin_default(), |params, _| {
        params.integrator = integrator;
        params.threads = threads;
    })
}

/// Presses the built-in default scene's tool 8 mm into the skin over 0.5 s, holds it to
/// 2 s, and returns the vertical force on the tool, N; the factor stored as `storage` asks.
fn press_force(integrator: IntegratorKind, storage: FactorStorage) -> f64 {
    let (mut sim, origin) = common::limb_with_tool::<f32>(Scene::builtin_default(), |params, _| {
        params.integrator = integrator;
        params.factor_storage = storage;
    });
    for frame in 0..2000 {
        let depth = 0.008 * (frame as f64 / 500.0).min(1.0);
        sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2]];
        sim.step();
    }
    assert_eq!(sim.guard_totals().rollbacks, 0);
    sim.tool_feedback().force[1]
}

#[test]
fn implicit_factored_press_force_matches_the_explicit_solver_works() {
    let explicit = press_force(IntegratorKind::SymplecticEuler, FactorStorage::Full);
    assert!(explicit > 0.05, "the tool presses ({explicit} N)");
    // The factor in f32 and in binary16: the preconditioner's rounding leaves the force where
    // the explicit solver puts it.
    for storage in [FactorStorage::Full, FactorStorage::Half] {
        let factored = press_force(IntegratorKind::ImplicitFactored, storage);
        assert!(
            (factored - explicit).abs() <= 0.05 * explicit,
            "implicit_factored ({storage:?} factor) {factored} N, symplectic Euler {explicit} N"
        );
    }
}

#[test]
fn implicit_factored_on_two_threads_splits_its_sweeps_and_agrees_with_one_works() {
    // The default limb pressed 6 mm over 200 ms, in f64: on two threads the preconditioner's
    // factor is ordered in two halves and a separator (a different ordering, so different
    // round-off), on one thread by minimum degree alone. Same matrix, same steps.
    let run = |threads: usize| {
        let (mut sim, origin) = default_scene_with_tool::<f64>(IntegratorKind::ImplicitFactored, threads);
        for frame in 0..200 {
            let depth = 0.006 * (frame as f64 / 200.0);
            sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2]];
            sim.step();
        }
        let sweeps = sim.implicit_factored().unwrap().preconditioner_threads();
        (sweeps, sim.state().x.clone(), sim.tool_feedback().force[1])
    };
    let (one_sweeps, one, one_force) = run(1);
    let (two_sweeps, two, two_force) = run(2);
    assert_eq!((one_sweeps, two_sweeps), (1, 2));
    assert!(one_force > 0.01, "the tool presses ({one_force} N)");
    let worst = (0..one.len())
        .map(|i| {
            let (a, b) = (one.get_f64(i), two.get_f64(i));
            (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "positions differ by {worst:e} m");
    assert!((one_force - two_force).abs() < 1e-6 * one_force, "{one_force} N against {two_force} N");
}
