//! The generator's model sizes against the paper's Table 3.

use lamina_core::generator::{
    CylinderLimb, GridSize, LayeredTopology, Materials, PAPER_TABLE3, SpringFamily, generate, table3_rows,
};
use std::collections::HashSet;

/// Generates the default limb on `w × h` and checks its counts against the closed forms.
fn check_counts(w: u32, h: u32) {
    let model = generate(&CylinderLimb::new(w, h), &Materials::default()).unwrap();
    let (wu, hu) = (w as usize, h as usize);
    assert_eq!(model.nodes.len(), wu * (7 * hu + 1), "{w}x{h} masses");
    assert_eq!(model.springs.len(), wu * (55 * hu - 13), "{w}x{h} springs");
    let topo = LayeredTopology::new(GridSize::new(w, h));
    for family in SpringFamily::ALL {
        for &layer in family.layers() {
            assert_eq!(topo.count(family, layer), family.count_per_layer(GridSize::new(w, h)), "{w}x{h} {family:?}");
        }
    }
    let pairs: HashSet<(u32, u32)> =
        model.springs.a.iter().zip(&model.springs.b).map(|(&a, &b)| (a.min(b), a.max(b))).collect();
    assert_eq!(pairs.len(), model.springs.len(), "{w}x{h}: duplicate springs");
}

#[test]
fn generator_table3_mass_and_spring_counts_every_size_works() {
    for row in PAPER_TABLE3 {
        check_counts(row.columns, row.rows);
    }
}

#[test]
fn generator_table3_paper_numbers_follow_closed_forms_works() {
    for p in PAPER_TABLE3 {
        let (w, h) = (p.columns as usize, p.rows as usize);
        assert_eq!(p.masses, w * (7 * h + 1));
        assert_eq!(p.springs, w * (52 * h - 2));
    }
}

#[test]
fn generator_table3_rows_match_models_works() {
    let table = table3_rows();
    println!("{table}");
    assert_eq!(table.rows.len(), PAPER_TABLE3.len());
    for r in &table.rows {
        assert_eq!(r.masses, r.paper_masses, "{}x{}: masses must match the paper exactly", r.columns, r.rows);
        // Documented gap (generator::families): ours − paper = W(3H − 11).
        let gap = r.columns as i64 * (3 * r.rows as i64 - 11);
        assert_eq!(r.springs as i64 - r.paper_springs as i64, gap, "{}x{}", r.columns, r.rows);
        assert!(r.difference_percent.abs() < 4.0, "{}x{}: {:.2} %", r.columns, r.rows, r.difference_percent);
        let model = generate(&CylinderLimb::new(r.columns, r.rows), &Materials::default()).unwrap();
        assert_eq!((model.nodes.len(), model.springs.len()), (r.masses, r.springs));
    }
}
