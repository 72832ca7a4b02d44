//! Multirate stepping (the tool's region every tick, the rest of the limb once per `ratio`
//! ticks on its own thread) against the single-rate solvers: the same press force, the same
//! equilibrium, results independent of the bulk thread's timing, and clear refusals.

mod common;

use lamina_core::scene::{DEFAULT_SCENE_TOML, Scene, ToolSource};
use lamina_core::solver::{
    BoneMotion, IntegratorKind, LateBuild, MultirateSettings, PointLoad, Simulation, SimulationBuildError,
};

/// The built-in default scene with its tool held at the device origin, stepped by `integrator`,
/// multirate about the origin with `multirate`'s radius, ratio and following.
fn default_scene_with_tool(
    integrator: IntegratorKind,
    multirate: Option<MultirateSettings>,
) -> (Simulation<f32>, [f64; 3]) {
    limb_with_tool(Scene::builtin_default(), integrator, multirate)
}

/// The default limb on a grid of `columns` around and `rows` along (same limb, finer cells).
fn default_limb_on_grid(columns: u32, rows: u32) -> Scene {
    let text = DEFAULT_SCENE_TOML
        .replace("columns = 24", &format!("columns = {columns}"))
        .replace("rows = 6", &format!("rows = {rows}"));
    Scene::from_toml_str(&text, None).unwrap()
}

/// `scene` with its tool held at the device origin, stepped by `integrator`, multirate about
/// the origin with `multirate`'s radius, ratio and following.
fn limb_with_tool(
    scene: Scene,
    integrator: IntegratorKind,
    multirate: Option<MultirateSettings>,
) -> (Simulation<f32>, [f64; 3]) {
    common::limb_with_tool(scene, |params, origin| {
        params.integrator = integrator;
        params.multirate = multirate.map(|m| MultirateSettings { centre: origin, ..m });
    })
}

/// Multirate settings of `radius` (m) and `ratio`, the region following the tool.
/// Regions about the tool taken 8 exchanges after asking, waited for if late: the same result
/// however loaded the machine.
fn multirate(radius: f64, ratio: u32) -> Option<MultirateSettings> {
    Some(MultirateSettings {
        radius,
        ratio,
        build_exchanges: Some(8),
        late_build: LateBuild::Wait,
        ..MultirateSettings::default()
    })
}

/// Presses the tool of the default scene 8 mm into the skin over 0.5 s and holds it, for
/// `frames` frames; `after_step` sees each frame's index and the simulation after it.
fn press_for(
    integrator: IntegratorKind,
    settings: Option<MultirateSettings>,
    frames: usize,
    mut after_step: impl FnMut(usize, &mut Simulation<f32>),
) -> Simulation<f32> {
    let (mut sim, origin) = default_scene_with_tool(integrator, settings);
    for frame in 0..frames {
        let depth = 0.008 * (frame as f64 / 500.0).min(1.0);
        sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2]];
        sim.step();
        after_step(frame, &mut sim);
    }
    sim
}

/// Presses the tool 8 mm into the skin over 0.5 s and holds it to 2 s; returns the
/// simulation and the vertical force on the tool, N.
fn press(integrator: IntegratorKind, settings: Option<MultirateSettings>) -> (Simulation<f32>, f64) {
    let sim = press_for(integrator, settings, 2000, |_, _| {});
    assert_eq!(sim.guard_totals().rollbacks, 0);
    let force = sim.tool_feedback().force[1];
    (sim, force)
}

