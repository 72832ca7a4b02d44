//! Every scene shipped in `config/scenes/` loads, builds its model (the thigh reads the
//! repository's `data/bodyparts3d-leg/`), and steps a tenth of a second at its own rate with a
//! finite state: a scene file that drifts from the parser or from the data it names fails here,
//! not in front of a user.

use lamina_core::scene::Scene;
use lamina_core::solver::Simulation;
use std::path::PathBuf;

#[test]
fn every_shipped_scene_loads_builds_and_steps_works() {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../config/scenes"));
    let mut paths: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 4, "the shipped scenes: {paths:?}");
    for path in &paths {
        let scene = Scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let model = scene.build_model().unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut sim = Simulation::<f32>::new(&model, scene.solver.clone(), scene.effects.clone())
            .unwrap_or_else(|e| panic!("{}: {e:?}", path.display()));
        let frames = (scene.rate_hz / 10) as usize;
        for _ in 0..frames {
            sim.step();
        }
        assert!(sim.state().x.all_finite() && sim.state().v.all_finite(), "{}: state finite", path.display());
        eprintln!("{}: {} nodes, {} springs, {frames} frames", path.display(), model.nodes.len(), model.springs.len());
    }
}

#[test]
fn builtin_default_scene_is_the_documented_limb_works() {
    // The README's default: the generator's cylindrical limb on a 24 x 6 grid. Its node count
    // is the generator's closed form W(7H + 1): skin W(3H + 1), fat and bone 2WH each
    // (docs/generator.md).
    let model = Scene::builtin_default().build_model().unwrap();
    let (w, h) = (24, 6);
    assert_eq!(model.nodes.len(), w * (7 * h + 1));
    assert_eq!(model.springs.len(), 7_608, "the README's spring count");
}

/// Every shipped scene with a haptics tool puts the device's workspace centre one tool radius
/// out from the outer skin (within 2 mm), so device z = 0 is the tool just touching and a
/// press goes into the tissue.
#[test]
fn shipped_haptics_tools_start_one_radius_from_the_skin_works() {
    use lamina_core::scene::ToolSource;
    let mut checked = Vec::new();
    for entry in std::fs::read_dir(PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../config/scenes")).unwrap() {
        let path = entry.unwrap().path();
        let scene = Scene::load(&path).unwrap();
        let Some(tool) = scene.tool else { continue };
        let ToolSource::Haptics { device_origin, .. } = tool.source else { continue };
        let model = scene.build_model().unwrap();
        let skin = model.surfaces.iter().find(|s| s.name == "skin_outer").expect("an outer skin");
        let nearest = skin
            .triangles
            .iter()
            .flatten()
            .map(|&v| {
                let p = model.nodes.position[v as usize];
                (0..3).map(|c| (p[c] - device_origin[c]).powi(2)).sum::<f64>().sqrt()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(
            (nearest - tool.radius).abs() < 2e-3,
            "{}: the device centre is {nearest} m from the skin",
            path.display()
        );
        checked.push(path.file_name().unwrap().to_string_lossy().to_string());
    }
    checked.sort();
    assert!(checked.contains(&"thigh.toml".to_string()) && checked.len() >= 4, "{checked:?}");
}
