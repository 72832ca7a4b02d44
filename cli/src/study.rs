//! `lamina study accuracy`, `lamina study stability` and `lamina study indentation`.

use super::machine;
use super::plot::{Series, log_log_lines};
use lamina_core::fit::IndentationTargets;
use lamina_core::scene::Scene;
use lamina_core::solver::IntegratorKind;
use lamina_core::study::{
    AccuracyCase, AccuracyRow, AccuracyStudy, CouplingRow, MULTIRATE_ROW, PRESS_DEPTH_M, REFERENCE_TOLERANCE,
    accuracy_study, coupling_sweep, run_case, run_case_multirate, stability_cases,
};
use lamina_core::study::{
    PUBLISHED_MODULI, TISSUE_POISSON, effective_modulus, hertz_force, indentation as indent_scene,
};
use std::path::Path;

/// Wall time per simulated second that a 1 kHz core may spend on physics: half of real
/// time, leaving the rest of each 1 ms frame for publishing and jitter.
pub const REALTIME_BUDGET_S_PER_S: f64 = 0.5;

fn order_text(r: &AccuracyRow) -> String {
    if r.at_floor { "floor".into() } else { r.observed_order.map_or("-".into(), |o| format!("{o:.2}")) }
}

fn print_rows(title: &str, study: &AccuracyStudy) {
    let r = &study.reference;
    println!("\n{title}");
    if r.steps > 0 {
        println!(
            "reference: {}, {} steps, tolerance {:.0e}; its error estimate {:.2e} m (against a run at 100x the tolerance); errors below {:.2e} m are at the floor",
            r.method, r.steps, REFERENCE_TOLERANCE, r.error_estimate_m, r.floor_m
        );
    } else {
        println!(
            "reference: {}; errors below {:.2e} m (1,000 ulps of the positions) are at the floor",
            r.method, r.floor_m
        );
    }
    println!(
        "{:<17} {:>11} {:>9} {:>12} {:>13} {:>9} {:>7}",
        "integrator", "step s", "step/crit", "error m", "cost s/s", "order", "theory"
    );
    for r in study.rows.iter().filter(|r| r.realtime_substeps.is_none()) {
        println!(
            "{:<17} {:>11.3e} {:>9.3} {:>12.3e} {:>13.3e} {:>9} {:>7}",
            r.integrator,
            r.step_s,
            r.step_over_critical,
            r.error_m,
            r.cost_s_per_s,
            order_text(r),
            r.theoretical_order
        );
    }
    let realtime: Vec<&AccuracyRow> = study.rows.iter().filter(|r| r.realtime_substeps.is_some()).collect();
    if !realtime.is_empty() {
        println!("as the 1 kHz loop runs them (1 ms frames, automatic sub-steps):");
        println!("{:<25} {:>10} {:>11} {:>12} {:>13}", "integrator", "sub-steps", "step s", "error m", "cost s/s");
        for r in realtime {
            let name = match r.pcg_iterations {
                Some(k) => format!("{} ({k} PCG)", r.integrator),
                None => r.integrator.to_string(),
            };
            println!(
                "{:<25} {:>10} {:>11.3e} {:>12.3e} {:>13.3e}{}",
                name,
                r.realtime_substeps.unwrap_or(1),
                r.step_s,
                r.error_m,
                r.cost_s_per_s,
                if r.at_floor { " (at the floor)" } else { "" }
            );
        }
    }
}

