//! The per-tick path (loop + monitor recording + summary) never allocates:
//! a counting global allocator watches 10 000 ticks after warm-up.

use lamina_rt::{DeadlineMonitor, FakeClock, FixedRateLoop, MonitorConfig, OverrunPolicy, RunLimit};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::ops::ControlFlow;

struct Counting;

thread_local! {
    /// Count only on the thread under test, only while this is set.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    /// This thread's count: tests run in parallel threads, and another test's allocations
    /// must not show here.
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn note() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.with(|n| n.set(n.get() + 1));
    }
}

// SAFETY: forwards to the system allocator unchanged.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note();
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note();
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Allocations made by `f` on this thread.
fn allocations_in(f: impl FnOnce()) -> u64 {
    let before = ALLOCATIONS.with(Cell::get);
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get) - before
}

#[test]
fn counting_allocator_sees_allocations_works() {
    // The instrument itself works: a Vec allocates.
    assert!(allocations_in(|| drop(std::hint::black_box(vec![1u8; 64]))) > 0);
}

#[test]
fn loop_with_monitor_does_not_allocate_works() {
    for policy in [OverrunPolicy::Skip, OverrunPolicy::CatchUp] {
        // Mostly 0-0.9 periods, with a 2.5-period overrun every 997 ticks so
        // the skip / catch-up paths and the worst-tick list are exercised.
        let clock =
            FakeClock::new(0).with_compute(|tick| if tick % 997 == 996 { 2_500_000 } else { (tick * 7_919) % 900_000 });
        let mut lp = FixedRateLoop::new(clock.clone(), 1_000, policy);
        let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(P).with_record_capacity(1_024));
        let probe = monitor.send_probe();
        let mut body = |info: lamina_rt::TickInfo| {
            clock.spend(info.tick);
            probe.measure(&clock, || clock.advance(1_000));
            ControlFlow::Continue(())
        };

        // Warm-up, then forget it.
        lp.run(RunLimit::ticks(1_000), &mut monitor, &mut body);
        monitor.reset();

        let mut ticks = 0;
        let mut summary_ticks = 0;
        let n = allocations_in(|| {
            for _ in 0..10 {
                let run = lp.run(RunLimit::ticks(1_000), &mut monitor, &mut body);
                ticks += run.ticks;
                // The once-a-second summary does not allocate either.
                summary_ticks = monitor.summary().ticks;
            }
        });
        assert_eq!(n, 0, "{policy}: the per-tick path allocated {n} times");
        assert_eq!((ticks, summary_ticks), (10_000, 10_000));
        let s = monitor.summary();
        assert!(s.misses > 0 && s.worst.len() == lamina_rt::WORST_TICKS);
        match policy {
            OverrunPolicy::Skip => assert!(s.skipped_periods > 0),
            OverrunPolicy::CatchUp => assert!(s.caught_up_ticks > 0),
        }
    }
}

const P: u64 = 1_000_000;

#[test]
fn real_clock_sliced_sleeps_do_not_allocate_works() {
    use lamina_rt::MonotonicClock;
    // 5 kHz for 200 ticks (40 ms), each tick's wait sleeping in 20 µs slices: every path of the
    // real clock's sleep runs, under whatever load the machine has.
    let clock = MonotonicClock::new().with_sleep_slice_ns(20_000).with_spin_ns(10_000);
    let mut lp = FixedRateLoop::new(clock, 5_000, OverrunPolicy::Skip);
    let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(200_000));
    lp.run(RunLimit::ticks(10), &mut monitor, |_| ControlFlow::Continue(()));
    let mut ran = 0;
    let n = allocations_in(|| ran = lp.run(RunLimit::ticks(200), &mut monitor, |_| ControlFlow::Continue(())).ticks);
    assert_eq!(n, 0, "the real clock's loop allocated {n} times");
    assert!(ran > 0 && ran <= 200, "{ran} ticks");
}

#[test]
fn standby_ticks_allocate_nothing_on_either_thread_works() {
    use lamina_rt::standby::{Grid, Runner, run_with_standby};
    use lamina_rt::{Clock, MonotonicClock};
    // The standby wakes at each deadline too (no delay), so both threads claim ticks. From
    // each thread's first tick on, its allocations are counted: its ticks, the monitor's
    // records, its claims and sleeps.
    let clock = MonotonicClock::new();
    let grid = Grid {
        origin_ns: clock.now() + 2_000_000,
        first_tick: 0,
        period_ns: 1_000_000,
        slots: 2_000,
        standby_delay_ns: 0,
        previous_wake_ns: None,
    };
    let config = MonitorConfig::for_period_ns(grid.period_ns).with_record_capacity(2_000);
    let mut monitor = DeadlineMonitor::try_new(config).unwrap();
    // Per runner: the thread's allocation count at its first tick and at its last.
    let mut counts: [Option<(u64, u64)>; 2] = [None; 2];
    let summary = run_with_standby(
        [&clock, &clock],
        grid,
        None,
        &mut monitor,
        &mut counts,
        || (),
        |counts, _, runner| {
            COUNTING.with(|c| c.set(true));
            let now = ALLOCATIONS.with(Cell::get);
            let slot = &mut counts[usize::from(runner == Runner::Standby)];
            *slot = Some(slot.map_or((now, now), |(first, _)| (first, now)));
            ControlFlow::Continue(())
        },
    );
    COUNTING.with(|c| c.set(false));
    assert_eq!(summary.ticks + summary.skipped_periods, 2_000);
    assert_eq!(monitor.ticks(), summary.ticks);
    let [on_loop, on_standby] = counts.map(|c| c.map(|(first, last)| last - first));
    assert_eq!(on_loop, Some(0), "the loop's thread ran ticks without allocating");
    assert!(on_standby.is_none_or(|n| n == 0), "the standby's ticks allocated {on_standby:?} times");
    eprintln!("standby ran {} of {} ticks", summary.by_standby, summary.ticks);
}
