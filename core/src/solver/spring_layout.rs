//! The solver's streaming order of springs.
//!
//! A model lists springs in file order. Mass-spring models built on grids (the yardstick
//! lattice, the generator's limbs) contain long *runs*: springs `(a0+i, b0+i)` for
//! `i = 0..len`, i.e. consecutive first nodes and a constant index offset. Inside a run every
//! load and every force accumulation is a unit-stride slice, so the force kernel is a plain
//! loop that vectorises with no gathers, no scatters and no conflicts. Springs that belong to
//! no run of at least [`MIN_RUN_LEN`] go to a *loose* list handled spring by spring.
//!
//! Runs are sorted by first node, so one sweep walks memory forward, and they are cut into
//! per-thread parts of equal spring counts; each part accumulates into its own window of
//! the force arrays (no atomics), and the windows are summed per node afterwards.

use super::lane_block::{LANES, f16_from_f64};
use super::spring_pack::{
    PACKED_RELATIVE_BOUND, PackError, PackedLinear, PackedRecord, PackedRun, decode, f32_ulp, scale_of,
};
use crate::law::SpringLaw;
use crate::model::SpringSet;
use crate::real::Real;
use std::collections::HashMap;

/// Shortest run kept as a run; shorter ones go to the loose list. Default 4.
pub const MIN_RUN_LEN: usize = 4;

/// Springs `(a0 + i, b0 + i)` for `i in 0..len`, whose parameters sit at `first + i`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Run {
    /// First node of the first spring.
    pub a0: u32,
    /// Second node of the first spring.
    pub b0: u32,
    /// Number of springs.
    pub len: u32,
    /// Index of the first spring's parameters in the block's parameter arrays.
    pub first: u32,
    /// When every real spring of the run has the same parameters: their index in
    /// [`SpringBlock::shared`], so the kernel reads one entry instead of a stream. Else
    /// [`NO_ENTRY`].
    pub shared: u32,
    /// For a shared-parameter run that bridges gaps: index in [`SpringBlock::active`] of
    /// the run's first spring (1 = real spring, 0 = null spring). Else [`NO_ENTRY`].
    pub mask: u32,
}

impl Run {
    /// A run with its parameters streamed per spring.
    pub fn streamed(a0: u32, b0: u32, len: u32, first: u32) -> Self {
        Self { a0, b0, len, first, shared: NO_ENTRY, mask: NO_ENTRY }
    }
}

/// Marks an absent index in [`Run::shared`] and [`Run::mask`].
pub const NO_ENTRY: u32 = u32::MAX;

/// Columns of per-spring parameters that runs can share.
pub trait ParamTable: Default {
    /// Whether entries `i` and `j` are bitwise equal in every column.
    fn same(&self, i: usize, j: usize) -> bool;
    /// Appends a copy of `other`'s entry `i`.
    fn push_from(&mut self, other: &Self, i: usize);
    /// Number of entries.
    fn entries(&self) -> usize;
}

macro_rules! param_table {
    ($ty:ident: $first:ident $(, $col:ident)*) => {
        impl<T: Real> ParamTable for $ty<T> {
            fn same(&self, i: usize, j: usize) -> bool {
                self.$first[i].to_f64().to_bits() == self.$first[j].to_f64().to_bits()
                    $(&& self.$col[i].to_f64().to_bits() == self.$col[j].to_f64().to_bits())*
            }
            fn push_from(&mut self, other: &Self, i: usize) {
                self.$first.push(other.$first[i]);
                $(self.$col.push(other.$col[i]);)*
            }
            fn entries(&self) -> usize {
                self.$first.len()
            }
        }
    };
}
param_table!(LinearParams: rest, k, c);
param_table!(BilinearParams: rest, k1, k2, kc, turn, c);

/// Per-spring parameters of linear springs, in streaming order.
#[derive(Clone, Debug, Default)]
pub struct LinearParams<T> {
    /// Rest length, m.
    pub rest: Vec<T>,
    /// Stiffness, N/m.
    pub k: Vec<T>,
    /// Dashpot, N·s/m.
    pub c: Vec<T>,
}

