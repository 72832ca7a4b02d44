//! `lamina run`: the core process. Steps a scene at a fixed rate on absolute deadlines,
//! pinned and at SCHED_FIFO when the system allows, and reports every frame-budget miss.

use super::frame_gate::NodeFrameGate;
use lamina_core::hand_tool::HandTool;
use lamina_core::incision::Scalpel;
use lamina_core::model::Model;
use lamina_core::real::Real;
use lamina_core::scene::{OverrunChoice, Precision, STANDBY_DELAY_US, Scene};
use lamina_core::solver::FactorSwap;
use lamina_core::solver::{LateBuild, Simulation};
use lamina_rt::standby::{Grid, run_with_standby};
use lamina_rt::steal::StealSnapshot;
use lamina_rt::{
    Clock, DeadlineMonitor, FixedRateLoop, MonitorConfig, MonotonicClock, OverrunPolicy, RealtimeRequest,
    RealtimeSetup, RunLimit, SendProbe, StopReason, TickInfo, available_cpus, install_stop_handler,
};
use std::io::Write;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

static STOP: AtomicBool = AtomicBool::new(false);

/// A multirate coupling gap above this (m) is warned of. On the stability suite's sweep the
/// runs that kept an oscillation going (a region covering nearly the whole block at ratio 20)
/// showed 2.9-3.2 mm, every other 0.22 mm or less; the 96x24 limb with the tool sliding across
/// it at 2 cm/s at ratio 20 shows up to 2.3 mm. The 160x40 limb pressed 8 mm shows 12-15 mm
/// with every published node within 0.3 mm of single-rate: there the bulk's own copy of the
/// overlap lags (docs/accuracy-and-stability.md).
const COUPLING_GAP_WARNING_M: f64 = 3e-3;

/// The warning `lamina run` prints for a multirate coupling that drew the two halves more
/// than [`COUPLING_GAP_WARNING_M`] apart, if it did.
fn coupling_warning(m: &lamina_core::solver::MultirateStatus) -> Option<String> {
    (m.coupling_gap_max_m > COUPLING_GAP_WARNING_M).then(|| {
        format!(
            "warning: the multirate region and bulk drew up to {:.1} mm apart at the region's edge: the coupling may be off there (a bounded oscillation, or the tool working near the region's edge), or only the bulk's own copy of those nodes lags, as under a deep press on a fine limb (the published state takes the region's values there); a larger [solver.multirate] radius, a smaller ratio, or a bulk step that keeps up narrows it (docs/accuracy-and-stability.md)",
            m.coupling_gap_max_m * 1e3
        )
    })
}

/// Options of `lamina run`.
pub struct RunOptions {
    pub scene: Option<PathBuf>,
    /// Run length, s; `None`: until SIGINT or SIGTERM.
    pub seconds: Option<f64>,
    pub report: Option<PathBuf>,
    pub quiet: bool,
    /// iceoryx2 service prefix; `None`: do not publish.
    pub prefix: Option<String>,
    /// Write the last ticks' records (tick, wake, lateness, compute, send; ns) as CSV at exit.
    pub ticks_csv: Option<PathBuf>,
    /// How many ticks `ticks_csv` keeps (the newest); 1 to [`MAX_TICKS_CSV`].
    pub ticks_csv_last: usize,
    /// Record the run for ParaView (`--record`).
    pub record: Option<super::record::RecordOptions>,
}

/// Most ticks `--ticks-csv` keeps: one hour at 1 kHz (40 bytes each, 144 MB).
pub const MAX_TICKS_CSV: usize = 3_600_000;

/// Loads the scene named in `opts` or the built-in default.
pub fn load_scene(path: &Option<PathBuf>) -> Result<Scene, String> {
    match path {
        Some(p) => Scene::load(p).map_err(|e| e.to_string()),
        None => Ok(Scene::builtin_default()),
    }
}

pub fn run(opts: &RunOptions) -> Result<(), String> {
    let loaded = super::run_report::load_scene_hashed(opts.scene.as_deref())?;
    match loaded.scene.precision {
        Precision::F32 => run_scene::<f32>(&loaded, opts),
        Precision::F64 => run_scene::<f64>(&loaded, opts),
    }
}

