//! The real-time implicit step: one Newton step of backward Euler, its linear system solved
//! by a fixed number of conjugate-gradient iterations preconditioned by a prefactored
//! matrix.
//!
//! # How a step goes
//! Backward Euler's positions minimise `g(x) = 1/(2h²) ‖x − x₀ − h v₀‖²_M + E(x) − f_extᵀx`
//! (plus the dashpots' and viscous damping's dissipation). One Newton step from the explicit
//! predictor `x̂ = x₀ + h v₀`:
//!
//! 1. forces and the tangent at `(x̂, v₀)`: one pass over the springs (force, direction,
//!    tangent stiffness and tension of each, stored), the skin tetrahedra, the tool's
//!    contacts, handles, loads, gravity;
//! 2. solve `A Δx = f(x̂, v₀)` with `A = M (1 + α h)/h² + C/h + K(x̂)` by conjugate
//!    gradients from `Δx = 0`, preconditioned by `P⁻¹`, for `iterations` iterations (default 1):
//!    each one product with `A` (a pass over the springs' stored tangents) and one pair of
//!    triangular sweeps;
//! 3. `x = x̂ + Δx`, `v = (x − x₀)/h`.
//!
//! `P` (`factored_preconditioner.rs`) is `A` with every spring at its first-phase stiffness
//! and isotropic: Liu et al.'s local/global matrix, factored once. It is exact for soft-phase
//! motion along the springs; what it lacks (directions, a spring's stiff phase, contacts,
//! the skin's volume term) the conjugate-gradient step sees through the product with the
//! true `A`, whose curvature sets the step length, so a stiff direction is never
//! overshot. A step costs the same whatever the stiffness: no critical step, no sub-steps.
//!
//! At rest the step is exact: a state in equilibrium has `f = 0` and stays. Starting the
//! iterations from `Δx = 0` each step (not from the last step's `Δx`) keeps it so: with a
//! truncated solve, a warm start carries the last step's error forward and can grow it.

use super::dynamics::{Dynamics, State};
use super::factored_preconditioner::FactoredPreconditioner;
use super::lane_block::{Block, LANES, ScalarBlock};
use super::simd::SimdLevel;
use super::sparse_cholesky::{FactorBuildError, FactorStorage};
use super::spring_kernels::MIN_SPRING_LENGTH;
use super::spring_runs::{Run, SpringRuns};
use super::vec3s::Vec3s;
use super::worker_pool::WorkerPool;
use crate::model::Model;
use crate::real::Real;
use std::time::Instant;

/// Per-spring tangent data stored by the force pass, in run order.
struct Tangent<T> {
    /// Unit direction from the first node to the second.
    u: [Vec<T>; 3],
    /// Stiffness along the direction: the law's tangent plus the dashpot over the step, N/m.
    along: Vec<T>,
    /// Stiffness across it: the tension over the length (0 in compression), N/m.
    across: Vec<T>,
}

/// A material in the solver's precision.
#[derive(Clone, Copy)]
struct Law<T> {
    kc: T,
    k1: T,
    k2: T,
    c: T,
    c_over_h: T,
}

/// The real-time implicit integrator's state and scratch, built once per model and step.
pub struct ImplicitFactored<T: Real> {
    h: f64,
    runs: SpringRuns<T>,
    laws: Vec<Law<T>>,
    tangent: Tangent<T>,
    /// Per worker: forces, then products with `A`, per node.
    windows: Vec<Vec3s<T>>,
    pre: FactoredPreconditioner<T>,
    iterations: u32,
    simd: SimdLevel,
    x0: Vec3s<T>,
    /// Conjugate-gradient vectors, per node.
    r: Vec3s<T>,
    z: Vec3s<T>,
    p: Vec3s<T>,
    ap: Vec3s<T>,
    dx: Vec3s<T>,
    /// Per skin tetrahedron: `√(k/|V₀|) ∇V` per corner at the predictor (its Gauss-Newton
    /// stiffness is the outer product).
    tet_grad: Vec<[[T; 3]; 4]>,
    /// `A`'s diagonal mass term per node, `m (1 + α h)/h²` (0 on held nodes), N/m.
    mass_term: Vec<T>,
    /// Relative residual of the last step's solve (`‖r‖/‖f‖`).
    last_residual: f64,
}

