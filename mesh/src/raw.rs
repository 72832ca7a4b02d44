//! The parsers' common output: a triangle soup or indexed list, in file units, not yet welded.

use std::fmt;

/// The on-disk format a mesh was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// Binary STL: 80-byte header, `u32` count, 50 bytes per triangle.
    StlBinary,
    /// ASCII STL: `solid ... facet normal ... outer loop ... vertex x y z ... endsolid`.
    StlAscii,
    /// Wavefront OBJ: `v` and `f` lines.
    Obj,
}

impl fmt::Display for MeshFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::StlBinary => "STL (binary)",
            Self::StlAscii => "STL (ASCII)",
            Self::Obj => "OBJ",
        })
    }
}

/// Vertices (file units) and triangles as read, before welding and repair.
#[derive(Clone, Debug, Default)]
pub(crate) struct RawMesh {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}
