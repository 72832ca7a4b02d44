//! An accuracy reference independent of the integrators under test: the model's equations
//! of motion integrated in `f64` by the Dormand–Prince 5(4) pair (Dormand & Prince 1980,
//! the method of MATLAB's `ode45`) with adaptive steps and local error control.
//!
//! It shares only the right-hand side with the solver (the accelerations of
//! [`Simulation`]), not a single line of time stepping. Its own error is estimated by
//! integrating twice, at a tolerance and at a hundredth of it: the difference bounds the
//! coarser run's error, and the finer run is the reference.

use crate::solver::{Simulation, Vec3s};

/// Largest number of attempted steps per reference run: 20 million (about 20 minutes on the
/// default limb), so an ill-posed problem ends with an error instead of running forever.
pub const MAX_REFERENCE_STEPS: u64 = 20_000_000;

/// Why a reference run failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ReferenceError {
    /// The step size fell below 1e-14 of the run (the right-hand side is not smooth enough
    /// or not finite).
    #[error("the reference integration's step underflowed at t = {time:e} s (non-finite forces?)")]
    StepUnderflow {
        /// Time reached, s.
        time: f64,
    },
    /// More than [`MAX_REFERENCE_STEPS`] steps were attempted.
    #[error("the reference integration exceeded {MAX_REFERENCE_STEPS} steps")]
    TooManySteps,
}

/// Positions and velocities, the integrated variables.
#[derive(Clone)]
struct Phase {
    x: Vec3s<f64>,
    v: Vec3s<f64>,
}

impl Phase {
    fn zeros(n: usize) -> Self {
        Phase { x: Vec3s::zeros(n), v: Vec3s::zeros(n) }
    }

    /// `self = base + h Σ cᵢ kᵢ`.
    fn combine(&mut self, base: &Phase, h: f64, terms: &[(f64, &Phase)]) {
        for (out, b, pick) in [
            (&mut self.x, &base.x, (|p: &Phase| &p.x) as fn(&Phase) -> &Vec3s<f64>),
            (&mut self.v, &base.v, |p: &Phase| &p.v),
        ] {
            for (c, o) in out.slices_mut().into_iter().enumerate() {
                o.copy_from_slice(b.slices()[c]);
                for &(w, k) in terms {
                    if w != 0.0 {
                        let hw = h * w;
                        for (o, &d) in o.iter_mut().zip(pick(k).slices()[c]) {
                            *o += hw * d;
                        }
                    }
                }
            }
        }
    }
}

// Dormand–Prince 5(4) tableau.
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0, 0.0, 0.0],
    [9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0, 0.0],
    [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0],
];
/// Fifth-order weights minus the embedded fourth-order ones (the error estimate's).
const E: [f64; 7] = [
    35.0 / 384.0 - 5179.0 / 57600.0,
    0.0,
    500.0 / 1113.0 - 7571.0 / 16695.0,
    125.0 / 192.0 - 393.0 / 640.0,
    -2187.0 / 6784.0 + 92097.0 / 339200.0,
    11.0 / 84.0 - 187.0 / 2100.0,
    -1.0 / 40.0,
];

/// An adaptive Dormand–Prince integrator over a simulation's equations of motion.
pub struct Reference {
    /// Local error tolerance, relative to `scale_x` (m) and `scale_v` (m/s).
    pub tolerance: f64,
    /// Position scale of the error norm, m.
    pub scale_x: f64,
    /// Velocity scale of the error norm, m/s.
    pub scale_v: f64,
    y: Phase,
    k: Vec<Phase>,
    stage: Phase,
    time: f64,
    h: f64,
    /// Accepted steps so far.
    pub accepted: u64,
    /// Rejected steps so far.
    pub rejected: u64,
}

