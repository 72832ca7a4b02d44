//! What a haptics report records besides its measurements: the build, the host, the start
//! time, the scene the core runs (when named with `--scene`) and the model size seen on the
//! wire (the `topology` service's node count). Nothing here touches the device loop.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, SystemTime};

use lamina_bridge::{Bridge, BridgeConfig, TopologySubscriber};
use lamina_rt::digest::sha256_hex;
use lamina_rt::host::{HostInfo, rfc3339_utc};

/// The Lamina version (the workspace's `version`).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
/// The git commit the binary was built from (`git rev-parse HEAD`), or `unknown`.
pub const GIT_REVISION: &str = env!("LAMINA_GIT_REVISION");

/// Why `--scene` could not be read.
#[derive(Debug, thiserror::Error)]
pub enum SceneFileError {
    /// The file could not be read.
    #[error("--scene {}: {error}", .path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        error: std::io::Error,
    },
    /// The file is not TOML.
    #[error("--scene {}: not a scene file: {message}", path.display())]
    NotToml {
        /// The file.
        path: PathBuf,
        /// The TOML parser's message.
        message: String,
    },
}

/// The scene file the core runs, as named on the command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneFile {
    /// The file as given.
    pub file: PathBuf,
    /// Its top-level `name` (`unnamed` when it has none, as the core says).
    pub name: String,
    /// SHA-256 of its bytes, lower-case hex.
    pub sha256: String,
}

impl SceneFile {
    /// Reads and hashes `path`; its name is the TOML's top-level `name`.
    ///
    /// # Errors
    /// The file cannot be read or is not TOML, named with the path.
    pub fn read(path: &Path) -> Result<Self, SceneFileError> {
        let bytes = std::fs::read(path).map_err(|error| SceneFileError::Read { path: path.to_path_buf(), error })?;
        let text = String::from_utf8_lossy(&bytes);
        let table: toml::Table = text.parse().map_err(|e: toml::de::Error| SceneFileError::NotToml {
            path: path.to_path_buf(),
            message: e.message().to_string(),
        })?;
        let name = table.get("name").and_then(toml::Value::as_str).unwrap_or("unnamed").to_string();
        Ok(Self { file: path.to_path_buf(), name, sha256: sha256_hex(&bytes) })
    }
}

/// The run's context, fixed at start.
#[derive(Debug, Clone)]
pub struct RunContext {
    /// Start time, UTC, RFC 3339.
    pub started_utc: String,
    /// The machine.
    pub host: HostInfo,
    /// The scene, when given.
    pub scene: Option<SceneFile>,
}

impl RunContext {
    /// Now, this host, and `scene`.
    pub fn start(scene: Option<SceneFile>) -> Self {
        Self { started_utc: rfc3339_utc(SystemTime::now()), host: HostInfo::detect(), scene }
    }

    /// The report's context fields: `lamina`, `started_utc`, `host`, `scene`.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({
            "lamina": { "version": VERSION, "git_revision": GIT_REVISION },
            "started_utc": self.started_utc,
            "host": self.host,
            "scene": self.scene.as_ref().map(|s| serde_json::json!({
                "name": s.name, "file": s.file.display().to_string(), "sha256": s.sha256,
            })),
        })
    }
}

/// What the topology says about the core's model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModelSeen {
    /// Nodes.
    pub nodes: u32,
    /// Surface triangles.
    pub surface_triangles: u32,
}

/// A thread of its own (with its own iceoryx2 node) that waits for the core's topology, so
/// the device loop is untouched.
pub struct TopologyWatch {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<Option<ModelSeen>>,
}

impl TopologyWatch {
    /// Starts watching `<prefix>/topology`.
    pub fn start(prefix: &str) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let (flag, prefix) = (stop.clone(), prefix.to_string());
        let thread = std::thread::spawn(move || {
            let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).ok()?;
            let topology = TopologySubscriber::create(&bridge).ok()?;
            // Short slices: a late joiner's topology arrives without a wake-up.
            while !flag.load(Ordering::Relaxed) {
                if let Ok(Some(sample)) = topology.receive_timeout(Duration::from_millis(50)) {
                    let h = sample.header();
                    return Some(ModelSeen { nodes: h.node_count, surface_triangles: h.triangle_count });
                }
            }
            None
        });
        Self { stop, thread }
    }

    /// Stops watching; the model seen, if the topology came.
    pub fn finish(self) -> Option<ModelSeen> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().ok().flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_file_names_and_refusals_works() {
        let dir = std::env::temp_dir().join(format!("lamina_scene_file_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("s.toml");
        std::fs::write(&good, "name = \"x\"\nrate_hz = 500\n").unwrap();
        let s = SceneFile::read(&good).unwrap();
        assert_eq!((s.name.as_str(), s.sha256.len()), ("x", 64));
        let bad = dir.join("bad.toml");
        std::fs::write(&bad, "name = = 1").unwrap();
        let e = SceneFile::read(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("not a scene file"), "{e}");
        let e = SceneFile::read(&dir.join("missing.toml")).unwrap_err().to_string();
        assert!(e.contains("missing.toml"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
