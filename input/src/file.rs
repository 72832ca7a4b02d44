//! Reading a file only when it is a regular file within its format's size cap.
//!
//! How [`open_regular`] decides, in order:
//! 1. `stat` the path (this never blocks, whatever the path is): anything but a regular file
//!    (a directory, a FIFO, a character device such as `/dev/zero` or `/dev/urandom`, a block
//!    device, a socket) is [`FileReadError::NotRegular`], named by its kind;
//! 2. a size above the format's cap ([`FileLimit::max_bytes`]) is [`FileReadError::TooLarge`];
//! 3. the memory parsing will take, `size × `[`FileLimit::memory_per_byte`], is checked
//!    against what is available ([`crate::check_memory`]);
//! 4. open it without blocking (`O_NONBLOCK`, so a path swapped for a FIFO after step 1
//!    cannot hang the open) and check the opened file again (`fstat`).
//!
//! [`read_bytes`] and [`read_text`] then read at most the cap, so a file that grows while it
//! is read is refused rather than followed.

use std::fs::{File, Metadata};
use std::io::Read;
use std::os::unix::fs::{FileTypeExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

use crate::memory::{MemoryCheckError, check_memory, format_bytes};

/// What a format accepts: its name in messages, its size cap and the memory its parser takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FileLimit {
    /// The format in messages, e.g. `"mesh file"`.
    pub what: &'static str,
    /// Largest file accepted, bytes.
    pub max_bytes: u64,
    /// Memory the parser takes per byte of file (an upper estimate), bytes. Default 1.
    pub memory_per_byte: u64,
}

impl FileLimit {
    /// A format named `what` with files up to `max_bytes`, parsed in about the file's size.
    pub const fn new(what: &'static str, max_bytes: u64) -> Self {
        Self { what, max_bytes, memory_per_byte: 1 }
    }

    /// Sets [`FileLimit::memory_per_byte`].
    #[must_use]
    pub const fn memory_per_byte(mut self, bytes: u64) -> Self {
        self.memory_per_byte = bytes;
        self
    }
}

/// Why a file was not read.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FileReadError {
    /// The file could not be opened or read.
    #[error("{path}: {message}")]
    Io {
        /// File.
        path: PathBuf,
        /// OS error text.
        message: String,
    },
    /// The path is not a regular file.
    #[error("{path}: is {kind}, not a regular file; a {what} must be a regular file")]
    NotRegular {
        /// File.
        path: PathBuf,
        /// What it is: `"a directory"`, `"a FIFO (named pipe)"`, `"a character device"`, ...
        kind: &'static str,
        /// The format that was expected.
        what: &'static str,
    },
    /// The file is larger than its format's cap.
    #[error("{path}: {} is larger than a {what} may be (at most {})", format_bytes(*.bytes), format_bytes(*.max_bytes))]
    TooLarge {
        /// File.
        path: PathBuf,
        /// Its size, bytes (at least the cap + 1 when it grew while being read).
        bytes: u64,
        /// The cap, bytes.
        max_bytes: u64,
        /// The format.
        what: &'static str,
    },
    /// Parsing the file would take more memory than is available.
    #[error("{path}: {error}")]
    Memory {
        /// File.
        path: PathBuf,
        /// The refusal, with both sizes.
        error: MemoryCheckError,
    },
    /// A text format holds bytes that are not UTF-8.
    #[error("{path}:{line}: not UTF-8 text")]
    NotUtf8 {
        /// File.
        path: PathBuf,
        /// 1-based line of the first bad byte.
        line: usize,
    },
}

fn kind_of(meta: &Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("a directory")
    } else if t.is_fifo() {
        Some("a FIFO (named pipe)")
    } else if t.is_char_device() {
        Some("a character device")
    } else if t.is_block_device() {
        Some("a block device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        Some("not a file")
    }
}

/// Checks `meta` against `limit`: regular, within the cap, parseable in available memory.
fn check(path: &Path, meta: &Metadata, limit: &FileLimit) -> Result<u64, FileReadError> {
    if let Some(kind) = kind_of(meta) {
        return Err(FileReadError::NotRegular { path: path.to_path_buf(), kind, what: limit.what });
    }
    let bytes = meta.len();
    if bytes > limit.max_bytes {
        return Err(FileReadError::TooLarge {
            path: path.to_path_buf(),
            bytes,
            max_bytes: limit.max_bytes,
            what: limit.what,
        });
    }
    let what = format!("reading this {} ({})", limit.what, format_bytes(bytes));
    check_memory(&what, bytes.saturating_mul(limit.memory_per_byte))
        .map_err(|error| FileReadError::Memory { path: path.to_path_buf(), error })?;
    Ok(bytes)
}

/// Opens `path` for reading when it is a regular file within `limit` (see the
/// [module docs](self)); returns the file and its size in bytes. For streaming parsers:
/// read at most [`FileLimit::max_bytes`] from it (`Read::take`).
///
/// # Errors
/// [`FileReadError`]: cannot be read, not a regular file, over the cap, or over the memory
/// available.
pub fn open_regular(path: impl AsRef<Path>, limit: &FileLimit) -> Result<(File, u64), FileReadError> {
    let path = path.as_ref();
    let io = |e: std::io::Error| FileReadError::Io { path: path.to_path_buf(), message: e.to_string() };
    check(path, &std::fs::metadata(path).map_err(io)?, limit)?;
    let file = File::options().read(true).custom_flags(libc::O_NONBLOCK).open(path).map_err(io)?;
    let bytes = check(path, &file.metadata().map_err(io)?, limit)?;
    Ok((file, bytes))
}

/// Reads the whole of `path` when it is a regular file within `limit`.
///
/// # Errors
/// As [`open_regular`]; [`FileReadError::TooLarge`] also when the file grows past the cap
/// while it is read.
pub fn read_bytes(path: impl AsRef<Path>, limit: &FileLimit) -> Result<Vec<u8>, FileReadError> {
    let path = path.as_ref();
    let (file, bytes) = open_regular(path, limit)?;
    let mut out = Vec::with_capacity(usize::try_from(bytes).unwrap_or(0));
    file.take(limit.max_bytes.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| FileReadError::Io { path: path.to_path_buf(), message: e.to_string() })?;
    if out.len() as u64 > limit.max_bytes {
        return Err(FileReadError::TooLarge {
            path: path.to_path_buf(),
            bytes: out.len() as u64,
            max_bytes: limit.max_bytes,
            what: limit.what,
        });
    }
    Ok(out)
}

/// Reads `path` as UTF-8 text when it is a regular file within `limit`.
///
/// # Errors
/// As [`read_bytes`], and [`FileReadError::NotUtf8`] with the line of the first bad byte.
pub fn read_text(path: impl AsRef<Path>, limit: &FileLimit) -> Result<String, FileReadError> {
    let path = path.as_ref();
    let bytes = read_bytes(path, limit)?;
    String::from_utf8(bytes).map_err(|e| {
        let good = e.utf8_error().valid_up_to();
        let line = 1 + e.as_bytes()[..good].iter().filter(|&&b| b == b'\n').count();
        FileReadError::NotUtf8 { path: path.to_path_buf(), line }
    })
}
