//! `lamina bench effects`: what each effect costs. Times one step with springs only, with
//! each effect added alone, and with every effect on, on the same model; an effect that is
//! off is not in the loop, so the sum of the single-effect costs should match the
//! difference between all-on and springs-only.

use super::machine;
use lamina_core::model::Model;
use lamina_core::scene::Scene;
use lamina_core::solver::{
    BoneMotion, DragHandle, Effects, GuardSettings, IntegrationParameters, IntegratorKind, PointLoad, Simulation,
    SphereTool, Substeps,
};
use std::time::{Duration, Instant};

/// Times every configuration in interleaved rounds (so load from other processes hits all
/// alike) and keeps each one's fastest batch: s per step.
fn time_steps(
    model: &Model,
    params: &IntegrationParameters,
    configs: &[Effects],
    batch: Duration,
) -> Result<Vec<f64>, String> {
    let mut sims = configs
        .iter()
        .map(|e| Simulation::<f32>::new(model, params.clone(), e.clone()).map_err(|e| e.to_string()))
        .collect::<Result<Vec<_>, _>>()?;
    let mut steps = Vec::with_capacity(sims.len());
    for sim in &mut sims {
        let start = Instant::now();
        let mut warm = 0usize;
        while warm < 20 || start.elapsed() < Duration::from_millis(50) {
            sim.step();
            warm += 1;
        }
        steps.push(((batch.as_secs_f64() / (start.elapsed().as_secs_f64() / warm as f64)).ceil() as usize).max(5));
    }
    let mut best = vec![f64::INFINITY; sims.len()];
    for _ in 0..9 {
        for (i, sim) in sims.iter_mut().enumerate() {
            let t = Instant::now();
            for _ in 0..steps[i] {
                sim.step();
            }
            best[i] = best[i].min(t.elapsed().as_secs_f64() / steps[i] as f64);
        }
    }
    Ok(best)
}

