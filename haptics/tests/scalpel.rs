//! The scalpel from the haptics side: a trajectory's `kind` column (parsed, switched at rows,
//! refused with file and line when it names no tool), the kind and blade length the device loop
//! puts on every tool command, and `lamina-haptics --tool` / `--blade-length-mm` refusing what
//! they cannot use.

use std::process::Command;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use lamina_bridge::{Bridge, BridgeConfig, ToolCommand, ToolKind, ToolSubscriber};
use lamina_haptics::device::{DeviceError, HapticDevice, NullDevice, ScriptedDevice, Trajectory};
use lamina_haptics::{DeviceMapping, HapticsConfig, run_device_loop};
use lamina_rt::RunLimit;

#[test]
fn trajectory_kind_column_parses_and_switches_at_rows_works() {
    let text = "t_s,x_m,y_m,z_m,kind\n0,0,0,0,sphere\n1,0,0,0,scalpel\n2,0,0,0,0\n3,0,0,0,1\n";
    let t = Trajectory::parse(text, "cut.csv").unwrap();
    assert!(t.has_kind());
    let at = [-1.0, 0.5, 1.0, 1.5, 2.0, 2.9, 3.0, 9.0].map(|s| t.kind_at(s));
    use ToolKind::{Scalpel, Sphere};
    assert_eq!(at, [Sphere, Sphere, Scalpel, Scalpel, Sphere, Sphere, Scalpel, Scalpel].map(Some));
    // Buttons and kind in either order; without a kind column the kind is not the file's.
    let both = Trajectory::parse("t_s,x_m,y_m,z_m,kind,buttons\n0,0,0,0,scalpel,1\n", "b.csv").unwrap();
    assert_eq!((both.kind_at(0.0), both.buttons_at(0.0)), (Some(Scalpel), 1));
    let both = Trajectory::parse("t_s,x_m,y_m,z_m,buttons,kind\n0,0,0,0,1,scalpel\n", "b.csv").unwrap();
    assert_eq!((both.kind_at(0.0), both.buttons_at(0.0)), (Some(Scalpel), 1));
    let plain = Trajectory::parse("t_s,x_m,y_m,z_m,buttons\n0,0,0,0,1\n", "p.csv").unwrap();
    assert_eq!((plain.has_kind(), plain.kind_at(0.0)), (false, None));
    // The scripted device reports the row's kind after each read.
    let mut d = ScriptedDevice::new(t, ScriptedDevice::default_info(), 0);
    for (s, want) in [(0.5, Sphere), (1.5, Scalpel), (2.5, Sphere)] {
        d.set_time_s(s);
        d.read().unwrap();
        assert_eq!(d.tool_kind(), Some(want), "at {s} s");
    }
    let shipped = concat!(env!("CARGO_MANIFEST_DIR"), "/../config/trajectories/incision.csv");
    let incision = Trajectory::load(std::path::Path::new(shipped)).unwrap();
    assert!(incision.points().iter().all(|p| p.kind == Scalpel), "the incision is cut with the scalpel throughout");
}

#[test]
fn trajectory_bad_kind_is_refused_naming_file_and_line_fails() {
    let cases = [
        ("t_s,x_m,y_m,z_m,kind\n0,0,0,0,sphere\n# c\n1,0,0,0,knife\n", 4, "kind: 'knife' is not a tool"),
        ("t_s,x_m,y_m,z_m,kind\n0,0,0,0,2\n", 2, "kind: '2' is not a tool (expected sphere, scalpel, 0 or 1)"),
        ("t_s,x_m,y_m,z_m,kind\n0,0,0,0,\n", 2, "kind: '' is not a tool"),
        ("t_s,x_m,y_m,z_m,kind\n0,0,0,0\n", 2, "4 values, expected 5"),
        ("t_s,x_m,y_m,z_m,kind,kind\n0,0,0,0,0,0\n", 1, "column 'kind' twice"),
        ("t_s,x_m,y_m,z_m,tool\n0,0,0,0,0\n", 1, "expected t_s,x_m,y_m,z_m[,buttons][,kind]"),
    ];
    for (text, line, what) in cases {
        match Trajectory::parse(text, "cut.csv") {
            Err(e @ DeviceError::Script { .. }) => {
                let DeviceError::Script { file, line: l, what: w } = &e else { unreachable!() };
                assert_eq!((file.as_str(), *l), ("cut.csv", line), "{text:?}: {e}");
                assert!(w.contains(what), "{text:?}: '{w}' should say '{what}'");
                assert!(e.to_string().starts_with("cut.csv"), "{e}");
            }
            other => panic!("{text:?}: expected a script error, got {other:?}"),
        }
    }
}

