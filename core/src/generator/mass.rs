//! Node masses from tissue density and each node's share of the element volumes.
//!
//! The skin layer is cut into tetrahedra that tile it exactly (the paper's "tetrahedral
//! skin layer"): per outer triangle `(a, b, c)` with skin/fat node `t`, the tet
//! `(a, b, c, t)`; per outer edge `(a, b)` shared by triangles with nodes `t`, `t′`, the tet
//! `(a, b, t, t′)`; per triangle `(t₁, t₂, t₃)` of the dual polygon around grid point `v`,
//! the tet `(v, t₁, t₂, t₃)`. Each tet gives a quarter of `ρ_skin · V` to each corner. A
//! block is cut into one triangular prism per level triangle, each giving a sixth of
//! `ρ · V` to each corner. Total mass is then `Σ ρ · V` over the polyhedral layers.

use super::grid::GridSize;
use super::materials::Materials;
use super::topology::LayeredTopology;
use super::vec3::tet_volume;

/// Mass of every model node, kg, for node positions `positions` (m) in model order.
pub(crate) fn node_masses(positions: &[[f64; 3]], topo: &LayeredTopology, materials: &Materials) -> Vec<f64> {
    let grid: GridSize = topo.grid;
    let mut mass = vec![0.0; positions.len()];
    let p = |i: u32| positions[i as usize];
    let add_tet = |nodes: [u32; 4], density: f64, mass: &mut [f64]| {
        let share = density * tet_volume(p(nodes[0]), p(nodes[1]), p(nodes[2]), p(nodes[3])) / 4.0;
        nodes.iter().for_each(|&n| mass[n as usize] += share);
    };
    let skin = materials.skin.density;
    for (t, c) in topo.outer_triangles.iter().enumerate() {
        let s = |v: u32| grid.surface_node(v);
        add_tet([s(c[0]), s(c[1]), s(c[2]), grid.triangle_node(1, t as u32)], skin, &mut mass);
    }
    for &([a, b], [t, u]) in &topo.shared_edges {
        add_tet(
            [grid.surface_node(a), grid.surface_node(b), grid.triangle_node(1, t), grid.triangle_node(1, u)],
            skin,
            &mut mass,
        );
    }
    for (tri, &v) in topo.level_triangles.iter().zip(&topo.level_triangle_apex) {
        let l = |t: u32| grid.triangle_node(1, t);
        add_tet([grid.surface_node(v), l(tri[0]), l(tri[1]), l(tri[2])], skin, &mut mass);
    }
    for (upper, density) in [(1, materials.fat.density), (2, materials.muscle.density)] {
        for tri in &topo.level_triangles {
            let a = tri.map(|t| grid.triangle_node(upper, t));
            let b = tri.map(|t| grid.triangle_node(upper + 1, t));
            let volume = tet_volume(p(a[0]), p(a[1]), p(a[2]), p(b[0]))
                + tet_volume(p(a[1]), p(a[2]), p(b[0]), p(b[1]))
                + tet_volume(p(a[2]), p(b[0]), p(b[1]), p(b[2]));
            let share = density * volume / 6.0;
            a.iter().chain(&b).for_each(|&n| mass[n as usize] += share);
        }
    }
    mass
}
