//! ARCHITECTURE.md stays true: every repository path it names exists, the crates depend on
//! each other as it says, read from cargo's resolved dependency graph (`cargo metadata`), and no
//! crate's modules import each other in a cycle of any length.

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

// Import cycles between the modules of one crate.
//
// The reader below builds each crate's module graph from its source text, without compiling:
// - the module tree follows `mod name;` (to `name.rs` or `name/mod.rs`, where rustc looks) and
//   inline `mod name { .. }` blocks from every crate root `cargo metadata` lists (each target of
//   each workspace package: libraries, binaries, tests, examples, benches, build scripts);
// - comments, doc comments, strings and character literals are blanked first, so a doc link or a
//   message that names `crate::x` is no reference;
// - references are `use` trees (groups, `self`, `as`, globs) and paths in code whose first
//   segment is `crate`, `$crate`, `super`, `self`, a child module or a name a `use` brought in;
// - a path is followed through `use` aliases to the module that defines the item, so
//   `crate::solver::Simulation`, re-exported by `solver/mod.rs`, is a reference to
//   `solver/simulation.rs`. A `pub use` only forwards a name: it counts as a reference of the
//   file that holds it when that file names the item again;
// - paths into other crates, macros' textual scope and items defined by macros are not followed.
// One node per file: an inline module belongs to its file. The graph is the shipped code's: a
// module under `#[cfg(test)]` (a `mod tests` block, a test-only file) adds no edge, since a unit
// test may build its fixture with a higher layer (solver tests load the built-in scene) and is
// compiled into the test binary only. A `#[path]` attribute, which the reader does not follow,
// is reported as an error.

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Ident(String),
    PathSep,
    Punct(char),
}

/// A token and its 1-based line.
struct Token {
    tok: Tok,
    line: usize,
}

/// The identifiers, `::` and punctuation of Rust source `text`, without comments, string,
/// character and number literals, lifetimes or labels.
fn tokens(text: &str) -> Vec<Token> {
    let c: Vec<char> = text.chars().collect();
    let at = |i: usize| c.get(i).copied().unwrap_or('\0');
    let ident_start = |ch: char| ch.is_alphabetic() || ch == '_';
    let ident_char = |ch: char| ch.is_alphanumeric() || ch == '_';
    let mut out = Vec::new();
    let mut line = 1;
    let mut i = 0;
    // Skips a quoted literal whose opening quote is at `i`, counting lines; returns the index
    // after the closing quote.
    let skip_quoted = |mut i: usize, quote: char, line: &mut usize| {
        i += 1;
        while i < c.len() && c[i] != quote {
            if c[i] == '\\' {
                i += 1;
            }
            if at(i) == '\n' {
                *line += 1;
            }
            i += 1;
        }
        i + 1
    };
    while i < c.len() {
        let ch = c[i];
        let raw_prefix = match (ch, at(i + 1)) {
            ('r', '"' | '#') => Some(1),
            ('b' | 'c', 'r') if matches!(at(i + 2), '"' | '#') => Some(2),
            _ => None,
        };
        let raw_hashes = raw_prefix.map(|p| (p, (i + p..c.len()).take_while(|&k| c[k] == '#').count()));
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && at(i + 1) == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && at(i + 1) == '*' {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && at(i + 1) == '*' {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && at(i + 1) == '/' {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    line += usize::from(c[i] == '\n');
                    i += 1;
                }
            }
        } else if let Some((p, n)) = raw_hashes.filter(|&(p, n)| at(i + p + n) == '"') {
            // r"..", r#".."#, br"..", cr"..": ends at a quote followed by the same hashes.
            i += p + n + 1;
            while i < c.len() && !(c[i] == '"' && (1..=n).all(|k| at(i + k) == '#')) {
                line += usize::from(c[i] == '\n');
                i += 1;
            }
            i += n + 1;
        } else if ch == '"' || (matches!(ch, 'b' | 'c') && at(i + 1) == '"') {
            i = skip_quoted(if ch == '"' { i } else { i + 1 }, '"', &mut line);
        } else if ch == '\'' || (ch == 'b' && at(i + 1) == '\'') {
            let q = if ch == '\'' { i } else { i + 1 };
            if at(q + 1) == '\\' {
                i = skip_quoted(q, '\'', &mut line);
            } else if at(q + 2) == '\'' {
                i = q + 3;
            } else {
                // A lifetime or a label.
                i = q + 1;
                while i < c.len() && ident_char(c[i]) {
                    i += 1;
                }
            }
        } else if ch == 'r' && at(i + 1) == '#' && ident_start(at(i + 2)) {
            // A raw identifier, r#type.
            i += 2;
        } else if ident_start(ch) || (ch == '$' && ident_start(at(i + 1))) {
            let start = i;
            i += 1;
            while i < c.len() && ident_char(c[i]) {
                i += 1;
            }
            out.push(Token { tok: Tok::Ident(c[start..i].iter().collect()), line });
        } else if ch.is_ascii_digit() {
            while i < c.len() && ident_char(c[i]) {
                i += 1;
            }
        } else if ch == ':' && at(i + 1) == ':' {
            out.push(Token { tok: Tok::PathSep, line });
            i += 2;
        } else {
            out.push(Token { tok: Tok::Punct(ch), line });
            i += 1;
        }
    }
    out
}

