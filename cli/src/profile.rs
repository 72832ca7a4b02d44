//! `lamina profile`: one-way latency from the core to its subscribers, period jitter and
//! deadline misses, measured with real processes: the core (`lamina run`) or the synthetic
//! publisher (`lamina-publish-probe`, to sweep node counts without the physics), each with a
//! polling and a blocking `lamina-listen`. Writes JSON reports, latency histograms (CSV) and a
//! percentile plot (PNG).

use super::machine;
use super::plot::{Series, log_log_lines};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

fn sibling(name: &str) -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let path = exe.with_file_name(name);
    if path.exists() {
        Ok(path)
    } else {
        Err(format!(
            "{} not found beside lamina: build the workspace first (`cargo build --release --workspace`)",
            path.display()
        ))
    }
}

fn json(path: &Path) -> Result<serde_json::Value, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Longest measurement `--seconds` accepts, s (one hour).
pub const MAX_SECONDS: f64 = 3600.0;
/// Node counts `--nodes` accepts, as `lamina-publish-probe --nodes`.
pub const NODES: std::ops::RangeInclusive<u64> = 1..=1_000_000;

/// A child process that is killed and reaped when dropped before [`Guarded::wait`]: when a
/// step of the profile fails, no listener, core or probe is left running.
struct Guarded {
    child: Option<Child>,
    what: &'static str,
}

impl Guarded {
    /// Spawns `cmd`, the program named `what` in errors.
    fn spawn(cmd: &mut Command, what: &'static str) -> Result<Self, String> {
        let child = cmd.spawn().map_err(|e| format!("{what}: {e}"))?;
        Ok(Self { child: Some(child), what })
    }

    /// Waits for the process to end; an error unless it exited with status 0.
    fn wait(mut self) -> Result<(), String> {
        let Some(mut child) = self.child.take() else { return Ok(()) };
        let status = child.wait().map_err(|e| format!("{}: {e}", self.what))?;
        if status.success() { Ok(()) } else { Err(format!("{} exited with {status}", self.what)) }
    }
}

