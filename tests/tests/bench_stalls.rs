//! `lamina bench stalls`: each CPU's stops and those of every CPU at once. Checks the table
//! against what an intersection must satisfy, and that bad options are refused by name.

use lamina_tests::{assert_lamina_refuses, run_lamina};

/// A table row's cells, trimmed.
fn cells(line: &str) -> Vec<&str> {
    line.split('|').map(str::trim).filter(|c| !c.is_empty()).collect()
}

/// `2.89 ms` as ms.
fn ms(cell: &str) -> f64 {
    cell.strip_suffix(" ms").and_then(|v| v.parse().ok()).unwrap_or_else(|| panic!("not a duration: {cell}"))
}

#[test]
fn bench_stalls_rows_bound_the_stops_of_every_cpu_at_once_works() {
    // At the normal policy: a short watch that leaves the other tests their CPUs.
    let (ok, text) = run_lamina(&[
        "bench",
        "stalls",
        "--seconds",
        "0.2",
        "--gap-us",
        "20",
        "--fifo-priority",
        "0",
        "--work-us",
        "900",
    ]);
    assert!(ok, "{text}");
    let cpu_rows: Vec<Vec<&str>> = text.lines().filter(|l| l.starts_with("| CPU ")).map(cells).collect();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    assert_eq!(cpu_rows.len(), cpus, "{text}");
    for row in &cpu_rows {
        let n = |i: usize| row[i].parse::<u64>().unwrap_or_else(|_| panic!("column {i} of {row:?}"));
        // Stops counted at 20 µs include those of 0.5 and 1 ms.
        assert!(n(1) >= n(2) && n(2) >= n(3), "{row:?}");
        assert!(ms(row[4]) <= ms(row[5]) + 1e-9, "the longest stop is part of the total: {row:?}");
    }
    if cpus > 1 {
        let shared = text.lines().find(|l| l.starts_with("| every CPU at once")).map(cells).expect("the shared row");
        // Time every CPU was stopped is time each of them was: neither its longest stop nor
        // its total exceeds any CPU's, nor do its misses.
        for row in &cpu_rows {
            assert!(ms(shared[4]) <= ms(row[4]) + 0.01, "{shared:?} against {row:?}");
            assert!(ms(shared[5]) <= ms(row[5]) + 0.01, "{shared:?} against {row:?}");
            let misses = |r: &[&str]| r[6].parse::<f64>().expect("misses per minute");
            assert!(misses(&shared) <= misses(row) + 0.05, "{shared:?} against {row:?}");
        }
    }
    let watched = text.lines().find_map(|l| l.strip_prefix("watched ")).expect("the watched line");
    let seconds: f64 = watched.split(' ').next().and_then(|s| s.parse().ok()).expect("seconds watched");
    // 9 ms of every 10 ms over 0.2 s is 0.18 s, printed to 0.1 s; a loaded machine watches less.
    assert!(seconds <= 0.2, "{watched}");
}

#[test]
fn bench_stalls_refuses_bad_options_by_name_fails() {
    assert_lamina_refuses(
        &["bench", "stalls"],
        &[
            (&["--seconds", "0"], "--seconds 0"),
            (&["--seconds", "NaN"], "--seconds NaN"),
            (&["--gap-us", "1"], "--gap-us 1"),
            (&["--fifo-priority", "100"], "--fifo-priority 100"),
            (&["--rate-hz", "0"], "--rate-hz 0"),
            (&["--work-us", "1000"], "--work-us 1000"),
            (&["--work-us=-1"], "--work-us -1"),
        ],
    );
}
