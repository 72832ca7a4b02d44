//! Per-node accelerations from the spring forces of a block plus the per-node effects
//! (gravity, viscous damping, external forces), masked by the free flag.
//!
//! `a = free · ((f + f_ext − α m v) / m + g)`; with every effect off this is exactly the
//! yardstick's `f / m + g` (multiplying by 1.0 is exact). Each combination of effects is its
//! own monomorphised loop, so an effect that is off is not evaluated at all.

use super::spring_pass::NODE_CHUNK;
use crate::real::Real;

/// Per-node inputs of the acceleration, whole-model arrays.
#[derive(Clone, Copy)]
pub struct NodeTerms<'a, T> {
    /// Masses, kg.
    pub mass: &'a [T],
    /// 1 for integrated nodes, 0 for fixed and kinematic ones.
    pub free: &'a [T],
    /// Gravity, m/s² (when `Some`).
    pub gravity: Option<[T; 3]>,
    /// Viscous damping α, 1/s (when `Some`).
    pub viscous: Option<T>,
    /// External forces, N (when `Some`).
    pub external: Option<[&'a [T]; 3]>,
}

/// Accelerations `a` (m/s²) of the nodes in `range`, given their spring forces `f` (N) and
/// velocities `v` (m/s), both the block's own slices.
pub fn accelerations<T: Real>(
    terms: &NodeTerms<'_, T>,
    range: std::ops::Range<usize>,
    f: [&[T]; 3],
    v: [&[T]; 3],
    a: &mut [[T; NODE_CHUNK]; 3],
) {
    match (terms.gravity.is_some(), terms.viscous.is_some(), terms.external.is_some()) {
        (false, false, false) => kernel::<T, false, false, false>(terms, range, f, v, a),
        (true, false, false) => kernel::<T, true, false, false>(terms, range, f, v, a),
        (false, true, false) => kernel::<T, false, true, false>(terms, range, f, v, a),
        (true, true, false) => kernel::<T, true, true, false>(terms, range, f, v, a),
        (false, false, true) => kernel::<T, false, false, true>(terms, range, f, v, a),
        (true, false, true) => kernel::<T, true, false, true>(terms, range, f, v, a),
        (false, true, true) => kernel::<T, false, true, true>(terms, range, f, v, a),
        (true, true, true) => kernel::<T, true, true, true>(terms, range, f, v, a),
    }
}

#[inline(always)]
fn kernel<T: Real, const GRAVITY: bool, const VISCOUS: bool, const EXTERNAL: bool>(
    terms: &NodeTerms<'_, T>,
    range: std::ops::Range<usize>,
    f: [&[T]; 3],
    v: [&[T]; 3],
    a: &mut [[T; NODE_CHUNK]; 3],
) {
    let n = range.len();
    let mass = &terms.mass[range.clone()];
    let free = &terms.free[range.clone()];
    let g = terms.gravity.unwrap_or([T::ZERO; 3]);
    let alpha = terms.viscous.unwrap_or(T::ZERO);
    for axis in 0..3 {
        let fa = &f[axis][..n];
        let va = &v[axis][..n];
        let ext = match terms.external {
            Some(e) if EXTERNAL => &e[axis][range.clone()],
            _ => fa,
        };
        let out = &mut a[axis][..n];
        for i in 0..n {
            let mut force = fa[i];
            if EXTERNAL {
                force += ext[i];
            }
            if VISCOUS {
                force -= alpha * mass[i] * va[i];
            }
            let mut acc = force / mass[i];
            if GRAVITY {
                acc += g[axis];
            }
            out[i] = free[i] * acc;
        }
    }
}