impl Drop for Guarded {
    fn drop(&mut self) {
        if let Some(mut child) = self.child.take() {
            // The process may have ended already: both calls are then harmless.
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// One measured configuration.
struct Row {
    source: String,
    nodes: u64,
    mode: &'static str,
    report: serde_json::Value,
    histogram: PathBuf,
}

/// Starts one listener (`poll` or `block`, pinned to CPU 0; the publisher takes the last CPU).
/// Poll and block are measured in separate runs: a polling subscriber occupies its CPU.
fn listeners(
    prefix: &str,
    seconds: f64,
    out: &Path,
    tag: &str,
    mode: &'static str,
) -> Result<Vec<(Guarded, &'static str, PathBuf, PathBuf)>, String> {
    let listen = sibling("lamina-listen")?;
    let mut v = Vec::new();
    {
        let cpu = "0";
        let json = out.join(format!("{tag}_{mode}.json"));
        let hist = out.join(format!("{tag}_{mode}_histogram.csv"));
        let child = Guarded::spawn(
            Command::new(&listen)
                .args(["--prefix", prefix, "--mode", mode, "--pin", cpu, "--seconds", &format!("{}", seconds + 1.5)])
                .arg("--out")
                .arg(&json)
                .arg("--histogram")
                .arg(&hist)
                .stdout(Stdio::null()),
            "lamina-listen",
        )?;
        v.push((child, mode, json, hist));
    }
    std::thread::sleep(Duration::from_millis(400));
    Ok(v)
}

/// Runs the profile and prints the table: `seconds` per measurement (above 0 and at most
/// [`MAX_SECONDS`]), the probe at each of `sizes` nodes (each in [`NODES`]); both are checked
/// before any process starts.
pub fn profile(scene: Option<&Path>, seconds: f64, sizes: &[u64], out: &Path) -> Result<(), String> {
    lamina_rt::seconds_option("--seconds", seconds, MAX_SECONDS).map_err(|e| e.to_string())?;
    if let Some(n) = sizes.iter().find(|n| !NODES.contains(n)) {
        return Err(format!("--nodes {n}: must be from {} to {}", NODES.start(), NODES.end()));
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let pid = std::process::id();
    let mut rows: Vec<Row> = Vec::new();
    // The real core, with its physics.
    let mut core_report = None;
    let bar = super::progress::steps(3 + 2 * sizes.len() as u64, "profile");
    for mode in ["poll", "block"] {
        bar.set_message(format!("core, {mode} subscriber ({seconds} s)"));
        let prefix = format!("profile_core_{mode}_{pid}");
        let subs = listeners(&prefix, seconds, out, "core", mode)?;
        let report = out.join(format!("core_report_{mode}.json"));
        let mut cmd = Command::new(std::env::current_exe().map_err(|e| e.to_string())?);
        cmd.args(["run", "--quiet", "--prefix", &prefix, "--seconds", &seconds.to_string(), "--report"]).arg(&report);
        if let Some(s) = scene {
            cmd.arg("--scene").arg(s);
        }
        Guarded::spawn(cmd.stdout(Stdio::null()), "lamina run")?.wait()?;
        let nodes = {
            let scene = super::run::load_scene(&scene.map(Path::to_path_buf))?;
            scene.build_model().map_err(|e| e.to_string())?.nodes.len() as u64
        };
        for (child, mode, json_path, hist) in subs {
            child.wait()?;
            rows.push(Row { source: "core".into(), nodes, mode, report: json(&json_path)?, histogram: hist });
        }
        if mode == "block" {
            core_report = Some(json(&report)?);
        }
        bar.inc(1);
    }
    bar.set_message(format!("haptics against the core ({seconds} s)"));
    // The haptics process against the real core: a scripted device pressing and pulling
    // the skin, device loop at 4 kHz on the first CPU, the core on the last.
    let haptics = match super::demo::haptic_tool(scene)? {
        Some(_) => Some(profile_haptics(scene, seconds, out)?),
        None => None,
    };
    bar.inc(1);
    // The synthetic publisher at each node count.
    let probe = sibling("lamina-publish-probe")?;
    for (&n, mode) in sizes.iter().flat_map(|n| [(n, "poll"), (n, "block")]) {
        bar.set_message(format!("probe, {n} nodes, {mode} subscriber ({seconds} s)"));
        let prefix = format!("profile_probe_{n}_{mode}_{pid}");
        let subs = listeners(&prefix, seconds, out, &format!("probe_{n}"), mode)?;
        let child = Guarded::spawn(
            Command::new(&probe).stdout(Stdio::null()).args([
                "--nodes",
                &n.to_string(),
                "--rate",
                "1000",
                "--seconds",
                &seconds.to_string(),
                "--prefix",
                &prefix,
                "--pin",
                "1",
            ]),
            "lamina-publish-probe",
        )?;
        child.wait()?;
        for (child, mode, json_path, hist) in subs {
            child.wait()?;
            rows.push(Row { source: "probe".into(), nodes: n, mode, report: json(&json_path)?, histogram: hist });
        }
        bar.inc(1);
    }
    bar.finish_and_clear();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "cross-process profile; machine: {}; load average {}",
        machine::describe(),
        load.split(' ').take(3).collect::<Vec<_>>().join(" ")
    );
    println!(
        "one-way latency, publisher timestamp before send() to subscriber after receive(), 1 kHz, {seconds} s each"
    );
    println!(
        "{:<7} {:>7} {:<6} {:>7} {:>7} {:>9} {:>9} {:>9} {:>9}",
        "source", "nodes", "mode", "frames", "missing", "p50 us", "p99 us", "p99.9 us", "max us"
    );
    let us = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN) / 1e3;
    for r in &rows {
        let l = &r.report["latency"];
        println!(
            "{:<7} {:>7} {:<6} {:>7} {:>7} {:>9.2} {:>9.2} {:>9.2} {:>9.2}",
            r.source,
            r.nodes,
            r.mode,
            r.report["count"],
            r.report["missing"],
            us(&l["p50_ns"]),
            us(&l["p99_ns"]),
            us(&l["p999_ns"]),
            us(&l["max_ns"])
        );
    }
    if let Some(c) = &core_report {
        println!("(core loop figures from the run with the blocking subscriber)");
        let s = c;
        let pick = |k: &str, q: &str| s[k][q].as_f64().unwrap_or(f64::NAN) / 1e3;
        println!(
            "\ncore loop: ticks {}, misses {}; period p50 {:.1} us p99 {:.1} us p99.9 {:.1} us max {:.1} us; \
             wake-up lateness p99 {:.1} us max {:.1} us; compute p50 {:.1} us p99 {:.1} us; send p50 {:.1} us p99 {:.1} us",
            s["ticks"],
            s["misses"],
            pick("period", "p50_ns"),
            pick("period", "p99_ns"),
            pick("period", "p999_ns"),
            pick("period", "max_ns"),
            pick("lateness", "p99_ns"),
            pick("lateness", "max_ns"),
            pick("compute", "p50_ns"),
            pick("compute", "p99_ns"),
            pick("send", "p50_ns"),
            pick("send", "p99_ns")
        );
    }
    if let Some(h) = &haptics {
        let us = |k: &str, q: &str| h["loop"][k][q].as_f64().unwrap_or(f64::NAN) / 1e3;
        let l = &h["core_to_device_latency"];
        let lu = |q: &str| l[q].as_f64().unwrap_or(f64::NAN) / 1e3;
        println!(
            "\nhaptics device loop ({}, {} Hz): ticks {}, misses {}, skipped periods {}; period p50 {:.1} us p99 {:.1} us \
             p99.9 {:.1} us max {:.1} us; wake-up lateness p99 {:.1} us max {:.1} us; compute p99 {:.1} us",
            h["device"].as_str().unwrap_or("?"),
            h["rate_hz"],
            h["loop"]["ticks"],
            h["loop"]["misses"],
            h["loop"]["skipped_periods"],
            us("period", "p50_ns"),
            us("period", "p99_ns"),
            us("period", "p999_ns"),
            us("period", "max_ns"),
            us("lateness", "p99_ns"),
            us("lateness", "max_ns"),
            us("compute", "p99_ns"),
        );
        println!(
            "core -> device latency (core publishes feedback -> force written on the device), {} messages: \
             p50 {:.1} us p99 {:.1} us p99.9 {:.1} us max {:.1} us; max force {:.3} N",
            l["count"],
            lu("p50_ns"),
            lu("p99_ns"),
            lu("p999_ns"),
            lu("max_ns"),
            h["max_force_n"].as_f64().unwrap_or(f64::NAN)
        );
    }
    plot(&out.join("latency_percentiles.png"), &rows)?;
    tracing::info!("reports, histograms (CSV) and latency_percentiles.png written to {}", out.display());
    Ok(())
}

/// Core plus `lamina-haptics` (scripted press and pull) for `seconds`; the haptics report.
fn profile_haptics(scene: Option<&Path>, seconds: f64, out: &Path) -> Result<serde_json::Value, String> {
    let prefix = format!("profile_haptics_{}", std::process::id());
    let mut cmd = Command::new(std::env::current_exe().map_err(|e| e.to_string())?);
    cmd.args(["run", "--quiet", "--prefix", &prefix, "--seconds", &(seconds + 1.0).to_string()]);
    if let Some(s) = scene {
        cmd.arg("--scene").arg(s);
    }
    let core = Guarded::spawn(cmd.stdout(Stdio::null()), "lamina run")?;
    std::thread::sleep(Duration::from_millis(600));
    let trajectory = out.join("haptics_trajectory.csv");
    std::fs::write(&trajectory, super::demo::DEMO_TRAJECTORY).map_err(|e| format!("{}: {e}", trajectory.display()))?;
    let report = out.join("haptics_report.json");
    let mut h = Command::new(sibling("lamina-haptics")?);
    if let Some(s) = scene {
        h.arg("--scene").arg(s);
    }
    h.args(["--prefix", &prefix, "--cpu", "0", "--rate-hz", "4000", "--quiet", "--seconds", &seconds.to_string()])
        .arg("--device")
        .arg(format!("scripted:{}", trajectory.display()))
        .arg("--report")
        .arg(&report)
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    Guarded::spawn(&mut h, "lamina-haptics")?.wait()?;
    core.wait()?;
    json(&report)
}

fn plot(path: &Path, rows: &[Row]) -> Result<(), String> {
    let series: Vec<Series> = rows
        .iter()
        .filter_map(|r| {
            let text = std::fs::read_to_string(&r.histogram).ok()?;
            let points: Vec<(f64, f64)> = text
                .lines()
                .skip(1)
                .filter_map(|l| {
                    let f: Vec<f64> = l.split(',').filter_map(|v| v.parse().ok()).collect();
                    (f.len() == 3 && f[1] < 1.0).then(|| (1.0 / (1.0 - f[1]), f[0].max(1.0) / 1e3))
                })
                .collect();
            Some(Series { name: format!("{} {} nodes {}", r.source, r.nodes, r.mode), points })
        })
        .collect();
    log_log_lines(
        path,
        "one-way latency percentiles (x: 1/(1-q), 10 = p90, 1000 = p99.9)",
        "1 / (1 - quantile)",
        "latency (us)",
        &series,
        false,
    )
}

#[cfg(test)]
mod tests {
    use super::Guarded;
    use std::process::Command;

    #[test]
    fn a_dropped_child_is_killed_and_reaped_works() {
        let guarded = Guarded::spawn(Command::new("sleep").arg("1000"), "sleep").unwrap();
        let pid = guarded.child.as_ref().map(std::process::Child::id).unwrap() as libc::pid_t;
        // SAFETY: kill(2) with signal 0 only checks that the process exists.
        assert_eq!(unsafe { libc::kill(pid, 0) }, 0, "the child runs");
        drop(guarded);
        // Killed and reaped: the pid names no process any more (ESRCH), not even a zombie.
        // SAFETY: as above.
        assert_eq!(unsafe { libc::kill(pid, 0) }, -1);
        assert_eq!(std::io::Error::last_os_error().raw_os_error(), Some(libc::ESRCH));
    }

    #[test]
    fn a_waited_child_reports_its_exit_status_fail() {
        assert_eq!(Guarded::spawn(&mut Command::new("true"), "true").unwrap().wait(), Ok(()));
        let e = Guarded::spawn(&mut Command::new("false"), "false").unwrap().wait().unwrap_err();
        assert!(e.starts_with("false exited with") && e.contains('1'), "{e}");
    }
}
