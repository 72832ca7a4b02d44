//! File handling: welding, units, formats, malformed input. Files go to a temporary directory.

use std::path::{Path, PathBuf};

use lamina_mesh::{
    LoadOptions, MeshFormat, MeshLoadError, TriMesh, Units, inspect, inspect_with, load, save_obj, save_stl_ascii,
    save_stl_binary, synthetic,
};

fn put(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

const CUBE_OBJ: &str = "# unit cube, quads, mixed index forms\n\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\nvn 0 0 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1/1 2/1 6/1 5/1\nf 2//1 3//1 7//1 6//1\nf 3/1/1 4/1/1 8/1/1 7/1/1\nf -8 -4 -1 -5\n";

#[test]
fn stl_unwelded_welds_to_vertex_count_works() {
    let dir = tempfile::tempdir().unwrap();
    let cube = synthetic::cuboid([0.0; 3], [1.0; 3], 3);
    assert_eq!((cube.vertices().len(), cube.triangle_count()), (56, 108));
    let p = dir.path().join("cube.stl");
    save_stl_binary(&p, &cube, Units::Metre).unwrap();
    let r = load(&p, &LoadOptions::default()).unwrap().report;
    assert_eq!(r.format, MeshFormat::StlBinary);
    assert_eq!((r.raw_vertices, r.welded_vertices, r.triangles), (324, 56, 108));
    assert_eq!((r.degenerate_removed, r.flipped_fixed), (0, 0));
}

#[test]
fn stl_weld_tolerance_works() {
    // Two triangles whose shared corners differ by 1e-4 (file units).
    let text = "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\n\
                facet normal 0 0 1\nouter loop\nvertex 1.0001 0 0\nvertex 1 1 0\nvertex 0 1.0001 0\nendloop\nendfacet\n\
                endsolid t\n";
    let dir = tempfile::tempdir().unwrap();
    let p = put(dir.path(), "near.stl", text.as_bytes());
    let opts = LoadOptions::default().allow_open(true);
    assert_eq!(load(&p, &opts).unwrap().report.welded_vertices, 6);
    assert_eq!(load(&p, &opts.weld_tolerance(1e-3)).unwrap().report.welded_vertices, 4);
    assert_eq!(load(&p, &opts.weld_tolerance(0.0)).unwrap().report.welded_vertices, 6);
}

#[test]
fn stl_millimetre_inferred_to_metres_works() {
    let dir = tempfile::tempdir().unwrap();
    let limb = synthetic::cylinder(0.05, 0.2, 0.6, 48, 6);
    let p = dir.path().join("limb_mm.stl");
    save_stl_binary(&p, &limb, Units::Millimetre).unwrap();
    let loaded = load(&p, &LoadOptions::default()).unwrap();
    assert_eq!((loaded.report.units, loaded.report.units_inferred), (Units::Millimetre, true));
    let b = loaded.mesh.bounding_box().unwrap();
    assert!((b.max[2] - 0.6).abs() < 1e-7 && (b.min[2] - 0.2).abs() < 1e-7, "{b:?}");
    assert!((loaded.mesh.signed_volume() / limb.signed_volume() - 1.0).abs() < 1e-5);

    // Same numbers read as metres when the file is in metres; given units override.
    let pm = dir.path().join("limb_m.stl");
    save_stl_binary(&pm, &limb, Units::Metre).unwrap();
    assert_eq!(load(&pm, &LoadOptions::default()).unwrap().report.units, Units::Metre);
    let cm = load(&pm, &LoadOptions::default().units(Units::Centimetre)).unwrap();
    assert!(!cm.report.units_inferred);
    assert!((cm.mesh.bounding_box().unwrap().max[2] - 0.006).abs() < 1e-9);
    let ins = inspect_with(&pm, &LoadOptions::default().units(Units::Millimetre)).unwrap();
    assert!(!ins.units_inferred && (ins.bounding_box.max[2] - 0.0006).abs() < 1e-9);
    assert!(ins.to_string().contains("millimetre (given)"));
}

#[test]
fn stl_ascii_and_obj_round_trip_works() {
    let dir = tempfile::tempdir().unwrap();
    let sphere = synthetic::sphere([0.01, 0.02, 0.03], 0.04, 3);
    let pa = dir.path().join("s.stl");
    let po = dir.path().join("s.obj");
    save_stl_ascii(&pa, &sphere, Units::Millimetre).unwrap();
    save_obj(&po, &sphere, Units::Millimetre).unwrap();
    for (p, fmt) in [(pa, MeshFormat::StlAscii), (po, MeshFormat::Obj)] {
        let l = load(&p, &LoadOptions::default()).unwrap();
        assert_eq!(l.report.format, fmt);
        assert_eq!(l.report.units, Units::Millimetre);
        assert_eq!(l.report.welded_vertices, sphere.vertices().len());
        assert_eq!(l.report.flipped_fixed, 0);
        assert!((l.mesh.signed_volume() / sphere.signed_volume() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn obj_quads_and_negative_indices_works() {
    let dir = tempfile::tempdir().unwrap();
    let p = put(dir.path(), "cube.obj", CUBE_OBJ.as_bytes());
    let l = load(&p, &LoadOptions::default()).unwrap();
    assert_eq!((l.report.raw_vertices, l.report.welded_vertices, l.report.triangles), (8, 8, 12));
    assert!((l.mesh.signed_volume() - 1.0).abs() < 1e-12);
    // The bottom face `f 1 4 3 2` is wound outward (−z) already; nothing flipped.
    assert_eq!(l.report.flipped_fixed, 0);
}

#[test]
fn stl_truncated_binary_fails() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cut.stl");
    save_stl_binary(&p, &synthetic::cuboid([0.0; 3], [1.0; 3], 1), Units::Metre).unwrap();
    let mut bytes = std::fs::read(&p).unwrap();
    bytes.truncate(bytes.len() - 30);
    std::fs::write(&p, &bytes).unwrap();
    let e = load(&p, &LoadOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            MeshLoadError::StlTruncated { declared_triangles: 12, complete_triangles: 11, actual_bytes: 654, .. }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("cut.stl") && e.to_string().contains("truncated"), "{e}");
    assert!(inspect(&p).is_err());
}

#[test]
fn stl_ascii_malformed_fails() {
    let dir = tempfile::tempdir().unwrap();
    let text = "solid bad\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0.0.1 0\n";
    let p = put(dir.path(), "bad.stl", text.as_bytes());
    let e = load(&p, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::StlSyntax { line: 5, .. }), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("bad.stl:5:") && msg.contains("0.0.1"), "{msg}");

    let text = "solid bad\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 1 0 0\n  endloop\n endfacet\n";
    let e = load(put(dir.path(), "short.stl", text.as_bytes()), &LoadOptions::default()).unwrap_err();
    assert!(e.to_string().contains("short.stl:6:") && e.to_string().contains("2 vertices"), "{e}");
}

#[test]
fn obj_malformed_fails() {
    let dir = tempfile::tempdir().unwrap();
    let p = put(dir.path(), "bad.obj", b"v 0 0 0\nv 1 0 0\n\nv 0 1 zero\nf 1 2 3\n");
    let e = load(&p, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::ObjSyntax { line: 4, .. }), "{e}");
    assert!(e.to_string().contains("bad.obj:4:") && e.to_string().contains("zero"), "{e}");

    let p = put(dir.path(), "range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n");
    let e = load(&p, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::ObjIndexOutOfRange { line: 5, index: 9, vertex_count: 3, .. }), "{e}");
    assert!(e.to_string().contains("range.obj:5:"), "{e}");
}

#[test]
fn load_degenerate_triangles_removed_works() {
    let dir = tempfile::tempdir().unwrap();
    let (mut v, mut t) = synthetic::cuboid([0.0; 3], [1.0; 3], 1).into_parts();
    // A sliver whose two corners weld together, and one with a repeated index.
    v.push([1e-9, 0.0, 0.0]);
    t.push([0, (v.len() - 1) as u32, 3]);
    t.push([1, 1, 2]);
    let p = dir.path().join("degenerate.obj");
    save_obj(&p, &TriMesh::new(v, t).unwrap(), Units::Metre).unwrap();
    let r = load(&p, &LoadOptions::default()).unwrap().report;
    assert_eq!((r.raw_triangles, r.triangles, r.degenerate_removed, r.welded_vertices), (14, 12, 2, 8));
}

#[test]
fn load_bad_paths_and_empty_fail() {
    let dir = tempfile::tempdir().unwrap();
    let e = load(dir.path().join("missing.stl"), &LoadOptions::default()).unwrap_err();
    assert!(
        matches!(e, MeshLoadError::Read(lamina_input::FileReadError::Io { .. }))
            && e.to_string().contains("missing.stl"),
        "{e}"
    );
    let e = load(put(dir.path(), "mesh.ply", b"ply\n"), &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::UnsupportedFormat { .. }), "{e}");
    let e = load(put(dir.path(), "empty.stl", b"solid e\nendsolid e\n"), &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::Empty { degenerate_removed: 0, .. }), "{e}");
    let e = load(put(dir.path(), "UPPER.OBJ", b"v 0 0 0\n"), &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::Empty { .. }), "{e}");
}

#[test]
fn load_garbage_bytes_never_panics_works() {
    // Deterministic pseudo-random bytes and prefixes of valid files: errors, never panics.
    let dir = tempfile::tempdir().unwrap();
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut noise = vec![0u8; 4000];
    for b in &mut noise {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        *b = x as u8;
    }
    let valid_ascii = {
        let p = dir.path().join("v.stl");
        save_stl_ascii(&p, &synthetic::cuboid([0.0; 3], [1.0; 3], 1), Units::Metre).unwrap();
        std::fs::read(&p).unwrap()
    };
    for (k, len) in [0usize, 3, 84, 85, 134, 1000, 4000].into_iter().enumerate() {
        for (ext, bytes) in [("stl", &noise), ("obj", &noise), ("stl", &valid_ascii), ("obj", &valid_ascii)] {
            let cut = &bytes[..len.min(bytes.len())];
            let p = put(dir.path(), &format!("g{k}.{ext}"), cut);
            let _ = load(&p, &LoadOptions::default());
            let _ = inspect(&p);
        }
    }
}
