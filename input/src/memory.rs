//! How much memory a request may take: [`memory_budget`] and [`check_memory`].
//!
//! The budget is the smallest of
//! 1. `MemAvailable` in `/proc/meminfo` (what the kernel can give without swapping);
//! 2. the cgroup v2 limit of this process, `memory.max − memory.current`, when one is set
//!    (containers and CI runners often have one far below the host's memory);
//! 3. the address-space limit `RLIMIT_AS` (`ulimit -v`, `prlimit --as`), when one is set,
//!    minus the process's current virtual size (the first field of `/proc/self/statm`, in
//!    pages): the kernel refuses any mapping that would take the virtual size past the
//!    limit, so this is exactly what a new allocation may still map. Virtual size counts
//!    reserved but untouched memory too (thread stacks, allocator arenas), which is why the
//!    figure is the limit minus the virtual size and not minus the resident size;
//! 4. [`LIMIT_ENV`] (`LAMINA_MEMORY_LIMIT`, bytes), when set: a cap the user chooses;
//! 5. [`set_process_limit`], when called: a cap the program (or a test) chooses.
//!
//! Where none of them can be read (not Linux), the budget is unknown and every request
//! passes; the size caps of the formats still apply.
//!
//! # Examples
//! ```
//! use lamina_input::{check_memory, memory_budget};
//!
//! assert!(check_memory("a small table", 1 << 10).is_ok());
//! let e = check_memory("a table of 2^62 entries", u64::MAX).unwrap_err();
//! if memory_budget().is_ok_and(|b| b.bytes.is_some()) {
//!     // The message names what was asked for and both sizes.
//!     assert!(e.to_string().starts_with("a table of 2^62 entries needs"));
//! }
//! ```

use std::fmt;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// [`set_process_limit`]'s cap; `u64::MAX`: none.
static PROCESS_LIMIT: AtomicU64 = AtomicU64::new(u64::MAX);

/// Caps every later request of this process at `bytes` (on top of the host's figures).
/// Tests use it so that a refusal does not depend on the machine's memory.
pub fn set_process_limit(bytes: u64) {
    PROCESS_LIMIT.store(bytes, Ordering::Relaxed);
}

/// Environment variable that caps the memory a request may take, in bytes (a plain
/// integer, e.g. `LAMINA_MEMORY_LIMIT=2000000000`). Unset: no cap beyond the host's.
pub const LIMIT_ENV: &str = "LAMINA_MEMORY_LIMIT";

/// Where the budget's figure comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemorySource {
    /// `MemAvailable` in `/proc/meminfo`.
    MemAvailable,
    /// The cgroup's `memory.max` minus its `memory.current`.
    Cgroup,
    /// `RLIMIT_AS` minus the process's virtual size.
    AddressSpace,
    /// [`LIMIT_ENV`].
    Environment,
    /// [`set_process_limit`].
    Process,
}

impl fmt::Display for MemorySource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::MemAvailable => "MemAvailable in /proc/meminfo",
            Self::Cgroup => "the cgroup's memory.max minus memory.current",
            Self::AddressSpace => "RLIMIT_AS minus this process's virtual size",
            Self::Environment => LIMIT_ENV,
            Self::Process => "the limit this program set",
        })
    }
}

/// The memory a request may take now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryBudget {
    /// Bytes available; `None` when no source could be read (every request passes).
    pub bytes: Option<u64>,
    /// Which source gave `bytes` (the smallest of those read).
    pub source: Option<MemorySource>,
}

/// Why a request was refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MemoryCheckError {
    /// The estimate exceeds the budget.
    TooLarge {
        /// What was asked for, e.g. `cylinder limb 4096 x 4096 (117,444,608 nodes)`.
        what: String,
        /// Estimated bytes (`u64::MAX` when the estimate itself overflowed).
        needed_bytes: u64,
        /// Bytes available.
        available_bytes: u64,
        /// Where `available_bytes` comes from.
        source: MemorySource,
    },
    /// [`LIMIT_ENV`] is set but is not a whole number of bytes.
    BadLimit {
        /// The variable's value.
        value: String,
    },
}

// Written by hand: `thiserror` would take the `source` field for the error's cause.
impl fmt::Display for MemoryCheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooLarge { what, needed_bytes, available_bytes, source } => write!(
                f,
                "{what} needs {}{}, more than the {} available ({source})",
                if *needed_bytes == u64::MAX { "" } else { "about " },
                format_bytes(*needed_bytes),
                format_bytes(*available_bytes)
            ),
            Self::BadLimit { value } => {
                write!(f, "{LIMIT_ENV}={value:?} is not a whole number of bytes")
            }
        }
    }
}

impl std::error::Error for MemoryCheckError {}

