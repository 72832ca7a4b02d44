//! A small pool of pinned worker threads for the force pass.
//!
//! The calling thread is worker 0; the pool owns workers `1..threads`. [`WorkerPool::run`]
//! hands every worker the same job (a closure of the worker index) and returns when all are
//! done. Dispatch and completion are two atomics: no lock, no allocation, no syscall while
//! the workers are spinning. A worker that has had no job for [`SPIN_BEFORE_PARK`] parks
//! itself, so an idle pool does not burn a core that a viewer or haptics process needs;
//! waking a parked worker costs one `unpark`.

use std::cell::UnsafeCell;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long an idle worker spins before it parks. Default 200 µs.
pub const SPIN_BEFORE_PARK: Duration = Duration::from_micros(200);

type Job = *const (dyn Fn(usize) + Sync);

struct Shared {
    job: UnsafeCell<Option<Job>>,
    generation: AtomicU64,
    done: AtomicUsize,
    stop: AtomicBool,
    panicked: AtomicBool,
    sleeping: Vec<AtomicBool>,
}

// SAFETY: `job` is written only by the dispatching thread before it publishes a new
// generation (Release) and read by workers after they observe it (Acquire); the dispatcher
// does not touch it again until every worker has reported done.
unsafe impl Sync for Shared {}
// SAFETY: as above; the raw job pointer is only dereferenced during `run`.
unsafe impl Send for Shared {}

/// Pinned worker threads running one job at a time.
pub struct WorkerPool {
    shared: Arc<Shared>,
    handles: Vec<JoinHandle<()>>,
    threads: usize,
}

impl WorkerPool {
    /// A pool of `threads` workers (the caller counts as one). With `pin`, worker `i` is
    /// pinned to the `i`-th CPU of this process's CPU list (the caller is not re-pinned).
    pub fn new(threads: usize, pin: bool) -> Self {
        let threads = threads.max(1);
        let shared = Arc::new(Shared {
            job: UnsafeCell::new(None),
            generation: AtomicU64::new(0),
            done: AtomicUsize::new(0),
            stop: AtomicBool::new(false),
            panicked: AtomicBool::new(false),
            sleeping: (0..threads).map(|_| AtomicBool::new(false)).collect(),
        });
        let cores = if pin { core_affinity::get_core_ids().unwrap_or_default() } else { Vec::new() };
        let handles = (1..threads)
            .map(|index| {
                let shared = Arc::clone(&shared);
                let core = (!cores.is_empty()).then(|| cores[index % cores.len()]);
                std::thread::Builder::new()
                    .name(format!("lamina-worker-{index}"))
                    .spawn(move || {
                        if let Some(core) = core {
                            core_affinity::set_for_current(core);
                        }
                        worker_loop(&shared, index);
                    })
                    .expect("spawning a worker thread")
            })
            .collect();
        Self { shared, handles, threads }
    }

    /// Number of workers, the caller included.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// Runs `job(i)` on every worker `i` (0 on the calling thread) and waits for all.
    ///
    /// # Panics
    /// If the job panicked on a worker thread.
    pub fn run(&self, job: &(dyn Fn(usize) + Sync)) {
        if self.threads == 1 {
            job(0);
            return;
        }
        let shared = &*self.shared;
        // SAFETY: only the lifetime is erased; `run` does not return before every worker has
        // finished calling the job (the `done` count below), so the pointer never dangles.
        let ptr: Job = unsafe { std::mem::transmute::<&(dyn Fn(usize) + Sync), Job>(job) };
        // SAFETY: no worker reads `job` until the generation below changes.
        unsafe { *shared.job.get() = Some(ptr) };
        shared.done.store(0, Ordering::Relaxed);
        shared.generation.fetch_add(1, Ordering::SeqCst);
        for (i, h) in self.handles.iter().enumerate() {
            if shared.sleeping[i + 1].load(Ordering::SeqCst) {
                h.thread().unpark();
            }
        }
        job(0);
        while shared.done.load(Ordering::Acquire) != self.threads - 1 {
            std::hint::spin_loop();
        }
        if shared.panicked.load(Ordering::Relaxed) {
            panic!("a worker thread panicked while running a job");
        }
    }
}

fn worker_loop(shared: &Shared, index: usize) {
    let mut seen = 0u64;
    loop {
        let idle_since = Instant::now();
        let mut spins = 0u32;
        loop {
            if shared.stop.load(Ordering::Acquire) {
                return;
            }
            let generation = shared.generation.load(Ordering::Acquire);
            if generation != seen {
                seen = generation;
                break;
            }
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(64) && idle_since.elapsed() > SPIN_BEFORE_PARK {
                shared.sleeping[index].store(true, Ordering::SeqCst);
                if shared.generation.load(Ordering::SeqCst) == seen && !shared.stop.load(Ordering::SeqCst) {
                    std::thread::park();
                }
                shared.sleeping[index].store(false, Ordering::SeqCst);
            } else {
                std::hint::spin_loop();
            }
        }
        // SAFETY: the dispatcher wrote the job before publishing this generation and keeps
        // it alive until we report done.
        let job = unsafe { (*shared.job.get()).expect("job set before dispatch") };
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            // SAFETY: see above.
            unsafe { (*job)(index) }
        }));
        if result.is_err() {
            shared.panicked.store(true, Ordering::Relaxed);
        }
        shared.done.fetch_add(1, Ordering::Release);
    }
}

impl Drop for WorkerPool {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        for h in &self.handles {
            h.thread().unpark();
        }
        for h in self.handles.drain(..) {
            let _ = h.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pool_runs_every_worker_once_per_job_works() {
        let pool = WorkerPool::new(3, false);
        let hits: Vec<AtomicUsize> = (0..3).map(|_| AtomicUsize::new(0)).collect();
        for _ in 0..1000 {
            pool.run(&|i| {
                hits[i].fetch_add(1, Ordering::Relaxed);
            });
        }
        std::thread::sleep(Duration::from_millis(2));
        pool.run(&|i| {
            hits[i].fetch_add(1, Ordering::Relaxed);
        });
        for h in &hits {
            assert_eq!(h.load(Ordering::Relaxed), 1001);
        }
    }
}
