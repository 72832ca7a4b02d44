//! DeadlineMonitor on a FakeClock: exact miss counts, worst ticks,
//! percentiles within HDR precision, JSON round trip, record ring.

use std::ops::ControlFlow;

use lamina_rt::{DeadlineMonitor, FakeClock, FixedRateLoop, MonitorConfig, MonitorSummary, OverrunPolicy, RunLimit};

const P: u64 = 1_000_000;

/// Runs one compute time per tick from `script` (ns) and returns the monitor.
fn check(policy: OverrunPolicy, config: MonitorConfig, script: &[u64]) -> DeadlineMonitor {
    let clock = FakeClock::new(0).with_compute_script(script.to_vec());
    let mut lp = FixedRateLoop::try_with_period_ns(clock.clone(), config.period_ns, policy).unwrap();
    let mut monitor = DeadlineMonitor::new(config);
    let run = lp.run(RunLimit::ticks(script.len() as u64), &mut monitor, |i| {
        clock.spend(i.tick);
        ControlFlow::Continue(())
    });
    assert_eq!(run.ticks, script.len() as u64);
    monitor
}

/// Compute times in tenths of a period, CatchUp, budget 0.6 P. Per tick:
/// 0: 0.1        none
/// 1: 0.7        over budget, ends 1.7 <= 2
/// 2: 1.0        over budget, ends exactly at its deadline 3: no deadline miss
/// 3: 0.2        none
/// 4: 2.5        over budget and ends 6.5 > 5
/// 5: 0.1        caught up: wakes 6.5, ends 6.6 > 6: deadline miss only
/// 6: 0.1        caught up: wakes 6.6, ends 6.7 <= 7: no miss
/// 7, 8: 0.1     on time
const TENTHS: [u64; 9] = [1, 7, 10, 2, 25, 1, 1, 1, 1];

fn scripted() -> DeadlineMonitor {
    let script: Vec<u64> = TENTHS.iter().map(|t| t * P / 10).collect();
    check(OverrunPolicy::CatchUp, MonitorConfig::for_period_ns(P).with_budget_ns(6 * P / 10), &script)
}

#[test]
fn monitor_misses_counted_exactly_works() {
    let s = scripted().summary();
    assert_eq!(s.ticks, 9);
    assert_eq!(s.budget_misses, 3); // ticks 1, 2, 4
    assert_eq!(s.deadline_misses, 2); // ticks 4, 5
    assert_eq!(s.misses, 4); // ticks 1, 2, 4, 5
    assert_eq!(s.caught_up_ticks, 2); // ticks 5, 6
    assert_eq!(s.skipped_periods, 0);
    assert_eq!(s.budget_ns, 600_000);
}

#[test]
fn monitor_default_budget_is_period_works() {
    // Skip policy, default budget: only the 3.5-period tick misses.
    let mut script = vec![100_000; 30];
    script[10] = 3_500_000;
    let s = check(OverrunPolicy::Skip, MonitorConfig::for_period_ns(P), &script).summary();
    assert_eq!((s.misses, s.budget_misses, s.deadline_misses), (1, 1, 1));
    assert_eq!(s.skipped_periods, 3);
    assert_eq!(s.budget_ns, P);
}

#[test]
fn monitor_worst_ticks_listed_works() {
    let s = scripted().summary();
    let worst: Vec<(u64, u64, u64)> =
        s.worst.as_slice().iter().map(|w| (w.tick, w.lateness_ns, w.compute_ns)).collect();
    // Ranked by lateness + compute; ticks 1 and 6 tie at 0.7 P (earlier first);
    // tick 8 ties with 0 and 7 and does not fit in the 8 slots.
    assert_eq!(
        worst,
        [
            (4, 0, 2_500_000),
            (5, 1_500_000, 100_000),
            (2, 0, 1_000_000),
            (1, 0, 700_000),
            (6, 600_000, 100_000),
            (3, 0, 200_000),
            (0, 0, 100_000),
            (7, 0, 100_000),
        ]
    );
}

/// `got` within HDR's 3-significant-digit precision of `expected`.
fn assert_close(got: u64, expected: u64, what: &str) {
    let tol = expected / 1000 + 1;
    assert!(got.abs_diff(expected) <= tol, "{what}: got {got}, expected {expected} ± {tol}");
}

#[test]
fn monitor_percentiles_of_uniform_distribution_works() {
    // Compute times 1 µs, 2 µs, ..., 10 ms (uniform), period 20 ms: no misses.
    let n = 10_000u64;
    let script: Vec<u64> = (1..=n).map(|i| i * 1_000).collect();
    let s = check(OverrunPolicy::Skip, MonitorConfig::for_period_ns(20 * P), &script).summary();
    assert_eq!(s.misses, 0);
    let c = s.compute;
    assert_eq!(c.count, n);
    assert_eq!((c.min_ns, c.max_ns), (1_000, 10_000_000)); // exact
    assert_close(c.p50_ns, 5_000_000, "p50");
    assert_close(c.p90_ns, 9_000_000, "p90");
    assert_close(c.p99_ns, 9_900_000, "p99");
    assert_close(c.p999_ns, 9_990_000, "p99.9");
    assert_eq!(c.mean_ns, 5_000_500, "the mean is exact");
    // The fake clock is never late and the period is exact.
    assert_eq!((s.lateness.max_ns, s.lateness.p999_ns), (0, 0));
    assert_eq!(s.period.count, n - 1);
    assert_eq!((s.period.min_ns, s.period.p50_ns, s.period.max_ns), (20 * P, 20 * P, 20 * P));
}