fn max_difference(a: &Simulation<f32>, b: &Simulation<f32>) -> f64 {
    let (a, b) = (&a.state().x, &b.state().x);
    (0..a.len())
        .map(|i| {
            let (p, q) = (a.get_f64(i), b.get_f64(i));
            (0..3).map(|c| (p[c] - q[c]).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[test]
fn multirate_press_force_matches_the_explicit_solver_works() {
    let (_, explicit) = press(IntegratorKind::SymplecticEuler, None);
    let (single, single_force) = press(IntegratorKind::ImplicitFactored, None);
    for ratio in [4, 8] {
        let (multi, force) = press(IntegratorKind::ImplicitFactored, multirate(0.05, ratio));
        let status = multi.multirate_status().expect("multirate on");
        assert!(status.region_nodes > 10 && status.bulk_nodes > 10 * status.region_nodes, "{status:?}");
        assert_eq!(status.bulk_steps, 2000 / u64::from(ratio));
        assert!(explicit > 0.05, "the tool presses ({explicit} N)");
        assert!(
            (force - explicit).abs() <= 0.05 * explicit,
            "multirate (ratio {ratio}) {force} N, symplectic Euler {explicit} N, single-rate {single_force} N"
        );
        // The whole limb, held 1.5 s, sits where the single-rate solver puts it: both reach
        // the same equilibrium (the coupling is exact at rest).
        let d = max_difference(&multi, &single);
        eprintln!(
            "ratio {ratio}: {} region nodes, {} bulk nodes; force {force:.5} N (explicit {explicit:.5} N, single-rate {single_force:.5} N); positions within {d:.3e} m of single-rate; coupling gap {:.3e} m, largest {:.3e} m",
            status.region_nodes, status.bulk_nodes, status.coupling_gap_m, status.coupling_gap_max_m
        );
        assert!(d < 2e-4, "ratio {ratio}: positions differ by up to {d:e} m from the single-rate solver");
        // At rest both halves put the nodes they both step in the same place.
        assert!(status.coupling_gap_m < 5e-5, "ratio {ratio}: {status:?}");
    }
}

/// On the default limb at 48x12 (4,080 nodes), presses the tool 4 mm into the skin over 0.2 s,
/// slides it 6 cm along the limb over 1 s and holds it there to 2 s; returns the simulation and
/// the vertical force on the tool at every tick, N.
fn press_and_slide(settings: Option<MultirateSettings>) -> (Simulation<f32>, Vec<f64>) {
    let (mut sim, origin) = limb_with_tool(default_limb_on_grid(48, 12), IntegratorKind::ImplicitFactored, settings);
    let mut forces = Vec::new();
    for frame in 1..=2000 {
        let depth = 0.004 * (frame as f64 / 200.0).min(1.0);
        let along = 0.06 * ((frame as f64 - 200.0) / 1000.0).clamp(0.0, 1.0);
        sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2] + along];
        sim.step();
        forces.push(sim.tool_feedback().force[1]);
    }
    assert_eq!(sim.guard_totals().rollbacks, 0);
    (sim, forces)
}

/// What a publisher relies on to rewrite only the region's nodes: between two ticks of the
/// same `frame_changes` epoch, every node outside its list keeps its position bit for bit,
/// through exchanges with the bulk and regions taken about a sliding tool.
#[test]
fn multirate_frame_changes_name_every_node_that_moved_works() {
    let (mut sim, origin) = default_scene_with_tool(IntegratorKind::ImplicitFactored, multirate(0.05, 4));
    // Another simulation of the same scene never shares an epoch with this one.
    let (other, _) = default_scene_with_tool(IntegratorKind::ImplicitFactored, multirate(0.05, 4));
    assert_ne!(other.frame_changes().unwrap().epoch, sim.frame_changes().unwrap().epoch);
    drop(other);
    let (mut same_epoch, mut epochs, mut region_moved) = (0, 0, 0);
    let mut before = sim.state().x.clone();
    let mut epoch = sim.frame_changes().unwrap().epoch;
    for frame in 1..=600 {
        // Pressed 4 mm, then slid 6 cm along the limb: the region moves with it.
        let depth = 0.004 * (frame as f64 / 100.0).min(1.0);
        let along = 0.06 * ((frame as f64 - 100.0) / 400.0).clamp(0.0, 1.0);
        sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2] + along];
        sim.step();
        let changes = sim.frame_changes().unwrap();
        let x = &sim.state().x;
        if changes.epoch == epoch {
            same_epoch += 1;
            let mut listed = vec![false; x.len()];
            for &i in changes.nodes {
                listed[i as usize] = true;
            }
            for i in (0..x.len()).filter(|&i| !listed[i]) {
                let (p, q) = (before.get_f64(i), x.get_f64(i));
                assert_eq!(p, q, "tick {frame}: node {i} moved outside the region within epoch {epoch}");
            }
            region_moved +=
                usize::from(changes.nodes.iter().any(|&i| before.get_f64(i as usize) != x.get_f64(i as usize)));
        } else {
            epochs += 1;
        }
        epoch = changes.epoch;
        before = x.clone();
    }
    let status = sim.multirate_status().unwrap();
    // Exchanges every 4 ticks begin a new epoch each: three ticks of four are checked.
    assert!(status.recentres >= 2, "{status:?}");
    assert!(epochs >= 150 && same_epoch >= 400, "{epochs} epochs, {same_epoch} ticks within one");
    assert!(region_moved >= 400, "the region's nodes moved on {region_moved} of them");
}

