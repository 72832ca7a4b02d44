//! Publishers: node frames, the topology, and fixed-size messages, each followed by a wake-up.
//!
//! Every publisher is non-blocking by construction: the services have safe overflow on (a
//! full subscriber buffer loses its oldest sample) and the ports use
//! [`BackpressureStrategy::DiscardData`], so a stalled, hung or killed subscriber never holds
//! up `publish`. After each send the publisher notifies the service's wake-up event so
//! blocking subscribers return; a failed notification is counted, not returned, because the
//! data itself was delivered.
//!
//! Late joiners receive the last sample (history 1) when the publisher next updates its
//! connections: every `publish` does that, and [`TopologyPublisher::serve_late_joiners`] (or
//! `update_connections` on the other publishers) does it without sending.
//!
//! # Examples
//!
//! ```
//! use lamina_bridge::{Bridge, BridgeConfig, NodesPublisher, NodesSubscriber};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_publish"))?;
//! let publisher = NodesPublisher::create(&bridge, 1000)?;
//! let subscriber = NodesSubscriber::create(&bridge)?;
//!
//! // Positions are written straight into shared memory.
//! publisher.publish_from_fn(0, 0, 0.0, 3, |i| [i as f32, 0.0, 0.0])?;
//!
//! let frame = subscriber.try_receive()?.expect("sent above");
//! assert_eq!(frame.positions()[2], [2.0, 0.0, 0.0]);
//! assert!(publisher.publish_from_fn(1, 1, 0.001, 1001, |_| [0.0; 3]).is_err());
//! # Ok(())
//! # }
//! ```

use core::cell::Cell;

use iceoryx2::port::LoanError;
use iceoryx2::port::SendError;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::update_connections::{ConnectionFailure, UpdateConnections};
use iceoryx2::prelude::{AllocationStrategy, BackpressureStrategy, PortFactory as _, ipc};
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::sample_mut_uninit::SampleMutUninit;

use crate::bridge::Bridge;
use crate::chunk_contents::ChunkContents;
use crate::domain::{PrefixLock, PrefixLockError};
use crate::interleave::{interleave_finite, scatter_finite};
use crate::services::{
    Message, MessageService, NodesService, PortCreateError, TopologyService, WakeService, open_message_service,
    open_nodes_service, open_topology_service, open_wake_service,
};
use crate::topology::{Topology, TopologyEncodeError};
use crate::wire::NodesHeader;
use lamina_rt::now_ns;

/// Why a node frame was not published. Nothing was sent when this is returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum NodesPublishError {
    /// More nodes than the publisher was created for (`requested > max`).
    #[error("cannot publish node frame: {requested} nodes exceed the maximum of {max}")]
    TooManyNodes {
        /// Node count of the rejected frame.
        requested: usize,
        /// The publisher's fixed maximum.
        max: usize,
    },
    /// No shared-memory chunk could be loaned.
    #[error("cannot publish node frame: {0}")]
    Loan(LoanError),
    /// iceoryx2 could not deliver the sample.
    #[error("cannot publish node frame: {0}")]
    Send(SendError),
    /// The coordinate arrays of one frame differ in length.
    #[error("cannot publish node frame: coordinate arrays of {x}, {y} and {z} entries (x, y, z) differ in length")]
    CoordinateLengths {
        /// Entries in x.
        x: usize,
        /// Entries in y.
        y: usize,
        /// Entries in z.
        z: usize,
    },
    /// A changed node's index is not below the frame's node count.
    #[error("cannot publish node frame: changed node {index} is not among its {node_count} nodes")]
    ChangedNodeOutOfRange {
        /// The index given.
        index: u32,
        /// Nodes in the frame.
        node_count: usize,
    },
}

/// Why a topology was not published. Nothing was sent when this is returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TopologyPublishError {
    /// The topology is invalid.
    #[error("cannot publish topology: {0}")]
    Encode(TopologyEncodeError),
    /// The encoding needs more words than the publisher was created for.
    #[error("cannot publish topology: {words} words exceed the maximum of {max}")]
    TooLarge {
        /// Words the topology needs.
        words: usize,
        /// The publisher's fixed maximum.
        max: usize,
    },
    /// No shared-memory chunk could be loaned.
    #[error("cannot publish topology: {0}")]
    Loan(LoanError),
    /// iceoryx2 could not deliver the sample.
    #[error("cannot publish topology: {0}")]
    Send(SendError),
}