/// Per-spring parameters of bilinear springs, in streaming order.
#[derive(Clone, Debug, Default)]
pub struct BilinearParams<T> {
    /// Rest length, m.
    pub rest: Vec<T>,
    /// First-phase stiffness, N/m.
    pub k1: Vec<T>,
    /// Second-phase stiffness, N/m.
    pub k2: Vec<T>,
    /// Compression stiffness, N/m.
    pub kc: Vec<T>,
    /// Stretch at the turning point, `TurnLen − RestLen`, m.
    pub turn: Vec<T>,
    /// Dashpot, N·s/m.
    pub c: Vec<T>,
}

/// One thread's share of a block.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Part {
    /// Range of runs.
    pub runs: std::ops::Range<usize>,
    /// Range of loose springs.
    pub loose: std::ops::Range<usize>,
}

/// Springs of one law family in streaming order.
#[derive(Clone, Debug, Default)]
pub struct SpringBlock<P> {
    /// Runs, sorted by `a0`.
    pub runs: Vec<Run>,
    /// Loose springs' end nodes; their parameters follow the runs' in `params`.
    pub loose_a: Vec<u32>,
    /// Second end nodes of loose springs.
    pub loose_b: Vec<u32>,
    /// Index in `params` of the first loose spring.
    pub loose_first: usize,
    /// Parameters, one entry per spring: runs' springs first, then loose ones.
    pub params: P,
    /// Parameters shared by every real spring of a run ([`Run::shared`]); a lattice of one
    /// material per layer streams almost no parameters.
    pub shared: P,
    /// 1 for a real spring, 0 for a null spring, for shared-parameter runs with gaps
    /// ([`Run::mask`]).
    pub active: Vec<u8>,
    /// Canonical (model) index of each spring in `params` order.
    pub source: Vec<u32>,
    /// Per-thread parts.
    pub parts: Vec<Part>,
}

impl<P> SpringBlock<P> {
    /// Number of springs in the block.
    pub fn len(&self) -> usize {
        self.source.len()
    }

    /// Lowest and one-past-highest node touched by part `t`.
    pub fn part_node_bounds(&self, t: usize) -> Option<(u32, u32)> {
        let part = self.parts.get(t)?;
        let mut lo = u32::MAX;
        let mut hi = 0u32;
        for r in &self.runs[part.runs.clone()] {
            lo = lo.min(r.a0.min(r.b0));
            hi = hi.max(r.a0.max(r.b0) + r.len);
        }
        for i in part.loose.clone() {
            let (a, b) = (self.loose_a[i], self.loose_b[i]);
            lo = lo.min(a.min(b));
            hi = hi.max(a.max(b) + 1);
        }
        (lo < hi).then_some((lo, hi))
    }
}

/// All springs of a model in the solver's streaming layout.
#[derive(Clone, Debug, Default)]
pub struct SpringLayout<T> {
    /// Linear springs.
    pub linear: SpringBlock<LinearParams<T>>,
    /// The linear runs' parameters packed ([`super::spring_pack`]), when every run streams
    /// its parameters (no sharing), the precision is f32 and every spring packs within the
    /// stated bounds; the kernel then reads these instead of `linear.params`.
    pub packed: Option<PackedLinear<T>>,
    /// Bilinear springs.
    pub bilinear: SpringBlock<BilinearParams<T>>,
}

/// Largest gap in first nodes that a run bridges with null springs (zero stiffness and
/// damping between two real nodes). Bridging the row ends of a grid turns many short runs
/// into a few long ones at the cost of about one null spring per row. Default 2.
pub const MAX_BRIDGED_GAP: u32 = 2;

/// Pieces shorter than this are never bridged: bridging short pieces would add null
/// springs in a proportion that costs more than the longer runs save. Default 16.
pub const BRIDGE_MIN_PIECE: usize = 16;

