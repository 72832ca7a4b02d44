//! One diagnostics setup for every Lamina process: `tracing` events at or above a level go to
//! stderr as plain lines (no time stamp, no target), coloured only on a terminal, so stdout
//! keeps the results users and scripts read.

use std::io::IsTerminal;

/// Sends `tracing` events at `level` and above to stderr. Call once, at the start of `main`
/// (a second call leaves the first setup in place).
pub fn init_logging(level: tracing::Level) {
    let _ = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_max_level(level)
        .with_target(false)
        .without_time()
        .with_ansi(std::io::stderr().is_terminal())
        .try_init();
}
