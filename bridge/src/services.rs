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
//! a free slot before the dead one is cleaned ([`PubSubSettings`]).
//!
//! # A service someone else created
//! Whoever creates a service first fixes its settings; Lamina opens it when every setting is
//! at least what Lamina asks for (safe overflow must match), so a service created with larger
//! buffers is used as it is. When one falls short (a client that created `nodes` with
//! iceoryx2's defaults: buffer 2, history 0), opening fails with
//! [`ServiceOpenError::Incompatible`], which reads the existing service and names every
//! setting with the value found and the value Lamina needs:
//!
//! ```text
//! publish-subscribe service 'lamina/nodes' exists with settings Lamina cannot use:
//! subscriber_max_buffer_size 2 (Lamina needs at least 16), history_size 0 (Lamina needs at least 1). ...
//! ```
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
use iceoryx2::prelude::{IceoryxSend, MessagingPattern, ServiceName, ZeroCopySend, ipc};
use iceoryx2::service::Service as _;
use iceoryx2::service::builder::event::EventOpenOrCreateError;
use iceoryx2::service::builder::publish_subscribe::{Builder as PubSubBuilder, PublishSubscribeOpenOrCreateError};
use iceoryx2::service::port_factory::{event, publish_subscribe};
use iceoryx2::service::static_config::message_type_details::{TypeDetail, TypeVariant};
use iceoryx2::service::static_config::messaging_pattern::MessagingPattern as StaticPattern;
use iceoryx2::service::static_config::publish_subscribe as publish_subscribe_config;

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

/// One setting of an existing service that Lamina cannot work with.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SettingMismatch {
    /// The setting, named as iceoryx2's service builder names it (`subscriber_max_buffer_size`,
    /// `history_size`, ...) or `payload type` / `user header type`.
    pub setting: &'static str,
    /// Its value in the existing service.
    pub found: String,
    /// What Lamina needs (`at least 16`, `true`, a type).
    pub needed: String,
}

impl core::fmt::Display for SettingMismatch {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} {} (Lamina needs {})", self.setting, self.found, self.needed)
    }
}

/// Why a service could not be opened or created.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ServiceOpenError {
    /// The service exists with settings or types Lamina cannot use: another process (a client
    /// with iceoryx2's default settings, an older build) created it first. Every mismatch is
    /// listed with the value found and the value Lamina needs.
    #[error("{pattern} service '{service}' exists with settings Lamina cannot use: {}. Another process created it first with other settings (iceoryx2's defaults, for example): stop it, or have it open or create the service with Lamina's settings (examples/python/README.md lists them), then start again", join_mismatches(.mismatches))]
    Incompatible {
        /// `publish-subscribe` or `event`.
        pattern: &'static str,
        /// The service name, `<prefix>/<service>`.
        service: String,
        /// What does not fit, at least one entry.
        mismatches: Vec<SettingMismatch>,
    },
    /// iceoryx2 refused the publish-subscribe service for another reason.
    #[error("cannot open or create publish-subscribe service '{service}': {error:?}")]
    PublishSubscribe {
        /// The service name.
        service: String,
        /// iceoryx2's error.
        error: PublishSubscribeOpenOrCreateError,
    },
    /// iceoryx2 refused the wake-up event service for another reason.
    #[error("cannot open or create event service '{service}': {error:?}")]
    Event {
        /// The service name.
        service: String,
        /// iceoryx2's error.
        error: EventOpenOrCreateError,
    },
}

/// `a 1 (Lamina needs 2), b 3 (Lamina needs 4)`.
fn join_mismatches(mismatches: &[SettingMismatch]) -> String {
    mismatches.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")
}