/// Runs are cut at node indices that are multiples of this (a multiple of every vector
/// width), the same for every offset, and sorted by first node, so the segments of all
/// offsets over the same nodes form a *group* that the kernel sweeps together, loading the
/// first nodes once. Default 128.
pub const SEGMENT_LEN: u32 = 128;

/// Marks a null spring in [`SpringBlock::source`].
pub const NULL_SPRING: u32 = u32::MAX;

/// A run before parameters are attached: members are canonical indices, or
/// [`NULL_SPRING`] for bridging springs.
type RawRun = (Run, Vec<u32>);

/// Orders springs `(a, b, canonical index)` (with `a < b`) into runs; returns the runs and
/// the loose springs' canonical indices in storage order.
fn find_runs(pairs: &[(u32, u32, u32)]) -> (Vec<RawRun>, Vec<u32>) {
    let mut by_offset: HashMap<u32, Vec<(u32, u32)>> = HashMap::new();
    for &(a, b, src) in pairs {
        by_offset.entry(b - a).or_default().push((a, src));
    }
    let mut runs: Vec<RawRun> = Vec::new();
    let mut loose = Vec::new();
    let mut offsets: Vec<u32> = by_offset.keys().copied().collect();
    offsets.sort_unstable();
    for off in offsets {
        let mut list = by_offset.remove(&off).unwrap_or_default();
        list.sort_unstable();
        // Maximal runs of consecutive first nodes.
        let mut pieces: Vec<(usize, usize)> = Vec::new();
        let mut start = 0;
        while start < list.len() {
            let mut end = start + 1;
            while end < list.len() && list[end].0 == list[end - 1].0 + 1 {
                end += 1;
            }
            pieces.push((start, end));
            start = end;
        }
        // Bridge a small gap between two long pieces with null springs.
        let mut groups: Vec<Vec<(usize, usize)>> = Vec::new();
        for piece in pieces {
            if let Some(group) = groups.last_mut() {
                let last = *group.last().expect("groups are never empty");
                // Two springs on the same pair of nodes (a model may repeat one) give equal
                // first nodes across the pieces: no gap to bridge.
                let gap = list[piece.0].0.checked_sub(list[last.1 - 1].0 + 1);
                let long = |p: (usize, usize)| p.1 - p.0 >= BRIDGE_MIN_PIECE;
                if gap.is_some_and(|g| g <= MAX_BRIDGED_GAP) && long(last) && long(piece) {
                    group.push(piece);
                    continue;
                }
            }
            groups.push(vec![piece]);
        }
        for group in groups {
            let real: usize = group.iter().map(|p| p.1 - p.0).sum();
            if real < MIN_RUN_LEN {
                for p in group {
                    loose.extend_from_slice(&list[p.0..p.1]);
                }
                continue;
            }
            let mut members = Vec::with_capacity(real + MAX_BRIDGED_GAP as usize * group.len());
            for (k, p) in group.iter().enumerate() {
                if k > 0 {
                    let gap = (list[p.0].0 - list[group[k - 1].1 - 1].0 - 1) as usize;
                    members.extend(std::iter::repeat_n(NULL_SPRING, gap));
                }
                members.extend(list[p.0..p.1].iter().map(|e| e.1));
            }
            let a0 = list[group[0].0].0;
            // Cuts fall on multiples of SEGMENT_LEN in node index, the same for every
            // offset, so runs of different offsets over the same nodes line up in groups.
            let mut cut = 0usize;
            while cut < members.len() {
                let a = a0 + cut as u32;
                let to_boundary = (SEGMENT_LEN - a % SEGMENT_LEN) as usize;
                let len = (members.len() - cut).min(to_boundary);
                runs.push((Run::streamed(a, a + off, len as u32, 0), members[cut..cut + len].to_vec()));
                cut += len;
            }
        }
    }
    runs.sort_by_key(|(r, _)| (r.a0, r.len, r.b0));
    loose.sort_unstable();
    (runs, loose.into_iter().map(|p| p.1).collect())
}