fn run_scene<T: Real>(loaded: &super::run_report::LoadedScene, opts: &RunOptions) -> Result<(), String> {
    check_options(opts)?;
    let scene = &loaded.scene;
    let scene_name = || scene.path.as_ref().map_or("<built-in default scene>".into(), |p| p.display().to_string());
    for (field, cpu) in [("realtime.cpu", scene.realtime.cpu), ("realtime.standby_cpu", scene.realtime.standby_cpu)] {
        check_cpu(field, cpu).map_err(|e| format!("{}: {e}", scene_name()))?;
    }
    if let Some(cpu) = scene.realtime.standby_cpu.filter(|&c| Some(c) == loop_cpu(scene)) {
        return Err(format!(
            "{}: realtime.standby_cpu = {cpu} is the loop's CPU (realtime.cpu, by default the last CPU): give the standby another",
            scene_name()
        ));
    }
    let model = scene.build_model().map_err(|e| e.to_string())?;
    let (mut sim, mut hand_tool) =
        build_simulation::<T>(scene, &model).map_err(|e| format!("{}: {e}", scene_name()))?;
    let context = super::run_report::RunContext::start(loaded, &model, &sim, opts.prefix.as_deref());
    let _ = install_stop_handler(&STOP);
    print_setup(scene, &model, &sim);
    // Before the real-time setup: the writer thread inherits neither its CPU nor its priority.
    let mut recorder = match &opts.record {
        Some(r) => Some(super::record::Recorder::start(&model, r, scene.rate_hz, loop_cpu(scene))?),
        None => None,
    };
    if let (Some(rec), Some(r)) = (recorder.as_mut(), &opts.record) {
        println!(
            "recording to {} every {} ticks ({:.1} frames per simulated second), at most {} frames",
            r.dir.join(lamina_core::io::RECORD_COLLECTION).display(),
            rec.every(),
            f64::from(scene.rate_hz) / f64::from(rec.every()),
            r.max_frames
        );
        rec.record(sim.state());
    }
    apply_realtime_setup(scene);
    // Warm-up outside the timed loop: first touches of every buffer. A stop signal ends a
    // frame between two sub-steps, so a scene with long frames still stops within one
    // sub-step's work.
    let mut stopped_after: Option<u64> = None;
    for _ in 0..warm_up_ticks(sim.multirate_status().map(|m| m.ratio)) {
        let before = sim.counters().substeps;
        if !sim.step_or_stop(&STOP) {
            stopped_after = Some(sim.counters().substeps - before);
            break;
        }
        if let Some(rec) = recorder.as_mut() {
            rec.after_step(sim.state());
        }
    }
    let policy = match scene.realtime.overrun {
        OverrunChoice::Skip => OverrunPolicy::Skip,
        OverrunChoice::CatchUp => OverrunPolicy::CatchUp,
    };
    let loop_clock = MonotonicClock::new().with_sleep_slice_ns(u64::from(scene.realtime.sleep_slice_us) * 1_000);
    let mut lp = FixedRateLoop::try_new(loop_clock, scene.rate_hz, policy).map_err(|e| e.to_string())?;
    let mut config = MonitorConfig::for_period_ns(lp.period_ns());
    if let Some(b) = scene.realtime.budget_us {
        config = config.with_budget_ns((b * 1e3) as u64);
    }
    if opts.ticks_csv.is_some() {
        // The newest ticks, in a ring allocated before the loop starts.
        config = config.with_record_capacity(opts.ticks_csv_last);
    }
    let mut monitor = DeadlineMonitor::try_new(config).map_err(|e| e.to_string())?;
    let node_frame_cutoff_us = scene.realtime.node_frame_cutoff_us(lp.period_ns() as f64 / 1e3);
    let mut frame_gate = NodeFrameGate::new(scene.realtime.node_frame_every, (node_frame_cutoff_us * 1e3) as u64);
    let mut publisher = match &opts.prefix {
        Some(prefix) => {
            let mut p =
                super::publish::CorePublisher::open(prefix, &model, scene.tool.as_ref(), scene.visual.as_ref())?;
            println!("publishing on iceoryx2 services '{prefix}/topology', '{prefix}/nodes', '{prefix}/stats'");
            let every = match scene.realtime.node_frame_every {
                1 => "every tick".to_string(),
                n => format!("every {n} ticks, {:.1} Hz", f64::from(scene.rate_hz) / f64::from(n)),
            };
            println!(
                "node frames: {every}; a tick past {:.0} us leaves its frame to the next tick on time ([realtime] node_frame_every, node_frame_cutoff_us)",
                node_frame_cutoff_us
            );
            if let Some(h) = p.haptic.as_mut() {
                if let Some(tool) = hand_tool.take() {
                    h.attach(tool);
                }
                if let (Some(settings), Some(tool)) = (scene.scalpel, scene.tool.as_ref()) {
                    let scalpel = Scalpel::new(&model, &sim, tool, settings)
                        .and_then(|s| sim.prepare_cutting(&model, FactorSwap::WhenReady).map(|()| s))
                        .map_err(|e| format!("{}: [scalpel]: {e}", scene_name()))?;
                    h.attach_scalpel(scalpel, scene.solver.dt);
                    println!(
                        "scalpel: a {:.0} mm blade when a command asks for it; the skin gives at {:.2} N; factors of the cut model built on a thread of the lowest priority",
                        settings.blade_length * 1e3,
                        settings.puncture_force
                    );
                }
                println!(
                    "tool: sphere driven by the haptics process on '{prefix}/tool', contact published on '{prefix}/feedback' every tick"
                );
            }
            Some(p)
        }
        None => None,
    };
    let probe = monitor.send_probe();
    let total_ns = opts.seconds.map_or(u64::MAX, |s| (s * 1e9) as u64);
    if opts.seconds.is_none() {
        println!("running until Ctrl-C (SIGINT) or SIGTERM");
    }
    let mut elapsed_ns = 0u64;
    let mut second = 0u64;
    // Host preemption, read between the one-second chunks (never inside the loop).
    let steal_at_start = StealSnapshot::read().map_err(|e| tracing::warn!("no steal time: {e}")).ok();
    let mut steal_before = steal_at_start.clone();
    let cpu = loop_cpu(scene);
    let mut out = std::io::stdout().lock();
    let mut standby = scene.realtime.standby_cpu.map(|cpu| Standby::new(scene, cpu, lp.period_ns()));
    while elapsed_ns < total_ns {
        let chunk = (total_ns - elapsed_ns).min(1_000_000_000);
        let clock = loop_clock;
        let mut state = TickState {
            sim: &mut sim,
            publisher: OneThreadAtATime(publisher.as_mut()),
            recorder: recorder.as_mut(),
            frame_gate: &mut frame_gate,
            stopped_after: &mut stopped_after,
        };
        let stop = match standby.as_mut() {
            None => {
                let limit = RunLimit::duration_ns(chunk).and_stop_flag(&STOP);
                lp.run(limit, &mut monitor, |info| state.tick(info, &clock, &probe)).stop
            }
            Some(standby) => standby.run(chunk, &clock, &mut monitor, &mut state, &probe),
        };
        elapsed_ns += chunk;
        second += 1;
        let s = monitor.summary();
        if let Some(p) = publisher.as_mut() {
            p.publish_stats(&s);
        }
        if !opts.quiet {
            let steal_now = StealSnapshot::read().ok();
            let stolen = loop_steal_ms(steal_now.as_ref(), steal_before.as_ref(), cpu);
            let gap = sim
                .multirate_status()
                .map_or(String::new(), |m| format!(" | coupling gap {:.3} mm", m.coupling_gap_m * 1e3));
            let _ = writeln!(
                out,
                "[{second:>3} s] ticks {:>6} misses {:>4} skipped {:>4} | compute p50 {:>7.1} us p99 {:>7.1} us max {:>7.1} us | lateness p99 {:>7.1} us | host steal {stolen} | guard rollbacks {}{gap}",
                s.ticks,
                s.misses,
                s.skipped_periods,
                s.compute.p50_ns as f64 / 1e3,
                s.compute.p99_ns as f64 / 1e3,
                s.compute.max_ns as f64 / 1e3,
                s.lateness.p99_ns as f64 / 1e3,
                sim.guard_totals().rollbacks
            );
            steal_before = steal_now;
        }
        if stop == StopReason::StopFlag || STOP.load(std::sync::atomic::Ordering::Relaxed) {
            break;
        }
    }
    if STOP.load(std::sync::atomic::Ordering::Relaxed) {
        let signal = lamina_rt::caught_stop_signal().map_or("a stop signal", lamina_rt::signal_name);
        match stopped_after {
            Some(done) => {
                let _ =
                    writeln!(out, "stopped by {signal} inside a frame after {done} of {} sub-steps", sim.substeps());
            }
            None => {
                let _ = writeln!(out, "stopped by {signal} between frames");
            }
        }
    }
    let _ = lp.clock().now();
    drop(out);
    println!("\n{monitor}");
    if let (Some(cpu), Some(s)) = (scene.realtime.standby_cpu, &standby) {
        println!(
            "standby on CPU {cpu}: ran {} ticks the loop's thread had not started {STANDBY_DELAY_US} µs after their deadline",
            s.ticks_run
        );
    }
    if let Some(hint) = machine_misses_hint(&monitor.summary(), scene.realtime.standby_cpu) {
        println!("{hint}");
    }
    let steal = steal_at_start.zip(StealSnapshot::read().ok()).map(|(start, end)| end.since(&start));
    if let Some(steal) = &steal {
        println!("{}", steal_line(steal, cpu));
    }
    let finite = print_physics(&sim, publisher.as_ref(), &frame_gate);
    let recorded = recorder.map(super::record::Recorder::finish);
    if let Some(Ok(summary)) = &recorded {
        println!("{summary}");
    }
    write_outputs(
        opts,
        &monitor,
        &context
            .with_steal(steal.as_ref(), cpu)
            .with_multirate(sim.multirate_status())
            .with_standby(scene.realtime.standby_cpu.zip(standby.as_ref().map(|s| s.ticks_run)))
            .with_node_frames(publisher.as_ref().map(|p| (p.sequence, &frame_gate))),
    )?;
    if let Some(Err(e)) = recorded {
        return Err(e);
    }
    if !finite {
        return Err(format!(
            "{}: the state diverged to non-finite values with the guard off (no such frame was published)",
            scene_name()
        ));
    }
    Ok(())
}

