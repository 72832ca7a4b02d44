//! What the haptics process takes from the core's topology message: the device-to-model
//! mapping (device origin, axes, position and force scales) and the tool, so that a haptics
//! process needs neither the scene file nor mapping flags.

use core::time::Duration;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use lamina_bridge::{Bridge, SampleReceiveError, Topology, TopologySubscriber, WireTool};

use crate::DeviceMapping;

/// `WireTool::source` of a tool the haptics process drives.
const SOURCE_HAPTICS: u32 = 2;

/// Why the core's model could not be learnt.
#[derive(Debug, thiserror::Error)]
pub enum CoreModelError {
    /// The topology subscriber could not be created.
    #[error("cannot subscribe to the core's topology: {0}")]
    Subscribe(#[from] lamina_bridge::PortCreateError),
    /// No topology arrived in time.
    #[error(
        "no Lamina core published its model on prefix '{prefix}' within {waited_s:.0} s: start `lamina run --prefix {prefix}` (or give --origin to drive the device without it)"
    )]
    NoCore {
        /// The service prefix listened on.
        prefix: String,
        /// How long it waited, s.
        waited_s: f64,
    },
    /// Stopped (SIGINT/SIGTERM) while waiting.
    #[error("stopped while waiting for the core's model")]
    Stopped,
    /// The topology on the wire is malformed.
    #[error("the core's topology is malformed: {0}")]
    Malformed(#[from] lamina_bridge::TopologyDecodeError),
}

/// The core's model as the haptics process uses it.
#[derive(Debug, Clone, PartialEq)]
pub struct CoreModel {
    /// Model name.
    pub name: String,
    /// Nodes.
    pub nodes: u32,
    /// The scene's tool and device mapping.
    pub tool: WireTool,
}

impl CoreModel {
    /// The device-to-model mapping the core's scene asks for.
    pub fn mapping(&self) -> DeviceMapping {
        DeviceMapping::from_wire(&self.tool)
    }

    /// Whether the core's scene drives its tool from a haptics process (else tool commands
    /// are ignored and the force stays zero).
    pub fn tool_follows_haptics(&self) -> bool {
        self.tool.source == SOURCE_HAPTICS
    }
}

impl From<&Topology> for CoreModel {
    fn from(t: &Topology) -> Self {
        Self { name: t.name.clone(), nodes: t.node_count, tool: t.tool }
    }
}

/// Waits for the core's topology on `bridge`'s prefix, up to `timeout` or until `stop` is set.
/// The core re-sends it to late joiners every second, so a running core answers within about
/// a second.
///
/// # Errors
/// [`CoreModelError`]: no core in time, stopped, or a malformed topology.
pub fn wait_for_core_model(
    bridge: &Bridge,
    prefix: &str,
    timeout: Duration,
    stop: &AtomicBool,
) -> Result<CoreModel, CoreModelError> {
    let subscriber = TopologySubscriber::create(bridge)?;
    let start = Instant::now();
    while start.elapsed() < timeout {
        if stop.load(Ordering::Relaxed) {
            return Err(CoreModelError::Stopped);
        }
        match subscriber.receive_timeout(Duration::from_millis(50)) {
            Ok(Some(sample)) => return Ok(CoreModel::from(&sample.decode()?)),
            Ok(None) | Err(SampleReceiveError::Interrupted) => {}
            Err(_) => std::thread::sleep(Duration::from_millis(50)),
        }
    }
    Err(CoreModelError::NoCore { prefix: prefix.to_owned(), waited_s: timeout.as_secs_f64() })
}
