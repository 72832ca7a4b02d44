//! Closed-form checks of measures, topology and orientation repair on synthetic surfaces
//! written to temporary files and loaded back.

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use lamina_mesh::{LoadOptions, MeshLoadError, TriMesh, Units, inspect, load, save_stl_binary, synthetic};

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// Writes `mesh` (metres) as binary STL in metres: every triangle has its own corners.
fn write(dir: &Path, name: &str, mesh: &TriMesh) -> PathBuf {
    let p = dir.join(name);
    save_stl_binary(&p, mesh, Units::Metre).unwrap();
    p
}

fn with_triangles(mesh: &TriMesh, f: impl FnOnce(&mut Vec<[u32; 3]>)) -> TriMesh {
    let (v, mut t) = mesh.clone().into_parts();
    f(&mut t);
    TriMesh::new(v, t).unwrap()
}

fn unit_cube() -> TriMesh {
    synthetic::cuboid([0.0; 3], [1.0; 3], 2)
}

#[test]
fn cube_volume_area_euler_works() {
    let cube = unit_cube();
    assert_eq!(cube.triangle_count(), 48);
    assert!((cube.signed_volume() - 1.0).abs() < 1e-12);
    assert!((cube.area() - 6.0).abs() < 1e-12);
    let dir = tmp();
    let ins = inspect(write(dir.path(), "cube.stl", &cube)).unwrap();
    assert_eq!(ins.units, Units::Metre);
    assert!(ins.is_closed());
    assert_eq!(ins.euler_characteristic, 2);
    assert_eq!((ins.welded_vertices, ins.edges, ins.triangles), (26, 72, 48));
    assert!((ins.volume - 1.0).abs() < 1e-6);
    assert!((ins.area - 6.0).abs() < 1e-6);
    assert!((ins.mean_edge_length - (48.0 * 0.5 + 24.0 * 0.5f64 * 2f64.sqrt()) / 72.0).abs() < 1e-6);
}

#[test]
fn sphere_volume_area_euler_works() {
    let r = 0.1;
    let sphere = synthetic::sphere([0.3, -0.2, 0.5], r, 5);
    let (v_exact, a_exact) = (4.0 / 3.0 * PI * r.powi(3), 4.0 * PI * r * r);
    let (v, a) = (sphere.signed_volume(), sphere.area());
    println!("sphere 20480 triangles: volume error {:.2e}, area error {:.2e}", v / v_exact - 1.0, a / a_exact - 1.0);
    // Inscribed polyhedron: smaller than the sphere, by about (edge angle)² / 4 ≈ 3e-4 here.
    assert!(v < v_exact && v > v_exact * (1.0 - 1e-3));
    assert!(a < a_exact && a > a_exact * (1.0 - 1e-3));
    let dir = tmp();
    let ins = inspect(write(dir.path(), "sphere.stl", &sphere)).unwrap();
    assert_eq!(ins.euler_characteristic, 2);
    assert_eq!(ins.flipped_triangles, 0);
    assert!((ins.volume / v - 1.0).abs() < 1e-5); // f32 rounding in the file
}

#[test]
fn cylinder_and_cone_volume_works() {
    let n = 64;
    let polygon = |r: f64| n as f64 / 2.0 * r * r * (2.0 * PI / n as f64).sin();
    let cyl = synthetic::cylinder(0.05, 0.1, 0.4, n, 7);
    assert!((cyl.signed_volume() - polygon(0.05) * 0.3).abs() < 1e-15);
    let cone = synthetic::cone(0.05, 0.0, 0.0, 0.3, n, 5);
    assert!((cone.signed_volume() - polygon(0.05) * 0.3 / 3.0).abs() < 1e-15);
    // Reversed heights are still wound outward.
    assert!(synthetic::cone(0.02, 0.05, 0.3, 0.0, n, 5).signed_volume() > 0.0);
}

#[test]
fn cube_one_face_removed_fails() {
    let cube = unit_cube();
    // The last 8 triangles are one face (2 × 2 cells).
    let open = with_triangles(&cube, |t| t.truncate(40));
    let dir = tmp();
    let path = write(dir.path(), "open_cube.stl", &open);
    let e = load(&path, &LoadOptions::default()).unwrap_err();
    let MeshLoadError::OpenSurface { boundary_edges, holes, first_edge, .. } = &e else { panic!("{e}") };
    assert_eq!((*boundary_edges, *holes), (8, 1));
    assert!(first_edge.iter().all(|p| p.iter().all(|c| (0.0..=1.0).contains(c))));
    let msg = e.to_string();
    assert!(msg.contains("open_cube.stl") && msg.contains("1 hole") && msg.contains("8 boundary"), "{msg}");

    let ins = inspect(&path).unwrap();
    assert!(!ins.is_closed());
    assert_eq!((ins.boundary_edges, ins.holes, ins.euler_characteristic), (8, 1, 1));
    assert!(ins.to_string().contains("NO"));

    let loaded = load(&path, &LoadOptions::default().allow_open(true)).unwrap();
    assert_eq!(loaded.report.boundary_edges, 8);
    assert_eq!(loaded.mesh.triangle_count(), 40);
}