/// Why a message (tool, feedback, stats) was not published.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MessagePublishError {
    /// No shared-memory chunk could be loaned.
    #[error("cannot publish message: {0}")]
    Loan(LoanError),
    /// iceoryx2 could not deliver the sample.
    #[error("cannot publish message: {0}")]
    Send(SendError),
}

macro_rules! publish_error_impls {
    ($t:ident) => {
        impl From<LoanError> for $t {
            fn from(value: LoanError) -> Self {
                Self::Loan(value)
            }
        }
        impl From<SendError> for $t {
            fn from(value: SendError) -> Self {
                Self::Send(value)
            }
        }
    };
}
publish_error_impls!(NodesPublishError);
publish_error_impls!(TopologyPublishError);
publish_error_impls!(MessagePublishError);

impl From<TopologyEncodeError> for TopologyPublishError {
    fn from(value: TopologyEncodeError) -> Self {
        Self::Encode(value)
    }
}

/// Why a [`NodesPublisher`] could not be created.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NodesPublisherCreateError {
    /// Another process publishes node frames on this prefix (one core per prefix).
    #[error("{0}")]
    PrefixInUse(PrefixLockError),
    /// iceoryx2 refused the service, publisher or notifier.
    #[error("{0}")]
    Port(PortCreateError),
}

impl<E: Into<PortCreateError>> From<E> for NodesPublisherCreateError {
    fn from(value: E) -> Self {
        Self::Port(value.into())
    }
}

/// A notifier that counts its failures instead of failing the publish.
#[derive(Debug)]
struct Waker {
    _service: WakeService,
    notifier: Notifier<ipc::Service>,
    failures: Cell<u64>,
}

impl Waker {
    fn create(bridge: &Bridge, name: &iceoryx2::prelude::ServiceName) -> Result<Self, PortCreateError> {
        let service = open_wake_service(bridge, name)?;
        let notifier = service.notifier_builder().create()?;
        Ok(Self { _service: service, notifier, failures: Cell::new(0) })
    }

    fn wake(&self) {
        if self.notifier.notify().is_err() {
            self.failures.set(self.failures.get().saturating_add(1));
        }
    }
}

/// Publishes node frames on `<prefix>/nodes`, writing positions straight into shared memory.
///
/// The maximum node count is fixed at creation (static allocation: shared memory is sized
/// once: chunks of `max_nodes * 12 B`, and with the default QoS
/// `MAX_SUBSCRIBERS * (NODES_BUFFER_SIZE + MAX_BORROWED_SAMPLES) + 2` = 146 of them, so
/// 175 MB of `/dev/shm` for 100,000 nodes, measured).
/// Not `Send`: create it on the thread that publishes.
#[derive(Debug)]
pub struct NodesPublisher {
    _lock: PrefixLock,
    service: NodesService,
    publisher: Publisher<ipc::Service, [[f32; 3]], NodesHeader>,
    waker: Waker,
    max_nodes: usize,
    /// What the chunks hold, for [`NodesPublisher::publish_finite_xyz_changed`].
    chunks: ChunkContents,
}

/// The nodes that move within an epoch, for [`NodesPublisher::publish_finite_xyz_changed`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeChanges<'a> {
    /// The caller's count of the times nodes outside `nodes` moved (or `nodes` changed);
    /// two sources of frames publishing through one publisher must never share an epoch.
    pub epoch: u64,
    /// Indices of the nodes that may differ from one frame of the epoch to the next.
    pub nodes: &'a [u32],
}

/// A loaned node frame, not yet written.
type UninitFrame = SampleMutUninit<ipc::Service, [core::mem::MaybeUninit<[f32; 3]>], NodesHeader>;

