//! One connection to a Lamina core, in safe Rust: the ports on the core's services, the
//! topology read when opening, and the checks every call makes. The exported functions in
//! `lib.rs` only convert arguments and call these methods.

use core::time::Duration;
use std::time::Instant;

use iceoryx2::service::port_factory::PortFactory as _;
use lamina_bridge::services::{NodesService, open_nodes_service};
use lamina_bridge::{
    Bridge, BridgeConfig, BridgeOpenError, FeedbackSubscriber, NodesSample, NodesSubscriber, SampleReceiveError,
    ToolCommand, ToolKind, ToolPublisher, Topology, TopologySubscriber, now_ns,
};

use crate::failure::Failure;
use crate::types::{
    LaminaFeedback, LaminaFrameInfo, LaminaLayerInfo, LaminaStatus, LaminaSurfaceInfo, LaminaToolCommand,
    LaminaToolInfo, LaminaTopologyInfo,
};

/// The core refuses a command coordinate at or beyond this magnitude, m (per coordinate).
const POSITION_BOUND_M: f64 = 1000.0;
/// The core refuses a radius at or beyond this, m.
const RADIUS_BOUND_M: f64 = 1.0;
/// Tool source code of a tool that follows tool commands.
const TOOL_SOURCE_COMMANDS: u32 = 2;
/// Slice of the topology wait: the core hands the topology to late joiners without a
/// wake-up, so the wait polls at this interval.
const TOPOLOGY_POLL: Duration = Duration::from_millis(20);
/// Interval of the feedback poll (the core does not notify feedback).
const FEEDBACK_POLL: Duration = Duration::from_micros(250);

/// A connection to one core: see the module documentation.
#[derive(Debug)]
pub(crate) struct Client {
    prefix: String,
    topology: Topology,
    revision: u64,
    nodes: NodesSubscriber,
    feedback: FeedbackSubscriber,
    /// Created by the first tool command, so a client that only reads takes no publisher slot.
    tool: Option<ToolPublisher>,
    tool_sequence: u64,
    /// Kept to count the publishers of `nodes`: none left means the core is gone.
    nodes_service: NodesService,
    bridge: Bridge,
}

fn connect(prefix: &str, what: &str, e: impl core::fmt::Display) -> Failure {
    Failure::new(LaminaStatus::Connect, format!("lamina_open: prefix '{prefix}': cannot open {what}: {e}"))
}

fn ipc(function: &str, e: SampleReceiveError) -> Failure {
    Failure::new(LaminaStatus::Ipc, format!("{function}: {e}"))
}

/// `text` in a NUL-terminated field of `N` bytes (it fits: wire names are shorter).
fn c_name<const N: usize>(text: &str) -> [core::ffi::c_char; N] {
    let mut out = [0; N];
    for (o, b) in out.iter_mut().zip(text.bytes().take(N - 1)) {
        *o = b as core::ffi::c_char;
    }
    out
}

/// Refuses a capacity below `needed` elements for `argument` of `function`.
pub(crate) fn check_capacity(function: &str, argument: &str, capacity: usize, needed: usize) -> Result<(), Failure> {
    if capacity < needed {
        return Err(Failure::new(
            LaminaStatus::BufferTooSmall,
            format!("{function}: {argument} holds {capacity}, the model needs {needed}"),
        ));
    }
    Ok(())
}

