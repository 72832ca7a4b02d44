//! Helpers shared by the solver test crates.

use lamina_core::real::Real;
use lamina_core::scene::{Scene, ToolSource};
use lamina_core::solver::{IntegrationParameters, Simulation, SphereTool};

/// `scene`'s model with its haptic tool held at the device origin, its solver settings changed
/// by `set` (which is given the origin, m); returns the simulation and the origin.
pub fn limb_with_tool<T: Real>(
    scene: Scene,
    set: impl FnOnce(&mut IntegrationParameters, [f64; 3]),
) -> (Simulation<T>, [f64; 3]) {
    let model = scene.build_model().unwrap();
    let tool = scene.tool.expect("the scene has a tool");
    let ToolSource::Haptics { device_origin: origin, .. } = tool.source else { panic!("a haptic tool") };
    let mut params = scene.solver.clone();
    set(&mut params, origin);
    let mut effects = scene.effects.clone();
    effects.tool =
        Some(SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: origin, velocity: [0.0; 3] });
    (Simulation::<T>::new(&model, params, effects).unwrap(), origin)
}
