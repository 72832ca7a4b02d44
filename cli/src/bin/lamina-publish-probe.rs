//! `lamina-publish-probe`: publishes synthetic node frames at a fixed rate so latency can be
//! measured without the physics core.
//!
//! Absolute deadlines (`next += period`, `clock_nanosleep(TIMER_ABSTIME)`). Overrun policy:
//! skip — when a deadline has already passed by more than one period, the missed slots are
//! skipped and counted (`overruns`), never published in a burst. Prints a JSON summary at the
//! end (after `--seconds`, or on SIGTERM/SIGINT).

use std::time::{Duration, Instant};

use clap::Parser;
use lamina_bridge::{Bridge, BridgeConfig, NodesPublisher};
use lamina_rt::caught_stop_signal;
use lamina_rt::{now_ns, sleep_until_ns};
use serde::Serialize;

/// Publish synthetic Lamina node frames at a fixed rate.
#[derive(Debug, Parser)]
#[command(version)]
struct Args {
    /// Nodes per frame, from 1 to 1,000,000.
    #[arg(long, default_value_t = 2769)]
    nodes: usize,
    /// Frames per second, from 0.001 to 1e6.
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Run time in seconds: above 0, at most 1e9.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Service prefix of the simulation.
    #[arg(long, default_value = lamina_bridge::DEFAULT_PREFIX)]
    prefix: String,
    /// iceoryx2 file prefix (domain); default iceoryx2's own.
    #[arg(long)]
    file_prefix: Option<String>,
    /// Pin this process to a CPU index, one it may run on (another is refused).
    #[arg(long)]
    pin: Option<usize>,
    /// Before starting, wait up to 10 s for this many subscribers.
    #[arg(long, default_value_t = 0)]
    wait_subscribers: usize,
}

#[derive(Debug, Serialize)]
struct Summary {
    prefix: String,
    nodes: usize,
    rate_hz: f64,
    duration_s: f64,
    sent: u64,
    publish_errors: u64,
    overruns: u64,
    notify_failures: u64,
    max_publish_call_ns: u64,
    delivered_total: u64,
}

/// Most `--nodes` accepted: the node service holds 146 frames of 12 bytes per node in
/// `/dev/shm`, 1.75 GB at this count.
const MAX_NODES: usize = 1_000_000;

/// Slowest and fastest `--rate` accepted, frames per second.
const MIN_RATE_HZ: f64 = 1e-3;
const MAX_RATE_HZ: f64 = 1e6;

/// Longest `--seconds` accepted, s (about 32 years, as for `lamina run`).
const MAX_SECONDS: f64 = 1e9;

/// Set by the SIGINT/SIGTERM handler (lamina-rt's signal module).
static STOP: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("lamina-publish-probe: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn run() -> Result<(), Box<dyn std::error::Error>> {
    let args = Args::parse();
    if !(MIN_RATE_HZ..=MAX_RATE_HZ).contains(&args.rate) {
        let rate = lamina_rt::format_value(args.rate);
        return Err(format!("--rate {rate}: must be from {MIN_RATE_HZ} to {MAX_RATE_HZ:e} frames per second").into());
    }
    if !(1..=MAX_NODES).contains(&args.nodes) {
        return Err(format!(
            "--nodes {}: must be from 1 to {MAX_NODES} (the node service's shared memory is sized for 146 frames \
             of 12 bytes per node: 1.75 GB of /dev/shm at the most)",
            args.nodes
        )
        .into());
    }
    let run_for = lamina_rt::seconds_option("--seconds", args.seconds, MAX_SECONDS)?;
    if let Some(cpu) = args.pin {
        lamina_rt::pin_for_option("--pin", cpu)?;
    }
    let _ = lamina_rt::install_stop_handler(&STOP);
    let cfg = BridgeConfig {
        file_prefix: args.file_prefix.clone(),
        node_name: Some("lamina-publish-probe".into()),
        ..BridgeConfig::with_prefix(&args.prefix)
    };
    let bridge = Bridge::open(&cfg)?;
    let publisher = NodesPublisher::create(&bridge, args.nodes)?;

    let wait_start = Instant::now();
    while publisher.subscriber_count() < args.wait_subscribers
        && wait_start.elapsed() < Duration::from_secs(10)
        && caught_stop_signal().is_none()
    {
        std::thread::sleep(Duration::from_millis(10));
    }

    let period_ns = (1e9 / args.rate).max(1.0) as u64;
    let dt = 1.0 / args.rate;
    let (mut sent, mut errors, mut overruns, mut max_call, mut delivered_total) = (0u64, 0u64, 0u64, 0u64, 0u64);
    let start = Instant::now();
    let mut next = now_ns();
    let mut tick = 0u64;
    while caught_stop_signal().is_none() && start.elapsed() < run_for {
        let t0 = now_ns();
        let phase = tick as f32 * 1e-3;
        match publisher.publish_from_fn(sent, tick, tick as f64 * dt, args.nodes, |i| [i as f32 * 1e-4, phase, 0.0]) {
            Ok(n) => {
                sent += 1;
                delivered_total += n as u64;
            }
            Err(e) => {
                errors += 1;
                if errors == 1 {
                    eprintln!("lamina-publish-probe: {e}");
                }
            }
        }
        max_call = max_call.max(now_ns().saturating_sub(t0));
        next += period_ns;
        tick += 1;
        let now = now_ns();
        if now > next + period_ns {
            let behind = (now - next) / period_ns;
            overruns += behind;
            tick += behind;
            next += behind * period_ns;
        }
        sleep_until_ns(next);
    }
    let summary = Summary {
        prefix: args.prefix,
        nodes: args.nodes,
        rate_hz: args.rate,
        duration_s: start.elapsed().as_secs_f64(),
        sent,
        publish_errors: errors,
        overruns,
        notify_failures: publisher.notify_failures(),
        max_publish_call_ns: max_call,
        delivered_total,
    };
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
