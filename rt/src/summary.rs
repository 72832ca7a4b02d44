//! [`MonitorSummary`]: a plain, copyable snapshot of a
//! [`DeadlineMonitor`](crate::DeadlineMonitor), printable as a table and
//! serialisable as the JSON report.

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::worst::WorstTicks;

/// Distribution of one per-tick quantity, ns.
///
/// Percentiles come from an HDR histogram with 3 significant digits: each is
/// the highest value equivalent to the true percentile, within 0.1 % of it,
/// and clamped to the exact `max_ns`. `min_ns` and `max_ns` are exact.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Percentiles {
    /// Number of values recorded.
    pub count: u64,
    /// Smallest value, ns (exact; 0 when `count == 0`).
    pub min_ns: u64,
    /// Median, ns.
    pub p50_ns: u64,
    /// 90th percentile, ns.
    pub p90_ns: u64,
    /// 99th percentile, ns.
    pub p99_ns: u64,
    /// 99.9th percentile, ns.
    pub p999_ns: u64,
    /// Largest value, ns (exact, even above the histogram's range).
    pub max_ns: u64,
    /// Mean, ns: exact (from a running sum), rounded to the nearest ns.
    pub mean_ns: u64,
    /// Values above the histogram's range, recorded as its maximum.
    pub saturated: u64,
}

/// A snapshot of a [`DeadlineMonitor`](crate::DeadlineMonitor). All times ns.
///
/// Produced by [`DeadlineMonitor::summary`](crate::DeadlineMonitor::summary)
/// without allocating; `Display` prints it as a table, serde gives the JSON
/// report.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct MonitorSummary {
    /// Ticks recorded.
    pub ticks: u64,
    /// Nominal loop period, ns.
    pub period_ns: u64,
    /// Compute budget per tick, ns.
    pub budget_ns: u64,
    /// Ticks that missed: `compute_ns > budget_ns` or finished after their
    /// deadline (see [`DeadlineMonitor`](crate::DeadlineMonitor)). A tick that
    /// did both counts once.
    pub misses: u64,
    /// Ticks whose compute time exceeded the budget.
    pub budget_misses: u64,
    /// Ticks that finished after their deadline (`end_ns > deadline_ns`).
    pub deadline_misses: u64,
    /// Periods skipped by the loop ([`OverrunPolicy::Skip`](crate::OverrunPolicy::Skip)).
    pub skipped_periods: u64,
    /// Ticks run after their deadline had passed
    /// ([`OverrunPolicy::CatchUp`](crate::OverrunPolicy::CatchUp)).
    pub caught_up_ticks: u64,
    /// Wake-up lateness: wake time minus scheduled time.
    pub lateness: Percentiles,
    /// Compute time: body end minus wake time.
    pub compute: Percentiles,
    /// Actual period: wake time minus the previous tick's wake time (one
    /// fewer value than ticks).
    pub period: Percentiles,
    /// Send time reported per tick through the [`SendProbe`](crate::SendProbe).
    pub send: Percentiles,
    /// The worst ticks by lateness + compute, worst first.
    pub worst: WorstTicks,
}

/// Formats ns as µs with about 4 significant digits (3 decimals below
/// 10 µs, 2 below 100 µs, 1 below 1 ms, none above), without floating point.
/// More digits would be noise: the histograms resolve 3 significant digits.
struct Us(u64);

