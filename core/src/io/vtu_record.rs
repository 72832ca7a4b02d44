//! A recorded run for ParaView: the model's volume cells, deformed, one `.vtu` per frame,
//! and a `.pvd` collection with each frame's simulated time.
//!
//! Each frame is an XML UnstructuredGrid with its arrays base64-encoded (`format="binary"`,
//! `header_type="UInt64"`, uncompressed), which ParaView, VTK and meshio read. Points are
//! the nodes at their recorded positions. Cells are the model's volume cells
//! ([`Model::cells`]: `VTK_TETRA` 10, `VTK_WEDGE` 13, `VTK_HEXAHEDRON` 12, in model order);
//! a model without cells is written with its springs as `VTK_LINE` (3) instead.
//!
//! | Array | Where | Type | Meaning |
//! |---|---|---|---|
//! | `displacement` | point | Float32 ×3 | position − rest position, m |
//! | `velocity` | point | Float32 ×3 | m/s |
//! | `layer` | point | Int32 | the node's layer index |
//! | `layer` | cell | Int32 | the cell's (or spring's) layer index |
//! | `strain` | cell | Float32 | engineering strain `(ℓ − ℓ₀)/ℓ₀`: of the spring for a line cell; for a volume cell the mean over the springs joining two of its nodes (0 when none does) |
//!
//! The parts that do not change between frames (cells, layers) are encoded once, at
//! [`VtuRecorder::create`].

use super::error::VtuWriteError;
use crate::model::Model;
use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

/// VTK cell type of a two-node line (springs, for a model without volume cells).
const VTK_LINE: u8 = 3;

/// Name of the collection file in the recording folder.
pub const RECORD_COLLECTION: &str = "run.pvd";

/// The `.pvd` is rewritten after this many frames (and when the recording finishes), so an
/// interrupted run still opens with all but the last few frames.
const COLLECTION_EVERY: usize = 25;

/// Writes a run as `frame_000000.vtu`, `frame_000001.vtu`, ... and `run.pvd` into a folder.
///
/// # Examples
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use lamina_core::io::VtuRecorder;
/// use lamina_core::scene::Scene;
/// let model = Scene::builtin_default().build_model()?;
/// # let dir = std::env::temp_dir().join(format!("lamina_record_doc_{}", std::process::id()));
/// let mut rec = VtuRecorder::create(&model, &dir)?;
/// let still = vec![[0.0; 3]; model.nodes.len()];
/// rec.write_frame(0.0, &model.nodes.position, &still)?;
/// rec.write_frame(0.02, &model.nodes.position, &still)?;
/// let pvd = rec.finish()?;
/// assert!(pvd.ends_with("run.pvd"));
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok(())
/// # }
/// ```
pub struct VtuRecorder {
    dir: PathBuf,
    rest: Vec<[f64; 3]>,
    /// Spring ends and rest lengths, for the strain.
    springs: Vec<(u32, u32, f64)>,
    /// Per output cell, the range of its springs in `cell_springs`.
    cell_range: Vec<(u32, u32)>,
    cell_springs: Vec<u32>,
    /// Pre-rendered XML: up to the point data's `layer`, up to the cell data's `layer`,
    /// to the points, and from the points to the end.
    head: String,
    middle: String,
    before_points: String,
    tail: String,
    /// Time (s) and file name of every frame written.
    frames: Vec<(f64, String)>,
    /// Frames listed in the collection file as last written.
    listed: usize,
    bytes: u64,
    /// Scratch buffers, reused from frame to frame.
    raw: Vec<u8>,
    text: String,
    strain: Vec<f32>,
}