impl NodesPublisher {
    /// Creates the publisher for frames of at most `max_nodes` positions (at least 1). It
    /// holds the prefix's [`PrefixLock`] while it lives: subscribers never see two streams.
    ///
    /// # Errors
    /// [`NodesPublisherCreateError::PrefixInUse`] when another process already publishes
    /// node frames on the prefix; otherwise what iceoryx2 refused.
    pub fn create(bridge: &Bridge, max_nodes: usize) -> Result<Self, NodesPublisherCreateError> {
        let lock =
            PrefixLock::acquire(bridge.domain(), bridge.prefix()).map_err(NodesPublisherCreateError::PrefixInUse)?;
        let max_nodes = max_nodes.max(1);
        let service = open_nodes_service(bridge)?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(max_nodes)
            .allocation_strategy(AllocationStrategy::Static)
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .max_loaned_samples(1)
            .create()?;
        let waker = Waker::create(bridge, &bridge.names().nodes)?;
        Ok(Self { _lock: lock, service, publisher, waker, max_nodes, chunks: ChunkContents::default() })
    }

    /// The fixed maximum node count per frame.
    pub fn max_nodes(&self) -> usize {
        self.max_nodes
    }

    /// Loans a chunk for `node_count` nodes that the caller writes whole: what was known of
    /// its content no longer holds.
    fn loan(&self, node_count: usize) -> Result<UninitFrame, NodesPublishError> {
        let mut sample = self.publisher.loan_slice_uninit(node_count)?;
        self.chunks.forget(sample.payload_mut().as_ptr() as usize);
        Ok(sample)
    }

    /// The node count of a frame given as three coordinate arrays, as `usize` and as the
    /// header's `u32`.
    fn check_xyz(&self, x: &[f32], y: &[f32], z: &[f32]) -> Result<(usize, u32), NodesPublishError> {
        let node_count = x.len();
        if y.len() != node_count || z.len() != node_count {
            return Err(NodesPublishError::CoordinateLengths { x: x.len(), y: y.len(), z: z.len() });
        }
        Ok((node_count, self.check(node_count)?))
    }

    fn check(&self, node_count: usize) -> Result<u32, NodesPublishError> {
        let too_many = NodesPublishError::TooManyNodes { requested: node_count, max: self.max_nodes };
        if node_count > self.max_nodes {
            return Err(too_many);
        }
        u32::try_from(node_count).map_err(|_| too_many)
    }

    /// Publishes one frame whose position `i` is `position(i)` (metres), written directly into
    /// the loaned shared memory, then wakes blocking subscribers.
    ///
    /// `sequence`, `tick` and `sim_time_s` (seconds) go into the [`NodesHeader`];
    /// `publish_time_ns` is stamped after the positions are written, just before sending.
    /// Returns the number of subscribers the frame was delivered to. Never blocks on a
    /// subscriber.
    pub fn publish_from_fn<F: FnMut(usize) -> [f32; 3]>(
        &self,
        sequence: u64,
        tick: u64,
        sim_time_s: f64,
        node_count: usize,
        position: F,
    ) -> Result<usize, NodesPublishError> {
        let count = self.check(node_count)?;
        let sample = self.loan(node_count)?.write_from_fn(position);
        self.send(sample, sequence, tick, sim_time_s, count)
    }

    /// Like [`NodesPublisher::publish_from_fn`], but a frame with a coordinate that is not
    /// finite (NaN, or an infinity, e.g. from a value beyond `f32`'s range) is withheld: the
    /// positions are checked as they are written, in the same pass, and such a frame goes back
    /// to the pool unsent (`Ok(None)`), so no subscriber ever sees it. `Ok(Some(n))`: sent to
    /// `n` subscribers.
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use lamina_bridge::{Bridge, BridgeConfig, NodesPublisher};
    ///
    /// let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_finite"))?;
    /// let publisher = NodesPublisher::create(&bridge, 3)?;
    /// assert!(publisher.publish_finite_from_fn(0, 0, 0.0, 3, |i| [i as f32, 0.0, 0.0])?.is_some());
    /// assert_eq!(publisher.publish_finite_from_fn(1, 1, 0.001, 3, |_| [f32::NAN, 0.0, 0.0])?, None);
    /// # Ok(())
    /// # }
    /// ```
    pub fn publish_finite_from_fn<F: FnMut(usize) -> [f32; 3]>(
        &self,
        sequence: u64,
        tick: u64,
        sim_time_s: f64,
        node_count: usize,
        mut position: F,
    ) -> Result<Option<usize>, NodesPublishError> {
        let count = self.check(node_count)?;
        let mut finite = true;
        let sample = self.loan(node_count)?.write_from_fn(|i| {
            let p = position(i);
            finite &= p[0].is_finite() & p[1].is_finite() & p[2].is_finite();
            p
        });
        if !finite {
            // Dropping the loan returns the frame to the pool without sending it.
            return Ok(None);
        }
        self.send(sample, sequence, tick, sim_time_s, count).map(Some)
    }

