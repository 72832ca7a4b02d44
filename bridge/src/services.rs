//! Service construction: the ONE place each service's quality of service is defined.
//!
//! iceoryx2 treats QoS as minimum requirements when opening and refuses mismatches, so every
//! publisher and subscriber of a service is built through the function here:
//! [`open_nodes_service`], [`open_topology_service`], [`open_message_service`] (tool, feedback,
//! stats, chosen by the [`Message`] type) and [`open_wake_service`] for the wake-up events.
//!
//! Common settings: safe overflow on (a full subscriber buffer drops its oldest sample, the
//! publisher never waits), history 1 (late joiners get the last value), small buffers,
//! [`MAX_SUBSCRIBERS`] subscribers and [`MAX_PUBLISHERS`] publishers so a restarted peer finds
//! a free slot before the dead one is cleaned.
//!
//! # Examples
//!
//! ```
//! use iceoryx2::service::port_factory::PortFactory;
//! use lamina_bridge::{Bridge, BridgeConfig, services, wire::ToolCommand};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_services"))?;
//! let tool = services::open_message_service::<ToolCommand>(&bridge)?;
//! assert_eq!(tool.name().as_str(), "doc_services/tool");
//! # Ok(())
//! # }
//! ```

use core::fmt::Debug;

use iceoryx2::port::listener::ListenerCreateError;
use iceoryx2::port::notifier::NotifierCreateError;
use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::port::subscriber::SubscriberCreateError;
use iceoryx2::prelude::{ServiceName, ZeroCopySend, ipc};
use iceoryx2::service::builder::event::EventOpenOrCreateError;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError;
use iceoryx2::service::port_factory::{event, publish_subscribe};

use crate::bridge::{Bridge, ServiceNames};
use crate::wire::{ContactFeedback, NodesHeader, StatsSummary, ToolCommand, TopologyHeader};

/// Maximum subscribers per service (viewer, haptics, profiler, tools, restarts).
pub const MAX_SUBSCRIBERS: usize = 8;
/// Maximum publishers per service (the owner plus one restarted before cleanup).
pub const MAX_PUBLISHERS: usize = 2;
/// Maximum iceoryx2 nodes (processes) attached to one service.
pub const MAX_SERVICE_NODES: usize = 20;
/// Samples a subscriber may hold at once before returning them.
pub const MAX_BORROWED_SAMPLES: usize = 2;
/// Subscriber buffer of the `nodes` service: frames queued before the oldest is dropped
/// (16 ticks at 1 kHz: a haptics process descheduled for up to 16 ms still sees every frame).
pub const NODES_BUFFER_SIZE: usize = 16;
/// Subscriber buffer of the `topology` service.
pub const TOPOLOGY_BUFFER_SIZE: usize = 1;
/// Maximum listeners (blocking subscribers) per wake-up event service.
pub const MAX_LISTENERS: usize = 16;
/// Maximum notifiers per wake-up event service.
pub const MAX_NOTIFIERS: usize = 4;

/// The `nodes` service handle: `[[f32; 3]]` positions with a [`NodesHeader`].
pub type NodesService = publish_subscribe::PortFactory<ipc::Service, [[f32; 3]], NodesHeader>;
/// The `topology` service handle: `[u32]` words with a [`TopologyHeader`].
pub type TopologyService = publish_subscribe::PortFactory<ipc::Service, [u32], TopologyHeader>;
/// A fixed-size message service handle (tool, feedback, stats).
pub type MessageService<M> = publish_subscribe::PortFactory<ipc::Service, M, ()>;
/// A wake-up event service handle.
pub type WakeService = event::PortFactory<ipc::Service>;

/// A fixed-size message with its own service: its name and QoS live with the type.
pub trait Message: Debug + Copy + Default + ZeroCopySend + 'static {
    /// Service name below the prefix, for example `"tool"`.
    fn service_name(names: &ServiceNames) -> &ServiceName;
    /// Subscriber buffer size: messages queued before the oldest is dropped.
    const BUFFER_SIZE: usize;
    /// Messages kept for late joiners.
    const HISTORY_SIZE: usize = 1;
}

impl Message for ToolCommand {
    fn service_name(names: &ServiceNames) -> &ServiceName {
        &names.tool
    }
    /// Newest wins: the core drains to the latest each tick.
    const BUFFER_SIZE: usize = 4;
}

impl Message for ContactFeedback {
    fn service_name(names: &ServiceNames) -> &ServiceName {
        &names.feedback
    }
    /// Every tick: a little slack for a haptics loop that runs late.
    const BUFFER_SIZE: usize = 8;
}

impl Message for StatsSummary {
    fn service_name(names: &ServiceNames) -> &ServiceName {
        &names.stats
    }
    /// One per second.
    const BUFFER_SIZE: usize = 4;
}

/// Why a service could not be opened or created.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ServiceOpenError {
    /// The publish-subscribe service failed (often: QoS or type mismatch with an old peer).
    PublishSubscribe(PublishSubscribeOpenOrCreateError),
    /// The wake-up event service failed.
    Event(EventOpenOrCreateError),
}