/// One name a `use` brings into a module: `path` as written (relative to the module), the name
/// it is known by (`None` for a glob), whether the `use` is `pub` in any form, and its line.
struct UseItem {
    path: Vec<String>,
    name: Option<String>,
    public: bool,
    line: usize,
}

/// One module, from a file or an inline block.
struct Module {
    /// Path from the crate root (`["solver", "params"]`; empty for the root).
    path: Vec<String>,
    parent: Option<usize>,
    /// The file that holds the module (an index into `Crate::files`).
    file: usize,
    /// The folder where `mod x;` inside this module looks for `x.rs` and `x/mod.rs`.
    dir: PathBuf,
    children: BTreeMap<String, usize>,
    uses: Vec<UseItem>,
    /// Paths in code that may name a module of the crate, with their lines.
    paths: Vec<(Vec<String>, usize)>,
    /// Whether the module or one around it is under `#[cfg(test)]`.
    test_only: bool,
}

/// One file of a crate: where it is, the module it is, and how often each identifier occurs.
struct SourceFile {
    path: PathBuf,
    module: usize,
    idents: BTreeMap<String, usize>,
}

/// One crate's module tree as read from its source (module 0 is the root).
struct Crate {
    files: Vec<SourceFile>,
    modules: Vec<Module>,
    /// Module files that could not be found or read, and `#[path]` attributes.
    errors: Vec<String>,
}

/// What a name means inside a module: a module, or an item defined in a module.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Found {
    Module(usize),
    ItemIn(usize),
}

/// Deep enough for any chain of `use` aliases in the workspace; stops alias loops.
const MAX_ALIAS_DEPTH: usize = 32;

/// Parses one use tree at `t[*i]` below `prefix`, pushing its names to `out` (`public` and the
/// line are filled in by the caller).
fn use_tree(t: &[Token], i: &mut usize, prefix: &[String], out: &mut Vec<(Vec<String>, Option<String>)>) {
    let tok = |i: usize| t.get(i).map(|t| &t.tok);
    let mut path = prefix.to_vec();
    if tok(*i) == Some(&Tok::PathSep) {
        // `::name`: an external crate, which resolution leaves alone.
        path.push("::".into());
        *i += 1;
    }
    loop {
        match tok(*i) {
            Some(Tok::Ident(s)) => {
                path.push(s.clone());
                *i += 1;
            }
            Some(Tok::Punct('*')) => {
                *i += 1;
                out.push((path, None));
                return;
            }
            Some(Tok::Punct('{')) => {
                *i += 1;
                while let Some(next) = tok(*i) {
                    match next {
                        Tok::Punct('}') => {
                            *i += 1;
                            break;
                        }
                        Tok::Punct(',') => *i += 1,
                        _ => {
                            let before = *i;
                            use_tree(t, i, &path, out);
                            if *i == before {
                                *i += 1;
                            }
                        }
                    }
                }
                return;
            }
            _ => break,
        }
        if tok(*i) == Some(&Tok::PathSep) {
            *i += 1;
        } else {
            break;
        }
    }
    if path.last().is_some_and(|s| s == "self") {
        path.pop();
    }
    let mut name = path.last().cloned();
    if tok(*i) == Some(&Tok::Ident("as".into())) {
        if let Some(Tok::Ident(alias)) = tok(*i + 1) {
            name = Some(alias.clone());
        }
        *i += 2;
    }
    if name.is_some() {
        out.push((path, name));
    }
}

