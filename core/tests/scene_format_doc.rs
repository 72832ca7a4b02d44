//! docs/scene-format.md against the scene reader. The page's key tables are parsed; then
//! 1. every key a table of the reader accepts is documented: each table is given an unknown
//!    key and the keys the reader's error says it expects are compared with the page's;
//! 2. every documented key loads with its documented example value, and (outside `[model]`,
//!    whose examples name files) the simulation builds with it;
//! 3. every documented default is the default: a scene with the key set to it equals the
//!    scene without the key;
//! 4. the shipped scenes quoted on the page are the files in `config/scenes/`, and they load.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use lamina_core::scene::{BlockSpec, Scene};
use lamina_core::solver::Simulation;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/.."))
}

fn page() -> String {
    let path = root().join("docs/scene-format.md");
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One documented table of keys: the TOML table it belongs to and its rows.
#[derive(Debug)]
struct Section {
    /// Heading text, for messages.
    heading: String,
    /// Dotted TOML path (`""` for the top level, `effects.tool`, ...).
    path: String,
    /// `[[path]]`: an array of tables.
    array: bool,
    /// Rows: key → (column → cell), back-quotes removed.
    rows: BTreeMap<String, BTreeMap<String, String>>,
}

fn cells(line: &str) -> Vec<String> {
    let line = line.trim().trim_start_matches('|').trim_end_matches('|');
    line.split('|').map(|c| c.trim().replace('`', "")).collect()
}

/// Sections: a heading naming a TOML table (`` `[path]` ``, `` `[[path]]` ``, or "Top level")
/// followed, before the next heading, by a table with a `key` column.
fn sections(text: &str) -> Vec<Section> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if !line.starts_with('#') {
            continue;
        }
        let heading = line.trim_start_matches('#').trim();
        let (path, array) = if heading == "Top level" {
            (String::new(), false)
        } else if let Some(rest) = heading.strip_prefix("`[[") {
            (rest.split_once("]]`").expect("`[[path]]`").0.to_string(), true)
        } else if let Some(rest) = heading.strip_prefix("`[") {
            (rest.split_once("]`").expect("`[path]`").0.to_string(), false)
        } else {
            continue;
        };
        let mut j = i + 1;
        while j < lines.len() && !lines[j].starts_with('#') && !lines[j].starts_with('|') {
            j += 1;
        }
        if j >= lines.len() || !lines[j].starts_with('|') {
            continue; // an introduction: the keys come in the sub-sections
        }
        let header = cells(lines[j]);
        assert_eq!(header[0], "key", "{heading}: the first column is the key");
        let mut rows = BTreeMap::new();
        for row in lines[j + 2..].iter().take_while(|l| l.starts_with('|')) {
            let c = cells(row);
            assert_eq!(c.len(), header.len(), "{heading}: cell count of {row}");
            rows.insert(c[0].clone(), header.iter().cloned().zip(c).collect());
        }
        out.push(Section { heading: heading.to_string(), path, array, rows });
    }
    out
}

fn is_required(row: &BTreeMap<String, String>) -> bool {
    row["default"] == "required" || row["default"].starts_with("required unless ")
}

/// The key that may stand in for a required one (`required unless KEY`), if any.
fn alternative(row: &BTreeMap<String, String>) -> Option<&str> {
    row["default"].strip_prefix("required unless ")
}

/// A TOML value cell, or `None` for prose (`off`, `the period`, `-`).
fn toml_value(cell: &str) -> Option<String> {
    let text = format!("v = {cell}\n");
    text.parse::<toml::Table>().ok().map(|_| cell.to_string())
}

/// The scene text of `section` with its required keys at their examples, plus `extra` lines
/// in the section's table.
fn scene_text(section: &Section, extra: &[String]) -> String {
    let mut text = String::new();
    // A layer material lives in a layered block.
    if section.path.starts_with("model.") {
        text.push_str("[model]\nkind = \"layered_block\"\n");
    }
    // Multirate stepping needs the real-time integrator and bone, and a centre without a tool.
    let multirate = section.path == "solver.multirate";
    if multirate {
        text.push_str("[solver]\nintegrator = \"implicit_factored\"\n[effects]\nbone = true\n");
    }
    // Bone motion moves the bone.
    if section.path == "effects.bone_motion" {
        text.push_str("[effects]\nbone = true\n");
    }
    if !section.path.is_empty() {
        let (open, close) = if section.array { ("[[", "]]") } else { ("[", "]") };
        text.push_str(&format!("{open}{}{close}\n", section.path));
    }
    let given = |key: &str| extra.iter().any(|e| e.starts_with(&format!("{key} = ")));
    for (key, row) in &section.rows {
        if is_required(row) && !given(key) && !alternative(row).is_some_and(given) {
            text.push_str(&format!("{key} = {}\n", row["example"]));
        }
    }
    if multirate && !extra.iter().any(|e| e.starts_with("centre = ")) {
        text.push_str("centre = [0.0, 0.062, 0.12]\n");
    }
    if section.path == "effects" && extra.iter().any(|e| e.starts_with("bone_motion = ")) {
        text.push_str("bone = true\n");
    }
    for line in extra {
        text.push_str(line);
        text.push('\n');
    }
    text
}

