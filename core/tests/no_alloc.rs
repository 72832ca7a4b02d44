//! The step loop allocates nothing after warm-up: a counting global allocator watches 1000
//! frames of every integrator (and multirate stepping, whose bulk thread is counted too; with
//! the tool sliding, only the stepping thread, as regions and their bulks are built on a thread
//! of their own and the bulk's drops the ones replaced), on
//! one thread and on two, with every effect on, through
//! guard rollbacks, with the pool's workers left idle long enough to park and be woken, and
//! with the scalpel cutting (the factors of the cut model built on a thread of their own).
//! One busy thread per CPU spins beside the step throughout, so the solver's workers are
//! preempted, park and wake as they do on a loaded machine.
//!
//! The allocator counts every thread of the process, so this file runs without libtest's
//! harness (`harness = false` in `core/Cargo.toml`): the harness's own thread allocates when
//! it prints "has been running for over 60 seconds", which a loaded machine reaches, and was
//! counted as the step's. Here the only threads are this one and the solver's workers.

use lamina_core::scene::Scene;
use lamina_core::solver::{
    DragHandle, GuardSettings, IntegratorKind, LateBuild, MultirateSettings, PointLoad, Simulation, SphereTool,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
/// Allocations on the thread that steps (the loop's), counted apart.
static LOOP_ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Set on the thread that steps. Const-initialised without a destructor: reading it
    /// allocates nothing.
    static ON_LOOP_THREAD: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count_one() {
    if COUNTING.load(Ordering::Relaxed) {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        if ON_LOOP_THREAD.try_with(std::cell::Cell::get).unwrap_or(false) {
            LOOP_ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        }
    }
}

// SAFETY: forwards to the system allocator; only counts.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count_one();
        // SAFETY: same contract as ours.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as ours.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count_one();
        // SAFETY: same contract as ours.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn main() {
    // `cargo test` passes harness options (filters, --test-threads, ...): there is one check.
    print!("test step_loop_allocates_nothing_after_warm_up_works ... ");
    step_loop_allocates_nothing_after_warm_up_works();
    println!("ok");
}

/// Spins one thread per CPU until dropped; the threads allocate nothing while they spin.
struct BusyThreads {
    stop: std::sync::Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<u64>>,
}

impl BusyThreads {
    fn start() -> BusyThreads {
        let cpus = std::thread::available_parallelism().map_or(2, |n| n.get());
        let stop = std::sync::Arc::new(AtomicBool::new(false));
        let threads = (0..cpus)
            .map(|_| {
                let stop = stop.clone();
                std::thread::spawn(move || {
                    let mut spins = 0u64;
                    while !stop.load(Ordering::Relaxed) {
                        spins = spins.wrapping_add(1);
                        std::hint::spin_loop();
                    }
                    spins
                })
            })
            .collect();
        BusyThreads { stop, threads }
    }
}

impl Drop for BusyThreads {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for thread in self.threads.drain(..) {
            let spins = thread.join().expect("a busy thread panicked");
            assert!(spins > 0, "a busy thread never ran");
        }
    }
}

