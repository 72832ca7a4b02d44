//! The scene loader on broken scenes: every defect in `tests/data/scenes/broken/` gives the
//! right error, naming the file, the line and (for a value out of range) the field.

use lamina_core::scene::{Scene, SceneLoadError};
use std::path::PathBuf;

fn data(file: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/scenes/broken").join(file)
}

/// What a broken scene must give: a syntax error (malformed TOML, unknown key, wrong type) or
/// a value error on a field, each at a line.
enum Expect {
    Syntax { line: usize },
    Value { field: &'static str, line: usize },
}
use Expect::{Syntax, Value};

/// Loads `file` and checks the error against `expect`.
fn check(file: &str, expect: &Expect) {
    let path = data(file);
    let err = match Scene::load(&path) {
        Ok(_) => panic!("{file}: loaded without error"),
        Err(e) => e,
    };
    let line = match (&err, expect) {
        (SceneLoadError::Syntax { path: p, line, .. }, Syntax { line: want }) => {
            assert_eq!(p, &path, "{file}: {err}");
            assert_eq!(line, want, "{file}: wrong line: {err}");
            line
        }
        (SceneLoadError::Value { path: p, line, field, .. }, Value { field: want_field, line: want }) => {
            assert_eq!(p, &path, "{file}: {err}");
            assert_eq!(field, want_field, "{file}: wrong field: {err}");
            assert_eq!(line, &Some(*want), "{file}: wrong line: {err}");
            want
        }
        _ => panic!("{file}: wrong kind of error: {err:?}"),
    };
    assert!(err.to_string().starts_with(&format!("{}:{line}:", path.display())), "{err}");
}

const BROKEN: &[(&str, Expect)] = &[
    ("malformed.toml", Syntax { line: 2 }),
    ("unknown_top_key.toml", Syntax { line: 2 }),
    ("unknown_effects_key.toml", Syntax { line: 4 }),
    ("wrong_type.toml", Syntax { line: 2 }),
    ("unknown_model_kind.toml", Syntax { line: 2 }),
    ("zero_rate.toml", Value { field: "rate_hz", line: 3 }),
    ("bad_precision.toml", Value { field: "precision", line: 1 }),
    ("block_too_small.toml", Value { field: "model", line: 1 }),
    ("negative_material.toml", Value { field: "model.fat", line: 3 }),
    ("bad_yardstick_size.toml", Value { field: "model.size", line: 4 }),
    ("bad_integrator.toml", Value { field: "solver.integrator", line: 3 }),
    ("zero_substeps.toml", Value { field: "solver.substeps", line: 3 }),
    ("too_many_threads.toml", Value { field: "solver.threads", line: 2 }),
    ("nan_gravity.toml", Value { field: "effects.gravity", line: 3 }),
    ("bone_motion_without_bone.toml", Value { field: "effects.bone_motion", line: 3 }),
    ("nan_load.toml", Value { field: "effects.loads[1]", line: 7 }),
    ("negative_handle.toml", Value { field: "effects.handles[0]", line: 1 }),
    // The missing key's table is named.
    ("tool_without_origin.toml", Value { field: "effects.tool.device_origin", line: 4 }),
    ("tool_bad_source.toml", Value { field: "effects.tool.source", line: 4 }),
    ("tool_min_radius_above_radius.toml", Value { field: "effects.tool.min_radius", line: 6 }),
    ("bad_overrun.toml", Value { field: "realtime.overrun", line: 3 }),
    ("bad_fifo_priority.toml", Value { field: "realtime.fifo_priority", line: 2 }),
];

#[test]
fn scene_broken_corpus_reports_field_and_line_works() {
    for (file, expect) in BROKEN {
        check(file, expect);
    }
}

#[test]
fn scene_broken_corpus_is_all_in_table_works() {
    let mut on_disk: Vec<String> = std::fs::read_dir(data(""))
        .expect("corpus directory")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = BROKEN.iter().map(|(f, _)| f.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
}
