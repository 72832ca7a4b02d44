//! `lamina demo` headless, as a person runs it: a 5 s run plays the whole script (press,
//! hold, release, grasp, pull, let go) faster than its nominal 7.4 s, the core counts one
//! grasp, and the demo's summary gives the peak skin displacement under the tool (at least the
//! scripted 12 mm press, less the tolerance below) and a positive, finite peak force on the tool.
//! A 3 s run is too short for the grasp-and-pull: the demo says so and the core counts none.
//!
//! Tolerance of the press: the skin's nodes under the ball follow it by less than the ball
//! goes. The tool's contact acts on the skin's point shell (points sampled on the surface
//! between nodes, `effects.tool.min_radius`) through a penalty of the scene's
//! `effects.tool.stiffness` (300 N/m) per point, so the nodes, the corners of that surface, are
//! pushed through the points around them and lag the sphere's lowest point. Measured here:
//! 9.02-9.04 mm under the 12 mm press (four runs, 0.33 N pressing). The test asserts at least
//! [`PRESS_TOLERANCE_M`] less than the press (8 mm), which a tool that stopped short or a
//! skin that did not follow (a press of a few mm, the 0.8 mm gravity sag) fails, and that the
//! skin's node nearest the press axis lies under the ball (from the default scene's model).
//!
//! Runs in one test so the two demos never share the two CPUs.

use lamina_haptics::device::Trajectory;
use lamina_tests::{wait_with_watchdog, workspace_bin};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

/// The scripted press, m (`cli/src/demo_script.rs`).
const PRESS_M: f64 = 0.012;
/// The default scene's tool radius, m.
const TOOL_RADIUS_M: f64 = 0.012;
/// How far the skin's nodes under the ball may stay above its lowest point, m.
const PRESS_TOLERANCE_M: f64 = 0.004;

/// Horizontal distance from the axis of the press (through the default scene's device
/// origin) to the nearest node on top of the skin (within 2 mm of the highest), m.
fn node_offset_m() -> f64 {
    use lamina_core::scene::{Scene, ToolSource};
    let scene = Scene::builtin_default();
    let model = scene.build_model().expect("the default scene builds");
    let ToolSource::Haptics { device_origin: o, .. } = scene.tool.expect("a tool").source else {
        panic!("the default scene's tool follows haptics")
    };
    let p = &model.nodes.position;
    let top = p.iter().map(|q| q[1]).fold(f64::NEG_INFINITY, f64::max);
    p.iter()
        .filter(|q| q[1] > top - 0.002)
        .map(|q| ((q[0] - o[0]).powi(2) + (q[2] - o[2]).powi(2)).sqrt())
        .fold(f64::INFINITY, f64::min)
}

fn demo(seconds: &str, out: &Path) -> String {
    let lamina = workspace_bin("lamina");
    if !lamina.with_file_name("lamina-viewer").exists() {
        let release = lamina.parent().is_some_and(|d| d.ends_with("release"));
        let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
        cmd.args(["build", "-p", "lamina-viewer", "--bins"]);
        if release {
            cmd.arg("--release");
        }
        assert!(cmd.status().expect("cargo build").success(), "building lamina-viewer failed");
    }
    let mut child = Command::new(&lamina)
        .args(["demo", "--seconds", seconds, "--out"])
        .arg(out)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting lamina demo");
    let stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || std::io::read_to_string(stdout).unwrap_or_default());
    // A watchdog, not a speed bound.
    let status = wait_with_watchdog(&mut child, Duration::from_secs(180), "lamina demo");
    let text = reader.join().unwrap();
    let stderr = std::io::read_to_string(child.stderr.take().unwrap()).unwrap_or_default();
    assert!(status.success(), "{status}\n{text}\n{stderr}");
    text
}

/// The number just before `marker` in `text` (e.g. "3" in "3 grasp(s)").
fn number_before(text: &str, marker: &str) -> f64 {
    let at = text.find(marker).unwrap_or_else(|| panic!("no '{marker}' in:\n{text}"));
    let head = text[..at].trim_end();
    let start = head.rfind([' ', '(']).map_or(0, |i| i + 1);
    head[start..].parse().unwrap_or_else(|e| panic!("'{}' before '{marker}': {e}", &head[start..]))
}

fn out_dir(tag: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!("lamina_demo_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    out
}

#[test]
fn demo_presses_and_grasps_in_five_seconds_and_says_what_three_seconds_skip_works() {
    let out = out_dir("5s");
    let text = demo("5", &out);
    assert!(text.contains("scripted device: press 12 mm, hold, release, grasp and pull 8 mm up"), "{text}");
    // The script the haptics process replayed fits the run: its own parser reads it.
    let script = Trajectory::load(&out.join("demo_press_pull.csv")).expect("the demo's script parses");
    assert!(script.duration_s() <= 4.0 + 1e-9, "{} s", script.duration_s());
    assert!(script.points().iter().any(|p| p.buttons & 1 != 0), "the script grasps");
    assert_eq!(number_before(&text, " grasp(s)"), 1.0, "{text}");

    let line = text.lines().find(|l| l.starts_with("peak skin displacement under the tool: ")).unwrap_or_else(|| {
        panic!("no peak line in:\n{text}");
    });
    let press_mm = number_before(line, " mm down pressing");
    let pull_mm = number_before(line, " mm up pulling");
    let force = number_before(line, " N (");
    let press_force = number_before(line, " N pressing)");
    assert!(force.is_finite() && force > 0.0, "peak force {force} N\n{text}");
    assert!(press_force.is_finite() && press_force > 0.0 && press_force <= force, "{press_force} N\n{text}");
    let d = node_offset_m();
    assert!(d < 0.5 * TOOL_RADIUS_M, "a skin node lies under the tool ({d} m from its axis)");
    let least_mm = (PRESS_M - PRESS_TOLERANCE_M) * 1e3;
    eprintln!("peak press {press_mm} mm (at least {least_mm:.2} mm), pull {pull_mm} mm, force {force} N");
    assert!(press_mm >= least_mm, "peak press {press_mm} mm < {least_mm:.2} mm\n{text}");
    // Nothing pushes the skin further than the tool went (plus a millimetre for the dimple's
    // rim and the core's last sub-step).
    assert!(press_mm <= PRESS_M * 1e3 + 1.0, "peak press {press_mm} mm\n{text}");
    assert!(pull_mm > 1.0, "the grasp lifts the skin: {pull_mm} mm\n{text}");
    let _ = std::fs::remove_dir_all(&out);

    let out = out_dir("3s");
    let text = demo("3", &out);
    assert!(text.contains("--seconds 3 is too short for the grasp-and-pull"), "{text}");
    assert!(text.contains("only presses, holds and releases"), "{text}");
    assert_eq!(number_before(&text, " grasp(s)"), 0.0, "{text}");
    let _ = std::fs::remove_dir_all(&out);
}
