//! The haptic tool against the skin surface: the contact force of a sphere pressed into a flat,
//! held skin against the closed-form integral of its penalty pressure, and no slipping
//! between the nodes of a coarse grid (the default limb's rows are 40 mm apart, the tool's
//! radius is 12 mm).

use lamina_core::model::{Layer, Model, NodeKind, Surface, Tissue};
use lamina_core::scene::{Scene, ToolSource};
use lamina_core::solver::{Effects, IntegrationParameters, Simulation, SphereTool};

/// A flat skin in the plane y = 0: `n × n` held nodes `h` apart, each square split in two.
fn flat_skin(n: u32, h: f64) -> Model {
    let mut model = Model::default();
    model.layers.push(Layer { name: "skin".into(), tissue: Tissue::Skin });
    for j in 0..n {
        for i in 0..n {
            model.nodes.push([f64::from(i) * h, 0.0, f64::from(j) * h], 1e-3, NodeKind::Fixed, 0);
        }
    }
    let id = |i: u32, j: u32| j * n + i;
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            // Counter-clockwise seen from +y (outside).
            triangles.push([id(i, j), id(i + 1, j + 1), id(i + 1, j)]);
            triangles.push([id(i, j), id(i, j + 1), id(i + 1, j + 1)]);
        }
    }
    model.surfaces.push(Surface { name: "skin_outer".into(), triangles, grid: None });
    model
}

#[test]
fn sphere_on_held_flat_skin_matches_the_pressure_integral_works() {
    // Sphere of radius r, centre h = r − δ above the plane: a skin point at distance
    // d = √(ρ² + h²) from the centre (ρ from the axis, out to d = r) is pushed along the
    // centre-to-point direction with pressure κ (r − d), whose vertical part is h/d. With
    // ρ dρ = d dd the force on the tool is F = 2π h κ ∫_h^r (r − d) dd = π κ h δ². On a
    // uniform grid every inner node owns h_grid² of skin, and κ = (per-node stiffness) / h_grid².
    // A fine grid (5 mm), and a coarse one (40 mm) with the tool between its nodes, where a
    // contact on nodes alone would feel nothing.
    for (n, spacing, cases) in [
        (41u32, 0.005, vec![(0.002, 0.0), (0.004, 0.0), (0.004, 0.37), (0.008, 0.5)]),
        (5u32, 0.04, vec![(0.004, 0.5), (0.008, 0.3)]),
    ] {
        let model = flat_skin(n, spacing);
        let (r, k): (f64, f64) = (0.012, 300.0);
        let kappa = k / (spacing * spacing);
        let centre_xz = 0.5 * f64::from(n - 1) * spacing;
        for (depth, offset_cells) in cases {
            let offset = offset_cells * spacing;
            let h = r - depth;
            let expected = std::f64::consts::PI * kappa * h * depth * depth;
            let centre = [centre_xz + offset, h, centre_xz - 0.6 * offset];
            let tool = SphereTool { radius: r, stiffness: k, start: centre, velocity: [0.0; 3] };
            let effects = Effects { bone: true, tool: Some(tool), ..Effects::default() };
            let mut sim = Simulation::<f64>::new(&model, IntegrationParameters::default(), effects).unwrap();
            sim.step();
            let fb = sim.tool_feedback();
            assert!(fb.in_contact, "grid {spacing} m, depth {depth}: in contact");
            let rel = (fb.force[1] - expected) / expected;
            eprintln!(
                "grid {spacing} m, depth {depth} m, offset {offset:.4} m: force {:.5} N, closed form {expected:.5} N ({:+.2} %)",
                fb.force[1],
                100.0 * rel
            );
            // The shell's samples are a midpoint rule on sub-triangles at most r/2 apart: the
            // rim of the contact disk is where it is off.
            assert!(rel.abs() < 0.05, "grid {spacing}, depth {depth}: {} N against {expected} N", fb.force[1]);
            assert!(fb.force[0].abs() < 0.05 * expected && fb.force[2].abs() < 0.05 * expected, "{:?}", fb.force);
            // The local stiffness is symmetric and pushes back along y.
            assert!(fb.stiffness[1][1] < 0.0);
            for a in 0..3 {
                for b in 0..3 {
                    assert!((fb.stiffness[a][b] - fb.stiffness[b][a]).abs() < 1e-9);
                }
            }
        }
    }
}

