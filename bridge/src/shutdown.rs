//! Termination requests (SIGTERM, SIGINT) as a flag a loop can poll.
//!
//! The handler only stores to an atomic, which is async-signal-safe. It is installed without
//! `SA_RESTART`, so a blocking wait returns early ([`crate::SampleReceiveError::Interrupted`])
//! and the loop sees the flag at once.
//!
//! # Examples
//!
//! ```
//! lamina_bridge::shutdown::install();
//! assert!(!lamina_bridge::shutdown::requested());
//! ```

use core::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_signal: libc::c_int) {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Installs the handler for SIGTERM and SIGINT. Returns `false` if the kernel refused
/// (then signals keep their default action and terminate the process).
pub fn install() -> bool {
    let mut ok = true;
    for signal in [libc::SIGTERM, libc::SIGINT] {
        // SAFETY: a zeroed sigaction is valid; the handler is an extern "C" fn that only
        // touches an atomic, which is async-signal-safe.
        unsafe {
            let mut action: libc::sigaction = core::mem::zeroed();
            action.sa_sigaction = on_signal as *const () as libc::sighandler_t;
            libc::sigemptyset(&mut action.sa_mask);
            action.sa_flags = 0;
            ok &= libc::sigaction(signal, &action, core::ptr::null_mut()) == 0;
        }
    }
    ok
}

/// Whether SIGTERM or SIGINT arrived since [`install`].
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
