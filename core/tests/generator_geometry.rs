//! Geometry and structure of generated limbs: surfaces, polygons, boundaries, kinds,
//! masses, failures.

use lamina_core::generator::{
    Boundary, BoundarySurface, Centreline, Cylinder, CylinderLimb, GeneratorError, GridSize, InwardOffset,
    LayeredTopology, LimbSurfaces, Materials, STAGES, SpringMaterial, generate, generate_layered,
    generate_with_progress,
};
use lamina_core::model::{Model, NodeKind, Tissue};
use std::collections::HashMap;

fn limb(w: u32, h: u32) -> (CylinderLimb, Model) {
    let spec = CylinderLimb::new(w, h);
    let model = generate(&spec, &Materials::default()).unwrap();
    (spec, model)
}

fn radius(p: [f64; 3]) -> f64 {
    p[0].hypot(p[1])
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

#[test]
fn generator_model_validates_and_springs_are_sound_works() {
    for (w, h) in [(12, 3), (21, 6), (39, 10)] {
        let (_, model) = limb(w, h);
        model.validate().unwrap();
        let mut degree = vec![0usize; model.nodes.len()];
        for i in 0..model.springs.len() {
            let (a, b) = (model.springs.a[i] as usize, model.springs.b[i] as usize);
            assert!(
                model.springs.rest_length[i] > 1e-4,
                "{w}x{h} spring {i} has length {}",
                model.springs.rest_length[i]
            );
            degree[a] += 1;
            degree[b] += 1;
        }
        assert!(degree.iter().all(|&d| d >= 3), "{w}x{h}: a node has fewer than 3 springs");
    }
}

#[test]
fn generator_outer_surface_closed_around_and_outward_works() {
    let (spec, model) = limb(15, 5);
    let (w, h) = (15u32, 5u32);
    let outer = &model.surfaces[0];
    assert_eq!(outer.name, "skin_outer");
    assert_eq!(outer.triangles.len(), (2 * w * h) as usize);
    // Closed around: every edge is shared by two triangles except the ring edges at the two ends.
    let mut uses: HashMap<(u32, u32), usize> = HashMap::new();
    for t in &outer.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let open: Vec<_> = uses.iter().filter(|(_, n)| **n == 1).map(|(e, _)| *e).collect();
    assert_eq!(open.len(), 2 * w as usize);
    let ring = |v: u32| v / w;
    assert!(open.iter().all(|&(a, b)| ring(a) == ring(b) && (ring(a) == 0 || ring(a) == h)));
    assert!(uses.values().all(|&n| n <= 2));
    // The grid repeats the seam column so it covers every cell.
    let (cols, rows, nodes) = outer.grid.as_ref().unwrap();
    assert_eq!((*cols, *rows), (w + 1, h + 1));
    assert_eq!(nodes.len(), ((w + 1) * (h + 1)) as usize);
    for r in 0..=h as usize {
        assert_eq!(nodes[r * (w as usize + 1)], nodes[r * (w as usize + 1) + w as usize]);
    }
    for (k, p) in model.nodes.position.iter().take(((w * (h + 1)) as usize).min(nodes.len())).enumerate() {
        assert!((radius(*p) - spec.outer_skin_radius).abs() <= 1e-12 * spec.outer_skin_radius, "node {k}");
    }
}

#[test]
fn generator_every_surface_counter_clockwise_from_outside_works() {
    let (_, model) = limb(18, 5);
    assert_eq!(
        model.surfaces.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(),
        ["skin_outer", "skin_fat", "fat_muscle", "muscle_bone"]
    );
    for s in &model.surfaces {
        for t in &s.triangles {
            let [a, b, c] = t.map(|i| model.nodes.position[i as usize]);
            let n = cross(sub(b, a), sub(c, a));
            let m = [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0];
            assert!(n[0] * m[0] + n[1] * m[1] > 0.0, "{}: triangle {t:?} faces inward", s.name);
        }
    }
}

#[test]
fn generator_dual_polygons_inner_vertices_have_six_masses_works() {
    let grid = GridSize::new(12, 5);
    let topo = LayeredTopology::new(grid);
    for p in &topo.polygons {
        let ring = p.vertex / grid.columns;
        if ring == 0 || ring == grid.rows {
            assert!(!p.closed);
            assert_eq!(p.triangles.len(), 3, "end-ring vertex {}", p.vertex);
        } else {
            assert!(p.closed);
            assert_eq!(p.triangles.len(), 6, "inner vertex {}", p.vertex);
        }
        // Each listed triangle has the vertex as a corner, and consecutive ones share an edge.
        for &t in &p.triangles {
            assert!(topo.outer_triangles[t as usize].contains(&p.vertex));
        }
        for w in p.triangles.windows(2) {
            let (a, b) = (topo.outer_triangles[w[0] as usize], topo.outer_triangles[w[1] as usize]);
            assert_eq!(a.iter().filter(|v| b.contains(v)).count(), 2);
        }
    }
    // Each inner hexagon is cut into 4 triangles, each end chain into 1.
    let inner = (grid.columns * (grid.rows - 1)) as usize;
    assert_eq!(topo.level_triangles.len(), 4 * inner + 2 * grid.columns as usize);
}

#[test]
fn generator_boundary_nodes_lie_on_their_cylinders_works() {
    let (spec, model) = limb(39, 10);
    let grid = spec.grid;
    for (level, boundary) in [(1, Boundary::SkinFat), (2, Boundary::FatMuscle), (3, Boundary::MuscleBone)] {
        let r = spec.radius(boundary);
        for t in 0..grid.triangles() as u32 {
            let p = model.nodes.position[grid.triangle_node(level, t) as usize];
            assert!((radius(p) - r).abs() <= 1e-12 * r, "{boundary:?} triangle {t}: radius {}", radius(p));
        }
    }
}

#[test]
fn generator_bone_nodes_fixed_others_free_works() {
    let (spec, model) = limb(24, 6);
    let first_bone = spec.grid.triangle_node(3, 0) as usize;
    let bone = model.layer_index("bone").unwrap();
    assert_eq!(model.layers[bone as usize].tissue, Tissue::Bone);
    for (n, kind) in model.nodes.kind.iter().enumerate() {
        let expect = if n >= first_bone { NodeKind::Fixed } else { NodeKind::Free };
        assert_eq!(*kind, expect, "node {n}");
        assert_eq!(model.nodes.layer[n] == bone, n >= first_bone);
    }
    assert!(model.springs.layer.iter().all(|&l| l != bone), "no springs in the bone layer");
}

#[test]
fn generator_springs_take_their_layer_material_works() {
    let (_, model) = limb(12, 3);
    let m = Materials::default();
    for i in 0..model.springs.len() {
        let layer = model.springs.layer[i];
        let material = m.of_layer(layer);
        assert_eq!(model.springs.law[i], material.spring.law(model.springs.rest_length[i]));
        assert_eq!(model.springs.damping[i], material.damping);
    }
    assert!(matches!(m.fat.spring, SpringMaterial::Linear { .. }));
}

#[test]
fn generator_node_masses_sum_to_layer_volumes_works() {
    let (spec, model) = limb(39, 10);
    let m = Materials::default();
    let shell = |outer: f64, inner: f64| std::f64::consts::PI * (outer * outer - inner * inner) * spec.length;
    let expected = m.skin.density * shell(spec.outer_skin_radius, spec.skin_fat_radius)
        + m.fat.density * shell(spec.skin_fat_radius, spec.fat_muscle_radius)
        + m.muscle.density * shell(spec.fat_muscle_radius, spec.bone_radius);
    let total = model.nodes.total_mass();
    println!("total mass {total:.4} kg, smooth cylinders {expected:.4} kg");
    // The elements are polyhedral (inscribed in the cylinders: the 2 mm skin loses about 4 %
    // to the 39-gon), and the deeper levels end at the end cells' triangle nodes, a third to
    // two thirds of a cell (1–2 cm) inside each end: a few per cent less than the smooth limb.
    assert!(total < expected && total > 0.94 * expected, "total {total} kg against {expected} kg");
    assert!(model.nodes.mass.iter().all(|&x| x > 0.0));
}

#[test]
fn generator_progress_reports_every_stage_works() {
    let mut seen: Vec<(String, usize, usize)> = Vec::new();
    let mut record = |stage: &str, done: usize, total: usize| seen.push((stage.to_string(), done, total));
    generate_with_progress(&CylinderLimb::new(12, 3), &Materials::default(), Some(&mut record)).unwrap();
    for stage in STAGES {
        let of_stage: Vec<_> = seen.iter().filter(|s| s.0 == stage).collect();
        assert!(of_stage.len() >= 2, "stage {stage}");
        assert_eq!(of_stage[0].1, 0);
        let last = of_stage.last().unwrap();
        assert_eq!(last.1, last.2, "stage {stage} ends at its total");
        assert!(of_stage.windows(2).all(|w| w[0].1 <= w[1].1));
    }
}

#[test]
fn generator_layer_counts_follow_closed_forms_works() {
    // The closed forms of `generator::families` and docs/generator.md: on a W x H grid the
    // skin holds the outer nodes and the skin/fat level, W(3H+1), the fat the fat/muscle level
    // and the bone the muscle/bone level, 2WH each (the muscle has no level of its own); the
    // skin has W(15H-1) springs, fat and muscle each a cross-linked block of W(20H-6), the bone
    // none. 39 x 10: 1,209 / 780 / 0 / 780 nodes, 5,811 / 7,566 / 7,566 / 0 springs.
    for (w, h) in [(24usize, 6usize), (39, 10)] {
        let (_, model) = limb(w as u32, h as u32);
        for (name, nodes, springs) in [
            ("skin", w * (3 * h + 1), w * (15 * h - 1)),
            ("fat", 2 * w * h, w * (20 * h - 6)),
            ("muscle", 0, w * (20 * h - 6)),
            ("bone", 2 * w * h, 0),
        ] {
            let layer = model.layer_index(name).unwrap();
            let of_nodes = model.nodes.layer.iter().filter(|&&l| l == layer).count();
            let of_springs = model.springs.layer.iter().filter(|&&l| l == layer).count();
            assert_eq!((of_nodes, of_springs), (nodes, springs), "{w}x{h} {name}: nodes, springs");
        }
    }
}

#[test]
fn generator_inward_offset_of_cylinder_matches_inner_cylinder_works() {
    let outer = Cylinder { point: [0.0; 3], direction: [0.0, 0.0, 1.0], radius: 0.05 };
    let offset = InwardOffset { surface: outer, thickness: 0.002, reach: 0.2 };
    let inner = Cylinder { radius: 0.048, ..outer };
    for (origin, axis) in [([0.0485, 0.001, 0.1], [0.0, 0.0, 0.1]), ([0.3, -0.2, 0.0], [0.0, 0.0, 0.0])] {
        let (a, b) = (offset.hit_toward_axis(origin, axis).unwrap(), inner.hit_toward_axis(origin, axis).unwrap());
        assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-15), "{a:?} vs {b:?}");
    }
    // An origin already below the offset surface does not hit it.
    assert_eq!(offset.hit_toward_axis([0.047, 0.0, 0.0], [0.0; 3]), None);
}