fn write_csv(path: &Path, rows: &[AccuracyRow]) -> Result<(), String> {
    let mut text = String::from(
        "case,integrator,pcg_iterations,realtime_substeps,step_s,step_over_critical,error_m,cost_s_per_s,observed_order,at_floor,theoretical_order\n",
    );
    for r in rows {
        text.push_str(&format!(
            "{:?},{},{},{},{},{},{},{},{},{},{}\n",
            r.case,
            r.integrator,
            r.pcg_iterations.map_or(String::new(), |n| n.to_string()),
            r.realtime_substeps.map_or(String::new(), |n| n.to_string()),
            r.step_s,
            r.step_over_critical,
            r.error_m,
            r.cost_s_per_s,
            r.observed_order.map_or(String::new(), |o| o.to_string()),
            r.at_floor,
            r.theoretical_order
        ));
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

fn plot(path: &Path, title: &str, rows: &[AccuracyRow]) -> Result<(), String> {
    let point = |r: &AccuracyRow| (r.cost_s_per_s, r.error_m);
    let mut series: Vec<Series> = IntegratorKind::ALL
        .iter()
        .map(|k| Series {
            name: k.name().to_string(),
            points: rows
                .iter()
                .filter(|r| r.integrator == k.name() && r.realtime_substeps.is_none() && r.error_m.is_finite())
                .map(point)
                .collect(),
        })
        .collect();
    series.push(Series {
        name: "1 kHz frames, automatic sub-steps".into(),
        points: rows.iter().filter(|r| r.realtime_substeps.is_some() && r.error_m.is_finite()).map(point).collect(),
    });
    // A line with no finite point (every run blew up) is left out rather than drawn empty.
    series.retain(|s| !s.points.is_empty());
    log_log_lines(path, title, "wall time per simulated second (s/s)", "max position error (m)", &series, true)
}

/// `lamina study accuracy`.
pub fn accuracy(scene: &Scene, out: &Path, quick: bool, t_end: f64) -> Result<(), String> {
    if !(t_end.is_finite() && (0.002..=10.0).contains(&t_end)) {
        return Err(format!("--seconds {}: the model case runs 0.002 to 10 s", lamina_rt::format_value(t_end)));
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let model = scene.build_model().map_err(|e| e.to_string())?;
    let effects = scene.effects.clone();
    println!("accuracy versus cost; machine: {}", machine::describe());
    let mut all = Vec::new();
    let bar = super::progress::steps(3, "study accuracy");
    let press = format!(
        "{} pressed {:.0} mm by the sphere tool and released, x({:.3} s) against an adaptive f64 reference",
        scene.name,
        PRESS_DEPTH_M * 1e3,
        (t_end / 0.002).round().max(1.0) * 0.002
    );
    for (case, title, file) in [
        (AccuracyCase::SingleSpring, "damped spring, x(0.5 s) against the closed form".to_string(), "single_spring"),
        (
            AccuracyCase::HangingChain,
            "hanging chain after 2 s settling, against the analytic static sag".to_string(),
            "hanging_chain",
        ),
        (AccuracyCase::Model, press, "model_press"),
    ] {
        bar.set_message(file);
        let study = accuracy_study(case, &model, &effects, t_end, quick).map_err(|e| format!("{title}: {e}"))?;
        bar.inc(1);
        bar.suspend(|| print_rows(&title, &study));
        plot(&out.join(format!("accuracy_{file}.png")), &title, &study.rows)?;
        all.extend(study.rows);
    }
    bar.finish_and_clear();
    write_csv(&out.join("accuracy.csv"), &all)?;
    let within: Vec<&AccuracyRow> = all
        .iter()
        .filter(|r| {
            r.case == AccuracyCase::Model
                && r.realtime_substeps.is_some()
                && r.error_m.is_finite()
                && r.cost_s_per_s <= REALTIME_BUDGET_S_PER_S
        })
        .collect();
    if let Some(best) = within.iter().min_by(|a, b| a.error_m.total_cmp(&b.error_m)) {
        println!(
            "\nwithin the 1 kHz budget ({REALTIME_BUDGET_S_PER_S} s of wall time per simulated second, f32, 1 ms frames): most accurate is {}{} (error {:.3e} m, cost {:.3e} s/s)",
            best.integrator,
            best.pcg_iterations.map_or(String::new(), |k| format!(" with {k} PCG iterations")),
            best.error_m,
            best.cost_s_per_s
        );
    } else {
        println!(
            "\nno integrator ran the model within the 1 kHz budget ({REALTIME_BUDGET_S_PER_S} s/s) on this machine"
        );
    }
    tracing::info!("wrote {}/accuracy.csv and accuracy_*.png", out.display());
    Ok(())
}

/// `lamina study stability`.
pub fn stability(json: bool) -> Result<(), String> {
    let mut rows = Vec::new();
    if !json {
        println!(
            "hard cases, f32, every integrator and multirate stepping (3 cm region about the top centre, ratio 8); machine: {}",
            machine::describe()
        );
        println!(
            "{:<33} {:<17} {:>5} {:>7} {:>6} {:>9} {:>8} {:>9} {:>6} {:>9} {:>5} {:>5} {:>5} {:>6}",
            "case",
            "integrator",
            "sub",
            "h/crit",
            "finite",
            "max|u| m",
            "stretch",
            "k ratio",
            "stiff",
            "E excess",
            "rollb",
            "impl",
            "froz",
            "wall s"
        );
    }
    // Silent with --json (the table prints as it goes otherwise): a bar shows the cases.
    let bar = if json {
        super::progress::steps((stability_cases().len() * (IntegratorKind::ALL.len() + 1)) as u64, "study stability")
    } else {
        indicatif::ProgressBar::hidden()
    };
    for case in stability_cases() {
        // Every integrator, then multirate stepping (`None`).
        for k in IntegratorKind::ALL.map(Some).into_iter().chain([None]) {
            bar.set_message(format!("{} {}", case.name, k.map_or(MULTIRATE_ROW, IntegratorKind::name)));
            let r = match k {
                Some(k) => run_case(&case, k),
                None => run_case_multirate(&case),
            };
            bar.inc(1);
            if !json {
                println!(
                    "{:<33} {:<17} {:>5} {:>7.3} {:>6} {:>9.4} {:>8.2} {:>9.2e} {:>6} {:>9.2e} {:>5} {:>5} {:>5} {:>6.2}",
                    r.case,
                    r.integrator,
                    r.substeps,
                    r.substep_over_critical,
                    r.finite,
                    r.max_displacement_m,
                    r.max_stretch_ratio,
                    r.loaded_stiffness_ratio,
                    r.stiff_phase_springs,
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
    bar.finish_and_clear();
    if !json {
        println!(
            "\nE excess: largest (E(t) - W_loads(t) - E(0)) / energy scale; 0 means energy never exceeded the work put in.\nk ratio: stiffest over softest spring tangent in the final state; stiff: bilinear springs in their stiff phase then."
        );
        for case in stability_cases() {
            println!("  {:<33} {}", case.name, case.description);
        }
    }
    let coupling = coupling_table(json);
    if json {
        let out = serde_json::json!({ "cases": rows, "multirate_coupling": coupling });
        println!("{}", serde_json::to_string_pretty(&out).map_err(|e| e.to_string())?);
    }
    Ok(())
}

/// Cases of the multirate coupling sweep: the stiff skin, and a sudden load on the default one.
const COUPLING_CASES: [&str; 3] = ["stiffness_ratio_1e4", "stiffness_ratio_1e6", "sudden_large_load"];

/// Runs [`coupling_sweep`] on [`COUPLING_CASES`] and prints it as a table unless `json`.
fn coupling_table(json: bool) -> Vec<CouplingRow> {
    const RADII_M: [f64; 6] = [0.025, 0.03, 0.035, 0.04, 0.045, 0.05];
    const RATIOS: [u32; 3] = [2, 8, 20];
    const SECONDS: f64 = 2.0;
    let cases: Vec<_> = stability_cases().into_iter().filter(|c| COUPLING_CASES.contains(&c.name)).collect();
    let bar = super::progress::steps(cases.len() as u64, "multirate coupling sweep");
    let mut rows = Vec::new();
    for case in &cases {
        bar.set_message(case.name);
        rows.extend(coupling_sweep(case, &RADII_M, &RATIOS, SECONDS));
        bar.inc(1);
    }
    bar.finish_and_clear();
    if !json {
        println!(
            "\nmultirate coupling: region radius and ratio swept, {SECONDS} s each beside single-rate implicit_factored (f32);\nover the second second: the largest node distance from the single-rate run (deviation), the largest coupling gap the run reported, the largest kinetic energy"
        );
        println!(
            "{:<20} {:>9} {:>6} {:>12} {:>12} {:>10} {:>12} {:>15}",
            "case", "radius mm", "ratio", "deviation m", "gap m", "KE J", "single KE J", "single max|u| m"
        );
        for r in &rows {
            println!(
                "{:<20} {:>9.1} {:>6} {:>12.2e} {:>12.2e} {:>10.1e} {:>12.1e} {:>15.2e}",
                r.case,
                r.radius_m * 1e3,
                r.ratio,
                r.late_deviation_m,
                r.late_coupling_gap_m,
                r.late_kinetic_j,
                r.single_late_kinetic_j,
                r.single_max_displacement_m
            );
        }
    }
    rows
}

/// Runs `lamina study indentation`: every scene's sites pressed, printed against the published
/// moduli's Hertz forces, written as CSV and a log-log plot.
pub fn indentation(scenes: &[std::path::PathBuf], sites: usize, depth_mm: u32, out: &Path) -> Result<(), String> {
    let mut loaded = Vec::new();
    if scenes.is_empty() {
        loaded.push(Scene::builtin_default());
        let thigh = Path::new("config/scenes/thigh.toml");
        if thigh.is_file() {
            loaded.push(Scene::load(thigh).map_err(|e| e.to_string())?);
        }
    }
    for p in scenes {
        loaded.push(Scene::load(p).map_err(|e| e.to_string())?);
    }
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let mut csv = String::from("scene,site,depth_m,force_n,effective_modulus_pa\n");
    let mut series = Vec::new();
    let mut radius_m = 0.012;
    let bar = super::progress::steps(loaded.len() as u64, "study indentation");
    bar.enable_steady_tick(std::time::Duration::from_millis(250));
    let targets = IndentationTargets::shipped();
    let band = targets.band.clone();
    let mut checks = Vec::new();
    let mut measured = Vec::new();
    for scene in &loaded {
        bar.set_message(scene.name.clone());
        measured.push(indent_scene(scene, sites, depth_mm).map_err(|e| format!("{}: {e}", scene.name))?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    println!("indentation: a sphere lowered 1 mm at a time (10 mm/s, each depth held 0.2 s), force along the press");
    for (scene, (radius, curves)) in loaded.iter().zip(measured) {
        radius_m = radius;
        println!("\n{} (sphere radius {:.1} mm)", scene.name, radius * 1e3);
        print!("{:<44}", "site \\ depth mm");
        for d in [1, 2, 4, 6, 8, 10].iter().filter(|d| **d <= depth_mm) {
            print!(" {d:>8}");
        }
        println!("   E_eff at deepest");
        for c in &curves {
            print!("{:<44}", c.site);
            for d in [1usize, 2, 4, 6, 8, 10].iter().filter(|d| **d as u32 <= depth_mm) {
                print!(" {:>7.4}N", c.force_n[d - 1]);
            }
            let (d, f) = (c.depth_m[c.depth_m.len() - 1], c.force_n[c.force_n.len() - 1]);
            println!("   {:.2} kPa", effective_modulus(f, radius, d) / 1e3);
            checks.push((scene.name.clone(), c.site.clone(), band.check(&c.depth_m, &c.force_n)));
            for (d, f) in c.depth_m.iter().zip(&c.force_n) {
                csv.push_str(&format!("{},{},{d},{f},{}\n", scene.name, c.site, effective_modulus(*f, radius, *d)));
            }
            series.push(Series {
                name: format!("{}: {}", scene.name, c.site),
                points: c.depth_m.iter().map(|d| d * 1e3).zip(c.force_n.iter().copied()).collect(),
            });
        }
    }
    println!("\nagainst the in-vivo band ({}): {}", targets.band.kind, targets.band.label);
    println!(
        "{:<28} {:<44} {:>10} {:>14} {:>8}",
        "scene",
        "site",
        format!("F {:.0} mm", band.depth_m * 1e3),
        format!("secant {:.0}/{:.0} mm", band.depth_m * 1e3, band.shallow_depth_m * 1e3),
        "verdict"
    );
    let mut passed = 0;
    for (scene, site, check) in &checks {
        match check {
            Some(c) => {
                let verdict = c.verdict();
                passed += usize::from(c.force_in_band && c.stiffens);
                println!("{scene:<28} {site:<44} {:>9.3}N {:>14.2} {verdict:>8}", c.force_n, c.secant_ratio);
            }
            None => println!("{scene:<28} {site:<44} {:>10} {:>14} {:>8}", "-", "-", "not reached"),
        }
    }
    println!(
        "{passed} of {} sites in the band ({:.0}-{:.0} N at {:.0} mm, secant ratio >= {:.1})",
        checks.len(),
        band.force_min_n,
        band.force_max_n,
        band.depth_m * 1e3,
        band.min_secant_ratio
    );
    if depth_mm as f64 * 1e-3 >= band.depth_m {
        // The band's ends drawn as Hertz curves (F ~ d^1.5) through them.
        for (end, force) in [("low", band.force_min_n), ("high", band.force_max_n)] {
            series.push(Series {
                name: format!("band {end}: Hertz through {force:.0} N at {:.0} mm", band.depth_m * 1e3),
                points: (1..=depth_mm).map(|d| (f64::from(d), band.hertz_through(force, f64::from(d)))).collect(),
            });
        }
    }
    println!("\npublished in-vivo moduli as the same sphere's Hertz force (nu = {TISSUE_POISSON})");
    for m in PUBLISHED_MODULI {
        let at = |mm: f64| hertz_force(m.modulus_pa, radius_m, mm * 1e-3);
        println!("{:<58} {:>6.1} kPa: {:.4} N at 1 mm, {:.3} N at 8 mm", m.label, m.modulus_pa / 1e3, at(1.0), at(8.0));
        series.push(Series {
            name: format!("{} ({:.1} kPa)", m.label, m.modulus_pa / 1e3),
            points: (1..=depth_mm).map(|d| (f64::from(d), at(f64::from(d)))).collect(),
        });
    }
    let csv_path = out.join("indentation.csv");
    std::fs::write(&csv_path, csv).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let png = out.join("indentation.png");
    log_log_lines(&png, "indentation: force against depth", "depth (mm)", "force (N)", &series, true)?;
    tracing::info!("written: {} and {}", csv_path.display(), png.display());
    Ok(())
}

/// The `p`-quantile (0 to 1) of `v`, s (0 for none).
fn quantile(v: &[f64], p: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() { 0.0 } else { v[((v.len() - 1) as f64 * p).round() as usize] }
}

/// Runs `lamina study incision`: the cut drawn on `scene`, printed and written as CSV.
pub fn incision(scene: &Path, length_mm: u32, depth_mm: u32, speed_mm_s: u32, out: &Path) -> Result<(), String> {
    use lamina_core::study::{IncisionCase, incision_study};
    let loaded = Scene::load(scene).map_err(|e| e.to_string())?;
    if loaded.scalpel.is_none() {
        return Err(format!("{}: the scene has no [scalpel] table (docs/scene-format.md#scalpel)", scene.display()));
    }
    let case = IncisionCase {
        length_m: f64::from(length_mm) * 1e-3,
        depth_m: f64::from(depth_mm) * 1e-3,
        speed_m_s: f64::from(speed_mm_s) * 1e-3,
        ..IncisionCase::default()
    };
    std::fs::create_dir_all(out).map_err(|e| format!("{}: {e}", out.display()))?;
    let r = incision_study(&loaded, &case).map_err(|e| format!("{}: {e}", scene.display()))?;
    println!(
        "incision: {} - a {length_mm} mm cut, tip {depth_mm} mm under the skin, drawn at {speed_mm_s} mm/s, then {:.1} s to settle",
        loaded.name, case.settle_s
    );
    println!("{:<34} {:>8} {:>8} {:>8}", "", "skin", "fat", "muscle");
    println!("{:<34} {:>8} {:>8} {:>8}", "springs cut", r.springs_cut[0], r.springs_cut[1], r.springs_cut[2]);
    let d = r.deepest;
    println!(
        "{:<34} {:>8.1} {:>8.1} {:>8.1}",
        "deepest edge in the layer, mm",
        d.skin * 1e3,
        d.fat * 1e3,
        d.muscle * 1e3
    );
    println!("press force when the skin gave      {:.2} N ({} puncture)", r.peak_press_force, r.punctures);
    println!(
        "peak cutting force                  {:.2} N ({:.1} mm of tip travel in the tissue)",
        r.peak_cutting_force,
        r.cut_length_m * 1e3
    );
    println!("\nwound gape on the outer skin (cut skin springs, length after less before)");
    println!("{:>10} {:>10}", "z mm", "gap mm");
    let mut csv = String::from("z_m,gap_m\n");
    let mut gaps = r.gaps.clone();
    gaps.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (z, g) in &gaps {
        println!("{:>10.1} {:>10.2}", z * 1e3, g * 1e3);
        csv.push_str(&format!("{z},{g}\n"));
    }
    let (lo, hi) = r.closed_form_gap_m;
    println!(
        "widest {:.2} mm, mean {:.2} mm; a free sheet at the scene's {:.1} % pre-strain opens {:.1}-{:.1} mm mid-cut (2 L eps / (1 - nu), nu 0-1/3)",
        r.max_gap() * 1e3,
        r.mean_gap() * 1e3,
        r.skin_prestrain * 100.0,
        lo * 1e3,
        hi * 1e3
    );
    let (before, old, new) = r.residuals;
    println!(
        "PCG relative residual per tick (mean): {before:.3} before the first cut, {old:.3} after a cut the factor lacks, {new:.3} with the factor of the cut model"
    );
    let f = r.refactor;
    println!(
        "factors of the cut model built off the loop: {} taken, each {} ticks after its ask; last build {:.1} ms, longest {:.1} ms",
        f.taken,
        lamina_core::study::INCISION_FACTOR_TICKS,
        f.last_build_s * 1e3,
        f.longest_build_s * 1e3
    );
    println!("compute per tick on this loop (unpinned):");
    for (what, v) in [
        ("ticks that cut", &r.tick_seconds_cutting),
        ("taking a factor", &r.tick_seconds_taking),
        ("other ticks", &r.tick_seconds_other),
    ] {
        println!(
            "  {what:<16} {:>6} ticks   p50 {:>7.1} us   p99 {:>7.1} us   max {:>7.1} us",
            v.len(),
            quantile(v, 0.5) * 1e6,
            quantile(v, 0.99) * 1e6,
            quantile(v, 1.0) * 1e6
        );
    }
    println!("every state finite: {}", r.finite);
    let path = out.join("incision_gaps.csv");
    std::fs::write(&path, csv).map_err(|e| format!("{}: {e}", path.display()))?;
    tracing::info!("written: {}", path.display());
    if !r.finite {
        return Err("a state was not finite".into());
    }
    Ok(())
}
