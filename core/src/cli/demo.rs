//! `lamina demo`: the main job as cooperating processes: the core (`lamina run`) stepping the
//! scene at 1 kHz and publishing, and the viewer (`lamina-viewer`, headless when there is no
//! display) drawing it to PNG frames. At exit it prints the core's deadline figures, the
//! viewer's frame times and core-to-viewer latency, and where the frames are.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn sibling(name: &str) -> Result<PathBuf, String> {
    let path = std::env::current_exe().map_err(|e| e.to_string())?.with_file_name(name);
    if path.exists() {
        Ok(path)
    } else {
        Err(format!("{} not found: build the workspace first (`cargo build --release --workspace`)", path.display()))
    }
}

/// Runs the demo for `seconds`, writing frames under `out`.
pub fn demo(scene: Option<&Path>, seconds: f64, out: &Path) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let prefix = format!("demo_{}", std::process::id());
    let frames_dir = out.join("frames");
    std::fs::create_dir_all(&frames_dir).map_err(|e| format!("{}: {e}", frames_dir.display()))?;
    let headless = std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none();
    // The viewer first: it waits for the core and must not miss its topology.
    let mut viewer = Command::new(sibling("lamina-viewer")?);
    viewer.args(["--prefix", &prefix, "--size", "960x540", "--samples", "1", "--every", "5"]);
    viewer.arg("--frames").arg(format!("{}", (seconds * 60.0).max(10.0) as u64));
    if headless {
        viewer.arg("--headless").arg("--out").arg(&frames_dir);
    }
    if let Some(s) = scene {
        viewer.arg("--scene").arg(s);
    }
    let viewer_log = out.join("viewer.log");
    let log = std::fs::File::create(&viewer_log).map_err(|e| format!("{}: {e}", viewer_log.display()))?;
    let mut viewer =
        viewer.stdout(Stdio::from(log)).stderr(Stdio::inherit()).spawn().map_err(|e| format!("lamina-viewer: {e}"))?;
    let report = out.join("core_report.json");
    let mut core = Command::new(std::env::current_exe().map_err(|e| e.to_string())?);
    core.args(["run", "--quiet", "--prefix", &prefix, "--seconds", &seconds.to_string(), "--report"]).arg(&report);
    if let Some(s) = scene {
        core.arg("--scene").arg(s);
    }
    println!(
        "lamina demo: core and viewer ({}) as separate processes on prefix '{prefix}' for {seconds} s",
        if headless { "headless, no display found" } else { "window" }
    );
    let core_out = core.output().map_err(|e| format!("lamina run: {e}"))?;
    // The viewer stops after its frame count or when told.
    let _ = Command::new("kill").args(["-TERM", &viewer.id().to_string()]).status();
    let _ = viewer.wait();
    println!("\n== core (lamina run)\n{}", String::from_utf8_lossy(&core_out.stdout));
    println!("== viewer (lamina-viewer)");
    let text = std::fs::read_to_string(&viewer_log).unwrap_or_default();
    for line in text.lines().filter(|l| !l.starts_with("frame ")).take(40) {
        println!("{line}");
    }
    let frames = std::fs::read_dir(&frames_dir).map(|d| d.count()).unwrap_or(0);
    println!(
        "\n{frames} frames written to {}; core report {}; viewer log {}",
        frames_dir.display(),
        report.display(),
        viewer_log.display()
    );
    println!("(haptics with a scripted device joins the demo with issue 7)");
    if !core_out.status.success() {
        return Err(format!("the core exited with {}", core_out.status));
    }
    Ok(())
}