#[test]
fn generator_layered_with_offset_skin_works() {
    let spec = CylinderLimb::new(21, 6);
    let centreline = Centreline::new(vec![[0.0; 3], [0.0, 0.0, 0.15], [0.0, 0.0, 0.3]]).unwrap();
    let [outer, _, fat_muscle, bone] = Boundary::ALL.map(|b| spec.cylinder(b));
    let skin_fat = InwardOffset { surface: outer, thickness: 0.002, reach: 0.2 };
    let surfaces = LimbSurfaces {
        centreline: &centreline,
        outer_skin: &outer,
        skin_fat: &skin_fat,
        fat_muscle: &fat_muscle,
        muscle_bone: &bone,
        reach: 0.1,
    };
    let with_offset = generate_layered("offset", &surfaces, spec.grid, &Materials::default(), None).unwrap();
    let analytic = generate(&spec, &Materials::default()).unwrap();
    assert_eq!(with_offset.springs.a, analytic.springs.a);
    for (p, q) in with_offset.nodes.position.iter().zip(&analytic.nodes.position) {
        assert!(p.iter().zip(q).all(|(x, y)| (x - y).abs() < 1e-12));
    }
}

#[test]
fn generator_too_few_columns_for_skin_fails() {
    // With 10 columns the outer triangles' centroids lie 1.7 mm inside a 50 mm skin: below
    // the skin/fat cylinder 2 mm down.
    let err = generate(&CylinderLimb::new(10, 3), &Materials::default()).unwrap_err();
    assert_eq!(err, GeneratorError::RayMissed { boundary: Boundary::SkinFat, column: 0, row: 0, triangle: Some(0) });
    assert!(err.to_string().contains("skin_fat") && err.to_string().contains("column 0, row 0"), "{err}");
}

