//! `lamina bench capacity`: compute per 1 kHz tick against model size, every solver side by
//! side. The default scene's cylinder limb is generated at several grids (same limb, finer
//! cells), plus any scene files given (the thigh); each model runs every integrator on 1 and
//! 2 threads with the sphere tool pressed 4 mm into the skin (where the scene has a tool),
//! plus multirate stepping on two threads about the tool (its ticks paced at 1 kHz, as the
//! bulk steps in real time), and every configuration of one model is timed in interleaved
//! rounds, so load from other processes falls on all of them alike.

use super::{machine, plot};
use lamina_core::model::Model;
use lamina_core::scene::{ModelSource, Scene, ToolSource};
use lamina_core::solver::{IntegratorKind, MultirateSettings, Simulation, SphereTool, Substeps};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What to measure.
pub struct CapacityOptions {
    /// Cylinder limb grids, columns × rows.
    pub grids: Vec<(u32, u32)>,
    /// Further scene files (their own model and effects).
    pub scenes: Vec<PathBuf>,
    /// Integrators to compare.
    pub integrators: Vec<IntegratorKind>,
    /// Thread counts.
    pub threads: Vec<usize>,
    /// Ticks timed per configuration (fewer when `max_seconds` runs out first).
    pub ticks: usize,
    /// Wall time per configuration, s, warm-up included.
    pub max_seconds: f64,
    /// Directory for capacity.csv and capacity.png.
    pub out: PathBuf,
    /// SCHED_FIFO priority for the measuring thread and its workers (0: leave as is).
    pub fifo_priority: i32,
    /// Radius of the multirate configuration's region about the tool, m. Default 0.03.
    pub region_radius_m: f64,
    /// Ticks per bulk step of the multirate configuration. Default 20.
    pub ratio: u32,
}

/// Name of the generated limbs in the table.
const LIMB: &str = "limb";
/// Budget of one 1 kHz tick, µs.
const BUDGET_US: f64 = 1000.0;
/// Tool depth under the skin's rest surface while timing, m.
const PRESS_DEPTH_M: f64 = 0.004;
/// Ticks per configuration per round.
const ROUND_TICKS: usize = 25;
/// Untimed ticks that estimate a configuration's cost before its warm-up.
const PROBE_TICKS: usize = 3;
/// Name of the multirate configurations (`implicit_factored` with `[solver.multirate]`).
const MULTIRATE: &str = "multirate";
/// One tick's period, for pacing the multirate configurations (their bulk steps in real time).
const TICK: Duration = Duration::from_millis(1);

/// One measured configuration.
struct Row {
    model: String,
    nodes: usize,
    springs: usize,
    integrator: IntegratorKind,
    /// The integrator's name, or [`MULTIRATE`].
    solver: &'static str,
    threads: usize,
    /// Sub-steps (explicit) or solver iterations per tick, as printed.
    steps: String,
    samples_ns: Vec<u64>,
    error: Option<String>,
}

impl Row {
    fn quantile_us(&self, q: f64) -> f64 {
        if self.samples_ns.is_empty() {
            return f64::NAN;
        }
        let mut s = self.samples_ns.clone();
        s.sort_unstable();
        let i = ((s.len() - 1) as f64 * q).round() as usize;
        s[i] as f64 / 1e3
    }
}

/// A configuration being timed.
struct Timed {
    row: Row,
    sim: Option<Simulation<f32>>,
    tool: Option<(SphereTool, [f64; 3])>,
    spent: Duration,
    ticks_run: usize,
    /// Untimed ticks while the tool is ramped in.
    warm: usize,
    cg_iterations: u64,
}