/// The index of the `pub` or `pub(..)` in front of the item whose first keyword is at `t[i]`,
/// or `i` when it has none.
fn item_start(t: &[Token], i: usize) -> usize {
    let mut k = i;
    if k > 0 && t[k - 1].tok == Tok::Punct(')') {
        while k > 0 && t[k - 1].tok != Tok::Punct('(') {
            k -= 1;
        }
        k = k.saturating_sub(1);
    }
    if k > 0 && t[k - 1].tok == Tok::Ident("pub".into()) { k - 1 } else { i }
}

/// Whether the item whose first keyword is at `t[i]` carries a `pub` or `pub(..)`.
fn is_public(t: &[Token], i: usize) -> bool {
    item_start(t, i) != i
}

/// Whether the item whose first keyword is at `t[i]` (after any `pub`) carries `#[cfg(test)]`.
fn under_cfg_test(t: &[Token], i: usize) -> bool {
    let mut k = item_start(t, i);
    let cfg_test = [Tok::Ident("cfg".into()), Tok::Punct('('), Tok::Ident("test".into()), Tok::Punct(')')];
    // Attributes `#[..]` before the item, the nearest first.
    while k > 0 && t[k - 1].tok == Tok::Punct(']') {
        let end = k - 1;
        let mut start = end;
        let mut depth = 0;
        loop {
            match t[start].tok {
                Tok::Punct(']') => depth += 1,
                Tok::Punct('[') => depth -= 1,
                _ => {}
            }
            if depth == 0 {
                break;
            }
            if start == 0 {
                return false;
            }
            start -= 1;
        }
        if t[start + 1..end].iter().map(|t| &t.tok).eq(cfg_test.iter()) {
            return true;
        }
        if start == 0 || t[start - 1].tok != Tok::Punct('#') {
            return false;
        }
        k = start - 1;
    }
    false
}

impl Crate {
    /// Reads the crate whose root file is `root`, through `read` (a file's text, or `None`).
    fn read(root: &Path, read: &dyn Fn(&Path) -> Option<String>) -> Crate {
        let dir = root.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut krate = Crate { files: Vec::new(), modules: Vec::new(), errors: Vec::new() };
        krate.modules.push(Module {
            path: Vec::new(),
            parent: None,
            file: 0,
            dir,
            children: BTreeMap::new(),
            uses: Vec::new(),
            paths: Vec::new(),
            test_only: false,
        });
        match read(root) {
            Some(text) => krate.read_file(root.to_path_buf(), &text, 0, read),
            None => krate.errors.push(format!("{}: cannot read the crate root", root.display())),
        }
        krate
    }

    fn add_module(&mut self, parent: usize, name: &str, file: usize, cfg_test: bool) -> usize {
        let mut path = self.modules[parent].path.clone();
        path.push(name.to_string());
        let index = self.modules.len();
        self.modules.push(Module {
            path,
            parent: Some(parent),
            file,
            dir: self.modules[parent].dir.join(name),
            children: BTreeMap::new(),
            uses: Vec::new(),
            paths: Vec::new(),
            test_only: cfg_test || self.modules[parent].test_only,
        });
        self.modules[parent].children.insert(name.to_string(), index);
        index
    }

