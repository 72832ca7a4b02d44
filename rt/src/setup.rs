//! Real-time setup: CPU pinning, `SCHED_FIFO` priority and locked memory,
//! each asked for and reported plainly when refused.
//!
//! None of these panic: a refusal (not root, no `CAP_SYS_NICE`, a cpuset
//! that excludes the CPU, an `RLIMIT_MEMLOCK` too small, ...) comes back as an
//! error value, and [`RealtimeSetup`] collects the three outcomes into one
//! report whose `Display` says what was granted and what was refused.
//!
//! # Examples
//!
//! ```
//! use lamina_rt::{RealtimeRequest, RealtimeSetup};
//!
//! # std::thread::spawn(|| {
//! let setup = RealtimeSetup::apply(&RealtimeRequest::new().pin_to(0).fifo_priority(10));
//! println!("{setup}"); // granted or refused, never a panic
//! # }).join().unwrap();
//! ```

use std::fmt;

/// Why [`pin_current_thread`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ThreadPinError {
    /// The CPU is not in this process's allowed set (it does not exist, or a
    /// cpuset / `taskset` excludes it).
    #[error("cpu {cpu} is not in this process's allowed set ({available} cpus available)")]
    CpuUnavailable {
        /// The requested CPU index.
        cpu: usize,
        /// How many CPUs the process may use.
        available: usize,
    },
    /// The kernel refused to set the affinity.
    #[error("the kernel refused to pin to cpu {cpu}")]
    Refused {
        /// The requested CPU index.
        cpu: usize,
    },
}

/// Why [`set_fifo_priority`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FifoPrioritySetError {
    /// The priority is outside the range `SCHED_FIFO` accepts (1..=99 on Linux).
    #[error("priority {priority} is outside SCHED_FIFO's range {min}..={max}")]
    OutOfRange {
        /// The requested priority.
        priority: i32,
        /// Lowest `SCHED_FIFO` priority.
        min: i32,
        /// Highest `SCHED_FIFO` priority.
        max: i32,
    },
    /// `EPERM`: needs root, `CAP_SYS_NICE`, or `RLIMIT_RTPRIO` (`ulimit -r`)
    /// at least the priority; containers usually also need `--cap-add
    /// SYS_NICE` and, with cgroup v1 RT groups, an RT runtime budget.
    #[error(
        "permission denied (EPERM) for priority {priority}: needs root, CAP_SYS_NICE or RLIMIT_RTPRIO >= {priority}"
    )]
    PermissionDenied {
        /// The requested priority.
        priority: i32,
    },
    /// Any other error number from `sched_setscheduler`.
    #[error("sched_setscheduler(SCHED_FIFO, {priority}) failed: errno {errno}")]
    Os {
        /// The requested priority.
        priority: i32,
        /// `errno`.
        errno: i32,
    },
}

/// Why [`lock_memory`] failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MemoryLockError {
    /// `EPERM`: needs root, `CAP_IPC_LOCK`, or a large enough `RLIMIT_MEMLOCK`.
    #[error("permission denied (EPERM): needs root, CAP_IPC_LOCK or a larger RLIMIT_MEMLOCK")]
    PermissionDenied,
    /// `ENOMEM`: `RLIMIT_MEMLOCK` (`ulimit -l`) is smaller than the memory to
    /// lock.
    #[error("RLIMIT_MEMLOCK (ulimit -l) is too small for the process (ENOMEM)")]
    LimitExceeded,
    /// Any other error number from `mlockall`.
    #[error("mlockall failed: errno {errno}")]
    Os {
        /// `errno`.
        errno: i32,
    },
}

fn errno() -> i32 {
    std::io::Error::last_os_error().raw_os_error().unwrap_or(0)
}