impl Client {
    /// Joins the user's iceoryx2 domain under `prefix` and waits up to `timeout` for the
    /// core's topology.
    pub fn open(prefix: &str, timeout: Duration) -> Result<Self, Failure> {
        let config = BridgeConfig { node_name: Some("lamina_client".into()), ..BridgeConfig::with_prefix(prefix) };
        let bridge = Bridge::open(&config).map_err(|e| match e {
            BridgeOpenError::InvalidPrefix => Failure::new(
                LaminaStatus::InvalidArgument,
                format!(
                    "lamina_open: prefix '{prefix}' is not a service prefix: it must be non-empty, '<prefix>/topology' at most 255 bytes, not starting with iox2://"
                ),
            ),
            other => connect(prefix, "the iceoryx2 node", other),
        })?;
        let nodes_service = open_nodes_service(&bridge).map_err(|e| connect(prefix, "the nodes service", e))?;
        let nodes = NodesSubscriber::create(&bridge).map_err(|e| connect(prefix, "the nodes subscriber", e))?;
        let feedback =
            FeedbackSubscriber::create(&bridge).map_err(|e| connect(prefix, "the feedback subscriber", e))?;
        let topology_sub =
            TopologySubscriber::create(&bridge).map_err(|e| connect(prefix, "the topology subscriber", e))?;
        let start = Instant::now();
        let sample = loop {
            if let Some(sample) = topology_sub.try_receive().map_err(|e| ipc("lamina_open", e))? {
                break sample;
            }
            let left = timeout.saturating_sub(start.elapsed());
            if left.is_zero() {
                let domain = bridge.domain();
                return Err(Failure::new(
                    LaminaStatus::Timeout,
                    format!(
                        "lamina_open: no Lamina core answered on prefix '{prefix}' within {} ms (no topology on '{prefix}/topology'): is `lamina run --prefix {prefix}` running as this user (uid {}, iceoryx2 domain {})?",
                        timeout.as_millis(),
                        domain.uid,
                        domain.root.display()
                    ),
                ));
            }
            if let Some(sample) =
                topology_sub.receive_timeout(left.min(TOPOLOGY_POLL)).map_err(|e| ipc("lamina_open", e))?
            {
                break sample;
            }
        };
        let revision = sample.header().revision;
        let topology = sample
            .decode()
            .map_err(|e| Failure::new(LaminaStatus::Protocol, format!("lamina_open: prefix '{prefix}': {e}")))?;
        drop(sample);
        Ok(Self {
            prefix: prefix.to_owned(),
            topology,
            revision,
            nodes,
            feedback,
            tool: None,
            tool_sequence: 0,
            nodes_service,
            bridge,
        })
    }

    /// The topology's counts and tool.
    pub fn topology_info(&self) -> LaminaTopologyInfo {
        let t = &self.topology;
        let w = &t.tool;
        let r = w.device_rotation;
        LaminaTopologyInfo {
            revision: self.revision,
            node_count: t.node_count,
            triangle_count: t.triangles.len() as u32,
            layer_count: t.layers.len() as u32,
            surface_count: t.surfaces.len() as u32,
            spring_count: t.springs.len() as u32,
            rest_position_count: t.rest_positions.len() as u32,
            tool: LaminaToolInfo {
                source: w.source,
                reserved: 0,
                radius_m: w.radius_m,
                min_radius_m: w.min_radius_m,
                stiffness_n_per_m: w.stiffness_n_per_m,
                device_origin_m: w.device_origin_m,
                device_rotation: [r[0][0], r[0][1], r[0][2], r[1][0], r[1][1], r[1][2], r[2][0], r[2][1], r[2][2]],
                position_scale: w.position_scale,
                force_scale: w.force_scale,
            },
            model_name: c_name(&t.name),
        }
    }

    fn index(function: &str, what: &str, index: u32, count: usize) -> Result<usize, Failure> {
        let i = index as usize;
        if i >= count {
            return Err(Failure::new(
                LaminaStatus::InvalidArgument,
                format!("{function}: {what} index {index} is past the table ({count} entries)"),
            ));
        }
        Ok(i)
    }

    /// Layer `index`.
    pub fn layer_info(&self, index: u32) -> Result<LaminaLayerInfo, Failure> {
        let l = &self.topology.layers[Self::index("lamina_layer_info", "layer", index, self.topology.layers.len())?];
        Ok(LaminaLayerInfo {
            first_node: l.first_node,
            node_count: l.node_count,
            tissue: l.tissue.code(),
            name: c_name(&l.name),
        })
    }

    /// Surface `index`.
    pub fn surface_info(&self, index: u32) -> Result<LaminaSurfaceInfo, Failure> {
        let s = self.surface("lamina_surface_info", index)?;
        let (grid_cols, grid_rows) = s.grid.unwrap_or((0, 0));
        Ok(LaminaSurfaceInfo {
            tissue: s.tissue.code(),
            grid_cols,
            grid_rows,
            index_count: s.indices.len() as u32,
            name: c_name(&s.name),
        })
    }