/// What one tick touches. The loop's thread and the standby (if any) hold it one at a time.
struct TickState<'a, T: Real> {
    sim: &'a mut Simulation<T>,
    publisher: OneThreadAtATime<Option<&'a mut super::publish::CorePublisher>>,
    recorder: Option<&'a mut super::record::Recorder>,
    frame_gate: &'a mut NodeFrameGate,
    /// Sub-steps done when a stop signal ended a frame, if one did.
    stopped_after: &'a mut Option<u64>,
}

/// A value that may move from thread to thread as long as one thread at a time uses it.
///
/// The publisher holds every iceoryx2 object of the process: the node and its ports, of the
/// single-threaded service kind, whose shared state is counted by `Rc`. It is reached only
/// through a [`TickState`], which the standby's baton hands from one thread to the other
/// (`lamina_rt::standby`): one holder at a time, each hand-over a release the next holder
/// acquires, so no two threads ever touch those counts at once. Between chunks only the
/// loop's thread runs.
struct OneThreadAtATime<P>(P);

// SAFETY: see the type's documentation: the value moves between threads whole and is used by
// one of them at a time, each hand-over ordered by the baton's release and acquire.
unsafe impl<P> Send for OneThreadAtATime<P> {}

impl<T: Real> TickState<'_, T> {
    /// One tick: the haptic command in, one step, the recorder's copy, the feedback and the
    /// node frame out. `Break` when a stop signal ended the step (the partial frame is not
    /// published).
    fn tick(&mut self, info: TickInfo, clock: &MonotonicClock, probe: &SendProbe) -> ControlFlow<()> {
        let publisher = &mut self.publisher.0;
        if let Some(h) = publisher.as_mut().and_then(|p| p.haptic.as_mut()) {
            h.before_step(self.sim);
        }
        let before = self.sim.counters().substeps;
        if !self.sim.step_or_stop(&STOP) {
            *self.stopped_after = Some(self.sim.counters().substeps - before);
            return ControlFlow::Break(());
        }
        if let Some(rec) = self.recorder.as_mut() {
            // A copy into a preallocated slot; the writer thread does the rest.
            rec.after_step(self.sim.state());
        }
        if let Some(p) = publisher.as_mut() {
            let (sim, frame_gate) = (&*self.sim, &mut *self.frame_gate);
            probe.measure(clock, || {
                if let Some(h) = p.haptic.as_mut() {
                    h.after_step(sim, info.tick);
                }
                if frame_gate.write_now(info.tick, || clock.now().saturating_sub(info.scheduled_ns)) {
                    p.publish_nodes(info.tick, sim.state(), sim.frame_changes());
                }
            });
        }
        ControlFlow::Continue(())
    }
}

