//! `lamina bench noise`: the machine's own deadline misses. The loop of `lamina run` (pinned,
//! SCHED_FIFO, locked memory, absolute deadlines, the same deadline monitor) runs a fixed
//! synthetic work in place of the physics, once per sleep slice, so the misses of a
//! `lamina run` can be set against what the machine does to any loop of the same length.

use super::machine;
use lamina_rt::standby::{Grid, run_with_standby};
use lamina_rt::steal::StealSnapshot;
use lamina_rt::{
    Clock, DeadlineMonitor, FixedRateLoop, MonitorConfig, MonotonicClock, OverrunPolicy, RealtimeRequest,
    RealtimeSetup, RunLimit,
};
use std::ops::ControlFlow;
use std::time::Instant;

/// Elements the work walks apart, f32s: one 64-byte cache line each.
const STRIDE: usize = 16;

/// A tick is slow when its work takes this many times the median.
const SLOW_FACTOR: u64 = 3;

/// Fast ticks a burst of slow ticks may contain and still count as one burst.
const BURST_JOIN: usize = 3;

/// Most ticks one sleep slice may run (each recorded, 40 bytes): an hour at 1 kHz.
const MAX_TICKS: usize = 3_600_000;

/// What `lamina bench noise` measures.
pub struct NoiseOptions {
    /// Seconds per sleep slice, (0, 3600].
    pub seconds: f64,
    /// Loop rate, Hz.
    pub rate_hz: u32,
    /// Synthetic work per tick, µs.
    pub work_us: f64,
    /// Buffer the work walks, KiB.
    pub working_set_kib: usize,
    /// Sleep slices compared, µs (0: one sleep per tick).
    pub sleep_slices_us: Vec<u32>,
    /// CPU the loop is pinned to; `None`: the last one available.
    pub cpu: Option<usize>,
    /// SCHED_FIFO priority, 0 for none.
    pub fifo_priority: i32,
    /// A standby thread to measure beside the loop alone; `None`: the loop alone.
    pub standby: Option<Standby>,
}

/// A standby thread for the loop ([`lamina_rt::standby`]).
#[derive(Clone, Copy, Debug)]
pub struct Standby {
    /// CPU it is pinned to.
    pub cpu: usize,
    /// How long after a tick's deadline it takes a tick still not started, µs.
    pub delay_us: u32,
}

/// Synthetic work: a dependent read-modify-write walk over a buffer, one cache line per
/// element, resumed each tick where the last one stopped.
struct Work {
    buffer: Vec<f32>,
    cursor: usize,
}

impl Work {
    /// A buffer of `kib` KiB, allocated and touched now; an error if memory refuses it.
    fn new(kib: usize) -> Result<Self, String> {
        let len = (kib * 1024 / 4).max(STRIDE);
        let mut buffer = Vec::new();
        buffer.try_reserve_exact(len).map_err(|e| format!("--working-set-kib {kib}: cannot allocate it ({e})"))?;
        buffer.extend((0..len).map(|i| i as f32 * 1e-6));
        Ok(Self { buffer, cursor: 0 })
    }

    /// Walks `elements` cache lines, each taking half a decaying running sum (which is at most
    /// twice the largest value met, so no value grows past its start or 0.5); returns the sum
    /// so the walk is not optimised out.
    fn walk(&mut self, elements: usize) -> f32 {
        let mut acc = 1.0f32;
        for _ in 0..elements {
            let x = &mut self.buffer[self.cursor];
            acc = acc * 0.5 + *x;
            *x = acc * 0.5;
            self.cursor += STRIDE;
            if self.cursor >= self.buffer.len() {
                self.cursor = 0;
            }
        }
        acc
    }

    /// Elements per `work_ns`, from the fastest of several timed walks of the whole buffer
    /// on this (pinned) thread.
    fn elements_for(&mut self, work_ns: f64) -> usize {
        let lines = self.buffer.len() / STRIDE;
        let passes = (2_000_000 / lines).max(1);
        let mut best = f64::INFINITY;
        for _ in 0..7 {
            let t = Instant::now();
            std::hint::black_box(self.walk(lines * passes));
            best = best.min(t.elapsed().as_secs_f64() * 1e9 / (lines * passes) as f64);
        }
        (work_ns / best).round().max(1.0) as usize
    }
}

/// Runs of slow ticks in a loop's record.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct SlowBursts {
    /// Bursts: runs of slow ticks, each gap of at most [`BURST_JOIN`] fast ticks inside one.
    pub count: usize,
    /// Slow ticks in all.
    pub slow_ticks: usize,
    /// Ticks from the first to the last slow tick of the longest burst.
    pub longest: usize,
}

