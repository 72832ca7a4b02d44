//! A request above the memory available is refused with both sizes; this file caps its
//! process at 1 MiB so the figures do not depend on the machine.

use lamina_input::memory::set_process_limit;
use lamina_input::{FileLimit, FileReadError, MemoryCheckError, MemorySource, check_memory, memory_budget};

#[test]
fn memory_above_limit_fails() {
    set_process_limit(1 << 20);
    let budget = memory_budget().unwrap();
    assert!(budget.bytes.is_some_and(|b| b <= 1 << 20), "{budget:?}");
    assert!(check_memory("a small request", 1 << 19).is_ok());
    let e = check_memory("a 2 MiB request", 2 << 20).unwrap_err();
    assert_eq!(
        e,
        MemoryCheckError::TooLarge {
            what: "a 2 MiB request".into(),
            needed_bytes: 2 << 20,
            available_bytes: 1 << 20,
            source: MemorySource::Process
        }
    );
    assert_eq!(
        e.to_string(),
        "a 2 MiB request needs about 2.00 MiB (2,097,152 bytes), more than the 1.00 MiB (1,048,576 bytes) \
         available (the limit this program set)"
    );

    // A file whose parser takes 1000 bytes per byte: 2 KiB of file is refused.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.xml");
    std::fs::write(&path, vec![b' '; 2048]).unwrap();
    let limit = FileLimit::new("model file", 1 << 30).memory_per_byte(1000);
    let e = lamina_input::read_bytes(&path, &limit).unwrap_err();
    assert!(
        matches!(&e, FileReadError::Memory { error: MemoryCheckError::TooLarge { needed_bytes: 2_048_000, .. }, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("reading this model file (2.00 KiB (2,048 bytes)) needs about"), "{e}");
}

/// Set in the child of [`memory_under_rlimit_as_is_the_limit_less_the_virtual_size_works`].
const CHILD: &str = "LAMINA_INPUT_RLIMIT_CHILD";

/// The process's virtual size, bytes (`/proc/self/statm`'s first field, in pages).
fn virtual_bytes() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap();
    let pages: u64 = statm.split_whitespace().next().unwrap().parse().unwrap();
    // SAFETY: sysconf reads a configuration value.
    pages * unsafe { libc::sysconf(libc::_SC_PAGESIZE) } as u64
}

#[test]
fn memory_under_rlimit_as_is_the_limit_less_the_virtual_size_works() {
    const LIMIT: u64 = 3 << 30;
    if std::env::var_os(CHILD).is_some() {
        // The child, under RLIMIT_AS = 3 GiB: the budget is at most the limit less what is
        // mapped now, and a request above it is refused naming RLIMIT_AS.
        let before = virtual_bytes();
        let budget = memory_budget().unwrap();
        let after = virtual_bytes();
        let bytes = budget.bytes.unwrap();
        let slack = 1 << 20;
        // The smallest source: never more than the limit less the mapped size.
        assert!(bytes + before.min(after) <= LIMIT + slack, "{budget:?}, virtual {before}..{after} bytes");
        // Unless the host or its cgroup has less, it is the limit less the mapped size.
        if budget.source == Some(MemorySource::AddressSpace) {
            assert!(bytes + before.max(after) + slack >= LIMIT, "{budget:?}, virtual {before}..{after} bytes");
            let e = check_memory("a 3 GiB table", LIMIT).unwrap_err();
            assert!(e.to_string().ends_with("available (RLIMIT_AS minus this process's virtual size)"), "{e}");
        }
        return;
    }
    let mut cmd = std::process::Command::new(std::env::current_exe().unwrap());
    cmd.args(["--exact", "memory_under_rlimit_as_is_the_limit_less_the_virtual_size_works", "--test-threads=1"])
        .env(CHILD, "1")
        .env_remove(lamina_input::memory::LIMIT_ENV);
    // SAFETY: between fork and exec the closure calls only setrlimit(2), which is
    // async-signal-safe, and builds its error from errno.
    unsafe {
        std::os::unix::process::CommandExt::pre_exec(&mut cmd, || {
            let limit = libc::rlimit { rlim_cur: LIMIT, rlim_max: LIMIT };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let out = cmd.output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}\n{}", text, String::from_utf8_lossy(&out.stderr));
    assert!(text.contains("1 passed"), "the child ran the test: {text}");
}
