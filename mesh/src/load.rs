//! Loading a mesh file into a clean, closed, outward [`TriMesh`] in metres.
//!
//! How it works, in order:
//! 1. read the file, only when it is a regular file within [`MESH_FILE`]'s cap (1 GiB) and
//!    the memory available, and parse it by extension (`.stl`: binary or ASCII, see
//!    [`crate::stl`]; `.obj`: see [`crate::obj`]), giving vertices in file units, each
//!    coordinate within ±[`MAX_ABS_COORDINATE`](crate::raw::MAX_ABS_COORDINATE);
//! 2. refuse a stray vertex, one more than [`OUTLIER_RATIO`] times farther from the median
//!    point than the median vertex ([`MeshLoadError::OutlierVertex`]): it would set the
//!    units and the weld tolerance below on its own;
//! 3. choose the units: [`LoadOptions::units`], or inferred by [`Units::infer`] from the
//!    bounding-box diagonal (above 10 file units: millimetres, otherwise metres);
//! 4. weld coincident vertices within [`LoadOptions::weld_tolerance`] (file units; default
//!    10⁻⁶ × bounding-box diagonal), drop the triangles welding collapses (two corners on one
//!    vertex) and the vertices no triangle uses;
//! 5. check the edges: holes and non-manifold edges are errors unless allowed;
//! 6. orient consistently and outward (flood fill over edge adjacency, minority flipped, closed parts made to
//!    enclose positive volume; see [`LoadReport::flipped_fixed`]); a surface with no consistent
//!    winding is an error;
//! 7. scale to metres.

use std::path::Path;

use crate::error::MeshLoadError;
use crate::orient::{Orientation, orient};
use crate::raw::{MESH_FILE, MeshFormat, RawMesh};
use crate::topology::{EdgeDefects, EdgeTable};
use crate::trimesh::{BoundingBox, TriMesh};
use crate::units::Units;
use crate::weld::{compact, remap_triangles, weld};
use crate::{obj, stl};

/// How to load a mesh file. `LoadOptions::default()` suits closed tissue surfaces.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadOptions {
    /// Units of the file's coordinates. Default `None`: inferred from the bounding-box
    /// diagonal by [`Units::infer`] (above 10 file units: millimetres, otherwise metres).
    pub units: Option<Units>,
    /// Distance, in file units, within which vertices are merged. Default `None`:
    /// 10⁻⁶ × the bounding-box diagonal (about 1 µm on a 1 m limb). `Some(0.0)` merges only
    /// bit-identical positions.
    pub weld_tolerance: Option<f64>,
    /// Accept surfaces with holes (boundary edges). Default `false`: a hole is
    /// [`MeshLoadError::OpenSurface`].
    pub allow_open: bool,
    /// Accept edges shared by more than two triangles. Default `false`: such an edge is
    /// [`MeshLoadError::NonManifold`].
    pub allow_non_manifold: bool,
}

impl LoadOptions {
    /// Default weld tolerance as a fraction of the bounding-box diagonal.
    pub const DEFAULT_WELD_FRACTION: f64 = 1e-6;

    /// Sets [`LoadOptions::units`].
    pub fn units(mut self, units: Units) -> Self {
        self.units = Some(units);
        self
    }

    /// Sets [`LoadOptions::weld_tolerance`] (file units).
    pub fn weld_tolerance(mut self, tolerance: f64) -> Self {
        self.weld_tolerance = Some(tolerance);
        self
    }

    /// Sets [`LoadOptions::allow_open`].
    pub fn allow_open(mut self, allow: bool) -> Self {
        self.allow_open = allow;
        self
    }

    /// Sets [`LoadOptions::allow_non_manifold`].
    pub fn allow_non_manifold(mut self, allow: bool) -> Self {
        self.allow_non_manifold = allow;
        self
    }
}

