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

impl Surface {
    /// The tissue just beneath this surface, from its name ([`Tissue::beneath_boundary`]):
    /// `skin_outer` → skin, `skin_fat` → fat, `fat_muscle` → muscle, `muscle_bone` → bone.
    ///
    /// [`Tissue::beneath_boundary`]: super::Tissue::beneath_boundary
    pub fn tissue_beneath(&self) -> super::Tissue {
        super::Tissue::beneath_boundary(&self.name)
    }
}
