//! The guard: nothing non-finite ever leaves a step, and bad frames are recorded.

use lamina_core::scene::Scene;
use lamina_core::solver::{GuardReason, PointLoad, Recovery, Simulation};

/// The layered block scene: its springs stay in the phase that sets the critical step, so a
/// step several times that step really is unstable (the limb's skin springs work in their soft
/// phase, 157 times below the stiff one the critical step is computed from).
fn block_scene() -> Scene {
    Scene::load(std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../config/scenes/block.toml"))).unwrap()
}

#[test]
fn guard_nan_load_never_leaves_a_step_works() {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let mut effects = scene.effects.clone();
    // Node 78: the outer skin at mid-length, top (row 3, column 6 of the 24 x 6 grid).
    effects.loads.push(PointLoad { node: 78, force: [0.0, -0.01, 0.0], ramp_s: 0.0 });
    let mut sim = Simulation::<f32>::new(&model, scene.solver.clone(), effects).unwrap();
    for _ in 0..20 {
        sim.step();
    }
    // A NaN slips into the load between frames (the scene loader would refuse it; this
    // is the path a buggy caller takes).
    sim.effects_mut().loads[0].force = [0.0, f64::NAN, 0.0];
    for frame in 0..50 {
        sim.step();
        let s = sim.state();
        assert!(s.x.all_finite() && s.v.all_finite(), "frame {frame}: non-finite state left the step");
        let events = sim.quarantine();
        assert_eq!(events.len(), 1, "frame {frame}: the bad frame is recorded");
        assert_eq!(events[0].reason, GuardReason::NonFinite);
        assert_eq!(events[0].recovery, Recovery::Frozen);
    }
    // Clearing the load lets the simulation go on.
    sim.effects_mut().loads[0].force = [0.0, -0.01, 0.0];
    sim.step();
    assert!(sim.quarantine().is_empty());
    assert_eq!(sim.guard_totals().frozen, 50);
}

#[test]
fn guard_step_far_above_critical_recovers_by_substeps_works() {
    // Fixed sub-steps of 8x the critical step explode; the guard re-steps with more.
    let scene = block_scene();
    let model = scene.build_model().unwrap();
    let mut params = scene.solver.clone();
    let probe = Simulation::<f64>::new(&model, params.clone(), scene.effects.clone()).unwrap();
    let critical = probe.critical_step();
    params.substeps = lamina_core::solver::Substeps::Fixed(1);
    params.dt = 8.0 * critical;
    let mut sim = Simulation::<f64>::new(&model, params, scene.effects.clone()).unwrap();
    for _ in 0..200 {
        sim.step();
        assert!(sim.state().x.all_finite() && sim.state().v.all_finite());
    }
    let totals = sim.guard_totals();
    assert!(totals.rollbacks > 0, "8x the critical step must trip the guard");
    assert_eq!(totals.frozen, 0, "every bad frame was saved by sub-steps or implicit Euler: {totals:?}");
}