/// What loading found and changed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadReport {
    /// Format the file was read as.
    pub format: MeshFormat,
    /// Vertices as stored in the file (3 per triangle for STL).
    pub raw_vertices: usize,
    /// Vertices after welding, counting only those triangles use.
    pub welded_vertices: usize,
    /// Triangles in the file (after fan-triangulating polygons).
    pub raw_triangles: usize,
    /// Triangles kept.
    pub triangles: usize,
    /// Triangles removed because two of their corners are the same vertex after welding.
    pub degenerate_removed: usize,
    /// Triangles whose winding was reversed to make the surface consistent and outward.
    ///
    /// On a closed surface this is exactly the number of triangles the file had wound inward
    /// (whether they are the minority or the majority); on an open component, where inside
    /// and outside are undefined, it is the smaller of the two consistent classes.
    pub flipped_fixed: usize,
    /// Units the file was read in.
    pub units: Units,
    /// True when `units` was inferred rather than given.
    pub units_inferred: bool,
    /// Weld tolerance used, in file units.
    pub weld_tolerance: f64,
    /// Edges used by one triangle (0 unless [`LoadOptions::allow_open`]).
    pub boundary_edges: usize,
    /// Edges used by three or more triangles (0 unless [`LoadOptions::allow_non_manifold`]).
    pub non_manifold_edges: usize,
}

/// A loaded mesh and the report of how it was obtained.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadedMesh {
    /// The surface, in metres, wound outward.
    pub mesh: TriMesh,
    /// What loading found and changed.
    pub report: LoadReport,
}

/// Everything the pipeline computed, in file units (shared by [`load()`] and inspection).
pub(crate) struct Processed {
    pub format: MeshFormat,
    pub raw_vertices: usize,
    pub raw_triangles: usize,
    /// Welded, compacted vertices (file units).
    pub vertices: Vec<[f64; 3]>,
    /// Oriented triangles.
    pub triangles: Vec<[u32; 3]>,
    pub degenerate_removed: usize,
    pub units: Units,
    pub units_inferred: bool,
    pub weld_tolerance: f64,
    pub edges: EdgeTable,
    pub defects: EdgeDefects,
    pub orientation: Orientation,
}

/// A format's parser: file bytes and the path (for error messages) to a raw mesh.
type Parser = fn(&[u8], &Path) -> Result<(RawMesh, MeshFormat), MeshLoadError>;

pub(crate) fn read_and_parse(path: &Path) -> Result<(RawMesh, MeshFormat), MeshLoadError> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let parser: Parser = match ext.as_deref() {
        Some("stl") => stl::parse,
        Some("obj") => |b, p| obj::parse(b, p).map(|r| (r, MeshFormat::Obj)),
        _ => return Err(MeshLoadError::UnsupportedFormat { path: path.to_path_buf() }),
    };
    let bytes = lamina_input::read_bytes(path, &MESH_FILE)?;
    parser(&bytes, path)
}

