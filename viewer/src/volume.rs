//! The paper's deformable 3D volume texture: a volume fixed in the model's rest frame, sampled
//! (trilinearly, on the GPU) at each drawn point's rest position, so the texture moves with
//! the tissue and a cut shows the anatomy inside.
//!
//! Two sources:
//! - a user's volume, a NIfTI-1 file ([`read_nifti`]) or a NRRD file
//!   ([`read_nrrd`](crate::nrrd::read_nrrd)), told apart by its name
//!   ([`read_volume`](crate::volume_file::read_volume)): its voxels as grey levels through an intensity
//!   window (or as colours, for an RGB volume such as a cryosection series), placed in the
//!   model frame by the origin and spacing of its header (or the scene's `origin_m`);
//! - otherwise a procedural one ([`bake_procedural`]), baked on the CPU when the first frame
//!   arrives: each voxel takes the tissue of the nearest rest sample (the nodes, and points
//!   between nested boundary grids) and that tissue's texture: skin with fine speckle, fat in
//!   yellow lobules, muscle with fibres along the limb, ivory bone with trabecular pores.
//!
//! Voxel order everywhere: x fastest, then y, then z.

use core::ops::Add;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use glam::Vec3;

use crate::material::Material;
use crate::source::{FrameSource, SourceEvent};
use crate::view_model::{Tissue, ViewModel, VolumeSpec};

/// Largest volume texture accepted, bytes (1 GiB).
pub const MAX_TEXTURE_BYTES: u64 = 1 << 30;

/// Voxels of the procedural volume, in total (128³), spread over the rest bounding box so that
/// voxels are cubes.
pub const PROCEDURAL_VOXELS: u64 = 128 * 128 * 128;

/// Seed of the procedural textures' noise (the volume is the same on every run).
pub const PROCEDURAL_SEED: u32 = 0x1a31_7a00;

/// How a volume's voxels are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VoxelFormat {
    /// One byte per voxel: a grey level after the intensity window (drawn in grey).
    Grey,
    /// Four bytes per voxel: sRGB colour and 255.
    Rgba,
}

impl VoxelFormat {
    /// Bytes per voxel.
    pub fn bytes(self) -> usize {
        match self {
            Self::Grey => 1,
            Self::Rgba => 4,
        }
    }
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// A volume ready for upload, and where it lies in the model frame.
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeImage {
    id: u64,
    /// Voxels along x, y, z.
    pub size: [u32; 3],
    /// Storage of each voxel.
    pub format: VoxelFormat,
    /// The voxels, x fastest.
    pub data: Vec<u8>,
    /// Corner of the box the volume fills (the outer corner of its first voxel), metres.
    pub box_min: Vec3,
    /// Size of that box, metres (voxels × spacing).
    pub box_size: Vec3,
}

impl VolumeImage {
    /// A volume of `size` voxels of `format` filling the box `box_min .. box_min + box_size`.
    ///
    /// # Panics
    /// If `data` does not hold exactly one voxel per cell.
    pub fn new(size: [u32; 3], format: VoxelFormat, data: Vec<u8>, box_min: Vec3, box_size: Vec3) -> Self {
        assert_eq!(data.len(), size.iter().map(|&n| n as usize).product::<usize>() * format.bytes());
        Self { id: NEXT_ID.fetch_add(1, Ordering::Relaxed), size, format, data, box_min, box_size }
    }

    /// A number no other volume of this process has (the renderer uploads a volume once).
    pub fn id(&self) -> u64 {
        self.id
    }

    /// The texture coordinate of a rest position: `(rest - box_min) / box_size`, in `0..1`
    /// inside the box.
    pub fn texcoord(&self, rest: Vec3) -> Vec3 {
        (rest - self.box_min) / self.box_size
    }

    /// The voxel nearest to texture coordinate `tc` (clamped to the volume) as RGBA bytes
    /// (a grey voxel `g` gives `[g, g, g, 255]`).
    pub fn voxel_at(&self, tc: Vec3) -> [u8; 4] {
        let idx = |k: usize| ((tc[k] * self.size[k] as f32).floor().max(0.0) as u32).min(self.size[k] - 1) as usize;
        let i = idx(0) + self.size[0] as usize * (idx(1) + self.size[1] as usize * idx(2));
        match self.format {
            VoxelFormat::Grey => [self.data[i], self.data[i], self.data[i], 255],
            VoxelFormat::Rgba => self.data[4 * i..4 * i + 4].try_into().unwrap_or([0; 4]),
        }
    }

    /// The volume with at most `max_dim` voxels along each axis (every `k`-th voxel, `k` the
    /// smallest whole factor that fits), covering the same box; `self` when it already fits.
    pub fn fitted(&self, max_dim: u32) -> Option<Self> {
        if self.size.iter().all(|&n| n <= max_dim) || max_dim == 0 {
            return None;
        }
        let step = self.size.map(|n| n.div_ceil(max_dim));
        let size = [0, 1, 2].map(|k| self.size[k].div_ceil(step[k]));
        let bytes = self.format.bytes();
        let mut data = Vec::with_capacity(size.iter().map(|&n| n as usize).product::<usize>() * bytes);
        for z in 0..size[2] {
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let (sx, sy, sz) = ((x * step[0]) as usize, (y * step[1]) as usize, (z * step[2]) as usize);
                    let i = sx + self.size[0] as usize * (sy + self.size[1] as usize * sz);
                    data.extend_from_slice(&self.data[i * bytes..(i + 1) * bytes]);
                }
            }
        }
        Some(Self::new(size, self.format, data, self.box_min, self.box_size))
    }
}

