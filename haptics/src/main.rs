//! `lamina-haptics`: the haptics process. Drives a force-feedback device at 1-4 kHz on
//! absolute deadlines, sends its pose to the core on `tool`, renders force locally from the
//! core's newest `feedback`, and keeps the hand safe (clamped, finite, zero when the core
//! goes quiet). Prints the device loop's rate and jitter and the core-to-device latency at
//! exit, and writes them as JSON with `--report`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{Context, bail};
use clap::Parser;
use lamina_bridge::{Bridge, BridgeConfig, ToolKind};
use lamina_haptics::core_model::wait_for_core_model;
use lamina_haptics::device::{
    DeviceDynamics, DeviceError, EmergencyStop, Hand, HapticDevice, NullDevice, PluginDevice, ScriptedDevice,
    SimulatedDevice, Trajectory, within_ceilings,
};
use lamina_haptics::run_context::{ModelSeen, RunContext, SceneFile, TopologyWatch};
use lamina_haptics::watchdog::{CallWatch, DEVICE_CALL_LIMIT_NS};
use lamina_haptics::{DeviceMapping, HapticsConfig, HapticsReport, SafetyEvent, check_force_cap, run_device_loop};
use lamina_rt::{RealtimeRequest, RealtimeSetup, RunLimit, install_stop_handler, now_ns};

static STOP: AtomicBool = AtomicBool::new(false);

/// Drive a haptic device against a running Lamina core.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Service prefix of the simulation.
    #[arg(long, default_value = lamina_bridge::DEFAULT_PREFIX)]
    prefix: String,
    /// Device: `null`, `scripted:FILE.csv` (trajectory replay), `simulated:FILE.csv` (a handle
    /// with mass and damping held by a grip that follows the trajectory; --device-args
    /// mass_kg=, damping_n_s_per_m=, grip_n_per_m=, grip_n_s_per_m=) or `plugin:LIB.so` (a
    /// vendor wrapper built against haptics/include/lamina_device.h).
    #[arg(long, default_value = "null")]
    device: String,
    /// Argument string handed to a plugin's `lamina_device_open`.
    #[arg(long, default_value = "")]
    device_args: String,
    /// Device loop rate, Hz.
    #[arg(long, default_value_t = 4000)]
    rate_hz: u32,
    /// Run time, s, above 0 and at most 1e9; default: a scripted device's trajectory length
    /// plus 0.2 s, else until SIGINT/SIGTERM. Honoured even if a device call blocks: the
    /// process then exits with code 3 at this time.
    #[arg(long)]
    seconds: Option<f64>,
    /// Model position of the device's workspace centre, m, as `x,y,z`, with the device's
    /// axes on a y-up model and scales 1. Default: the mapping the core's model message
    /// carries (the scene's `effects.tool` device_origin, device_scale and force_scale),
    /// waited for up to --wait-core-s.
    #[arg(long, value_parser = parse_vec3)]
    origin: Option<[f64; 3]>,
    /// How long to wait for the core's model when --origin is not given, s (0 to 86400).
    #[arg(long, default_value_t = 30.0)]
    wait_core_s: f64,
    /// Tool tip radius sent to the core, m; 0 uses the scene's.
    #[arg(long, default_value_t = 0.0)]
    tool_radius: f64,
    /// The tool in the hand: `sphere` (press, grasp with button 0) or `scalpel` (cuts along its
    /// edge, from the tip straight up the stylus). Default: sphere, or what a scripted
    /// trajectory's `kind` column says (the two cannot both be given).
    #[arg(long, value_parser = parse_tool)]
    tool: Option<ToolKind>,
    /// Length of the scalpel's cutting edge, mm, from 1 to 50.
    #[arg(long, default_value_t = 10.0, allow_negative_numbers = true)]
    blade_length_mm: f64,
    /// Cap on the force, N: above 0 and at most the device's limit (its reported limit held to
    /// its class ceiling, printed at start); any other value is refused.
    #[arg(long, allow_negative_numbers = true)]
    max_force: Option<f64>,
    /// Write the JSON report here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// The scene file the core runs: its name and SHA-256 go into the report.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Write every tick (time, handle position, force, gain, contact) as CSV here: the first
    /// ten minutes of the run at most (2.4 million rows at 4 kHz), kept in memory allocated
    /// before the loop.
    #[arg(long)]
    trace_csv: Option<PathBuf>,
    /// Turn the passivity controller off: the observer still measures the energy the device
    /// gives the hand, but nothing damps what the rendering creates (for measurements only).
    #[arg(long)]
    no_passivity_control: bool,
    /// Pin the device loop to this CPU.
    #[arg(long)]
    cpu: Option<usize>,
    /// SCHED_FIFO priority (0: off).
    #[arg(long, default_value_t = 85)]
    fifo: i32,
    /// Print only the final table.
    #[arg(long)]
    quiet: bool,
    /// Diagnostics shown on stderr: error, warn, info, debug or trace.
    #[arg(long, value_name = "LEVEL", default_value = "info")]
    log_level: tracing::Level,
}

