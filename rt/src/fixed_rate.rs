//! [`FixedRateLoop`]: runs a body on a fixed grid of absolute deadlines.
//!
//! # How it works
//!
//! 1. The first [`run`](FixedRateLoop::run) anchors the grid at the clock's
//!    current time, the *origin*: slot `k` is due at `origin + k * period`.
//! 2. Each iteration computes the next deadline by `next += period` and calls
//!    [`Clock::sleep_until(next)`](Clock::sleep_until). It never sleeps "one
//!    period", so time spent in the body, or a late wake-up, never shifts
//!    later deadlines: the loop does not drift.
//! 3. If the next deadline has already passed when the loop comes to wait for
//!    it (the body overran), the [`OverrunPolicy`] decides: skip the missed
//!    slots, or run them back to back. Both are counted.
//! 4. After each tick, a [`TickSample`] (lateness, compute time, actual
//!    period, ...) goes to a [`TickObserver`] such as the
//!    [`DeadlineMonitor`](crate::DeadlineMonitor).
//!
//! The per-tick path allocates nothing, takes no lock and does no I/O
//! (`tests/no_alloc.rs` checks the allocation part).
//!
//! # Examples
//!
//! ```
//! use std::ops::ControlFlow;
//! use lamina_rt::{FakeClock, FixedRateLoop, OverrunPolicy, RunLimit, StopReason};
//!
//! let clock = FakeClock::new(0);
//! let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::Skip);
//! let mut scheduled = Vec::new();
//! let run = lp.run(RunLimit::ticks(3), &mut (), |info| {
//!     scheduled.push(info.scheduled_ns);
//!     ControlFlow::Continue(())
//! });
//! assert_eq!(scheduled, [0, 1_000_000, 2_000_000]);
//! assert_eq!(run.stop, StopReason::TickLimit);
//! ```

use std::fmt;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};

use crate::clock::Clock;
use crate::tick::{TickInfo, TickObserver, TickSample};

const NS_PER_S: u64 = 1_000_000_000;

/// What the loop does when the body overruns, i.e. when the next deadline has
/// already passed (strictly: `now > deadline`) by the time the loop comes to
/// wait for it.
///
/// A deadline that is exactly `now` is not an overrun: it runs at once with
/// lateness 0. Lateness from oversleeping (the clock woke late) is recorded
/// but is not an overrun: the tick runs late and the grid is unchanged.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum OverrunPolicy {
    /// Drop the missed slots and realign to the first grid deadline at or
    /// after now: `next += ceil((now - next) / period) * period`. The dropped
    /// slots are counted as skipped periods; tick numbers stay consecutive
    /// while slot numbers jump. Suits haptics, where a stale force is worse
    /// than a missing one.
    Skip,
    /// Run the missed slots immediately, back to back, each with its own
    /// scheduled time, until the loop is back on time; each such tick is
    /// counted as caught up. Suits physics, where simulated time must keep up
    /// with wall time. There is no cap on the backlog: a 1 s stall at 1 kHz
    /// runs 1000 ticks back to back.
    CatchUp,
}

impl fmt::Display for OverrunPolicy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Skip => "skip",
            Self::CatchUp => "catch up",
        })
    }
}

/// Why creating a [`FixedRateLoop`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FixedRateLoopCreateError {
    /// The rate was 0 Hz.
    #[error("loop rate is 0 Hz")]
    ZeroRate,
    /// The rate was above 1 GHz, so the period would round to 0 ns.
    #[error("loop rate {rate_hz} Hz is above 1 GHz (period < 1 ns)")]
    RateAbove1GHz {
        /// The requested rate, Hz.
        rate_hz: u32,
    },
    /// The period was 0 ns.
    #[error("loop period is 0 ns")]
    ZeroPeriod,
}