/// Runs the comparison and prints the table.
pub fn bench(scene: &Scene, batch: Duration) -> Result<(), String> {
    let mut model = scene.build_model().map_err(|e| e.to_string())?;
    // The bone rows move the bone; the rows without `bone` step every node whatever its kind.
    model.nodes.set_bone_moving();
    // Effects cost what they add to the force pass, timed with the explicit integrator
    // whatever the scene's (an implicit step's cost is mostly its solve, and holding the bone
    // changes its unknowns).
    let mut params = IntegrationParameters {
        integrator: IntegratorKind::SymplecticEuler,
        substeps: Substeps::Fixed(1),
        multirate: None,
        ..scene.solver.clone()
    };
    let n = model.nodes.len() as u32;
    let loads: Vec<PointLoad> =
        (0..16).map(|i| PointLoad { node: (n - 1 - i * (n / 32)), force: [0.0, -0.01, 0.0], ramp_s: 0.1 }).collect();
    let handles: Vec<DragHandle> = (0..16)
        .map(|i| {
            let node = n - 1 - i * (n / 40);
            let p = model.nodes.position[node as usize];
            DragHandle { node, target: [p[0], p[1] + 0.005, p[2]], stiffness: 1.0, damping: 0.01 }
        })
        .collect();
    // A 1 cm sphere pressed 3 mm into the top face above the centre node.
    let top = model
        .nodes
        .position
        .iter()
        .copied()
        .max_by(|a, b| a[1].total_cmp(&b[1]).then(b[0].total_cmp(&a[0])))
        .unwrap_or([0.0; 3]);
    let centre = model.nodes.position[(n / 2) as usize];
    let tool = SphereTool {
        radius: 0.01,
        stiffness: 200.0,
        start: [centre[0], top[1] + 0.007, centre[2]],
        velocity: [0.0; 3],
    };
    // One sub-step per step at 0.8 of the explicit critical step with every effect on (the
    // tool's and handles' springs included), so every configuration steps a stable state.
    let probe = Simulation::<f64>::new(&model, params.clone(), all_on_effects(&loads, &handles, tool))
        .map_err(|e| e.to_string())?;
    // One explicit sub-step per step at 0.8 of the critical step with every effect on: stable
    // in every configuration.
    params.dt = 0.8 * probe.critical_step();
    let springs_only = Effects::default();
    let singles: Vec<(&str, Effects)> = vec![
        ("spring dashpots", Effects { spring_damping: true, ..Effects::default() }),
        ("gravity", Effects { gravity: Some([0.0, -9.81, 0.0]), ..Effects::default() }),
        ("viscous damping", Effects { viscous_damping: Some(2.0), ..Effects::default() }),
        (
            "bone (fixed + moving)",
            Effects {
                bone: true,
                bone_motion: Some(BoneMotion { amplitude: [0.0, 0.001, 0.0], frequency_hz: 1.0 }),
                ..Effects::default()
            },
        ),
        ("16 point loads", Effects { loads: loads.clone(), ..Effects::default() }),
        ("16 drag handles", Effects { handles: handles.clone(), ..Effects::default() }),
        ("sphere tool", Effects { tool: Some(tool), ..Effects::default() }),
        ("skin volume", Effects { skin_volume: Some(SKIN_VOLUME_PA), ..Effects::default() }),
        ("guard", Effects { guard: Some(GuardSettings::default()), ..Effects::default() }),
    ];
    let all_on = all_on_effects(&loads, &handles, tool);
    println!(
        "effects benchmark: scene '{}', {} nodes, {} springs, f32, {}, 1 sub-step of {:.3e} s per step, {} thread(s), SIMD {}",
        scene.name,
        model.nodes.len(),
        model.springs.len(),
        params.integrator,
        params.dt,
        params.threads,
        params.simd
    );
    println!("machine: {}", machine::describe());
    let mut configs = vec![springs_only];
    configs.extend(singles.iter().map(|(_, e)| e.clone()));
    configs.push(all_on);
    let times = time_steps(&model, &params, &configs, batch)?;
    let base = times[0];
    let all = times[times.len() - 1];
    println!("{:<24} {:>12} {:>16}", "configuration", "us/step", "cost vs springs");
    println!("{:<24} {:>12.2} {:>16}", "springs only", base * 1e6, "-");
    let mut sum = 0.0;
    for ((name, _), &t) in singles.iter().zip(&times[1..]) {
        sum += t - base;
        println!("{:<24} {:>12.2} {:>+16.2}", format!("+ {name}"), t * 1e6, (t - base) * 1e6);
    }
    println!("{:<24} {:>12.2} {:>+16.2}", "every effect on", all * 1e6, (all - base) * 1e6);
    println!(
        "\nsum of single-effect costs {:+.2} us; all-on minus springs-only {:+.2} us (difference {:+.2} us)",
        sum * 1e6,
        (all - base) * 1e6,
        (all - base - sum) * 1e6
    );
    println!("(fastest of 9 interleaved batches per configuration)");
    Ok(())
}

/// Skin volume stiffness of the benchmark, Pa (the default scene's).
const SKIN_VOLUME_PA: f64 = 5e4;

/// Every effect at once: gravity, damping, bone (fixed and moving), the loads, handles and
/// tool of the single-effect runs, the skin's volume term and the guard.
fn all_on_effects(loads: &[PointLoad], handles: &[DragHandle], tool: SphereTool) -> Effects {
    Effects {
        gravity: Some([0.0, -9.81, 0.0]),
        viscous_damping: Some(2.0),
        spring_damping: true,
        bone: true,
        bone_motion: Some(BoneMotion { amplitude: [0.0, 0.001, 0.0], frequency_hz: 1.0 }),
        loads: loads.to_vec(),
        handles: handles.to_vec(),
        guard: Some(GuardSettings::default()),
        tool: Some(tool),
        skin_volume: Some(SKIN_VOLUME_PA),
    }
}
