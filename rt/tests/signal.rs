//! The stop handler: a SIGTERM / SIGINT sets the flag and the loop stops
//! between ticks. One test function: signal dispositions are process-wide.

use std::ops::ControlFlow;
use std::sync::atomic::{AtomicBool, Ordering};

use lamina_rt::{
    FakeClock, FixedRateLoop, OverrunPolicy, RunLimit, StopReason, caught_stop_signal, install_stop_handler,
    signal_name,
};

static STOP: AtomicBool = AtomicBool::new(false);

#[test]
fn signal_stop_handler_stops_loop_works() {
    install_stop_handler(&STOP).unwrap();
    let mut lp = FixedRateLoop::new(FakeClock::new(0), 1_000, OverrunPolicy::Skip);
    let run = lp.run(RunLimit::until_stopped(&STOP).and_ticks(1_000), &mut (), |i| {
        if i.tick == 3 {
            // SAFETY: raise is always safe to call.
            unsafe { libc::raise(libc::SIGTERM) };
        }
        ControlFlow::Continue(())
    });
    assert_eq!((run.ticks, run.stop), (4, StopReason::StopFlag));
    assert_eq!(caught_stop_signal(), Some(libc::SIGTERM));

    // SA_RESETHAND reset SIGTERM to its default; install again before SIGINT.
    STOP.store(false, Ordering::Relaxed);
    install_stop_handler(&STOP).unwrap();
    // SAFETY: raise is always safe to call.
    unsafe { libc::raise(libc::SIGINT) };
    assert!(STOP.load(Ordering::Relaxed));
    assert_eq!(caught_stop_signal(), Some(libc::SIGINT));
    assert_eq!(signal_name(libc::SIGINT), "SIGINT");
}
