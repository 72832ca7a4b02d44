//! The one clock every Lamina process stamps messages with: `CLOCK_MONOTONIC`.
//!
//! `CLOCK_MONOTONIC` is system-wide on Linux, so a time taken in the core and one taken in the
//! viewer can be subtracted to get a one-way latency. `std::time::Instant` is not used because
//! its value cannot be sent to another process.
//!
//! # Examples
//!
//! ```
//! let a = lamina_bridge::clock::now_ns();
//! let b = lamina_bridge::clock::now_ns();
//! assert!(b >= a);
//! ```

/// Current `CLOCK_MONOTONIC` time in nanoseconds (since an unspecified start, usually boot).
///
/// Never fails: should `clock_gettime` ever report an error (it cannot for this clock on
/// Linux), 0 is returned.
pub fn now_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec and CLOCK_MONOTONIC is always available.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    if rc != 0 {
        return 0;
    }
    (ts.tv_sec as u64).saturating_mul(1_000_000_000).saturating_add(ts.tv_nsec as u64)
}

/// Sleeps until `CLOCK_MONOTONIC` reaches `deadline_ns` (absolute, so loops do not drift).
///
/// Returns at once if the deadline has passed; restarts after signal interruptions.
pub fn sleep_until_ns(deadline_ns: u64) {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / 1_000_000_000) as libc::time_t,
        tv_nsec: (deadline_ns % 1_000_000_000) as libc::c_long,
    };
    loop {
        // SAFETY: `ts` is a valid timespec; the remainder pointer may be null with TIMER_ABSTIME.
        let rc =
            unsafe { libc::clock_nanosleep(libc::CLOCK_MONOTONIC, libc::TIMER_ABSTIME, &ts, core::ptr::null_mut()) };
        if rc != libc::EINTR {
            return;
        }
    }
}
