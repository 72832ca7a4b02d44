//! The machine's stops: time a CPU ran none of a thread that had nothing to wait for. One
//! thread per CPU reads the clock as fast as it can ([`watch`]); two readings further apart
//! than a threshold are a stop (a [`Gap`]): the host taking the virtual CPU, an interrupt, the
//! kernel's own work. Stops of every CPU at once ([`all_at_once`]) are the ones no thread on
//! another CPU can cover, a loop's standby included; [`expected_misses`] turns them into the
//! deadlines a fixed-rate loop misses through them.
//!
//! # Examples
//!
//! Two CPUs' stops; only the stretch both share counts as a stop of the whole machine, and
//! a 1 kHz loop computing 100 µs per tick loses a deadline to it only if it is longer than
//! the 900 µs left between its ticks:
//!
//! ```
//! use lamina_rt::stalls::{Gap, all_at_once, expected_misses};
//!
//! let cpu0 = [Gap { start_ns: 1_000_000, end_ns: 3_000_000 }];
//! let cpu1 = [Gap { start_ns: 1_500_000, end_ns: 4_000_000 }, Gap { start_ns: 9_000_000, end_ns: 9_400_000 }];
//! let both = all_at_once(&[&cpu0[..], &cpu1[..]]);
//! assert_eq!(both, [Gap { start_ns: 1_500_000, end_ns: 3_000_000 }]);
//! // 1.5 ms: 0.6 ms past the 0.9 ms slack, so 0.6 of a deadline on average over the phase.
//! assert!((expected_misses(&both, 1_000_000, 100_000) - 0.6).abs() < 1e-12);
//! ```

use crate::clock::Clock;

/// A stretch of time, ns on a clock's time line: `[start_ns, end_ns)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gap {
    /// The last reading before the stop, ns.
    pub start_ns: u64,
    /// The first reading after it, ns.
    pub end_ns: u64,
}

impl Gap {
    /// Its length, ns.
    pub fn len_ns(&self) -> u64 {
        self.end_ns.saturating_sub(self.start_ns)
    }
}

/// When a watching thread spins and when it rests: it spins over `[origin + k·cycle,
/// origin + k·cycle + spin)` and sleeps for the rest of each cycle, so that threads of every
/// CPU watch the same stretches and a SCHED_FIFO spinner leaves the kernel's real-time
/// throttling (by default 95 % of each second per CPU) nothing to cut.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WatchPlan {
    /// Start of the first cycle, ns on the clock's time line.
    pub origin_ns: u64,
    /// Cycle length, ns (> 0).
    pub cycle_ns: u64,
    /// Spinning part of each cycle, ns (at most `cycle_ns`).
    pub spin_ns: u64,
    /// Cycles watched.
    pub cycles: u64,
    /// Shortest stop recorded, ns: two readings further apart than this are a [`Gap`].
    pub threshold_ns: u64,
}

impl WatchPlan {
    /// The time the plan spins, ns: what a [`watch`] that was never late watches.
    pub fn spin_total_ns(&self) -> u64 {
        self.cycles.saturating_mul(self.spin_ns.min(self.cycle_ns))
    }
}

/// What one thread's [`watch`] saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct WatchTotals {
    /// Time it spun, ns (cycles whose rest ended after their spin's end are not watched).
    pub watched_ns: u64,
    /// Stops longer than the threshold that found `gaps` full and were dropped.
    pub dropped: u64,
}

