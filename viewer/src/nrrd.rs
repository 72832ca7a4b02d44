//! NRRD volumes, the format 3D Slicer and teem write: a text header, then the voxels in the
//! same file (`.nrrd`) or in a file the header names (`.nhdr` with `data file:`).
//!
//! Read: NRRD0001 to NRRD0005; 8- to 64-bit integer and 32- and 64-bit float samples in
//! `raw`, `gzip` or `ascii` encoding, either byte order; three spatial axes, plus at most one
//! more: a colour axis first (3 or 4 unsigned bytes per voxel, drawn in its colours) or a
//! list or time axis last (its first volume is drawn). Spacing comes from `space directions`
//! (each axis's vector length) or `spacings`, the first voxel's centre from `space origin`,
//! lengths in `space units` (`m`, `cm`, `mm`, `um`; none given: millimetres). As with NIfTI,
//! the volume's axes are taken along the model's x, y and z: rotations and flips in the
//! directions are not applied. Not read: `hex` and `bzip2` encodings, `block` samples,
//! data split over several files.
//!
//! Format: <https://teem.sourceforge.net/nrrd/format.html>.

use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use crate::view_model::VolumeSpec;
use crate::volume::{
    MAX_TEXTURE_BYTES, VolumeError, VolumeGeometry, VolumeImage, VoxelFormat, check_conversion_memory,
    checked_geometry, checked_placement, grey_levels, open_volume_file, try_to_f64,
};

/// Longest header accepted, bytes: a header is a few hundred bytes; this bounds a file that
/// starts like NRRD and never ends its header.
const MAX_HEADER_BYTES: u64 = 1 << 20;

/// The type of one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Sample {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Sample {
    /// The sample type a `type:` field names (teem's spellings).
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "signed char" | "int8" | "int8_t" => Self::I8,
            "uchar" | "unsigned char" | "uint8" | "uint8_t" => Self::U8,
            "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => Self::I16,
            "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => Self::U16,
            "int" | "signed int" | "int32" | "int32_t" => Self::I32,
            "uint" | "unsigned int" | "uint32" | "uint32_t" => Self::U32,
            "longlong"
            | "long long"
            | "long long int"
            | "signed long long"
            | "signed long long int"
            | "int64"
            | "int64_t" => Self::I64,
            "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => Self::U64,
            "float" => Self::F32,
            "double" => Self::F64,
            _ => return None,
        })
    }

    /// Bytes per sample.
    fn bytes(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::I64 | Self::U64 | Self::F64 => 8,
        }
    }

    /// The value of one sample stored in `b` (`bytes()` long) in the given byte order.
    fn value(self, b: &[u8], big_endian: bool) -> f64 {
        macro_rules! read {
            ($t:ty) => {{
                let a = b.try_into().unwrap_or_default();
                (if big_endian { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f64
            }};
        }
        match self {
            Self::I8 => f64::from(b[0] as i8),
            Self::U8 => f64::from(b[0]),
            Self::I16 => read!(i16),
            Self::U16 => read!(u16),
            Self::I32 => read!(i32),
            Self::U32 => read!(u32),
            Self::I64 => read!(i64),
            Self::U64 => read!(u64),
            Self::F32 => read!(f32),
            Self::F64 => read!(f64),
        }
    }
}

/// How the samples are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Encoding {
    Raw,
    Gzip,
    Ascii,
}

/// What role the one axis beside the three spatial ones plays.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ExtraAxis {
    /// None: a scalar volume.
    None,
    /// First and fastest: the components of a colour (3 or 4).
    Colour(usize),
    /// Last and slowest: volumes one after another (list, time); the first is read.
    Volumes,
}

/// Everything the header says that reading the voxels needs.
#[derive(Debug, Clone, PartialEq)]
struct Header {
    geometry: VolumeGeometry,
    sample: Sample,
    encoding: Encoding,
    big_endian: bool,
    extra: ExtraAxis,
    /// Samples in the whole data (every axis), and in what is read (the first volume).
    total_samples: u64,
    read_samples: u64,
    /// The file holding the samples and where in it they start (after the header of an
    /// attached `.nrrd`, 0 in a detached data file).
    data_file: PathBuf,
    data_offset: u64,
    line_skip: u64,
    /// Bytes skipped after the line skip (decoded bytes under gzip); -1: the data end the file.
    byte_skip: i64,
}

