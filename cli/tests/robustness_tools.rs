//! Bad option values of the bridge tools `lamina-listen` and `lamina-publish-probe` are
//! refused at start, naming the option, the value and the bound, before anything is opened.

use std::process::Command;

/// Runs `bin` with `args`; returns its exit status's success and its stderr.
fn run(bin: &str, args: &[&str]) -> (bool, String) {
    let out = Command::new(bin).args(args).output().expect("the tool starts");
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The CPUs this test may run on, as the tools list them.
fn cpus() -> String {
    lamina_rt::format_cpu_list(&lamina_rt::available_cpus())
}

const LISTEN: &str = env!("CARGO_BIN_EXE_lamina-listen");
const PROBE: &str = env!("CARGO_BIN_EXE_lamina-publish-probe");

#[test]
fn robustness_pin_to_a_cpu_that_does_not_exist_fail() {
    // 1024 is CPU_SETSIZE: passed to CPU_SET it aborted the process (no unwinding).
    for bin in [LISTEN, PROBE] {
        for cpu in ["1024", "4096"] {
            let (ok, err) = run(bin, &["--prefix", "robust_pin_none", "--seconds", "1", "--pin", cpu]);
            assert!(!ok, "{bin} --pin {cpu} exits non-zero");
            let expect = format!("--pin {cpu}: no such CPU; this process may run on CPUs {}", cpus());
            assert!(err.contains(&expect), "{bin}: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
}

#[test]
fn robustness_listen_seconds_outside_the_bound_fail() {
    for (given, shown) in
        [("nan", "NaN"), ("inf", "inf"), ("-inf", "-inf"), ("-5", "-5"), ("0", "0"), ("1e300", "1e300"), ("2e9", "2e9")]
    {
        for bin in [LISTEN, PROBE] {
            let (ok, err) = run(bin, &["--prefix", "robust_seconds_none", &format!("--seconds={given}")]);
            assert!(!ok, "{bin} --seconds {given} exits non-zero");
            let expect = format!("--seconds {shown}: must be a number of seconds above 0 and at most 1e9");
            assert!(err.contains(&expect), "{bin} --seconds {given}: {err}");
        }
    }
}

#[test]
fn robustness_probe_rate_outside_the_bound_fail() {
    for (given, shown) in [("nan", "NaN"), ("0", "0"), ("1e-300", "1e-300"), ("1e7", "1e7")] {
        let (ok, err) = run(PROBE, &["--prefix", "robust_rate_none", &format!("--rate={given}")]);
        assert!(!ok, "--rate {given} exits non-zero");
        let expect = format!("--rate {shown}: must be from 0.001 to 1e6 frames per second");
        assert!(err.contains(&expect), "--rate {given}: {err}");
    }
}

#[test]
fn robustness_probe_nodes_outside_the_bound_fail() {
    // 1e10 nodes sized a 17.5 TB sparse segment in /dev/shm.
    for nodes in ["0", "1000001", "10000000000"] {
        let (ok, err) = run(PROBE, &["--prefix", "robust_nodes_none", "--nodes", nodes]);
        assert!(!ok, "--nodes {nodes} exits non-zero");
        assert!(err.contains(&format!("--nodes {nodes}: must be from 1 to 1000000")), "--nodes {nodes}: {err}");
    }
}
