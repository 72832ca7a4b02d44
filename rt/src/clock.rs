//! Time sources behind one small trait: [`Clock`].
//!
//! All times are `u64` nanoseconds on a monotonic time line whose origin is
//! unspecified (boot for [`MonotonicClock`], whatever the test chose for
//! [`FakeClock`]). Only differences and comparisons are meaningful.
//!
//! # Examples
//!
//! ```
//! use lamina_rt::{Clock, FakeClock};
//!
//! let clock = FakeClock::new(1_000);
//! clock.sleep_until(5_000); // jumps, does not block
//! assert_eq!(clock.now(), 5_000);
//! clock.advance(250); // "compute" for 250 ns
//! assert_eq!(clock.now(), 5_250);
//! ```

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

/// A monotonic time source that can sleep until an absolute deadline.
///
/// ## Correctness
///
/// - `now()` never goes backwards.
/// - `sleep_until(d)` returns no earlier than `d` (as seen by `now()`); it
///   returns at once if `d` is already in the past.
/// - Both must be usable in a real-time loop: no allocation, no locks.
pub trait Clock {
    /// Current time, ns since an unspecified fixed origin.
    fn now(&self) -> u64;

    /// Blocks (or, for a fake clock, jumps) until `now() >= deadline_ns`.
    fn sleep_until(&self, deadline_ns: u64);
}

impl<C: Clock + ?Sized> Clock for &C {
    fn now(&self) -> u64 {
        (**self).now()
    }

    fn sleep_until(&self, deadline_ns: u64) {
        (**self).sleep_until(deadline_ns);
    }
}

/// Default busy-spin window at the end of [`MonotonicClock::sleep_until`]: 50 µs, in ns.
pub const DEFAULT_SPIN_NS: u64 = 50_000;

/// Default longest single sleep of [`MonotonicClock::sleep_until`]: 100 µs, in ns.
///
/// On a virtual machine a CPU that stays idle longer than the host's halt-polling window
/// (200 µs by default in KVM) is handed back to the host's scheduler, and waking it for the
/// next tick can then take milliseconds. Waking every 100 µs keeps it inside the window.
/// Measured on a 2-vCPU KVM guest, a pinned SCHED_FIFO loop computing 200 µs per 1 ms tick,
/// 30 s: one sleep per tick, 7-46 ticks over 1 ms and wake-ups up to 2.8 ms late; sleeps of
/// at most 100 µs, none over 1 ms and wake-ups at most 0.39 ms late
/// (`docs/benchmarks.md`, `lamina bench noise`).
pub const DEFAULT_SLEEP_SLICE_NS: u64 = 100_000;

const NS_PER_S: u64 = 1_000_000_000;

/// The real clock: `CLOCK_MONOTONIC`, read with `clock_gettime` (vDSO, no
/// system call on Linux).
///
/// [`sleep_until`](Clock::sleep_until) sleeps with
/// `clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME)` until `spin_ns` before
/// the deadline, in sleeps of at most `sleep_slice_ns` each, then busy-spins on
/// `now()` for the rest. The absolute sleep means an interrupted or late sleep
/// never shifts later deadlines; the spin hides the kernel's wake-up latency
/// (typically 5-60 µs) at the cost of up to `spin_ns` of CPU per period; the
/// slices keep a virtual CPU from being descheduled by its host while it waits
/// ([`DEFAULT_SLEEP_SLICE_NS`]), at the cost of a wake-up per slice.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MonotonicClock {
    spin_ns: u64,
    sleep_slice_ns: u64,
}

impl MonotonicClock {
    /// A monotonic clock with the default spin window, [`DEFAULT_SPIN_NS`] (50 µs), and
    /// sleep slice, [`DEFAULT_SLEEP_SLICE_NS`] (100 µs).
    pub const fn new() -> Self {
        Self { spin_ns: DEFAULT_SPIN_NS, sleep_slice_ns: DEFAULT_SLEEP_SLICE_NS }
    }

    /// Sets the longest single sleep, ns; `0` sleeps to the spin window in one call.
    /// Default [`DEFAULT_SLEEP_SLICE_NS`].
    ///
    /// ```
    /// use lamina_rt::{Clock, MonotonicClock};
    ///
    /// let clock = MonotonicClock::new().with_sleep_slice_ns(0);
    /// let deadline = clock.now() + 300_000; // 0.3 ms from now
    /// clock.sleep_until(deadline);
    /// assert!(clock.now() >= deadline);
    /// assert_eq!(clock.sleep_slice_ns(), 0);
    /// ```
    #[must_use]
    pub const fn with_sleep_slice_ns(mut self, sleep_slice_ns: u64) -> Self {
        self.sleep_slice_ns = sleep_slice_ns;
        self
    }

    /// The longest single sleep, ns (`0`: one sleep).
    pub const fn sleep_slice_ns(&self) -> u64 {
        self.sleep_slice_ns
    }

