//! The Python package's wire declarations (`python/lamina/wire.py`) against the Rust types of
//! `bridge/src/wire.rs`: for every wire structure, the size, the alignment, the iceoryx2 type
//! name and each field's name, offset and size, as Python's `ctypes` computes them, must be
//! what `size_of`, `align_of` and `offset_of!` give for the Rust type (`wire::layouts()`);
//! the array bounds and the services' settings the module declares must be the bridge's
//! constants. A field added,
//! removed, renamed, reordered or retyped on one side only fails here.
//!
//! Needs `python3` with iceoryx2 and numpy (`pip install -r examples/python/requirements.txt`);
//! without them the test prints SKIP, unless `LAMINA_REQUIRE_PYTHON_CLIENTS` is set (CI sets
//! it), then it fails.

use lamina_bridge::{services, wire};
use lamina_tests::python_package_dir;
use serde_json::Value;
use std::collections::BTreeMap;
use std::mem::{align_of, size_of};
use std::process::Command;

/// Prints, as one JSON object, every `ctypes` structure of `lamina.wire` that Lamina sends
/// (the keys of `WIRE_SIZES`, plus `Percentiles`) and the module's constants.
const DUMP: &str = r#"
import ctypes, json
from lamina import wire
types = list(wire.WIRE_SIZES) + [wire.Percentiles]
out = {"types": {}, "constants": {}}
for t in types:
    fields = [[name, getattr(t, name).offset, getattr(t, name).size] for name, _ in t._fields_]
    out["types"][t.__name__] = {"size": ctypes.sizeof(t), "align": ctypes.alignment(t),
                                "type_name": t.type_name(), "fields": fields}
for name in ["MAX_LAYERS", "LAYER_NAME_LEN", "MAX_SURFACES", "SURFACE_NAME_LEN", "MODEL_NAME_LEN",
             "VOLUME_PATH_LEN", "MAX_SUBSCRIBERS", "MAX_PUBLISHERS", "MAX_SERVICE_NODES",
             "MAX_BORROWED_SAMPLES", "NODES_BUFFER_SIZE", "TOPOLOGY_BUFFER_SIZE", "MAX_LISTENERS",
             "MAX_NOTIFIERS"]:
    out["constants"][name] = getattr(wire, name)
print(json.dumps(out))
"#;

/// One structure's layout: size and alignment (bytes), iceoryx2 type name, and per field
/// its name, offset and size (bytes), in declaration order.
#[derive(Debug, PartialEq)]
struct Layout {
    size: usize,
    align: usize,
    type_name: String,
    fields: Vec<(String, usize, usize)>,
}

/// The Rust side: `lamina_bridge::wire::layouts()` and the `nodes` element `[f32; 3]`,
/// whose coordinates Python names x, y, z.
fn rust_layouts() -> BTreeMap<String, Layout> {
    let f32_size = size_of::<f32>();
    let position = Layout {
        size: size_of::<[f32; 3]>(),
        align: align_of::<[f32; 3]>(),
        type_name: std::any::type_name::<[f32; 3]>().to_string(),
        fields: ["x", "y", "z"].iter().enumerate().map(|(i, n)| (n.to_string(), i * f32_size, f32_size)).collect(),
    };
    let mut out = BTreeMap::from([("Position".to_string(), position)]);
    for t in wire::layouts() {
        let fields = t.fields.iter().map(|f| (f.name.to_string(), f.offset, f.size)).collect();
        let layout = Layout { size: t.size, align: t.align, type_name: t.type_name.to_string(), fields };
        out.insert(t.name.to_string(), layout);
    }
    out
}