    /// Like [`NodesPublisher::publish_finite_from_fn`], with the positions given as three
    /// coordinate arrays (metres, one entry per node, as the solver keeps them): node `i` is
    /// `[x[i], y[i], z[i]]`. The records are interleaved with vector permutes chosen at run
    /// time (AVX-512 or AVX2; a scalar loop elsewhere), about twice as fast as writing one
    /// node at a time. `Ok(None)`: a coordinate is not finite and the frame went back to the
    /// pool unsent.
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use lamina_bridge::{Bridge, BridgeConfig, NodesPublisher};
    ///
    /// let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_xyz"))?;
    /// let publisher = NodesPublisher::create(&bridge, 3)?;
    /// let (x, y, z) = ([0.0, 0.01, 0.02], [0.0; 3], [0.05; 3]);
    /// assert!(publisher.publish_finite_xyz(0, 0, 0.0, &x, &y, &z)?.is_some());
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`NodesPublishError::CoordinateLengths`] when the three arrays differ in length,
    /// [`NodesPublishError::TooManyNodes`] beyond the publisher's maximum; otherwise what
    /// iceoryx2 refused.
    pub fn publish_finite_xyz(
        &self,
        sequence: u64,
        tick: u64,
        sim_time_s: f64,
        x: &[f32],
        y: &[f32],
        z: &[f32],
    ) -> Result<Option<usize>, NodesPublishError> {
        let (node_count, count) = self.check_xyz(x, y, z)?;
        let mut sample = self.loan(node_count)?;
        let finite = interleave_finite(x, y, z, sample.payload_mut());
        // SAFETY: `interleave_finite` wrote every record of the payload, finite or not.
        let sample = unsafe { sample.assume_init() };
        if !finite {
            // Dropping the loan returns the frame to the pool without sending it.
            return Ok(None);
        }
        self.send(sample, sequence, tick, sim_time_s, count).map(Some)
    }

    /// Like [`NodesPublisher::publish_finite_xyz`] (the coordinate arrays `[x, y, z]`), for a
    /// caller that knows which nodes moved: within one `changes.epoch` (a number the caller
    /// changes whenever any node outside `changes.nodes` moves, or that list itself changes),
    /// every frame differs from the one before only at `changes.nodes` (indices below the
    /// node count). A chunk that last carried a
    /// frame of the same epoch and size gets only those nodes rewritten (and checked for
    /// finiteness); any other chunk gets the whole frame. The subscriber receives the same
    /// frame either way. With a multirate simulation's region of 271 nodes in 16,224, most
    /// frames then write 1.7 % of the positions.
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use lamina_bridge::{Bridge, BridgeConfig, NodeChanges, NodesPublisher};
    ///
    /// let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_changed"))?;
    /// let publisher = NodesPublisher::create(&bridge, 4)?;
    /// let (x, y, mut z) = ([0.0, 0.01, 0.02, 0.03], [0.0; 4], [0.05; 4]);
    /// let changes = NodeChanges { epoch: 7, nodes: &[1, 2] };
    /// publisher.publish_finite_xyz_changed(0, 0, 0.0, [&x, &y, &z], changes)?;
    /// // Only nodes 1 and 2 move while the epoch stays 7.
    /// z[1] = 0.049;
    /// publisher.publish_finite_xyz_changed(1, 1, 0.001, [&x, &y, &z], changes)?;
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`NodesPublisher::publish_finite_xyz`], and
    /// [`NodesPublishError::ChangedNodeOutOfRange`] for an index in `changed` not below the
    /// node count.
    pub fn publish_finite_xyz_changed(
        &self,
        sequence: u64,
        tick: u64,
        sim_time_s: f64,
        [x, y, z]: [&[f32]; 3],
        changes: NodeChanges<'_>,
    ) -> Result<Option<usize>, NodesPublishError> {
        let NodeChanges { epoch, nodes: changed } = changes;
        let (node_count, count) = self.check_xyz(x, y, z)?;
        if let Some(&index) = changed.iter().find(|&&i| i as usize >= node_count) {
            return Err(NodesPublishError::ChangedNodeOutOfRange { index, node_count });
        }
        let mut sample = self.publisher.loan_slice_uninit(node_count)?;
        let payload = sample.payload_mut();
        let address = payload.as_ptr() as usize;
        let finite = if self.chunks.holds(address, node_count, epoch) {
            scatter_finite(x, y, z, changed, payload)
        } else {
            interleave_finite(x, y, z, payload)
        };
        if !finite {
            // Some nodes hold this frame's values now: the chunk's content is not a frame.
            self.chunks.forget(address);
            return Ok(None);
        }
        self.chunks.remember(address, node_count, epoch);
        // SAFETY: every record of the payload is initialised: either all were written just
        // now, or the chunk holds a whole frame this publisher wrote there earlier (same
        // address, size and epoch: `holds`), of which the changed nodes were rewritten.
        // Subscribers map chunks read-only and iceoryx2 does not write payloads, so those
        // bytes are still there.
        let sample = unsafe { sample.assume_init() };
        self.send(sample, sequence, tick, sim_time_s, count).map(Some)
    }

    /// Like [`NodesPublisher::publish_from_fn`], but `fill` receives the whole positions slice
    /// (metres) in shared memory. The slice is zeroed first (one pass over the frame), so
    /// prefer `publish_from_fn` when positions can be produced per index.
    pub fn publish<F: FnOnce(&mut [[f32; 3]])>(
        &self,
        sequence: u64,
        tick: u64,
        sim_time_s: f64,
        node_count: usize,
        fill: F,
    ) -> Result<usize, NodesPublishError> {
        let count = self.check(node_count)?;
        let mut sample = self.loan(node_count)?.write_from_fn(|_| [0.0; 3]);
        fill(sample.payload_mut());
        self.send(sample, sequence, tick, sim_time_s, count)
    }

    /// Stamps a written frame's header (`publish_time_ns` now), sends it and wakes blocking
    /// subscribers; the number of subscribers it was delivered to.
    fn send(
        &self,
        mut sample: SampleMut<ipc::Service, [[f32; 3]], NodesHeader>,
        sequence: u64,
        tick: u64,
        sim_time_s: f64,
        node_count: u32,
    ) -> Result<usize, NodesPublishError> {
        *sample.user_header_mut() =
            NodesHeader { sequence, tick, sim_time_s, publish_time_ns: now_ns(), node_count, reserved: 0 };
        let delivered = sample.send()?;
        self.waker.wake();
        Ok(delivered)
    }

    /// Connects new subscribers and hands them the last frame (history) without sending.
    pub fn update_connections(&self) -> Result<(), ConnectionFailure> {
        self.publisher.update_connections()
    }

    /// Wake-up notifications that failed so far (the frames themselves were delivered).
    pub fn notify_failures(&self) -> u64 {
        self.waker.failures.get()
    }

    /// Subscribers currently registered on the `nodes` service (including dead ones not yet
    /// cleaned up).
    pub fn subscriber_count(&self) -> usize {
        self.service.dynamic_config().number_of_subscribers()
    }
}