    /// Reads `text`, the file `path` of module `module`, then the module files it declares.
    fn read_file(&mut self, path: PathBuf, text: &str, module: usize, read: &dyn Fn(&Path) -> Option<String>) {
        let t = tokens(text);
        let file = self.files.len();
        let mut idents = BTreeMap::new();
        for token in &t {
            if let Tok::Ident(s) = &token.tok {
                *idents.entry(s.clone()).or_insert(0) += 1;
            }
        }
        self.files.push(SourceFile { path: path.clone(), module, idents });
        self.modules[module].file = file;
        let tok = |i: usize| t.get(i).map(|t| &t.tok);
        let ident = |i: usize| match tok(i) {
            Some(Tok::Ident(s)) => Some(s.as_str()),
            _ => None,
        };
        // Inline modules open at the brace depth recorded beside them.
        let mut open: Vec<(usize, usize)> = vec![(module, 0)];
        let mut depth = 0;
        let mut declared = Vec::new();
        let mut i = 0;
        while i < t.len() {
            let current = open.last().expect("the file's own module stays open").0;
            match &t[i].tok {
                Tok::Punct('{') => depth += 1,
                Tok::Punct('}') => {
                    depth -= 1;
                    if open.len() > 1 && open.last().is_some_and(|o| o.1 == depth) {
                        open.pop();
                    }
                }
                Tok::Punct('#') if tok(i + 1) == Some(&Tok::Punct('[')) && ident(i + 2) == Some("path") => {
                    self.errors.push(format!(
                        "{}:{}: a #[path] attribute, which this reader does not follow",
                        path.display(),
                        t[i].line
                    ));
                }
                Tok::Ident(k) if k == "mod" && ident(i + 1).is_some() => {
                    let name = ident(i + 1).expect("checked").to_string();
                    let cfg_test = under_cfg_test(&t, i);
                    match tok(i + 2) {
                        Some(Tok::Punct(';')) => {
                            declared.push((self.add_module(current, &name, file, cfg_test), t[i].line));
                            i += 3;
                            continue;
                        }
                        Some(Tok::Punct('{')) => {
                            let child = self.add_module(current, &name, file, cfg_test);
                            open.push((child, depth));
                            depth += 1;
                            i += 3;
                            continue;
                        }
                        _ => {}
                    }
                }
                Tok::Ident(k) if k == "use" => {
                    let public = is_public(&t, i);
                    let line = t[i].line;
                    i += 1;
                    let mut items = Vec::new();
                    use_tree(&t, &mut i, &[], &mut items);
                    while i < t.len() && t[i].tok != Tok::Punct(';') {
                        i += 1;
                    }
                    let uses = items.into_iter().map(|(path, name)| UseItem { path, name, public, line });
                    self.modules[current].uses.extend(uses);
                    continue;
                }
                Tok::Ident(first)
                    if tok(i + 1) == Some(&Tok::PathSep)
                        && !matches!(i.checked_sub(1).and_then(tok), Some(Tok::PathSep | Tok::Punct('.'))) =>
                {
                    let mut segments = vec![first.clone()];
                    let mut j = i + 1;
                    while tok(j) == Some(&Tok::PathSep)
                        && let Some(next) = ident(j + 1)
                    {
                        segments.push(next.to_string());
                        j += 2;
                    }
                    self.modules[current].paths.push((segments, t[i].line));
                    i = j;
                    continue;
                }
                _ => {}
            }
            i += 1;
        }
        for (child, line) in declared {
            let dir = &self.modules[self.modules[child].parent.expect("a declared module has a parent")].dir;
            let name = self.modules[child].path.last().expect("a named module").clone();
            let candidates = [dir.join(format!("{name}.rs")), dir.join(&name).join("mod.rs")];
            match candidates.iter().find_map(|c| read(c).map(|text| (c.clone(), text))) {
                Some((child_path, text)) => self.read_file(child_path, &text, child, read),
                None => self.errors.push(format!(
                    "{}:{line}: `mod {name};` but neither {} nor {} can be read",
                    path.display(),
                    candidates[0].display(),
                    candidates[1].display()
                )),
            }
        }
    }

