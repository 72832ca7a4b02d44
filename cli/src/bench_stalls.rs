//! `lamina bench stalls`: the machine's stops, CPU by CPU and of every CPU at once. One thread
//! per CPU, pinned and at SCHED_FIFO, reads the clock as fast as it can
//! ([`lamina_rt::stalls`]); the stops of every CPU at once are the ones no thread on another
//! CPU can cover, a `lamina run` standby included, and the table turns them into the deadlines
//! a loop of the given rate and compute misses through them.

use super::machine;
use lamina_rt::stalls::{Gap, WatchPlan, all_at_once, expected_misses, watch};
use lamina_rt::steal::StealSnapshot;
use lamina_rt::{Clock, MonotonicClock, RealtimeRequest, RealtimeSetup, available_cpus};

/// One watch cycle, ns: each thread spins [`SPIN_NS`] of it and sleeps the rest.
const CYCLE_NS: u64 = 10_000_000;

/// Spinning part of each cycle, ns: 90 %, under the kernel's real-time throttling (by default
/// SCHED_FIFO threads may take 95 % of each second of a CPU), which would otherwise stop every
/// spinner at once and read as a stop of the machine.
const SPIN_NS: u64 = 9_000_000;

/// Most stops one CPU's list holds (16 bytes each); further ones are counted as dropped.
const MAX_GAPS_PER_CPU: usize = 1 << 20;

/// Stop lengths the table counts, µs, besides the threshold.
const LONG_STOPS_US: [u64; 2] = [500, 1_000];

/// `500 µs`, `1 ms`: a stop length for the table's header.
fn duration_label(us: u64) -> String {
    if us.is_multiple_of(1_000) { format!("{} ms", us / 1_000) } else { format!("{us} µs") }
}

/// What `lamina bench stalls` measures.
pub struct StallOptions {
    /// Seconds watched, (0, 3600].
    pub seconds: f64,
    /// Shortest stop counted, µs: two clock readings further apart than this.
    pub gap_us: u64,
    /// SCHED_FIFO priority of the watching threads, 0 for none.
    pub fifo_priority: i32,
    /// Rate of the loop the misses are reckoned for, Hz.
    pub rate_hz: u32,
    /// Compute per tick of that loop, µs.
    pub work_us: f64,
}

/// What one CPU's watcher saw.
struct CpuWatch {
    cpu: usize,
    gaps: Vec<Gap>,
    watched_ns: u64,
    dropped: u64,
    setup_refused: Option<String>,
}

