//! Incision on the living limb (config/scenes/limb-in-vivo.toml): the springs a blade's sweep
//! cuts are those an independent brute-force oracle finds, bone is never cut, the cut model
//! stays valid, a press does not cut until the skin gives, and the pre-strained skin gapes.

use lamina_core::hand_tool::HandTool;
use lamina_core::incision::{Blade, BladeState, Scalpel, ScalpelSettings, Sweep};
use lamina_core::model::{Model, Tissue};
use lamina_core::scene::Scene;
use lamina_core::solver::Simulation;
use proptest::prelude::*;

fn living_limb() -> (Scene, Model) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/limb-in-vivo.toml");
    let scene = Scene::load(&path).expect("the living limb scene");
    let model = scene.build_model().expect("the living limb builds");
    (scene, model)
}

fn simulation(scene: &Scene, model: &Model) -> (Simulation<f64>, Scalpel) {
    let tool = scene.tool.expect("the living limb has a tool");
    let (sim, _) =
        HandTool::simulation::<f64>(model, scene.solver.clone(), scene.effects.clone(), tool).expect("simulation");
    let scalpel = Scalpel::new(model, &sim, &tool, ScalpelSettings::default()).expect("cuttable");
    (sim, scalpel)
}

/// Six times the signed volume of the tetrahedron `(a, b, c, d)`.
fn orient(a: [f64; 3], b: [f64; 3], c: [f64; 3], d: [f64; 3]) -> f64 {
    let (u, v, w) = ([0, 1, 2].map(|k| b[k] - a[k]), [0, 1, 2].map(|k| c[k] - a[k]), [0, 1, 2].map(|k| d[k] - a[k]));
    u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0])
}

/// The oracle: segment `p`-`q` crosses triangle `t` when `p` and `q` lie on opposite sides of
/// its plane and the segment's line passes inside all three of its edges (orientation signs,
/// not the library's parametric test).
fn oracle_crosses_triangle(p: [f64; 3], q: [f64; 3], t: [[f64; 3]; 3]) -> bool {
    let (sp, sq) = (orient(t[0], t[1], t[2], p), orient(t[0], t[1], t[2], q));
    if sp * sq > 0.0 || (sp == 0.0 && sq == 0.0) {
        return false;
    }
    let e = [orient(p, q, t[0], t[1]), orient(p, q, t[1], t[2]), orient(p, q, t[2], t[0])];
    e.iter().all(|&v| v >= 0.0) || e.iter().all(|&v| v <= 0.0)
}

/// Every spring of `model` at positions `x` the sweep crosses, but those of bone, by
/// testing all of them.
fn oracle(model: &Model, x: &[[f64; 3]], sweep: &Sweep) -> Vec<usize> {
    let (f, t) = (sweep.from, sweep.to);
    let triangles = [[f.tip, f.back, t.back], [f.tip, t.back, t.tip]];
    (0..model.springs.len())
        .filter(|&s| model.layers[model.springs.layer[s] as usize].tissue != Tissue::Bone)
        .filter(|&s| {
            let (p, q) = (x[model.springs.a[s] as usize], x[model.springs.b[s] as usize]);
            triangles.iter().any(|&tri| oracle_crosses_triangle(p, q, tri))
        })
        .collect()
}

