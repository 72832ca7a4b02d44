//! Spring force kernels over the streaming layout (see [`super::spring_layout`]).
//!
//! The layout hands over *groups*: runs of springs with the same first nodes and different
//! offsets (a lattice node's nine spring families). The kernel walks a group in lane blocks
//! of [`LANES`] first nodes: it loads their positions and velocities once, computes the
//! block's springs run by run, subtracts each run's forces from its second nodes, and sums
//! the first nodes' forces in registers, adding them to the window once per block. The
//! arithmetic is written once over [`Block`] and built three times ([`accumulate_part`]
//! picks the build for the chosen [`SimdLevel`]): plain arrays for the baseline, AVX
//! registers for AVX2 and for AVX-512 (whose 512-bit units gain nothing on a block of 8).
//! Every build performs the same operations in the same order, so all give the same bits.
//! Forces are *added* into a window of the force arrays that starts at node `lo`. Linear
//! runs whose parameters are packed ([`super::spring_pack`]) are walked the same way, each
//! run's lane block decoding its record from the group's one parameter stream.

use super::lane_block::{Block, LANES, ScalarBlock, max, min};
use super::simd::SimdLevel;
use super::spring_layout::{BilinearParams, LinearParams, NO_ENTRY, Part, Run, SpringBlock, SpringLayout, same_group};
use super::spring_pack::{PackedLinear, decode};
use crate::real::Real;

/// Springs shorter than this (m) have no direction: they exert no force, and no NaN.
pub const MIN_SPRING_LENGTH: f64 = 1e-12;