impl VtuRecorder {
    /// Starts a recording of `model` in folder `dir` (created if missing) and writes the
    /// empty collection.
    ///
    /// # Errors
    /// [`VtuWriteError::Io`] if the folder or the collection cannot be written.
    pub fn create(model: &Model, dir: impl AsRef<Path>) -> Result<Self, VtuWriteError> {
        let dir = dir.as_ref().to_path_buf();
        fs::create_dir_all(&dir)
            .map_err(|e| VtuWriteError::Io { file: dir.display().to_string(), message: e.to_string() })?;
        let n = model.nodes.len();
        let s = &model.springs;
        let springs: Vec<(u32, u32, f64)> = (0..s.len()).map(|i| (s.a[i], s.b[i], s.rest_length[i])).collect();
        let mut raw = Vec::new();
        let mut cell_range = Vec::new();
        let mut cell_springs = Vec::new();
        let (mut connectivity, mut offsets, mut types, mut layers) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        if model.cells.is_empty() {
            for (i, &(a, b, _)) in springs.iter().enumerate() {
                connectivity.extend([a, b]);
                offsets.push(connectivity.len());
                types.push(VTK_LINE);
                layers.push(i32::from(s.layer[i]));
                cell_range.push((i as u32, i as u32 + 1));
                cell_springs.push(i as u32);
            }
        } else {
            let by_pair: HashMap<(u32, u32), u32> =
                springs.iter().enumerate().map(|(i, &(a, b, _))| ((a.min(b), a.max(b)), i as u32)).collect();
            for cell in &model.cells {
                let nodes = cell.nodes();
                connectivity.extend_from_slice(nodes);
                offsets.push(connectivity.len());
                types.push(cell.kind.vtk_type());
                layers.push(i32::from(cell.layer));
                let first = cell_springs.len() as u32;
                for (k, &a) in nodes.iter().enumerate() {
                    for &b in &nodes[k + 1..] {
                        if let Some(&spring) = by_pair.get(&(a.min(b), a.max(b))) {
                            cell_springs.push(spring);
                        }
                    }
                }
                cell_range.push((first, cell_springs.len() as u32));
            }
        }
        let cells = types.len();
        let wide = n > i32::MAX as usize || connectivity.len() > i32::MAX as usize;
        let index_type = if wide { "Int64" } else { "Int32" };
        let mut head = String::from(
            "<?xml version=\"1.0\"?>\n<!-- Lamina recording; arrays and units: docs/recording.md -->\n\
             <VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  \
             <UnstructuredGrid>\n",
        );
        let _ = writeln!(head, "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{cells}\">");
        head.push_str("      <PointData Vectors=\"displacement\" Scalars=\"layer\">\n");
        encode(&mut raw, &mut head, "Int32", "layer", 1, model.nodes.layer.iter().map(|&l| i32::from(l)));
        let mut middle = String::from("      </PointData>\n      <CellData Scalars=\"strain\">\n");
        encode(&mut raw, &mut middle, "Int32", "layer", 1, layers.into_iter());
        let before_points = String::from("      </CellData>\n      <Points>\n");
        let mut tail = String::from("      </Points>\n      <Cells>\n");
        if wide {
            encode(&mut raw, &mut tail, index_type, "connectivity", 1, connectivity.iter().map(|&v| i64::from(v)));
            encode(&mut raw, &mut tail, index_type, "offsets", 1, offsets.iter().map(|&o| o as i64));
        } else {
            encode(&mut raw, &mut tail, index_type, "connectivity", 1, connectivity.iter().map(|&v| v as i32));
            encode(&mut raw, &mut tail, index_type, "offsets", 1, offsets.iter().map(|&o| o as i32));
        }
        encode(&mut raw, &mut tail, "UInt8", "types", 1, types.into_iter());
        tail.push_str("      </Cells>\n    </Piece>\n  </UnstructuredGrid>\n</VTKFile>\n");
        let recorder = Self {
            dir,
            rest: model.nodes.position.clone(),
            springs,
            cell_range,
            cell_springs,
            head,
            middle,
            before_points,
            tail,
            frames: Vec::new(),
            listed: 0,
            bytes: 0,
            raw,
            text: String::new(),
            strain: Vec::with_capacity(cells),
        };
        recorder.write_collection()?;
        Ok(recorder)
    }

    /// Writes the next frame: node `positions` (m) and `velocities` (m/s), one per node, at
    /// simulated `time` (s, finite, not before the previous frame). Returns the bytes written.
    ///
    /// # Errors
    /// [`VtuWriteError::BadTime`], [`VtuWriteError::PositionCount`] (also for velocities),
    /// [`VtuWriteError::Io`].
    pub fn write_frame(
        &mut self,
        time: f64,
        positions: &[[f64; 3]],
        velocities: &[[f64; 3]],
    ) -> Result<u64, VtuWriteError> {
        let frame = self.frames.len();
        if !time.is_finite() || self.frames.last().is_some_and(|(t, _)| time < *t) {
            return Err(VtuWriteError::BadTime { frame });
        }
        let n = self.rest.len();
        for found in [positions.len(), velocities.len()] {
            if found != n {
                return Err(VtuWriteError::PositionCount { expected: n, found });
            }
        }
        self.strain.clear();
        for &(first, end) in &self.cell_range {
            let springs = &self.cell_springs[first as usize..end as usize];
            let sum: f64 = springs.iter().map(|&s| strain(self.springs[s as usize], positions)).sum();
            self.strain.push(if springs.is_empty() { 0.0 } else { (sum / springs.len() as f64) as f32 });
        }
        let (raw, text) = (&mut self.raw, &mut self.text);
        text.clear();
        text.push_str(&self.head);
        let rest = &self.rest;
        let d = positions.iter().zip(rest).flat_map(|(p, r)| [0, 1, 2].map(|k| (p[k] - r[k]) as f32));
        encode(raw, text, "Float32", "displacement", 3, d);
        encode(raw, text, "Float32", "velocity", 3, velocities.iter().flat_map(|v| v.map(|c| c as f32)));
        text.push_str(&self.middle);
        encode(raw, text, "Float32", "strain", 1, self.strain.iter().copied());
        text.push_str(&self.before_points);
        encode(raw, text, "Float32", "Points", 3, positions.iter().flat_map(|p| p.map(|c| c as f32)));
        text.push_str(&self.tail);
        let name = format!("frame_{frame:06}.vtu");
        let path = self.dir.join(&name);
        let io_error =
            |e: std::io::Error| VtuWriteError::Io { file: path.display().to_string(), message: e.to_string() };
        File::create(&path).and_then(|mut f| f.write_all(text.as_bytes())).map_err(io_error)?;
        let bytes = text.len() as u64;
        self.bytes += bytes;
        self.frames.push((time, name));
        if self.frames.len() - self.listed >= COLLECTION_EVERY {
            self.write_collection()?;
        }
        Ok(bytes)
    }