/// Whether two runs adjacent in storage order belong to one group (same first nodes).
pub fn same_group(a: &Run, b: &Run) -> bool {
    a.a0 == b.a0 && a.len == b.len
}

/// Cuts `runs` and `loose` into `threads` parts of about equal spring counts.
fn cut_parts(runs: &[Run], loose_len: usize, threads: usize) -> Vec<Part> {
    let threads = threads.max(1);
    let total: usize = runs.iter().map(|r| r.len as usize).sum::<usize>() + loose_len;
    let mut parts = Vec::with_capacity(threads);
    let mut run_start = 0;
    let mut loose_start = 0;
    let mut done = 0usize;
    for t in 0..threads {
        let target = total * (t + 1) / threads;
        let mut run_end = run_start;
        // Whole groups only (runs with the same first node and length): the kernel sweeps
        // a group's runs together.
        while run_end < runs.len() && done + (runs[run_end].len as usize) / 2 < target {
            done += runs[run_end].len as usize;
            run_end += 1;
            while run_end < runs.len() && same_group(&runs[run_end - 1], &runs[run_end]) {
                done += runs[run_end].len as usize;
                run_end += 1;
            }
        }
        let loose_target = loose_len * (t + 1) / threads;
        let loose_end = if t + 1 == threads { loose_len } else { loose_target };
        let run_end = if t + 1 == threads { runs.len() } else { run_end };
        done += loose_end - loose_start;
        parts.push(Part { runs: run_start..run_end, loose: loose_start..loose_end });
        run_start = run_end;
        loose_start = loose_end;
    }
    parts
}

/// Builds a block: `select` keeps the springs of this family; `push` appends a kept
/// spring's parameters (`None`: a null spring).
fn build_block<P: ParamTable>(
    springs: &SpringSet,
    threads: usize,
    share: bool,
    select: impl Fn(&SpringLaw) -> bool,
    mut push: impl FnMut(&mut P, Option<usize>),
) -> SpringBlock<P> {
    let pairs: Vec<(u32, u32, u32)> = (0..springs.len())
        .filter(|&i| select(&springs.law[i]))
        .map(|i| {
            let (a, b) = (springs.a[i], springs.b[i]);
            (a.min(b), a.max(b), i as u32)
        })
        .collect();
    let (runs, loose) = find_runs(&pairs);
    let mut block = SpringBlock::<P>::default();
    for (mut run, members) in runs {
        let first = block.source.len();
        run.first = first as u32;
        for &src in &members {
            push(&mut block.params, (src != NULL_SPRING).then_some(src as usize));
            block.source.push(src);
        }
        let real: Vec<usize> = (0..members.len()).filter(|&i| members[i] != NULL_SPRING).map(|i| first + i).collect();
        if let Some(&r0) = real.first()
            && share
            && real.iter().all(|&r| block.params.same(r0, r))
        {
            run.shared = block.shared.entries() as u32;
            block.shared.push_from(&block.params, r0);
            if real.len() < members.len() {
                run.mask = block.active.len() as u32;
                block.active.extend(members.iter().map(|&m| u8::from(m != NULL_SPRING)));
            }
        }
        block.runs.push(run);
    }
    block.loose_first = block.source.len();
    for src in loose {
        let (a, b) = (springs.a[src as usize], springs.b[src as usize]);
        block.loose_a.push(a.min(b));
        block.loose_b.push(a.max(b));
        push(&mut block.params, Some(src as usize));
        block.source.push(src);
    }
    block.parts = cut_parts(&block.runs, block.loose_a.len(), threads);
    block
}

impl<T: Real> SpringLayout<T> {
    /// Streaming layout of `springs`, cut into `threads` parts, runs of identical springs
    /// sharing one parameter entry.
    #[cfg(test)]
    pub fn new(springs: &SpringSet, threads: usize) -> Self {
        Self::with_sharing(springs, threads, true)
    }

