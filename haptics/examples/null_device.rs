//! A device loop on a device of your own: the smallest haptic driver.
//!
//! ```text
//! lamina run --seconds 10 &     # the core with the default scene, prefix "lamina"
//! cargo run --release -p lamina-haptics --example null_device -- lamina 2
//! ```
//!
//! Arguments: the service prefix (default `lamina`) and seconds (default 2). `HoldStill` is a
//! device whose handle stays 4 mm below its workspace centre and that records the forces it
//! is given; a real driver reads its encoders in `read` and sets its motors in
//! `write_force`. The workspace centre is mapped onto the default scene's `device_origin`
//! (one tool radius above the skin on top of the limb), so the tool presses 4 mm into the
//! skin and the core's contact force comes back. The loop runs at 4 kHz on absolute
//! deadlines, publishes the pose on `tool`, renders the core's contact model and prints its
//! deadline figures and the force it felt.

use lamina_bridge::{Bridge, BridgeConfig};
use lamina_haptics::device::{DeviceError, DeviceInfo, DeviceState, HapticDevice};
use lamina_haptics::{DeviceMapping, HapticsConfig, run_device_loop};
use lamina_rt::RunLimit;

/// A handle held still 4 mm below the workspace centre (device z is up); forces are recorded.
struct HoldStill {
    info: DeviceInfo,
    largest_force_n: f64,
}

impl HapticDevice for HoldStill {
    fn info(&self) -> &DeviceInfo {
        &self.info
    }
    fn read(&mut self) -> Result<DeviceState, DeviceError> {
        Ok(DeviceState { position_m: [0.0, 0.0, -0.004], ..DeviceState::default() })
    }
    fn write_force(&mut self, force_n: [f64; 3]) -> Result<(), DeviceError> {
        let norm = force_n.iter().map(|f| f * f).sum::<f64>().sqrt();
        self.largest_force_n = self.largest_force_n.max(norm);
        Ok(())
    }
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let prefix = args.next().unwrap_or_else(|| "lamina".into());
    let seconds: f64 = match args.next() {
        Some(s) => s.parse().map_err(|e| format!("seconds '{s}': {e}"))?,
        None => 2.0,
    };
    let mut device = HoldStill {
        info: DeviceInfo {
            name: "hold-still".into(),
            max_force_n: 3.0,
            max_stiffness_n_per_m: 1000.0,
            max_damping_n_s_per_m: 5.0,
            workspace_radius_m: 0.08,
        },
        largest_force_n: 0.0,
    };
    let bridge = Bridge::open(&BridgeConfig::with_prefix(&prefix))?;
    // The default scene's device_origin (config/scenes/default.toml), m.
    let config = HapticsConfig { mapping: DeviceMapping::y_up_model([0.0, 0.062, 0.12]), ..HapticsConfig::default() };
    let limit = RunLimit::duration_ns((seconds.clamp(0.0, 3600.0) * 1e9) as u64);
    let report = run_device_loop(&mut device, &bridge, &config, limit, None, None)?;
    let s = report.monitor.summary();
    println!(
        "{} ticks at {} Hz, {} missed; period p50 {:.1} us, p99 {:.1} us; {} tool commands sent",
        s.ticks,
        config.rate_hz,
        s.misses,
        s.period.p50_ns as f64 / 1e3,
        s.period.p99_ns as f64 / 1e3,
        report.commands_sent
    );
    println!("largest force commanded: {:.4} N (zero when no core answered)", device.largest_force_n);
    Ok(())
}