#[test]
fn multirate_region_follows_a_sliding_tool_works() {
    let (single, single_forces) = press_and_slide(None);
    let (moving, forces) = press_and_slide(multirate(0.05, 8));
    let status = moving.multirate_status().expect("multirate on");
    // The halves agree where both step through the press and the slide (a failing coupling
    // shows millimetres, docs/accuracy-and-stability.md); measured 8.9e-5 m at most.
    assert!(status.coupling_gap_max_m < 5e-4, "{status:?}");
    // 6 cm in steps of a quarter radius (12.5 mm): at least four moves, none refused, and the
    // region ends about the tool.
    assert!(status.recentres >= 4 && status.recentres_refused == 0, "{status:?}");
    let tool = moving.effects().tool.unwrap().start;
    let off = (0..3).map(|k| (status.centre[k] - tool[k]).powi(2)).sum::<f64>().sqrt();
    assert!(off <= 0.25 * 0.05, "the region's centre {:?} is {off} m from the tool {tool:?}", status.centre);
    // The force follows the single-rate solver's through the press, the slide and the hold
    // (from 0.1 s, once the tool is 2 mm in).
    let worst = |forces: &[f64]| {
        forces.iter().zip(&single_forces).skip(100).map(|(f, s)| (f - s).abs() / s).fold(0.0, f64::max)
    };
    let largest_jump = |forces: &[f64]| forces.windows(2).skip(100).map(|w| (w[1] - w[0]).abs()).fold(0.0, f64::max);
    assert!(single_forces.iter().skip(100).all(|&f| f > 0.05), "the tool presses throughout");
    let d = max_difference(&moving, &single);
    eprintln!(
        "slide: {} moves, longest build {} us; force within {:.2} % of single-rate at every tick; largest change in one tick {:.2e} N (single-rate {:.2e} N); positions within {d:.3e} m",
        status.recentres,
        status.recentre_build_max_ns / 1000,
        100.0 * worst(&forces),
        largest_jump(&forces),
        largest_jump(&single_forces)
    );
    assert!(worst(&forces) <= 0.05, "multirate {forces:?} N, single-rate {single_forces:?} N");
    // Taking a new region does not jolt the tool: no change in one tick beyond the
    // single-rate solver's own largest by more than half.
    assert!(largest_jump(&forces) <= 1.5 * largest_jump(&single_forces));
    assert!(d < 5e-4, "positions differ by up to {d:e} m from the single-rate solver");
    // A region that stays where it was built loses the tool: 6 cm away, the tool presses
    // only the ring the region holds and the bulk's slow step, and the force is half.
    let fixed = MultirateSettings { follow_tool: false, ..multirate(0.05, 8).unwrap() };
    let (stuck, stuck_forces) = press_and_slide(Some(fixed));
    assert_eq!(stuck.multirate_status().unwrap().recentres, 0);
    eprintln!("fixed region: force within {:.1} % of single-rate", 100.0 * worst(&stuck_forces));
    assert!(worst(&stuck_forces) > 0.2, "fixed region {stuck_forces:?} N");
}

