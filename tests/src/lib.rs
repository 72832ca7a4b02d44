//! Helpers for the workspace-level tests: finding and running the workspace's binaries, unique
//! iceoryx2 service prefixes, and a watchdog for child processes.

use std::path::PathBuf;
use std::process::{Child, Command};
use std::sync::Once;
use std::time::{Duration, Instant};

/// The folder holding this build's binaries (`target/<profile>`).
pub fn bin_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    exe.parent().and_then(|p| p.parent()).expect("target/<profile>/deps/<test>").to_path_buf()
}

/// Path of workspace binary `name`, after one `cargo build` of the binaries per test process
/// (`cargo test -p lamina-tests` alone does not build other packages' binaries, and a binary
/// left from an older build must not be tested).
pub fn workspace_bin(name: &str) -> PathBuf {
    static BUILD: Once = Once::new();
    let path = bin_dir().join(name);
    {
        BUILD.call_once(|| {
            let release = bin_dir().ends_with("release");
            let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
            cmd.args(["build", "-p", "lamina", "-p", "lamina-haptics", "--bins"]);
            if release {
                cmd.arg("--release");
            }
            let status = cmd.status().expect("running cargo build");
            assert!(status.success(), "building the workspace binaries failed");
        });
    }
    assert!(path.exists(), "{} not found", path.display());
    path
}

/// Runs the workspace's `lamina` with `args` to the end: whether it succeeded, and its
/// stdout followed by its stderr.
pub fn run_lamina(args: &[&str]) -> (bool, String) {
    let out = Command::new(workspace_bin("lamina")).args(args).output().expect("run lamina");
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    (out.status.success(), text)
}

/// Runs `lamina` with `command` followed by each case's arguments and asserts it refuses them,
/// its output naming what the case gives (the option and value, or the reason).
pub fn assert_lamina_refuses(command: &[&str], cases: &[(&[&str], &str)]) {
    for (args, named) in cases {
        let (ok, text) = run_lamina(&[command, args].concat());
        assert!(!ok, "{args:?} accepted: {text}");
        assert!(text.contains(named), "{args:?}: {text}");
    }
}

/// A service prefix no other test or run uses.
pub fn unique_prefix(tag: &str) -> String {
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.subsec_nanos());
    format!("t_{tag}_{}_{nanos}", std::process::id())
}

/// Waits for `child` at most `limit`; kills it (and fails) if it runs longer.
pub fn wait_with_watchdog(child: &mut Child, limit: Duration, what: &str) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("waiting for a child") {
            return status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} did not finish within {limit:?}: killed by the watchdog");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Sends SIGKILL to `child` and reaps it.
pub fn kill9(child: &mut Child) {
    let _ = child.kill();
    let _ = child.wait();
}

/// `chrt -f PRIO` in front of a command when the system allows real-time priority (root and
/// `chrt` present), so a subscriber that must keep up is not starved on a busy machine.
pub fn realtime_prefix(prio: u32) -> Vec<String> {
    let root = unsafe { libc::geteuid() } == 0;
    let has_chrt = Command::new("chrt").arg("--version").output().is_ok_and(|o| o.status.success());
    if root && has_chrt { vec!["chrt".into(), "-f".into(), prio.to_string()] } else { Vec::new() }
}

/// Reads a JSON report written by `lamina-listen`.
pub fn read_json(path: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The repository's Python package directory (`python/`, holding `lamina/`), for
/// `PYTHONPATH`: the Python clients under test import this checkout's `lamina`, not an
/// installed copy of another revision.
pub fn python_package_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../python")
}
