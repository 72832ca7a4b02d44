//! `lamina bench noise`: the machine's own misses, measured by the loop of `lamina run` with
//! synthetic work, alone and with a standby thread. Checks the table it prints and that bad
//! options are refused by name.

use lamina_tests::{assert_lamina_refuses, run_lamina};

fn noise(args: &[&str]) -> (bool, String) {
    run_lamina(&[&["bench", "noise"], args].concat())
}

#[test]
fn bench_noise_prints_one_row_per_sleep_slice_works() {
    let (ok, text) = noise(&[
        "--seconds",
        "0.2",
        "--work-us",
        "50",
        "--working-set-kib",
        "64",
        "--sleep-slices-us",
        "0,100",
        "--standby-cpu",
        "0",
    ]);
    assert!(ok, "{text}");
    let rows: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| l.starts_with("| one sleep") || l.starts_with("| 100 µs"))
        .map(|l| l.split('|').map(str::trim).collect())
        .collect();
    // Each slice alone, then with the standby.
    assert_eq!(rows.len(), 4, "{text}");
    for (k, row) in rows.iter().enumerate() {
        let n = |i: usize| row[i].parse::<u64>().unwrap_or_else(|_| panic!("column {i} of {row:?}"));
        // 0.2 s at 1 kHz: at most 200 ticks (fewer when a loaded machine skips periods).
        let (ticks, misses, slow, skipped) = (n(3), n(4), n(10), n(14));
        assert!((1..=200).contains(&ticks), "{row:?}");
        assert!(misses <= ticks && slow <= ticks, "{row:?}");
        // Each of the 200 slots of 0.2 s either ran a tick or was skipped.
        assert_eq!(ticks + skipped, 200, "{row:?}");
        if k % 2 == 0 {
            assert_eq!(row[2], "none", "{row:?}");
        } else {
            let by_standby = row[2]
                .strip_prefix("CPU 0, 250 µs: ran ")
                .and_then(|r| r.strip_suffix(" ticks"))
                .and_then(|n| n.parse::<u64>().ok())
                .unwrap_or_else(|| panic!("the standby's cell of {row:?}"));
            assert!(by_standby <= ticks, "{row:?}");
        }
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
            (&["--standby-cpu", "0", "--standby-delay-us", "5"], "--standby-delay-us 5"),
            (&["--standby-cpu", "0", "--standby-delay-us", "1000"], "--standby-delay-us 1000"),
        ],
    );
}
