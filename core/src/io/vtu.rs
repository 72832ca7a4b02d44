//! VTK export: a model (optionally deformed) as a ParaView `.vtu` file.
//!
//! XML UnstructuredGrid, ASCII, version 1.0. Points are the nodes (at the given positions,
//! else at rest); cells are the springs as `VTK_LINE` (3) in model order, then the triangles
//! of every surface as `VTK_TRIANGLE` (5), surface after surface.
//!
//! | Point data | Type | Meaning |
//! |---|---|---|
//! | `mass` | Float64 | node mass, kg |
//! | `layer` | Int32 | layer index |
//! | `kind` | Int32 | 0 free, 1 fixed, 2 kinematic |
//! | `displacement` | Float64 ×3 | position − rest position, m (only when positions are given) |
//!
//! | Cell data | Type | Meaning |
//! |---|---|---|
//! | `layer` | Int32 | spring layer; −1 for triangles |
//! | `stiffness` | Float64 | linear stiffness or bilinear `k1`, N/m; 0 for triangles |
//! | `k2` | Float64 | bilinear `k2`, N/m; the stiffness for linear springs; 0 for triangles |
//! | `law` | Int32 | 0 linear, 1 bilinear; −1 for triangles |
//! | `surface` | Int32 | surface index of a triangle; −1 for springs |

use super::error::VtuWriteError;
use crate::law::SpringLaw;
use crate::model::{Model, NodeKind};
use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// VTK cell type of a two-node line.
pub const VTK_LINE: u8 = 3;
/// VTK cell type of a three-node triangle.
pub const VTK_TRIANGLE: u8 = 5;

/// Writes `model` as a `.vtu` file at `path`. `positions` (m, one per node) places the
/// points and adds the `displacement` point array; `None` writes the rest shape.
///
/// # Errors
/// [`VtuWriteError::PositionCount`] if `positions` is not one per node;
/// [`VtuWriteError::Io`] if the file cannot be written.
pub fn write_vtu(model: &Model, positions: Option<&[[f64; 3]]>, path: impl AsRef<Path>) -> Result<(), VtuWriteError> {
    VtuStatic::new(model).write(model, positions, path.as_ref())
}

/// The text of the `.vtu` file [`write_vtu`] would write.
///
/// # Errors
/// [`VtuWriteError::PositionCount`] if `positions` is not one per node.
pub fn vtu_to_string(model: &Model, positions: Option<&[[f64; 3]]>) -> Result<String, VtuWriteError> {
    let mut out = Vec::new();
    VtuStatic::new(model)
        .emit(model, positions, &mut out)
        .map_err(|e| VtuWriteError::Io { file: "<string>".into(), message: e.to_string() })??;
    Ok(String::from_utf8(out).expect("the VTU writer emits UTF-8 only"))
}

/// The parts of a `.vtu` file that do not change from frame to frame, pre-rendered.
pub(crate) struct VtuStatic {
    /// From the XML header through the static point arrays.
    head: String,
    /// `</PointData>`, cell data, `<Points>` open tags.
    middle: String,
    /// Closing `<Points>`, the cells, and the end of the file.
    tail: String,
}