#[test]
fn generator_bad_inputs_fails() {
    let m = Materials::default();
    assert_eq!(generate(&CylinderLimb::new(2, 3), &m).unwrap_err(), GeneratorError::BadGrid { columns: 2, rows: 3 });
    assert_eq!(generate(&CylinderLimb::new(12, 0), &m).unwrap_err(), GeneratorError::BadGrid { columns: 12, rows: 0 });
    let inverted = CylinderLimb { fat_muscle_radius: 0.049, ..CylinderLimb::new(12, 3) };
    assert_eq!(generate(&inverted, &m).unwrap_err(), GeneratorError::BadCylinder);
    let mut bad = m;
    bad.fat.density = 0.0;
    assert_eq!(
        generate(&CylinderLimb::new(12, 3), &bad).unwrap_err(),
        GeneratorError::BadMaterial { tissue: Tissue::Fat }
    );
    // An outer skin beyond the rays' reach is missed at the first grid point.
    let spec = CylinderLimb::new(12, 3);
    let centreline = spec.centreline().unwrap();
    let [outer, skin_fat, fat_muscle, bone] = Boundary::ALL.map(|b| spec.cylinder(b));
    let surfaces = LimbSurfaces {
        centreline: &centreline,
        outer_skin: &outer,
        skin_fat: &skin_fat,
        fat_muscle: &fat_muscle,
        muscle_bone: &bone,
        reach: 0.03,
    };
    let err = generate_layered("short", &surfaces, spec.grid, &m, None).unwrap_err();
    assert_eq!(err, GeneratorError::RayMissed { boundary: Boundary::OuterSkin, column: 0, row: 0, triangle: None });
}
