//! What a simulation refuses at construction, and the stop flag: regression tests for
//! scenes and model files that hung the core or made every tick roll back.

use std::sync::atomic::AtomicBool;

use lamina_core::law::SpringLaw;
use lamina_core::model::Model;
use lamina_core::scene::Scene;
use lamina_core::solver::{
    IntegrationParameters, IntegratorKind, MAX_CG_ITERATIONS, MAX_FACTORED_ITERATIONS, MAX_SUBSTEPS, Simulation,
    SimulationBuildError, Substeps, max_coordinate,
};

/// The built-in default scene's model and settings.
fn default_scene() -> (Scene, Model) {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    (scene, model)
}

/// Builds in `T` with `params` and the scene's effects; the error, if any.
fn build<T: lamina_core::real::Real>(
    scene: &Scene,
    model: &Model,
    params: IntegrationParameters,
) -> Result<Simulation<T>, SimulationBuildError> {
    Simulation::<T>::new(model, params, scene.effects.clone())
}

fn above_cap(e: &SimulationBuildError) -> (&'static str, u64, u64) {
    match e {
        SimulationBuildError::AboveCap { parameter, value, cap } => (parameter, *value, *cap),
        other => panic!("expected AboveCap, got {other}"),
    }
}

#[test]
fn substeps_100000_is_refused_works() {
    let (scene, model) = default_scene();
    let params = IntegrationParameters { substeps: Substeps::Fixed(100_000), ..scene.solver.clone() };
    let e = build::<f32>(&scene, &model, params).err().expect("refused");
    assert_eq!(above_cap(&e), ("substeps", 100_000, u64::from(MAX_SUBSTEPS)));
    assert_eq!(e.to_string(), "substeps = 100000 is above its cap of 10000");
    // The cap itself is accepted.
    let params = IntegrationParameters { substeps: Substeps::Fixed(MAX_SUBSTEPS), ..scene.solver.clone() };
    assert!(build::<f32>(&scene, &model, params).is_ok());
}

#[test]
fn max_substeps_4294967295_is_refused_works() {
    let (scene, model) = default_scene();
    let params = IntegrationParameters { max_substeps: u32::MAX, ..scene.solver.clone() };
    let e = build::<f32>(&scene, &model, params).err().expect("refused");
    assert_eq!(above_cap(&e), ("max_substeps", 4_294_967_295, 10_000));
}

#[test]
fn cg_max_iterations_unbounded_is_refused_works() {
    let (scene, model) = default_scene();
    let params = IntegrationParameters {
        integrator: IntegratorKind::ImplicitEuler,
        cg_max_iterations: u32::MAX,
        ..scene.solver.clone()
    };
    let e = build::<f32>(&scene, &model, params).err().expect("refused");
    assert_eq!(above_cap(&e), ("cg_max_iterations", u64::from(u32::MAX), u64::from(MAX_CG_ITERATIONS)));
}

#[test]
fn factored_iterations_unbounded_is_refused_works() {
    let (scene, model) = default_scene();
    let params = IntegrationParameters {
        integrator: IntegratorKind::ImplicitFactored,
        factored_iterations: MAX_FACTORED_ITERATIONS + 1,
        ..scene.solver.clone()
    };
    let e = build::<f32>(&scene, &model, params).err().expect("refused");
    assert_eq!(above_cap(&e), ("factored_iterations", 65, 64));
}

#[test]
fn guard_retries_unbounded_is_refused_works() {
    let (scene, model) = default_scene();
    let mut effects = scene.effects.clone();
    effects.guard = Some(lamina_core::solver::GuardSettings { retries: 40, ..Default::default() });
    let e = Simulation::<f32>::new(&model, scene.solver.clone(), effects).err().expect("refused");
    assert_eq!(above_cap(&e), ("guard.retries", 40, 8));
}

#[test]
fn stability_safety_out_of_range_is_refused_works() {
    let (scene, model) = default_scene();
    for bad in [0.0, 1e-300 * 0.0, 1.5, f64::NAN] {
        let params = IntegrationParameters { stability_safety: bad, ..scene.solver.clone() };
        let e = build::<f32>(&scene, &model, params).err().expect("refused");
        assert!(matches!(e, SimulationBuildError::BadParameter { parameter: "stability_safety", .. }), "{e}");
    }
}

#[test]
fn stiffness_1e300_is_refused_works() {
    // Every tick used to roll back: the critical step came out NaN.
    let (scene, mut model) = default_scene();
    model.springs.law[5] = SpringLaw::Linear { stiffness: 1e300 };
    let e = build::<f32>(&scene, &model, scene.solver.clone()).err().expect("refused in f32");
    assert!(
        matches!(&e, SimulationBuildError::NotRepresentable { item, precision: "f32" } if item == "spring 5: stiffness 1e300 N/m"),
        "{e}"
    );
    let e = build::<f64>(&scene, &model, scene.solver.clone()).err().expect("refused in f64");
    assert!(
        matches!(&e, SimulationBuildError::NonFiniteStability { stiffest, .. } if stiffest.starts_with("spring 5: stiffness 1e300 N/m")),
        "{e}"
    );
}

#[test]
fn mass_1e_300_is_refused_works() {
    let (scene, mut model) = default_scene();
    model.nodes.mass[40] = 1e-300;
    let e = build::<f32>(&scene, &model, scene.solver.clone()).err().expect("refused in f32");
    assert!(
        matches!(&e, SimulationBuildError::NotRepresentable { item, .. } if item == "node 40: mass 1e-300 kg"),
        "{e}"
    );
    let e = build::<f64>(&scene, &model, scene.solver.clone()).err().expect("refused in f64");
    assert!(matches!(e, SimulationBuildError::NonFiniteStability { .. }), "{e}");
}