/// Why a volume file could not be used. Every variant names the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum VolumeError {
    /// The file could not be opened or read.
    #[error("volume {}: cannot read it: {message}", .path.display())]
    Io {
        /// File.
        path: PathBuf,
        /// OS or decoder error text.
        message: String,
    },
    /// The header is not a usable NIfTI-1 header.
    #[error("volume {}: not a usable NIfTI-1 volume: {message}", .path.display())]
    Header {
        /// File.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A line of a NRRD header is wrong, or a field it needs is missing.
    #[error("volume {}: line {line}: not a usable NRRD header: {message}", .path.display())]
    NrrdHeader {
        /// File.
        path: PathBuf,
        /// Line of the header, from 1 (for a missing field: the header's last line).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// A NRRD file's voxels do not match its header (too few, not decodable).
    #[error("volume {}: NRRD data: {message}", .path.display())]
    NrrdData {
        /// The file holding the voxels.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The volume is larger than [`MAX_TEXTURE_BYTES`] as a texture.
    #[error(
        "volume {}: {}x{}x{} voxels would take {:.2} GiB of texture, more than the 1 GiB limit",
        .path.display(), .dims[0], .dims[1], .dims[2], *.bytes as f64 / (1u64 << 30) as f64
    )]
    TooLarge {
        /// File.
        path: PathBuf,
        /// Voxels along x, y, z.
        dims: [u64; 3],
        /// Texture bytes it would take.
        bytes: u64,
    },
    /// The file is not a regular file (a FIFO, a device, a directory), or cannot be opened.
    #[error("volume {0}")]
    File(lamina_input::FileReadError),
    /// A header field or a `[visual]` setting is outside its bound.
    #[error("volume {}: {field} {value}: {bound}", .path.display())]
    Field {
        /// File.
        path: PathBuf,
        /// The field: `pixdim[1]`, `vox_offset`, `spacings`, `visual.window`, ...
        field: &'static str,
        /// The value given.
        value: String,
        /// What it must be.
        bound: String,
    },
    /// Reading and converting the voxels would take more memory than is available.
    #[error("volume {}: {error}", .path.display())]
    Memory {
        /// File.
        path: PathBuf,
        /// The refusal, with the estimate and what is available.
        error: lamina_input::MemoryCheckError,
    },
    /// Some voxels are NaN or infinite.
    #[error("volume {}: {count} voxels are NaN or infinite (the first is voxel {first})", .path.display())]
    NonFinite {
        /// File.
        path: PathBuf,
        /// How many.
        count: usize,
        /// Index of the first (x fastest).
        first: usize,
    },
}

/// What a volume file's header says about the volume, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VolumeGeometry {
    /// Voxels along x, y, z.
    pub dims: [u32; 3],
    /// Voxel spacing, metres.
    pub spacing_m: Vec3,
    /// Centre of the first voxel, metres (NIfTI: the `sform` offset, else the `qform` offset,
    /// else 0; NRRD: `space origin`, else 0).
    pub origin_m: Vec3,
    /// Storage of each voxel as a texture.
    pub format: VoxelFormat,
}

impl VolumeGeometry {
    /// The volume of these voxels (`data`, x fastest, in `self.format`), its first voxel's
    /// centre at `origin_m` (metres, model frame), else at the header's origin.
    ///
    /// # Panics
    /// If `data` does not hold exactly one voxel per cell.
    pub fn image(&self, data: Vec<u8>, origin_m: Option<[f32; 3]>) -> VolumeImage {
        let origin = origin_m.map_or(self.origin_m, Vec3::from_array);
        let box_size = Vec3::from_array(self.dims.map(|n| n as f32)) * self.spacing_m;
        VolumeImage::new(self.dims, self.format, data, origin - self.spacing_m * 0.5, box_size)
    }
}

/// Volume files this viewer opens: regular files only (never a FIFO or a device, which
/// would block or never end), up to 16 GiB (a 1 GiB texture of 64-bit samples, twice
/// over). The memory their voxels take is estimated from the header instead
/// ([`check_conversion_memory`]).
const VOLUME_FILE: lamina_input::FileLimit = lamina_input::FileLimit::new("volume file", 16 << 30).memory_per_byte(0);

/// Checks that `path` is a regular volume file within [`VOLUME_FILE`]'s cap, without
/// opening anything that could block; returns the opened file and its size, bytes.
pub(crate) fn open_volume_file(path: &Path) -> Result<(std::fs::File, u64), VolumeError> {
    lamina_input::open_regular(path, &VOLUME_FILE).map_err(|e| match e {
        lamina_input::FileReadError::Io { path, message } => VolumeError::Io { path, message },
        other => VolumeError::File(other),
    })
}

/// Smallest and largest voxel spacing accepted, metres: the normal `f32` range the texture
/// coordinates are computed in (a subnormal spacing loses its precision, a larger one is
/// infinite).
pub const SPACING_RANGE_M: [f64; 2] = [f32::MIN_POSITIVE as f64, f32::MAX as f64];

/// `v` as messages show it (scientific notation beyond a few digits).
fn shown(v: f64) -> String {
    lamina_rt::format_value(v)
}

