//! The real BodyParts3D right-leg surfaces of the repository's `data/bodyparts3d-leg/` (see
//! its README.md for the source and licence).

use std::path::PathBuf;
use std::time::Instant;

use lamina_mesh::{CentrelineOptions, LoadOptions, Units, centreline, cross_section, inspect, load};

/// The repository's `data/bodyparts3d-leg/`.
fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/bodyparts3d-leg")
}

#[test]
fn leg_fat_muscle_boundary_load_works() {
    let dir = data_dir();
    let path = dir.join("fat_muscle_boundary.stl");
    let t0 = Instant::now();
    let loaded = load(&path, &LoadOptions::default()).unwrap();
    println!("load {}: {:.1} ms", path.display(), t0.elapsed().as_secs_f64() * 1e3);
    let r = loaded.report;
    println!("{r:?}");
    assert_eq!(r.units, Units::Millimetre);
    assert!(r.units_inferred);
    assert_eq!(r.raw_triangles, 129_236);
    assert_eq!(r.raw_vertices, 3 * 129_236);
    // The README's count: the triangles wound inward on a closed surface.
    assert_eq!(r.flipped_fixed, 6_794);
    assert!(loaded.mesh.signed_volume() > 0.0);
}

/// Triangles in a binary STL as its own header states (the u32 after the 80-byte header),
/// with the file's size checked against it (84 bytes + 50 per triangle): a reader apart
/// from `lamina-mesh`'s.
fn stl_header_triangles(path: &std::path::Path) -> usize {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 84 + 50 * n, "{}: size against its header's {n} triangles", path.display());
    n
}

#[test]
fn leg_inspect_all_files_match_the_data_readme_works() {
    let dir = data_dir();
    // The table of data/bodyparts3d-leg/README.md: file, triangles, z range in mm.
    for (name, triangles, z_min_mm, z_max_mm) in [
        ("skin_outer.stl", 58_010, -13.0, 810.0),
        ("fat_muscle_boundary.stl", 129_236, 157.0, 804.0),
        ("bone_femur.stl", 8_574, 403.0, 843.0),
        ("bone_tibia.stl", 5_742, 60.0, 405.0),
        ("bone_fibula.stl", 4_206, 41.0, 391.0),
        ("bone_patella.stl", 836, 397.0, 436.0),
    ] {
        let path = dir.join(name);
        let ins = inspect(&path).unwrap();
        println!("{ins}");
        assert_eq!(ins.raw_triangles, triangles, "{name}: triangles");
        assert_eq!(ins.raw_triangles, stl_header_triangles(&path), "{name}: the STL header's count");
        assert_eq!(ins.raw_vertices, 3 * triangles, "{name}: unwelded corners");
        assert_eq!(ins.units, Units::Millimetre, "{name}");
        // The README's surfaces are closed once coincident corners are welded.
        assert!(ins.is_closed() && ins.holes == 0, "{name}: closed ({} boundary edges)", ins.boundary_edges);
        // Bounds in metres; the README rounds them to the millimetre.
        let (lo, hi) = (ins.bounding_box.min[2] * 1e3, ins.bounding_box.max[2] * 1e3);
        assert!((lo - z_min_mm).abs() <= 0.5 && (hi - z_max_mm).abs() <= 0.5, "{name}: z {lo:.2}..{hi:.2} mm");
    }
}

#[test]
fn leg_skin_centreline_thigh_works() {
    let dir = data_dir();
    let skin = load(dir.join("skin_outer.stl"), &LoadOptions::default()).unwrap().mesh;
    let opts = CentrelineOptions { stations: 34, range: Some((0.450, 0.780)), ..Default::default() };
    let line = centreline(&skin, &opts).unwrap();
    assert_eq!(line.axis, [0.0, 0.0, 1.0]);
    for s in &line.sections {
        println!(
            "z {:.3} m  centroid ({:.4}, {:.4})  area {:.5} m²  mean r {:.1} mm  equiv r {:.1} mm  loops {}",
            s.height,
            s.centroid[0],
            s.centroid[1],
            s.area,
            s.mean_radius * 1e3,
            s.equivalent_radius * 1e3,
            s.loops
        );
    }
    let s = line.nearest(0.650).unwrap();
    assert!((s.height - 0.650).abs() < 1e-9);
    assert!((s.mean_radius - 0.082).abs() < 0.004, "mean radius {} m", s.mean_radius);

    // The README's other measured mean radii: calf skin, and the fat/muscle boundary.
    let fat = load(dir.join("fat_muscle_boundary.stl"), &LoadOptions::default()).unwrap().mesh;
    for (mesh, name, z, r) in
        [(&skin, "skin", 0.350, 0.057), (&fat, "fat/muscle", 0.650, 0.066), (&fat, "fat/muscle", 0.350, 0.047)]
    {
        let s = cross_section(mesh, [0.0, 0.0, 1.0], z).unwrap();
        println!(
            "{name} z {z} m: mean radius {:.1} mm (README {:.0} mm), loops {}",
            s.mean_radius * 1e3,
            r * 1e3,
            s.loops
        );
        assert!((s.mean_radius - r).abs() < 0.004, "{name} at z {z}: {} m", s.mean_radius);
    }
}

#[test]
fn leg_all_files_load_closed_works() {
    let dir = data_dir();
    println!("{:<26}{:>10}{:>10}{:>10}{:>9}{:>10}", "file", "triangles", "welded", "flipped", "load ms", "volume L");
    for name in [
        "skin_outer.stl",
        "fat_muscle_boundary.stl",
        "bone_femur.stl",
        "bone_tibia.stl",
        "bone_fibula.stl",
        "bone_patella.stl",
    ] {
        let t0 = Instant::now();
        let loaded = load(dir.join(name), &LoadOptions::default()).unwrap();
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let r = loaded.report;
        println!(
            "{name:<26}{:>10}{:>10}{:>10}{ms:>9.1}{:>10.3}",
            r.triangles,
            r.welded_vertices,
            r.flipped_fixed,
            loaded.mesh.signed_volume() * 1e3
        );
        // Closed genus-0 surfaces: V − E + F = 2 with E = 3F / 2.
        assert_eq!(2 * r.welded_vertices, r.triangles + 4, "{name}");
    }
}
