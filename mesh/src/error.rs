//! Error types of the crate: flat enums named `<Thing><Op>Error`.
//!
//! Every variant that comes from a file names the file; syntax errors name the 1-based line;
//! topology errors give counts and the coordinates of the first offending edge (the edge of
//! the lowest-numbered triangle, in file order), in the file's own units.

use std::path::PathBuf;

use lamina_input::FileReadError;

use crate::units::Units;

/// Why a mesh file could not be loaded (see [`crate::load()`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshLoadError {
    /// The file could not be read: missing, not a regular file (a FIFO, a device), larger
    /// than [`MESH_FILE`](crate::raw::MESH_FILE)'s cap, or more than the memory available.
    #[error(transparent)]
    Read(FileReadError),
    /// The file name does not end in `.stl` or `.obj` (case-insensitive).
    #[error("{path}: unsupported mesh format (expected a .stl or .obj file)")]
    UnsupportedFormat {
        /// File.
        path: PathBuf,
    },
    /// A binary STL is shorter than its header's triangle count requires, or shorter than the
    /// 84-byte header itself.
    #[error(
        "{path}: truncated binary STL: header declares {declared_triangles} triangles ({expected_bytes} bytes) but the file has {actual_bytes} bytes ({complete_triangles} complete triangles; triangle {complete_triangles} is cut)"
    )]
    StlTruncated {
        /// File.
        path: PathBuf,
        /// Triangle count declared at byte 80 (0 when the header itself is cut).
        declared_triangles: u64,
        /// Complete triangles present.
        complete_triangles: u64,
        /// Bytes needed: 84 + 50 × declared triangles.
        expected_bytes: u64,
        /// Bytes in the file.
        actual_bytes: u64,
    },
    /// A binary STL vertex has a NaN or infinite coordinate.
    #[error("{path}: binary STL triangle {triangle} has a NaN or infinite coordinate")]
    StlNonFinite {
        /// File.
        path: PathBuf,
        /// 0-based triangle index.
        triangle: u64,
    },
    /// A binary STL vertex has a coordinate beyond
    /// ±[`MAX_ABS_COORDINATE`](crate::raw::MAX_ABS_COORDINATE).
    #[error(
        "{path}: binary STL triangle {triangle} has coordinate {value:e}, beyond ±{:e}, the largest a mesh file may hold",
        crate::raw::MAX_ABS_COORDINATE
    )]
    StlCoordinateTooLarge {
        /// File.
        path: PathBuf,
        /// 0-based triangle index.
        triangle: u64,
        /// The coordinate, file units.
        value: f64,
    },
    /// An ASCII STL is malformed: unexpected keyword, bad number, missing `endloop`, ...
    #[error("{path}:{line}: {message}")]
    StlSyntax {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An OBJ line is malformed: bad or non-finite number, too few coordinates, a face with
    /// fewer than three corners, index 0.
    #[error("{path}:{line}: {message}")]
    ObjSyntax {
        /// File.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An OBJ face refers to a vertex that does not exist.
    #[error("{path}:{line}: face vertex index {index} is out of range ({vertex_count} vertices)")]
    ObjIndexOutOfRange {
        /// File.
        path: PathBuf,
        /// 1-based line of the face.
        line: usize,
        /// The index as written (1-based, or negative = relative).
        index: i64,
        /// Vertices available to that face.
        vertex_count: usize,
    },
    /// More vertices or triangles than 32-bit indices can address.
    #[error("{path}: too many vertices or triangles for 32-bit indices")]
    TooLarge {
        /// File.
        path: PathBuf,
    },
    /// No triangle is left (the file has none, or all are degenerate).
    #[error("{path}: {}", empty_message(*.degenerate_removed, *.weld_tolerance))]
    Empty {
        /// File.
        path: PathBuf,
        /// Degenerate triangles that were removed.
        degenerate_removed: usize,
        /// Weld tolerance used, file units.
        weld_tolerance: f64,
    },
    /// One vertex lies so far from the others that it would set the units and the weld
    /// tolerance on its own (a stray vertex: `1000 ×` farther from the vertices' median
    /// point than the median vertex is).
    #[error("{path}: {location} at {} lies {ratio:.3e} times farther from the surface's median point than the median vertex; a stray vertex would set the units and weld tolerance on its own: remove it", p(*.position))]
    OutlierVertex {
        /// File.
        path: PathBuf,
        /// Where it is: `"vertex 17"` (OBJ, the 17th `v` line) or `"triangle 412"` (STL).
        location: String,
        /// Its position, file units.
        position: [f64; 3],
        /// Its distance from the median point over the median vertex's distance.
        ratio: f64,
    },
    /// The surface has holes: edges used by only one triangle. Allowed with
    /// [`crate::LoadOptions::allow_open`].
    #[error("{path}: surface is not closed: {holes} hole(s), {boundary_edges} boundary edge(s) used by only one triangle; first from {} to {} {}", p(.first_edge[0]), p(.first_edge[1]), .units.symbol())]
    OpenSurface {
        /// File.
        path: PathBuf,
        /// Edges used by exactly one triangle.
        boundary_edges: usize,
        /// Holes: connected loops of boundary edges.
        holes: usize,
        /// Endpoints of the first boundary edge, in `units`.
        first_edge: [[f64; 3]; 2],
        /// Units of `first_edge` (the file's).
        units: Units,
    },
    /// Some edges are shared by more than two triangles. Allowed with
    /// [`crate::LoadOptions::allow_non_manifold`].
    #[error("{path}: surface is not manifold: {non_manifold_edges} edge(s) shared by more than two triangles; first ({triangles_on_first_edge} triangles) from {} to {} {}", p(.first_edge[0]), p(.first_edge[1]), .units.symbol())]
    NonManifold {
        /// File.
        path: PathBuf,
        /// Edges used by three or more triangles.
        non_manifold_edges: usize,
        /// Triangles on the first such edge.
        triangles_on_first_edge: usize,
        /// Endpoints of the first such edge, in `units`.
        first_edge: [[f64; 3]; 2],
        /// Units of `first_edge` (the file's).
        units: Units,
    },
    /// The triangles cannot be given one consistent winding (a Möbius-like surface).
    #[error("{path}: surface is not orientable: no consistent winding exists; contradiction at the edge from {} to {} {}", p(.first_edge[0]), p(.first_edge[1]), .units.symbol())]
    NonOrientable {
        /// File.
        path: PathBuf,
        /// Endpoints of the edge where the flood fill met a contradiction, in `units`.
        first_edge: [[f64; 3]; 2],
        /// Units of `first_edge` (the file's).
        units: Units,
    },
}

fn p(v: [f64; 3]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

/// The message of [`MeshLoadError::Empty`] after the path.
fn empty_message(degenerate_removed: usize, weld_tolerance: f64) -> String {
    if degenerate_removed == 0 {
        "the file has no triangles".to_string()
    } else {
        format!(
            "no triangles left: welding vertices closer than {weld_tolerance:e} file units made all \
             {degenerate_removed} triangles degenerate (two corners on one vertex)"
        )
    }
}

impl From<FileReadError> for MeshLoadError {
    fn from(e: FileReadError) -> Self {
        Self::Read(e)
    }
}

/// Why a mesh file could not be written.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshSaveError {
    /// The file could not be created or written.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: PathBuf,
        /// OS error text.
        message: String,
    },
}

