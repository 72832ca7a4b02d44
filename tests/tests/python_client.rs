//! docs/examples/lamina_client.py, the Python client on the `lamina` package (this checkout's
//! `python/`, on `PYTHONPATH`) and the iceoryx2 package 0.10.0 from PyPI, against a running core: it must read the topology,
//! node frames without a gap and statistics, find `sim_time_s = (tick + 11) / rate_hz`, and
//! press the tool into contact.
//!
//! Without the package the test prints SKIP and passes, unless `LAMINA_REQUIRE_PY_ICEORYX2` is
//! set (CI sets it and runs `pip install iceoryx2==0.10.0`). `LAMINA_PYTHON` names the Python
//! interpreter (default `python3`).

use lamina_core::scene::Scene;
use lamina_tests::{python_package_dir, unique_prefix, wait_with_watchdog, workspace_bin};
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

fn python() -> String {
    std::env::var("LAMINA_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Whether the interpreter has iceoryx2 0.10.0; if not, SKIP (or fail when required).
fn iceoryx2_available() -> bool {
    let check = "import importlib.metadata as m, iceoryx2; assert m.version('iceoryx2') == '0.10.0'";
    let ok = Command::new(python()).args(["-c", check]).output().is_ok_and(|o| o.status.success());
    if !ok {
        let required = std::env::var_os("LAMINA_REQUIRE_PY_ICEORYX2").is_some();
        assert!(!required, "LAMINA_REQUIRE_PY_ICEORYX2 is set but {} has no iceoryx2 0.10.0", python());
        println!("SKIP: {} has no iceoryx2 0.10.0 (pip install iceoryx2==0.10.0)", python());
    }
    ok
}

/// The number after `label` in `line` (up to the next space, comma or semicolon).
fn number_after(line: &str, label: &str) -> f64 {
    let rest = line.split_once(label).unwrap_or_else(|| panic!("'{label}' not in: {line}")).1;
    let token: String = rest.trim_start().chars().take_while(|c| !matches!(c, ' ' | ',' | ';' | ')')).collect();
    token.parse().unwrap_or_else(|_| panic!("'{label}' is not followed by a number in: {line}"))
}

#[test]
fn python_client_reads_frames_and_presses_the_tool_works() {
    if !iceoryx2_available() {
        return;
    }
    let prefix = unique_prefix("pyclient");
    let mut core = Command::new(workspace_bin("lamina"))
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "5"])
        .stdout(Stdio::null())
        .spawn()
        .expect("starting lamina run");
    std::thread::sleep(Duration::from_millis(1000));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/examples/lamina_client.py");
    let out = Command::new(python())
        .env("PYTHONPATH", python_package_dir())
        .arg(&script)
        .args(["--prefix", &prefix, "--seconds", "2.5", "--press"])
        .output()
        .expect("running the Python client");
    assert!(wait_with_watchdog(&mut core, Duration::from_secs(60), "lamina run").success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    let line =
        |part: &str| text.lines().find(|l| l.contains(part)).unwrap_or_else(|| panic!("no '{part}' in:\n{text}"));

    let scene = Scene::builtin_default();
    let nodes = scene.build_model().unwrap().nodes.len() as f64;
    let first = line("first frame:");
    let (tick, sim) = (number_after(first, "tick"), number_after(first, "sim_time_s"));
    assert!((sim - (tick + 11.0) / f64::from(scene.rate_hz)).abs() < 1e-6, "{first}");
    let topology = line("topology revision 0:");
    assert_eq!(number_after(topology, "revision 0:"), nodes, "{topology}");
    let model = scene.build_model().unwrap();
    assert_eq!(number_after(topology, "coordinates,"), model.springs.len() as f64, "springs: {topology}");
    assert!(topology.contains("'skin_outer 25x7'"), "the skin's grid (24 columns and the seam, 7 rings): {topology}");
    let summary = line("frames, last:");
    assert!(number_after(summary, "") > 1000.0, "frames at 1 kHz for 2.5 s: {summary}");
    // A gap is a frame the 16-frame buffer dropped while Python was descheduled: rare, and
    // only on a loaded machine (one in 2,484 frames seen while a CI build ran beside it).
    let frames = number_after(summary, "");
    assert!(number_after(summary, "sequence gaps") <= frames / 100.0, "{summary}");
    let stats = summary.split(';').find(|part| part.contains("stats messages"));
    let stats = stats.and_then(|part| part.split_whitespace().next()?.parse::<f64>().ok());
    assert!(stats.is_some_and(|n| n >= 1.0), "statistics received: {summary}");
    assert_eq!(number_after(summary, "topology node count"), nodes, "{summary}");
    let feedback = line("last feedback:");
    assert_eq!(number_after(feedback, "in_contact"), 1.0, "the 8 mm press touches: {feedback}");
    // The tissue pushes the tool back up (+y), by the 0.100 N docs/haptics.md reports for
    // the 8 mm press (the press starts at the device origin the topology carries).
    let fy: f64 = feedback.split_once("force (").unwrap().1.split(',').nth(1).unwrap().trim().parse().unwrap();
    assert!(fy > 0.07 && fy < 0.14, "{feedback}");
}
