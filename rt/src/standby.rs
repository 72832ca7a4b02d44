//! A standby for a fixed-rate loop: [`run_with_standby`] runs one grid of absolute deadlines
//! from two threads, each pinned to its own CPU. The loop's thread runs each tick at its
//! deadline; the standby wakes `delay` later and runs the tick itself if the loop's thread has
//! not started it, as when the host has stopped that thread's virtual CPU. Who runs a tick is
//! settled by one compare-and-swap on the next slot ([`TickBaton`]): neither thread ever waits
//! for the other, and the loser of a slot goes back to sleep until the next one.
//!
//! # Examples
//!
//! Ten ticks at 1 kHz, the standby 250 µs behind the loop's thread; each slot runs once, on
//! whichever thread claimed it (on a busy machine a slot both threads reach a whole period late
//! is skipped):
//!
//! ```
//! use lamina_rt::standby::{Grid, run_with_standby};
//! use lamina_rt::{Clock, MonotonicClock};
//!
//! let clock = MonotonicClock::new();
//! let origin_ns = clock.now() + 1_000_000;
//! let grid = Grid {
//!     origin_ns,
//!     first_tick: 0,
//!     period_ns: 1_000_000,
//!     slots: 10,
//!     standby_delay_ns: 250_000,
//!     previous_wake_ns: None,
//! };
//! let mut slots_run = Vec::new();
//! let summary = run_with_standby([&clock, &clock], grid, None, &mut (), &mut slots_run, || (), |run, info, _| {
//!     run.push(info.slot);
//!     std::ops::ControlFlow::Continue(())
//! });
//! assert!(slots_run.windows(2).all(|w| w[0] < w[1]));
//! assert_eq!(summary.ticks + summary.skipped_periods, 10);
//! ```

use std::cell::UnsafeCell;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::clock::Clock;
use crate::fixed_rate::StopReason;
use crate::tick::{TickInfo, TickObserver, TickSample};

/// The right to run the next slot of a grid, and the state only its holder may touch.
///
/// `next` holds `slot << 1 | held`: the slot to run next, and whether a thread is running it.
/// [`TickBaton::claim`] takes it by one compare-and-swap, never waiting; the guard passes it on.
pub struct TickBaton<T> {
    next: AtomicU64,
    value: UnsafeCell<T>,
}

// SAFETY: `value` is reached only through a `BatonGuard`, and at most one exists at a time:
// `claim` sets the held bit by a compare-and-swap that succeeds for one thread only, and the
// bit is cleared (Release) only when that guard is dropped, after its last access; the next
// claim (Acquire) sees every write made under the previous guard. So `T` moves between
// threads one holder at a time, which `T: Send` allows.
unsafe impl<T: Send> Sync for TickBaton<T> {}

impl<T> TickBaton<T> {
    /// A baton whose first slot to run is `first_slot`, not held.
    pub fn new(first_slot: u64, value: T) -> Self {
        Self { next: AtomicU64::new(first_slot << 1), value: UnsafeCell::new(value) }
    }

    /// The slot to run next, and whether a thread is running it now.
    pub fn peek(&self) -> (u64, bool) {
        let v = self.next.load(Ordering::Acquire);
        (v >> 1, v & 1 == 1)
    }

    /// The baton for `slot`, if `slot` is the next slot and no thread holds it; `None` at once
    /// otherwise (never waits).
    pub fn claim(&self, slot: u64) -> Option<BatonGuard<'_, T>> {
        self.next
            .compare_exchange(slot << 1, slot << 1 | 1, Ordering::Acquire, Ordering::Relaxed)
            .ok()
            .map(|_| BatonGuard { baton: self, next_slot: slot })
    }

    /// The state, once no thread can hold the baton.
    pub fn into_inner(self) -> T {
        self.value.into_inner()
    }
}

/// Holding the baton: access to its state; on drop the baton goes free with the next slot
/// set by [`BatonGuard::set_next_slot`] (else the claimed one, for another thread to take).
pub struct BatonGuard<'a, T> {
    baton: &'a TickBaton<T>,
    next_slot: u64,
}

impl<T> BatonGuard<'_, T> {
    /// The slot the baton names when this guard lets it go.
    pub fn set_next_slot(&mut self, slot: u64) {
        self.next_slot = slot;
    }

    /// The state.
    pub fn value(&mut self) -> &mut T {
        // SAFETY: this guard is the only one (see `TickBaton`'s `Sync`).
        unsafe { &mut *self.baton.value.get() }
    }
}

impl<T> Drop for BatonGuard<'_, T> {
    fn drop(&mut self) {
        self.baton.next.store(self.next_slot << 1, Ordering::Release);
    }
}

