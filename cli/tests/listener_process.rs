//! Multi-process: a `lamina-listen` subscriber killed with SIGKILL and restarted receives
//! again, while the publisher in this process keeps publishing through the kill.

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use lamina_bridge::{Bridge, BridgeConfig, NodesPublisher};

/// Watchdog for waits that must succeed; it bounds a hang, it is not a timing requirement.
const WATCHDOG: Duration = Duration::from_secs(60);

/// Starts `lamina-listen` and a thread forwarding its stdout lines.
fn spawn_listener(prefix: &str, out: &std::path::Path) -> (Child, Receiver<String>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lamina-listen"))
        .args(["--prefix", prefix, "--mode", "block", "--seconds", "120", "--print-every", "10"])
        .arg("--out")
        .arg(out)
        .stdout(Stdio::piped())
        .spawn()
        .expect("lamina-listen starts");
    let stdout = child.stdout.take().expect("piped stdout");
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    (child, rx)
}

/// Waits for the listener's first progress line: proof it received frames.
fn wait_for_frames(rx: &Receiver<String>) {
    let deadline = Instant::now() + WATCHDOG;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let line = rx.recv_timeout(left).expect("listener reports frames before the watchdog");
        if line.starts_with("received") {
            return;
        }
    }
}

fn wait_until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + WATCHDOG;
    while !done() {
        assert!(Instant::now() < deadline, "watchdog expired waiting for {what}");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn listener_sigkill_restart_works() {
    let prefix = format!("t{}_listener_sigkill", std::process::id());
    let dir = std::env::temp_dir();
    let out1 = dir.join(format!("{prefix}_1.json"));
    let out2 = dir.join(format!("{prefix}_2.json"));

    // Publisher thread: ~1 kHz until told to stop, counting successful and failed sends.
    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let failed = Arc::new(AtomicU64::new(0));
    let publisher_thread = {
        let (stop, sent, failed, prefix) = (stop.clone(), sent.clone(), failed.clone(), prefix.clone());
        std::thread::spawn(move || {
            let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
            let publisher = NodesPublisher::create(&bridge, 2769).unwrap();
            let mut seq = 0u64;
            while !stop.load(Ordering::SeqCst) {
                match publisher.publish_from_fn(seq, seq, seq as f64 * 1e-3, 2769, |i| [i as f32, 0.0, 0.0]) {
                    Ok(_) => sent.fetch_add(1, Ordering::SeqCst),
                    Err(_) => failed.fetch_add(1, Ordering::SeqCst),
                };
                seq += 1;
                std::thread::sleep(Duration::from_millis(1));
            }
        })
    };

    let (mut first, rx1) = spawn_listener(&prefix, &out1);
    wait_for_frames(&rx1);
    first.kill().expect("SIGKILL delivered");
    first.wait().expect("killed listener reaped");

    // The publisher keeps going with a dead subscriber still registered.
    let at_kill = sent.load(Ordering::SeqCst);
    wait_until("publishes after the kill", || sent.load(Ordering::SeqCst) >= at_kill + 200);
    let during_kill_window = sent.load(Ordering::SeqCst) - at_kill;

    let (mut second, rx2) = spawn_listener(&prefix, &out2);
    wait_for_frames(&rx2);
    // SAFETY: plain kill(2) on our own child's pid.
    let rc = unsafe { libc::kill(second.id() as libc::pid_t, libc::SIGTERM) };
    assert_eq!(rc, 0);
    let status = second.wait().expect("listener exits on SIGTERM");
    assert!(status.success(), "listener exit status {status}");

    stop.store(true, Ordering::SeqCst);
    publisher_thread.join().unwrap();

    assert!(during_kill_window >= 200);
    assert_eq!(failed.load(Ordering::SeqCst), 0, "no publish failed");
    assert!(!out1.exists(), "a SIGKILLed listener writes nothing");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out2).expect("report written on SIGTERM")).unwrap();
    assert_eq!(report["terminated_by_signal"], true);
    assert!(report["count"].as_u64().unwrap() >= 10);
    assert_eq!(report["last_node_count"], 2769);
    let _ = std::fs::remove_file(&out2);
}