fn positions(sim: &Simulation<f64>) -> Vec<[f64; 3]> {
    (0..sim.state().x.len()).map(|i| sim.state().x.get_f64(i)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn a_sweep_cuts_the_springs_the_brute_force_oracle_finds_works(
        angle in 1.2f64..1.9, z0 in 0.04f64..0.2, depth in 0.0f64..0.03,
        dz in -0.03f64..0.03, da in -0.2f64..0.2, tilt in -0.3f64..0.3,
    ) {
        let (scene, model) = living_limb();
        let (mut sim, mut scalpel) = simulation(&scene, &model);
        // A blade 3 cm long whose tip sits `depth` under the 50 mm skin, tilted about z.
        let blade = |a: f64, z: f64| {
            let r = 0.05 - depth;
            let tip = [r * a.cos(), r * a.sin(), z];
            let h = 0.5 * tilt;
            Blade::from_pose(tip, [0.0, 0.0, h.sin(), h.cos()], 0.03)
        };
        let sweep = Sweep { from: blade(angle, z0), to: blade(angle + da, z0 + dz) };
        let x = positions(&sim);
        let mut expected = oracle(&model, &x, &sweep);
        scalpel.cut_along(&mut sim, &sweep);
        let mut got: Vec<usize> = scalpel.cut_order().iter().map(|&s| s as usize).collect();
        expected.sort_unstable();
        got.sort_unstable();
        prop_assert_eq!(got, expected);
    }
}

#[test]
fn a_cut_to_the_bone_leaves_bone_whole_and_the_model_valid_works() {
    let (scene, model) = living_limb();
    let (mut sim, mut scalpel) = simulation(&scene, &model);
    // A 6 cm edge from 5 mm inside the bone (radius 15 mm) up through the skin, swept 5 cm
    // along the axis at the top of the limb.
    let a = 1.7f64;
    let blade = |z: f64| Blade::from_pose([0.01 * a.cos(), 0.01 * a.sin(), z], [0.0, 0.0, 0.0, 1.0], 0.06);
    let n = scalpel.cut_along(&mut sim, &Sweep { from: blade(0.095), to: blade(0.145) });
    let totals = scalpel.totals();
    assert!(totals.springs_cut.iter().all(|&c| c > 0), "every soft layer cut: {:?}", totals.springs_cut);
    assert_eq!(n as u64, totals.springs_cut.iter().sum::<u64>());
    for &s in scalpel.cut_order() {
        assert_ne!(model.layers[model.springs.layer[s as usize] as usize].tissue, Tissue::Bone);
    }
    // The same sweep again cuts nothing more.
    assert_eq!(scalpel.cut_along(&mut sim, &Sweep { from: blade(0.095), to: blade(0.145) }), 0);
    let cut = scalpel.cut_model(&model);
    assert_eq!(cut.springs.len(), model.springs.len() - n as usize);
    assert!(cut.cells.len() < model.cells.len());
    cut.validate().expect("the cut model is valid");
    // The cut limb steps on, finite.
    for _ in 0..200 {
        sim.step();
    }
    assert!((0..sim.state().x.len()).all(|i| sim.state().x.get_f64(i).iter().all(|c| c.is_finite())));
}

#[test]
fn a_press_below_the_puncture_force_cuts_nothing_and_a_stab_then_cuts_works() {
    let (scene, model) = living_limb();
    let tool = scene.tool.unwrap();
    let (mut sim, _) = HandTool::simulation::<f64>(&model, scene.solver.clone(), scene.effects.clone(), tool).unwrap();
    let stab = ScalpelSettings { puncture_force: 1.22, ..ScalpelSettings::default() };
    let mut scalpel = Scalpel::new(&model, &sim, &tool, ScalpelSettings::default()).unwrap();
    let mut stabbing = Scalpel::new(&model, &sim, &tool, stab).unwrap();
    let mut sim2 = HandTool::simulation::<f64>(&model, scene.solver.clone(), scene.effects.clone(), tool).unwrap().0;
    // Straight down at the top, mid-length, from 2 mm above the skin to 6 mm into it in 0.4 s.
    let top = 0.05;
    let at = |y: f64, z: f64| Blade::from_pose([0.003, y, z], [0.0, 0.0, 0.0, 1.0], 0.01);
    let mut peak_press = 0.0f64;
    for k in 0..=400 {
        let y = top + 0.002 - 0.008 * f64::from(k) / 400.0;
        let t1 = scalpel.move_to(&mut sim, at(y, 0.12), 1e-3);
        sim.step();
        peak_press = peak_press.max(scalpel.feedback(&sim).force[1]);
        assert_eq!(t1.springs_cut, 0);
        stabbing.move_to(&mut sim2, at(y, 0.12), 1e-3);
        sim2.step();
    }
    // The 36 N blade-edge threshold is not reached by a 6 mm press: still outside, uncut,
    // the tissue pushing the blade up.
    assert_eq!(scalpel.state(), BladeState::Outside);
    assert_eq!(sim.cuts(), 0);
    assert!(peak_press > 0.05, "the press is felt: {peak_press} N");
    // The point-first stab (1.22 N) gave, and drawing the blade 3 cm along cuts skin and
    // fat and is resisted against the motion.
    assert_eq!(stabbing.state(), BladeState::Cutting);
    assert_eq!(stabbing.totals().punctures, 1);
    let mut resisted = 0.0f64;
    for k in 1..=1000 {
        let z = 0.12 + 0.03 * f64::from(k) / 1000.0;
        let tick = stabbing.move_to(&mut sim2, at(top - 0.006, z), 1e-3);
        sim2.step();
        resisted = resisted.max(-tick.force[2]);
    }
    let totals = stabbing.totals();
    assert!(totals.springs_cut[0] > 0 && totals.springs_cut[1] > 0, "{totals:?}");
    // Skin 1,700 N/m over at most its 2 mm, fat 170 N/m over the rest of the 6 mm.
    assert!(resisted > 0.0 && resisted <= 1700.0 * 0.0025 + 170.0 * 0.006, "{resisted} N");
}

fn incision_scene(in_vivo: &str) -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/incision.toml");
    let text = std::fs::read_to_string(&path).expect("the incision scene");
    let (head, tail) = text.split_once("[in_vivo]").expect("the scene has [in_vivo]");
    let rest = &tail[tail.find("\n[").expect("a table after [in_vivo]")..];
    Scene::from_toml_str(&format!("{head}[in_vivo]\n{in_vivo}\n{rest}"), Some(&path)).expect("scene")
}