    /// Sets the busy-spin window before each deadline, ns. `0` sleeps all the
    /// way in the kernel (no spin; lateness then includes the kernel's wake-up
    /// latency). Default [`DEFAULT_SPIN_NS`].
    #[must_use]
    pub const fn with_spin_ns(mut self, spin_ns: u64) -> Self {
        self.spin_ns = spin_ns;
        self
    }

    /// The busy-spin window before each deadline, ns.
    pub const fn spin_ns(&self) -> u64 {
        self.spin_ns
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}

fn ns_to_timespec(ns: u64) -> libc::timespec {
    libc::timespec {
        // Fits: u64 ns / 1e9 < 2^35, well inside time_t.
        tv_sec: (ns / NS_PER_S) as libc::time_t,
        tv_nsec: (ns % NS_PER_S) as libc::c_long,
    }
}

/// `CLOCK_MONOTONIC` now, ns since an unspecified origin (usually boot).
///
/// This is the one time base of every Lamina process: it is system-wide on Linux, so a time
/// stamp taken in the core and one taken in the viewer can be subtracted to get a one-way
/// latency (the wire's `publish_time_ns` fields are stamped with it).
/// `std::time::Instant` is not used because its value cannot be sent to another process.
///
/// ```
/// let (a, b) = (lamina_rt::now_ns(), lamina_rt::now_ns());
/// assert!(b >= a);
/// ```
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always
    // exists on Linux, so the call cannot fail.
    unsafe {
        libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts);
    }
    ts.tv_sec as u64 * NS_PER_S + ts.tv_nsec as u64
}

/// Sleeps until `CLOCK_MONOTONIC` reaches `deadline_ns` (absolute, so loops do not drift);
/// returns at once if it has passed and restarts after signal interruptions. No spin: see
/// [`MonotonicClock`] for a sleep that hides the kernel's wake-up latency.
pub fn sleep_until_ns(deadline_ns: u64) {
    let ts = ns_to_timespec(deadline_ns);
    loop {
        // SAFETY: `ts` is a valid timespec; the remaining-time pointer may be null with
        // TIMER_ABSTIME.
        let rc =
            unsafe { libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, std::ptr::null_mut()) };
        // clock_nanosleep returns the error number (not -1/errno). Only EINTR is worth a
        // retry: with an absolute deadline a retry cannot oversleep.
        if rc != libc::EINTR {
            return;
        }
    }
}

impl Clock for MonotonicClock {
    fn now(&self) -> u64 {
        now_ns()
    }

    fn sleep_until(&self, deadline_ns: u64) {
        let coarse = deadline_ns.saturating_sub(self.spin_ns);
        loop {
            let now = self.now();
            if now >= coarse {
                break;
            }
            let until =
                if self.sleep_slice_ns == 0 { coarse } else { coarse.min(now.saturating_add(self.sleep_slice_ns)) };
            sleep_until_ns(until);
        }
        while self.now() < deadline_ns {
            std::hint::spin_loop();
        }
    }
}

/// A per-tick compute-time model for [`FakeClock`]: maps a tick number to the
/// ns of simulated compute for that tick.
pub type ComputeModel = dyn Fn(u64) -> u64 + Send + Sync;

/// A clock for tests: time moves only when told to.
///
/// - [`now`](Clock::now) returns the current fake time, ns.
/// - [`sleep_until`](Clock::sleep_until) jumps straight to the deadline
///   (never backwards).
/// - [`advance`](Self::advance) moves time forward, e.g. to stand for
///   compute time inside a loop body.
/// - A compute model ([`with_compute`](Self::with_compute),
///   [`with_compute_script`](Self::with_compute_script)) gives each tick a
///   scripted compute time; the body calls [`spend`](Self::spend) with its
///   tick number to apply it. This is how tests create overruns
///   deterministically.
///
/// Cloning is cheap and clones share the same time line (an `Arc`), so a test
/// can give one clone to a [`FixedRateLoop`](crate::FixedRateLoop) and move
/// another into the loop body. No operation allocates or locks.
#[derive(Clone)]
pub struct FakeClock {
    now_ns: Arc<AtomicU64>,
    compute: Option<Arc<ComputeModel>>,
}

impl std::fmt::Debug for FakeClock {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FakeClock")
            .field("now_ns", &self.now())
            .field("has_compute_model", &self.compute.is_some())
            .finish()
    }
}

impl FakeClock {
    /// A fake clock reading `start_ns`, with no compute model (every
    /// [`spend`](Self::spend) is 0 ns).
    pub fn new(start_ns: u64) -> Self {
        Self { now_ns: Arc::new(AtomicU64::new(start_ns)), compute: None }
    }

    /// Sets the compute model: `model(tick)` is the ns that
    /// [`spend(tick)`](Self::spend) advances the clock by.
    #[must_use]
    pub fn with_compute(mut self, model: impl Fn(u64) -> u64 + Send + Sync + 'static) -> Self {
        self.compute = Some(Arc::new(model));
        self
    }

    /// Sets a scripted compute model: tick `i` spends `script[i]` ns; ticks
    /// past the end of the script spend 0 ns.
    #[must_use]
    pub fn with_compute_script(self, script: Vec<u64>) -> Self {
        self.with_compute(move |tick| usize::try_from(tick).ok().and_then(|i| script.get(i).copied()).unwrap_or(0))
    }

