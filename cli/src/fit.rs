//! `lamina fit`: fits each layer's springs to its tissue targets (`config/materials/`, or the
//! copy compiled into the binary; see [`load_targets`]), per grid size of the cylindrical limb, prints the targets against what the fitted layers
//! achieve, writes every annealing iteration's curve (CSV) and a plot like the paper's
//! Fig. 10 (PNG), and the fitted 39 × 10 (or chosen) limb as an XML model with provenance.

use super::plot::font_available;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use lamina_core::fit::{FitSettings, LayerFit, LayerGeometry, TissueTargets, fit_layer};
use lamina_core::generator::{CylinderLimb, GridSize, Materials, generate};
use plotters::prelude::*;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `lamina fit`.
pub struct FitOptions {
    /// Folder holding `skin.toml`, `fat.toml`, `muscle.toml`; `None`: the search order of
    /// [`load_targets`].
    pub materials: Option<PathBuf>,
    /// Grid sizes to fit for.
    pub grids: Vec<GridSize>,
    /// Grid whose fitted limb is written as XML.
    pub model_grid: GridSize,
    /// Annealing seed.
    pub seed: u64,
    /// Most objective evaluations per layer's annealing (default 1500).
    pub max_evaluations: u32,
    /// Output folder.
    pub out: PathBuf,
}

/// The shipped tissue targets (`config/materials/`), compiled in.
const BUILTIN_TARGETS: [(&str, &str); 3] = [
    ("skin", include_str!("../../config/materials/skin.toml")),
    ("fat", include_str!("../../config/materials/fat.toml")),
    ("muscle", include_str!("../../config/materials/muscle.toml")),
];

/// The skin, fat and muscle targets, and where they came from. Search order: the folder given
/// (`--materials DIR`), else `config/materials/` under the working directory when it exists,
/// else the shipped targets compiled into the binary (so `lamina fit` works from any
/// directory).
pub fn load_targets(folder: Option<&Path>) -> Result<([TissueTargets; 3], String), String> {
    let local = Path::new("config/materials");
    let folder = folder.or_else(|| local.is_dir().then_some(local));
    let load = |(name, text): (&str, &str)| match folder {
        Some(dir) => TissueTargets::load(&dir.join(format!("{name}.toml"))).map_err(|e| e.to_string()),
        None => TissueTargets::parse(text, Path::new(&format!("<built-in config/materials/{name}.toml>")))
            .map_err(|e| e.to_string()),
    };
    let [skin, fat, muscle] = BUILTIN_TARGETS.map(load);
    let source =
        folder.map_or_else(|| "built in (config/materials/ of this release)".into(), |d| d.display().to_string());
    Ok(([skin?, fat?, muscle?], source))
}

/// The layers' geometry in a cylindrical limb of grid `grid`: spacing = the geometric mean
/// of a cell's sides on the skin (circumference / W by length / H), thickness = the layer's
/// radial extent.
pub fn limb_geometry(grid: GridSize) -> [(usize, LayerGeometry); 3] {
    let limb = CylinderLimb { grid, ..CylinderLimb::default() };
    let around = 2.0 * std::f64::consts::PI * limb.outer_skin_radius / grid.columns as f64;
    let along = limb.length / grid.rows as f64;
    let h = (around * along).sqrt();
    [
        (0, LayerGeometry { spacing_m: h, thickness_m: limb.outer_skin_radius - limb.skin_fat_radius }),
        (1, LayerGeometry { spacing_m: h, thickness_m: limb.skin_fat_radius - limb.fat_muscle_radius }),
        (2, LayerGeometry { spacing_m: h, thickness_m: limb.fat_muscle_radius - limb.bone_radius }),
    ]
}

fn spring_text(fit: &LayerFit) -> String {
    match fit.material {
        lamina_core::generator::SpringMaterial::Linear { stiffness } => format!("k = {stiffness:.4} N/m"),
        lamina_core::generator::SpringMaterial::Bilinear { k1, k2, turn_strain, .. } => {
            format!("k1 = {k1:.4} N/m, k2 = {k2:.3} N/m, turn strain {turn_strain:.4}")
        }
    }
}

