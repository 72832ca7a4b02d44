//! The live source against a stand-in core publishing over iceoryx2 in another thread:
//! the viewer subscribes before the core exists, gets the model and frames, and carries on
//! when the core restarts (its sequence starts again at 0).

use core::time::Duration;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use lamina_bridge::{
    Bridge, BridgeConfig, LayerRange, NodesPublisher, SurfaceTopology, TissueKind, Topology, TopologyPublisher,
};
use lamina_viewer::source::{FrameSource, LiveSource, SourceEvent};
use lamina_viewer::synthetic::SyntheticLimb;
use lamina_viewer::view_model::{Tissue, ViewModel};

fn kind(t: Tissue) -> TissueKind {
    match t {
        Tissue::Skin => TissueKind::Skin,
        Tissue::Fat => TissueKind::Fat,
        Tissue::Muscle => TissueKind::Muscle,
        Tissue::Bone => TissueKind::Bone,
        Tissue::Other => TissueKind::Other,
    }
}

/// The wire topology a core would publish for the synthetic limb, written independently of
/// the viewer's reader: each grid with its seam column repeated (the generator's
/// convention), one layer per tissue, every spring with its layer.
fn topology_of(model: &ViewModel) -> Topology {
    let tissues = [Tissue::Skin, Tissue::Fat, Tissue::Muscle, Tissue::Bone, Tissue::Other];
    let surfaces = model
        .grids
        .iter()
        .map(|g| {
            let cols = g.cols + usize::from(g.wrap);
            let indices = g.nodes.chunks(g.cols).flat_map(|row| (0..cols).map(|c| row[c % g.cols])).collect();
            SurfaceTopology {
                name: g.name.clone(),
                tissue: kind(g.beneath),
                grid: Some((cols as u32, g.rows as u32)),
                indices,
            }
        })
        .collect();
    Topology {
        name: model.name.clone(),
        node_count: model.node_count as u32,
        layers: tissues
            .iter()
            .map(|t| LayerRange { name: t.name().into(), tissue: kind(*t), first_node: 0, node_count: 0 })
            .collect(),
        surfaces,
        springs: model.springs.clone(),
        spring_layer: model.spring_tissue.iter().map(|t| tissues.iter().position(|x| x == t).unwrap() as u32).collect(),
        ..Topology::default()
    }
}

/// A stand-in core: publishes the topology, then `frames` node frames of the synthetic limb.
fn run_core(prefix: String, frames: u64, stop: Arc<AtomicBool>) {
    let limb = SyntheticLimb::default();
    let model = limb.view_model();
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).expect("bridge");
    let topology = topology_of(&model);
    let mut topo_pub = TopologyPublisher::create(&bridge, topology.word_count()).expect("topology publisher");
    let nodes_pub = NodesPublisher::create(&bridge, model.node_count).expect("nodes publisher");
    topo_pub.publish(&topology).expect("topology published");
    for k in 0..frames {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let frame = limb.frame(k, k as f64 / 200.0);
        let _ = topo_pub.serve_late_joiners();
        nodes_pub
            .publish_from_fn(k, k, k as f64 / 200.0, model.node_count, |i| frame.positions[i].to_array())
            .expect("frame published");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn live_source_follows_core_and_restart_works() {
    let prefix = format!("lamina_viewer_test_{}", std::process::id());
    let reference = SyntheticLimb::default().view_model();
    // The viewer first: no core yet.
    let mut source = LiveSource::open(&prefix).expect("live source opens");
    assert!(matches!(source.next_event(Duration::from_millis(50)), SourceEvent::Idle(_)));

    let stop = Arc::new(AtomicBool::new(false));
    let mut models = 0;
    let mut frames = 0;
    let mut latencies = Vec::new();
    for run in 0..2 {
        let (p, s) = (prefix.clone(), stop.clone());
        let core = std::thread::spawn(move || run_core(p, 200, s));
        // Watchdog: give up after 20 s rather than hang (no timing is asserted).
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut frames_this_run = 0;
        while frames_this_run < 20 && Instant::now() < deadline {
            match source.next_event(Duration::from_millis(200)) {
                SourceEvent::Model(m) => {
                    assert_eq!(m, reference, "the whole model (grids, springs, tissues) comes over the wire");
                    models += 1;
                }
                SourceEvent::Frame(f) => {
                    assert_eq!(f.positions.len(), reference.node_count);
                    assert!(f.publish_time_ns > 0);
                    latencies.push(lamina_bridge::now_ns().saturating_sub(f.publish_time_ns));
                    frames += 1;
                    frames_this_run += 1;
                }
                SourceEvent::Idle(_) => {}
            }
        }
        stop.store(true, Ordering::SeqCst);
        core.join().expect("core thread");
        stop.store(false, Ordering::SeqCst);
        assert!(frames_this_run >= 20, "run {run}: only {frames_this_run} frames before the watchdog");
    }
    assert!(models >= 2, "the restarted core's topology was taken ({models} models)");
    assert!(frames >= 40);
    latencies.sort_unstable();
    eprintln!(
        "in-process latency publish -> received: p50 {:.3} ms, max {:.3} ms over {} frames",
        latencies[latencies.len() / 2] as f64 / 1e6,
        latencies[latencies.len() - 1] as f64 / 1e6,
        latencies.len()
    );
}

#[test]
fn live_source_draws_the_newest_queued_frame_works() {
    // Frames queue up while the viewer draws; the next one it takes must be the newest, not
    // the oldest in its 16-frame buffer.
    let prefix = format!("lamina_viewer_newest_{}", std::process::id());
    let limb = SyntheticLimb::default();
    let model = limb.view_model();
    let mut source = LiveSource::open(&prefix).expect("live source opens");
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).expect("bridge");
    let topology = topology_of(&model);
    let mut topo_pub = TopologyPublisher::create(&bridge, topology.word_count()).expect("topology publisher");
    let nodes_pub = NodesPublisher::create(&bridge, model.node_count).expect("nodes publisher");
    topo_pub.publish(&topology).expect("topology published");
    let mut got_model = false;
    for _ in 0..50 {
        if let SourceEvent::Model(_) = source.next_event(Duration::from_millis(100)) {
            got_model = true;
            break;
        }
    }
    assert!(got_model, "the viewer took the topology");
    for k in 0..10u64 {
        let frame = limb.frame(k, k as f64 / 1000.0);
        nodes_pub
            .publish_from_fn(k, k, k as f64 / 1000.0, model.node_count, |i| frame.positions[i].to_array())
            .expect("frame published");
    }
    match source.next_event(Duration::from_millis(500)) {
        SourceEvent::Frame(f) => assert_eq!(f.sequence, 9, "the newest of 10 queued frames"),
        other => panic!("expected a frame, got {other:?}"),
    }
    assert!(matches!(source.next_event(Duration::from_millis(20)), SourceEvent::Idle(_)), "nothing older is left");
}