/// A volume's geometry, each value checked after conversion to metres: spacings in
/// [`SPACING_RANGE_M`] with the whole extent (voxels × spacing) within `f32`, and an origin
/// within `f32`. `spacing_field` and `origin_field` name the header fields in the errors;
/// `unit_m` is metres per unit of the header's values.
pub(crate) fn checked_geometry(
    path: &Path,
    dims: [u32; 3],
    (spacing, spacing_field): ([f64; 3], &'static str),
    (origin, origin_field): ([f64; 3], &'static str),
    unit_m: f64,
    format: VoxelFormat,
) -> Result<VolumeGeometry, VolumeError> {
    let field =
        |field, value: String, bound: String| VolumeError::Field { path: path.to_path_buf(), field, value, bound };
    let list = |v: [f64; 3]| format!("[{}, {}, {}]", shown(v[0]), shown(v[1]), shown(v[2]));
    let [lo, hi] = SPACING_RANGE_M;
    for k in 0..3 {
        let metres = spacing[k] * unit_m;
        let extent = metres * f64::from(dims[k]);
        if !(metres >= lo && metres <= hi && extent <= hi) {
            let bound = format!(
                "axis {k} spacing is {} m; each must be from {} m to {} m (the normal f32 range) \
                 and, times the {} voxels along its axis, at most {} m",
                shown(metres),
                shown(lo),
                shown(hi),
                dims[k],
                shown(hi)
            );
            return Err(field(spacing_field, list(spacing), bound));
        }
    }
    let origin_m = origin.map(|c| c * unit_m);
    if !origin_m.iter().all(|c| c.abs() <= hi) {
        let bound = format!("is {} m; each coordinate must be within ±{} m (f32)", list(origin_m), shown(hi));
        return Err(field(origin_field, list(origin), bound));
    }
    Ok(VolumeGeometry {
        dims,
        spacing_m: Vec3::from_array((spacing.map(|c| c * unit_m)).map(|c| c as f32)),
        origin_m: Vec3::from_array(origin_m.map(|c| c as f32)),
        format,
    })
}

/// Where a volume's first voxel goes (metres, `f32`; `None`: the header's origin) and its
/// intensity window (`None`: the data's range).
pub(crate) type Placement = (Option<[f32; 3]>, Option<[f64; 2]>);

/// The placement a [`VolumeSpec`] asks for, checked: an origin within `f32` (metres) and a
/// window `[lo, hi]` within `f32` with `lo < hi` (the scene's `visual.origin_m` and
/// `visual.window`).
pub(crate) fn checked_placement(path: &Path, spec: &VolumeSpec) -> Result<Placement, VolumeError> {
    let max = f64::from(f32::MAX);
    let field =
        |field, value: String, bound: String| VolumeError::Field { path: path.to_path_buf(), field, value, bound };
    if let Some(o) = spec.origin_m
        && !o.iter().all(|c| c.abs() <= max)
    {
        let value = format!("[{}, {}, {}]", shown(o[0]), shown(o[1]), shown(o[2]));
        return Err(field("visual.origin_m", value, format!("each coordinate must be within ±{} m (f32)", shown(max))));
    }
    if let Some([lo, hi]) = spec.window
        && !(lo.abs() <= max && hi.abs() <= max && (lo as f32) < (hi as f32))
    {
        let value = format!("[{}, {}]", shown(lo), shown(hi));
        let bound = format!("must be [lo, hi] within ±{} (f32) with lo below hi", shown(max));
        return Err(field("visual.window", value, bound));
    }
    Ok((spec.origin_m.map(|o| o.map(|c| c as f32)), spec.window))
}

/// Refuses a volume whose reading and conversion would take more memory than is available
/// ([`lamina_input::check_memory`]), before anything is allocated: `raw_bytes` as read from
/// the file, `values` samples converted to 64-bit floats (8 bytes each; 0 for a colour
/// volume) and the texture of `texture_bytes`. `what` names the voxels in the message.
pub(crate) fn check_conversion_memory(
    path: &Path,
    what: &str,
    raw_bytes: u64,
    values: u64,
    texture_bytes: u64,
) -> Result<(), VolumeError> {
    let needed = values.checked_mul(8).and_then(|f| f.checked_add(raw_bytes)?.checked_add(texture_bytes));
    let request = if values > 0 {
        format!(
            "reading {what} ({}) and converting them to 64-bit floats ({})",
            bytes(raw_bytes),
            bytes(values.saturating_mul(8))
        )
    } else {
        format!("reading {what} ({})", bytes(raw_bytes))
    };
    lamina_input::check_memory(&request, needed.unwrap_or(u64::MAX))
        .map_err(|error| VolumeError::Memory { path: path.to_path_buf(), error })
}

fn bytes(n: u64) -> String {
    lamina_input::format_bytes(n)
}

/// `values` as 64-bit floats, allocated fallibly: a refusal, not an abort, when the memory is
/// not there.
pub(crate) fn try_to_f64<T: Copy>(
    path: &Path,
    values: impl ExactSizeIterator<Item = T>,
    f: impl Fn(T) -> f64,
) -> Result<Vec<f64>, VolumeError> {
    let mut out = Vec::new();
    out.try_reserve_exact(values.len()).map_err(|e| VolumeError::Io {
        path: path.to_path_buf(),
        message: format!("cannot allocate {} voxels as 64-bit floats: {e}", values.len()),
    })?;
    out.extend(values.map(f));
    Ok(out)
}

/// Grey levels (0 black, 255 white) of the voxel values of `path` through `window`
/// (`[lo, hi]`; `None`: the values' minimum and maximum). Refuses NaN and infinite values.
pub(crate) fn grey_levels(path: &Path, values: Vec<f64>, window: Option<[f64; 2]>) -> Result<Vec<u8>, VolumeError> {
    let non_finite = values.iter().filter(|v| !v.is_finite()).count();
    if non_finite > 0 {
        let first = values.iter().position(|v| !v.is_finite()).unwrap_or(0);
        return Err(VolumeError::NonFinite { path: path.to_path_buf(), count: non_finite, first });
    }
    let [lo, hi] = match window {
        Some([lo, hi]) => [lo, hi],
        None => values.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &v| [lo.min(v), hi.max(v)]),
    };
    let scale = if hi > lo { 255.0 / (hi - lo) } else { 0.0 };
    Ok(values.iter().map(|&v| ((v - lo) * scale).clamp(0.0, 255.0).round() as u8).collect())
}

fn nifti_error(path: &Path, e: nifti::NiftiError) -> VolumeError {
    match e {
        nifti::NiftiError::Io(io) => VolumeError::Io { path: path.to_path_buf(), message: io.to_string() },
        other => VolumeError::Header { path: path.to_path_buf(), message: other.to_string() },
    }
}

/// Reads and checks the header of a NIfTI-1 file (`.nii`, or `.nii.gz` gzip-compressed):
/// a regular file, at least three dimensions (a 4-D file gives its first volume), a voxel
/// type the viewer reads (8- to 64-bit integers, 32- and 64-bit floats, RGB24), a texture of
/// at most [`MAX_TEXTURE_BYTES`], voxels that start where the header and its extensions end
/// (`vox_offset`), and, after conversion to metres (the header's units: metres,
/// millimetres, micrometres; unknown: millimetres), spacings in [`SPACING_RANGE_M`] and an
/// origin within `f32`. The volume's axes are taken along the model's x, y and z: rotations
/// and flips in the header are not applied.
pub fn read_nifti_header(path: &Path) -> Result<VolumeGeometry, VolumeError> {
    nifti_header(path).map(|(geometry, _)| geometry)
}

/// The NIfTI-1 header of `path`, checked ([`read_nifti_header`]), and its geometry.
fn nifti_header(path: &Path) -> Result<(VolumeGeometry, nifti::NiftiHeader), VolumeError> {
    use nifti::NiftiType;
    drop(open_volume_file(path)?);
    let header = nifti::NiftiHeader::from_file(path).map_err(|e| nifti_error(path, e))?;
    let bad = |message: String| VolumeError::Header { path: path.to_path_buf(), message };
    let dim = header.dim().map_err(|e| bad(e.to_string()))?;
    if dim.len() < 3 || dim[..3].contains(&0) {
        return Err(bad(format!("needs three dimensions of at least one voxel, has {dim:?}")));
    }
    let dims = [dim[0], dim[1], dim[2]].map(u32::from);
    let format = match header.data_type().map_err(|e| bad(e.to_string()))? {
        NiftiType::Rgb24 | NiftiType::Rgba32 => VoxelFormat::Rgba,
        NiftiType::Uint8
        | NiftiType::Int8
        | NiftiType::Uint16
        | NiftiType::Int16
        | NiftiType::Uint32
        | NiftiType::Int32
        | NiftiType::Uint64
        | NiftiType::Int64
        | NiftiType::Float32
        | NiftiType::Float64 => VoxelFormat::Grey,
        other => return Err(bad(format!("voxel type {other:?} is not read (integers, floats or RGB24)"))),
    };
    let voxels = dims.iter().map(|&n| u64::from(n)).product::<u64>();
    let bytes = voxels * format.bytes() as u64;
    if bytes > MAX_TEXTURE_BYTES {
        return Err(VolumeError::TooLarge { path: path.to_path_buf(), dims: dims.map(u64::from), bytes });
    }
    check_vox_offset(path, &header)?;
    let unit_m = match header.xyzt_units & 0x07 {
        1 => 1.0,
        3 => 1.0e-6,
        _ => 1.0e-3,
    };
    let spacing = [1, 2, 3].map(|k| f64::from(header.pixdim[k]));
    let (origin, origin_field) = if header.sform_code > 0 {
        ([header.srow_x[3], header.srow_y[3], header.srow_z[3]], "srow_x/y/z[3] (sform offset)")
    } else if header.qform_code > 0 {
        ([header.quatern_x, header.quatern_y, header.quatern_z], "qoffset_x/y/z (qform offset)")
    } else {
        ([0.0; 3], "origin")
    };
    let geometry =
        checked_geometry(path, dims, (spacing, "pixdim[1..3]"), (origin.map(f64::from), origin_field), unit_m, format)?;
    Ok((geometry, header))
}

/// Largest run of NIfTI extensions read between the header and the voxels, bytes.
pub const MAX_NIFTI_EXTENSION_BYTES: u64 = 64 << 20;

/// Refuses a NIfTI-1 file whose `vox_offset` is not where its voxels are read from: the
/// end of the 348-byte header, the 4-byte extender and any extensions in a single `.nii`
/// file; byte 0 of the `.img` of a `.hdr`/`.img` pair (whose `.img` must be a regular file).
fn check_vox_offset(path: &Path, header: &nifti::NiftiHeader) -> Result<(), VolumeError> {
    let v = f64::from(header.vox_offset);
    let refuse =
        |bound: String| VolumeError::Field { path: path.to_path_buf(), field: "vox_offset", value: shown(v), bound };
    if &header.magic == b"ni1\0" {
        if v != 0.0 {
            return Err(refuse(
                "the voxels of a .hdr/.img pair are read from the start of the .img: it must be 0".into(),
            ));
        }
        let img = path.with_extension("img");
        let gz = path.with_extension("img.gz");
        drop(open_volume_file(if gz.exists() { &gz } else { &img })?);
        return Ok(());
    }
    let header_end = 352.0;
    if !(header_end..=header_end + MAX_NIFTI_EXTENSION_BYTES as f64).contains(&v) {
        return Err(refuse(format!(
            "the voxels start after the 352 bytes of header and extender, and at most {} bytes of extensions",
            MAX_NIFTI_EXTENSION_BYTES
        )));
    }
    let extensions = nifti_extension_bytes(path, header, v as u64 - 352)?;
    if v != header_end + extensions as f64 {
        let has =
            if extensions == 0 { "no extensions".to_string() } else { format!("{extensions} bytes of extensions") };
        return Err(refuse(format!(
            "the voxels are read from where the header ends, byte {} (352 bytes of header and extender, {has}); \
             voxels placed elsewhere are not read",
            352 + extensions
        )));
    }
    Ok(())
}

/// Bytes of extensions after the 352 bytes of header and extender of a single-file NIfTI-1
/// volume (`.nii`, or gzip-compressed), walked up to `within` bytes: each extension starts
/// with its size (a multiple of 16, at least 16) and code; the walk ends at the first size
/// that is not one.
fn nifti_extension_bytes(path: &Path, header: &nifti::NiftiHeader, within: u64) -> Result<u64, VolumeError> {
    use std::io::Read;
    let (file, _) = open_volume_file(path)?;
    let mut reader = std::io::BufReader::new(file);
    let gzip = {
        use std::io::BufRead;
        let head =
            reader.fill_buf().map_err(|e| VolumeError::Io { path: path.to_path_buf(), message: e.to_string() })?;
        head.starts_with(&[0x1f, 0x8b])
    };
    let mut source: Box<dyn Read> =
        if gzip { Box::new(flate2::bufread::MultiGzDecoder::new(reader)) } else { Box::new(reader) };
    let io = |e: std::io::Error| VolumeError::Io { path: path.to_path_buf(), message: e.to_string() };
    let mut head = [0u8; 352];
    source.read_exact(&mut head).map_err(io)?;
    if head[348] == 0 {
        return Ok(0);
    }
    let mut walked = 0u64;
    while walked < within {
        let mut word = [0u8; 8];
        source.read_exact(&mut word).map_err(io)?;
        let esize = match header.endianness {
            nifti::Endianness::Little => i32::from_le_bytes([word[0], word[1], word[2], word[3]]),
            nifti::Endianness::Big => i32::from_be_bytes([word[0], word[1], word[2], word[3]]),
        };
        if esize < 16 || esize % 16 != 0 {
            // Not an extension: the extensions end here, before `vox_offset`.
            break;
        }
        let rest = u64::from(esize.unsigned_abs()) - 8;
        let skipped = std::io::copy(&mut (&mut source).take(rest), &mut std::io::sink()).map_err(io)?;
        if skipped < rest {
            return Err(VolumeError::Io {
                path: path.to_path_buf(),
                message: format!("ends within its extension at byte {}", 352 + walked),
            });
        }
        walked += u64::from(esize.unsigned_abs());
    }
    Ok(walked)
}

/// Reads the volume of `spec` (see [`read_nifti_header`] for what is accepted): grey volumes
/// go through the intensity window (`spec.window`, default the data's minimum and maximum,
/// after the header's `scl_slope`/`scl_inter` scaling), RGB ones are kept as colours. The
/// first voxel's centre is at `spec.origin_m`, default the header's origin. The memory that
/// reading and converting takes is estimated from the header and refused, before anything is
/// allocated, when more than is available.
pub fn read_nifti(spec: &VolumeSpec) -> Result<VolumeImage, VolumeError> {
    use nifti::{NiftiObject, NiftiType, NiftiVolume, ReaderOptions};
    let path = spec.path.as_path();
    let (origin_m, window) = checked_placement(path, spec)?;
    let (geometry, header) = nifti_header(path)?;
    let all_voxels = header.dim().map_or(u64::MAX, |d| d.iter().map(|&n| u64::from(n)).product::<u64>());
    let sample_bytes = u64::from(header.bitpix.max(8) as u16 / 8);
    let count = geometry.dims.iter().map(|&n| n as usize).product::<usize>();
    let [x, y, z] = geometry.dims;
    let what = format!("{x}x{y}x{z} voxels of {:?}", header.data_type().unwrap_or(NiftiType::Uint8));
    let grey_values = if geometry.format == VoxelFormat::Grey { count as u64 } else { 0 };
    let texture = count as u64 * geometry.format.bytes() as u64;
    check_conversion_memory(path, &what, all_voxels.saturating_mul(sample_bytes), grey_values, texture)?;
    let object = ReaderOptions::new().read_file(path).map_err(|e| nifti_error(path, e))?;
    let (slope, inter) = (object.header().scl_slope, object.header().scl_inter);
    let volume = object.into_volume();
    let datatype = volume.data_type();
    let bad = |e: nifti::NiftiError| nifti_error(path, e);
    let data = match geometry.format {
        VoxelFormat::Rgba => {
            let raw = volume.into_raw_data();
            let stride = if datatype == NiftiType::Rgba32 { 4 } else { 3 };
            if raw.len() < count * stride {
                return Err(VolumeError::Header {
                    path: path.to_path_buf(),
                    message: format!("{} bytes of voxels, {} expected", raw.len(), count * stride),
                });
            }
            raw.chunks_exact(stride).take(count).flat_map(|c| [c[0], c[1], c[2], 255]).collect()
        }
        VoxelFormat::Grey => {
            fn as_f64<T: Copy + Into<f64>>(path: &Path, v: Vec<T>, count: usize) -> Result<Vec<f64>, VolumeError> {
                try_to_f64(path, v.into_iter().take(count), Into::into)
            }
            let mut values: Vec<f64> = match datatype {
                NiftiType::Uint8 => as_f64(path, volume.into_nifti_typed_data::<u8>().map_err(bad)?, count)?,
                NiftiType::Int8 => as_f64(path, volume.into_nifti_typed_data::<i8>().map_err(bad)?, count)?,
                NiftiType::Uint16 => as_f64(path, volume.into_nifti_typed_data::<u16>().map_err(bad)?, count)?,
                NiftiType::Int16 => as_f64(path, volume.into_nifti_typed_data::<i16>().map_err(bad)?, count)?,
                NiftiType::Uint32 => as_f64(path, volume.into_nifti_typed_data::<u32>().map_err(bad)?, count)?,
                NiftiType::Int32 => as_f64(path, volume.into_nifti_typed_data::<i32>().map_err(bad)?, count)?,
                NiftiType::Uint64 => {
                    let v = volume.into_nifti_typed_data::<u64>().map_err(bad)?;
                    try_to_f64(path, v.into_iter().take(count), |v| v as f64)?
                }
                NiftiType::Int64 => {
                    let v = volume.into_nifti_typed_data::<i64>().map_err(bad)?;
                    try_to_f64(path, v.into_iter().take(count), |v| v as f64)?
                }
                NiftiType::Float32 => as_f64(path, volume.into_nifti_typed_data::<f32>().map_err(bad)?, count)?,
                _ => {
                    let mut v = volume.into_nifti_typed_data::<f64>().map_err(bad)?;
                    v.truncate(count);
                    v
                }
            };
            if values.len() < count {
                return Err(VolumeError::Header {
                    path: path.to_path_buf(),
                    message: format!("{} voxels in the file, {count} expected", values.len()),
                });
            }
            if slope != 0.0 && slope.is_finite() && inter.is_finite() {
                let (slope, inter) = (f64::from(slope), f64::from(inter));
                values.iter_mut().for_each(|v| *v = *v * slope + inter);
            }
            grey_levels(path, values, window)?
        }
    };
    Ok(geometry.image(data, origin_m))
}

/// A source that gives every model it passes on the volume `spec` (`lamina-viewer --volume`).
#[derive(Debug)]
pub struct WithVolume<S> {
    inner: S,
    spec: VolumeSpec,
}

impl<S> WithVolume<S> {
    /// Wraps `inner`.
    pub fn new(inner: S, spec: VolumeSpec) -> Self {
        Self { inner, spec }
    }
}

impl<S: FrameSource + ?Sized> FrameSource for WithVolume<Box<S>> {
    fn next_event(&mut self, timeout: Duration) -> SourceEvent {
        match self.inner.next_event(timeout) {
            SourceEvent::Model(mut model) => {
                model.volume = Some(self.spec.clone());
                SourceEvent::Model(model)
            }
            other => other,
        }
    }

    fn describe(&self) -> String {
        format!("{}, volume {}", self.inner.describe(), self.spec.path.display())
    }
}

// ---------------------------------------------------------------------------------------------
// The procedural volume.

/// The tissue classes the procedural volume paints (the tissues, and the marrow inside bone).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Class {
    Tissue(Tissue),
    Marrow,
}