/// The grid both threads run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grid {
    /// Slot 0's deadline, ns on the clock's time line.
    pub origin_ns: u64,
    /// The number slot 0's tick gets ([`TickInfo::tick`]), so that successive runs count on.
    pub first_tick: u64,
    /// Period, ns (> 0).
    pub period_ns: u64,
    /// Slots in the run: the run ends once the next slot is `slots` or later.
    pub slots: u64,
    /// How long after a slot's deadline the standby wakes to run it if it is still free, ns.
    pub standby_delay_ns: u64,
    /// When the tick before this grid's first woke, ns, if this grid goes on from one that
    /// ran ([`Grid::following`]): the first tick's actual period is measured from it. `None`
    /// for a first grid.
    pub previous_wake_ns: Option<u64>,
}

impl Grid {
    /// The grid that goes on from this one once `run` has run it: as long, starting where this
    /// one ends, its ticks numbered on from `run`'s and its first tick's actual period measured
    /// from `run`'s last wake-up.
    pub fn following<R>(&self, run: &StandbySummary<R>) -> Grid {
        Grid {
            origin_ns: self.origin_ns.saturating_add(self.slots.saturating_mul(self.period_ns)),
            first_tick: self.first_tick + run.ticks,
            previous_wake_ns: run.last_wake_ns,
            ..*self
        }
    }
}

/// Which thread ran a tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Runner {
    /// The loop's own thread (the caller of [`run_with_standby`]).
    Loop,
    /// The standby thread.
    Standby,
}

/// What a [`run_with_standby`] call did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StandbySummary<R> {
    /// Why it returned: [`StopReason::Duration`] (every slot of the grid was run or skipped),
    /// [`StopReason::StopFlag`] or [`StopReason::Body`].
    pub stop: StopReason,
    /// Ticks run, by either thread.
    pub ticks: u64,
    /// Of them, ticks the standby ran.
    pub by_standby: u64,
    /// Slots dropped because both threads came to them a whole period late or more.
    pub skipped_periods: u64,
    /// What the standby thread's setup returned (its pinning and priority, say).
    pub standby_setup: R,
    /// When the last tick run woke, ns (else the grid's `previous_wake_ns`): the next grid's
    /// `previous_wake_ns`.
    pub last_wake_ns: Option<u64>,
}

/// What only the baton's holder touches.
struct Shared<'a, O: ?Sized, S> {
    observer: &'a mut O,
    state: &'a mut S,
    ticks: u64,
    by_standby: u64,
    skipped: u64,
    prev_wake_ns: Option<u64>,
    stop: StopReason,
}

/// Runs `body` once per slot of `grid`, from the calling thread and a standby thread
/// (scoped: both are done when this returns), each reading and sleeping on its own clock of
/// `clocks` (`[loop, standby]`: the same time line, such as two copies of one
/// [`MonotonicClock`](crate::MonotonicClock)).
///
/// The standby thread first calls `standby_setup` (pin it, raise its priority), then sleeps
/// until each slot's deadline plus `grid.standby_delay_ns` and runs the slot if the calling
/// thread has not claimed it. Whoever claims a slot a whole period or more after its
/// deadline runs the slot now due instead, the ones between counted as skipped (as
/// [`OverrunPolicy::Skip`](crate::OverrunPolicy::Skip)). Each tick goes to `observer` as a
/// [`TickSample`], from the thread that ran it; `body` gets `state`, the tick and who runs it.
/// Both threads stop at the end of the grid, once `stop_flag` reads `true` (checked before
/// each slot), or after a tick whose body returned `ControlFlow::Break`.
///
/// ## Correctness
///
/// The baton is the only thing the threads share; `observer`, `state` and the counters are
/// touched by its holder alone. Nothing here allocates or locks once the standby thread runs.
pub fn run_with_standby<C, O, S, R, F>(
    clocks: [&C; 2],
    grid: Grid,
    stop_flag: Option<&AtomicBool>,
    observer: &mut O,
    state: &mut S,
    standby_setup: impl FnOnce() -> R + Send,
    body: F,
) -> StandbySummary<R>
where
    C: Clock + Sync,
    O: TickObserver + Send + ?Sized,
    S: Send,
    R: Send,
    F: Fn(&mut S, TickInfo, Runner) -> ControlFlow<()> + Sync,
{
    assert!(grid.period_ns > 0, "run_with_standby: a period of 0 ns");
    let shared = Shared {
        observer,
        state,
        ticks: 0,
        by_standby: 0,
        skipped: 0,
        prev_wake_ns: grid.previous_wake_ns,
        stop: StopReason::Duration,
    };
    let baton = TickBaton::new(0, shared);
    let standby_setup = std::thread::scope(|scope| {
        let standby = scope.spawn(|| {
            let setup = standby_setup();
            run_side(clocks[1], grid, stop_flag, &baton, &body, Runner::Standby);
            setup
        });
        run_side(clocks[0], grid, stop_flag, &baton, &body, Runner::Loop);
        standby.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    });
    let shared = baton.into_inner();
    StandbySummary {
        stop: shared.stop,
        ticks: shared.ticks,
        by_standby: shared.by_standby,
        skipped_periods: shared.skipped,
        standby_setup,
        last_wake_ns: shared.prev_wake_ns,
    }
}

