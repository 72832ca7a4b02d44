//! [`DeadlineMonitor`]: per-tick timing statistics for a
//! [`FixedRateLoop`](crate::FixedRateLoop).
//!
//! Per tick it records wake-up lateness, compute time, actual period and send
//! time into HDR histograms (ns, 3 significant digits), counts frame-budget
//! misses, keeps the [`WORST_TICKS`](crate::WORST_TICKS) worst ticks and,
//! optionally, a ring of individual [`TickRecord`]s. All memory is allocated
//! when the monitor is created; recording never allocates, locks or does I/O.
//!
//! # Examples
//!
//! ```
//! use std::ops::ControlFlow;
//! use lamina_rt::{DeadlineMonitor, FakeClock, FixedRateLoop, MonitorConfig, OverrunPolicy, RunLimit};
//!
//! // Tick 2 computes for 1.5 periods.
//! let clock = FakeClock::new(0).with_compute(|tick| if tick == 2 { 1_500_000 } else { 100_000 });
//! let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::Skip);
//! let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(lp.period_ns()));
//! lp.run(RunLimit::ticks(10), &mut monitor, |info| {
//!     clock.spend(info.tick);
//!     ControlFlow::Continue(())
//! });
//! let summary = monitor.summary();
//! assert_eq!((summary.ticks, summary.misses, summary.skipped_periods), (10, 1, 1));
//! assert_eq!(summary.worst.as_slice()[0].tick, 2);
//! println!("{summary}");
//! ```

use std::fmt;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use hdrhistogram::Histogram;

use crate::clock::Clock;
use crate::ring::{TickRecord, TickRecordRing};
use crate::summary::{MonitorSummary, Percentiles};
use crate::tick::{TickObserver, TickSample};
use crate::worst::{WorstTick, WorstTicks};

/// Default nominal period: 1 ms (1 kHz), in ns.
pub const DEFAULT_PERIOD_NS: u64 = 1_000_000;
/// Default highest value the histograms resolve: 10 s, in ns. Larger values
/// are recorded as this value and counted as saturated.
pub const DEFAULT_MAX_TRACKABLE_NS: u64 = 10_000_000_000;
/// Significant decimal digits the histograms keep: 3 (0.1 % resolution).
pub const SIGNIFICANT_DIGITS: u8 = 3;

/// Settings of a [`DeadlineMonitor`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MonitorConfig {
    /// Nominal loop period, ns. Default [`DEFAULT_PERIOD_NS`] (1 ms). Only
    /// used as the default budget and in reports; each tick's deadline comes
    /// from the loop.
    pub period_ns: u64,
    /// Compute budget per tick, ns. Default `None`, meaning `period_ns`.
    pub budget_ns: Option<u64>,
    /// Highest value the histograms resolve, ns. Default
    /// [`DEFAULT_MAX_TRACKABLE_NS`] (10 s). Memory grows with its logarithm:
    /// about 200 KiB per histogram at 10 s, four histograms.
    pub max_trackable_ns: u64,
    /// Capacity of the per-tick [`TickRecord`] ring. Default 0 (no ring).
    pub record_capacity: usize,
}

impl Default for MonitorConfig {
    fn default() -> Self {
        Self::for_period_ns(DEFAULT_PERIOD_NS)
    }
}

impl MonitorConfig {
    /// Defaults for a loop of period `period_ns` ns: budget = period, 10 s
    /// range, no record ring.
    pub const fn for_period_ns(period_ns: u64) -> Self {
        Self { period_ns, budget_ns: None, max_trackable_ns: DEFAULT_MAX_TRACKABLE_NS, record_capacity: 0 }
    }

    /// Sets the compute budget per tick, ns.
    #[must_use]
    pub const fn with_budget_ns(mut self, budget_ns: u64) -> Self {
        self.budget_ns = Some(budget_ns);
        self
    }

    /// Keeps the last `capacity` ticks as [`TickRecord`]s.
    #[must_use]
    pub const fn with_record_capacity(mut self, capacity: usize) -> Self {
        self.record_capacity = capacity;
        self
    }

