//! One iceoryx2 node per process, configured for Lamina: service prefix, isolation, logging,
//! and recovery from peers that were killed.
//!
//! # Examples
//!
//! ```
//! use lamina_bridge::{Bridge, BridgeConfig};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let bridge = Bridge::open(&BridgeConfig::with_prefix("doc_bridge"))?;
//! assert_eq!(bridge.names().nodes.as_str(), "doc_bridge/nodes");
//! # Ok(())
//! # }
//! ```

use crate::domain::{DomainError, UserDomain};
use iceoryx2::config::Config;
use iceoryx2::node::{CleanupState, NodeCreationFailure};
use iceoryx2::prelude::{
    FileName, LogLevel, Node, NodeBuilder, NodeName, Path, SemanticString, ServiceName, SignalHandlingMode, ipc,
    set_log_level_from_env_or,
};

/// Default service prefix: services are named `lamina/nodes`, `lamina/tool`, ...
pub const DEFAULT_PREFIX: &str = "lamina";

/// How to open a [`Bridge`]. `Default` gives the production settings.
#[derive(Debug, Clone, PartialEq)]
pub struct BridgeConfig {
    /// Service name prefix, so several simulations can share a host. Default [`DEFAULT_PREFIX`].
    /// Every process of one simulation must use the same prefix.
    pub prefix: String,
    /// iceoryx2 root directory for its management files. Default `None`: the user's own
    /// domain, `/tmp/lamina-<uid>/` created `0700` (see [`UserDomain`]). Must end with `/`.
    /// All peers must agree.
    pub root_path: Option<String>,
    /// iceoryx2 file-name prefix for shared memory and management files (letters, digits, `_`,
    /// `-`, `.`). Default `None`: the user's own, `iox2_lamina_u<uid>_`. A distinct value
    /// gives a fully separate iceoryx2 domain (its own node list); all peers must agree.
    pub file_prefix: Option<String>,
    /// iceoryx2 node name shown by `iox2 node list`. Default `None` (unnamed).
    pub node_name: Option<String>,
    /// iceoryx2 log level for the whole process. Default [`LogLevel::Error`] (quiet);
    /// the environment variable `IOX2_LOG_LEVEL` overrides it.
    pub log_level: LogLevel,
    /// Whether iceoryx2 notes SIGINT/SIGTERM for `Node::wait`. Default
    /// [`SignalHandlingMode::Disabled`]: Lamina processes install their own handlers.
    pub signal_handling: SignalHandlingMode,
}

impl Default for BridgeConfig {
    fn default() -> Self {
        Self {
            prefix: DEFAULT_PREFIX.to_owned(),
            root_path: None,
            file_prefix: None,
            node_name: None,
            log_level: LogLevel::Error,
            signal_handling: SignalHandlingMode::Disabled,
        }
    }
}

impl BridgeConfig {
    /// The default configuration with another service prefix (for example one per test).
    pub fn with_prefix(prefix: &str) -> Self {
        Self { prefix: prefix.to_owned(), ..Self::default() }
    }
}

/// Why a [`Bridge`] could not be opened.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BridgeOpenError {
    /// The user's domain directory or shared memory is not safely this user's.
    #[error("{0}")]
    Domain(DomainError),
    /// The prefix is empty or makes an invalid iceoryx2 service name.
    #[error("invalid service prefix")]
    InvalidPrefix,
    /// `root_path` is not a valid absolute directory path.
    #[error("invalid iceoryx2 root path")]
    InvalidRootPath,
    /// `file_prefix` is not a valid file name.
    #[error("invalid iceoryx2 file prefix")]
    InvalidFilePrefix,
    /// `node_name` is not a valid iceoryx2 node name.
    #[error("invalid iceoryx2 node name")]
    InvalidNodeName,
    /// iceoryx2 could not create the node.
    #[error("cannot create iceoryx2 node: {0} (iceoryx2 domain: root {root}, files /dev/shm/{file_prefix}*)", root = UserDomain::current().root.display(), file_prefix = UserDomain::current().file_prefix)]
    Node(NodeCreationFailure),
}

impl From<NodeCreationFailure> for BridgeOpenError {
    fn from(value: NodeCreationFailure) -> Self {
        Self::Node(value)
    }
}

