//! Mutation fuzzing of every file format a user hands Lamina: each case takes a file of the
//! seed corpus (`tests/fuzz/corpus/<format>/`), applies one to four mutations (bit flips,
//! deleted, inserted or duplicated byte runs, truncation, a number replaced by an extreme
//! one such as `1e300`, `nan` or `4294967296`, a line deleted or repeated), writes it and
//! loads it. Every case must end in either an accepted input or an error that names the file
//! (and the line, for syntax errors); a panic, or an error naming neither, fails the test.
//!
//! The stream of cases is fixed (seeded ChaCha), so CI sees the same cases every run.
//! `LAMINA_FUZZ_CASES` sets the cases per format (default [`DEFAULT_CASES`]);
//! `LAMINA_FUZZ_SEED` (a number) picks another stream. The memory budget of this process is
//! capped at 256 MiB, so a mutated size is refused cheaply instead of built.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use lamina_core::fit::TargetsLoadError;
use lamina_core::io::ModelReadError;
use lamina_core::scene::SceneLoadError;
use lamina_core::solver::{IntegrationParameters, Simulation};
use lamina_haptics::device::DeviceError;
use lamina_mesh::{LoadOptions, MeshLoadError};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};

/// Cases per format when `LAMINA_FUZZ_CASES` is not set.
const DEFAULT_CASES: u32 = 3_500;
/// Largest mutated input, bytes: cases stay cheap.
const MAX_INPUT: usize = 64 * 1024;
/// Numbers that have broken parsers and the code after them.
const EXTREMES: [&str; 16] = [
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "-0",
    "0",
    "-1",
    "4294967295",
    "4294967296",
    "18446744073709551616",
    "1e39",
    "3.5e38",
    "99999999999999999999",
    "0.000000000000000000001",
];

/// One mutation; positions are taken modulo the input's length.
#[derive(Clone, Debug)]
enum Mutation {
    FlipBit { at: usize, bit: u8 },
    SetByte { at: usize, byte: u8 },
    Delete { at: usize, len: usize },
    Insert { at: usize, bytes: Vec<u8> },
    Duplicate { from: usize, len: usize, to: usize },
    Truncate { at: usize },
    Number { nth: usize, extreme: usize },
    DeleteLine { nth: usize },
    RepeatLine { nth: usize, times: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::FlipBit { at, bit }),
        (any::<usize>(), any::<u8>()).prop_map(|(at, byte)| Mutation::SetByte { at, byte }),
        (any::<usize>(), 1usize..64).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (any::<usize>(), vec(any::<u8>(), 1..16)).prop_map(|(at, bytes)| Mutation::Insert { at, bytes }),
        (any::<usize>(), 1usize..256, any::<usize>()).prop_map(|(from, len, to)| Mutation::Duplicate { from, len, to }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), 0..EXTREMES.len()).prop_map(|(nth, extreme)| Mutation::Number { nth, extreme }),
        (any::<usize>(), 0..EXTREMES.len()).prop_map(|(nth, extreme)| Mutation::Number { nth, extreme }),
        any::<usize>().prop_map(|nth| Mutation::DeleteLine { nth }),
        (any::<usize>(), 1usize..4).prop_map(|(nth, times)| Mutation::RepeatLine { nth, times }),
    ]
}

/// Byte ranges of the numbers in `b`: a digit run with its sign, point and exponent.
fn numbers(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let starts = b[i].is_ascii_digit()
            || (matches!(b[i], b'-' | b'+' | b'.') && b.get(i + 1).is_some_and(u8::is_ascii_digit));
        if starts && (i == 0 || !b[i - 1].is_ascii_alphanumeric()) {
            let mut j = i + 1;
            while j < b.len() && (b[j].is_ascii_digit() || matches!(b[j], b'.' | b'e' | b'E' | b'-' | b'+')) {
                j += 1;
            }
            out.push((i, j));
            i = j;
        } else {
            i += 1;
        }
    }
    out
}

/// Byte ranges of the lines of `b`, newline included.
fn lines(b: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = 0;
    for (i, &c) in b.iter().enumerate() {
        if c == b'\n' {
            out.push((start, i + 1));
            start = i + 1;
        }
    }
    if start < b.len() {
        out.push((start, b.len()));
    }
    out
}

