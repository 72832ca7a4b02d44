//! The device loop: read the handle, send the pose to the core, render force from the core's
//! latest contact model, command the device, on absolute deadlines.

use core::ops::ControlFlow;

use crossbeam::channel::Sender;
use hdrhistogram::Histogram;
use lamina_rt::{DeadlineMonitor, FixedRateLoop, MonitorConfig, MonotonicClock, OverrunPolicy, RunLimit};

use super::mapping::DeviceMapping;
use super::renderer::{ForceRenderer, RenderLimits};
use super::safety::{SafetyCounts, SafetyEvent};
use crate::device::{DeviceError, HapticDevice};
use lamina_bridge::wire::ToolCommand;
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
    /// Upper bound on force below the device's own limit, N. Default: none.
    pub max_force_n: Option<f64>,
    /// Rows of the per-tick trace kept in memory (allocated before the loop). Default 0.
    pub trace_capacity: usize,
}

impl Default for HapticsConfig {
    fn default() -> Self {
        Self {
            rate_hz: 4000,
            mapping: DeviceMapping::y_up_model([0.0; 3]),
            tool_radius_m: 0.0,
            max_force_n: None,
            trace_capacity: 0,
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
    /// Tool commands sent to the core.
    pub commands_sent: u64,
    /// Failed publishes or receives.
    pub port_failures: u64,
    /// Largest force norm commanded, N.
    pub max_force_n: f64,
    /// The limits that were in force.
    pub limits: RenderLimits,
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
}

/// Runs the device loop until `limit`, then commands zero force and returns the report.
///
/// Per tick: sample the device; publish the pose (model frame) on `tool`; take the newest
/// `feedback`; render and command the force. A device error ends the loop (the error is in
/// the report, the core is untouched). Safety events go to `events` without blocking.
pub fn run_device_loop(
    device: &mut dyn HapticDevice,
    bridge: &Bridge,
    cfg: &HapticsConfig,
    limit: RunLimit<'_>,
    events: Option<&Sender<SafetyEvent>>,
) -> Result<HapticsReport, HapticsStartError> {
    let tool = ToolPublisher::create(bridge).map_err(HapticsStartError::Port)?;
    let feedback = FeedbackSubscriber::create(bridge).map_err(HapticsStartError::Port)?;
    let mut lp = FixedRateLoop::try_new(MonotonicClock::new(), cfg.rate_hz, OverrunPolicy::Skip)
        .map_err(|e| HapticsStartError::Rate(e.to_string()))?;
    let info = device.info().clone();
    let limits_ok = [info.max_force_n, info.max_stiffness_n_per_m, info.max_damping_n_s_per_m]
        .iter()
        .all(|v| v.is_finite() && *v >= 0.0)
        && info.max_force_n > 0.0;
    if !limits_ok {
        return Err(HapticsStartError::DeviceLimits(format!(
            "'{}' reports max force {} N, stiffness {} N/m, damping {} N s/m",
            info.name, info.max_force_n, info.max_stiffness_n_per_m, info.max_damping_n_s_per_m
        )));
    }
    let mut limits = RenderLimits::for_device(&info, lp.period_ns());
    if let Some(cap) = cfg.max_force_n.filter(|c| c.is_finite() && *c > 0.0) {
        limits.max_force_n = limits.max_force_n.min(cap);
    }
    let mut renderer = ForceRenderer::new(limits, cfg.mapping);
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
    lp.run(limit, &mut monitor, |info| {
        let state = match device.read() {
            Ok(s) => s,
            Err(e) => {
                device_error = Some(e);
                return ControlFlow::Break(());
            }
        };
        let pose_ok = state.position_m.iter().chain(state.orientation.iter()).all(|v| v.is_finite());
        if pose_ok {
            let cmd = ToolCommand {
                sequence: commands_sent,
                time_ns: info.wake_ns,
                position: cfg.mapping.to_model(state.position_m),
                orientation: cfg.mapping.orientation_to_model(state.orientation),
                buttons: state.buttons,
                reserved: 0,
                tool_radius_m: cfg.tool_radius_m,
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
        let position = if pose_ok { state.position_m } else { [f64::NAN; 3] };
        let (out, event) = renderer.render_with_event(position, now_ns());
        if let Some(kind) = event {
            emit(info.tick, kind);
        }
        if let Err(e) = device.write_force(out.force_n) {
            device_error = Some(e);
            return ControlFlow::Break(());
        }
        let written = now_ns();
        if let Some(p) = fresh_publish_ns {
            let _ = latency.record(written.saturating_sub(p).max(1));
        }
        let n = (out.force_n[0].powi(2) + out.force_n[1].powi(2) + out.force_n[2].powi(2)).sqrt();
        max_force = max_force.max(n);
        if trace.len() < trace.capacity() {
            trace.push(TraceRow {
                time_ns: written,
                position_dev_m: state.position_m,
                force_dev_n: out.force_n,
                gain: out.gain,
                in_contact: out.in_contact,
                core_tick,
            });
        }
        ControlFlow::Continue(())
    });
    // Leave the device at rest whatever happened (a vanished device may refuse).
    let _ = device.write_force([0.0; 3]);
    let mut safety = renderer.counts;
    safety.events_dropped = dropped;
    Ok(HapticsReport {
        monitor,
        core_to_device_ns: latency,
        safety,
        commands_sent,
        port_failures,
        max_force_n: max_force,
        limits,
        trace,
        device_error,
    })
}
