//! The core process's side of the bridge: topology once (with history for late joiners),
//! node positions on the ticks `frame_gate` picks, written straight into shared memory, the
//! deadline monitor's summary every second. Publishing never waits for a subscriber (see
//! `lamina-bridge`).

use lamina_bridge::{
    Bridge, BridgeConfig, LayerRange, NodeChanges, NodesPublisher, StatsPublisher, StatsSummary, SurfaceTopology,
    TissueKind, Topology, TopologyPublisher, VolumeTopology, WireTool, now_ns,
};
use lamina_core::model::{Model, Tissue};
use lamina_core::real::Real;
use lamina_core::scene::{DEVICE_TO_Y_UP_MODEL, ToolSettings, ToolSource, VisualSection};
use lamina_core::solver::{FrameChanges, State};
use lamina_rt::MonitorSummary;
use std::any::Any;

/// Publishers of one core process.
pub struct CorePublisher {
    // Field order is drop order: ports before the node that owns them.
    /// The haptic link, when the scene's tool is driven by the haptics process.
    pub haptic: Option<super::haptic_link::HapticLink>,
    nodes: NodesPublisher,
    stats: StatsPublisher,
    topology: TopologyPublisher,
    _bridge: Bridge,
    stats_sequence: u64,
    /// Frames published.
    pub sequence: u64,
    /// Publishes that failed (the tick went on).
    pub failures: u64,
    /// Node frames not published because the state was not finite (only possible with the
    /// guard off): subscribers never receive NaN or infinity.
    pub withheld: u64,
}

/// The wire's name for a model tissue.
fn tissue_kind(tissue: Tissue) -> TissueKind {
    match tissue {
        Tissue::Skin => TissueKind::Skin,
        Tissue::Fat => TissueKind::Fat,
        Tissue::Muscle => TissueKind::Muscle,
        Tissue::Bone => TissueKind::Bone,
        Tissue::Other => TissueKind::Other,
    }
}

/// The scene's tool and device mapping as the wire carries it (`source` 0 without a tool).
pub fn wire_tool(tool: Option<&ToolSettings>) -> WireTool {
    let Some(tool) = tool else { return WireTool::default() };
    let mut wire = WireTool {
        radius_m: tool.radius,
        min_radius_m: tool.shell_radius(),
        stiffness_n_per_m: tool.stiffness,
        device_rotation: DEVICE_TO_Y_UP_MODEL,
        position_scale: 1.0,
        force_scale: 1.0,
        ..WireTool::default()
    };
    match tool.source {
        ToolSource::Scripted { .. } => wire.source = 1,
        ToolSource::Haptics { device_origin, device_scale, force_scale, .. } => {
            wire.source = 2;
            wire.device_origin_m = device_origin;
            wire.position_scale = device_scale;
            wire.force_scale = force_scale;
        }
    }
    wire
}

/// The scene's volume texture as the wire carries it.
pub fn volume_of(visual: &VisualSection) -> VolumeTopology {
    VolumeTopology { path: visual.volume.display().to_string(), origin_m: visual.origin_m, window: visual.window }
}

/// Everything the viewer and the haptics process need of the model, in one message: name,
/// layers with their tissue and node range, every surface (grids for the Bézier patches),
/// springs with their layer, each node's layer and rest position, the tool and device
/// mapping, and the volume texture the scene names.
pub fn topology_of(model: &Model, tool: Option<&ToolSettings>, volume: Option<VolumeTopology>) -> Topology {
    let layers = model
        .layers
        .iter()
        .enumerate()
        .map(|(index, layer)| {
            let in_layer = |l: &u16| usize::from(*l) == index;
            let first = model.nodes.layer.iter().position(in_layer);
            let last = model.nodes.layer.iter().rposition(in_layer);
            let (first_node, node_count) = match (first, last) {
                (Some(f), Some(l)) => (f as u32, (l - f + 1) as u32),
                _ => (0, 0),
            };
            LayerRange { name: layer.name.clone(), tissue: tissue_kind(layer.tissue), first_node, node_count }
        })
        .collect();
    let surfaces = model
        .surfaces
        .iter()
        .map(|s| {
            let tissue = tissue_kind(s.tissue_beneath());
            match &s.grid {
                Some((cols, rows, nodes)) => {
                    SurfaceTopology { name: s.name.clone(), tissue, grid: Some((*cols, *rows)), indices: nodes.clone() }
                }
                None => SurfaceTopology {
                    name: s.name.clone(),
                    tissue,
                    grid: None,
                    indices: s.triangles.iter().flatten().copied().collect(),
                },
            }
        })
        .collect();
    let springs = &model.springs;
    Topology {
        name: model.name.clone(),
        node_count: model.nodes.len() as u32,
        triangles: model.surfaces.iter().flat_map(|s| s.triangles.iter().copied()).collect(),
        layers,
        tex_coords: model.nodes.texcoord.iter().map(|t| [t[0], t[1]]).collect(),
        surfaces,
        springs: (0..springs.len()).map(|s| [springs.a[s], springs.b[s]]).collect(),
        spring_layer: springs.layer.iter().map(|&l| u32::from(l)).collect(),
        node_layer: model.nodes.layer.iter().map(|&l| u32::from(l)).collect(),
        rest_positions: model.nodes.position.iter().map(|p| p.map(|c| c as f32)).collect(),
        tool: wire_tool(tool),
        volume,
    }
}