/// The period for a rate: `1e9 / rate_hz` ns, rounded to the nearest ns.
///
/// Rates that do not divide 1e9 run very slightly off: 3 kHz gives
/// 333 333 ns, i.e. 3000.003 Hz (1 ppm), far below a crystal's error.
pub const fn period_ns_from_rate_hz(rate_hz: u32) -> Result<u64, FixedRateLoopCreateError> {
    if rate_hz == 0 {
        return Err(FixedRateLoopCreateError::ZeroRate);
    }
    if rate_hz as u64 > NS_PER_S {
        return Err(FixedRateLoopCreateError::RateAbove1GHz { rate_hz });
    }
    let hz = rate_hz as u64;
    Ok((NS_PER_S + hz / 2) / hz)
}

/// When a [`FixedRateLoop::run`] call stops: at the first of the conditions
/// set here (or when the body returns `ControlFlow::Break`).
///
/// All conditions are checked before each tick, so a stop takes effect
/// between ticks, at most one period after the flag is set.
#[derive(Debug, Clone, Copy, Default)]
pub struct RunLimit<'a> {
    /// Stop after this many ticks of this run. Default `None` (no limit).
    pub max_ticks: Option<u64>,
    /// Run only ticks scheduled in `[first, first + max_duration_ns)`, where
    /// `first` is the first deadline of this run; ns. Default `None`.
    pub max_duration_ns: Option<u64>,
    /// Stop once this flag reads `true` (see
    /// [`install_stop_handler`](crate::install_stop_handler)). Default `None`.
    pub stop_flag: Option<&'a AtomicBool>,
}

impl<'a> RunLimit<'a> {
    /// No limit: runs until the body breaks.
    pub const fn unbounded() -> Self {
        Self { max_ticks: None, max_duration_ns: None, stop_flag: None }
    }

    /// Stop after `n` ticks.
    pub const fn ticks(n: u64) -> Self {
        Self::unbounded().and_ticks(n)
    }

    /// Run the ticks scheduled in the first `ns` nanoseconds of the run (at
    /// 1 kHz, 5 s is exactly 5000 ticks unless periods are skipped).
    pub const fn duration_ns(ns: u64) -> Self {
        Self::unbounded().and_duration_ns(ns)
    }

    /// Run until `flag` reads `true`.
    pub const fn until_stopped(flag: &'a AtomicBool) -> Self {
        Self::unbounded().and_stop_flag(flag)
    }

    /// Also stop after `n` ticks.
    #[must_use]
    pub const fn and_ticks(mut self, n: u64) -> Self {
        self.max_ticks = Some(n);
        self
    }

    /// Also stop after `ns` nanoseconds of deadlines.
    #[must_use]
    pub const fn and_duration_ns(mut self, ns: u64) -> Self {
        self.max_duration_ns = Some(ns);
        self
    }

    /// Also stop when `flag` reads `true`.
    #[must_use]
    pub const fn and_stop_flag(mut self, flag: &'a AtomicBool) -> Self {
        self.stop_flag = Some(flag);
        self
    }
}

/// Why a [`FixedRateLoop::run`] call returned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StopReason {
    /// [`RunLimit::max_ticks`] ticks ran.
    TickLimit,
    /// The next deadline fell outside [`RunLimit::max_duration_ns`].
    Duration,
    /// [`RunLimit::stop_flag`] was set.
    StopFlag,
    /// The body returned `ControlFlow::Break`.
    Body,
}

/// What one [`FixedRateLoop::run`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunSummary {
    /// Ticks run by this call.
    pub ticks: u64,
    /// Periods skipped by this call ([`OverrunPolicy::Skip`]).
    pub skipped_periods: u64,
    /// Ticks of this call that ran after their deadline had passed
    /// ([`OverrunPolicy::CatchUp`]).
    pub caught_up_ticks: u64,
    /// The first deadline of this call, ns.
    pub first_deadline_ns: u64,
    /// The clock when the call returned, ns.
    pub end_ns: u64,
    /// Why the call returned.
    pub stop: StopReason,
}

