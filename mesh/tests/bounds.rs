//! Bounded input: only regular files are read, coordinates are bounded, and a stray vertex
//! is named instead of collapsing the surface. Regression tests for what a mutation fuzzer
//! and hand-made files found.

use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;
use std::path::Path;

use lamina_input::FileReadError;
use lamina_mesh::{LoadOptions, MeshLoadError, Units, inspect, load, save_stl_binary, synthetic};

/// Binary STL bytes of a sphere of radius 80 mm (in mm): 1,280 triangles.
fn sphere_stl(dir: &Path) -> Vec<u8> {
    let p = dir.join("sphere.stl");
    save_stl_binary(&p, &synthetic::sphere([0.0; 3], 0.08, 3), Units::Millimetre).unwrap();
    std::fs::read(&p).unwrap()
}

/// Sets the first corner of binary STL triangle `t` to `v`.
fn set_corner(bytes: &mut [u8], t: usize, v: [f32; 3]) {
    let at = 84 + 50 * t + 12;
    for (k, c) in v.iter().enumerate() {
        bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&c.to_le_bytes());
    }
}

#[test]
fn mesh_one_outlier_vertex_is_named_works() {
    // One corner moved 10^8 mm away: its bounding-box diagonal used to set a weld tolerance
    // of 100 mm that merged the whole sphere ("no triangles left (N degenerate ...)").
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = sphere_stl(dir.path());
    set_corner(&mut bytes, 412, [1e8, 0.0, 0.0]);
    let p = dir.path().join("outlier.stl");
    std::fs::write(&p, &bytes).unwrap();
    for e in [load(&p, &LoadOptions::default()).unwrap_err(), inspect(&p).unwrap_err()] {
        assert!(matches!(&e, MeshLoadError::OutlierVertex { location, .. } if location == "triangle 412"), "{e}");
        let text = e.to_string();
        assert!(text.contains("outlier.stl: triangle 412 at (100000000, 0, 0) lies"), "{text}");
        assert!(text.contains("remove it"), "{text}");
    }
    // The same sphere without the stray vertex loads.
    let p = dir.path().join("clean.stl");
    std::fs::write(&p, sphere_stl(dir.path())).unwrap();
    assert_eq!(load(&p, &LoadOptions::default()).unwrap().report.triangles, 1280);
}

#[test]
fn mesh_obj_outlier_vertex_names_its_v_line_works() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::new();
    let sphere = synthetic::sphere([0.0; 3], 80.0, 2);
    for (i, v) in sphere.vertices().iter().enumerate() {
        let v = if i == 16 { [0.0, 0.0, 5e8] } else { *v };
        text.push_str(&format!("v {} {} {}\n", v[0], v[1], v[2]));
    }
    for t in sphere.triangles() {
        text.push_str(&format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1));
    }
    let p = dir.path().join("outlier.obj");
    std::fs::write(&p, text).unwrap();
    let e = load(&p, &LoadOptions::default()).unwrap_err();
    assert!(matches!(&e, MeshLoadError::OutlierVertex { location, .. } if location == "vertex 17"), "{e}");
}

#[test]
fn mesh_coordinates_beyond_bound_are_refused_works() {
    // A surface at 1e30 file units gave `lamina inspect` a NaN volume (cubes overflow).
    let dir = tempfile::tempdir().unwrap();
    let mut bytes = sphere_stl(dir.path());
    set_corner(&mut bytes, 7, [3e30, 0.0, 0.0]);
    let p = dir.path().join("huge.stl");
    std::fs::write(&p, &bytes).unwrap();
    let e = inspect(&p).unwrap_err();
    assert!(matches!(e, MeshLoadError::StlCoordinateTooLarge { triangle: 7, .. }), "{e}");
    assert!(e.to_string().contains("beyond ±1e9"), "{e}");

    let obj = "v 0 0 0\nv 1 0 0\nv 0 1e300 0\nf 1 2 3\n";
    let p = dir.path().join("huge.obj");
    std::fs::write(&p, obj).unwrap();
    let e = inspect(&p).unwrap_err();
    assert!(matches!(e, MeshLoadError::ObjSyntax { line: 3, .. }), "{e}");

    let stl = "solid h\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 -2e9 0\nendloop\nendfacet\nendsolid h\n";
    let p = dir.path().join("huge_ascii.stl");
    std::fs::write(&p, stl).unwrap();
    let e = inspect(&p).unwrap_err();
    assert!(matches!(e, MeshLoadError::StlSyntax { line: 6, .. }), "{e}");
}

#[test]
fn inspect_largest_coordinates_gives_finite_volume_works() {
    // A sphere as large as the bound allows: every figure `lamina inspect` prints is finite.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("big.stl");
    save_stl_binary(&p, &synthetic::sphere([0.0; 3], 0.9e9, 3), Units::Metre).unwrap();
    let i = inspect(&p).unwrap();
    assert!(i.volume.is_finite() && i.volume > 0.0 && i.area.is_finite(), "{i:?}");
    assert!(!i.to_string().contains("NaN"), "{i}");
}

#[test]
fn mesh_fifo_is_refused_works() {
    // A FIFO with no writer: reading it used to block forever.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("pipe.stl");
    let c = CString::new(p.as_os_str().as_bytes()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let e = load(&p, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::Read(FileReadError::NotRegular { .. })), "{e}");
    assert!(e.to_string().contains("pipe.stl: is a FIFO (named pipe), not a regular file"), "{e}");
}

#[test]
fn mesh_dev_urandom_and_dev_zero_are_refused_works() {
    // Linked as `x.stl` so the extension picks a parser: still refused by its metadata.
    let dir = tempfile::tempdir().unwrap();
    for dev in ["/dev/urandom", "/dev/zero"] {
        let p = dir.path().join("x.stl");
        let _ = std::fs::remove_file(&p);
        std::os::unix::fs::symlink(dev, &p).unwrap();
        let e = inspect(&p).unwrap_err();
        assert!(matches!(e, MeshLoadError::Read(FileReadError::NotRegular { kind: "a character device", .. })), "{e}");
    }
}

#[test]
fn mesh_empty_after_welding_names_the_tolerance_works() {
    // Every triangle smaller than the weld tolerance asked for: the message says why.
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("tiny.stl");
    save_stl_binary(&p, &synthetic::sphere([0.0; 3], 1.0, 1), Units::Metre).unwrap();
    let e = load(&p, &LoadOptions::default().weld_tolerance(10.0)).unwrap_err();
    assert!(matches!(e, MeshLoadError::Empty { degenerate_removed: 80, .. }), "{e}");
    assert!(
        e.to_string().contains("welding vertices closer than 1e1 file units made all 80 triangles degenerate"),
        "{e}"
    );
}
