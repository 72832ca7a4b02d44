//! Real-time setup helpers: refusals come back as values and are printed
//! plainly; nothing panics, whether this runs as root or not.

use lamina_rt::{
    FifoPrioritySetError, Grant, MemoryLockError, RealtimeRequest, RealtimeSetup, ThreadPinError, available_cpus,
    pin_current_thread, set_fifo_priority, unlock_memory,
};

#[test]
fn setup_apply_reports_either_way_works() {
    // A throwaway thread, so pinning and SCHED_FIFO do not outlive the test.
    let setup = std::thread::spawn(|| {
        let cpu = *available_cpus().first().expect("at least one cpu");
        RealtimeSetup::apply(&RealtimeRequest::new().pin_to(cpu).fifo_priority(1).lock_memory())
    })
    .join()
    .unwrap();
    unlock_memory();
    let text = setup.to_string();
    println!("{text}");
    for (label, refused) in [
        ("cpu pinning", setup.pinning.is_refused()),
        ("SCHED_FIFO", setup.fifo.is_refused()),
        ("memory lock", setup.memory_lock.is_refused()),
    ] {
        let line = text.lines().find(|l| l.contains(label)).unwrap();
        assert_eq!(line.contains("REFUSED"), refused, "{line}");
        assert_eq!(line.contains("granted"), !refused, "{line}");
    }
    assert_eq!(setup.all_granted(), setup.refused_count() == 0);
}

#[test]
fn setup_refusals_display_plainly_works() {
    let setup = RealtimeSetup {
        request: RealtimeRequest::new().pin_to(4096).fifo_priority(80).lock_memory(),
        pinning: Grant::Refused(ThreadPinError::CpuUnavailable { cpu: 4096, available: 2 }),
        fifo: Grant::Refused(FifoPrioritySetError::PermissionDenied { priority: 80 }),
        memory_lock: Grant::Refused(MemoryLockError::LimitExceeded),
    };
    let text = setup.to_string();
    assert_eq!(setup.refused_count(), 3);
    assert!(text.starts_with("real-time setup: 3 request(s) refused"));
    assert!(text.contains("cpu 4096 is not in this process's allowed set (2 cpus available)"));
    assert!(text.contains("permission denied (EPERM) for priority 80"));
    assert!(text.contains("RLIMIT_MEMLOCK"));

    let nothing = RealtimeSetup::apply(&RealtimeRequest::new());
    assert!(nothing.all_granted());
    assert_eq!(nothing.to_string().matches("not requested").count(), 3);
}

#[test]
fn setup_pin_to_missing_cpu_fails() {
    let err = pin_current_thread(1 << 20).unwrap_err();
    assert!(matches!(err, ThreadPinError::CpuUnavailable { cpu, .. } if cpu == 1 << 20));
}

#[test]
fn setup_fifo_priority_out_of_range_fails() {
    for priority in [0, 100, -1] {
        let err = set_fifo_priority(priority).unwrap_err();
        assert!(matches!(err, FifoPrioritySetError::OutOfRange { .. }), "{err}");
    }
}

#[test]
fn standby_request_sits_one_below_the_loop_on_its_own_cpu_works() {
    let standby = RealtimeRequest::new().pin_to(1).fifo_priority(80).lock_memory().for_standby_on(0);
    assert_eq!((standby.cpu, standby.fifo_priority, standby.lock_memory), (Some(0), Some(79), false));
    assert_eq!(RealtimeRequest::new().fifo_priority(1).for_standby_on(0).fifo_priority, Some(1), "at least 1");
    assert_eq!(RealtimeRequest::new().for_standby_on(3).fifo_priority, None, "no priority asked, none given");
}
