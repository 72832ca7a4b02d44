//! Energy bookkeeping: kinetic, elastic, gravitational and handle energy, and the work put in
//! by point loads, so a study can check that energy never grows beyond the work put in.

use crate::model::{Model, NodeKind};
use crate::real::Real;
use crate::solver::Simulation;

/// Mechanical energy of a state, J.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EnergyBreakdown {
    /// ½ m |v|² over free nodes.
    pub kinetic: f64,
    /// Spring energy ([`crate::law::SpringLaw::energy`]).
    pub elastic: f64,
    /// −m g·x over free nodes (with gravity on).
    pub gravity: f64,
    /// ½ k |target − x|² of drag handles.
    pub handles: f64,
}

impl EnergyBreakdown {
    /// Sum, J.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.gravity + self.handles
    }
}

/// Mechanical energy of `sim`'s state (`model` is the one it was built from).
pub fn mechanical_energy<T: Real>(model: &Model, sim: &Simulation<T>) -> EnergyBreakdown {
    let s = sim.state();
    let e = sim.effects();
    let mut out = EnergyBreakdown::default();
    for i in 0..model.nodes.len() {
        if e.bone && model.nodes.kind[i] != NodeKind::Free {
            continue;
        }
        let (v, x, m) = (s.v.get_f64(i), s.x.get_f64(i), model.nodes.mass[i]);
        out.kinetic += 0.5 * m * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if let Some(g) = e.gravity {
            out.gravity -= m * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2]);
        }
    }
    let sp = &model.springs;
    for j in 0..sp.len() {
        let (a, b) = (s.x.get_f64(sp.a[j] as usize), s.x.get_f64(sp.b[j] as usize));
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        out.elastic += sp.law[j].energy(l, sp.rest_length[j]);
    }
    for h in &e.handles {
        let x = s.x.get_f64(h.node as usize);
        let d2 = (0..3).map(|c| (h.target[c] - x[c]).powi(2)).sum::<f64>();
        out.handles += 0.5 * h.stiffness * d2;
    }
    out
}

/// The conservative forces (springs, gravity, handles, loads at full ramp) on every node, N.
fn conservative_forces<T: Real>(model: &Model, sim: &Simulation<T>) -> Vec<[f64; 3]> {
    let s = sim.state();
    let e = sim.effects();
    let n = model.nodes.len();
    let mut f = vec![[0.0f64; 3]; n];
    let sp = &model.springs;
    for j in 0..sp.len() {
        let (ia, ib) = (sp.a[j] as usize, sp.b[j] as usize);
        let (a, b) = (s.x.get_f64(ia), s.x.get_f64(ib));
        let d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        if l < crate::solver::MIN_SPRING_LENGTH {
            continue;
        }
        let t = sp.law[j].force(l, sp.rest_length[j]) / l;
        for c in 0..3 {
            f[ia][c] += t * d[c];
            f[ib][c] -= t * d[c];
        }
    }
    for i in 0..n {
        if let Some(g) = e.gravity {
            for c in 0..3 {
                f[i][c] += model.nodes.mass[i] * g[c];
            }
        }
    }
    for h in &e.handles {
        let x = s.x.get_f64(h.node as usize);
        for c in 0..3 {
            f[h.node as usize][c] += h.stiffness * (h.target[c] - x[c]);
        }
    }
    f
}

/// Symplectic Euler's shadow-energy correction `(h/2) Σ v·F(x)`, J: with it the energy of a
/// quadratic potential is conserved exactly by the scheme, so what is left is real gain.
fn symplectic_correction<T: Real>(model: &Model, sim: &Simulation<T>) -> f64 {
    let h = sim.params().dt / sim.substeps() as f64;
    let f = conservative_forces(model, sim);
    let s = sim.state();
    let mut sum = 0.0;
    for (i, fi) in f.iter().enumerate() {
        if sim.effects().bone && model.nodes.kind[i] != NodeKind::Free {
            continue;
        }
        let v = s.v.get_f64(i);
        sum += v[0] * fi[0] + v[1] * fi[1] + v[2] * fi[2];
    }
    0.5 * h * sum
}

fn ledger_energy<T: Real>(model: &Model, sim: &Simulation<T>) -> f64 {
    let e = mechanical_energy(model, sim).total();
    if sim.params().integrator == crate::solver::IntegratorKind::SymplecticEuler {
        e + symplectic_correction(model, sim)
    } else {
        e
    }
}

/// Tracks `E(t) − W(t)`: mechanical energy minus the work point loads have done. For
/// symplectic Euler the energy is its shadow energy (see `symplectic_correction`).
#[derive(Clone, Debug)]
pub struct EnergyLedger {
    last_x: Vec<[f64; 3]>,
    /// Every node's last position, kept when a tool is on (its work is Σ f·Δx over nodes).
    last_all: Vec<[f64; 3]>,
    /// Work done by point loads so far, J.
    pub work_in: f64,
    /// Mechanical energy at the start, J.
    pub initial: f64,
    /// Largest `E(t) − W(t) − E(0)` seen, J (> 0 means energy was created).
    pub max_excess: f64,
    /// Largest |E| or |W| seen, J: the scale to judge the excess against.
    pub scale: f64,
}

impl EnergyLedger {
    /// Starts the ledger at `sim`'s current state.
    pub fn new<T: Real>(model: &Model, sim: &Simulation<T>) -> Self {
        let e = ledger_energy(model, sim);
        let last_x = sim.effects().loads.iter().map(|l| sim.state().x.get_f64(l.node as usize)).collect();
        let last_all = if sim.effects().tool.is_some() {
            (0..model.nodes.len()).map(|i| sim.state().x.get_f64(i)).collect()
        } else {
            Vec::new()
        };
        Self { last_x, last_all, work_in: 0.0, initial: e, max_excess: 0.0, scale: e.abs() }
    }

    /// Records the state after a step. Load work is integrated with the force at the end
    /// of the step (loads are constant after their ramp).
    pub fn record<T: Real>(&mut self, model: &Model, sim: &Simulation<T>) {
        let s = sim.state();
        for (k, l) in sim.effects().loads.iter().enumerate() {
            let x = s.x.get_f64(l.node as usize);
            let ramp = if l.ramp_s > 0.0 { (s.time / l.ramp_s).min(1.0) } else { 1.0 };
            for c in 0..3 {
                self.work_in += ramp * l.force[c] * (x[c] - self.last_x[k][c]);
            }
            self.last_x[k] = x;
        }
        if let Some(tool) = sim.effects().tool {
            let c = tool.centre(s.time);
            for i in 0..self.last_all.len() {
                let x = s.x.get_f64(i);
                let d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
                let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if dist < tool.radius && dist > 0.0 && !(sim.effects().bone && model.nodes.kind[i] != NodeKind::Free) {
                    let push = tool.stiffness * (tool.radius - dist) / dist;
                    for k in 0..3 {
                        self.work_in += push * d[k] * (x[k] - self.last_all[i][k]);
                    }
                }
                self.last_all[i] = x;
            }
        }
        let e = ledger_energy(model, sim);
        self.scale = self.scale.max(e.abs()).max(self.work_in.abs());
        self.max_excess = self.max_excess.max(e - self.work_in - self.initial);
    }
}