/// Builds every model measured: each grid's limb, then each scene's. Any that cannot be built
/// (a scene that does not load, a grid over the memory budget) refuses the whole benchmark
/// before anything is timed, naming each such grid or scene and why.
fn build_models(opts: &CapacityOptions) -> Result<Vec<(Scene, Model)>, String> {
    let mut out = Vec::new();
    let mut failed = Vec::new();
    for &(columns, rows) in &opts.grids {
        let mut scene = Scene::builtin_default();
        // The default limb's length and springs on every grid.
        let (length, springs) = match scene.model {
            ModelSource::CylinderLimb { length, springs, .. } => (length, springs),
            _ => (0.24, None),
        };
        scene.model = ModelSource::CylinderLimb { columns, rows, length, springs };
        scene.name = format!("{LIMB} {columns}x{rows}");
        match scene.build_model() {
            Ok(model) => out.push((scene, model)),
            Err(e) => failed.push(format!("grid {columns}x{rows}: {e}")),
        }
    }
    for path in &opts.scenes {
        match Scene::load(path).map_err(|e| e.to_string()).and_then(|s| {
            let model = s.build_model().map_err(|e| format!("{}: {e}", path.display()))?;
            Ok((s, model))
        }) {
            Ok(pair) => out.push(pair),
            Err(e) => failed.push(format!("scene {e}")),
        }
    }
    if !failed.is_empty() {
        return Err(format!("nothing measured: {} model(s) could not be built: {}", failed.len(), failed.join("; ")));
    }
    if out.is_empty() {
        return Err("nothing to measure: --grids and --scenes are both empty".into());
    }
    Ok(out)
}

/// Builds every configuration of one model.
fn configurations(scene: &Scene, model: &Model, opts: &CapacityOptions) -> Vec<Timed> {
    let tool = scene.tool.and_then(|t| match t.source {
        ToolSource::Haptics { device_origin, .. } => Some((
            SphereTool { radius: t.radius, stiffness: t.stiffness, start: device_origin, velocity: [0.0; 3] },
            device_origin,
        )),
        _ => None,
    });
    let mut variants = Vec::new();
    for &integrator in &opts.integrators {
        for &threads in &opts.threads {
            variants.push((integrator, threads, None));
        }
    }
    // Multirate on two threads (the region on the caller's, the bulk on its own) about the tool.
    if let Some((_, origin)) = tool
        && opts.integrators.contains(&IntegratorKind::ImplicitFactored)
        && opts.threads.contains(&2)
    {
        let settings = MultirateSettings {
            centre: origin,
            radius: opts.region_radius_m,
            ratio: opts.ratio,
            ..MultirateSettings::default()
        };
        variants.push((IntegratorKind::ImplicitFactored, 2, Some(settings)));
    }
    let mut list = Vec::new();
    for (integrator, threads, multirate) in variants {
        let mut params = scene.solver.clone();
        params.integrator = integrator;
        params.threads = threads;
        params.substeps = Substeps::Auto;
        params.multirate = multirate;
        let mut effects = scene.effects.clone();
        if let Some((t, _)) = tool {
            effects.tool = Some(t);
        }
        let row = Row {
            model: scene.name.clone(),
            nodes: model.nodes.len(),
            springs: model.springs.len(),
            integrator,
            solver: if multirate.is_some() { MULTIRATE } else { integrator.name() },
            threads,
            steps: String::new(),
            samples_ns: Vec::new(),
            error: None,
        };
        let mut timed =
            Timed { row, sim: None, tool, spent: Duration::ZERO, ticks_run: 0, warm: PROBE_TICKS, cg_iterations: 0 };
        match Simulation::<f32>::new(model, params, effects) {
            Ok(sim) => timed.sim = Some(sim),
            Err(e) => timed.row.error = Some(e.to_string()),
        }
        list.push(timed);
    }
    list
}

/// Runs `ticks` ticks of one configuration; its first `warm` ticks ramp the tool in and are
/// not timed.
fn run_ticks(t: &mut Timed, ticks: usize) {
    let warm = t.warm;
    let Some(sim) = t.sim.as_mut() else { return };
    let begin = Instant::now();
    for _ in 0..ticks {
        if let Some((_, origin)) = t.tool {
            let ramp = ((t.ticks_run + 1) as f64 / warm as f64).min(1.0);
            if let Some(tool) = sim.effects_mut().tool.as_mut() {
                tool.start = [origin[0], origin[1] - PRESS_DEPTH_M * ramp, origin[2]];
            }
        }
        let start = Instant::now();
        sim.step();
        let ns = start.elapsed().as_nanos() as u64;
        if sim.multirate_status().is_some() {
            // The bulk steps while the region's ticks pass in real time: pace them at 1 kHz.
            while start.elapsed() < TICK {
                std::thread::sleep(TICK.saturating_sub(start.elapsed()).min(Duration::from_micros(200)));
            }
        }
        if t.ticks_run >= warm {
            t.row.samples_ns.push(ns);
            t.cg_iterations += u64::from(sim.last_cg().0);
        }
        t.ticks_run += 1;
        if !sim.state().x.all_finite() {
            t.row.error = Some("state not finite".into());
            t.sim = None;
            break;
        }
    }
    t.spent += begin.elapsed();
}