impl fmt::Display for Us {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ns = self.0;
        let decimals: u32 = match ns {
            0..10_000 => 3,
            10_000..100_000 => 2,
            100_000..1_000_000 => 1,
            _ => 0,
        };
        let unit = 10u64.pow(3 - decimals); // ns per last printed digit
        let scale = 10u64.pow(decimals);
        let rounded = ns / unit + u64::from(ns % unit >= unit.div_ceil(2));
        // Build the text in a stack buffer so the width applies to all of it.
        let mut buf = [0u8; 32];
        let mut w = StackWriter { buf: &mut buf, len: 0 };
        if decimals == 0 {
            fmt::write(&mut w, format_args!("{rounded}"))?;
        } else {
            let d = decimals as usize;
            fmt::write(&mut w, format_args!("{}.{:0d$}", rounded / scale, rounded % scale))?;
        }
        let len = w.len;
        let s = std::str::from_utf8(&buf[..len]).map_err(|_| fmt::Error)?;
        let width = f.width().unwrap_or(0);
        write!(f, "{s:>width$}")
    }
}

struct StackWriter<'a> {
    buf: &'a mut [u8],
    len: usize,
}

impl fmt::Write for StackWriter<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let end = self.len + s.len();
        if end > self.buf.len() {
            return Err(fmt::Error);
        }
        self.buf[self.len..end].copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

impl fmt::Display for MonitorSummary {
    /// A table, times in µs to about 4 significant digits (the JSON report
    /// has exact ns):
    ///
    /// ```text
    /// ticks 5000 at 1000.000 Hz (period 1000 µs, budget 1000 µs)
    /// misses 0 (over budget 0, after deadline 0), skipped periods 0, caught-up ticks 0
    /// µs                min         p50         p90         p99       p99.9         max        mean
    /// lateness        0.031       0.115       0.435       2.469       45.08       391.4       1.987
    /// ...
    /// ```
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let hz = if self.period_ns == 0 { 0.0 } else { 1e9 / self.period_ns as f64 };
        writeln!(
            f,
            "ticks {} at {hz:.3} Hz (period {} µs, budget {} µs)",
            self.ticks,
            Us(self.period_ns),
            Us(self.budget_ns)
        )?;
        writeln!(
            f,
            "misses {} (over budget {}, after deadline {}), skipped periods {}, caught-up ticks {}",
            self.misses, self.budget_misses, self.deadline_misses, self.skipped_periods, self.caught_up_ticks
        )?;
        writeln!(
            f,
            "{:<10}{:>12}{:>12}{:>12}{:>12}{:>12}{:>12}{:>12}",
            "µs", "min", "p50", "p90", "p99", "p99.9", "max", "mean"
        )?;
        for (name, p) in
            [("lateness", &self.lateness), ("compute", &self.compute), ("period", &self.period), ("send", &self.send)]
        {
            write!(
                f,
                "{name:<10}{:>12}{:>12}{:>12}{:>12}{:>12}{:>12}{:>12}",
                Us(p.min_ns),
                Us(p.p50_ns),
                Us(p.p90_ns),
                Us(p.p99_ns),
                Us(p.p999_ns),
                Us(p.max_ns),
                Us(p.mean_ns)
            )?;
            if p.saturated > 0 {
                write!(f, "  ({} above range)", p.saturated)?;
            }
            writeln!(f)?;
        }
        if self.worst.is_empty() {
            return Ok(());
        }
        writeln!(f, "worst ticks (by lateness + compute):")?;
        writeln!(f, "{:>12}{:>14}{:>14}{:>14}", "tick", "lateness µs", "compute µs", "total µs")?;
        for w in self.worst.as_slice() {
            writeln!(f, "{:>12}{:>14}{:>14}{:>14}", w.tick, Us(w.lateness_ns), Us(w.compute_ns), Us(w.response_ns()))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn us_formats_ns_as_micros_works() {
        assert_eq!(format!("{:>10}", Us(42)), "     0.042");
        assert_eq!(format!("{}", Us(9_999)), "9.999");
        assert_eq!(format!("{}", Us(94_079)), "94.08");
        assert_eq!(format!("{}", Us(333_333)), "333.3");
        assert_eq!(format!("{}", Us(1_000_447)), "1000");
        assert_eq!(format!("{}", Us(1_234_567)), "1235");
        assert_eq!(format!("{}", Us(0)), "0.000");
    }
}