/// Pins the calling thread to CPU `cpu` (an index as in `/proc/cpuinfo`),
/// via `core_affinity`.
///
/// Allocates (it lists the allowed CPUs): call it at start-up, not in a loop.
pub fn pin_current_thread(cpu: usize) -> Result<(), ThreadPinError> {
    // The kernel checks `cpu` against the process's cpuset. This thread's own mask is not
    // consulted first: it may be narrower (a thread spawned by a pinned one inherits its CPU).
    let settable = cpu < libc::CPU_SETSIZE as usize;
    if settable && core_affinity::set_for_current(core_affinity::CoreId { id: cpu }) {
        return Ok(());
    }
    let ids = core_affinity::get_core_ids().unwrap_or_default();
    if settable && ids.iter().any(|c| c.id == cpu) {
        Err(ThreadPinError::Refused { cpu })
    } else {
        Err(ThreadPinError::CpuUnavailable { cpu, available: ids.len() })
    }
}

/// The CPUs this process may run on (its affinity mask), ascending.
pub fn available_cpus() -> Vec<usize> {
    let mut ids: Vec<usize> = core_affinity::get_core_ids().unwrap_or_default().into_iter().map(|c| c.id).collect();
    ids.sort_unstable();
    ids
}

/// A CPU list as the kernel writes one (`/sys/devices/system/cpu/online`): ascending runs
/// joined by commas, `0-3,6`; `none` for an empty list.
pub fn format_cpu_list(cpus: &[usize]) -> String {
    let mut sorted = cpus.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut runs: Vec<(usize, usize)> = Vec::new();
    for cpu in sorted {
        match runs.last_mut() {
            Some((_, end)) if *end + 1 == cpu => *end = cpu,
            _ => runs.push((cpu, cpu)),
        }
    }
    if runs.is_empty() {
        return "none".into();
    }
    let text: Vec<String> =
        runs.iter().map(|&(a, b)| if a == b { a.to_string() } else { format!("{a}-{b}") }).collect();
    text.join(",")
}

/// Why [`pin_for_option`] refused a CPU given on the command line.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{option} {cpu}: {reason}; this process may run on CPUs {}", format_cpu_list(.available))]
pub struct CpuOptionError {
    /// The option, e.g. `--pin`.
    pub option: String,
    /// The CPU index given.
    pub cpu: usize,
    /// `"no such CPU"` (not in the process's allowed set) or why the kernel refused it.
    pub reason: &'static str,
    /// The CPUs this process may run on ([`available_cpus`]).
    pub available: Vec<usize>,
}

/// Pins the calling thread to `cpu`, a value of the command-line option `option`, or refuses
/// it: a CPU outside this process's allowed set (one that does not exist, or that a cpuset
/// or `taskset` excludes) is never handed to `CPU_SET`, and the error names the option, the
/// value and the CPUs this process may run on.
///
/// # Errors
/// [`CpuOptionError`] when `cpu` is not one of those CPUs or the kernel refuses it.
pub fn pin_for_option(option: &str, cpu: usize) -> Result<(), CpuOptionError> {
    pin_current_thread(cpu).map_err(|e| CpuOptionError {
        option: option.to_owned(),
        cpu,
        reason: match e {
            ThreadPinError::CpuUnavailable { .. } => "no such CPU",
            ThreadPinError::Refused { .. } => "the kernel refused to pin to it",
        },
        available: available_cpus(),
    })
}

/// Gives the calling thread real-time priority `priority` under `SCHED_FIFO`
/// (`sched_setscheduler(0, ...)`, which on Linux applies to the calling
/// thread only).
///
/// ## Correctness
///
/// A `SCHED_FIFO` thread that never blocks starves everything below it on its
/// CPU; the kernel's RT throttling (`sched_rt_runtime_us`, 95 % by default)
/// is the only backstop. Pin the thread to a CPU you can spare.
pub fn set_fifo_priority(priority: i32) -> Result<(), FifoPrioritySetError> {
    // SAFETY: plain queries with a valid policy constant.
    let (min, max) =
        unsafe { (libc::sched_get_priority_min(libc::SCHED_FIFO), libc::sched_get_priority_max(libc::SCHED_FIFO)) };
    if priority < min || priority > max {
        return Err(FifoPrioritySetError::OutOfRange { priority, min, max });
    }
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: `param` is a valid sched_param; pid 0 means the calling thread.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if rc == 0 {
        return Ok(());
    }
    match errno() {
        libc::EPERM => Err(FifoPrioritySetError::PermissionDenied { priority }),
        errno => Err(FifoPrioritySetError::Os { priority, errno }),
    }
}

