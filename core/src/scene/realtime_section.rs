//! The scene's `[realtime]` table: how the core process runs its fixed-rate loop.

use super::section::FieldError;
use serde::Deserialize;

/// What the real-time loop does when a tick overruns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OverrunChoice {
    /// Drop missed periods and realign to the grid.
    Skip,
    /// Run missed ticks back to back until on time.
    CatchUp,
}

/// Real-time settings of the core process.
#[derive(Clone, Debug, PartialEq)]
pub struct RealtimeSettings {
    /// CPU to pin the loop to. Default: the last CPU.
    pub cpu: Option<usize>,
    /// CPU of a standby thread that runs a tick the loop's thread has not started
    /// [`STANDBY_DELAY_US`] after its deadline (as when the host has stopped the loop's virtual
    /// CPU); it must differ from the loop's. Default `None`: no standby.
    pub standby_cpu: Option<usize>,
    /// SCHED_FIFO priority (1–99). Default 80; `None` in the file as `0`.
    pub fifo_priority: Option<i32>,
    /// `mlockall` the process. Default true.
    pub lock_memory: bool,
    /// Frame budget, µs. Default: the period.
    pub budget_us: Option<f64>,
    /// Overrun policy. Default skip.
    pub overrun: OverrunChoice,
    /// Longest single sleep while the loop waits for its next tick, µs; `0` sleeps to the
    /// tick in one call. Default 100: on a virtual machine a CPU idle for longer than the
    /// host's halt-polling window (200 µs in KVM) can be woken milliseconds late.
    pub sleep_slice_us: u32,
    /// Ticks from one node frame to the next on `<prefix>/nodes`, 1 to 1,000,000. Default
    /// 1: a frame every tick. A viewer draws at its display's rate (60 Hz takes one frame
    /// in 16 at 1 kHz); a larger value leaves the writes of the others out of the loop's
    /// ticks. The haptic feedback goes out every tick whatever this is.
    pub node_frame_every: u32,
    /// A tick that has used more than this since its scheduled start (wake-up lateness plus
    /// the step so far), µs, does not write the node frame due on it: the frame goes out on
    /// the first later tick within the cutoff, or is shed when the next one falls due first.
    /// Default: half the budget (500 µs at 1 kHz); at least [`MIN_NODE_FRAME_CUTOFF_US`]. The
    /// haptic feedback is never held back.
    pub node_frame_cutoff_us: Option<f64>,
}

impl RealtimeSettings {
    /// [`node_frame_cutoff_us`](Self::node_frame_cutoff_us) for a loop of period
    /// `period_us`, µs: the value set, or half the budget.
    pub fn node_frame_cutoff_us(&self, period_us: f64) -> f64 {
        self.node_frame_cutoff_us.unwrap_or(0.5 * self.budget_us.unwrap_or(period_us))
    }
}

/// Default [`RealtimeSettings::sleep_slice_us`], µs.
const DEFAULT_SLEEP_SLICE_US: u32 = 100;

/// How long after a tick's deadline the standby ([`RealtimeSettings::standby_cpu`]) takes a
/// tick the loop's thread has not started, µs: past the few µs of a wake-up on time, well
/// inside the 500 µs node-frame cutoff.
pub const STANDBY_DELAY_US: u32 = 250;

/// Largest [`RealtimeSettings::sleep_slice_us`], µs (one second).
const MAX_SLEEP_SLICE_US: u32 = 1_000_000;

/// Smallest [`RealtimeSettings::node_frame_cutoff_us`], µs: a tick's wake-up alone takes
/// longer, so a smaller cutoff (1e-300 rounds to 0 ns) would only ever shed frames.
pub const MIN_NODE_FRAME_CUTOFF_US: f64 = 1.0;

/// Largest [`RealtimeSettings::node_frame_every`], ticks.
const MAX_NODE_FRAME_EVERY: u32 = 1_000_000;

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRealtime {
    cpu: Option<usize>,
    standby_cpu: Option<usize>,
    fifo_priority: Option<i32>,
    lock_memory: Option<bool>,
    budget_us: Option<f64>,
    overrun: Option<String>,
    sleep_slice_us: Option<u32>,
    node_frame_every: Option<u32>,
    node_frame_cutoff_us: Option<f64>,
}

