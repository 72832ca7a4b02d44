//! The specification's step, written as the plain scalar loop it shows: springs in their
//! canonical order, forces scattered to both ends, then symplectic Euler. It is the
//! baseline Lamina's solver is compared with in the same run, and the checksum reference.

use crate::model::{Model, NodeKind};
use crate::real::Real;

/// Plain scalar stepping of a linear-spring model, exactly as in the specification.
pub struct ReferenceStepper<T> {
    a: Vec<u32>,
    b: Vec<u32>,
    rest: Vec<T>,
    k: Vec<T>,
    c: Vec<T>,
    mass: Vec<T>,
    fixed: Vec<bool>,
    /// Positions, m.
    pub x: Vec<[T; 3]>,
    /// Velocities, m/s.
    pub v: Vec<[T; 3]>,
    f: Vec<[T; 3]>,
    g: [T; 3],
    dt: T,
}

impl<T: Real> ReferenceStepper<T> {
    /// From a model whose springs are all linear, with gravity `g` (m/s²) and step `dt` (s).
    /// Returns `None` if a spring is not linear.
    pub fn new(model: &Model, g: [f64; 3], dt: f64) -> Option<Self> {
        let s = &model.springs;
        let k = s
            .law
            .iter()
            .map(|l| match l {
                crate::law::SpringLaw::Linear { stiffness } => Some(T::from_f64(*stiffness)),
                _ => None,
            })
            .collect::<Option<Vec<T>>>()?;
        let n = model.nodes.len();
        Some(Self {
            a: s.a.clone(),
            b: s.b.clone(),
            rest: s.rest_length.iter().map(|&r| T::from_f64(r)).collect(),
            k,
            c: s.damping.iter().map(|&c| T::from_f64(c)).collect(),
            mass: model.nodes.mass.iter().map(|&m| T::from_f64(m)).collect(),
            fixed: model.nodes.kind.iter().map(|k| *k != NodeKind::Free).collect(),
            x: model.nodes.position.iter().map(|p| p.map(T::from_f64)).collect(),
            v: vec![[T::ZERO; 3]; n],
            f: vec![[T::ZERO; 3]; n],
            g: g.map(T::from_f64),
            dt: T::from_f64(dt),
        })
    }

    /// One step: clear forces, springs in order, integrate free nodes.
    pub fn step(&mut self) {
        for f in &mut self.f {
            *f = [T::ZERO; 3];
        }
        for s in 0..self.a.len() {
            let (a, b) = (self.a[s] as usize, self.b[s] as usize);
            let (xa, xb, va, vb) = (self.x[a], self.x[b], self.v[a], self.v[b]);
            let d = [xb[0] - xa[0], xb[1] - xa[1], xb[2] - xa[2]];
            let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let u = [d[0] / l, d[1] / l, d[2] / l];
            let dv = [vb[0] - va[0], vb[1] - va[1], vb[2] - va[2]];
            let fs = self.k[s] * (l - self.rest[s]) + self.c[s] * (dv[0] * u[0] + dv[1] * u[1] + dv[2] * u[2]);
            for c in 0..3 {
                self.f[a][c] += fs * u[c];
                self.f[b][c] -= fs * u[c];
            }
        }
        for n in 0..self.x.len() {
            if self.fixed[n] {
                continue;
            }
            for c in 0..3 {
                self.v[n][c] += self.dt * (self.f[n][c] / self.mass[n] + self.g[c]);
                self.x[n][c] += self.dt * self.v[n][c];
            }
        }
    }
}