/// The Python side, or `None` (SKIP) when python3 cannot import iceoryx2 and numpy.
fn python_dump() -> Option<Value> {
    let out = Command::new("python3")
        .env("PYTHONPATH", python_package_dir())
        .args(["-c", DUMP])
        .output()
        .expect("running python3 (install Python 3.10 or newer)");
    let err = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        let missing = err.contains("No module named 'iceoryx2'") || err.contains("No module named 'numpy'");
        let required = std::env::var_os("LAMINA_REQUIRE_PYTHON_CLIENTS").is_some();
        assert!(missing && !required, "python3 could not read lamina.wire:\n{err}");
        println!("SKIP: python3 cannot import iceoryx2 and numpy (pip install -r examples/python/requirements.txt)");
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout);
    Some(serde_json::from_str(text.trim()).unwrap_or_else(|e| panic!("not JSON ({e}): {text}\n{err}")))
}

fn usize_of(v: &Value, what: &str) -> usize {
    v.as_u64().unwrap_or_else(|| panic!("{what}: not a number: {v}")) as usize
}

fn python_layouts(dump: &Value) -> BTreeMap<String, Layout> {
    let types = dump["types"].as_object().expect("types");
    types
        .iter()
        .map(|(name, t)| {
            let fields = t["fields"].as_array().expect("fields").iter().map(|f| {
                let name = f[0].as_str().expect("a field name").to_string();
                (name.clone(), usize_of(&f[1], &name), usize_of(&f[2], &name))
            });
            let layout = Layout {
                size: usize_of(&t["size"], name),
                align: usize_of(&t["align"], name),
                type_name: t["type_name"].as_str().expect("type_name").to_string(),
                fields: fields.collect(),
            };
            (name.clone(), layout)
        })
        .collect()
}

#[test]
fn python_wire_declarations_match_the_rust_types_field_by_field_works() {
    let Some(dump) = python_dump() else { return };
    let python = python_layouts(&dump);
    let rust = rust_layouts();
    let names = |m: &BTreeMap<String, Layout>| m.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&python), names(&rust), "the wire types lamina.wire declares");
    for (name, r) in &rust {
        let p = &python[name];
        assert_eq!((p.size, p.align), (r.size, r.align), "{name}: (size, align) in Python against Rust");
        assert_eq!(p.type_name, r.type_name, "{name}: iceoryx2 type name");
        let field_names = |l: &Layout| l.fields.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
        assert_eq!(field_names(p), field_names(r), "{name}: fields in order");
        for (pf, rf) in p.fields.iter().zip(&r.fields) {
            assert_eq!(pf, rf, "{name}.{}: (name, offset, size) in Python against Rust", rf.0);
        }
    }
}

#[test]
fn python_wire_constants_match_the_bridge_works() {
    let Some(dump) = python_dump() else { return };
    let rust = [
        ("MAX_LAYERS", wire::MAX_LAYERS),
        ("LAYER_NAME_LEN", wire::LAYER_NAME_LEN),
        ("MAX_SURFACES", wire::MAX_SURFACES),
        ("SURFACE_NAME_LEN", wire::SURFACE_NAME_LEN),
        ("MODEL_NAME_LEN", wire::MODEL_NAME_LEN),
        ("VOLUME_PATH_LEN", wire::VOLUME_PATH_LEN),
        ("MAX_SUBSCRIBERS", services::MAX_SUBSCRIBERS),
        ("MAX_PUBLISHERS", services::MAX_PUBLISHERS),
        ("MAX_SERVICE_NODES", services::MAX_SERVICE_NODES),
        ("MAX_BORROWED_SAMPLES", services::MAX_BORROWED_SAMPLES),
        ("NODES_BUFFER_SIZE", services::NODES_BUFFER_SIZE),
        ("TOPOLOGY_BUFFER_SIZE", services::TOPOLOGY_BUFFER_SIZE),
        ("MAX_LISTENERS", services::MAX_LISTENERS),
        ("MAX_NOTIFIERS", services::MAX_NOTIFIERS),
    ];
    for (name, value) in rust {
        assert_eq!(usize_of(&dump["constants"][name], name), value, "lamina.wire.{name} against the bridge");
    }
}