/// Why a publisher or subscriber (with its notifier or listener) could not be created.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum PortCreateError {
    /// The service itself could not be opened.
    #[error("{0}")]
    Service(ServiceOpenError),
    /// iceoryx2 refused the publisher (for example: too many publishers).
    #[error("cannot create publisher: {0}")]
    Publisher(PublisherCreateError),
    /// iceoryx2 refused the subscriber (for example: too many subscribers).
    #[error("cannot create subscriber: {0}")]
    Subscriber(SubscriberCreateError),
    /// iceoryx2 refused the wake-up notifier.
    #[error("cannot create notifier: {0}")]
    Notifier(NotifierCreateError),
    /// iceoryx2 refused the wake-up listener.
    #[error("cannot create listener: {0}")]
    Listener(ListenerCreateError),
}

impl From<ServiceOpenError> for PortCreateError {
    fn from(value: ServiceOpenError) -> Self {
        Self::Service(value)
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

/// What Lamina asks of a publish-subscribe service: every field a minimum, except
/// `safe_overflow`, which must match. A service created with larger values is used as it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PubSubSettings {
    /// Samples a subscriber queues before the oldest is dropped.
    pub subscriber_max_buffer_size: usize,
    /// Samples kept for late joiners.
    pub history_size: usize,
    /// Samples a subscriber may hold at once.
    pub subscriber_max_borrowed_samples: usize,
    /// Subscribers at once.
    pub max_subscribers: usize,
    /// Publishers at once.
    pub max_publishers: usize,
    /// iceoryx2 nodes (processes) attached at once.
    pub max_nodes: usize,
    /// A full subscriber buffer drops its oldest sample instead of refusing the new one.
    pub safe_overflow: bool,
}

impl PubSubSettings {
    /// Lamina's common settings with a subscriber buffer of `buffer` samples.
    pub const fn with_buffer(buffer: usize) -> Self {
        Self {
            subscriber_max_buffer_size: buffer,
            history_size: 1,
            subscriber_max_borrowed_samples: MAX_BORROWED_SAMPLES,
            max_subscribers: MAX_SUBSCRIBERS,
            max_publishers: MAX_PUBLISHERS,
            max_nodes: MAX_SERVICE_NODES,
            safe_overflow: true,
        }
    }

    /// Sets every field on `builder`.
    fn apply<P: Debug + IceoryxSend + ?Sized, H: Debug + ZeroCopySend>(
        &self,
        builder: PubSubBuilder<P, H, ipc::Service>,
    ) -> PubSubBuilder<P, H, ipc::Service> {
        builder
            .enable_safe_overflow(self.safe_overflow)
            .history_size(self.history_size)
            .subscriber_max_buffer_size(self.subscriber_max_buffer_size)
            .subscriber_max_borrowed_samples(self.subscriber_max_borrowed_samples)
            .max_subscribers(self.max_subscribers)
            .max_publishers(self.max_publishers)
            .max_nodes(self.max_nodes)
    }

