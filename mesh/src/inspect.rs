//! [`inspect()`]: measures and defects of a mesh file, for `lamina inspect FILE`.
//!
//! Inspection runs the loader's steps (parse, units, weld, orient) but never fails on a
//! surface's shape: holes, non-manifold edges and non-orientable parts are counted and
//! shown. It fails only when the file cannot be read or parsed.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::error::MeshLoadError;
use crate::load::{LoadOptions, process};
use crate::raw::MeshFormat;
use crate::trimesh::{BoundingBox, area_of, signed_volume_of};
use crate::units::Units;

/// Measures and defects of one mesh file. All lengths are in metres.
#[derive(Clone, Debug, PartialEq)]
pub struct Inspection {
    /// File inspected.
    pub path: PathBuf,
    /// Format it was read as.
    pub format: MeshFormat,
    /// Units of the file (given or inferred).
    pub units: Units,
    /// True when `units` was inferred.
    pub units_inferred: bool,
    /// Weld tolerance used (file units).
    pub weld_tolerance: f64,
    /// Vertices as stored in the file.
    pub raw_vertices: usize,
    /// Vertices after welding (only those used by triangles).
    pub welded_vertices: usize,
    /// Triangles in the file (polygons fan-triangulated).
    pub raw_triangles: usize,
    /// Triangles after removing degenerate ones.
    pub triangles: usize,
    /// Triangles with two corners on one vertex after welding.
    pub degenerate_removed: usize,
    /// Distinct undirected edges.
    pub edges: usize,
    /// Edges used by exactly one triangle.
    pub boundary_edges: usize,
    /// Holes: connected loops of boundary edges.
    pub holes: usize,
    /// Edges used by three or more triangles.
    pub non_manifold_edges: usize,
    /// Connected components (joined through manifold edges).
    pub components: usize,
    /// Euler characteristic V − E + F (2 for one closed genus-0 surface).
    pub euler_characteristic: i64,
    /// False when some component cannot be wound consistently.
    pub orientable: bool,
    /// Triangles whose winding had to be reversed to be consistent and outward.
    pub flipped_triangles: usize,
    /// Enclosed volume after orientation (m³); meaningful only when [`Inspection::is_closed`].
    pub volume: f64,
    /// Surface area (m²).
    pub area: f64,
    /// Bounding box (m).
    pub bounding_box: BoundingBox,
    /// Mean length of the distinct edges (m).
    pub mean_edge_length: f64,
}

impl Inspection {
    /// True when no edge is a boundary or non-manifold edge.
    pub fn is_closed(&self) -> bool {
        self.boundary_edges == 0 && self.non_manifold_edges == 0
    }
}

/// Inspects a mesh file with default options (units inferred, default weld tolerance).
///
/// # Errors
/// [`MeshLoadError`] only when the file cannot be read or parsed, or has no triangles; never
/// for holes, non-manifold edges or non-orientable surfaces.
pub fn inspect(path: impl AsRef<Path>) -> Result<Inspection, MeshLoadError> {
    inspect_with(path, &LoadOptions::default())
}