/// Read-only node state for the kernels.
#[derive(Clone, Copy)]
pub struct NodeView<'a, T> {
    /// Positions x, y, z, m.
    pub x: [&'a [T]; 3],
    /// Velocities x, y, z, m/s.
    pub v: [&'a [T]; 3],
}

/// A window `[lo, lo + len)` of the force arrays, N.
pub struct ForceWindow<'a, T> {
    /// Force components.
    pub f: [&'a mut [T]; 3],
    /// Node index of the window's first entry.
    pub lo: usize,
}

/// A spring law as the kernels see it: elastic tension from the stretch `L − L0`, read
/// from a chunk of parameter slices that all have the chunk's length (so indexing inside
/// the loop needs no bounds checks and the loop vectorises).
trait KernelLaw<T: Real>: Sync {
    /// The parameters of springs `s0 .. s0 + n`.
    type Chunk<'a>: Copy
    where
        Self: 'a;
    /// Parameters of springs `s0 .. s0 + n`.
    fn chunk(&self, s0: usize, n: usize) -> Self::Chunk<'_>;
    /// Rest length of the chunk's spring `i`, m.
    fn rest(c: &Self::Chunk<'_>, i: usize) -> T;
    /// Dashpot of spring `i`, N·s/m.
    fn damping(c: &Self::Chunk<'_>, i: usize) -> T;
    /// Elastic tension of spring `i` at `stretch`, N.
    fn tension(c: &Self::Chunk<'_>, i: usize, stretch: T) -> T;
    /// Parameters of a lane block: `[rest, damping, law...]`, per lane from the chunk's
    /// first entries, or the chunk's first entry in every lane when `shared`.
    fn block_params<B: Block<T>>(c: &Self::Chunk<'_>, shared: bool) -> [B; 6];
    /// [`KernelLaw::tension`] of a lane block, lane for lane the same operations.
    fn block_tension<B: Block<T>>(p: &[B; 6], stretch: B) -> B;
}

/// Lanes of `s` from its start, or `s[0]` in every lane.
#[inline(always)]
fn block_of<T: Real, B: Block<T>>(s: &[T], shared: bool) -> B {
    if shared { B::splat(s[0]) } else { B::load(s, 0) }
}

impl<T: Real> KernelLaw<T> for LinearParams<T> {
    type Chunk<'a> = (&'a [T], &'a [T], &'a [T]);
    #[inline(always)]
    fn chunk(&self, s0: usize, n: usize) -> Self::Chunk<'_> {
        (&self.rest[s0..s0 + n], &self.k[s0..s0 + n], &self.c[s0..s0 + n])
    }
    #[inline(always)]
    fn rest(c: &Self::Chunk<'_>, i: usize) -> T {
        c.0[i]
    }
    #[inline(always)]
    fn damping(c: &Self::Chunk<'_>, i: usize) -> T {
        c.2[i]
    }
    #[inline(always)]
    fn tension(c: &Self::Chunk<'_>, i: usize, stretch: T) -> T {
        c.1[i] * stretch
    }
    #[inline(always)]
    fn block_params<B: Block<T>>(c: &Self::Chunk<'_>, shared: bool) -> [B; 6] {
        let k = block_of(c.1, shared);
        [block_of(c.0, shared), block_of(c.2, shared), k, k, k, k]
    }
    #[inline(always)]
    fn block_tension<B: Block<T>>(p: &[B; 6], stretch: B) -> B {
        p[2].mul(stretch)
    }
}

/// Bilinear parameters of a chunk: rest, k1, k2, kc, turn, c.
type BilinearChunk<'a, T> = [&'a [T]; 6];

impl<T: Real> KernelLaw<T> for BilinearParams<T> {
    type Chunk<'a> = BilinearChunk<'a, T>;
    #[inline(always)]
    fn chunk(&self, s0: usize, n: usize) -> Self::Chunk<'_> {
        let r = s0..s0 + n;
        [
            &self.rest[r.clone()],
            &self.k1[r.clone()],
            &self.k2[r.clone()],
            &self.kc[r.clone()],
            &self.turn[r.clone()],
            &self.c[r],
        ]
    }
    #[inline(always)]
    fn rest(c: &Self::Chunk<'_>, i: usize) -> T {
        c[0][i]
    }
    #[inline(always)]
    fn damping(c: &Self::Chunk<'_>, i: usize) -> T {
        c[5][i]
    }
    #[inline(always)]
    fn tension(c: &Self::Chunk<'_>, i: usize, stretch: T) -> T {
        let turn = c[4][i];
        let pull = max(stretch, T::ZERO);
        c[3][i] * min(stretch, T::ZERO) + c[1][i] * min(pull, turn) + c[2][i] * max(pull - turn, T::ZERO)
    }
    #[inline(always)]
    fn block_params<B: Block<T>>(c: &Self::Chunk<'_>, shared: bool) -> [B; 6] {
        // [rest, damping, k1, k2, kc, turn]; no `array::map`: its closure may stay out of
        // line, compiled without this level's instructions.
        [
            block_of(c[0], shared),
            block_of(c[5], shared),
            block_of(c[1], shared),
            block_of(c[2], shared),
            block_of(c[3], shared),
            block_of(c[4], shared),
        ]
    }
    #[inline(always)]
    fn block_tension<B: Block<T>>(p: &[B; 6], stretch: B) -> B {
        let zero = B::splat(T::ZERO);
        let pull = stretch.max(zero);
        let compression = p[4].mul(stretch.min(zero));
        compression.add(p[2].mul(pull.min(p[5]))).add(p[3].mul(pull.sub(p[5]).max(zero)))
    }
}

/// Force on end `a` of spring `i` of a chunk (end `b` gets the opposite), N.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spring_force<T: Real, L: KernelLaw<T>, const DAMP: bool>(
    chunk: &L::Chunk<'_>,
    i: usize,
    dx: T,
    dy: T,
    dz: T,
    dvx: T,
    dvy: T,
    dvz: T,
    keep: bool,
) -> [T; 3] {
    let length = (dx * dx + dy * dy + dz * dz).sqrt();
    let inv = T::ONE / max(length, T::from_f64(MIN_SPRING_LENGTH));
    let (ux, uy, uz) = (dx * inv, dy * inv, dz * inv);
    let mut fs = L::tension(chunk, i, length - L::rest(chunk, i));
    if DAMP {
        fs += L::damping(chunk, i) * (dvx * ux + dvy * uy + dvz * uz);
    }
    // A null spring exerts +0 along its direction, as a streamed null spring (k = c = 0) does.
    if !keep {
        fs = T::ZERO;
    }
    [fs * ux, fs * uy, fs * uz]
}