impl CorePublisher {
    /// Opens the bridge under `prefix` and publishes the topology; with a haptics-driven
    /// `tool`, also subscribes to `tool` and publishes `feedback`.
    pub fn open(
        prefix: &str,
        model: &Model,
        tool: Option<&ToolSettings>,
        visual: Option<&VisualSection>,
    ) -> Result<Self, String> {
        let bridge = Bridge::open(&BridgeConfig::with_prefix(prefix)).map_err(|e| format!("bridge: {e}"))?;
        // The node publisher first: it holds the prefix's lock, so a second core on a live
        // prefix stops here, before it publishes anything.
        let nodes = NodesPublisher::create(&bridge, model.nodes.len()).map_err(|e| e.to_string())?;
        let topology = topology_of(model, tool, visual.map(volume_of));
        let mut topo_pub =
            TopologyPublisher::create(&bridge, topology.word_count()).map_err(|e| format!("topology service: {e}"))?;
        topo_pub.publish(&topology).map_err(|e| format!("topology: {e}"))?;
        let stats = StatsPublisher::create(&bridge).map_err(|e| format!("stats service: {e}"))?;
        let haptic = super::haptic_link::HapticLink::open(&bridge, tool)?;
        Ok(Self {
            haptic,
            nodes,
            stats,
            topology: topo_pub,
            _bridge: bridge,
            stats_sequence: 0,
            sequence: 0,
            failures: 0,
            withheld: 0,
        })
    }

    /// Publishes the positions of `state` (m, as f32) for physics tick `tick`; `changes`,
    /// when the simulation knows them, names the only nodes that moved within its epoch
    /// (then only those are written into a chunk that carried a frame of that epoch).
    pub fn publish_nodes<T: Real>(&mut self, tick: u64, state: &State<T>, changes: Option<FrameChanges<'_>>) {
        let (x, y, z) = (&state.x.x, &state.x.y, &state.x.z);
        let n = x.len();
        let (sequence, time) = (self.sequence, state.time);
        // Checked as written: a state with NaN or infinities (or beyond f32) is not published.
        let result = match (as_f32(x), as_f32(y), as_f32(z), changes) {
            (Some(x), Some(y), Some(z), Some(c)) => self.nodes.publish_finite_xyz_changed(
                sequence,
                tick,
                time,
                [x, y, z],
                NodeChanges { epoch: c.epoch, nodes: c.nodes },
            ),
            // An f32 state goes out as it is, interleaved with vector permutes.
            (Some(x), Some(y), Some(z), None) => self.nodes.publish_finite_xyz(sequence, tick, time, x, y, z),
            _ => self.nodes.publish_finite_from_fn(sequence, tick, time, n, |i| {
                [x[i].to_f64() as f32, y[i].to_f64() as f32, z[i].to_f64() as f32]
            }),
        };
        match result {
            Ok(Some(_)) => self.sequence += 1,
            Ok(None) => self.withheld += 1,
            Err(_) => self.failures += 1,
        }
    }

    /// Publishes the monitor's summary, and hands the topology to subscribers that joined
    /// since the last call (once a second, between ticks).
    pub fn publish_stats(&mut self, s: &MonitorSummary) {
        if self.topology.serve_late_joiners().is_err() {
            self.failures += 1;
        }
        let p = |q: &lamina_rt::Percentiles| lamina_bridge::Percentiles {
            p50_ns: q.p50_ns,
            p99_ns: q.p99_ns,
            p999_ns: q.p999_ns,
            max_ns: q.max_ns,
        };
        let msg = StatsSummary {
            sequence: self.stats_sequence,
            publish_time_ns: now_ns(),
            ticks: s.ticks,
            misses: s.misses,
            lateness: p(&s.lateness),
            compute: p(&s.compute),
            period: p(&s.period),
            worst_tick: s.worst.as_slice().first().map_or(0, |w| w.tick),
        };
        self.stats_sequence += 1;
        if self.stats.publish(&msg).is_err() {
            self.failures += 1;
        }
    }
}

/// `c` as `f32`s when `T` is `f32`.
#[allow(clippy::ptr_arg)] // `Any` downcasts a sized type: the `Vec`, not its slice.
fn as_f32<T: Real>(c: &Vec<T>) -> Option<&[f32]> {
    (c as &dyn Any).downcast_ref::<Vec<f32>>().map(Vec::as_slice)
}
