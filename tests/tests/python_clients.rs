//! Python clients on the official `iceoryx2` package (examples/python/) against a live
//! `lamina run`: the subscriber reads the topology and node frames as numpy arrays, the
//! haptic driver presses the default scene's skin step by step and reads the contact force.
//! Both print JSON that is checked here against the model (node count, rest bounding box) and
//! against the same press computed offline with the physics library. `lamina.Core` (the package in
//! python/) reads the topology and frames as numpy arrays, presses 8 mm and gets the force
//! docs/haptics.md reports, and raises the errors it documents. A client that created a
//! service first with the binding's default settings makes `lamina run` stop with an error
//! naming the setting, the value found and the value Lamina needs.
//!
//! Needs `python3` with `pip install -r examples/python/requirements.txt` (the clients import
//! this checkout's `python/lamina` through `PYTHONPATH`); without them the
//! tests print SKIP, unless `LAMINA_REQUIRE_PYTHON_CLIENTS` is set (CI sets it), then they fail.

use lamina_bridge::{Bridge, BridgeConfig};
use lamina_core::hand_tool::HandTool;
use lamina_core::scene::Scene;
use lamina_tests::{python_package_dir, unique_prefix, wait_with_watchdog, workspace_bin};
use serde_json::Value;
use std::io::Read;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// One scenario at a time: each loads both CPUs of a small machine.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Set to fail instead of skipping when Python or its packages are missing.
const REQUIRE_ENV: &str = "LAMINA_REQUIRE_PYTHON_CLIENTS";

fn examples_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../examples/python")
}

/// Whether `python3` can import the clients' packages; if not, SKIP (or fail when required).
fn python_ready(test: &str) -> bool {
    let probe = Command::new("python3").args(["-c", "import iceoryx2, numpy"]).output();
    let ok = probe.as_ref().is_ok_and(|o| o.status.success());
    if !ok {
        let why = match &probe {
            Err(e) => format!("python3 not found ({e})"),
            Ok(o) => {
                let err = String::from_utf8_lossy(&o.stderr);
                let last = err.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").trim().to_string();
                format!("python3 cannot import iceoryx2 and numpy ({last})")
            }
        };
        assert!(std::env::var_os(REQUIRE_ENV).is_none(), "{test}: {REQUIRE_ENV} is set but {why}");
        eprintln!(
            "SKIP {test}: {why}; pip install -r examples/python/requirements.txt, or set {REQUIRE_ENV} to fail instead"
        );
    }
    ok
}

fn python(script: &str, args: &[&str]) -> Command {
    let mut cmd = Command::new("python3");
    cmd.env("PYTHONPATH", python_package_dir())
        .arg(examples_dir().join(script))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    cmd
}

/// Waits for `child` (watchdog `limit`) and returns its status, stdout and stderr.
fn finish(mut child: Child, limit: Duration, what: &str) -> (std::process::ExitStatus, String, String) {
    // Read the pipes while waiting, so a chatty child never blocks on a full pipe.
    let mut stdout = child.stdout.take().expect("piped stdout");
    let mut stderr = child.stderr.take().expect("piped stderr");
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let err = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let status = wait_with_watchdog(&mut child, limit, what);
    (status, out.join().unwrap_or_default(), err.join().unwrap_or_default())
}

/// The last line of a script's output, parsed as JSON.
fn json_of(out: &str, what: &str) -> Value {
    let line = out.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or_else(|| panic!("{what} printed nothing"));
    serde_json::from_str(line).unwrap_or_else(|e| panic!("{what}: not JSON ({e}): {line}"))
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array().unwrap_or_else(|| panic!("not an array: {v}")).iter().map(|x| x.as_f64().unwrap()).collect()
}

/// The node count `lamina run` prints: "scene 'NAME' (SOURCE): N nodes, ...".
/// The built-in scene's tool: radius (m) and device origin (m), read from the scene.
fn model_tool() -> (f64, [f64; 3]) {
    let tool = Scene::builtin_default().tool.expect("the default scene has a tool");
    match tool.source {
        lamina_core::scene::ToolSource::Haptics { device_origin, .. } => (tool.radius, device_origin),
        lamina_core::scene::ToolSource::Scripted { .. } => {
            panic!("the default scene's tool follows the haptics process")
        }
    }
}

fn printed_node_count(core_out: &str) -> u64 {
    let line = core_out.lines().find(|l| l.starts_with("scene '")).unwrap_or_else(|| panic!("{core_out}"));
    let words: Vec<&str> = line.split_whitespace().collect();
    let i = words.iter().position(|w| w.trim_end_matches(',') == "nodes").unwrap_or_else(|| panic!("{line}"));
    words[i - 1].parse().unwrap_or_else(|_| panic!("{line}"))
}

