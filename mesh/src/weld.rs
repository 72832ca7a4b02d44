//! Welding of coincident vertices with a spatial hash, then removal of the triangles that
//! welding collapses.
//!
//! Each vertex is compared with the representatives already kept in the hash cells within
//! `tolerance` of it (cells are `4 × tolerance` wide, so a query touches 1 to 8 cells, about
//! 3.4 on average): O(n) expected time. A vertex joins the lowest-numbered representative
//! within `tolerance` (Euclidean distance, file units), otherwise it becomes a new one. The
//! merge is therefore greedy, not transitive: points in a chain each `0.9 × tolerance` apart
//! may end up in more than one group. A tolerance of zero (or one too small to matter next to
//! the coordinates) merges only bit-identical positions.

use rustc_hash::FxHashMap;

use crate::vec3::V3;

/// Result of welding: one position per kept vertex, and where each input vertex went.
pub(crate) struct Welded {
    pub positions: Vec<V3>,
    pub remap: Vec<u32>,
}

/// Welds `vertices` (file units) with `tolerance` (file units, ≥ 0).
pub(crate) fn weld(vertices: &[V3], tolerance: f64) -> Welded {
    let max_abs = vertices.iter().flat_map(|v| v.iter()).fold(0.0f64, |m, c| m.max(c.abs()));
    if tolerance.is_nan() || tolerance <= 0.0 || !tolerance.is_finite() || tolerance < max_abs * 1e-12 {
        return weld_exact(vertices);
    }
    let cell = 4.0 * tolerance;
    let tol2 = tolerance * tolerance;
    let key = |x: f64| (x / cell).floor() as i64;
    let mut heads: FxHashMap<[i64; 3], u32> = FxHashMap::default();
    heads.reserve(vertices.len() / 4);
    let mut next: Vec<u32> = Vec::new();
    let mut positions: Vec<V3> = Vec::new();
    let mut remap = Vec::with_capacity(vertices.len());
    for &p in vertices {
        let lo = p.map(|c| key(c - tolerance));
        let hi = p.map(|c| key(c + tolerance));
        let mut best = u32::MAX;
        for i in lo[0]..=hi[0] {
            for j in lo[1]..=hi[1] {
                for k in lo[2]..=hi[2] {
                    let mut r = heads.get(&[i, j, k]).copied().unwrap_or(u32::MAX);
                    while r != u32::MAX {
                        let q = positions[r as usize];
                        let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
                        if r < best && d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= tol2 {
                            best = r;
                        }
                        r = next[r as usize];
                    }
                }
            }
        }
        if best == u32::MAX {
            best = positions.len() as u32;
            let home = p.map(key);
            let head = heads.entry(home).or_insert(u32::MAX);
            next.push(*head);
            *head = best;
            positions.push(p);
        }
        remap.push(best);
    }
    Welded { positions, remap }
}

fn weld_exact(vertices: &[V3]) -> Welded {
    // `+ 0.0` turns -0.0 into 0.0 so that both hash alike.
    let bits = |v: V3| v.map(|c| (c + 0.0).to_bits());
    let mut seen: FxHashMap<[u64; 3], u32> = FxHashMap::default();
    seen.reserve(vertices.len() / 4);
    let mut positions = Vec::new();
    let mut remap = Vec::with_capacity(vertices.len());
    for &p in vertices {
        let id = *seen.entry(bits(p)).or_insert_with(|| {
            positions.push(p);
            (positions.len() - 1) as u32
        });
        remap.push(id);
    }
    Welded { positions, remap }
}

/// Maps triangles through `remap`, drops those with a repeated corner (collapsed by welding
/// or degenerate in the file) and returns them with the number dropped.
pub(crate) fn remap_triangles(triangles: &[[u32; 3]], remap: &[u32]) -> (Vec<[u32; 3]>, usize) {
    let mut out = Vec::with_capacity(triangles.len());
    for t in triangles {
        let m = t.map(|i| remap[i as usize]);
        if m[0] != m[1] && m[1] != m[2] && m[0] != m[2] {
            out.push(m);
        }
    }
    let dropped = triangles.len() - out.len();
    (out, dropped)
}

/// Drops vertices no triangle uses, keeping the others' order, and renumbers `triangles`.
pub(crate) fn compact(positions: Vec<V3>, triangles: &mut [[u32; 3]]) -> Vec<V3> {
    let mut new_index = vec![u32::MAX; positions.len()];
    for t in triangles.iter() {
        for &i in t {
            new_index[i as usize] = 0;
        }
    }
    let mut kept = Vec::with_capacity(positions.len());
    for (i, p) in positions.into_iter().enumerate() {
        if new_index[i] == 0 {
            new_index[i] = kept.len() as u32;
            kept.push(p);
        }
    }
    for t in triangles.iter_mut() {
        *t = t.map(|i| new_index[i as usize]);
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weld_within_tolerance_works() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1e-7], [1.0 + 4e-7, 0.0, 0.0], [0.5, 0.0, 0.0]];
        let w = weld(&v, 1e-6);
        assert_eq!(w.remap, vec![0, 1, 0, 1, 2]);
        assert_eq!(w.positions.len(), 3);
    }

    #[test]
    fn weld_across_cell_boundary_works() {
        // 4e-6 is a cell boundary for tolerance 1e-6; points on either side must merge.
        let v = [[4e-6 - 1e-7, 0.0, 0.0], [4e-6 + 1e-7, 0.0, 0.0]];
        assert_eq!(weld(&v, 1e-6).remap, vec![0, 0]);
    }

    #[test]
    fn weld_exact_signed_zero_works() {
        let v = [[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [0.0, 1.0, 2.0000001]];
        assert_eq!(weld(&v, 0.0).remap, vec![0, 0, 1]);
    }

    #[test]
    fn weld_degenerate_removal_and_compaction_works() {
        let (mut t, dropped) = remap_triangles(&[[0, 1, 2], [0, 0, 3], [3, 1, 2]], &[0, 1, 2, 4, 3]);
        assert_eq!(dropped, 1);
        assert_eq!(t, vec![[0, 1, 2], [4, 1, 2]]);
        let kept = compact(vec![[0.0; 3], [1.0; 3], [2.0; 3], [3.0; 3], [4.0; 3]], &mut t);
        assert_eq!(kept, vec![[0.0; 3], [1.0; 3], [2.0; 3], [4.0; 3]]);
        assert_eq!(t, vec![[0, 1, 2], [3, 1, 2]]);
    }
}
