//! The device loop: read the handle, send the pose to the core, render force from the core's
//! latest contact model, command the device, on absolute deadlines.

use core::ops::ControlFlow;

use crossbeam::channel::Sender;
use hdrhistogram::Histogram;
use lamina_rt::{DeadlineMonitor, FixedRateLoop, MonitorConfig, MonotonicClock, OverrunPolicy, RunLimit};

use super::mapping::DeviceMapping;
use super::passivity::{PassivityFigures, PassivityObserver};
use super::renderer::{ForceRenderer, RenderLimits};
use super::safety::{SafetyCounts, SafetyEvent, SafetyEventKind};
use crate::device::{DeviceError, HapticDevice, LimitClamp, norm3, within_ceilings};
use crate::watchdog::{CallWatch, DEVICE_CALL_LIMIT_NS, DeviceCall};
use lamina_bridge::wire::{ToolCommand, ToolKind};
use lamina_bridge::{Bridge, FeedbackSubscriber, PortCreateError, ToolPublisher};
use lamina_rt::now_ns;

/// Settings of one haptics run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HapticsConfig {
    /// Device loop rate, Hz. Default 4000.
    pub rate_hz: u32,
    /// Device frame → model frame.
    pub mapping: DeviceMapping,
    /// Tool tip radius sent with each command, m; 0 lets the core use its scene's. Default 0.
    pub tool_radius_m: f64,
    /// The tool sent with each command unless the device names its own
    /// ([`HapticDevice::tool_kind`]). Default: the sphere.
    pub tool_kind: ToolKind,
    /// Scalpel blade length sent with each command, m; 0 lets the core use its scene's.
    /// Default 0.
    pub blade_length_m: f64,
    /// Upper bound on force, N: above 0 and at most the device's limit (held to its class
    /// ceiling), else the loop refuses to start ([`check_force_cap`]). Default: none.
    pub max_force_n: Option<f64>,
    /// Rows of the per-tick trace kept in memory (allocated before the loop). Default 0.
    pub trace_capacity: usize,
    /// Whether the passivity controller damps the energy the rendering would create
    /// ([`PassivityObserver`]); the observer measures either way. Default true.
    pub passivity_control: bool,
}

impl Default for HapticsConfig {
    fn default() -> Self {
        Self {
            rate_hz: 4000,
            mapping: DeviceMapping::y_up_model([0.0; 3]),
            tool_radius_m: 0.0,
            tool_kind: ToolKind::Sphere,
            blade_length_m: 0.0,
            max_force_n: None,
            trace_capacity: 0,
            passivity_control: true,
        }
    }
}

/// One row of the device-loop trace.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TraceRow {
    /// `CLOCK_MONOTONIC` after the force was written, ns.
    pub time_ns: u64,
    /// Handle position, device frame, m.
    pub position_dev_m: [f64; 3],
    /// Force commanded, device frame, N.
    pub force_dev_n: [f64; 3],
    /// Staleness and onset gain, 0..=1.
    pub gain: f64,
    /// Whether the local model was in contact.
    pub in_contact: bool,
    /// Core tick of the feedback in use.
    pub core_tick: u64,
}

/// What a haptics run measured.
pub struct HapticsReport {
    /// Device-loop deadline monitor: rate, period jitter, lateness, compute.
    pub monitor: DeadlineMonitor,
    /// Core publish → force written on the device, for each new feedback message, ns.
    pub core_to_device_ns: Histogram<u64>,
    /// Safety counters.
    pub safety: SafetyCounts,
    /// The passivity observer's energy figures.
    pub passivity: PassivityFigures,
    /// Tool commands sent to the core.
    pub commands_sent: u64,
    /// Failed publishes or receives.
    pub port_failures: u64,
    /// Largest force norm commanded, N.
    pub max_force_n: f64,
    /// The limits that were in force.
    pub limits: RenderLimits,
    /// The device's class (`DeviceClass::name`), whose ceilings bound its limits.
    pub device_class: &'static str,
    /// The reported limits that were above the class ceiling, and the ceilings used.
    pub limit_clamps: Vec<LimitClamp>,
    /// Per-tick trace (first `trace_capacity` ticks).
    pub trace: Vec<TraceRow>,
    /// Why the loop ended early, if it did: the device failed.
    pub device_error: Option<DeviceError>,
}

/// Why the haptics loop could not start.
#[derive(Debug, thiserror::Error)]
pub enum HapticsStartError {
    /// The `tool` or `feedback` port could not be created.
    #[error("haptics ports: {0}")]
    Port(PortCreateError),
    /// The loop rate is invalid.
    #[error("haptics loop rate: {0}")]
    Rate(String),
    /// The device's limits are not usable (non-positive or non-finite).
    #[error("haptic device limits: {0}")]
    DeviceLimits(String),
    /// The force cap is not a usable value for this device.
    #[error("force cap: {0}")]
    ForceCap(String),
}