/// Positions and velocities of the nodes from `first` on.
struct Ends<'a, T> {
    x: [&'a [T]; 3],
    v: [&'a [T]; 3],
}

impl<'a, T> Ends<'a, T> {
    #[inline(always)]
    fn at(nodes: &NodeView<'a, T>, first: usize, n: usize) -> Self {
        let r = first..first + n;
        let [x, y, z] = nodes.x;
        let [vx, vy, vz] = nodes.v;
        Self { x: [&x[r.clone()], &y[r.clone()], &z[r.clone()]], v: [&vx[r.clone()], &vy[r.clone()], &vz[r]] }
    }
}

/// The first ends' forces (N) of a full lane block of one run; `keep` zeroes null springs.
/// Lane for lane the operations of [`spring_force`].
#[inline(always)]
fn block_forces<T: Real, B: Block<T>, L: KernelLaw<T>, const DAMP: bool>(
    params: &[B; 6],
    keep: Option<&[u8]>,
    a: &[B; 6],
    b: &Ends<'_, T>,
) -> [B; 3] {
    let dx = B::load(b.x[0], 0).sub(a[0]);
    let dy = B::load(b.x[1], 0).sub(a[1]);
    let dz = B::load(b.x[2], 0).sub(a[2]);
    let length = dx.mul(dx).add(dy.mul(dy)).add(dz.mul(dz)).sqrt();
    let inv = B::splat(T::ONE).div(length.max(B::splat(T::from_f64(MIN_SPRING_LENGTH))));
    let (ux, uy, uz) = (dx.mul(inv), dy.mul(inv), dz.mul(inv));
    let mut fs = L::block_tension(params, length.sub(params[0]));
    if DAMP {
        let dvx = B::load(b.v[0], 0).sub(a[3]);
        let dvy = B::load(b.v[1], 0).sub(a[4]);
        let dvz = B::load(b.v[2], 0).sub(a[5]);
        fs = fs.add(params[1].mul(dvx.mul(ux).add(dvy.mul(uy)).add(dvz.mul(uz))));
    }
    if let Some(keep) = keep {
        fs = fs.keep(keep);
    }
    [fs.mul(ux), fs.mul(uy), fs.mul(uz)]
}

/// Where a run's parameters and null-spring mask are.
#[inline(always)]
fn run_params<'a, T: Real, L: KernelLaw<T>>(
    block: &'a SpringBlock<L>,
    run: &Run,
    done: usize,
    n: usize,
) -> (L::Chunk<'a>, bool, Option<&'a [u8]>) {
    if run.shared == NO_ENTRY {
        return (block.params.chunk(run.first as usize + done, n), false, None);
    }
    let mask = (run.mask != NO_ENTRY).then(|| {
        let m = run.mask as usize + done;
        &block.active[m..m + n]
    });
    (block.shared.chunk(run.shared as usize, 1), true, mask)
}