/// The rest samples whose nearest one gives a voxel its tissue: with nested closed boundary
/// grids (a limb), points between each pair of boundaries at the same grid point (the tissue
/// beneath the outer one) and inside the innermost toward each row's centre (bone, marrow at
/// its core), plus the outer skin's nodes; otherwise every node with its tissue.
fn tissue_samples(model: &ViewModel, rest: &[Vec3], spacing: f32) -> Vec<(Vec3, Class)> {
    let mut out = Vec::new();
    let nested: Vec<usize> = match model.grids.first() {
        Some(outer) if outer.wrap => (0..model.grids.len())
            .filter(|&g| model.grids[g].wrap && model.grids[g].cols == outer.cols && model.grids[g].rows == outer.rows)
            .collect(),
        _ => Vec::new(),
    };
    if nested.len() >= 2 {
        // Each grid cell is sampled at su × sv points (bilinear between its corners) and each
        // band at nd depths, so that samples are at most about `spacing` apart.
        let (cols, rows) = (model.grids[0].cols, model.grids[0].rows);
        let at = |g: usize, c: usize, r: usize, u: f32, v: f32| {
            let grid = &model.grids[g];
            let p = |c: usize, r: usize| rest[grid.nodes[r.min(rows - 1) * cols + c % cols] as usize];
            p(c, r).lerp(p(c + 1, r), u).lerp(p(c, r + 1).lerp(p(c + 1, r + 1), u), v)
        };
        let cells = || (0..rows).flat_map(|r| (0..cols).map(move |c| (c, r)));
        let longest = |d: (usize, usize)| {
            cells().map(|(c, r)| at(0, c, r, 0.0, 0.0).distance(at(0, c + d.0, r + d.1, 0.0, 0.0))).fold(0.0, f32::max)
        };
        let count = |length: f32, lo: usize| ((length / spacing).ceil() as usize).clamp(lo, 16);
        let (su, sv) = (count(longest((1, 0)), 2), count(longest((0, 1)), 2));
        let mut lattice = Vec::with_capacity(cols * rows * su * sv);
        for (c, r) in cells() {
            for (i, j) in (0..su).flat_map(|i| (0..sv).map(move |j| (i, j))) {
                if r + 1 < rows || j == 0 {
                    lattice.push((c, r, i as f32 / su as f32, j as f32 / sv as f32));
                }
            }
        }
        let depths = |n: usize, lo: f32, hi: f32| (0..n).map(move |k| lo + (hi - lo) * (k as f32 + 0.5) / n as f32);
        out.extend(lattice.iter().map(|&(c, r, u, v)| (at(0, c, r, u, v), Class::Tissue(Tissue::Skin))));
        for pair in nested.windows(2) {
            let tissue = if pair[0] == 0 { Tissue::Skin } else { model.grids[pair[0]].beneath };
            let thickness = cells().map(|(c, r)| at(pair[0], c, r, 0.0, 0.0).distance(at(pair[1], c, r, 0.0, 0.0)));
            let nd = count(thickness.fold(0.0, f32::max), 3);
            for &(c, r, u, v) in &lattice {
                let (pa, pb) = (at(pair[0], c, r, u, v), at(pair[1], c, r, u, v));
                out.extend(depths(nd, 0.0, 1.0).map(|t| (pa.lerp(pb, t), Class::Tissue(tissue))));
            }
        }
        let last = *nested.last().unwrap_or(&0);
        let inner = &model.grids[last];
        let centres: Vec<Vec3> =
            (0..rows).map(|r| (0..cols).map(|c| at(last, c, r, 0.0, 0.0)).sum::<Vec3>() / cols as f32).collect();
        let radius = cells().map(|(c, r)| at(last, c, r, 0.0, 0.0).distance(centres[r])).fold(0.0, f32::max);
        let nd = count(radius, 4);
        for &(c, r, u, v) in &lattice {
            let centre = centres[r].lerp(centres[(r + 1).min(rows - 1)], v);
            let p = at(last, c, r, u, v);
            out.push((centre, Class::Marrow));
            for t in depths(nd, 0.0, 1.0) {
                let class = if t < 0.55 { Class::Marrow } else { Class::Tissue(inner.beneath) };
                out.push((centre.lerp(p, t), class));
            }
        }
        return out;
    }
    let mut tissue = model.node_tissue.clone();
    if tissue.len() < model.node_count {
        tissue.resize(model.node_count, Tissue::Other);
        for (g, grid) in model.grids.iter().enumerate().rev() {
            let t = if g == 0 { Tissue::Skin } else { grid.beneath };
            grid.nodes.iter().for_each(|&i| tissue[i as usize] = t);
        }
        for s in &model.triangle_surfaces {
            s.triangles.iter().flatten().for_each(|&i| tissue[i as usize] = s.tissue);
        }
    }
    out.extend(rest.iter().zip(&tissue).map(|(&p, &t)| (p, Class::Tissue(t))));
    // Five points along each spring carry its layer's tissue: a layer may have springs and no nodes
    // of its own (the generator's muscle joins the fat/muscle boundary to the bone), and its
    // band would otherwise take the tissue of the nodes on either side.
    for (&[a, b], &t) in model.springs.iter().zip(&model.spring_tissue) {
        if let (Some(&pa), Some(&pb)) = (rest.get(a as usize), rest.get(b as usize))
            && t != Tissue::Other
        {
            out.extend([0.1f32, 0.3, 0.5, 0.7, 0.9].map(|k| (pa.lerp(pb, k), Class::Tissue(t))));
        }
    }
    // Inside an innermost closed grid with bone beneath (a limb whose grids do not pair up):
    // bone toward its axis, marrow at its core, rows interpolated so every ring between two
    // grid rows is filled.
    if let Some(inner) = model.grids.last().filter(|g| g.wrap && g.beneath == Tissue::Bone && g.rows >= 2) {
        let point = |c: usize, r: usize| rest.get(inner.nodes[r * inner.cols + c % inner.cols] as usize).copied();
        for r in 0..inner.rows - 1 {
            for v in [0.0, 0.25, 0.5, 0.75] {
                let ring: Option<Vec<Vec3>> =
                    (0..inner.cols).map(|c| Some(point(c, r)?.lerp(point(c, r + 1)?, v))).collect();
                let Some(ring) = ring else { continue };
                let centre = ring.iter().copied().sum::<Vec3>() / ring.len() as f32;
                out.push((centre, Class::Marrow));
                for p in &ring {
                    out.extend([0.25f32, 0.5, 0.75, 0.9, 1.0].map(|t| {
                        (centre.lerp(*p, t), if t < 0.55 { Class::Marrow } else { Class::Tissue(Tissue::Bone) })
                    }));
                }
            }
        }
    }
    out
}

