//! The reports carry their context (docs/reports.md): `lamina run --report` and
//! `lamina-haptics --report` are read back and every context field is compared with an
//! independent source: `sha256sum` for the scene's hash, the physics library for the model's
//! size, `uname` for the host, `git rev-parse HEAD` for the revision, `date` for the start
//! time. The haptics report's `loop.send` holds one measured send per tool command.

use lamina_core::scene::Scene;
use lamina_tests::{read_json, unique_prefix, wait_with_watchdog, workspace_bin};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

/// One scenario at a time: each loads both CPUs of a small machine.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(unique_prefix(tag));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Standard output of a command, trimmed; `None` when it fails.
fn stdout_of(program: &str, args: &[&str], dir: &Path) -> Option<String> {
    let out = Command::new(program).args(args).current_dir(dir).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

fn sha256sum(path: &Path) -> String {
    let out = stdout_of("sha256sum", &[path.to_str().unwrap()], &root()).expect("sha256sum (coreutils) runs");
    out.split_whitespace().next().unwrap().to_string()
}

/// Every CPU's steal so far, in clock ticks: the 8th number of each `cpuN` line of `/proc/stat`
/// (proc(5)), read here without the product's reader.
fn steal_ticks() -> Vec<(String, u64)> {
    let text = std::fs::read_to_string("/proc/stat").expect("Linux has /proc/stat");
    text.lines()
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            let cpu = f.first()?.strip_prefix("cpu").filter(|n| !n.is_empty())?;
            Some((cpu.to_string(), f.get(8)?.parse().ok()?))
        })
        .collect()
}

fn utc_now() -> String {
    stdout_of("date", &["-u", "+%Y-%m-%dT%H:%M:%SZ"], &root()).expect("date runs")
}

/// The fields both reports share: build, host, start time.
fn check_build_and_host(report: &Value, started_after: &str, finished_before: &str, what: &str) {
    assert_eq!(report["lamina"]["version"], env!("CARGO_PKG_VERSION"), "{what}");
    let head = stdout_of("git", &["rev-parse", "HEAD"], &root()).unwrap_or_else(|| "unknown".into());
    assert_eq!(report["lamina"]["git_revision"], head.as_str(), "{what}: the binaries are built from HEAD");
    let started = report["started_utc"].as_str().unwrap_or_else(|| panic!("{what}: started_utc"));
    assert_eq!(started.len(), 20, "{what}: RFC 3339 UTC with whole seconds: {started}");
    assert!(started.ends_with('Z') && &started[10..11] == "T", "{what}: {started}");
    // Same format, so the text orders as the time does.
    assert!(
        started_after <= started && started <= finished_before,
        "{what}: {started_after} <= {started} <= {finished_before}"
    );
    let host = &report["host"];
    assert_eq!(host["name"], stdout_of("uname", &["-n"], &root()).unwrap().as_str(), "{what}");
    assert_eq!(host["kernel"], stdout_of("uname", &["-srv"], &root()).unwrap().as_str(), "{what}");
    assert!(host["cpu_model"].as_str().is_some_and(|m| !m.is_empty()), "{what}: {host}");
    assert!(host["logical_cpus"].as_u64().is_some_and(|n| n >= 1), "{what}: {host}");
}