/// One full lane block of a group: the [`LANES`] springs starting `done` into each of its
/// runs. The first nodes' state is loaded once and their force summed in registers over
/// the runs, then added to the window once; each run's second nodes get their forces as
/// the run is visited.
#[inline(always)]
fn group_block<T: Real, B: Block<T>, L: KernelLaw<T>, const DAMP: bool>(
    block: &SpringBlock<L>,
    group: &[Run],
    done: usize,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let a = group[0].a0 as usize + done;
    let ends_a = Ends::at(nodes, a, LANES);
    let state_a: [B; 6] = [
        B::load(ends_a.x[0], 0),
        B::load(ends_a.x[1], 0),
        B::load(ends_a.x[2], 0),
        B::load(ends_a.v[0], 0),
        B::load(ends_a.v[1], 0),
        B::load(ends_a.v[2], 0),
    ];
    let mut acc = [B::splat(T::ZERO); 3];
    for run in group {
        let b = run.b0 as usize + done;
        let (chunk, shared, keep) = run_params(block, run, done, LANES);
        let params = L::block_params::<B>(&chunk, shared);
        let f = block_forces::<T, B, L, DAMP>(&params, keep, &state_a, &Ends::at(nodes, b, LANES));
        let wb = b - out.lo;
        for c in 0..3 {
            acc[c] = acc[c].add(f[c]);
            B::load(out.f[c], wb).sub(f[c]).store(out.f[c], wb);
        }
    }
    let wa = a - out.lo;
    for c in 0..3 {
        B::load(out.f[c], wa).add(acc[c]).store(out.f[c], wa);
    }
}

/// A partial lane block of `n < LANES` springs, lane by lane with the operations and the
/// order of [`group_block`] (so the same bits).
#[inline(always)]
fn group_tail<T: Real, L: KernelLaw<T>, const DAMP: bool>(
    block: &SpringBlock<L>,
    group: &[Run],
    done: usize,
    n: usize,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let a = group[0].a0 as usize + done;
    let ea = Ends::at(nodes, a, n);
    let mut acc = [[T::ZERO; 3]; LANES];
    for run in group {
        let b = run.b0 as usize + done;
        let eb = Ends::at(nodes, b, n);
        let (chunk, shared, keep) = run_params(block, run, done, n);
        let wb = b - out.lo;
        for l in 0..n {
            let d = [eb.x[0][l] - ea.x[0][l], eb.x[1][l] - ea.x[1][l], eb.x[2][l] - ea.x[2][l]];
            let dv = if DAMP {
                [eb.v[0][l] - ea.v[0][l], eb.v[1][l] - ea.v[1][l], eb.v[2][l] - ea.v[2][l]]
            } else {
                [T::ZERO; 3]
            };
            let p = if shared { 0 } else { l };
            let kept = keep.is_none_or(|k| k[l] != 0);
            let f = spring_force::<T, L, DAMP>(&chunk, p, d[0], d[1], d[2], dv[0], dv[1], dv[2], kept);
            for c in 0..3 {
                acc[l][c] += f[c];
                out.f[c][wb + l] -= f[c];
            }
        }
    }
    let wa = a - out.lo;
    for (l, acc) in acc.iter().enumerate().take(n) {
        for c in 0..3 {
            out.f[c][wa + l] += acc[c];
        }
    }
}

/// One full lane block of a group of linear runs with packed parameters: as
/// [`group_block`], the parameters decoded from the group's record stream (`records`
/// starts at this lane block's record of the group's first run).
#[inline(always)]
fn packed_group_block<T: Real, B: Block<T>, const DAMP: bool>(
    packed: &PackedLinear<T>,
    group: &[Run],
    r0: usize,
    records: usize,
    done: usize,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let a = group[0].a0 as usize + done;
    let ends_a = Ends::at(nodes, a, LANES);
    let state_a: [B; 6] = [
        B::load(ends_a.x[0], 0),
        B::load(ends_a.x[1], 0),
        B::load(ends_a.x[2], 0),
        B::load(ends_a.v[0], 0),
        B::load(ends_a.v[1], 0),
        B::load(ends_a.v[2], 0),
    ];
    let mut acc = [B::splat(T::ZERO); 3];
    let recs = &packed.records[records..records + group.len()];
    let bases = &packed.runs[r0..r0 + group.len()];
    for ((run, rec), base) in group.iter().zip(recs).zip(bases) {
        let b = run.b0 as usize + done;
        let rest = B::splat(base.base).add(B::load_u16(&rec.rest, 0).mul(B::splat(base.unit)));
        let k = B::splat(base.k_max).mul(B::load_f16(&rec.k, 0));
        let c = B::splat(base.c_max).mul(B::load_f16(&rec.c, 0));
        let params = [rest, c, k, k, k, k];
        let f = block_forces::<T, B, LinearParams<T>, DAMP>(&params, None, &state_a, &Ends::at(nodes, b, LANES));
        let wb = b - out.lo;
        for c in 0..3 {
            acc[c] = acc[c].add(f[c]);
            B::load(out.f[c], wb).sub(f[c]).store(out.f[c], wb);
        }
    }
    let wa = a - out.lo;
    for c in 0..3 {
        B::load(out.f[c], wa).add(acc[c]).store(out.f[c], wa);
    }
}

