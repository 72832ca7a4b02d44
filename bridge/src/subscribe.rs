//! Subscribers that poll or block: node frames, the topology, and fixed-size messages.
//!
//! Every subscriber offers `try_receive` (never blocks), `receive_timeout` (sleeps on the
//! service's wake-up event until a sample arrives or the timeout passes) and `latest` (drains
//! the buffer and keeps the newest). Samples are views into shared memory: nothing is copied,
//! and the chunk returns to the publisher when the sample is dropped. A subscriber may hold at
//! most [`crate::services::MAX_BORROWED_SAMPLES`] samples at once.
//!
//! Samples still queued when their publisher is dropped are lost with its shared memory
//! (observed with iceoryx2 0.10): a publisher that sends once and exits may never be seen.
//!
//! For several sources in one loop, attach each subscriber's [`NodesSubscriber::listener`]
//! to an iceoryx2 `WaitSet`.
//!
//! # Examples
//!
//! ```
//! use core::time::Duration;
//! use lamina_bridge::{Bridge, BridgeConfig, StatsSubscriber};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_subscribe"))?;
//! let stats = StatsSubscriber::create(&bridge)?;
//! // Nobody publishes: the wait ends with `None` after the timeout.
//! assert!(stats.receive_timeout(Duration::from_millis(5))?.is_none());
//! # Ok(())
//! # }
//! ```

use core::time::Duration;
use std::time::Instant;

use iceoryx2::port::ReceiveError;
use iceoryx2::port::listener::{Listener, ListenerWaitError};
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::{ServiceName, ipc};
use iceoryx2::sample::Sample;

use crate::bridge::Bridge;
use crate::services::{
    Message, MessageService, NodesService, PortCreateError, TopologyService, WakeService, open_message_service,
    open_nodes_service, open_topology_service, open_wake_service,
};
use crate::topology::{Topology, TopologyDecodeError};
use crate::wire::{NodesHeader, TopologyHeader};

/// Why receiving failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SampleReceiveError {
    /// iceoryx2 could not receive (too many samples held, or a broken connection).
    #[error("cannot receive: {0}")]
    Receive(ReceiveError),
    /// Waiting on the wake-up event failed.
    #[error("cannot wait for a sample: {0}")]
    Wait(ListenerWaitError),
    /// A signal interrupted the wait; check for termination, then call again.
    #[error("wait interrupted by a signal")]
    Interrupted,
}

impl From<ReceiveError> for SampleReceiveError {
    fn from(value: ReceiveError) -> Self {
        Self::Receive(value)
    }
}

impl From<ListenerWaitError> for SampleReceiveError {
    fn from(value: ListenerWaitError) -> Self {
        match value {
            ListenerWaitError::InterruptSignal => Self::Interrupted,
            other => Self::Wait(other),
        }
    }
}

/// The listener half of a subscriber: sleeps until the publisher's notification.
#[derive(Debug)]
struct Wait {
    _service: WakeService,
    listener: Listener<ipc::Service>,
}

impl Wait {
    fn create(bridge: &Bridge, name: &ServiceName) -> Result<Self, PortCreateError> {
        let service = open_wake_service(bridge, name)?;
        let listener = service.listener_builder().create()?;
        Ok(Self { _service: service, listener })
    }

    /// Calls `try_once` until it yields a sample, sleeping on the listener in between, or
    /// until `timeout` has passed (then `None`). A notification sent between a failed
    /// `try_once` and the wait stays pending, so no wake-up is lost.
    fn until<S>(
        &self,
        timeout: Duration,
        mut try_once: impl FnMut() -> Result<Option<S>, SampleReceiveError>,
    ) -> Result<Option<S>, SampleReceiveError> {
        let deadline = Instant::now().checked_add(timeout);
        loop {
            if let Some(sample) = try_once()? {
                return Ok(Some(sample));
            }
            match deadline {
                None => {
                    self.listener.blocking_wait(|_| {})?;
                }
                Some(deadline) => {
                    let now = Instant::now();
                    if now >= deadline {
                        return Ok(None);
                    }
                    self.listener.timed_wait(|_| {}, deadline - now)?;
                }
            }
        }
    }
}

/// Keeps the newest of the samples `try_once` yields until it yields `None`.
fn drain<S>(
    mut try_once: impl FnMut() -> Result<Option<S>, SampleReceiveError>,
) -> Result<Option<S>, SampleReceiveError> {
    let mut latest = None;
    while let Some(sample) = try_once()? {
        latest = Some(sample);
    }
    Ok(latest)
}

/// One received node frame, a view into shared memory.
#[derive(Debug)]
pub struct NodesSample(Sample<ipc::Service, [[f32; 3]], NodesHeader>);

impl NodesSample {
    /// The frame header (sequence, tick, times, node count).
    pub fn header(&self) -> &NodesHeader {
        self.0.user_header()
    }

    /// The node positions, metres, `header().node_count` entries.
    pub fn positions(&self) -> &[[f32; 3]] {
        self.0.payload()
    }
}

/// Receives node frames from `<prefix>/nodes`.
#[derive(Debug)]
pub struct NodesSubscriber {
    _service: NodesService,
    subscriber: Subscriber<ipc::Service, [[f32; 3]], NodesHeader>,
    wait: Wait,
}

impl NodesSubscriber {
    /// Creates the subscriber (buffer [`crate::services::NODES_BUFFER_SIZE`] frames; the oldest
    /// is dropped when full) and its wake-up listener.
    pub fn create(bridge: &Bridge) -> Result<Self, PortCreateError> {
        let service = open_nodes_service(bridge)?;
        let subscriber = service.subscriber_builder().create()?;
        let wait = Wait::create(bridge, &bridge.names().nodes)?;
        Ok(Self { _service: service, subscriber, wait })
    }