fn parse_tool(s: &str) -> Result<ToolKind, String> {
    ToolKind::parse(s).ok_or_else(|| format!("'{s}': expected sphere or scalpel"))
}

/// Shortest and longest --blade-length-mm, mm.
const BLADE_LENGTH_MM: (f64, f64) = (1.0, 50.0);

fn parse_vec3(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> =
        s.split(',').map(|p| p.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([*x, *y, *z]),
        _ => Err(format!("'{s}': expected three finite numbers x,y,z (m)")),
    }
}

/// Opens the device named by `--device`, with the script length when it has one.
fn open_device(spec: &str, args: &str) -> Result<(Box<dyn HapticDevice>, Option<f64>), String> {
    if spec == "null" {
        return Ok((Box::new(NullDevice::default()), None));
    }
    let path_of = |kind: &str, example: &str| match spec.strip_prefix(kind) {
        Some("") => Err(format!("--device '{kind}': no file after '{kind}' (expected {kind}{example})")),
        Some(path) => Ok(Some(Path::new(path))),
        None => Ok(None),
    };
    if let Some(path) = path_of("scripted:", "FILE.csv")? {
        return open_scripted(path, args).map_err(|e| e.to_string());
    }
    if let Some(path) = path_of("simulated:", "FILE.csv")? {
        return open_simulated(path, args).map_err(|e| e.to_string());
    }
    if let Some(path) = path_of("plugin:", "PATH/TO/LIB.so")? {
        return open_plugin(path, args).map_err(|e| e.to_string());
    }
    Err(format!("unknown device '{spec}': use null, scripted:FILE.csv, simulated:FILE.csv or plugin:LIB.so"))
}

/// `v` as a user reads it: scientific notation beyond six digits.
fn show(v: f64) -> String {
    lamina_haptics::device::show_number(v)
}

/// Longest --wait-core-s, s: one day.
const MAX_WAIT_CORE_S: f64 = 86_400.0;

/// Longest --seconds, s (as `lamina run`).
const MAX_RUN_S: f64 = 1e9;

/// Longest run --trace-csv keeps, s: ten minutes.
const TRACE_SECONDS: f64 = 600.0;

/// A scripted device; `args` may hold `disconnect_after_s=T` (the device vanishes at T s).
fn open_scripted(path: &Path, args: &str) -> Result<(Box<dyn HapticDevice>, Option<f64>), DeviceError> {
    let trajectory = Trajectory::load(path)?;
    let duration = trajectory.duration_s();
    let mut device = ScriptedDevice::new(trajectory, ScriptedDevice::default_info(), 0);
    for arg in args.split([',', ' ']).filter(|a| !a.is_empty()) {
        match arg.split_once('=') {
            Some(("disconnect_after_s", v)) => match v.parse::<f64>() {
                Ok(t) if t.is_finite() && t >= 0.0 => device.disconnect_after(t),
                _ => {
                    return Err(DeviceError::Script {
                        file: path.display().to_string(),
                        line: 0,
                        what: format!("--device-args: '{arg}': expected disconnect_after_s=SECONDS"),
                    });
                }
            },
            _ => {
                return Err(DeviceError::Script {
                    file: path.display().to_string(),
                    line: 0,
                    what: format!("--device-args: unknown '{arg}' (scripted devices take disconnect_after_s=SECONDS)"),
                });
            }
        }
    }
    Ok((Box::new(device), Some(duration)))
}

