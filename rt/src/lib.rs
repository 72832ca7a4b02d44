//! Real-time plumbing: clocks, fixed-rate loops, the deadline monitor.
