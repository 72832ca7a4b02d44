//! Time a hypervisor took from each CPU: the `steal` column of `/proc/stat`. On a virtual
//! machine a vCPU that the host deschedules stops for that long whatever its priority, so a
//! loop at `SCHED_FIFO` wakes late; steal measured over a run tells host preemption apart from
//! the loop's own overruns. Bare metal, and kernels that do not account steal, read 0.
//!
//! # Examples
//!
//! ```
//! use lamina_rt::steal::{CpuSteal, StealSnapshot};
//!
//! let text = "cpu  10 0 5 100 0 0 0 7 0 0\ncpu0 4 0 2 50 0 0 0 3 0 0\ncpu1 6 0 3 50 0 0 0 4 0 0\n";
//! let before = StealSnapshot::parse(text, 100)?;
//! let later = "cpu  10 0 5 200 0 0 0 19 0 0\ncpu0 4 0 2 100 0 0 0 5 0 0\ncpu1 6 0 3 100 0 0 0 14 0 0\n";
//! let after = StealSnapshot::parse(later, 100)?;
//! // CPU 1 lost 10 ticks of 1/100 s to the host: 100 ms.
//! assert_eq!(after.since(&before).cpu(1), Some(CpuSteal { cpu: 1, stolen_ms: 100 }));
//! # Ok::<(), lamina_rt::steal::StealReadError>(())
//! ```

use std::fmt;

/// Where the kernel accounts CPU time.
pub const PROC_STAT: &str = "/proc/stat";

/// The most CPUs a snapshot keeps (per-CPU lines beyond it are ignored).
pub const MAX_CPUS: usize = 256;

/// Why `/proc/stat` could not be read as CPU time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum StealReadError {
    /// The file could not be read (not Linux, or `/proc` not mounted).
    Io(String),
    /// A `cpuN` line (1-based line number) has no steal column or a field that is not a count.
    Malformed {
        /// 1-based line number in the file.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The clock-tick rate (`sysconf(_SC_CLK_TCK)`) is not positive.
    NoTickRate,
}

impl fmt::Display for StealReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io(m) => write!(f, "{PROC_STAT}: {m}"),
            Self::Malformed { line, message } => write!(f, "{PROC_STAT}, line {line}: {message}"),
            Self::NoTickRate => write!(f, "sysconf(_SC_CLK_TCK) gave no clock-tick rate"),
        }
    }
}

impl std::error::Error for StealReadError {}

/// Steal time of one CPU over an interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CpuSteal {
    /// Logical CPU number (the `N` of `cpuN`).
    pub cpu: usize,
    /// Time the hypervisor ran something else on this vCPU, ms (resolution one clock tick,
    /// usually 10 ms).
    pub stolen_ms: u64,
}

/// Cumulative steal per CPU at one instant, in ms since boot.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StealSnapshot {
    per_cpu: Vec<CpuSteal>,
}

impl StealSnapshot {
    /// Reads [`PROC_STAT`] now. Allocates: call it outside the per-tick path.
    pub fn read() -> Result<Self, StealReadError> {
        let text = std::fs::read_to_string(PROC_STAT).map_err(|e| StealReadError::Io(e.to_string()))?;
        // SAFETY: sysconf only reads a configuration value.
        let ticks_per_second = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
        let ticks_per_second = u64::try_from(ticks_per_second).ok().filter(|&t| t > 0);
        Self::parse(&text, ticks_per_second.ok_or(StealReadError::NoTickRate)?)
    }