/// Largest simulated mass, kg; largest simulated damping or grip damping, N s/m; largest grip
/// stiffness, N/m.
const SIM_MAX_MASS_KG: f64 = 100.0;
const SIM_MAX_DAMPING: f64 = 1e4;
const SIM_MAX_GRIP: f64 = 1e6;

/// A simulated device whose grip follows the trajectory at `path`; `args` may set `mass_kg`
/// (default 0.2, above 0 and at most 100), `damping_n_s_per_m` (0.05), `grip_n_per_m` (400) and
/// `grip_n_s_per_m` (3), each from 0 to its bound.
fn open_simulated(path: &Path, args: &str) -> Result<(Box<dyn HapticDevice>, Option<f64>), DeviceError> {
    let trajectory = Trajectory::load(path)?;
    let duration = trajectory.duration_s();
    let start = trajectory.position_at(0.0);
    let mut dynamics = DeviceDynamics::default();
    let (mut grip_k, mut grip_b) = (400.0, 3.0);
    let bad = |what: String| DeviceError::Script { file: path.display().to_string(), line: 0, what };
    for arg in args.split([',', ' ']).filter(|a| !a.is_empty()) {
        let Some((key, value)) = arg.split_once('=') else {
            return Err(bad(format!("--device-args: '{arg}': expected KEY=VALUE")));
        };
        let (slot, low_open, max, unit) = match key {
            "mass_kg" => (&mut dynamics.mass_kg, true, SIM_MAX_MASS_KG, "kg"),
            "damping_n_s_per_m" => (&mut dynamics.damping_n_s_per_m, false, SIM_MAX_DAMPING, "N s/m"),
            "grip_n_per_m" => (&mut grip_k, false, SIM_MAX_GRIP, "N/m"),
            "grip_n_s_per_m" => (&mut grip_b, false, SIM_MAX_DAMPING, "N s/m"),
            _ => {
                return Err(bad(format!(
                    "--device-args: unknown '{key}' (simulated devices take mass_kg, damping_n_s_per_m, grip_n_per_m, grip_n_s_per_m)"
                )));
            }
        };
        let v = value.parse::<f64>().ok().filter(|v| v.is_finite());
        match v {
            Some(v) if (if low_open { v > 0.0 } else { v >= 0.0 }) && v <= max => *slot = v,
            _ => {
                let low = if low_open { "above 0" } else { "from 0" };
                return Err(bad(format!(
                    "--device-args: {key} '{value}' must be a number {low} to {} {unit}",
                    show(max)
                )));
            }
        }
    }
    let hand = Hand {
        grip_stiffness_n_per_m: grip_k,
        grip_damping_n_s_per_m: grip_b,
        anchor: Some(trajectory),
        ..Hand::default()
    };
    let device = SimulatedDevice::new(SimulatedDevice::default_info(), dynamics, hand).starting_at(start, [0.0; 3]);
    Ok((Box::new(device), Some(duration)))
}

fn open_plugin(path: &Path, args: &str) -> Result<(Box<dyn HapticDevice>, Option<f64>), DeviceError> {
    Ok((Box::new(PluginDevice::load(path, args)?), None))
}

fn us(ns: u64) -> f64 {
    ns as f64 / 1e3
}