/// A 32-bit hash of a lattice point.
fn hash(x: i32, y: i32, z: i32, seed: u32) -> u32 {
    let mut h = seed
        ^ (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 16;
    h = h.wrapping_mul(0x7feb_352d);
    h ^= h >> 15;
    h = h.wrapping_mul(0x846c_a68b);
    h ^ (h >> 16)
}

fn unit(h: u32) -> f32 {
    (h >> 8) as f32 / (1u32 << 24) as f32
}

/// Smooth value noise in `0..1` at `p` (lattice spacing 1).
fn value_noise(p: Vec3, seed: u32) -> f32 {
    let f = p.floor();
    let t = p - f;
    let s = t * t * (Vec3::splat(3.0) - 2.0 * t);
    let (x, y, z) = (f.x as i32, f.y as i32, f.z as i32);
    let v = |dx, dy, dz| unit(hash(x + dx, y + dy, z + dz, seed));
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(v(0, 0, 0), v(1, 0, 0), s.x);
    let x10 = lerp(v(0, 1, 0), v(1, 1, 0), s.x);
    let x01 = lerp(v(0, 0, 1), v(1, 0, 1), s.x);
    let x11 = lerp(v(0, 1, 1), v(1, 1, 1), s.x);
    lerp(lerp(x00, x10, s.y), lerp(x01, x11, s.y), s.z)
}

/// Cellular (Worley) noise at `p` (one feature point per unit cell): distances to the nearest
/// and second nearest feature points.
fn worley(p: Vec3, seed: u32) -> (f32, f32) {
    let f = p.floor();
    let (mut d1, mut d2) = (f32::INFINITY, f32::INFINITY);
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let c = f + Vec3::new(dx as f32, dy as f32, dz as f32);
                let (x, y, z) = (c.x as i32, c.y as i32, c.z as i32);
                // One hash gives the feature point's three coordinates (10 bits each).
                let h = hash(x, y, z, seed);
                let bits = Vec3::new((h & 1023) as f32, ((h >> 10) & 1023) as f32, ((h >> 20) & 1023) as f32);
                let q = c + bits / 1024.0;
                let d = q.distance(p);
                if d < d1 {
                    (d1, d2) = (d, d1);
                } else if d < d2 {
                    d2 = d;
                }
            }
        }
    }
    (d1, d2)
}