impl<T: Real> ImplicitFactored<T> {
    /// Builds the integrator for `model` under `dynamics`' effects, stepping `h` seconds with
    /// `iterations` conjugate-gradient iterations per step, its preconditioner's factor stored
    /// as `storage` asks.
    pub fn new(
        model: &Model,
        dynamics: &Dynamics<T>,
        h: f64,
        iterations: u32,
        simd: SimdLevel,
        storage: FactorStorage,
    ) -> Result<Self, FactorBuildError> {
        let n = model.nodes.len();
        let free: Vec<bool> = (0..n).map(|i| dynamics.free[i] != T::ZERO).collect();
        let threads = dynamics.pool.threads();
        let runs = SpringRuns::<T>::new(&model.springs, &free, dynamics.effects.spring_damping, threads);
        let laws = runs
            .materials
            .iter()
            .map(|m| Law {
                kc: T::from_f64(m.kc),
                k1: T::from_f64(m.k1),
                k2: T::from_f64(m.k2),
                c: T::from_f64(m.c),
                c_over_h: T::from_f64(m.c / h),
            })
            .collect();
        let alpha = dynamics.effects.viscous_damping.unwrap_or(0.0);
        let pre =
            FactoredPreconditioner::new(model, dynamics, (1.0 + alpha * h) / (h * h), 1.0 / h, 1.0, simd, storage)?;
        let len = runs.padded_len();
        let z = || vec![T::ZERO; len];
        let mass_term = (0..n)
            .map(|i| if free[i] { T::from_f64(model.nodes.mass[i] * (1.0 + alpha * h) / (h * h)) } else { T::ZERO })
            .collect();
        Ok(Self {
            h,
            windows: runs.windows(n),
            tangent: Tangent { u: [z(), z(), z()], along: z(), across: z() },
            runs,
            laws,
            pre,
            iterations: iterations.max(1),
            simd: simd.clamp_to_cpu(),
            x0: Vec3s::zeros(n),
            r: Vec3s::zeros(n),
            z: Vec3s::zeros(n),
            p: Vec3s::zeros(n),
            ap: Vec3s::zeros(n),
            dx: Vec3s::zeros(n),
            tet_grad: vec![[[T::ZERO; 3]; 4]; dynamics.skin_volume.tets.len()],
            mass_term,
            last_residual: 0.0,
        })
    }

    /// Step the integrator was built for, s.
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// Conjugate-gradient iterations per step.
    pub fn iterations(&self) -> u32 {
        self.iterations
    }

    /// Stored entries of the preconditioner's factor.
    pub fn factor_entries(&self) -> usize {
        self.pre.factor_entries()
    }

    /// Threads the preconditioner's triangular sweeps run on (2 when its factor splits into
    /// two halves and a separator, on a pool of 2 or more).
    pub fn preconditioner_threads(&self) -> usize {
        if self.pre.is_split() { 2 } else { 1 }
    }

    /// Relative residual `‖f − A Δx‖ / ‖f‖` of the last step's solve.
    pub fn last_residual(&self) -> f64 {
        self.last_residual
    }