    /// Sets the highest value the histograms resolve, ns.
    #[must_use]
    pub const fn with_max_trackable_ns(mut self, max_ns: u64) -> Self {
        self.max_trackable_ns = max_ns;
        self
    }

    /// The effective budget: `budget_ns`, or `period_ns` when unset.
    pub const fn effective_budget_ns(&self) -> u64 {
        match self.budget_ns {
            Some(b) => b,
            None => self.period_ns,
        }
    }
}

/// Why creating a [`DeadlineMonitor`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DeadlineMonitorCreateError {
    /// `max_trackable_ns` was below 2 ns; HDR histograms need a range of at
    /// least `[1, 2]`.
    #[error("histogram range of {max_trackable_ns} ns is too small (need at least 2 ns)")]
    RangeTooSmall {
        /// The requested range, ns.
        max_trackable_ns: u64,
    },
}

/// Why writing the JSON report failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MonitorReportWriteError {
    /// Creating or writing the file failed.
    #[error("writing the deadline report failed: {0}")]
    Io(std::io::ErrorKind),
}

impl From<std::io::Error> for MonitorReportWriteError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e.kind())
    }
}

/// Lets the loop body report how long it spent sending during a tick, so the
/// monitor can keep it with the tick ([`TickRecord::send_ns`],
/// [`MonitorSummary::send`]).
///
/// Get one from [`DeadlineMonitor::send_probe`] before the loop starts and
/// move it into the body. Clones share one counter (an `Arc<AtomicU64>`):
/// reporting is a relaxed atomic add, no allocation, no lock. The monitor
/// takes and zeroes the counter when it records the tick.
#[derive(Debug, Clone, Default)]
pub struct SendProbe {
    pending_ns: Arc<AtomicU64>,
}

impl SendProbe {
    /// Adds `ns` of send time to the current tick.
    pub fn add_ns(&self, ns: u64) {
        self.pending_ns.fetch_add(ns, Ordering::Relaxed);
    }

    /// Runs `send`, adds its duration on `clock` to the current tick and
    /// returns its result.
    pub fn measure<C: Clock + ?Sized, R>(&self, clock: &C, send: impl FnOnce() -> R) -> R {
        let start = clock.now();
        let out = send();
        self.add_ns(clock.now().saturating_sub(start));
        out
    }

    fn take_ns(&self) -> u64 {
        self.pending_ns.swap(0, Ordering::Relaxed)
    }
}

/// One histogram plus exact extremes.
#[derive(Debug, Clone)]
struct Metric {
    hist: Histogram<u64>,
    min_ns: u64,
    max_ns: u64,
    /// Exact sum of the values, for an exact mean without scanning the histogram.
    sum_ns: u128,
    saturated: u64,
}

impl Metric {
    fn new(max_trackable_ns: u64) -> Result<Self, DeadlineMonitorCreateError> {
        let hist = Histogram::new_with_bounds(1, max_trackable_ns, SIGNIFICANT_DIGITS)
            .map_err(|_| DeadlineMonitorCreateError::RangeTooSmall { max_trackable_ns })?;
        Ok(Self { hist, min_ns: u64::MAX, max_ns: 0, sum_ns: 0, saturated: 0 })
    }

    /// Never allocates: the histogram does not auto-resize and values above
    /// its range are clamped.
    fn record(&mut self, ns: u64) {
        if ns > self.hist.high() {
            self.saturated += 1;
        }
        self.hist.saturating_record(ns);
        self.min_ns = self.min_ns.min(ns);
        self.max_ns = self.max_ns.max(ns);
        self.sum_ns += u128::from(ns);
    }

    fn percentiles(&self) -> Percentiles {
        let count = self.hist.len();
        if count == 0 {
            return Percentiles::default();
        }
        let mut q = [0u64; 4];
        for (slot, v) in q.iter_mut().zip(self.hist.value_at_quantiles([0.5, 0.9, 0.99, 0.999])) {
            *slot = v.min(self.max_ns);
        }
        Percentiles {
            count,
            min_ns: self.min_ns,
            p50_ns: q[0],
            p90_ns: q[1],
            p99_ns: q[2],
            p999_ns: q[3],
            max_ns: self.max_ns,
            // Rounded to the nearest ns; a mean never exceeds the max, so it fits.
            mean_ns: ((self.sum_ns + u128::from(count / 2)) / u128::from(count)) as u64,
            saturated: self.saturated,
        }
    }

