//! Spring force kernels over the streaming layout (see [`super::spring_layout`]).
//!
//! One kernel per spring law and damping choice, each a plain loop over a run that LLVM
//! vectorises; [`accumulate_part`] dispatches to the build for the chosen [`SimdLevel`].
//! Forces are *added* into a window of the force arrays that starts at node `lo`.

use super::simd::SimdLevel;
use super::spring_layout::{BilinearParams, LinearParams, Part, SpringBlock, SpringLayout};
use crate::real::Real;

/// Elements per inner chunk: forces of up to this many springs are staged on the stack
/// before being added to their end nodes.
const CHUNK: usize = super::spring_layout::SEGMENT_LEN as usize;

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

/// A spring law as the kernels see it: elastic tension from the stretch `L − L0`.
trait KernelLaw<T: Real>: Sync {
    /// Rest length of spring `s`, m.
    fn rest(&self, s: usize) -> T;
    /// Dashpot of spring `s`, N·s/m.
    fn damping(&self, s: usize) -> T;
    /// Elastic tension of spring `s` at `stretch`, N.
    fn tension(&self, s: usize, stretch: T) -> T;
}

impl<T: Real> KernelLaw<T> for LinearParams<T> {
    #[inline(always)]
    fn rest(&self, s: usize) -> T {
        self.rest[s]
    }
    #[inline(always)]
    fn damping(&self, s: usize) -> T {
        self.c[s]
    }
    #[inline(always)]
    fn tension(&self, s: usize, stretch: T) -> T {
        self.k[s] * stretch
    }
}

impl<T: Real> KernelLaw<T> for BilinearParams<T> {
    #[inline(always)]
    fn rest(&self, s: usize) -> T {
        self.rest[s]
    }
    #[inline(always)]
    fn damping(&self, s: usize) -> T {
        self.c[s]
    }
    #[inline(always)]
    fn tension(&self, s: usize, stretch: T) -> T {
        let turn = self.turn[s];
        let pull = stretch.max(T::ZERO);
        self.kc[s] * stretch.min(T::ZERO) + self.k1[s] * pull.min(turn) + self.k2[s] * (pull - turn).max(T::ZERO)
    }
}

/// Force on end `a` of one spring (end `b` gets the opposite), N.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn spring_force<T: Real, L: KernelLaw<T>, const DAMP: bool>(
    law: &L,
    s: usize,
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
    let mut fs = law.tension(s, length - law.rest(s));
    if DAMP {
        fs += law.damping(s) * (dvx * ux + dvy * uy + dvz * uz);
    }
    [fs * ux, fs * uy, fs * uz]
}

#[inline(always)]
fn accumulate_block<T: Real, L: KernelLaw<T>, const DAMP: bool>(
    block: &SpringBlock<L>,
    part: &Part,
    nodes: &NodeView<'_, T>,
    out: &mut ForceWindow<'_, T>,
) {
    let [x, y, z] = nodes.x;
    let [vx, vy, vz] = nodes.v;
    let lo = out.lo;
    let [fx, fy, fz] = &mut out.f;
    let mut tx = [T::ZERO; CHUNK];
    let mut ty = [T::ZERO; CHUNK];
    let mut tz = [T::ZERO; CHUNK];
    for run in &block.runs[part.runs.clone()] {
        let mut done = 0usize;
        while done < run.len as usize {
            let n = (run.len as usize - done).min(CHUNK);
            let a = run.a0 as usize + done;
            let b = run.b0 as usize + done;
            let s0 = run.first as usize + done;
            let (xa, ya, za) = (&x[a..a + n], &y[a..a + n], &z[a..a + n]);
            let (xb, yb, zb) = (&x[b..b + n], &y[b..b + n], &z[b..b + n]);
            let (vxa, vya, vza) = (&vx[a..a + n], &vy[a..a + n], &vz[a..a + n]);
            let (vxb, vyb, vzb) = (&vx[b..b + n], &vy[b..b + n], &vz[b..b + n]);
            let (tx, ty, tz) = (&mut tx[..n], &mut ty[..n], &mut tz[..n]);
            for i in 0..n {
                let (dvx, dvy, dvz) = if DAMP {
                    (vxb[i] - vxa[i], vyb[i] - vya[i], vzb[i] - vza[i])
                } else {
                    (T::ZERO, T::ZERO, T::ZERO)
                };
                let f = spring_force::<T, L, DAMP>(
                    &block.params,
                    s0 + i,
                    xb[i] - xa[i],
                    yb[i] - ya[i],
                    zb[i] - za[i],
                    dvx,
                    dvy,
                    dvz,
                );
                tx[i] = f[0];
                ty[i] = f[1];
                tz[i] = f[2];
            }
            let (wa, wb) = (a - lo, b - lo);
            for (dst, src) in [(&mut **fx, &*tx), (&mut **fy, &*ty), (&mut **fz, &*tz)] {
                for (d, s) in dst[wa..wa + n].iter_mut().zip(src) {
                    *d += *s;
                }
                for (d, s) in dst[wb..wb + n].iter_mut().zip(src) {
                    *d -= *s;
                }
            }
            done += n;
        }
    }
    for i in part.loose.clone() {
        let (a, b) = (block.loose_a[i] as usize, block.loose_b[i] as usize);
        let s = block.loose_first + i;
        let (dvx, dvy, dvz) =
            if DAMP { (vx[b] - vx[a], vy[b] - vy[a], vz[b] - vz[a]) } else { (T::ZERO, T::ZERO, T::ZERO) };
        let f = spring_force::<T, L, DAMP>(&block.params, s, x[b] - x[a], y[b] - y[a], z[b] - z[a], dvx, dvy, dvz);
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