/// Times every configuration of one model in interleaved rounds: a few probe ticks, a
/// warm-up of up to 100 ticks (a quarter of the time allowed), then rounds until each has its
/// ticks or its time.
fn measure(list: &mut [Timed], opts: &CapacityOptions) {
    let budget = Duration::from_secs_f64(opts.max_seconds);
    for t in list.iter_mut() {
        run_ticks(t, PROBE_TICKS);
        let per = t.spent.as_secs_f64() / PROBE_TICKS as f64;
        t.warm = ((budget.as_secs_f64() / 4.0 / per.max(1e-9)) as usize).clamp(PROBE_TICKS + 5, 100);
        run_ticks(t, t.warm - PROBE_TICKS);
    }
    loop {
        let mut any = false;
        for t in list.iter_mut() {
            let enough = t.row.samples_ns.len() >= opts.ticks || (t.spent >= budget && t.row.samples_ns.len() >= 5);
            if t.sim.is_none() || enough {
                continue;
            }
            any = true;
            run_ticks(t, ROUND_TICKS);
        }
        if !any {
            break;
        }
    }
    for t in list.iter_mut() {
        let Some(sim) = t.sim.as_ref() else { continue };
        let measured = t.row.samples_ns.len().max(1) as f64;
        t.row.steps = match t.row.integrator {
            IntegratorKind::ImplicitEuler => format!("{:.1} CG", t.cg_iterations as f64 / measured),
            IntegratorKind::ImplicitFactored if t.row.solver == MULTIRATE => {
                let m = sim.multirate_status().unwrap_or_default();
                format!("{}+{}/{} nodes", m.region_nodes, m.bulk_nodes, m.ratio)
            }
            IntegratorKind::ImplicitFactored => format!("1 + {} PCG", sim.params().factored_iterations),
            _ => format!("{} sub", sim.substeps()),
        };
    }
}

/// Runs the benchmark and prints its table; writes capacity.csv and capacity.png.
pub fn bench(opts: &CapacityOptions) -> Result<(), String> {
    if opts.fifo_priority > 0 {
        match lamina_rt::setup::set_fifo_priority(opts.fifo_priority) {
            Ok(()) => println!("measuring thread and workers at SCHED_FIFO priority {}", opts.fifo_priority),
            Err(e) => println!("SCHED_FIFO not set ({e}); timings include preemption by other processes"),
        }
    }
    let models = build_models(opts)?;
    std::fs::create_dir_all(&opts.out).map_err(|e| format!("{}: {e}", opts.out.display()))?;
    println!(
        "capacity benchmark: compute per 1 kHz tick (budget {BUDGET_US:.0} us), f32, tool pressed {:.0} mm where the scene has one",
        PRESS_DEPTH_M * 1e3
    );
    println!("machine: {}", machine::describe());
    println!(
        "each configuration: up to {} timed ticks or {:.1} s after warm-up, in interleaved rounds of {ROUND_TICKS} ticks\n",
        opts.ticks, opts.max_seconds
    );
    println!(
        "{:<22} {:>7} {:>8} {:<18} {:>3} {:>11} {:>9} {:>9} {:>9} {:>7} {:>8}",
        "model", "nodes", "springs", "solver", "thr", "steps/tick", "p50 us", "p99 us", "max us", "ticks", "vs expl."
    );
    let mut rows: Vec<Row> = Vec::new();
    // Moves between models, never while one is timed.
    let bar = super::progress::steps(models.len() as u64, "bench capacity");
    for (scene, model) in models {
        bar.set_message(scene.name.clone());
        let mut list = configurations(&scene, &model, opts);
        measure(&mut list, opts);
        bar.inc(1);
        let reference = list
            .iter()
            .find(|t| t.row.solver == IntegratorKind::SymplecticEuler.name() && t.row.threads == 1)
            .map(|t| t.row.quantile_us(0.5));
        bar.suspend(|| {
            for t in list {
                let r = t.row;
                if let Some(e) = &r.error {
                    println!("{:<22} {:>7} {:>8} {:<18} {:>3} {e}", r.model, r.nodes, r.springs, r.solver, r.threads);
                } else {
                    let p50 = r.quantile_us(0.5);
                    let ratio = reference.map(|x| format!("{:.2}x", x / p50)).unwrap_or_default();
                    println!(
                        "{:<22} {:>7} {:>8} {:<18} {:>3} {:>11} {:>9.1} {:>9.1} {:>9.1} {:>7} {:>8}",
                        r.model,
                        r.nodes,
                        r.springs,
                        r.solver,
                        r.threads,
                        r.steps,
                        p50,
                        r.quantile_us(0.99),
                        r.quantile_us(1.0),
                        r.samples_ns.len(),
                        ratio
                    );
                }
                rows.push(r);
            }
        });
    }
    bar.finish_and_clear();
    println!("\nlargest model within half the budget (p99 <= {:.0} us):", BUDGET_US / 2.0);
    for (solver, threads) in solver_groups(&rows) {
        let best = rows
            .iter()
            .filter(|r| r.solver == solver && r.threads == threads && r.error.is_none())
            .filter(|r| r.quantile_us(0.99) <= BUDGET_US / 2.0)
            .max_by_key(|r| r.nodes);
        let text = best.map(|r| format!("{} ({} nodes, p99 {:.0} us)", r.model, r.nodes, r.quantile_us(0.99)));
        println!("  {solver:<18} {threads} thread(s): {}", text.as_deref().unwrap_or("none"));
    }
    if rows.iter().all(|r| r.error.is_some()) {
        return Err(
            "nothing measured: no configuration of any model could be built (the errors are in the table)".into()
        );
    }
    write_csv(&opts.out.join("capacity.csv"), &rows)?;
    write_plot(&opts.out.join("capacity.png"), &rows)?;
    tracing::info!(
        "written: {} and {}",
        opts.out.join("capacity.csv").display(),
        opts.out.join("capacity.png").display()
    );
    Ok(())
}

