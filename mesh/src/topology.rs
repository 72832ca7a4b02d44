//! Edge table of an indexed triangle list: which triangles share each undirected edge.
//!
//! Built by sorting the `3F` half-edges by their undirected key, so it is deterministic and
//! needs no hashing. An edge used by one triangle is a boundary edge (part of a hole), by two
//! a manifold edge, by three or more a non-manifold edge.

use crate::vec3::{self, V3};

/// One side of an edge as seen from one triangle.
#[derive(Clone, Copy, Debug)]
pub(crate) struct HalfEdge {
    /// Smaller vertex index.
    pub lo: u32,
    /// Larger vertex index.
    pub hi: u32,
    /// Triangle it belongs to.
    pub tri: u32,
    /// True when the triangle's winding goes `lo → hi`.
    pub forward: bool,
}

/// Half-edges grouped by undirected edge.
pub(crate) struct EdgeTable {
    /// Sorted by `(lo, hi, tri)`.
    pub half: Vec<HalfEdge>,
    /// `(start, len)` of each undirected edge's run in `half`.
    pub groups: Vec<(u32, u32)>,
}

/// Counts and first examples of the edges that keep a surface from being closed.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct EdgeDefects {
    pub boundary_edges: usize,
    pub holes: usize,
    pub non_manifold_edges: usize,
    /// `(lo, hi)` of the boundary edge whose first triangle comes first in the file.
    pub first_boundary: Option<(u32, u32)>,
    /// `(lo, hi, triangles)` of the first non-manifold edge, same ordering.
    pub first_non_manifold: Option<(u32, u32, usize)>,
}

impl EdgeTable {
    pub(crate) fn build(triangles: &[[u32; 3]]) -> Self {
        let mut half = Vec::with_capacity(triangles.len() * 3);
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                half.push(HalfEdge { lo: a.min(b), hi: a.max(b), tri: t as u32, forward: a < b });
            }
        }
        half.sort_unstable_by_key(|h| ((u64::from(h.lo) << 32) | u64::from(h.hi), h.tri));
        let mut groups = Vec::with_capacity(half.len() / 2 + 1);
        let mut start = 0usize;
        for i in 1..=half.len() {
            if i == half.len() || (half[i].lo, half[i].hi) != (half[start].lo, half[start].hi) {
                groups.push((start as u32, (i - start) as u32));
                start = i;
            }
        }
        Self { half, groups }
    }

    /// The half-edges of group `g`.
    pub(crate) fn group(&self, g: usize) -> &[HalfEdge] {
        let (s, n) = self.groups[g];
        &self.half[s as usize..(s + n) as usize]
    }

    /// Number of distinct undirected edges.
    pub(crate) fn edge_count(&self) -> usize {
        self.groups.len()
    }

    pub(crate) fn defects(&self, vertex_count: usize) -> EdgeDefects {
        let mut d = EdgeDefects::default();
        let mut first_b = u32::MAX;
        let mut first_n = u32::MAX;
        let mut uf = UnionFind::new(0);
        let mut uf_ready = false;
        for g in 0..self.groups.len() {
            let h = self.group(g);
            match h.len() {
                1 => {
                    d.boundary_edges += 1;
                    if h[0].tri < first_b {
                        first_b = h[0].tri;
                        d.first_boundary = Some((h[0].lo, h[0].hi));
                    }
                    if !uf_ready {
                        uf = UnionFind::new(vertex_count);
                        uf_ready = true;
                    }
                    uf.union(h[0].lo, h[0].hi);
                }
                2 => {}
                n => {
                    d.non_manifold_edges += 1;
                    if h[0].tri < first_n {
                        first_n = h[0].tri;
                        d.first_non_manifold = Some((h[0].lo, h[0].hi, n));
                    }
                }
            }
        }
        if uf_ready {
            let mut roots: Vec<u32> = Vec::new();
            for g in 0..self.groups.len() {
                let h = self.group(g);
                if h.len() == 1 {
                    roots.push(uf.find(h[0].lo));
                }
            }
            roots.sort_unstable();
            roots.dedup();
            d.holes = roots.len();
        }
        d
    }

    /// Mean length of the distinct edges, in the units of `vertices` (0 without edges).
    pub(crate) fn mean_edge_length(&self, vertices: &[V3]) -> f64 {
        if self.groups.is_empty() {
            return 0.0;
        }
        let total: f64 = self
            .groups
            .iter()
            .map(|&(s, _)| {
                let h = self.half[s as usize];
                vec3::norm(vec3::sub(vertices[h.hi as usize], vertices[h.lo as usize]))
            })
            .sum();
        total / self.groups.len() as f64
    }
}

/// Disjoint sets over `0..n` with path halving and union by size.
pub(crate) struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    pub(crate) fn new(n: usize) -> Self {
        Self { parent: (0..n as u32).collect(), size: vec![1; n] }
    }

    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let p = self.parent[x as usize];
            self.parent[x as usize] = self.parent[p as usize];
            x = p;
        }
        x
    }

    pub(crate) fn union(&mut self, a: u32, b: u32) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a as usize] < self.size[b as usize] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b as usize] = a;
        self.size[a as usize] += self.size[b as usize];
    }
}