/// Checks an operator's force cap `cap_n` against the device's limit `device_limit_n` (its
/// reported limit held to its class ceiling): it must be finite, above 0 and at most the
/// limit. The message names the value and the valid range.
///
/// # Examples
///
/// ```
/// use lamina_haptics::check_force_cap;
///
/// assert!(check_force_cap(2.0, 8.0).is_ok());
/// for bad in [0.0, -5.0, f64::NAN, f64::INFINITY, 9.0] {
///     assert!(check_force_cap(bad, 8.0).unwrap_err().contains("0 < F <= 8 N"));
/// }
/// ```
pub fn check_force_cap(cap_n: f64, device_limit_n: f64) -> Result<(), String> {
    if cap_n.is_finite() && cap_n > 0.0 && cap_n <= device_limit_n {
        Ok(())
    } else {
        let (cap, limit) = (crate::device::show_number(cap_n), crate::device::show_number(device_limit_n));
        Err(format!("{cap} N is outside the valid range 0 < F <= {limit} N (the device's limit)"))
    }
}

/// Runs the device loop until `limit`, then commands zero force and returns the report.
///
/// Per tick: sample the device; publish the pose (model frame) on `tool`; take the newest
/// `feedback`; render the force, pass it through the passivity observer and controller
/// ([`PassivityObserver`]) and command it. A device error ends the loop (the error is in
/// the report, the core is untouched). Safety events go to `events` without blocking.
///
/// The device's limits are held to its class ceilings ([`within_ceilings`]) before anything
/// is rendered; a pose beyond the workspace radius is a fault (force fades to zero, no tool
/// command); a device call longer than [`DEVICE_CALL_LIMIT_NS`] is a fault (force restarts
/// from zero). With `watch`, every device call is stamped on it, so that another thread can
/// see a call that blocks (and act while the loop is stuck in it).
pub fn run_device_loop(
    device: &mut dyn HapticDevice,
    bridge: &Bridge,
    cfg: &HapticsConfig,
    limit: RunLimit<'_>,
    events: Option<&Sender<SafetyEvent>>,
    watch: Option<&CallWatch>,
) -> Result<HapticsReport, HapticsStartError> {
    let unwatched = CallWatch::new();
    let watch = watch.unwrap_or(&unwatched);
    let tool = ToolPublisher::create(bridge).map_err(HapticsStartError::Port)?;
    let feedback = FeedbackSubscriber::create(bridge).map_err(HapticsStartError::Port)?;
    let mut lp = FixedRateLoop::try_new(MonotonicClock::new(), cfg.rate_hz, OverrunPolicy::Skip)
        .map_err(|e| HapticsStartError::Rate(e.to_string()))?;
    let reported = device.info().clone();
    let info = &reported;
    let limits_ok = [info.max_force_n, info.max_stiffness_n_per_m, info.max_damping_n_s_per_m]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0)
        && info.max_force_n > 0.0
        && info.workspace_radius_m.is_finite()
        && info.workspace_radius_m > 0.0;
    if !limits_ok {
        return Err(HapticsStartError::DeviceLimits(format!(
            "'{}' reports max force {} N, stiffness {} N/m, damping {} N s/m, workspace {} m",
            info.name,
            info.max_force_n,
            info.max_stiffness_n_per_m,
            info.max_damping_n_s_per_m,
            info.workspace_radius_m
        )));
    }
    let (info, limit_clamps) = within_ceilings(&reported);
    let device_class = crate::device::DeviceClass::of(&info.name).name;
    let mut limits = RenderLimits::for_device(&info, lp.period_ns());
    if let Some(cap) = cfg.max_force_n {
        check_force_cap(cap, limits.max_force_n).map_err(HapticsStartError::ForceCap)?;
        limits.max_force_n = cap;
    }
    let mut renderer = ForceRenderer::new(limits, cfg.mapping);
    // The controller's damper and the renderer's coupling damping together stay within the
    // device's damping ceiling.
    let pc_damping = (info.max_damping_n_s_per_m - limits.damping_n_s_per_m).max(0.0);
    let mut passivity = PassivityObserver::new(pc_damping, cfg.passivity_control);
    let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(lp.period_ns()));
    // The tool command's publish is the tick's send time (the report's `loop.send`).
    let probe = monitor.send_probe();
    let send_clock = MonotonicClock::new();
    let mut latency = Histogram::<u64>::new_with_bounds(1, 10_000_000_000, 3).expect("valid bounds");
    let mut trace: Vec<TraceRow> = Vec::with_capacity(cfg.trace_capacity);
    let (mut commands_sent, mut port_failures, mut max_force, mut core_tick) = (0u64, 0u64, 0.0f64, 0u64);
    let mut device_error = None;
    let mut dropped = 0u64;
    let mut emit = |tick: u64, kind| {
        let ev = SafetyEvent { time_ns: now_ns(), tick, kind };
        if events.is_none_or(|tx| tx.try_send(ev).is_err()) {
            dropped += 1;
        }
    };
    let workspace_radius_m = limits.workspace_radius_m;
    // Each device call, stamped on `watch`; one that takes longer than the limit is a fault.
    let timed = |call: DeviceCall| {
        let start = now_ns();
        watch.begin(call, start);
        start
    };
    let done = |renderer: &mut ForceRenderer, call: DeviceCall, start: u64| -> Option<SafetyEventKind> {
        let end = now_ns();
        watch.end();
        let took = end.saturating_sub(start);
        (took > DEVICE_CALL_LIMIT_NS).then(|| {
            renderer.device_call_stalled(end);
            SafetyEventKind::DeviceCallStalled { call, duration_ns: took, limit_ns: DEVICE_CALL_LIMIT_NS }
        })
    };
    lp.run(limit, &mut monitor, |info| {
        let start = timed(DeviceCall::Read);
        let read = device.read();
        if let Some(kind) = done(&mut renderer, DeviceCall::Read, start) {
            emit(info.tick, kind);
        }
        let state = match read {
            Ok(s) => s,
            Err(e) => {
                device_error = Some(e);
                return ControlFlow::Break(());
            }
        };
        // A pose beyond the workspace is a fault: no tool command (the renderer fades the force).
        let pose_ok = state.position_m.iter().chain(state.orientation.iter()).all(|v| v.is_finite())
            && norm3(state.position_m) <= workspace_radius_m;
        if pose_ok {
            let cmd = ToolCommand {
                sequence: commands_sent,
                time_ns: info.wake_ns,
                position: cfg.mapping.to_model(state.position_m),
                orientation: cfg.mapping.orientation_to_model(state.orientation),
                buttons: state.buttons,
                kind: device.tool_kind().unwrap_or(cfg.tool_kind).code(),
                tool_radius_m: cfg.tool_radius_m,
                blade_length_m: cfg.blade_length_m,
            };
            match probe.measure(&send_clock, || tool.publish_polled(&cmd)) {
                Ok(_) => commands_sent += 1,
                Err(_) => port_failures += 1,
            }
        }
        let mut fresh_publish_ns = None;
        match feedback.latest() {
            Ok(Some(sample)) => {
                let fb = *sample.message();
                match renderer.accept_feedback(&fb, now_ns()) {
                    Ok(()) => {
                        fresh_publish_ns = Some(fb.publish_time_ns);
                        core_tick = fb.tick;
                    }
                    Err(kind) => emit(info.tick, kind),
                }
            }
            Ok(None) => {}
            Err(_) => port_failures += 1,
        }
        let finite = state.position_m.iter().chain(state.orientation.iter()).all(|v| v.is_finite());
        let position = if finite { state.position_m } else { [f64::NAN; 3] };
        let render_ns = now_ns();
        let (out, event) = renderer.render_with_event(position, render_ns);
        if let Some(kind) = event {
            emit(info.tick, kind);
        }
        passivity.set_gain(out.gain);
        let force = passivity.tick(pose_ok.then_some(state.position_m), render_ns, out.force_n, limits.max_force_n);
        let start = timed(DeviceCall::WriteForce);
        let wrote = device.write_force(force);
        if let Some(kind) = done(&mut renderer, DeviceCall::WriteForce, start) {
            emit(info.tick, kind);
        }
        if let Err(e) = wrote {
            device_error = Some(e);
            return ControlFlow::Break(());
        }
        let written = now_ns();
        if let Some(p) = fresh_publish_ns {
            let _ = latency.record(written.saturating_sub(p).max(1));
        }
        max_force = max_force.max(norm3(force));
        if trace.len() < trace.capacity() {
            trace.push(TraceRow {
                time_ns: written,
                position_dev_m: state.position_m,
                force_dev_n: force,
                gain: out.gain,
                in_contact: out.in_contact,
                core_tick,
            });
        }
        ControlFlow::Continue(())
    });
    // Leave the device at rest whatever happened (a vanished device may refuse).
    watch.begin(DeviceCall::WriteForce, now_ns());
    let _ = device.write_force([0.0; 3]);
    watch.end();
    let mut safety = renderer.counts;
    safety.events_dropped = dropped;
    Ok(HapticsReport {
        monitor,
        core_to_device_ns: latency,
        safety,
        passivity: *passivity.figures(),
        commands_sent,
        port_failures,
        max_force_n: max_force,
        limits,
        device_class,
        limit_clamps,
        trace,
        device_error,
    })
}
