//! SIGINT/SIGTERM handling for loops: a handler that only sets a stop flag.
//!
//! The handler is async-signal-safe: it does two lock-free atomic stores and
//! nothing else. The loop sees the flag through
//! [`RunLimit::until_stopped`](crate::RunLimit::until_stopped) and stops
//! between ticks, so the process can write its report and exit cleanly.
//!
//! The handler is installed with `SA_RESETHAND`: the first signal sets the
//! flag, a second one of the same kind gets the default action (terminate),
//! so a loop that is stuck can still be stopped with a second Ctrl-C.
//!
//! # Examples
//!
//! ```
//! use std::sync::atomic::{AtomicBool, Ordering};
//!
//! static STOP: AtomicBool = AtomicBool::new(false);
//! lamina_rt::install_stop_handler(&STOP)?;
//! // ... lp.run(RunLimit::until_stopped(&STOP), ...)
//! # Ok::<(), lamina_rt::StopHandlerInstallError>(())
//! ```

use std::sync::atomic::{AtomicBool, AtomicI32, AtomicPtr, Ordering};

static STOP_FLAG: AtomicPtr<AtomicBool> = AtomicPtr::new(std::ptr::null_mut());
static LAST_SIGNAL: AtomicI32 = AtomicI32::new(0);

/// Why [`install_stop_handler`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum StopHandlerInstallError {
    /// `sigaction` failed for this signal.
    #[error("installing the {} handler failed: errno {errno}", signal_name(*.signal))]
    Sigaction {
        /// The signal number.
        signal: i32,
        /// `errno`.
        errno: i32,
    },
}

extern "C" fn on_stop_signal(signal: libc::c_int) {
    // Async-signal-safe: lock-free atomics only, no allocation, no locks.
    LAST_SIGNAL.store(signal, Ordering::Relaxed);
    let flag = STOP_FLAG.load(Ordering::Acquire);
    if !flag.is_null() {
        // SAFETY: the pointer came from a `&'static AtomicBool`.
        unsafe { (*flag).store(true, Ordering::Release) };
    }
}

/// Installs a SIGINT and SIGTERM handler that sets `flag` to `true` (see the
/// [module docs](self)). Calling it again points the handler at the new flag.
pub fn install_stop_handler(flag: &'static AtomicBool) -> Result<(), StopHandlerInstallError> {
    STOP_FLAG.store(std::ptr::from_ref(flag).cast_mut(), Ordering::Release);
    for signal in [libc::SIGINT, libc::SIGTERM] {
        // SAFETY: a zeroed sigaction is valid (empty mask, no flags); the
        // handler has the `void (*)(int)` signature sigaction expects.
        let rc = unsafe {
            let mut action: libc::sigaction = std::mem::zeroed();
            action.sa_sigaction = on_stop_signal as extern "C" fn(libc::c_int) as usize;
            action.sa_flags = libc::SA_RESTART | libc::SA_RESETHAND;
            libc::sigemptyset(&mut action.sa_mask);
            libc::sigaction(signal, &action, std::ptr::null_mut())
        };
        if rc != 0 {
            let errno = std::io::Error::last_os_error().raw_os_error().unwrap_or(0);
            return Err(StopHandlerInstallError::Sigaction { signal, errno });
        }
    }
    Ok(())
}

/// The last signal the stop handler caught (`libc::SIGINT` or
/// `libc::SIGTERM`), or `None`.
pub fn caught_stop_signal() -> Option<i32> {
    match LAST_SIGNAL.load(Ordering::Relaxed) {
        0 => None,
        s => Some(s),
    }
}

/// `"SIGINT"`, `"SIGTERM"`, or `"signal"` for any other number.
pub fn signal_name(signal: i32) -> &'static str {
    match signal {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        _ => "signal",
    }
}