    /// One step of `h` seconds from `state` (held nodes already at their end-of-step
    /// places). Allocates nothing.
    pub fn step(&mut self, dynamics: &mut Dynamics<T>, state: &mut State<T>) {
        let start = Instant::now();
        let ht = T::from_f64(self.h);
        let t1 = state.time + self.h;
        self.x0.copy_from(&state.x);
        // The predictor x̂ = x₀ + h v₀ (free nodes).
        for (xc, vc) in state.x.slices_mut().into_iter().zip(state.v.slices()) {
            for ((x, &v), &f) in xc.iter_mut().zip(vc).zip(&dynamics.free) {
                *x += f * ht * v;
            }
        }
        // Forces and tangent at (x̂, v₀).
        dynamics.eval_external_at(&state.x, &state.v, t1);
        let t_springs = Instant::now();
        self.spring_forces(&dynamics.pool, &state.x, &state.v);
        dynamics.counters.springs += t_springs.elapsed();
        let gravity = dynamics.effects.gravity.map(|g| g.map(T::from_f64)).unwrap_or([T::ZERO; 3]);
        let alpha = T::from_f64(dynamics.effects.viscous_damping.unwrap_or(0.0));
        let external = dynamics.has_external();
        let (mass, free, v) = (&dynamics.mass, &dynamics.free, state.v.slices());
        let e = dynamics.external.slices();
        for (c, r) in self.r.slices_mut().into_iter().enumerate() {
            sum_windows(r, &self.windows, c);
            let (g, vc, ec) = (gravity[c], v[c], e[c]);
            assemble_residual(r, free, mass, vc, external.then_some(ec), g, alpha);
        }
        if let Some(k) = dynamics.effects.skin_volume {
            // Each worker its share of the tetrahedra.
            let (volume, x) = (&dynamics.skin_volume, &state.x);
            let tets = self.tet_grad.len();
            let workers = dynamics.pool.threads();
            let grads = super::disjoint::DisjointSlice::new(self.tet_grad.as_mut_slice());
            dynamics.pool.run(&|worker| {
                let share = tets * worker / workers..tets * (worker + 1) / workers;
                let first = share.start;
                // SAFETY: the workers' shares are disjoint.
                let out = unsafe { grads.range_mut(share) };
                for (i, out) in out.iter_mut().enumerate() {
                    *out = volume.weighted_gradient(first + i, k, x);
                }
            });
        }
        let fnorm = dot(self.simd, &self.r, &self.r).sqrt();
        self.dx.fill_zero();
        let mut rz = 0.0;
        for k in 0..self.iterations {
            let t_pre = Instant::now();
            self.pre.apply(&dynamics.pool, &self.r, &mut self.z);
            dynamics.counters.preconditioner += t_pre.elapsed();
            let rz_new = dot(self.simd, &self.r, &self.z);
            if !(rz_new.is_finite() && rz_new > 0.0) {
                break;
            }
            if k == 0 {
                // p = z; z is rewritten whole by the next preconditioner solve.
                std::mem::swap(&mut self.p, &mut self.z);
            } else {
                scale_add(&mut self.p, rz_new / rz, &self.z);
            }
            rz = rz_new;
            self.apply(dynamics);
            let pap = dot(self.simd, &self.p, &self.ap);
            if !(pap.is_finite() && pap > 0.0) {
                break;
            }
            let a = rz / pap;
            axpy(&mut self.dx, a, &self.p);
            axpy(&mut self.r, -a, &self.ap);
        }
        self.last_residual = if fnorm > 0.0 { dot(self.simd, &self.r, &self.r).sqrt() / fnorm } else { 0.0 };
        let inv_h = T::from_f64(1.0 / self.h);
        // A non-finite residual (a NaN or infinite force) stops the iterations at their
        // breakdown test with Δx = 0; the step's result is made non-finite instead, so the
        // guard (or the caller) sees the bad force rather than a silently skipped update.
        let poison = if fnorm.is_finite() { T::ZERO } else { T::from_f64(f64::NAN) };
        let free = &dynamics.free;
        let (xs, vs) = (state.x.slices_mut(), state.v.slices_mut());
        for (((x, v), d), x0) in xs.into_iter().zip(vs).zip(self.dx.slices()).zip(self.x0.slices()) {
            update_positions(x, v, d, x0, free, poison, inv_h);
        }
        dynamics.counters.implicit += start.elapsed();
        dynamics.counters.cg_iterations += self.iterations as u64;
    }

    /// Swaps the preconditioner with `other` (a factor of the cut model built off the loop).
    /// Moves, allocates nothing.
    pub(crate) fn swap_preconditioner(&mut self, other: &mut FactoredPreconditioner<T>) {
        std::mem::swap(&mut self.pre, other);
    }

