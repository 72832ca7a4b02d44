//! Linearly implicit backward Euler, solved by warm-started preconditioned conjugate
//! gradients (Baraff & Witkin 1998).
//!
//! With `Δv = v₁ − v₀` and `x₁ = x₀ + h v₁`, one Newton step of backward Euler is
//!
//! ```text
//! [ (1 + h(α + α_v)) M + h C_s + (hβ + h²) K ] Δv = h ( M a₀ − α M v₀ − (β + h) K v₀ )
//! ```
//!
//! where `a₀` is the acceleration at the start (springs, dashpots, gravity, loads, viscous
//! damping α_v), `K` the tangent stiffness, `C_s` the spring dashpots, and `α`, `β` the
//! Rayleigh coefficients. Each spring contributes `k_t uuᵀ + g (I − uuᵀ)` to `K`, with
//! `k_t` the law's tangent and `g = max(F/L, 0)`: the geometric term is dropped under
//! compression, which keeps `K` positive semi-definite and CG applicable. The skin's volume
//! term (when on) adds each tetrahedron's Gauss-Newton stiffness `k/|V₀| ∇V ∇Vᵀ`. Held nodes
//! are filtered out (`Δv = 0`). The matrix is never formed: products go spring by spring and
//! tetrahedron by tetrahedron.

use super::dynamics::{Dynamics, State};
use super::params::IntegrationParameters;
use super::spring_kernels::MIN_SPRING_LENGTH;
use super::vec3s::Vec3s;
use crate::real::Real;
use std::time::Instant;

/// Scratch of the implicit solver; allocated once.
pub struct ImplicitSolver<T> {
    ea: Vec<u32>,
    eb: Vec<u32>,
    u: Vec<[T; 3]>,
    kt: Vec<T>,
    g: Vec<T>,
    c: Vec<T>,
    /// Per skin tetrahedron: its volume gradient per corner (m²) times `√(k/|V₀|)`.
    tet_grad: Vec<[[T; 3]; 4]>,
    a0: Vec3s<T>,
    rhs: Vec3s<T>,
    dv: Vec3s<T>,
    r: Vec3s<T>,
    z: Vec3s<T>,
    p: Vec3s<T>,
    q: Vec3s<T>,
    diag: Vec3s<T>,
    /// The prefactored preconditioner, when built (else Jacobi).
    pub(crate) factored: Option<super::factored_preconditioner::FactoredPreconditioner<T>>,
    /// CG iterations of the last solve.
    pub last_iterations: u32,
    /// Relative residual of the last solve.
    pub last_residual: f64,
}

impl<T: Real> ImplicitSolver<T> {
    /// Scratch for `dynamics`' model.
    pub fn new(dynamics: &Dynamics<T>) -> Self {
        let n = dynamics.len();
        let layout = dynamics.pass.layout();
        let mut ea = Vec::with_capacity(layout.len());
        let mut eb = Vec::with_capacity(layout.len());
        let mut push_block = |runs: &[super::spring_layout::Run], la: &[u32], lb: &[u32]| {
            for r in runs {
                for i in 0..r.len {
                    ea.push(r.a0 + i);
                    eb.push(r.b0 + i);
                }
            }
            ea.extend_from_slice(la);
            eb.extend_from_slice(lb);
        };
        push_block(&layout.linear.runs, &layout.linear.loose_a, &layout.linear.loose_b);
        push_block(&layout.bilinear.runs, &layout.bilinear.loose_a, &layout.bilinear.loose_b);
        let s = ea.len();
        let z = || Vec3s::zeros(n);
        Self {
            ea,
            eb,
            u: vec![[T::ZERO; 3]; s],
            kt: vec![T::ZERO; s],
            g: vec![T::ZERO; s],
            c: vec![T::ZERO; s],
            tet_grad: vec![[[T::ZERO; 3]; 4]; dynamics.skin_volume.tets.len()],
            a0: z(),
            rhs: z(),
            dv: z(),
            r: z(),
            z: z(),
            p: z(),
            q: z(),
            diag: z(),
            factored: None,
            last_iterations: 0,
            last_residual: 0.0,
        }
    }

