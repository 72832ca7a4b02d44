//! Multirate stepping (the tool's region every tick, the rest of the limb once per `ratio`
//! ticks on its own thread) against the single-rate solvers: the same press force, the same
//! equilibrium, results independent of the bulk thread's timing, and clear refusals.

use lamina_core::scene::{Scene, ToolSource};
use lamina_core::solver::{
    BoneMotion, IntegratorKind, MultirateSettings, Simulation, SimulationBuildError, SphereTool,
};

/// The built-in default scene with its tool held at the device origin, stepped by `integrator`,
/// multirate about the origin when `multirate` gives a radius (m) and ratio.
fn default_scene_with_tool(integrator: IntegratorKind, multirate: Option<(f64, u32)>) -> (Simulation<f32>, [f64; 3]) {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let tool = scene.tool.expect("the default scene has a tool");
    let ToolSource::Haptics { device_origin: origin, .. } = tool.source else { panic!("a haptic tool") };
    let mut params = scene.solver.clone();
    params.integrator = integrator;
    params.multirate = multirate.map(|(radius, ratio)| MultirateSettings { centre: origin, radius, ratio });
    let mut effects = scene.effects.clone();
    effects.tool =
        Some(SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: origin, velocity: [0.0; 3] });
    (Simulation::<f32>::new(&model, params, effects).unwrap(), origin)
}

/// Presses the tool 8 mm into the skin over 0.5 s and holds it to 2 s; returns the
/// simulation and the vertical force on the tool, N.
fn press(integrator: IntegratorKind, multirate: Option<(f64, u32)>) -> (Simulation<f32>, f64) {
    let (mut sim, origin) = default_scene_with_tool(integrator, multirate);
    for frame in 0..2000 {
        let depth = 0.008 * (frame as f64 / 500.0).min(1.0);
        sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2]];
        sim.step();
    }
    assert_eq!(sim.guard_totals().rollbacks, 0);
    let force = sim.tool_feedback().force[1];
    (sim, force)
}

fn max_difference(a: &Simulation<f32>, b: &Simulation<f32>) -> f64 {
    let (a, b) = (&a.state().x, &b.state().x);
    (0..a.len())
        .map(|i| {
            let (p, q) = (a.get_f64(i), b.get_f64(i));
            (0..3).map(|c| (p[c] - q[c]).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[test]
fn multirate_press_force_matches_the_explicit_solver_works() {
    let (_, explicit) = press(IntegratorKind::SymplecticEuler, None);
    let (single, single_force) = press(IntegratorKind::ImplicitFactored, None);
    for ratio in [4, 8] {
        let (multi, force) = press(IntegratorKind::ImplicitFactored, Some((0.05, ratio)));
        let status = multi.multirate_status().expect("multirate on");
        assert!(status.region_nodes > 10 && status.bulk_nodes > 10 * status.region_nodes, "{status:?}");
        assert_eq!(status.bulk_steps, 2000 / u64::from(ratio));
        assert!(explicit > 0.05, "the tool presses ({explicit} N)");
        assert!(
            (force - explicit).abs() <= 0.05 * explicit,
            "multirate (ratio {ratio}) {force} N, symplectic Euler {explicit} N, single-rate {single_force} N"
        );
        // The whole limb, held 1.5 s, sits where the single-rate solver puts it: both reach
        // the same equilibrium (the coupling is exact at rest).
        let d = max_difference(&multi, &single);
        eprintln!(
            "ratio {ratio}: {} region nodes, {} bulk nodes; force {force:.5} N (explicit {explicit:.5} N, single-rate {single_force:.5} N); positions within {d:.3e} m of single-rate",
            status.region_nodes, status.bulk_nodes
        );
        assert!(d < 2e-4, "ratio {ratio}: positions differ by up to {d:e} m from the single-rate solver");
    }
}

#[test]
fn multirate_results_do_not_depend_on_the_bulk_threads_timing_works() {
    // The region waits for the bulk's state at each exchange, so two runs give the same bits
    // however the two threads were scheduled (here under whatever load the test machine has).
    let run = || {
        let (mut sim, origin) = default_scene_with_tool(IntegratorKind::ImplicitFactored, Some((0.05, 5)));
        for frame in 0..300 {
            let depth = 0.006 * (frame as f64 / 300.0);
            sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2]];
            sim.step();
            if frame % 97 == 0 {
                std::thread::sleep(std::time::Duration::from_millis(3));
            }
        }
        sim
    };
    let (a, b) = (run(), run());
    assert!(a.tool_feedback().force[1] > 0.01, "the tool presses");
    assert_eq!(max_difference(&a, &b), 0.0);
    assert_eq!(a.tool_feedback().force, b.tool_feedback().force);
}

#[test]
fn multirate_refusals_name_what_is_wrong_fails() {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let tool = scene.tool.unwrap();
    let ToolSource::Haptics { device_origin: origin, .. } = tool.source else { panic!("a haptic tool") };
    let build = |integrator: IntegratorKind, settings: MultirateSettings, bone_motion: bool| {
        let mut params = scene.solver.clone();
        params.integrator = integrator;
        params.multirate = Some(settings);
        let mut effects = scene.effects.clone();
        if bone_motion {
            effects.bone_motion = Some(BoneMotion { amplitude: [0.0, 0.001, 0.0], frequency_hz: 1.0 });
        }
        match Simulation::<f32>::new(&model, params, effects) {
            Err(SimulationBuildError::Multirate(why)) => why,
            Err(other) => panic!("another refusal: {other}"),
            Ok(_) => panic!("built"),
        }
    };
    let ok = MultirateSettings { centre: origin, radius: 0.05, ratio: 8 };
    assert!(build(IntegratorKind::SymplecticEuler, ok, false).contains("implicit_factored"));
    assert!(build(IntegratorKind::ImplicitFactored, ok, true).contains("bone_motion"));
    let far = MultirateSettings { centre: [5.0, 5.0, 5.0], ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, far, false).contains("holds 0 of"));
    // 3 cm about the tool holds a cap of skin a spring deep on this coarse limb: no core.
    let thin = MultirateSettings { radius: 0.03, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, thin, false).contains("enlarge the radius"));
    let all = MultirateSettings { radius: 10.0, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, all, false).contains("not all"));
    let bad = MultirateSettings { radius: f64::NAN, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, bad, false).contains("radius"));
    let slow = MultirateSettings { ratio: 1, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, slow, false).contains("ratio 1"));
}