/// The header's fields, as written (the field name in lower case), each with its line.
#[derive(Debug, Default)]
struct Fields {
    entries: Vec<(usize, String, String)>,
}

impl Fields {
    fn get(&self, name: &str) -> Option<(usize, &str)> {
        self.entries.iter().rev().find(|(_, n, _)| n == name).map(|(line, _, v)| (*line, v.as_str()))
    }
}

/// A header error on `line` (1-based) of `path`.
fn at(path: &Path, line: usize, message: impl Into<String>) -> VolumeError {
    VolumeError::NrrdHeader { path: path.to_path_buf(), line, message: message.into() }
}

/// A problem with the voxels of `path` (the header's data file).
fn data_error(path: &Path, message: impl Into<String>) -> VolumeError {
    VolumeError::NrrdData { path: path.to_path_buf(), message: message.into() }
}

fn io_error(path: &Path, e: &std::io::Error) -> VolumeError {
    VolumeError::Io { path: path.to_path_buf(), message: e.to_string() }
}

/// Reads the header lines up to the blank line (attached data) or the end of the file: the
/// fields, the number of the header's last line, and the byte offset just past the header.
fn read_fields(path: &Path) -> Result<(Fields, usize, u64), VolumeError> {
    let (file, _) = open_volume_file(path)?;
    let mut reader = BufReader::new(file).take(MAX_HEADER_BYTES);
    let mut fields = Fields::default();
    let (mut line_no, mut offset) = (0usize, 0u64);
    let mut raw = Vec::new();
    loop {
        raw.clear();
        let n = reader.read_until(b'\n', &mut raw).map_err(|e| io_error(path, &e))?;
        if n == 0 {
            if line_no == 0 {
                return Err(at(path, 1, "empty file: expected NRRD000N on the first line"));
            }
            break;
        }
        line_no += 1;
        offset += n as u64;
        if offset >= MAX_HEADER_BYTES {
            return Err(at(path, line_no, format!("no end of the header within {MAX_HEADER_BYTES} bytes")));
        }
        let text = std::str::from_utf8(&raw)
            .map_err(|_| at(path, line_no, "not text: the header is lines of ASCII"))?
            .trim_end_matches(['\n', '\r']);
        if line_no == 1 {
            let version = text.strip_prefix("NRRD000").and_then(|v| v.parse::<u8>().ok());
            if !matches!(version, Some(1..=5)) {
                return Err(at(path, 1, format!("expected NRRD0001 to NRRD0005, found {:?}", truncated(text))));
            }
            continue;
        }
        if text.is_empty() {
            line_no -= 1; // the blank line ends the header, it is not one of its lines
            break;
        }
        if text.starts_with('#') || text.contains(":=") {
            continue; // a comment, or a key/value pair for other programs
        }
        let Some((name, value)) = text.split_once(": ") else {
            return Err(at(path, line_no, format!("expected \"field: value\", found {:?}", truncated(text))));
        };
        fields.entries.push((line_no, name.trim().to_ascii_lowercase(), value.trim().to_string()));
    }
    Ok((fields, line_no, offset))
}

fn truncated(text: &str) -> String {
    text.chars().take(60).collect()
}

/// The `(x,y,z)` vectors of a `space directions` or `space origin` value; `None` for `none`.
fn vectors(value: &str) -> Result<Vec<Option<[f64; 3]>>, String> {
    value
        .split_whitespace()
        .map(|item| {
            if item == "none" {
                return Ok(None);
            }
            let inner = item.strip_prefix('(').and_then(|s| s.strip_suffix(')'));
            let parts: Vec<f64> = inner
                .ok_or_else(|| format!("expected (x,y,z) or none, found {item:?}"))?
                .split(',')
                .map(|c| c.trim().parse::<f64>().map_err(|_| format!("{c:?} in {item:?} is not a number")))
                .collect::<Result<_, _>>()?;
            let v: [f64; 3] =
                parts.try_into().map_err(|_| format!("{item:?}: three components expected (a 3-D space)"))?;
            if v.iter().all(|c| c.is_finite()) { Ok(Some(v)) } else { Err(format!("{item:?} is not finite")) }
        })
        .collect()
}

