//! Watching device calls: the device loop stamps each `read` and `write_force` when it starts
//! and ends; another thread (the haptics process's watchdog) sees a call that has not
//! returned within [`DEVICE_CALL_LIMIT_NS`] and acts on it while the loop is stuck.

use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};

/// Longest a device call may take, ns: 5 ms. Five periods of a 1 kHz loop, twenty at 4 kHz,
/// and past the 4.5 ms at which a quiet core's force reaches zero. A call that takes longer is
/// a fault.
pub const DEVICE_CALL_LIMIT_NS: u64 = 5_000_000;

/// A device call the loop makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeviceCall {
    /// `HapticDevice::read` (a plugin's `lamina_device_read`).
    Read,
    /// `HapticDevice::write_force` (a plugin's `lamina_device_write_force`).
    WriteForce,
}

impl core::fmt::Display for DeviceCall {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Read => "read",
            Self::WriteForce => "write_force",
        })
    }
}

/// A device call found blocked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stall {
    /// Which call.
    pub call: DeviceCall,
    /// When it started, ns (the loop's clock).
    pub started_ns: u64,
    /// How long it has been running, ns.
    pub blocked_ns: u64,
}

/// The start stamp of the device call in progress, shared between the device loop (which
/// writes it) and a watchdog (which reads it). Lock-free; nothing allocates.
///
/// # Examples
///
/// ```
/// use lamina_haptics::watchdog::{CallWatch, DeviceCall, DEVICE_CALL_LIMIT_NS};
///
/// let watch = CallWatch::new();
/// watch.begin(DeviceCall::Read, 1_000);
/// assert_eq!(watch.blocked(1_000 + DEVICE_CALL_LIMIT_NS, DEVICE_CALL_LIMIT_NS), None);
/// let stall = watch.blocked(1_001 + DEVICE_CALL_LIMIT_NS, DEVICE_CALL_LIMIT_NS).unwrap();
/// assert_eq!((stall.call, stall.blocked_ns), (DeviceCall::Read, DEVICE_CALL_LIMIT_NS + 1));
/// watch.end();
/// assert_eq!(watch.blocked(u64::MAX, DEVICE_CALL_LIMIT_NS), None);
/// ```
#[derive(Debug, Default)]
pub struct CallWatch {
    /// Start of the call in progress, ns, plus one (0: no call in progress).
    started: AtomicU64,
    call: AtomicU8,
}

impl CallWatch {
    /// No call in progress.
    pub fn new() -> Self {
        Self::default()
    }

    /// A call starts at `now_ns`.
    pub fn begin(&self, call: DeviceCall, now_ns: u64) {
        self.call.store(call as u8, Ordering::Relaxed);
        self.started.store(now_ns.saturating_add(1), Ordering::Release);
    }

    /// The call returned.
    pub fn end(&self) {
        self.started.store(0, Ordering::Release);
    }

    /// The call in progress, if any, and when it started, ns.
    pub fn in_progress(&self) -> Option<(DeviceCall, u64)> {
        let stamp = self.started.load(Ordering::Acquire);
        let call = if self.call.load(Ordering::Relaxed) == DeviceCall::WriteForce as u8 {
            DeviceCall::WriteForce
        } else {
            DeviceCall::Read
        };
        (stamp != 0).then(|| (call, stamp - 1))
    }

    /// The call in progress if it has run for more than `limit_ns` at `now_ns`.
    pub fn blocked(&self, now_ns: u64, limit_ns: u64) -> Option<Stall> {
        let (call, started_ns) = self.in_progress()?;
        let blocked_ns = now_ns.saturating_sub(started_ns);
        (blocked_ns > limit_ns).then_some(Stall { call, started_ns, blocked_ns })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_rt::{Clock, FakeClock};

    #[test]
    fn call_watch_sees_a_blocked_call_on_a_fake_clock_works() {
        let clock = FakeClock::new(7_000_000_000);
        let watch = CallWatch::new();
        watch.begin(DeviceCall::WriteForce, clock.now());
        clock.advance(4_900_000);
        assert_eq!(watch.blocked(clock.now(), DEVICE_CALL_LIMIT_NS), None, "4.9 ms is within the 5 ms limit");
        clock.advance(200_000);
        let stall = watch.blocked(clock.now(), DEVICE_CALL_LIMIT_NS).expect("5.1 ms is past it");
        assert_eq!(stall, Stall { call: DeviceCall::WriteForce, started_ns: 7_000_000_000, blocked_ns: 5_100_000 });
        watch.end();
        clock.advance(1_000_000_000);
        assert_eq!(watch.blocked(clock.now(), DEVICE_CALL_LIMIT_NS), None, "a call that returned is not blocked");
        // A call starting at time 0 is still a call in progress (the stamp is offset by one).
        watch.begin(DeviceCall::Read, 0);
        assert_eq!(watch.in_progress(), Some((DeviceCall::Read, 0)));
    }
}