/// The standby of `[realtime] standby_cpu`: how its thread is set up, the grid the next
/// chunk goes on with, and the ticks it ran.
struct Standby {
    request: RealtimeRequest,
    next: Grid,
    ticks_run: u64,
}

impl Standby {
    /// A standby on `cpu`, one SCHED_FIFO priority below the loop's, its grid starting one
    /// period from now.
    fn new(scene: &Scene, cpu: usize, period_ns: u64) -> Self {
        let request = loop_request(scene).for_standby_on(cpu);
        let next = Grid {
            origin_ns: MonotonicClock::new().now() + period_ns,
            first_tick: 0,
            period_ns,
            slots: 0,
            standby_delay_ns: u64::from(STANDBY_DELAY_US) * 1_000,
            previous_wake_ns: None,
        };
        Self { request, next, ticks_run: 0 }
    }

    /// Runs the next `chunk_ns` of the grid with the standby beside the loop's thread; why it
    /// stopped.
    fn run<T: Real>(
        &mut self,
        chunk_ns: u64,
        clock: &MonotonicClock,
        monitor: &mut DeadlineMonitor,
        state: &mut TickState<'_, T>,
        probe: &SendProbe,
    ) -> StopReason {
        let grid = Grid { slots: chunk_ns.div_ceil(self.next.period_ns), ..self.next };
        let request = self.request;
        let setup = move || {
            let setup = RealtimeSetup::apply(&request);
            if !setup.all_granted() {
                tracing::warn!("standby thread: {setup}");
            }
        };
        // One sleep per wait: the standby shares its CPU with the bulk's thread, which every
        // wake-up would interrupt.
        let standby_clock = clock.with_sleep_slice_ns(0);
        let clocks = [clock, &standby_clock];
        let run = run_with_standby(clocks, grid, Some(&STOP), monitor, state, setup, |state, info, _| {
            state.tick(info, clock, probe)
        });
        self.next = grid.following(&run);
        self.ticks_run += run.by_standby;
        run.stop
    }
}

/// Ticks stepped before the timed loop: at least 10. With multirate stepping at `ratio`, the
/// warm-up ends on the tick after an exchange, so the timed loop's first exchange is a whole
/// bulk step of real time later. (Warm-up ticks run back to back: the timed loop's first
/// exchange would otherwise come milliseconds after the warm-up's, and wait for its step.)
fn warm_up_ticks(multirate_ratio: Option<u32>) -> u32 {
    match multirate_ratio {
        Some(ratio) if ratio > 0 => ratio * 10u32.div_ceil(ratio) + 1,
        _ => 10,
    }
}

