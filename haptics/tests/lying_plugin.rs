//! `lamina-haptics` driving a plugin that lies, as real processes: limits of 1e308, a pose of
//! 1e300 m, a call that blocks; and options out of range. The plugin is
//! `haptics/plugins/sim_device.c` with its misbehaviours switched on by `--device-args`; it
//! logs the largest force it was commanded, so each test checks what the device received.
//! A stand-in core (a stiff flat wall, `common::WallCore`) gives the press something to
//! push against.

mod common;

use common::{WallCore, haptics, plugin, plugin_log, prefix, scratch, stderr, stdout};

/// One pressing run at a time: each loads a CPU at 4 kHz, with its stand-in core beside it.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn serial() -> std::sync::MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn device() -> String {
    format!("plugin:{}", plugin().display())
}

/// Runs the plugin with `device_args` for `seconds`, without a core, `--quiet`.
fn alone(tag: &str, device_args: &str, seconds: &str) -> std::process::Output {
    let (p, dev) = (prefix(tag), device());
    haptics(&[
        "--prefix",
        &p,
        "--device",
        &dev,
        "--device-args",
        device_args,
        "--origin",
        "0,0,0",
        "--seconds",
        seconds,
        "--quiet",
    ])
}

/// Runs the plugin with `device_args` against a wall of stiffness `k` for `seconds`, with the
/// device's centre at the model origin; the output and the plugin's log.
fn press(
    tag: &str,
    device_args: &str,
    k: f64,
    seconds: &str,
    extra: &[&str],
) -> (std::process::Output, (u64, f64, u64)) {
    let _one = serial();
    let p = prefix(tag);
    let log = scratch().join(format!("{p}.log"));
    let core = WallCore::start(&p, k);
    let args = format!("{device_args},log={}", log.display());
    let dev = device();
    let mut all = vec!["--prefix", &p, "--device", &dev, "--device-args", &args, "--origin", "0,0,0"];
    all.extend(["--seconds", seconds]);
    all.extend(extra);
    let out = haptics(&all);
    drop(core);
    let figures = plugin_log(&log);
    (out, figures)
}

#[test]
fn plugin_reporting_1e308_limits_is_clamped_reported_and_an_8mm_press_gets_at_most_the_ceiling_works() {
    // A wall of 1e6 N/m pressed 8 mm asks for 8 kN; the plugin claims it can take 1e308 N.
    let report = scratch().join(format!("{}.json", prefix("huge")));
    let r = report.display().to_string();
    let (out, (writes, max_force, _)) = press("huge", "huge_limits,press_mm=8", 1e6, "1", &["--quiet", "--report", &r]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    for what in ["max force 1e308 N reported", "max stiffness 1e308 N/m reported", "max damping 1e308 N s/m reported"] {
        assert!(err.contains(what), "the clamp of {what} is reported at start: {err}");
    }
    assert!(err.contains("unlisted device ceiling: 12 N used"), "{err}");
    eprintln!("1e308 limits, 8 mm into 1e6 N/m: largest force commanded {max_force:.6} N in {writes} writes");
    assert!(writes > 1000, "the loop ran: {writes} writes");
    assert!(max_force <= 12.0 + 1e-9, "the device was commanded {max_force} N, above the 12 N ceiling");
    assert!(max_force > 11.9, "the press reached the ceiling: {max_force} N");
    let summary = stdout(&out);
    assert!(summary.contains("device class unlisted device: max force"), "{summary}");
    assert!(
        summary.contains("(limit 12.00 N)") && summary.contains("(limit 5000 N/m)"),
        "the loop's limits: {summary}"
    );
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["device_class"], "unlisted device");
    let clamps: Vec<(String, f64, f64)> = json["limit_clamps"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            (c["limit"].as_str().unwrap().to_string(), c["reported"].as_f64().unwrap(), c["ceiling"].as_f64().unwrap())
        })
        .collect();
    assert_eq!(
        clamps,
        [
            ("max force".into(), 1e308, 12.0),
            ("max stiffness".into(), 1e308, 5000.0),
            ("max damping".into(), 1e308, 30.0)
        ]
    );
    assert_eq!(json["limits"]["max_force_n"], 12.0);
}