    /// Reads the `cpuN` lines of `/proc/stat` text: the 8th number after the name is steal,
    /// in clock ticks of `1 / ticks_per_second` s. Kernels older than 2.6.11 have no steal
    /// column; their lines are refused.
    pub fn parse(text: &str, ticks_per_second: u64) -> Result<Self, StealReadError> {
        if ticks_per_second == 0 {
            return Err(StealReadError::NoTickRate);
        }
        let mut per_cpu = Vec::new();
        for (index, line) in text.lines().enumerate() {
            let mut fields = line.split_ascii_whitespace();
            let Some(cpu) = fields.next().and_then(|name| name.strip_prefix("cpu")).filter(|n| !n.is_empty()) else {
                continue;
            };
            let malformed = |message: String| StealReadError::Malformed { line: index + 1, message };
            let cpu: usize = cpu.parse().map_err(|_| malformed(format!("'cpu{cpu}' is not a CPU number")))?;
            let steal = fields.nth(7).ok_or_else(|| malformed("fewer than 8 time columns (no steal)".into()))?;
            let ticks: u64 = steal.parse().map_err(|_| malformed(format!("steal '{steal}' is not a tick count")))?;
            if per_cpu.len() < MAX_CPUS {
                per_cpu.push(CpuSteal { cpu, stolen_ms: ticks.saturating_mul(1_000) / ticks_per_second });
            }
        }
        Ok(Self { per_cpu })
    }

    /// Steal of every CPU between `earlier` and this snapshot (CPUs in both).
    pub fn since(&self, earlier: &Self) -> Self {
        let per_cpu = self
            .per_cpu
            .iter()
            .filter_map(|now| {
                let then = earlier.cpu(now.cpu)?;
                Some(CpuSteal { cpu: now.cpu, stolen_ms: now.stolen_ms.saturating_sub(then.stolen_ms) })
            })
            .collect();
        Self { per_cpu }
    }

    /// One CPU's steal, if the snapshot has it.
    pub fn cpu(&self, cpu: usize) -> Option<CpuSteal> {
        self.per_cpu.iter().find(|c| c.cpu == cpu).copied()
    }

    /// Every CPU's steal, in the file's order.
    pub fn cpus(&self) -> &[CpuSteal] {
        &self.per_cpu
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_takes_the_eighth_column_and_skips_the_total_works() {
        // A real line layout (kernel 6.1): user nice system idle iowait irq softirq steal guest guest_nice.
        let text = "cpu  11271046 130801 769870 1969693 64308 0 9746 133119 0 0\n\
                    cpu0 5540378 66949 371872 1111440 19417 0 932 64782 0 0\n\
                    cpu1 5730668 63851 397998 858253 44891 0 8814 68337 0 0\n\
                    intr 1 2 3\nctxt 99\n";
        let s = StealSnapshot::parse(text, 100).unwrap();
        assert_eq!(s.cpus(), [CpuSteal { cpu: 0, stolen_ms: 647_820 }, CpuSteal { cpu: 1, stolen_ms: 683_370 }]);
    }

    #[test]
    fn parse_refuses_a_line_without_steal_naming_it_works() {
        let e = StealSnapshot::parse("cpu 1 2 3 4\ncpu0 1 2 3 4\n", 100).unwrap_err();
        assert_eq!(e, StealReadError::Malformed { line: 2, message: "fewer than 8 time columns (no steal)".into() });
        let e = StealSnapshot::parse("cpu0 1 2 3 4 5 6 7 x\n", 100).unwrap_err();
        assert!(e.to_string().contains("line 1") && e.to_string().contains("'x'"), "{e}");
        assert_eq!(StealSnapshot::parse("", 0).unwrap_err(), StealReadError::NoTickRate);
    }

    #[test]
    fn since_subtracts_per_cpu_and_drops_cpus_that_came_online_works() {
        let before = StealSnapshot::parse("cpu0 0 0 0 0 0 0 0 5 0 0\n", 250).unwrap();
        let after = StealSnapshot::parse("cpu0 0 0 0 0 0 0 0 30 0 0\ncpu1 0 0 0 0 0 0 0 9 0 0\n", 250).unwrap();
        assert_eq!(after.since(&before).cpus(), [CpuSteal { cpu: 0, stolen_ms: 100 }]);
    }

    #[test]
    fn read_on_this_machine_works() {
        // Linux always has /proc/stat; every CPU this process may run on has a line.
        let s = StealSnapshot::read().unwrap();
        assert!(s.cpus().len() >= crate::available_cpus().len().min(MAX_CPUS));
    }
}
