//! FixedRateLoop on a FakeClock: no drift, overrun policies, run limits.
//! No wall time anywhere: every number here is exact.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};

use lamina_rt::{
    Clock, FakeClock, FixedRateLoop, OverrunPolicy, RunLimit, RunSummary, StopReason, TickObserver, TickSample,
};

const P: u64 = 1_000_000; // 1 kHz
const ORIGIN: u64 = 123_456_789;

/// Keeps every sample (tests only: it allocates).
#[derive(Default)]
struct Samples(Vec<TickSample>);

impl TickObserver for Samples {
    fn on_tick(&mut self, s: &TickSample) {
        self.0.push(*s);
    }
}

/// The one caller of the loop in this file: runs `ticks` ticks of period
/// `period_ns` from ORIGIN, each spending `compute(tick)` ns.
fn check(
    policy: OverrunPolicy,
    period_ns: u64,
    ticks: u64,
    compute: impl Fn(u64) -> u64 + Send + Sync + 'static,
) -> (Vec<TickSample>, RunSummary) {
    let clock = FakeClock::new(ORIGIN).with_compute(compute);
    let mut lp = FixedRateLoop::try_with_period_ns(clock.clone(), period_ns, policy).unwrap();
    let mut samples = Samples::default();
    let run = lp.run(RunLimit::ticks(ticks), &mut samples, |info| {
        clock.spend(info.tick);
        ControlFlow::Continue(())
    });
    assert_eq!(lp.origin_ns(), Some(ORIGIN));
    (samples.0, run)
}

/// Compute times that vary pseudo-randomly in [0, period).
fn jitter(period_ns: u64) -> impl Fn(u64) -> u64 + Send + Sync {
    move |tick| tick.wrapping_mul(2_654_435_761) % period_ns
}

#[test]
fn fixed_rate_deadlines_do_not_drift_works() {
    for policy in [OverrunPolicy::Skip, OverrunPolicy::CatchUp] {
        // 1 kHz, and 3 kHz whose period (333 333 ns) does not divide 1 s.
        for period in [P, 333_333] {
            let (samples, run) = check(policy, period, 10_000, jitter(period));
            assert_eq!(run.ticks, 10_000);
            assert_eq!((run.skipped_periods, run.caught_up_ticks), (0, 0));
            for (k, s) in samples.iter().enumerate() {
                let k = k as u64;
                assert_eq!(s.info.tick, k);
                assert_eq!(s.info.slot, k);
                assert_eq!(s.info.scheduled_ns, ORIGIN + k * period, "tick {k}");
                assert_eq!(s.info.wake_ns, s.info.scheduled_ns);
                assert_eq!(s.info.lateness_ns, 0);
                assert_eq!(s.compute_ns, jitter(period)(k));
                assert_eq!(s.deadline_ns, s.info.scheduled_ns + period);
                assert_eq!(s.actual_period_ns, (k > 0).then_some(period));
            }
        }
    }
}

/// Tick 10 computes 3.5 periods, all others 0.1 period.
fn overrun_at_10(tick: u64) -> u64 {
    if tick == 10 { 3_500_000 } else { 100_000 }
}

#[test]
fn fixed_rate_skip_overrun_realigns_to_grid_works() {
    let (samples, run) = check(OverrunPolicy::Skip, P, 30, overrun_at_10);
    assert_eq!(run.ticks, 30);
    assert_eq!(run.skipped_periods, 3);
    assert_eq!(run.caught_up_ticks, 0);
    for s in &samples {
        let (tick, slot) = (s.info.tick, s.info.slot);
        // Slots 11, 12, 13 are dropped; tick 11 runs in slot 14.
        assert_eq!(slot, if tick <= 10 { tick } else { tick + 3 });
        assert_eq!(s.info.scheduled_ns, ORIGIN + slot * P);
        assert_eq!(s.info.lateness_ns, 0, "tick {tick} is on the grid");
        assert_eq!(s.skipped_before, if tick == 11 { 3 } else { 0 });
        assert!(!s.caught_up);
    }
    // Tick 11 waited for the next future deadline (14P) after tick 10 ended at 13.5P.
    assert_eq!(samples[11].actual_period_ns, Some(4 * P));
}

#[test]
fn fixed_rate_catch_up_overrun_runs_backlog_works() {
    let (samples, run) = check(OverrunPolicy::CatchUp, P, 30, overrun_at_10);
    assert_eq!(run.ticks, 30);
    assert_eq!(run.skipped_periods, 0);
    assert_eq!(run.caught_up_ticks, 3);
    let expected_lateness = |tick: u64| match tick {
        11 => 2_500_000, // woke at 13.5P, end of tick 10
        12 => 1_600_000, // back to back: 13.6P
        13 => 700_000,   // 13.7P
        _ => 0,          // tick 14 waits for 14P: back on the grid
    };
    for s in &samples {
        let tick = s.info.tick;
        assert_eq!(s.info.slot, tick);
        assert_eq!(s.info.scheduled_ns, ORIGIN + tick * P);
        assert_eq!(s.info.lateness_ns, expected_lateness(tick), "tick {tick}");
        assert_eq!(s.caught_up, (11..=13).contains(&tick), "tick {tick}");
        assert_eq!(s.skipped_before, 0);
    }
}