/// Refuses run lengths and tick rings outside their bounds, naming the option and value.
fn check_options(opts: &RunOptions) -> Result<(), String> {
    if let Some(s) = opts.seconds
        && !(s.is_finite() && s > 0.0 && s <= 1e9)
    {
        let shown = if s.is_finite() && (1e-3..1e6).contains(&s.abs()) { format!("{s}") } else { format!("{s:e}") };
        return Err(format!(
            "--seconds {shown}: must be a positive number of seconds, at most 1e9 (omit it to run until Ctrl-C)"
        ));
    }
    if !(1..=MAX_TICKS_CSV).contains(&opts.ticks_csv_last) {
        return Err(format!("--ticks-csv-last {}: must be from 1 to {MAX_TICKS_CSV}", opts.ticks_csv_last));
    }
    Ok(())
}

/// The simulation of `model` under the scene's solver and effects. A haptics-driven tool is
/// built into it (its stiffness counted in the critical step) and parked until the haptics
/// process speaks.
fn build_simulation<T: Real>(
    scene: &Scene,
    model: &Model,
) -> Result<(Simulation<T>, Option<HandTool>), lamina_core::solver::SimulationBuildError> {
    match scene.tool {
        Some(settings) if matches!(settings.source, lamina_core::scene::ToolSource::Haptics { .. }) => {
            let (sim, tool) = HandTool::simulation::<T>(model, scene.solver.clone(), scene.effects.clone(), settings)?;
            Ok((sim, Some(tool)))
        }
        _ => Ok((Simulation::<T>::new(model, scene.solver.clone(), scene.effects.clone())?, None)),
    }
}

/// Prints the scene, the model's size, the solver and why, and the stages in the loop.
fn print_setup<T: Real>(scene: &Scene, model: &Model, sim: &Simulation<T>) {
    println!(
        "scene '{}' ({}): {} nodes, {} springs, {} layers",
        scene.name,
        scene.path.as_ref().map_or("built-in default".into(), |p| p.display().to_string()),
        model.nodes.len(),
        model.springs.len(),
        model.layers.len()
    );
    println!(
        "solver: {} in {}, {} Hz, {} sub-step(s) per tick (critical step {:.3e} s, omega_max {:.3e} rad/s), {} thread(s), SIMD {}",
        sim.params().integrator,
        T::NAME,
        scene.rate_hz,
        sim.substeps(),
        sim.critical_step(),
        sim.stability().omega_max,
        sim.params().threads,
        sim.params().simd
    );
    println!("{}", integrator_reason(sim, scene.rate_hz));
    if let Some(needed) = sim.substeps_clamped() {
        println!(
            "warning: the critical step asks for {needed} sub-steps per tick; solver.max_substeps = {} holds it to {}, so each sub-step is {:.1}x the critical step and stability rests on the guard",
            sim.params().max_substeps,
            sim.substeps(),
            needed as f64 / f64::from(sim.substeps())
        );
    }
    if let (Some(m), Some(settings)) = (sim.multirate_status(), sim.params().multirate) {
        println!(
            "multirate: {} nodes within {} mm of ({:.3}, {:.3}, {:.3}) m every tick on the loop's thread, the other {} every {} ticks on a thread of their own, holding the region's core; the region {}; {} (late_build = \"{}\") (docs/solvers.md)",
            m.region_nodes,
            settings.radius * 1e3,
            settings.centre[0],
            settings.centre[1],
            settings.centre[2],
            m.bulk_nodes,
            m.ratio,
            if !settings.follow_tool {
                "stays where it is".to_string()
            } else {
                format!("follows the tool, each region taken {} or more exchanges after asking", m.build_exchanges)
            },
            match settings.late_build {
                LateBuild::Defer =>
                    "late work on the bulk's thread (a step, a region) is taken once done, the loop never waits for it",
                LateBuild::Wait => "the loop waits for late work on the bulk's thread",
            },
            settings.late_build.name()
        );
    }
    println!("stages in the loop: {}", sim.effects().stage_names().join(", "));
    if let Some(tool) = scene.tool {
        let source = match tool.source {
            lamina_core::scene::ToolSource::Scripted { .. } => "scripted",
            lamina_core::scene::ToolSource::Haptics { .. } => "driven by the haptics process",
        };
        // The scene set the per-node stiffness to the per-area one times this area.
        let per_area = tool.stiffness_per_area.map_or(String::new(), |k| {
            let area = tool.stiffness / k;
            format!(" ({k:.3e} N/m per m² of skin times the largest skin node area, {:.2} mm²)", area * 1e6)
        });
        println!(
            "tool: a sphere of radius {:.1} mm {source}, {:.1} N/m per node in contact{per_area}",
            tool.radius * 1e3,
            tool.stiffness
        );
    }
}