fn step_loop_allocates_nothing_after_warm_up_works() {
    let busy = BusyThreads::start();
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let mut effects = scene.effects.clone();
    effects.viscous_damping = Some(1.0);
    effects.loads.push(PointLoad { node: 78, force: [0.0, -0.01, 0.0], ramp_s: 0.01 });
    effects.handles.push(DragHandle { node: 30, target: [0.0, 0.08, 0.05], stiffness: 1.0, damping: 0.01 });
    effects.guard = Some(GuardSettings::default());
    // The haptic tool pressing 8 mm into the skin (its point shell and deep-node contact).
    effects.tool = Some(SphereTool { radius: 0.012, stiffness: 300.0, start: [0.0, 0.054, 0.12], velocity: [0.0; 3] });
    // Sanity: the counter sees allocations.
    ON_LOOP_THREAD.with(|on| on.set(true));
    COUNTING.store(true, Ordering::SeqCst);
    let v: Vec<u64> = std::hint::black_box(vec![1, 2, 3]);
    COUNTING.store(false, Ordering::SeqCst);
    ON_LOOP_THREAD.with(|on| on.set(false));
    assert!(ALLOCATIONS.swap(0, Ordering::SeqCst) >= 1 && v.len() == 3);
    assert!(LOOP_ALLOCATIONS.swap(0, Ordering::SeqCst) >= 1);

    for integrator in IntegratorKind::ALL {
        for threads in [1, 2] {
            let mut params = scene.solver.clone();
            params.integrator = integrator;
            params.threads = threads;
            let mut sim = Simulation::<f32>::new(&model, params, effects.clone()).unwrap();
            step_counted(&mut sim, 7, &format!("{integrator} with {threads} thread(s)"));
        }
    }
    // The factor in binary16 (`factor_storage = "f16"`): its own sweep kernels.
    for threads in [1, 2] {
        let mut params = scene.solver.clone();
        params.integrator = IntegratorKind::ImplicitFactored;
        params.factor_storage = lamina_core::solver::FactorStorage::Half;
        params.threads = threads;
        let mut sim = Simulation::<f32>::new(&model, params, effects.clone()).unwrap();
        step_counted(&mut sim, 7, &format!("implicit_factored, binary16 factor, with {threads} thread(s)"));
    }
    // Multirate stepping: the region on this thread, the bulk on its own (counted too: the
    // allocator sees every thread), exchanging every 4 ticks; then with the tool sliding 3 cm
    // along the limb, the region following it: regions are built on the bulk's thread, and
    // this thread still allocates nothing.
    let centre = [0.0, 0.062, 0.12];
    let nearest = (0..model.nodes.len())
        .filter(|&i| model.nodes.kind[i] == lamina_core::model::NodeKind::Free)
        .min_by(|&a, &b| {
            let d = |i: usize| (0..3).map(|k| (model.nodes.position[i][k] - centre[k]).powi(2)).sum::<f64>();
            d(a).total_cmp(&d(b))
        })
        .expect("a free node");
    for (threads, slide) in [(1, None), (2, None), (2, Some(0.03))] {
        let mut params = scene.solver.clone();
        params.integrator = IntegratorKind::ImplicitFactored;
        params.threads = threads;
        // Regions about the tool waited for 8 exchanges after asking: the spinning threads
        // leave the builder's lowest priority little time, and the moves must happen.
        let settings = MultirateSettings { centre, radius: 0.05, ratio: 4, ..MultirateSettings::default() };
        let settings = MultirateSettings { build_exchanges: Some(8), late_build: LateBuild::Wait, ..settings };
        params.multirate = Some(settings);
        let mut sim = Simulation::<f32>::new(&model, params, effects.clone()).unwrap();
        let what = format!("multirate with {threads} thread(s), the tool sliding {slide:?} m");
        step_counted_sliding(&mut sim, nearest, &what, slide);
        let status = sim.multirate_status().unwrap();
        assert_eq!(status.bulk_steps, 1010 / 4 + 1);
        assert_eq!(status.recentres >= 2, slide.is_some(), "{what}: {status:?}");
    }
    scalpel_counted(None);
    // Multirate: the region cuts inside the tick, the bulk at its exchange, and regions built
    // without the cut springs are taken like those that follow the tool.
    let settings = MultirateSettings { centre: [0.0, 0.062, 0.12], radius: 0.05, ratio: 4, ..Default::default() };
    scalpel_counted(Some(MultirateSettings { build_exchanges: Some(8), late_build: LateBuild::Wait, ..settings }));
    drop(busy);
}

