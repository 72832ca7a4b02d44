//! The skin's volume term against the failure it exists for: the default limb's 2 mm skin on
//! 13 × 40 mm cells, pressed 8 mm by the haptic tool and let go. Springs alone let the outer
//! skin pass through its own bottom nodes and stay collapsed after the tool has gone (the
//! mirrored tetrahedron has the same spring lengths); with the scene's volume term every skin
//! tetrahedron keeps its orientation and returns to its rest volume.

use lamina_core::scene::{Scene, ToolSource};
use lamina_core::solver::{IntegratorKind, Simulation, SkinVolume, SphereTool, Substeps};

/// Volume ratios `V/V₀` seen while pressing 8 mm over 1 s, holding 1 s and lifting the tool
/// clear over 0.6 s: (smallest during the run, smallest and largest 0.4 s after the lift).
fn press_and_release(skin_volume: Option<f64>, integrator: IntegratorKind) -> (f64, f64, f64) {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let tool = scene.tool.unwrap();
    let ToolSource::Haptics { device_origin, .. } = tool.source else { panic!("a haptics tool") };
    let mut effects = scene.effects.clone();
    effects.skin_volume = skin_volume;
    let mut params = scene.solver.clone();
    params.integrator = integrator;
    if integrator == IntegratorKind::ImplicitEuler {
        params.substeps = Substeps::Fixed(1);
    }
    let mut sim = Simulation::<f32>::new(&model, params, effects).unwrap();
    let tets = SkinVolume::of_model(&model);
    assert_eq!(tets.tets.len(), 288, "one tetrahedron per outer-skin triangle of the 24 x 6 limb");
    let mut smallest = f64::INFINITY;
    for k in 0..3000 {
        let t = f64::from(k) / 1000.0;
        let press = match t {
            t if t < 1.0 => 0.008 * t,
            t if t < 2.0 => 0.008,
            t if t < 2.6 => 0.008 - 0.023 * (t - 2.0) / 0.6,
            _ => -0.015,
        };
        let centre = [device_origin[0], device_origin[1] - press, device_origin[2]];
        sim.effects_mut().tool =
            Some(SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: centre, velocity: [0.0; 3] });
        sim.step();
        smallest = tets.volume_ratios(&sim.state().x).fold(smallest, f64::min);
    }
    assert!(sim.state().x.all_finite());
    let after: Vec<f64> = tets.volume_ratios(&sim.state().x).collect();
    (smallest, after.iter().copied().fold(f64::INFINITY, f64::min), after.iter().copied().fold(0.0, f64::max))
}

#[test]
fn skin_volume_keeps_the_pressed_skin_from_inverting_works() {
    let scene = Scene::builtin_default();
    let k = scene.effects.skin_volume.expect("the default scene keeps the skin's volume");
    let (during, after_min, after_max) = press_and_release(Some(k), IntegratorKind::SymplecticEuler);
    eprintln!("with the volume term ({k} Pa): V/V0 >= {during:.3} pressed; {after_min:.4}..{after_max:.4} after");
    assert!(during > 0.9, "a skin tetrahedron lost {:.0} % of its volume", 100.0 * (1.0 - during));
    assert!(after_min > 0.99 && after_max < 1.01, "after the press: {after_min}..{after_max}");
}

#[test]
fn springs_alone_let_the_pressed_skin_invert_works() {
    // The failure the term removes, so the test above is not passing by accident.
    let (during, after_min, _) = press_and_release(None, IntegratorKind::SymplecticEuler);
    eprintln!("springs alone: V/V0 >= {during:.3} pressed; >= {after_min:.3} after");
    assert!(during < 0.0, "no skin tetrahedron inverted under the press ({during})");
    assert!(after_min < 0.5, "the skin recovered by itself ({after_min})");
}

#[test]
fn skin_volume_holds_in_implicit_euler_at_the_full_frame_works() {
    // One backward-Euler step per 1 ms frame, 14 times the explicit step: the volume term is
    // in the implicit solver's tangent, so it stays stable and keeps the skin's orientation.
    let k = Scene::builtin_default().effects.skin_volume.unwrap();
    let (during, after_min, after_max) = press_and_release(Some(k), IntegratorKind::ImplicitEuler);
    eprintln!("implicit Euler: V/V0 >= {during:.3} pressed; {after_min:.4}..{after_max:.4} after");
    assert!(during > 0.9, "a skin tetrahedron lost {:.0} % of its volume", 100.0 * (1.0 - during));
    assert!(after_min > 0.99 && after_max < 1.01, "after the press: {after_min}..{after_max}");
}
