//! The regular W × H grid of the reparameterisation and the node numbering of the model
//! built on it.

/// Size of the generator's grid: `columns` (W) around the axis and `rows` (H) of cells
/// along it, so `rows + 1` rings of `columns` sample points. The grid wraps around in
/// angle (column `W − 1` neighbours column 0) but not along the axis.
///
/// Cell `(c, r)` has corners `(c, r)`, `(c+1, r)`, `(c+1, r+1)`, `(c, r+1)` (ring index
/// second) and is split along its `(c, r)`–`(c+1, r+1)` diagonal into triangle 0
/// `[(c,r), (c+1,r), (c+1,r+1)]` and triangle 1 `[(c,r), (c+1,r+1), (c,r+1)]`, both
/// counter-clockwise seen from outside. Triangle id: `2·(r·W + c) + half`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GridSize {
    /// W: columns around the axis (≥ 3). The paper's limb: 39.
    pub columns: u32,
    /// H: rows of cells along the axis (≥ 1). The paper's limb: 10.
    pub rows: u32,
}

impl GridSize {
    /// A `columns × rows` grid.
    pub const fn new(columns: u32, rows: u32) -> Self {
        Self { columns, rows }
    }

    /// At least 3 columns and 1 row, and few enough nodes for `u32` indices.
    pub fn is_valid(&self) -> bool {
        self.columns >= 3 && self.rows >= 1 && self.model_size().nodes.is_some_and(|n| n < u64::from(u32::MAX))
    }

    /// Counts of the model generated on this grid, without overflow: `W·(7H+1)` nodes,
    /// `W·(55H−13)` springs ([`distinct_springs`](super::families::distinct_springs)), and
    /// `2WH` triangles on each of the four boundary surfaces.
    pub fn model_size(&self) -> crate::model::ModelSize {
        let (w, h) = (u64::from(self.columns), u64::from(self.rows));
        let nodes = h.checked_mul(7).and_then(|x| x.checked_add(1)).and_then(|x| x.checked_mul(w));
        let springs = h.checked_mul(55).map(|x| x.saturating_sub(13)).and_then(|x| x.checked_mul(w));
        let triangles = w.checked_mul(h).and_then(|x| x.checked_mul(8));
        crate::model::ModelSize::counted(nodes, springs, triangles)
    }

    /// Sample points on the outer skin: `W·(H+1)`.
    pub fn surface_nodes(&self) -> usize {
        self.columns as usize * (self.rows as usize + 1)
    }

    /// Triangles of the outer grid, and nodes per deeper level: `2·W·H`.
    pub fn triangles(&self) -> usize {
        2 * self.columns as usize * self.rows as usize
    }

    /// Masses of the layered model: `W·(H+1) + 3·2WH = W·(7H+1)` (the paper's Table 3).
    pub fn masses(&self) -> usize {
        self.surface_nodes() + 3 * self.triangles()
    }

    /// Index of the grid point at `column` (taken modulo W) on `ring` (0..=H).
    pub fn vertex(&self, column: i64, ring: u32) -> u32 {
        let w = self.columns as i64;
        (ring as i64 * w + column.rem_euclid(w)) as u32
    }

    /// `(column, ring)` of grid point `v`.
    pub fn vertex_cell(&self, v: u32) -> (u32, u32) {
        (v % self.columns, v / self.columns)
    }

    /// Id of triangle `half` (0 or 1) of cell `(column, row)`.
    pub fn triangle(&self, column: u32, row: u32, half: u32) -> u32 {
        2 * (row * self.columns + column) + half
    }

    /// `(column, row, half)` of triangle `t`.
    pub fn triangle_cell(&self, t: u32) -> (u32, u32, u32) {
        let cell = t / 2;
        (cell % self.columns, cell / self.columns, t % 2)
    }

    /// The grid points at the corners of triangle `t`, counter-clockwise seen from outside.
    pub fn triangle_corners(&self, t: u32) -> [u32; 3] {
        let (c, r, half) = self.triangle_cell(t);
        let c = c as i64;
        let v00 = self.vertex(c, r);
        let v10 = self.vertex(c + 1, r);
        let v11 = self.vertex(c + 1, r + 1);
        let v01 = self.vertex(c, r + 1);
        if half == 0 { [v00, v10, v11] } else { [v00, v11, v01] }
    }

    /// Model node of outer grid point `v`: the surface nodes come first, `0..W(H+1)`.
    pub fn surface_node(&self, v: u32) -> u32 {
        v
    }

    /// Model node of triangle `t` on `level` 1 (skin/fat), 2 (fat/muscle) or 3
    /// (muscle/bone): `W(H+1) + (level − 1)·2WH + half·WH + cell`, i.e. each level holds
    /// the first halves of all cells, then the second halves. Numbered so, a triangle node
    /// and its cell's corner `(c, r)` (grid point `cell`) differ by the same amount in
    /// every cell, as do the nodes of neighbouring triangles: every spring family becomes
    /// a long run of constant index offset, which the solver streams (interleaving the
    /// halves, `… + t`, left 60 % of a limb's springs without a run).
    pub fn triangle_node(&self, level: u32, t: u32) -> u32 {
        let cells = self.columns * self.rows;
        (self.surface_nodes() + (level as usize - 1) * self.triangles()) as u32 + (t % 2) * cells + t / 2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_wrapping_vertex_works() {
        let g = GridSize::new(12, 3);
        assert_eq!(g.vertex(-1, 0), 11);
        assert_eq!(g.vertex(12, 1), 12);
        assert_eq!(g.triangle_corners(g.triangle(11, 0, 0)), [11, 0, 12]);
        assert_eq!(g.masses(), 264);
    }
}