    /// Directions, tangents and geometric terms of every spring at positions `x`.
    fn assemble(&mut self, dynamics: &Dynamics<T>, x: &Vec3s<T>) {
        let layout = dynamics.pass.layout();
        let lin = &layout.linear.params;
        let bil = &layout.bilinear.params;
        let nl = layout.linear.len();
        let damp = dynamics.effects.spring_damping;
        for s in 0..self.ea.len() {
            let (a, b) = (self.ea[s] as usize, self.eb[s] as usize);
            let d = [x.x[b] - x.x[a], x.y[b] - x.y[a], x.z[b] - x.z[a]];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let inv = T::ONE / len.max(T::from_f64(MIN_SPRING_LENGTH));
            self.u[s] = [d[0] * inv, d[1] * inv, d[2] * inv];
            let (kt, force, c) = if s < nl {
                let k = lin.k[s];
                (k, k * (len - lin.rest[s]), lin.c[s])
            } else {
                let j = s - nl;
                let stretch = len - bil.rest[j];
                let turn = bil.turn[j];
                let kt = if stretch < T::ZERO {
                    bil.kc[j]
                } else if stretch <= turn {
                    bil.k1[j]
                } else {
                    bil.k2[j]
                };
                let pull = stretch.max(T::ZERO);
                let f = bil.kc[j] * stretch.min(T::ZERO)
                    + bil.k1[j] * pull.min(turn)
                    + bil.k2[j] * (pull - turn).max(T::ZERO);
                (kt, f, bil.c[j])
            };
            self.kt[s] = kt;
            self.g[s] = (force * inv).max(T::ZERO);
            self.c[s] = if damp { c } else { T::ZERO };
        }
        if let Some(k) = dynamics.effects.skin_volume {
            for (t, out) in self.tet_grad.iter_mut().enumerate() {
                *out = dynamics.skin_volume.weighted_gradient(t, k, x);
            }
        }
    }

    /// `y = cm·M p + Σ_springs [(cc·c + ck·k_t)(u·d)u + ck·g(d − (u·d)u)]`, `d = p_a − p_b`,
    /// with held nodes filtered.
    fn apply(&self, dynamics: &Dynamics<T>, cm: T, cc: T, ck: T, p: &Vec3s<T>, y: &mut Vec3s<T>) {
        for i in 0..p.len() {
            let m = cm * dynamics.mass[i];
            y.set(i, [m * p.x[i], m * p.y[i], m * p.z[i]]);
        }
        for s in 0..self.ea.len() {
            let (a, b) = (self.ea[s] as usize, self.eb[s] as usize);
            let u = self.u[s];
            let d = [p.x[a] - p.x[b], p.y[a] - p.y[b], p.z[a] - p.z[b]];
            let ud = u[0] * d[0] + u[1] * d[1] + u[2] * d[2];
            let w1 = cc * self.c[s] + ck * self.kt[s];
            let w2 = ck * self.g[s];
            let t = [0, 1, 2].map(|k| w1 * ud * u[k] + w2 * (d[k] - ud * u[k]));
            let (ya, yb) = (y.get(a), y.get(b));
            y.set(a, [ya[0] + t[0], ya[1] + t[1], ya[2] + t[2]]);
            y.set(b, [yb[0] - t[0], yb[1] - t[1], yb[2] - t[2]]);
        }
        if dynamics.effects.skin_volume.is_some() {
            dynamics.skin_volume.add_stiffness_product(&self.tet_grad, ck, p, y);
        }
        // The tool's contact points: stiffness along their normals (listed when the
        // simulation asked the tool evaluation to record them).
        for c in &dynamics.contacts {
            let mut q = [0.0f64; 3];
            for (&n, &w) in c.nodes.iter().zip(&c.weights) {
                let pv = p.get_f64(n as usize);
                for k in 0..3 {
                    q[k] += w * pv[k];
                }
            }
            let along = ck.to_f64() * c.stiffness * (c.normal[0] * q[0] + c.normal[1] * q[1] + c.normal[2] * q[2]);
            for (&n, &w) in c.nodes.iter().zip(&c.weights) {
                if w != 0.0 {
                    let yv = y.get(n as usize);
                    y.set(n as usize, [0, 1, 2].map(|k| yv[k] + T::from_f64(w * along * c.normal[k])));
                }
            }
        }
        for i in 0..p.len() {
            let f = dynamics.free[i];
            y.set(i, y.get(i).map(|v| v * f));
        }
    }