/// Publishes the static [`Topology`] on `<prefix>/topology`, kept for late joiners.
#[derive(Debug)]
pub struct TopologyPublisher {
    _service: TopologyService,
    publisher: Publisher<ipc::Service, [u32], crate::wire::TopologyHeader>,
    waker: Waker,
    max_words: usize,
    revision: u64,
}

impl TopologyPublisher {
    /// Creates a publisher for encodings of at most `max_words` words
    /// (see [`Topology::word_count`]).
    pub fn create(bridge: &Bridge, max_words: usize) -> Result<Self, PortCreateError> {
        let max_words = max_words.max(1);
        let service = open_topology_service(bridge)?;
        let publisher = service
            .publisher_builder()
            .initial_max_slice_len(max_words)
            .allocation_strategy(AllocationStrategy::Static)
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .max_loaned_samples(1)
            .create()?;
        let waker = Waker::create(bridge, &bridge.names().topology)?;
        Ok(Self { _service: service, publisher, waker, max_words, revision: 0 })
    }

    /// Publishes `topology` with the next revision number (0 first); returns the number of
    /// subscribers it was delivered to.
    pub fn publish(&mut self, topology: &Topology) -> Result<usize, TopologyPublishError> {
        let mut header = topology.header()?;
        let words = topology.word_count();
        if words > self.max_words {
            return Err(TopologyPublishError::TooLarge { words, max: self.max_words });
        }
        header.revision = self.revision;
        let mut sample = self.publisher.loan_slice_uninit(words)?.write_from_fn(|i| topology.word(i));
        *sample.user_header_mut() = header;
        let delivered = sample.send()?;
        self.revision = self.revision.wrapping_add(1);
        self.waker.wake();
        Ok(delivered)
    }