    /// As [`SpringLayout::new`]; with `share` false every run streams its parameters.
    pub fn with_sharing(springs: &SpringSet, threads: usize, share: bool) -> Self {
        let r = |v: f64| T::from_f64(v);
        let linear = build_block::<LinearParams<T>>(
            springs,
            threads,
            share,
            |law| matches!(law, SpringLaw::Linear { .. }),
            |p, i| {
                let (rest, k, c) = match i.map(|i| (springs.rest_length[i], springs.law[i], springs.damping[i])) {
                    Some((rest, SpringLaw::Linear { stiffness }, c)) => (rest, stiffness, c),
                    _ => (0.0, 0.0, 0.0),
                };
                p.rest.push(r(rest));
                p.k.push(r(k));
                p.c.push(r(c));
            },
        );
        let bilinear = build_block::<BilinearParams<T>>(
            springs,
            threads,
            share,
            |law| matches!(law, SpringLaw::Bilinear(_)),
            |p, i| {
                let (rest, b, c) = match i.map(|i| (springs.rest_length[i], springs.law[i], springs.damping[i])) {
                    Some((rest, SpringLaw::Bilinear(b), c)) => (rest, b, c),
                    _ => (0.0, crate::law::Bilinear { k1: 0.0, k2: 0.0, turn_length: 0.0, k_compression: 0.0 }, 0.0),
                };
                p.rest.push(r(rest));
                p.k1.push(r(b.k1));
                p.k2.push(r(b.k2));
                p.kc.push(r(b.k_compression));
                p.turn.push(r(b.turn_length - rest));
                p.c.push(r(c));
            },
        );
        let packed = if share { None } else { pack_linear(&linear).ok() };
        Self { linear, bilinear, packed }
    }

    /// Total number of springs in the layout, null springs included.
    pub fn len(&self) -> usize {
        self.linear.len() + self.bilinear.len()
    }

    /// Null springs added to bridge gaps in runs.
    #[cfg(test)]
    pub fn null_springs(&self) -> usize {
        let count = |src: &[u32]| src.iter().filter(|&&s| s == NULL_SPRING).count();
        count(&self.linear.source) + count(&self.bilinear.source)
    }

    /// Node window `[lo, hi)` that thread `t` accumulates forces into.
    pub fn window(&self, t: usize) -> (u32, u32) {
        let a = self.linear.part_node_bounds(t);
        let b = self.bilinear.part_node_bounds(t);
        match (a, b) {
            (Some(a), Some(b)) => (a.0.min(b.0), a.1.max(b.1)),
            (Some(w), None) | (None, Some(w)) => w,
            (None, None) => (0, 0),
        }
    }
}