/// Locks all current and future pages of the process in RAM
/// (`mlockall(MCL_CURRENT | MCL_FUTURE)`), so the loop never takes a page
/// fault to disk.
pub fn lock_memory() -> Result<(), MemoryLockError> {
    // SAFETY: mlockall takes only flags.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 {
        return Ok(());
    }
    match errno() {
        libc::EPERM => Err(MemoryLockError::PermissionDenied),
        libc::ENOMEM => Err(MemoryLockError::LimitExceeded),
        errno => Err(MemoryLockError::Os { errno }),
    }
}

/// Undoes [`lock_memory`] (`munlockall`). Returns `true` on success.
pub fn unlock_memory() -> bool {
    // SAFETY: munlockall takes no arguments.
    unsafe { libc::munlockall() == 0 }
}

/// What to ask for in [`RealtimeSetup::apply`]. Default: nothing.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RealtimeRequest {
    /// Pin the calling thread to this CPU. Default `None`.
    pub cpu: Option<usize>,
    /// Give the calling thread this `SCHED_FIFO` priority (1..=99). Default
    /// `None`.
    pub fifo_priority: Option<i32>,
    /// Lock all memory with `mlockall`. Default `false`.
    pub lock_memory: bool,
}

impl RealtimeRequest {
    /// Asks for nothing.
    pub const fn new() -> Self {
        Self { cpu: None, fifo_priority: None, lock_memory: false }
    }

    /// Also pin to `cpu`.
    #[must_use]
    pub const fn pin_to(mut self, cpu: usize) -> Self {
        self.cpu = Some(cpu);
        self
    }

    /// Also ask for `SCHED_FIFO` at `priority`.
    #[must_use]
    pub const fn fifo_priority(mut self, priority: i32) -> Self {
        self.fifo_priority = Some(priority);
        self
    }

    /// Also lock memory.
    #[must_use]
    pub const fn lock_memory(mut self) -> Self {
        self.lock_memory = true;
        self
    }

    /// The request for a standby thread ([`crate::standby`]) beside a loop set up by this
    /// one: pinned to `cpu`, at `SCHED_FIFO` one below the loop's priority (at least 1; none
    /// if the loop has none), memory left alone (`mlockall` already holds the process).
    #[must_use]
    pub fn for_standby_on(self, cpu: usize) -> Self {
        Self { cpu: Some(cpu), fifo_priority: self.fifo_priority.map(|p| (p - 1).max(1)), lock_memory: false }
    }
}

/// The outcome of one request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Grant<E> {
    /// Not asked for.
    NotRequested,
    /// Asked for and granted.
    Granted,
    /// Asked for and refused, with the reason.
    Refused(E),
}

impl<E> Grant<E> {
    fn from_result(r: Option<Result<(), E>>) -> Self {
        match r {
            None => Self::NotRequested,
            Some(Ok(())) => Self::Granted,
            Some(Err(e)) => Self::Refused(e),
        }
    }

    /// `true` if asked for and refused.
    pub fn is_refused(&self) -> bool {
        matches!(self, Self::Refused(_))
    }
}

/// What [`RealtimeSetup::apply`] was granted; `Display` says it plainly, one
/// line per request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RealtimeSetup {
    /// The request this answers.
    pub request: RealtimeRequest,
    /// CPU pinning.
    pub pinning: Grant<ThreadPinError>,
    /// `SCHED_FIFO` priority.
    pub fifo: Grant<FifoPrioritySetError>,
    /// Memory locking.
    pub memory_lock: Grant<MemoryLockError>,
}

