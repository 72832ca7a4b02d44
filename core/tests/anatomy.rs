//! The generator on segmented surfaces: synthetic nested cylinders written as STL must give
//! the built-in analytic cylinder limb; the real BodyParts3D thigh must give a valid layered
//! model whose nodes lie inside the skin, in skin → fat → muscle → bone order along every
//! ray, with a missing file named in the error. The real data is the repository's
//! `data/bodyparts3d-leg/`.

use lamina_core::generator::{AnatomySpec, CylinderLimb, GridSize, Materials, generate, generate_anatomy};
use lamina_mesh::synthetic::cylinder;
use lamina_mesh::{RayCaster, Units, save_stl_binary};
use std::path::PathBuf;

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_anatomy_{tag}_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A 1024-gon cylinder of radius `r` (m) reaching 5 cm past both ends of `limb`, as STL.
fn write_cylinder(dir: &std::path::Path, name: &str, r: f64, limb: &CylinderLimb) -> PathBuf {
    let p = dir.join(name);
    save_stl_binary(&p, &cylinder(r, -0.05, limb.length + 0.05, 1024, 40), Units::Millimetre).unwrap();
    p
}

/// Largest distance between corresponding nodes of two models, m.
fn largest_node_difference(a: &lamina_core::model::Model, b: &lamina_core::model::Model) -> f64 {
    a.nodes
        .position
        .iter()
        .zip(&b.nodes.position)
        .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt())
        .fold(0.0, f64::max)
}

#[test]
fn anatomy_of_synthetic_cylinders_matches_analytic_limb_works() {
    let dir = scratch("cyl");
    let limb = CylinderLimb { grid: GridSize::new(20, 5), ..CylinderLimb::default() };
    let write = |name: &str, r: f64| write_cylinder(&dir, name, r, &limb);
    let spec = AnatomySpec {
        skin: write("skin.stl", limb.outer_skin_radius),
        fat_muscle: write("fat_muscle.stl", limb.fat_muscle_radius),
        bone: write("bone.stl", limb.bone_radius),
        z_range: (0.0, limb.length),
        grid: limb.grid,
        skin_fat: None,
        skin_thickness: limb.outer_skin_radius - limb.skin_fat_radius,
        min_layer: 1e-3,
        materials: Materials::default(),
    };
    let (mesh_model, report) = generate_anatomy(&spec, None).unwrap();
    let analytic = generate(&limb, &Materials::default()).unwrap();
    assert_eq!(mesh_model.nodes.len(), analytic.nodes.len());
    assert_eq!(mesh_model.springs.len(), analytic.springs.len());
    let worst = largest_node_difference(&mesh_model, &analytic);
    // 1024-gon against the circle: the chord lies at most r (1 - cos(pi/1024)) = 0.24 um inside.
    assert!(worst < 2e-6, "largest node difference {worst} m");
    assert_eq!(report.fat_muscle_repairs, (0, 0), "nested cylinders need no repair");
    assert_eq!(report.bone_repairs, (0, 0));
    assert_eq!(report.skin_fat_repairs, (0, 0));
}

#[test]
fn anatomy_with_a_segmented_skin_fat_surface_takes_the_skin_thickness_from_it_works() {
    // The dermis bottom given as a fourth surface 3 mm under the skin while skin_thickness
    // says 2 mm: the model must follow the surface, i.e. equal the analytic limb whose
    // skin/fat radius is 47 mm.
    let dir = scratch("dermis");
    let limb = CylinderLimb { grid: GridSize::new(16, 4), skin_fat_radius: 0.047, ..CylinderLimb::default() };
    let write = |name: &str, r: f64| write_cylinder(&dir, name, r, &limb);
    let spec = AnatomySpec {
        skin: write("skin.stl", limb.outer_skin_radius),
        fat_muscle: write("fat_muscle.stl", limb.fat_muscle_radius),
        bone: write("bone.stl", limb.bone_radius),
        skin_fat: Some(write("skin_fat.stl", limb.skin_fat_radius)),
        z_range: (0.0, limb.length),
        grid: limb.grid,
        skin_thickness: 0.002,
        min_layer: 1e-3,
        materials: Materials::default(),
    };
    let (mesh_model, report) = generate_anatomy(&spec, None).unwrap();
    let analytic = generate(&limb, &Materials::default()).unwrap();
    let worst = largest_node_difference(&mesh_model, &analytic);
    assert!(worst < 2e-6, "largest node difference {worst} m");
    assert_eq!(report.loads.len(), 4, "the fourth surface's load report is kept");
    assert_eq!(report.skin_fat_repairs, (0, 0));
    assert!(mesh_model.provenance.iter().any(|(k, v)| k == "anatomy.skin_fat" && v.ends_with("skin_fat.stl")));
    // The fit's geometry measures the skin as 3 mm thick: an outer grid point's distance to
    // the skin/fat surface, whose flat triangles lie inside the 47 mm circle by at most
    // 47 mm (1 - cos(11.25 deg)) = 0.9 mm (32 nodes around, chords of 11.25 deg).
    let g = lamina_core::fit::anatomy_geometry(&mesh_model, &spec).unwrap();
    assert!(g[0].thickness_m >= 0.003 - 1e-6 && g[0].thickness_m < 0.0039, "skin {} m", g[0].thickness_m);
    assert!((g[1].thickness_m - 0.007).abs() < 1e-4, "fat {} m", g[1].thickness_m);
}

