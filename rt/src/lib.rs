//! Real-time plumbing for Lamina: clocks, fixed-rate loops on absolute
//! deadlines, the deadline monitor, and real-time setup (CPU pinning,
//! `SCHED_FIFO`, locked memory, stop signals).
//!
//! Used by the core process (physics at a fixed rate, 1 kHz by default) and
//! the haptics process (device loop at 1-4 kHz).
//!
//! # How it fits together
//!
//! 1. [`Clock`]: `now()` and `sleep_until(deadline)` in ns.
//!    [`MonotonicClock`] is the real one; [`FakeClock`] moves only when told,
//!    so tests are exact and never depend on wall time.
//! 2. [`FixedRateLoop`]: `next += period; sleep_until(next)`, never "sleep one
//!    period"; overruns handled by an explicit, counted [`OverrunPolicy`].
//! 3. [`DeadlineMonitor`]: per-tick lateness, compute, period and send time
//!    into HDR histograms, misses, worst ticks, a [`MonitorSummary`] table and
//!    a JSON report.
//! 4. [`RealtimeSetup`] and [`install_stop_handler`]: the process-level setup,
//!    each refusal reported, never a panic.
//! 5. [`host`]: the machine and start time a run's report records; [`steal`]: the time a
//!    hypervisor took from each CPU over a run; [`stalls`]: the stops of every CPU at once, which
//!    no thread can cover; [`digest`]: the scene file's SHA-256.
//!
//! **Architecture invariant:** the per-tick path (loop + monitor recording)
//! allocates nothing, takes no lock and does no I/O; `tests/no_alloc.rs`
//! checks the allocation part with a counting global allocator.
//!
//! # Examples
//!
//! ```
//! use std::ops::ControlFlow;
//! use lamina_rt::{DeadlineMonitor, FakeClock, FixedRateLoop, MonitorConfig, OverrunPolicy, RunLimit};
//!
//! let clock = FakeClock::new(0).with_compute(|_| 200_000); // 0.2 ms per tick
//! let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::CatchUp);
//! let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(lp.period_ns()));
//! let run = lp.run(RunLimit::duration_ns(1_000_000_000), &mut monitor, |info| {
//!     clock.spend(info.tick);
//!     ControlFlow::Continue(())
//! });
//! assert_eq!(run.ticks, 1_000);
//! assert_eq!(monitor.summary().misses, 0);
//! ```

#![warn(missing_docs)]

pub mod clock;
pub mod digest;
pub mod fixed_rate;
pub mod host;
pub mod logging;
pub mod monitor;
pub mod ring;
pub mod setup;
pub mod signal;
pub mod stalls;
pub mod standby;
pub mod steal;
pub mod summary;
pub mod tick;
pub mod worst;

pub use clock::{
    Clock, ComputeModel, DEFAULT_SLEEP_SLICE_NS, DEFAULT_SPIN_NS, FakeClock, MonotonicClock, SecondsOptionError,
    format_value, now_ns, seconds_option, sleep_until_ns,
};
pub use fixed_rate::{
    FixedRateLoop, FixedRateLoopCreateError, OverrunPolicy, RunLimit, RunSummary, StopReason, period_ns_from_rate_hz,
};
pub use logging::init_logging;
pub use monitor::{
    DEFAULT_MAX_TRACKABLE_NS, DEFAULT_PERIOD_NS, DeadlineMonitor, DeadlineMonitorCreateError, MonitorConfig,
    MonitorReportWriteError, SIGNIFICANT_DIGITS, SendProbe,
};
pub use ring::{TickRecord, TickRecordRing};
pub use setup::{
    CpuOptionError, FifoPrioritySetError, Grant, MemoryLockError, RealtimeRequest, RealtimeSetup, ThreadPinError,
    available_cpus, format_cpu_list, lock_memory, pin_current_thread, pin_for_option, set_fifo_priority, unlock_memory,
};
pub use signal::{StopHandlerInstallError, caught_stop_signal, install_stop_handler, signal_name};
pub use summary::{MonitorSummary, Percentiles};
pub use tick::{TickInfo, TickObserver, TickSample};
pub use worst::{WORST_TICKS, WorstTick, WorstTicks};