    /// Frames written so far.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// Bytes of `.vtu` files written so far.
    pub fn bytes_written(&self) -> u64 {
        self.bytes
    }

    /// Path of the `.pvd` collection.
    pub fn collection_path(&self) -> PathBuf {
        self.dir.join(RECORD_COLLECTION)
    }

    /// Writes the collection listing every frame; returns its path.
    ///
    /// # Errors
    /// [`VtuWriteError::Io`] if the collection cannot be written.
    pub fn finish(mut self) -> Result<PathBuf, VtuWriteError> {
        self.write_collection()?;
        self.listed = self.frames.len();
        Ok(self.collection_path())
    }

    /// Writes the collection to a temporary file and renames it into place.
    fn write_collection(&self) -> Result<(), VtuWriteError> {
        super::vtu_series::write_pvd(&self.frames, &self.collection_path(), &self.dir.join(".run.pvd.tmp"))
    }
}

impl Drop for VtuRecorder {
    /// A recording dropped without [`VtuRecorder::finish`] still lists every frame written.
    fn drop(&mut self) {
        if self.listed < self.frames.len() {
            let _ = self.write_collection();
        }
    }
}

/// Recorded files this reader accepts: at most 1 GiB each, read into at most twice that.
const RECORDED_FILE: lamina_input::FileLimit =
    lamina_input::FileLimit::new("recorded frame", 1 << 30).memory_per_byte(2);

/// Why a recording could not be read back.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{file}: {message}")]
pub struct RecordReadError {
    /// The file.
    pub file: String,
    /// What is wrong with it.
    pub message: String,
}

/// One frame listed in a recording's collection.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordedFrame {
    /// Simulated time, s.
    pub time: f64,
    /// The frame's `.vtu` file.
    pub path: PathBuf,
}

fn read_text(path: &Path) -> Result<String, RecordReadError> {
    use std::io::Read as _;
    let error = |message: String| RecordReadError { file: path.display().to_string(), message };
    let (file, size) = lamina_input::open_regular(path, &RECORDED_FILE).map_err(|e| error(e.to_string()))?;
    let mut text = String::with_capacity(size as usize);
    file.take(RECORDED_FILE.max_bytes).read_to_string(&mut text).map_err(|e| error(e.to_string()))?;
    Ok(text)
}

/// The value of attribute `name` in one start tag's text (`<DataSet a="1" b="2"/>`).
fn attribute<'t>(tag: &'t str, name: &str) -> Option<&'t str> {
    let key = format!(" {name}=\"");
    let start = tag.find(&key)? + key.len();
    tag[start..].find('"').map(|end| &tag[start..start + end])
}

/// The frames listed in a recording's collection (`run.pvd`), in time order, with their
/// files resolved next to it.
///
/// # Errors
/// [`RecordReadError`] naming the file when it cannot be read, lists no frame, or a
/// `<DataSet>` lacks a finite `timestep` or a `file`.
pub fn read_recording(pvd: impl AsRef<Path>) -> Result<Vec<RecordedFrame>, RecordReadError> {
    let pvd = pvd.as_ref();
    let text = read_text(pvd)?;
    let error = |message: String| RecordReadError { file: pvd.display().to_string(), message };
    let base = pvd.parent().unwrap_or(Path::new("."));
    let mut frames = Vec::new();
    for (k, piece) in text.split("<DataSet").skip(1).enumerate() {
        let tag = &piece[..piece.find('>').unwrap_or(piece.len())];
        let time = attribute(tag, "timestep").and_then(|t| t.parse::<f64>().ok()).filter(|t| t.is_finite());
        let file = attribute(tag, "file").filter(|f| !f.is_empty());
        let (Some(time), Some(file)) = (time, file) else {
            return Err(error(format!("DataSet {k}: needs a finite timestep and a file")));
        };
        frames.push(RecordedFrame { time, path: base.join(file) });
    }
    if frames.is_empty() {
        return Err(error("lists no frame (no <DataSet>)".into()));
    }
    frames.sort_by(|a, b| a.time.total_cmp(&b.time));
    Ok(frames)
}

