//! The layered topology of the paper's Fig. 2, on grid indices only: outer triangles,
//! the dual (Voronoi) polygon around each grid point, their triangulation, and every
//! spring by family. Geometry comes later; this part cannot fail.

use super::edge_table::{EdgeTable, TopologySpring};
use super::families::{SpringFamily, distinct_springs};
use super::grid::GridSize;
use super::layers::{FAT, MUSCLE, SKIN};
use std::collections::HashMap;

/// The bottom masses around one outer grid point: the nodes of its incident triangles,
/// counter-clockwise seen from outside (the paper's sorted queue).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DualPolygon {
    /// The outer grid point.
    pub vertex: u32,
    /// Ids of the incident triangles, counter-clockwise seen from outside. An inner grid
    /// point starts at the lowest-id triangle that has it as first corner (triangle 0 of
    /// its own cell), so every hexagon is triangulated the same way.
    pub triangles: Vec<u32>,
    /// Whether the triangles close a loop (inner grid point) or form an open chain
    /// (grid point on an end ring).
    pub closed: bool,
}

/// The connectivity of a layered model on a W × H grid.
///
/// Node levels: level 0 is the outer grid (`W(H+1)` nodes); levels 1, 2, 3 hold one
/// node per outer triangle on the skin/fat, fat/muscle and muscle/bone boundaries. Model
/// node numbers are [`GridSize::surface_node`] and [`GridSize::triangle_node`].
#[derive(Clone, Debug)]
pub struct LayeredTopology {
    /// The grid.
    pub grid: GridSize,
    /// Outer triangles as grid points, counter-clockwise seen from outside; index = id.
    pub outer_triangles: Vec<[u32; 3]>,
    /// One dual polygon per outer grid point, indexed by grid point.
    pub polygons: Vec<DualPolygon>,
    /// Triangles of each deeper level's surface, as outer-triangle ids (the same on every
    /// level), counter-clockwise seen from outside.
    pub level_triangles: Vec<[u32; 3]>,
    /// For each of `level_triangles`, the outer grid point whose polygon it triangulates.
    pub level_triangle_apex: Vec<u32>,
    /// Outer edges shared by two triangles: `([a, b], [left, right])`, grid points and
    /// triangle ids.
    pub shared_edges: Vec<([u32; 2], [u32; 2])>,
    /// Edges within a deeper level, as outer-triangle id pairs: dual edges then polygon
    /// diagonals (the same on every level).
    pub level_edges: Vec<([u32; 2], SpringFamily)>,
    /// Every spring, distinct, in construction order.
    pub springs: Vec<TopologySpring>,
    /// Insertions the edge table refused as repeats (each dual edge is met twice when the
    /// skin/fat polygons are connected one by one): `W(3H − 1)`.
    pub repeats: usize,
}

/// Zigzag triangulation of a polygon (or open chain) of `n ≥ 3` corners numbered
/// counter-clockwise: `(0,1,2)`, then alternately from the high end and the low end. For a
/// hexagon the diagonals are 0–2, 2–5, 3–5, which spreads them evenly over the two kinds of
/// triangle nodes. Returns triangles (counter-clockwise) and diagonals (for an open chain
/// the closing edge counts as a diagonal).
pub fn zigzag(n: usize, closed: bool) -> (Vec<[usize; 3]>, Vec<[usize; 2]>) {
    let mut triangles = vec![[0, 1, 2]];
    let (mut high, mut low) = (0usize, 2usize);
    let (mut next_low, mut next_high) = (3usize, n - 1);
    let mut take_high = true;
    while n > 3 && next_low <= next_high {
        if take_high {
            triangles.push([low, next_high, high]);
            high = next_high;
            next_high -= 1;
        } else {
            triangles.push([low, next_low, high]);
            low = next_low;
            next_low += 1;
        }
        take_high = !take_high;
    }
    let is_side = |i: usize, j: usize| i.abs_diff(j) == 1 || (closed && i.abs_diff(j) == n - 1);
    let mut diagonals = Vec::new();
    for t in &triangles {
        for k in 0..3 {
            let (i, j) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
            if !is_side(i, j) && !diagonals.contains(&[i, j]) {
                diagonals.push([i, j]);
            }
        }
    }
    (triangles, diagonals)
}

