//! `lamina run --record DIR`: the run as a ParaView time series (`DIR/run.pvd` and
//! `DIR/frame_NNNNNN.vtu`, `docs/recording.md`), written off the real-time thread.
//!
//! The loop's side ([`Recorder::after_step`]) copies positions and velocities into a free
//! slot of a ring allocated before the loop and hands it to a writer thread through a
//! lock-free queue (`crossbeam::queue::ArrayQueue`); it never allocates, locks, waits or
//! does I/O. When the writer falls behind and no slot is free, the frame is dropped and
//! counted. The writer thread encodes and writes each frame, then returns the slot.

use crossbeam::queue::ArrayQueue;
use lamina_core::io::VtuRecorder;
use lamina_core::model::Model;
use lamina_core::real::Real;
use lamina_core::solver::State;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Frames per second of simulated time a recording takes by default: `--record-every` is
/// the scene's rate divided by this (20 ticks at 1 kHz).
pub const DEFAULT_FRAMES_PER_SECOND: u32 = 50;

/// Frames a recording writes by default before it stops recording: 30 s of simulated time
/// at 50 frames per second (about 100 MB for the default scene).
pub const DEFAULT_MAX_FRAMES: usize = 1500;

/// Most frames `--record-max-frames` allows.
pub const MAX_FRAMES: usize = 1_000_000;

/// Slots in the hand-off ring: at most 32, fewer for large models so the ring stays under
/// [`RING_BYTES`].
const MAX_SLOTS: usize = 32;
const MIN_SLOTS: usize = 4;
/// Memory the ring may take, bytes.
const RING_BYTES: usize = 64 << 20;

/// What `--record` asks for.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// Output folder.
    pub dir: PathBuf,
    /// Record every this many ticks; `None`: the scene's rate / [`DEFAULT_FRAMES_PER_SECOND`].
    pub every: Option<u32>,
    /// Stop recording after this many frames.
    pub max_frames: usize,
}

impl RecordOptions {
    /// Ticks between frames at `rate_hz`.
    pub fn every_ticks(&self, rate_hz: u32) -> u32 {
        self.every.unwrap_or((rate_hz / DEFAULT_FRAMES_PER_SECOND).max(1))
    }

    /// Refuses an interval or cap out of range, naming the option and the value.
    pub fn check(&self) -> Result<(), String> {
        if self.every == Some(0) {
            return Err("--record-every 0: must be at least 1 tick".into());
        }
        if !(1..=MAX_FRAMES).contains(&self.max_frames) {
            return Err(format!("--record-max-frames {}: must be from 1 to {MAX_FRAMES}", self.max_frames));
        }
        Ok(())
    }
}

/// Refuses a ring of `slots` frames of `n` nodes (positions and velocities, 48 bytes a
/// node) that exceeds the memory available, before it is allocated; the message gives both.
fn check_ring_memory(n: usize, slots: usize) -> Result<(), String> {
    let bytes = (n as u64).checked_mul(48).and_then(|b| b.checked_mul(slots as u64)).unwrap_or(u64::MAX);
    lamina_input::check_memory(&format!("--record: a ring of {slots} frames of {n} nodes"), bytes)
        .map_err(|e| e.to_string())
}

/// One recorded state: simulated time (s), positions (m) and velocities (m/s) per node.
struct Frame {
    time: f64,
    x: Vec<[f64; 3]>,
    v: Vec<[f64; 3]>,
}

/// The loop's side of a recording.
pub struct Recorder {
    free: Arc<ArrayQueue<Box<Frame>>>,
    full: Arc<ArrayQueue<Box<Frame>>>,
    done: Arc<AtomicBool>,
    writer: Option<JoinHandle<WriterResult>>,
    dir: PathBuf,
    every: u32,
    max_frames: usize,
    /// Steps seen since the recording started.
    steps: u64,
    /// Frames handed to the writer.
    handed: usize,
    /// Frames dropped because no slot was free.
    dropped: u64,
    /// Frames not taken because the cap was reached.
    over_cap: u64,
    slots: usize,
}

/// What the writer thread did.
struct WriterResult {
    written: usize,
    bytes: u64,
    busy: Duration,
    error: Option<String>,
    collection: PathBuf,
}

/// What a finished recording reports.
pub struct RecordSummary {
    pub collection: PathBuf,
    pub written: usize,
    pub bytes: u64,
    pub dropped: u64,
    pub over_cap: u64,
    pub every: u32,
    /// Writer time spent encoding and writing, s.
    pub busy_s: f64,
    pub slots: usize,
}