fn print_report(r: &HapticsReport, rate_hz: u32, device: &str) {
    let s = r.monitor.summary();
    let l = &r.core_to_device_ns;
    println!("haptics device loop ({device}) at {rate_hz} Hz");
    println!("  ticks {} misses {} skipped periods {}", s.ticks, s.misses, s.skipped_periods);
    println!(
        "  period  p50 {:>8.1} us  p99 {:>8.1} us  p99.9 {:>8.1} us  max {:>8.1} us  (jitter p99 {:+.1} us)",
        us(s.period.p50_ns),
        us(s.period.p99_ns),
        us(s.period.p999_ns),
        us(s.period.max_ns),
        us(s.period.p99_ns) - 1e6 / rate_hz as f64
    );
    println!(
        "  lateness p50 {:>7.1} us  p99 {:>8.1} us  max {:>8.1} us | compute p50 {:.1} us p99 {:.1} us max {:.1} us",
        us(s.lateness.p50_ns),
        us(s.lateness.p99_ns),
        us(s.lateness.max_ns),
        us(s.compute.p50_ns),
        us(s.compute.p99_ns),
        us(s.compute.max_ns)
    );
    if l.is_empty() {
        println!("  core -> device latency: no feedback received (is the core running with a haptics tool?)");
    } else {
        println!(
            "  core -> device latency ({} feedback messages): p50 {:.1} us  p99 {:.1} us  p99.9 {:.1} us  max {:.1} us",
            l.len(),
            us(l.value_at_quantile(0.5)),
            us(l.value_at_quantile(0.99)),
            us(l.value_at_quantile(0.999)),
            us(l.max())
        );
    }
    let c = &r.safety;
    println!(
        "  safety: max force {:.3} N (limit {:.2} N); clamped ticks {}; stiffness limited {} (limit {:.0} N/m); non-finite feedback {}, pose {}, force {}; quiet ticks {} in {} episode(s); events dropped {}",
        r.max_force_n,
        r.limits.max_force_n,
        c.force_clamped_ticks,
        c.stiffness_limited,
        r.limits.max_stiffness_n_per_m,
        c.feedback_non_finite,
        c.device_pose_non_finite,
        c.force_non_finite,
        c.quiet_ticks,
        c.quiet_episodes,
        c.events_dropped
    );
    println!(
        "  faults: poses beyond the {} m workspace {} in {} fault(s); device calls over {:.0} ms {}",
        r.limits.workspace_radius_m,
        c.workspace_fault_ticks,
        c.workspace_faults,
        DEVICE_CALL_LIMIT_NS as f64 / 1e6,
        c.device_call_stalls
    );
    let clamps: Vec<String> = r.limit_clamps.iter().map(ToString::to_string).collect();
    println!(
        "  device class {}: {}",
        r.device_class,
        if clamps.is_empty() { "reported limits within its ceilings".to_string() } else { clamps.join("; ") }
    );
    let p = &r.passivity;
    println!(
        "  passivity: energy to the hand {:.4e} J, from the hand {:.4e} J; observed energy {:.4e} J (lowest {:.4e} J); controller {}: dissipated {:.4e} J in {} tick(s), {} at the damping ceiling; ticks without a pose {}",
        p.energy_to_hand_j,
        p.energy_from_hand_j,
        p.observed_energy_j,
        p.min_observed_energy_j,
        if p.controller_on { "on" } else { "off" },
        p.dissipated_j,
        p.controller_ticks,
        p.controller_saturated_ticks,
        p.unobserved_ticks
    );
    println!("  tool commands sent {}, port failures {}", r.commands_sent, r.port_failures);
}

/// What the report says about the run besides its measurements.
struct ReportContext<'a> {
    run: &'a RunContext,
    prefix: &'a str,
    device: &'a str,
    rate_hz: u32,
    model: Option<ModelSeen>,
}