    /// Surface `index` of the topology, for `function`'s message.
    pub fn surface(&self, function: &str, index: u32) -> Result<&lamina_bridge::SurfaceTopology, Failure> {
        Ok(&self.topology.surfaces[Self::index(function, "surface", index, self.topology.surfaces.len())?])
    }

    /// The topology itself.
    pub fn topology(&self) -> &Topology {
        &self.topology
    }

    /// Copies `sample` into `positions` (3 floats per node) after checking it belongs to
    /// this topology.
    fn copy_frame(
        &self,
        function: &str,
        sample: &NodesSample,
        positions: &mut [f32],
    ) -> Result<LaminaFrameInfo, Failure> {
        let h = *sample.header();
        let p = sample.positions();
        if p.len() != self.topology.node_count as usize || h.node_count as usize != p.len() {
            return Err(Failure::new(
                LaminaStatus::Protocol,
                format!(
                    "{function}: a frame of {} nodes (header {}) on '{}/nodes', the topology has {}: the core runs another model now; close and open again",
                    p.len(),
                    h.node_count,
                    self.prefix,
                    self.topology.node_count
                ),
            ));
        }
        for (out, node) in positions.chunks_exact_mut(3).zip(p) {
            out.copy_from_slice(node);
        }
        Ok(LaminaFrameInfo {
            sequence: h.sequence,
            tick: h.tick,
            sim_time_s: h.sim_time_s,
            publish_time_ns: h.publish_time_ns,
            node_count: h.node_count,
            reserved: 0,
        })
    }

    /// Nothing arrived within `timeout`: [`LaminaStatus::CoreGone`] when no process publishes
    /// node frames any more (dead peers cleaned up first), else [`LaminaStatus::Timeout`].
    fn nothing(&self, function: &str, what: &str, timeout: Duration) -> Failure {
        let _ = self.bridge.cleanup_dead_peers();
        if self.nodes_service.dynamic_config().number_of_publishers() == 0 {
            return Failure::new(
                LaminaStatus::CoreGone,
                format!(
                    "{function}: the core on prefix '{}' is gone (no process publishes '{}/nodes' any more): it stopped or was killed; open again to wait for the next one",
                    self.prefix, self.prefix
                ),
            );
        }
        Failure::new(
            LaminaStatus::Timeout,
            format!("{function}: no {what} on prefix '{}' within {} ms", self.prefix, timeout.as_millis()),
        )
    }

    /// The oldest queued frame (frames in order), waiting up to `timeout`.
    pub fn next_frame(&self, timeout: Duration, positions: &mut [f32]) -> Result<LaminaFrameInfo, Failure> {
        const F: &str = "lamina_next_frame";
        match self.nodes.receive_timeout(timeout).map_err(|e| ipc(F, e))? {
            Some(sample) => self.copy_frame(F, &sample, positions),
            None => Err(self.nothing(F, "node frame", timeout)),
        }
    }

    /// The newest frame, dropping older queued ones, waiting up to `timeout` when none is
    /// queued. One copy: the newest frame only.
    pub fn latest_frame(&self, timeout: Duration, positions: &mut [f32]) -> Result<LaminaFrameInfo, Failure> {
        const F: &str = "lamina_latest_frame";
        let Some(mut newest) = self.nodes.receive_timeout(timeout).map_err(|e| ipc(F, e))? else {
            return Err(self.nothing(F, "node frame", timeout));
        };
        // At most two samples held at once: the newest so far and the one just received.
        while let Some(next) = self.nodes.try_receive().map_err(|e| ipc(F, e))? {
            newest = next;
        }
        self.copy_frame(F, &newest, positions)
    }