fn start_core(prefix: &str) -> Child {
    // --seconds caps the run; the test stops it with SIGTERM once the clients are done.
    Command::new(workspace_bin("lamina"))
        .args(["run", "--prefix", prefix, "--seconds", "300"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting lamina run")
}

fn stop(core: Child) -> (std::process::ExitStatus, String, String) {
    // SAFETY: kill(2) on our own child's pid.
    unsafe { libc::kill(core.id() as libc::pid_t, libc::SIGTERM) };
    finish(core, Duration::from_secs(120), "lamina run")
}

/// Waits until `<prefix>/nodes` exists in the user's domain (a client created it).
fn wait_for_service(prefix: &str, limit: Duration) {
    use iceoryx2::prelude::MessagingPattern;
    use iceoryx2::service::Service as _;
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&format!("{prefix}_probe"))).unwrap();
    let name = lamina_bridge::ServiceNames::new(prefix).unwrap().nodes;
    let start = Instant::now();
    loop {
        let exists = iceoryx2::prelude::ipc::Service::does_exist(
            &name,
            bridge.node().config(),
            MessagingPattern::PublishSubscribe,
        )
        .unwrap_or(false);
        if exists {
            return;
        }
        assert!(start.elapsed() < limit, "no client created '{prefix}/nodes' within {limit:?}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// The driver's press computed offline: the default scene settled for 3 s with the tool
/// parked (as the core runs before the driver speaks), then 0.3 s 2 cm above the touch point
/// and each depth held for `hold_s`, exactly as the driver commands it. Returns the force on
/// the tool averaged over the second half of the last hold, N.
fn offline_last_step_force(touch: [f64; 3], radius: f64, depths: &[f64], hold_s: f64) -> [f64; 3] {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let (mut sim, mut tool) =
        HandTool::simulation::<f32>(&model, scene.solver.clone(), scene.effects.clone(), scene.tool.unwrap()).unwrap();
    let rate = scene.rate_hz as f64;
    for _ in 0..3 * scene.rate_hz {
        sim.step();
    }
    let mut run = |centre: [f64; 3], seconds: f64| -> [f64; 3] {
        let ticks = (seconds * rate).round() as usize;
        let mut sum = [0.0; 3];
        let mut kept = 0.0;
        for k in 0..ticks {
            tool.move_to(&mut sim, centre, Some(radius));
            sim.step();
            if k >= ticks / 2 {
                let f = tool.feedback(&sim).force;
                (0..3).for_each(|c| sum[c] += f[c]);
                kept += 1.0;
            }
        }
        sum.map(|s| s / kept)
    };
    run([touch[0], touch[1] + radius + 0.02, touch[2]], 0.3);
    let mut last = [0.0; 3];
    for d in depths {
        last = run([touch[0], touch[1] + radius - d, touch[2]], hold_s);
    }
    last
}

#[test]
fn python_subscriber_and_haptic_driver_against_lamina_run_works() {
    let test = "python_subscriber_and_haptic_driver_against_lamina_run_works";
    if !python_ready(test) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("py");

    // The subscriber starts first: it creates the services with Lamina's settings, and the
    // core opens them.
    let subscriber = python("subscriber.py", &["--prefix", &prefix, "--frames", "2000", "--timeout", "60", "--json"])
        .spawn()
        .expect("starting python3 subscriber.py");
    wait_for_service(&prefix, Duration::from_secs(60));
    let core = start_core(&prefix);
    let (status, sub_out, sub_err) = finish(subscriber, Duration::from_secs(180), "subscriber.py");
    if !status.success() {
        let (_, core_out, core_err) = stop(core);
        panic!("subscriber.py failed: {status}\n{sub_out}\n{sub_err}\ncore:\n{core_out}\n{core_err}");
    }
    let hold_s = 0.4;
    let driver = python("haptic_driver.py", &["--prefix", &prefix, "--hold", &hold_s.to_string(), "--json"])
        .spawn()
        .expect("starting python3 haptic_driver.py");
    let (status, drv_out, drv_err) = finish(driver, Duration::from_secs(180), "haptic_driver.py");
    let (core_status, core_out, core_err) = stop(core);
    assert!(status.success(), "haptic_driver.py failed: {status}\n{drv_out}\n{drv_err}\ncore:\n{core_out}");
    assert!(core_status.success(), "lamina run failed: {core_status}\n{core_out}\n{core_err}");

    // --- subscriber: what it read against the model ---
    let sub = json_of(&sub_out, "subscriber.py");
    eprintln!("subscriber.py: {sub}");
    let model = Scene::builtin_default().build_model().unwrap();
    let n = model.nodes.position.len() as u64;
    assert_eq!(printed_node_count(&core_out), n, "the core runs the default scene");
    assert_eq!(sub["topology"]["node_count"].as_u64(), Some(n), "{sub}");
    assert_eq!(sub["node_counts"], serde_json::json!([n]), "every frame carries every node: {sub}");
    assert_eq!(sub["positions_shape"], serde_json::json!([n, 3]), "{sub}");
    assert_eq!(sub["positions_dtype"], "float32");
    // The binding's slice length is in bytes; the client's element count (the workaround)
    // must be the node count.
    assert_eq!(sub["payload_len_elements"].as_u64(), Some(n), "{sub}");
    let triangles: u64 = model.surfaces.iter().map(|s| s.triangles.len() as u64).sum();
    assert_eq!(sub["topology"]["triangle_count"].as_u64(), Some(triangles), "{sub}");
    assert!(sub["topology"]["triangle_index_max"].as_u64().is_some_and(|i| i < n), "{sub}");
    let layer_nodes: u64 =
        sub["topology"]["layers"].as_array().unwrap().iter().map(|l| l["node_count"].as_u64().unwrap()).sum();
    assert_eq!(layer_nodes, n, "the layers cover every node: {sub}");
    assert_eq!(sub["topology"]["layers"][0]["name"], "skin", "{sub}");
    // The whole model comes over the wire: springs, tissue boundary grids, each layer's
    // tissue (muscle too, which has springs but no nodes of its own), rest positions, the
    // scene's tool.
    let t = &sub["topology"];
    assert_eq!(t["name"], model.name.as_str(), "{sub}");
    assert_eq!(t["spring_count"].as_u64(), Some(model.springs.len() as u64), "{sub}");
    assert!(t["spring_index_max"].as_u64().is_some_and(|i| i < n), "{sub}");
    assert_eq!(t["spring_layer_tissues"], serde_json::json!(["fat", "muscle", "skin"]), "{sub}");
    let grids: Vec<(String, Value)> = t["surfaces"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["name"].as_str().unwrap().to_owned(), s["grid"].clone()))
        .collect();
    let expected_grids: Vec<(String, Value)> = model
        .surfaces
        .iter()
        .map(|s| (s.name.clone(), s.grid.as_ref().map_or(Value::Null, |(c, r, _)| serde_json::json!([c, r]))))
        .collect();
    assert_eq!(grids, expected_grids, "{sub}");
    assert_eq!(t["rest_positions_shape"], serde_json::json!([n, 3]), "{sub}");
    // No gravity and the tool parked: the first frame is the rest state up to the limb's
    // settling under its own springs (0.4 mm measured; a wrong or shuffled rest position would
    // be centimetres off).
    assert!(t["rest_to_first_frame_max_m"].as_f64().is_some_and(|d| d < 2e-3), "{sub}");
    let tool = model_tool();
    assert_eq!(t["tool_source"], "haptics", "{sub}");
    assert!((t["tool_radius_m"].as_f64().unwrap() - tool.0).abs() < 1e-12, "{sub}");
    assert_eq!(t["device_origin_m"], serde_json::json!(tool.1), "{sub}");
    assert_eq!(sub["frames"].as_u64(), Some(2000));
    assert_eq!(sub["sequence_increasing"], true, "{sub}");
    let (first, last) = (sub["sequence_first"].as_u64().unwrap(), sub["sequence_last"].as_u64().unwrap());
    assert!(last >= first + 1999, "{sub}");
    assert_eq!(sub["positions_finite"], true, "{sub}");
    // Inside the rest bounding box grown by 2 cm (the drag handle pulls 1 cm; nothing else
    // loads the limb while the subscriber reads).
    let margin = 0.02;
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in &model.nodes.position {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let (seen_lo, seen_hi) = (f64s(&sub["bbox_min_m"]), f64s(&sub["bbox_max_m"]));
    for c in 0..3 {
        assert!(seen_lo[c] >= lo[c] - margin && seen_hi[c] <= hi[c] + margin, "axis {c}: {sub}, rest {lo:?}..{hi:?}");
    }
    let stats = &sub["stats"];
    assert!(stats["ticks"].as_u64().is_some_and(|t| t > 0), "a stats summary was read: {sub}");

    // --- haptic driver: force against depth ---
    let drv = json_of(&drv_out, "haptic_driver.py");
    eprintln!("haptic_driver.py: {drv}");
    let steps = drv["steps"].as_array().unwrap();
    assert_eq!(steps.len(), 12, "-3 mm to 8 mm in 1 mm steps: {drv}");
    assert_eq!(drv["feedback_sequence_increasing"], true, "{drv}");
    let depth = |s: &Value| s["depth_m"].as_f64().unwrap();
    let up = |s: &Value| s["force_up_n"].as_f64().unwrap();
    for s in steps.iter().filter(|s| depth(s) < -1e-4) {
        assert_eq!(s["force_magnitude_n"].as_f64(), Some(0.0), "no force before contact: {s}");
        assert_eq!(s["in_contact"].as_f64(), Some(0.0), "{s}");
    }
    let pressed: Vec<&Value> = steps.iter().filter(|s| depth(s) > 1e-4).collect();
    assert_eq!(pressed.len(), 8);
    for s in &pressed {
        assert_eq!(s["in_contact"].as_f64(), Some(1.0), "in contact once pressed: {s}");
        assert!(up(s) > 0.0, "the skin pushes the tool up: {s}");
    }
    // Rising with depth: each 1 mm deeper pushes back harder, within 2 mN of noise.
    for w in pressed.windows(2) {
        assert!(up(w[1]) > up(w[0]) - 0.002, "force falls with depth: {} then {}", w[0], w[1]);
    }
    let deepest = up(pressed[pressed.len() - 1]);
    assert!(deepest > 3.0 * up(pressed[0]), "the force grows over the press: {drv}");

    // The deepest step against the same press offline (f32 model, same sub-steps, same tool
    // path): what differs is the core's timing (commands land up to a few ticks apart from
    // the offline path) and how long the tissue settled; 5 % of the force plus 5 mN.
    let touch: [f64; 3] = f64s(&drv["touch_point_m"]).try_into().unwrap();
    let depths: Vec<f64> = steps.iter().map(depth).collect();
    let offline = offline_last_step_force(touch, drv["radius_m"].as_f64().unwrap(), &depths, hold_s);
    let online: [f64; 3] = f64s(&pressed[pressed.len() - 1]["force_n"]).try_into().unwrap();
    let err = (0..3).map(|c| (online[c] - offline[c]).powi(2)).sum::<f64>().sqrt();
    let mag = offline.iter().map(|f| f * f).sum::<f64>().sqrt();
    eprintln!("deepest step: online {online:?} N, offline {offline:?} N, difference {err:.4} N");
    assert!(err <= 0.05 * mag + 0.005, "online {online:?} N vs offline {offline:?} N");
    assert!(core_out.contains(" 0 refused"), "every command the driver sent was sane: {core_out}");
}

#[test]
fn python_client_with_default_settings_first_makes_lamina_run_name_the_setting_works() {
    let test = "python_client_with_default_settings_first_makes_lamina_run_name_the_setting_works";
    if !python_ready(test) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("pyqos");
    // A client creates `nodes` with Lamina's types and the binding's default settings, then
    // holds it until its stdin closes.
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("python/create_with_defaults.py");
    let mut holder = Command::new("python3")
        .env("PYTHONPATH", python_package_dir())
        .arg(&script)
        .args(["--prefix", &prefix, "--services", "nodes"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting python3 create_with_defaults.py");
    let mut line = String::new();
    {
        use std::io::BufRead;
        let mut out = std::io::BufReader::new(holder.stdout.as_mut().unwrap());
        out.read_line(&mut line).unwrap();
    }
    let created: Value = match serde_json::from_str(line.trim()) {
        Ok(v) => v,
        Err(e) => {
            drop(holder.stdin.take());
            let (_, _, err) = finish(holder, Duration::from_secs(30), "create_with_defaults.py");
            panic!("create_with_defaults.py: not JSON ({e}): {line}\n{err}")
        }
    };
    // The binding's defaults, as the script read them back from the service it created.
    assert_eq!(created["nodes"]["subscriber_max_buffer_size"].as_u64(), Some(2), "{created}");
    assert_eq!(created["nodes"]["history_size"].as_u64(), Some(0), "{created}");

    let core = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "2"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting lamina run");
    let (status, out, err) = finish(core, Duration::from_secs(120), "lamina run");
    assert!(!status.success(), "lamina run must refuse the service: {out}\n{err}");
    eprintln!("lamina run: {}", err.trim());
    for expected in [
        format!("service '{prefix}/nodes' exists"),
        "subscriber_max_buffer_size 2 (Lamina needs at least 16)".to_string(),
        "history_size 0 (Lamina needs at least 1)".to_string(),
    ] {
        assert!(err.contains(&expected), "the error names '{expected}': {err}");
    }
    assert!(!out.contains("publishing on"), "nothing was published: {out}");

    // Once the client is gone, so is its service, and the core starts on the same prefix.
    drop(holder.stdin.take());
    let (status, _, holder_err) = finish(holder, Duration::from_secs(60), "create_with_defaults.py");
    assert!(status.success(), "create_with_defaults.py: {status}\n{holder_err}");
    let core = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting lamina run");
    let (status, out, err) = finish(core, Duration::from_secs(120), "lamina run");
    assert!(status.success(), "lamina run starts once the client is gone: {out}\n{err}");
}

/// Drives `lamina.Core` (python/lamina/client.py): prints one JSON object with what it read,
/// the force after an 8 mm press from the device origin, and the errors it raised.
const CORE_API: &str = r#"
import json, sys, time
import lamina
prefix = sys.argv[1]
out = {}
with lamina.Core(prefix, timeout_s=60) as core:
    t = core.topology
    a, b = core.newest_nodes(), core.newest_nodes()
    origin = t["tool"]["device_origin_m"]
    start = time.monotonic()
    while (s := time.monotonic() - start) < 1.5:
        core.send_sphere([origin[0], origin[1] - 0.008 * min(s, 1.0), origin[2]])
        time.sleep(0.002)
    fb = core.newest_feedback()
    out.update(node_count=t["node_count"], rest_shape=list(t["rest_positions"].shape),
               frame_shape=list(b.positions.shape), frame_dtype=str(b.positions.dtype),
               sequences=[a.sequence, b.sequence], device_origin_m=origin.tolist(),
               in_contact=fb.in_contact, force=fb.force.tolist())
    try:
        core.send_sphere([0.0, 0.1])
    except ValueError as e:
        out["bad_position"] = str(e)
try:
    lamina.Core(prefix, timeout_s=0)
except ValueError as e:
    out["bad_timeout"] = str(e)
try:
    lamina.Core(prefix + "_absent", timeout_s=0.5)
except lamina.LaminaError as e:
    out["absent"] = str(e)
print(json.dumps(out))
"#;

#[test]
fn python_package_core_reads_frames_and_presses_the_tool_works() {
    let test = "python_package_core_reads_frames_and_presses_the_tool_works";
    if !python_ready(test) {
        return;
    }
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("pycore");
    let core = start_core(&prefix);
    let client = Command::new("python3")
        .env("PYTHONPATH", python_package_dir())
        .args(["-c", CORE_API, &prefix])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting python3");
    let (status, out, err) = finish(client, Duration::from_secs(180), "lamina.Core client");
    let (_, core_out, core_err) = stop(core);
    assert!(status.success(), "lamina.Core client: {status}\n{out}\n{err}\ncore: {core_err}");
    let v = json_of(&out, "lamina.Core client");
    let nodes = printed_node_count(&core_out);
    assert_eq!(v["node_count"].as_u64(), Some(nodes), "{v}");
    let n = nodes as f64;
    assert_eq!(f64s(&v["rest_shape"]), [n, 3.0], "{v}");
    assert_eq!(f64s(&v["frame_shape"]), [n, 3.0], "{v}");
    assert_eq!(v["frame_dtype"], "float32", "{v}");
    let seq = f64s(&v["sequences"]);
    assert!(seq[1] > seq[0], "the second newest frame is newer: {v}");
    let (_, origin) = model_tool();
    for (got, want) in f64s(&v["device_origin_m"]).iter().zip(origin) {
        assert!((got - want).abs() < 1e-9, "device origin against the scene's: {v}");
    }
    // The 8 mm press of docs/haptics.md: 0.100 N up (+y) on the tool.
    assert_eq!(v["in_contact"], true, "{v}");
    let fy = f64s(&v["force"])[1];
    assert!(fy > 0.07 && fy < 0.14, "force after the 8 mm press: {v}");
    let text = |k: &str| v[k].as_str().unwrap_or_else(|| panic!("no '{k}' error raised: {v}")).to_string();
    assert!(text("bad_position").contains("position_m") && text("bad_position").contains("[0.0, 0.1]"), "{v}");
    assert!(text("bad_timeout").contains("timeout_s") && text("bad_timeout").contains("0.0"), "{v}");
    assert!(text("absent").contains(&format!("{prefix}_absent/topology")) && text("absent").contains("0.5 s"), "{v}");
}
