//! Moving bone (`effects.bone_motion`): a generated limb's bone nodes follow the law
//! `x_rest + amplitude · sin(2π f t)` and carry the tissue with them; a scene whose model has
//! no bone to move is refused, naming the file.

use lamina_core::model::NodeKind;
use lamina_core::scene::{DEFAULT_SCENE_TOML, Scene, SceneLoadError};
use lamina_core::solver::{Simulation, SimulationBuildError};

const MOTION: &str = "bone_motion = { amplitude = [0.0, 0.002, 0.0], frequency_hz = 1.0 }\n";

/// The built-in default scene with its bone moving 2 mm up and down at 1 Hz.
fn default_with_moving_bone() -> Scene {
    Scene::from_toml_str(&DEFAULT_SCENE_TOML.replace("[effects]\n", &format!("[effects]\n{MOTION}")), None).unwrap()
}

#[test]
fn generated_limbs_bone_follows_its_motion_and_carries_the_tissue_works() {
    let scene = default_with_moving_bone();
    let fixed = Scene::builtin_default().build_model().unwrap();
    let model = scene.build_model().unwrap();
    // The nodes fixed to bone are the ones that move; nothing else changes kind.
    for (i, (&was, &is)) in fixed.nodes.kind.iter().zip(&model.nodes.kind).enumerate() {
        let want = if was == NodeKind::Fixed { NodeKind::Kinematic } else { was };
        assert_eq!(is, want, "node {i}");
    }
    let bone: Vec<usize> = (0..model.nodes.len()).filter(|&i| model.nodes.kind[i] == NodeKind::Kinematic).collect();
    assert!(!bone.is_empty());
    let mut sim = Simulation::<f64>::new(&model, scene.solver.clone(), scene.effects.clone()).unwrap();
    // A quarter period: the bone at its highest, 2 mm up.
    for _ in 0..250 {
        sim.step();
    }
    let t = sim.state().time;
    let law = 0.002 * (2.0 * std::f64::consts::PI * t).sin();
    assert!((t - 0.25).abs() < 1e-9 && (law - 0.002).abs() < 1e-9);
    for &i in &bone {
        let (x, rest) = (sim.state().x.get_f64(i), model.nodes.position[i]);
        assert!(
            (x[0] - rest[0]).abs() < 1e-12 && (x[1] - rest[1] - law).abs() < 1e-12 && (x[2] - rest[2]).abs() < 1e-12
        );
    }
    // 1 Hz is far below the limb's lowest mode: the tissue rides on the bone, every free node
    // lifted about as much (measured 1.93 to 2.17 mm).
    let lift: Vec<f64> = (0..model.nodes.len())
        .filter(|&i| model.nodes.kind[i] == NodeKind::Free)
        .map(|i| sim.state().x.get_f64(i)[1] - model.nodes.position[i][1])
        .collect();
    let (low, high) = lift.iter().fold((f64::MAX, f64::MIN), |(lo, hi), &y| (lo.min(y), hi.max(y)));
    assert!(low > 0.8 * law && high < 1.2 * law, "free nodes lifted {low} to {high} m, the bone {law} m");
}

#[test]
fn bone_motion_on_a_model_with_no_moving_bone_fails() {
    // A model file whose bone nodes are all of kind "fixed": the scene cannot move them.
    let dir = std::env::temp_dir().join(format!("lamina-bone-motion-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let xml = dir.join("limb.xml");
    lamina_core::io::write_model(&Scene::builtin_default().build_model().unwrap(), &xml).unwrap();
    let scene_path = dir.join("scene.toml");
    std::fs::write(
        &scene_path,
        format!("[model]\nkind = \"file\"\npath = \"limb.xml\"\n\n[effects]\nbone = true\n{MOTION}"),
    )
    .unwrap();
    let scene = Scene::load(&scene_path).unwrap();
    match scene.build_model() {
        Err(err @ SceneLoadError::Model { .. }) => {
            let text = err.to_string();
            assert!(text.contains("scene.toml") && text.contains("limb.xml") && text.contains("kinematic"), "{text}");
        }
        other => panic!("built: {:?}", other.map(|m| m.nodes.len())),
    }
    // The library refuses the same effects on that model, and without bone.
    let model = lamina_core::io::read_model(&xml).unwrap();
    let moving = default_with_moving_bone().effects;
    let refused = |effects| Simulation::<f64>::new(&model, scene.solver.clone(), effects).err();
    assert_eq!(refused(moving.clone()), Some(SimulationBuildError::NothingToMove));
    let mut moving_model = model.clone();
    moving_model.nodes.set_bone_moving();
    let no_bone = lamina_core::solver::Effects { bone: false, ..moving };
    assert_eq!(
        Simulation::<f64>::new(&moving_model, scene.solver.clone(), no_bone).err(),
        Some(SimulationBuildError::NothingToMove)
    );
    std::fs::remove_dir_all(&dir).ok();
}