fn apply(input: &mut Vec<u8>, m: &Mutation) {
    let n = input.len();
    let at = |p: usize| if n == 0 { 0 } else { p % n };
    match m {
        Mutation::FlipBit { at: p, bit } if n > 0 => input[at(*p)] ^= 1 << bit,
        Mutation::SetByte { at: p, byte } if n > 0 => input[at(*p)] = *byte,
        Mutation::Delete { at: p, len } => {
            let s = at(*p);
            input.drain(s..(s + len).min(n));
        }
        Mutation::Insert { at: p, bytes } => {
            let s = if n == 0 { 0 } else { p % (n + 1) };
            input.splice(s..s, bytes.iter().copied());
        }
        Mutation::Duplicate { from, len, to } if n > 0 => {
            let s = at(*from);
            let chunk = input[s..(s + len).min(n)].to_vec();
            let t = to % (n + 1);
            input.splice(t..t, chunk);
        }
        Mutation::Truncate { at: p } => input.truncate(at(*p)),
        Mutation::Number { nth, extreme } => {
            let found = numbers(input);
            if !found.is_empty() {
                let (s, e) = found[nth % found.len()];
                input.splice(s..e, EXTREMES[*extreme].bytes());
            }
        }
        Mutation::DeleteLine { nth } => {
            let found = lines(input);
            if !found.is_empty() {
                let (s, e) = found[nth % found.len()];
                input.drain(s..e);
            }
        }
        Mutation::RepeatLine { nth, times } => {
            let found = lines(input);
            if !found.is_empty() {
                let (s, e) = found[nth % found.len()];
                let line = input[s..e].to_vec();
                for _ in 0..*times {
                    input.splice(e..e, line.iter().copied());
                }
            }
        }
        _ => {}
    }
    input.truncate(MAX_INPUT);
}

/// One case judged: `Ok(true)` accepted, `Ok(false)` refused with a clear error, `Err` what
/// is wrong with how it was refused.
type Verdict = Result<bool, String>;

/// A format: its extension, corpus folder and how a case is loaded and judged.
struct Target {
    name: &'static str,
    ext: &'static str,
    check: fn(&Path) -> Verdict,
}

/// The error's message must name `path` and, when `line` says the error is about a line,
/// carry `path:LINE:`.
fn names_file(message: &str, path: &Path, line: Option<usize>) -> Result<(), String> {
    let file = path.display().to_string();
    if !message.contains(&file) {
        return Err(format!("error does not name the file: {message}"));
    }
    if let Some(line) = line
        && (line == 0 || !message.contains(&format!("{file}:{line}")))
    {
        return Err(format!("error does not name its line: {message}"));
    }
    Ok(())
}

fn check_mesh(path: &Path) -> Verdict {
    let mut accepted = true;
    for result in [
        lamina_mesh::load(path, &LoadOptions::default()).map(|_| ()),
        lamina_mesh::inspect(path).map(|i| {
            assert!(!i.volume.is_nan() && !i.area.is_nan(), "inspect printed NaN: {i}");
        }),
    ] {
        if let Err(e) = result {
            let line = match &e {
                MeshLoadError::StlSyntax { line, .. } | MeshLoadError::ObjSyntax { line, .. } => Some(*line),
                MeshLoadError::ObjIndexOutOfRange { line, .. } => Some(*line),
                _ => None,
            };
            names_file(&e.to_string(), path, line)?;
            accepted = false;
        }
    }
    Ok(accepted)
}

fn check_model(path: &Path) -> Verdict {
    match lamina_core::io::read_model(path) {
        Ok(model) => {
            // What loads must also build, or be refused with a reason (never a panic).
            let params = IntegrationParameters { threads: 1, ..IntegrationParameters::default() };
            if let Ok(mut sim) = Simulation::<f32>::new(&model, params, Default::default()) {
                sim.step();
            }
            Ok(true)
        }
        Err(e) => {
            let line = match &e {
                ModelReadError::Io { .. } | ModelReadError::Refused(_) => None,
                located => located.line().map(|l| l as usize),
            };
            names_file(&e.to_string(), path, line).map(|()| false)
        }
    }
}

/// Scene files are loaded and checked value by value (the model they name is not built:
/// a mutated grid size within the allowed range can take seconds to generate).
fn check_scene(path: &Path) -> Verdict {
    match lamina_core::scene::Scene::load(path) {
        Ok(_) => Ok(true),
        Err(e) => {
            let line = match &e {
                SceneLoadError::Syntax { line, .. } => Some(*line),
                SceneLoadError::Value { line, .. } => *line,
                _ => None,
            };
            names_file(&e.to_string(), path, line).map(|()| false)
        }
    }
}

fn check_trajectory(path: &Path) -> Verdict {
    match lamina_haptics::device::Trajectory::load(path) {
        Ok(t) => {
            let end = t.duration_s();
            assert!(end.is_finite() && end <= lamina_haptics::device::MAX_SCRIPT_S, "accepted a script of {end} s");
            Ok(true)
        }
        Err(e) => {
            let line = match &e {
                DeviceError::Script { line, .. } if *line > 0 => Some(*line),
                _ => None,
            };
            names_file(&e.to_string(), path, line).map(|()| false)
        }
    }
}

