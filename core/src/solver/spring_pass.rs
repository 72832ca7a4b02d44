//! The parallel spring-force pass: each worker adds its part's spring forces into its own
//! force window, then each worker sums the windows over its own range of nodes and hands
//! the total to a per-node callback (the integrator's update). Two dispatches per pass, no
//! atomics per spring, no allocation.

use super::disjoint::DisjointSlice;
use super::simd::SimdLevel;
use super::spring_kernels::{ForceWindow, NodeView, accumulate_part};
use super::spring_layout::SpringLayout;
use super::vec3s::Vec3s;
use super::worker_pool::WorkerPool;
use crate::model::SpringSet;
use crate::real::Real;
use std::ops::Range;

/// Nodes per block handed to the per-node callback.
pub const NODE_CHUNK: usize = 256;

struct Window<T> {
    f: Vec3s<T>,
    lo: usize,
    hi: usize,
}

/// Spring forces of a model, computed in parallel.
pub struct SpringPass<T> {
    layout: SpringLayout<T>,
    windows: Vec<Window<T>>,
    node_ranges: Vec<Range<usize>>,
    /// Instruction set the kernels use.
    pub level: SimdLevel,
    /// Whether the dashpots along springs are evaluated.
    pub damping: bool,
}

impl<T: Real> SpringPass<T> {
    /// Lays out `springs` of a model of `nodes` nodes for `threads` workers; `share` lets
    /// runs of identical springs share one parameter entry ([`SpringLayout::with_sharing`]).
    pub fn new(
        springs: &SpringSet,
        nodes: usize,
        threads: usize,
        level: SimdLevel,
        damping: bool,
        share: bool,
    ) -> Self {
        let threads = threads.max(1);
        let layout = SpringLayout::<T>::with_sharing(springs, threads, share);
        let windows = (0..threads)
            .map(|t| {
                let (lo, hi) = if threads == 1 {
                    (0, nodes)
                } else {
                    let (lo, hi) = layout.window(t);
                    (lo as usize, hi as usize)
                };
                Window { f: Vec3s::zeros(hi.saturating_sub(lo)), lo, hi: hi.max(lo) }
            })
            .collect();
        let node_ranges = (0..threads).map(|t| nodes * t / threads..nodes * (t + 1) / threads).collect();
        Self { layout, windows, node_ranges, level: level.clamp_to_cpu(), damping }
    }

    /// The streaming layout.
    pub fn layout(&self) -> &SpringLayout<T> {
        &self.layout
    }

    /// Computes spring forces at positions `x` (m) and velocities `v` (m/s) into the
    /// workers' windows. Read them with [`SpringPass::for_each_block`].
    ///
    /// `pool` must have as many workers as the pass was laid out for.
    pub fn accumulate(&mut self, pool: &WorkerPool, x: &Vec3s<T>, v: &Vec3s<T>) {
        assert_eq!(pool.threads(), self.windows.len(), "pool and layout thread counts differ");
        let nodes = NodeView { x: x.slices(), v: v.slices() };
        let (level, damping, layout) = (self.level, self.damping, &self.layout);
        let window_slots = DisjointSlice::new(&mut self.windows);
        pool.run(&|t| {
            // SAFETY: worker t touches only window t.
            let w = unsafe { &mut window_slots.range_mut(t..t + 1)[0] };
            w.f.fill_zero();
            let mut out = ForceWindow { f: w.f.slices_mut(), lo: w.lo };
            accumulate_part(level, layout, t, damping, &nodes, &mut out);
        });
    }

    /// Calls `per_node(range, f)` once per block of at most [`NODE_CHUNK`] nodes, from the
    /// worker owning the block, with `f` the total spring force on those nodes (N) from the
    /// last [`SpringPass::accumulate`].
    pub fn for_each_block<F>(&self, pool: &WorkerPool, per_node: F)
    where
        F: Fn(Range<usize>, [&[T]; 3]) + Sync,
    {
        let windows = &self.windows;
        let node_ranges = &self.node_ranges;
        pool.run(&|t| {
            let range = node_ranges[t].clone();
            let mut fx = [T::ZERO; NODE_CHUNK];
            let mut fy = [T::ZERO; NODE_CHUNK];
            let mut fz = [T::ZERO; NODE_CHUNK];
            let mut start = range.start;
            while start < range.end {
                let end = (start + NODE_CHUNK).min(range.end);
                let n = end - start;
                fx[..n].fill(T::ZERO);
                fy[..n].fill(T::ZERO);
                fz[..n].fill(T::ZERO);
                for w in windows {
                    let (s, e) = (start.max(w.lo), end.min(w.hi));
                    if s >= e {
                        continue;
                    }
                    let (src, dst) = (s - w.lo..e - w.lo, s - start..e - start);
                    for (d, s) in fx[dst.clone()].iter_mut().zip(&w.f.x[src.clone()]) {
                        *d += *s;
                    }
                    for (d, s) in fy[dst.clone()].iter_mut().zip(&w.f.y[src.clone()]) {
                        *d += *s;
                    }
                    for (d, s) in fz[dst].iter_mut().zip(&w.f.z[src]) {
                        *d += *s;
                    }
                }
                per_node(start..end, [&fx[..n], &fy[..n], &fz[..n]]);
                start = end;
            }
        });
    }
}