    fn reset(&mut self) {
        self.hist.reset();
        self.min_ns = u64::MAX;
        self.max_ns = 0;
        self.sum_ns = 0;
        self.saturated = 0;
    }
}

/// Per-tick timing statistics; a [`TickObserver`] for
/// [`FixedRateLoop::run`](crate::FixedRateLoop::run).
///
/// # What is recorded, per tick (ns)
///
/// - **lateness** = wake time − scheduled time;
/// - **compute** = body end − wake time;
/// - **period** = wake time − previous wake time (not for the first tick);
/// - **send** = what the body reported through the [`SendProbe`] (0 if
///   nothing).
///
/// # Misses, precisely
///
/// A tick's *deadline* is its scheduled time plus one period, the time the
/// next slot is due. A tick **misses** if
///
/// - its compute time is over budget: `compute_ns > budget_ns` (a budget
///   miss), or
/// - it finished after its deadline: `end_ns > deadline_ns` (a deadline
///   miss), which also catches ticks that computed within budget but started
///   so late that they ended past the deadline.
///
/// A tick that does both is one miss. Finishing exactly at the deadline is
/// not a miss. With the default budget (= period) every budget miss is also a
/// deadline miss.
///
/// ## Correctness
///
/// Recording ([`TickObserver::on_tick`]) and [`summary`](Self::summary)
/// never allocate. `summary` scans each histogram once, up to its p99.9
/// bucket (of about 25 000 at the default 10 s range): a few tens of µs for
/// the four histograms. Fine once a second; do it in a tick with slack.
#[derive(Debug, Clone)]
pub struct DeadlineMonitor {
    config: MonitorConfig,
    lateness: Metric,
    compute: Metric,
    period: Metric,
    send: Metric,
    ticks: u64,
    misses: u64,
    budget_misses: u64,
    deadline_misses: u64,
    skipped_periods: u64,
    caught_up_ticks: u64,
    worst: WorstTicks,
    records: TickRecordRing,
    send_probe: SendProbe,
}

impl DeadlineMonitor {
    /// A monitor with all memory allocated up front.
    ///
    /// ## Panics
    ///
    /// If `config.max_trackable_ns < 2`. [`try_new`](Self::try_new) returns
    /// an error instead.
    pub fn new(config: MonitorConfig) -> Self {
        match Self::try_new(config) {
            Ok(m) => m,
            Err(e) => panic!("DeadlineMonitor::new: {e}"),
        }
    }

    /// A monitor, or an error if `config.max_trackable_ns < 2`.
    pub fn try_new(config: MonitorConfig) -> Result<Self, DeadlineMonitorCreateError> {
        let max = config.max_trackable_ns;
        Ok(Self {
            config,
            lateness: Metric::new(max)?,
            compute: Metric::new(max)?,
            period: Metric::new(max)?,
            send: Metric::new(max)?,
            ticks: 0,
            misses: 0,
            budget_misses: 0,
            deadline_misses: 0,
            skipped_periods: 0,
            caught_up_ticks: 0,
            worst: WorstTicks::new(),
            records: TickRecordRing::with_capacity(config.record_capacity),
            send_probe: SendProbe::default(),
        })
    }

    /// The settings the monitor was created with.
    pub fn config(&self) -> &MonitorConfig {
        &self.config
    }

    /// A handle the loop body uses to report send time per tick.
    pub fn send_probe(&self) -> SendProbe {
        self.send_probe.clone()
    }

    /// Ticks recorded since creation or the last [`reset`](Self::reset).
    pub fn ticks(&self) -> u64 {
        self.ticks
    }

    /// Misses counted since creation or the last [`reset`](Self::reset).
    pub fn misses(&self) -> u64 {
        self.misses
    }