/// The length of `v`, scaled so that neither tiny nor huge components underflow or
/// overflow on the way (a direction of `1e-300` is `1e-300` long, not 0).
fn length(v: [f64; 3]) -> f64 {
    let scale = v.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return scale;
    }
    scale * v.iter().map(|c| (c / scale).powi(2)).sum::<f64>().sqrt()
}

/// Metres per unit of a `space units` entry.
fn unit_m(unit: &str) -> Option<f64> {
    Some(match unit {
        "m" => 1.0,
        "cm" => 1e-2,
        "mm" => 1e-3,
        "um" | "µm" | "micron" => 1e-6,
        _ => return None,
    })
}

/// Reads and checks a NRRD header (see the module's documentation for what is read), and
/// that the texture would take at most [`MAX_TEXTURE_BYTES`].
pub fn read_nrrd_header(path: &Path) -> Result<VolumeGeometry, VolumeError> {
    read_header(path).map(|h| h.geometry)
}

fn read_header(path: &Path) -> Result<Header, VolumeError> {
    let (fields, lines, header_end) = read_fields(path)?;
    let required = |name: &str| fields.get(name).ok_or_else(|| at(path, lines, format!("no \"{name}:\" field")));

    let (line, type_name) = required("type")?;
    let sample = Sample::parse(type_name).ok_or_else(|| {
        at(path, line, format!("type {type_name:?} is not read (8- to 64-bit integers, float or double)"))
    })?;

    let (line, value) = required("dimension")?;
    let dimension: usize = value.parse().map_err(|_| at(path, line, format!("dimension {value:?} is not a number")))?;
    if !(3..=4).contains(&dimension) {
        return Err(at(
            path,
            line,
            format!("dimension {dimension}: three spatial axes expected, and at most one more"),
        ));
    }
    let per_axis = |name: &str, line: usize, n: usize| {
        if n == dimension { Ok(()) } else { Err(at(path, line, format!("{name}: {n} entries for {dimension} axes"))) }
    };

    let (sizes_line, value) = required("sizes")?;
    let sizes: Vec<u64> = value
        .split_whitespace()
        .map(|s| s.parse::<u64>().ok().filter(|&n| n > 0))
        .collect::<Option<_>>()
        .ok_or_else(|| at(path, sizes_line, format!("sizes {value:?}: whole numbers of at least 1 expected")))?;
    per_axis("sizes", sizes_line, sizes.len())?;

    let (line, value) = required("encoding")?;
    let encoding = match value {
        "raw" => Encoding::Raw,
        "gz" | "gzip" => Encoding::Gzip,
        "txt" | "text" | "ascii" => Encoding::Ascii,
        other => return Err(at(path, line, format!("encoding {other:?} is not read (raw, gzip or ascii)"))),
    };
    let big_endian = match fields.get("endian") {
        Some((_, "big")) => true,
        Some((_, "little")) => false,
        Some((line, other)) => return Err(at(path, line, format!("endian {other:?}: little or big expected"))),
        None if sample.bytes() > 1 && encoding != Encoding::Ascii => {
            return Err(at(path, lines, format!("no \"endian:\" field, needed for {}-byte samples", sample.bytes())));
        }
        None => false,
    };

    // Which axes are spatial: by their kinds, else by their space directions (`none` for a
    // non-spatial one), else all of them.
    let directions = match fields.get("space directions") {
        Some((line, value)) => {
            let v = vectors(value).map_err(|m| at(path, line, format!("space directions: {m}")))?;
            per_axis("space directions", line, v.len())?;
            Some((line, v))
        }
        None => None,
    };
    let mut spatial = vec![true; dimension];
    if let Some((line, kinds)) = fields.get("kinds") {
        let kinds: Vec<&str> = kinds.split_whitespace().collect();
        per_axis("kinds", line, kinds.len())?;
        for (k, kind) in kinds.iter().enumerate() {
            spatial[k] = match kind.to_ascii_lowercase().as_str() {
                "domain" | "space" => true,
                "???" | "none" => directions.as_ref().is_none_or(|(_, d)| d[k].is_some()),
                _ => false,
            };
        }
    } else if let Some((_, d)) = &directions {
        spatial = d.iter().map(Option::is_some).collect();
    }
    let spatial_axes: Vec<usize> = (0..dimension).filter(|&k| spatial[k]).collect();
    let Ok(axes) = <[usize; 3]>::try_from(spatial_axes.as_slice()) else {
        let line = fields.get("kinds").or(directions.as_ref().map(|(l, _)| (*l, ""))).map_or(lines, |(l, _)| l);
        return Err(at(path, line, format!("{} spatial axes, three expected", spatial_axes.len())));
    };
    let extra = match (0..dimension).find(|&k| !spatial[k]) {
        None => ExtraAxis::None,
        Some(0) if matches!(sizes[0], 3 | 4) && sample == Sample::U8 => ExtraAxis::Colour(sizes[0] as usize),
        Some(0) => {
            let found = format!("found {} of type {type_name}", sizes[0]);
            let message =
                format!("a first non-spatial axis is read as colour: 3 or 4 unsigned 8-bit components, {found}");
            return Err(at(path, sizes_line, message));
        }
        Some(_) => ExtraAxis::Volumes,
    };

    let dims64 = axes.map(|k| sizes[k]);
    let voxels = dims64.iter().try_fold(1u64, |a, &n| a.checked_mul(n));
    let format = if matches!(extra, ExtraAxis::Colour(_)) { VoxelFormat::Rgba } else { VoxelFormat::Grey };
    let bytes = voxels.and_then(|v| v.checked_mul(format.bytes() as u64)).unwrap_or(u64::MAX);
    if bytes > MAX_TEXTURE_BYTES || dims64.iter().any(|&n| n > u64::from(u32::MAX)) {
        return Err(VolumeError::TooLarge { path: path.to_path_buf(), dims: dims64, bytes });
    }
    let voxels = voxels.unwrap_or(u64::MAX);
    let total_samples = sizes.iter().try_fold(1u64, |a, &n| a.checked_mul(n)).unwrap_or(u64::MAX);
    let read_samples = match extra {
        ExtraAxis::Colour(c) => voxels * c as u64,
        ExtraAxis::None | ExtraAxis::Volumes => voxels,
    };

    let unit = match fields.get("space units") {
        None => 1e-3,
        Some((line, value)) => {
            let units: Vec<&str> = value.split_whitespace().map(|u| u.trim_matches('"')).collect();
            let factors: Vec<f64> = units
                .iter()
                .map(|u| unit_m(u).ok_or_else(|| at(path, line, format!("space unit {u:?}: m, cm, mm or um expected"))))
                .collect::<Result<_, _>>()?;
            match factors.first() {
                Some(&f) if factors.iter().all(|&g| g == f) => f,
                _ => return Err(at(path, line, format!("space units {value:?}: one unit for every axis expected"))),
            }
        }
    };
    let spacing = match (&directions, fields.get("spacings")) {
        (Some((_, d)), _) => axes.map(|k| d[k].map_or(0.0, length)),
        (None, Some((line, value))) => {
            let s: Vec<f64> = value.split_whitespace().map(|v| v.parse::<f64>().unwrap_or(f64::NAN)).collect();
            per_axis("spacings", line, s.len())?;
            axes.map(|k| s[k])
        }
        (None, None) => {
            return Err(at(path, lines, "no voxel spacing: give \"space directions:\" or \"spacings:\""));
        }
    };
    let origin = match fields.get("space origin") {
        None => [0.0; 3],
        Some((line, value)) => match vectors(value).map_err(|m| at(path, line, format!("space origin: {m}")))?[..] {
            [Some(o)] => o,
            _ => return Err(at(path, line, "space origin: one (x,y,z) expected")),
        },
    };

    let (data_file, data_offset) = match fields.get("data file").or(fields.get("datafile")) {
        None => (path.to_path_buf(), header_end),
        Some((line, value)) => {
            if value.split_whitespace().count() > 1 || value.starts_with("LIST") {
                return Err(at(path, line, "data file: the data split over several files is not read"));
            }
            (path.parent().unwrap_or(Path::new(".")).join(value), 0)
        }
    };
    let number = |names: [&str; 2]| -> Result<i64, VolumeError> {
        match fields.get(names[0]).or(fields.get(names[1])) {
            None => Ok(0),
            Some((line, v)) => v.parse().map_err(|_| at(path, line, format!("{}: {v:?} is not a number", names[0]))),
        }
    };
    let line_skip = number(["line skip", "lineskip"])?;
    let byte_skip = number(["byte skip", "byteskip"])?;
    if line_skip < 0 || byte_skip < -1 || (byte_skip == -1 && encoding != Encoding::Raw) {
        let line = fields.get("byte skip").or(fields.get("line skip")).map_or(lines, |(l, _)| l);
        return Err(at(path, line, "line skip must be 0 or more, byte skip 0 or more (or -1 with raw encoding)"));
    }

    let spacing_field = if directions.is_some() { "space directions" } else { "spacings" };
    let geometry = checked_geometry(
        path,
        dims64.map(|n| n as u32),
        (spacing, spacing_field),
        (origin, "space origin"),
        unit,
        format,
    )
    .map_err(|e| match e {
        // The header's line with the field, as every NRRD header error gives.
        VolumeError::Field { field, value, bound, .. } => {
            let line = fields.get(field).map_or(lines, |(l, _)| l);
            at(path, line, format!("{field} {value}: {bound}"))
        }
        other => other,
    })?;
    Ok(Header {
        geometry,
        sample,
        encoding,
        big_endian,
        extra,
        total_samples,
        read_samples,
        data_file,
        data_offset,
        line_skip: line_skip as u64,
        byte_skip,
    })
}