    /// `c_m`, `c_c`, `c_k` of the preconditioner's matrix `c_m M + c_c C + c_k K`.
    pub(crate) fn preconditioner_coefficients(&self, viscous_damping: f64) -> (f64, f64, f64) {
        let h = self.h;
        ((1.0 + viscous_damping * h) / (h * h), 1.0 / h, 1.0)
    }

    /// Cuts model spring `spring` out of the runs; its two nodes when it was in them and not
    /// cut before. Allocates nothing.
    pub(crate) fn cut_spring(&mut self, spring: usize) -> Option<[u32; 2]> {
        if !self.runs.cut(spring) {
            return None;
        }
        let k = self.runs.slot[spring];
        let i = self.runs.runs.partition_point(|r| r.first <= k) - 1;
        let r = self.runs.runs[i];
        Some([r.a0 + (k - r.first), r.b0 + (k - r.first)])
    }

    /// Spring forces at `(x, v)` into the windows, and each spring's tangent data.
    fn spring_forces(&mut self, pool: &WorkerPool, x: &Vec3s<T>, v: &Vec3s<T>) {
        let simd = self.simd;
        let (runs, laws) = (&self.runs, &self.laws);
        let tangent = TangentSlices::new(&mut self.tangent);
        let windows = super::disjoint::DisjointSlice::new(self.windows.as_mut_slice());
        pool.run(&|worker| {
            // SAFETY: worker `i` alone takes window `i`, and the runs of its part.
            let win = &mut unsafe { windows.range_mut(worker..worker + 1) }[0];
            win.fill_zero();
            for run in &runs.runs[runs.parts[worker].clone()] {
                let tan = unsafe { tangent.run(run) };
                forces_dispatch(simd, run, runs, &laws[run.material as usize], x, v, tan, win);
            }
        });
    }

    /// `ap = A p` (free nodes).
    fn apply(&mut self, dynamics: &Dynamics<T>) {
        let simd = self.simd;
        let (runs, tangent, p) = (&self.runs, &self.tangent, &self.p);
        let windows = super::disjoint::DisjointSlice::new(self.windows.as_mut_slice());
        dynamics.pool.run(&|worker| {
            // SAFETY: worker `i` alone takes window `i`.
            let win = &mut unsafe { windows.range_mut(worker..worker + 1) }[0];
            win.fill_zero();
            for run in &runs.runs[runs.parts[worker].clone()] {
                apply_dispatch(simd, run, tangent, p, win);
            }
        });
        let ap = &mut self.ap;
        for (c, y) in ap.slices_mut().into_iter().enumerate() {
            sum_windows(y, &self.windows, c);
            for ((y, &m), &pv) in y.iter_mut().zip(&self.mass_term).zip(p.slices()[c]) {
                *y += m * pv;
            }
        }
        let h = self.h;
        for hd in &dynamics.effects.handles {
            let i = hd.node as usize;
            let k = T::from_f64(hd.stiffness + hd.damping / h);
            let (pv, y) = (p.get(i), ap.get(i));
            ap.set(i, [0, 1, 2].map(|c| y[c] + k * pv[c]));
        }
        if dynamics.effects.skin_volume.is_some() {
            dynamics.skin_volume.add_stiffness_product(&self.tet_grad, T::ONE, p, ap);
        }
        for s in &dynamics.contacts {
            let mut q = [0.0f64; 3];
            for (&n, &w) in s.nodes.iter().zip(&s.weights) {
                let pv = p.get_f64(n as usize);
                for c in 0..3 {
                    q[c] += w * pv[c];
                }
            }
            let along = s.stiffness * (s.normal[0] * q[0] + s.normal[1] * q[1] + s.normal[2] * q[2]);
            for (&n, &w) in s.nodes.iter().zip(&s.weights) {
                if w != 0.0 {
                    let y = ap.get(n as usize);
                    ap.set(n as usize, [0, 1, 2].map(|c| y[c] + T::from_f64(w * along * s.normal[c])));
                }
            }
        }
        for y in ap.slices_mut() {
            for (y, &f) in y.iter_mut().zip(&dynamics.free) {
                *y *= f;
            }
        }
    }
}