impl Recorder {
    /// Creates the folder and the empty collection (so a bad folder fails before the run
    /// starts), allocates the ring and starts the writer thread. Call it before the loop
    /// thread asks for real-time priority and a CPU: the writer inherits neither. The writer
    /// runs at normal priority, pinned to the first CPU other than `loop_cpu` when there is
    /// one, so its encoding and file writes stay off the loop's CPU.
    pub fn start(model: &Model, opts: &RecordOptions, rate_hz: u32, loop_cpu: Option<usize>) -> Result<Self, String> {
        opts.check()?;
        let dir = opts.dir.clone();
        if dir.exists() && !dir.is_dir() {
            return Err(format!("--record {}: exists and is not a folder", dir.display()));
        }
        let stale = stale_frames(&dir);
        if stale > 0 {
            return Err(format!(
                "--record {}: already holds {stale} frame file(s) of an earlier recording; give an empty or new folder",
                dir.display()
            ));
        }
        let mut writer = VtuRecorder::create(model, &dir).map_err(|e| format!("--record {}: {e}", dir.display()))?;
        let n = model.nodes.len();
        let slots = (RING_BYTES / (48 * n).max(1)).clamp(MIN_SLOTS, MAX_SLOTS);
        check_ring_memory(n, slots)?;
        let free = Arc::new(ArrayQueue::new(slots));
        let full: Arc<ArrayQueue<Box<Frame>>> = Arc::new(ArrayQueue::new(slots));
        for _ in 0..slots {
            let frame = Box::new(Frame { time: 0.0, x: vec![[0.0; 3]; n], v: vec![[0.0; 3]; n] });
            let _ = free.push(frame);
        }
        let done = Arc::new(AtomicBool::new(false));
        let (w_free, w_full, w_done) = (free.clone(), full.clone(), done.clone());
        let writer_cpu = lamina_rt::available_cpus().into_iter().find(|&c| Some(c) != loop_cpu);
        let handle = std::thread::Builder::new()
            .name("lamina-record".into())
            .spawn(move || {
                if let Some(cpu) = writer_cpu {
                    // Best effort: unpinned, it still runs below the loop's priority.
                    let _ = lamina_rt::pin_current_thread(cpu);
                }
                let mut result = WriterResult {
                    written: 0,
                    bytes: 0,
                    busy: Duration::ZERO,
                    error: None,
                    collection: writer.collection_path(),
                };
                loop {
                    let Some(frame) = w_full.pop() else {
                        if w_done.load(Ordering::Acquire) && w_full.is_empty() {
                            break;
                        }
                        std::thread::sleep(Duration::from_millis(2));
                        continue;
                    };
                    if result.error.is_none() {
                        let started = Instant::now();
                        match writer.write_frame(frame.time, &frame.x, &frame.v) {
                            Ok(bytes) => {
                                result.written += 1;
                                result.bytes += bytes;
                            }
                            Err(e) => result.error = Some(e.to_string()),
                        }
                        result.busy += started.elapsed();
                    }
                    let _ = w_free.push(frame);
                }
                if let Err(e) = writer.finish() {
                    result.error.get_or_insert(e.to_string());
                }
                result
            })
            .map_err(|e| format!("--record: cannot start the writer thread: {e}"))?;
        Ok(Self {
            free,
            full,
            done,
            writer: Some(handle),
            dir,
            every: opts.every_ticks(rate_hz),
            max_frames: opts.max_frames,
            steps: 0,
            handed: 0,
            dropped: 0,
            over_cap: 0,
            slots,
        })
    }

    /// Ticks between frames.
    pub fn every(&self) -> u32 {
        self.every
    }

    /// Records `state` now (the frame at rest, before the first step).
    pub fn record<T: Real>(&mut self, state: &State<T>) {
        if self.handed >= self.max_frames {
            self.over_cap += 1;
            return;
        }
        let Some(mut frame) = self.free.pop() else {
            self.dropped += 1;
            return;
        };
        frame.time = state.time;
        for (i, (x, v)) in frame.x.iter_mut().zip(frame.v.iter_mut()).enumerate() {
            *x = state.x.get_f64(i);
            *v = state.v.get_f64(i);
        }
        // Never full: the two queues share the ring's slots.
        let _ = self.full.push(frame);
        self.handed += 1;
    }

    /// Counts one step and records `state` on every `every`-th.
    pub fn after_step<T: Real>(&mut self, state: &State<T>) {
        self.steps += 1;
        if self.steps.is_multiple_of(u64::from(self.every)) {
            self.record(state);
        }
    }

    /// Lets the writer drain the queue, waits for it and returns what was recorded.
    pub fn finish(mut self) -> Result<RecordSummary, String> {
        self.done.store(true, Ordering::Release);
        let result = self
            .writer
            .take()
            .map(|h| h.join().map_err(|_| "--record: the writer thread panicked".to_string()))
            .transpose()?;
        let Some(r) = result else { return Err("--record: no writer thread".into()) };
        let summary = RecordSummary {
            collection: r.collection,
            written: r.written,
            bytes: r.bytes,
            dropped: self.dropped,
            over_cap: self.over_cap,
            every: self.every,
            busy_s: r.busy.as_secs_f64(),
            slots: self.slots,
        };
        match r.error {
            Some(e) => Err(format!("--record {}: {e} ({} frames written before it)", self.dir.display(), r.written)),
            None => Ok(summary),
        }
    }
}