/// The `[realtime]` table over the defaults.
pub(super) fn realtime_settings(r: RawRealtime) -> Result<RealtimeSettings, FieldError> {
    let overrun = match r.overrun.as_deref().unwrap_or("skip") {
        "skip" => OverrunChoice::Skip,
        "catch_up" | "catch-up" => OverrunChoice::CatchUp,
        _ => return Err(FieldError::new("realtime.overrun", "\"skip\" or \"catch_up\"")),
    };
    if r.budget_us.is_some_and(|b| !(b.is_finite() && b > 0.0)) {
        return Err(FieldError::new("realtime.budget_us", "must be finite and positive"));
    }
    let fifo_priority = match r.fifo_priority {
        None => Some(80),
        Some(0) => None,
        Some(p) if (1..=99).contains(&p) => Some(p),
        Some(_) => return Err(FieldError::new("realtime.fifo_priority", "0 (off) or 1..=99")),
    };
    let sleep_slice_us = r.sleep_slice_us.unwrap_or(DEFAULT_SLEEP_SLICE_US);
    if !(sleep_slice_us == 0 || (10..=MAX_SLEEP_SLICE_US).contains(&sleep_slice_us)) {
        return Err(FieldError::new("realtime.sleep_slice_us", "0 (one sleep) or 10..=1000000"));
    }
    let node_frame_every = r.node_frame_every.unwrap_or(1);
    if !(1..=MAX_NODE_FRAME_EVERY).contains(&node_frame_every) {
        return Err(FieldError::new("realtime.node_frame_every", "1..=1000000 ticks"));
    }
    if let Some(c) = r.node_frame_cutoff_us.filter(|c| !(c.is_finite() && *c >= MIN_NODE_FRAME_CUTOFF_US)) {
        return Err(FieldError::new(
            "realtime.node_frame_cutoff_us",
            format!("{c:e} µs: must be finite and at least {MIN_NODE_FRAME_CUTOFF_US} µs"),
        ));
    }
    if r.standby_cpu.is_some() && r.standby_cpu == r.cpu {
        return Err(FieldError::new("realtime.standby_cpu", "must differ from realtime.cpu (the loop's)"));
    }
    Ok(RealtimeSettings {
        cpu: r.cpu,
        standby_cpu: r.standby_cpu,
        fifo_priority,
        lock_memory: r.lock_memory.unwrap_or(true),
        budget_us: r.budget_us,
        overrun,
        sleep_slice_us,
        node_frame_every,
        node_frame_cutoff_us: r.node_frame_cutoff_us,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(body: &str) -> Result<RealtimeSettings, FieldError> {
        realtime_settings(toml::from_str(body).expect("well-formed"))
    }

    #[test]
    fn realtime_section_defaults_and_values_works() {
        let d = parse("").unwrap();
        assert_eq!(
            d,
            RealtimeSettings {
                cpu: None,
                standby_cpu: None,
                fifo_priority: Some(80),
                lock_memory: true,
                budget_us: None,
                overrun: OverrunChoice::Skip,
                sleep_slice_us: 100,
                node_frame_every: 1,
                node_frame_cutoff_us: None,
            }
        );
        assert_eq!(d.node_frame_cutoff_us(1_000.0), 500.0, "half the period");
        let r = parse("cpu = 1\nstandby_cpu = 0\nfifo_priority = 0\nlock_memory = false\nbudget_us = 800.0\noverrun = \"catch_up\"\nsleep_slice_us = 0\nnode_frame_every = 16\nnode_frame_cutoff_us = 300.0\n")
            .unwrap();
        assert_eq!((r.cpu, r.standby_cpu, r.fifo_priority, r.lock_memory), (Some(1), Some(0), None, false));
        assert_eq!((r.budget_us, r.overrun, r.sleep_slice_us), (Some(800.0), OverrunChoice::CatchUp, 0));
        assert_eq!((r.node_frame_every, r.node_frame_cutoff_us(1_000.0)), (16, 300.0));
        let floor = parse("node_frame_cutoff_us = 1.0\n").unwrap();
        assert_eq!(floor.node_frame_cutoff_us(1_000.0), 1.0, "the floor itself is accepted");
        let budget = parse("budget_us = 800.0\n").unwrap();
        assert_eq!(budget.node_frame_cutoff_us(1_000.0), 400.0, "half the budget");
    }

    #[test]
    fn realtime_section_bad_values_name_the_field_fails() {
        for (body, field) in [
            ("overrun = \"panic\"\n", "realtime.overrun"),
            ("cpu = 1\nstandby_cpu = 1\n", "realtime.standby_cpu"),
            ("budget_us = 0.0\n", "realtime.budget_us"),
            ("fifo_priority = 100\n", "realtime.fifo_priority"),
            ("sleep_slice_us = 5\n", "realtime.sleep_slice_us"),
            ("sleep_slice_us = 1000001\n", "realtime.sleep_slice_us"),
            ("node_frame_every = 0\n", "realtime.node_frame_every"),
            ("node_frame_every = 1000001\n", "realtime.node_frame_every"),
            ("node_frame_cutoff_us = 0.0\n", "realtime.node_frame_cutoff_us"),
            ("node_frame_cutoff_us = -5.0\n", "realtime.node_frame_cutoff_us"),
            ("node_frame_cutoff_us = nan\n", "realtime.node_frame_cutoff_us"),
            ("node_frame_cutoff_us = inf\n", "realtime.node_frame_cutoff_us"),
            ("node_frame_cutoff_us = 1e-300\n", "realtime.node_frame_cutoff_us"),
            ("node_frame_cutoff_us = 0.999\n", "realtime.node_frame_cutoff_us"),
        ] {
            assert_eq!(parse(body).expect_err(body).field, field, "{body}");
        }
    }
}