/// Watches every available CPU and prints the table.
pub fn bench(opts: &StallOptions) -> Result<(), String> {
    lamina_rt::seconds_option("--seconds", opts.seconds, 3600.0).map_err(|e| e.to_string())?;
    if !(5..=100_000).contains(&opts.gap_us) {
        return Err(format!("--gap-us {}: 5 to 100000", opts.gap_us));
    }
    if !(0..=99).contains(&opts.fifo_priority) {
        return Err(format!("--fifo-priority {}: 0 (none) to 99", opts.fifo_priority));
    }
    if !(1..=100_000).contains(&opts.rate_hz) {
        return Err(format!("--rate-hz {}: 1 to 100000", opts.rate_hz));
    }
    let period_ns = 1_000_000_000 / u64::from(opts.rate_hz);
    if !(opts.work_us.is_finite() && opts.work_us >= 0.0 && opts.work_us * 1e3 < period_ns as f64) {
        return Err(format!(
            "--work-us {}: at least 0 and less than the period, {:.1} µs",
            lamina_rt::format_value(opts.work_us),
            period_ns as f64 / 1e3
        ));
    }
    let cpus = available_cpus();
    let clock = MonotonicClock::new();
    let plan = WatchPlan {
        // Time for every thread to start and set itself up before the first cycle.
        origin_ns: clock.now() + 50_000_000,
        cycle_ns: CYCLE_NS,
        spin_ns: SPIN_NS,
        cycles: ((opts.seconds * 1e9) as u64).div_ceil(CYCLE_NS),
        threshold_ns: opts.gap_us * 1_000,
    };
    let capacity = usize::try_from(plan.spin_total_ns() / plan.threshold_ns + 1).unwrap_or(usize::MAX);
    let capacity = capacity.min(MAX_GAPS_PER_CPU);
    println!("machine: {}", machine::describe());
    println!(
        "watching CPUs {cpus:?} for {} s: on each, one thread{} reads the clock for {} ms of every {} ms; a stop is two readings more than {} µs apart",
        opts.seconds,
        if opts.fifo_priority > 0 { format!(" at SCHED_FIFO {}", opts.fifo_priority) } else { String::new() },
        SPIN_NS / 1_000_000,
        CYCLE_NS / 1_000_000,
        opts.gap_us
    );
    let steal_before = StealSnapshot::read().ok();
    let watches: Vec<CpuWatch> = std::thread::scope(|scope| {
        let threads: Vec<_> = cpus
            .iter()
            .map(|&cpu| {
                scope.spawn(move || {
                    let mut request = RealtimeRequest::new().pin_to(cpu);
                    if opts.fifo_priority > 0 {
                        request = request.fifo_priority(opts.fifo_priority);
                    }
                    let setup = RealtimeSetup::apply(&request);
                    let setup_refused = (!setup.all_granted()).then(|| setup.to_string());
                    let mut gaps = Vec::with_capacity(capacity);
                    let totals = watch(&MonotonicClock::new(), &plan, &mut gaps);
                    CpuWatch { cpu, gaps, watched_ns: totals.watched_ns, dropped: totals.dropped, setup_refused }
                })
            })
            .collect();
        threads.into_iter().map(|t| t.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))).collect()
    });
    let steal_after = StealSnapshot::read().ok();
    for w in &watches {
        if let Some(refused) = &w.setup_refused {
            eprint!(
                "warning: CPU {}'s watcher was not set up as asked (its stops include the kernel's):\n{refused}",
                w.cpu
            );
        }
        if w.dropped > 0 {
            eprintln!("warning: CPU {}: {} stops past the first {capacity} were not recorded", w.cpu, w.dropped);
        }
    }
    let lists: Vec<&[Gap]> = watches.iter().map(|w| &w.gaps[..]).collect();
    let shared = all_at_once(&lists);
    let watched_ns = watches.iter().map(|w| w.watched_ns).min().unwrap_or(0);
    let compute_ns = (opts.work_us * 1e3) as u64;
    let per_minute = |misses: f64| if watched_ns == 0 { 0.0 } else { misses * 60e9 / watched_ns as f64 };
    println!(
        "\n| CPUs | stops | ≥ {} | ≥ {} | longest | total | loop misses per minute | host steal (/proc/stat) |",
        duration_label(LONG_STOPS_US[0]),
        duration_label(LONG_STOPS_US[1])
    );
    println!("|---|---|---|---|---|---|---|---|");
    let row = |name: String, gaps: &[Gap], stolen: String| {
        let at_least = |us: u64| gaps.iter().filter(|g| g.len_ns() >= us * 1_000).count();
        let ms = |ns: u64| format!("{:.2} ms", ns as f64 / 1e6);
        println!(
            "| {name} | {} | {} | {} | {} | {} | {:.1} | {stolen} |",
            gaps.len(),
            at_least(LONG_STOPS_US[0]),
            at_least(LONG_STOPS_US[1]),
            ms(gaps.iter().map(Gap::len_ns).max().unwrap_or(0)),
            ms(gaps.iter().map(Gap::len_ns).sum()),
            per_minute(expected_misses(gaps, period_ns, compute_ns)),
        );
    };
    for w in &watches {
        let stolen = super::run::loop_steal_ms(steal_after.as_ref(), steal_before.as_ref(), Some(w.cpu));
        row(format!("CPU {}", w.cpu), &w.gaps, stolen);
    }
    if watches.len() > 1 {
        row("every CPU at once".into(), &shared, "-".into());
    }
    println!(
        "\nwatched {:.1} s of each CPU. Loop misses per minute: the deadlines a loop at {} Hz computing {} µs per tick misses through these stops, on average over its phase (a stop longer than the {:.0} µs between its ticks pushes a tick past its budget). A loop on one CPU misses through that CPU's stops; a loop with a standby thread on another CPU (`[realtime] standby_cpu`) through the stops of every CPU at once, which no thread can cover.",
        watched_ns as f64 / 1e9,
        opts.rate_hz,
        opts.work_us,
        (period_ns - compute_ns) as f64 / 1e3
    );
    Ok(())
}