/// A tool given a stiffness per area (`stiffness_per_area` in the scene) presses two grids of
/// the same flat skin, 5 mm and 10 mm, with the same force: the closed form `π κ h δ²` with the
/// scene's κ on both, where a per-node stiffness gives a pressure 4 times larger on the finer
/// grid. The scenes read the skin from model files, as a scene of segmented anatomy would.
#[test]
fn tool_stiffness_per_area_feels_the_same_on_any_grid_works() {
    let dir = std::env::temp_dir().join(format!("lamina_tool_per_area_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (r, depth, kappa): (f64, f64, f64) = (0.012, 0.004, 1.2e7);
    let h = r - depth;
    let expected = std::f64::consts::PI * kappa * h * depth * depth;
    let mut forces = Vec::new();
    for (n, spacing) in [(41u32, 0.005), (21u32, 0.01)] {
        let model_path = dir.join(format!("flat_{n}.xml"));
        lamina_core::io::write_model(&flat_skin(n, spacing), &model_path).unwrap();
        let centre = 0.5 * f64::from(n - 1) * spacing;
        let text = format!(
            "[model]\nkind = \"file\"\npath = \"flat_{n}.xml\"\n[effects]\nbone = true\n[effects.tool]\nsource = \"scripted\"\nradius = {r}\nstiffness_per_area = {kappa:e}\nstart = [{centre}, {h}, {centre}]\n"
        );
        let scene_path = dir.join(format!("flat_{n}.toml"));
        std::fs::write(&scene_path, text).unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        // An inner node of the uniform grid carries a third of six half-squares: spacing².
        let per_node = scene.tool.unwrap().stiffness;
        assert!((per_node - kappa * spacing * spacing).abs() < 1e-9 * per_node, "{spacing} m: {per_node} N/m");
        let model = scene.build_model().unwrap();
        let mut sim = Simulation::<f64>::new(&model, scene.solver.clone(), scene.effects.clone()).unwrap();
        sim.step();
        let force = sim.tool_feedback().force[1];
        eprintln!("grid {spacing} m: {per_node:.1} N/m per node, force {force:.5} N, closed form {expected:.5} N");
        assert!((force - expected).abs() < 0.05 * expected, "grid {spacing} m: {force} N against {expected} N");
        forces.push(force);
    }
    assert!((forces[0] - forces[1]).abs() < 0.05 * forces[0], "{forces:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scene whose model has no outer skin cannot spread a stiffness per area over it: refused,
/// naming the file, the line and the key.
#[test]
fn tool_stiffness_per_area_without_a_skin_fails() {
    let dir = std::env::temp_dir().join(format!("lamina_tool_per_area_no_skin_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut model = flat_skin(3, 0.01);
    model.surfaces.clear();
    lamina_core::io::write_model(&model, dir.join("bare.xml")).unwrap();
    let scene_path = dir.join("bare.toml");
    std::fs::write(
        &scene_path,
        "[model]\nkind = \"file\"\npath = \"bare.xml\"\n[effects.tool]\nsource = \"scripted\"\nradius = 0.01\nstiffness_per_area = 1e7\nstart = [0.0, 0.0, 0.0]\n",
    )
    .unwrap();
    let error = Scene::load(&scene_path).expect_err("no skin to spread the stiffness over").to_string();
    assert!(error.contains("bare.toml:7:") && error.contains("effects.tool.stiffness_per_area"), "{error}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn tool_sliding_along_the_default_limb_always_meets_the_skin_works() {
    // The tool at a constant 8 mm below the skin top, moved along the limb from one row of
    // nodes (z = 120 mm) to the next (z = 80 mm): with contact on nodes only it would meet
    // nothing between the rows and sink through the skin; on the skin's point shell it is
    // pushed back everywhere.
    let scene = Scene::builtin_default();
    let model = scene.build_model().unwrap();
    let tool = scene.tool.unwrap();
    let ToolSource::Haptics { device_origin, .. } = tool.source else { panic!("a haptics tool") };
    let mut forces = Vec::new();
    for step in 0..=8 {
        let dz = 0.005 * f64::from(step);
        let mut effects = scene.effects.clone();
        effects.tool = None;
        let mut sim = Simulation::<f32>::new(&model, scene.solver.clone(), effects).unwrap();
        for k in 0..1500 {
            let press = 0.008 * (f64::from(k) / 500.0).min(1.0);
            let centre = [device_origin[0], device_origin[1] - press, device_origin[2] - dz];
            let sphere =
                SphereTool { radius: tool.radius, stiffness: tool.stiffness, start: centre, velocity: [0.0; 3] };
            sim.effects_mut().tool = Some(sphere);
            sim.step();
        }
        let fb = sim.tool_feedback();
        assert!(sim.state().x.all_finite());
        eprintln!("z = {:.3} m: force {:?} N on {} contact points", device_origin[2] - dz, fb.force, fb.nodes);
        forces.push(fb.force[1]);
    }
    let max = forces.iter().copied().fold(0.0, f64::max);
    assert!(max > 0.03, "the press is felt: {forces:?}");
    assert!(forces.iter().all(|&f| f > 0.4 * max), "the skin pushes back all along: {forces:?}");
}

#[test]
fn small_tool_needs_a_shell_sampled_for_its_radius_works() {
    // A 3 mm tool pressed 1.5 mm into the 40 mm grid at places between the nodes. On a shell
    // sampled for a 12 mm tool (samples up to 6 mm apart) its 2.6 mm contact disk meets few
    // samples or none, and the force is far from the closed form; on one sampled for 3 mm
    // (the scene's `min_radius`, which the core raises smaller commands to) it matches.
    let (n, spacing) = (5u32, 0.04);
    let model = flat_skin(n, spacing);
    let (r, k, depth): (f64, f64, f64) = (0.003, 300.0, 0.0015);
    let kappa = k / (spacing * spacing);
    let h = r - depth;
    let expected = std::f64::consts::PI * kappa * h * depth * depth;
    let mut worst = [0.0_f64; 2];
    for (which, shell_radius) in [0.003, 0.012].into_iter().enumerate() {
        let parked = SphereTool { radius: shell_radius, stiffness: k, start: [1.0, 1.0, 1.0], velocity: [0.0; 3] };
        let effects = Effects { bone: true, tool: Some(parked), ..Effects::default() };
        let mut sim = Simulation::<f64>::new(&model, IntegrationParameters::default(), effects).unwrap();
        for (u, v) in [(0.5, 0.5), (0.37, 0.61), (0.13, 0.29), (0.71, 0.23), (0.5, 0.05)] {
            let centre = [(1.0 + u) * spacing, h, (2.0 + v) * spacing];
            sim.effects_mut().tool = Some(SphereTool { radius: r, stiffness: k, start: centre, velocity: [0.0; 3] });
            sim.step();
            let f = sim.tool_feedback().force[1];
            let rel = (f - expected) / expected;
            eprintln!(
                "shell for {shell_radius} m, tool at ({u}, {v}) of a cell: {f:.5} N, closed form {expected:.5} N ({:+.1} %)",
                100.0 * rel
            );
            worst[which] = worst[which].max(rel.abs());
        }
    }
    assert!(worst[0] < 0.05, "sampled for the tool: worst {:.1} %", 100.0 * worst[0]);
    assert!(worst[1] > 0.2, "sampled for a 12 mm tool: worst {:.1} %", 100.0 * worst[1]);
}
