//! ARCHITECTURE.md stays true: every repository path it names exists, and the physics core
//! does not depend on the IPC layer.

use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

/// Back-quoted tokens that look like repository paths: they start with a top-level folder
/// of the workspace.
fn named_paths(text: &str) -> Vec<String> {
    let tops = ["core/", "rt/", "bridge/", "mesh/", "viewer/", "tests/", "config/", "docs/"];
    text.split('`')
        .skip(1)
        .step_by(2)
        .filter(|t| tops.iter().any(|p| t.starts_with(p)) && !t.contains(' '))
        .map(str::to_string)
        .collect()
}

#[test]
fn architecture_named_paths_exist_works() {
    let root = root();
    let text = std::fs::read_to_string(root.join("ARCHITECTURE.md")).expect("ARCHITECTURE.md at the root");
    let paths = named_paths(&text);
    assert!(paths.len() > 20, "expected many paths, found {paths:?}");
    let missing: Vec<_> = paths.iter().filter(|p| !root.join(p.trim_end_matches('/')).exists()).collect();
    assert!(missing.is_empty(), "ARCHITECTURE.md names paths that do not exist: {missing:?}");
}

#[test]
fn core_physics_knows_nothing_of_ipc_works() {
    let root = root();
    let mut stack = vec![root.join("core/src")];
    let mut offenders = Vec::new();
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                if !path.ends_with("cli") {
                    stack.push(path);
                }
            } else if path.extension().is_some_and(|e| e == "rs") && !path.ends_with("main.rs") {
                let text = std::fs::read_to_string(&path).unwrap();
                let code: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect();
                if ["iceoryx2::", "lamina_bridge", "wgpu::", "use iceoryx2"].iter().any(|p| code.contains(p)) {
                    offenders.push(path);
                }
            }
        }
    }
    assert!(offenders.is_empty(), "physics modules that name the IPC or window layers: {offenders:?}");
}
