//! `lamina demo`: the main job as three cooperating processes on one service prefix:
//! - the core (`lamina run`) stepping the scene at its rate, pinned to the last CPU;
//! - the haptics process (`lamina-haptics`) with a scripted device pressing 12 mm into the
//!   skin and then grasping and pulling it, fitted to the run's length
//!   ([`DemoScript`]; `config/trajectories/demo_press_pull.csv` is the script at its nominal
//!   pace), device loop at 4 kHz pinned to the first CPU;
//! - the viewer (`lamina-viewer`): a window when there is a display, else headless writing PNG
//!   frames.
//!
//! At exit, or on Ctrl-C (SIGINT) or SIGTERM, it stops the children in order (haptics, core,
//! viewer), prints the cross-process profile (core deadlines, device-loop rate and jitter,
//! core-to-device and core-to-viewer latency, viewer frame time), the peak skin displacement
//! under the tool and the peak force on the tool ([`Peaks`], measured by the demo from the
//! core's messages), and where everything went. Each run clears the previous run's frames.

use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use super::demo_script::DemoScript;
use super::demo_watch::{Peaks, Watch};

/// How much longer than `--seconds` the core may run when the scripted device drives its
/// tool, s. The core runs until the device's run is over, and the device's start comes after
/// the core's: about 0.1 s on an idle machine, seconds on a loaded one. This bounds a device
/// that never finishes.
const DEVICE_START_ALLOWANCE_S: f64 = 30.0;

/// How long after the core the device starts: the viewer's first frames, drawn on a software
/// rasteriser, then show the tool still clear of the skin.
const VIEWER_HEAD_START: Duration = Duration::from_millis(600);

/// The demo's device script at its nominal pace (device frame, metres, buttons); `lamina
/// demo` plays it fitted to its run ([`DemoScript`]).
pub const DEMO_TRAJECTORY: &str = include_str!("../../config/trajectories/demo_press_pull.csv");

fn sibling(name: &str) -> Result<PathBuf, String> {
    let path = std::env::current_exe().map_err(|e| e.to_string())?.with_file_name(name);
    if path.exists() {
        Ok(path)
    } else {
        Err(format!("{} not found: build the workspace first (`cargo build --release --workspace`)", path.display()))
    }
}