/// The procedural colour (sRGB, `0..1`) of `class` at `p` (metres, rest frame); `axis` is the
/// limb's long axis (the muscle fibres run along it).
fn tissue_colour(class: Class, p: Vec3, axis: Vec3, seed: u32) -> [f32; 3] {
    let base = |t: Tissue| Vec3::from_array(Material::of(t).srgb);
    let c = match class {
        Class::Tissue(Tissue::Skin) => {
            // Fine speckle (0.4 mm) and sparse darker pigment spots.
            let speckle = value_noise(p / 0.0004, seed) - 0.5;
            let spots = value_noise(p / 0.0015, seed ^ 1);
            let dark = if spots > 0.78 { 0.82 } else { 1.0 };
            base(Tissue::Skin) * (1.0 + 0.16 * speckle) * dark
        }
        Class::Tissue(Tissue::Fat) => {
            // Lobules ~5 mm across: yellow inside, pale pink septa along the cell borders.
            let (f1, f2) = worley(p / 0.005, seed ^ 2);
            let edge = ((f2 - f1) / 0.12).clamp(0.0, 1.0);
            let inside = base(Tissue::Fat) * (0.92 + 0.12 * value_noise(p / 0.001, seed ^ 3));
            Vec3::new(0.93, 0.72, 0.62).lerp(inside, edge)
        }
        Class::Tissue(Tissue::Muscle) => {
            // Fibres: noise stretched 30× along the axis (0.5 mm across, 15 mm along).
            let along = p.dot(axis) * axis;
            let across = p - along;
            let q = across / 0.0005 + along / 0.015;
            let fibre = value_noise(q, seed ^ 4);
            let bundle = value_noise(across / 0.003 + along / 0.05, seed ^ 5);
            base(Tissue::Muscle) * (0.72 + 0.45 * fibre) * (0.9 + 0.2 * bundle)
        }
        Class::Tissue(Tissue::Bone) => {
            // Compact ivory with fine trabecular pores.
            let (f1, _) = worley(p / 0.0012, seed ^ 6);
            let pore = if f1 < 0.22 { 0.78 } else { 1.0 };
            base(Tissue::Bone) * pore * (0.95 + 0.08 * value_noise(p / 0.0005, seed ^ 7))
        }
        Class::Marrow => {
            // Spongy bone: a trabecular lattice (ivory struts) over red-brown marrow.
            let (f1, f2) = worley(p / 0.0018, seed ^ 8);
            let strut = ((f2 - f1) < 0.08) as u8 as f32;
            Vec3::from_array(Material::marrow().srgb).lerp(base(Tissue::Bone), strut * 0.7)
        }
        Class::Tissue(Tissue::Other) => base(Tissue::Other),
    };
    c.clamp(Vec3::ZERO, Vec3::ONE).to_array()
}