/// The iceoryx2 service names of one simulation, `<prefix>/<service>`.
///
/// Each publish-subscribe service has an event service of the same name (iceoryx2 keeps the
/// messaging patterns apart) that publishers notify after every send, so subscribers can block.
#[derive(Debug, Clone)]
pub struct ServiceNames {
    /// `<prefix>/topology`: static model, core → all, history 1.
    pub topology: ServiceName,
    /// `<prefix>/nodes`: node positions, core → all, every tick (or every
    /// `node_frame_every` ticks, as the scene says), late ticks' frames on the next.
    pub nodes: ServiceName,
    /// `<prefix>/tool`: tool pose, haptics → core, newest wins.
    pub tool: ServiceName,
    /// `<prefix>/feedback`: contact model, core → haptics, every tick.
    pub feedback: ServiceName,
    /// `<prefix>/stats`: deadline-monitor summary, core → all, every second.
    pub stats: ServiceName,
}

impl ServiceNames {
    /// The names under `prefix`; `None` if the prefix is empty or not a valid service name.
    pub fn new(prefix: &str) -> Option<Self> {
        if prefix.is_empty() {
            return None;
        }
        let name = |s: &str| ServiceName::new(&format!("{prefix}/{s}")).ok();
        Some(Self {
            topology: name("topology")?,
            nodes: name("nodes")?,
            tool: name("tool")?,
            feedback: name("feedback")?,
            stats: name("stats")?,
        })
    }
}

/// A process's connection to Lamina's iceoryx2 services: one node plus the service names.
///
/// Opening a bridge removes the resources of dead peers (processes killed with SIGKILL), so a
/// restarted process reattaches at once. Ports are created from it (`NodesPublisher::create`,
/// `NodesSubscriber::create`, ...). Not `Send`: create it on the thread that uses it.
#[derive(Debug)]
pub struct Bridge {
    node: Node<ipc::Service>,
    names: ServiceNames,
    prefix: String,
    domain: UserDomain,
}

impl Bridge {
    /// Creates the iceoryx2 node, sets the log level and cleans up dead peers.
    pub fn open(cfg: &BridgeConfig) -> Result<Self, BridgeOpenError> {
        set_log_level_from_env_or(cfg.log_level);
        let names = ServiceNames::new(&cfg.prefix).ok_or(BridgeOpenError::InvalidPrefix)?;
        let mut config = Config::default();
        let mut domain = UserDomain::current();
        if let Some(root) = &cfg.root_path {
            domain.root = std::path::PathBuf::from(root);
        }
        if let Some(prefix) = &cfg.file_prefix {
            domain.file_prefix.clone_from(prefix);
        }
        if cfg.root_path.is_none() {
            domain.prepare().map_err(BridgeOpenError::Domain)?;
        }
        let mut root = domain.root.display().to_string();
        if !root.ends_with('/') {
            root.push('/');
        }
        let path = Path::new(root.as_bytes()).map_err(|_| BridgeOpenError::InvalidRootPath)?;
        config.global.set_root_path(&path);
        config.global.prefix =
            FileName::new(domain.file_prefix.as_bytes()).map_err(|_| BridgeOpenError::InvalidFilePrefix)?;
        let mut builder = NodeBuilder::new().config(&config).signal_handling_mode(cfg.signal_handling);
        if let Some(name) = &cfg.node_name {
            let name = NodeName::new(name).map_err(|_| BridgeOpenError::InvalidNodeName)?;
            builder = builder.name(&name);
        }
        let node = builder.create::<ipc::Service>()?;
        // Node creation already cleans up with the default config; do it explicitly so a
        // changed config cannot silently turn recovery off.
        node.try_cleanup_dead_nodes();
        if cfg.file_prefix.is_none() {
            domain.secure().map_err(BridgeOpenError::Domain)?;
        }
        Ok(Self { node, names, prefix: cfg.prefix.clone(), domain })
    }

    /// The iceoryx2 domain this bridge lives in.
    pub fn domain(&self) -> &UserDomain {
        &self.domain
    }

    /// Removes the resources of peers whose process died; returns how many were cleaned.
    pub fn cleanup_dead_peers(&self) -> CleanupState {
        self.node.try_cleanup_dead_nodes()
    }

    /// The underlying iceoryx2 node (for WaitSets or custom services).
    pub fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }

    /// The service names of this simulation.
    pub fn names(&self) -> &ServiceNames {
        &self.names
    }

    /// The service prefix this bridge was opened with.
    pub fn prefix(&self) -> &str {
        &self.prefix
    }
}