#[test]
fn core_and_haptics_reports_carry_their_context_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("reports");
    let prefix = unique_prefix("reports");
    let scene_file = root().join("config/scenes/default.toml");
    let scene = Scene::load(&scene_file).unwrap();
    let model = scene.build_model().unwrap();
    let (core_json, haptics_json) = (dir.join("core_report.json"), dir.join("haptics_report.json"));
    let before = utc_now();
    let steal_before = steal_ticks();
    let mut core = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "4", "--scene"])
        .arg(&scene_file)
        .arg("--report")
        .arg(&core_json)
        .stdout(Stdio::null())
        .spawn()
        .expect("starting lamina run");
    // The haptics process joins once the core is up (its topology reaches late joiners
    // within a second).
    std::thread::sleep(Duration::from_millis(500));
    let mut haptics = Command::new(workspace_bin("lamina-haptics"))
        .args(["--prefix", &prefix, "--device", "null", "--origin", "0,0.1,0.12", "--seconds", "2.5", "--quiet"])
        .args(["--cpu", "0", "--scene"])
        .arg(&scene_file)
        .arg("--report")
        .arg(&haptics_json)
        .stdout(Stdio::null())
        .spawn()
        .expect("starting lamina-haptics");
    assert!(wait_with_watchdog(&mut haptics, Duration::from_secs(60), "lamina-haptics").success());
    assert!(wait_with_watchdog(&mut core, Duration::from_secs(60), "lamina run").success());
    let after = utc_now();
    let steal_after = steal_ticks();
    let sha = sha256sum(&scene_file);

    let c = read_json(&core_json);
    check_build_and_host(&c, &before, &after, "core report");
    assert_eq!(c["scene"]["name"], scene.name.as_str());
    assert_eq!(c["scene"]["file"], scene_file.display().to_string().as_str());
    assert_eq!(c["scene"]["sha256"], sha.as_str(), "the core report's hash is the file's");
    assert_eq!(c["model"]["nodes"].as_u64(), Some(model.nodes.len() as u64));
    assert_eq!(c["model"]["springs"].as_u64(), Some(model.springs.len() as u64));
    assert_eq!(c["model"]["layers"].as_u64(), Some(model.layers.len() as u64));
    assert_eq!(c["rate_hz"].as_u64(), Some(u64::from(scene.rate_hz)));
    assert_eq!(c["solver"]["integrator"], scene.solver.integrator.name());
    assert_eq!(c["solver"]["precision"], "f32");
    assert_eq!(c["solver"]["threads"].as_u64(), Some(scene.solver.threads as u64));
    assert_eq!(c["solver"]["substeps_setting"], "auto");
    assert!(c["solver"]["substeps"].as_u64().is_some_and(|n| n >= 1), "{}", c["solver"]);
    assert!(c["solver"]["simd"].as_str().is_some_and(|s| !s.is_empty()));
    assert_eq!(c["prefix"], prefix.as_str());
    // Published, the node frames are counted: a frame every tick by default, each written or shed.
    let frames = &c["node_frames"];
    let count = |key: &str| frames[key].as_u64().unwrap_or_else(|| panic!("node_frames.{key}: {frames}"));
    assert_eq!(count("published") + count("shed"), c["ticks"].as_u64().unwrap(), "{frames}");
    assert!(count("deferred") == 0, "every tick's frame is due on it: none can be written later: {frames}");
    // Host steal: each CPU's figure lies within what /proc/stat moved by around the whole run.
    let tick_ms = 1000 / stdout_of("getconf", &["CLK_TCK"], &root()).unwrap().parse::<u64>().unwrap();
    let steal = &c["host_steal"]["per_cpu_ms"];
    assert_eq!(steal.as_object().map(|o| o.len()), Some(steal_after.len()), "{steal}");
    for ((cpu, then), (_, now)) in steal_before.iter().zip(&steal_after) {
        let reported = steal[cpu.as_str()].as_u64().unwrap_or_else(|| panic!("no steal for CPU {cpu}: {steal}"));
        assert!(reported <= (now - then) * tick_ms, "CPU {cpu}: {reported} ms, /proc/stat moved {} ticks", now - then);
    }
    let loop_cpu = c["host_steal"]["loop_cpu"].as_u64().expect("the loop is pinned").to_string();
    assert!(steal.get(&loop_cpu).is_some(), "{}", c["host_steal"]);
    // Publishing: every tick's send is measured.
    let ticks = c["ticks"].as_u64().unwrap();
    assert!(ticks > 1000, "{ticks}");
    assert_eq!(c["send"]["count"].as_u64(), Some(ticks));
    assert!(c["send"]["p50_ns"].as_u64().unwrap() > 0, "{}", c["send"]);

    let h = read_json(&haptics_json);
    check_build_and_host(&h, &before, &after, "haptics report");
    assert_eq!(h["scene"]["name"], scene.name.as_str());
    assert_eq!(h["scene"]["sha256"], sha.as_str(), "the haptics report's hash is the file's");
    assert_eq!(h["model"]["nodes"].as_u64(), Some(model.nodes.len() as u64), "the node count the core published");
    let triangles: usize = model.surfaces.iter().map(|s| s.triangles.len()).sum();
    assert_eq!(h["model"]["surface_triangles"].as_u64(), Some(triangles as u64));
    assert_eq!(h["prefix"], prefix.as_str());
    assert_eq!(h["device"], "null");
    assert_eq!(h["rate_hz"].as_u64(), Some(4000));
    let send = &h["loop"]["send"];
    assert_eq!(send["count"], h["loop"]["ticks"], "one send per tick");
    assert_eq!(h["commands_sent"], h["loop"]["ticks"], "the null device gives a pose every tick: {h}");
    assert!(send["p50_ns"].as_u64().unwrap() > 0 && send["max_ns"].as_u64() >= send["p50_ns"].as_u64(), "{send}");
    assert!(h["loop"].get("caught_up_ticks").is_none(), "the device loop never catches up");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn built_in_scene_is_hashed_as_its_text_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("reports_builtin");
    let report = dir.join("core_report.json");
    let before = utc_now();
    let out = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--no-publish", "--seconds", "0.3", "--report"])
        .arg(&report)
        .stdout(Stdio::null())
        .spawn()
        .expect("starting lamina run");
    let mut out = out;
    assert!(wait_with_watchdog(&mut out, Duration::from_secs(60), "lamina run").success());
    let c = read_json(&report);
    check_build_and_host(&c, &before, &utc_now(), "core report");
    // The built-in default is config/scenes/default.toml's text.
    assert_eq!(c["scene"]["sha256"], sha256sum(&root().join("config/scenes/default.toml")).as_str());
    assert!(c["scene"]["file"].is_null(), "{}", c["scene"]);
    assert_eq!(c["scene"]["name"], Scene::builtin_default().name.as_str());
    assert!(c["prefix"].is_null());
    // Nothing is published, so nothing is sent; no multirate stepping.
    assert_eq!(c["send"]["max_ns"].as_u64(), Some(0), "{}", c["send"]);
    assert!(c["multirate"].is_null(), "{}", c["multirate"]);
    assert!(c["node_frames"].is_null(), "{}", c["node_frames"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The default scene with multirate stepping (a 5 cm region, ratio 8): the report's
/// `multirate` counts the bulk's steps against the ticks run, sizes the region against the
/// model, and its coupling gap is the healthy coupling's (the limb pulled by its handle: the
/// halves agree to hundredths of a millimetre; a failing coupling shows millimetres).
#[test]
fn multirate_run_reports_its_coupling_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("reports_multirate");
    let (scene_file, report) = (dir.join("multirate.toml"), dir.join("core_report.json"));
    let text = std::fs::read_to_string(root().join("config/scenes/default.toml")).unwrap();
    std::fs::write(&scene_file, format!("{text}\n[solver.multirate]\nradius = 0.05\nratio = 8\n")).unwrap();
    let model = Scene::load(&scene_file).unwrap().build_model().unwrap();
    let mut run = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--no-publish", "--seconds", "1", "--scene"])
        .arg(&scene_file)
        .arg("--report")
        .arg(&report)
        .stdout(Stdio::null())
        .spawn()
        .expect("starting lamina run");
    assert!(wait_with_watchdog(&mut run, Duration::from_secs(60), "lamina run").success());
    let c = read_json(&report);
    let m = &c["multirate"];
    let count = |key: &str| m[key].as_u64().unwrap_or_else(|| panic!("multirate.{key}: {m}"));
    assert_eq!(count("ratio"), 8, "{m}");
    let free = model.nodes.kind.iter().filter(|k| **k == lamina_core::model::NodeKind::Free).count() as u64;
    assert_eq!(count("region_nodes") + count("bulk_nodes"), free, "{m}");
    assert!(count("region_nodes") > 0 && count("bulk_nodes") > count("region_nodes"), "{m}");
    // The scene's 5 cm: its 12 mm tool needs no wider region.
    assert_eq!(m["region_radius_m"].as_f64(), Some(0.05), "{m}");
    // One bulk step per 8 ticks, counting the untimed warm-up frames and any skipped tick,
    // and the ticks the loop went on past a bulk step late in real time.
    let ticks = c["ticks"].as_u64().unwrap();
    let counted = count("bulk_steps") * 8 + count("held_ticks");
    assert!(
        counted >= ticks,
        "{} bulk steps and {} held ticks for {ticks} ticks",
        count("bulk_steps"),
        count("held_ticks")
    );
    assert!(count("held_max_ticks") <= count("held_ticks"), "{m}");
    let gap = m["coupling_gap_max_m"].as_f64().unwrap();
    assert!(gap > 0.0 && gap < 1e-4, "{m}");
    assert!(!m["bulk_stopped"].as_bool().unwrap(), "{m}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The stability suite's hardest case for the multirate coupling as a scene: a 10 x 6 cm block
/// whose skin is 10^4 times stiffer than its fat in its stiff phase, pulled up at the centre
/// of its top by a handle, a 5 cm region about it.
fn stiff_skin_block(ratio: u32) -> String {
    format!(
        r#"name = "stiff-skin-block"
rate_hz = 1000
precision = "f32"

[model]
kind = "layered_block"
nx = 10
nz = 6
spacing = 0.01
muscle_rows = 2
fat_rows = 2
skin_rows = 1
density = 1000.0
skin = {{ law = "bilinear", k1 = 30000.0, k2 = 300000.0, turn_strain = 1e-6, damping = 0.02 }}
fat = {{ law = "linear", k = 30.0, damping = 0.01 }}
muscle = {{ law = "bilinear", k1 = 150.0, k2 = 1500.0, turn_strain = 0.4, damping = 0.02 }}

[solver]
integrator = "implicit_factored"
threads = 2

[solver.multirate]
centre = [0.05, 0.05, 0.03]
radius = 0.05
ratio = {ratio}

[effects]
gravity = [0.0, -9.81, 0.0]
viscous_damping = 2.0
spring_damping = true
bone = true
guard = true

[[effects.handles]]
node = 335
target = [0.05, 0.06, 0.03]
stiffness = 50.0
damping = 0.0
"#
    )
}

/// The stiff skin's coupling holds through `lamina run` at ratio 8 and 2: the two halves stay
/// within a millimetre where both step (measured 0.08 and 0.06 mm) and no warning is printed
/// (a bulk that stepped the region's core too swung centimetres here at ratio 8).
#[test]
fn stiff_skin_multirate_coupling_holds_in_lamina_run_works() {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("reports_coupling");
    for ratio in [8, 2] {
        let (scene_file, report) = (dir.join(format!("block_{ratio}.toml")), dir.join(format!("report_{ratio}.json")));
        std::fs::write(&scene_file, stiff_skin_block(ratio)).unwrap();
        let out = Command::new(workspace_bin("lamina"))
            .args(["run", "--no-publish", "--seconds", "2", "--scene"])
            .arg(&scene_file)
            .arg("--report")
            .arg(&report)
            .output()
            .expect("running lamina run");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let stdout = String::from_utf8_lossy(&out.stdout);
        let warned = stdout.contains("warning: the multirate region and bulk drew up to");
        let gap = read_json(&report)["multirate"]["coupling_gap_max_m"].as_f64().expect("a multirate report");
        assert!(!warned && gap < 1e-3, "ratio {ratio}: gap {gap} m, output:\n{stdout}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
