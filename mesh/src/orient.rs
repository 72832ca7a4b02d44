//! Consistent, outward orientation of a triangle surface.
//!
//! How it works:
//! 1. Across every manifold edge (two triangles) the two windings must run the edge in
//!    opposite directions. A breadth-first flood fill from the lowest-numbered unvisited
//!    triangle gives every triangle of its connected component a parity relative to the seed;
//!    boundary and non-manifold edges are not crossed. A contradiction means the component
//!    is not orientable (it is left as the fill found it, and reported).
//! 2. Each component is first fixed by flipping its minority parity class (fewest changes).
//! 3. A closed component (every edge manifold) whose signed volume is then negative is
//!    turned inside out as a whole, so that every closed component ends up wound outward.
//!
//! The flipped count is therefore the number of triangles whose winding differs from the
//! file's in the final, outward orientation. For a closed surface it is exactly the number of
//! triangles that were wound inward, whether they are the minority or not.

use crate::topology::EdgeTable;
use crate::trimesh::BoundingBox;
use crate::vec3::{self, V3};

/// What orientation repair found and did.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Orientation {
    /// Triangles reversed.
    pub flipped: usize,
    /// Connected components (through manifold edges).
    pub components: usize,
    /// Components with only manifold edges.
    pub closed_components: usize,
    /// False when some component has no consistent winding.
    pub orientable: bool,
    /// `(lo, hi)` of the edge where the first contradiction was met.
    pub conflict_edge: Option<(u32, u32)>,
}

const NONE: u32 = u32::MAX;

/// Reorients `triangles` in place (see the module docs) and reports what it did.
pub(crate) fn orient(vertices: &[V3], triangles: &mut [[u32; 3]], edges: &EdgeTable) -> Orientation {
    let n = triangles.len();
    // Up to three manifold neighbours per triangle, with "must differ in parity" bits.
    let mut adj = vec![[(NONE, false, 0u32); 3]; n];
    let mut deg = vec![0u8; n];
    let mut open = vec![false; n];
    for g in 0..edges.groups.len() {
        let h = edges.group(g);
        if h.len() == 2 {
            let differ = h[0].forward == h[1].forward;
            for (a, b) in [(h[0], h[1]), (h[1], h[0])] {
                let t = a.tri as usize;
                // A triangle has three edges, so at most three manifold neighbours.
                if let Some(slot) = adj[t].get_mut(deg[t] as usize) {
                    *slot = (b.tri, differ, g as u32);
                    deg[t] += 1;
                }
            }
        } else {
            for e in h {
                open[e.tri as usize] = true;
            }
        }
    }

    let mut parity = vec![2u8; n];
    let mut comp = vec![0u32; n];
    let mut out = Orientation { orientable: true, ..Default::default() };
    let mut queue: Vec<u32> = Vec::new();
    // Per component: triangles, parity-1 triangles, closed.
    let mut stats: Vec<(usize, usize, bool)> = Vec::new();
    for seed in 0..n {
        if parity[seed] != 2 {
            continue;
        }
        let c = stats.len() as u32;
        stats.push((0, 0, true));
        parity[seed] = 0;
        queue.clear();
        queue.push(seed as u32);
        let mut head = 0;
        while head < queue.len() {
            let t = queue[head] as usize;
            head += 1;
            comp[t] = c;
            let s = &mut stats[c as usize];
            s.0 += 1;
            s.1 += parity[t] as usize;
            s.2 &= !open[t] && deg[t] == 3;
            for &(nb, differ, g) in &adj[t][..deg[t] as usize] {
                let want = parity[t] ^ u8::from(differ);
                let nb = nb as usize;
                if parity[nb] == 2 {
                    parity[nb] = want;
                    queue.push(nb as u32);
                } else if parity[nb] != want && out.orientable {
                    out.orientable = false;
                    let e = edges.group(g as usize)[0];
                    out.conflict_edge = Some((e.lo, e.hi));
                }
            }
        }
    }
    out.components = stats.len();

    // Minority class flips; then closed components are made outward.
    let mut invert: Vec<bool> = stats.iter().map(|&(size, ones, _)| ones > size - ones).collect();
    let origin = BoundingBox::of_points(vertices).map_or([0.0; 3], |b| b.centre());
    let mut six_vol = vec![0.0f64; stats.len()];
    for (t, tri) in triangles.iter().enumerate() {
        let c = comp[t] as usize;
        let [a, b, cc] = tri.map(|i| vec3::sub(vertices[i as usize], origin));
        let det = vec3::dot(a, vec3::cross(b, cc));
        let flip = (parity[t] == 1) ^ invert[c];
        six_vol[c] += if flip { -det } else { det };
    }
    for (c, &(_, _, closed)) in stats.iter().enumerate() {
        if closed {
            out.closed_components += 1;
            if six_vol[c] < 0.0 {
                invert[c] = !invert[c];
            }
        }
    }
    for (t, tri) in triangles.iter_mut().enumerate() {
        if (parity[t] == 1) ^ invert[comp[t] as usize] {
            tri.swap(1, 2);
            out.flipped += 1;
        }
    }
    out
}