/// The tangent arrays, handed out run by run to worker threads.
struct TangentSlices<'a, T> {
    u: [super::disjoint::DisjointSlice<'a, T>; 3],
    along: super::disjoint::DisjointSlice<'a, T>,
    across: super::disjoint::DisjointSlice<'a, T>,
}

/// One run's tangent data.
struct RunTangent<'a, T> {
    u: [&'a mut [T]; 3],
    along: &'a mut [T],
    across: &'a mut [T],
}

impl<'a, T> TangentSlices<'a, T> {
    fn new(t: &'a mut Tangent<T>) -> Self {
        let [ux, uy, uz] = &mut t.u;
        use super::disjoint::DisjointSlice as D;
        Self { u: [D::new(ux), D::new(uy), D::new(uz)], along: D::new(&mut t.along), across: D::new(&mut t.across) }
    }

    /// # Safety
    /// Each run may be taken by one thread at a time.
    unsafe fn run(&self, run: &Run) -> RunTangent<'_, T> {
        let r = run.first as usize..(run.first + run.len) as usize;
        // SAFETY: runs cover disjoint data ranges (the caller's contract).
        unsafe {
            RunTangent {
                u: [self.u[0].range_mut(r.clone()), self.u[1].range_mut(r.clone()), self.u[2].range_mut(r.clone())],
                along: self.along.range_mut(r.clone()),
                across: self.across.range_mut(r),
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn forces_dispatch<T: Real>(
    simd: SimdLevel,
    run: &Run,
    runs: &SpringRuns<T>,
    law: &Law<T>,
    x: &Vec3s<T>,
    v: &Vec3s<T>,
    tan: RunTangent<'_, T>,
    win: &mut Vec3s<T>,
) {
    #[cfg(target_arch = "x86_64")]
    if simd >= SimdLevel::Avx2 {
        // SAFETY: `simd` was clamped to what this CPU has.
        unsafe { forces_avx2(run, runs, law, x, v, tan, win) };
        return;
    }
    let _ = simd;
    forces_run::<T, ScalarBlock<T>>(run, runs, law, x, v, tan, win);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn forces_avx2<T: Real>(
    run: &Run,
    runs: &SpringRuns<T>,
    law: &Law<T>,
    x: &Vec3s<T>,
    v: &Vec3s<T>,
    tan: RunTangent<'_, T>,
    win: &mut Vec3s<T>,
) {
    forces_run::<T, T::AvxBlock>(run, runs, law, x, v, tan, win);
}

fn apply_dispatch<T: Real>(simd: SimdLevel, run: &Run, tangent: &Tangent<T>, p: &Vec3s<T>, win: &mut Vec3s<T>) {
    #[cfg(target_arch = "x86_64")]
    if simd >= SimdLevel::Avx2 {
        // SAFETY: `simd` was clamped to what this CPU has.
        unsafe { apply_avx2(run, tangent, p, win) };
        return;
    }
    let _ = simd;
    apply_run::<T, ScalarBlock<T>>(run, tangent, p, win);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn apply_avx2<T: Real>(run: &Run, tangent: &Tangent<T>, p: &Vec3s<T>, win: &mut Vec3s<T>) {
    apply_run::<T, T::AvxBlock>(run, tangent, p, win);
}

/// Loads `L` values from `s` at `i` as a block: a full block, or (the end of a run that
/// could not be padded) a block of copies of the last in-range value.
#[inline(always)]
fn load_at<T: Real, B: Block<T>>(s: &[T], i: usize, real: usize) -> B {
    if real == LANES {
        B::load(s, i)
    } else {
        let mut lanes = [T::ZERO; LANES];
        for (l, v) in lanes.iter_mut().enumerate() {
            *v = s[i + l.min(real - 1)];
        }
        B::load(&lanes, 0)
    }
}

/// Adds `v`'s first `real` lanes to `s[i..]`.
#[inline(always)]
fn add_at<T: Real, B: Block<T>>(s: &mut [T], i: usize, v: B, real: usize) {
    if real == LANES {
        B::load(s, i).add(v).store(s, i);
    } else {
        let mut lanes = [T::ZERO; LANES];
        v.store(&mut lanes, 0);
        for l in 0..real {
            s[i + l] += lanes[l];
        }
    }
}

/// Stores `v`'s first `real` lanes at `s[i..]`.
#[inline(always)]
fn store_at<T: Real, B: Block<T>>(s: &mut [T], i: usize, v: B, real: usize) {
    if real == LANES {
        v.store(s, i);
    } else {
        let mut lanes = [T::ZERO; LANES];
        v.store(&mut lanes, 0);
        s[i..i + real].copy_from_slice(&lanes[..real]);
    }
}

/// The mask of lanes `k..k + LANES` (`real` of them in range).
#[inline(always)]
fn mask_at(real_flags: &[u8], k: usize, real: usize) -> [u8; LANES] {
    let mut m = [0u8; LANES];
    m[..real].copy_from_slice(&real_flags[k..k + real]);
    m
}

/// Forces at `(x, v)` of one run's springs into `win`, and their tangent data.
#[inline(always)]
fn forces_run<T: Real, B: Block<T>>(
    run: &Run,
    runs: &SpringRuns<T>,
    law: &Law<T>,
    x: &Vec3s<T>,
    v: &Vec3s<T>,
    tan: RunTangent<'_, T>,
    win: &mut Vec3s<T>,
) {
    let (kc, k1, k2, c, ch) =
        (B::splat(law.kc), B::splat(law.k1), B::splat(law.k2), B::splat(law.c), B::splat(law.c_over_h));
    let zero = B::splat(T::ZERO);
    let min_len = B::splat(T::from_f64(MIN_SPRING_LENGTH));
    let (a0, b0, first, len) = (run.a0 as usize, run.b0 as usize, run.first as usize, run.len as usize);
    let RunTangent { u: [tux, tuy, tuz], along, across } = tan;
    let [wx, wy, wz] = win.slices_mut();
    let mut i = 0;
    while i < len {
        let real = (len - i).min(LANES);
        let (a, b, k) = (a0 + i, b0 + i, first + i);
        let mask = mask_at(&runs.real, k, real);
        let d = [
            load_at::<T, B>(&x.x, b, real).sub(load_at(&x.x, a, real)),
            load_at::<T, B>(&x.y, b, real).sub(load_at(&x.y, a, real)),
            load_at::<T, B>(&x.z, b, real).sub(load_at(&x.z, a, real)),
        ];
        let dv = [
            load_at::<T, B>(&v.x, b, real).sub(load_at(&v.x, a, real)),
            load_at::<T, B>(&v.y, b, real).sub(load_at(&v.y, a, real)),
            load_at::<T, B>(&v.z, b, real).sub(load_at(&v.z, a, real)),
        ];
        let (rest, turn) = (load_at::<T, B>(&runs.rest, k, real), load_at::<T, B>(&runs.turn, k, real));
        let length = d[0].mul(d[0]).add(d[1].mul(d[1])).add(d[2].mul(d[2])).sqrt();
        let inv = B::splat(T::ONE).div(length.max(min_len));
        let u = [d[0].mul(inv), d[1].mul(inv), d[2].mul(inv)];
        let stretch = length.sub(rest);
        let turn_stretch = turn.sub(rest);
        let pull = stretch.max(zero);
        let elastic =
            kc.mul(stretch.min(zero)).add(k1.mul(pull.min(turn_stretch))).add(k2.mul(pull.sub(turn_stretch).max(zero)));
        let rate = dv[0].mul(u[0]).add(dv[1].mul(u[1])).add(dv[2].mul(u[2]));
        let force = elastic.add(c.mul(rate)).keep(&mask);
        let tangent_k = stretch.select_positive(stretch.sub(turn_stretch).select_positive(k2, k1), kc);
        store_at(along, i, tangent_k.add(ch).keep(&mask), real);
        store_at(across, i, elastic.mul(inv).max(zero).keep(&mask), real);
        for (t, uc) in [&mut *tux, &mut *tuy, &mut *tuz].into_iter().zip(u) {
            store_at(t, i, uc, real);
        }
        for (wc, uc) in [&mut *wx, &mut *wy, &mut *wz].into_iter().zip(u) {
            let f = force.mul(uc);
            add_at(wc, a, f, real);
            add_at(wc, b, zero.sub(f), real);
        }
        i += LANES;
    }
}

/// `win += K_springs p` over one run's springs (their stored tangents).
#[inline(always)]
fn apply_run<T: Real, B: Block<T>>(run: &Run, tangent: &Tangent<T>, p: &Vec3s<T>, win: &mut Vec3s<T>) {
    let (a0, b0, first, len) = (run.a0 as usize, run.b0 as usize, run.first as usize, run.len as usize);
    let [wx, wy, wz] = win.slices_mut();
    let mut i = 0;
    while i < len {
        let real = (len - i).min(LANES);
        let (a, b, k) = (a0 + i, b0 + i, first + i);
        let d = [
            load_at::<T, B>(&p.x, b, real).sub(load_at(&p.x, a, real)),
            load_at::<T, B>(&p.y, b, real).sub(load_at(&p.y, a, real)),
            load_at::<T, B>(&p.z, b, real).sub(load_at(&p.z, a, real)),
        ];
        let u = [
            load_at::<T, B>(&tangent.u[0], k, real),
            load_at::<T, B>(&tangent.u[1], k, real),
            load_at::<T, B>(&tangent.u[2], k, real),
        ];
        let (along, across) = (load_at::<T, B>(&tangent.along, k, real), load_at::<T, B>(&tangent.across, k, real));
        let ud = u[0].mul(d[0]).add(u[1].mul(d[1])).add(u[2].mul(d[2]));
        let a_ud = along.mul(ud);
        for (c, wc) in [&mut *wx, &mut *wy, &mut *wz].into_iter().enumerate() {
            // S d = along (u·d) u + across (d − (u·d) u)
            let t = a_ud.mul(u[c]).add(across.mul(d[c].sub(ud.mul(u[c]))));
            add_at(wc, a, B::splat(T::ZERO).sub(t), real);
            add_at(wc, b, t, real);
        }
        i += LANES;
    }
}

/// `a · b` over the three components, in f64. The same sums in the same order on every
/// instruction-set level (eight lanes, a multiply then an add, no fused multiply-add), only
/// wider registers where the CPU has them: the 96x24 limb's region (569 nodes) in 0.54 µs
/// with AVX2 where the baseline's two-lane loop takes 1.4 µs (Xeon VM, fastest of 20,000).
fn dot<T: Real>(simd: SimdLevel, a: &Vec3s<T>, b: &Vec3s<T>) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if simd >= SimdLevel::Avx2 {
        // SAFETY: `simd` was clamped to what this CPU has.
        return unsafe { dot_avx2(a, b) };
    }
    let _ = simd;
    dot_lanes(a, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn dot_avx2<T: Real>(a: &Vec3s<T>, b: &Vec3s<T>) -> f64 {
    dot_lanes(a, b)
}

#[inline(always)]
fn dot_lanes<T: Real>(a: &Vec3s<T>, b: &Vec3s<T>) -> f64 {
    // Eight independent partial sums, so the loop vectorises; summed in f64.
    let mut lanes = [0.0f64; 8];
    for (ac, bc) in a.slices().into_iter().zip(b.slices()) {
        let (ca, cb) = (ac.chunks_exact(8), bc.chunks_exact(8));
        let (ra, rb) = (ca.remainder(), cb.remainder());
        for (x, y) in ca.zip(cb) {
            for l in 0..8 {
                lanes[l] += x[l].to_f64() * y[l].to_f64();
            }
        }
        for (x, y) in ra.iter().zip(rb) {
            lanes[0] += x.to_f64() * y.to_f64();
        }
    }
    lanes.iter().sum()
}

/// One component of the residual: `r = free (r + e + m (g − α v))` per node, where `r`
/// holds the spring forces, `e` the external forces (`None`: there are none), `g` gravity
/// (m/s²) and `α` the viscous damping (1/s). A function of its own so the slices are known
/// not to alias and the loop vectorises.
#[inline(never)]
fn assemble_residual<T: Real>(r: &mut [T], free: &[T], mass: &[T], v: &[T], e: Option<&[T]>, g: T, alpha: T) {
    match e {
        Some(e) => {
            for ((((r, &f), &m), &vi), &ei) in r.iter_mut().zip(free).zip(mass).zip(v).zip(e) {
                *r = f * (*r + ei + m * (g - alpha * vi));
            }
        }
        None => {
            for (((r, &f), &m), &vi) in r.iter_mut().zip(free).zip(mass).zip(v) {
                *r = f * (*r + m * (g - alpha * vi));
            }
        }
    }
}

/// One component of the step's end: `x += Δx` and `v = (x − x₀)/h` for free nodes; held
/// nodes (`free` 0) have `Δx = 0` (their residual and operator rows are zeroed) and keep the
/// velocity the bone motion gave them. `poison` (0 or NaN) makes a free node's result
/// non-finite. Vectorises (see [`assemble_residual`]).
#[inline(never)]
fn update_positions<T: Real>(x: &mut [T], v: &mut [T], dx: &[T], x0: &[T], free: &[T], poison: T, inv_h: T) {
    for ((((x, v), &d), &x0), &f) in x.iter_mut().zip(v.iter_mut()).zip(dx).zip(x0).zip(free) {
        let x1 = *x + d + f * poison;
        *x = x1;
        *v = f * ((x1 - x0) * inv_h) + (T::ONE - f) * *v;
    }
}

/// `out = Σ_w windows[w]` for component `c`.
fn sum_windows<T: Real>(out: &mut [T], windows: &[Vec3s<T>], c: usize) {
    out.copy_from_slice(windows[0].slices()[c]);
    for w in &windows[1..] {
        for (o, &x) in out.iter_mut().zip(w.slices()[c]) {
            *o += x;
        }
    }
}

/// `y += a x`.
fn axpy<T: Real>(y: &mut Vec3s<T>, a: f64, x: &Vec3s<T>) {
    let a = T::from_f64(a);
    for (yc, xc) in y.slices_mut().into_iter().zip(x.slices()) {
        for (yv, xv) in yc.iter_mut().zip(xc.iter()) {
            *yv += a * *xv;
        }
    }
}

/// `y = x + a y`.
fn scale_add<T: Real>(y: &mut Vec3s<T>, a: f64, x: &Vec3s<T>) {
    let a = T::from_f64(a);
    for (yc, xc) in y.slices_mut().into_iter().zip(x.slices()) {
        for (yv, xv) in yc.iter_mut().zip(xc.iter()) {
            *yv = *xv + a * *yv;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_is_the_same_sum_on_every_simd_level_and_near_the_exact_one_works() {
        for n in 0..40usize {
            let pa: Vec<[f64; 3]> =
                (0..n).map(|i| [0.1 + i as f64, -1.0 / (1.0 + i as f64), 1e-3 * (i * i) as f64]).collect();
            let pb: Vec<[f64; 3]> = (0..n).map(|i| [1.5 - 0.3 * i as f64, 2.0, (i % 7) as f64 - 3.0]).collect();
            let (a, b) = (Vec3s::<f32>::from_f64(&pa), Vec3s::<f32>::from_f64(&pb));
            // The exact sum of the f32 values' products (each product is exact in f64).
            let exact: f64 = (0..n).map(|i| (0..3).map(|c| a.get_f64(i)[c] * b.get_f64(i)[c]).sum::<f64>()).sum();
            let base = dot(SimdLevel::Baseline, &a, &b);
            assert!((base - exact).abs() <= 1e-12 * (1.0 + exact.abs()), "{n} nodes: {base} against {exact}");
            for level in SimdLevel::available() {
                assert_eq!(dot(level, &a, &b).to_bits(), base.to_bits(), "{level} on {n} nodes");
            }
        }
    }
}
