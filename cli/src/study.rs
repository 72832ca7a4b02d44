//! `lamina study accuracy` and `lamina study stability`.

use super::machine;
use super::plot::{Series, log_log_lines};
use lamina_core::scene::Scene;
use lamina_core::solver::IntegratorKind;
use lamina_core::study::{AccuracyCase, AccuracyRow, accuracy_study, run_case, stability_cases};
use std::path::Path;

/// Wall time per simulated second that a 1 kHz core may spend on physics: half of real
/// time, leaving the rest of each 1 ms frame for publishing and jitter.
pub const REALTIME_BUDGET_S_PER_S: f64 = 0.5;

fn print_rows(title: &str, rows: &[AccuracyRow]) {
    println!("\n{title}");
    println!(
        "{:<17} {:>11} {:>9} {:>12} {:>13} {:>9} {:>7}",
        "integrator", "step s", "step/crit", "error m", "cost s/s", "order", "theory"
    );
    for r in rows {
        println!(
            "{:<17} {:>11.3e} {:>9.3} {:>12.3e} {:>13.3e} {:>9} {:>7}",
            r.integrator,
            r.step_s,
            r.step_over_critical,
            r.error_m,
            r.cost_s_per_s,
            r.observed_order.map_or("-".into(), |o| format!("{o:.2}")),
            r.theoretical_order
        );
    }
}

fn write_csv(path: &Path, rows: &[AccuracyRow]) -> Result<(), String> {
    let mut text = String::from(
        "case,integrator,step_s,step_over_critical,error_m,cost_s_per_s,observed_order,theoretical_order\n",
    );
    for r in rows {
        text.push_str(&format!(
            "{:?},{},{},{},{},{},{},{}\n",
            r.case,
            r.integrator,
            r.step_s,
            r.step_over_critical,
            r.error_m,
            r.cost_s_per_s,
            r.observed_order.map_or(String::new(), |o| o.to_string()),
            r.theoretical_order
        ));
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

fn plot(path: &Path, title: &str, rows: &[AccuracyRow]) -> Result<(), String> {
    let series: Vec<Series> = IntegratorKind::ALL
        .iter()
        .map(|k| Series {
            name: k.name().to_string(),
            points: rows
                .iter()
                .filter(|r| r.integrator == k.name() && r.error_m.is_finite())
                .map(|r| (r.cost_s_per_s, r.error_m))
                .collect(),
        })
        .collect();
    log_log_lines(path, title, "wall time per simulated second (s/s)", "max position error (m)", &series, true)
}

/// `lamina study accuracy`.
pub fn accuracy(scene: &Scene, out: &Path, quick: bool, t_end: f64) -> Result<(), String> {
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let model = scene.build_model().map_err(|e| e.to_string())?;
    let mut effects = scene.effects.clone();
    effects.guard = None;
    println!("accuracy versus cost; machine: {}", machine::describe());
    let mut all = Vec::new();
    for (case, title, file) in [
        (AccuracyCase::SingleSpring, "damped spring, x(0.5 s) against the closed form", "single_spring"),
        (
            AccuracyCase::HangingChain,
            "hanging chain after 2 s settling, against the analytic static sag",
            "hanging_chain",
        ),
        (
            AccuracyCase::Model,
            "default scene model, x(T) against f64 RK4 at 1/20 of the critical step",
            "default_model",
        ),
    ] {
        let rows = accuracy_study(case, &model, &effects, t_end, quick);
        print_rows(title, &rows);
        plot(&out.join(format!("accuracy_{file}.png")), title, &rows)?;
        all.extend(rows);
    }
    write_csv(&out.join("accuracy.csv"), &all)?;
    let within: Vec<&AccuracyRow> = all
        .iter()
        .filter(|r| r.case == AccuracyCase::Model && r.error_m.is_finite() && r.cost_s_per_s <= REALTIME_BUDGET_S_PER_S)
        .collect();
    if let Some(best) = within.iter().min_by(|a, b| a.error_m.total_cmp(&b.error_m)) {
        println!(
            "\nwithin the 1 kHz budget ({REALTIME_BUDGET_S_PER_S} s of wall time per simulated second, f32): most accurate is {} at step {:.3e} s (error {:.3e} m, cost {:.3e} s/s)",
            best.integrator, best.step_s, best.error_m, best.cost_s_per_s
        );
    }
    println!("wrote {}/accuracy.csv and accuracy_*.png", out.display());
    Ok(())
}

/// `lamina study stability`.
pub fn stability(json: bool) -> Result<(), String> {
    let mut rows = Vec::new();
    if !json {
        println!("hard cases, f32, every integrator; machine: {}", machine::describe());
        println!(
            "{:<33} {:<17} {:>5} {:>7} {:>6} {:>9} {:>8} {:>9} {:>5} {:>5} {:>5} {:>6}",
            "case",
            "integrator",
            "sub",
            "h/crit",
            "finite",
            "max|u| m",
            "stretch",
            "E excess",
            "rollb",
            "impl",
            "froz",
            "wall s"
        );
    }
    for case in stability_cases() {
        for k in IntegratorKind::ALL {
            let r = run_case(&case, k);
            if !json {
                println!(
                    "{:<33} {:<17} {:>5} {:>7.3} {:>6} {:>9.4} {:>8.2} {:>9.2e} {:>5} {:>5} {:>5} {:>6.2}",
                    r.case,
                    r.integrator,
                    r.substeps,
                    r.substep_over_critical,
                    r.finite,
                    r.max_displacement_m,
                    r.max_stretch_ratio,
                    r.energy_excess,
                    r.rollbacks,
                    r.by_implicit,
                    r.frozen,
                    r.wall_s
                );
            }
            rows.push(r);
        }
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&rows).map_err(|e| e.to_string())?);
    } else {
        println!(
            "\nE excess: largest (E(t) - W_loads(t) - E(0)) / energy scale; 0 means energy never exceeded the work put in."
        );
        for case in stability_cases() {
            println!("  {:<33} {}", case.name, case.description);
        }
    }
    Ok(())
}