impl LayeredTopology {
    /// Builds the topology of a valid grid (see [`GridSize::is_valid`]).
    ///
    /// ## Panics
    /// When the grid is not valid.
    pub fn new(grid: GridSize) -> Self {
        assert!(grid.is_valid(), "grid {}x{} is not valid", grid.columns, grid.rows);
        let t_count = grid.triangles() as u32;
        let outer_triangles: Vec<[u32; 3]> = (0..t_count).map(|t| grid.triangle_corners(t)).collect();
        let polygons = dual_polygons(grid, &outer_triangles);
        let mut edges_of: HashMap<(u32, u32), Vec<u32>> = HashMap::with_capacity(3 * grid.triangles());
        for (t, c) in outer_triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                edges_of.entry((a.min(b), a.max(b))).or_default().push(t as u32);
            }
        }
        let mut shared_edges: Vec<([u32; 2], [u32; 2])> =
            edges_of.iter().filter(|(_, ts)| ts.len() == 2).map(|(&(a, b), ts)| ([a, b], [ts[0], ts[1]])).collect();
        shared_edges.sort_unstable();

        let mut table = EdgeTable::with_capacity(distinct_springs(grid));
        let level = |k: u32, t: u32| grid.triangle_node(k, t);
        // Skin, top: the triangulated outer grid.
        for c in &outer_triangles {
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                if !table.contains(a, b) {
                    table.insert(grid.surface_node(a), grid.surface_node(b), SpringFamily::OuterGrid, SKIN);
                }
            }
        }
        // Skin, bottom: each queue connected one by one (the edge table drops the second
        // meeting of each dual edge), then its triangulation.
        let mut level_edges = Vec::new();
        let mut level_triangles = Vec::new();
        let mut level_triangle_apex = Vec::new();
        for poly in &polygons {
            let q = &poly.triangles;
            let sides = if poly.closed { q.len() } else { q.len() - 1 };
            for i in 0..sides {
                let (s, t) = (q[i], q[(i + 1) % q.len()]);
                if table.insert(level(1, s), level(1, t), SpringFamily::DualEdge, SKIN) {
                    level_edges.push(([s, t], SpringFamily::DualEdge));
                }
            }
        }
        for poly in &polygons {
            let q = &poly.triangles;
            let (tris, diagonals) = zigzag(q.len(), poly.closed);
            for [i, j] in diagonals {
                if table.insert(level(1, q[i]), level(1, q[j]), SpringFamily::PolygonDiagonal, SKIN) {
                    level_edges.push(([q[i], q[j]], SpringFamily::PolygonDiagonal));
                }
            }
            for [i, j, k] in tris {
                level_triangles.push([q[i], q[j], q[k]]);
                level_triangle_apex.push(poly.vertex);
            }
        }
        // Skin, sides: each skin/fat node to the corners of its triangle (tetrahedra).
        for (t, c) in outer_triangles.iter().enumerate() {
            for &v in c {
                table.insert(level(1, t as u32), grid.surface_node(v), SpringFamily::TopBottom, SKIN);
            }
        }
        // Cross-linked blocks: fat between levels 1 and 2, muscle between 2 and 3.
        for (upper, layer) in [(1, FAT), (2, MUSCLE)] {
            let lower = upper + 1;
            for &([s, t], family) in &level_edges {
                table.insert(level(lower, s), level(lower, t), family, layer);
            }
            for t in 0..t_count {
                table.insert(level(upper, t), level(lower, t), SpringFamily::Vertical, layer);
            }
            for &([s, t], _) in &level_edges {
                table.insert(level(upper, s), level(lower, t), SpringFamily::Cross, layer);
                table.insert(level(upper, t), level(lower, s), SpringFamily::Cross, layer);
            }
        }
        let repeats = table.repeats();
        Self {
            grid,
            outer_triangles,
            polygons,
            level_triangles,
            level_triangle_apex,
            shared_edges,
            level_edges,
            springs: table.into_springs(),
            repeats,
        }
    }

    /// Springs of `family` in `layer`.
    pub fn count(&self, family: SpringFamily, layer: u16) -> usize {
        self.springs.iter().filter(|s| s.family == family && s.layer == layer).count()
    }
}

