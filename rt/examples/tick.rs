//! An empty fixed-rate loop on the real clock, pinned and at SCHED_FIFO when
//! allowed; prints the real-time setup, a line per second and the deadline
//! monitor table at the end.
//!
//! ```text
//! cargo run --release -p lamina-rt --example tick -- \
//!     [--seconds 5] [--rate 1000] [--cpu LAST] [--prio 80] \
//!     [--policy skip|catch-up] [--spin-us 50] [--report tick.json]
//! ```
//!
//! Stops early, cleanly, on SIGINT / SIGTERM.

use std::io::Write;
use std::ops::ControlFlow;
use std::sync::atomic::AtomicBool;

use lamina_rt::{
    Clock, DeadlineMonitor, FixedRateLoop, MonitorConfig, MonotonicClock, OverrunPolicy, RealtimeRequest,
    RealtimeSetup, RunLimit, StopReason, available_cpus, install_stop_handler,
};

static STOP: AtomicBool = AtomicBool::new(false);

struct Args {
    seconds: u64,
    rate_hz: u32,
    cpu: Option<usize>,
    prio: i32,
    policy: OverrunPolicy,
    spin_us: u64,
    report: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        seconds: 5,
        rate_hz: 1_000,
        cpu: available_cpus().last().copied(),
        prio: 80,
        policy: OverrunPolicy::Skip,
        spin_us: 50,
        report: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let mut value = || it.next().ok_or(format!("{flag} needs a value"));
        let bad = |e: std::num::ParseIntError| format!("{flag}: {e}");
        match flag.as_str() {
            "--seconds" => a.seconds = value()?.parse().map_err(bad)?,
            "--rate" => a.rate_hz = value()?.parse().map_err(bad)?,
            "--cpu" => a.cpu = Some(value()?.parse().map_err(bad)?),
            "--prio" => a.prio = value()?.parse().map_err(bad)?,
            "--spin-us" => a.spin_us = value()?.parse().map_err(bad)?,
            "--report" => a.report = Some(value()?),
            "--policy" => {
                a.policy = match value()?.as_str() {
                    "skip" => OverrunPolicy::Skip,
                    "catch-up" => OverrunPolicy::CatchUp,
                    other => return Err(format!("--policy: unknown {other:?}")),
                }
            }
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    Ok(a)
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("tick: {e}");
            std::process::exit(2);
        }
    };
    if let Err(e) = install_stop_handler(&STOP) {
        eprintln!("tick: {e}; Ctrl-C will kill without a report");
    }

    let clock = MonotonicClock::new().with_spin_ns(args.spin_us * 1_000);
    let mut lp = match FixedRateLoop::try_new(clock, args.rate_hz, args.policy) {
        Ok(lp) => lp,
        Err(e) => {
            eprintln!("tick: {e}");
            std::process::exit(2);
        }
    };
    let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(lp.period_ns()));

    let mut request = RealtimeRequest::new().fifo_priority(args.prio).lock_memory();
    request.cpu = args.cpu;
    let setup = RealtimeSetup::apply(&request);
    print!("{setup}");
    println!("running {} s at {} Hz, policy {}, spin {} µs", args.seconds, args.rate_hz, args.policy, args.spin_us);

    // One run per second; the one-line summary is printed between runs, in the
    // slack before the next deadline, so the grid is unbroken.
    let mut stdout = std::io::stdout().lock();
    for second in 1..=args.seconds {
        let run = lp.run(RunLimit::duration_ns(1_000_000_000).and_stop_flag(&STOP), &mut monitor, |_| {
            ControlFlow::Continue(())
        });
        let t0 = lp.clock().now();
        let s = monitor.summary();
        let summary_ns = lp.clock().now() - t0;
        let _ = writeln!(
            stdout,
            "[{second:>3} s] ticks {} misses {} skipped {} | lateness p99 {} ns max {} ns | \
             compute max {} ns | summary() took {summary_ns} ns",
            s.ticks, s.misses, s.skipped_periods, s.lateness.p99_ns, s.lateness.max_ns, s.compute.max_ns
        );
        if run.stop == StopReason::StopFlag {
            let _ = writeln!(stdout, "stopped by signal");
            break;
        }
    }
    drop(stdout);

    println!("\n{monitor}");
    if let Some(path) = args.report {
        match monitor.write_report(&path) {
            Ok(()) => println!("report written to {path}"),
            Err(e) => eprintln!("tick: {e}"),
        }
    }
}