/// `bytes` for people: `1.50 GiB (1,610,612,736 bytes)`; `u64::MAX` (an estimate that
/// overflowed) reads `more than 16 EiB`.
pub fn format_bytes(bytes: u64) -> String {
    if bytes == u64::MAX {
        return "more than 16 EiB".into();
    }
    const UNITS: [&str; 6] = ["KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let exact = group_thousands(bytes);
    if bytes < 1024 {
        return format!("{exact} bytes");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    format!("{value:.2} {} ({exact} bytes)", UNITS[unit])
}

fn group_thousands(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The memory a request may take now (see the [module docs](self)).
///
/// # Errors
/// [`MemoryCheckError::BadLimit`] when [`LIMIT_ENV`] is set to something other than a
/// whole number.
pub fn memory_budget() -> Result<MemoryBudget, MemoryCheckError> {
    let mut best: Option<(u64, MemorySource)> = None;
    let mut offer = |bytes: Option<u64>, source: MemorySource| {
        if let Some(b) = bytes
            && best.is_none_or(|(old, _)| b < old)
        {
            best = Some((b, source));
        }
    };
    offer(mem_available(Path::new("/proc/meminfo")), MemorySource::MemAvailable);
    offer(cgroup_available(), MemorySource::Cgroup);
    offer(address_space_available(), MemorySource::AddressSpace);
    if let Some(value) = std::env::var_os(LIMIT_ENV) {
        let text = value.to_string_lossy().into_owned();
        match text.trim().parse::<u64>() {
            Ok(b) => offer(Some(b), MemorySource::Environment),
            Err(_) => return Err(MemoryCheckError::BadLimit { value: text }),
        }
    }
    let process = PROCESS_LIMIT.load(Ordering::Relaxed);
    offer((process != u64::MAX).then_some(process), MemorySource::Process);
    Ok(MemoryBudget { bytes: best.map(|b| b.0), source: best.map(|b| b.1) })
}

/// Refuses `needed_bytes` (an estimate; pass `u64::MAX` when computing it overflowed) when
/// it exceeds [`memory_budget`]. `what` names the request in the error.
///
/// # Errors
/// [`MemoryCheckError::TooLarge`] with both sizes, or [`MemoryCheckError::BadLimit`].
pub fn check_memory(what: &str, needed_bytes: u64) -> Result<(), MemoryCheckError> {
    let budget = memory_budget()?;
    match (budget.bytes, budget.source) {
        (Some(available_bytes), Some(source)) if needed_bytes > available_bytes => {
            Err(MemoryCheckError::TooLarge { what: what.to_owned(), needed_bytes, available_bytes, source })
        }
        _ => Ok(()),
    }
}

/// `MemAvailable` from a `/proc/meminfo`-format file, bytes.
fn mem_available(path: &Path) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    parse_mem_available(&text)
}

fn parse_mem_available(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut words = line.split_whitespace().skip(1);
    let value: u64 = words.next()?.parse().ok()?;
    let scale = match words.next() {
        Some("kB") => 1024,
        None => 1,
        Some(_) => return None,
    };
    value.checked_mul(scale)
}

/// `memory.max − memory.current` of this process's cgroup (v2), bytes; `None` without a
/// limit.
fn cgroup_available() -> Option<u64> {
    let membership = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let relative = membership.lines().find_map(|l| l.strip_prefix("0::"))?;
    let dir = Path::new("/sys/fs/cgroup").join(relative.trim_start_matches('/'));
    let max = std::fs::read_to_string(dir.join("memory.max")).ok()?;
    let max: u64 = max.trim().parse().ok()?; // "max" means no limit
    let current: u64 = std::fs::read_to_string(dir.join("memory.current")).ok()?.trim().parse().ok()?;
    Some(max.saturating_sub(current))
}

/// `RLIMIT_AS`'s soft limit minus this process's virtual size, bytes; `None` without a
/// limit (`RLIM_INFINITY`) or where either cannot be read.
fn address_space_available() -> Option<u64> {
    let limit = address_space_limit()?;
    let statm = std::fs::read_to_string("/proc/self/statm").ok()?;
    let virtual_bytes = parse_statm_size(&statm)?.checked_mul(page_size()?)?;
    Some(limit.saturating_sub(virtual_bytes))
}

/// The soft `RLIMIT_AS`, bytes; `None` when unlimited.
fn address_space_limit() -> Option<u64> {
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: `getrlimit` writes one `rlimit` through a pointer to a live, aligned one.
    let ok = unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } == 0;
    (ok && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur)
}

/// Bytes per page.
fn page_size() -> Option<u64> {
    // SAFETY: `sysconf` reads a configuration value; it has no memory effects.
    let size = unsafe { libc::sysconf(libc::_SC_PAGESIZE) };
    u64::try_from(size).ok().filter(|&s| s > 0)
}

/// The total program size in pages: the first field of `/proc/self/statm`.
fn parse_statm_size(text: &str) -> Option<u64> {
    text.split_whitespace().next()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mem_available_parses_kilobytes_works() {
        let text = "MemTotal:       24576000 kB\nMemFree:         1000 kB\nMemAvailable:   20000000 kB\n";
        assert_eq!(parse_mem_available(text), Some(20_000_000 * 1024));
        assert_eq!(parse_mem_available("MemTotal: 5 kB\n"), None);
        assert_eq!(parse_mem_available("MemAvailable: 5 MB\n"), None);
    }

    #[test]
    fn statm_size_parses_pages_works() {
        assert_eq!(parse_statm_size("1048576 2000 300 40 0 5000 0\n"), Some(1_048_576));
        assert_eq!(parse_statm_size(""), None);
        assert_eq!(parse_statm_size("x 1 2"), None);
    }

    #[test]
    fn format_bytes_reads_works() {
        assert_eq!(format_bytes(512), "512 bytes");
        assert_eq!(format_bytes(1_610_612_736), "1.50 GiB (1,610,612,736 bytes)");
        assert_eq!(format_bytes(u64::MAX), "more than 16 EiB");
    }

    #[test]
    fn too_large_message_gives_both_sizes_works() {
        let e = MemoryCheckError::TooLarge {
            what: "block 100 x 100 x 100".into(),
            needed_bytes: 3 << 30,
            available_bytes: 1 << 30,
            source: MemorySource::MemAvailable,
        };
        assert_eq!(
            e.to_string(),
            "block 100 x 100 x 100 needs about 3.00 GiB (3,221,225,472 bytes), more than the \
             1.00 GiB (1,073,741,824 bytes) available (MemAvailable in /proc/meminfo)"
        );
    }
}