fn report_json(r: &HapticsReport, c: &ReportContext) -> serde_json::Value {
    let l = &r.core_to_device_ns;
    let q = |p: f64| if l.is_empty() { 0 } else { l.value_at_quantile(p) };
    let mut lp = serde_json::from_str::<serde_json::Value>(&r.monitor.report_json()).unwrap_or_default();
    // The device loop skips missed periods (OverrunPolicy::Skip): it never catches up.
    if let Some(m) = lp.as_object_mut() {
        m.remove("caught_up_ticks");
    }
    let mut report = c.run.json();
    let fields = serde_json::json!({
        "prefix": c.prefix,
        "model": c.model.map(|m| serde_json::json!({ "nodes": m.nodes, "surface_triangles": m.surface_triangles })),
        "device": c.device,
        "rate_hz": c.rate_hz,
        "loop": lp,
        "core_to_device_latency": {
            "count": l.len(), "p50_ns": q(0.5), "p99_ns": q(0.99), "p999_ns": q(0.999),
            "max_ns": if l.is_empty() { 0 } else { l.max() },
        },
        "safety": r.safety,
        "passivity": r.passivity,
        "max_force_n": r.max_force_n,
        "limits": {
            "max_force_n": r.limits.max_force_n,
            "max_stiffness_n_per_m": r.limits.max_stiffness_n_per_m,
            "damping_n_s_per_m": r.limits.damping_n_s_per_m,
            "zero_after_ns": r.limits.zero_after_ns(),
            "workspace_radius_m": r.limits.workspace_radius_m,
            "device_call_limit_ns": DEVICE_CALL_LIMIT_NS,
        },
        "device_class": r.device_class,
        "limit_clamps": r.limit_clamps.iter().map(|c| serde_json::json!({
            "limit": c.limit, "unit": c.unit, "reported": c.reported, "ceiling": c.ceiling,
        })).collect::<Vec<_>>(),
        "commands_sent": r.commands_sent,
        "port_failures": r.port_failures,
        "device_error": r.device_error.as_ref().map(|e| e.to_string()),
    });
    if let (Some(report), serde_json::Value::Object(fields)) = (report.as_object_mut(), fields) {
        report.extend(fields);
    }
    report
}

fn write_trace(r: &HapticsReport, path: &Path) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(out, "time_ns,x_m,y_m,z_m,fx_n,fy_n,fz_n,gain,in_contact,core_tick")?;
    for t in &r.trace {
        let (p, f) = (t.position_dev_m, t.force_dev_n);
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{}",
            t.time_ns,
            p[0],
            p[1],
            p[2],
            f[0],
            f[1],
            f[2],
            t.gain,
            u8::from(t.in_contact),
            t.core_tick
        )?;
    }
    out.flush()
}

/// The mapping the core's model message carries; says what it uses.
fn device_mapping_from_core(args: &Args, bridge: &Bridge) -> anyhow::Result<DeviceMapping> {
    // Bounded by `check_options`.
    let wait = std::time::Duration::from_secs_f64(args.wait_core_s);
    let model = wait_for_core_model(bridge, &args.prefix, wait, &STOP)?;
    let m = model.mapping();
    if !args.quiet {
        println!(
            "core model '{}' ({} nodes): device origin {:?} m, position scale {}, force scale {}",
            model.name, model.nodes, m.origin_m, m.position_scale, m.force_scale
        );
    }
    if !model.tool_follows_haptics() {
        tracing::warn!("the core's scene does not drive its tool from a haptics process: its force will stay zero");
    }
    Ok(m)
}

/// Checks the options that do not depend on the device or the core.
fn check_options(args: &Args) -> anyhow::Result<()> {
    if let Some(s) = args.seconds
        && !(s > 0.0 && s <= MAX_RUN_S)
    {
        bail!("--seconds {}: must be a number of seconds above 0 and at most {MAX_RUN_S:e}", show(s));
    }
    let (shortest, longest) = BLADE_LENGTH_MM;
    if !(shortest..=longest).contains(&args.blade_length_mm) {
        bail!(
            "--blade-length-mm {}: must be a blade length from {shortest} to {longest} mm",
            show(args.blade_length_mm)
        );
    }
    if !(0.0..=MAX_WAIT_CORE_S).contains(&args.wait_core_s) {
        bail!(
            "--wait-core-s {}: must be a number of seconds from 0 to {MAX_WAIT_CORE_S} (one day)",
            show(args.wait_core_s)
        );
    }
    Ok(())
}

/// Says which of the device's reported limits its class ceilings lowered, and checks
/// --max-force against the limit in force.
fn check_limits(args: &Args, device: &dyn HapticDevice) -> anyhow::Result<()> {
    let (held, clamps) = within_ceilings(device.info());
    let name = &device.info().name;
    for clamp in &clamps {
        tracing::warn!("haptic device '{name}': {clamp}");
    }
    if let Some(cap) = args.max_force {
        check_force_cap(cap, held.max_force_n)
            .map_err(|e| anyhow::anyhow!("--max-force {e}, for haptic device '{name}'"))?;
    }
    Ok(())
}

