//! `lamina run --record DIR` on the default scene with its tool pressing into the skin, read
//! back by an independent VTK reader (Python `meshio`, tests/python/read_recording.py).
//!
//! Without python3 and meshio the meshio test prints SKIP and passes, unless the environment
//! variable `LAMINA_REQUIRE_MESHIO` is set (CI sets it), then it fails.

use lamina_core::model::CellKind;
use lamina_core::scene::{DEFAULT_SCENE_TOML, Scene};
use lamina_tests::{unique_prefix, wait_with_watchdog, workspace_bin};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::Duration;

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(unique_prefix(tag));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The default scene with its haptics tool replaced by a scripted one: the same sphere
/// (12 mm, 300 N/m) starting 2 mm above the top of the skin at mid-length and moving down
/// at 30 mm/s, so it touches at 0.067 s and is 7 mm deep at 0.3 s.
fn pressing_scene(dir: &Path) -> PathBuf {
    let start = DEFAULT_SCENE_TOML.find("[effects.tool]").expect("the default scene has a tool");
    let end = DEFAULT_SCENE_TOML.find("[realtime]").expect("the default scene has [realtime]");
    let text = format!(
        "{}[effects.tool]\nsource = \"scripted\"\nradius = 0.012\nstiffness = 300.0\nstart = [0.0, 0.064, 0.12]\nvelocity = [0.0, -0.03, 0.0]\n\n{}",
        &DEFAULT_SCENE_TOML[..start],
        &DEFAULT_SCENE_TOML[end..]
    );
    let path = dir.join("pressing.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn lamina_run(args: &[&str], extra: &[&Path]) -> Output {
    let mut cmd = Command::new(workspace_bin("lamina"));
    cmd.arg("run").args(args);
    for p in extra {
        cmd.arg(p);
    }
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("starting lamina run");
    let status = wait_with_watchdog(&mut child, Duration::from_secs(120), "lamina run --record");
    let mut out = child.wait_with_output().expect("lamina run output");
    out.status = status;
    out
}

/// Whether `python3 -c "import meshio"` works; if not, SKIP (or fail when required).
fn meshio_available(test: &str) -> bool {
    let ok = Command::new("python3").args(["-c", "import meshio, numpy"]).output().is_ok_and(|o| o.status.success());
    if !ok {
        let required = std::env::var_os("LAMINA_REQUIRE_MESHIO").is_some();
        assert!(!required, "{test}: LAMINA_REQUIRE_MESHIO is set but `python3 -c \"import meshio, numpy\"` fails");
        println!(
            "SKIP {test}: python3 with meshio not found (pip install meshio); set LAMINA_REQUIRE_MESHIO to fail instead"
        );
    }
    ok
}

#[test]
fn record_default_scene_press_reads_in_meshio_works() {
    if !meshio_available("record_default_scene_press_reads_in_meshio_works") {
        return;
    }
    let dir = scratch("record");
    let scene = pressing_scene(&dir);
    let rec = dir.join("rec");
    let out =
        lamina_run(&["--quiet", "--no-publish", "--seconds", "0.3", "--scene"], &[&scene, Path::new("--record"), &rec]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "lamina run failed:\n{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("recording to ") && stdout.contains("every 20 ticks"), "{stdout}");
    let summary = stdout.lines().find(|l| l.starts_with("recorded ")).unwrap_or_else(|| panic!("{stdout}"));
    let dropped: u64 = summary.split(" dropped").next().and_then(|s| s.rsplit(' ').next()).unwrap().parse().unwrap();

    // What the model says, from the library.
    let model = Scene::load(&scene).unwrap().build_model().unwrap();
    let by_kind = |k: CellKind| model.cells.iter().filter(|c| c.kind == k).count() as u64;
    let (tetra, wedge) = (by_kind(CellKind::Tetra), by_kind(CellKind::Wedge));
    assert!(tetra > 0 && wedge > 0);
    let mut node_layers: Vec<u16> = model.nodes.layer.clone();
    node_layers.sort_unstable();
    node_layers.dedup();

    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/read_recording.py");
    // The outer-skin node under the tool's path: top of the skin (y = 50 mm) at mid-length.
    let skin: Vec<u32> = model.surfaces[0].triangles.iter().flatten().copied().collect();
    let distance = |n: u32| {
        let p = model.nodes.position[n as usize];
        p[0].powi(2) + (p[1] - 0.05).powi(2) + (p[2] - 0.12).powi(2)
    };
    let probe = skin.iter().copied().min_by(|&a, &b| distance(a).total_cmp(&distance(b))).unwrap();
    assert!(distance(probe).sqrt() < 1e-3, "a grid node lies under the tool");
    let read = Command::new("python3")
        .arg(&script)
        .arg(rec.join("run.pvd"))
        .arg(probe.to_string())
        .output()
        .expect("python3 runs");
    assert!(read.status.success(), "read_recording.py failed:\n{}", String::from_utf8_lossy(&read.stderr));
    let frames: Vec<Value> =
        String::from_utf8_lossy(&read.stdout).lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    // 0.3 s of wall time plus 10 warm-up ticks: 16 frames at 20 ticks each when every tick
    // runs, fewer when a loaded machine skips ticks.
    assert!(frames.len() >= 8, "{} frames", frames.len());
    assert!(summary.starts_with(&format!("recorded {} frames", frames.len())), "{summary}");
    let f = |k: usize, key: &str| frames[k][key].as_f64().unwrap();
    let tick = 1e-3;
    for (k, frame) in frames.iter().enumerate() {
        assert_eq!(frame["points"], model.nodes.len() as u64, "frame {k}");
        assert_eq!(frame["cells"]["tetra"], tetra, "frame {k}");
        assert_eq!(frame["cells"]["wedge"], wedge, "frame {k}");
        assert_eq!(frame["cells"].as_object().unwrap().len(), 2, "frame {k}: only tetra and wedge cells");
        for key in ["points_finite", "velocity_finite", "strain_finite"] {
            assert_eq!(frame[key], true, "frame {k}: {key}");
        }
        assert_eq!(frame["cell_layers"], serde_json::json!([0, 1, 2]), "frame {k}: skin, fat, muscle cells");
        assert_eq!(frame["point_layers"], serde_json::json!(node_layers), "frame {k}");
        if k > 0 {
            // 20 ticks of 1 ms between frames (a multiple of it where a frame was dropped).
            let steps = (f(k, "time") - f(k - 1, "time")) / (20.0 * tick);
            assert!(steps >= 0.999 && (steps - steps.round()).abs() < 1e-6, "frame {k}: {steps} intervals");
            if dropped == 0 {
                assert!((steps - 1.0).abs() < 1e-6, "frame {k}: {steps} intervals with no frame dropped");
            }
        }
    }
    // The frame at rest: time 0, nothing displaced (f32 rounding of the rest positions),
    // nothing strained, every cell of positive volume in VTK's corner order.
    assert_eq!(f(0, "time"), 0.0);
    assert!(f(0, "max_displacement") < 1e-6, "{}", frames[0]);
    assert!(f(0, "max_abs_strain") < 1e-5, "{}", frames[0]);
    assert!(f(0, "min_volume") > 0.0, "{}", frames[0]);
    // The press: the tool touches at 0.067 s and moves down 0.6 mm per frame. From 0.1 s on
    // the skin under it moves down frame after frame, more than 2 mm by the last frame (7 mm
    // of travel into the skin at 0.3 s), and so does the deepest displacement anywhere.
    let last = frames.len() - 1;
    let down = |k: usize| -frames[k]["probe"][1].as_f64().unwrap();
    assert!(down(0).abs() < 1e-6, "{}", frames[0]);
    let pressing = frames.iter().position(|fr| fr["time"].as_f64().unwrap() >= 0.1).unwrap();
    for (k, frame) in frames.iter().enumerate().skip(pressing + 1) {
        assert!(down(k) > down(k - 1), "frame {k}: the skin under the tool moves down: {frame}");
    }
    assert!(down(last) > 0.002, "{}", frames[last]);
    assert!(f(last, "max_displacement") >= down(last) && f(last, "max_displacement") > f(pressing, "max_displacement"));
    assert!(f(last, "max_speed") > 0.0 && f(last, "max_abs_strain") > 0.0);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn record_into_folder_with_earlier_frames_is_refused_fails() {
    let dir = scratch("record_stale");
    let rec = dir.join("rec");
    std::fs::create_dir_all(&rec).unwrap();
    std::fs::write(rec.join("frame_000000.vtu"), "old").unwrap();
    let out = lamina_run(&["--quiet", "--no-publish", "--seconds", "0.05", "--record"], &[&rec]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("already holds 1 frame file(s) of an earlier recording"), "{stderr}");
    let out = lamina_run(
        &["--quiet", "--no-publish", "--seconds", "0.05", "--record-every", "0", "--record"],
        &[&dir.join("new")],
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("--record-every 0: must be at least 1 tick"));
    std::fs::remove_dir_all(&dir).unwrap();
}