/// Bakes the procedural volume of `model` at rest positions `rest` (one per node): about
/// `voxels` cubic voxels over the rest bounding box (padded by one voxel and 2 %), each
/// coloured by the texture of its tissue (see the module docs). Deterministic: the noise is
/// seeded with [`PROCEDURAL_SEED`]. Work is split over up to `threads` threads.
///
/// Returns `None` if `rest` is empty or not finite.
pub fn bake_procedural(model: &ViewModel, rest: &[Vec3], voxels: u64, threads: usize) -> Option<VolumeImage> {
    let (min, max) = rest.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    if rest.is_empty() || !min.is_finite() || !max.is_finite() {
        return None;
    }
    let extent = (max - min).max(Vec3::splat(1e-4));
    let voxel = (extent.x * extent.y * extent.z / voxels.max(1) as f32).cbrt();
    // Samples about two bins apart (bins of 4 voxels, below): dense enough for the bands,
    // sparse enough to bake in well under a second.
    let bin = voxel * 4.0;
    let samples = tissue_samples(model, rest, 2.0 * bin);
    let pad = Vec3::splat(voxel) + extent * 0.02;
    let (box_min, box_size) = (min - pad, extent + 2.0 * pad);
    let size = (box_size / voxel).ceil().as_uvec3().clamp(glam::UVec3::ONE, glam::UVec3::splat(1024)).to_array();
    let box_size = Vec3::new(size[0] as f32, size[1] as f32, size[2] as f32) * voxel;
    // Longest axis of the rest box: the limb's.
    let axis = match extent.max_position() {
        0 => Vec3::X,
        1 => Vec3::Y,
        _ => Vec3::Z,
    };
    // Uniform bins of 4 voxels. Each bin lists the samples of its 3 × 3 × 3 neighbourhood
    // (wider where that holds none) that can be the nearest for some point in it (nearest possible distance to the bin no
    // more than the smallest farthest distance): a voxel checks those alone. A bin with no
    // sample around is outside the tissue.
    let bins = (box_size / bin).ceil().as_ivec3().max(glam::IVec3::ONE);
    let bin_of = |p: Vec3| ((p - box_min) / bin).floor().as_ivec3().clamp(glam::IVec3::ZERO, bins - 1);
    let flat = |b: glam::IVec3| (b.x + bins.x * (b.y + bins.y * b.z)) as usize;
    let bin_count = (bins.x * bins.y * bins.z) as usize;
    let mut in_bin: Vec<Vec<u32>> = vec![Vec::new(); bin_count];
    for (k, s) in samples.iter().enumerate() {
        in_bin[flat(bin_of(s.0))].push(k as u32);
    }
    let mut candidates: Vec<Vec<u32>> = vec![Vec::new(); bin_count];
    for z in 0..bins.z {
        for y in 0..bins.y {
            for x in 0..bins.x {
                let b = glam::IVec3::new(x, y, z);
                let lo = box_min + b.as_vec3() * bin;
                let hi = lo + Vec3::splat(bin);
                let around = |reach: i32| -> Vec<u32> {
                    (-reach..=reach)
                        .flat_map(|dz| {
                            (-reach..=reach)
                                .flat_map(move |dy| (-reach..=reach).map(move |dx| b + glam::IVec3::new(dx, dy, dz)))
                        })
                        .filter(|n| n.cmpge(glam::IVec3::ZERO).all() && n.cmplt(bins).all())
                        .flat_map(|n| in_bin[flat(n)].iter().copied())
                        .collect()
                };
                // Sparse samples (a coarse grid): widen the neighbourhood until it holds some,
                // then by one more bin, up to 3 bins away; beyond that the voxel is outside.
                let mut near = around(1);
                let mut reach = 1;
                while near.is_empty() && reach < 3 {
                    reach += 1;
                    near = around(reach);
                }
                if reach > 1 && !near.is_empty() {
                    near = around(reach + 1);
                }
                let min_d = |p: Vec3| (p.clamp(lo, hi) - p).length();
                let max_d = |p: Vec3| (p - (lo + hi) * 0.5).abs().add(Vec3::splat(bin * 0.5)).length();
                let bound = near.iter().map(|&k| max_d(samples[k as usize].0)).fold(f32::INFINITY, f32::min);
                candidates[flat(b)] = near.into_iter().filter(|&k| min_d(samples[k as usize].0) <= bound).collect();
            }
        }
    }
    let nearest = |p: Vec3| -> Option<Class> {
        let mut best: Option<(f32, Class)> = None;
        for &k in &candidates[flat(bin_of(p))] {
            let (q, class) = samples[k as usize];
            let d2 = q.distance_squared(p);
            if best.is_none_or(|(b2, _)| d2 < b2) {
                best = Some((d2, class));
            }
        }
        best.map(|b| b.1)
    };
    let (nx, ny, nz) = (size[0] as usize, size[1] as usize, size[2] as usize);
    let mut data = vec![0u8; nx * ny * nz * 4];
    let threads = threads.clamp(1, 16);
    let slab = nz.div_ceil(threads) * nx * ny * 4;
    std::thread::scope(|scope| {
        for (t, chunk) in data.chunks_mut(slab.max(4)).enumerate() {
            let z0 = t * nz.div_ceil(threads);
            let nearest = &nearest;
            scope.spawn(move || {
                for (i, texel) in chunk.chunks_exact_mut(4).enumerate() {
                    let (x, y, z) = (i % nx, (i / nx) % ny, z0 + i / (nx * ny));
                    let p = box_min + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * voxel;
                    let rgba = match nearest(p) {
                        Some(class) => {
                            let [r, g, b] = tissue_colour(class, p, axis, PROCEDURAL_SEED);
                            [r, g, b].map(|c| (c * 255.0).round() as u8)
                        }
                        None => [40, 40, 44],
                    };
                    texel.copy_from_slice(&[rgba[0], rgba[1], rgba[2], 255]);
                }
            });
        }
    });
    Some(VolumeImage::new(size, VoxelFormat::Rgba, data, box_min, box_size))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::SyntheticLimb;

    fn limb_rest() -> (ViewModel, Vec<Vec3>) {
        let limb = SyntheticLimb { indent_depth: 0.0, ..SyntheticLimb::default() };
        (limb.view_model(), limb.frame(0, 0.0).positions)
    }

    #[test]
    fn procedural_volume_is_deterministic_and_fills_the_rest_box_works() {
        let (model, rest) = limb_rest();
        let a = bake_procedural(&model, &rest, 48 * 48 * 48, 2).unwrap();
        let b = bake_procedural(&model, &rest, 48 * 48 * 48, 1).unwrap();
        assert_eq!((a.size, &a.data), (b.size, &b.data), "same volume whatever the thread count");
        assert_ne!(a.id(), b.id());
        for p in &rest {
            let tc = a.texcoord(*p);
            assert!(tc.cmpgt(Vec3::ZERO).all() && tc.cmplt(Vec3::ONE).all(), "{p} outside the box");
        }
        // About the voxels asked for, more by the padding (a voxel and 2 % on every side).
        let voxels = a.size.iter().product::<u32>();
        assert!((48 * 48 * 48..=48 * 48 * 72).contains(&voxels), "{:?}", a.size);
    }

    #[test]
    fn procedural_tissues_follow_the_layers_works() {
        // Along a radius at mid-length: skin colours at the outer skin, then fat, muscle and
        // bone toward the axis (each judged by its hue: skin/fat/bone light, muscle red).
        let (model, rest) = limb_rest();
        let v = bake_procedural(&model, &rest, 96 * 96 * 96, 2).unwrap();
        let limb = SyntheticLimb::default();
        let at = |k: usize, c: usize| rest[limb.node(k, c, limb.rows / 2) as usize];
        let axis = (0..limb.columns).map(|c| at(3, c)).sum::<Vec3>() / limb.columns as f32;
        let fat_point = at(1, 0).lerp(at(2, 0), 0.5);
        let muscle_point = at(2, 0).lerp(at(3, 0), 0.5);
        let bone_point = axis.lerp(at(3, 0), 0.8);
        let fat = v.voxel_at(v.texcoord(fat_point));
        let muscle = v.voxel_at(v.texcoord(muscle_point));
        let bone = v.voxel_at(v.texcoord(bone_point));
        let red = |c: [u8; 4]| c[0] as f32 - c[1] as f32;
        assert!(red(muscle) > 90.0, "muscle {muscle:?}");
        assert!(red(fat) < 90.0 && fat[2] < fat[1], "fat {fat:?} is yellow");
        assert!(red(bone) < 40.0 && bone[2] > 150, "bone {bone:?} is ivory");
    }

    #[test]
    fn procedural_tissues_of_the_default_limb_show_its_muscle_works() {
        // The core's default limb (radii 50 / 48 / 40 / 15 mm, axis +z, y up): its muscle layer
        // has springs but no nodes, and its grids differ in row count. Straight up from the axis
        // at mid-length, between two rings of grid nodes: 44 mm is fat, 27.5 mm (mid-muscle)
        // muscle, 11 mm bone (its marrow core is inside 8 mm).
        let model = lamina_core::scene::Scene::builtin_default().build_model().unwrap();
        let view = ViewModel::from_core_model(&model);
        let v = bake_procedural(&view, &view.rest_positions, 96 * 96 * 96, 2).unwrap();
        let at = |radius_m: f32| v.voxel_at(v.texcoord(Vec3::new(0.0, radius_m, 0.12)));
        let red = |c: [u8; 4]| c[0] as f32 - c[1] as f32;
        let (fat, muscle, bone) = (at(0.044), at(0.0275), at(0.011));
        assert!(red(muscle) > 90.0, "muscle {muscle:?}");
        assert!(red(fat) < 90.0 && fat[2] < fat[1], "fat {fat:?} is yellow");
        assert!(red(bone) < 40.0 && bone[2] > 150, "bone {bone:?} is ivory");
    }

    #[test]
    fn fitted_volume_keeps_its_box_works() {
        let data = (0..4 * 6 * 2).map(|i| i as u8).collect();
        let v = VolumeImage::new([4, 6, 2], VoxelFormat::Grey, data, Vec3::ZERO, Vec3::ONE);
        assert!(v.fitted(8).is_none());
        let f = v.fitted(3).unwrap();
        assert_eq!(f.size, [2, 3, 2], "x and y halved, z already fits");
        assert_eq!((f.box_min, f.box_size), (v.box_min, v.box_size));
        assert_eq!(f.data[1], 2, "every second voxel along x");
    }
}