impl Reference {
    /// Starts at `sim`'s state, with an initial step `h0` s.
    pub fn new(sim: &Simulation<f64>, tolerance: f64, scale_x: f64, scale_v: f64, h0: f64) -> Self {
        let n = sim.state().x.len();
        let mut y = Phase::zeros(n);
        y.x.copy_from(&sim.state().x);
        y.v.copy_from(&sim.state().v);
        Reference {
            tolerance,
            scale_x,
            scale_v,
            y,
            k: (0..7).map(|_| Phase::zeros(n)).collect(),
            stage: Phase::zeros(n),
            time: sim.state().time,
            h: h0,
            accepted: 0,
            rejected: 0,
        }
    }

    /// Positions now.
    pub fn positions(&self) -> Vec<[f64; 3]> {
        (0..self.y.x.len()).map(|i| self.y.x.get_f64(i)).collect()
    }

    /// Time now, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    fn rhs(sim: &mut Simulation<f64>, y: &Phase, t: f64, out: &mut Phase) {
        out.x.copy_from(&y.v);
        sim.accelerations_into(&y.x, &y.v, t, &mut out.v);
    }

    /// Integrates to `t_end` with `sim`'s right-hand side (its effects as they are now).
    pub fn advance_to(&mut self, sim: &mut Simulation<f64>, t_end: f64) -> Result<(), ReferenceError> {
        let span = (t_end - self.time).abs().max(1e-300);
        let mut k = std::mem::take(&mut self.k);
        Self::rhs(sim, &self.y, self.time, &mut k[0]);
        while self.time < t_end {
            if self.accepted + self.rejected >= MAX_REFERENCE_STEPS {
                self.k = k;
                return Err(ReferenceError::TooManySteps);
            }
            let last = self.time + self.h >= t_end;
            let h = if last { t_end - self.time } else { self.h };
            if h < 1e-14 * span {
                self.k = k;
                return Err(ReferenceError::StepUnderflow { time: self.time });
            }
            for s in 1..7 {
                let terms: Vec<(f64, &Phase)> = (0..s).map(|j| (A[s][j], &k[j])).collect();
                self.stage.combine(&self.y, h, &terms);
                let (_, rest) = k.split_at_mut(s);
                Self::rhs(sim, &self.stage, self.time + C[s] * h, &mut rest[0]);
            }
            // stage now holds the fifth-order solution (A's last row is its weights).
            let err = self.error_norm(&k, h);
            if err.is_finite() && err <= 1.0 {
                std::mem::swap(&mut self.y, &mut self.stage);
                self.time = if last { t_end } else { self.time + h };
                k.swap(0, 6);
                self.accepted += 1;
            } else {
                self.rejected += 1;
            }
            let factor = if err.is_finite() { (0.9 * err.max(1e-10).powf(-0.2)).clamp(0.2, 5.0) } else { 0.2 };
            if !(last && err <= 1.0) {
                self.h = h * factor;
            }
        }
        self.k = k;
        Ok(())
    }

    /// Scaled infinity norm of the embedded error estimate.
    fn error_norm(&self, k: &[Phase], h: f64) -> f64 {
        let mut worst: f64 = 0.0;
        for (pick, scale) in
            [((|p: &Phase| &p.x) as fn(&Phase) -> &Vec3s<f64>, self.scale_x), (|p: &Phase| &p.v, self.scale_v)]
        {
            for c in 0..3 {
                let n = pick(&self.y).slices()[c].len();
                for i in 0..n {
                    let mut e = 0.0;
                    for (s, w) in E.iter().enumerate() {
                        e += w * pick(&k[s]).slices()[c][i];
                    }
                    let e = (h * e).abs() / (scale * self.tolerance);
                    if !e.is_finite() {
                        return f64::INFINITY;
                    }
                    worst = worst.max(e);
                }
            }
        }
        worst
    }
}

/// Largest distance between two position sets, m (NaN when either is not finite).
pub fn max_distance(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let mut e: f64 = 0.0;
    for (p, q) in a.iter().zip(b) {
        let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt();
        if !d.is_finite() {
            return f64::NAN;
        }
        e = e.max(d);
    }
    e
}