/// Why a [`crate::TriMesh`] could not be built from vertex and index arrays.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum TriMeshBuildError {
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle {triangle} refers to vertex {index} but there are {vertex_count} vertices")]
    IndexOutOfRange {
        /// 0-based triangle.
        triangle: usize,
        /// The offending index.
        index: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// A vertex has a NaN or infinite coordinate.
    #[error("vertex {vertex} has a NaN or infinite coordinate")]
    NonFiniteVertex {
        /// 0-based vertex.
        vertex: usize,
    },
    /// More vertices than 32-bit indices can address.
    #[error("{vertex_count} vertices cannot be addressed with 32-bit indices")]
    TooManyVertices {
        /// Number of vertices given.
        vertex_count: usize,
    },
}

/// Why a centreline could not be computed (see [`crate::centreline()`]).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum CentrelineComputeError {
    /// The mesh has no triangles.
    #[error("the mesh has no triangles")]
    EmptyMesh,
    /// The given axis is zero or not finite.
    #[error("the centreline axis is zero or not finite")]
    InvalidAxis,
    /// The given height range has a NaN or infinite end.
    #[error("the centreline height range is not finite")]
    InvalidRange,
    /// Zero stations were asked for.
    #[error("at least one centreline station is needed")]
    NoStations,
    /// No station plane cuts the surface in a closed loop.
    #[error("no station plane cuts the surface in a closed loop")]
    NoCrossSection,
}
