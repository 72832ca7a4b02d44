//! `lamina`: the command line of the physics core, one module per subcommand.

mod bench_capacity;
mod bench_effects;
mod bench_noise;
mod bench_stalls;
mod bench_yardstick;
mod demo;
mod demo_script;
mod demo_watch;
mod fit;
mod frame_gate;
mod generate;
mod haptic_link;
mod machine;
mod plot;
mod profile;
mod progress;
mod publish;
mod record;
mod run;
mod run_report;
mod study;
mod yardstick_c;
mod yardstick_cmd;

use clap::{Parser, Subcommand};
use lamina_core::solver::{IntegratorKind, MAX_MULTIRATE_RATIO, SimdLevel};
use lamina_core::yardstick::LatticeSize;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

#[derive(Parser)]
#[command(name = "lamina", version, about = "Real-time layered soft-tissue simulation core")]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Diagnostics shown on stderr: error, warn, info, debug or trace. Results (tables,
    /// summaries, JSON) go to stdout whatever the level.
    #[arg(long, global = true, value_name = "LEVEL", default_value = "info")]
    log_level: tracing::Level,
}

#[derive(Subcommand)]
enum Command {
    /// Run the core process: step a scene at a fixed rate and report deadline misses.
    Run {
        /// Scene file (TOML); the built-in default scene when omitted.
        #[arg(long)]
        scene: Option<PathBuf>,
        /// How long to run, s. Without it the core runs until SIGINT (Ctrl-C) or SIGTERM, then
        /// prints its tables and writes its report.
        #[arg(long)]
        seconds: Option<f64>,
        /// Write the deadline monitor's JSON report here at exit.
        #[arg(long)]
        report: Option<PathBuf>,
        /// Print only the final tables.
        #[arg(long)]
        quiet: bool,
        /// iceoryx2 service prefix, so several simulations can share a host.
        #[arg(long, default_value = "lamina")]
        prefix: String,
        /// Do not publish over iceoryx2.
        #[arg(long)]
        no_publish: bool,
        /// Write the last ticks' records (tick, wake, lateness, compute, send; ns) as CSV at
        /// exit: at most --ticks-csv-last of them, kept in a ring allocated before the loop.
        #[arg(long)]
        ticks_csv: Option<PathBuf>,
        /// Ticks --ticks-csv keeps (the newest), 1 to 3,600,000 (one hour at 1 kHz; 40 bytes
        /// each, 144 MB). Default 600,000: the last ten minutes at 1 kHz, 24 MB.
        #[arg(long, default_value_t = 600_000)]
        ticks_csv_last: usize,
        /// Record the run for ParaView into this folder: run.pvd (open it) and one
        /// frame_NNNNNN.vtu per frame with the volume cells, displacement (m), velocity (m/s),
        /// layer and spring strain; written by a separate thread, never blocking the loop
        /// (docs/recording.md). The folder must not hold an earlier recording's frames.
        #[arg(long, value_name = "DIR")]
        record: Option<PathBuf>,
        /// Ticks between recorded frames. Default: the scene's rate / 50, i.e. 50 frames per
        /// second of simulated time (every 20 ticks at 1 kHz). The frame at rest (t = 0) is
        /// recorded too.
        #[arg(long, value_name = "N", requires = "record")]
        record_every: Option<u32>,
        /// Frames after which recording stops (the run goes on), 1 to 1,000,000. Default
        /// 1,500: 30 s of simulated time at 50 frames/s, about 100 MB for the default scene.
        #[arg(long, value_name = "N", default_value_t = record::DEFAULT_MAX_FRAMES, requires = "record")]
        record_max_frames: usize,
    },
    /// Benchmarks that print tables.
    Bench {
        #[command(subcommand)]
        what: BenchCommand,
    },
    /// Generate a layered model: the paper's Table 3 comparison, or the cylindrical limb.
    Generate {
        /// Print our mass and spring counts beside the paper's Table 3.
        #[arg(long)]
        table3: bool,
        /// Grid of the synthetic cylindrical limb, WxH: columns 3 to 4096, rows 1 to 4096.
        #[arg(long, default_value = "39x10")]
        cylinder: String,
        /// Limb length, m.
        #[arg(long, default_value_t = 0.30)]
        length: f64,
        /// Output model (XML).
        #[arg(long, default_value = "limb.xml")]
        out: PathBuf,
        /// Also write the model as VTK (.vtu) for ParaView.
        #[arg(long)]
        vtu: Option<PathBuf>,
        /// Generate the model of this anatomy scene (segmented surfaces) instead.
        #[arg(long)]
        scene: Option<PathBuf>,
    },
    /// Inspect a surface mesh (STL or OBJ): counts, closedness, defects, volume, area, bounds.
    Inspect {
        /// The mesh file.
        file: PathBuf,
    },
    /// Run the whole simulator on a scene: the core, haptics with a scripted device, and the
    /// viewer (headless without a display), as separate processes.
    Demo {
        /// Scene; the built-in default when omitted.
        #[arg(long)]
        scene: Option<PathBuf>,
        /// How long to run, s. With the scripted device, the device runs this less 0.8 s from
        /// its own start and the core until the device is done (its start comes 0.1-1 s after
        /// the core's, more on a loaded machine); the script is fitted to it.
        #[arg(long, default_value_t = 8.0)]
        seconds: f64,
        /// Output folder (frames, reports, logs).
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
        /// Have the core record the run for ParaView into this folder (`lamina run --record`,
        /// docs/recording.md).
        #[arg(long, value_name = "DIR")]
        record: Option<PathBuf>,
    },
    /// Cross-process profile: core-to-subscriber latency (poll and block), jitter, misses.
    Profile {
        /// Scene for the core run; the built-in default when omitted.
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Seconds per measurement, above 0 and at most 3600.
        #[arg(long, default_value_t = 5.0)]
        seconds: f64,
        /// Node counts for the synthetic publisher, comma-separated, each 1 to 1,000,000.
        #[arg(long, default_value = "2769,100000")]
        nodes: String,
        /// Output folder.
        #[arg(long, default_value = "out/profile")]
        out: PathBuf,
    },
    /// Fits each layer's springs to measured tissue (virtual tensile test, bilinear
    /// regression, simulated annealing; a layer whose moduli do not converge, such as skin on
    /// cells of a few mm, is fitted to its strain under every load), per grid size of the
    /// cylindrical limb or for a scene's limb, and measures each fitted layer against the
    /// tissue's own curve.
    Fit {
        /// Folder with skin.toml, fat.toml and muscle.toml. Default: ./config/materials when
        /// it exists, else the shipped targets built into this binary.
        #[arg(long)]
        materials: Option<PathBuf>,
        /// Grid sizes of the limb to fit for, comma-separated WxH: columns 3 to 4096, rows 1 to 4096.
        #[arg(long, default_value = "39x10")]
        grid_sizes: String,
        /// Scene files whose limb to fit for (repeatable): prints the `[model.springs]` table
        /// to put in the scene, writes it as springs_NAME.toml, and says whether the scene's
        /// springs match it. With --scene, --grid-sizes is only fitted when given.
        #[arg(long)]
        scene: Vec<PathBuf>,
        /// Grid whose fitted limb is written as XML (fitted too if not listed).
        #[arg(long, default_value = "39x10")]
        model_grid: String,
        /// Seed of the annealing's random stream.
        #[arg(long, default_value_t = 2008)]
        seed: u64,
        /// Most objective evaluations per annealing run (each one a virtual tensile test); a
        /// layer takes up to four runs per objective, fewer once a run gains under 1 %.
        #[arg(long, default_value_t = 1500, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
        max_evaluations: u32,
        /// Evaluations of each scene's indentation fit (each one a virtual indentation of the
        /// scene's limb, about 1-3 s): fat's and muscle's compression fitted to the in-vivo
        /// band of config/materials/indentation.toml. 0 skips it.
        #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u32).range(0..=100_000))]
        indentation_evaluations: u32,
        /// Output folder.
        #[arg(long, default_value = "out/fit")]
        out: PathBuf,
    },
    /// Accuracy-versus-time and hard-case stability studies.
    Study {
        #[command(subcommand)]
        what: StudyCommand,
    },
    /// Step the yardstick scene and write final positions as CSV.
    Yardstick {
        /// small, medium, large, or NXxNYxNZ.
        #[arg(long, default_value = "small")]
        size: String,
        /// Steps of 1e-4 s.
        #[arg(long, default_value_t = 1000)]
        steps: usize,
        /// Output CSV (header x_m,y_m,z_m).
        #[arg(long)]
        out: PathBuf,
        /// f64 or f32.
        #[arg(long, default_value = "f64")]
        precision: String,
        /// Use the specification's scalar loop instead of Lamina's solver.
        #[arg(long)]
        reference: bool,
        /// Worker threads.
        #[arg(long, default_value_t = 1)]
        threads: usize,
    },
}

