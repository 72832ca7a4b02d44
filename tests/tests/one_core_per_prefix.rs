//! One core per prefix, with real processes: a second `lamina run` on a live prefix refuses
//! with an error naming the prefix and the first core's pid, and a subscriber sees one
//! stream only (its sequence numbers never go backwards).

use lamina_bridge::UserDomain;
use lamina_tests::{read_json, unique_prefix, wait_with_watchdog, workspace_bin};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn second_core_on_live_prefix_is_refused_works() {
    let prefix = unique_prefix("second_core");
    let dir = std::env::temp_dir().join(&prefix);
    std::fs::create_dir_all(&dir).unwrap();
    let run = |seconds: &str| {
        let mut cmd = Command::new(workspace_bin("lamina"));
        cmd.args(["run", "--quiet", "--prefix", &prefix, "--seconds", seconds]);
        cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
        cmd
    };
    let mut first = run("4").spawn().expect("starting the first core");
    // The first core holds the prefix once its lock file names it.
    let lock = UserDomain::current().root.join(format!("{prefix}.nodes.lock"));
    let start = Instant::now();
    while std::fs::read_to_string(&lock).map_or(true, |t| t.trim() != first.id().to_string()) {
        assert!(start.elapsed() < Duration::from_secs(30), "the first core never took {}", lock.display());
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = dir.join("listener.json");
    let mut listener = Command::new(workspace_bin("lamina-listen"))
        .args(["--prefix", &prefix, "--mode", "block", "--seconds", "2.5", "--out"])
        .arg(&out)
        .spawn()
        .expect("starting the listener");
    std::thread::sleep(Duration::from_millis(300));

    let mut second = run("2").spawn().expect("starting the second core");
    let status = wait_with_watchdog(&mut second, Duration::from_secs(60), "second lamina run");
    let mut err = String::new();
    std::io::Read::read_to_string(&mut second.stderr.take().unwrap(), &mut err).unwrap();
    assert!(!status.success(), "the second core must refuse the live prefix: {err}");
    assert!(err.contains(&format!("prefix '{prefix}' is live")), "{err}");
    assert!(err.contains(&format!("(pid {})", first.id())), "{err}");

    wait_with_watchdog(&mut listener, Duration::from_secs(60), "lamina-listen");
    let report = read_json(&out);
    assert!(report["count"].as_u64().unwrap_or(0) > 100, "{report}");
    assert_eq!(report["resets"].as_u64(), Some(0), "two streams interleaved: {report}");
    let status = wait_with_watchdog(&mut first, Duration::from_secs(60), "first lamina run");
    assert!(status.success(), "the first core ran its full time: {status}");
    // Once it is gone, the prefix is free again.
    let mut third = run("0.2").spawn().expect("starting a third core");
    let status = wait_with_watchdog(&mut third, Duration::from_secs(60), "third lamina run");
    assert!(status.success(), "{status}");
    let _ = std::fs::remove_dir_all(&dir);
}