#[test]
fn max_force_is_obeyed_in_the_commands_the_device_receives_works() {
    // 8 mm into 1e4 N/m asks for 80 N; the plugin's own limit is 8 N.
    let (out, (_, uncapped, _)) = press("cap0", "press_mm=8", 1e4, "1", &["--quiet"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!((uncapped - 8.0).abs() < 1e-9, "without --max-force the device limit holds: {uncapped} N");
    let (out, (_, capped, _)) = press("cap2", "press_mm=8", 1e4, "1", &["--quiet", "--max-force", "2"]);
    assert!(out.status.success(), "{}", stderr(&out));
    eprintln!("8 mm into 1e4 N/m: largest force commanded {uncapped:.6} N, with --max-force 2 {capped:.6} N");
    assert!(capped <= 2.0 + 1e-9, "--max-force 2 but the device was commanded {capped} N");
    assert!(capped > 1.99, "the press reached the cap: {capped} N");
    assert!(stdout(&out).contains("(limit 2.00 N)"), "{}", stdout(&out));
}

#[test]
fn max_force_out_of_range_is_refused_naming_the_option_value_and_range_fails() {
    let dev = device();
    for value in ["0", "-5", "nan", "inf", "8.5"] {
        let cap = format!("--max-force={value}");
        let p = prefix("capbad");
        let out = haptics(&["--prefix", &p, "--device", &dev, "--origin", "0,0,0", "--seconds", "1", &cap]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{value}: {err}");
        let shown = lamina_haptics::device::show_number(value.parse().unwrap());
        assert!(err.contains(&format!("--max-force {shown} N")), "{value}: names the option and value: {err}");
        assert!(err.contains("0 < F <= 8 N"), "{value}: gives the valid range: {err}");
    }
}

#[test]
fn pose_beyond_the_workspace_is_a_fault_that_fades_the_force_and_is_reported_works() {
    let dir = scratch();
    let report = dir.join(format!("{}.json", prefix("pose")));
    let trace = dir.join(format!("{}.csv", prefix("pose")));
    let (r, t) = (report.display().to_string(), trace.display().to_string());
    // Pressed 8 mm by read 1800, then the pose jumps to z = 1e300 m from read 3001 on.
    let (out, _) =
        press("pose", "press_mm=8,huge_pose_after=3000", 1e4, "2", &["--quiet", "--report", &r, "--trace-csv", &t]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("beyond its 0.075 m radius: fault"), "a stderr line says it: {err}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    let safety = &json["safety"];
    assert_eq!(safety["workspace_faults"], 1, "{safety}");
    assert!(safety["workspace_fault_ticks"].as_u64().unwrap() > 100, "{safety}");
    let sent = json["commands_sent"].as_u64().unwrap() + json["port_failures"].as_u64().unwrap();
    assert_eq!(sent, 3000, "no tool command is sent for a pose beyond the workspace");
    assert!(stdout(&out).contains("in 1 fault(s)"), "the summary counts it: {}", stdout(&out));
    // The trace: the force held before the fault, never grows during it and is zero at the end.
    let rows: Vec<(f64, f64)> = std::fs::read_to_string(&trace)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            (v[3], (v[4] * v[4] + v[5] * v[5] + v[6] * v[6]).sqrt())
        })
        .collect();
    let first = rows.iter().position(|r| r.0 > 1.0).expect("the trace holds the fault");
    let before = rows[first.saturating_sub(400)..first].iter().fold(0.0f64, |m, r| m.max(r.1));
    assert!(before > 7.9, "pressing at the device's 8 N before the fault: {before} N");
    let during = &rows[first..];
    assert!(during.windows(2).all(|w| w[1].1 <= w[0].1 + 1e-12), "the force never grows during the fault");
    assert_eq!(during.last().unwrap().1, 0.0, "faded to zero");
}

#[test]
fn plugin_call_that_blocks_forever_is_a_fault_and_seconds_is_honoured_works() {
    let _one = serial();
    let out = alone("block", "block_after=1000", "1");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "the process ends although the plugin never returns: {err}");
    assert!(err.contains("call read has not returned after") && err.contains("(limit 5 ms): fault"), "{err}");
    assert!(err.contains("emergency stop sent (zero force)"), "{err}");
    assert!(err.contains("simulated device: emergency stop, force set to zero"), "the plugin got it: {err}");
    assert!(err.contains("still blocked in read") && err.contains("exiting without a report"), "{err}");
}

#[test]
fn plugin_call_that_blocks_for_30_ms_is_a_counted_fault_and_the_run_goes_on_works() {
    let report = scratch().join(format!("{}.json", prefix("stall")));
    let r = report.display().to_string();
    let (out, (_, _, stops)) = press("stall", "block_after=1000,block_ms=30", 1e4, "1", &["--quiet", "--report", &r]);
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("device call read took"), "{err}");
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert!(json["safety"]["device_call_stalls"].as_u64().unwrap() >= 1, "{}", json["safety"]);
    let stalls = json["safety"]["device_call_stalls"].as_u64().unwrap();
    assert!(stops <= stalls, "an emergency stop only for a call that stalled: {stops} stops, {stalls} stalls");
}

#[test]
fn wait_core_s_and_seconds_beyond_their_bounds_are_refused_fails() {
    for (option, value, bound) in [
        ("--wait-core-s", "1e300", "from 0 to 86400"),
        ("--seconds", "1e300", "at most 1e9"),
        ("--seconds", "nan", "above 0"),
    ] {
        let p = prefix("bounds");
        let out = haptics(&["--prefix", &p, "--origin", "0,0,0", option, value]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{option} {value}: {err}");
        let shown = lamina_haptics::device::show_number(value.parse().unwrap());
        assert!(err.contains(&format!("{option} {shown}:")) && err.contains(bound), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn device_plugin_with_an_empty_path_names_the_option_fails() {
    for spec in ["plugin:", "scripted:"] {
        let p = prefix("empty");
        let out = haptics(&["--prefix", &p, "--device", spec, "--origin", "0,0,0", "--seconds", "1"]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(err.contains(&format!("--device '{spec}': no file after '{spec}'")), "{err}");
        assert!(!err.contains("missing symbol"), "blames the option, not the program: {err}");
    }
}

#[test]
fn plugin_open_that_never_returns_ends_at_seconds_fails() {
    let out = alone("open", "block_open", "0.5");
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("opening it has not returned within --seconds 0.5"), "{err}");
}