/// Every (solver, thread count) measured, in the order first met.
fn solver_groups(rows: &[Row]) -> Vec<(&'static str, usize)> {
    let mut out: Vec<(&'static str, usize)> = Vec::new();
    for r in rows {
        if !out.contains(&(r.solver, r.threads)) {
            out.push((r.solver, r.threads));
        }
    }
    out
}

fn write_csv(path: &Path, rows: &[Row]) -> Result<(), String> {
    let mut text = String::from("model,nodes,springs,solver,threads,steps_per_tick,p50_us,p99_us,max_us,ticks,error\n");
    for r in rows {
        let _ = writeln!(
            text,
            "{},{},{},{},{},{},{:.2},{:.2},{:.2},{},{}",
            r.model,
            r.nodes,
            r.springs,
            r.solver,
            r.threads,
            r.steps,
            r.quantile_us(0.5),
            r.quantile_us(0.99),
            r.quantile_us(1.0),
            r.samples_ns.len(),
            r.error.as_deref().unwrap_or("")
        );
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Nodes against p50 µs per tick of the cylinder limbs (the other scenes are in the table),
/// one line per solver and thread count, with the budget and half-budget lines.
fn write_plot(path: &Path, rows: &[Row]) -> Result<(), String> {
    let mut series = Vec::new();
    for (solver, threads) in solver_groups(rows) {
        let mut points: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.solver == solver && r.threads == threads && r.error.is_none())
            .filter(|r| r.model.starts_with(LIMB))
            .map(|r| (r.nodes as f64, r.quantile_us(0.5)))
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        series.push(plot::Series { name: format!("{solver} {threads}T p50"), points });
    }
    let (lo, hi) = rows.iter().fold((f64::MAX, 0.0f64), |(lo, hi), r| (lo.min(r.nodes as f64), hi.max(r.nodes as f64)));
    if hi > 0.0 {
        series.push(plot::Series { name: "budget 1 ms".into(), points: vec![(lo, BUDGET_US), (hi, BUDGET_US)] });
        series.push(plot::Series {
            name: "half budget".into(),
            points: vec![(lo, BUDGET_US / 2.0), (hi, BUDGET_US / 2.0)],
        });
    }
    plot::log_log_lines(path, "compute per 1 kHz tick", "nodes", "us per tick (p50)", &series, true)
}