impl VtuStatic {
    pub(crate) fn new(model: &Model) -> Self {
        let nodes = &model.nodes;
        let springs = &model.springs;
        let triangles: usize = model.surfaces.iter().map(|s| s.triangles.len()).sum();
        let cells = springs.len() + triangles;
        let mut head = String::new();
        head.push_str("<?xml version=\"1.0\"?>\n<!-- Lamina model export; see docs/model-format.md -->\n");
        head.push_str(
            "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n",
        );
        head.push_str("  <UnstructuredGrid>\n");
        let _ = writeln!(head, "    <Piece NumberOfPoints=\"{}\" NumberOfCells=\"{cells}\">", nodes.len());
        head.push_str("      <PointData Scalars=\"mass\">\n");
        array(&mut head, "Float64", "mass", 1, nodes.mass.iter().copied());
        array(&mut head, "Int32", "layer", 1, nodes.layer.iter().map(|&l| l as i64));
        let kind = |k: &NodeKind| match k {
            NodeKind::Free => 0i64,
            NodeKind::Fixed => 1,
            NodeKind::Kinematic => 2,
        };
        array(&mut head, "Int32", "kind", 1, nodes.kind.iter().map(kind));

        let mut middle = String::new();
        middle.push_str("      </PointData>\n      <CellData Scalars=\"layer\">\n");
        let layer = springs.layer.iter().map(|&l| l as i64).chain(std::iter::repeat_n(-1, triangles));
        array(&mut middle, "Int32", "layer", 1, layer);
        let k1 = |law: &SpringLaw| match law {
            SpringLaw::Linear { stiffness } => *stiffness,
            SpringLaw::Bilinear(b) => b.k1,
        };
        let k2 = |law: &SpringLaw| match law {
            SpringLaw::Linear { stiffness } => *stiffness,
            SpringLaw::Bilinear(b) => b.k2,
        };
        let stiffness = springs.law.iter().map(k1).chain(std::iter::repeat_n(0.0, triangles));
        array(&mut middle, "Float64", "stiffness", 1, stiffness);
        let second = springs.law.iter().map(k2).chain(std::iter::repeat_n(0.0, triangles));
        array(&mut middle, "Float64", "k2", 1, second);
        let law = springs.law.iter().map(|l| if matches!(l, SpringLaw::Linear { .. }) { 0i64 } else { 1 });
        array(&mut middle, "Int32", "law", 1, law.chain(std::iter::repeat_n(-1, triangles)));
        let surface = std::iter::repeat_n(-1i64, springs.len()).chain(
            model.surfaces.iter().enumerate().flat_map(|(k, s)| std::iter::repeat_n(k as i64, s.triangles.len())),
        );
        array(&mut middle, "Int32", "surface", 1, surface);
        middle.push_str("      </CellData>\n      <Points>\n");

        let mut tail = String::new();
        tail.push_str("      </Points>\n      <Cells>\n");
        let connectivity = (0..springs.len())
            .flat_map(|s| [springs.a[s], springs.b[s]])
            .chain(model.surfaces.iter().flat_map(|s| s.triangles.iter().flatten().copied()))
            .map(i64::from);
        array(&mut tail, "Int64", "connectivity", 1, connectivity);
        let offsets = (1..=springs.len())
            .map(|s| 2 * s)
            .chain((1..=triangles).map(|t| 2 * springs.len() + 3 * t))
            .map(|o| o as i64);
        array(&mut tail, "Int64", "offsets", 1, offsets);
        let types = std::iter::repeat_n(VTK_LINE as i64, springs.len())
            .chain(std::iter::repeat_n(VTK_TRIANGLE as i64, triangles));
        array(&mut tail, "UInt8", "types", 1, types);
        tail.push_str("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
        Self { head, middle, tail }
    }

    /// Writes one file; positions as for [`write_vtu`].
    pub(crate) fn write(
        &self,
        model: &Model,
        positions: Option<&[[f64; 3]]>,
        path: &Path,
    ) -> Result<(), VtuWriteError> {
        let io_error =
            |e: std::io::Error| VtuWriteError::Io { file: path.display().to_string(), message: e.to_string() };
        check_positions(model, positions)?;
        let mut out = BufWriter::with_capacity(1 << 20, File::create(path).map_err(io_error)?);
        self.emit(model, positions, &mut out).map_err(io_error)??;
        out.flush().map_err(io_error)
    }

    /// Outer error: I/O; inner: bad positions.
    fn emit(
        &self,
        model: &Model,
        positions: Option<&[[f64; 3]]>,
        out: &mut impl Write,
    ) -> std::io::Result<Result<(), VtuWriteError>> {
        if let Err(e) = check_positions(model, positions) {
            return Ok(Err(e));
        }
        let rest = &model.nodes.position;
        out.write_all(self.head.as_bytes())?;
        let mut text = String::new();
        if let Some(p) = positions {
            let d = p.iter().zip(rest).flat_map(|(p, r)| [p[0] - r[0], p[1] - r[1], p[2] - r[2]]);
            array(&mut text, "Float64", "displacement", 3, d);
            out.write_all(text.as_bytes())?;
            text.clear();
        }
        out.write_all(self.middle.as_bytes())?;
        let points = positions.unwrap_or(rest);
        array(&mut text, "Float64", "Points", 3, points.iter().flatten().copied());
        out.write_all(text.as_bytes())?;
        out.write_all(self.tail.as_bytes())?;
        Ok(Ok(()))
    }
}

fn check_positions(model: &Model, positions: Option<&[[f64; 3]]>) -> Result<(), VtuWriteError> {
    match positions {
        Some(p) if p.len() != model.nodes.len() => {
            Err(VtuWriteError::PositionCount { expected: model.nodes.len(), found: p.len() })
        }
        _ => Ok(()),
    }
}

/// A value of an ASCII data array.
trait AsciiValue: Copy {
    fn push(self, out: &mut String);
}

impl AsciiValue for f64 {
    fn push(self, out: &mut String) {
        out.push_str(zmij::Buffer::new().format(self));
    }
}

impl AsciiValue for i64 {
    fn push(self, out: &mut String) {
        out.push_str(itoa::Buffer::new().format(self));
    }
}

/// Appends one ASCII `<DataArray>`, `components` values per line (8 for scalars).
fn array<V: AsciiValue>(out: &mut String, ty: &str, name: &str, components: usize, values: impl Iterator<Item = V>) {
    let _ = write!(out, "        <DataArray type=\"{ty}\" Name=\"{name}\"");
    if components > 1 {
        let _ = write!(out, " NumberOfComponents=\"{components}\"");
    }
    out.push_str(" format=\"ascii\">\n");
    let per_line = if components == 1 { 8 } else { components };
    for (k, v) in values.enumerate() {
        if k % per_line == 0 {
            if k > 0 {
                out.push('\n');
            }
            out.push_str("          ");
        } else {
            out.push(' ');
        }
        v.push(out);
    }
    out.push_str("\n        </DataArray>\n");
}
