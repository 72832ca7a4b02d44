//! Lamina's wire contract over iceoryx2: frame types, service names and QoS, and the
//! publishers and subscribers every Lamina process uses.
//!
//! # How it fits together
//! 1. [`Bridge::open`] creates the process's iceoryx2 node under a service prefix
//!    (default `lamina`) and cleans up peers that died.
//! 2. [`services`] builds every service from one function each, so QoS always matches.
//! 3. [`publish`] writes straight into shared memory and never waits for a subscriber.
//! 4. [`subscribe`] polls or blocks (with a timeout) and hands out views, not copies.
//! 5. [`wire`] holds the only definition of the byte layout; [`topology`] converts the static
//!    model to and from it; [`now_ns`] is the cross-process time base.
//!
//! Architecture invariant: this crate knows nothing of the physics; it moves positions,
//! poses, forces and statistics.
//!
//! # Examples
//!
//! ```
//! use core::time::Duration;
//! use lamina_bridge::{Bridge, BridgeConfig, NodesPublisher, NodesSubscriber};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_lib"))?;
//! let subscriber = NodesSubscriber::create(&bridge)?;
//! let publisher = NodesPublisher::create(&bridge, 2769)?;
//! publisher.publish(0, 0, 0.0, 2769, |p| p.fill([0.0, 0.0, 1.0]))?;
//! let frame = subscriber.receive_timeout(Duration::from_secs(1))?.expect("published");
//! assert_eq!(frame.header().node_count, 2769);
//! # Ok(())
//! # }
//! ```

pub mod bridge;
mod chunk_contents;
pub mod domain;
mod interleave;
pub mod publish;
pub mod services;
pub mod subscribe;
pub mod topology;
pub mod wire;

pub use bridge::{Bridge, BridgeConfig, BridgeOpenError, DEFAULT_PREFIX, ServiceNames};
pub use domain::{DomainError, PrefixLock, PrefixLockError, UserDomain};
/// The time base of every `*_time_ns` field on the wire: `CLOCK_MONOTONIC`, ns.
pub use lamina_rt::now_ns;
pub use publish::{
    FeedbackPublisher, MessagePublishError, MessagePublisher, NodeChanges, NodesPublishError, NodesPublisher,
    NodesPublisherCreateError, StatsPublisher, ToolPublisher, TopologyPublishError, TopologyPublisher,
};
pub use services::{Message, PortCreateError, PubSubSettings, ServiceOpenError, SettingMismatch};
pub use subscribe::{
    FeedbackSubscriber, MessageSample, MessageSubscriber, NodesSample, NodesSubscriber, SampleReceiveError,
    StatsSubscriber, ToolSubscriber, TopologySample, TopologySubscriber,
};
pub use topology::{
    LayerRange, SurfaceTopology, TissueKind, Topology, TopologyDecodeError, TopologyEncodeError, VolumePathError,
    VolumeTopology,
};
pub use wire::{ContactFeedback, NodesHeader, Percentiles, StatsSummary, ToolCommand, ToolKind, WireTool};
