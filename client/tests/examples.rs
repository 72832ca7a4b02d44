//! The client examples build and run against a live `lamina run` (default scene): C
//! (`examples/c`, gcc, linked with the static liblamina_client.a), C++ (`examples/cpp`, CMake and
//! g++, the RAII wrapper `lamina.hpp`) and C# (`examples/csharp`, Mono's `mcs`, run with
//! `mono`). Each reads 1,000 frames checking the sequence and node count and presses the
//! sphere 2, 4 and 6 mm deep, the force rising; here its exit status and what it printed are
//! checked against the default scene's model.
//!
//! A missing compiler prints SKIP, unless `LAMINA_REQUIRE_CLIENT_EXAMPLES` is set (CI sets
//! it), then the test fails.

mod common;

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::sync::Once;
use std::time::Duration;

use common::{SERIAL, start_core, stop};
use lamina_core::scene::Scene;
use lamina_tests::{bin_dir, unique_prefix, wait_with_watchdog};

/// Set to fail instead of skipping when a compiler is missing.
const REQUIRE_ENV: &str = "LAMINA_REQUIRE_CLIENT_EXAMPLES";

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The folder of liblamina_client.so and .a, after one `cargo build -p lamina-client` in this
/// test's profile (a test build does not put the cdylib beside the binaries).
fn library_dir() -> PathBuf {
    static BUILD: Once = Once::new();
    BUILD.call_once(|| {
        let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
        cmd.args(["build", "-p", "lamina-client", "--lib"]);
        if bin_dir().ends_with("release") {
            cmd.arg("--release");
        }
        assert!(cmd.status().expect("running cargo build").success(), "building lamina-client failed");
    });
    let dir = bin_dir();
    for lib in ["liblamina_client.so", "liblamina_client.a"] {
        assert!(dir.join(lib).exists(), "{} has no {lib}", dir.display());
    }
    dir
}

/// Whether `program` runs (`--version`); if not, SKIP (or fail when required).
fn have(program: &str, test: &str) -> bool {
    let ok = Command::new(program).arg("--version").output().is_ok_and(|o| o.status.success());
    if !ok {
        assert!(std::env::var_os(REQUIRE_ENV).is_none(), "{test}: {REQUIRE_ENV} is set but {program} is not installed");
        eprintln!("SKIP {test}: {program} is not installed (apt-get install it), or set {REQUIRE_ENV} to fail instead");
    }
    ok
}

/// A fresh scratch folder for one build.
fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(unique_prefix(tag));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs a build step; fails the test with its output if it fails.
fn build(cmd: &mut Command, what: &str) {
    let out = cmd.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed: {}\n{}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// Runs the built example `cmd` against a fresh core and checks what it printed.
fn run_against_core(mut cmd: Command, what: &str) {
    let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let prefix = unique_prefix("client_example");
    let core = start_core(&prefix);
    let out_path = std::env::temp_dir().join(format!("{prefix}.out"));
    let err_path = std::env::temp_dir().join(format!("{prefix}.err"));
    let mut child = cmd
        .args(["--prefix", &prefix, "--frames", "1000"])
        .stdout(Stdio::from(std::fs::File::create(&out_path).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(&err_path).unwrap()))
        .spawn()
        .unwrap_or_else(|e| panic!("starting {what}: {e}"));
    let status = wait_with_watchdog(&mut child, Duration::from_secs(240), what);
    stop(core);
    let out = std::fs::read_to_string(&out_path).unwrap_or_default();
    let err = std::fs::read_to_string(&err_path).unwrap_or_default();
    let _ = (std::fs::remove_file(&out_path), std::fs::remove_file(&err_path));
    eprintln!("{what}:\n{out}{err}");
    assert!(status.success(), "{what} failed: {status}\n{out}\n{err}");

    let model = Scene::builtin_default().build_model().unwrap();
    let n = model.nodes.position.len();
    assert!(out.contains(&format!("topology of '{}': {n} nodes", model.name)), "{out}");
    assert!(out.contains("1000 frames, sequence "), "{out}");
    assert!(out.contains(&format!(" lost, {n} nodes each")), "{out}");
    let forces: Vec<f64> = out
        .lines()
        .filter_map(|l| l.strip_prefix("depth ")?.split("force up ").nth(1)?.split(' ').next()?.parse().ok())
        .collect();
    assert_eq!(forces.len(), 3, "three depths pressed: {out}");
    assert!(forces[0] > 0.0 && forces[0] < forces[1] && forces[1] < forces[2], "force rises with depth: {forces:?}");
    assert_eq!(out.lines().last(), Some("ok"), "{out}");
}

fn include_dir() -> PathBuf {
    repo().join("client/include")
}

#[test]
fn c_example_builds_and_presses_a_live_core_works() {
    let test = "c_example_builds_and_presses_a_live_core_works";
    if !have("gcc", test) {
        return;
    }
    let lib = library_dir();
    let exe = scratch("c_example").join("lamina_press");
    build(
        Command::new("gcc")
            .args(["-std=c11", "-O2", "-Wall", "-Wextra", "-Werror", "-I"])
            .arg(include_dir())
            .arg(repo().join("examples/c/lamina_press.c"))
            .arg(lib.join("liblamina_client.a"))
            .args(["-lpthread", "-ldl", "-lm", "-o"])
            .arg(&exe),
        "gcc examples/c/lamina_press.c with liblamina_client.a",
    );
    run_against_core(Command::new(&exe), "examples/c/lamina_press");
}

#[test]
fn cpp_example_builds_with_cmake_and_presses_a_live_core_works() {
    let test = "cpp_example_builds_with_cmake_and_presses_a_live_core_works";
    if !have("g++", test) || !have("cmake", test) {
        return;
    }
    let lib = library_dir();
    let build_dir = scratch("cpp_example");
    build(
        Command::new("cmake")
            .arg("-S")
            .arg(repo().join("examples/cpp"))
            .arg("-B")
            .arg(&build_dir)
            .arg(format!("-DLAMINA_LIBRARY_DIR={}", lib.display()))
            .arg("-DCMAKE_CXX_FLAGS=-Werror"),
        "cmake configure examples/cpp",
    );
    build(Command::new("cmake").arg("--build").arg(&build_dir), "cmake --build examples/cpp");
    run_against_core(Command::new(build_dir.join("lamina_press")), "examples/cpp/lamina_press");
}

#[test]
fn csharp_example_builds_with_mono_and_presses_a_live_core_works() {
    let test = "csharp_example_builds_with_mono_and_presses_a_live_core_works";
    if !have("mcs", test) || !have("mono", test) {
        return;
    }
    let lib = library_dir();
    let exe = scratch("csharp_example").join("lamina_press.exe");
    let src = repo().join("examples/csharp");
    build(
        Command::new("mcs")
            .args(["-warnaserror+", &format!("-out:{}", exe.display())])
            .arg(src.join("Lamina.cs"))
            .arg(src.join("Press.cs")),
        "mcs examples/csharp",
    );
    let mut cmd = Command::new("mono");
    cmd.arg(&exe).env("LD_LIBRARY_PATH", &lib);
    run_against_core(cmd, "examples/csharp/lamina_press.exe");
}
