//! Option and file values outside their bounds are refused before anything runs: the error
//! names the option or the file and field, the value given and the bound, and the command
//! exits non-zero without panicking.

use std::process::{Command, Output};

fn lamina(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lamina")).current_dir(env!("CARGO_MANIFEST_DIR")).args(args).output().unwrap()
}

/// Asserts `out` is a clean refusal (exit 1, no panic) whose stderr holds every one of `parts`.
fn assert_refused(out: &Output, parts: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}\n{}", String::from_utf8_lossy(&out.stdout));
    assert!(!err.contains("panicked"), "{err}");
    for part in parts {
        assert!(err.contains(part), "no '{part}' in: {err}");
    }
}

#[test]
fn batch_seconds_beyond_its_range_is_refused_fail() {
    for bench in ["effects", "yardstick"] {
        for (value, shown) in [("1e300", "1e300"), ("nan", "NaN"), ("0", "0"), ("-1", "-1"), ("601", "601")] {
            let out = lamina(&["bench", bench, &format!("--batch-seconds={value}")]);
            assert_refused(&out, &[&format!("--batch-seconds {shown}:"), "from 0.001 to 600 s"]);
        }
    }
}

#[test]
fn fit_grid_sizes_beyond_the_scene_bounds_are_refused_fail() {
    for (option, grid) in [("--grid-sizes", "100000x100000"), ("--grid-sizes", "2x10"), ("--model-grid", "39x0")] {
        let out = lamina(&["fit", option, grid]);
        assert_refused(&out, &[&format!("{option} '{grid}'"), "columns must be 3 to 4096 and rows 1 to 4096"]);
    }
}

#[test]
fn profile_lengths_and_node_counts_beyond_their_bounds_are_refused_before_any_process_fail() {
    let dir = std::env::temp_dir().join(format!("lamina_profile_bounds_{}", std::process::id()));
    let out_dir = dir.to_str().unwrap();
    let out = lamina(&["profile", "--seconds", "1e300", "--out", out_dir]);
    assert_refused(&out, &["--seconds 1e300: must be a number of seconds above 0 and at most 3600"]);
    let out = lamina(&["profile", "--seconds", "1", "--nodes", "2769,10000000000", "--out", out_dir]);
    assert_refused(&out, &["--nodes 10000000000: must be from 1 to 1000000"]);
    assert!(!dir.exists(), "refused before anything was written");
}

/// The CPUs this process may run on as the kernel lists them (`Cpus_allowed_list`, e.g. `0-1`).
fn allowed_cpu_list() -> String {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("Cpus_allowed_list:")).unwrap();
    line["Cpus_allowed_list:".len()..].trim().to_owned()
}

