//! `lamina-listen`: subscribes to `<prefix>/nodes`, measures one-way latency and sequence
//! gaps, and writes a JSON report at exit (after `--seconds`, or on SIGTERM/SIGINT).
//!
//! Latency is `now_ns()` right after `receive` minus the header's `publish_time_ns`, both
//! `CLOCK_MONOTONIC`, recorded in an HDR histogram (ns, 3 significant digits).

use std::io::Write;
use std::time::{Duration, Instant};

use clap::{Parser, ValueEnum};
use hdrhistogram::Histogram;
use lamina_bridge::{Bridge, BridgeConfig, NodesSubscriber, SampleReceiveError, now_ns};
use lamina_rt::caught_stop_signal;
use serde::Serialize;

/// How the listener waits for frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
enum Mode {
    /// Busy-poll `try_receive` (one CPU at 100 %, lowest latency).
    Poll,
    /// Sleep on the wake-up event (`receive_timeout`).
    Block,
}

/// Subscribe to Lamina node frames and report latency and gaps as JSON.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Service prefix of the simulation.
    #[arg(long, default_value = lamina_bridge::DEFAULT_PREFIX)]
    prefix: String,
    /// iceoryx2 file prefix (domain); default iceoryx2's own.
    #[arg(long)]
    file_prefix: Option<String>,
    /// Poll or block.
    #[arg(long, value_enum, default_value_t = Mode::Block)]
    mode: Mode,
    /// Run time in seconds (then write the report and exit): above 0, at most 1e9.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Report file; default: standard output.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Pin this process to a CPU index, one it may run on (another is refused).
    #[arg(long)]
    pin: Option<usize>,
    /// Print a progress line every N frames (0: never).
    #[arg(long, default_value_t = 0)]
    print_every: u64,
    /// Include every sequence number seen in the report.
    #[arg(long)]
    record_sequences: bool,
    /// Also write the latency histogram as CSV (`latency_ns,quantile,count`).
    #[arg(long)]
    histogram: Option<std::path::PathBuf>,
}

#[derive(Debug, Default, Serialize)]
struct LatencyReport {
    p50_ns: u64,
    p99_ns: u64,
    p999_ns: u64,
    max_ns: u64,
    min_ns: u64,
    mean_ns: f64,
}

#[derive(Debug, Serialize)]
struct Report {
    prefix: String,
    mode: Mode,
    pinned_cpu: Option<usize>,
    duration_s: f64,
    terminated_by_signal: bool,
    count: u64,
    first_sequence: Option<u64>,
    last_sequence: Option<u64>,
    /// Places where the sequence jumped forward by more than one.
    gaps: u64,
    /// Frames skipped over by those jumps.
    missing: u64,
    /// Times the sequence went backwards or repeated (publisher restart).
    resets: u64,
    receive_errors: u64,
    last_node_count: Option<u32>,
    /// Time from subscribing to the first frame, ns: how soon a (re)started subscriber is fed.
    first_frame_after_ns: Option<u64>,
    latency: LatencyReport,
    #[serde(skip_serializing_if = "Option::is_none")]
    sequences: Option<Vec<u64>>,
}

struct Tally {
    histogram: Histogram<u64>,
    count: u64,
    first: Option<u64>,
    last: Option<u64>,
    gaps: u64,
    missing: u64,
    resets: u64,
    node_count: Option<u32>,
    sequences: Option<Vec<u64>>,
}

impl Tally {
    fn record(&mut self, sequence: u64, latency_ns: u64, node_count: u32) {
        // Saturate rather than fail: an absurd latency is still worth counting.
        self.histogram.saturating_record(latency_ns);
        self.count += 1;
        self.first.get_or_insert(sequence);
        if let Some(last) = self.last {
            if sequence > last.saturating_add(1) {
                self.gaps += 1;
                self.missing += sequence - last - 1;
            } else if sequence <= last {
                self.resets += 1;
            }
        }
        self.last = Some(sequence);
        self.node_count = Some(node_count);
        if let Some(seqs) = &mut self.sequences {
            seqs.push(sequence);
        }
    }
}

/// Longest `--seconds` accepted, s (about 32 years, as for `lamina run`).
const MAX_SECONDS: f64 = 1e9;