/// The scalpel on the living limb (`config/scenes/incision.toml`), single-rate or with
/// `multirate`: entering point-first and drawn 3 cm through skin and fat over 1500 counted
/// ticks, cutting springs and skin tetrahedra inside the tick; nothing is allocated on the
/// stepping thread.
fn scalpel_counted(multirate: Option<MultirateSettings>) {
    use lamina_core::hand_tool::HandTool;
    use lamina_core::incision::{Blade, Scalpel};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/incision.toml");
    let scene = Scene::load(&path).expect("the incision scene");
    let model = scene.build_model().unwrap();
    let tool = scene.tool.expect("a tool");
    let params = lamina_core::solver::IntegrationParameters { multirate, ..scene.solver.clone() };
    let (mut sim, _) = HandTool::simulation::<f32>(&model, params, scene.effects.clone(), tool).unwrap();
    let mut scalpel = Scalpel::new(&model, &sim, &tool, scene.scalpel.expect("a [scalpel]")).unwrap();
    // Factors of the cut model built on a thread of their own, each taken 50 ticks after it
    // was asked for (the loop waits for it if need be): only this thread is counted.
    sim.prepare_cutting(&model, lamina_core::solver::FactorSwap::AfterTicks(50)).unwrap();
    let at = |y: f64, z: f64| Blade::from_pose([0.003, y, z], [0.0, 0.0, 0.0, 1.0], 0.015);
    for _ in 0..10 {
        scalpel.move_to(&mut sim, at(0.06, 0.1), 1e-3);
        sim.step();
    }
    ON_LOOP_THREAD.with(|on| on.set(true));
    COUNTING.store(true, Ordering::SeqCst);
    for k in 0..1500 {
        let (y, z) = if k < 500 {
            (0.06 - 0.018 * f64::from(k) / 500.0, 0.1)
        } else {
            (0.042, 0.1 + 0.03 * f64::from(k - 500) / 1000.0)
        };
        scalpel.move_to(&mut sim, at(y, z), 1e-3);
        sim.step();
    }
    COUNTING.store(false, Ordering::SeqCst);
    ON_LOOP_THREAD.with(|on| on.set(false));
    ALLOCATIONS.swap(0, Ordering::SeqCst);
    let n = LOOP_ALLOCATIONS.swap(0, Ordering::SeqCst);
    assert_eq!(n, 0, "the scalpel allocated {n} times on the stepping thread");
    assert!(sim.cuts() > 5, "the scalpel cut {} springs", sim.cuts());
    match sim.multirate_status() {
        Some(m) => assert!(m.recentres >= 1 && m.cuts_in_factor > 0 && m.cuts as u64 == sim.cuts(), "{m:?}"),
        None => {
            let built = sim.refactor_status().unwrap();
            assert!(built.taken >= 1 && built.cuts_in_factor > 0, "{built:?}");
        }
    }
    assert!(sim.state().x.all_finite());
}

/// Ten warm-up frames, then 1000 counted ones with a NaN put into node `nan_node`'s velocity
/// half-way and three 2 ms idles; asserts nothing was allocated, the guard caught the NaN, the
/// state is finite and the tool pressed throughout.
fn step_counted(sim: &mut Simulation<f32>, nan_node: usize, what: &str) {
    step_counted_sliding(sim, nan_node, what, None);
}

/// [`step_counted`], the tool sliding `slide` m along the limb (+z) over the counted frames
/// when given; then only this thread's allocations must be none.
fn step_counted_sliding(sim: &mut Simulation<f32>, nan_node: usize, what: &str, slide: Option<f64>) {
    for _ in 0..10 {
        sim.step();
    }
    let start = sim.effects().tool.expect("the tool is on").start;
    ON_LOOP_THREAD.with(|on| on.set(true));
    COUNTING.store(true, Ordering::SeqCst);
    for k in 0..1000 {
        if let Some(along) = slide {
            let tool = sim.effects_mut().tool.as_mut().unwrap();
            tool.start[2] = start[2] + along * f64::from(k) / 1000.0;
        }
        if k == 500 {
            // Corrupt the state: the guard must roll back, without allocating.
            sim.state_mut().v.x[nan_node] = f32::NAN;
        }
        if k % 250 == 100 {
            // Idle for ten times the pool's spin time: the workers park, and the
            // next step wakes them (a worker's first park falls in the window).
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        sim.step();
    }
    COUNTING.store(false, Ordering::SeqCst);
    ON_LOOP_THREAD.with(|on| on.set(false));
    let (n, on_loop) = (ALLOCATIONS.swap(0, Ordering::SeqCst), LOOP_ALLOCATIONS.swap(0, Ordering::SeqCst));
    assert_eq!(on_loop, 0, "{what} allocated {on_loop} times on the stepping thread");
    if slide.is_none() {
        assert_eq!(n, 0, "{what} allocated {n} times");
    } else {
        // The counter saw the regions built on the bulk's thread.
        assert!(n > 0, "{what}: no region was built");
    }
    assert!(sim.guard_totals().rollbacks >= 1, "{what}: the injected NaN was caught");
    assert!(sim.state().x.all_finite() && sim.state().v.all_finite());
    assert!(sim.tool_feedback().in_contact, "{what}: the tool pressed the skin throughout");
}