    fn diagonal(&mut self, dynamics: &Dynamics<T>, cm: T, cc: T, ck: T, h: T) {
        for i in 0..self.diag.len() {
            let m = cm * dynamics.mass[i];
            self.diag.set(i, [m; 3]);
        }
        for s in 0..self.ea.len() {
            let u = self.u[s];
            let w1 = cc * self.c[s] + ck * self.kt[s];
            let w2 = ck * self.g[s];
            let t = [0, 1, 2].map(|k| w1 * u[k] * u[k] + w2 * (T::ONE - u[k] * u[k]));
            for node in [self.ea[s] as usize, self.eb[s] as usize] {
                let d = self.diag.get(node);
                self.diag.set(node, [d[0] + t[0], d[1] + t[1], d[2] + t[2]]);
            }
        }
        if dynamics.effects.skin_volume.is_some() {
            for (tet, g) in dynamics.skin_volume.tets.iter().zip(&self.tet_grad) {
                for (&i, gi) in tet.iter().zip(g) {
                    let d = self.diag.get(i as usize);
                    self.diag.set(i as usize, [0, 1, 2].map(|c| d[c] + ck * gi[c] * gi[c]));
                }
            }
        }
        for hd in &dynamics.effects.handles {
            let i = hd.node as usize;
            let add = T::from_f64(hd.damping) * h + T::from_f64(hd.stiffness) * h * h;
            let d = self.diag.get(i);
            self.diag.set(i, d.map(|v| v + add));
        }
    }

    /// One backward-Euler sub-step of `h` seconds.
    pub fn substep(
        &mut self,
        dynamics: &mut Dynamics<T>,
        params: &IntegrationParameters,
        state: &mut State<T>,
        h: f64,
    ) {
        let mut a0 = std::mem::take(&mut self.a0);
        dynamics.accelerations_into(&state.x, &state.v, state.time, &mut a0);
        self.a0 = a0;
        let start = Instant::now();
        self.assemble(dynamics, &state.x);
        let ht = T::from_f64(h);
        let alpha = T::from_f64(params.rayleigh_alpha);
        let alpha_v = T::from_f64(dynamics.effects.viscous_damping.unwrap_or(0.0));
        let beta = T::from_f64(params.rayleigh_beta);
        // rhs = h (M a0 − α M v0 − (β + h) K v0)
        let mut kv = std::mem::take(&mut self.q);
        self.apply(dynamics, T::ZERO, T::ZERO, T::ONE, &state.v, &mut kv);
        for i in 0..state.x.len() {
            let m = dynamics.mass[i];
            let (a, v, k) = (self.a0.get(i), state.v.get(i), kv.get(i));
            let f = dynamics.free[i];
            self.rhs.set(i, [0, 1, 2].map(|c| f * ht * (m * a[c] - alpha * m * v[c] - (beta + ht) * k[c])));
        }
        self.q = kv;
        let cm = T::ONE + ht * (alpha + alpha_v);
        let cc = ht;
        let ck = ht * beta + ht * ht;
        self.diagonal(dynamics, cm, cc, ck, ht);
        self.solve(dynamics, params, cm, cc, ck, ht);
        for i in 0..state.x.len() {
            let f = dynamics.free[i];
            let dv = self.dv.get(i);
            let v = state.v.get(i);
            let v1 = [v[0] + f * dv[0], v[1] + f * dv[1], v[2] + f * dv[2]];
            state.v.set(i, v1);
            let x = state.x.get(i);
            state.x.set(i, [x[0] + f * ht * v1[0], x[1] + f * ht * v1[1], x[2] + f * ht * v1[2]]);
        }
        dynamics.counters.implicit += start.elapsed();
        dynamics.counters.cg_iterations += self.last_iterations as u64;
    }

