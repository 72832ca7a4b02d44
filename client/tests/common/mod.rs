//! What the live-core tests share: starting and stopping `lamina run`, the library's last
//! error message.

#![allow(dead_code)]

use core::ffi::CStr;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use lamina_tests::{wait_with_watchdog, workspace_bin};

/// One core at a time: each loads both CPUs of a small machine.
pub static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// `lamina run` on the built-in default scene under `prefix`, for at most 300 s.
pub fn start_core(prefix: &str) -> Child {
    Command::new(workspace_bin("lamina"))
        .args(["run", "--prefix", prefix, "--seconds", "300"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("starting lamina run")
}

/// Stops `core` with SIGTERM and reaps it.
pub fn stop(mut core: Child) {
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(core.id() as libc::pid_t, libc::SIGTERM) };
    wait_with_watchdog(&mut core, Duration::from_secs(120), "lamina run");
}

/// The library's last error message on this thread.
pub fn message() -> String {
    // SAFETY: a NUL-terminated string valid until the next failing call on this thread.
    unsafe { CStr::from_ptr(lamina_client::lamina_last_error_message()) }.to_string_lossy().into_owned()
}
