//! Smoke test on the real clock: 200 ticks at 1 kHz. Checks counts and
//! monotonicity only; no timing thresholds (this machine may be loaded).

use std::ops::ControlFlow;

use lamina_rt::{
    Clock, DeadlineMonitor, FixedRateLoop, MonitorConfig, MonotonicClock, OverrunPolicy, RunLimit, StopReason, TickInfo,
};

#[test]
fn monotonic_loop_200_ticks_smoke_works() {
    for policy in [OverrunPolicy::Skip, OverrunPolicy::CatchUp] {
        let mut lp = FixedRateLoop::new(MonotonicClock::new(), 1_000, policy);
        let period = lp.period_ns();
        let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(period));
        let mut infos: Vec<TickInfo> = Vec::with_capacity(200);
        let run = lp.run(RunLimit::ticks(200), &mut monitor, |info| {
            infos.push(info);
            ControlFlow::Continue(())
        });
        assert_eq!((run.ticks, run.stop), (200, StopReason::TickLimit));
        assert_eq!(monitor.ticks(), 200);
        let origin = lp.origin_ns().unwrap();
        for (k, i) in infos.iter().enumerate() {
            assert_eq!(i.tick, k as u64);
            assert_eq!(i.scheduled_ns, origin + i.slot * period);
            assert!(i.wake_ns >= i.scheduled_ns, "sleep_until returned early");
            assert_eq!(i.lateness_ns, i.wake_ns - i.scheduled_ns);
        }
        for w in infos.windows(2) {
            assert!(w[1].slot > w[0].slot);
            assert!(w[1].wake_ns > w[0].wake_ns);
        }
        let last = infos.last().unwrap();
        assert_eq!(last.slot, 199 + run.skipped_periods);
        assert!(lp.clock().now() >= last.wake_ns);
        let s = monitor.summary();
        assert_eq!(s.period.count, 199);
        assert_eq!(s.skipped_periods, run.skipped_periods);
        assert_eq!(s.caught_up_ticks, run.caught_up_ticks);
        println!("{policy}:\n{s}");
    }
}
