//! Triangle surfaces over model nodes, for rendering and contact.

/// A triangulated surface whose vertices are model nodes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Surface {
    /// Name, e.g. `skin_outer`.
    pub name: String,
    /// Triangles as node-index triples, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// When the surface is a regular grid: `(columns around, rows along)` and the node of
    /// each grid point, row-major. The viewer's Bézier patches need it.
    pub grid: Option<(u32, u32, Vec<u32>)>,
}
