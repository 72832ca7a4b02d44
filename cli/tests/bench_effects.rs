//! `lamina bench effects` runs on the built-in default scene (whose own solver is implicit, with
//! no critical step) and on the layered block, and prints a row for every configuration.

use std::process::Command;

fn bench_effects(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_lamina"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["bench", "effects", "--batch-seconds", "0.002"])
        .args(args)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    stdout
}

/// The per-step time (us) of the row named `name`.
fn row(stdout: &str, name: &str) -> f64 {
    let line = stdout.lines().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no row {name}: {stdout}"));
    line[name.len()..].split_whitespace().next().and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("{line}"))
}

#[test]
fn bench_effects_times_every_configuration_works() {
    for args in [&[][..], &["--scene", "../config/scenes/block.toml"][..]] {
        let stdout = bench_effects(args);
        assert!(stdout.contains("symplectic_euler"), "{stdout}");
        for name in ["springs only", "+ bone (fixed + moving)", "+ sphere tool", "+ guard", "every effect on"] {
            let us = row(&stdout, name);
            assert!(us.is_finite() && us > 0.0, "{name}: {us} us\n{stdout}");
        }
    }
}