#[test]
fn a_cut_through_prestrained_skin_gapes_and_without_prestrain_stays_shut_works() {
    use lamina_core::study::{IncisionCase, incision_study};
    let case = IncisionCase::default();
    let tense = incision_study(&incision_scene("skin_prestrain = 0.03"), &case).expect("study");
    let slack = incision_study(&incision_scene("skin_prestrain = 0.0"), &case).expect("study");
    assert!(tense.finite && slack.finite);
    assert!(
        tense.springs_cut[0] > 0 && tense.springs_cut[1] > 0 && tense.springs_cut[2] == 0,
        "{:?}",
        tense.springs_cut
    );
    assert!(tense.punctures == 1 && tense.gaps.len() >= 3, "{} punctures, {} gaps", tense.punctures, tense.gaps.len());
    // Pre-strained skin opens by millimetres, widest mid-cut (Griffith's elliptical opening),
    // below the closed form for a free sheet (the fat holds the skin).
    let (lo, hi) = tense.closed_form_gap_m;
    assert!((lo - 0.003).abs() < 1e-12 && (hi - 0.0045).abs() < 1e-12, "2 L eps, 3 L eps: {lo} {hi}");
    assert!(tense.max_gap() > 0.001 && tense.max_gap() < hi, "{:?}", tense.gaps);
    let mid = tense.gaps.iter().min_by(|a, b| (a.0 - 0.12).abs().total_cmp(&(b.0 - 0.12).abs())).unwrap();
    let ends = tense.gaps.iter().filter(|g| (g.0 - 0.12).abs() > 0.015);
    for end in ends {
        assert!(end.1 < mid.1, "the ends open less than the middle: {:?}", tense.gaps);
    }
    // Without pre-strain the cut stays shut (under 0.05 mm).
    assert!(slack.max_gap() < 5e-5, "{:?}", slack.gaps);
    // Two runs give the same bits.
    let again = incision_study(&incision_scene("skin_prestrain = 0.03"), &case).expect("study");
    let bits = |r: &lamina_core::study::IncisionResult| {
        r.final_positions.iter().flat_map(|p| p.map(f64::to_bits)).collect::<Vec<u64>>()
    };
    assert_eq!(bits(&tense), bits(&again));
}

#[test]
fn a_piece_cut_free_stays_finite_and_where_it_was_works() {
    let (scene, model) = living_limb();
    let (mut sim, _) = simulation(&scene, &model);
    // Free a patch of outer skin: every spring of its nodes and their neighbours cut.
    let node = (0..model.nodes.len()).find(|&i| model.nodes.position[i][1] > 0.049).expect("a top skin node");
    let springs = &model.springs;
    let touching = |i: usize| -> Vec<usize> {
        (0..springs.len()).filter(|&s| springs.a[s] as usize == i || springs.b[s] as usize == i).collect()
    };
    let mut freed = vec![node];
    freed.extend(touching(node).into_iter().map(|s| (springs.a[s] + springs.b[s]) as usize - node));
    let mut cut = 0;
    for &i in &freed {
        for s in touching(i) {
            cut += usize::from(sim.cut_spring(s));
        }
    }
    assert!(cut > freed.len(), "{cut} springs cut around {} nodes", freed.len());
    assert_eq!(sim.cuts() as usize, cut);
    let start = sim.state().x.get_f64(node);
    for _ in 0..1000 {
        sim.step();
    }
    let x = sim.state().x.get_f64(node);
    assert!(x.iter().all(|c| c.is_finite()));
    // No spring holds it and no gravity pulls it: it stays within 1 mm, its speed damped out.
    let moved = ((x[0] - start[0]).powi(2) + (x[1] - start[1]).powi(2) + (x[2] - start[2]).powi(2)).sqrt();
    assert!(moved < 1e-3, "moved {moved} m");
    let v = sim.state().v.get_f64(node);
    assert!(v.iter().all(|c| c.abs() < 1e-3), "{v:?}");
}