/// The node positions (m) of one recorded frame, as [`VtuRecorder`] writes them (the
/// `Points` array, Float32, base64 binary).
///
/// # Errors
/// [`RecordReadError`] naming the file when it cannot be read or its `Points` array is
/// missing, not Float32 binary, or not 3 × `NumberOfPoints` values.
pub fn read_recorded_points(path: impl AsRef<Path>) -> Result<Vec<[f32; 3]>, RecordReadError> {
    let path = path.as_ref();
    let text = read_text(path)?;
    let error = |message: &str| RecordReadError { file: path.display().to_string(), message: message.to_string() };
    let piece = text.find("<Piece").map(|i| &text[i..]).ok_or_else(|| error("no <Piece>"))?;
    let count: usize = attribute(&piece[..piece.find('>').unwrap_or(0)], "NumberOfPoints")
        .and_then(|n| n.parse().ok())
        .ok_or_else(|| error("<Piece> lacks NumberOfPoints"))?;
    let points = text.find("<Points>").map(|i| &text[i..]).ok_or_else(|| error("no <Points>"))?;
    let open = points.find("<DataArray").map(|i| &points[i..]).ok_or_else(|| error("<Points> holds no <DataArray>"))?;
    let tag_end = open.find('>').ok_or_else(|| error("unterminated <DataArray>"))?;
    let tag = &open[..tag_end];
    if attribute(tag, "type") != Some("Float32") || attribute(tag, "format") != Some("binary") {
        return Err(error("the points are not a Float32 binary array (not written by lamina run --record)"));
    }
    let body = &open[tag_end + 1..];
    let body = body[..body.find('<').unwrap_or(body.len())].trim_ascii();
    let bytes = BASE64.decode(body).map_err(|e| error(&format!("points: bad base64: {e}")))?;
    let data = bytes.get(8..).ok_or_else(|| error("points: shorter than their header"))?;
    let declared = u64::from_le_bytes(bytes[..8].try_into().unwrap_or([0; 8]));
    if declared != data.len() as u64 || data.len() != count.saturating_mul(12) {
        // The count is the file's: 12 bytes each may pass 2^64, said so rather than wrapped.
        let expected = count.checked_mul(12).map_or_else(|| "more than 2^64".to_owned(), |b| b.to_string());
        return Err(error(&format!("points: {} bytes for {count} points (expected {expected})", data.len())));
    }
    let f = |k: usize| f32::from_le_bytes([data[k], data[k + 1], data[k + 2], data[k + 3]]);
    Ok((0..count).map(|i| [f(12 * i), f(12 * i + 4), f(12 * i + 8)]).collect())
}

/// Engineering strain of spring `(a, b, rest)` at `positions`; 0 for a zero rest length.
fn strain((a, b, rest): (u32, u32, f64), positions: &[[f64; 3]]) -> f64 {
    let (p, q) = (positions[a as usize], positions[b as usize]);
    let length = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2) + (q[2] - p[2]).powi(2)).sqrt();
    if rest > 0.0 { (length - rest) / rest } else { 0.0 }
}

/// A value of a binary data array, little-endian.
trait BinaryValue: Copy {
    fn put(self, out: &mut Vec<u8>);
}

macro_rules! binary_value {
    ($($t:ty),*) => {$(
        impl BinaryValue for $t {
            fn put(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
        }
    )*};
}
binary_value!(f32, i32, i64, u8);

/// Appends one `<DataArray format="binary">`: base64 of the byte count (UInt64) followed by
/// the values, encoded together, as VTK reads uncompressed inline data.
fn encode<V: BinaryValue>(
    raw: &mut Vec<u8>,
    out: &mut String,
    ty: &str,
    name: &str,
    components: usize,
    values: impl Iterator<Item = V>,
) {
    raw.clear();
    raw.extend_from_slice(&[0; 8]);
    for v in values {
        v.put(raw);
    }
    let bytes = (raw.len() - 8) as u64;
    raw[..8].copy_from_slice(&bytes.to_le_bytes());
    let _ = write!(out, "        <DataArray type=\"{ty}\" Name=\"{name}\"");
    if components > 1 {
        let _ = write!(out, " NumberOfComponents=\"{components}\"");
    }
    out.push_str(" format=\"binary\">\n          ");
    BASE64.encode_string(&raw[..], out);
    out.push_str("\n        </DataArray>\n");
}