    /// Moves time forward by `ns`.
    pub fn advance(&self, ns: u64) {
        self.now_ns.fetch_add(ns, Ordering::Relaxed);
    }

    /// Applies the compute model for `tick`: advances by `model(tick)` ns and
    /// returns that amount (0 without a model).
    pub fn spend(&self, tick: u64) -> u64 {
        let ns = self.compute.as_ref().map_or(0, |model| model(tick));
        self.advance(ns);
        ns
    }
}

impl Clock for FakeClock {
    fn now(&self) -> u64 {
        self.now_ns.load(Ordering::Relaxed)
    }

    fn sleep_until(&self, deadline_ns: u64) {
        self.now_ns.fetch_max(deadline_ns, Ordering::Relaxed);
    }
}

/// A number as messages show it: plainly between 1e-3 and 1e6 in magnitude (and 0), in
/// scientific notation otherwise (`1e300`, not 301 digits), `NaN`, `inf` and `-inf` as such.
pub fn format_value(v: f64) -> String {
    if v == 0.0 || (v.is_finite() && (1e-3..1e6).contains(&v.abs())) { format!("{v}") } else { format!("{v:e}") }
}

/// Why [`seconds_option`] refused a run length.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{option} {}: must be a number of seconds above 0 and at most {}", format_value(*.seconds), format_value(*.max_s))]
pub struct SecondsOptionError {
    /// The option, e.g. `--seconds`.
    pub option: String,
    /// The value given, s.
    pub seconds: f64,
    /// The largest value accepted, s.
    pub max_s: f64,
}

/// The run length `seconds` given as command-line option `option`, when it is a number
/// above 0 and at most `max_s` (seconds); NaN, infinities, 0, negative values and values
/// above `max_s` are refused, never clamped.
///
/// # Errors
/// [`SecondsOptionError`] naming the option, the value and the bound.
pub fn seconds_option(option: &str, seconds: f64, max_s: f64) -> Result<core::time::Duration, SecondsOptionError> {
    let refuse = || SecondsOptionError { option: option.to_owned(), seconds, max_s };
    if !(seconds > 0.0 && seconds <= max_s) {
        return Err(refuse());
    }
    core::time::Duration::try_from_secs_f64(seconds).map_err(|_| refuse())
}

#[cfg(test)]
mod tests {
    #[test]
    fn seconds_option_refuses_values_outside_its_bound_fail() {
        use super::seconds_option;
        assert_eq!(seconds_option("--seconds", 2.5, 1e9), Ok(core::time::Duration::from_millis(2500)));
        assert_eq!(seconds_option("--seconds", 1e9, 1e9), Ok(core::time::Duration::from_secs(1_000_000_000)));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1.0, 0.0, 1e300, 1.000_001e9] {
            let e = seconds_option("--seconds", bad, 1e9).unwrap_err().to_string();
            assert!(e.starts_with("--seconds ") && e.ends_with("above 0 and at most 1e9"), "{e}");
        }
        let e = seconds_option("--seconds", 1e300, 1e9).unwrap_err().to_string();
        assert_eq!(e, "--seconds 1e300: must be a number of seconds above 0 and at most 1e9");
        let e = seconds_option("--seconds", f64::NAN, 1e9).unwrap_err().to_string();
        assert!(e.starts_with("--seconds NaN:"), "{e}");
    }

    use super::*;

    #[test]
    fn fake_clock_sleep_never_goes_back_works() {
        let clock = FakeClock::new(100);
        clock.sleep_until(50);
        assert_eq!(clock.now(), 100);
        clock.sleep_until(300);
        assert_eq!(clock.now(), 300);
    }

    #[test]
    fn fake_clock_compute_script_works() {
        let clock = FakeClock::new(0).with_compute_script(vec![10, 20]);
        let shared = clock.clone();
        assert_eq!(clock.spend(0), 10);
        assert_eq!(clock.spend(1), 20);
        assert_eq!(clock.spend(2), 0);
        assert_eq!(shared.now(), 30);
    }

    #[test]
    fn monotonic_clock_sleep_until_reaches_deadline_works() {
        let clock = MonotonicClock::new().with_spin_ns(20_000);
        let mut last = clock.now();
        for _ in 0..20 {
            let deadline = clock.now() + 100_000;
            clock.sleep_until(deadline);
            let now = clock.now();
            assert!(now >= deadline);
            assert!(now >= last);
            last = now;
        }
        // A deadline in the past returns at once without sleeping.
        clock.sleep_until(0);
    }

    #[test]
    fn monotonic_clock_sliced_sleep_reaches_deadline_works() {
        for slice_ns in [0, 10_000, 100_000, 5_000_000] {
            let clock = MonotonicClock::new().with_sleep_slice_ns(slice_ns);
            let deadline = clock.now() + 1_000_000;
            clock.sleep_until(deadline);
            assert!(clock.now() >= deadline, "slice {slice_ns} ns");
        }
    }
}