/// One thread's side of [`run_with_standby`].
fn run_side<C, O, S, F>(
    clock: &C,
    grid: Grid,
    stop_flag: Option<&AtomicBool>,
    baton: &TickBaton<Shared<'_, O, S>>,
    body: &F,
    runner: Runner,
) where
    C: Clock,
    O: TickObserver + ?Sized,
    F: Fn(&mut S, TickInfo, Runner) -> ControlFlow<()>,
{
    let delay = if runner == Runner::Standby { grid.standby_delay_ns } else { 0 };
    let deadline = |slot: u64| grid.origin_ns.saturating_add(slot.saturating_mul(grid.period_ns));
    loop {
        let (slot, held) = baton.peek();
        if slot >= grid.slots {
            return;
        }
        if held {
            // The other thread is running `slot`: come back for the one after it.
            clock.sleep_until(deadline(slot + 1).saturating_add(delay));
            continue;
        }
        clock.sleep_until(deadline(slot).saturating_add(delay));
        let Some(mut guard) = baton.claim(slot) else { continue };
        if stop_flag.is_some_and(|f| f.load(Ordering::Relaxed)) {
            guard.value().stop = StopReason::StopFlag;
            guard.set_next_slot(grid.slots);
            return;
        }
        let wake_ns = clock.now();
        // A whole period late or more: run the slot now due, drop the ones between.
        let due = if wake_ns >= deadline(slot + 1) { (wake_ns - grid.origin_ns) / grid.period_ns } else { slot };
        let shared = guard.value();
        if due >= grid.slots {
            // Past the grid's end: its last slots are dropped, as a skip that ends a run.
            shared.skipped += grid.slots - slot;
            shared.observer.on_skip(grid.slots - slot);
            guard.set_next_slot(grid.slots);
            return;
        }
        let skipped_before = due - slot;
        if skipped_before > 0 {
            shared.skipped += skipped_before;
            shared.observer.on_skip(skipped_before);
        }
        let scheduled_ns = deadline(due);
        let info = TickInfo {
            tick: grid.first_tick + shared.ticks,
            slot: due,
            scheduled_ns,
            wake_ns,
            lateness_ns: wake_ns.saturating_sub(scheduled_ns),
        };
        let flow = body(shared.state, info, runner);
        let end_ns = clock.now();
        shared.observer.on_tick(&TickSample {
            info,
            end_ns,
            compute_ns: end_ns.saturating_sub(wake_ns),
            deadline_ns: scheduled_ns + grid.period_ns,
            period_ns: grid.period_ns,
            actual_period_ns: shared.prev_wake_ns.map(|p| wake_ns.saturating_sub(p)),
            skipped_before,
            caught_up: false,
        });
        shared.prev_wake_ns = Some(wake_ns);
        shared.ticks += 1;
        shared.by_standby += u64::from(runner == Runner::Standby);
        if flow.is_break() {
            shared.stop = StopReason::Body;
            guard.set_next_slot(grid.slots);
            return;
        }
        guard.set_next_slot(due + 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::MonotonicClock;

    /// The loop thread's clock: oversleeps the deadlines of the `stalled` slots by `stall_ns`,
    /// as a virtual CPU the host stops while its thread sleeps.
    struct StallingClock {
        inner: MonotonicClock,
        grid: Grid,
        stalled: Vec<u64>,
        stall_ns: u64,
    }

    impl Clock for StallingClock {
        fn now(&self) -> u64 {
            self.inner.now()
        }

        fn sleep_until(&self, deadline_ns: u64) {
            let slot = deadline_ns.saturating_sub(self.grid.origin_ns) / self.grid.period_ns;
            let on_grid = deadline_ns == self.grid.origin_ns + slot * self.grid.period_ns;
            let extra = if on_grid && self.stalled.contains(&slot) { self.stall_ns } else { 0 };
            self.inner.sleep_until(deadline_ns + extra);
        }
    }

    fn grid(slots: u64, standby_delay_ns: u64) -> Grid {
        let origin_ns = MonotonicClock::new().now() + 2_000_000;
        Grid { origin_ns, first_tick: 0, period_ns: 1_000_000, slots, standby_delay_ns, previous_wake_ns: None }
    }

    /// Every tick as (slot, runner), the loop's thread stalled `stall_ns` at the `stalled` slots.
    fn run(grid: Grid, stalled: Vec<u64>, stall_ns: u64) -> (Vec<(u64, Runner)>, StandbySummary<&'static str>) {
        let loop_clock = StallingClock { inner: MonotonicClock::new(), grid, stalled, stall_ns };
        let standby_clock = StallingClock { inner: MonotonicClock::new(), grid, stalled: Vec::new(), stall_ns: 0 };
        let mut ticks = Vec::with_capacity(grid.slots as usize);
        let summary = run_with_standby(
            [&loop_clock, &standby_clock],
            grid,
            None,
            &mut (),
            &mut ticks,
            || "set up",
            |ticks: &mut Vec<(u64, Runner)>, info, runner| {
                ticks.push((info.slot, runner));
                ControlFlow::Continue(())
            },
        );
        (ticks, summary)
    }

    #[test]
    fn standby_runs_the_slots_whose_loop_thread_is_stalled_works() {
        // The loop's thread oversleeps slot 5's deadline by 300 ms: the standby, 250 µs behind
        // each deadline, takes slot 5 and every slot after it until the run ends. (Only a
        // standby itself held up 300 ms could miss slot 5, which no load of a test run does.)
        let (ticks, summary) = run(grid(40, 250_000), vec![5], 300_000_000);
        assert_eq!(summary.standby_setup, "set up");
        assert_eq!(summary.ticks + summary.skipped_periods, 40, "{ticks:?}");
        assert!(ticks.windows(2).all(|w| w[0].0 < w[1].0), "each slot once, in order: {ticks:?}");
        assert!(ticks.iter().filter(|t| t.0 >= 5).all(|t| t.1 == Runner::Standby), "{ticks:?}");
        assert!(ticks.iter().any(|t| t.0 == 5), "slot 5 ran: {ticks:?}");
        let by_standby = ticks.iter().filter(|t| t.1 == Runner::Standby).count() as u64;
        assert_eq!(summary.by_standby, by_standby);
    }

    #[test]
    fn standby_leaves_every_slot_to_a_loop_thread_on_time_works() {
        // A standby 500 ms behind never reaches a slot the loop's thread has not run: every tick
        // is the loop's, none twice.
        let (ticks, summary) = run(grid(30, 500_000_000), Vec::new(), 0);
        assert_eq!(summary.by_standby, 0);
        assert!(ticks.iter().all(|t| t.1 == Runner::Loop));
        assert_eq!(summary.ticks + summary.skipped_periods, 30);
        assert!(ticks.windows(2).all(|w| w[0].0 < w[1].0), "{ticks:?}");
    }

    #[test]
    fn a_grid_going_on_from_another_measures_its_first_ticks_period_works() {
        /// Each tick's wake and actual period.
        struct Wakes(Vec<(u64, Option<u64>)>);
        impl TickObserver for Wakes {
            fn on_tick(&mut self, sample: &TickSample) {
                self.0.push((sample.info.wake_ns, sample.actual_period_ns));
            }
        }
        let clock = MonotonicClock::new();
        let mut wakes = Wakes(Vec::with_capacity(20));
        let mut go = |grid: Grid| {
            run_with_standby(
                [&clock, &clock],
                grid,
                None,
                &mut wakes,
                &mut (),
                || (),
                |_, _, _| ControlFlow::Continue(()),
            )
        };
        let first = grid(5, 250_000);
        let a = go(first);
        let second = first.following(&a);
        assert_eq!((second.origin_ns, second.first_tick), (first.origin_ns + 5 * first.period_ns, a.ticks));
        let b = go(second);
        let wakes = wakes.0;
        assert_eq!(wakes.len() as u64, a.ticks + b.ticks);
        assert_eq!(wakes[0].1, None, "a first grid's first tick has no tick before it");
        // Every later tick, the second grid's first included, is measured from the tick before.
        for pair in wakes.windows(2) {
            assert_eq!(pair[1].1, Some(pair[1].0 - pair[0].0), "{wakes:?}");
        }
        assert_eq!(b.last_wake_ns, wakes.last().map(|w| w.0));
    }

    #[test]
    fn baton_goes_to_one_claimant_and_passes_on_its_slot_works() {
        let baton = TickBaton::new(4, 0u32);
        let mut first = baton.claim(4).expect("free");
        assert!(baton.claim(4).is_none(), "held: a second claim fails at once");
        assert_eq!(baton.peek(), (4, true));
        *first.value() += 1;
        first.set_next_slot(5);
        drop(first);
        assert_eq!(baton.peek(), (5, false));
        assert!(baton.claim(4).is_none(), "slot 4 is done");
        drop(baton.claim(5).expect("slot 5 is free"));
        assert_eq!(baton.peek(), (5, false), "a guard dropped without a new slot leaves it to take");
        assert_eq!(baton.into_inner(), 1);
    }
}