/// On the default limb at 48x12, presses the 12 mm tool 8 mm into the skin over 0.3 s; widens
/// it to `wide` m (its lowest point kept where it was) and slides it 3 cm along the limb over
/// 0.5 s, held to 1.5 s; narrows it back, held to 2.5 s. Returns the simulation, the vertical
/// force on the tool (N) at the end of each hold, the region's radius (m) at both times (0
/// single-rate), and the nodes that were inside the tool and outside the region from 0.1 s
/// after each change of radius.
fn press_widen_narrow(
    wide: f64,
    settings: Option<MultirateSettings>,
) -> (Simulation<f32>, [f64; 2], [f64; 2], Vec<usize>) {
    let scene = default_limb_on_grid(48, 12);
    let rest = scene.build_model().unwrap().nodes.position;
    let (mut sim, origin) = limb_with_tool(scene, IntegratorKind::ImplicitFactored, settings);
    let narrow = sim.effects().tool.unwrap().radius;
    let (mut forces, mut radii, mut outside) = ([0.0; 2], [0.0; 2], Vec::new());
    for frame in 1..=2500 {
        let depth = 0.008 * (frame as f64 / 300.0).min(1.0);
        let along = 0.03 * ((frame as f64 - 300.0) / 500.0).clamp(0.0, 1.0);
        let radius = if (300..1500).contains(&frame) { wide } else { narrow };
        let tool = sim.effects_mut().tool.as_mut().unwrap();
        tool.radius = radius;
        tool.start = [origin[0], origin[1] - depth + (radius - narrow), origin[2] + along];
        sim.step();
        if frame == 1499 || frame == 2500 {
            let k = usize::from(frame == 2500);
            forces[k] = sim.tool_feedback().force[1];
            radii[k] = sim.multirate_status().map_or(0.0, |m| m.radius);
        }
        // The region is taken 64 ticks after asking: from 0.1 s after each change of radius.
        let settled = !(300..400).contains(&frame) && !(1500..1600).contains(&frame);
        if let Some(m) = sim.multirate_status().filter(|_| settled) {
            let tool = sim.effects().tool.unwrap();
            let x = &sim.state().x;
            let dist = |a: [f64; 3], b: [f64; 3]| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt();
            outside.extend(
                (0..x.len())
                    .filter(|&i| dist(x.get_f64(i), tool.start) < tool.radius && dist(rest[i], m.centre) > m.radius),
            );
        }
    }
    assert_eq!(sim.guard_totals().rollbacks, 0);
    outside.sort_unstable();
    outside.dedup();
    (sim, forces, radii, outside)
}

#[test]
fn multirate_region_widens_for_a_wide_tool_works() {
    // A 45 mm tool pressing 8 mm has its centre 37 mm above the skin: a 30 mm region about it
    // would hold no node. The region is built at 4/3 of the tool's radius instead, so it
    // follows the sliding tool and holds every node the tool touches; narrowed, the region
    // returns to 30 mm. The force is the single-rate solver's.
    let (base, wide) = (0.03, 0.045);
    let (_, single, _, _) = press_widen_narrow(wide, None);
    let (multi, forces, radii, outside) = press_widen_narrow(wide, multirate(base, 8));
    let status = multi.multirate_status().unwrap();
    eprintln!(
        "wide tool: force {:.5} N (single-rate {:.5} N), region {} mm; narrowed: {:.5} N (single-rate {:.5} N), region {} mm; {} moves",
        forces[0],
        single[0],
        radii[0] * 1e3,
        forces[1],
        single[1],
        radii[1] * 1e3,
        status.recentres
    );
    assert!(status.recentres >= 3 && status.recentres_refused == 0, "{status:?}");
    assert!(outside.is_empty(), "nodes {outside:?} were inside the tool and outside the region");
    assert!((radii[0] - wide * 4.0 / 3.0).abs() < 1e-12 && radii[1] == base, "{radii:?}");
    for k in 0..2 {
        assert!(single[k] > 0.05, "the tool presses ({} N)", single[k]);
        assert!((forces[k] - single[k]).abs() <= 0.01 * single[k], "multirate {forces:?} N, single-rate {single:?} N");
    }
}