/// After a run with misses or skipped periods, the commands that measure how many the machine
/// itself causes: the same loop with the run's median compute per tick and no physics (with
/// the run's standby, if it had one), and, with a standby, the stops of every CPU at once,
/// which no standby covers.
fn machine_misses_hint(summary: &lamina_rt::MonitorSummary, standby_cpu: Option<usize>) -> Option<String> {
    (summary.misses + summary.skipped_periods > 0).then(|| {
        let work_us = (summary.compute.p50_ns as f64 / 1e3).round().max(1.0);
        let seconds = (summary.ticks as f64 * summary.period_ns as f64 / 1e9).round().max(1.0);
        let noise = format!("lamina bench noise --work-us {work_us:.0} --seconds {seconds:.0}");
        match standby_cpu {
            None => format!(
                "to see how many misses the machine causes to any loop of this length: {noise} (docs/benchmarks.md)"
            ),
            Some(cpu) => format!(
                "to see how many misses the machine causes to any loop of this length: {noise} --standby-cpu {cpu}; and through stops of every CPU at once, which no standby covers: lamina bench stalls --work-us {work_us:.0} (docs/benchmarks.md)"
            ),
        }
    })
}

/// The CPU the loop is pinned to: the scene's, else the last one available.
fn loop_cpu(scene: &Scene) -> Option<usize> {
    cpu_or_last(scene.realtime.cpu)
}

/// Refuses a CPU index given as `field` (an option or a scene field) that is not one of the
/// CPUs this process may run on: the error names the field, the value and those CPUs. `None`
/// (the default CPU) passes.
pub(super) fn check_cpu(field: &str, cpu: Option<usize>) -> Result<(), String> {
    let available = available_cpus();
    match cpu {
        Some(cpu) if !available.contains(&cpu) => {
            Err(lamina_rt::CpuOptionError { option: field.to_owned(), cpu, reason: "no such CPU", available }
                .to_string())
        }
        _ => Ok(()),
    }
}

/// `cpu`, else the last CPU the process may use: where `lamina run` pins its loop.
pub(super) fn cpu_or_last(cpu: Option<usize>) -> Option<usize> {
    cpu.or_else(|| available_cpus().last().copied())
}

/// The loop CPU's steal between two snapshots, as `12 ms`, or `n/a`.
pub(super) fn loop_steal_ms(now: Option<&StealSnapshot>, before: Option<&StealSnapshot>, cpu: Option<usize>) -> String {
    let stolen = now.zip(before).zip(cpu).and_then(|((now, before), cpu)| now.since(before).cpu(cpu));
    stolen.map_or("n/a".into(), |c| format!("{} ms", c.stolen_ms))
}

/// One line naming the time the hypervisor took from each CPU over the run.
fn steal_line(steal: &StealSnapshot, loop_cpu: Option<usize>) -> String {
    let per_cpu: Vec<String> = steal.cpus().iter().map(|c| format!("CPU {} {} ms", c.cpu, c.stolen_ms)).collect();
    let on = loop_cpu.map_or(String::new(), |c| format!("; the loop ran on CPU {c}"));
    format!("host steal over the run (time the hypervisor took, /proc/stat): {}{on}", per_cpu.join(", "))
}

/// What the scene's `[realtime]` table asks for the loop's thread.
fn loop_request(scene: &Scene) -> RealtimeRequest {
    let mut request = RealtimeRequest::new();
    request.cpu = loop_cpu(scene);
    if let Some(p) = scene.realtime.fifo_priority {
        request = request.fifo_priority(p);
    }
    if scene.realtime.lock_memory {
        request = request.lock_memory();
    }
    request
}

/// Pins the core, asks for SCHED_FIFO and locked memory as the scene says, and prints what
/// was granted and refused.
fn apply_realtime_setup(scene: &Scene) {
    let setup = RealtimeSetup::apply(&loop_request(scene));
    print!("{setup}");
    if let Some(standby) = scene.realtime.standby_cpu {
        println!(
            "  standby         cpu {standby}, SCHED_FIFO one below the loop: runs a tick the loop's thread has not started {STANDBY_DELAY_US} µs after its deadline ([realtime] standby_cpu)"
        );
    }
    match scene.realtime.sleep_slice_us {
        0 => println!("  between ticks   one sleep to the next tick ([realtime] sleep_slice_us = 0)"),
        us => println!(
            "  between ticks   sleeps of at most {us} µs, so a virtual CPU stays with its host ([realtime] sleep_slice_us)"
        ),
    }
}

