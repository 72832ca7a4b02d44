//! The lowest thread priority, for work the loop must never wait on.

/// Puts the calling thread in `SCHED_IDLE` and lets it run on every online CPU (Linux;
/// elsewhere a no-op). A thread spawned by the bulk's inherits its priority and its CPU, which
/// the bulk keeps busy on a large model; at the lowest priority the builder takes only what
/// the bulk and the loop leave idle on any CPU, and the loop's wake-up preempts it at once.
pub(super) fn lower_this_threads_priority() {
    #[cfg(target_os = "linux")]
    // SAFETY: sysconf, sched_setscheduler and sched_setaffinity on the calling thread (pid 0)
    // with a valid parameter and a CPU set built by the libc macros.
    unsafe {
        let param = libc::sched_param { sched_priority: 0 };
        // Lowering a thread's own priority is always allowed; on failure it keeps the bulk's.
        libc::sched_setscheduler(0, libc::SCHED_IDLE, &param);
        // Every online CPU (the inherited mask holds the bulk's alone); the kernel keeps the
        // ones the process may use. On failure it stays on the bulk's CPU.
        let online = libc::sysconf(libc::_SC_NPROCESSORS_ONLN).clamp(1, libc::CPU_SETSIZE as libc::c_long);
        let mut every: libc::cpu_set_t = std::mem::zeroed();
        for cpu in 0..online as usize {
            libc::CPU_SET(cpu, &mut every);
        }
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &every);
    }
}
