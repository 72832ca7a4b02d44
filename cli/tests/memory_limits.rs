//! Models too large for the memory the process may take are refused before they are
//! allocated, whatever limits the process. Each case runs `lamina` in a child process under a
//! 4 GiB address-space limit (`RLIMIT_AS`, set with `setrlimit` between fork and exec): a
//! model allocated before its estimate is checked aborts there ("memory allocation of N bytes
//! failed"), and one whose loop runs on without a check never ends. Each must instead exit 1
//! with a message naming the input, the estimate in bytes and the budget in bytes.
//!
//! The estimates are computed here from the lattice's closed-form counts
//! (`docs/yardstick-scene.md`) and the model's bytes per node and spring.

use lamina_core::model::{NODE_BYTES, RUN_MEMORY_FACTOR, SPRING_BYTES, TRIANGLE_BYTES};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The address-space limit of every child, bytes.
const LIMIT: u64 = 4 << 30;

/// `lamina args` with `RLIMIT_AS` at [`LIMIT`] and `env` set; a watchdog (not a speed bound)
/// kills a child that runs for 10 minutes, which is what a missing check looks like.
fn lamina_limited(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_lamina"));
    cmd.args(args).env_remove("LAMINA_MEMORY_LIMIT").stdout(Stdio::piped()).stderr(Stdio::piped());
    for (k, v) in env {
        cmd.env(k, v);
    }
    // SAFETY: between fork and exec the closure calls only setrlimit(2), which is
    // async-signal-safe, and builds its error from errno.
    unsafe {
        cmd.pre_exec(|| {
            let limit = libc::rlimit { rlim_cur: LIMIT, rlim_max: LIMIT };
            if libc::setrlimit(libc::RLIMIT_AS, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let mut child = cmd.spawn().unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(600) {
            let _ = child.kill();
            panic!("lamina {args:?} still running after 600 s under a {LIMIT}-byte RLIMIT_AS");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

/// `n` as the messages write it: `1,234,567`.
fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// The closed-form counts of an `x × y × z` lattice with the yardstick's nine forward
/// neighbours: nodes, springs, and the `2·x·z` top-face triangles the estimate allows.
fn lattice_counts(x: u64, y: u64, z: u64) -> (u64, u64, u64) {
    let springs = (x - 1) * y * z
        + x * (y - 1) * z
        + x * y * (z - 1)
        + 2 * ((x - 1) * (y - 1) * z + (x - 1) * y * (z - 1) + x * (y - 1) * (z - 1));
    (x * y * z, springs, 2 * x * z)
}

/// Bytes a run of this lattice is estimated to take.
fn run_estimate(x: u64, y: u64, z: u64) -> u64 {
    let (nodes, springs, triangles) = lattice_counts(x, y, z);
    (nodes * NODE_BYTES + springs * SPRING_BYTES + triangles * TRIANGLE_BYTES) * RUN_MEMORY_FACTOR
}

/// How a refusal gives `estimate`: "needs about X GiB (N bytes), more than the".
fn needed(estimate: u64) -> String {
    format!(" ({} bytes), more than the ", grouped(estimate))
}

/// Asserts `out` is a clean refusal (exit 1, no panic, no abort) whose stderr holds every one
/// of `parts` and a budget of at most [`LIMIT`] bytes; returns stderr.
fn assert_refused(out: &Output, parts: &[&str]) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(1), "{:?}\n{err}\n{}", out.status, String::from_utf8_lossy(&out.stdout));
    assert!(!err.contains("panicked") && !err.contains("memory allocation of"), "{err}");
    for part in parts {
        assert!(err.contains(part), "no '{part}' in: {err}");
    }
    let budget = budget_bytes(&err);
    assert!(budget > 0 && budget <= LIMIT, "budget {budget} bytes in: {err}");
    err
}

/// The budget a refusal gives: N in "more than the X GiB (N bytes) available".
fn budget_bytes(err: &str) -> u64 {
    let tail = err.split("more than the ").nth(1).unwrap_or_else(|| panic!("no budget in: {err}"));
    let inside = tail.split('(').nth(1).and_then(|t| t.split(" bytes)").next()).unwrap();
    inside.replace(',', "").parse().unwrap_or_else(|_| panic!("no byte count in: {err}"))
}

/// The sources the budget may come from under the limit: the limit itself, unless the host
/// or its cgroup has even less.
fn assert_budget_source(err: &str) {
    let sources = ["RLIMIT_AS minus this process's virtual size", "MemAvailable", "the cgroup's memory.max"];
    assert!(sources.iter().any(|s| err.contains(&format!("available ({s}"))), "{err}");
}

fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("lamina_memory_limits_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The shipped block scene with its `[model]` table's `nx` and `nz` replaced, in `dir`.
fn block_scene(dir: &Path, nx: &str, nz: &str) -> PathBuf {
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/block.toml"))
        .unwrap()
        .replace("nx = 24\n", &format!("nx = {nx}\n"))
        .replace("nz = 12\n", &format!("nz = {nz}\n"));
    assert!(text.contains(&format!("nx = {nx}\n")) && text.contains(&format!("nz = {nz}\n")), "block.toml changed");
    let path = dir.join("block.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn run_scene(scene: &Path, env: &[(&str, &str)]) -> Output {
    lamina_limited(&["run", "--no-publish", "--quiet", "--seconds", "0.05", "--scene", scene.to_str().unwrap()], env)
}

#[test]
fn memory_limits_layered_block_of_5e7_nodes_is_refused_fail() {
    // 2,886 x 6 x 2,886 nodes: within the block's 5e7-node cap, about 190 GB to run.
    let dir = scratch("block");
    let scene = block_scene(&dir, "2886", "2886");
    let (nodes, springs, _) = lattice_counts(2886, 6, 2886);
    let needed = needed(run_estimate(2886, 6, 2886));
    let what = format!("layered block 2886 x 6 x 2886 nodes ({nodes} nodes, {springs} springs)");
    let err = assert_refused(&run_scene(&scene, &[]), &[scene.to_str().unwrap(), &what, &needed]);
    assert_budget_source(&err);
    // A LAMINA_MEMORY_LIMIT above the address-space limit does not lift it.
    let err = assert_refused(&run_scene(&scene, &[("LAMINA_MEMORY_LIMIT", "100000000000")]), &[&what, &needed]);
    assert_budget_source(&err);
    // One below it is the budget, exactly.
    let err = assert_refused(&run_scene(&scene, &[("LAMINA_MEMORY_LIMIT", "2000000000")]), &[&what, &needed]);
    assert!(err.contains("1.86 GiB (2,000,000,000 bytes) available (LAMINA_MEMORY_LIMIT)"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn memory_limits_block_nx_nz_2_pow_32_is_refused_fail() {
    // nx * nz * rows overflows 64 bits: the estimate is more than 16 EiB.
    let dir = scratch("block_2_32");
    let scene = block_scene(&dir, "4294967296", "4294967296");
    let what = "layered block 4294967296 x 6 x 4294967296 nodes (more than 2^64 nodes, more than 2^64 springs)";
    let err = assert_refused(&run_scene(&scene, &[]), &[scene.to_str().unwrap(), what, "needs more than 16 EiB"]);
    assert_budget_source(&err);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn memory_limits_yardstick_scene_1000_cubed_is_refused_fail() {
    let dir = scratch("yardstick_scene");
    let scene = dir.join("yardstick.toml");
    let text =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/block.toml")).unwrap();
    let model_table = text.find("[model]").unwrap();
    let solver_table = text.find("[solver]").unwrap();
    let text = format!(
        "{}[model]\nkind = \"yardstick\"\nsize = \"1000x1000x1000\"\n\n{}",
        &text[..model_table],
        &text[solver_table..]
    );
    std::fs::write(&scene, text).unwrap();
    let (nodes, springs, _) = lattice_counts(1000, 1000, 1000);
    let what = format!("yardstick lattice 1000x1000x1000 ({nodes} nodes, {springs} springs)");
    let needed = needed(run_estimate(1000, 1000, 1000));
    let err = assert_refused(&run_scene(&scene, &[]), &[scene.to_str().unwrap(), &what, &needed]);
    assert_budget_source(&err);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn memory_limits_yardstick_command_100000_cubed_is_refused_fail() {
    let dir = scratch("yardstick_cmd");
    let out_csv = dir.join("positions.csv");
    let out = lamina_limited(&["yardstick", "--size", "100000x100000x100000", "--out", out_csv.to_str().unwrap()], &[]);
    let (nodes, springs, _) = lattice_counts(100_000, 100_000, 100_000);
    let what = format!(
        "--size 100000x100000x100000: yardstick lattice 100000x100000x100000 ({nodes} nodes, {springs} springs)"
    );
    let needed = needed(run_estimate(100_000, 100_000, 100_000));
    let err = assert_refused(&out, &[&what, &needed]);
    assert_budget_source(&err);
    assert!(!out_csv.exists(), "nothing written");
    // The benchmark refuses the same size before timing anything.
    let out = lamina_limited(&["bench", "yardstick", "--sizes", "small,100000x100000x100000", "--no-c"], &[]);
    assert_refused(&out, &["--sizes 100000x100000x100000: yardstick lattice 100000x100000x100000", &needed]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn memory_limits_shipped_block_runs_under_the_limit_works() {
    // The budget is what is left under the limit, not a refusal of everything: the shipped
    // block scene runs under the same 4 GiB limit.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/scenes/block.toml");
    let out = run_scene(&scene, &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}\n{err}", out.status);
    let dir = scratch("yardstick_small");
    let out_csv = dir.join("positions.csv");
    let out =
        lamina_limited(&["yardstick", "--size", "small", "--steps", "10", "--out", out_csv.to_str().unwrap()], &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // A header and one row per node of the 39 x 7 x 10 lattice.
    assert_eq!(std::fs::read_to_string(&out_csv).unwrap().lines().count(), 1 + 2730);
    std::fs::remove_dir_all(&dir).unwrap();
}
