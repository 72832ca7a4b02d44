//! `lamina bench yardstick` tables and `lamina yardstick` (final positions as CSV).

use super::bench_yardstick::{
    ChecksumRow, YardstickRow, c_checksum_row, c_name, checksum_row, implementations, time_c, time_config,
};
use super::machine;
use lamina_core::model::Model;
use lamina_core::real::Real;
use lamina_core::solver::{SimdLevel, Simulation};
use lamina_core::yardstick::{self, LatticeSize, ReferenceStepper};
use std::io::Write;
use std::time::Duration;

/// Options of `lamina bench yardstick`.
pub struct BenchOptions {
    pub sizes: Vec<LatticeSize>,
    pub threads: Vec<usize>,
    pub precisions: Vec<&'static str>,
    pub levels: Vec<SimdLevel>,
    pub reference: bool,
    /// Time the plain-C baseline (f32: one thread, and OpenMP on each thread count above 1).
    pub c: bool,
    /// Also time every level with per-spring parameter streams (no shared run entries).
    pub streamed: bool,
    pub json: bool,
    pub batch: Duration,
}

/// Runs the yardstick benchmark and prints a table (or JSON).
pub fn bench(opts: &BenchOptions) -> Result<(), String> {
    // Every size is estimated before any is built or timed.
    for size in &opts.sizes {
        size.check().map_err(|e| format!("--sizes {}: {e}", size.name()))?;
    }
    let mut rows: Vec<YardstickRow> = Vec::new();
    let machine = machine::describe();
    if !opts.json {
        println!("yardstick scene (docs/yardstick-scene.md), symplectic Euler dt = 1e-4 s");
        println!("machine: {machine}");
        println!(
            "{:<7} {:>9} {:>10} {:<5} {:<27} {:>3} {:>10} {:>9} {:>10}",
            "size", "nodes", "springs", "prec", "implementation", "thr", "ms/step", "ns/spr-st", "Mspring/s"
        );
    }
    // Silent with --json (the table prints as it goes otherwise): a bar counts the
    // configurations, moving between them, never while one is timed.
    let bar = if opts.json {
        let mut imps = implementations(&opts.levels, opts.streamed);
        if !opts.reference {
            imps.remove(0);
        }
        let per_precision: usize = imps
            .iter()
            .map(|&imp| if imp == yardstick::YardstickImpl::Reference { 1 } else { opts.threads.len() })
            .sum();
        super::progress::steps((opts.sizes.len() * opts.precisions.len() * per_precision) as u64, "bench yardstick")
    } else {
        indicatif::ProgressBar::hidden()
    };
    for &size in &opts.sizes {
        for &precision in &opts.precisions {
            let mut imps = implementations(&opts.levels, opts.streamed);
            if !opts.reference {
                imps.remove(0);
            }
            if opts.c && precision == "f32" {
                for &threads in &opts.threads {
                    match time_c(size, threads, opts.batch) {
                        Ok(row) => {
                            if !opts.json {
                                print_row(&row);
                            }
                            rows.push(row);
                        }
                        Err(why) if !opts.json => {
                            println!("{:<7} {} on {threads} thread(s) skipped: {why}", size.name(), c_name(threads))
                        }
                        Err(why) => {
                            eprintln!("{} {} on {threads} thread(s) skipped: {why}", size.name(), c_name(threads))
                        }
                    }
                }
            }
            for imp in imps {
                let thread_list: Vec<usize> =
                    if imp == yardstick::YardstickImpl::Reference { vec![1] } else { opts.threads.clone() };
                for threads in thread_list {
                    let row = time_config(size, precision, imp, threads, opts.batch);
                    bar.inc(1);
                    if !opts.json {
                        print_row(&row);
                    }
                    rows.push(row);
                }
            }
        }
    }
    bar.finish_and_clear();
    let mut checks: Vec<ChecksumRow> = Vec::new();
    for &precision in &opts.precisions {
        if opts.reference {
            checks.push(checksum_row(precision, yardstick::YardstickImpl::Reference, 1));
        }
        if opts.c && precision == "f32" {
            // Rows for what is built; the timing section already said what is skipped.
            checks.extend(opts.threads.iter().filter_map(|&t| c_checksum_row(t).ok()));
        }
        let best = *opts.levels.last().unwrap_or(&SimdLevel::detect());
        for &threads in &opts.threads {
            checks.push(checksum_row(precision, yardstick::YardstickImpl::Lamina(best), threads));
        }
    }
    if opts.json {
        let doc = serde_json::json!({ "machine": machine, "timings": rows, "checksum_small_1000_steps": checks });
        println!("{}", serde_json::to_string_pretty(&doc).map_err(|e| e.to_string())?);
    } else {
        println!("\nchecksum, small size after 1000 steps (u = x - x0, metres)");
        println!(
            "{:<5} {:<18} {:>3} {:>14} {:>12} {:>12} {:>12} {:>12}",
            "prec", "implementation", "thr", "sum_u.y", "max|u|", "rms|u|", "sum_u.x", "sum_u.z"
        );
        for c in &checks {
            println!(
                "{:<5} {:<18} {:>3} {:>14.9e} {:>12.6e} {:>12.6e} {:>12.3e} {:>12.3e}",
                c.precision, c.implementation, c.threads, c.sum_uy, c.max_u, c.rms_u, c.sum_ux, c.sum_uz
            );
        }
    }
    Ok(())
}