/// Finds a stray vertex: one more than [`OUTLIER_RATIO`] times farther from the vertices'
/// per-axis median point than the median vertex is. Returns its index and that ratio.
/// `None` when there is none, or when half the vertices sit on the median point.
fn find_outlier(vertices: &[[f64; 3]]) -> Option<(usize, f64)> {
    if vertices.len() < 3 {
        return None;
    }
    let median = |values: &mut Vec<f64>| {
        let mid = values.len() / 2;
        *values.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let mut scratch: Vec<f64> = Vec::with_capacity(vertices.len());
    let mut centre = [0.0; 3];
    for (axis, c) in centre.iter_mut().enumerate() {
        scratch.clear();
        scratch.extend(vertices.iter().map(|v| v[axis]));
        *c = median(&mut scratch);
    }
    let distance =
        |v: &[f64; 3]| ((v[0] - centre[0]).powi(2) + (v[1] - centre[1]).powi(2) + (v[2] - centre[2]).powi(2)).sqrt();
    scratch.clear();
    scratch.extend(vertices.iter().map(distance));
    let typical = median(&mut scratch);
    if typical <= 0.0 {
        return None;
    }
    let (index, far) = vertices.iter().map(distance).enumerate().max_by(|a, b| a.1.total_cmp(&b.1))?;
    let ratio = far / typical;
    (ratio > OUTLIER_RATIO).then_some((index, ratio))
}

/// How many times farther than the median vertex a vertex may lie from the median point.
pub const OUTLIER_RATIO: f64 = 1000.0;

pub(crate) fn process(path: &Path, options: &LoadOptions) -> Result<Processed, MeshLoadError> {
    let (raw, format) = read_and_parse(path)?;
    if let Some((index, ratio)) = find_outlier(&raw.vertices) {
        let location = match format {
            MeshFormat::Obj => format!("vertex {}", index + 1),
            MeshFormat::StlBinary | MeshFormat::StlAscii => format!("triangle {}", index / 3),
        };
        return Err(MeshLoadError::OutlierVertex {
            path: path.to_path_buf(),
            location,
            position: raw.vertices[index],
            ratio,
        });
    }
    let diagonal = BoundingBox::of_points(&raw.vertices).map_or(0.0, |b| b.diagonal());
    let (units, units_inferred) = match options.units {
        Some(u) => (u, false),
        None => (Units::infer(diagonal), true),
    };
    let weld_tolerance = options
        .weld_tolerance
        .filter(|t| t.is_finite() && *t >= 0.0)
        .unwrap_or(diagonal * LoadOptions::DEFAULT_WELD_FRACTION);
    let welded = weld(&raw.vertices, weld_tolerance);
    let (mut triangles, degenerate_removed) = remap_triangles(&raw.triangles, &welded.remap);
    let vertices = compact(welded.positions, &mut triangles);
    if triangles.is_empty() {
        return Err(MeshLoadError::Empty { path: path.to_path_buf(), degenerate_removed, weld_tolerance });
    }
    let edges = EdgeTable::build(&triangles);
    let defects = edges.defects(vertices.len());
    let orientation = orient(&vertices, &mut triangles, &edges);
    Ok(Processed {
        format,
        raw_vertices: raw.vertices.len(),
        raw_triangles: raw.triangles.len(),
        vertices,
        triangles,
        degenerate_removed,
        units,
        units_inferred,
        weld_tolerance,
        edges,
        defects,
        orientation,
    })
}

/// Loads an STL or OBJ file as a welded, closed, outward-wound surface in metres.
///
/// See the [module docs](self) for the steps. Never panics on bad input.
///
/// # Errors
/// [`MeshLoadError`]: the file cannot be read (missing, not a regular file, over its cap or
/// the memory available), has an unknown extension, is malformed (the error names the file
/// and line, or the binary STL triangle), has a stray vertex, is empty after cleaning, has
/// holes or non-manifold edges (unless allowed by `options`; the error gives counts and the
/// first offending edge in file units), or cannot be oriented consistently.
pub fn load(path: impl AsRef<Path>, options: &LoadOptions) -> Result<LoadedMesh, MeshLoadError> {
    let path = path.as_ref();
    let p = process(path, options)?;
    let edge = |lo: u32, hi: u32| [p.vertices[lo as usize], p.vertices[hi as usize]];
    if let (false, Some((lo, hi, n))) = (options.allow_non_manifold, p.defects.first_non_manifold) {
        return Err(MeshLoadError::NonManifold {
            path: path.to_path_buf(),
            non_manifold_edges: p.defects.non_manifold_edges,
            triangles_on_first_edge: n,
            first_edge: edge(lo, hi),
            units: p.units,
        });
    }
    if let (false, Some((lo, hi))) = (options.allow_open, p.defects.first_boundary) {
        return Err(MeshLoadError::OpenSurface {
            path: path.to_path_buf(),
            boundary_edges: p.defects.boundary_edges,
            holes: p.defects.holes,
            first_edge: edge(lo, hi),
            units: p.units,
        });
    }
    if let Some((lo, hi)) = p.orientation.conflict_edge {
        return Err(MeshLoadError::NonOrientable {
            path: path.to_path_buf(),
            first_edge: edge(lo, hi),
            units: p.units,
        });
    }
    let report = LoadReport {
        format: p.format,
        raw_vertices: p.raw_vertices,
        welded_vertices: p.vertices.len(),
        raw_triangles: p.raw_triangles,
        triangles: p.triangles.len(),
        degenerate_removed: p.degenerate_removed,
        flipped_fixed: p.orientation.flipped,
        units: p.units,
        units_inferred: p.units_inferred,
        weld_tolerance: p.weld_tolerance,
        boundary_edges: p.defects.boundary_edges,
        non_manifold_edges: p.defects.non_manifold_edges,
    };
    let k = p.units.metres_per_unit();
    let vertices = p.vertices.into_iter().map(|v| v.map(|c| c * k)).collect();
    Ok(LoadedMesh { mesh: TriMesh::from_valid(vertices, p.triangles), report })
}