/// Text read of an ascii-encoded volume, bytes per sample: a number as teem writes it takes
/// under 30 characters with its separator; more is whitespace, or a file that never ends.
const ASCII_BYTES_PER_SAMPLE: u64 = 64;

/// Most text read for `samples` ascii samples, bytes (a gzip stream of blanks is not
/// followed past it).
fn ascii_text_limit(samples: u64) -> u64 {
    samples.saturating_mul(ASCII_BYTES_PER_SAMPLE).saturating_add(4096)
}

/// The samples read (`header.read_samples` of them, the first volume's), as numbers.
fn read_samples(header: &Header) -> Result<Vec<f64>, VolumeError> {
    let path = header.data_file.as_path();
    let (mut file, _) = open_volume_file(path)?;
    let sample_bytes = header.sample.bytes() as u64;
    let wanted = header.read_samples;
    let start = if header.byte_skip == -1 {
        // The data are the last bytes of the file (raw only; no lines skipped).
        let file_len = file.metadata().map_err(|e| io_error(path, &e))?.len();
        let total = header.total_samples.saturating_mul(sample_bytes);
        file_len.checked_sub(total).filter(|&s| s >= header.data_offset).ok_or_else(|| {
            data_error(path, format!("{file_len} bytes, too short for {total} bytes of data at its end"))
        })?
    } else {
        header.data_offset
    };
    file.seek(SeekFrom::Start(start)).map_err(|e| io_error(path, &e))?;
    let mut reader = BufReader::new(file);
    let mut line = Vec::new();
    for _ in 0..header.line_skip {
        line.clear();
        if reader.read_until(b'\n', &mut line).map_err(|e| io_error(path, &e))? == 0 {
            return Err(data_error(path, format!("ends within the {} lines to skip", header.line_skip)));
        }
    }
    let mut decoded: Box<dyn Read> = match header.encoding {
        Encoding::Gzip => Box::new(flate2::bufread::MultiGzDecoder::new(reader)),
        Encoding::Raw | Encoding::Ascii => Box::new(reader),
    };
    if header.byte_skip > 0 {
        let skip = header.byte_skip as u64;
        let skipped = std::io::copy(&mut (&mut decoded).take(skip), &mut std::io::sink())
            .map_err(|e| data_error(path, format!("cannot decode it: {e}")))?;
        if skipped < skip {
            return Err(data_error(path, format!("ends within the {skip} bytes to skip")));
        }
    }
    if header.encoding == Encoding::Ascii {
        let limit = ascii_text_limit(wanted);
        let mut text = String::new();
        (&mut decoded).take(limit).read_to_string(&mut text).map_err(|e| data_error(path, format!("not text: {e}")))?;
        // Cut at the limit, the last number may be partial: it is not read.
        let separator = |c: char| c.is_ascii_whitespace() || c == ',';
        let body = if text.len() as u64 >= limit { &text[..text.rfind(separator).unwrap_or(0)] } else { &text[..] };
        let values: Vec<f64> = body
            .split(separator)
            .filter(|t| !t.is_empty())
            .take(wanted as usize)
            .map(|t| t.parse::<f64>().map_err(|_| data_error(path, format!("{:?} is not a number", truncated(t)))))
            .collect::<Result<_, _>>()?;
        if (values.len() as u64) < wanted {
            let within = if text.len() as u64 >= limit {
                format!(" within the first {limit} bytes of text")
            } else {
                String::new()
            };
            return Err(data_error(path, format!("{} numbers{within}, {wanted} expected", values.len())));
        }
        return Ok(values);
    }
    // Read as it comes (not allocated from the header's sizes), so a header promising more
    // than the file holds costs only what the file holds.
    let wanted_bytes = wanted * sample_bytes;
    let mut bytes = Vec::new();
    decoded
        .take(wanted_bytes)
        .read_to_end(&mut bytes)
        .map_err(|e| data_error(path, format!("cannot decode it: {e}")))?;
    if (bytes.len() as u64) < wanted_bytes {
        return Err(data_error(path, format!("{} bytes of data, {wanted_bytes} expected", bytes.len())));
    }
    try_to_f64(path, bytes.chunks_exact(sample_bytes as usize), |b| header.sample.value(b, header.big_endian))
}