    /// The per-tick record ring (empty if `record_capacity` is 0).
    pub fn records(&self) -> &TickRecordRing {
        &self.records
    }

    /// Forgets everything recorded (e.g. after a warm-up), keeping all
    /// memory. Does not allocate.
    pub fn reset(&mut self) {
        for m in [&mut self.lateness, &mut self.compute, &mut self.period, &mut self.send] {
            m.reset();
        }
        self.ticks = 0;
        self.misses = 0;
        self.budget_misses = 0;
        self.deadline_misses = 0;
        self.skipped_periods = 0;
        self.caught_up_ticks = 0;
        self.worst.clear();
        self.records.clear();
        self.send_probe.take_ns();
    }

    /// Counts `periods` skipped grid slots. This is what
    /// [`TickObserver::on_skip`] calls; [`record`](Self::record) does not
    /// count [`TickSample::skipped_before`], so a skip that ends a run (a
    /// stall crossing a report boundary) is counted too, and only once.
    pub fn record_skip(&mut self, periods: u64) {
        self.skipped_periods += periods;
    }

    /// Records one tick. This is what [`TickObserver::on_tick`] calls.
    pub fn record(&mut self, s: &TickSample) {
        let lateness_ns = s.info.lateness_ns;
        let send_ns = self.send_probe.take_ns();
        self.ticks += 1;
        self.lateness.record(lateness_ns);
        self.compute.record(s.compute_ns);
        self.send.record(send_ns);
        if let Some(p) = s.actual_period_ns {
            self.period.record(p);
        }

        let budget_miss = s.compute_ns > self.config.effective_budget_ns();
        let deadline_miss = s.end_ns > s.deadline_ns;
        self.budget_misses += u64::from(budget_miss);
        self.deadline_misses += u64::from(deadline_miss);
        self.misses += u64::from(budget_miss || deadline_miss);
        self.caught_up_ticks += u64::from(s.caught_up);

        self.worst.offer(WorstTick { tick: s.info.tick, lateness_ns, compute_ns: s.compute_ns });
        self.records.push(TickRecord {
            tick: s.info.tick,
            wake_ns: s.info.wake_ns,
            lateness_ns,
            compute_ns: s.compute_ns,
            send_ns,
        });
    }

    /// A snapshot of everything recorded. Does not allocate (see the
    /// type-level Correctness note for its cost).
    pub fn summary(&self) -> MonitorSummary {
        MonitorSummary {
            ticks: self.ticks,
            period_ns: self.config.period_ns,
            budget_ns: self.config.effective_budget_ns(),
            misses: self.misses,
            budget_misses: self.budget_misses,
            deadline_misses: self.deadline_misses,
            skipped_periods: self.skipped_periods,
            caught_up_ticks: self.caught_up_ticks,
            lateness: self.lateness.percentiles(),
            compute: self.compute.percentiles(),
            period: self.period.percentiles(),
            send: self.send.percentiles(),
            worst: self.worst,
        }
    }

    /// The summary as pretty-printed JSON (allocates: for exit time).
    pub fn report_json(&self) -> String {
        summary_json(&self.summary())
    }

    /// Writes [`report_json`](Self::report_json) to `path` (allocates and
    /// does I/O: for exit time).
    pub fn write_report(&self, path: impl AsRef<Path>) -> Result<(), MonitorReportWriteError> {
        let mut json = self.report_json();
        json.push('\n');
        std::fs::write(path, json)?;
        Ok(())
    }
}

/// `summary` as pretty-printed JSON.
fn summary_json(summary: &MonitorSummary) -> String {
    // A struct of integers and a sequence of structs of integers always
    // serialises: there are no maps with non-string keys and no fallible
    // custom serialisers.
    serde_json::to_string_pretty(summary).unwrap_or_default()
}

impl TickObserver for DeadlineMonitor {
    fn on_tick(&mut self, sample: &TickSample) {
        self.record(sample);
    }

    fn on_skip(&mut self, periods: u64) {
        self.record_skip(periods);
    }
}

impl fmt::Display for DeadlineMonitor {
    /// The [`MonitorSummary`] table.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(&self.summary(), f)
    }
}