#[test]
fn fixed_rate_skip_counts_table_works() {
    // (compute of tick 10 in ns, periods skipped after it)
    let table = [
        (P, 0),     // ends exactly at the next deadline: not an overrun
        (P + 1, 1), // just past it
        (2 * P, 1), // ends at 12P: slot 11 dropped, 12 runs on time
        (3 * P, 2),
        (3 * P + P / 2, 3), // the 3.5-period case
        (10 * P, 9),
    ];
    for (compute, skipped) in table {
        let (samples, run) = check(OverrunPolicy::Skip, P, 20, move |t| if t == 10 { compute } else { 0 });
        assert_eq!(run.skipped_periods, skipped, "compute {compute}");
        assert_eq!(samples[11].info.slot, 11 + skipped);
        assert_eq!(samples[11].info.lateness_ns, 0);
    }
}

#[test]
fn fixed_rate_duration_limit_works() {
    let clock = FakeClock::new(0).with_compute(|_| 10_000);
    let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::Skip);
    let run = lp.run(RunLimit::duration_ns(5 * P), &mut (), |i| {
        clock.spend(i.tick);
        ControlFlow::Continue(())
    });
    assert_eq!((run.ticks, run.stop), (5, StopReason::Duration));
    assert_eq!(run.first_deadline_ns, 0);
}

#[test]
fn fixed_rate_stop_flag_works() {
    let stop = AtomicBool::new(false);
    let mut lp = FixedRateLoop::new(FakeClock::new(0), 1_000, OverrunPolicy::Skip);
    let run = lp.run(RunLimit::until_stopped(&stop).and_ticks(100), &mut (), |i| {
        if i.tick == 5 {
            stop.store(true, Ordering::Relaxed);
        }
        ControlFlow::Continue(())
    });
    assert_eq!((run.ticks, run.stop), (6, StopReason::StopFlag));
}

#[test]
fn fixed_rate_body_break_works() {
    let mut samples = Samples::default();
    let mut lp = FixedRateLoop::new(FakeClock::new(0), 1_000, OverrunPolicy::Skip);
    let run = lp.run(RunLimit::unbounded(), &mut samples, |i| {
        if i.tick == 7 { ControlFlow::Break(()) } else { ControlFlow::Continue(()) }
    });
    assert_eq!((run.ticks, run.stop), (8, StopReason::Body));
    assert_eq!(samples.0.len(), 8, "the breaking tick is observed");
}

#[test]
fn fixed_rate_runs_continue_on_one_grid_works() {
    let clock = FakeClock::new(ORIGIN);
    let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::Skip);
    lp.run(RunLimit::ticks(3), &mut (), |_| ControlFlow::Continue(()));
    let mut samples = Samples::default();
    lp.run(RunLimit::ticks(4), &mut samples, |_| ControlFlow::Continue(()));
    let ticks: Vec<(u64, u64)> = samples.0.iter().map(|s| (s.info.tick, s.info.scheduled_ns - ORIGIN)).collect();
    assert_eq!(ticks, [(3, 3 * P), (4, 4 * P), (5, 5 * P), (6, 6 * P)]);
    assert_eq!(lp.ticks_run(), 7);
    assert_eq!(lp.next_deadline_ns(), Some(ORIGIN + 7 * P));
    // Re-anchoring after a gap avoids a spurious overrun.
    clock.advance(1_000 * P);
    lp.start_at(clock.now());
    let run = lp.run(RunLimit::ticks(2), &mut (), |_| ControlFlow::Continue(()));
    assert_eq!(run.skipped_periods, 0);
}

#[test]
fn fixed_rate_zero_rate_fails() {
    let err = FixedRateLoop::try_new(FakeClock::new(0), 0, OverrunPolicy::Skip).unwrap_err();
    assert_eq!(err, lamina_rt::FixedRateLoopCreateError::ZeroRate);
    assert!(FixedRateLoop::try_with_period_ns(FakeClock::new(0), 0, OverrunPolicy::Skip).is_err());
}

/// A clock that moves 1 ns every time it is read, like a real one.
struct CreepingClock(std::sync::atomic::AtomicU64);

impl Clock for CreepingClock {
    fn now(&self) -> u64 {
        self.0.fetch_add(1, Ordering::Relaxed)
    }

    fn sleep_until(&self, deadline_ns: u64) {
        self.0.fetch_max(deadline_ns, Ordering::Relaxed);
    }
}

/// Regression: the first tick was found a few ns past slot 0 (the clock moved
/// between anchoring and the overrun check) and Skip dropped a whole period.
#[test]
fn fixed_rate_first_tick_not_an_overrun_works() {
    for policy in [OverrunPolicy::Skip, OverrunPolicy::CatchUp] {
        let clock = CreepingClock(std::sync::atomic::AtomicU64::new(1_000));
        let mut samples = Samples::default();
        let mut lp = FixedRateLoop::new(&clock, 1_000, policy);
        let run = lp.run(RunLimit::ticks(3), &mut samples, |_| ControlFlow::Continue(()));
        assert_eq!((run.skipped_periods, run.caught_up_ticks), (0, 0), "{policy}");
        let slots: Vec<u64> = samples.0.iter().map(|s| s.info.slot).collect();
        assert_eq!(slots, [0, 1, 2]);
    }
}
