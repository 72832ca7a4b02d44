//! `lamina demo` stopped with Ctrl-C (SIGINT): it stops its children in order, prints every
//! summary and says where it wrote; a second run clears the first run's frames.

use lamina_tests::{wait_with_watchdog, workspace_bin};
use std::io::Read;
use std::process::{Command, Stdio};
use std::time::Duration;

#[test]
fn demo_stopped_by_sigint_prints_every_summary_and_clears_old_frames_works() {
    let lamina = workspace_bin("lamina");
    let viewer = lamina.with_file_name("lamina-viewer");
    if !viewer.exists() {
        let release = lamina.parent().is_some_and(|d| d.ends_with("release"));
        let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
        cmd.args(["build", "-p", "lamina-viewer", "--bins"]);
        if release {
            cmd.arg("--release");
        }
        assert!(cmd.status().expect("cargo build").success(), "building lamina-viewer failed");
    }
    let out = std::env::temp_dir().join(format!("lamina_demo_stop_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let frames = out.join("frames");
    std::fs::create_dir_all(&frames).unwrap();
    let stale = frames.join("frame_99999.png");
    std::fs::write(&stale, b"an earlier run's frame").unwrap();

    let mut demo = Command::new(&lamina)
        .args(["demo", "--seconds", "600", "--out"])
        .arg(&out)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting lamina demo");
    // Until the core has written its first per-second line, then Ctrl-C.
    let core_log = out.join("core.log");
    let mut waited = 0;
    while !std::fs::read_to_string(&core_log).is_ok_and(|t| t.contains("ticks")) && waited < 600 {
        std::thread::sleep(Duration::from_millis(100));
        waited += 1;
    }
    // SAFETY: kill(2) on the child's pid.
    assert_eq!(unsafe { libc::kill(demo.id() as libc::pid_t, libc::SIGINT) }, 0);
    // A watchdog, not a speed bound: without the stop the demo would run 600 s.
    let status = wait_with_watchdog(&mut demo, Duration::from_secs(120), "lamina demo");
    let (mut stdout, mut stderr) = (String::new(), String::new());
    demo.stdout.take().unwrap().read_to_string(&mut stdout).unwrap();
    demo.stderr.take().unwrap().read_to_string(&mut stderr).unwrap();
    assert!(status.success(), "{status}\n{stdout}\n{stderr}");
    assert!(stdout.contains("1 earlier frames cleared"), "{stdout}");
    assert!(!stale.exists(), "the earlier run's frame is gone");
    assert!(stdout.contains("SIGINT: stopping haptics, core and viewer, in that order"), "{stdout}");
    for section in ["== core (lamina run)", "== haptics (lamina-haptics)", "== viewer (lamina-viewer)"] {
        assert!(stdout.contains(section), "missing {section}:\n{stdout}");
    }
    // The core stopped on its signal and still wrote its tables and report.
    assert!(stdout.contains("stopped by SIGTERM"), "{stdout}");
    assert!(out.join("core_report.json").exists(), "{stdout}");
    assert!(stdout.contains("stopped early by SIGINT"), "{stdout}");
    let _ = std::fs::remove_dir_all(&out);
}