#[derive(Subcommand)]
enum StudyCommand {
    /// Error against cost per simulated second for every integrator over a range of steps.
    Accuracy {
        /// Scene whose model is pressed and released in the third case; the built-in default
        /// when omitted.
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Output folder for the CSV and PNG plots.
        #[arg(long, default_value = "out/study")]
        out: PathBuf,
        /// Fewer steps per integrator.
        #[arg(long)]
        quick: bool,
        /// Simulated time of the model case (press over the first half, release over the
        /// second), s; rounded to whole 2 ms, 0.002 to 10.
        #[arg(long, default_value_t = 0.1)]
        seconds: f64,
    },
    /// The hard cases with every integrator and multirate stepping: finite, bounded, no
    /// energy gain, guard activity.
    Stability {
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// The limb pressed 1-10 mm by the scene's sphere at a few sites, force against depth,
    /// beside published in-vivo indentation of limb soft tissue (Hertz contact).
    Indentation {
        /// Scene files (repeatable); default: the built-in default scene and
        /// config/scenes/thigh.toml when it exists.
        #[arg(long)]
        scene: Vec<PathBuf>,
        /// Sites per scene, spread around the limb at mid-length.
        #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=64))]
        sites: u32,
        /// Deepest press, mm (1 mm steps).
        #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u32).range(1..=30))]
        depth_mm: u32,
        /// Output folder for the CSV and PNG.
        #[arg(long, default_value = "out/study")]
        out: PathBuf,
    },
    /// A cut through skin and fat along the top of a living limb, drawn by the scalpel at the
    /// scene's tick: springs cut per layer, forces, and how far the wound gapes against a
    /// pre-strained sheet's closed form.
    Incision {
        /// Scene with a tool and a `[scalpel]` table.
        #[arg(long, default_value = "config/scenes/incision.toml")]
        scene: PathBuf,
        /// Length of the cut along the limb, mm.
        #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u32).range(5..=150))]
        length_mm: u32,
        /// Depth of the blade's tip below the skin, mm.
        #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=30))]
        depth_mm: u32,
        /// Speed of the blade, mm/s.
        #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..=200))]
        speed_mm_s: u32,
        /// Output folder for the CSV.
        #[arg(long, default_value = "out/study")]
        out: PathBuf,
    },
}

#[derive(Subcommand)]
enum BenchCommand {
    /// Time per step with springs only, each effect alone, and every effect on.
    Effects {
        /// Scene file whose model is used; the built-in default when omitted.
        #[arg(long)]
        scene: Option<PathBuf>,
        /// Seconds per timed batch (9 interleaved batches per configuration, the fastest
        /// reported), 0.001 to 600.
        #[arg(long, default_value_t = 0.2)]
        batch_seconds: f64,
    },
    /// Compute per 1 kHz tick against model size: the default limb at several grids and
    /// other scenes, every solver on 1 and 2 threads side by side (and multirate stepping about
    /// the tool on 2, its ticks paced at 1 kHz); a table, CSV and log-log PNG.
    Capacity {
        /// Comma-separated cylinder limb grids, columns x rows (same limb, finer cells; columns
        /// 3 to 4096, rows 1 to 4096); "" for scenes alone. A grid or scene that cannot be
        /// built refuses the run before anything is timed.
        #[arg(long, default_value = "24x6,39x10,48x12,96x24,160x40")]
        grids: String,
        /// Comma-separated scene files measured as well (their own model and effects).
        #[arg(long, default_value = "config/scenes/thigh.toml")]
        scenes: String,
        /// Comma-separated solvers.
        #[arg(long, default_value = "symplectic_euler,velocity_verlet,rk4,implicit_euler,implicit_factored")]
        solvers: String,
        /// Comma-separated thread counts.
        #[arg(long, default_value = "1,2")]
        threads: String,
        /// Timed ticks per configuration (fewer when --max-seconds runs out first).
        #[arg(long, default_value_t = 2000)]
        ticks: usize,
        /// Wall time allowed per configuration, s.
        #[arg(long, default_value_t = 3.0)]
        max_seconds: f64,
        /// SCHED_FIFO priority of the measuring thread and its workers (0 leaves it).
        #[arg(long, default_value_t = 50)]
        fifo_priority: i32,
        /// Radius of the multirate configuration's region about the tool, m (its tick costs
        /// about what the region's nodes do).
        #[arg(long, default_value_t = 0.03)]
        region_radius: f64,
        /// Ticks per bulk step of the multirate configuration, 2 to 1,000.
        #[arg(long, default_value_t = 20)]
        ratio: u32,
        /// Directory for capacity.csv and capacity.png.
        #[arg(long, default_value = "capacity")]
        out: PathBuf,
    },
    /// The machine's own deadline misses: the loop of `lamina run` (pinned, SCHED_FIFO, locked
    /// memory, absolute deadlines) with fixed synthetic work in place of the physics, once per
    /// sleep slice. Set a run's misses against these at the same compute per tick.
    Noise {
        /// Seconds per sleep slice.
        #[arg(long, default_value_t = 20.0)]
        seconds: f64,
        /// Loop rate, Hz.
        #[arg(long, default_value_t = 1000)]
        rate_hz: u32,
        /// Synthetic work per tick, µs (calibrated on the pinned CPU before the loop); less
        /// than the period.
        #[arg(long, default_value_t = 200.0)]
        work_us: f64,
        /// Buffer the work walks, KiB (1024: about one core's L2 cache).
        #[arg(long, default_value_t = 1024)]
        working_set_kib: usize,
        /// Sleep slices compared, µs, comma-separated: 0 sleeps once per tick, N sleeps at
        /// most N µs at a time (the scene's `[realtime] sleep_slice_us`, default 100).
        #[arg(long, default_value = "0,100")]
        sleep_slices_us: String,
        /// CPU the loop is pinned to. Default: the last one available (as `lamina run`).
        #[arg(long)]
        cpu: Option<usize>,
        /// SCHED_FIFO priority (0 leaves it); `lamina run`'s default is 80.
        #[arg(long, default_value_t = 80)]
        fifo_priority: i32,
        /// Also run each sleep slice with a standby thread pinned to this CPU (SCHED_FIFO one
        /// below the loop): it runs a tick whose loop thread has not started it
        /// --standby-delay-us after its deadline, as when the host has stopped the loop's
        /// virtual CPU. Each slice is then measured alone, then with the standby.
        #[arg(long)]
        standby_cpu: Option<usize>,
        /// How long after a tick's deadline the standby takes a tick still not started, µs,
        /// 10 to less than the period.
        #[arg(long, default_value_t = 250)]
        standby_delay_us: u32,
    },
    /// The machine's stops: one thread per CPU, pinned and at SCHED_FIFO, reads the clock for
    /// 9 ms of every 10 ms; readings further apart than --gap-us are a stop (the host taking
    /// the virtual CPU, an interrupt, the kernel's work). Prints each CPU's stops, the stops
    /// of every CPU at once (which no standby thread can cover), and the deadlines a loop of
    /// --rate-hz computing --work-us per tick misses through them. The watchers take nearly
    /// every CPU for --seconds: run it on a machine doing nothing else.
    Stalls {
        /// Seconds watched.
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        /// Shortest stop counted, µs, 5 to 100,000.
        #[arg(long, default_value_t = 100)]
        gap_us: u64,
        /// SCHED_FIFO priority of the watching threads (0 leaves them at the normal policy,
        /// where the kernel's other threads add stops of their own).
        #[arg(long, default_value_t = 80)]
        fifo_priority: i32,
        /// Rate of the loop whose misses are reckoned, Hz.
        #[arg(long, default_value_t = 1000)]
        rate_hz: u32,
        /// Compute per tick of that loop, µs (`lamina run` prints its p50).
        #[arg(long, default_value_t = 50.0)]
        work_us: f64,
    },
    /// The yardstick scene: ms per step and ns per spring-step, Lamina beside the scalar loop.
    Yardstick {
        /// Comma-separated: small, medium, large, or NXxNYxNZ.
        #[arg(long, default_value = "small,medium,large")]
        sizes: String,
        /// Comma-separated thread counts; default 1 and all CPUs.
        #[arg(long)]
        threads: Option<String>,
        /// Comma-separated: f32, f64.
        #[arg(long, default_value = "f32,f64")]
        precision: String,
        /// Kernel levels: best, all, or a comma-separated list of baseline, avx2, avx512.
        #[arg(long, default_value = "best")]
        simd: String,
        /// Leave out the scalar reference loop.
        #[arg(long)]
        no_reference: bool,
        /// Leave out the plain-C baseline (f32; `-O3 -march=native`, one thread and OpenMP).
        #[arg(long)]
        no_c: bool,
        /// Also time every level with each spring's parameters streamed from memory (runs of
        /// identical springs not sharing one entry): the layout without parameter sharing.
        #[arg(long)]
        streamed_params: bool,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Seconds per timed batch (5 batches, median reported), 0.001 to 600.
        #[arg(long, default_value_t = 0.4)]
        batch_seconds: f64,
    },
}

/// Shortest timed batch `--batch-seconds` accepts, s.
const MIN_BATCH_S: f64 = 0.001;
/// Longest timed batch `--batch-seconds` accepts, s (ten minutes).
const MAX_BATCH_S: f64 = 600.0;

/// `--batch-seconds` as a duration, or a usage error naming the option, the value and the
/// range (0.001 to 600 s); NaN, infinities and values outside are refused, never clamped.
fn batch_seconds_option(seconds: f64) -> Result<Duration, String> {
    if (MIN_BATCH_S..=MAX_BATCH_S).contains(&seconds) {
        Ok(Duration::from_secs_f64(seconds))
    } else {
        Err(format!(
            "--batch-seconds {}: must be from {MIN_BATCH_S} to {MAX_BATCH_S} s",
            lamina_rt::format_value(seconds)
        ))
    }
}

fn parse_list<T>(s: &str, what: &str, f: impl Fn(&str) -> Option<T>) -> Result<Vec<T>, String> {
    s.split(',').map(|p| f(p.trim()).ok_or_else(|| format!("unknown {what} '{p}'"))).collect()
}

fn run(command: Command) -> Result<(), String> {
    match command {
        Command::Inspect { file } => {
            let report = lamina_mesh::inspect(&file).map_err(|e| e.to_string())?;
            println!("{report}");
            Ok(())
        }
        Command::Fit {
            materials,
            grid_sizes,
            scene,
            model_grid,
            seed,
            max_evaluations,
            indentation_evaluations,
            out,
        } => {
            let grids_given = std::env::args().any(|a| a.starts_with("--grid-sizes") || a.starts_with("--model-grid"));
            let (grids, model_grid) = if scene.is_empty() || grids_given {
                let grids = generate::parse_grids("--grid-sizes", &grid_sizes)?;
                (grids, Some(generate::parse_grid("--model-grid", &model_grid)?))
            } else {
                (Vec::new(), None)
            };
            fit::fit(&fit::FitOptions {
                materials,
                grids,
                scenes: scene,
                model_grid,
                seed,
                max_evaluations,
                indentation_evaluations,
                out,
            })
        }
        Command::Demo { scene, seconds, out, record } => demo::demo(scene.as_deref(), seconds, &out, record.as_deref()),
        Command::Profile { scene, seconds, nodes, out } => {
            let sizes = parse_list(&nodes, "node count", |p| p.parse().ok().filter(|&n: &u64| n >= 1))?;
            profile::profile(scene.as_deref(), seconds, &sizes, &out)
        }
        Command::Generate { table3, cylinder, length, out, vtu, scene } => {
            if table3 {
                generate::table3()
            } else if let Some(scene) = scene {
                generate::anatomy(&scene, &out, vtu.as_deref())
            } else {
                generate::cylinder(generate::parse_grid("--cylinder", &cylinder)?, length, &out, vtu.as_deref())
            }
        }
        Command::Study { what: StudyCommand::Accuracy { scene, out, quick, seconds } } => {
            let scene = run::load_scene(&scene)?;
            study::accuracy(&scene, &out, quick, seconds)
        }
        Command::Study { what: StudyCommand::Stability { json } } => study::stability(json),
        Command::Study { what: StudyCommand::Indentation { scene, sites, depth_mm, out } } => {
            study::indentation(&scene, sites as usize, depth_mm, &out)
        }
        Command::Study { what: StudyCommand::Incision { scene, length_mm, depth_mm, speed_mm_s, out } } => {
            study::incision(&scene, length_mm, depth_mm, speed_mm_s, &out)
        }
        Command::Bench { what: BenchCommand::Effects { scene, batch_seconds } } => {
            let scene = run::load_scene(&scene)?;
            bench_effects::bench(&scene, batch_seconds_option(batch_seconds)?)
        }
        Command::Bench {
            what:
                BenchCommand::Capacity {
                    grids,
                    scenes,
                    solvers,
                    threads,
                    ticks,
                    max_seconds,
                    fifo_priority,
                    region_radius,
                    ratio,
                    out,
                },
        } => {
            let opts = bench_capacity::CapacityOptions {
                grids: if grids.trim().is_empty() {
                    Vec::new()
                } else {
                    generate::parse_grids("--grids", &grids)?.into_iter().map(|g| (g.columns, g.rows)).collect()
                },
                scenes: scenes.split(',').filter(|p| !p.trim().is_empty()).map(|p| PathBuf::from(p.trim())).collect(),
                integrators: parse_list(&solvers, "solver", IntegratorKind::parse)?,
                threads: parse_list(&threads, "thread count", |p| {
                    p.parse().ok().filter(|n: &usize| (1..=256).contains(n))
                })?,
                ticks: if ticks >= 5 { ticks } else { return Err(format!("--ticks {ticks}: at least 5")) },
                max_seconds: if max_seconds.is_finite() && (0.1..=3600.0).contains(&max_seconds) {
                    max_seconds
                } else {
                    return Err(format!(
                        "--max-seconds {}: between 0.1 and 3600",
                        lamina_rt::format_value(max_seconds)
                    ));
                },
                region_radius_m: if region_radius.is_finite() && region_radius > 0.0 {
                    region_radius
                } else {
                    return Err(format!(
                        "--region-radius {}: a length in m greater than 0",
                        lamina_rt::format_value(region_radius)
                    ));
                },
                ratio: if (2..=MAX_MULTIRATE_RATIO).contains(&ratio) {
                    ratio
                } else {
                    return Err(format!("--ratio {ratio}: from 2 to {MAX_MULTIRATE_RATIO}"));
                },
                out,
                fifo_priority,
            };
            if opts.grids.is_empty() && opts.scenes.is_empty() {
                return Err("--grids and --scenes are both empty: nothing to measure".into());
            }
            bench_capacity::bench(&opts)
        }
        Command::Bench {
            what:
                BenchCommand::Noise {
                    seconds,
                    rate_hz,
                    work_us,
                    working_set_kib,
                    sleep_slices_us,
                    cpu,
                    fifo_priority,
                    standby_cpu,
                    standby_delay_us,
                },
        } => bench_noise::bench(&bench_noise::NoiseOptions {
            seconds,
            rate_hz,
            work_us,
            working_set_kib,
            sleep_slices_us: parse_list(&sleep_slices_us, "sleep slice", |p| p.parse().ok())?,
            cpu,
            fifo_priority,
            standby: standby_cpu.map(|cpu| bench_noise::Standby { cpu, delay_us: standby_delay_us }),
        }),
        Command::Bench { what: BenchCommand::Stalls { seconds, gap_us, fifo_priority, rate_hz, work_us } } => {
            bench_stalls::bench(&bench_stalls::StallOptions { seconds, gap_us, fifo_priority, rate_hz, work_us })
        }
        Command::Run {
            scene,
            seconds,
            report,
            quiet,
            prefix,
            no_publish,
            ticks_csv,
            ticks_csv_last,
            record,
            record_every,
            record_max_frames,
        } => {
            let prefix = (!no_publish).then_some(prefix);
            let record =
                record.map(|dir| record::RecordOptions { dir, every: record_every, max_frames: record_max_frames });
            run::run(&run::RunOptions { scene, seconds, report, quiet, prefix, ticks_csv, ticks_csv_last, record })
        }
        Command::Bench {
            what:
                BenchCommand::Yardstick {
                    sizes,
                    threads,
                    precision,
                    simd,
                    no_reference,
                    no_c,
                    streamed_params,
                    json,
                    batch_seconds,
                },
        } => {
            let all = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
            let threads = match threads {
                Some(t) => parse_list(&t, "thread count", |p| p.parse().ok().filter(|&n: &usize| n >= 1))?,
                None if all > 1 => vec![1, all],
                None => vec![1],
            };
            let levels = match simd.as_str() {
                "best" => vec![SimdLevel::detect()],
                "all" => SimdLevel::available(),
                list => parse_list(list, "SIMD level", SimdLevel::parse)?,
            };
            let opts = yardstick_cmd::BenchOptions {
                sizes: parse_list(&sizes, "size", LatticeSize::parse)?,
                threads,
                precisions: parse_list(&precision, "precision", |p| match p {
                    "f32" => Some("f32"),
                    "f64" => Some("f64"),
                    _ => None,
                })?,
                levels,
                reference: !no_reference,
                c: !no_c,
                streamed: streamed_params,
                json,
                batch: batch_seconds_option(batch_seconds)?,
            };
            yardstick_cmd::bench(&opts)
        }
        Command::Yardstick { size, steps, out, precision, reference, threads } => {
            let size = LatticeSize::parse(&size).ok_or_else(|| format!("unknown size '{size}'"))?;
            yardstick_cmd::write_csv(size, steps, &precision, reference, threads, &out)
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    lamina_rt::init_logging(cli.log_level);
    match run(cli.command).map_err(anyhow::Error::msg) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lamina: {e:#}");
            ExitCode::FAILURE
        }
    }
}