/// Watches the device loop's calls from a thread of its own: a call blocked longer than
/// [`DEVICE_CALL_LIMIT_NS`] is reported and the device's emergency stop called; if the call
/// is still blocked when the run should end (`deadline_ns`, or a stop signal), the process
/// exits with code 3, since the loop cannot.
struct Watchdog {
    finished: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<()>,
}

impl Watchdog {
    fn start(
        watch: Arc<CallWatch>,
        stop: Option<Arc<dyn EmergencyStop>>,
        device: String,
        deadline_ns: Option<u64>,
    ) -> Self {
        let finished = Arc::new(AtomicBool::new(false));
        let done = finished.clone();
        let thread = std::thread::spawn(move || {
            let mut reported = None;
            while !done.load(Ordering::Acquire) {
                std::thread::sleep(std::time::Duration::from_millis(1));
                let now = now_ns();
                let Some(stall) = watch.blocked(now, DEVICE_CALL_LIMIT_NS) else { continue };
                if reported != Some(stall.started_ns) {
                    reported = Some(stall.started_ns);
                    let action = match &stop {
                        Some(s) => {
                            s.zero_force();
                            "emergency stop sent (zero force)"
                        }
                        None => {
                            "the device has no emergency stop: it holds its last command until its own watchdog acts"
                        }
                    };
                    tracing::error!(
                        "haptics: device '{device}' call {} has not returned after {:.1} ms (limit {:.0} ms): fault; {action}",
                        stall.call,
                        stall.blocked_ns as f64 / 1e6,
                        DEVICE_CALL_LIMIT_NS as f64 / 1e6
                    );
                }
                let ended = deadline_ns.is_some_and(|d| now >= d) || STOP.load(Ordering::Relaxed);
                if ended && !done.load(Ordering::Acquire) {
                    tracing::error!(
                        "haptics: device '{device}' still blocked in {} after {:.3} s; the run is over: exiting without a report (code 3)",
                        stall.call,
                        stall.blocked_ns as f64 / 1e9
                    );
                    std::process::exit(3);
                }
            }
        });
        Self { finished, thread }
    }

    /// The loop returned: stop watching.
    fn finish(self) {
        self.finished.store(true, Ordering::Release);
        let _ = self.thread.join();
    }
}

/// Ends the process (code 2) if opening the device has not returned by the end of the run
/// (`--seconds`): a plugin's `lamina_device_open` that blocks must not outlast it.
fn guard_open(seconds: Option<f64>, device: &str) -> Arc<AtomicBool> {
    let opened = Arc::new(AtomicBool::new(false));
    if let Some(s) = seconds {
        let (done, device) = (opened.clone(), device.to_string());
        let deadline = now_ns().saturating_add((s * 1e9) as u64);
        std::thread::spawn(move || {
            while !done.load(Ordering::Acquire) {
                if now_ns() >= deadline {
                    eprintln!(
                        "lamina-haptics: haptic device '{device}': opening it has not returned within --seconds {s}: exiting"
                    );
                    std::process::exit(2);
                }
                std::thread::sleep(std::time::Duration::from_millis(10));
            }
        });
    }
    opened
}

