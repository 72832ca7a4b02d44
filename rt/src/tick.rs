//! What one tick of a [`FixedRateLoop`](crate::FixedRateLoop) looks like:
//! [`TickInfo`] (given to the body before it runs), [`TickSample`] (the
//! measured tick, after it ran) and [`TickObserver`] (who receives samples,
//! e.g. the [`DeadlineMonitor`](crate::DeadlineMonitor)).
//!
//! All times are ns on the loop's [`Clock`](crate::Clock) time line.

/// What the loop body is told about the tick it is running.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TickInfo {
    /// Number of this tick: 0 for the first tick the loop ran, +1 per tick
    /// run. Skipped periods do not get a tick number.
    pub tick: u64,
    /// Grid slot of this tick: `scheduled_ns == origin_ns + slot * period_ns`.
    /// Equal to `tick` until a period is skipped ([`OverrunPolicy::Skip`](crate::OverrunPolicy::Skip)).
    pub slot: u64,
    /// The absolute deadline this tick was scheduled for, ns.
    pub scheduled_ns: u64,
    /// When the loop woke up to run this tick, ns (`>= scheduled_ns` for a
    /// correct clock).
    pub wake_ns: u64,
    /// `wake_ns - scheduled_ns` (0 if the clock woke early), ns.
    pub lateness_ns: u64,
}

/// One measured tick, as handed to a [`TickObserver`] after the body returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TickSample {
    /// What the body was told.
    pub info: TickInfo,
    /// When the body returned, ns.
    pub end_ns: u64,
    /// `end_ns - info.wake_ns`: time spent in the body, ns.
    pub compute_ns: u64,
    /// This tick's deadline: `info.scheduled_ns + period_ns`, the time the next
    /// grid slot is due, ns.
    pub deadline_ns: u64,
    /// Nominal loop period, ns.
    pub period_ns: u64,
    /// `info.wake_ns` minus the previous tick's wake time, ns; `None` for the
    /// first tick of the loop.
    pub actual_period_ns: Option<u64>,
    /// Periods skipped just before this tick ([`OverrunPolicy::Skip`](crate::OverrunPolicy::Skip)),
    /// in the same run call. Counts belong to [`TickObserver::on_skip`], which
    /// also hears of skips that end a run (a stall crossing the run's window).
    pub skipped_before: u64,
    /// `true` if this tick's deadline had already passed when the loop came to
    /// wait for it, so it ran at once ([`OverrunPolicy::CatchUp`](crate::OverrunPolicy::CatchUp)).
    pub caught_up: bool,
}

/// Receives every [`TickSample`] of a [`FixedRateLoop`](crate::FixedRateLoop) run.
///
/// ## Correctness
///
/// `on_tick` runs inside the real-time loop, between two ticks: it must not
/// allocate, lock or do I/O.
pub trait TickObserver {
    /// Called once per tick, after the body returned.
    fn on_tick(&mut self, sample: &TickSample);

    /// Called when the loop drops `periods` missed grid slots
    /// ([`OverrunPolicy::Skip`](crate::OverrunPolicy::Skip)), at the moment it
    /// skips them: before the tick that follows, or before the run returns
    /// when the realigned deadline falls outside the run's window. Every
    /// skipped slot is reported here exactly once. Default: nothing.
    fn on_skip(&mut self, periods: u64) {
        let _ = periods;
    }
}

/// The no-op observer: records nothing.
impl TickObserver for () {
    fn on_tick(&mut self, _sample: &TickSample) {}
}

impl<T: TickObserver + ?Sized> TickObserver for &mut T {
    fn on_tick(&mut self, sample: &TickSample) {
        (**self).on_tick(sample);
    }

    fn on_skip(&mut self, periods: u64) {
        (**self).on_skip(periods);
    }
}