#[test]
fn multirate_bulk_feels_handles_and_loads_changed_while_running_works() {
    // The default scene's drag handle pulls node 24, 11 cm from the region about the tool
    // (the bulk's). At 0.2 s its target moves 1 cm further out and a 30 mN load pushes down
    // node 42, under the limb (also the bulk's): 2.8 s later both sit where the single-rate
    // solver puts them (a bulk ignoring them leaves them 0.70 mm and 0.04 mm from where they
    // started, where the single-rate solver moves them 1.22 mm and 1.0 mm).
    let run = |settings: Option<MultirateSettings>| {
        let (mut sim, _) = default_scene_with_tool(IntegratorKind::ImplicitFactored, settings);
        let start = [24, 42].map(|i| sim.state().x.get_f64(i));
        for tick in 1..=3000 {
            if tick == 200 {
                let effects = sim.effects_mut();
                effects.handles[0].target[0] += 0.01;
                effects.loads.push(PointLoad { node: 42, force: [0.0, -0.03, 0.0], ramp_s: 0.0 });
            }
            sim.step();
        }
        assert_eq!(sim.guard_totals().rollbacks, 0);
        let moved = [0, 1].map(|k| {
            let (a, b) = (start[k], sim.state().x.get_f64([24, 42][k]));
            (0..3).map(|c| (a[c] - b[c]).powi(2)).sum::<f64>().sqrt()
        });
        (sim, moved)
    };
    let (single, single_moved) = run(None);
    let (multi, moved) = run(multirate(0.05, 8));
    let d = max_difference(&multi, &single);
    eprintln!(
        "handle node moved {:.3e} m (single-rate {:.3e} m), load node {:.3e} m ({:.3e} m); limb within {d:.3e} m of single-rate",
        moved[0], single_moved[0], moved[1], single_moved[1]
    );
    for (k, node) in [24u32, 42].into_iter().enumerate() {
        assert!(single_moved[k] > 5e-4, "node {node} moves ({} m)", single_moved[k]);
        assert!(
            (moved[k] - single_moved[k]).abs() < 0.05 * single_moved[k],
            "node {node}: {moved:?} m, single-rate {single_moved:?} m"
        );
    }
    assert!(d < 2e-4, "the limb is {d} m from the single-rate solver's");
}

/// A kick to the whole pressed limb (every free node lifted 2 mm at once) puts the region's
/// copy of the overlap 2 mm from the bulk's; the coupling settles back by itself, to where the
/// single-rate solver kicked the same way settles, its two halves agreeing again. (A bulk
/// taking the region's overlap whenever they drift over 1 mm apart kept this kick swinging:
/// docs/accuracy-and-stability.md.)
#[test]
fn multirate_coupling_settles_back_after_a_kick_works() {
    let kicked = |settings: Option<MultirateSettings>| {
        let mut gap_after_kick = 0.0f64;
        let sim = press_for(IntegratorKind::ImplicitFactored, settings, 1500, |frame, sim| {
            if frame == 599 {
                // Lifted before frame 600.
                for i in 0..sim.state().x.len() {
                    if sim.node_is_free(i) {
                        sim.state_mut().x.y[i] += 0.002;
                    }
                }
            }
            if (600..700).contains(&frame) {
                gap_after_kick = gap_after_kick.max(sim.multirate_status().map_or(0.0, |m| m.coupling_gap_m));
            }
        });
        (sim, gap_after_kick)
    };
    let (single, _) = kicked(None);
    let (multi, gap_after_kick) = kicked(multirate(0.05, 4));
    let status = multi.multirate_status().expect("multirate on");
    let d = max_difference(&multi, &single);
    let (force, single_force) = (multi.tool_feedback().force[1], single.tool_feedback().force[1]);
    eprintln!(
        "kicked 2 mm: gap {gap_after_kick:.3e} m in the 0.1 s after, {:.3e} m at 1.5 s; positions within {d:.3e} m of single-rate; force {force:.5} N (single-rate {single_force:.5} N)",
        status.coupling_gap_m
    );
    assert!(gap_after_kick > 1e-3, "the kick drew the halves apart: {gap_after_kick} m");
    assert!(status.coupling_gap_m < 5e-5, "{status:?}");
    assert!(d < 2e-4, "positions differ by up to {d:e} m from the single-rate solver");
    assert!(
        multi.tool_feedback().in_contact && (force - single_force).abs() < 0.01 * single_force,
        "{force} N against {single_force} N"
    );
}