fn run(args: &Args) -> anyhow::Result<bool> {
    check_options(args)?;
    let opened = guard_open(args.seconds, &args.device);
    let device = open_device(&args.device, &args.device_args);
    opened.store(true, Ordering::Release);
    let (mut device, script_s) =
        device.map_err(anyhow::Error::msg).with_context(|| format!("haptic device '{}'", args.device))?;
    check_limits(args, device.as_ref())?;
    if let (Some(tool), Some(_)) = (args.tool, device.tool_kind()) {
        bail!(
            "--tool {tool}: haptic device '{}' names the tool itself (the trajectory's kind column); drop --tool or the column",
            args.device
        );
    }
    let scene = args.scene.as_deref().map(SceneFile::read).transpose()?;
    let context = RunContext::start(scene);
    let seconds = args.seconds.or(script_s.map(|s| s + 0.2));
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&args.prefix)).context("bridge")?;
    let _ = install_stop_handler(&STOP);
    let mapping = match args.origin {
        Some(origin) => DeviceMapping::y_up_model(origin),
        None => device_mapping_from_core(args, &bridge)?,
    };
    let (tx, rx) = crossbeam::channel::bounded::<SafetyEvent>(1024);
    let quiet = args.quiet;
    let logger = std::thread::spawn(move || {
        let mut first: Option<u64> = None;
        for ev in rx {
            let t0 = *first.get_or_insert(ev.time_ns);
            // Faults are said even with --quiet.
            if !quiet || ev.kind.is_fault() {
                tracing::warn!("haptics: [{:>9.3} ms, tick {}] {}", (ev.time_ns - t0) as f64 / 1e6, ev.tick, ev.kind);
            }
        }
    });
    // Started before the real-time setup, so that it is neither pinned with the loop nor
    // SCHED_FIFO: it runs while the loop's thread is stuck in a device call.
    let watch = Arc::new(CallWatch::new());
    let deadline_ns = seconds.map(|s| now_ns().saturating_add((s * 1e9) as u64));
    let watchdog = Watchdog::start(watch.clone(), device.emergency_stop(), device.info().name.clone(), deadline_ns);
    let mut request = RealtimeRequest::new();
    request.cpu = args.cpu;
    if args.fifo > 0 {
        request = request.fifo_priority(args.fifo);
    }
    let setup = RealtimeSetup::apply(&request.lock_memory());
    if !args.quiet {
        print!("{setup}");
    }
    let trace_capacity = match (&args.trace_csv, seconds) {
        (Some(_), Some(s)) => (s.min(TRACE_SECONDS) * args.rate_hz as f64) as usize + 16,
        (Some(_), None) => (TRACE_SECONDS * args.rate_hz as f64) as usize,
        _ => 0,
    };
    let cfg = HapticsConfig {
        rate_hz: args.rate_hz,
        mapping,
        tool_radius_m: args.tool_radius,
        tool_kind: args.tool.unwrap_or_default(),
        blade_length_m: args.blade_length_mm * 1e-3,
        max_force_n: args.max_force,
        trace_capacity,
        passivity_control: !args.no_passivity_control,
    };
    let name = device.info().name.clone();
    let limit = match seconds {
        Some(s) => RunLimit::duration_ns((s * 1e9) as u64).and_stop_flag(&STOP),
        None => RunLimit::until_stopped(&STOP),
    };
    let topology = TopologyWatch::start(&args.prefix);
    let report = run_device_loop(device.as_mut(), &bridge, &cfg, limit, Some(&tx), Some(&watch));
    watchdog.finish();
    let model = topology.finish();
    let report = report?;
    drop(tx);
    let _ = logger.join();
    print_report(&report, args.rate_hz, &name);
    if let Some(path) = &args.report {
        let c = ReportContext { run: &context, prefix: &args.prefix, device: &name, rate_hz: args.rate_hz, model };
        let text = serde_json::to_string_pretty(&report_json(&report, &c)).unwrap_or_default();
        std::fs::write(path, text + "\n").with_context(|| format!("writing the report {}", path.display()))?;
        tracing::info!("report written to {}", path.display());
    }
    if let Some(path) = &args.trace_csv {
        write_trace(&report, path).with_context(|| format!("writing the trace {}", path.display()))?;
        tracing::info!("trace written to {} ({} ticks)", path.display(), report.trace.len());
    }
    match &report.device_error {
        Some(e) => {
            tracing::error!("haptics: device '{name}' failed: {e}. Force set to zero; the core keeps running.");
            Ok(false)
        }
        None => Ok(true),
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    lamina_rt::init_logging(args.log_level);
    match run(&args) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(3),
        Err(e) => {
            eprintln!("lamina-haptics: {e:#}");
            ExitCode::from(2)
        }
    }
}