#[test]
fn coordinates_beyond_f32_range_are_refused_works() {
    // 1e39 m rounds to infinity in f32: the state was non-finite from the start.
    let (scene, mut model) = default_scene();
    model.nodes.position[3] = [1e39, 0.0, 0.0];
    let e = build::<f32>(&scene, &model, scene.solver.clone()).err().expect("refused");
    assert!(matches!(e, SimulationBuildError::PositionOutOfRange { node: 3, precision: "f32", .. }), "{e}");
    assert!(e.to_string().starts_with("node 3 at (1e39, 0e0, 0e0) m is beyond ±1.2e18 m"), "{e}");
    // The bound is sqrt(f32::MAX) / 16: squared distances of coordinates within it stay finite.
    let limit = max_coordinate::<f32>();
    assert!(((2.0 * limit) as f32).powi(2).is_finite() && limit > 1e18);
}

#[test]
fn substeps_clamped_are_reported_works() {
    // Symplectic Euler needs more than one sub-step per 1 kHz frame on the default limb
    // (its thin skin's critical step); max_substeps = 1 clamps it.
    let (scene, model) = default_scene();
    let explicit = IntegrationParameters { integrator: IntegratorKind::SymplecticEuler, ..scene.solver.clone() };
    let sim = build::<f32>(&scene, &model, explicit.clone()).unwrap();
    let needed = sim.substeps() as u64;
    assert!(needed > 1 && sim.substeps_clamped().is_none());
    let params = IntegrationParameters { max_substeps: 1, ..explicit };
    let sim = build::<f32>(&scene, &model, params).unwrap();
    assert_eq!((sim.substeps(), sim.substeps_clamped()), (1, Some(needed)));
}

#[test]
fn stop_flag_ends_a_long_frame_within_one_substep_works() {
    // A core stuck in a 10,000-sub-step frame used to ignore SIGTERM until the frame ended.
    let (scene, model) = default_scene();
    let params = IntegrationParameters { substeps: Substeps::Fixed(MAX_SUBSTEPS), ..scene.solver.clone() };
    let mut sim = build::<f32>(&scene, &model, params).unwrap();
    assert!(sim.step_or_stop(&AtomicBool::new(false)));
    assert_eq!(sim.counters().substeps, u64::from(MAX_SUBSTEPS));
    assert!(!sim.step_or_stop(&AtomicBool::new(true)));
    assert_eq!(sim.counters().substeps, u64::from(MAX_SUBSTEPS) + 1);
    let h = scene.solver.dt / f64::from(MAX_SUBSTEPS);
    assert!((sim.state().time - (scene.solver.dt + h)).abs() < 1e-12, "{}", sim.state().time);
    assert!(sim.state().x.all_finite());
}

#[test]
fn model_path_dev_zero_is_refused_works() {
    // `/dev/zero` as a model file used to be read until memory ran out.
    for dev in ["/dev/zero", "/dev/urandom"] {
        let e = lamina_core::io::read_model(dev).expect_err("refused");
        assert!(
            matches!(e, lamina_core::io::ModelReadError::Refused(lamina_input::FileReadError::NotRegular { .. })),
            "{e}"
        );
        assert_eq!(
            e.to_string(),
            format!("{dev}: is a character device, not a regular file; a model file must be a regular file")
        );
    }
}

#[test]
fn model_memory_estimate_covers_list_reservations_works() {
    // The reader reserves one list element per MIN_ELEMENT_BYTES of file; the file's memory
    // estimate must cover the largest element (a spring: two indices, rest length, law,
    // damping, layer), node and surface triangle.
    use lamina_core::io::{MIN_ELEMENT_BYTES, MODEL_FILE};
    use std::mem::size_of;
    let spring = 2 * size_of::<u32>() + size_of::<f64>() + size_of::<SpringLaw>() + size_of::<f64>() + size_of::<u16>();
    let node = size_of::<[f64; 3]>()
        + size_of::<f64>()
        + size_of::<lamina_core::model::NodeKind>()
        + size_of::<u16>()
        + size_of::<[f32; 3]>();
    let budget = (MODEL_FILE.memory_per_byte * MIN_ELEMENT_BYTES) as usize;
    assert!(spring <= budget && node <= budget && size_of::<[u32; 3]>() <= budget, "{spring} {node} {budget}");
}

#[test]
fn zero_substep_and_iteration_limits_are_refused_fails() {
    // A limit of zero would leave a frame with no step (or a solve with no iteration).
    let (scene, model) = default_scene();
    for params in [
        IntegrationParameters { max_substeps: 0, ..scene.solver.clone() },
        IntegrationParameters { cg_max_iterations: 0, ..scene.solver.clone() },
        IntegrationParameters { factored_iterations: 0, ..scene.solver.clone() },
    ] {
        let e = build::<f32>(&scene, &model, params).err().expect("refused");
        assert!(matches!(e, SimulationBuildError::BadParameter { expected: "at least 1", .. }), "{e}");
    }
    let params = IntegrationParameters { substeps: Substeps::Fixed(0), ..scene.solver.clone() };
    let e = build::<f32>(&scene, &model, params).err().expect("refused");
    assert!(matches!(e, SimulationBuildError::BadStep), "{e}");
}