#[test]
fn monitor_saturates_above_range_works() {
    let script = [1_000, 5_000, 2_000];
    let s = check(OverrunPolicy::Skip, MonitorConfig::for_period_ns(10_000).with_max_trackable_ns(3_000), &script)
        .summary();
    assert_eq!(s.compute.saturated, 1);
    assert_eq!(s.compute.max_ns, 5_000, "max stays exact");
    assert!(s.compute.p999_ns <= 5_000);
}

#[test]
fn monitor_json_report_round_trip_works() {
    let monitor = scripted();
    let summary = monitor.summary();
    let json = monitor.report_json();
    let back: MonitorSummary = serde_json::from_str(&json).unwrap();
    assert_eq!(back, summary);
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!(value["misses"], 4);
    assert_eq!(value["worst"][0]["tick"], 4);
    assert_eq!(value["compute"]["max_ns"], 2_500_000);

    let path = std::env::temp_dir().join(format!("lamina-rt-report-{}.json", std::process::id()));
    monitor.write_report(&path).unwrap();
    let from_file: MonitorSummary = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert_eq!(from_file, summary);
}

#[test]
fn monitor_write_report_to_missing_dir_fails() {
    let err = scripted().write_report("/nonexistent-lamina-dir/report.json").unwrap_err();
    assert_eq!(err, lamina_rt::MonitorReportWriteError::Io(std::io::ErrorKind::NotFound));
}

#[test]
fn monitor_record_ring_keeps_send_times_works() {
    let clock = FakeClock::new(0);
    let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::Skip);
    let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(P).with_record_capacity(16));
    let probe = monitor.send_probe();
    lp.run(RunLimit::ticks(40), &mut monitor, |i| {
        clock.advance(100_000); // compute
        if i.tick % 2 == 0 {
            probe.measure(&clock, || clock.advance(50_000)); // a 50 µs send
        }
        ControlFlow::Continue(())
    });
    let records: Vec<_> = monitor.records().iter().copied().collect();
    assert_eq!(records.len(), 16);
    assert_eq!(monitor.records().pushed(), 40);
    for (r, tick) in records.iter().zip(24..) {
        assert_eq!(r.tick, tick);
        assert_eq!(r.wake_ns, tick * P);
        assert_eq!(r.lateness_ns, 0);
        assert_eq!(r.send_ns, if tick % 2 == 0 { 50_000 } else { 0 });
        assert_eq!(r.compute_ns, 100_000 + r.send_ns);
    }
    // No tick was held up in a send for more than 50 µs.
    assert_eq!(monitor.summary().send.max_ns, 50_000);
}

#[test]
fn monitor_reset_forgets_everything_works() {
    let mut monitor = scripted();
    monitor.reset();
    assert_eq!(monitor.summary(), MonitorSummary { period_ns: P, budget_ns: 600_000, ..Default::default() });
}

#[test]
fn monitor_display_table_works() {
    let table = scripted().to_string();
    println!("{table}");
    for needle in [
        "ticks 9 at 1000.000 Hz (period 1000 µs, budget 600.0 µs)",
        "misses 4 (over budget 3, after deadline 2), skipped periods 0, caught-up ticks 2",
        "lateness",
        "compute",
        "period",
        "send",
        "worst ticks",
        "2500",
    ] {
        assert!(table.contains(needle), "missing {needle:?} in\n{table}");
    }
}

#[test]
fn monitor_zero_range_fails() {
    let err = DeadlineMonitor::try_new(MonitorConfig::for_period_ns(P).with_max_trackable_ns(1));
    assert!(err.is_err());
}

/// Runs `seconds` one-second windows at 1 kHz (Skip), as `lamina run` reports once a second,
/// with one tick computing for `stall_ns` and the others 0.1 ms; returns the summary.
fn chunked_with_stall(stall_tick: u64, stall_ns: u64, seconds: u64) -> MonitorSummary {
    let clock = FakeClock::new(0).with_compute(move |t| if t == stall_tick { stall_ns } else { P / 10 });
    let mut lp = FixedRateLoop::try_with_period_ns(clock.clone(), P, OverrunPolicy::Skip).unwrap();
    let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(P));
    let mut skipped_by_runs = 0;
    for _ in 0..seconds {
        let run = lp.run(RunLimit::duration_ns(1_000_000_000), &mut monitor, |i| {
            clock.spend(i.tick);
            ControlFlow::Continue(())
        });
        skipped_by_runs += run.skipped_periods;
    }
    let s = monitor.summary();
    assert_eq!(s.skipped_periods, skipped_by_runs);
    assert_eq!(s.skipped_periods, lp.skipped_periods());
    // Every grid slot before the next deadline was either run or skipped.
    assert_eq!(s.ticks + s.skipped_periods, lp.next_deadline_ns().unwrap() / P);
    s
}

#[test]
fn monitor_stall_across_report_boundary_counts_every_skipped_period_works() {
    // A tick that computes for S periods ends S - 1 periods after its deadline passed: the
    // S - 1 slots due during the stall are skipped (the next one is due exactly when it ends).
    // Stall at tick 700 of the first second: 0.5 s and 1.5 s both cross the 1 s boundary.
    // 300 ms ends exactly on the boundary; 200 ms stays inside the first second.
    for (stall_ms, expected) in [(500u64, 499u64), (1_500, 1_499), (300, 299), (200, 199)] {
        let s = chunked_with_stall(700, stall_ms * P, 4);
        assert_eq!(s.skipped_periods, expected, "stall {stall_ms} ms");
        assert_eq!(s.misses, 1, "stall {stall_ms} ms");
    }
}
