//! A core running a model file (not the built-in scene): the viewer draws it and needs no
//! scene file. `lamina generate` writes a 30 x 8 limb (1,530 nodes; the built-in scene has
//! 1,032), a scene runs it from the file, and:
//! - the model the live source builds from the core's topology message alone equals the one
//!   built from the file itself (grids with their seam, springs with their tissue, the
//!   scene's tool radius);
//! - the `lamina-viewer` binary, given only the service prefix, draws it headless and names
//!   it with the file's node, grid and spring counts.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use lamina_core::io::read_model;
use lamina_core::scene::{DEFAULT_SCENE_TOML, Scene};
use lamina_viewer::source::{FrameSource, LiveSource, SourceEvent};
use lamina_viewer::view_model::ViewModel;

mod support;
use support::lamina_bin;

/// The built-in scene with its `[model]` (and fitted `[model.springs]`) replaced by the file.
fn scene_running(model_file: &str) -> String {
    let start = DEFAULT_SCENE_TOML.find("[model]").expect("the default scene has a [model] table");
    let end = DEFAULT_SCENE_TOML.find("[solver]").expect("the default scene has a [solver] table");
    format!(
        "{}[model]\nkind = \"file\"\npath = \"{model_file}\"\n\n{}",
        &DEFAULT_SCENE_TOML[..start],
        &DEFAULT_SCENE_TOML[end..]
    )
}

fn generate(dir: &Path) {
    let out = Command::new(lamina_bin())
        .current_dir(dir)
        .args(["generate", "--cylinder", "30x8", "--length", "0.24", "--out", "limb30x8.xml"])
        .output()
        .expect("running lamina generate");
    assert!(out.status.success(), "lamina generate failed: {}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn core_on_a_model_file_is_drawn_from_its_topology_alone_works() {
    let dir = std::env::temp_dir().join(format!("lamina_file_model_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    generate(&dir);
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, scene_running("limb30x8.xml")).unwrap();
    // What the file holds, read here independently of any process.
    let scene = Scene::load(&scene_path).expect("the test scene loads");
    let file_model = read_model(dir.join("limb30x8.xml")).expect("the generated file loads");
    let builtin_nodes = Scene::builtin_default().build_model().unwrap().nodes.len();
    assert_ne!(file_model.nodes.len(), builtin_nodes, "the file's model differs from the built-in scene's");
    let expected = ViewModel {
        tool_radius_m: scene.tool.expect("the scene has a tool").radius as f32,
        ..ViewModel::from_core_model(&file_model)
    };

    let prefix = format!("t_vfile_{}", std::process::id());
    let mut core = Command::new(lamina_bin())
        .args(["run", "--quiet", "--prefix", &prefix, "--seconds", "30", "--scene"])
        .arg(&scene_path)
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("starting lamina run");
    let mut source = LiveSource::open(&prefix).expect("subscribing to the core");
    let deadline = Instant::now() + Duration::from_secs(30);
    let got = loop {
        assert!(Instant::now() < deadline, "no model from the core within 30 s");
        if let SourceEvent::Model(m) = source.next_event(Duration::from_millis(200)) {
            break m;
        }
    };
    assert_eq!(got.node_count, file_model.nodes.len());
    assert_eq!((got.grids.len(), got.springs.len()), (expected.grids.len(), expected.springs.len()));
    assert_eq!(got, expected, "the model from the wire is the file's");

    let viewer = Command::new(env!("CARGO_BIN_EXE_lamina-viewer"))
        .args(["--prefix", &prefix, "--frames", "3", "--size", "320x240", "--samples", "1", "--out"])
        .arg(dir.join("frames"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("running lamina-viewer");
    let _ = core.kill();
    let _ = core.wait();
    let log = String::from_utf8_lossy(&viewer.stdout);
    assert!(viewer.status.success(), "lamina-viewer failed: {log}\n{}", String::from_utf8_lossy(&viewer.stderr));
    let line = format!(
        "model '{}': {} nodes, {} grids, {} springs",
        file_model.name,
        file_model.nodes.len(),
        expected.grids.len(),
        file_model.springs.len()
    );
    assert!(log.contains(&line), "expected '{line}' in:\n{log}");
    let pngs = std::fs::read_dir(dir.join("frames")).unwrap().filter_map(Result::ok);
    assert_eq!(pngs.filter(|e| e.path().extension().is_some_and(|x| x == "png")).count(), 3, "{log}");
    let _ = std::fs::remove_dir_all(&dir);
}
