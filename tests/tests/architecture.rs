//! ARCHITECTURE.md stays true: every repository path it names exists, and the crates depend on
//! each other as it says, read from cargo's resolved dependency graph (`cargo metadata`).

use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

/// Back-quoted tokens that look like repository paths: they start with a top-level folder
/// of the workspace.
fn named_paths(text: &str) -> Vec<String> {
    let tops =
        ["core/", "rt/", "bridge/", "cli/", "haptics/", "mesh/", "viewer/", "tests/", "config/", "docs/", "data/"];
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

/// The workspace's resolved dependency graph: package name to the names of its normal
/// (non-dev, non-build) dependencies, and to the names of its direct dependencies of any kind.
struct Graph {
    normal: BTreeMap<String, BTreeSet<String>>,
    direct_any: BTreeMap<String, BTreeSet<String>>,
}

fn graph() -> Graph {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .args(["metadata", "--format-version", "1"])
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("running `{cargo} metadata`: {e}"));
    assert!(out.status.success(), "cargo metadata failed: {}", String::from_utf8_lossy(&out.stderr));
    let meta: Value = serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON");
    let names: BTreeMap<&str, &str> = meta["packages"]
        .as_array()
        .expect("packages")
        .iter()
        .map(|p| (p["id"].as_str().expect("id"), p["name"].as_str().expect("name")))
        .collect();
    let mut graph = Graph { normal: BTreeMap::new(), direct_any: BTreeMap::new() };
    for node in meta["resolve"]["nodes"].as_array().expect("resolve.nodes") {
        let name = names[node["id"].as_str().expect("node id")].to_string();
        for dep in node["deps"].as_array().expect("deps") {
            let dep_name = names[dep["pkg"].as_str().expect("dep pkg")].to_string();
            let kinds = dep["dep_kinds"].as_array().expect("dep_kinds");
            if kinds.iter().any(|k| k["kind"].is_null()) {
                graph.normal.entry(name.clone()).or_default().insert(dep_name.clone());
            }
            graph.direct_any.entry(name.clone()).or_default().insert(dep_name);
        }
    }
    graph
}

/// Every package `package` pulls in as a normal dependency, directly or transitively.
fn normal_closure(graph: &Graph, package: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut stack = vec![package.to_string()];
    while let Some(p) = stack.pop() {
        for d in graph.normal.get(&p).into_iter().flatten() {
            if seen.insert(d.clone()) {
                stack.push(d.clone());
            }
        }
    }
    seen
}

fn forbidden_in(graph: &Graph, package: &str, forbidden: &[&str]) -> Vec<String> {
    let closure = normal_closure(graph, package);
    assert!(!closure.is_empty(), "{package} not found in cargo metadata (or has no dependencies)");
    forbidden.iter().filter(|f| closure.contains(**f)).map(|f| f.to_string()).collect()
}

#[test]
fn core_library_depends_on_no_ipc_window_or_cli_crate_works() {
    let graph = graph();
    let found = forbidden_in(
        &graph,
        "lamina-core",
        &["iceoryx2", "clap", "wgpu", "plotters", "indicatif", "lamina-bridge", "lamina-haptics"],
    );
    assert!(found.is_empty(), "lamina-core depends (normally, maybe transitively) on {found:?}");
}

#[test]
fn bridge_depends_on_neither_physics_nor_haptics_works() {
    let graph = graph();
    let found = forbidden_in(&graph, "lamina-bridge", &["lamina-core", "lamina-haptics", "clap", "wgpu"]);
    assert!(found.is_empty(), "lamina-bridge depends (normally, maybe transitively) on {found:?}");
    let direct = &graph.direct_any["lamina-bridge"];
    assert!(!direct.contains("lamina-haptics"), "lamina-bridge names lamina-haptics among its dependencies");
}

#[test]
fn haptics_knows_nothing_of_the_physics_works() {
    let graph = graph();
    let found = forbidden_in(&graph, "lamina-haptics", &["lamina-core", "wgpu"]);
    assert!(found.is_empty(), "lamina-haptics depends (normally, maybe transitively) on {found:?}");
}
