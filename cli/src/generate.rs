//! `lamina generate`: the paper's Table 3 comparison, and the synthetic cylindrical limb
//! written as an XML model (and VTU for ParaView).

use lamina_core::generator::{CylinderLimb, GridSize, Materials, generate_with_progress, table3_rows};
use std::path::Path;
use std::time::Instant;

/// Prints our mass and spring counts beside the paper's Table 3.
pub fn table3() -> Result<(), String> {
    println!("{}", table3_rows());
    println!(
        "masses: W(7H+1) exactly, as the paper. springs: ours are the distinct node pairs, W(55H-13);\n\
         the paper's are W(52H-2). The gap W(3H-11) is explained family by family in\n\
         core/src/generator/families.rs: the paper's count is lower than a fully cross-linked\n\
         construction (it cannot be double counting), and no subset of spring families reproduces it."
    );
    Ok(())
}

/// Columns a limb grid may have (around the limb), as a scene's `[model]` table.
pub const GRID_COLUMNS: std::ops::RangeInclusive<u32> = 3..=4096;
/// Rows a limb grid may have (through the thickness), as a scene's `[model]` table.
pub const GRID_ROWS: std::ops::RangeInclusive<u32> = 1..=4096;

/// Parses `WxH` given as command-line option `option`: columns 3 to 4096 and rows 1 to 4096
/// (the bounds of a scene's `[model]` table), else an error naming the option, the value and
/// the bounds.
pub fn parse_grid(option: &str, text: &str) -> Result<GridSize, String> {
    let (w, h) = text.split_once('x').ok_or_else(|| format!("{option} '{text}': expected WxH, e.g. 39x10"))?;
    let parse = |v: &str| v.parse::<u32>().map_err(|_| format!("{option} '{text}': '{v}' is not a whole number"));
    let (columns, rows) = (parse(w)?, parse(h)?);
    if !(GRID_COLUMNS.contains(&columns) && GRID_ROWS.contains(&rows)) {
        return Err(format!(
            "{option} '{text}': columns must be {} to {} and rows {} to {}",
            GRID_COLUMNS.start(),
            GRID_COLUMNS.end(),
            GRID_ROWS.start(),
            GRID_ROWS.end()
        ));
    }
    Ok(GridSize::new(columns, rows))
}

/// Parses a comma-separated list of `WxH` grids given as option `option` ([`parse_grid`]).
pub fn parse_grids(option: &str, text: &str) -> Result<Vec<GridSize>, String> {
    text.split(',').map(|g| parse_grid(option, g.trim())).collect()
}

/// Generates the cylindrical limb and writes it.
pub fn cylinder(grid: GridSize, length: f64, out: &Path, vtu: Option<&Path>) -> Result<(), String> {
    let spec = CylinderLimb { grid, length, ..CylinderLimb::default() };
    let start = Instant::now();
    let bar = super::progress::steps(0, "generate");
    let mut last_stage = String::new();
    let mut progress = |stage: &str, done: usize, total: usize| {
        if stage != last_stage {
            bar.set_message(stage.to_string());
            bar.set_length(total as u64);
            last_stage = stage.to_string();
        }
        bar.set_position(done as u64);
    };
    let model = generate_with_progress(&spec, &Materials::default(), Some(&mut progress)).map_err(|e| e.to_string())?;
    bar.finish_and_clear();
    let generated = start.elapsed();
    lamina_core::io::write_model(&model, out).map_err(|e| e.to_string())?;
    if let Some(v) = vtu {
        lamina_core::io::write_vtu(&model, None, v).map_err(|e| e.to_string())?;
    }
    println!(
        "generated {}x{} limb in {:.2} ms: {} nodes, {} springs, {} layers, {} surfaces; wrote {}{}",
        grid.columns,
        grid.rows,
        generated.as_secs_f64() * 1e3,
        model.nodes.len(),
        model.springs.len(),
        model.layers.len(),
        model.surfaces.len(),
        out.display(),
        vtu.map_or(String::new(), |v| format!(" and {}", v.display()))
    );
    Ok(())
}