impl RealtimeSetup {
    /// Applies `request` to the calling thread (pinning, priority) and the
    /// process (memory lock), in that order. Never panics; refusals are in
    /// the result.
    pub fn apply(request: &RealtimeRequest) -> Self {
        Self {
            request: *request,
            pinning: Grant::from_result(request.cpu.map(pin_current_thread)),
            fifo: Grant::from_result(request.fifo_priority.map(set_fifo_priority)),
            memory_lock: Grant::from_result(request.lock_memory.then(lock_memory)),
        }
    }

    /// `true` if nothing asked for was refused.
    pub fn all_granted(&self) -> bool {
        self.refused_count() == 0
    }

    /// How many requests were refused (0..=3).
    pub fn refused_count(&self) -> usize {
        usize::from(self.pinning.is_refused())
            + usize::from(self.fifo.is_refused())
            + usize::from(self.memory_lock.is_refused())
    }
}

fn write_line<E: fmt::Display>(
    f: &mut fmt::Formatter<'_>,
    what: &str,
    grant: &Grant<E>,
    granted: fmt::Arguments<'_>,
) -> fmt::Result {
    match grant {
        Grant::NotRequested => writeln!(f, "  {what:<16}not requested"),
        Grant::Granted => writeln!(f, "  {what:<16}granted: {granted}"),
        Grant::Refused(e) => writeln!(f, "  {what:<16}REFUSED: {e}"),
    }
}

impl fmt::Display for RealtimeSetup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let refused = self.refused_count();
        if refused == 0 {
            writeln!(f, "real-time setup: everything requested was granted")?;
        } else {
            writeln!(f, "real-time setup: {refused} request(s) refused")?;
        }
        write_line(f, "cpu pinning", &self.pinning, format_args!("cpu {}", self.request.cpu.unwrap_or_default()))?;
        write_line(
            f,
            "SCHED_FIFO",
            &self.fifo,
            format_args!("priority {}", self.request.fifo_priority.unwrap_or_default()),
        )?;
        write_line(f, "memory lock", &self.memory_lock, format_args!("mlockall(MCL_CURRENT | MCL_FUTURE)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_list_is_written_as_the_kernel_writes_it_works() {
        assert_eq!(format_cpu_list(&[]), "none");
        assert_eq!(format_cpu_list(&[0]), "0");
        assert_eq!(format_cpu_list(&[3, 0, 1, 2, 6, 8, 9]), "0-3,6,8-9");
        assert_eq!(format_cpu_list(&[1, 1, 5]), "1,5");
    }

    #[test]
    fn pin_for_option_refuses_a_cpu_that_does_not_exist_fail() {
        // CPU_SETSIZE is 1024: the index that aborted inside CPU_SET, and far past any CPU here.
        let e = std::thread::spawn(|| pin_for_option("--pin", 1024)).join().unwrap().unwrap_err();
        assert_eq!((e.cpu, e.reason), (1024, "no such CPU"));
        let text = e.to_string();
        assert!(text.starts_with("--pin 1024: no such CPU; this process may run on CPUs "), "{text}");
        assert!(text.ends_with(&format_cpu_list(&available_cpus())), "{text}");
        let e = std::thread::spawn(|| pin_for_option("--pin", usize::MAX)).join().unwrap().unwrap_err();
        assert_eq!(e.cpu, usize::MAX);
    }

    #[test]
    fn pin_for_option_pins_to_an_allowed_cpu_works() {
        let cpu = *available_cpus().last().expect("some CPU");
        let pinned = std::thread::spawn(move || {
            pin_for_option("--pin", cpu).map(|()| core_affinity::get_core_ids().map(|ids| ids.len()))
        });
        // The pinned thread's own mask holds one CPU (core_affinity lists the thread's mask).
        assert_eq!(pinned.join().unwrap(), Ok(Some(1)));
    }
}