    /// Preconditioned CG on `A dv = rhs`, warm-started from the previous `dv`.
    fn solve(&mut self, dynamics: &Dynamics<T>, params: &IntegrationParameters, cm: T, cc: T, ck: T, h: T) {
        let dot = |a: &Vec3s<T>, b: &Vec3s<T>| -> f64 {
            let mut s = 0.0f64;
            for (pa, pb) in [(&a.x, &b.x), (&a.y, &b.y), (&a.z, &b.z)] {
                for (x, y) in pa.iter().zip(pb.iter()) {
                    s += x.to_f64() * y.to_f64();
                }
            }
            s
        };
        let handles_term = |p: &Vec3s<T>, y: &mut Vec3s<T>| {
            for hd in &dynamics.effects.handles {
                let i = hd.node as usize;
                let add = (T::from_f64(hd.damping) * h + T::from_f64(hd.stiffness) * h * h) * dynamics.free[i];
                let (pv, yv) = (p.get(i), y.get(i));
                y.set(i, [yv[0] + add * pv[0], yv[1] + add * pv[1], yv[2] + add * pv[2]]);
            }
        };
        let bnorm = dot(&self.rhs, &self.rhs).sqrt();
        if !bnorm.is_finite() {
            // Non-finite forces: propagate them, so the guard sees a bad frame instead of
            // a silently frozen node.
            self.dv.x.fill(T::from_f64(f64::NAN));
            self.last_iterations = 0;
            self.last_residual = f64::NAN;
            return;
        }
        if bnorm == 0.0 {
            self.dv.fill_zero();
            self.last_iterations = 0;
            self.last_residual = 0.0;
            return;
        }
        if !self.dv.all_finite() {
            self.dv.fill_zero();
        }
        // r = b − A dv
        let mut q = std::mem::take(&mut self.q);
        self.apply(dynamics, cm, cc, ck, &self.dv, &mut q);
        handles_term(&self.dv, &mut q);
        for (r, (b, aq)) in [
            (&mut self.r.x, (&self.rhs.x, &q.x)),
            (&mut self.r.y, (&self.rhs.y, &q.y)),
            (&mut self.r.z, (&self.rhs.z, &q.z)),
        ] {
            for i in 0..r.len() {
                r[i] = b[i] - aq[i];
            }
        }
        let precondition = |r: &Vec3s<T>, z: &mut Vec3s<T>, diag: &Vec3s<T>| {
            for (zc, (rc, dc)) in
                [(&mut z.x, (&r.x, &diag.x)), (&mut z.y, (&r.y, &diag.y)), (&mut z.z, (&r.z, &diag.z))]
            {
                for i in 0..zc.len() {
                    zc[i] = if dc[i] > T::ZERO { rc[i] / dc[i] } else { T::ZERO };
                }
            }
        };
        match &mut self.factored {
            Some(f) => f.apply(&dynamics.pool, &self.r, &mut self.z),
            None => precondition(&self.r, &mut self.z, &self.diag),
        }
        self.p.copy_from(&self.z);
        let mut rz = dot(&self.r, &self.z);
        let tol = params.cg_tolerance * bnorm;
        let mut iterations = 0;
        let mut rnorm = dot(&self.r, &self.r).sqrt();
        while iterations < params.cg_max_iterations && rnorm > tol {
            self.apply(dynamics, cm, cc, ck, &self.p, &mut q);
            handles_term(&self.p, &mut q);
            let pq = dot(&self.p, &q);
            if pq <= 0.0 || !pq.is_finite() {
                break;
            }
            let alpha = T::from_f64(rz / pq);
            for c in 0..3 {
                let (dv, p, r, qv) = match c {
                    0 => (&mut self.dv.x, &self.p.x, &mut self.r.x, &q.x),
                    1 => (&mut self.dv.y, &self.p.y, &mut self.r.y, &q.y),
                    _ => (&mut self.dv.z, &self.p.z, &mut self.r.z, &q.z),
                };
                for i in 0..dv.len() {
                    dv[i] += alpha * p[i];
                    r[i] -= alpha * qv[i];
                }
            }
            match &mut self.factored {
                Some(f) => f.apply(&dynamics.pool, &self.r, &mut self.z),
                None => precondition(&self.r, &mut self.z, &self.diag),
            }
            let rz_new = dot(&self.r, &self.z);
            let beta = T::from_f64(rz_new / rz);
            rz = rz_new;
            for (p, z) in [(&mut self.p.x, &self.z.x), (&mut self.p.y, &self.z.y), (&mut self.p.z, &self.z.z)] {
                for i in 0..p.len() {
                    p[i] = z[i] + beta * p[i];
                }
            }
            rnorm = dot(&self.r, &self.r).sqrt();
            iterations += 1;
        }
        self.q = q;
        self.last_iterations = iterations;
        self.last_residual = rnorm / bnorm;
    }
}