    /// What `path`, written inside module `from`, names; `None` for paths outside the crate.
    fn resolve(&self, from: usize, path: &[String], depth: usize) -> Option<Found> {
        if depth > MAX_ALIAS_DEPTH || path.is_empty() {
            return None;
        }
        let (mut current, rest) = match path[0].as_str() {
            "crate" | "$crate" => (0, &path[1..]),
            "self" => (from, &path[1..]),
            "super" => {
                let mut m = from;
                let supers = path.iter().take_while(|s| *s == "super").count();
                for _ in 0..supers {
                    m = self.modules[m].parent?;
                }
                (m, &path[supers..])
            }
            first => match self.lookup(from, first, depth)? {
                Found::Module(m) => (m, &path[1..]),
                item => return Some(item),
            },
        };
        for segment in rest {
            match self.lookup(current, segment, depth) {
                Some(Found::Module(m)) => current = m,
                Some(item) => return Some(item),
                None => return Some(Found::ItemIn(current)),
            }
        }
        Some(Found::Module(current))
    }

    /// What `name` means inside module `m`: a child module, what a `use` there brings in
    /// (named, else through a glob), or `None` (an item of `m`, or something outside the crate).
    fn lookup(&self, m: usize, name: &str, depth: usize) -> Option<Found> {
        let module = &self.modules[m];
        if let Some(&child) = module.children.get(name) {
            return Some(Found::Module(child));
        }
        if let Some(u) = module.uses.iter().find(|u| u.name.as_deref() == Some(name)) {
            return self.resolve(m, &u.path, depth + 1);
        }
        module.uses.iter().filter(|u| u.name.is_none()).find_map(|u| match self.resolve(m, &u.path, depth + 1) {
            Some(Found::Module(g)) if g != m => self.lookup(g, name, depth + 1),
            _ => None,
        })
    }

    /// The file a found name lives in.
    fn file_of(&self, found: Found) -> usize {
        match found {
            Found::Module(m) | Found::ItemIn(m) => self.modules[m].file,
        }
    }

    /// The references between files: `edges[a]` maps each file `a` names to the first line of
    /// `a` that names it and the path written there.
    fn file_edges(&self) -> Vec<BTreeMap<usize, (usize, String)>> {
        let mut edges = vec![BTreeMap::new(); self.files.len()];
        for (m, module) in self.modules.iter().enumerate().filter(|(_, m)| !m.test_only) {
            let from = module.file;
            let idents = &self.files[from].idents;
            let uses = module.uses.iter().filter(|u| match &u.name {
                Some(name) => !u.public || name == "_" || idents.get(name).copied().unwrap_or(0) > 1,
                None => !u.public,
            });
            let uses = uses.map(|u| (&u.path, u.line));
            for (path, line) in uses.chain(module.paths.iter().map(|(p, l)| (p, *l))) {
                if let Some(found) = self.resolve(m, path, 0) {
                    let to = self.file_of(found);
                    if to != from {
                        edges[from].entry(to).or_insert_with(|| (line, path.join("::")));
                    }
                }
            }
        }
        edges
    }

    /// A file's module path for messages (`solver::params`, or `crate` for the root).
    fn module_name(&self, file: usize) -> String {
        let path = &self.modules[self.files[file].module].path;
        if path.is_empty() { "crate".to_string() } else { path.join("::") }
    }
}

/// The strongly connected components of the directed graph on nodes `0..edges.len()` that hold
/// a cycle (more than one node, or a node with an edge to itself), each sorted (Tarjan's
/// algorithm).
fn cyclic_components(edges: &[BTreeSet<usize>]) -> Vec<Vec<usize>> {
    struct Walk<'a> {
        edges: &'a [BTreeSet<usize>],
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on_stack: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(w: &mut Walk, v: usize) {
        w.index[v] = Some(w.next);
        w.low[v] = w.next;
        w.next += 1;
        w.stack.push(v);
        w.on_stack[v] = true;
        let edges = w.edges;
        for &to in &edges[v] {
            match w.index[to] {
                None => {
                    visit(w, to);
                    w.low[v] = w.low[v].min(w.low[to]);
                }
                Some(index) if w.on_stack[to] => w.low[v] = w.low[v].min(index),
                Some(_) => {}
            }
        }
        if w.index[v] == Some(w.low[v]) {
            let mut component = Vec::new();
            while let Some(to) = w.stack.pop() {
                w.on_stack[to] = false;
                component.push(to);
                if to == v {
                    break;
                }
            }
            if component.len() > 1 || edges[v].contains(&v) {
                component.sort_unstable();
                w.out.push(component);
            }
        }
    }
    let n = edges.len();
    let mut walk = Walk {
        edges,
        index: vec![None; n],
        low: vec![0; n],
        on_stack: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if walk.index[v].is_none() {
            visit(&mut walk, v);
        }
    }
    walk.out.sort();
    walk.out
}