    /// Hands the last topology to subscribers that joined since the last call. Call it
    /// regularly (each tick or each second) from the publishing loop; it is cheap when nobody
    /// joined.
    pub fn serve_late_joiners(&self) -> Result<(), ConnectionFailure> {
        self.publisher.update_connections()
    }
}

/// Publishes fixed-size messages of type `M` ([`crate::wire::ToolCommand`],
/// [`crate::wire::ContactFeedback`], [`crate::wire::StatsSummary`]) on `M`'s service.
#[derive(Debug)]
pub struct MessagePublisher<M: Message> {
    _service: MessageService<M>,
    publisher: Publisher<ipc::Service, M, ()>,
    waker: Waker,
}

/// Publisher of tool commands (haptics → core).
pub type ToolPublisher = MessagePublisher<crate::wire::ToolCommand>;
/// Publisher of contact feedback (core → haptics).
pub type FeedbackPublisher = MessagePublisher<crate::wire::ContactFeedback>;
/// Publisher of deadline-monitor summaries (core → all).
pub type StatsPublisher = MessagePublisher<crate::wire::StatsSummary>;

impl<M: Message> MessagePublisher<M> {
    /// Creates the publisher on `M`'s service.
    pub fn create(bridge: &Bridge) -> Result<Self, PortCreateError> {
        let service = open_message_service::<M>(bridge)?;
        let publisher = service
            .publisher_builder()
            .backpressure_strategy(BackpressureStrategy::DiscardData)
            .max_loaned_samples(1)
            .create()?;
        let waker = Waker::create(bridge, M::service_name(bridge.names()))?;
        Ok(Self { _service: service, publisher, waker })
    }

    /// Sends a copy of `message` (it is small) and wakes blocking subscribers; returns the
    /// number of subscribers it was delivered to.
    pub fn publish(&self, message: &M) -> Result<usize, MessagePublishError> {
        let delivered = self.publisher.loan_uninit()?.write_payload(*message).send()?;
        self.waker.wake();
        Ok(delivered)
    }

    /// Sends a copy of `message` without the wake-up: for streams whose subscribers poll
    /// every tick (tool commands at the device rate, feedback to the haptics loop), where the
    /// notification's system call would cost more than the message.
    pub fn publish_polled(&self, message: &M) -> Result<usize, MessagePublishError> {
        Ok(self.publisher.loan_uninit()?.write_payload(*message).send()?)
    }

    /// Connects new subscribers and hands them the last message (history) without sending.
    pub fn update_connections(&self) -> Result<(), ConnectionFailure> {
        self.publisher.update_connections()
    }

    /// Wake-up notifications that failed so far (the messages themselves were delivered).
    pub fn notify_failures(&self) -> u64 {
        self.waker.failures.get()
    }
}
