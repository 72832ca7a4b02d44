//! Reading untrusted input within stated bounds.
//!
//! Every file Lamina reads (meshes, model files, scenes, trajectories, material targets) comes
//! from a user and may be anything: a FIFO that never ends, `/dev/zero`, a 40 GB file, a
//! count that overflows. This crate holds the two checks every reader makes before it trusts
//! a size:
//!
//! - [`file`](mod@file): only regular files are read, refused by their metadata before a byte is read
//!   (a FIFO, `/dev/urandom` or `/dev/zero` is named as such), each format with its own size
//!   cap ([`FileLimit`]);
//! - [`memory`]: a size estimated in bytes is refused when it exceeds the memory available
//!   (the smallest of `MemAvailable` in `/proc/meminfo`, the cgroup's limit, `RLIMIT_AS` less
//!   the process's virtual size, and [`memory::LIMIT_ENV`]); the error gives both numbers.
//!
//! # Examples
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use lamina_input::{FileLimit, FileReadError, read_text};
//! # let dir = tempfile::tempdir()?;
//! # let path = dir.path().join("scene.toml");
//! # std::fs::write(&path, "name = \"block\"\n")?;
//! const SCENE: FileLimit = FileLimit::new("scene file", 1 << 20);
//! let text = read_text(&path, &SCENE)?;
//! assert!(text.starts_with("name"));
//! let e = read_text("/dev/zero", &SCENE).unwrap_err();
//! assert!(matches!(e, FileReadError::NotRegular { .. }));
//! assert!(e.to_string().contains("character device"));
//! # Ok(())
//! # }
//! ```

pub mod file;
pub mod memory;

pub use file::{FileLimit, FileReadError, open_regular, read_bytes, read_text};
pub use memory::{MemoryBudget, MemoryCheckError, MemorySource, check_memory, format_bytes, memory_budget};
