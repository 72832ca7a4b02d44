//! A short subscriber: prints the node frames a running core publishes.
//!
//! ```text
//! lamina run --seconds 10 &            # the core, publishing under the prefix "lamina"
//! cargo run -p lamina-bridge --example print_nodes -- lamina 5
//! ```
//!
//! Arguments: the service prefix (default `lamina`) and how many seconds to listen (default
//! 5). Each line: sequence number, simulated time, node count, the first node's position and
//! the one-way latency from the core's publish to this read (both stamped on
//! `CLOCK_MONOTONIC`, see `lamina_bridge::now_ns`).

use core::time::Duration;
use lamina_bridge::{Bridge, BridgeConfig, NodesSubscriber, now_ns};

fn main() -> Result<(), Box<dyn core::error::Error>> {
    let mut args = std::env::args().skip(1);
    let prefix = args.next().unwrap_or_else(|| "lamina".into());
    let seconds: f64 = match args.next() {
        Some(s) => s.parse().map_err(|e| format!("seconds '{s}': {e}"))?,
        None => 5.0,
    };
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix))?;
    let nodes = NodesSubscriber::create(&bridge)?;
    let until = std::time::Instant::now() + Duration::from_secs_f64(seconds.clamp(0.0, 3600.0));
    let mut frames = 0u64;
    while std::time::Instant::now() < until {
        // Blocks until the core signals a new frame, or 100 ms pass.
        let Some(frame) = nodes.receive_timeout(Duration::from_millis(100))? else { continue };
        let h = frame.header();
        frames += 1;
        // Print every 100th frame: at 1 kHz that is ten lines a second.
        if h.sequence % 100 == 0 {
            let first = frame.positions().first().copied().unwrap_or_default();
            let latency_us = now_ns().saturating_sub(h.publish_time_ns) as f64 / 1e3;
            println!(
                "frame {:>7}  t = {:8.3} s  {} nodes  node 0 at ({:+.4}, {:+.4}, {:+.4}) m  latency {latency_us:.1} us",
                h.sequence, h.sim_time_s, h.node_count, first[0], first[1], first[2]
            );
        }
    }
    println!("{frames} frames in {seconds} s on '{prefix}/nodes'");
    Ok(())
}
