//! The haptics device loop allocates nothing of its own after warm-up: a counting global
//! allocator counts what the device-loop thread allocates and frees between its 200th and
//! 2900th tick, while a stand-in core publishes contact feedback from another thread.
//!
//! The one allocation left is iceoryx2's: in 0.10 every loaned sample carries an `Rc` box
//! (`iceoryx2::port::details::chunk_mut_shared_state`), allocated by `loan_uninit` and freed
//! by `send`, so each tool command costs exactly one small allocation that is returned within
//! the same tick (glibc serves it from the thread's cache: no lock, no system call). The test
//! pins exactly that: one allocation per command sent, every byte freed, nothing else.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Duration;

use lamina_bridge::wire::ContactFeedback;
use lamina_bridge::{Bridge, BridgeConfig, FeedbackPublisher};
use lamina_haptics::device::{DeviceError, DeviceInfo, DeviceState, HapticDevice};
use lamina_haptics::{DeviceMapping, HapticsConfig, run_device_loop};
use lamina_rt::RunLimit;

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);
static LIVE_BYTES: std::sync::atomic::AtomicI64 = std::sync::atomic::AtomicI64::new(0);

thread_local! {
    static COUNT_HERE: Cell<bool> = const { Cell::new(false) };
}

fn counting() -> bool {
    COUNT_HERE.try_with(Cell::get).unwrap_or(false)
}

fn note(size: usize) {
    if counting() {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        LIVE_BYTES.fetch_add(size as i64, Ordering::Relaxed);
    }
}

fn note_free(size: usize) {
    if counting() {
        LIVE_BYTES.fetch_sub(size as i64, Ordering::Relaxed);
    }
}

// SAFETY: forwards every call to the system allocator unchanged; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        note_free(layout.size());
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        note_free(layout.size());
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// A handle circling in and out of contact; counts allocations between two of its reads.
struct CirclingDevice {
    info: DeviceInfo,
    reads: u64,
}

/// Ticks in the counted window (reads 200 to 2900).
const WINDOW_TICKS: u64 = 2700;

impl HapticDevice for CirclingDevice {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        self.reads += 1;
        match self.reads {
            200 => COUNT_HERE.with(|c| c.set(true)),
            2900 => COUNT_HERE.with(|c| c.set(false)),
            _ => {}
        }
        let phase = self.reads as f64 * 1e-3;
        Ok(DeviceState {
            position_m: [0.01 * phase.cos(), 0.01 * phase.sin(), 0.002 * phase.sin()],
            ..Default::default()
        })
    }
    fn write_force(&mut self, _force_n: [f64; 3]) -> Result<(), DeviceError> {
        Ok(())
    }
}

#[test]
fn haptics_device_loop_allocates_only_iceoryx2_loans_after_warm_up_works() {
    let prefix = format!("t_hap_alloc_{}", std::process::id());
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    let core = {
        let stop = stop.clone();
        let prefix = prefix.clone();
        std::thread::spawn(move || {
            let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix)).unwrap();
            let publisher = FeedbackPublisher::create(&bridge).unwrap();
            let mut k = 0u64;
            while !stop.load(Ordering::Relaxed) {
                let mut fb = ContactFeedback { sequence: k, tick: k, in_contact: 1, ..Default::default() };
                fb.force = [0.0, 0.5 + 0.1 * (k as f64 * 0.01).sin(), 0.0];
                fb.stiffness[1][1] = -400.0;
                fb.publish_time_ns = lamina_bridge::now_ns();
                let _ = publisher.publish_polled(&fb);
                k += 1;
                std::thread::sleep(Duration::from_millis(1));
            }
        })
    };
    std::thread::sleep(Duration::from_millis(50));
    let mut device = CirclingDevice {
        info: DeviceInfo {
            name: "circling".into(),
            max_force_n: 5.0,
            max_stiffness_n_per_m: 2000.0,
            max_damping_n_s_per_m: 10.0,
            workspace_radius_m: 0.08,
        },
        reads: 0,
    };
    let cfg = HapticsConfig {
        rate_hz: 4000,
        mapping: DeviceMapping::y_up_model([0.0; 3]),
        trace_capacity: 4000,
        ..HapticsConfig::default()
    };
    let (tx, rx) = crossbeam::channel::bounded(64);
    let report = run_device_loop(&mut device, &bridge, &cfg, RunLimit::ticks(3000), Some(&tx), None).unwrap();
    stop.store(true, Ordering::Relaxed);
    core.join().unwrap();
    drop(rx);
    assert!(device.reads >= 2900, "the loop ran ({} reads)", device.reads);
    assert!(report.safety.feedback_accepted > 100, "real work was done: {:?}", report.safety);
    assert!(report.trace.iter().any(|r| r.in_contact), "the model was in contact");
    // One pose per tick, each a tool command (the pose is finite): one iceoryx2 loan each.
    assert_eq!(report.commands_sent, 3000);
    assert_eq!(
        ALLOCATIONS.load(Ordering::Relaxed),
        WINDOW_TICKS,
        "allocations in the device loop after warm-up: exactly iceoryx2's one per command sent"
    );
    assert_eq!(LIVE_BYTES.load(Ordering::Relaxed), 0, "every byte allocated in the window was freed in it");
}
