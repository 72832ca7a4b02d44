//! `lamina fit`: fits each layer's springs to its tissue targets (`config/materials/`, or the
//! copy compiled into the binary; see [`load_targets`]), per grid size of the cylindrical limb
//! or for a scene's limb; prints the targets against what the fitted layers achieve and each
//! layer's error against the tissue's own curve; writes every annealing iteration's curve and
//! the fitted curve against the tissue's (CSV) and a plot like the paper's Fig. 10 (PNG) for
//! every fit; for a scene, the `[model.springs]` table; for the model grid, the fitted limb as
//! an XML model with provenance.

use super::plot::font_available;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use lamina_core::fit::{
    CurveError, FitObjective, FitSettings, LayerFit, LayerGeometry, TargetCurve, TissueTargets, curve_error,
    cylinder_geometry, fit_layers, scene_geometry, scene_springs,
};
use lamina_core::generator::{CylinderLimb, GridSize, Materials, generate};
use lamina_core::scene::{ModelSource, Scene, SceneSprings};
use plotters::prelude::*;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `lamina fit`.
pub struct FitOptions {
    /// Folder holding `skin.toml`, `fat.toml`, `muscle.toml`; `None`: the search order of
    /// [`load_targets`].
    pub materials: Option<PathBuf>,
    /// Grid sizes of the cylindrical limb to fit for.
    pub grids: Vec<GridSize>,
    /// Scene files whose limb to fit for.
    pub scenes: Vec<PathBuf>,
    /// Grid whose fitted limb is written as XML (fitted too if not in `grids`).
    pub model_grid: Option<GridSize>,
    /// Annealing seed.
    pub seed: u64,
    /// Most objective evaluations per annealing run (default 1500).
    pub max_evaluations: u32,
    /// Evaluations of the indentation fit per scene (each one a virtual indentation); 0
    /// skips it.
    pub indentation_evaluations: u32,
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

/// The layers' geometry in the default cylindrical limb (0.30 m) on `grid`.
pub fn limb_geometry(grid: GridSize) -> [LayerGeometry; 3] {
    cylinder_geometry(&CylinderLimb { grid, ..CylinderLimb::default() })
}

fn spring_text(fit: &LayerFit) -> String {
    match fit.material {
        lamina_core::generator::SpringMaterial::Linear { stiffness } => format!("k = {stiffness:.4} N/m"),
        lamina_core::generator::SpringMaterial::Bilinear { k1, k2, turn_strain, .. } => {
            format!("k1 = {k1:.4} N/m, k2 = {k2:.3} N/m, turn strain {turn_strain:.4}")
        }
    }
}

/// Fits the three layers on `geometry` (one thread per layer), with a progress bar each.
fn fit_three(
    targets: &[TissueTargets; 3],
    label: &str,
    geometry: &[LayerGeometry; 3],
    settings: &FitSettings,
    bars: &MultiProgress,
) -> Result<[LayerFit; 3], String> {
    let style = ProgressStyle::with_template("{prefix:>20} [{bar:30}] {pos} evaluations (at most {len}), {msg}")
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    let progress: Vec<(ProgressBar, std::sync::Mutex<f64>)> = targets
        .iter()
        .map(|t| {
            let bar = bars.add(ProgressBar::new(settings.most_evaluations() as u64));
            bar.set_style(style.clone());
            bar.set_prefix(format!("{} {label}", t.name));
            (bar, std::sync::Mutex::new(f64::INFINITY))
        })
        .collect();
    let on_step = |layer: usize, step: &lamina_core::fit::AnnealStep| {
        let (bar, best) = &progress[layer];
        let mut best = best.lock().unwrap_or_else(|e| e.into_inner());
        *best = best.min(step.psi);
        bar.set_position(step.evaluation as u64);
        bar.set_message(format!("best psi {:.2e}", *best));
    };
    let results = fit_layers(targets, geometry, settings, &on_step);
    progress.iter().for_each(|(bar, _)| bar.finish());
    let [skin, fat, muscle] = results;
    let named = |r: Result<LayerFit, lamina_core::fit::LayerFitError>, t: &TissueTargets| {
        r.map_err(|e| format!("{} ({label}): {e}", t.name))
    };
    Ok([named(skin, &targets[0])?, named(fat, &targets[1])?, named(muscle, &targets[2])?])
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

/// Writes the fitted layer's curve against the tissue's (`strain,fitted_stress_pa,
/// tissue_stress_pa,error_of_peak`), one row per tested strain.
fn write_curve_error(error: &CurveError, path: &Path) -> Result<(), String> {
    let peak = error.points.iter().map(|p| p.2.abs()).fold(0.0, f64::max);
    let mut text = String::from("strain,fitted_stress_pa,tissue_stress_pa,error_of_peak\n");
    for (e, got, want) in &error.points {
        text.push_str(&format!("{e},{got},{want},{}\n", (got - want) / peak));
    }
    std::fs::write(path, text).map_err(|e| format!("{}: {e}", path.display()))
}

/// The paper's Fig. 10: every iteration's stress-strain curve (grey), the tissue's curve
/// (black, labelled with what it is), the bilinear targets when they differ from it
/// (dashed), and the fitted layer (blue).
fn plot_fit(fit: &LayerFit, target: &TissueTargets, path: &Path) -> Result<(), String> {
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let x_max = target.max_strain * 1.1;
    let y_max = target.stress_at(target.max_strain).max(target.curve_stress_at(target.max_strain)) * 1.3 / 1e3;
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
    let sample = |f: &dyn Fn(f64) -> f64| -> Vec<(f64, f64)> {
        (0..=100).map(|i| target.max_strain * i as f64 / 100.0).map(|e| (e, f(e) / 1e3)).collect()
    };
    let t = chart
        .draw_series(LineSeries::new(sample(&|e| target.curve_stress_at(e)), BLACK.stroke_width(3)))
        .map_err(|e| err(&e))?;
    if font {
        t.label(format!("tissue: {}", target.curve_label))
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
    }
    if target.curve != TargetCurve::Law {
        let dashed = DashedLineSeries::new(sample(&|e| target.stress_at(e)), 8, 6, BLACK.stroke_width(1));
        let d = chart.draw_series(dashed).map_err(|e| err(&e))?;
        if font {
            d.label("bilinear targets (best bilinear of the tissue curve)")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK));
        }
    }
    let b = chart.draw_series(LineSeries::new(clip(&fit.best_curve), BLUE.stroke_width(2))).map_err(|e| err(&e))?;
    if font {
        b.label("fitted springs (virtual tensile test)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
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

/// One fit: a grid of the default limb or a scene's limb.
struct Job {
    /// `24x6`, or the scene's name.
    label: String,
    geometry: [LayerGeometry; 3],
    /// The scene file and its springs, for a scene.
    scene: Option<(PathBuf, Option<SceneSprings>)>,
}

fn scene_job(path: &Path) -> Result<Job, String> {
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let geometry = scene_geometry(&scene).map_err(|e| e.to_string())?;
    let springs = match &scene.model {
        ModelSource::CylinderLimb { springs, .. } => *springs,
        ModelSource::Anatomy(spec) => Some(spec.materials)
            .filter(|m| *m != Materials::default())
            .map(|m| SceneSprings { fit_seed: 0, skin: m.skin.spring, fat: m.fat.spring, muscle: m.muscle.spring }),
        _ => None,
    };
    Ok(Job { label: scene.name.clone(), geometry, scene: Some((path.to_path_buf(), springs)) })
}

/// Largest relative difference between two springs' parameters (`None` when their laws differ).
pub fn spring_difference(
    a: &lamina_core::generator::SpringMaterial,
    b: &lamina_core::generator::SpringMaterial,
) -> Option<f64> {
    use lamina_core::generator::SpringMaterial::{Bilinear, Linear};
    let rel = |x: f64, y: f64| ((x - y) / y).abs();
    match (*a, *b) {
        (Linear { stiffness: x }, Linear { stiffness: y }) => Some(rel(x, y)),
        (Bilinear { k1, k2, turn_strain, .. }, Bilinear { k1: l1, k2: l2, turn_strain: t, .. }) => {
            Some(rel(k1, l1).max(rel(k2, l2)).max(rel(turn_strain, t)))
        }
        _ => None,
    }
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
    if let Some(g) = opts.model_grid.filter(|g| !grids.contains(g)) {
        grids.push(g);
    }
    let grid_label = |g: &GridSize| format!("{}x{}", g.columns, g.rows);
    let mut jobs: Vec<Job> =
        grids.iter().map(|g| Job { label: grid_label(g), geometry: limb_geometry(*g), scene: None }).collect();
    for path in &opts.scenes {
        jobs.push(scene_job(path)?);
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
    let mut fitted = Vec::new();
    for job in &jobs {
        let start = Instant::now();
        let fits = fit_three(&targets, &job.label, &job.geometry, &settings, &bars)?;
        fitted.push((fits, start.elapsed().as_secs_f64()));
    }
    println!("\nfitted springs (the paper's Table 2 trend: stiffer springs on coarser grids)");
    println!(
        "{:<24} {:>8} {:>8} {:<7} {:<62} {:<7} {:>10} {:>10} {:>6}",
        "limb", "cell mm", "layer mm", "layer", "springs", "fit to", "psi", "moduli psi", "evals"
    );
    for (job, (fits, _)) in jobs.iter().zip(&fitted) {
        for (fit, geo) in fits.iter().zip(&job.geometry) {
            println!(
                "{:<24} {:>8.2} {:>8.2} {:<7} {:<62} {:<7} {:>10.2e} {:>10.2e} {:>6}",
                job.label,
                geo.spacing_m * 1e3,
                geo.thickness_m * 1e3,
                fit.tissue,
                spring_text(fit),
                fit.objective.name(),
                fit.psi,
                fit.moduli_psi,
                fit.anneal.history.len()
            );
        }
    }
    if fitted.iter().flat_map(|(fits, _)| fits).any(|f| f.objective == FitObjective::Strain) {
        println!(
            "fit to strain: the regression's moduli reached no psi below {:e} on that layer's cells, so its springs were fitted to the tissue's strain under every load (docs/fitting.md)",
            settings.anneal.psi_stop
        );
    }
    println!(
        "\nfitted layers against the tissue's curve, at every tested strain: RMS and largest error as a share of the curve's RMS and peak stress, and the error at the smallest strain"
    );
    println!("{:<24} {:<7} {:<62} {:>7} {:>7} {:>10}", "limb", "layer", "tissue curve", "RMS", "max", "low strain");
    for (job, (fits, _)) in jobs.iter().zip(&fitted) {
        for (fit, target) in fits.iter().zip(&targets) {
            let safe = job.label.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_");
            let csv = opts.out.join(format!("{}_{safe}_iterations.csv", fit.tissue));
            write_curves(fit, &csv)?;
            let png = opts.out.join(format!("{}_{safe}_fit.png", fit.tissue));
            plot_fit(fit, target, &png)?;
            let Some(error) = curve_error(target, &fit.best_curve) else {
                println!("{:<24} {:<7} {:<62} (no tested strain)", job.label, fit.tissue, target.curve_label);
                continue;
            };
            write_curve_error(&error, &opts.out.join(format!("{}_{safe}_curve_error.csv", fit.tissue)))?;
            println!(
                "{:<24} {:<7} {:<62} {:>6.1}% {:>6.1}% {:>9.1}%",
                job.label,
                fit.tissue,
                target.curve_label,
                100.0 * error.rms,
                100.0 * error.max,
                100.0 * error.low_strain
            );
        }
    }
    for (job, (fits, seconds)) in jobs.iter().zip(&fitted) {
        let Some((path, current)) = &job.scene else { continue };
        let springs = scene_springs(fits, settings.anneal.seed);
        let toml = springs.to_toml();
        let file = opts
            .out
            .join(format!("springs_{}.toml", job.label.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_")));
        std::fs::write(&file, &toml).map_err(|e| format!("{}: {e}", file.display()))?;
        let verdict = match current {
            None => "the scene has no [model.springs]: it runs the generator's default springs".to_string(),
            Some(c) => {
                let worst = [(c.skin, springs.skin), (c.fat, springs.fat), (c.muscle, springs.muscle)]
                    .iter()
                    .map(|(a, b)| spring_difference(a, b).unwrap_or(f64::INFINITY))
                    .fold(0.0, f64::max);
                format!("the scene's springs differ from this fit by {:.2} % at most", 100.0 * worst)
            }
        };
        println!("\n{} ({seconds:.1} s): {verdict}; its [model.springs] ({}):\n{toml}", path.display(), file.display());
        if opts.indentation_evaluations > 0 {
            fit_scene_indentation(path, &job.label, springs, opts)?;
        }
    }
    let Some(model_grid) = opts.model_grid else {
        println!(
            "written to {}: iteration curves and curve errors (CSV), Fig. 10-style plots (PNG)",
            opts.out.display()
        );
        return Ok(());
    };
    let index = grids.iter().position(|g| *g == model_grid).ok_or("model grid was not fitted")?;
    let (fits, seconds) = &fitted[index];
    println!(
        "\ntargets against the fitted layers, {} limb ({seconds:.1} s for its three layers)",
        grid_label(&model_grid)
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
    for fit in fits.iter().filter(|f| f.objective == FitObjective::Strain) {
        println!(
            "{}: fitted to its strains; the values above are the regression's reading of its rounded knee, its error against the tissue's curve is the table before",
            fit.tissue
        );
    }
    // The fitted limb, springs replaced, with provenance.
    let materials = scene_springs(fits, settings.anneal.seed).materials();
    let limb = CylinderLimb { grid: model_grid, ..CylinderLimb::default() };
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
        model.provenance.push((p("objective"), fit.objective.name().to_string()));
        model.provenance.push((p("psi"), format!("{:e}", fit.psi)));
        model.provenance.push((p("iterations"), fit.anneal.history.len().to_string()));
        for a in &fit.achieved {
            model.provenance.push((p(a.name), format!("target {:e}, achieved {:e}", a.target, a.achieved)));
        }
        if let Some(e) = curve_error(target, &fit.best_curve) {
            model.provenance.push((
                p("curve_error"),
                format!("{}: RMS {:.4}, max {:.4} of the curve's RMS and peak", target.curve_label, e.rms, e.max),
            ));
        }
    }
    let xml = opts.out.join(format!("limb_{}_fitted.xml", grid_label(&model_grid)));
    lamina_core::io::write_model(&model, &xml).map_err(|e| format!("{}: {e}", xml.display()))?;
    println!(
        "\nwritten to {}: the fitted model {}, iteration curves and curve errors (CSV) and Fig. 10-style plots (PNG)",
        opts.out.display(),
        xml.display()
    );
    Ok(())
}

/// The indentation stage of a scene's fit: fat's and muscle's compression fitted to the in-vivo
/// band by virtual indentation of the scene's own limb (`lamina_core::fit::indentation_fit`),
/// printed, written as CSV (every evaluation, the force-depth curve), plotted beside the band,
/// and the scene's `[model.springs]` with them written as springs_NAME_in_vivo.toml.
fn fit_scene_indentation(path: &Path, label: &str, tensile: SceneSprings, opts: &FitOptions) -> Result<(), String> {
    use lamina_core::fit::{AnnealSettings, INDENTATION_WEIGHTS, IndentationTargets, fit_indentation};
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let targets = IndentationTargets::shipped();
    let settings = AnnealSettings {
        seed: opts.seed,
        max_evaluations: opts.indentation_evaluations as usize,
        ..AnnealSettings::default()
    };
    let bar = super::progress::steps(u64::from(opts.indentation_evaluations), "indentation fit");
    let start = Instant::now();
    let fit = fit_indentation(&scene, tensile, &targets, &settings, |s| {
        bar.set_message(format!("psi {:.3e}", s.psi));
        bar.inc(1);
    })
    .map_err(|e| format!("{}: indentation fit: {e}", path.display()))?;
    bar.finish_and_clear();
    let safe = label.replace(|c: char| !c.is_ascii_alphanumeric() && c != '-', "_");
    let band = &targets.band;
    println!(
        "indentation fit of {label} ({:.1} s, {} evaluations, weights outside band {} / stiffening {} / off centre {}): fat compression {:.1} x its tension stiffness, muscle {:.2} x, psi {:.3e}",
        start.elapsed().as_secs_f64(),
        fit.steps.len(),
        INDENTATION_WEIGHTS.0,
        INDENTATION_WEIGHTS.1,
        INDENTATION_WEIGHTS.2,
        fit.fat_compression_ratio,
        fit.muscle_compression_ratio,
        fit.psi
    );
    println!(
        "{:<44} {:>12} {:>14} {:>10}",
        "site",
        format!("F {:.0} mm", band.depth_m * 1e3),
        "secant 8/2 mm",
        "verdict"
    );
    for (curve, check) in fit.curves.iter().zip(&fit.checks) {
        match check {
            Some(c) => {
                let verdict = c.verdict();
                println!("{:<44} {:>11.3}N {:>14.2} {verdict:>10}", curve.site, c.force_n, c.secant_ratio);
            }
            None => println!("{:<44} {:>12} {:>14} {:>10}", curve.site, "-", "-", "not reached"),
        }
    }
    println!(
        "band: {:.0}-{:.0} N at {:.0} mm, secant ratio >= {:.1} ({})",
        band.force_min_n,
        band.force_max_n,
        band.depth_m * 1e3,
        band.min_secant_ratio,
        band.kind
    );
    let mut csv = String::from("evaluation,fat_compression_ratio,muscle_compression_ratio,psi,accepted\n");
    for s in &fit.steps {
        csv.push_str(&format!("{},{},{},{},{}\n", s.evaluation, s.params[0], s.params[1], s.psi, s.accepted));
    }
    let iterations = opts.out.join(format!("indentation_{safe}_iterations.csv"));
    std::fs::write(&iterations, csv).map_err(|e| format!("{}: {e}", iterations.display()))?;
    let mut curve = String::from("site,depth_m,force_n\n");
    for c in &fit.curves {
        for (d, f) in c.depth_m.iter().zip(&c.force_n) {
            curve.push_str(&format!("{},{d},{f}\n", c.site));
        }
    }
    let curve_csv = opts.out.join(format!("indentation_{safe}_curve.csv"));
    std::fs::write(&curve_csv, curve).map_err(|e| format!("{}: {e}", curve_csv.display()))?;
    let depths: Vec<f64> = fit.curves.first().map(|c| c.depth_m.iter().map(|d| d * 1e3).collect()).unwrap_or_default();
    let mut series: Vec<super::plot::Series> = fit
        .curves
        .iter()
        .map(|c| super::plot::Series {
            name: format!("{label}: fitted limb, virtual indentation, {}", c.site),
            points: c.depth_m.iter().map(|d| d * 1e3).zip(c.force_n.iter().copied()).collect(),
        })
        .collect();
    for (end, force) in [("low", band.force_min_n), ("high", band.force_max_n)] {
        series.push(super::plot::Series {
            name: format!("band {end}: Hertz through {force:.0} N at {:.0} mm", band.depth_m * 1e3),
            points: depths.iter().map(|d| (*d, band.hertz_through(force, *d))).collect(),
        });
    }
    let png = opts.out.join(format!("indentation_{safe}_fit.png"));
    super::plot::log_log_lines(&png, "indentation fit: force against depth", "depth (mm)", "force (N)", &series, true)?;
    let toml = fit.springs.to_toml();
    let file = opts.out.join(format!("springs_{safe}_in_vivo.toml"));
    std::fs::write(&file, &toml).map_err(|e| format!("{}: {e}", file.display()))?;
    println!("its [model.springs] with the fitted compression ({}, plot {}):\n{toml}", file.display(), png.display());
    Ok(())
}