/// A partial lane block of packed runs, lane by lane with the operations of
/// [`packed_group_block`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn packed_group_tail<T: Real, const DAMP: bool>(
    packed: &PackedLinear<T>,
    group: &[Run],
    r0: usize,
    records: usize,
    done: usize,
    n: usize,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let a = group[0].a0 as usize + done;
    let ea = Ends::at(nodes, a, n);
    let mut acc = [[T::ZERO; 3]; LANES];
    for (j, run) in group.iter().enumerate() {
        let (rec, base) = (&packed.records[records + j], &packed.runs[r0 + j]);
        let b = run.b0 as usize + done;
        let eb = Ends::at(nodes, b, n);
        let wb = b - out.lo;
        for l in 0..n {
            let [rest, k, c] = decode(base, rec, l);
            let chunk: (&[T], &[T], &[T]) = (&[rest], &[k], &[c]);
            let d = [eb.x[0][l] - ea.x[0][l], eb.x[1][l] - ea.x[1][l], eb.x[2][l] - ea.x[2][l]];
            let dv = if DAMP {
                [eb.v[0][l] - ea.v[0][l], eb.v[1][l] - ea.v[1][l], eb.v[2][l] - ea.v[2][l]]
            } else {
                [T::ZERO; 3]
            };
            let f = spring_force::<T, LinearParams<T>, DAMP>(&chunk, 0, d[0], d[1], d[2], dv[0], dv[1], dv[2], true);
            for c in 0..3 {
                acc[l][c] += f[c];
                out.f[c][wb + l] -= f[c];
            }
        }
    }
    let wa = a - out.lo;
    for (l, acc) in acc.iter().enumerate().take(n) {
        for c in 0..3 {
            out.f[c][wa + l] += acc[c];
        }
    }
}

/// [`accumulate_block`] for linear runs with packed parameters.
#[inline(always)]
fn accumulate_packed<T: Real, B: Block<T>, const DAMP: bool>(
    block: &SpringBlock<LinearParams<T>>,
    packed: &PackedLinear<T>,
    part: &Part,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let mut start = part.runs.start;
    let end_all = part.runs.end;
    let runs = &block.runs;
    while start < end_all {
        let mut end = start + 1;
        while end < end_all && same_group(&runs[start], &runs[end]) {
            end += 1;
        }
        let group = &runs[start..end];
        let m = group.len();
        let len = group[0].len as usize;
        let mut records = packed.first_record[start] as usize;
        let mut done = 0;
        while done + LANES <= len {
            packed_group_block::<T, B, DAMP>(packed, group, start, records, done, nodes, out);
            records += m;
            done += LANES;
        }
        if done < len {
            packed_group_tail::<T, DAMP>(packed, group, start, records, done, len - done, nodes, out);
        }
        start = end;
    }
    // The loose springs, from the f32 parameters.
    accumulate_block::<T, B, LinearParams<T>, DAMP>(block, &Part { runs: 0..0, loose: part.loose.clone() }, nodes, out);
}