fn load(text: &str) -> Result<Scene, String> {
    Scene::from_toml_str(text, None).map_err(|e| e.to_string())
}

/// The keys named after "expected" in a reader's unknown-key error.
fn expected_keys(message: &str) -> BTreeSet<String> {
    let (_, after) = message.split_once("expected").unwrap_or_else(|| panic!("no expected keys in: {message}"));
    after.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

#[test]
fn every_key_the_reader_accepts_is_documented_works() {
    let text = page();
    let sections = sections(&text);
    assert!(sections.len() >= 15, "sections found: {:?}", sections.iter().map(|s| &s.heading).collect::<Vec<_>>());
    for s in &sections {
        let error = load(&scene_text(s, &["zz_not_a_key = 1".to_string()]))
            .expect_err(&format!("{}: an unknown key is refused", s.heading));
        assert!(error.contains("zz_not_a_key"), "{}: the error names the key: {error}", s.heading);
        let accepted = if error.contains("expected") {
            expected_keys(&error)
        } else {
            // The layered block's keys are flattened into the `kind` enum, and serde then
            // names no expected keys; its reader takes exactly `BlockSpec`'s fields.
            assert!(s.heading.contains("layered_block"), "{}: no expected keys in: {error}", s.heading);
            let e = toml::from_str::<BlockSpec>("zz_not_a_key = 1").expect_err("BlockSpec refuses unknown keys");
            expected_keys(e.message())
        };
        let documented: BTreeSet<String> = s.rows.keys().cloned().collect();
        // A field that chooses among several documented tables (`source`, a plain field) is
        // listed with the fields of all of them; an enum tag (`kind`, `law`) is not, and its
        // variant's fields are exactly its table's.
        let siblings: BTreeSet<String> = sections
            .iter()
            .filter(|o| o.path == s.path && o.array == s.array)
            .flat_map(|o| o.rows.keys().cloned())
            .collect();
        let tag = documented.iter().find(|k| !accepted.contains(*k)).cloned();
        match tag {
            Some(tag) => {
                let mut without_tag = documented.clone();
                without_tag.remove(&tag);
                assert_eq!(accepted, without_tag, "{}: keys the reader accepts (tag '{tag}')", s.heading);
            }
            None => {
                assert!(accepted.is_subset(&siblings), "{}: undocumented keys {:?}", s.heading, &accepted - &siblings);
                assert!(documented.is_subset(&accepted), "{}", s.heading);
            }
        }
    }
}

#[test]
fn every_documented_key_loads_with_its_example_works() {
    let text = page();
    let mut built = 0;
    for s in sections(&text) {
        for (key, row) in &s.rows {
            let Some(example) = toml_value(&row["example"]) else {
                assert_eq!(row["type"], "table", "{} {key}: an example is needed", s.heading);
                continue;
            };
            let text = scene_text(&s, &[format!("{key} = {example}")]);
            let scene = load(&text).unwrap_or_else(|e| panic!("{} {key} = {example}: {e}\n{text}", s.heading));
            // Limits checked when the simulation is built (caps, node indices) hold too; the
            // model sections name files this test does not have.
            if !s.path.starts_with("model") {
                let model = scene.build_model().unwrap();
                Simulation::<f64>::new(&model, scene.solver.clone(), scene.effects.clone())
                    .unwrap_or_else(|e| panic!("{} {key} = {example}: {e}\n{text}", s.heading));
                built += 1;
            }
        }
    }
    assert!(built >= 40, "simulations built: {built}");
}

#[test]
fn every_documented_default_is_the_default_works() {
    let text = page();
    let mut checked = 0;
    for s in sections(&text) {
        let base = load(&scene_text(&s, &[])).unwrap_or_else(|e| panic!("{}: {e}", s.heading));
        for (key, row) in &s.rows {
            let Some(default) = toml_value(&row["default"]) else { continue };
            let with = load(&scene_text(&s, &[format!("{key} = {default}")]))
                .unwrap_or_else(|e| panic!("{} {key} = {default}: {e}", s.heading));
            assert_eq!(with, base, "{} {key}: the documented default {default} is not the default", s.heading);
            checked += 1;
        }
    }
    assert!(checked >= 40, "defaults checked: {checked}");
}

#[test]
fn shipped_scenes_on_the_page_are_the_files_works() {
    let text = page();
    let mut quoted = 0;
    for entry in std::fs::read_dir(root().join("config/scenes")).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        let heading = format!("### `config/scenes/{name}`");
        let at = text.find(&heading).unwrap_or_else(|| panic!("docs/scene-format.md does not quote {name}"));
        let block = text[at..].split("```toml\n").nth(1).and_then(|b| b.split("\n```").next()).expect("a toml block");
        let file = std::fs::read_to_string(&path).unwrap();
        assert_eq!(block, file.trim_end(), "docs/scene-format.md quotes an old {name}");
        Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        quoted += 1;
    }
    assert_eq!(quoted, 8);
}
