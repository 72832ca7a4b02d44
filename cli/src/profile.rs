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

fn wait(mut child: Child, what: &str) -> Result<(), String> {
    let status = child.wait().map_err(|e| format!("{what}: {e}"))?;
    if status.success() { Ok(()) } else { Err(format!("{what} exited with {status}")) }
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
) -> Result<Vec<(Child, &'static str, PathBuf, PathBuf)>, String> {
    let listen = sibling("lamina-listen")?;
    let mut v = Vec::new();
    {
        let cpu = "0";
        let json = out.join(format!("{tag}_{mode}.json"));
        let hist = out.join(format!("{tag}_{mode}_histogram.csv"));
        let child = Command::new(&listen)
            .args(["--prefix", prefix, "--mode", mode, "--pin", cpu, "--seconds", &format!("{}", seconds + 1.5)])
            .arg("--out")
            .arg(&json)
            .arg("--histogram")
            .arg(&hist)
            .stdout(Stdio::null())
            .spawn()
            .map_err(|e| format!("lamina-listen: {e}"))?;
        v.push((child, mode, json, hist));
    }
    std::thread::sleep(Duration::from_millis(400));
    Ok(v)
}

/// Runs the profile and prints the table.
pub fn profile(scene: Option<&Path>, seconds: f64, sizes: &[u64], out: &Path) -> Result<(), String> {
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
        let core = cmd.stdout(Stdio::null()).spawn().map_err(|e| format!("lamina run: {e}"))?;
        wait(core, "lamina run")?;
        let nodes = {
            let scene = super::run::load_scene(&scene.map(Path::to_path_buf))?;
            scene.build_model().map_err(|e| e.to_string())?.nodes.len() as u64
        };
        for (child, mode, json_path, hist) in subs {
            wait(child, "lamina-listen")?;
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
        let child = Command::new(&probe)
            .args([
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
            ])
            .stdout(Stdio::null())
            .spawn()
            .map_err(|e| format!("lamina-publish-probe: {e}"))?;
        wait(child, "lamina-publish-probe")?;
        for (child, mode, json_path, hist) in subs {
            wait(child, "lamina-listen")?;
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
    let core = cmd.stdout(Stdio::null()).spawn().map_err(|e| format!("lamina run: {e}"))?;
    std::thread::sleep(Duration::from_millis(600));
    let trajectory = out.join("haptics_trajectory.csv");
    std::fs::write(&trajectory, super::demo::DEMO_TRAJECTORY).map_err(|e| format!("{}: {e}", trajectory.display()))?;
    let report = out.join("haptics_report.json");
    let mut h = Command::new(sibling("lamina-haptics")?);
    if let Some(s) = scene {
        h.arg("--scene").arg(s);
    }
    let h = h
        .args(["--prefix", &prefix, "--cpu", "0", "--rate-hz", "4000", "--quiet", "--seconds", &seconds.to_string()])
        .arg("--device")
        .arg(format!("scripted:{}", trajectory.display()))
        .arg("--report")
        .arg(&report)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("lamina-haptics: {e}"))?;
    wait(h, "lamina-haptics")?;
    wait(core, "lamina run")?;
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