#[test]
fn anatomy_missing_file_is_named_fails() {
    let spec = AnatomySpec {
        skin: PathBuf::from("/nonexistent/skin_outer.stl"),
        fat_muscle: PathBuf::from("/nonexistent/fat.stl"),
        bone: PathBuf::from("/nonexistent/bone.stl"),
        z_range: (0.45, 0.78),
        grid: GridSize::new(12, 3),
        skin_fat: None,
        skin_thickness: 0.002,
        min_layer: 0.001,
        materials: Materials::default(),
    };
    let e = generate_anatomy(&spec, None).unwrap_err().to_string();
    assert!(e.contains("/nonexistent/skin_outer.stl"), "{e}");
}

/// Whether `p` is inside the closed surface of `caster`: odd number of crossings of a ray.
fn inside(caster: &RayCaster, p: [f64; 3]) -> bool {
    // A slightly skewed direction avoids grazing shared edges.
    caster.cast_all(p, [1.0, 0.013, 0.007], f64::INFINITY).len() % 2 == 1
}

#[test]
fn anatomy_real_thigh_is_layered_and_inside_the_skin_works() {
    let data = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/bodyparts3d-leg");
    let grid = GridSize::new(24, 6);
    let spec = AnatomySpec {
        skin: data.join("skin_outer.stl"),
        fat_muscle: data.join("fat_muscle_boundary.stl"),
        bone: data.join("bone_femur.stl"),
        z_range: (0.45, 0.78),
        grid,
        skin_fat: None,
        skin_thickness: 0.002,
        min_layer: 0.001,
        materials: Materials::default(),
    };
    let (model, report) = generate_anatomy(&spec, None).unwrap();
    model.validate().unwrap();
    let (w, h) = (grid.columns as usize, grid.rows as usize);
    assert_eq!(model.nodes.len(), w * (7 * h + 1), "W(7H+1) masses");
    assert_eq!(report.loads[1].1.flipped_fixed, 6_794, "the README's flipped triangles, fixed");
    assert!(model.springs.rest_length.iter().all(|&l| l > 1e-4), "no degenerate springs");
    // Every node inside the skin surface (or on it, for the outer grid).
    let skin = lamina_mesh::load(&spec.skin, &lamina_mesh::LoadOptions::default()).unwrap().mesh;
    let caster = RayCaster::new(&skin);
    let outer = w * (h + 1);
    let outside = model.nodes.position[outer..].iter().filter(|p| !inside(&caster, **p)).count();
    assert_eq!(outside, 0, "nodes below the skin that are outside it");
    // Along each ray (one per outer triangle), levels 1..3 go inward: skin/fat, fat/muscle,
    // bone; distance to the femur's axis (the region's z axis at the node's height through
    // the femur centroid) decreases. The femur centroid moves little over the region; use
    // each level-3 node's own position as the ray's end instead: the previous levels must be
    // farther from it than the next.
    let t_count = 2 * w * h;
    let node = |level: usize, t: usize| model.nodes.position[outer + (level - 1) * t_count + t];
    let mut out_of_order = 0;
    for t in 0..t_count {
        let end = node(3, t);
        let d = |p: [f64; 3]| ((p[0] - end[0]).powi(2) + (p[1] - end[1]).powi(2)).sqrt();
        if !(d(node(1, t)) > d(node(2, t)) && d(node(2, t)) > 0.0) {
            out_of_order += 1;
        }
    }
    assert_eq!(out_of_order, 0, "rays whose layers are not in skin, fat, muscle, bone order");
    let repaired = report.fat_muscle_repairs.0 + report.fat_muscle_repairs.1;
    assert!(repaired * 20 < t_count, "repairs are the exception: {repaired} of {t_count}");
}
