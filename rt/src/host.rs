//! What a run's report says about the machine it ran on, and when it started: host name, CPU
//! model, kernel ([`HostInfo`]), and a UTC time stamp in RFC 3339 ([`rfc3339_utc`]).
//!
//! # Examples
//!
//! ```
//! use std::time::{Duration, UNIX_EPOCH};
//! use lamina_rt::host::{HostInfo, rfc3339_utc};
//!
//! let host = HostInfo::detect();
//! assert!(host.logical_cpus >= 1);
//! assert_eq!(rfc3339_utc(UNIX_EPOCH + Duration::from_secs(951_782_400)), "2000-02-29T00:00:00Z");
//! ```

use std::time::{SystemTime, UNIX_EPOCH};

use serde::{Deserialize, Serialize};

/// The machine a process runs on. Fields that cannot be read say `"unknown"`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct HostInfo {
    /// Host name (`uname -n`).
    pub name: String,
    /// CPU model: the first `model name` of `/proc/cpuinfo` (on machines without one, the
    /// architecture, e.g. `aarch64`).
    pub cpu_model: String,
    /// Logical CPUs this process may run on.
    pub logical_cpus: usize,
    /// Kernel: system name, release and version (`uname -srv`).
    pub kernel: String,
}

/// One `uname` field as text.
fn field(chars: &[libc::c_char]) -> String {
    let bytes: Vec<u8> = chars.iter().take_while(|&&c| c != 0).map(|&c| c as u8).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

impl HostInfo {
    /// Reads the host name and kernel (`uname`), the CPU model (`/proc/cpuinfo`) and the
    /// CPUs available to this process.
    pub fn detect() -> Self {
        // SAFETY: utsname is plain old data; uname fills it and only reads the pointer.
        let mut uts: libc::utsname = unsafe { core::mem::zeroed() };
        // SAFETY: a valid, writable utsname.
        let ok = unsafe { libc::uname(&mut uts) } == 0;
        let (name, kernel) = if ok {
            let kernel = format!("{} {} {}", field(&uts.sysname), field(&uts.release), field(&uts.version));
            (field(&uts.nodename), kernel)
        } else {
            ("unknown".to_string(), "unknown".to_string())
        };
        let cpu_model = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split_once(':'))
                    .map(|(_, v)| v.trim().to_string())
            })
            .filter(|m| !m.is_empty())
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        let logical_cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        Self { name, cpu_model, logical_cpus, kernel }
    }
}

/// `t` in UTC as RFC 3339 with whole seconds, e.g. `2026-03-01T09:30:00Z`. Times before
/// 1970 are written as 1970-01-01T00:00:00Z.
pub fn rfc3339_utc(t: SystemTime) -> String {
    let secs = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let (days, rem) = (secs / 86_400, secs % 86_400);
    let (y, m, d) = civil_from_days(days as i64);
    format!("{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z", rem / 3600, rem % 3600 / 60, rem % 60)
}

/// Year, month (1-12) and day (1-31) of the day `days` after 1970-01-01 in the proleptic
/// Gregorian calendar (H. Hinnant's `civil_from_days`).
fn civil_from_days(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    let y = yoe + era * 400 + i64::from(m <= 2);
    (y, m, d)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    fn at(secs: u64) -> String {
        rfc3339_utc(UNIX_EPOCH + Duration::from_secs(secs))
    }

    #[test]
    fn rfc3339_utc_known_instants_works() {
        // Values from `date -u -d @SECONDS +%Y-%m-%dT%H:%M:%SZ`.
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        assert_eq!(at(86_399), "1970-01-01T23:59:59Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(at(951_868_800), "2000-03-01T00:00:00Z");
        assert_eq!(at(1_234_567_890), "2009-02-13T23:31:30Z");
        assert_eq!(at(4_107_542_399), "2100-02-28T23:59:59Z");
        assert_eq!(at(4_107_542_400), "2100-03-01T00:00:00Z");
        assert_eq!(rfc3339_utc(UNIX_EPOCH - Duration::from_secs(5)), "1970-01-01T00:00:00Z");
    }

    #[test]
    fn host_info_detect_fills_every_field_works() {
        let h = HostInfo::detect();
        assert!(!h.name.is_empty() && !h.cpu_model.is_empty() && !h.kernel.is_empty(), "{h:?}");
        assert!(h.logical_cpus >= 1);
        if cfg!(target_os = "linux") {
            assert!(h.kernel.starts_with("Linux "), "{}", h.kernel);
        }
    }
}