#[test]
fn multirate_results_do_not_depend_on_the_bulk_threads_timing_works() {
    // The region waits for the bulk's state at each exchange, so two runs give the same bits
    // however the two threads were scheduled (here under whatever load the test machine has).
    let run = || {
        // Regions about the tool taken 3 exchanges after asking, built in time or not.
        let settings = MultirateSettings { build_exchanges: Some(3), ..multirate(0.05, 5).unwrap() };
        let (mut sim, origin) = default_scene_with_tool(IntegratorKind::ImplicitFactored, Some(settings));
        for frame in 0..300 {
            // 6 mm down and 3 cm along the limb: the region moves with the tool.
            let (depth, along) = (0.006 * (frame as f64 / 300.0), 0.03 * (frame as f64 / 300.0));
            sim.effects_mut().tool.as_mut().unwrap().start = [origin[0], origin[1] - depth, origin[2] + along];
            sim.step();
            if frame % 97 == 0 {
                std::thread::sleep(std::time::Duration::from_millis(3));
            }
        }
        sim
    };
    let (a, b) = (run(), run());
    assert!(a.tool_feedback().force[1] > 0.01, "the tool presses");
    assert!(a.multirate_status().unwrap().recentres >= 2, "{:?}", a.multirate_status());
    assert_eq!(max_difference(&a, &b), 0.0);
    assert_eq!(a.tool_feedback().force, b.tool_feedback().force);
}

#[test]
fn multirate_refusals_name_what_is_wrong_fails() {
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let tool = scene.tool.unwrap();
    let ToolSource::Haptics { device_origin: origin, .. } = tool.source else { panic!("a haptic tool") };
    let build = |integrator: IntegratorKind, settings: MultirateSettings, bone_motion: bool| {
        let mut params = scene.solver.clone();
        params.integrator = integrator;
        params.multirate = Some(settings);
        let mut effects = scene.effects.clone();
        if bone_motion {
            effects.bone_motion = Some(BoneMotion { amplitude: [0.0, 0.001, 0.0], frequency_hz: 1.0 });
        }
        match Simulation::<f32>::new(&model, params, effects) {
            Err(SimulationBuildError::Multirate(why)) => why,
            Err(other) => panic!("another refusal: {other}"),
            Ok(_) => panic!("built"),
        }
    };
    let ok = MultirateSettings { centre: origin, ..MultirateSettings::default() };
    assert!(build(IntegratorKind::SymplecticEuler, ok, false).contains("implicit_factored"));
    assert!(build(IntegratorKind::ImplicitFactored, ok, true).contains("bone_motion"));
    let far = MultirateSettings { centre: [5.0, 5.0, 5.0], ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, far, false).contains("holds 0 of"));
    // 3 cm about the tool holds a cap of skin a spring deep on this coarse limb: no core.
    let thin = MultirateSettings { radius: 0.03, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, thin, false).contains("enlarge the radius"));
    let all = MultirateSettings { radius: 10.0, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, all, false).contains("not all"));
    let bad = MultirateSettings { radius: f64::NAN, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, bad, false).contains("radius"));
    let slow = MultirateSettings { ratio: 1, ..ok };
    assert!(build(IntegratorKind::ImplicitFactored, slow, false).contains("ratio 1"));
}
