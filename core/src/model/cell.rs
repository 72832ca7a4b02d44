//! Volume cells over model nodes: the tetrahedra and prisms the generator cuts the tissue
//! into, the cubes of a lattice block. The solver does not need them (its springs and the
//! skin's volume term carry the physics); exports do, to show the tissue as a solid.

/// The shape of a volume cell, with VTK's node ordering.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CellKind {
    /// Four nodes; positive when `(x₁ − x₀) × (x₂ − x₀) · (x₃ − x₀) > 0` (VTK_TETRA, 10).
    Tetra,
    /// Triangular prism: base `0, 1, 2`, top `3, 4, 5` above them in order; positive when
    /// the base, counter-clockwise by the right-hand rule, faces the top (VTK_WEDGE, 13).
    Wedge,
    /// Hexahedron: bottom face `0, 1, 2, 3`, top `4, 5, 6, 7` above them in order;
    /// positive when the bottom, counter-clockwise by the right-hand rule, faces the top
    /// (VTK_HEXAHEDRON, 12).
    Hexahedron,
}

impl CellKind {
    /// Every kind, in the order exports group them.
    pub const ALL: [CellKind; 3] = [CellKind::Tetra, CellKind::Wedge, CellKind::Hexahedron];

    /// Nodes of a cell of this kind: 4, 6 or 8.
    pub const fn node_count(self) -> usize {
        match self {
            CellKind::Tetra => 4,
            CellKind::Wedge => 6,
            CellKind::Hexahedron => 8,
        }
    }

    /// Name used in files: `tetra`, `wedge`, `hexahedron` (as VTK and meshio name them).
    pub const fn name(self) -> &'static str {
        match self {
            CellKind::Tetra => "tetra",
            CellKind::Wedge => "wedge",
            CellKind::Hexahedron => "hexahedron",
        }
    }

    /// Parses [`CellKind::name`]'s output.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// VTK cell type number: 10, 13 or 12.
    pub const fn vtk_type(self) -> u8 {
        match self {
            CellKind::Tetra => 10,
            CellKind::Wedge => 13,
            CellKind::Hexahedron => 12,
        }
    }

    /// The cell cut into tetrahedra of the same orientation, as corner indices: a positive
    /// cell gives positive tetrahedra, whose volumes sum to the cell's.
    fn tetrahedra(self) -> &'static [[usize; 4]] {
        match self {
            CellKind::Tetra => &[[0, 1, 2, 3]],
            CellKind::Wedge => &[[0, 1, 2, 3], [1, 2, 3, 4], [2, 3, 4, 5]],
            CellKind::Hexahedron => {
                &[[0, 1, 2, 6], [0, 2, 3, 6], [0, 3, 7, 6], [0, 7, 4, 6], [0, 4, 5, 6], [0, 5, 1, 6]]
            }
        }
    }

    /// The same cell with the opposite orientation (corner order mirrored).
    fn mirror(self) -> &'static [usize] {
        match self {
            CellKind::Tetra => &[0, 2, 1, 3],
            CellKind::Wedge => &[0, 2, 1, 3, 5, 4],
            CellKind::Hexahedron => &[0, 3, 2, 1, 4, 7, 6, 5],
        }
    }
}

/// One volume cell: its shape, layer and nodes (the first [`CellKind::node_count`] of
/// `nodes`; the rest are 0).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Cell {
    /// Shape and node ordering.
    pub kind: CellKind,
    /// Layer index, as for nodes and springs.
    pub layer: u16,
    /// Node indices, VTK order; unused entries 0.
    nodes: [u32; 8],
}

impl Cell {
    /// A cell of `kind` on `nodes` (VTK order), or `None` when `nodes` does not hold exactly
    /// [`CellKind::node_count`] entries.
    pub fn new(kind: CellKind, layer: u16, nodes: &[u32]) -> Option<Self> {
        if nodes.len() != kind.node_count() {
            return None;
        }
        let mut all = [0; 8];
        all[..nodes.len()].copy_from_slice(nodes);
        Some(Self { kind, layer, nodes: all })
    }

    /// The cell on `nodes` oriented so that its volume at `positions` (m) is not negative:
    /// mirrored when it is.
    pub fn oriented(kind: CellKind, layer: u16, nodes: &[u32], positions: &[[f64; 3]]) -> Option<Self> {
        let cell = Self::new(kind, layer, nodes)?;
        if cell.volume(positions) >= 0.0 {
            return Some(cell);
        }
        let mirrored: Vec<u32> = kind.mirror().iter().map(|&k| nodes[k]).collect();
        Self::new(kind, layer, &mirrored)
    }

    /// Node indices, VTK order.
    pub fn nodes(&self) -> &[u32] {
        &self.nodes[..self.kind.node_count()]
    }

    /// Signed volume at `positions` (m³; positive for a cell in VTK order that is not
    /// inverted). Every node must index `positions`.
    pub fn volume(&self, positions: &[[f64; 3]]) -> f64 {
        let p = |k: usize| positions[self.nodes[k] as usize];
        self.kind.tetrahedra().iter().map(|t| tet_volume([p(t[0]), p(t[1]), p(t[2]), p(t[3])])).sum()
    }
}

/// Signed volume of a tetrahedron, m³: `(x₁ − x₀) × (x₂ − x₀) · (x₃ − x₀) / 6`.
fn tet_volume(x: [[f64; 3]; 4]) -> f64 {
    let d = |k: usize| [x[k][0] - x[0][0], x[k][1] - x[0][1], x[k][2] - x[0][2]];
    let (a, b, c) = (d(1), d(2), d(3));
    let cross = [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    (cross[0] * c[0] + cross[1] * c[1] + cross[2] * c[2]) / 6.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// VTK's parametric corners of each kind: positive, volumes 1/6, 1/2, 1.
    #[test]
    fn cell_parametric_corners_have_unit_volumes_works() {
        let tet = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let wedge =
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]];
        let hex = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
        ];
        for (kind, p, v) in [
            (CellKind::Tetra, &tet[..], 1.0 / 6.0),
            (CellKind::Wedge, &wedge[..], 0.5),
            (CellKind::Hexahedron, &hex[..], 1.0),
        ] {
            let nodes: Vec<u32> = (0..p.len() as u32).collect();
            let cell = Cell::new(kind, 0, &nodes).unwrap();
            assert!((cell.volume(p) - v).abs() < 1e-15, "{kind:?}");
            let mirrored: Vec<u32> = kind.mirror().iter().map(|&k| nodes[k]).collect();
            assert!((Cell::new(kind, 0, &mirrored).unwrap().volume(p) + v).abs() < 1e-15, "{kind:?} mirrored");
            assert_eq!(Cell::oriented(kind, 0, &mirrored, p).unwrap().volume(p), cell.volume(p));
            assert_eq!(CellKind::from_name(kind.name()), Some(kind));
        }
        assert_eq!(Cell::new(CellKind::Tetra, 0, &[0, 1, 2]), None);
    }
}
