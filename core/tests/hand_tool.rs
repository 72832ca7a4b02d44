//! The hand-held tool as library API: the critical step it is built with, grasp reach,
//! the grasp springs' reaction in closed form, release and park.

use lamina_core::hand_tool::{GRASP_REACH, HandTool, MAX_GRASPED};
use lamina_core::scene::{Scene, ToolSettings, ToolSource};
use lamina_core::solver::{IntegrationParameters, IntegratorKind, Simulation, SphereTool};

fn explicit_default() -> (Scene, lamina_core::model::Model, IntegrationParameters, ToolSettings) {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let params = IntegrationParameters { integrator: IntegratorKind::SymplecticEuler, ..scene.solver.clone() };
    let tool = scene.tool.expect("the default scene has a tool");
    (scene, model, params, tool)
}

#[test]
fn hand_tool_simulation_counts_the_tool_in_the_critical_step_works() {
    let (scene, model, params, tool) = explicit_default();
    let (with_tool, _) = HandTool::simulation::<f64>(&model, params.clone(), scene.effects.clone(), tool).unwrap();
    // The same tool written into the effects by hand, far away.
    let mut effects = scene.effects.clone();
    effects.tool = Some(SphereTool {
        radius: tool.shell_radius(),
        stiffness: tool.stiffness,
        start: [1e3; 3],
        velocity: [0.0; 3],
    });
    let by_hand = Simulation::<f64>::new(&model, params.clone(), effects).unwrap();
    let without = Simulation::<f64>::new(&model, params, scene.effects.clone()).unwrap();
    assert_eq!(with_tool.critical_step(), by_hand.critical_step());
    assert!(with_tool.critical_step() < without.critical_step(), "the tool's stiffness lowers the critical step");
    // Built parked: no tool in the loop, no contact.
    assert!(with_tool.effects().tool.is_none());
}

#[test]
fn hand_tool_grasp_holds_the_nodes_in_reach_and_pulls_back_works() {
    let (scene, model, params, settings) = explicit_default();
    let (mut sim, mut tool) = HandTool::simulation::<f64>(&model, params, scene.effects.clone(), settings).unwrap();
    let ToolSource::Haptics { device_origin: top, .. } = settings.source else { panic!("a haptics tool") };
    let handles_before = sim.effects().handles.len();
    tool.move_to(&mut sim, top, None);
    // The nodes within reach, counted here from the state.
    let reach = GRASP_REACH * settings.radius;
    let in_reach = (0..sim.state().x.len())
        .filter(|&i| {
            let p = sim.state().x.get_f64(i);
            let d2: f64 = (0..3).map(|c| (p[c] - top[c]).powi(2)).sum();
            d2 < reach * reach && sim.node_is_free(i)
        })
        .count();
    assert!(in_reach > 0);
    let grasped = tool.grasp(&mut sim);
    assert_eq!(grasped, in_reach.min(MAX_GRASPED));
    assert!(tool.is_grasping() && sim.effects().tool.is_none());
    assert_eq!(sim.effects().handles.len(), handles_before + grasped);
    // Moving the tool by d without stepping: every grasp spring is stretched by d, so the
    // tissue pulls the tool back with −k n d and stiffness −k n per axis.
    let d = [0.0, 0.002, -0.001];
    tool.move_to(&mut sim, [top[0] + d[0], top[1] + d[1], top[2] + d[2]], None);
    let fb = tool.feedback(&sim);
    let kn = settings.stiffness * grasped as f64;
    for c in 0..3 {
        assert!((fb.force[c] + kn * d[c]).abs() <= 1e-12 * kn, "axis {c}: {:?}", fb.force);
        assert_eq!(fb.stiffness[c][c], -kn);
    }
    // Release gives the handles back; park takes the sphere out.
    tool.release(&mut sim);
    assert_eq!(sim.effects().handles.len(), handles_before);
    tool.move_to(&mut sim, top, None);
    assert!(sim.effects().tool.is_some());
    tool.park(&mut sim);
    assert!(sim.effects().tool.is_none() && !tool.feedback(&sim).in_contact);
}

#[test]
fn hand_tool_radius_below_the_shell_is_raised_works() {
    let (scene, model, params, settings) = explicit_default();
    let (mut sim, mut tool) = HandTool::simulation::<f32>(&model, params, scene.effects.clone(), settings).unwrap();
    let smallest = settings.shell_radius();
    assert!(tool.move_to(&mut sim, [0.0, 1.0, 0.0], Some(smallest / 2.0)));
    assert_eq!(tool.radius(), smallest);
    assert!(!tool.move_to(&mut sim, [0.0, 1.0, 0.0], Some(2.0 * smallest)));
    assert_eq!(sim.effects().tool.map(|t| t.radius), Some(2.0 * smallest));
}