    /// The newest contact feedback, polling up to `timeout` when none is queued.
    pub fn latest_feedback(&self, timeout: Duration) -> Result<LaminaFeedback, Failure> {
        const F: &str = "lamina_latest_feedback";
        let start = Instant::now();
        loop {
            if let Some(sample) = self.feedback.latest().map_err(|e| ipc(F, e))? {
                let m = *sample.message();
                let s = m.stiffness;
                return Ok(LaminaFeedback {
                    sequence: m.sequence,
                    tick: m.tick,
                    publish_time_ns: m.publish_time_ns,
                    in_contact: m.in_contact,
                    reserved: 0,
                    force: m.force,
                    stiffness: [s[0][0], s[0][1], s[0][2], s[1][0], s[1][1], s[1][2], s[2][0], s[2][1], s[2][2]],
                    x_ref: m.x_ref,
                });
            }
            if start.elapsed() >= timeout {
                let mut failure = self.nothing(F, "contact feedback", timeout);
                if failure.status == LaminaStatus::Timeout && self.topology.tool.source != TOOL_SOURCE_COMMANDS {
                    failure.message.push_str(&format!(
                        ": the scene's tool does not follow tool commands (tool source {}), so the core sends none",
                        self.topology.tool.source
                    ));
                }
                return Err(failure);
            }
            std::thread::sleep(FEEDBACK_POLL);
        }
    }

    /// Checks `command` against the core's bounds and sends it on `tool`.
    pub fn send_tool(&mut self, function: &str, command: &LaminaToolCommand) -> Result<(), Failure> {
        let bad = |message: String| Err(Failure::new(LaminaStatus::InvalidArgument, format!("{function}: {message}")));
        for (axis, &v) in ["x", "y", "z"].iter().zip(&command.position) {
            if !v.is_finite() || v.abs() >= POSITION_BOUND_M {
                return bad(format!(
                    "position {axis} = {v} m is not finite or beyond the bound of {POSITION_BOUND_M} m per coordinate"
                ));
            }
        }
        if !command.orientation.iter().all(|v| v.is_finite()) {
            return bad(format!("orientation {:?} is not finite", command.orientation));
        }
        let r = command.radius_m;
        if !(r.is_finite() && (0.0..RADIUS_BOUND_M).contains(&r)) {
            return bad(format!("radius {r} m is outside 0 <= r < {RADIUS_BOUND_M} m"));
        }
        let Ok(kind) = ToolKind::from_code(command.kind) else {
            return bad(format!("kind {} is no tool (0: LAMINA_TOOL_SPHERE, 1: LAMINA_TOOL_SCALPEL)", command.kind));
        };
        let blade = command.blade_length_m;
        if !(blade.is_finite() && (0.0..RADIUS_BOUND_M).contains(&blade)) {
            return bad(format!("blade length {blade} m is outside 0 <= l < {RADIUS_BOUND_M} m"));
        }
        if kind == ToolKind::Scalpel && command.orientation.iter().all(|&q| q == 0.0) {
            return bad("orientation [0, 0, 0, 0] turns the scalpel's edge nowhere: give a unit quaternion (identity [0, 0, 0, 1]: the edge straight up)".into());
        }
        if self.topology.tool.source != TOOL_SOURCE_COMMANDS {
            return Err(Failure::new(
                LaminaStatus::NoTool,
                format!(
                    "{function}: the scene on prefix '{}' has no tool that follows tool commands (tool source {}: 0 none, 1 scripted); run a scene with [effects.tool] source = \"haptics\"",
                    self.prefix, self.topology.tool.source
                ),
            ));
        }
        if self.tool.is_none() {
            let publisher = ToolPublisher::create(&self.bridge).map_err(|e| {
                Failure::new(
                    LaminaStatus::Connect,
                    format!("{function}: cannot publish on '{}/tool': {e}", self.prefix),
                )
            })?;
            self.tool = Some(publisher);
        }
        let message = ToolCommand {
            sequence: self.tool_sequence,
            time_ns: now_ns(),
            position: command.position,
            orientation: command.orientation,
            buttons: command.buttons,
            kind: kind.code(),
            tool_radius_m: r,
            blade_length_m: blade,
        };
        if let Some(tool) = &self.tool {
            tool.publish_polled(&message).map_err(|e| {
                Failure::new(LaminaStatus::Ipc, format!("{function}: cannot send on '{}/tool': {e}", self.prefix))
            })?;
        }
        self.tool_sequence += 1;
        Ok(())
    }
}
