//! A recorded run as a ParaView time series: one `.vtu` per frame plus a `.pvd` collection.

use super::error::VtuWriteError;
use super::format::escape_attribute;
use super::vtu::VtuStatic;
use crate::model::Model;
use std::fs;
use std::path::{Path, PathBuf};

/// Writes frames `<stem>_0000.vtu`, `<stem>_0001.vtu`, ... into a directory, and the
/// collection `<stem>.pvd` listing them with their times (open that in ParaView).
///
/// The collection is rewritten after every frame, so an interrupted run still opens. The
/// model's connectivity and per-node and per-spring data are rendered once, at
/// [`VtuSeriesWriter::create`]; each frame writes only positions and displacements.
///
/// # Examples
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use lamina_core::io::VtuSeriesWriter;
/// use lamina_core::yardstick::{LatticeSize, lattice_model};
/// let model = lattice_model(LatticeSize { nx: 3, ny: 2, nz: 2 });
/// # let dir = std::env::temp_dir().join(format!("lamina_vtu_doc_{}", std::process::id()));
/// let mut series = VtuSeriesWriter::create(&model, &dir, "run")?;
/// series.write_frame(0.0, &model.nodes.position)?;
/// series.write_frame(0.001, &model.nodes.position)?;
/// let pvd = series.finish()?;
/// assert!(pvd.ends_with("run.pvd"));
/// # std::fs::remove_dir_all(&dir)?;
/// # Ok(())
/// # }
/// ```
pub struct VtuSeriesWriter {
    dir: PathBuf,
    stem: String,
    model: Model,
    statics: VtuStatic,
    /// Time (s) and file name of every frame written.
    frames: Vec<(f64, String)>,
}

impl VtuSeriesWriter {
    /// Starts a series for `model` in directory `dir` (created if missing), files named
    /// after `stem`. Writes the (empty) collection at once.
    ///
    /// # Errors
    /// [`VtuWriteError::Io`] if the directory or the collection cannot be written.
    pub fn create(model: &Model, dir: impl AsRef<Path>, stem: &str) -> Result<Self, VtuWriteError> {
        let dir = dir.as_ref().to_path_buf();
        fs::create_dir_all(&dir)
            .map_err(|e| VtuWriteError::Io { file: dir.display().to_string(), message: e.to_string() })?;
        let writer = Self {
            dir,
            stem: stem.to_string(),
            model: model.clone(),
            statics: VtuStatic::new(model),
            frames: Vec::new(),
        };
        writer.write_collection()?;
        Ok(writer)
    }

    /// Writes the next frame: node `positions` (m, one per node) at simulated `time` (s,
    /// finite, not before the previous frame). Returns the path of the `.vtu` written.
    ///
    /// # Errors
    /// [`VtuWriteError::BadTime`], [`VtuWriteError::PositionCount`], [`VtuWriteError::Io`].
    pub fn write_frame(&mut self, time: f64, positions: &[[f64; 3]]) -> Result<PathBuf, VtuWriteError> {
        let frame = self.frames.len();
        if !time.is_finite() || self.frames.last().is_some_and(|(t, _)| time < *t) {
            return Err(VtuWriteError::BadTime { frame });
        }
        let name = format!("{}_{frame:04}.vtu", self.stem);
        let path = self.dir.join(&name);
        self.statics.write(&self.model, Some(positions), &path)?;
        self.frames.push((time, name));
        self.write_collection()?;
        Ok(path)
    }

    /// Number of frames written so far.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// Path of the `.pvd` collection.
    pub fn collection_path(&self) -> PathBuf {
        self.dir.join(format!("{}.pvd", self.stem))
    }

    /// Ends the series; returns the path of the `.pvd` collection.
    ///
    /// # Errors
    /// [`VtuWriteError::Io`] if the collection cannot be written.
    pub fn finish(self) -> Result<PathBuf, VtuWriteError> {
        self.write_collection()?;
        Ok(self.collection_path())
    }

    /// Writes the collection to a temporary file and renames it into place.
    fn write_collection(&self) -> Result<(), VtuWriteError> {
        write_pvd(&self.frames, &self.collection_path(), &self.dir.join(format!(".{}.pvd.tmp", self.stem)))
    }
}

/// Writes a `.pvd` collection listing `frames` (simulated time s, file name) to `tmp`, then
/// renames it to `path`, so a reader never sees half a collection.
pub(crate) fn write_pvd(frames: &[(f64, String)], path: &Path, tmp: &Path) -> Result<(), VtuWriteError> {
    let mut text = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    let mut float = zmij::Buffer::new();
    for (time, file) in frames {
        text.push_str("    <DataSet timestep=\"");
        text.push_str(float.format(*time));
        text.push_str("\" group=\"\" part=\"0\" file=\"");
        escape_attribute(file, &mut text);
        text.push_str("\"/>\n");
    }
    text.push_str("  </Collection>\n</VTKFile>\n");
    let io_error = |e: std::io::Error| VtuWriteError::Io { file: path.display().to_string(), message: e.to_string() };
    fs::write(tmp, text).map_err(io_error)?;
    fs::rename(tmp, path).map_err(io_error)
}