/// Adds the forces of the runs of `part` (grouped) and of its loose springs.
#[inline(always)]
fn accumulate_block<T: Real, B: Block<T>, L: KernelLaw<T>, const DAMP: bool>(
    block: &SpringBlock<L>,
    part: &Part,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let runs = &block.runs[part.runs.clone()];
    let mut start = 0;
    while start < runs.len() {
        let mut end = start + 1;
        while end < runs.len() && same_group(&runs[start], &runs[end]) {
            end += 1;
        }
        let group = &runs[start..end];
        let len = group[0].len as usize;
        let mut done = 0;
        while done + LANES <= len {
            group_block::<T, B, L, DAMP>(block, group, done, nodes, out);
            done += LANES;
        }
        if done < len {
            group_tail::<T, L, DAMP>(block, group, done, len - done, nodes, out);
        }
        start = end;
    }
    let [x, y, z] = nodes.x;
    let [vx, vy, vz] = nodes.v;
    let lo = out.lo;
    let [fx, fy, fz] = &mut out.f;
    for i in part.loose.clone() {
        let (a, b) = (block.loose_a[i] as usize, block.loose_b[i] as usize);
        let s = block.loose_first + i;
        let (dvx, dvy, dvz) =
            if DAMP { (vx[b] - vx[a], vy[b] - vy[a], vz[b] - vz[a]) } else { (T::ZERO, T::ZERO, T::ZERO) };
        let params = block.params.chunk(s, 1);
        let f = spring_force::<T, L, DAMP>(&params, 0, x[b] - x[a], y[b] - y[a], z[b] - z[a], dvx, dvy, dvz, true);
        fx[a - lo] += f[0];
        fy[a - lo] += f[1];
        fz[a - lo] += f[2];
        fx[b - lo] -= f[0];
        fy[b - lo] -= f[1];
        fz[b - lo] -= f[2];
    }
}

/// Every law and damping variant of the kernel over part `t`, compiled for one level.
#[inline(always)]
fn accumulate_all<T: Real, B: Block<T>>(
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    if let (Some(part), Some(packed)) = (layout.linear.parts.get(t), &layout.packed) {
        if damp {
            accumulate_packed::<T, B, true>(&layout.linear, packed, part, nodes, out);
        } else {
            accumulate_packed::<T, B, false>(&layout.linear, packed, part, nodes, out);
        }
    } else if let Some(part) = layout.linear.parts.get(t) {
        if damp {
            accumulate_block::<T, B, _, true>(&layout.linear, part, nodes, out);
        } else {
            accumulate_block::<T, B, _, false>(&layout.linear, part, nodes, out);
        }
    }
    if let Some(part) = layout.bilinear.parts.get(t) {
        if damp {
            accumulate_block::<T, B, _, true>(&layout.bilinear, part, nodes, out);
        } else {
            accumulate_block::<T, B, _, false>(&layout.bilinear, part, nodes, out);
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,f16c")]
fn accumulate_avx2<T: Real>(
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    accumulate_all::<T, T::AvxBlock>(layout, t, damp, nodes, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma,f16c")]
fn accumulate_avx512<T: Real>(
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    accumulate_all::<T, T::AvxBlock>(layout, t, damp, nodes, out)
}

/// Adds the forces of thread part `t`'s springs (with dashpots when `damp`) into `out`.
///
/// `out` must cover the part's node window ([`SpringLayout::window`]); `level` above what the
/// CPU supports is lowered to what it has.
pub fn accumulate_part<T: Real>(
    level: SimdLevel,
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    match level.clamp_to_cpu() {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: clamp_to_cpu() returned Avx512 only if the CPU has avx512f and avx512vl.
        SimdLevel::Avx512 => unsafe { accumulate_avx512(layout, t, damp, nodes, out) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: clamp_to_cpu() returned Avx2 only if the CPU has avx2 and fma.
        SimdLevel::Avx2 => unsafe { accumulate_avx2(layout, t, damp, nodes, out) },
        _ => accumulate_all::<T, ScalarBlock<T>>(layout, t, damp, nodes, out),
    }
}