/// The bursts of ticks slower than `slow_ns` in `compute_ns` (in tick order).
pub fn slow_bursts(compute_ns: impl IntoIterator<Item = u64>, slow_ns: u64) -> SlowBursts {
    let mut bursts = SlowBursts::default();
    // First and last slow tick of the burst under way.
    let mut open: Option<(usize, usize)> = None;
    for (i, c) in compute_ns.into_iter().enumerate() {
        if c <= slow_ns {
            continue;
        }
        bursts.slow_ticks += 1;
        open = match open {
            Some((first, last)) if i - last <= BURST_JOIN + 1 => Some((first, i)),
            previous => {
                if let Some((first, last)) = previous {
                    bursts.longest = bursts.longest.max(last - first + 1);
                }
                bursts.count += 1;
                Some((i, i))
            }
        };
    }
    if let Some((first, last)) = open {
        bursts.longest = bursts.longest.max(last - first + 1);
    }
    bursts
}

/// Runs the loop once per sleep slice and prints the table.
pub fn bench(opts: &NoiseOptions) -> Result<(), String> {
    lamina_rt::seconds_option("--seconds", opts.seconds, 3600.0).map_err(|e| e.to_string())?;
    let period_us = 1e6 / f64::from(opts.rate_hz.max(1));
    if !(opts.work_us.is_finite() && opts.work_us >= 0.0 && opts.work_us < period_us) {
        return Err(format!(
            "--work-us {}: at least 0 and less than the period, {period_us:.1} µs",
            lamina_rt::format_value(opts.work_us)
        ));
    }
    if !(1..=1 << 20).contains(&opts.working_set_kib) {
        return Err(format!("--working-set-kib {}: 1 to 1048576 (1 GiB)", opts.working_set_kib));
    }
    if let Some(bad) = opts.sleep_slices_us.iter().find(|&&s| s != 0 && !(10..=1_000_000).contains(&s)) {
        return Err(format!("--sleep-slices-us {bad}: 0 (one sleep) or 10 to 1000000"));
    }
    if let Some(s) = opts.standby
        && !(10.0..period_us).contains(&f64::from(s.delay_us))
    {
        return Err(format!("--standby-delay-us {}: 10 to less than the period, {period_us:.1} µs", s.delay_us));
    }
    let ticks = (opts.seconds * f64::from(opts.rate_hz)).ceil() as usize;
    if ticks > MAX_TICKS {
        return Err(format!(
            "--seconds {} at {} Hz is {ticks} ticks; at most {MAX_TICKS} are recorded (40 bytes each)",
            opts.seconds, opts.rate_hz
        ));
    }
    super::run::check_cpu("--cpu", opts.cpu)?;
    super::run::check_cpu("--standby-cpu", opts.standby.map(|s| s.cpu))?;
    let cpu = super::run::cpu_or_last(opts.cpu);
    let mut request = RealtimeRequest::new().lock_memory();
    request.cpu = cpu;
    if opts.fifo_priority > 0 {
        request = request.fifo_priority(opts.fifo_priority);
    }
    let mut work = Work::new(opts.working_set_kib)?;
    // Before pinning, which narrows the CPUs the process sees.
    println!("machine: {}", machine::describe());
    print!("{}", RealtimeSetup::apply(&request));
    let elements = work.elements_for(opts.work_us * 1e3);
    println!(
        "loop: {} Hz on CPU {}, {:.0} µs of work per tick ({elements} dependent cache-line updates over {} KiB), {} s per sleep slice; a tick is slow at {SLOW_FACTOR}x the median work",
        opts.rate_hz,
        cpu.map_or("any".into(), |c| c.to_string()),
        opts.work_us,
        opts.working_set_kib,
        opts.seconds
    );
    println!(
        "\n| sleep slice | standby | ticks | misses | lateness p99 | lateness max | work p50 | work p99 | work max | slow ticks | slow bursts | longest burst | host steal on the CPU | skipped periods |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for &slice in &opts.sleep_slices_us {
        for standby in std::iter::once(None).chain(opts.standby.map(Some)) {
            let clock = MonotonicClock::new().with_sleep_slice_ns(u64::from(slice) * 1_000);
            let mut lp = FixedRateLoop::try_new(clock, opts.rate_hz, OverrunPolicy::Skip).map_err(|e| e.to_string())?;
            let config = MonitorConfig::for_period_ns(lp.period_ns()).with_record_capacity(ticks);
            let mut monitor = DeadlineMonitor::try_new(config).map_err(|e| e.to_string())?;
            let steal_before = StealSnapshot::read().ok();
            let mut sink = 0.0f32;
            let window_ns = (opts.seconds * 1e9) as u64;
            let standby_cell = match standby {
                None => {
                    lp.run(RunLimit::duration_ns(window_ns), &mut monitor, |_| {
                        sink += work.walk(elements);
                        ControlFlow::Continue(())
                    });
                    "none".to_string()
                }
                Some(s) => {
                    let period_ns = lp.period_ns();
                    let grid = Grid {
                        origin_ns: clock.now() + period_ns,
                        first_tick: 0,
                        period_ns,
                        slots: window_ns.div_ceil(period_ns),
                        standby_delay_ns: u64::from(s.delay_us) * 1_000,
                        previous_wake_ns: None,
                    };
                    let standby_request = request.for_standby_on(s.cpu);
                    let mut state = (&mut work, &mut sink);
                    // One sleep per wait for the standby, as `lamina run`'s.
                    let standby_clock = clock.with_sleep_slice_ns(0);
                    let summary = run_with_standby(
                        [&clock, &standby_clock],
                        grid,
                        None,
                        &mut monitor,
                        &mut state,
                        || RealtimeSetup::apply(&standby_request).all_granted(),
                        |(work, sink), _, _| {
                            **sink += work.walk(elements);
                            ControlFlow::Continue(())
                        },
                    );
                    if !summary.standby_setup {
                        eprintln!("warning: the standby thread's pinning to CPU {} or priority was refused", s.cpu);
                    }
                    format!("CPU {}, {} µs: ran {} ticks", s.cpu, s.delay_us, summary.by_standby)
                }
            };
            std::hint::black_box(sink);
            let stolen = super::run::loop_steal_ms(StealSnapshot::read().ok().as_ref(), steal_before.as_ref(), cpu);
            let s = monitor.summary();
            let bursts = slow_bursts(monitor.records().iter().map(|r| r.compute_ns), s.compute.p50_ns * SLOW_FACTOR);
            let us = |ns: u64| format!("{:.1} µs", ns as f64 / 1e3);
            println!(
                "| {} | {standby_cell} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} ticks | {stolen} | {} |",
                if slice == 0 { "one sleep".to_string() } else { format!("{slice} µs") },
                s.ticks,
                s.misses,
                us(s.lateness.p99_ns),
                us(s.lateness.max_ns),
                us(s.compute.p50_ns),
                us(s.compute.p99_ns),
                us(s.compute.max_ns),
                bursts.slow_ticks,
                bursts.count,
                bursts.longest,
                s.skipped_periods,
            );
        }
    }
    println!(
        "\nmisses: ticks whose work ended after the budget (the period); skipped periods: slots no tick ran, every thread coming to them a period or more late. Slow ticks are ones the machine slowed: the same work took {SLOW_FACTOR}x its median or more. Set a `lamina run` against these figures at the same compute per tick: misses it shares with this loop belong to the machine."
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slow_bursts_join_short_gaps_and_measure_the_longest_works() {
        let fast = 100;
        let slow = 1_000;
        // Ticks 2-3 slow, 4 fast, 5 slow: one burst of 4 ticks. Ticks 6-9 fast (a gap of 4 >
        // BURST_JOIN): the slow tick 10 starts a second burst.
        let record = [fast, fast, slow, slow, fast, slow, fast, fast, fast, fast, slow, fast];
        assert_eq!(slow_bursts(record, 300), SlowBursts { count: 2, slow_ticks: 4, longest: 4 });
        assert_eq!(slow_bursts([fast; 5], 300), SlowBursts::default());
        assert_eq!(slow_bursts([slow; 5], 300), SlowBursts { count: 1, slow_ticks: 5, longest: 5 });
    }

    #[test]
    fn work_walks_every_cache_line_of_its_buffer_works() {
        let mut work = Work::new(4).unwrap(); // 1,024 f32s: 64 lines
        let lines = work.buffer.len() / STRIDE;
        assert_eq!(lines, 64);
        work.buffer.fill(0.0);
        work.walk(lines);
        assert_eq!(work.cursor, 0, "a walk of every line ends where it started");
        // Line k's first element takes 0.5^(k+2) of the starting sum, 1; no other element is
        // touched.
        for (i, &x) in work.buffer.iter().enumerate() {
            let expected = if i % STRIDE == 0 { 0.5f32.powi((i / STRIDE) as i32 + 2) } else { 0.0 };
            assert_eq!(x, expected, "element {i}");
        }
        // Walked again and again, values stay bounded (no overflow into infinities).
        work.walk(1_000 * lines);
        assert!(work.buffer.iter().all(|&x| (0.0..=0.5).contains(&x)));
    }
}