    /// The oldest queued frame, or `None` at once if there is none.
    pub fn try_receive(&self) -> Result<Option<NodesSample>, SampleReceiveError> {
        Ok(self.subscriber.receive()?.map(NodesSample))
    }

    /// The oldest queued frame, waiting up to `timeout` for one; `None` when none came.
    pub fn receive_timeout(&self, timeout: Duration) -> Result<Option<NodesSample>, SampleReceiveError> {
        self.wait.until(timeout, || self.try_receive())
    }

    /// The newest queued frame, dropping older ones; `None` at once if there is none.
    pub fn latest(&self) -> Result<Option<NodesSample>, SampleReceiveError> {
        drain(|| self.try_receive())
    }

    /// The wake-up listener, to attach to an iceoryx2 `WaitSet`.
    pub fn listener(&self) -> &Listener<ipc::Service> {
        &self.wait.listener
    }
}

/// One received topology frame, a view into shared memory.
#[derive(Debug)]
pub struct TopologySample(Sample<ipc::Service, [u32], TopologyHeader>);

impl TopologySample {
    /// The wire header.
    pub fn header(&self) -> &TopologyHeader {
        self.0.user_header()
    }

    /// The raw payload words (layout in [`TopologyHeader`]).
    pub fn words(&self) -> &[u32] {
        self.0.payload()
    }

    /// Validates and converts to a [`Topology`].
    pub fn decode(&self) -> Result<Topology, TopologyDecodeError> {
        Topology::decode(self.header(), self.words())
    }
}

/// Receives the topology from `<prefix>/topology`, including the last one published before
/// this subscriber existed.
#[derive(Debug)]
pub struct TopologySubscriber {
    _service: TopologyService,
    subscriber: Subscriber<ipc::Service, [u32], TopologyHeader>,
    wait: Wait,
}

impl TopologySubscriber {
    /// Creates the subscriber and its wake-up listener.
    pub fn create(bridge: &Bridge) -> Result<Self, PortCreateError> {
        let service = open_topology_service(bridge)?;
        let subscriber = service.subscriber_builder().create()?;
        let wait = Wait::create(bridge, &bridge.names().topology)?;
        Ok(Self { _service: service, subscriber, wait })
    }

    /// A queued topology, or `None` at once.
    pub fn try_receive(&self) -> Result<Option<TopologySample>, SampleReceiveError> {
        Ok(self.subscriber.receive()?.map(TopologySample))
    }

    /// A topology, waiting up to `timeout` for one; `None` when none came.
    ///
    /// A late joiner receives the last topology once the publisher serves late joiners
    /// ([`crate::TopologyPublisher::serve_late_joiners`]), which also wakes this wait only if
    /// the publisher then notifies; so wait in short slices if the publisher only serves.
    pub fn receive_timeout(&self, timeout: Duration) -> Result<Option<TopologySample>, SampleReceiveError> {
        self.wait.until(timeout, || self.try_receive())
    }

    /// The wake-up listener, to attach to an iceoryx2 `WaitSet`.
    pub fn listener(&self) -> &Listener<ipc::Service> {
        &self.wait.listener
    }
}

/// One received fixed-size message, a view into shared memory.
#[derive(Debug)]
pub struct MessageSample<M: Message>(Sample<ipc::Service, M, ()>);

impl<M: Message> MessageSample<M> {
    /// The message.
    pub fn message(&self) -> &M {
        self.0.payload()
    }
}

/// Receives fixed-size messages of type `M` from `M`'s service, including the last one
/// published before this subscriber existed (history 1).
#[derive(Debug)]
pub struct MessageSubscriber<M: Message> {
    _service: MessageService<M>,
    subscriber: Subscriber<ipc::Service, M, ()>,
    wait: Wait,
}

/// Subscriber of tool commands (core side).
pub type ToolSubscriber = MessageSubscriber<crate::wire::ToolCommand>;
/// Subscriber of contact feedback (haptics side).
pub type FeedbackSubscriber = MessageSubscriber<crate::wire::ContactFeedback>;
/// Subscriber of deadline-monitor summaries.
pub type StatsSubscriber = MessageSubscriber<crate::wire::StatsSummary>;

impl<M: Message> MessageSubscriber<M> {
    /// Creates the subscriber (buffer `M::BUFFER_SIZE`) and its wake-up listener.
    pub fn create(bridge: &Bridge) -> Result<Self, PortCreateError> {
        let service = open_message_service::<M>(bridge)?;
        let subscriber = service.subscriber_builder().create()?;
        let wait = Wait::create(bridge, M::service_name(bridge.names()))?;
        Ok(Self { _service: service, subscriber, wait })
    }

    /// The oldest queued message, or `None` at once.
    pub fn try_receive(&self) -> Result<Option<MessageSample<M>>, SampleReceiveError> {
        Ok(self.subscriber.receive()?.map(MessageSample))
    }

    /// The oldest queued message, waiting up to `timeout`; `None` when none came.
    pub fn receive_timeout(&self, timeout: Duration) -> Result<Option<MessageSample<M>>, SampleReceiveError> {
        self.wait.until(timeout, || self.try_receive())
    }

    /// The newest queued message, dropping older ones ("newest wins"); `None` at once if none.
    pub fn latest(&self) -> Result<Option<MessageSample<M>>, SampleReceiveError> {
        drain(|| self.try_receive())
    }

    /// The wake-up listener, to attach to an iceoryx2 `WaitSet`.
    pub fn listener(&self) -> &Listener<ipc::Service> {
        &self.wait.listener
    }
}
