//! Spring force kernels over the streaming layout (see [`super::spring_layout`]).
//!
//! One kernel per spring law and damping choice, each a plain loop over a run that LLVM
//! vectorises; [`accumulate_part`] dispatches to the build for the chosen [`SimdLevel`].
//! Forces are *added* into a window of the force arrays that starts at node `lo`.

use super::simd::SimdLevel;
use super::spring_layout::{BilinearParams, LinearParams, NO_ENTRY, Part, Run, SpringBlock, SpringLayout};
use crate::real::Real;

/// Elements per inner chunk: forces of up to this many springs are staged on the stack
/// before being added to their end nodes.
const CHUNK: usize = super::spring_layout::SEGMENT_LEN as usize;

/// Runs whose node offset is at least this (a multiple of every vector width) accumulate
/// forces directly; shorter offsets stage them in a chunk buffer first.
const DIRECT_MIN_OFFSET: usize = 16;

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
        let pull = stretch.max(T::ZERO);
        c[3][i] * stretch.min(T::ZERO) + c[1][i] * pull.min(turn) + c[2][i] * (pull - turn).max(T::ZERO)
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
) -> [T; 3] {
    let length = (dx * dx + dy * dy + dz * dz).sqrt();
    let inv = T::ONE / length.max(T::from_f64(MIN_SPRING_LENGTH));
    let (ux, uy, uz) = (dx * inv, dy * inv, dz * inv);
    let mut fs = L::tension(chunk, i, length - L::rest(chunk, i));
    if DAMP {
        fs += L::damping(chunk, i) * (dvx * ux + dvy * uy + dvz * uz);
    }
    [fs * ux, fs * uy, fs * uz]
}

/// How a run reads its parameters.
const STREAMED: u8 = 0;
/// One shared parameter entry for the whole run.
const SHARED: u8 = 1;
/// One shared entry, and a mask that zeroes the run's null springs.
const SHARED_MASKED: u8 = 2;

/// Adds the forces of one run's springs into the window. `params` is the run's parameter
/// table (`MODE == STREAMED`: the block's per-spring table; else its shared table), `active` the run's mask (read only when `MODE == SHARED_MASKED`).
#[inline(always)]
fn accumulate_run<T: Real, L: KernelLaw<T>, const DAMP: bool, const MODE: u8>(
    run: &Run,
    params: &L,
    active: &[u8],
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
    stage: &mut [[T; CHUNK]; 3],
) {
    let [x, y, z] = nodes.x;
    let [vx, vy, vz] = nodes.v;
    let lo = out.lo;
    let [fx, fy, fz] = &mut out.f;
    let [tx, ty, tz] = stage;
    let offset = (run.b0 - run.a0) as usize;
    // Sub-chunks no longer than the offset have disjoint first-node and second-node
    // ranges: their forces go straight into the window. Shorter offsets stage forces.
    let direct = offset >= DIRECT_MIN_OFFSET;
    let step = if direct { (offset / DIRECT_MIN_OFFSET * DIRECT_MIN_OFFSET).min(CHUNK) } else { CHUNK };
    let mut done = 0usize;
    while done < run.len as usize {
        let n = (run.len as usize - done).min(step);
        let a = run.a0 as usize + done;
        let b = run.b0 as usize + done;
        let (xa, ya, za) = (&x[a..a + n], &y[a..a + n], &z[a..a + n]);
        let (xb, yb, zb) = (&x[b..b + n], &y[b..b + n], &z[b..b + n]);
        let (vxa, vya, vza) = (&vx[a..a + n], &vy[a..a + n], &vz[a..a + n]);
        let (vxb, vyb, vzb) = (&vx[b..b + n], &vy[b..b + n], &vz[b..b + n]);
        let chunk = if MODE == STREAMED {
            params.chunk(run.first as usize + done, n)
        } else {
            params.chunk(run.shared as usize, 1)
        };
        let mask = if MODE == SHARED_MASKED { &active[done..done + n] } else { &active[..0] };
        // A macro, not a closure: a closure may be left out of line, and then it is
        // neither vectorised nor compiled for this function's target features.
        macro_rules! force {
            ($i:expr) => {{
                let i = $i;
                let (dvx, dvy, dvz) = if DAMP {
                    (vxb[i] - vxa[i], vyb[i] - vya[i], vzb[i] - vza[i])
                } else {
                    (T::ZERO, T::ZERO, T::ZERO)
                };
                let p = if MODE == STREAMED { i } else { 0 };
                let (dx, dy, dz) = (xb[i] - xa[i], yb[i] - ya[i], zb[i] - za[i]);
                let f = spring_force::<T, L, DAMP>(&chunk, p, dx, dy, dz, dvx, dvy, dvz);
                // A null spring exerts +0, exactly as a streamed null spring (k = c = 0) does.
                if MODE == SHARED_MASKED && mask[i] == 0 { [T::ZERO; 3] } else { f }
            }};
        }
        let (wa, wb) = (a - lo, b - lo);
        if direct {
            let (fxa, fxb) = fx.split_at_mut(wb);
            let (fya, fyb) = fy.split_at_mut(wb);
            let (fza, fzb) = fz.split_at_mut(wb);
            let (fxa, fya, fza) = (&mut fxa[wa..wa + n], &mut fya[wa..wa + n], &mut fza[wa..wa + n]);
            let (fxb, fyb, fzb) = (&mut fxb[..n], &mut fyb[..n], &mut fzb[..n]);
            for i in 0..n {
                let f = force!(i);
                fxa[i] += f[0];
                fya[i] += f[1];
                fza[i] += f[2];
                fxb[i] -= f[0];
                fyb[i] -= f[1];
                fzb[i] -= f[2];
            }
        } else {
            let (tx, ty, tz) = (&mut tx[..n], &mut ty[..n], &mut tz[..n]);
            for i in 0..n {
                let f = force!(i);
                tx[i] = f[0];
                ty[i] = f[1];
                tz[i] = f[2];
            }
            for (dst, src) in [(&mut **fx, &*tx), (&mut **fy, &*ty), (&mut **fz, &*tz)] {
                for (d, s) in dst[wa..wa + n].iter_mut().zip(src) {
                    *d += *s;
                }
                for (d, s) in dst[wb..wb + n].iter_mut().zip(src) {
                    *d -= *s;
                }
            }
        }
        done += n;
    }
}

