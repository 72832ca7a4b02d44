//! The critical (largest stable) time step of the explicit integrators, from the model.
//!
//! The stiffest mode's angular frequency `ω` comes from power iteration on `M⁻¹K`, with
//! every spring at its largest stiffness (k2 for a bilinear spring in its second phase)
//! along its rest direction; the damping rate `γ` from a Gershgorin bound on `M⁻¹C`. For
//! `ẍ = −ω²x − γẋ` symplectic Euler is stable for `h < (−γ + √(γ² + 4ω²)) / ω²` (Jury
//! criterion on its 2×2 step matrix; `2/ω` undamped); RK4 for `h|λ| < 2.5` with
//! `|λ| = max(ω, γ)` (its stability region reaches 2.83 on the imaginary axis and 2.78 on
//! the real one).

use super::params::IntegratorKind;
use crate::model::{Model, NodeKind};

/// What bounds an explicit step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StabilityEstimate {
    /// Highest angular frequency, rad/s.
    pub omega_max: f64,
    /// Highest damping rate, 1/s.
    pub gamma_max: f64,
}

impl StabilityEstimate {
    /// Estimates the model's stiffest mode. `extra_damping` (1/s) is added to every node's
    /// damping rate (viscous damping); `held` says whether fixed nodes are held.
    pub fn of_model(model: &Model, spring_damping: bool, extra_damping: f64, held: bool) -> Self {
        let n = model.nodes.len();
        let s = &model.springs;
        let free: Vec<bool> = model.nodes.kind.iter().map(|k| !held || *k == NodeKind::Free).collect();
        let inv_m: Vec<f64> = model.nodes.mass.iter().map(|m| 1.0 / m).collect();
        let dirs: Vec<[f64; 3]> = (0..s.len())
            .map(|i| {
                let (pa, pb) = (model.nodes.position[s.a[i] as usize], model.nodes.position[s.b[i] as usize]);
                let d = [pb[0] - pa[0], pb[1] - pa[1], pb[2] - pa[2]];
                let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                if l > 0.0 { [d[0] / l, d[1] / l, d[2] / l] } else { [1.0, 0.0, 0.0] }
            })
            .collect();
        let kmax: Vec<f64> = s.law.iter().map(|l| l.max_stiffness()).collect();
        // Power iteration on M^-1 K over free nodes, from a deterministic rough start.
        let mut p: Vec<[f64; 3]> = (0..n)
            .map(|i| {
                let h = (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                let r = |k: u32| ((h >> k) & 0xFFFF) as f64 / 65535.0 - 0.5;
                if free[i] { [r(0), r(16), r(32)] } else { [0.0; 3] }
            })
            .collect();
        let mut lambda = 0.0f64;
        let mut q = vec![[0.0f64; 3]; n];
        for _ in 0..60 {
            q.iter_mut().for_each(|v| *v = [0.0; 3]);
            for i in 0..s.len() {
                let (a, b) = (s.a[i] as usize, s.b[i] as usize);
                let u = dirs[i];
                let d = [p[a][0] - p[b][0], p[a][1] - p[b][1], p[a][2] - p[b][2]];
                let t = kmax[i] * (u[0] * d[0] + u[1] * d[1] + u[2] * d[2]);
                for c in 0..3 {
                    q[a][c] += t * u[c];
                    q[b][c] -= t * u[c];
                }
            }
            let mut norm = 0.0;
            for ((qi, &fr), &im) in q.iter_mut().zip(&free).zip(&inv_m) {
                for c in qi.iter_mut() {
                    *c = if fr { *c * im } else { 0.0 };
                    norm += *c * *c;
                }
            }
            let norm = norm.sqrt();
            let pnorm = p.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
            if norm == 0.0 || pnorm == 0.0 {
                break;
            }
            lambda = norm / pnorm;
            for i in 0..n {
                for c in 0..3 {
                    p[i][c] = q[i][c] / norm;
                }
            }
        }
        // Power iteration approaches λ_max from below: 5 % margin, and never below the
        // largest single-spring two-body frequency.
        let mut two_body = 0.0f64;
        let mut gamma = 0.0f64;
        let mut damp_row = vec![0.0f64; n];
        for (i, &k) in kmax.iter().enumerate() {
            let (a, b) = (s.a[i] as usize, s.b[i] as usize);
            let ia = if free[a] { inv_m[a] } else { 0.0 };
            let ib = if free[b] { inv_m[b] } else { 0.0 };
            two_body = two_body.max(k * (ia + ib));
            if spring_damping {
                damp_row[a] += 2.0 * s.damping[i];
                damp_row[b] += 2.0 * s.damping[i];
            }
        }
        for i in 0..n {
            if free[i] {
                gamma = gamma.max(damp_row[i] * inv_m[i]);
            }
        }
        let omega2 = (lambda * 1.05).max(two_body);
        Self { omega_max: omega2.sqrt(), gamma_max: gamma + extra_damping }
    }

    /// Largest stable step, s (infinite for implicit Euler or a model with no stiffness).
    pub fn critical_step(&self, integrator: IntegratorKind) -> f64 {
        let (w, g) = (self.omega_max, self.gamma_max);
        match integrator {
            IntegratorKind::ImplicitEuler | IntegratorKind::ImplicitFactored => f64::INFINITY,
            // Leapfrog's stability bound is symplectic Euler's: both are the same map on
            // positions, shifted by half a step in the velocities.
            IntegratorKind::SymplecticEuler | IntegratorKind::VelocityVerlet => {
                if w == 0.0 {
                    if g == 0.0 { f64::INFINITY } else { 2.0 / g }
                } else {
                    (-g + (g * g + 4.0 * w * w).sqrt()) / (w * w)
                }
            }
            IntegratorKind::Rk4 => {
                let l = w.max(g);
                if l == 0.0 { f64::INFINITY } else { 2.5 / l }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law::SpringLaw;

    #[test]
    fn critical_step_two_masses_matches_closed_form_works() {
        // Two free 1 kg masses, k = 100 N/m: omega^2 = k (1/m1 + 1/m2) = 200.
        let mut m = Model::default();
        m.layers.push(crate::model::Layer { name: "x".into(), tissue: crate::model::Tissue::Other });
        m.nodes.push([0.0; 3], 1.0, NodeKind::Free, 0);
        m.nodes.push([1.0, 0.0, 0.0], 1.0, NodeKind::Free, 0);
        m.springs.push(0, 1, 1.0, SpringLaw::Linear { stiffness: 100.0 }, 0.0, 0);
        let est = StabilityEstimate::of_model(&m, false, 0.0, true);
        let w = 200f64.sqrt();
        assert!(est.omega_max >= w && est.omega_max <= w * 1.03, "{}", est.omega_max);
        let h = est.critical_step(IntegratorKind::SymplecticEuler);
        assert!(h <= 2.0 / w && h > 1.9 / w);
    }
}