/// Packs `block`'s runs (its loose springs keep their f32 entries).
///
/// # Errors
/// [`PackError`]: `T` is not f32, or a spring does not pack within the stated bounds.
pub fn pack_linear<T: Real>(block: &SpringBlock<LinearParams<T>>) -> Result<PackedLinear<T>, PackError> {
    if T::NAME != "f32" {
        return Err(PackError::NotF32);
    }
    let p = &block.params;
    let mut out = PackedLinear {
        runs: Vec::with_capacity(block.runs.len()),
        first_record: vec![0; block.runs.len()],
        records: Vec::new(),
    };
    // Bases of every run.
    for (r, run) in block.runs.iter().enumerate() {
        let first = run.first as usize;
        let real: Vec<usize> = (first..first + run.len as usize).filter(|&s| block.source[s] != NULL_SPRING).collect();
        let base = real.iter().map(|&s| p.rest[s].to_f64() as f32).fold(f32::INFINITY, f32::min);
        let base = if real.is_empty() { 0.0 } else { base };
        let unit = f32_ulp(base);
        if !base.is_finite() || !unit.is_finite() {
            return Err(PackError::RestSpread { run: r });
        }
        let k: Vec<T> = real.iter().map(|&s| p.k[s]).collect();
        let c: Vec<T> = real.iter().map(|&s| p.c[s]).collect();
        out.runs.push(PackedRun {
            base: T::from_f64(base.into()),
            unit: T::from_f64(unit.into()),
            k_max: scale_of(&k),
            c_max: scale_of(&c),
        });
    }
    // Records, group by group, lane block by lane block, run by run.
    let runs = &block.runs;
    let mut start = 0;
    while start < runs.len() {
        let mut end = start + 1;
        while end < runs.len() && same_group(&runs[start], &runs[end]) {
            end += 1;
        }
        let len = runs[start].len as usize;
        let group_first = out.records.len();
        for (j, r) in (start..end).enumerate() {
            out.first_record[r] = (group_first + j) as u32;
        }
        for done in (0..len).step_by(LANES) {
            for r in start..end {
                let pr = out.runs[r];
                let mut rec = PackedRecord::default();
                for l in 0..LANES.min(len - done) {
                    let s = runs[r].first as usize + done + l;
                    if block.source[s] == NULL_SPRING {
                        // k = c = 0: no force, whatever the rest length.
                        continue;
                    }
                    let (rest, k, c) = (p.rest[s], p.k[s], p.c[s]);
                    let steps = (rest.to_f64() - pr.base.to_f64()) / pr.unit.to_f64();
                    if !(0.0..=65535.0).contains(&steps) || steps.fract() != 0.0 {
                        return Err(PackError::RestSpread { run: r });
                    }
                    rec.rest[l] = steps as u16;
                    rec.k[l] = f16_from_f64(k.to_f64() / pr.k_max.to_f64());
                    rec.c[l] = f16_from_f64(c.to_f64() / pr.c_max.to_f64());
                    let [rest2, k2, c2] = decode(&pr, &rec, l);
                    let close = |got: T, want: T| {
                        (got.to_f64() - want.to_f64()).abs() <= PACKED_RELATIVE_BOUND * want.to_f64().abs()
                    };
                    if rest2.to_f64() != rest.to_f64() {
                        return Err(PackError::RestSpread { run: r });
                    }
                    if !close(k2, k) || !close(c2, c) {
                        return Err(PackError::Factor { run: r });
                    }
                }
                out.records.push(rec);
            }
        }
        start = end;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chain(n: u32) -> SpringSet {
        let mut s = SpringSet::default();
        for i in 0..n - 1 {
            s.push(i + 1, i, 1.0, SpringLaw::Linear { stiffness: 1.0 }, 0.0, 0);
        }
        s.push(0, n - 1, 1.0, SpringLaw::Linear { stiffness: 2.0 }, 0.0, 0);
        s
    }

    #[test]
    fn layout_of_a_repeated_spring_keeps_both_works() {
        // A chain of 20 springs with the spring 5-6 given twice (a model may repeat one):
        // both copies are laid out, each spring once, no gap bridged between them.
        let mut s = SpringSet::default();
        for a in 0u32..20 {
            s.push(a, a + 1, 1.0, SpringLaw::Linear { stiffness: 3.0 }, 0.1, 0);
        }
        s.push(5, 6, 1.0, SpringLaw::Linear { stiffness: 3.0 }, 0.1, 0);
        let layout = SpringLayout::<f64>::new(&s, 1);
        assert_eq!(layout.null_springs(), 0);
        let mut sources: Vec<u32> = layout.linear.source.iter().copied().filter(|&i| i != NULL_SPRING).collect();
        sources.sort_unstable();
        assert_eq!(sources, (0u32..21).collect::<Vec<_>>());
    }

    #[test]
    fn layout_chain_forms_one_run_and_one_loose_works() {
        let layout = SpringLayout::<f64>::new(&chain(10), 1);
        // Nine springs of stiffness 1 in a run: one shared parameter entry, no mask.
        assert_eq!(layout.linear.runs, vec![Run { shared: 0, ..Run::streamed(0, 1, 9, 0) }]);
        assert_eq!(layout.linear.shared.k, vec![1.0]);
        assert_eq!(layout.linear.loose_a, vec![0]);
        assert_eq!(layout.linear.loose_b, vec![9]);
        assert_eq!(layout.linear.params.k[9], 2.0);
        let mut src = layout.linear.source.clone();
        src.sort_unstable();
        assert_eq!(src, (0..10).collect::<Vec<_>>());
    }

    #[test]
    fn layout_bridges_small_gaps_with_null_springs_works() {
        // Two pieces of 20 springs with first nodes 0..20 and 22..42: one run with 2 nulls.
        let mut s = SpringSet::default();
        for a in (0u32..20).chain(22..42) {
            s.push(a, a + 1, 1.0, SpringLaw::Linear { stiffness: 3.0 }, 0.1, 0);
        }
        let layout = SpringLayout::<f64>::new(&s, 1);
        assert_eq!(layout.linear.runs, vec![Run { shared: 0, mask: 0, ..Run::streamed(0, 1, 42, 0) }]);
        let active: Vec<u8> = (0..42).map(|i| u8::from(!(20..22).contains(&i))).collect();
        assert_eq!(layout.linear.active, active);
        assert_eq!((layout.linear.shared.k.as_slice(), layout.linear.shared.c.as_slice()), (&[3.0][..], &[0.1][..]));
        assert_eq!(layout.null_springs(), 2);
        assert_eq!(&layout.linear.params.k[20..22], &[0.0, 0.0]);
        assert_eq!(&layout.linear.params.c[20..22], &[0.0, 0.0]);
        assert_eq!(layout.linear.source[20], NULL_SPRING);
    }

    #[test]
    fn layout_run_of_differing_springs_streams_its_parameters_works() {
        let mut s = SpringSet::default();
        for a in 0u32..20 {
            s.push(a, a + 1, 1.0, SpringLaw::Linear { stiffness: if a == 7 { 4.0 } else { 3.0 } }, 0.1, 0);
        }
        let layout = SpringLayout::<f32>::new(&s, 1);
        assert_eq!(layout.linear.runs, vec![Run::streamed(0, 1, 20, 0)]);
        assert!(layout.linear.shared.k.is_empty() && layout.linear.active.is_empty());
    }

    #[test]
    fn layout_short_pieces_are_not_bridged_works() {
        let mut s = SpringSet::default();
        for a in [0u32, 1, 2, 5, 6, 7] {
            s.push(a, a + 1, 1.0, SpringLaw::Linear { stiffness: 3.0 }, 0.1, 0);
        }
        let layout = SpringLayout::<f64>::new(&s, 1);
        assert_eq!(layout.null_springs(), 0);
        assert_eq!(layout.linear.loose_a.len(), 6);
    }

    #[test]
    fn layout_long_runs_are_cut_into_segments_works() {
        let layout = SpringLayout::<f32>::new(&chain(1000), 1);
        assert_eq!(layout.linear.runs.len(), 999usize.div_ceil(SEGMENT_LEN as usize));
        assert!(layout.linear.runs.iter().all(|r| r.len <= SEGMENT_LEN));
        assert!(layout.linear.runs.windows(2).all(|w| w[0].a0 + w[0].len == w[1].a0));
    }

    #[test]
    fn layout_parts_cover_every_spring_once_works() {
        let layout = SpringLayout::<f32>::new(&chain(1000), 3);
        let parts = &layout.linear.parts;
        assert_eq!(parts.len(), 3);
        assert_eq!(parts[0].runs.start, 0);
        assert_eq!(parts[2].runs.end, layout.linear.runs.len());
        assert_eq!(parts[2].loose.end, layout.linear.loose_a.len());
        for w in parts.windows(2) {
            assert_eq!(w[0].runs.end, w[1].runs.start);
            assert_eq!(w[0].loose.end, w[1].loose.start);
        }
    }
}