impl From<PublishSubscribeOpenOrCreateError> for ServiceOpenError {
    fn from(value: PublishSubscribeOpenOrCreateError) -> Self {
        Self::PublishSubscribe(value)
    }
}

impl From<EventOpenOrCreateError> for ServiceOpenError {
    fn from(value: EventOpenOrCreateError) -> Self {
        Self::Event(value)
    }
}

impl core::fmt::Display for ServiceOpenError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::PublishSubscribe(e) => write!(f, "cannot open publish-subscribe service: {e:?}"),
            Self::Event(e) => write!(f, "cannot open event service: {e:?}"),
        }
    }
}

impl core::error::Error for ServiceOpenError {}

/// Why a publisher or subscriber (with its notifier or listener) could not be created.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PortCreateError {
    /// The service itself could not be opened.
    Service(ServiceOpenError),
    /// iceoryx2 refused the publisher (for example: too many publishers).
    Publisher(PublisherCreateError),
    /// iceoryx2 refused the subscriber (for example: too many subscribers).
    Subscriber(SubscriberCreateError),
    /// iceoryx2 refused the wake-up notifier.
    Notifier(NotifierCreateError),
    /// iceoryx2 refused the wake-up listener.
    Listener(ListenerCreateError),
}

impl From<ServiceOpenError> for PortCreateError {
    fn from(value: ServiceOpenError) -> Self {
        Self::Service(value)
    }
}
impl From<PublishSubscribeOpenOrCreateError> for PortCreateError {
    fn from(value: PublishSubscribeOpenOrCreateError) -> Self {
        Self::Service(value.into())
    }
}
impl From<EventOpenOrCreateError> for PortCreateError {
    fn from(value: EventOpenOrCreateError) -> Self {
        Self::Service(value.into())
    }
}
impl From<PublisherCreateError> for PortCreateError {
    fn from(value: PublisherCreateError) -> Self {
        Self::Publisher(value)
    }
}
impl From<SubscriberCreateError> for PortCreateError {
    fn from(value: SubscriberCreateError) -> Self {
        Self::Subscriber(value)
    }
}
impl From<NotifierCreateError> for PortCreateError {
    fn from(value: NotifierCreateError) -> Self {
        Self::Notifier(value)
    }
}
impl From<ListenerCreateError> for PortCreateError {
    fn from(value: ListenerCreateError) -> Self {
        Self::Listener(value)
    }
}

impl core::fmt::Display for PortCreateError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Service(e) => write!(f, "{e}"),
            Self::Publisher(e) => write!(f, "cannot create publisher: {e}"),
            Self::Subscriber(e) => write!(f, "cannot create subscriber: {e}"),
            Self::Notifier(e) => write!(f, "cannot create notifier: {e}"),
            Self::Listener(e) => write!(f, "cannot create listener: {e}"),
        }
    }
}

impl core::error::Error for PortCreateError {}

/// Opens or creates `<prefix>/nodes`: buffer [`NODES_BUFFER_SIZE`], history 1, safe overflow.
pub fn open_nodes_service(bridge: &Bridge) -> Result<NodesService, ServiceOpenError> {
    Ok(bridge
        .node()
        .service_builder(&bridge.names().nodes)
        .publish_subscribe::<[[f32; 3]]>()
        .user_header::<NodesHeader>()
        .enable_safe_overflow(true)
        .history_size(1)
        .subscriber_max_buffer_size(NODES_BUFFER_SIZE)
        .subscriber_max_borrowed_samples(MAX_BORROWED_SAMPLES)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create()?)
}

/// Opens or creates `<prefix>/topology`: buffer 1, history 1 (late joiners), safe overflow.
pub fn open_topology_service(bridge: &Bridge) -> Result<TopologyService, ServiceOpenError> {
    Ok(bridge
        .node()
        .service_builder(&bridge.names().topology)
        .publish_subscribe::<[u32]>()
        .user_header::<TopologyHeader>()
        .enable_safe_overflow(true)
        .history_size(1)
        .subscriber_max_buffer_size(TOPOLOGY_BUFFER_SIZE)
        .subscriber_max_borrowed_samples(MAX_BORROWED_SAMPLES)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create()?)
}

/// Opens or creates the service of message type `M` (`<prefix>/tool`, `/feedback`, `/stats`)
/// with `M`'s buffer and history sizes and safe overflow.
pub fn open_message_service<M: Message>(bridge: &Bridge) -> Result<MessageService<M>, ServiceOpenError> {
    Ok(bridge
        .node()
        .service_builder(M::service_name(bridge.names()))
        .publish_subscribe::<M>()
        .enable_safe_overflow(true)
        .history_size(M::HISTORY_SIZE)
        .subscriber_max_buffer_size(M::BUFFER_SIZE)
        .subscriber_max_borrowed_samples(MAX_BORROWED_SAMPLES)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create()?)
}

/// Opens or creates the wake-up event service named like its data service (`name`).
pub fn open_wake_service(bridge: &Bridge, name: &ServiceName) -> Result<WakeService, ServiceOpenError> {
    Ok(bridge
        .node()
        .service_builder(name)
        .event()
        .max_listeners(MAX_LISTENERS)
        .max_notifiers(MAX_NOTIFIERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create()?)
}