impl Drop for Recorder {
    /// A recording abandoned without [`Recorder::finish`] (the run failed) still lets the
    /// writer finish the frames it holds and list them.
    fn drop(&mut self) {
        self.done.store(true, Ordering::Release);
    }
}

impl std::fmt::Display for RecordSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "recorded {} frames (every {} ticks, {:.1} MB, {:.0} kB per frame) to {}; {} dropped (writer behind, {} slots), {} past --record-max-frames; writer busy {:.2} s ({:.1} ms per frame)",
            self.written,
            self.every,
            self.bytes as f64 / 1e6,
            self.bytes as f64 / 1e3 / self.written.max(1) as f64,
            self.collection.display(),
            self.dropped,
            self.slots,
            self.over_cap,
            self.busy_s,
            self.busy_s * 1e3 / self.written.max(1) as f64
        )
    }
}

/// Frame files (`frame_*.vtu`) already in `dir`.
fn stale_frames(dir: &Path) -> usize {
    std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(Result::ok)
                .filter(|e| {
                    let name = e.file_name();
                    let name = name.to_string_lossy();
                    name.starts_with("frame_") && name.ends_with(".vtu")
                })
                .count()
        })
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_core::scene::Scene;
    use lamina_core::solver::Simulation;
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    #[test]
    fn record_ring_beyond_the_memory_budget_is_refused_fails() {
        // 4 frames of 1e12 nodes: 1.92e14 bytes (175 TiB), more than any host's budget.
        let e = check_ring_memory(1_000_000_000_000, 4).unwrap_err();
        assert!(
            e.starts_with("--record: a ring of 4 frames of 1000000000000 nodes needs about 174.62 TiB (192,000,000,000,000 bytes), more than the "),
            "{e}"
        );
        // A count whose bytes overflow is refused, not wrapped.
        let e = check_ring_memory(usize::MAX, 4).unwrap_err();
        assert!(e.contains("needs more than 16 EiB"), "{e}");
        // The default scene's ring fits.
        assert!(check_ring_memory(2_769, MAX_SLOTS).is_ok());
    }

    /// Counts the allocations of the thread that makes them (the test harness and the
    /// writer thread allocate on their own threads).
    struct Counting;

    thread_local! {
        static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
    }

    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            ALLOCATIONS.with(|c| c.set(c.get() + 1));
            unsafe { System.alloc(layout) }
        }
        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            ALLOCATIONS.with(|c| c.set(c.get() + 1));
            unsafe { System.dealloc(ptr, layout) }
        }
        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            ALLOCATIONS.with(|c| c.set(c.get() + 1));
            unsafe { System.realloc(ptr, layout, new_size) }
        }
    }

    #[global_allocator]
    static GLOBAL: Counting = Counting;

    fn allocations() -> u64 {
        ALLOCATIONS.with(Cell::get)
    }

    /// The loop's side of the hand-off allocates and frees nothing, whether the frame is
    /// taken, dropped (ring full) or past the cap; the writer writes every frame taken.
    #[test]
    fn record_hand_off_allocates_nothing_works() {
        let scene = Scene::builtin_default();
        let model = scene.build_model().unwrap();
        let sim = Simulation::<f32>::new(&model, scene.solver.clone(), scene.effects.clone()).unwrap();
        let dir = std::env::temp_dir().join(format!("lamina_record_unit_{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let opts = RecordOptions { dir: dir.clone(), every: Some(2), max_frames: 40 };
        let mut rec = Recorder::start(&model, &opts, scene.rate_hz, None).unwrap();
        rec.record(sim.state());
        let before = allocations();
        for _ in 0..200 {
            rec.after_step(sim.state());
        }
        assert_eq!(allocations() - before, 0, "the hand-off allocated");
        let probe = allocations();
        drop(std::hint::black_box(vec![0u8; 16]));
        assert_eq!(allocations() - probe, 2, "the counter sees this thread's allocations");
        // One frame at rest and one every second step: each taken, dropped or over the cap.
        let (handed, dropped, over_cap) = (rec.handed, rec.dropped, rec.over_cap);
        assert_eq!(handed as u64 + dropped + over_cap, 101);
        assert!(handed <= 40);
        let summary = rec.finish().unwrap();
        assert_eq!(summary.written, handed, "the writer writes every frame handed to it");
        let vtu = |e: &std::fs::DirEntry| e.path().extension().is_some_and(|x| x == "vtu");
        let files = std::fs::read_dir(&dir).unwrap().filter_map(Result::ok).filter(vtu).count();
        assert_eq!(files, handed);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