/// Inspects a mesh file using `options.units` and `options.weld_tolerance`
/// (`allow_open` and `allow_non_manifold` are ignored: inspection accepts any surface).
///
/// # Errors
/// As [`inspect()`].
pub fn inspect_with(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Inspection, MeshLoadError> {
    let path = path.as_ref();
    let p = process(path, options)?;
    let k = p.units.metres_per_unit();
    let vertices: Vec<[f64; 3]> = p.vertices.iter().map(|v| v.map(|c| c * k)).collect();
    let bounding_box = BoundingBox::of_points(&vertices).unwrap_or(BoundingBox { min: [0.0; 3], max: [0.0; 3] });
    Ok(Inspection {
        path: path.to_path_buf(),
        format: p.format,
        units: p.units,
        units_inferred: p.units_inferred,
        weld_tolerance: p.weld_tolerance,
        raw_vertices: p.raw_vertices,
        welded_vertices: vertices.len(),
        raw_triangles: p.raw_triangles,
        triangles: p.triangles.len(),
        degenerate_removed: p.degenerate_removed,
        edges: p.edges.edge_count(),
        boundary_edges: p.defects.boundary_edges,
        holes: p.defects.holes,
        non_manifold_edges: p.defects.non_manifold_edges,
        components: p.orientation.components,
        euler_characteristic: vertices.len() as i64 - p.edges.edge_count() as i64 + p.triangles.len() as i64,
        orientable: p.orientation.orientable,
        flipped_triangles: p.orientation.flipped,
        volume: signed_volume_of(&vertices, &p.triangles),
        area: area_of(&vertices, &p.triangles),
        bounding_box,
        mean_edge_length: p.edges.mean_edge_length(&vertices),
    })
}

impl fmt::Display for Inspection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let row = |f: &mut fmt::Formatter<'_>, k: &str, v: String| writeln!(f, "  {k:<22}{v}");
        writeln!(f, "{}", self.path.display())?;
        row(f, "format", self.format.to_string())?;
        let how = if self.units_inferred {
            format!(
                " (inferred: box diagonal {} {})",
                fmt_g(self.bounding_box.diagonal() / self.units.metres_per_unit()),
                self.units.symbol()
            )
        } else {
            " (given)".to_string()
        };
        row(f, "units", format!("{}{how}", self.units))?;
        row(f, "weld tolerance", format!("{} {}", fmt_g(self.weld_tolerance), self.units.symbol()))?;
        row(f, "raw vertices", self.raw_vertices.to_string())?;
        row(f, "welded vertices", self.welded_vertices.to_string())?;
        row(
            f,
            "triangles",
            format!(
                "{} ({} in file, {} degenerate removed)",
                self.triangles, self.raw_triangles, self.degenerate_removed
            ),
        )?;
        row(f, "edges", self.edges.to_string())?;
        row(f, "closed", if self.is_closed() { "yes".into() } else { "NO".into() })?;
        row(f, "boundary edges", format!("{} ({} holes)", self.boundary_edges, self.holes))?;
        row(f, "non-manifold edges", self.non_manifold_edges.to_string())?;
        row(f, "components", self.components.to_string())?;
        row(
            f,
            "Euler characteristic",
            format!(
                "{} (V − E + F = {} − {} + {})",
                self.euler_characteristic, self.welded_vertices, self.edges, self.triangles
            ),
        )?;
        row(f, "orientable", if self.orientable { "yes".into() } else { "NO".into() })?;
        row(f, "flipped triangles", format!("{} (reversed to wind consistently outward)", self.flipped_triangles))?;
        let vol_note = if self.is_closed() { "" } else { " (surface not closed: not meaningful)" };
        row(f, "volume", format!("{} m³ = {} L{vol_note}", fmt_g(self.volume), fmt_g(self.volume * 1000.0)))?;
        row(f, "surface area", format!("{} m²", fmt_g(self.area)))?;
        let (b, s) = (self.bounding_box, self.bounding_box.size());
        row(f, "bounding box min", format!("({}, {}, {}) m", fmt_g(b.min[0]), fmt_g(b.min[1]), fmt_g(b.min[2])))?;
        row(f, "bounding box max", format!("({}, {}, {}) m", fmt_g(b.max[0]), fmt_g(b.max[1]), fmt_g(b.max[2])))?;
        row(f, "bounding box size", format!("{} × {} × {} m", fmt_g(s[0]), fmt_g(s[1]), fmt_g(s[2])))?;
        row(f, "mean edge length", format!("{} m", fmt_g(self.mean_edge_length)))
    }
}

/// Five significant digits, plain notation between 10⁻³ and 10⁶, scientific otherwise.
fn fmt_g(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..6).contains(&mag) {
        let decimals = (4 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.4e}")
    }
}

#[cfg(test)]
mod tests {
    use super::fmt_g;

    #[test]
    fn fmt_g_digits_works() {
        assert_eq!(fmt_g(0.0), "0");
        assert_eq!(fmt_g(1.23456), "1.2346");
        assert_eq!(fmt_g(-0.012345), "-0.012345");
        assert_eq!(fmt_g(123456.7), "123457");
        assert_eq!(fmt_g(1.5e-6), "1.5000e-6");
    }
}