/// Generates the model of an anatomy scene (segmented surfaces) with a progress bar, prints
/// counts per layer, time per stage and the surface defects found and repaired, and writes it.
pub fn anatomy(scene: &Path, out: &Path, vtu: Option<&Path>) -> Result<(), String> {
    let s = lamina_core::scene::Scene::load(scene).map_err(|e| e.to_string())?;
    let lamina_core::scene::ModelSource::Anatomy(spec) = &s.model else {
        return Err(format!("{}: `lamina generate --scene` needs a model of kind \"anatomy\"", scene.display()));
    };
    let bar = indicatif::ProgressBar::new(0);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    bar.set_style(
        indicatif::ProgressStyle::with_template("{prefix:>12} [{bar:30}] {pos}/{len}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_prefix("loading");
    let mut stage_times: Vec<(String, f64)> = Vec::new();
    let mut stage_start = Instant::now();
    let mut current = String::new();
    let mut progress = |stage: &str, done: usize, total: usize| {
        if stage != current {
            if !current.is_empty() {
                stage_times.push((current.clone(), stage_start.elapsed().as_secs_f64()));
            }
            current = stage.to_string();
            stage_start = Instant::now();
            bar.set_prefix(stage.to_string());
            bar.set_length(total as u64);
        }
        bar.set_position(done as u64);
    };
    let start = Instant::now();
    let (model, report) =
        lamina_core::generator::generate_anatomy(spec, Some(&mut progress)).map_err(|e| e.to_string())?;
    let total = start.elapsed().as_secs_f64();
    stage_times.push((current.clone(), stage_start.elapsed().as_secs_f64()));
    bar.finish_and_clear();
    println!("{} from {}", model.name, scene.display());
    println!("surfaces:");
    for (path, r) in &report.loads {
        println!(
            "  {}: {} triangles, {} -> {} vertices welded, {} flipped triangles fixed, {} degenerate removed, units {:?}{}",
            path.display(),
            r.triangles,
            r.raw_vertices,
            r.welded_vertices,
            r.flipped_fixed,
            r.degenerate_removed,
            r.units,
            if r.units_inferred { " (inferred)" } else { "" }
        );
    }
    println!(
        "repairs: skin/fat {} missed, {} not below the outer triangle; fat/muscle boundary {} rays missed, {} samples not nested (placed {} mm below the level above); femur {} missed, {} not nested",
        report.skin_fat_repairs.0,
        report.skin_fat_repairs.1,
        report.fat_muscle_repairs.0,
        report.fat_muscle_repairs.1,
        spec.min_layer * 1e3,
        report.bone_repairs.0,
        report.bone_repairs.1
    );
    println!(
        "centreline: {} femur cross-sections between z = {} and {} mm",
        report.stations,
        spec.z_range.0 * 1e3,
        spec.z_range.1 * 1e3
    );
    let names = ["skin", "fat", "muscle", "bone"];
    for (l, name) in names.iter().enumerate() {
        let nodes = model.nodes.layer.iter().filter(|&&x| x as usize == l).count();
        let springs = model.springs.layer.iter().filter(|&&x| x as usize == l).count();
        println!("  {name:<7} {nodes:>6} nodes {springs:>7} springs");
    }
    println!("  total   {:>6} nodes {:>7} springs", model.nodes.len(), model.springs.len());
    println!(
        "time: load {:.0} ms, centreline {:.0} ms, generation {:.0} ms ({}), total {:.0} ms",
        report.seconds[0] * 1e3,
        report.seconds[1] * 1e3,
        report.seconds[2] * 1e3,
        stage_times.iter().map(|(s, t)| format!("{s} {:.0} ms", t * 1e3)).collect::<Vec<_>>().join(", "),
        total * 1e3
    );
    model.validate().map_err(|e| format!("generated model invalid: {e}"))?;
    lamina_core::io::write_model(&model, out).map_err(|e| e.to_string())?;
    if let Some(v) = vtu {
        lamina_core::io::write_vtu(&model, None, v).map_err(|e| e.to_string())?;
    }
    tracing::info!("wrote {}{}", out.display(), vtu.map_or(String::new(), |v| format!(" and {}", v.display())));
    Ok(())
}