#[test]
fn cube_non_manifold_fin_fails() {
    let cube = unit_cube();
    let (mut v, mut t) = cube.into_parts();
    // A fin on the edge between two cube triangles: that edge now has three triangles.
    let [a, b, _] = t[0];
    v.push([5.0, 5.0, 5.0]);
    t.push([a, b, (v.len() - 1) as u32]);
    let fin = TriMesh::new(v, t).unwrap();
    let dir = tmp();
    let path = write(dir.path(), "fin.stl", &fin);
    let e = load(&path, &LoadOptions::default()).unwrap_err();
    assert!(matches!(e, MeshLoadError::NonManifold { non_manifold_edges: 1, triangles_on_first_edge: 3, .. }), "{e}");
    assert!(e.to_string().contains("fin.stl") && e.to_string().contains("not manifold"), "{e}");
    let ins = inspect(&path).unwrap();
    assert_eq!((ins.non_manifold_edges, ins.boundary_edges), (1, 2));
    // Allowing non-manifold edges still leaves the fin's two free edges.
    let e = load(&path, &LoadOptions::default().allow_non_manifold(true)).unwrap_err();
    assert!(matches!(e, MeshLoadError::OpenSurface { boundary_edges: 2, holes: 1, .. }), "{e}");
    let ok = load(&path, &LoadOptions::default().allow_non_manifold(true).allow_open(true)).unwrap();
    assert_eq!(ok.report.non_manifold_edges, 1);
}

#[test]
fn cube_flipped_triangles_fixed_and_counted_works() {
    let cube = unit_cube();
    let dir = tmp();
    // 3 of 48 inward: 3 reversed.
    let three = with_triangles(&cube, |t| [0, 17, 40].iter().for_each(|&i| t[i].swap(1, 2)));
    let r = load(write(dir.path(), "three.stl", &three), &LoadOptions::default()).unwrap();
    assert_eq!(r.report.flipped_fixed, 3);
    assert!((r.mesh.signed_volume() - 1.0).abs() < 1e-6);
    // One whole face (8 triangles) inward.
    let face = with_triangles(&cube, |t| t[40..].iter_mut().for_each(|t| t.swap(1, 2)));
    assert_eq!(load(write(dir.path(), "face.stl", &face), &LoadOptions::default()).unwrap().report.flipped_fixed, 8);
    // 45 of 48 inward: the count is the inward set (45), not the minority (3).
    let most = with_triangles(&cube, |t| {
        t.iter_mut().enumerate().filter(|(i, _)| ![0, 17, 40].contains(i)).for_each(|(_, t)| t.swap(1, 2))
    });
    let r = load(write(dir.path(), "most.stl", &most), &LoadOptions::default()).unwrap();
    assert_eq!(r.report.flipped_fixed, 45);
    assert!(r.mesh.signed_volume() > 0.0);
    // Entirely inside out: all 48.
    let mut inside_out = cube.clone();
    inside_out.flip_all();
    let r = load(write(dir.path(), "inside_out.stl", &inside_out), &LoadOptions::default()).unwrap();
    assert_eq!(r.report.flipped_fixed, 48);
    assert_eq!(inspect(dir.path().join("three.stl")).unwrap().flipped_triangles, 3);
}

#[test]
fn open_surface_flips_minority_works() {
    // Without a volume to decide, an open surface is made consistent with the fewest flips.
    let cube = unit_cube();
    let open = with_triangles(&cube, |t| {
        t.truncate(40);
        [1, 2, 30].iter().for_each(|&i| t[i].swap(1, 2));
    });
    let dir = tmp();
    let r = load(write(dir.path(), "open.stl", &open), &LoadOptions::default().allow_open(true)).unwrap();
    assert_eq!(r.report.flipped_fixed, 3);
}

#[test]
fn mobius_strip_non_orientable_fails() {
    let n = 12;
    let mut v = Vec::new();
    for i in 0..n {
        let th = 2.0 * PI * i as f64 / n as f64;
        let (c, s) = (th.cos(), th.sin());
        for w in [-0.1, 0.1] {
            let (rr, z) = (1.0 + w * (th / 2.0).cos(), w * (th / 2.0).sin());
            v.push([rr * c, rr * s, z]);
        }
    }
    let mut t = Vec::new();
    for i in 0..n {
        let (a0, a1) = (2 * i as u32, 2 * i as u32 + 1);
        // The last quad joins with a half twist: inner meets outer.
        let (b0, b1) = if i + 1 < n { (2 * (i as u32 + 1), 2 * (i as u32 + 1) + 1) } else { (1, 0) };
        t.push([a0, b0, b1]);
        t.push([a0, b1, a1]);
    }
    let strip = TriMesh::new(v, t).unwrap();
    let dir = tmp();
    let path = write(dir.path(), "mobius.stl", &strip);
    let e = load(&path, &LoadOptions::default().allow_open(true)).unwrap_err();
    assert!(matches!(e, MeshLoadError::NonOrientable { .. }), "{e}");
    assert!(e.to_string().contains("mobius.stl"));
    let ins = inspect(&path).unwrap();
    assert!(!ins.orientable);
    assert_eq!((ins.holes, ins.euler_characteristic), (1, 0));
}

#[test]
fn trimesh_new_invalid_fails() {
    use lamina_mesh::TriMeshBuildError;
    let e = TriMesh::new(vec![[0.0; 3]; 3], vec![[0, 1, 3]]).unwrap_err();
    assert_eq!(e, TriMeshBuildError::IndexOutOfRange { triangle: 0, index: 3, vertex_count: 3 });
    let e = TriMesh::new(vec![[0.0, f64::NAN, 0.0]], vec![]).unwrap_err();
    assert_eq!(e, TriMeshBuildError::NonFiniteVertex { vertex: 0 });
    let m = TriMesh::new(vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], vec![[0, 1, 2]]).unwrap();
    assert_eq!(m.triangle_normal(0), Some([0.0, 0.0, 1.0]));
    assert_eq!(m.triangle_normal(1), None);
    assert!((m.area() - 0.5).abs() < 1e-15);
}