    /// What an existing service with `found` settings and types lacks.
    fn mismatches(
        &self,
        found: &publish_subscribe_config::StaticConfig,
        payload: &TypeDetail,
        user_header: &TypeDetail,
    ) -> Vec<SettingMismatch> {
        let mut out = Vec::new();
        let types = found.message_type_details();
        for (setting, need, have) in
            [("payload type", payload, &types.payload), ("user header type", user_header, &types.user_header)]
        {
            let fits = need.type_name() == have.type_name()
                && need.variant() == have.variant()
                && need.size() == have.size()
                && need.alignment() <= have.alignment();
            if !fits {
                out.push(SettingMismatch { setting, found: describe_type(have), needed: describe_type(need) });
            }
        }
        let minimums = [
            ("subscriber_max_buffer_size", found.subscriber_max_buffer_size(), self.subscriber_max_buffer_size),
            ("history_size", found.history_size(), self.history_size),
            (
                "subscriber_max_borrowed_samples",
                found.subscriber_max_borrowed_samples(),
                self.subscriber_max_borrowed_samples,
            ),
            ("max_subscribers", found.max_subscribers(), self.max_subscribers),
            ("max_publishers", found.max_publishers(), self.max_publishers),
            ("max_nodes", found.max_nodes(), self.max_nodes),
        ];
        for (setting, have, need) in minimums {
            if have < need {
                out.push(SettingMismatch { setting, found: have.to_string(), needed: format!("at least {need}") });
            }
        }
        if found.has_safe_overflow() != self.safe_overflow {
            out.push(SettingMismatch {
                setting: "enable_safe_overflow",
                found: found.has_safe_overflow().to_string(),
                needed: self.safe_overflow.to_string(),
            });
        }
        out
    }
}

/// `'name' (size S, alignment A)`, with `slice of` for a slice's element type.
fn describe_type(t: &TypeDetail) -> String {
    let slice = if t.variant() == TypeVariant::Dynamic { "slice of " } else { "" };
    format!("{slice}'{}' (size {}, alignment {})", t.type_name(), t.size(), t.alignment())
}

/// Settings of the `nodes` service.
pub const NODES_SETTINGS: PubSubSettings = PubSubSettings::with_buffer(NODES_BUFFER_SIZE);
/// Settings of the `topology` service.
pub const TOPOLOGY_SETTINGS: PubSubSettings = PubSubSettings::with_buffer(TOPOLOGY_BUFFER_SIZE);

/// Settings of message type `M`'s service.
pub const fn message_settings<M: Message>() -> PubSubSettings {
    let mut s = PubSubSettings::with_buffer(M::BUFFER_SIZE);
    s.history_size = M::HISTORY_SIZE;
    s
}

/// Turns iceoryx2's refusal to open an existing service into the list of what does not fit,
/// read from the service itself; other errors (and a service that cannot be read) are kept
/// as they are.
fn pubsub_error(
    bridge: &Bridge,
    name: &ServiceName,
    settings: &PubSubSettings,
    payload: TypeDetail,
    user_header: TypeDetail,
    error: PublishSubscribeOpenOrCreateError,
) -> ServiceOpenError {
    use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError as E;
    let service = name.to_string();
    let PublishSubscribeOpenOrCreateError::PublishSubscribeOpenError(
        E::IncompatibleTypes
        | E::DoesNotSupportRequestedMinBufferSize
        | E::DoesNotSupportRequestedMinHistorySize
        | E::DoesNotSupportRequestedMinSubscriberBorrowedSamples
        | E::DoesNotSupportRequestedAmountOfPublishers
        | E::DoesNotSupportRequestedAmountOfSubscribers
        | E::DoesNotSupportRequestedAmountOfNodes
        | E::IncompatibleOverflowBehavior,
    ) = error
    else {
        return ServiceOpenError::PublishSubscribe { service, error };
    };
    let details = ipc::Service::details(name, bridge.node().config(), MessagingPattern::PublishSubscribe);
    let mismatches = match details {
        Ok(Some(d)) => match d.static_details.messaging_pattern() {
            StaticPattern::PublishSubscribe(found) => settings.mismatches(found, &payload, &user_header),
            _ => Vec::new(),
        },
        _ => Vec::new(),
    };
    if mismatches.is_empty() {
        ServiceOpenError::PublishSubscribe { service, error }
    } else {
        ServiceOpenError::Incompatible { pattern: "publish-subscribe", service, mismatches }
    }
}

/// Opens or creates `<prefix>/nodes` with [`NODES_SETTINGS`]: buffer [`NODES_BUFFER_SIZE`],
/// history 1, safe overflow.
///
/// # Errors
/// [`ServiceOpenError::Incompatible`] naming each setting of an existing service that falls
/// short of Lamina's, with both values.
pub fn open_nodes_service(bridge: &Bridge) -> Result<NodesService, ServiceOpenError> {
    let name = &bridge.names().nodes;
    let builder = bridge.node().service_builder(name).publish_subscribe::<[[f32; 3]]>().user_header::<NodesHeader>();
    NODES_SETTINGS.apply(builder).open_or_create().map_err(|e| {
        let payload = TypeDetail::new::<[f32; 3]>(TypeVariant::Dynamic);
        let header = TypeDetail::new::<NodesHeader>(TypeVariant::FixedSize);
        pubsub_error(bridge, name, &NODES_SETTINGS, payload, header, e)
    })
}

/// Opens or creates `<prefix>/topology` with [`TOPOLOGY_SETTINGS`]: buffer 1, history 1 (late
/// joiners), safe overflow.
///
/// # Errors
/// As [`open_nodes_service`].
pub fn open_topology_service(bridge: &Bridge) -> Result<TopologyService, ServiceOpenError> {
    let name = &bridge.names().topology;
    let builder = bridge.node().service_builder(name).publish_subscribe::<[u32]>().user_header::<TopologyHeader>();
    TOPOLOGY_SETTINGS.apply(builder).open_or_create().map_err(|e| {
        let payload = TypeDetail::new::<u32>(TypeVariant::Dynamic);
        let header = TypeDetail::new::<TopologyHeader>(TypeVariant::FixedSize);
        pubsub_error(bridge, name, &TOPOLOGY_SETTINGS, payload, header, e)
    })
}

/// Opens or creates the service of message type `M` (`<prefix>/tool`, `/feedback`, `/stats`)
/// with [`message_settings`]: `M`'s buffer and history sizes and safe overflow.
///
/// # Errors
/// As [`open_nodes_service`].
pub fn open_message_service<M: Message>(bridge: &Bridge) -> Result<MessageService<M>, ServiceOpenError> {
    let name = M::service_name(bridge.names());
    let settings = message_settings::<M>();
    let builder = bridge.node().service_builder(name).publish_subscribe::<M>();
    settings.apply(builder).open_or_create().map_err(|e| {
        let payload = TypeDetail::new::<M>(TypeVariant::FixedSize);
        let header = TypeDetail::new::<()>(TypeVariant::FixedSize);
        pubsub_error(bridge, name, &settings, payload, header, e)
    })
}

/// Opens or creates the wake-up event service named like its data service (`name`): at least
/// [`MAX_LISTENERS`] listeners, [`MAX_NOTIFIERS`] notifiers and [`MAX_SERVICE_NODES`] nodes.
///
/// # Errors
/// [`ServiceOpenError::Incompatible`] naming each of these settings an existing event service
/// falls short of.
pub fn open_wake_service(bridge: &Bridge, name: &ServiceName) -> Result<WakeService, ServiceOpenError> {
    use iceoryx2::service::builder::event::EventOpenError as E;
    let result = bridge
        .node()
        .service_builder(name)
        .event()
        .max_listeners(MAX_LISTENERS)
        .max_notifiers(MAX_NOTIFIERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create();
    let error = match result {
        Ok(service) => return Ok(service),
        Err(error) => error,
    };
    let service = name.to_string();
    let EventOpenOrCreateError::EventOpenError(
        E::DoesNotSupportRequestedAmountOfListeners
        | E::DoesNotSupportRequestedAmountOfNotifiers
        | E::DoesNotSupportRequestedAmountOfNodes,
    ) = error
    else {
        return Err(ServiceOpenError::Event { service, error });
    };
    let mut mismatches = Vec::new();
    if let Ok(Some(d)) = ipc::Service::details(name, bridge.node().config(), MessagingPattern::Event)
        && let StaticPattern::Event(found) = d.static_details.messaging_pattern()
    {
        let minimums = [
            ("max_listeners", found.max_listeners(), MAX_LISTENERS),
            ("max_notifiers", found.max_notifiers(), MAX_NOTIFIERS),
            ("max_nodes", found.max_nodes(), MAX_SERVICE_NODES),
        ];
        for (setting, have, need) in minimums {
            if have < need {
                mismatches.push(SettingMismatch {
                    setting,
                    found: have.to_string(),
                    needed: format!("at least {need}"),
                });
            }
        }
    }
    Err(if mismatches.is_empty() {
        ServiceOpenError::Event { service, error }
    } else {
        ServiceOpenError::Incompatible { pattern: "event", service, mismatches }
    })
}