/// Runs a body at a fixed rate on absolute deadlines (see the
/// [module docs](self)).
///
/// The loop keeps its grid and counters across [`run`](Self::run) calls, so a
/// warm-up run followed by a measured run stays on one grid. If the clock
/// moved on between two calls, the second call starts with an overrun,
/// handled by the policy; call [`start_at`](Self::start_at) to re-anchor.
#[derive(Debug)]
pub struct FixedRateLoop<C: Clock> {
    clock: C,
    period_ns: u64,
    policy: OverrunPolicy,
    origin_ns: Option<u64>,
    next_slot: u64,
    next_deadline_ns: u64,
    next_tick: u64,
    prev_wake_ns: Option<u64>,
    skipped_periods: u64,
    caught_up_ticks: u64,
}

impl<C: Clock> FixedRateLoop<C> {
    /// A loop at `rate_hz` (period `1e9 / rate_hz` ns, rounded; see
    /// [`period_ns_from_rate_hz`]).
    ///
    /// ## Panics
    ///
    /// If `rate_hz` is 0 or above 1 GHz. [`try_new`](Self::try_new) returns
    /// an error instead.
    pub fn new(clock: C, rate_hz: u32, policy: OverrunPolicy) -> Self {
        match Self::try_new(clock, rate_hz, policy) {
            Ok(lp) => lp,
            Err(e) => panic!("FixedRateLoop::new: {e}"),
        }
    }

    /// A loop at `rate_hz`, or an error if `rate_hz` is 0 or above 1 GHz.
    pub fn try_new(clock: C, rate_hz: u32, policy: OverrunPolicy) -> Result<Self, FixedRateLoopCreateError> {
        let period_ns = period_ns_from_rate_hz(rate_hz)?;
        Self::try_with_period_ns(clock, period_ns, policy)
    }

    /// A loop with a period of `period_ns` ns, or an error if it is 0.
    pub fn try_with_period_ns(
        clock: C,
        period_ns: u64,
        policy: OverrunPolicy,
    ) -> Result<Self, FixedRateLoopCreateError> {
        if period_ns == 0 {
            return Err(FixedRateLoopCreateError::ZeroPeriod);
        }
        Ok(Self {
            clock,
            period_ns,
            policy,
            origin_ns: None,
            next_slot: 0,
            next_deadline_ns: 0,
            next_tick: 0,
            prev_wake_ns: None,
            skipped_periods: 0,
            caught_up_ticks: 0,
        })
    }

    /// The clock the loop reads and sleeps on.
    pub fn clock(&self) -> &C {
        &self.clock
    }

    /// The nominal period, ns.
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// The overrun policy.
    pub fn policy(&self) -> OverrunPolicy {
        self.policy
    }

    /// The grid origin (slot 0's deadline), ns; `None` before the first run.
    pub fn origin_ns(&self) -> Option<u64> {
        self.origin_ns
    }

    /// The deadline the next tick is scheduled for, ns; `None` before the
    /// first run.
    pub fn next_deadline_ns(&self) -> Option<u64> {
        self.origin_ns.map(|_| self.next_deadline_ns)
    }

    /// Ticks run since the loop was created.
    pub fn ticks_run(&self) -> u64 {
        self.next_tick
    }

    /// Periods skipped since the loop was created ([`OverrunPolicy::Skip`]).
    pub fn skipped_periods(&self) -> u64 {
        self.skipped_periods
    }

    /// Ticks run after their deadline had passed, since the loop was created
    /// ([`OverrunPolicy::CatchUp`]).
    pub fn caught_up_ticks(&self) -> u64 {
        self.caught_up_ticks
    }

    /// Anchors the grid at `origin_ns`: the next tick is slot 0, due at
    /// `origin_ns`. Tick numbers and counters carry on. The first
    /// [`run`](Self::run) calls this with the clock's current time if it was
    /// never called.
    pub fn start_at(&mut self, origin_ns: u64) {
        self.origin_ns = Some(origin_ns);
        self.next_slot = 0;
        self.next_deadline_ns = origin_ns;
        self.prev_wake_ns = None;
    }