/// Cycles inside one strongly connected `component`: for each of its edges `a -> b`, the
/// shortest way back from `b` to `a`. Each cycle starts at its smallest node and is listed once.
fn component_cycles(edges: &[BTreeSet<usize>], component: &[usize]) -> Vec<Vec<usize>> {
    let inside: BTreeSet<usize> = component.iter().copied().collect();
    let mut cycles = BTreeSet::new();
    for &a in component {
        for &b in edges[a].iter().filter(|b| inside.contains(b)) {
            // Breadth-first from b to a, inside the component.
            let mut came_from = BTreeMap::from([(b, b)]);
            let mut queue = std::collections::VecDeque::from([b]);
            while let Some(v) = queue.pop_front() {
                if v == a {
                    break;
                }
                for &to in edges[v].iter().filter(|to| inside.contains(to)) {
                    if let std::collections::btree_map::Entry::Vacant(e) = came_from.entry(to) {
                        e.insert(v);
                        queue.push_back(to);
                    }
                }
            }
            if !came_from.contains_key(&a) {
                continue;
            }
            // Back from a to b along the predecessors, then the cycle a, b, .., (a).
            let mut back = vec![a];
            while *back.last().expect("starts with a") != b {
                back.push(came_from[back.last().expect("not empty")]);
            }
            back.reverse();
            let mut cycle: Vec<usize> = std::iter::once(a).chain(back[..back.len() - 1].iter().copied()).collect();
            let start = cycle.iter().enumerate().min_by_key(|(_, v)| **v).map_or(0, |(k, _)| k);
            cycle.rotate_left(start);
            cycles.insert(cycle);
        }
    }
    cycles.into_iter().collect()
}

/// Every crate root of the workspace (each target of each member package), relative to the
/// workspace root, with `package (kind name)` for messages.
fn crate_roots() -> Vec<(String, PathBuf)> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .args(["metadata", "--format-version", "1", "--no-deps"])
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("running `{cargo} metadata`: {e}"));
    assert!(out.status.success(), "cargo metadata failed: {}", String::from_utf8_lossy(&out.stderr));
    let meta: Value = serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON");
    let root = root().canonicalize().expect("workspace root");
    let mut roots = Vec::new();
    for package in meta["packages"].as_array().expect("packages") {
        for target in package["targets"].as_array().expect("targets") {
            let src = PathBuf::from(target["src_path"].as_str().expect("src_path"));
            let src = src.strip_prefix(&root).map(Path::to_path_buf).unwrap_or(src);
            let kind = target["kind"][0].as_str().unwrap_or("?");
            let label = format!("{} ({kind} {})", package["name"].as_str().expect("name"), target["name"]);
            roots.push((label, src));
        }
    }
    roots.sort_by(|a, b| a.1.cmp(&b.1));
    roots.dedup_by(|a, b| a.1 == b.1);
    roots
}

/// The import cycles of one crate, each as `a -> b -> a` followed by the line of each file
/// that names the next.
fn crate_cycles(krate: &Crate) -> Vec<String> {
    let named = krate.file_edges();
    let edges: Vec<BTreeSet<usize>> = named.iter().map(|e| e.keys().copied().collect()).collect();
    let mut found = Vec::new();
    for component in cyclic_components(&edges) {
        for cycle in component_cycles(&edges, &component) {
            let mut text: Vec<String> = cycle.iter().map(|&f| krate.module_name(f)).collect();
            text.push(krate.module_name(cycle[0]));
            let mut message = text.join(" -> ");
            for (k, &a) in cycle.iter().enumerate() {
                let b = cycle[(k + 1) % cycle.len()];
                let (line, path) = &named[a][&b];
                message += &format!("\n    {}:{line} names {path}", krate.files[a].path.display());
            }
            found.push(message);
        }
    }
    found
}

