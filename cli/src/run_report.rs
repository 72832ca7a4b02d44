//! What `lamina run`'s report records besides the deadline monitor's figures: the build, the
//! host, the start time, the scene (name and SHA-256 of its file, or of the built-in text),
//! the model's size, the rate and the solver. `docs/reports.md` describes every field.

use std::path::{Path, PathBuf};
use std::time::SystemTime;

use super::frame_gate::NodeFrameGate;
use lamina_core::model::Model;
use lamina_core::real::Real;
use lamina_core::scene::{DEFAULT_SCENE_TOML, Scene, SceneLoadError};
use lamina_core::solver::{MultirateStatus, Simulation, Substeps};
use lamina_rt::digest::sha256_hex;
use lamina_rt::host::{HostInfo, rfc3339_utc};
use lamina_rt::steal::StealSnapshot;

/// The Lamina version (the workspace's `version`).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
/// The git commit the binary was built from (`git rev-parse HEAD`), or `unknown`.
pub const GIT_REVISION: &str = env!("LAMINA_GIT_REVISION");

/// A scene with the hash of the text it was read from.
pub struct LoadedScene {
    /// The scene.
    pub scene: Scene,
    /// SHA-256 of the file's bytes, or of the built-in default's text.
    pub sha256: String,
}

/// Reads the scene file `path` once (hashing the bytes the scene is parsed from), or the
/// built-in default.
pub fn load_scene_hashed(path: Option<&Path>) -> Result<LoadedScene, String> {
    let Some(path) = path else {
        return Ok(LoadedScene { scene: Scene::builtin_default(), sha256: sha256_hex(DEFAULT_SCENE_TOML.as_bytes()) });
    };
    let io = |message: String| SceneLoadError::Io { path: path.to_path_buf(), message }.to_string();
    let bytes = std::fs::read(path).map_err(|e| io(e.to_string()))?;
    let text = std::str::from_utf8(&bytes).map_err(|e| io(format!("not UTF-8 text: {e}")))?;
    let scene = Scene::from_toml_str(text, Some(path)).map_err(|e| e.to_string())?;
    Ok(LoadedScene { scene, sha256: sha256_hex(&bytes) })
}

/// The run's context, taken before the loop starts.
pub struct RunContext {
    started_utc: String,
    host: HostInfo,
    fields: serde_json::Value,
}

impl RunContext {
    /// Now, this host, and what the scene, model and simulation are.
    pub fn start<T: Real>(loaded: &LoadedScene, model: &Model, sim: &Simulation<T>, prefix: Option<&str>) -> Self {
        let scene = &loaded.scene;
        let params = sim.params();
        let substeps_setting = match params.substeps {
            Substeps::Auto => serde_json::json!("auto"),
            Substeps::Fixed(n) => serde_json::json!(n),
        };
        let file: Option<PathBuf> = scene.path.clone();
        let fields = serde_json::json!({
            "scene": {
                "name": scene.name,
                "file": file.map(|f| f.display().to_string()),
                "sha256": loaded.sha256,
            },
            "model": {
                "nodes": model.nodes.len(),
                "springs": model.springs.len(),
                "layers": model.layers.len(),
            },
            "rate_hz": scene.rate_hz,
            "solver": {
                "integrator": params.integrator.name(),
                "substeps": sim.substeps(),
                "substeps_setting": substeps_setting,
                "threads": params.threads,
                "precision": T::NAME,
                "simd": params.simd.to_string(),
            },
            "prefix": prefix,
        });
        Self { started_utc: rfc3339_utc(SystemTime::now()), host: HostInfo::detect(), fields }
    }

    /// Adds the time the hypervisor took from each CPU over the run (`host_steal`), and the
    /// CPU the loop was pinned to.
    pub fn with_steal(mut self, steal: Option<&StealSnapshot>, loop_cpu: Option<usize>) -> Self {
        let steal = steal.map_or(serde_json::Value::Null, |s| {
            let per_cpu: serde_json::Map<String, serde_json::Value> =
                s.cpus().iter().map(|c| (c.cpu.to_string(), c.stolen_ms.into())).collect();
            serde_json::json!({ "loop_cpu": loop_cpu, "per_cpu_ms": per_cpu })
        });
        if let Some(fields) = self.fields.as_object_mut() {
            fields.insert("host_steal".into(), steal);
        }
        self
    }

    /// Adds the multirate coupling's counts (`multirate`), `null` without multirate stepping.
    pub fn with_multirate(mut self, status: Option<MultirateStatus>) -> Self {
        let multirate = status.map_or(serde_json::Value::Null, |m| {
            serde_json::json!({
                "region_nodes": m.region_nodes,
                "region_radius_m": m.radius,
                "bulk_nodes": m.bulk_nodes,
                "ratio": m.ratio,
                "bulk_steps": m.bulk_steps,
                "bulk_step_max_us": m.bulk_step_max_ns as f64 / 1e3,
                "waits": m.waits,
                "wait_max_us": m.wait_max_ns as f64 / 1e3,
                "held_ticks": m.held_ticks,
                "held_max_ticks": m.held_max_ticks,
                "refused": m.refused,
                "recentres": m.recentres,
                "recentres_refused": m.recentres_refused,
                "recentre_build_max_us": m.recentre_build_max_ns as f64 / 1e3,
                "build_exchanges": m.build_exchanges,
                "coupling_gap_m": m.coupling_gap_m,
                "coupling_gap_max_m": m.coupling_gap_max_m,
                "bulk_stopped": m.bulk_stopped,
            })
        });
        if let Some(fields) = self.fields.as_object_mut() {
            fields.insert("multirate".into(), multirate);
        }
        self
    }

    /// Adds the standby's CPU and the ticks it ran (`standby`), `null` without one.
    pub fn with_standby(mut self, standby: Option<(usize, u64)>) -> Self {
        let value = standby.map_or(serde_json::Value::Null, |(cpu, ticks)| {
            serde_json::json!({ "cpu": cpu, "ticks": ticks, "delay_us": lamina_core::scene::STANDBY_DELAY_US })
        });
        if let Some(fields) = self.fields.as_object_mut() {
            fields.insert("standby".into(), value);
        }
        self
    }

    /// Adds the node frames' counts (`node_frames`) from the frames `published` and the
    /// gate that chose their ticks; `null` without publishing.
    pub fn with_node_frames(mut self, frames: Option<(u64, &NodeFrameGate)>) -> Self {
        let value = frames.map_or(serde_json::Value::Null, |(published, gate)| {
            serde_json::json!({
                "published": published,
                "deferred": gate.deferred(),
                "shed": gate.shed(),
                "cutoff_us": gate.cutoff_ns() as f64 / 1e3,
            })
        });
        if let Some(fields) = self.fields.as_object_mut() {
            fields.insert("node_frames".into(), value);
        }
        self
    }

    /// The report: the monitor's summary (`summary_json`) with the context's fields added.
    pub fn report(&self, summary_json: &str) -> serde_json::Value {
        let mut report: serde_json::Value = serde_json::from_str(summary_json).unwrap_or_default();
        let context = serde_json::json!({
            "lamina": { "version": VERSION, "git_revision": GIT_REVISION },
            "started_utc": self.started_utc,
            "host": self.host,
        });
        if let Some(r) = report.as_object_mut() {
            for part in [context, self.fields.clone()] {
                if let serde_json::Value::Object(fields) = part {
                    r.extend(fields);
                }
            }
        }
        report
    }
}