/// The incident triangles of every grid point, walked counter-clockwise: in triangle
/// `(v, a, b)` (rotated so `v` comes first) the next triangle around `v` is the one whose
/// `a` is this one's `b`.
fn dual_polygons(grid: GridSize, triangles: &[[u32; 3]]) -> Vec<DualPolygon> {
    let n = grid.surface_nodes();
    // Per grid point: (triangle, a, b, v is first corner).
    let mut incident: Vec<Vec<(u32, u32, u32, bool)>> = vec![Vec::with_capacity(6); n];
    for (t, c) in triangles.iter().enumerate() {
        for k in 0..3 {
            incident[c[k] as usize].push((t as u32, c[(k + 1) % 3], c[(k + 2) % 3], k == 0));
        }
    }
    incident
        .into_iter()
        .enumerate()
        .map(|(v, around)| {
            let open_start = around.iter().position(|&(_, a, _, _)| !around.iter().any(|&(_, _, b, _)| b == a));
            let closed = open_start.is_none();
            let start = open_start.unwrap_or_else(|| {
                let first =
                    around.iter().filter(|e| e.3).min_by_key(|e| e.0).or_else(|| around.iter().min_by_key(|e| e.0));
                around.iter().position(|e| Some(e) == first).unwrap_or(0)
            });
            let mut order = vec![around[start].0];
            let mut b = around[start].2;
            while let Some(next) = around.iter().find(|e| e.1 == b) {
                if next.0 == order[0] || order.len() == around.len() {
                    break;
                }
                order.push(next.0);
                b = next.2;
            }
            DualPolygon { vertex: v as u32, triangles: order, closed }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zigzag_hexagon_works() {
        let (tris, diags) = zigzag(6, true);
        assert_eq!(tris, vec![[0, 1, 2], [2, 5, 0], [2, 3, 5], [3, 4, 5]]);
        assert_eq!(diags, vec![[0, 2], [2, 5], [3, 5]]);
        let (tris, diags) = zigzag(3, false);
        assert_eq!((tris, diags), (vec![[0, 1, 2]], vec![[0, 2]]));
    }

    #[test]
    fn topology_family_counts_match_closed_forms_works() {
        for (w, h) in [(3, 1), (4, 2), (12, 3), (39, 10)] {
            let g = GridSize::new(w, h);
            let topo = LayeredTopology::new(g);
            for f in SpringFamily::ALL {
                for &layer in f.layers() {
                    assert_eq!(topo.count(f, layer), f.count_per_layer(g), "{w}x{h} {f:?} layer {layer}");
                }
            }
            assert_eq!(topo.springs.len(), distinct_springs(g));
            assert_eq!(topo.repeats, (w * (3 * h - 1)) as usize);
        }
    }

    #[test]
    fn dual_polygon_inner_hexagon_works() {
        let g = GridSize::new(12, 3);
        let topo = LayeredTopology::new(g);
        let v = g.vertex(5, 1);
        let p = &topo.polygons[v as usize];
        assert!(p.closed);
        let (c, r) = (5, 1);
        let expect = [
            g.triangle(c, r, 0),
            g.triangle(c, r, 1),
            g.triangle(c - 1, r, 0),
            g.triangle(c - 1, r - 1, 1),
            g.triangle(c - 1, r - 1, 0),
            g.triangle(c, r - 1, 1),
        ];
        assert_eq!(p.triangles, expect);
    }
}