/// Watches for stops on the calling thread: spins on `clock.now()` through each cycle's
/// spinning part (see [`WatchPlan`]) and pushes every stretch between two readings longer
/// than `plan.threshold_ns` onto `gaps`, while `gaps` has room (its capacity is never grown,
/// so nothing is allocated while watching). A stop straddling the end of a spin counts whole;
/// the sleep between spins does not count.
pub fn watch<C: Clock>(clock: &C, plan: &WatchPlan, gaps: &mut Vec<Gap>) -> WatchTotals {
    let mut totals = WatchTotals::default();
    let spin_ns = plan.spin_ns.min(plan.cycle_ns);
    for k in 0..plan.cycles {
        let start = plan.origin_ns.saturating_add(k.saturating_mul(plan.cycle_ns));
        let end = start.saturating_add(spin_ns);
        clock.sleep_until(start);
        let mut prev = clock.now();
        if prev >= end {
            continue;
        }
        let first = prev;
        while prev < end {
            let t = clock.now();
            if t.saturating_sub(prev) > plan.threshold_ns {
                if gaps.len() < gaps.capacity() {
                    gaps.push(Gap { start_ns: prev, end_ns: t });
                } else {
                    totals.dropped += 1;
                }
            }
            prev = t;
        }
        totals.watched_ns += prev.saturating_sub(first);
    }
    totals
}

/// The stretches in which every list has a gap: the intersection of `cpus`' stops, each list
/// in time order and without overlaps (as [`watch`] gives them). Empty for no lists.
pub fn all_at_once(cpus: &[&[Gap]]) -> Vec<Gap> {
    let Some((first, rest)) = cpus.split_first() else { return Vec::new() };
    rest.iter().fold(first.to_vec(), |shared, other| intersect(&shared, other))
}

/// The intersection of two time-ordered, non-overlapping lists of gaps.
fn intersect(a: &[Gap], b: &[Gap]) -> Vec<Gap> {
    let (mut i, mut j, mut out) = (0, 0, Vec::new());
    while i < a.len() && j < b.len() {
        let start_ns = a[i].start_ns.max(b[j].start_ns);
        let end_ns = a[i].end_ns.min(b[j].end_ns);
        if start_ns < end_ns {
            out.push(Gap { start_ns, end_ns });
        }
        if a[i].end_ns <= b[j].end_ns {
            i += 1;
        } else {
            j += 1;
        }
    }
    out
}

