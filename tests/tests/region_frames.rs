//! A multirate simulation's node frames, published as the core publishes them (only the
//! region's nodes rewritten into a chunk that holds the rest), read back by a subscriber and
//! compared with the simulation's own state, tick by tick, through exchanges with the bulk and
//! regions taken about a sliding tool.

use lamina_bridge::{Bridge, BridgeConfig, NodeChanges, NodesPublisher, NodesSubscriber};
use lamina_core::scene::{Scene, ToolSource};
use lamina_core::solver::{IntegratorKind, LateBuild, MultirateSettings, Simulation, SphereTool};

#[test]
fn region_frames_arrive_as_the_simulation_state_works() {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let tool = scene.tool.unwrap();
    let ToolSource::Haptics { device_origin: origin, .. } = tool.source else { panic!("a haptics tool") };
    let mut params = scene.solver.clone();
    params.integrator = IntegratorKind::ImplicitFactored;
    params.multirate = Some(MultirateSettings {
        centre: origin,
        radius: 0.05,
        ratio: 4,
        build_exchanges: Some(2),
        late_build: LateBuild::Wait,
        ..MultirateSettings::default()
    });
    let mut effects = scene.effects.clone();
    effects.tool =
        Some(SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: origin, velocity: [0.0; 3] });
    let mut sim = Simulation::<f32>::new(&model, params, effects).unwrap();

    let bridge = Bridge::open(&BridgeConfig::with_prefix(&format!("t{}_region_frames", std::process::id()))).unwrap();
    let publisher = NodesPublisher::create(&bridge, model.nodes.len()).unwrap();
    let subscriber = NodesSubscriber::create(&bridge).unwrap();
    let mut partial_ticks = 0;
    let mut last_epoch = None;
    for tick in 0..400u64 {
        // Pressed 4 mm, then slid 6 cm along the limb: the region moves with it.
        let depth = 0.004 * (tick as f64 / 100.0).min(1.0);
        let along = 0.06 * ((tick as f64 - 100.0) / 250.0).clamp(0.0, 1.0);
        sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2] + along];
        sim.step();
        let changes = sim.frame_changes().expect("multirate");
        partial_ticks += usize::from(last_epoch == Some(changes.epoch));
        last_epoch = Some(changes.epoch);
        let x = &sim.state().x;
        let sent = publisher
            .publish_finite_xyz_changed(
                tick,
                tick,
                sim.state().time,
                [&x.x, &x.y, &x.z],
                NodeChanges { epoch: changes.epoch, nodes: changes.nodes },
            )
            .unwrap();
        assert_eq!(sent, Some(1), "tick {tick}");
        let frame = subscriber.try_receive().unwrap().expect("the frame");
        assert_eq!(frame.header().tick, tick);
        for (i, p) in frame.positions().iter().enumerate() {
            assert_eq!(*p, [x.x[i], x.y[i], x.z[i]], "tick {tick}, node {i}");
        }
    }
    let status = sim.multirate_status().unwrap();
    assert!(status.recentres >= 2, "the region moved: {status:?}");
    assert!(partial_ticks >= 250, "{partial_ticks} ticks within an epoch");
}