/// Fits the three layers of one grid size, in parallel (one thread per layer).
fn fit_grid(
    targets: &[TissueTargets; 3],
    grid: GridSize,
    settings: &FitSettings,
    bars: &MultiProgress,
) -> Result<Vec<LayerFit>, String> {
    let geometry = limb_geometry(grid);
    let results: Vec<Result<LayerFit, String>> = std::thread::scope(|s| {
        let handles: Vec<_> = geometry
            .iter()
            .map(|&(i, g)| {
                let t = &targets[i];
                let bar = bars.add(ProgressBar::new(settings.anneal.max_evaluations as u64));
                bar.set_style(
                    ProgressStyle::with_template("{prefix:>14} [{bar:30}] {pos}/{len} evaluations, {msg}")
                        .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
                bar.set_prefix(format!("{} {}x{}", t.name, grid.columns, grid.rows));
                s.spawn(move || {
                    let mut best = f64::INFINITY;
                    let fit = fit_layer(t, g, settings, |step| {
                        best = best.min(step.psi);
                        bar.set_position(step.evaluation as u64);
                        bar.set_message(format!("best psi {best:.2e}"));
                    });
                    bar.finish();
                    fit.map_err(|e| format!("{} ({}x{}): {e}", t.name, grid.columns, grid.rows))
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|_| Err("fitting thread panicked".into()))).collect()
    });
    results.into_iter().collect()
}

/// Writes every evaluation's curve as CSV (`evaluation,psi,accepted,strain,stress_pa`).
fn write_curves(fit: &LayerFit, path: &Path) -> Result<(), String> {
    let mut text = String::from("evaluation,psi,accepted,strain,stress_pa\n");
    for (step, curve) in fit.anneal.history.iter().zip(&fit.curves) {
        for (e, s) in curve.strain.iter().zip(&curve.stress_pa) {
            text.push_str(&format!("{},{},{},{e},{s}\n", step.evaluation, step.psi, u8::from(step.accepted)));
        }
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The paper's Fig. 10: every iteration's stress-strain curve (grey), the target (black)
/// and the fitted layer (blue).
fn plot_fit(fit: &LayerFit, target: &TissueTargets, path: &Path) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let x_max = target.max_strain * 1.1;
    let y_max = target.stress_at(target.max_strain) * 1.3 / 1e3;
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let font = font_available();
    let mut builder = ChartBuilder::on(&root);
    builder.margin(20).x_label_area_size(if font { 50 } else { 10 }).y_label_area_size(if font { 80 } else { 10 });
    if font {
        builder.caption(format!("{}: stress-strain of every annealing iteration", fit.tissue), ("sans-serif", 20));
    }
    let mut chart = builder.build_cartesian_2d(0.0..x_max, 0.0..y_max).map_err(|e| err(&e))?;
    let mut mesh = chart.configure_mesh();
    if font {
        mesh.x_desc("engineering strain").y_desc("engineering stress (kPa)");
    } else {
        mesh.disable_x_axis().disable_y_axis();
    }
    mesh.draw().map_err(|e| err(&e))?;
    let clip = |c: &lamina_core::fit::TensileCurve| -> Vec<(f64, f64)> {
        c.strain.iter().zip(&c.stress_pa).map(|(e, s)| (*e, s / 1e3)).filter(|p| p.0 <= x_max && p.1 <= y_max).collect()
    };
    for curve in &fit.curves {
        chart
            .draw_series(LineSeries::new(clip(curve), RGBColor(190, 190, 190).stroke_width(1)))
            .map_err(|e| err(&e))?;
    }
    let n = 100;
    let target_pts: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let e = target.max_strain * i as f64 / n as f64;
            (e, target.stress_at(e) / 1e3)
        })
        .collect();
    let t = chart.draw_series(LineSeries::new(target_pts, BLACK.stroke_width(3))).map_err(|e| err(&e))?;
    if font {
        t.label("target (measured tissue)").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    }
    let b = chart.draw_series(LineSeries::new(clip(&fit.best_curve), BLUE.stroke_width(2))).map_err(|e| err(&e))?;
    if font {
        b.label("fitted springs").legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

/// Runs `lamina fit`.
pub fn fit(opts: &FitOptions) -> Result<(), String> {
    let (targets, source) = load_targets(opts.materials.as_deref())?;
    println!("tissue targets: {source}");
    std::fs::create_dir_all(&opts.out).map_err(|e| format!("{}: {e}", opts.out.display()))?;
    let mut settings = FitSettings::default();
    settings.anneal.seed = opts.seed;
    settings.anneal.max_evaluations = opts.max_evaluations as usize;
    let bars = MultiProgress::new();
    if !std::io::stderr().is_terminal() {
        bars.set_draw_target(ProgressDrawTarget::hidden());
    }
    let mut grids = opts.grids.clone();
    if !grids.contains(&opts.model_grid) {
        grids.push(opts.model_grid);
    }
    println!(
        "lamina fit: seed {}, annealing T0 = {} psi(x0), cooling {} every {} moves, stop at psi < {:e} or {} evaluations; {} loads per tensile test",
        settings.anneal.seed,
        settings.anneal.initial_temperature,
        settings.anneal.cooling,
        settings.anneal.moves_per_temperature,
        settings.anneal.psi_stop,
        settings.anneal.max_evaluations,
        settings.loads
    );
    let mut per_grid = Vec::new();
    for &grid in &grids {
        let start = Instant::now();
        let fits = fit_grid(&targets, grid, &settings, &bars)?;
        per_grid.push((grid, fits, start.elapsed().as_secs_f64()));
    }
    println!("\nfitted springs per grid size (the paper's Table 2 trend: stiffer springs on coarser grids)");
    println!("{:<7} {:>9} {:<7} {:<62} {:>10} {:>6}", "grid", "cell mm", "layer", "springs", "psi", "evals");
    for (grid, fits, _) in &per_grid {
        let g = limb_geometry(*grid);
        for (fit, (_, geo)) in fits.iter().zip(g) {
            println!(
                "{:<7} {:>9.2} {:<7} {:<62} {:>10.2e} {:>6}",
                format!("{}x{}", grid.columns, grid.rows),
                geo.spacing_m * 1e3,
                fit.tissue,
                spring_text(fit),
                fit.psi,
                fit.anneal.history.len()
            );
        }
    }
    let (grid, fits, seconds) =
        per_grid.iter().find(|(g, _, _)| *g == opts.model_grid).ok_or("model grid was not fitted")?;
    println!(
        "\ntargets against the fitted layers, {}x{} limb ({seconds:.1} s for its three layers on two threads)",
        grid.columns, grid.rows
    );
    println!("{:<7} {:<20} {:>14} {:>14} {:>9}", "layer", "target", "measured", "fitted model", "error");
    for fit in fits {
        for a in &fit.achieved {
            println!(
                "{:<7} {:<20} {:>14.5e} {:>14.5e} {:>8.2}%",
                fit.tissue,
                a.name,
                a.target,
                a.achieved,
                100.0 * a.error()
            );
        }
    }
    for (fit, target) in fits.iter().zip(&targets) {
        let csv = opts.out.join(format!("{}_{}x{}_iterations.csv", fit.tissue, grid.columns, grid.rows));
        write_curves(fit, &csv)?;
        let png = opts.out.join(format!("{}_{}x{}_fit.png", fit.tissue, grid.columns, grid.rows));
        plot_fit(fit, target, &png)?;
    }
    // The fitted limb, springs replaced, with provenance.
    let mut materials = Materials::default();
    materials.skin.spring = fits[0].material;
    materials.fat.spring = fits[1].material;
    materials.muscle.spring = fits[2].material;
    let limb = CylinderLimb { grid: *grid, ..CylinderLimb::default() };
    let mut model = generate(&limb, &materials).map_err(|e| e.to_string())?;
    model.provenance.push(("fit.seed".into(), settings.anneal.seed.to_string()));
    model.provenance.push((
        "fit.method".into(),
        "virtual tensile test + bilinear regression + simulated annealing (lamina fit)".into(),
    ));
    for (fit, target) in fits.iter().zip(&targets) {
        let p = |k: &str| format!("fit.{}.{k}", fit.tissue);
        model.provenance.push((p("targets"), target.path.display().to_string()));
        model.provenance.push((p("springs"), spring_text(fit)));
        model.provenance.push((p("psi"), format!("{:e}", fit.psi)));
        model.provenance.push((p("iterations"), fit.anneal.history.len().to_string()));
        for a in &fit.achieved {
            model.provenance.push((p(a.name), format!("target {:e}, achieved {:e}", a.target, a.achieved)));
        }
    }
    let xml = opts.out.join(format!("limb_{}x{}_fitted.xml", grid.columns, grid.rows));
    lamina_core::io::write_model(&model, &xml).map_err(|e| format!("{}: {e}", xml.display()))?;
    println!(
        "\nwritten to {}: the fitted model {}, iteration curves (CSV) and Fig. 10-style plots (PNG)",
        opts.out.display(),
        xml.display()
    );
    Ok(())
}