/// Import cycles the workspace still has, by crate and cycle, each with why it is there. The
/// test fails on any other cycle, and on a listed one that is gone, so the list stays true.
const KNOWN_CYCLES: &[(&str, &str)] = &[(
    "lamina-core (lib \"lamina_core\"): solver::multirate -> solver::simulation -> solver::multirate",
    "a Simulation with multirate on holds the coupling (solver::multirate::Multirate), which holds \
     the region's and the bulk's own Simulations: one recursive type across two files, until the \
     coupled mode is a type of its own above Simulation",
)];

#[test]
fn no_import_cycle_inside_any_crate_works() {
    let root = root();
    let read = |p: &Path| std::fs::read_to_string(root.join(p)).ok();
    let roots = crate_roots();
    let mut cycles = Vec::new();
    let mut errors = Vec::new();
    let mut read_files = BTreeSet::new();
    for (label, src) in &roots {
        let krate = Crate::read(src, &read);
        errors.extend(krate.errors.iter().map(|e| format!("{label}: {e}")));
        // Files of one crate that name none of each other would mean a reader that sees nothing.
        if krate.files.len() > 1 && krate.file_edges().iter().all(BTreeMap::is_empty) {
            errors.push(format!("{label}: {} files and not one reference between them", krate.files.len()));
        }
        cycles.extend(crate_cycles(&krate).into_iter().map(|c| format!("{label}: {c}")));
        read_files.extend(krate.files.iter().map(|f| f.path.clone()));
    }
    assert!(errors.is_empty(), "the module reader could not follow: {errors:#?}");
    // Every .rs file under a package's src/ is part of some crate, so none was missed.
    let mut unread = Vec::new();
    for package in ["core", "rt", "mesh", "bridge", "cli", "haptics", "viewer", "input", "tests"] {
        let mut stack = vec![PathBuf::from(package).join("src")];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(root.join(&dir)).expect("a source folder") {
                let name = dir.join(entry.expect("a folder entry").file_name());
                if root.join(&name).is_dir() {
                    stack.push(name);
                } else if name.extension().is_some_and(|e| e == "rs") && !read_files.contains(&name) {
                    unread.push(name);
                }
            }
        }
    }
    assert!(unread.is_empty(), "source files no crate root reaches through `mod`: {unread:?}");
    assert!(read_files.len() > 200, "only {} files read from {} crate roots", read_files.len(), roots.len());
    let is_known = |c: &str| KNOWN_CYCLES.iter().any(|(known, _)| c.lines().next() == Some(*known));
    let new: Vec<&String> = cycles.iter().filter(|c| !is_known(c)).collect();
    let gone: Vec<&str> =
        KNOWN_CYCLES.iter().map(|k| k.0).filter(|k| !cycles.iter().any(|c| c.lines().next() == Some(*k))).collect();
    let new_text: Vec<&str> = new.iter().map(|c| c.as_str()).collect();
    assert!(new.is_empty(), "{} import cycles between modules:\n{}", new.len(), new_text.join("\n"));
    assert!(gone.is_empty(), "KNOWN_CYCLES lists cycles that are gone, remove them: {gone:#?}");
}

#[test]
fn cycle_finder_finds_a_three_cycle_and_passes_a_dag_works() {
    let graph = |edges: &[(usize, usize)], n: usize| {
        let mut g = vec![BTreeSet::new(); n];
        for &(a, b) in edges {
            g[a].insert(b);
        }
        g
    };
    // 0 -> 1 -> 2 -> 0, with a tail 2 -> 3 -> 4 out of the circle.
    let circle = graph(&[(1, 2), (2, 0), (0, 1), (2, 3), (3, 4)], 5);
    assert_eq!(cyclic_components(&circle), vec![vec![0, 1, 2]]);
    assert_eq!(component_cycles(&circle, &[0, 1, 2]), vec![vec![0, 1, 2]]);
    // Two circles through node 1: 0 -> 1 -> 0 and 1 -> 2 -> 3 -> 1.
    let two = graph(&[(0, 1), (1, 0), (1, 2), (2, 3), (3, 1)], 4);
    assert_eq!(cyclic_components(&two), vec![vec![0, 1, 2, 3]]);
    assert_eq!(component_cycles(&two, &[0, 1, 2, 3]), vec![vec![0, 1], vec![1, 2, 3]]);
    // A diamond 0 -> {1, 2} -> 3 is acyclic; a self edge is a cycle of one.
    let dag = graph(&[(0, 1), (0, 2), (1, 3), (2, 3)], 4);
    assert!(cyclic_components(&dag).is_empty());
    assert_eq!(cyclic_components(&graph(&[(0, 1), (1, 1)], 2)), vec![vec![1]]);
}