/// Prints the per-frame stage costs and the physics summary (and the publishing and haptic
/// link counts); returns whether the final state is finite.
fn print_physics<T: Real>(
    sim: &Simulation<T>,
    publisher: Option<&super::publish::CorePublisher>,
    frame_gate: &NodeFrameGate,
) -> bool {
    let c = sim.counters();
    let frames = c.frames.max(1) as f64;
    println!(
        "per frame: springs {:.1} us, nodes {:.1} us, external {:.1} us, bone {:.1} us, guard {:.1} us, implicit {:.1} us (preconditioner {:.1} us)",
        c.springs.as_secs_f64() * 1e6 / frames,
        c.nodes.as_secs_f64() * 1e6 / frames,
        c.external.as_secs_f64() * 1e6 / frames,
        c.bone.as_secs_f64() * 1e6 / frames,
        c.guard.as_secs_f64() * 1e6 / frames,
        c.implicit.as_secs_f64() * 1e6 / frames,
        c.preconditioner.as_secs_f64() * 1e6 / frames
    );
    if let Some(m) = sim.multirate_status() {
        println!(
            "multirate: {} bulk steps, mean {:.1} us, longest {:.1} us; the loop waited for the bulk {} time(s), longest {:.1} us (the untimed warm-up's back-to-back ticks included); went on {} tick(s) past a late bulk step (at most {} in a row), the ring held; {} non-finite bulk state(s) refused",
            m.bulk_steps,
            m.bulk_step_total_ns as f64 / 1e3 / m.bulk_steps.saturating_sub(1).max(1) as f64,
            m.bulk_step_max_ns as f64 / 1e3,
            m.waits,
            m.wait_max_ns as f64 / 1e3,
            m.held_ticks,
            m.held_max_ticks,
            m.refused
        );
        println!(
            "multirate region: moved with the tool {} time(s) (taken {} or more exchanges after asking; longest build {:.1} us, on a thread of its own), {} region(s) about the tool refused; now {} nodes within {:.1} mm of ({:.3}, {:.3}, {:.3}) m",
            m.recentres,
            m.build_exchanges,
            m.recentre_build_max_ns as f64 / 1e3,
            m.recentres_refused,
            m.region_nodes,
            m.radius * 1e3,
            m.centre[0],
            m.centre[1],
            m.centre[2]
        );
        println!(
            "multirate coupling gap (where the region and the bulk put the nodes both step): {:.3} mm at the last exchange, largest {:.3} mm",
            m.coupling_gap_m * 1e3,
            m.coupling_gap_max_m * 1e3
        );
        if let Some(warning) = coupling_warning(&m) {
            println!("{warning}");
        }
        if m.bulk_stopped {
            println!(
                "warning: the multirate bulk thread stopped; the region ran on alone with the rest of the model held"
            );
        }
    }
    let g = sim.guard_totals();
    let state = sim.state();
    let rest = sim.rest_positions();
    let max_u = (0..state.x.len())
        .map(|i| {
            let (p, r) = (state.x.get_f64(i), rest.get_f64(i));
            ((p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2) + (p[2] - r[2]).powi(2)).sqrt()
        })
        .fold(0.0f64, |m, u| if u.is_nan() || m.is_nan() { f64::NAN } else { m.max(u) });
    let finite = state.x.all_finite() && state.v.all_finite();
    if !finite {
        println!(
            "the state is not finite: the simulation diverged (guard off; turn effects.guard on to roll bad frames back)"
        );
    }
    println!(
        "physics: simulated {:.3} s, max displacement {:.3} mm, guard rollbacks {} (substeps {}, implicit {}, frozen {}), state finite: {}",
        state.time,
        max_u * 1e3,
        g.rollbacks,
        g.by_substeps,
        g.by_implicit,
        g.frozen,
        finite
    );
    if let Some(p) = publisher {
        println!(
            "published {} node frames ({} publish failures, {} withheld: state not finite; {} written a tick or more late and {} shed: their ticks had used more than {:.0} us)",
            p.sequence,
            p.failures,
            p.withheld,
            frame_gate.deferred(),
            frame_gate.shed(),
            frame_gate.cutoff_ns() as f64 / 1e3
        );
        if let Some(h) = &p.haptic {
            let c = h.counts;
            println!(
                "haptic link: {} tool commands applied, {} refused (non-finite or implausible; {} of an unknown tool kind), {} scalpel commands (sphere parked), {} with a radius raised to the scene's min_radius, parked {} time(s), {} grasp(s), {} feedback messages ({} non-finite replaced by no-contact), {} port failures",
                c.commands,
                c.bad_commands,
                c.unknown_kinds,
                c.scalpel_commands,
                c.radius_raised,
                c.parked,
                c.grasps,
                c.feedback,
                c.bad_feedback,
                c.failures
            );
            if let Some(t) = h.scalpel_totals() {
                println!(
                    "scalpel: {} puncture(s), springs cut skin {} fat {} muscle {}, deepest edge skin {:.1} fat {:.1} muscle {:.1} mm, peak press {:.2} N, peak cutting force {:.2} N, {:.1} mm of tip travel in the tissue",
                    t.punctures,
                    t.springs_cut[0],
                    t.springs_cut[1],
                    t.springs_cut[2],
                    t.deepest.skin * 1e3,
                    t.deepest.fat * 1e3,
                    t.deepest.muscle * 1e3,
                    t.peak_press,
                    t.peak_force,
                    t.cut_length * 1e3
                );
            }
            if let Some(r) = sim.refactor_status() {
                println!(
                    "factors of the cut model: {} taken, {} cuts in the one in use, last build {:.1} ms, longest {:.1} ms",
                    r.taken,
                    r.cuts_in_factor,
                    r.last_build_s * 1e3,
                    r.longest_build_s * 1e3
                );
            }
        }
    }
    finite
}

