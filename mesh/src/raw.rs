//! The parsers' common output: a triangle soup or indexed list, in file units, not yet welded.

use std::fmt;

use lamina_input::FileLimit;

/// Largest coordinate magnitude accepted in a mesh file, in file units: 10⁹ (1,000 km in
/// millimetres). Far beyond any body, and small enough that volumes, areas and `f32`
/// positions computed from it stay finite.
pub const MAX_ABS_COORDINATE: f64 = 1e9;

/// Mesh files: at most 1 GiB (20 million binary STL triangles), parsed in at most 8 bytes of
/// memory per byte of file (vertices, welding and edge tables of a binary STL).
pub const MESH_FILE: FileLimit = FileLimit::new("mesh file", 1 << 30).memory_per_byte(8);

/// True when `c` is a coordinate a mesh file may hold: finite and within
/// ±[`MAX_ABS_COORDINATE`].
pub(crate) fn coordinate_ok(c: f64) -> bool {
    c.abs() <= MAX_ABS_COORDINATE
}

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