/// Reads the volume of `spec`, a NRRD file (see the module's documentation for what is read):
/// grey volumes go through the intensity window (`spec.window`, default the data's minimum
/// and maximum), colour ones are kept as colours. The first voxel's centre is at
/// `spec.origin_m`, default the header's `space origin`.
pub fn read_nrrd(spec: &VolumeSpec) -> Result<VolumeImage, VolumeError> {
    let path = spec.path.as_path();
    let (origin_m, window) = checked_placement(path, spec)?;
    let header = read_header(path)?;
    let [x, y, z] = header.geometry.dims;
    let what = format!("{x}x{y}x{z} voxels of {:?} samples", header.sample);
    let texture = u64::from(x) * u64::from(y) * u64::from(z) * header.geometry.format.bytes() as u64;
    let raw = match header.encoding {
        Encoding::Ascii => ascii_text_limit(header.read_samples),
        Encoding::Raw | Encoding::Gzip => header.read_samples.saturating_mul(header.sample.bytes() as u64),
    };
    check_conversion_memory(&header.data_file, &what, raw, header.read_samples, texture)?;
    let values = read_samples(&header)?;
    let data = match header.extra {
        ExtraAxis::Colour(c) => {
            values.chunks_exact(c).flat_map(|v| [v[0] as u8, v[1] as u8, v[2] as u8, 255]).collect()
        }
        ExtraAxis::None | ExtraAxis::Volumes => grey_levels(&header.data_file, values, window)?,
    };
    Ok(header.geometry.image(data, origin_m))
}