fn check_material(path: &Path) -> Verdict {
    match lamina_core::fit::TissueTargets::load(path) {
        Ok(t) => {
            assert!(t.weights.iter().any(|&w| w > 0.0), "accepted all-zero weights");
            Ok(true)
        }
        Err(e) => {
            let line = match &e {
                TargetsLoadError::Syntax { line, .. } if *line > 0 => Some(*line),
                _ => None,
            };
            names_file(&e.to_string(), path, line).map(|()| false)
        }
    }
}

const TARGETS: [Target; 6] = [
    Target { name: "stl", ext: "stl", check: check_mesh },
    Target { name: "obj", ext: "obj", check: check_mesh },
    Target { name: "xml", ext: "xml", check: check_model },
    Target { name: "scene", ext: "toml", check: check_scene },
    Target { name: "trajectory", ext: "csv", check: check_trajectory },
    Target { name: "material", ext: "toml", check: check_material },
];

fn corpus(name: &str) -> Vec<Vec<u8>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/corpus").join(name);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{}: empty seed corpus", dir.display());
    files.iter().map(|p| std::fs::read(p).unwrap()).collect()
}

fn env_number(name: &str, default: u64) -> u64 {
    std::env::var(name).ok().and_then(|v| v.trim().parse().ok()).unwrap_or(default)
}

/// Runs `cases` mutated cases of `target`; returns how many were accepted and rejected.
fn fuzz(target: &Target, cases: u32, seed: u64) -> (u32, u32) {
    let seeds = corpus(target.name);
    let dir = std::env::temp_dir().join(format!("lamina_fuzz_{}_{}", target.name, std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(format!("case.{}", target.ext));
    let mut key = [0u8; 32];
    key[..8].copy_from_slice(&seed.to_le_bytes());
    key[8..8 + target.name.len()].copy_from_slice(target.name.as_bytes());
    let config = Config { cases, failure_persistence: None, max_shrink_iters: 2_000, ..Config::default() };
    let mut runner = TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &key));
    let tally = std::cell::Cell::new((0u32, 0u32));
    let strategy = (0..seeds.len(), vec(mutation(), 1..=4));
    let result = runner.run(&strategy, |(seed_index, mutations)| {
        let mut input = seeds[seed_index].clone();
        for m in &mutations {
            apply(&mut input, m);
        }
        std::fs::write(&path, &input).map_err(|e| TestCaseError::fail(e.to_string()))?;
        let accepted = catch_unwind(AssertUnwindSafe(|| (target.check)(&path)))
            .map_err(|_| TestCaseError::fail("panicked"))?
            .map_err(TestCaseError::fail)?;
        let (yes, no) = tally.get();
        tally.set(if accepted { (yes + 1, no) } else { (yes, no + 1) });
        Ok(())
    });
    let _ = std::fs::remove_dir_all(&dir);
    if let Err(e) = result {
        panic!("{} fuzzing (seed {seed}): {e}", target.name);
    }
    tally.get()
}

#[test]
fn fuzz_every_format_never_panics_and_names_file_and_line_works() {
    lamina_input::memory::set_process_limit(256 << 20);
    let cases = env_number("LAMINA_FUZZ_CASES", u64::from(DEFAULT_CASES)) as u32;
    let seed = env_number("LAMINA_FUZZ_SEED", 15);
    let start = std::time::Instant::now();
    let mut total = 0;
    for target in &TARGETS {
        let (accepted, rejected) = fuzz(target, cases, seed);
        total += accepted + rejected;
        println!("{:>4}: {cases} cases, {accepted} accepted, {rejected} refused with a clear error", target.name);
    }
    println!("{total} cases in {:.1} s (seed {seed})", start.elapsed().as_secs_f64());
    assert_eq!(total, cases * TARGETS.len() as u32);
}

#[test]
fn fuzz_mutations_change_the_input_works() {
    // The mutation engine itself: each kind changes a seed as described.
    let mut b = b"v 1 2 3\nf 1 2 3\n".to_vec();
    apply(&mut b, &Mutation::Number { nth: 1, extreme: 0 });
    assert_eq!(b, b"v 1 1e300 3\nf 1 2 3\n");
    apply(&mut b, &Mutation::DeleteLine { nth: 0 });
    assert_eq!(b, b"f 1 2 3\n");
    apply(&mut b, &Mutation::RepeatLine { nth: 0, times: 2 });
    assert_eq!(b, b"f 1 2 3\nf 1 2 3\nf 1 2 3\n");
    apply(&mut b, &Mutation::Truncate { at: 5 });
    assert_eq!(b, b"f 1 2");
    assert_eq!(numbers(b"a1 -2.5e-3 x7 .5"), vec![(3, 10), (14, 16)]);
}
