//! Volume cells: the generator's limb is cut into tetrahedra (skin) and wedges (fat, muscle),
//! the layered block into hexahedra; every cell is positive at rest in VTK's node order, the
//! cells fit together face to face, and they survive the XML model format.

use lamina_core::generator::{CylinderLimb, Materials, generate};
use lamina_core::io::{ModelReadError, model_from_str, model_to_string};
use lamina_core::model::{Cell, CellKind, Model, ModelValidateError};
use lamina_core::scene::{BlockSpec, Scene, layered_block};
use std::collections::{HashMap, HashSet};

fn count(model: &Model, kind: CellKind) -> usize {
    model.cells.iter().filter(|c| c.kind == kind).count()
}

/// The faces of a cell, each as its sorted node list.
fn faces(cell: &Cell) -> Vec<Vec<u32>> {
    let n = cell.nodes();
    let lists: &[&[usize]] = match cell.kind {
        CellKind::Tetra => &[&[0, 1, 2], &[0, 1, 3], &[0, 2, 3], &[1, 2, 3]],
        CellKind::Wedge => &[&[0, 1, 2], &[3, 4, 5], &[0, 1, 4, 3], &[1, 2, 5, 4], &[2, 0, 3, 5]],
        CellKind::Hexahedron => {
            &[&[0, 1, 2, 3], &[4, 5, 6, 7], &[0, 1, 5, 4], &[1, 2, 6, 5], &[2, 3, 7, 6], &[3, 0, 4, 7]]
        }
    };
    lists
        .iter()
        .map(|f| {
            let mut v: Vec<u32> = f.iter().map(|&k| n[k]).collect();
            v.sort_unstable();
            v
        })
        .collect()
}

/// No face is shared by more than two cells (overlapping cells would share more), and the
/// faces on the boundary are those of the outside.
fn face_use(model: &Model) -> HashMap<Vec<u32>, usize> {
    let mut uses: HashMap<Vec<u32>, usize> = HashMap::new();
    for cell in &model.cells {
        for f in faces(cell) {
            *uses.entry(f).or_default() += 1;
        }
    }
    uses
}

#[test]
fn limb_cells_counts_orientation_and_fit_works() {
    let model = Scene::builtin_default().build_model().unwrap();
    let (w, h) = (24, 6);
    // Skin: one tetrahedron per outer triangle (2WH), per shared outer edge (W(3H − 1)) and
    // per triangle of the dual polygons (4 per inner grid point, 1 per end-ring point:
    // W(4H − 2)). Fat and muscle: one wedge per dual-polygon triangle each.
    let dual = w * (4 * h - 2);
    assert_eq!(count(&model, CellKind::Tetra), 2 * w * h + w * (3 * h - 1) + dual);
    assert_eq!(count(&model, CellKind::Wedge), 2 * dual);
    assert_eq!(count(&model, CellKind::Hexahedron), 0);
    let p = &model.nodes.position;
    let springs: HashSet<(u32, u32)> =
        (0..model.springs.len()).map(|i| (model.springs.a[i], model.springs.b[i])).collect();
    let is_spring = |a: u32, b: u32| springs.contains(&(a, b)) || springs.contains(&(b, a));
    let mut volume_by_layer = [0.0; 4];
    for (i, cell) in model.cells.iter().enumerate() {
        let v = cell.volume(p);
        assert!(v > 0.0, "cell {i} ({:?}) has rest volume {v}", cell.kind);
        volume_by_layer[cell.layer as usize] += v;
        let n = cell.nodes();
        let edges: &[(usize, usize)] = match cell.kind {
            CellKind::Tetra => &[(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)],
            CellKind::Wedge => &[(0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3), (0, 3), (1, 4), (2, 5)],
            CellKind::Hexahedron => unreachable!(),
        };
        for &(a, b) in edges {
            assert!(is_spring(n[a], n[b]), "cell {i}: edge {}-{} is not a spring", n[a], n[b]);
        }
        let expect_layer = match cell.kind {
            CellKind::Tetra => 0,
            // A wedge's top (nodes 3-5) is on the skin/fat level in the fat, on the
            // fat/muscle level in the muscle.
            _ => model.nodes.layer[n[3] as usize] + 1,
        };
        assert_eq!(cell.layer, expect_layer, "cell {i}");
    }
    let uses = face_use(&model);
    assert!(uses.values().all(|&u| u <= 2), "a face is shared by more than two cells");
    // Every outer-skin triangle is the face of exactly one cell: the skin is closed over.
    for t in &model.surfaces[0].triangles {
        let mut f = t.to_vec();
        f.sort_unstable();
        assert_eq!(uses.get(&f), Some(&1), "outer triangle {t:?}");
    }
    // The skin: 2 mm under the outer polygon (24 sides inscribed in r = 50 mm, 0.24 m long),
    // over a 48 mm polygon a third of a ring shorter at each end: within 10 % of the prism
    // between the two polygons.
    let polygon = |r: f64| 0.5 * w as f64 * r * r * (std::f64::consts::TAU / w as f64).sin();
    let skin = (polygon(0.050) - polygon(0.048)) * 0.24;
    assert!((volume_by_layer[0] / skin - 1.0).abs() < 0.10, "skin volume {} vs {skin}", volume_by_layer[0]);
}

