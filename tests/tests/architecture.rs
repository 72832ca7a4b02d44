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
    let tops = [
        "core/",
        "rt/",
        "bridge/",
        "cli/",
        "haptics/",
        "mesh/",
        "viewer/",
        "tests/",
        "config/",
        "docs/",
        "data/",
        "examples/",
    ];
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

/// The leaf modules (files other than `lib.rs`, `main.rs` and `mod.rs`) of one crate's
/// `src/`, by module path (`solver::lane_block`), with their source text.
fn leaf_modules(src: &Path) -> BTreeMap<String, String> {
    fn walk(dir: &Path, prefix: &str, out: &mut BTreeMap<String, String>) {
        let mut entries: Vec<_> = std::fs::read_dir(dir).expect("source folder").map(|e| e.unwrap().path()).collect();
        entries.sort();
        for path in entries {
            let name = path.file_stem().unwrap().to_string_lossy().to_string();
            if path.is_dir() {
                if name != "bin" {
                    walk(&path, &format!("{prefix}{name}::"), out);
                }
            } else if path.extension().is_some_and(|e| e == "rs") && !["lib", "main", "mod"].contains(&name.as_str()) {
                out.insert(format!("{prefix}{name}"), std::fs::read_to_string(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, "", &mut out);
    out
}

/// Leaf modules that `text` (the module at `path`) names through `crate::` or `super::` in
/// code (comments, doc links included, do not count).
fn referenced_modules(path: &str, text: &str, leaves: &BTreeMap<String, String>) -> BTreeSet<String> {
    let code: String = text.lines().filter(|l| !l.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
    let text = code.as_str();
    let parent: Vec<&str> = path.split("::").collect();
    let parent = &parent[..parent.len() - 1];
    let mut found = BTreeSet::new();
    for (anchor, base) in [("crate::", Vec::new()), ("super::", parent.to_vec())] {
        for (at, _) in text.match_indices(anchor) {
            let rest = &text[at + anchor.len()..];
            let tail: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_' || *c == ':').collect();
            let mut segments: Vec<String> = base.iter().map(|s| s.to_string()).collect();
            segments.extend(tail.split("::").filter(|s| !s.is_empty()).map(str::to_string));
            // The longest prefix that is a leaf module.
            for len in (1..=segments.len()).rev() {
                let candidate = segments[..len].join("::");
                if leaves.contains_key(&candidate) {
                    if candidate != path {
                        found.insert(candidate);
                    }
                    break;
                }
            }
        }
    }
    found
}

#[test]
fn no_two_modules_import_each_other_works() {
    let root = root();
    let mut circles = Vec::new();
    for krate in ["core", "rt", "mesh", "bridge", "cli", "haptics", "viewer"] {
        let leaves = leaf_modules(&root.join(krate).join("src"));
        assert!(!leaves.is_empty(), "{krate}/src has modules");
        let refs: BTreeMap<&String, BTreeSet<String>> =
            leaves.iter().map(|(path, text)| (path, referenced_modules(path, text, &leaves))).collect();
        for (a, targets) in &refs {
            for b in targets {
                if a.as_str() < b.as_str() && refs[b].contains(a.as_str()) {
                    circles.push(format!("{krate}: {a} <-> {b}"));
                }
            }
        }
    }
    assert!(circles.is_empty(), "modules that import each other: {circles:#?}");
}

#[test]
fn module_reference_reader_finds_imports_works() {
    // The reader above, on a hand-made pair: `a` names `b` through `crate::`, `b` names `a`
    // through `super::`, `c` names `a` in a doc comment only.
    let leaves: BTreeMap<String, String> = [
        ("x::a".to_string(), "use crate::x::b::Thing;".to_string()),
        ("x::b".to_string(), "fn f() { super::a::g() }".to_string()),
        ("x::c".to_string(), "/// See [`crate::x::a`].\nuse std::fmt;".to_string()),
    ]
    .into();
    assert_eq!(referenced_modules("x::a", &leaves["x::a"], &leaves), BTreeSet::from(["x::b".to_string()]));
    assert_eq!(referenced_modules("x::b", &leaves["x::b"], &leaves), BTreeSet::from(["x::a".to_string()]));
    assert!(referenced_modules("x::c", &leaves["x::c"], &leaves).is_empty());
}
