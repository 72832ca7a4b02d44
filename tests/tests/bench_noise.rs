//! `lamina bench noise`: the machine's own misses, measured by the loop of `lamina run` with
//! synthetic work. Checks the table it prints and that bad options are refused by name.

use lamina_tests::{assert_lamina_refuses, run_lamina};

fn noise(args: &[&str]) -> (bool, String) {
    run_lamina(&[&["bench", "noise"], args].concat())
}

#[test]
fn bench_noise_prints_one_row_per_sleep_slice_works() {
    let (ok, text) =
        noise(&["--seconds", "0.2", "--work-us", "50", "--working-set-kib", "64", "--sleep-slices-us", "0,100"]);
    assert!(ok, "{text}");
    let rows: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| l.starts_with("| one sleep") || l.starts_with("| 100 µs"))
        .map(|l| l.split('|').map(str::trim).collect())
        .collect();
    assert_eq!(rows.len(), 2, "{text}");
    for row in rows {
        let n = |i: usize| row[i].parse::<u64>().unwrap_or_else(|_| panic!("column {i} of {row:?}"));
        // 0.2 s at 1 kHz: at most 200 ticks (fewer when a loaded machine skips periods).
        let (ticks, misses, slow) = (n(2), n(3), n(9));
        assert!((1..=200).contains(&ticks), "{row:?}");
        assert!(misses <= ticks && slow <= ticks, "{row:?}");
    }
}

#[test]
fn bench_noise_refuses_bad_options_by_name_fails() {
    assert_lamina_refuses(
        &["bench", "noise"],
        &[
            (&["--work-us", "1500"], "--work-us 1500"),
            (&["--work-us", "NaN"], "--work-us NaN"),
            (&["--sleep-slices-us", "5"], "--sleep-slices-us 5"),
            (&["--working-set-kib", "0"], "--working-set-kib 0"),
            (&["--seconds", "4000"], "--seconds 4000"),
        ],
    );
}
