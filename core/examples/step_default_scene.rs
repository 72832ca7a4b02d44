//! Load a scene, step it, read positions: the physics library on its own, no processes.
//!
//! ```text
//! cargo run --release -p lamina-core --example step_default_scene
//! cargo run --release -p lamina-core --example step_default_scene -- config/scenes/thigh.toml
//! ```
//!
//! Steps one simulated second at the scene's rate with its own solver and effects, then
//! prints the sag of the lowest-hanging node and the guard's totals.

use lamina_core::scene::Scene;
use lamina_core::solver::Simulation;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scene = match std::env::args().nth(1) {
        Some(path) => Scene::load(std::path::Path::new(&path))?,
        None => Scene::builtin_default(),
    };
    let model = scene.build_model()?;
    let mut sim = Simulation::<f32>::new(&model, scene.solver.clone(), scene.effects.clone())?;
    println!(
        "scene '{}': {} nodes, {} springs; {} at {} Hz, {} sub-step(s) per frame",
        scene.name,
        model.nodes.len(),
        model.springs.len(),
        sim.params().integrator,
        scene.rate_hz,
        sim.substeps()
    );
    let started = std::time::Instant::now();
    for _ in 0..scene.rate_hz {
        sim.step();
    }
    let wall = started.elapsed();
    // Positions are read back per node, in metres.
    let x = &sim.state().x;
    let (node, sag) = (0..x.len())
        .map(|i| (i, model.nodes.position[i][1] - x.get_f64(i)[1]))
        .fold((0, f64::MIN), |best, cur| if cur.1 > best.1 { cur } else { best });
    println!(
        "after {:.3} s simulated ({:.1} ms wall): node {node} sagged most, {:.3} mm",
        sim.state().time,
        wall.as_secs_f64() * 1e3,
        sag * 1e3
    );
    println!("guard: {:?}", sim.guard_totals());
    Ok(())
}