/// Deadlines a loop of period `period_ns`, computing `compute_ns` per tick, misses through
/// `stops` of the whole machine, averaged over the loop's phase.
///
/// A deadline `d` falling in a stop `[s, e)` is missed when its tick, started at `e` at the
/// earliest, ends after `d + period`: when `d < e + compute - period`. The deadlines of the
/// grid falling in `[s, e + compute - period)`, over a uniform phase, number
/// `max(0, len + compute - period) / period` on average, for each stop.
pub fn expected_misses(stops: &[Gap], period_ns: u64, compute_ns: u64) -> f64 {
    let slack = period_ns.saturating_sub(compute_ns) as f64;
    // A fold from +0.0: a sum of no stops is 0, not the -0.0 `Sum` starts from.
    stops.iter().fold(0.0, |misses, g| misses + (g.len_ns() as f64 - slack).max(0.0) / period_ns as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::Cell;

    /// A clock each `now()` of which moves on 1 µs, and by `jump_ns` more at the readings in
    /// `jumps_at` (counted from 0); sleeping jumps to the deadline.
    struct SteppingClock {
        t: Cell<u64>,
        readings: Cell<u64>,
        jumps_at: Vec<u64>,
        jump_ns: u64,
    }

    impl Clock for SteppingClock {
        fn now(&self) -> u64 {
            let n = self.readings.get();
            self.readings.set(n + 1);
            let step = if self.jumps_at.contains(&n) { 1_000 + self.jump_ns } else { 1_000 };
            self.t.set(self.t.get() + step);
            self.t.get()
        }

        fn sleep_until(&self, deadline_ns: u64) {
            self.t.set(self.t.get().max(deadline_ns));
        }
    }

    #[test]
    fn watch_records_each_jump_past_the_threshold_once_works() {
        let clock = SteppingClock { t: Cell::new(0), readings: Cell::new(0), jumps_at: vec![10, 50], jump_ns: 300_000 };
        // Two cycles of 1 ms spinning 0.5 ms each; 1 µs readings, so the first cycle reads
        // about 500 times and sees both jumps (readings 10 and 50).
        let plan = WatchPlan { origin_ns: 0, cycle_ns: 1_000_000, spin_ns: 500_000, cycles: 2, threshold_ns: 100_000 };
        let mut gaps = Vec::with_capacity(8);
        let totals = watch(&clock, &plan, &mut gaps);
        assert_eq!(gaps.len(), 2);
        for g in &gaps {
            assert_eq!(g.len_ns(), 301_000);
        }
        // Reading 10 comes 11 µs in (readings 0-10 each 1 µs), so its stop starts 10 µs in.
        assert_eq!(gaps[0].start_ns, 10_000);
        assert_eq!(totals.dropped, 0);
        // The first spin runs from the first reading (1 µs) to the one after the second jump
        // (51 µs of readings plus 600 µs of stops); the second from 1.001 ms to 1.5 ms.
        assert_eq!(totals.watched_ns, 650_000 + 499_000);
    }

    #[test]
    fn watch_drops_stops_past_its_capacity_and_skips_cycles_entered_late_works() {
        let clock =
            SteppingClock { t: Cell::new(0), readings: Cell::new(0), jumps_at: vec![1, 2, 3], jump_ns: 200_000 };
        let plan = WatchPlan { origin_ns: 0, cycle_ns: 1_000_000, spin_ns: 900_000, cycles: 1, threshold_ns: 100_000 };
        let mut gaps = Vec::with_capacity(2);
        let totals = watch(&clock, &plan, &mut gaps);
        assert_eq!((gaps.len(), totals.dropped), (2, 1));
        // A clock already past the spin's end when the cycle starts watches nothing.
        let late = SteppingClock { t: Cell::new(5_000_000), readings: Cell::new(0), jumps_at: vec![], jump_ns: 0 };
        let totals = watch(&late, &WatchPlan { cycles: 3, ..plan }, &mut Vec::new());
        assert_eq!(totals.watched_ns, 0);
    }

    #[test]
    fn all_at_once_is_the_stretch_every_cpu_shares_works() {
        let g = |s: u64, e: u64| Gap { start_ns: s, end_ns: e };
        let a = [g(0, 10), g(20, 30), g(40, 50)];
        let b = [g(5, 25), g(45, 46), g(60, 70)];
        let c = [g(0, 100)];
        assert_eq!(all_at_once(&[&a[..], &b[..]]), [g(5, 10), g(20, 25), g(45, 46)]);
        assert_eq!(all_at_once(&[&a[..], &b[..], &c[..]]), [g(5, 10), g(20, 25), g(45, 46)]);
        // Touching ends share no time; one CPU's stops are its own; no CPUs, no stops.
        assert_eq!(all_at_once(&[&[g(0, 10)][..], &[g(10, 20)][..]]), []);
        assert_eq!(all_at_once(&[&a[..]]), a);
        assert_eq!(all_at_once(&[]), []);
        assert!(expected_misses(&[], 1_000, 0).is_sign_positive());
    }

    #[test]
    fn expected_misses_count_the_deadlines_a_stop_pushes_past_their_budget_works() {
        // Checked against a count over every phase of a 1 µs grid: a stop of length L at a
        // phase p, a loop computing c per period P.
        let (period, compute) = (1_000u64, 100u64);
        for len in [0u64, 500, 900, 901, 1_000, 1_899, 2_500, 7_300] {
            let stop = Gap { start_ns: 10_000, end_ns: 10_000 + len };
            let mut missed = 0u64;
            for phase in 0..period {
                // Deadlines phase + kP; one in [s, e) starts at e and ends at e + c.
                let mut d = phase;
                while d < stop.end_ns {
                    if d >= stop.start_ns && stop.end_ns + compute > d + period {
                        missed += 1;
                    }
                    d += period;
                }
            }
            let counted = missed as f64 / period as f64;
            let expected = expected_misses(&[stop], period, compute);
            assert!((counted - expected).abs() < 1.5e-3, "L {len}: counted {counted}, formula {expected}");
        }
    }
}
