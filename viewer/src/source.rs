//! Where frames come from: the live core over iceoryx2 ([`LiveSource`]), or the built-in
//! animated limb ([`SyntheticSource`]) for tests and for running without a core.
//!
//! Both hand out [`SourceEvent`]s: a new [`ViewModel`] whenever the model changes (first
//! contact, core restarted with another model), then [`Frame`]s.
//!
//! # Restart contract
//! The viewer only ever subscribes, so it can start before the core, crash or restart without
//! the core noticing (the bridge's publishers never wait for subscribers). When the core
//! restarts, its frame sequence starts again at 0 and it republishes the topology; the live
//! source notices either and carries on.

use core::time::Duration;

use glam::Vec3;
use lamina_bridge::{
    Bridge, BridgeConfig, NodesSubscriber, SampleReceiveError, StatsSubscriber, ToolSubscriber, TopologySubscriber,
};

use crate::synthetic::SyntheticLimb;
use crate::view_model::{CoreStats, Frame, ToolPose, ViewModel};

/// What a source produced.
#[derive(Debug, Clone, PartialEq)]
pub enum SourceEvent {
    /// The model to draw from now on (comes before the first frame of that model).
    Model(ViewModel),
    /// A new frame of the current model.
    Frame(Frame),
    /// Nothing arrived within the timeout (the text says what is awaited).
    Idle(&'static str),
}

/// Why a source failed for good (a missing core is not an error: it is [`SourceEvent::Idle`]).
#[derive(Debug, thiserror::Error)]
pub enum SourceOpenError {
    /// The iceoryx2 node could not be opened.
    #[error("cannot open the bridge: {0}")]
    Bridge(lamina_bridge::BridgeOpenError),
    /// A subscriber could not be created.
    #[error("cannot subscribe: {0}")]
    Port(lamina_bridge::PortCreateError),
}

/// A stream of models and frames.
pub trait FrameSource {
    /// The next event, waiting up to `timeout` for one.
    fn next_event(&mut self, timeout: Duration) -> SourceEvent;

    /// One line saying what this source is.
    fn describe(&self) -> String;
}

/// The built-in animated limb: frame `k` is the limb at `k / rate_hz` seconds. Never waits.
#[derive(Debug, Clone)]
pub struct SyntheticSource {
    limb: SyntheticLimb,
    rate_hz: f64,
    start_time_s: f64,
    next: Option<u64>,
}

impl SyntheticSource {
    /// Frames of `limb` at `rate_hz`, starting at simulated time `start_time_s`.
    pub fn new(limb: SyntheticLimb, rate_hz: f64, start_time_s: f64) -> Self {
        Self { limb, rate_hz, start_time_s, next: None }
    }
}

impl Default for SyntheticSource {
    /// The default limb at 60 frames per simulated second, from t = 0.
    fn default() -> Self {
        Self::new(SyntheticLimb::default(), 60.0, 0.0)
    }
}

impl FrameSource for SyntheticSource {
    fn next_event(&mut self, _timeout: Duration) -> SourceEvent {
        match self.next {
            None => {
                self.next = Some(0);
                SourceEvent::Model(self.limb.view_model())
            }
            Some(k) => {
                self.next = Some(k + 1);
                SourceEvent::Frame(self.limb.frame(k, self.start_time_s + k as f64 / self.rate_hz))
            }
        }
    }

    fn describe(&self) -> String {
        format!("synthetic limb ({} x {} grid, {} Hz)", self.limb.columns, self.limb.rows, self.rate_hz)
    }
}

/// The live core: `topology`, `nodes`, `stats` and `tool` under a service prefix.
///
/// The model comes from the core's topology message alone ([`ViewModel::from_topology`]):
/// surface grids for the Bézier patches, springs for the wireframe, the tissue of every
/// layer and surface, the tool radius. The core re-sends it to late joiners every second, so
/// the viewer may start before or after the core and needs no scene file.
#[derive(Debug)]
pub struct LiveSource {
    prefix: String,
    topology: TopologySubscriber,
    nodes: NodesSubscriber,
    stats: StatsSubscriber,
    tool: ToolSubscriber,
    // Dropped last: the ports above belong to its node.
    _bridge: Bridge,
    model_nodes: Option<usize>,
    tool_radius_m: f32,
    last_sequence: Option<u64>,
    core_stats: Option<CoreStats>,
    tool_pose: Option<ToolPose>,
    restarts: u64,
}

impl LiveSource {
    /// Subscribes under `prefix`.
    pub fn open(prefix: &str) -> Result<Self, SourceOpenError> {
        let bridge = Bridge::open(&BridgeConfig::with_prefix(prefix)).map_err(SourceOpenError::Bridge)?;
        let port = SourceOpenError::Port;
        Ok(Self {
            prefix: prefix.to_owned(),
            topology: TopologySubscriber::create(&bridge).map_err(port)?,
            nodes: NodesSubscriber::create(&bridge).map_err(port)?,
            stats: StatsSubscriber::create(&bridge).map_err(port)?,
            tool: ToolSubscriber::create(&bridge).map_err(port)?,
            _bridge: bridge,
            model_nodes: None,
            tool_radius_m: 0.0,
            last_sequence: None,
            core_stats: None,
            tool_pose: None,
            restarts: 0,
        })
    }