#[test]
fn block_cells_are_unit_cubes_works() {
    let spec = BlockSpec { nx: 5, nz: 4, ..BlockSpec::default() };
    let model = layered_block(&spec);
    let rows = spec.rows();
    assert_eq!(model.cells.len(), (spec.nx - 1) * (rows - 1) * (spec.nz - 1));
    assert_eq!(count(&model, CellKind::Hexahedron), model.cells.len());
    let cube = spec.spacing.powi(3);
    for cell in &model.cells {
        assert!((cell.volume(&model.nodes.position) / cube - 1.0).abs() < 1e-9);
        // The cube's layer is that of its upper face's nodes.
        assert_eq!(cell.layer, model.nodes.layer[cell.nodes()[4] as usize]);
    }
    assert!(face_use(&model).values().all(|&u| u <= 2));
}

#[test]
fn cells_round_trip_and_old_files_load_works() {
    for model in [
        generate(&CylinderLimb::new(12, 3), &Materials::default()).unwrap(),
        layered_block(&BlockSpec { nx: 3, nz: 2, ..BlockSpec::default() }),
    ] {
        assert!(!model.cells.is_empty());
        let text = model_to_string(&model).unwrap();
        assert!(text.contains("<cells count="));
        assert_eq!(model_from_str(&text).unwrap(), model);
        // A file from before cells existed: the same model without them.
        let start = text.find("  <cells").unwrap();
        let end = text.find("</cells>\n").unwrap() + "</cells>\n".len();
        let old = format!("{}{}", &text[..start], &text[end..]);
        let read = model_from_str(&old).unwrap();
        assert!(read.cells.is_empty());
        assert_eq!(Model { cells: model.cells.clone(), ..read }, model);
    }
}

#[test]
fn bad_cells_are_refused_with_their_place_fails() {
    let model =
        layered_block(&BlockSpec { nx: 2, nz: 2, muscle_rows: 1, fat_rows: 0, skin_rows: 0, ..BlockSpec::default() });
    let text = model_to_string(&model).unwrap();
    let line = text.lines().position(|l| l.contains("<cell index=\"0\"")).unwrap() as u32 + 1;
    let cell = text.lines().nth(line as usize - 1).unwrap().to_string();
    let nodes = &cell[cell.find("nodes=\"").unwrap() + 7..cell.rfind('"').unwrap()];
    let swap = |with: &str| text.replace(&cell, &cell.replace(nodes, with));
    // Five nodes for a hexahedron.
    let err = model_from_str(&swap("0 1 2 3 4")).unwrap_err();
    assert!(matches!(err, ModelReadError::BadCellNodes { expected: 8, found: 5, .. }), "{err}");
    assert_eq!(err.line(), Some(line));
    assert!(err.to_string().contains("cell 0: a hexahedron cell has 8 nodes, attribute 'nodes' lists 5"), "{err}");
    // A node that does not exist.
    let err = model_from_str(&swap("0 1 2 3 4 5 6 99")).unwrap_err();
    assert!(matches!(err, ModelReadError::IndexOutOfRange { index: 99, .. }), "{err}");
    // One node twice.
    let err = model_from_str(&swap("0 1 2 3 4 5 6 6")).unwrap_err();
    assert!(matches!(err, ModelReadError::Invalid { reason: ModelValidateError::BadCell { cell: 0 }, .. }), "{err}");
    assert_eq!(err.line(), Some(line));
    // An unknown kind.
    let err = model_from_str(&text.replace("kind=\"hexahedron\"", "kind=\"pyramid\"")).unwrap_err();
    assert!(err.to_string().contains("'pyramid' is not one of: tetra, wedge, hexahedron"), "{err}");
}