#[inline(always)]
fn accumulate_block<T: Real, L: KernelLaw<T>, const DAMP: bool>(
    block: &SpringBlock<L>,
    part: &Part,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let mut stage = [[T::ZERO; CHUNK]; 3];
    for run in &block.runs[part.runs.clone()] {
        if run.shared == NO_ENTRY {
            accumulate_run::<T, L, DAMP, STREAMED>(run, &block.params, &[], nodes, out, &mut stage);
            continue;
        }
        let shared = &block.shared;
        if run.mask == NO_ENTRY {
            accumulate_run::<T, L, DAMP, SHARED>(run, shared, &[], nodes, out, &mut stage);
        } else {
            let active = &block.active[run.mask as usize..run.mask as usize + run.len as usize];
            accumulate_run::<T, L, DAMP, SHARED_MASKED>(run, shared, active, nodes, out, &mut stage);
        }
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
        let f = spring_force::<T, L, DAMP>(&params, 0, x[b] - x[a], y[b] - y[a], z[b] - z[a], dvx, dvy, dvz);
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
fn accumulate_all<T: Real>(
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    if let Some(part) = layout.linear.parts.get(t) {
        if damp {
            accumulate_block::<T, _, true>(&layout.linear, part, nodes, out);
        } else {
            accumulate_block::<T, _, false>(&layout.linear, part, nodes, out);
        }
    }
    if let Some(part) = layout.bilinear.parts.get(t) {
        if damp {
            accumulate_block::<T, _, true>(&layout.bilinear, part, nodes, out);
        } else {
            accumulate_block::<T, _, false>(&layout.bilinear, part, nodes, out);
        }
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn accumulate_avx2<T: Real>(
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    accumulate_all(layout, t, damp, nodes, out)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
fn accumulate_avx512<T: Real>(
    layout: &SpringLayout<T>,
    t: usize,
    damp: bool,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    accumulate_all(layout, t, damp, nodes, out)
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
        _ => accumulate_all(layout, t, damp, nodes, out),
    }
}
