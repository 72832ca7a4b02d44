//! Shared by the plugin tests: the test plugin compiled from `haptics/plugins/sim_device.c`,
//! the `lamina-haptics` binary run with a hang guard, and a stand-in core that answers tool
//! commands with a flat wall's contact model.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::Arc;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use lamina_bridge::wire::ContactFeedback;
use lamina_bridge::{Bridge, BridgeConfig, FeedbackPublisher, ToolSubscriber, now_ns};

fn manifest() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A scratch directory of this test process.
pub fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_plugin_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Compiles a variant of the test plugin (`defines` like `-DLAMINA_SIM_BAD_ABI`).
pub fn build_plugin(tag: &str, defines: &[&str]) -> PathBuf {
    let out = scratch().join(format!("libsim_{tag}.so"));
    let cc = std::env::var("CC").unwrap_or_else(|_| "cc".into());
    let status = Command::new(&cc)
        .args(["-shared", "-fPIC", "-O2", "-Wall", "-Werror"])
        .arg("-I")
        .arg(manifest().join("include"))
        .args(defines)
        .arg("-o")
        .arg(&out)
        .arg(manifest().join("plugins/sim_device.c"))
        .arg("-lm")
        .status()
        .unwrap_or_else(|e| panic!("no C compiler '{cc}' to build the test plugin: {e}"));
    assert!(status.success(), "compiling the test plugin failed");
    out
}

/// The test plugin as shipped.
pub fn plugin() -> &'static Path {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| build_plugin("ok", &[]))
}

/// A fresh service prefix.
pub fn prefix(tag: &str) -> String {
    static N: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    format!("t_{tag}_{}_{}", std::process::id(), N.fetch_add(1, Ordering::Relaxed))
}

/// Runs `lamina-haptics` (no SCHED_FIFO) with `args` to its end; kills it and fails after
/// 60 s (a hang guard, far beyond any run here).
pub fn haptics(args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lamina-haptics"))
        .args(["--fifo", "0"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting lamina-haptics");
    let start = Instant::now();
    while child.try_wait().expect("waiting for lamina-haptics").is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("lamina-haptics {args:?} did not end within 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("lamina-haptics output")
}

/// stderr of `out`, as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// stdout of `out`, as text.
pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The figures the test plugin writes at close (`log=PATH`): writes received, largest force
/// norm received (N), emergency stops.
pub fn plugin_log(path: &Path) -> (u64, f64, u64) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let value = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key).map(|v| v.trim().to_string()))
            .unwrap_or_else(|| panic!("{key} missing from {text}"))
    };
    (
        value("writes ").parse().unwrap(),
        value("max_force_n ").parse().unwrap(),
        value("emergency_stops ").parse().unwrap(),
    )
}

/// A stand-in core on a prefix: a flat wall at model y = 0 of stiffness `k` (N/m), answering
/// each tool command as Lamina's core does, linearised at the commanded position
/// (force `k · depth` up, stiffness `−k` along y), every millisecond.
pub struct WallCore {
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl WallCore {
    /// Starts publishing on `prefix`.
    pub fn start(prefix: &str, k: f64) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let (flag, prefix) = (stop.clone(), prefix.to_string());
        let thread = std::thread::spawn(move || {
            let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).expect("bridge");
            let feedback = FeedbackPublisher::create(&bridge).expect("feedback publisher");
            let tool = ToolSubscriber::create(&bridge).expect("tool subscriber");
            let mut position = None;
            let mut sequence = 0;
            while !flag.load(Ordering::Relaxed) {
                if let Ok(Some(sample)) = tool.latest() {
                    position = Some(sample.message().position);
                }
                if let Some(p) = position {
                    let depth = (-p[1]).max(0.0);
                    let mut fb = ContactFeedback {
                        sequence,
                        tick: sequence,
                        publish_time_ns: now_ns(),
                        in_contact: u32::from(depth > 0.0),
                        x_ref: p,
                        ..Default::default()
                    };
                    if depth > 0.0 {
                        fb.force = [0.0, k * depth, 0.0];
                        fb.stiffness[1][1] = -k;
                    }
                    let _ = feedback.publish_polled(&fb);
                    sequence += 1;
                }
                std::thread::sleep(Duration::from_millis(1));
            }
        });
        Self { stop, thread: Some(thread) }
    }
}

impl Drop for WallCore {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