    /// Runs `body` once per period until `limit` is reached or the body
    /// returns `ControlFlow::Break` (that tick still counts and is observed).
    /// Each tick is reported to `observer` after the body returned; pass
    /// `&mut ()` for none.
    ///
    /// ## Correctness
    ///
    /// - Tick `k` of the grid is scheduled at exactly `origin + slot * period`
    ///   (integer ns, no accumulated rounding).
    /// - The loop itself does not allocate, lock or do I/O; the body and the
    ///   observer must not either if the loop is to stay real-time.
    pub fn run<O, F>(&mut self, limit: RunLimit<'_>, observer: &mut O, mut body: F) -> RunSummary
    where
        O: TickObserver + ?Sized,
        F: FnMut(TickInfo) -> ControlFlow<()>,
    {
        // When this call anchors the grid, the anchoring read is the first
        // tick's "now": reading the clock again would find it a few ns past
        // slot 0 and call that an overrun.
        let mut anchor_now = None;
        if self.origin_ns.is_none() {
            let now = self.clock.now();
            self.start_at(now);
            anchor_now = Some(now);
        }
        let first_deadline_ns = self.next_deadline_ns;
        let window_end_ns = limit.max_duration_ns.map(|d| first_deadline_ns.saturating_add(d));
        let past_window = |deadline: u64| window_end_ns.is_some_and(|end| deadline >= end);
        let (mut ticks, mut skipped, mut caught_up) = (0u64, 0u64, 0u64);

        let stop = loop {
            if limit.max_ticks.is_some_and(|max| ticks >= max) {
                break StopReason::TickLimit;
            }
            if limit.stop_flag.is_some_and(|f| f.load(Ordering::Relaxed)) {
                break StopReason::StopFlag;
            }
            if past_window(self.next_deadline_ns) {
                break StopReason::Duration;
            }

            let now = anchor_now.take().unwrap_or_else(|| self.clock.now());
            let mut skipped_before = 0;
            let mut late_start = false;
            if now > self.next_deadline_ns {
                match self.policy {
                    OverrunPolicy::Skip => {
                        let missed = (now - self.next_deadline_ns).div_ceil(self.period_ns);
                        self.next_deadline_ns += missed * self.period_ns;
                        self.next_slot += missed;
                        self.skipped_periods += missed;
                        skipped += missed;
                        skipped_before = missed;
                        observer.on_skip(missed);
                    }
                    OverrunPolicy::CatchUp => late_start = true,
                }
            }
            if past_window(self.next_deadline_ns) {
                break StopReason::Duration;
            }
            if self.next_deadline_ns > now {
                self.clock.sleep_until(self.next_deadline_ns);
            }

            let wake_ns = self.clock.now();
            let info = TickInfo {
                tick: self.next_tick,
                slot: self.next_slot,
                scheduled_ns: self.next_deadline_ns,
                wake_ns,
                lateness_ns: wake_ns.saturating_sub(self.next_deadline_ns),
            };
            let flow = body(info);
            let end_ns = self.clock.now();

            let sample = TickSample {
                info,
                end_ns,
                compute_ns: end_ns.saturating_sub(wake_ns),
                deadline_ns: info.scheduled_ns + self.period_ns,
                period_ns: self.period_ns,
                actual_period_ns: self.prev_wake_ns.map(|p| wake_ns.saturating_sub(p)),
                skipped_before,
                caught_up: late_start,
            };
            observer.on_tick(&sample);

            ticks += 1;
            if late_start {
                caught_up += 1;
                self.caught_up_ticks += 1;
            }
            self.next_tick += 1;
            self.next_slot += 1;
            self.next_deadline_ns += self.period_ns;
            self.prev_wake_ns = Some(wake_ns);

            if flow.is_break() {
                break StopReason::Body;
            }
        };

        RunSummary {
            ticks,
            skipped_periods: skipped,
            caught_up_ticks: caught_up,
            first_deadline_ns,
            end_ns: self.clock.now(),
            stop,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn period_from_rate_rounds_works() {
        assert_eq!(period_ns_from_rate_hz(1_000), Ok(1_000_000));
        assert_eq!(period_ns_from_rate_hz(3_000), Ok(333_333));
        assert_eq!(period_ns_from_rate_hz(0), Err(FixedRateLoopCreateError::ZeroRate));
        assert!(period_ns_from_rate_hz(2_000_000_000).is_err());
    }
}