#[test]
fn module_reader_follows_uses_paths_and_re_exports_works() {
    // A hand-made crate: a -> b (through a grouped `use crate::`), b -> c (through the root's
    // re-export of c::Thing), c -> a (a path in code through `super::`). Names of `b` in a
    // comment, a string, a raw string and a character literal do not count, nor does the
    // `super::` of c's inline module, which is c itself, nor c's `#[cfg(test)]` module.
    let files: BTreeMap<PathBuf, String> = [
        ("src/lib.rs", "mod a;\nmod b;\nmod c;\npub use c::Thing;\npub(crate) use b::f;\n"),
        ("src/a.rs", "use crate::{b::{self, f as g}};\npub fn h() { g() }\n"),
        ("src/b.rs", "pub fn f() {\n    let _t = super::Thing::new();\n}\n"),
        (
            "src/c.rs",
            "pub struct Thing;\nfn k() { super::a::h(); }\n// crate::b::f\nconst S: &str = \"crate::b::f\";\n\
             const R: &str = r#\"crate::b\"#;\nconst Q: char = '\"'; fn l<'a>(x: &'a str) {}\n\
             mod inner {\n    use super::*;\n    fn m() { super::k() }\n}\n\
             #[cfg(test)]\n#[allow(unused)]\nmod tests {\n    use crate::b::f;\n}\n",
        ),
        ("src/d.rs", "use crate::a;"),
    ]
    .into_iter()
    .map(|(p, t)| (PathBuf::from(p), t.to_string()))
    .collect();
    let krate = Crate::read(Path::new("src/lib.rs"), &|p: &Path| files.get(p).cloned());
    assert!(krate.errors.is_empty(), "{:?}", krate.errors);
    let test_only: Vec<String> = krate.modules.iter().filter(|m| m.test_only).map(|m| m.path.join("::")).collect();
    assert_eq!(test_only, ["c::tests"]);
    let names: Vec<String> = (0..krate.files.len()).map(|f| krate.module_name(f)).collect();
    // d.rs is declared nowhere, so it is not part of the crate.
    assert_eq!(names, ["crate", "a", "b", "c"]);
    let edges: Vec<Vec<(String, String)>> = krate
        .file_edges()
        .into_iter()
        .map(|e| e.into_iter().map(|(to, (line, path))| (format!("{}:{line}", names[to]), path)).collect())
        .collect();
    let pair = |to: &str, path: &str| (to.to_string(), path.to_string());
    // The root only forwards names (its `pub use`s) and declares modules: no edges.
    assert_eq!(edges[0], []);
    assert_eq!(edges[1], [pair("b:1", "crate::b")]);
    assert_eq!(edges[2], [pair("c:2", "super::Thing::new")]);
    assert_eq!(edges[3], [pair("a:2", "super::a::h")]);
    let cycles = crate_cycles(&krate);
    assert_eq!(cycles.len(), 1, "{cycles:?}");
    assert!(cycles[0].starts_with("a -> b -> c -> a\n    src/a.rs:1 names crate::b"), "{}", cycles[0]);
    assert!(cycles[0].ends_with("src/c.rs:2 names super::a::h"), "{}", cycles[0]);
    // A module file that does not exist is an error that names the declaring file and line.
    let missing =
        Crate::read(Path::new("src/lib.rs"), &|p: &Path| (p == Path::new("src/lib.rs")).then(|| "\nmod gone;".into()));
    assert_eq!(missing.errors.len(), 1);
    assert!(missing.errors[0].starts_with("src/lib.rs:2: `mod gone;`"), "{:?}", missing.errors);
}
