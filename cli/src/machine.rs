//! One line describing the machine, printed above every benchmark table.

use lamina_core::solver::SimdLevel;

/// CPU model, logical CPUs, widest SIMD level, OS.
pub fn describe() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let cpus = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    format!("{cpu}, {cpus} logical CPUs, SIMD {}, {}", SimdLevel::detect(), std::env::consts::OS)
}
