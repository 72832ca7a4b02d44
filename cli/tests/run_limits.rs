//! `lamina run` at its limits, with real processes: SIGTERM stops it within one sub-step's
//! work even inside a long frame; without --seconds it runs until a signal and keeps only the
//! newest ticks for --ticks-csv; absurd lengths are refused; a state that diverges with the
//! guard off is reported, never published, and fails the run.

use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn sigterm_inside_a_long_frame_stops_the_core_works() {
    let dir = std::env::temp_dir().join(format!("lamina_stop_signal_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let default = include_str!("../../config/scenes/default.toml");
    let scene = default
        .replace("integrator = \"implicit_factored\"", "integrator = \"symplectic_euler\"")
        .replace("substeps = \"auto\"", "substeps = 10000");
    assert!(
        scene.contains("substeps = 10000") && scene.contains("symplectic_euler"),
        "default.toml's solver table changed"
    );
    let scene_path = dir.join("long_frames.toml");
    std::fs::write(&scene_path, scene).unwrap();
    let report = dir.join("report.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_lamina"))
        .args(["run", "--no-publish", "--quiet", "--seconds", "600", "--scene"])
        .arg(&scene_path)
        .arg("--report")
        .arg(&report)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    // SAFETY: kill(2) on the child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) }, 0);
    // A watchdog, not a speed bound: a core that ignored the signal would run for 600 s.
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("lamina run ignored SIGTERM for 120 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let (mut out, mut err) = (String::new(), String::new());
    child.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    assert!(status.success(), "{status}\n{out}\n{err}");
    let line = out.lines().find(|l| l.starts_with("stopped by SIGTERM")).unwrap_or_else(|| panic!("{out}"));
    // "stopped by SIGTERM inside a frame after N of 10000 sub-steps"
    let done: u64 = line
        .split_whitespace()
        .skip_while(|w| *w != "after")
        .nth(1)
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(line.contains("inside a frame") && done < 10_000, "{line}");
    assert!(out.contains("state finite: true"), "{out}");
    assert!(report.exists(), "the report is written after the stop: {out}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_without_seconds_runs_until_sigterm_and_keeps_the_last_ticks_works() {
    let dir = std::env::temp_dir().join(format!("lamina_until_signal_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (report, ticks) = (dir.join("report.json"), dir.join("ticks.csv"));
    let mut child = Command::new(env!("CARGO_BIN_EXE_lamina"))
        .args(["run", "--no-publish", "--quiet", "--ticks-csv-last", "200", "--report"])
        .arg(&report)
        .arg("--ticks-csv")
        .arg(&ticks)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Long enough for more than 200 ticks at 1 kHz even on a loaded machine.
    std::thread::sleep(Duration::from_millis(1500));
    // SAFETY: kill(2) on the child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) }, 0);
    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        assert!(started.elapsed() < Duration::from_secs(120), "lamina run ignored SIGTERM");
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut out = String::new();
    child.stdout.take().unwrap().read_to_string(&mut out).unwrap();
    assert!(status.success(), "{status}\n{out}");
    assert!(out.contains("running until Ctrl-C") && out.contains("stopped by SIGTERM"), "{out}");
    let report_text = std::fs::read_to_string(&report).unwrap();
    let json: serde_json::Value = serde_json::from_str(&report_text).unwrap();
    let total_ticks =
        json["summary"]["ticks"].as_u64().or_else(|| json["ticks"].as_u64()).expect("ticks in the report");
    assert!(total_ticks > 200, "ran {total_ticks} ticks");
    // The CSV keeps exactly the newest 200 ticks, consecutive, in order.
    let csv = std::fs::read_to_string(&ticks).unwrap();
    let rows: Vec<u64> = csv.lines().skip(1).map(|l| l.split(',').next().unwrap().parse().unwrap()).collect();
    assert_eq!(rows.len(), 200, "{csv:.200}");
    assert!(rows.windows(2).all(|w| w[1] == w[0] + 1), "consecutive ticks");
    assert_eq!(*rows.last().unwrap() + 1, total_ticks, "the newest tick is the last one run");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn run_with_absurd_length_or_ring_is_refused_fails() {
    for (args, named) in [
        (&["--seconds", "1e300"][..], "--seconds 1e300"),
        (&["--seconds", "NaN"][..], "--seconds NaN"),
        (&["--seconds=-1"][..], "--seconds -1"),
        (&["--seconds", "1", "--ticks-csv-last", "0"][..], "--ticks-csv-last 0"),
        (&["--seconds", "1", "--ticks-csv-last", "3600001"][..], "--ticks-csv-last 3600001"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_lamina")).args(["run", "--no-publish"]).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(named), "{args:?}: {err}");
    }
}

#[test]
fn bench_capacity_with_an_absurd_region_or_ratio_is_refused_fails() {
    for (args, named) in [
        (&["--region-radius", "NaN"][..], "--region-radius NaN"),
        (&["--region-radius=-0.01"][..], "--region-radius -0.01"),
        (&["--region-radius", "0"][..], "--region-radius 0"),
        (&["--ratio", "1"][..], "--ratio 1"),
        (&["--ratio", "1001"][..], "--ratio 1001"),
    ] {
        // Refused before any model is built: the command returns at once.
        let out = Command::new(env!("CARGO_BIN_EXE_lamina")).args(["bench", "capacity"]).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(named), "{args:?}: {err}");
    }
}

#[test]
fn diverged_state_with_guard_off_is_reported_and_never_published_fails() {
    // A drag handle pulling toward a point 1 km away, symplectic Euler, guard off: the state
    // goes non-finite (after 0.35-0.45 s simulated). The run says so, publishes no such frame
    // and exits with an error. 2 s of wall time leave room for the periods a loaded machine
    // skips (a third of them, seen under CI's compile).
    let dir = std::env::temp_dir().join(format!("lamina_diverged_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = "name = \"far-handle\"\nrate_hz = 1000\n[model]\nkind = \"cylinder_limb\"\ncolumns = 12\nrows = 3\n\
                 length = 0.24\n[solver]\nintegrator = \"symplectic_euler\"\n[effects]\nguard = false\n\
                 [[effects.handles]]\nnode = 12\ntarget = [1000.0, 0.0, 0.0]\nstiffness = 2.0\n";
    let path = dir.join("far_handle.toml");
    std::fs::write(&path, scene).unwrap();
    let prefix = format!("diverged_{}", std::process::id());
    let out = Command::new(env!("CARGO_BIN_EXE_lamina"))
        .args(["run", "--quiet", "--seconds", "2", "--prefix", &prefix, "--scene"])
        .arg(&path)
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(!out.status.success(), "{stdout}");
    assert!(stderr.contains("far_handle.toml") && stderr.contains("diverged"), "{stderr}");
    assert!(stdout.contains("max displacement NaN mm") && stdout.contains("state finite: false"), "{stdout}");
    let withheld: u64 = stdout
        .split(" withheld")
        .next()
        .and_then(|s| s.rsplit(' ').next())
        .and_then(|w| w.parse().ok())
        .unwrap_or_else(|| panic!("{stdout}"));
    assert!(withheld > 0, "{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn max_substeps_below_the_critical_step_prints_a_warning_works() {
    // Symplectic Euler needs 14 sub-steps per 1 ms tick on the default limb; max_substeps = 2
    // holds it to 2. The run says so instead of clamping in silence; max_substeps = 0 is refused.
    let dir = std::env::temp_dir().join(format!("lamina_clamp_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let default = include_str!("../../config/scenes/default.toml");
    let explicit = default.replace("integrator = \"implicit_factored\"", "integrator = \"symplectic_euler\"");
    assert!(explicit.contains("symplectic_euler"), "default.toml's solver table changed");
    let run = |max_substeps: u32| {
        let scene =
            explicit.replace("substeps = \"auto\"", &format!("substeps = \"auto\"\nmax_substeps = {max_substeps}"));
        let path = dir.join(format!("clamped_{max_substeps}.toml"));
        std::fs::write(&path, scene).unwrap();
        Command::new(env!("CARGO_BIN_EXE_lamina"))
            .args(["run", "--no-publish", "--quiet", "--seconds", "0.05", "--scene"])
            .arg(&path)
            .output()
            .unwrap()
    };
    let out = run(2);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let warning = stdout
        .lines()
        .find(|l| l.starts_with("warning: the critical step asks for"))
        .unwrap_or_else(|| panic!("{stdout}"));
    let needed: u32 =
        warning.split_whitespace().nth(6).and_then(|w| w.parse().ok()).unwrap_or_else(|| panic!("{warning}"));
    assert!(needed > 2, "{warning}");
    assert!(warning.contains("max_substeps = 2 holds it to 2"), "{warning}");
    let out = run(0);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("solver.max_substeps") && stderr.contains("at least 1"),
        "{stderr}"
    );
    let out = run(1000);
    assert!(!String::from_utf8_lossy(&out.stdout).contains("warning: the critical step"));
    let _ = std::fs::remove_dir_all(&dir);
}
