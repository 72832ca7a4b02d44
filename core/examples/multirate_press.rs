//! Multirate stepping against single-rate on finer grids of the default limb: the tool pressed
//! 8 mm into the skin over 0.5 s and held to 2 s, the force on it and where every node ends.
//!
//! ```text
//! cargo run --release -p lamina-core --example multirate_press -- [GRIDS] [RATIOS] [RADIUS_M] [ITERATIONS]
//! cargo run --release -p lamina-core --example multirate_press -- 48x12,96x24,160x40 8,20 0.03
//! ```
//!
//! `GRIDS` lists the default limb's grids (`COLUMNSxROWS`) or scene files (`.toml`, run with their
//! own springs and solver settings, e.g. `config/scenes/limb-96x24.toml`).
//! `ITERATIONS` sets `factored_iterations` (PCG iterations per step, region and bulk alike,
//! 1 to 64); by default the scene's.
//!
//! Prints one table row per grid and ratio (docs/accuracy-and-stability.md holds a run).

use lamina_core::scene::{DEFAULT_SCENE_TOML, Scene, ToolSource};
use lamina_core::solver::{IntegratorKind, LateBuild, MultirateSettings, Simulation, SphereTool};

/// Ticks of the run (1 kHz): the press over the first 500, held to 2 s.
const TICKS: usize = 2000;
const PRESS_TICKS: usize = 500;
/// Press depth, m.
const DEPTH_M: f64 = 0.008;

/// The default scene with its limb on `columns` x `rows`.
fn limb(columns: u32, rows: u32) -> Result<Scene, String> {
    let text = DEFAULT_SCENE_TOML
        .replace("columns = 24", &format!("columns = {columns}"))
        .replace("rows = 6", &format!("rows = {rows}"));
    Scene::from_toml_str(&text, None).map_err(|e| e.to_string())
}

/// Presses the tool into `scene`'s limb, single-rate or multirate; the simulation and the
/// vertical force on the tool at every tick, N.
fn press(
    scene: &Scene,
    multirate: Option<(f64, u32)>,
    iterations: Option<u32>,
) -> Result<(Simulation<f32>, Vec<f64>), String> {
    let model = scene.build_model().map_err(|e| e.to_string())?;
    let tool = scene.tool.ok_or("the scene has no tool")?;
    let ToolSource::Haptics { device_origin: origin, .. } = tool.source else {
        return Err("the scene's tool is not driven by haptics".into());
    };
    let mut params = scene.solver.clone();
    params.integrator = IntegratorKind::ImplicitFactored;
    params.factored_iterations = iterations.unwrap_or(params.factored_iterations);
    params.multirate = multirate.map(|(radius, ratio)| MultirateSettings {
        centre: origin,
        radius,
        ratio,
        // Regions taken 8 exchanges after asking, waited for: the same result on any machine.
        build_exchanges: Some(8),
        late_build: LateBuild::Wait,
        ..MultirateSettings::default()
    });
    let mut effects = scene.effects.clone();
    effects.tool =
        Some(SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: origin, velocity: [0.0; 3] });
    let mut sim = Simulation::<f32>::new(&model, params, effects).map_err(|e| e.to_string())?;
    let mut forces = Vec::with_capacity(TICKS);
    for tick in 0..TICKS {
        let depth = DEPTH_M * (tick as f64 / PRESS_TICKS as f64).min(1.0);
        if let Some(t) = sim.effects_mut().tool.as_mut() {
            t.start = [origin[0], origin[1] - depth, origin[2]];
        }
        sim.step();
        forces.push(sim.tool_feedback().force[1]);
    }
    Ok((sim, forces))
}

/// Each node's largest coordinate difference between two simulations of one model, m.
fn node_differences(a: &Simulation<f32>, b: &Simulation<f32>) -> Vec<f64> {
    let (a, b) = (&a.state().x, &b.state().x);
    (0..a.len())
        .map(|i| {
            let (p, q) = (a.get_f64(i), b.get_f64(i));
            (0..3).map(|c| (p[c] - q[c]).abs()).fold(0.0, f64::max)
        })
        .collect()
}

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let grids = args.first().map_or("48x12,96x24,160x40", String::as_str);
    let ratios = args.get(1).map_or("8,20", String::as_str);
    let radius: f64 = args.get(2).map_or(Ok(0.03), |r| r.parse()).map_err(|e| format!("radius: {e}"))?;
    // Bounded (1 to 64) by `Simulation::new`, which refuses others by name.
    let iterations: Option<u32> = args.get(3).map(|i| i.parse()).transpose().map_err(|e| format!("iterations: {e}"))?;
    println!(
        "| grid | nodes | ratio | region nodes | force at 2 s, N (single-rate) | largest force difference from 0.1 s | largest node difference at 2 s | nodes over 1 mm off | largest coupling gap |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for grid in grids.split(',') {
        let scene = if grid.ends_with(".toml") {
            // A scene file: its own limb, springs and solver settings.
            Scene::load(std::path::Path::new(grid)).map_err(|e| e.to_string())?
        } else {
            let (c, r) = grid.split_once('x').ok_or_else(|| format!("grid '{grid}': COLUMNSxROWS or a scene file"))?;
            let parse = |s: &str| s.trim().parse::<u32>().map_err(|e| format!("grid '{grid}': {e}"));
            limb(parse(c)?, parse(r)?)?
        };
        let (single, single_forces) = press(&scene, None, iterations)?;
        for ratio in ratios.split(',') {
            let ratio: u32 = ratio.trim().parse().map_err(|e| format!("ratio '{ratio}': {e}"))?;
            let (multi, forces) = press(&scene, Some((radius, ratio)), iterations)?;
            let status = multi.multirate_status().ok_or("multirate is off")?;
            let worst = forces
                .iter()
                .zip(&single_forces)
                .skip(100)
                .map(|(f, s)| (f - s).abs() / s.abs().max(1e-9))
                .fold(0.0, f64::max);
            let d = node_differences(&multi, &single);
            let (f, s) = (forces[TICKS - 1], single_forces[TICKS - 1]);
            println!(
                "| {grid} | {} | {ratio} | {} | {f:.4} ({s:.4}), {:+.2} % | {:.1} % | {:.2} mm | {} | {:.2} mm |",
                d.len(),
                status.region_nodes,
                100.0 * (f - s) / s,
                100.0 * worst,
                1e3 * d.iter().copied().fold(0.0, f64::max),
                d.iter().filter(|&&x| x > 1e-3).count(),
                1e3 * status.coupling_gap_max_m,
            );
        }
    }
    Ok(())
}