/// The default scene with `lines` added to its `[realtime]` table, written into a fresh folder.
fn realtime_scene(tag: &str, lines: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("lamina_{tag}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let default = include_str!("../../config/scenes/default.toml");
    assert_eq!(default.matches("[realtime]\n").count(), 1, "default.toml's [realtime] table changed");
    let path = dir.join("scene.toml");
    std::fs::write(&path, default.replace("[realtime]\n", &format!("[realtime]\n{lines}\n"))).unwrap();
    (dir, path)
}

#[test]
fn realtime_cpus_that_do_not_exist_are_refused_naming_the_cpus_that_do_fail() {
    let allowed = allowed_cpu_list();
    for field in ["cpu", "standby_cpu"] {
        let (dir, scene) = realtime_scene(&format!("cpu_{field}"), &format!("{field} = 99999"));
        let out = lamina(&["run", "--no-publish", "--quiet", "--seconds", "0.05", "--scene", scene.to_str().unwrap()]);
        let expected = format!("realtime.{field} 99999: no such CPU; this process may run on CPUs {allowed}");
        assert_refused(&out, &["scene.toml: ", &expected]);
        let _ = std::fs::remove_dir_all(&dir);
    }
    for option in ["--cpu", "--standby-cpu"] {
        let out = lamina(&["bench", "noise", "--seconds", "0.05", option, "99999"]);
        assert_refused(&out, &[&format!("{option} 99999: no such CPU; this process may run on CPUs {allowed}")]);
    }
}

#[test]
fn a_node_frame_cutoff_below_one_microsecond_is_refused_fail() {
    let (dir, scene) = realtime_scene("cutoff", "node_frame_cutoff_us = 1e-300");
    let out = lamina(&["run", "--no-publish", "--quiet", "--seconds", "0.05", "--scene", scene.to_str().unwrap()]);
    assert_refused(&out, &["realtime.node_frame_cutoff_us", "1e-300 µs: must be finite and at least 1 µs"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn fit_targets_whose_curve_overflows_are_refused_naming_file_and_field_fail() {
    let dir = std::env::temp_dir().join(format!("lamina_fit_overflow_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/materials");
    for name in ["skin", "fat", "muscle"] {
        let text = std::fs::read_to_string(shipped.join(format!("{name}.toml"))).unwrap();
        std::fs::write(dir.join(format!("{name}.toml")), text.replace("alpha = 20.0", "alpha = 1e300")).unwrap();
    }
    let out_dir = dir.join("out");
    let out = lamina(&[
        "fit",
        "--materials",
        dir.to_str().unwrap(),
        "--out",
        out_dir.to_str().unwrap(),
        "--grid-sizes",
        "24x6",
        "--model-grid",
        "24x6",
    ]);
    assert_refused(&out, &["muscle.toml: curve: the curve's stress at max_strain is inf Pa, beyond 1e12 Pa"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_capacity_on_a_grid_it_cannot_build_measures_nothing_and_fails() {
    let dir = std::env::temp_dir().join(format!("lamina_capacity_unbuilt_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    // 64 MB of memory: the 24x6 limb fits, the 1000x400 one (about 2.8 million nodes) does not.
    let out = Command::new(env!("CARGO_BIN_EXE_lamina"))
        .env("LAMINA_MEMORY_LIMIT", "64000000")
        .args(["bench", "capacity", "--grids", "24x6,1000x400", "--scenes", "", "--fifo-priority", "0", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert_refused(&out, &["nothing measured: 1 model(s) could not be built: grid 1000x400: "]);
    assert!(!dir.exists(), "no CSV or plot written");
    let missing = dir.join("missing.toml");
    let out = lamina(&[
        "bench",
        "capacity",
        "--grids",
        "",
        "--scenes",
        missing.to_str().unwrap(),
        "--out",
        dir.to_str().unwrap(),
    ]);
    assert_refused(&out, &["could not be built: scene ", "missing.toml"]);
    assert!(!dir.exists(), "no CSV or plot written");
}

#[test]
fn refused_values_are_echoed_in_scientific_notation_fail() {
    let cases: [(&[&str], &str); 6] = [
        (&["bench", "noise", "--work-us", "1e300"], "--work-us 1e300: at least 0 and less than the period"),
        (
            &["bench", "noise", "--seconds", "1e300"],
            "--seconds 1e300: must be a number of seconds above 0 and at most 3600",
        ),
        (&["bench", "stalls", "--work-us", "1e300"], "--work-us 1e300: at least 0 and less than the period"),
        (&["bench", "stalls", "--seconds=-1e300"], "--seconds -1e300: must be a number of seconds above 0"),
        (&["bench", "capacity", "--max-seconds", "1e300"], "--max-seconds 1e300: between 0.1 and 3600"),
        (&["bench", "capacity", "--region-radius=-1e-300"], "--region-radius -1e-300: a length in m greater than 0"),
    ];
    for (args, expected) in cases {
        let out = lamina(args);
        assert_refused(&out, &[expected]);
        let err = String::from_utf8_lossy(&out.stderr);
        // No value printed digit by digit: 1e300 in full is 301 digits.
        assert!(err.split(|c: char| !c.is_ascii_digit()).all(|run| run.len() <= 12), "{args:?}: {err}");
    }
}