/// Runs the device loop on `device` for `ticks` at 1 kHz with `cfg`, collecting every tool
/// command a subscriber in another thread receives.
fn commands_sent(tag: &str, device: &mut dyn HapticDevice, cfg: &HapticsConfig, ticks: u64) -> Vec<ToolCommand> {
    let prefix = format!("t_scalpel_{tag}_{}", std::process::id());
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let listener = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
            let tool = ToolSubscriber::create(&bridge).unwrap();
            ready_tx.send(()).unwrap();
            let mut got = Vec::new();
            while !stop.load(Ordering::Relaxed) {
                while let Some(s) = tool.try_receive().unwrap() {
                    got.push(*s.message());
                }
                std::thread::sleep(Duration::from_micros(500));
            }
            got
        })
    };
    ready_rx.recv_timeout(Duration::from_secs(30)).expect("the subscriber is up");
    let report = run_device_loop(device, &bridge, cfg, RunLimit::ticks(ticks), None, None).unwrap();
    stop.store(true, Ordering::Relaxed);
    let got = listener.join().unwrap();
    assert!(report.commands_sent >= ticks / 2, "the loop sent commands ({})", report.commands_sent);
    got
}

#[test]
fn device_loop_sends_the_trajectory_kind_row_by_row_works() {
    // Sphere until the row at 0.6 s, which switches to the scalpel 1 cm along device x (model
    // z with the y-up mapping); the handle moves along x meanwhile, so each command's
    // position says which row it follows, whatever the machine's load.
    let text = "t_s,x_m,y_m,z_m,kind\n0,0,0,0,sphere\n0.6,0.01,0,0,scalpel\n";
    let mut device =
        ScriptedDevice::new(Trajectory::parse(text, "switch.csv").unwrap(), ScriptedDevice::default_info(), 0);
    let cfg = HapticsConfig {
        rate_hz: 1000,
        mapping: DeviceMapping::y_up_model([0.0; 3]),
        tool_kind: ToolKind::Sphere,
        blade_length_m: 0.012,
        ..HapticsConfig::default()
    };
    let got = commands_sent("rows", &mut device, &cfg, 1200);
    assert!(!got.is_empty());
    for c in &got {
        let past_switch = c.position[2] >= 0.01;
        let want = if past_switch { ToolKind::Scalpel } else { ToolKind::Sphere };
        assert_eq!(c.kind(), Ok(want), "command at model z {} m", c.position[2]);
        assert_eq!(c.blade_length_m, 0.012);
    }
    assert!(got.iter().any(|c| c.kind() == Ok(ToolKind::Sphere)), "sphere commands before the switch");
    assert_eq!(got.last().unwrap().kind(), Ok(ToolKind::Scalpel), "the scalpel after it");
}

#[test]
fn device_loop_sends_the_configured_kind_for_any_device_works() {
    let cfg = HapticsConfig {
        rate_hz: 1000,
        mapping: DeviceMapping::y_up_model([0.0, 0.062, 0.12]),
        tool_kind: ToolKind::Scalpel,
        blade_length_m: 0.01,
        ..HapticsConfig::default()
    };
    let got = commands_sent("null", &mut NullDevice::default(), &cfg, 300);
    assert!(!got.is_empty());
    assert!(got.iter().all(|c| c.kind() == Ok(ToolKind::Scalpel) && c.blade_length_m == 0.01), "{:?}", got[0]);
    assert!(got.iter().all(|c| c.position == [0.0, 0.062, 0.12]), "the null device holds the workspace centre");
}

fn haptics(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lamina-haptics"))
        .args(["--prefix", &format!("t_scalpel_cli_{}", std::process::id()), "--origin", "0,0.062,0.12"])
        .args(["--seconds", "0.2", "--fifo", "0", "--quiet"])
        .args(args)
        .output()
        .expect("running lamina-haptics");
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn haptics_blade_length_out_of_bounds_is_refused_fails() {
    for (mm, shown) in [("0", "0"), ("0.5", "0.5"), ("50.5", "50.5"), ("-10", "-10"), ("NaN", "NaN")] {
        let (ok, err) = haptics(&["--tool", "scalpel", "--blade-length-mm", mm]);
        assert!(!ok, "--blade-length-mm {mm} was accepted");
        let want = format!("--blade-length-mm {shown}: must be a blade length from 1 to 50 mm");
        assert!(err.contains(&want), "--blade-length-mm {mm}: '{err}' should say '{want}'");
    }
}

#[test]
fn haptics_unknown_tool_or_two_sources_of_the_tool_are_refused_fails() {
    let (ok, err) = haptics(&["--tool", "knife"]);
    assert!(!ok && err.contains("'knife': expected sphere or scalpel"), "{err}");
    let dir = std::env::temp_dir().join(format!("t_scalpel_two_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("cut.csv");
    std::fs::write(&file, "t_s,x_m,y_m,z_m,kind\n0,0,0,0,scalpel\n").unwrap();
    let device = format!("scripted:{}", file.display());
    let (ok, err) = haptics(&["--tool", "sphere", "--device", &device]);
    assert!(!ok, "--tool with a trajectory that names its tool was accepted");
    assert!(err.contains("--tool sphere: haptic device") && err.contains("drop --tool or the column"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}
