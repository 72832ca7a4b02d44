//! `lamina bench capacity`: a scene measured alone (no generated grid beside it), and bad
//! options refused by name before anything is measured (a grid whose model does not build is
//! reported and skipped instead, like a scene that does not load).

use lamina_tests::{assert_lamina_refuses, run_lamina};

fn capacity(args: &[&str]) -> (bool, String) {
    run_lamina(&[&["bench", "capacity"], args].concat())
}

#[test]
fn bench_capacity_measures_a_scene_alone_works() {
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../config/scenes/default.toml");
    let out = std::env::temp_dir().join(format!("lamina_capacity_{}", std::process::id()));
    let (ok, text) = capacity(&[
        "--grids",
        "",
        "--scenes",
        scene,
        "--solvers",
        "implicit_factored",
        "--threads",
        "1",
        "--ticks",
        "5",
        "--max-seconds",
        "0.1",
        "--fifo-priority",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{text}");
    // One model: the scene's limb (24 x 6, 1,032 nodes), and no generated grid.
    let rows: Vec<&str> = text.lines().filter(|l| l.contains("implicit_factored") && l.contains(" 1032 ")).collect();
    assert!(!rows.is_empty(), "{text}");
    assert!(!text.lines().any(|l| l.starts_with("cylinder-limb")), "{text}");
    assert!(out.join("capacity.csv").is_file(), "{text}");
    let _ = std::fs::remove_dir_all(&out);
}

#[test]
fn bench_capacity_refuses_bad_options_by_name_fails() {
    assert_lamina_refuses(
        &["bench", "capacity"],
        &[
            (&["--grids", "", "--scenes", ""], "nothing to measure"),
            (&["--grids", "24"], "--grids '24': expected WxH"),
            (&["--ratio", "1"], "--ratio 1"),
            (&["--threads", "0"], "thread count '0'"),
            (&["--ticks", "2"], "--ticks 2"),
        ],
    );
}