fn file(path: &Path) -> Result<std::fs::File, String> {
    std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The scene's tool when the haptics process drives it: where the device's workspace centre
/// sits in the model and the sphere's radius. The haptics process and the viewer learn both
/// from the core's model message; the demo needs them for its own view and measurements.
#[derive(Debug, Clone, Copy)]
pub struct HapticTool {
    /// Model position of the device's workspace centre, m.
    pub device_origin: [f64; 3],
    /// Sphere radius, m.
    pub radius: f64,
}

/// `scene`'s haptics-driven tool, or `None` when the scene has no such tool.
pub fn haptic_tool(scene: Option<&Path>) -> Result<Option<HapticTool>, String> {
    let scene = super::run::load_scene(&scene.map(Path::to_path_buf))?;
    Ok(scene.tool.and_then(|t| match t.source {
        lamina_core::scene::ToolSource::Haptics { device_origin, .. } => {
            Some(HapticTool { device_origin, radius: t.radius })
        }
        lamina_core::scene::ToolSource::Scripted { .. } => None,
    }))
}

/// Height of the demo's view at the tool, m: the top of the limb around the press and the
/// grasp, so the 12 mm press is about 50 pixels deep in the 540-pixel-high image.
const VIEW_SPAN_M: f64 = 0.12;

/// The viewer's `--focus` for the scripted press: the top of the skin (one tool radius below
/// the device origin), midway between the press and the grasp site (device x is model z).
fn focus(tool: &HapticTool) -> String {
    let o = tool.device_origin;
    let z = o[2] + 0.5 * super::demo_script::GRASP_OFFSET_X_M;
    format!("{},{},{z},{VIEW_SPAN_M}", o[0], o[1] - tool.radius)
}

/// What the viewer left: frames shown in a window (its log says how many; screenshots, key
/// S, go to `frames_dir`), or headless PNG frames in `frames_dir`.
fn frames_line(viewer_log: &str, frames_dir: &Path) -> String {
    let pngs = std::fs::read_dir(frames_dir)
        .map(|d| d.filter(|e| e.as_ref().is_ok_and(|e| e.path().extension().is_some_and(|x| x == "png"))).count())
        .unwrap_or(0);
    let shown = viewer_log
        .lines()
        .filter(|l| l.starts_with("window"))
        .find_map(|l| l.split_once(" frames shown on screen")?.0.rsplit(' ').next()?.parse::<u64>().ok());
    match shown {
        Some(n) => format!("{n} frames shown on screen in a window; {pngs} screenshots in {}", frames_dir.display()),
        None => format!("{pngs} frames written to {}", frames_dir.display()),
    }
}

/// Set by SIGINT or SIGTERM: the demo then stops its children in order and prints their
/// summaries.
static STOP: AtomicBool = AtomicBool::new(false);

/// Waits until one of `children` (each with its name, for errors) exits: its index and exit
/// status; `None` when the demo was told to stop first.
fn wait_for_first(children: &mut [(&mut Child, &str)]) -> Result<Option<(usize, ExitStatus)>, String> {
    loop {
        for (i, (child, name)) in children.iter_mut().enumerate() {
            if let Some(status) = child.try_wait().map_err(|e| format!("{name}: {e}"))? {
                return Ok(Some((i, status)));
            }
        }
        if STOP.load(Ordering::Relaxed) {
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Sends `child` SIGTERM (its own stop handler then writes its summary and report) and waits
/// for it; SIGKILL after 10 s.
fn terminate(child: &mut Child, name: &str) -> Result<ExitStatus, String> {
    if let Some(status) = child.try_wait().map_err(|e| format!("{name}: {e}"))? {
        return Ok(status);
    }
    let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| format!("{name}: {e}"))? {
            return Ok(status);
        }
        if started.elapsed() > Duration::from_secs(10) {
            let _ = child.kill();
            return child.wait().map_err(|e| format!("{name}: {e}"));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// What ended the wait for the scripted device.
enum DeviceWait {
    /// The device's run is over (its exit status).
    DeviceDone(ExitStatus),
    /// The core exited first: a failure, or its run's cap reached (its exit status).
    CoreDone(ExitStatus),
    /// The demo was told to stop.
    Stopped,
}

/// Waits until the haptics process exits, the core exits, or the demo is told to stop.
fn wait_for_device(haptics: &mut Child, core: &mut Child) -> Result<DeviceWait, String> {
    Ok(match wait_for_first(&mut [(haptics, "lamina-haptics"), (core, "lamina run")])? {
        Some((0, status)) => DeviceWait::DeviceDone(status),
        Some((_, status)) => DeviceWait::CoreDone(status),
        None => DeviceWait::Stopped,
    })
}

/// Says which children the demo stops, and in what order, when a signal told it to stop.
fn announce_stop() {
    if let Some(signal) = lamina_rt::caught_stop_signal() {
        println!("{}: stopping haptics, core and viewer, in that order", lamina_rt::signal_name(signal));
    }
}

/// Runs the demo for `seconds`, writing frames and reports under `out`. With a scripted device
/// the core runs until the device's run (`seconds` - 0.8 s from its own start) is over, so a
/// device that starts late still plays its whole script on a running core. Its children run in
/// their own process group, so Ctrl-C reaches the demo alone, which then stops the haptics
/// process (its force goes to zero first), the core and the viewer, in that order, and prints
/// every summary.
pub fn demo(scene: Option<&Path>, seconds: f64, out: &Path, record: Option<&Path>) -> Result<(), String> {
    if !(seconds.is_finite() && seconds > 0.0) {
        return Err("--seconds must be positive".into());
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let prefix = format!("demo_{}", std::process::id());
    let frames_dir = out.join("frames");
    // This run's frames only: an earlier run's are cleared.
    let cleared = std::fs::read_dir(&frames_dir).map(|d| d.count()).unwrap_or(0);
    if frames_dir.exists() {
        std::fs::remove_dir_all(&frames_dir).map_err(|e| format!("{}: {e}", frames_dir.display()))?;
    }
    std::fs::create_dir_all(&frames_dir).map_err(|e| format!("{}: {e}", frames_dir.display()))?;
    let _ = lamina_rt::install_stop_handler(&STOP);
    // The viewer decides: a window when it can open one, else headless PNG frames (it says
    // which in its log). Either way frames or screenshots (key S) go to `frames_dir`.
    let display = [std::env::var_os("DISPLAY"), std::env::var_os("WAYLAND_DISPLAY")]
        .iter()
        .any(|d| d.as_ref().is_some_and(|d| !d.is_empty()));
    let haptic_tool = haptic_tool(scene)?;
    let script = DemoScript::for_run(seconds);
    // The demo's own measurements, subscribed before the core starts.
    let watch = match &haptic_tool {
        Some(tool) => Some(Watch::start(&prefix, tool.radius)?),
        None => None,
    };

    // The viewer first: it waits for the core and must not miss its topology.
    let mut viewer = Command::new(sibling("lamina-viewer")?);
    viewer.args(["--prefix", &prefix, "--size", "960x540", "--samples", "1", "--every", "2"]);
    viewer.arg("--frames").arg(format!("{}", (seconds * 60.0).max(10.0) as u64));
    viewer.arg("--out").arg(&frames_dir);
    if !display {
        // Headless frames in flat tissue colours: the software rasteriser draws them faster,
        // and the first frame does not wait for the volume texture's bake (1.4 s, longer on a
        // loaded machine), so the frames keep up with the press. A window draws the texture.
        viewer.arg("--no-texture");
    }
    if let Some(tool) = &haptic_tool {
        viewer.arg("--focus").arg(focus(tool));
    }
    let viewer_log = out.join("viewer.log");
    let mut viewer = viewer
        .process_group(0)
        .stdout(Stdio::from(file(&viewer_log)?))
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("lamina-viewer: {e}"))?;

    let report = out.join("core_report.json");
    let mut core = Command::new(std::env::current_exe().map_err(|e| e.to_string())?);
    let core_seconds = if haptic_tool.is_some() { seconds + DEVICE_START_ALLOWANCE_S } else { seconds };
    core.args(["run", "--quiet", "--prefix", &prefix, "--seconds", &core_seconds.to_string(), "--report"]).arg(&report);
    if let Some(s) = scene {
        core.arg("--scene").arg(s);
    }
    if let Some(dir) = record {
        core.arg("--record").arg(dir);
    }
    let core_log = out.join("core.log");
    let mut core = core
        .process_group(0)
        .stdout(Stdio::from(file(&core_log)?))
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|e| format!("lamina run: {e}"))?;

    // Haptics waits for the core's model, then plays its script (it renders zero force until
    // the first feedback).
    let haptics_report = out.join("haptics_report.json");
    let haptics_log = out.join("haptics.log");
    let mut haptics = match haptic_tool {
        Some(_) => {
            let trajectory = out.join("demo_press_pull.csv");
            std::fs::write(&trajectory, &script.csv).map_err(|e| format!("{}: {e}", trajectory.display()))?;
            // The viewer's first frames show the tool clear of the skin before the press.
            std::thread::sleep(VIEWER_HEAD_START);
            let mut h = Command::new(sibling("lamina-haptics")?);
            h.args(["--prefix", &prefix, "--cpu", "0", "--rate-hz", "4000"])
                .arg("--device")
                .arg(format!("scripted:{}", trajectory.display()))
                .args(["--seconds", &format!("{}", (seconds - 0.8).max(0.5))])
                .arg("--report")
                .arg(&haptics_report)
                .arg("--trace-csv")
                .arg(out.join("haptics_trace.csv"));
            if let Some(s) = scene {
                h.arg("--scene").arg(s);
            }
            Some(
                h.process_group(0)
                    .stdout(Stdio::from(file(&haptics_log)?))
                    .stderr(Stdio::from(file(&out.join("haptics_events.log"))?))
                    .spawn()
                    .map_err(|e| format!("lamina-haptics: {e}"))?,
            )
        }
        None => None,
    };
    println!(
        "lamina demo: core, haptics ({}) and viewer ({}) as separate processes on prefix '{prefix}' for {seconds} s",
        if haptics.is_some() {
            "scripted device pressing and pulling the skin"
        } else {
            "off: the scene has no haptics tool"
        },
        if display { "a window on this display" } else { "headless, no display found" }
    );
    if haptics.is_some() {
        match script.skipped(seconds) {
            Some(skipped) => println!("{skipped}"),
            None => println!(
                "scripted device: press {:.0} mm, hold, release, grasp and pull {:.0} mm up, let go, in {:.2} s ({:.0} % of the nominal {:.1} s)",
                super::demo_script::PRESS_DEPTH_M * 1e3,
                super::demo_script::PULL_HEIGHT_M * 1e3,
                script.duration_s,
                100.0 * script.pace,
                super::demo_script::NOMINAL_S
            ),
        }
    }
    println!(
        "writing to {} (frames in {}{}); Ctrl-C stops it early",
        out.display(),
        frames_dir.display(),
        if cleared > 0 { format!(", {cleared} earlier frames cleared") } else { String::new() }
    );
    // With a device, the core runs until the device's run is over; without, its own length.
    let (haptics_status, core_status) = match haptics.as_mut() {
        Some(h) => match wait_for_device(h, &mut core)? {
            DeviceWait::DeviceDone(device) => {
                println!("the scripted device's run is over: stopping the core");
                (Some(device), terminate(&mut core, "lamina run")?)
            }
            DeviceWait::CoreDone(core_status) => (Some(terminate(h, "lamina-haptics")?), core_status),
            DeviceWait::Stopped => {
                announce_stop();
                (Some(terminate(h, "lamina-haptics")?), terminate(&mut core, "lamina run")?)
            }
        },
        None => {
            let core_done = wait_for_first(&mut [(&mut core, "lamina run")])?.map(|(_, status)| status);
            announce_stop();
            let core_status = match core_done {
                Some(status) => status,
                None => terminate(&mut core, "lamina run")?,
            };
            (None, core_status)
        }
    };
    // The viewer stops after its frame count or when told.
    terminate(&mut viewer, "lamina-viewer")?;
    let peaks: Option<Peaks> = watch.map(Watch::finish).transpose()?;

    println!("\n== core (lamina run)\n{}", std::fs::read_to_string(&core_log).unwrap_or_default());
    if haptics_status.is_some() {
        println!("== haptics (lamina-haptics)\n{}", std::fs::read_to_string(&haptics_log).unwrap_or_default());
    }
    println!("== viewer (lamina-viewer)");
    let text = std::fs::read_to_string(&viewer_log).unwrap_or_default();
    for line in text.lines().filter(|l| !l.starts_with("frame ")).take(40) {
        println!("{line}");
    }
    if let Some(p) = peaks {
        println!("\n== tool (measured by the demo)\n{p}");
    }
    println!(
        "\n{}\nreports: {} (core), {} (haptics); logs: {} {} {}",
        frames_line(&text, &frames_dir),
        report.display(),
        haptics_report.display(),
        core_log.display(),
        haptics_log.display(),
        viewer_log.display()
    );
    if let Some(signal) = lamina_rt::caught_stop_signal() {
        println!("stopped early by {}", lamina_rt::signal_name(signal));
        return Ok(());
    }
    if !core_status.success() {
        return Err(format!("the core exited with {core_status}"));
    }
    if let Some(s) = haptics_status.filter(|s| !s.success()) {
        return Err(format!("the haptics process exited with {s} (see {})", haptics_log.display()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_line_says_window_or_files() {
        let dir = std::env::temp_dir().join(format!("lamina_frames_line_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("frame_00000.png"), b"").unwrap();
        std::fs::write(dir.join("frames.csv"), b"").unwrap();
        let window = "lamina-viewer: x\nwindow on llvmpipe (LLVM 19, 256 bits): 412 frames shown on screen, frame time p50 1 ms\n";
        assert_eq!(
            frames_line(window, &dir),
            format!("412 frames shown on screen in a window; 1 screenshots in {}", dir.display())
        );
        assert_eq!(
            frames_line("== lamina-viewer: 3 frames in 1 s\n", &dir),
            format!("1 frames written to {}", dir.display())
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