/// Set by the SIGINT/SIGTERM handler (lamina-rt's signal module).
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lamina-listen: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    let run_for = lamina_rt::seconds_option("--seconds", args.seconds, MAX_SECONDS)?;
    if let Some(cpu) = args.pin {
        lamina_rt::pin_for_option("--pin", cpu)?;
    }
    if let Err(e) = lamina_rt::install_stop_handler(&STOP) {
        eprintln!("lamina-listen: {e}; no report on SIGTERM");
    }
    let cfg = BridgeConfig {
        file_prefix: args.file_prefix.clone(),
        node_name: Some("lamina-listen".into()),
        ..BridgeConfig::with_prefix(&args.prefix)
    };
    let bridge = Bridge::open(&cfg)?;
    let subscriber = NodesSubscriber::create(&bridge)?;

    let mut tally = Tally {
        histogram: Histogram::new_with_bounds(1, 60_000_000_000, 3)?,
        count: 0,
        first: None,
        last: None,
        gaps: 0,
        missing: 0,
        resets: 0,
        node_count: None,
        sequences: args.record_sequences.then(Vec::new),
    };
    let mut receive_errors = 0u64;
    let mut first_frame_after_ns = None;
    let start = Instant::now();
    let slice = Duration::from_millis(50);
    let mut stdout = std::io::stdout();

    while caught_stop_signal().is_none() && start.elapsed() < run_for {
        let received = match args.mode {
            Mode::Poll => subscriber.try_receive(),
            Mode::Block => subscriber.receive_timeout(slice),
        };
        match received {
            Ok(Some(frame)) => {
                let now = now_ns();
                let h = frame.header();
                first_frame_after_ns.get_or_insert(start.elapsed().as_nanos() as u64);
                tally.record(h.sequence, now.saturating_sub(h.publish_time_ns), h.node_count);
                drop(frame);
                if args.print_every > 0 && tally.count.is_multiple_of(args.print_every) {
                    let _ = writeln!(stdout, "received count={} sequence={}", tally.count, tally.last.unwrap_or(0));
                    let _ = stdout.flush();
                }
            }
            Ok(None) => {
                if args.mode == Mode::Poll {
                    core::hint::spin_loop();
                }
            }
            Err(SampleReceiveError::Interrupted) => {}
            Err(e) => {
                receive_errors += 1;
                if receive_errors == 1 {
                    eprintln!("lamina-listen: {e}");
                }
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    }

    let h = &tally.histogram;
    let latency = if tally.count == 0 {
        LatencyReport::default()
    } else {
        LatencyReport {
            p50_ns: h.value_at_quantile(0.5),
            p99_ns: h.value_at_quantile(0.99),
            p999_ns: h.value_at_quantile(0.999),
            max_ns: h.max(),
            min_ns: h.min(),
            mean_ns: h.mean(),
        }
    };
    let report = Report {
        prefix: args.prefix.clone(),
        mode: args.mode,
        pinned_cpu: args.pin,
        duration_s: start.elapsed().as_secs_f64(),
        terminated_by_signal: caught_stop_signal().is_some(),
        count: tally.count,
        first_sequence: tally.first,
        last_sequence: tally.last,
        gaps: tally.gaps,
        missing: tally.missing,
        resets: tally.resets,
        receive_errors,
        last_node_count: tally.node_count,
        first_frame_after_ns,
        latency,
        sequences: tally.sequences,
    };
    if let Some(path) = &args.histogram {
        let mut csv = String::from("latency_ns,quantile,count\n");
        if tally.count > 0 {
            for v in tally.histogram.iter_quantiles(2) {
                csv.push_str(&format!(
                    "{},{},{}\n",
                    v.value_iterated_to(),
                    v.quantile_iterated_to(),
                    v.count_since_last_iteration()
                ));
            }
        }
        std::fs::write(path, csv)?;
    }
    let json = serde_json::to_string_pretty(&report)?;
    match &args.out {
        Some(path) => {
            // Write then rename, so a reader never sees a half-written report.
            let tmp = path.with_extension("json.tmp");
            std::fs::write(&tmp, json.as_bytes())?;
            std::fs::rename(&tmp, path)?;
        }
        None => println!("{json}"),
    }
    Ok(())
}