fn print_row(row: &YardstickRow) {
    println!(
        "{:<7} {:>9} {:>10} {:<5} {:<27} {:>3} {:>10.3} {:>9.3} {:>10.1}",
        row.size,
        row.nodes,
        row.springs,
        row.precision,
        row.implementation,
        row.threads,
        row.ms_per_step,
        row.ns_per_spring_step,
        row.mspring_per_s
    );
    let _ = std::io::stdout().flush();
}

fn positions<T: Real>(model: &Model, steps: usize, reference: bool, threads: usize) -> Vec<[f64; 3]> {
    if reference {
        let mut r = ReferenceStepper::<T>::new(model, yardstick::GRAVITY, yardstick::DT).expect("linear springs");
        for _ in 0..steps {
            r.step();
        }
        r.x.iter().map(|p| p.map(|c| c.to_f64())).collect()
    } else {
        let mut s = Simulation::<T>::new(
            model,
            yardstick::lattice_params(threads, SimdLevel::detect()),
            yardstick::lattice_effects(),
        )
        .expect("valid");
        for _ in 0..steps {
            s.step();
        }
        (0..model.nodes.len()).map(|i| s.state().x.get_f64(i)).collect()
    }
}

/// `lamina yardstick`: steps the scene and writes final positions as CSV (`x_m,y_m,z_m`).
pub fn write_csv(
    size: LatticeSize,
    steps: usize,
    precision: &str,
    reference: bool,
    threads: usize,
    out: &std::path::Path,
) -> Result<(), String> {
    if !matches!(precision, "f32" | "f64") {
        return Err(format!("unknown precision '{precision}' (f32 or f64)"));
    }
    // Estimated against the memory available before any of it is allocated.
    let model = size.checked_model().map_err(|e| format!("--size {}: {e}", size.name()))?;
    let pos = match precision {
        "f64" => positions::<f64>(&model, steps, reference, threads),
        _ => positions::<f32>(&model, steps, reference, threads),
    };
    let mut text = String::with_capacity(pos.len() * 64);
    text.push_str("x_m,y_m,z_m\n");
    for p in &pos {
        // Display of f64 prints the shortest string that reads back to the same value.
        text.push_str(&format!("{},{},{}\n", p[0], p[1], p[2]));
    }
    std::fs::write(out, text).map_err(|e| format!("{}: {e}", out.display()))?;
    let c = yardstick::checksum(&model, |i| pos[i]);
    tracing::info!(
        "wrote {} rows to {}; sum_u.y = {:.9e} m, max|u| = {:.6e} m, rms|u| = {:.6e} m",
        pos.len(),
        out.display(),
        c.sum_uy,
        c.max_u,
        c.rms_u
    );
    Ok(())
}