    /// How many times the core was seen to restart (sequence went back).
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    fn take_topology(&mut self, wait: Duration) -> Option<ViewModel> {
        let sample = match self.topology.receive_timeout(wait) {
            Ok(Some(s)) => s,
            Ok(None) | Err(SampleReceiveError::Interrupted) => return None,
            Err(e) => {
                eprintln!("lamina-viewer: topology: {e}");
                return None;
            }
        };
        match sample.decode() {
            Ok(topology) => {
                let model = ViewModel::from_topology(&topology);
                self.model_nodes = Some(model.node_count);
                self.tool_radius_m = model.tool_radius_m;
                Some(model)
            }
            Err(e) => {
                eprintln!("lamina-viewer: ignoring a malformed topology: {e}");
                None
            }
        }
    }

    fn poll_side_channels(&mut self) {
        if let Ok(Some(s)) = self.stats.latest() {
            let m = s.message();
            let rate_hz = if m.period.p50_ns > 0 { 1e9 / m.period.p50_ns as f64 } else { 0.0 };
            self.core_stats = Some(CoreStats { rate_hz, misses: m.misses, ticks: m.ticks });
        }
        if let Ok(Some(t)) = self.tool.latest() {
            let m = t.message();
            let p = m.position;
            // A command's radius 0 means the scene's.
            let radius = if m.tool_radius_m > 0.0 { m.tool_radius_m as f32 } else { self.tool_radius_m };
            self.tool_pose =
                (radius > 0.0).then(|| ToolPose { center: Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32), radius });
        }
    }
}

impl FrameSource for LiveSource {
    fn next_event(&mut self, timeout: Duration) -> SourceEvent {
        // A (re)published topology always wins: the core (re)started.
        if let Some(model) = self.take_topology(if self.model_nodes.is_some() { Duration::ZERO } else { timeout }) {
            self.last_sequence = None;
            return SourceEvent::Model(model);
        }
        let Some(node_count) = self.model_nodes else {
            return SourceEvent::Idle("waiting for core (topology)");
        };
        self.poll_side_channels();
        let first = match self.nodes.receive_timeout(timeout) {
            Ok(Some(s)) => s,
            Ok(None) | Err(SampleReceiveError::Interrupted) => return SourceEvent::Idle("waiting for core (nodes)"),
            Err(e) => {
                eprintln!("lamina-viewer: nodes: {e}");
                return SourceEvent::Idle("waiting for core (nodes)");
            }
        };
        // Newest wins: drop what queued up while we were drawing. One sample is held while the
        // next is taken (a subscriber may borrow only `MAX_BORROWED_SAMPLES` = 2 at once; asking
        // `latest()` while still holding `first` took a third, failed, and drew the oldest
        // queued frame, ~15 ms behind the core).
        let mut sample = first;
        while let Ok(Some(newer)) = self.nodes.try_receive() {
            sample = newer;
        }
        let header = *sample.header();
        if header.node_count as usize != node_count || sample.positions().len() != node_count {
            // Frames of another model: the core restarted with a new model; await its topology.
            self.model_nodes = None;
            return SourceEvent::Idle("waiting for core (new topology)");
        }
        if self.last_sequence.is_some_and(|last| header.sequence < last) {
            self.restarts += 1;
            eprintln!("lamina-viewer: core restarted (sequence {} after {:?})", header.sequence, self.last_sequence);
        }
        self.last_sequence = Some(header.sequence);
        SourceEvent::Frame(Frame {
            sequence: header.sequence,
            sim_time_s: header.sim_time_s,
            publish_time_ns: header.publish_time_ns,
            positions: sample.positions().iter().map(|&p| Vec3::from_array(p)).collect(),
            tool: self.tool_pose,
            stats: self.core_stats,
        })
    }

    fn describe(&self) -> String {
        format!("live core on iceoryx2 services '{}/*'", self.prefix)
    }
}
