//! Timings and latencies kept per frame and summarised as percentiles at exit.

use std::time::Instant;

/// Samples of one quantity in nanoseconds.
#[derive(Debug, Clone, Default)]
pub struct Samples {
    values: Vec<u64>,
}

/// Percentiles of a [`Samples`] set, nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Summary {
    /// Number of samples.
    pub count: usize,
    /// Median.
    pub p50: u64,
    /// 99th percentile (nearest rank).
    pub p99: u64,
    /// Largest.
    pub max: u64,
}

impl Samples {
    /// Adds one sample, ns.
    pub fn push(&mut self, ns: u64) {
        self.values.push(ns);
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.values.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.values.is_empty()
    }

    /// Percentiles of all samples so far (zeros when empty).
    pub fn summary(&self) -> Summary {
        self.summary_of_last(self.values.len())
    }

    /// Percentiles of the last `n` samples (zeros when empty).
    pub fn summary_of_last(&self, n: usize) -> Summary {
        let mut v = self.values[self.values.len().saturating_sub(n)..].to_vec();
        if v.is_empty() {
            return Summary::default();
        }
        v.sort_unstable();
        let rank = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Summary { count: v.len(), p50: rank(0.5), p99: rank(0.99), max: v[v.len() - 1] }
    }
}

impl Summary {
    /// "p50 1.23 ms, p99 4.56 ms, max 7.89 ms (n = 10)".
    pub fn to_ms_string(&self) -> String {
        format!(
            "p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms (n = {})",
            ms(self.p50),
            ms(self.p99),
            ms(self.max),
            self.count
        )
    }
}

/// Nanoseconds as milliseconds.
pub fn ms(ns: u64) -> f64 {
    ns as f64 / 1e6
}

/// Nanoseconds elapsed since `start`.
pub fn elapsed_ns(start: Instant) -> u64 {
    start.elapsed().as_nanos().min(u128::from(u64::MAX)) as u64
}

/// Where one frame's time went, nanoseconds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameTiming {
    /// CPU tessellation (patches, sections, springs, tool).
    pub tessellate_ns: u64,
    /// Upload, draw and wait until the GPU (lavapipe: CPU threads) has finished.
    pub render_ns: u64,
    /// Copy to the CPU and unpack (0 when nothing is read back).
    pub readback_ns: u64,
}

/// Per-stage samples over a run.
#[derive(Debug, Clone, Default)]
pub struct FrameTimes {
    /// Tessellation.
    pub tessellate: Samples,
    /// Render.
    pub render: Samples,
    /// Readback.
    pub readback: Samples,
    /// Whole frame (all three plus overlay and PNG writing).
    pub total: Samples,
}

impl FrameTimes {
    /// Records one frame.
    pub fn push(&mut self, t: &FrameTiming, total_ns: u64) {
        self.tessellate.push(t.tessellate_ns);
        self.render.push(t.render_ns);
        self.readback.push(t.readback_ns);
        self.total.push(total_ns);
    }
}