/// Writes the --ticks-csv records and the --report JSON (the monitor's summary with the run's
/// context, `docs/reports.md`).
fn write_outputs(
    opts: &RunOptions,
    monitor: &DeadlineMonitor,
    context: &super::run_report::RunContext,
) -> Result<(), String> {
    if let Some(path) = &opts.ticks_csv {
        let mut text = String::from("tick,wake_ns,lateness_ns,compute_ns,send_ns\n");
        for r in monitor.records().iter() {
            text.push_str(&format!("{},{},{},{},{}\n", r.tick, r.wake_ns, r.lateness_ns, r.compute_ns, r.send_ns));
        }
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        tracing::info!("per-tick records written to {}", path.display());
    }
    if let Some(path) = &opts.report {
        let report = context.report(&monitor.report_json());
        let text = serde_json::to_string_pretty(&report).unwrap_or_default() + "\n";
        std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))?;
        tracing::info!("report written to {}", path.display());
    }
    Ok(())
}

/// Which integrator runs and why, from the model's own critical step.
fn integrator_reason<T: Real>(sim: &Simulation<T>, rate_hz: u32) -> String {
    use lamina_core::solver::IntegratorKind;
    let dt = 1.0 / f64::from(rate_hz);
    let explicit_steps = (dt
        / (sim.stability().critical_step(IntegratorKind::SymplecticEuler) * sim.params().stability_safety))
        .ceil()
        .max(1.0);
    match sim.params().integrator {
        IntegratorKind::ImplicitFactored => format!(
            "integrator: implicit_factored, one implicit step of {} PCG iteration(s) per tick{} where symplectic Euler \
             needs {explicit_steps:.0} sub-steps below its critical step; the cheapest per tick at the explicit press \
             force, with more damping of fast motion (docs/solvers.md, lamina bench capacity, lamina study accuracy)",
            sim.params().factored_iterations,
            match sim.params().factor_storage {
                lamina_core::solver::FactorStorage::Full => "",
                lamina_core::solver::FactorStorage::Half => ", its preconditioner's factor stored in binary16",
            }
        ),
        IntegratorKind::SymplecticEuler => format!(
            "integrator: symplectic Euler, {explicit_steps:.0} sub-step(s) per tick; the most accurate per unit of \
             compute when sub-steps are few (docs/accuracy-and-stability.md); implicit_factored takes one step \
             per tick (docs/solvers.md)"
        ),
        other => format!("integrator: {other} as the scene asks (docs/solvers.md compares the choices)"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lamina_core::solver::MultirateStatus;

    #[test]
    fn warm_up_ends_on_the_tick_after_an_exchange_works() {
        assert_eq!(warm_up_ticks(None), 10);
        for ratio in 2..=lamina_core::solver::MAX_MULTIRATE_RATIO {
            let n = warm_up_ticks(Some(ratio));
            // Exchanges come on ticks 0, ratio, 2·ratio, ...: the last warm-up tick is one,
            // and the warm-up is at least 10 ticks and less than a cycle more.
            assert_eq!((n - 1) % ratio, 0, "ratio {ratio}: {n} ticks");
            assert!((10..10 + ratio + 1).contains(&n), "ratio {ratio}: {n} ticks");
        }
    }

    #[test]
    fn coupling_warning_names_a_gap_above_three_millimetres_works() {
        let at = |gap| coupling_warning(&MultirateStatus { coupling_gap_max_m: gap, ..MultirateStatus::default() });
        assert_eq!(at(2.1e-3), None);
        let warning = at(6.4e-3).expect("a 6.4 mm gap is warned of");
        assert!(warning.contains("6.4 mm apart"), "{warning}");
    }

    #[test]
    fn machine_misses_hint_gives_the_runs_median_compute_and_length_works() {
        use lamina_rt::FakeClock;
        // One second at 1 kHz, 200 µs per tick; with `slow_tick`, that tick takes 1.5 ms.
        let monitor_of = |slow_tick: Option<u64>| {
            let clock = FakeClock::new(0).with_compute(move |t| if Some(t) == slow_tick { 1_500_000 } else { 200_000 });
            let mut lp = FixedRateLoop::new(clock.clone(), 1_000, OverrunPolicy::Skip);
            let mut monitor = DeadlineMonitor::new(MonitorConfig::for_period_ns(lp.period_ns()));
            lp.run(RunLimit::duration_ns(1_000_000_000), &mut monitor, |info| {
                clock.spend(info.tick);
                ControlFlow::Continue(())
            });
            monitor
        };
        assert_eq!(machine_misses_hint(&monitor_of(None).summary(), None), None);
        let hint = machine_misses_hint(&monitor_of(Some(400)).summary(), None).expect("a run with a miss");
        assert!(hint.contains("lamina bench noise --work-us 200 --seconds 1 "), "{hint}");
        assert!(!hint.contains("stalls"), "{hint}");
        // The 1.5 ms tick also skips a slot (`Skip`); with a standby on CPU 0 the hint measures
        // the loop with it, and the stops no standby covers.
        let hint = machine_misses_hint(&monitor_of(Some(400)).summary(), Some(0)).expect("a run with a miss");
        assert!(hint.contains("--seconds 1 --standby-cpu 0;"), "{hint}");
        assert!(hint.contains("lamina bench stalls --work-us 200 "), "{hint}");
    }
}
